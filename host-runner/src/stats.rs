//! Order statistics of timing samples: min, mean, percentiles, max and a histogram, as
//! cyclictest reports them.
//!
//! Runs of a known length (`replay`, `timing`) collect their samples into preallocated buffers
//! and summarise them here afterwards ([`summarise_ns`], [`histogram_us`]). A real-time run has
//! no known length: its servo records into a [`Histogram`] of fixed, log-linear buckets,
//! allocated once before its loop, which the status line, the viewer and the JSON all read.

use std::sync::atomic::{AtomicU64, Ordering};

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

/// Nanoseconds per unit of a [`Histogram`]'s buckets: 1/8 us, so that every bucket up to
/// 256 us lies inside one microsecond (the 1 us histogram of the JSON is exact there).
pub const HIST_UNIT_NS: u64 = 125;
/// Bits of a bucket's sub-range: values below `2^HIST_BITS` units have a bucket each; above,
/// each power of two has `2^(HIST_BITS - 1)` buckets (relative width at most 1/128).
const HIST_BITS: u32 = 8;
const HIST_SUB: u64 = 1 << HIST_BITS;
const HIST_HALF: u64 = HIST_SUB / 2;
/// Values of `2^HIST_TOP` units (about 38 hours) and more share the overflow bucket.
const HIST_TOP: u32 = 40;
/// Buckets of a [`Histogram`], the overflow bucket included.
pub const HIST_BUCKETS: usize = (HIST_SUB + (HIST_TOP - HIST_BITS) as u64 * HIST_HALF) as usize + 1;

/// The bucket of a value of `units` ([`HIST_UNIT_NS`] each).
fn hist_index(units: u64) -> usize {
    if units < HIST_SUB {
        return units as usize;
    }
    let e = 63 - units.leading_zeros();
    if e >= HIST_TOP {
        return HIST_BUCKETS - 1;
    }
    let shift = e - (HIST_BITS - 1);
    (HIST_SUB + u64::from(shift - 1) * HIST_HALF + ((units >> shift) - HIST_HALF)) as usize
}

/// The units bucket `i` holds: `[low, high)` (the overflow bucket's high is `u64::MAX`).
fn hist_range(i: usize) -> (u64, u64) {
    let i = i as u64;
    if i < HIST_SUB {
        return (i, i + 1);
    }
    let k = i - HIST_SUB;
    let shift = k / HIST_HALF + 1;
    if shift > u64::from(HIST_TOP - HIST_BITS) {
        return (1 << HIST_TOP, u64::MAX);
    }
    let low = (k % HIST_HALF + HIST_HALF) << shift;
    (low, low + (1 << shift))
}

/// A histogram of durations in fixed log-linear buckets ([`HIST_BUCKETS`] of them, about 35 KB
/// allocated and touched when it is made): 125 ns wide up to 32 us, then 1/128 of the value at
/// most, up to about 38 hours (longer ones share an overflow bucket). It also keeps the exact
/// count, sum, minimum and maximum. Recording is a few relaxed atomic operations (no
/// allocation, no lock, no wait), so the servo records while other threads read; its memory
/// does not grow with the number of samples.
#[derive(Debug)]
pub struct Histogram {
    counts: Box<[AtomicU64]>,
    count: AtomicU64,
    sum_ns: AtomicU64,
    min_ns: AtomicU64,
    max_ns: AtomicU64,
}

impl Default for Histogram {
    fn default() -> Self {
        Self::new()
    }
}

impl Histogram {
    /// An empty histogram (its buckets allocated and written, so every page is resident).
    pub fn new() -> Self {
        Self {
            counts: (0..HIST_BUCKETS).map(|_| AtomicU64::new(0)).collect(),
            count: AtomicU64::new(0),
            sum_ns: AtomicU64::new(0),
            min_ns: AtomicU64::new(u64::MAX),
            max_ns: AtomicU64::new(0),
        }
    }

    /// Counts one duration of `ns` nanoseconds.
    ///
    /// # Bounded work
    /// Constant: a leading-zero count and five relaxed atomic operations; no allocation, no
    /// lock.
    pub fn record(&self, ns: u64) {
        if let Some(c) = self.counts.get(hist_index(ns / HIST_UNIT_NS)) {
            c.fetch_add(1, Ordering::Relaxed);
        }
        self.count.fetch_add(1, Ordering::Relaxed);
        self.sum_ns.fetch_add(ns, Ordering::Relaxed);
        self.min_ns.fetch_min(ns, Ordering::Relaxed);
        self.max_ns.fetch_max(ns, Ordering::Relaxed);
    }

    /// Durations counted.
    pub fn count(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }

