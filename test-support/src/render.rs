//! Rendering a built scene in a test: the SMP renderer at a chosen thread count, tile size and
//! executor, with no progress reporting (what every image test needs, in one call).

use parrt_render::render::Renderer;
use parrt_render::smp::{render_smp, Executor, SmpOptions, SmpResult};

/// `renderer`'s image and counts, rendered by `threads` threads in `tile`-pixel tiles handed
/// out by `executor`.
pub fn render_with(
    renderer: &Renderer,
    threads: usize,
    tile: u32,
    executor: Executor,
) -> SmpResult {
    render_smp(
        renderer,
        &SmpOptions {
            threads,
            tile,
            executor,
        },
        &|_, _| {},
    )
}
