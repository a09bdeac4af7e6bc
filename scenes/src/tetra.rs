//! `tetra`: the recursive (Sierpinski) tetrahedron. A tetrahedron is inscribed in a cube (four
//! corners whose sign product is +1); it is replaced by four half-size tetrahedra at those
//! corners, N − 1 times, and the last level writes its four faces. Size N gives 4^(N−1)
//! tetrahedra, 4^N triangles.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "tetra";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 6;

/// The four cube corners of the tetrahedron (sign product +1), in SPD's vertex order.
const CORNERS: [[f64; 3]; 4] = [
    [-1.0, -1.0, 1.0],
    [-1.0, 1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, 1.0],
];

/// Faces as vertex indices, each counter-clockwise seen from outside.
const FACES: [[usize; 3]; 4] = [[0, 1, 2], [3, 2, 1], [2, 3, 0], [1, 0, 3]];

fn corner(center: Vec3d, half: f64, k: usize) -> Vec3d {
    let s = CORNERS[k];
    center + v3(s[0], s[1], s[2]) * half
}

fn tetra(b: &mut SceneBuilder, center: Vec3d, half: f64, depth: u32) {
    if depth == 0 {
        let v: [Vec3d; 4] = std::array::from_fn(|k| corner(center, half, k));
        for f in FACES {
            b.polygon(vec![v[f[0]], v[f[1]], v[f[2]]]);
        }
        return;
    }
    let h = half / 2.0;
    for k in 0..4 {
        tetra(b, corner(center, h, k), h, depth - 1);
    }
}

/// Generates the tetrahedron at size factor `size` (`size − 1` subdivisions).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let count = check_size(NAME, size, 4u64.checked_pow(size))?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(1.02285, -3.17715, -2.17451),
            v3(-0.004103, -0.004103, 0.216539),
            v3(-0.816497, -0.816497, 0.816497),
            45.0,
            1.0,
            512,
        ),
        vec![light(2.0, -18.0, -5.0)],
        count,
    );
    b.material(material(1.0, 0.2, 0.2, 1.0, 0.0, 100000.0, 0.0, 0.0));
    tetra(&mut b, Vec3d::zero(), 1.0, size - 1);
    Ok(b.finish())
}
