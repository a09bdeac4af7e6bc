//! `tree`: an Aono–Kunii binary tree. Every branch is a truncated cone along its frame's unit z
//! axis, capped by a sphere; each branch spawns two children whose frames are the parent's frame
//! rotated, scaled and moved to its tip. Size N gives 2^(N+1) − 1 cones and as many spheres,
//! standing on a 100 × 100 green field.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::matrix::Mat4;
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "tree";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 11;

/// Base radius of the trunk.
const TRUNK_RADIUS: f64 = 0.15;
/// Radius ratio per level (and apex/base ratio of each cone).
const RADIUS_RATIO: f64 = 0.67;

/// (branch angle about x, divergence about z, length contraction) of the two children.
const CHILDREN: [(f64, f64, f64); 2] = [(40.0, 90.0, 0.65), (25.0, 230.0, 0.70)];

fn branch(b: &mut SceneBuilder, kids: &[Mat4; 2], frame: &Mat4, radius: f64, depth: u32) {
    let base = frame.point(Vec3d::zero());
    let tip = frame.point(v3(0.0, 0.0, 1.0));
    let apex_r = radius * RADIUS_RATIO;
    b.cone(base, radius, tip, apex_r);
    b.sphere(tip, apex_r);
    if depth == 0 {
        return;
    }
    for k in kids {
        branch(b, kids, &k.then(frame), apex_r, depth - 1);
    }
}

/// Generates the tree at size factor `size` (levels of branching below the trunk).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let cones = 2u64.checked_pow(size.saturating_add(1)).map(|n| n - 1);
    let count = check_size(
        NAME,
        size,
        cones.and_then(|c| c.checked_mul(2)?.checked_add(1)),
    )?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(4.5, 0.4, 2.0),
            v3(0.0, 0.0, 1.5),
            v3(0.0, 0.0, 1.0),
            45.0,
            1.0,
            512,
        ),
        vec![
            light(-5.0, 5.0, 50.0),
            light(30.0, -30.0, 30.0),
            light(-40.0, -30.0, 20.0),
            light(10.0, 30.0, 40.0),
            light(-30.0, 40.0, 10.0),
            light(50.0, 25.0, 20.0),
            light(-10.0, -60.0, 30.0),
        ],
        count,
    );
    b.material(material(0.2, 0.7, 0.2, 1.0, 0.0, 100000.0, 0.0, 0.0));
    b.polygon(vec![
        v3(50.0, 50.0, 0.0),
        v3(-50.0, 50.0, 0.0),
        v3(-50.0, -50.0, 0.0),
        v3(50.0, -50.0, 0.0),
    ]);
    b.material(material(0.55, 0.4, 0.2, 1.0, 0.0, 100000.0, 0.0, 0.0));
    // A child's frame, relative to its parent's: tilt, turn, shrink, then move to the tip.
    let kids = CHILDREN.map(|(tilt, turn, scale)| {
        Mat4::rotate(0, tilt)
            .then(&Mat4::rotate(2, turn))
            .then(&Mat4::scale(scale))
            .then(&Mat4::translate(v3(0.0, 0.0, 1.0)))
    });
    branch(&mut b, &kids, &Mat4::identity(), TRUNK_RADIUS, size);
    Ok(b.finish())
}
