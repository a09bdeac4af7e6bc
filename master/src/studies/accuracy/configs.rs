//! The configurations the study measures, and the reference they are measured against. The
//! full cross product (5 cut-offs × 8 depths × 2 precisions × 2 sample counts = 160 renders per
//! scene) is pruned to the slices that answer the questions asked: the whole cut-off × depth
//! plane in the default regime (f32, 1 sample), and a 3 × 3 sub-grid of it for f64 and for
//! 4 samples, plus two f64/4-sample corners.

use parrt_render::settings::{Precision, RenderSettings};

/// The cut-off thresholds studied.
pub const CUTOFFS: [f64; 5] = [0.0, 0.001, 0.01, 0.05, 0.1];
/// The depth limits studied (eye ray = 1).
pub const DEPTHS: [u32; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

/// Reference: double precision, no cut-off, depth 16, 16 stratified samples per pixel.
pub const REF_DEPTH: u32 = 16;
/// Samples per pixel of the reference.
pub const REF_SPP: u32 = 16;

/// One configuration of the renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Adaptive cut-off (0 = none).
    pub cutoff: f64,
    /// Depth limit.
    pub depth: u32,
    /// Geometric precision.
    pub precision: Precision,
    /// Samples per pixel.
    pub spp: u32,
}

impl Config {
    /// The render settings of this configuration at `width × height`.
    pub fn settings(&self, width: u32, height: u32) -> RenderSettings {
        let mut s = RenderSettings::new(width, height);
        s.cutoff = self.cutoff;
        s.max_depth = self.depth;
        s.precision = self.precision;
        s.spp = self.spp;
        s
    }

    /// `f32`/`f64`.
    pub fn precision_name(&self) -> &'static str {
        match self.precision {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
            Precision::Auto => "auto",
        }
    }

    /// A short label: `c0.001 d5 f32 1spp`.
    pub fn label(&self) -> String {
        format!(
            "c{} d{} {} {}spp",
            self.cutoff,
            self.depth,
            self.precision_name(),
            self.spp
        )
    }

    /// True for the renderer's defaults (cut-off, depth, precision, one sample).
    pub fn is_default(&self) -> bool {
        self.cutoff == parrt_render::settings::DEFAULT_CUTOFF
            && self.depth == parrt_render::settings::DEFAULT_MAX_DEPTH
            && self.precision == Precision::F32
            && self.spp == 1
    }
}

/// The reference configuration for `spp` samples (the study's reference uses [`REF_SPP`]; the
/// same-sampling references isolate truncation and precision error from sampling error).
pub fn reference(spp: u32) -> Config {
    Config {
        cutoff: 0.0,
        depth: REF_DEPTH,
        precision: Precision::F64,
        spp,
    }
}

/// The configurations measured: `full` gives the whole cross product, otherwise the pruned set
/// described in the module documentation. No duplicates; f32/1-sample configurations first.
pub fn grid(full: bool) -> Vec<Config> {
    let mut out = Vec::new();
    let mut add = |cutoff: f64, depth: u32, precision: Precision, spp: u32| {
        let c = Config {
            cutoff,
            depth,
            precision,
            spp,
        };
        if !out.contains(&c) {
            out.push(c);
        }
    };
    if full {
        for spp in [1, 4] {
            for precision in [Precision::F32, Precision::F64] {
                for &c in &CUTOFFS {
                    for &d in &DEPTHS {
                        add(c, d, precision, spp);
                    }
                }
            }
        }
        return out;
    }
    for &c in &CUTOFFS {
        for &d in &DEPTHS {
            add(c, d, Precision::F32, 1);
        }
    }
    for (precision, spp) in [(Precision::F64, 1), (Precision::F32, 4)] {
        for c in [0.0, 0.001, 0.1] {
            for d in [2, 5, 8] {
                add(c, d, precision, spp);
            }
        }
    }
    add(0.001, 5, Precision::F64, 4);
    add(0.0, 8, Precision::F64, 4);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_have_the_expected_sizes_and_hold_the_default() {
        assert_eq!(grid(true).len(), 160);
        let g = grid(false);
        assert_eq!(g.len(), 40 + 9 + 9 + 2);
        assert!(g.iter().any(Config::is_default));
        assert!(g.iter().all(|c| *c != reference(REF_SPP)));
    }

    #[test]
    fn settings_carry_the_configuration() {
        let c = Config {
            cutoff: 0.05,
            depth: 3,
            precision: Precision::F64,
            spp: 4,
        };
        let s = c.settings(32, 16);
        assert_eq!((s.width, s.height, s.max_depth, s.spp), (32, 16, 3, 4));
        assert_eq!((s.cutoff, s.precision), (0.05, Precision::F64));
        assert!(parrt_render::render::validate_settings(&s).is_ok());
        assert_eq!(c.label(), "c0.05 d3 f64 4spp");
    }
}
