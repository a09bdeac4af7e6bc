//! The NFF reader and writer, one test binary with a file per subject: what the reader accepts
//! and how it reads it ([`parse`]), its numbers ([`number`]), the round trip through the writer
//! ([`roundtrip`]), every SPD file ([`spd`]), damaged files ([`mutation`]), and counts checked
//! before allocating ([`alloc`]).

use parrt_test_support as support;

mod alloc;
mod mutation;
mod number;
mod parse;
mod roundtrip;
mod spd;
