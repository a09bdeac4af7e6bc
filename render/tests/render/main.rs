//! Whole renders, one test binary: the same bits whatever the threads, tiles and executor; the
//! SPD procedure's ray counts; every real tile's statistics plausible; `--precision auto` and the
//! camera-relative frame; the memory-saving scene build equal to the borrowed one; an 8-bit
//! output's 8-bit film writing the linear film's bytes; a built renderer re-viewed for another
//! camera giving a fresh build's pixels.

use parrt_test_support as support;

mod determinism;
mod film_rgb8;
mod precision_auto;
mod scene_owned;
mod spd_stats;
mod stats_plausible;
mod with_view;
