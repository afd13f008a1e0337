//! Benchmarks: contact (being written).
fn main() {}