    /// The exact largest duration, ns (0 before the first).
    pub fn max_ns(&self) -> u64 {
        self.max_ns.load(Ordering::Relaxed)
    }

    /// The nearest-rank percentile `per_mille` (0..=1000: 990 is p99), ns, `None` before the
    /// first duration: the upper edge of the bucket that holds the sample of that rank, kept
    /// within the exact minimum and maximum. It is never below the exact percentile and above
    /// it by at most the bucket's width (125 ns up to 32 us, then 1/128 of the value).
    ///
    /// # Bounded work
    /// One pass over [`HIST_BUCKETS`] counters.
    pub fn percentile_ns(&self, per_mille: u32) -> Option<u64> {
        let n: u64 = self.counts.iter().map(|c| c.load(Ordering::Relaxed)).sum();
        if n == 0 {
            return None;
        }
        let rank = (u64::from(per_mille.min(1000)) * n).div_ceil(1000).max(1);
        let (lo, hi) = (
            self.min_ns.load(Ordering::Relaxed),
            self.max_ns.load(Ordering::Relaxed),
        );
        let mut seen = 0u64;
        for (i, c) in self.counts.iter().enumerate() {
            seen += c.load(Ordering::Relaxed);
            if seen >= rank {
                let top = hist_range(i).1.saturating_mul(HIST_UNIT_NS);
                return Some(top.min(hi).max(lo.min(hi)));
            }
        }
        Some(hi)
    }

    /// The summary in microseconds: exact count, minimum, mean and maximum; the percentiles
    /// as [`Histogram::percentile_ns`] gives them.
    pub fn summary(&self) -> Summary {
        let count = self.count();
        if count == 0 {
            return Summary::default();
        }
        let us = |ns: u64| ns as f64 / 1000.0;
        let p = |pm: u32| us(self.percentile_ns(pm).unwrap_or(0));
        Summary {
            count: count as usize,
            min: us(self.min_ns.load(Ordering::Relaxed)),
            mean: self.sum_ns.load(Ordering::Relaxed) as f64 / count as f64 / 1000.0,
            p50: p(500),
            p99: p(990),
            p999: p(999),
            max: us(self.max_ns()),
        }
    }

    /// A histogram with 1 us buckets up to `buckets - 1` us and an overflow bucket, as
    /// [`histogram_us`] makes from the samples: exact up to 256 us (every bucket there lies
    /// inside one microsecond); a wider bucket counts where it starts.
    pub fn histogram_us(&self, buckets: usize) -> Vec<u64> {
        let mut h = vec![0u64; buckets.max(1)];
        let last = h.len() - 1;
        for (i, c) in self.counts.iter().enumerate() {
            let c = c.load(Ordering::Relaxed);
            if c > 0 {
                let us = hist_range(i).0.saturating_mul(HIST_UNIT_NS) / 1000;
                h[(us as usize).min(last)] += c;
            }
        }
        h
    }
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

    #[test]
    fn buckets_tile_the_range_in_order() {
        let mut next = 0u64;
        for i in 0..HIST_BUCKETS {
            let (lo, hi) = hist_range(i);
            assert_eq!(lo, next, "bucket {i}");
            assert!(hi > lo);
            assert_eq!(hist_index(lo), i);
            assert_eq!(hist_index(hi - 1), i);
            if lo >= HIST_SUB && i + 1 < HIST_BUCKETS {
                assert!((hi - lo) * 128 <= lo, "bucket {i} too wide");
            }
            next = hi;
        }
        assert_eq!(next, u64::MAX);
        assert_eq!(hist_index(u64::MAX), HIST_BUCKETS - 1);
    }
}

/// A volume for a summary line: six decimals for an object of a unit's size or more, six
/// significant digits (`1.23457e-7`) for a small one, whose decimals would all be zero (a
/// tooth in metres is 4e-7 m^3).
pub fn volume_text(v: f64, object_volume: f64) -> String {
    if object_volume.abs() >= 1e-2 || v == 0.0 && object_volume == 0.0 {
        format!("{v:.6}")
    } else {
        format!("{v:.5e}")
    }
}

#[cfg(test)]
mod volume_text_tests {
    use super::volume_text;

    #[test]
    fn small_objects_keep_their_digits() {
        assert_eq!(volume_text(0.031705, 1.0), "0.031705");
        assert_eq!(volume_text(1.0, 1.0), "1.000000");
        assert_eq!(volume_text(6.93e-9, 3.954e-7), "6.93000e-9");
        assert_eq!(volume_text(3.954e-7, 3.954e-7), "3.95400e-7");
        assert_eq!(volume_text(0.0, 0.0), "0.000000");
    }
}
