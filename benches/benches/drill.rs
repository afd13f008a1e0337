//! Benchmarks: drill (being written).
fn main() {}
