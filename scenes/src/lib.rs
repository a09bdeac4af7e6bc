//! SPD-style procedural scene generators: each builds a [`parrt_render::description::SceneDescription`]
//! deterministically from a name and a size factor, reproducing the scenes of Eric Haines'
//! Standard Procedural Databases (object counts, materials, camera and lights as SPD writes them).
//!
//! ```
//! let scene = parrt_scenes::generate("tetra", Some(2)).unwrap();
//! assert_eq!(scene.primitives.len(), 16);
//! ```
//!
//! ## Layout
//! One file per generator (`balls.rs`, `gears.rs`, ...), each with a `generate(size)` function;
//! [`builder`] keeps the `f`-line structure and the size limit ([`builder::MAX_PRIMITIVES`]),
//! [`matrix`] the row-vector transforms. Generation uses only `f64` +, −, ×, ÷, sqrt and std trig
//! and integer arithmetic, so a scene is the same on every machine.
#![deny(missing_docs)]

pub mod balls;
pub mod builder;
pub mod gears;
pub mod jacks;
pub mod lattice;
pub mod matrix;
pub mod mount;
pub mod rings;
pub mod shells;
pub mod sombrero;
/// Not an SPD scene, so not in [`generators`]: the precision study's sliver soup.
pub mod soup;
pub mod teapot;
pub mod teapot_data;
pub mod tetra;
pub mod tree;

use parrt_render::description::SceneDescription;
use thiserror::Error;

/// Errors choosing or running a generator.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum GenError {
    /// No generator has this name.
    #[error("unknown scene '{0}' (known: {1})")]
    UnknownScene(String, String),
    /// The size factor is outside what the generator supports.
    #[error("scene '{name}' does not support size {size}: {why}")]
    BadSize {
        /// Generator name.
        name: String,
        /// Requested size.
        size: u32,
        /// Why not.
        why: String,
    },
}

/// A generator's name and default size factor.
#[derive(Clone, Copy, Debug)]
pub struct GeneratorInfo {
    /// Name as used on the command line (`balls`, `mount`, ...).
    pub name: &'static str,
    /// SPD's compiled-in default size factor.
    pub default_size: u32,
    /// One-line description.
    pub about: &'static str,
}

type GenFn = fn(u32) -> Result<SceneDescription, GenError>;

const GENERATORS: &[(GeneratorInfo, GenFn)] = &[
    (
        GeneratorInfo {
            name: "balls",
            default_size: 4,
            about: "sphereflake: 9 child spheres per sphere, N levels deep (Σ9^k spheres)",
        },
        balls::generate,
    ),
    (
        GeneratorInfo {
            name: "gears",
            default_size: 4,
            about: "N×N×N grid of meshing 36-tooth gears, some transparent (146·N³ polygons)",
        },
        gears::generate,
    ),
    (
        GeneratorInfo {
            name: "jacks",
            default_size: 1,
            about: "recursive jacks of cylinders and spheres, 8 children per level",
        },
        jacks::generate,
    ),
    (
        GeneratorInfo {
            name: "lattice",
            default_size: 12,
            about: "(N+1)³ shiny spheres joined by red, green and blue cylinders",
        },
        lattice::generate,
    ),
    (
        GeneratorInfo {
            name: "mount",
            default_size: 6,
            about: "fractal mountain (2·4^N triangles) with 4 glass spheres: the PARRT paper's scene",
        },
        mount::generate,
    ),
    (
        GeneratorInfo {
            name: "rings",
            default_size: 7,
            about: "pyramid of pentagonal rings of cylinders and spheres before a wall",
        },
        rings::generate,
    ),
    (
        GeneratorInfo {
            name: "shells",
            default_size: 5,
            about: "Pickover's seashell: a spiral of 180·2^N+1 overlapping spheres",
        },
        shells::generate,
    ),
    (
        GeneratorInfo {
            name: "sombrero",
            default_size: 1,
            about: "height field cos(2πr)·e^(−r) as flat triangles",
        },
        sombrero::generate,
    ),

    (
        GeneratorInfo {
            name: "teapot",
            default_size: 6,
            about: "Newell's teapot, 32 Bézier patches as N×N smooth triangles, on a checkerboard (standard size 12)",
        },
        teapot::generate,
    ),
    (
        GeneratorInfo {
            name: "tetra",
            default_size: 6,
            about: "recursive tetrahedron (Sierpinski), 4^N triangles",
        },
        tetra::generate,
    ),
    (
        GeneratorInfo {
            name: "tree",
            default_size: 11,
            about: "Aono–Kunii branching tree: 2^(N+1)−1 cones and spheres on a field",
        },
        tree::generate,
    ),
];

/// The generators, in alphabetical order.
pub fn generators() -> &'static [GeneratorInfo] {
    static INFOS: [GeneratorInfo; GENERATORS.len()] = {
        let mut out = [GENERATORS[0].0; GENERATORS.len()];
        let mut i = 0;
        while i < GENERATORS.len() {
            out[i] = GENERATORS[i].0;
            i += 1;
        }
        out
    };
    &INFOS
}

/// Generates scene `name` at size factor `size` (`None`: the generator's default).
///
/// The same name and size give the same scene on every machine. Unknown names give
/// [`GenError::UnknownScene`] listing the known ones; size 0, a size the generator does not
/// support, or one whose scene would exceed [`builder::MAX_PRIMITIVES`] give
/// [`GenError::BadSize`].
pub fn generate(name: &str, size: Option<u32>) -> Result<SceneDescription, GenError> {
    match GENERATORS.iter().find(|(info, _)| info.name == name) {
        Some((info, f)) => f(size.unwrap_or(info.default_size)),
        None => Err(GenError::UnknownScene(
            name.to_string(),
            generators()
                .iter()
                .map(|g| g.name)
                .collect::<Vec<_>>()
                .join(", "),
        )),
    }
}
