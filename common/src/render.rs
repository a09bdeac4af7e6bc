//! The renderer facade: builds a render-ready scene and accelerator from a description and
//! settings once, then renders any tile on any thread. Every pixel depends only on the scene,
//! the settings and its own coordinates, so tiles can be rendered in any order, anywhere.
//!
//! PLACEHOLDER BODY: the tracing core lands in the renderer-core change; until then
//! `render_tile` paints a deterministic gradient so callers (SMP, distributed) can be built and
//! tested against the final API.

use crate::description::SceneDescription;
use crate::film::Rgb;
use crate::settings::RenderSettings;
use crate::stats::RayStats;
use crate::tile::Tile;
use thiserror::Error;

/// Errors building a renderer.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The image has no pixels.
    #[error("image size {0}x{1} has no pixels")]
    EmptyImage(u32, u32),
}

/// Preprocessing figures of a built renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct BuildInfo {
    /// Seconds spent building the render-ready scene and the accelerator.
    pub build_s: f64,
}

/// A scene ready to trace, with its settings.
pub struct Renderer {
    settings: RenderSettings,
    background: [f32; 3],
    info: BuildInfo,
}

impl Renderer {
    /// Builds the render-ready scene and accelerator.
    pub fn new(desc: &SceneDescription, settings: &RenderSettings) -> Result<Self, RenderError> {
        if settings.width == 0 || settings.height == 0 {
            return Err(RenderError::EmptyImage(settings.width, settings.height));
        }
        let b = desc.background;
        Ok(Renderer {
            settings: settings.clone(),
            background: [b.x as f32, b.y as f32, b.z as f32],
            info: BuildInfo::default(),
        })
    }

    /// The settings this renderer was built with.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Preprocessing figures.
    pub fn build_info(&self) -> BuildInfo {
        self.info
    }

    /// Renders one tile into `out` (cleared first; row-major within the tile), adding to `stats`.
    pub fn render_tile(&self, tile: &Tile, out: &mut Vec<Rgb>, stats: &mut RayStats) {
        out.clear();
        let (w, h) = (self.settings.width as f32, self.settings.height as f32);
        for y in tile.y..tile.y + tile.h {
            for x in tile.x..tile.x + tile.w {
                stats.eye_rays += 1;
                out.push([
                    self.background[0] * (x as f32 + 0.5) / w,
                    self.background[1] * (y as f32 + 0.5) / h,
                    self.background[2],
                ]);
            }
        }
    }
}
