//! `parrt-worker`: the same program as `parrt worker`.
fn main() {}
