//! Order statistics of timing samples: min, mean, percentiles, max and a histogram, as
//! cyclictest reports them. Samples are collected into preallocated buffers on the real-time
//! side and summarised here afterwards.

use serde::Serialize;

/// Summary of a set of samples in microseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Number of samples.
    pub count: usize,
    /// Smallest.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub p50: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest.
    pub max: f64,
}

/// Summarises samples given in nanoseconds, reporting microseconds. Percentiles are the
/// nearest-rank ones (the smallest sample with at least p% of samples at or below it).
pub fn summarise_ns(samples: &[u64]) -> Summary {
    if samples.is_empty() {
        return Summary::default();
    }
    let mut s = samples.to_vec();
    s.sort_unstable();
    let us = |ns: u64| ns as f64 / 1000.0;
    // Nearest rank in exact integer arithmetic: `per_mille` of the samples at or below.
    let rank = |per_mille: usize| {
        let r = (per_mille * s.len()).div_ceil(1000);
        s[r.clamp(1, s.len()) - 1]
    };
    Summary {
        count: s.len(),
        min: us(s[0]),
        mean: s.iter().map(|&x| x as f64).sum::<f64>() / s.len() as f64 / 1000.0,
        p50: us(rank(500)),
        p99: us(rank(990)),
        p999: us(rank(999)),
        max: us(s[s.len() - 1]),
    }
}

/// A histogram with 1 us buckets up to `buckets - 1` us; the last bucket holds everything
/// longer (cyclictest's overflow bucket).
pub fn histogram_us(samples: &[u64], buckets: usize) -> Vec<u64> {
    let mut h = vec![0u64; buckets.max(1)];
    let last = h.len() - 1;
    for &ns in samples {
        h[((ns / 1000) as usize).min(last)] += 1;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<u64> = (1..=1000).map(|i| i * 1000).collect();
        let s = summarise_ns(&v);
        assert_eq!(
            (s.min, s.p50, s.p99, s.p999, s.max),
            (1.0, 500.0, 990.0, 999.0, 1000.0)
        );
        assert!((s.mean - 500.5).abs() < 1e-9);
        assert_eq!(summarise_ns(&[]).count, 0);
    }

    #[test]
    fn histogram_overflow_bucket() {
        let h = histogram_us(&[0, 999, 1000, 5000, 1_000_000], 10);
        assert_eq!(h[0], 2);
        assert_eq!(h[1], 1);
        assert_eq!(h[5], 1);
        assert_eq!(h[9], 1);
    }
}
