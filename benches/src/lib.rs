//! Shared set-up for tetradrill's benchmarks and worst-case timing harness.
