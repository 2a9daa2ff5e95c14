//! Allocation-free latency statistics for the control loop.
//!
//! A [`Histogram`] counts durations in log-linear buckets (16 per power of
//! two, so any percentile is within 1/16 = 6.25 % of the true value) in a
//! fixed array; recording is a few integer operations. [`Window`] keeps two
//! histograms and swaps them every `window` samples, so the published
//! p50/p99/max always describe the last complete window (about the last
//! second at 1 kHz), not the whole run.

const SUB_BITS: u32 = 4;
const SUB: usize = 1 << SUB_BITS;
/// Buckets cover 0 ns up to 2^40 ns (≈ 18 minutes); larger values saturate.
const MAJORS: usize = 40 - SUB_BITS as usize + 1;
const BUCKETS: usize = SUB + MAJORS * SUB;

/// Counts of durations (ns) in log-linear buckets. 9 KiB, no heap.
#[derive(Clone)]
pub struct Histogram {
    counts: [u32; BUCKETS],
    total: u64,
    max: u64,
}

impl core::fmt::Debug for Histogram {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Histogram")
            .field("total", &self.total)
            .field("max", &self.max)
            .finish()
    }
}

impl Default for Histogram {
    fn default() -> Self {
        Self {
            counts: [0; BUCKETS],
            total: 0,
            max: 0,
        }
    }
}

fn bucket_of(v: u64) -> usize {
    if v < SUB as u64 {
        return v as usize;
    }
    let msb = 63 - v.leading_zeros(); // ≥ SUB_BITS
    let major = (msb - SUB_BITS) as usize;
    if major >= MAJORS {
        return BUCKETS - 1;
    }
    let sub = ((v >> (msb - SUB_BITS)) as usize) & (SUB - 1);
    SUB + major * SUB + sub
}

/// Upper edge (inclusive) of bucket `i`.
fn bucket_top(i: usize) -> u64 {
    if i < SUB {
        return i as u64;
    }
    let major = (i - SUB) / SUB;
    let sub = ((i - SUB) % SUB) as u64;
    let shift = major as u32;
    (((SUB as u64) | sub) << shift) + ((1u64 << shift) - 1)
}

impl Histogram {
    /// Records one duration (ns).
    pub fn record(&mut self, v: u64) {
        let b = bucket_of(v);
        self.counts[b] = self.counts[b].saturating_add(1);
        self.total += 1;
        self.max = self.max.max(v);
    }

    /// Number of durations recorded.
    pub fn count(&self) -> u64 {
        self.total
    }

    /// Largest duration recorded (exact).
    pub fn max(&self) -> u64 {
        self.max
    }

    /// The `q`-quantile (0..=1): an upper bound within 6.25 % of the true
    /// value, never above the maximum. 0 when empty.
    pub fn quantile(&self, q: f64) -> u64 {
        if self.total == 0 {
            return 0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.total as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c as u64;
            if seen >= rank {
                return bucket_top(i).min(self.max);
            }
        }
        self.max
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.counts = [0; BUCKETS];
        self.total = 0;
        self.max = 0;
    }
}

/// Percentiles of the last complete window of samples.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// Median (ns).
    pub p50: u64,
    /// 99th percentile (ns).
    pub p99: u64,
    /// Maximum (ns).
    pub max: u64,
    /// Samples in the window.
    pub count: u64,
}

/// Two histograms that take turns: one fills while the other holds the last
/// complete window.
#[derive(Debug, Clone)]
pub struct Window {
    filling: Histogram,
    last: Summary,
    window: u64,
}

impl Window {
    /// Windows of `window` samples (at least 1).
    pub fn new(window: u64) -> Self {
        Self {
            filling: Histogram::default(),
            last: Summary::default(),
            window: window.max(1),
        }
    }

    /// Records one duration (ns); closes the window when it is full.
    pub fn record(&mut self, v: u64) {
        self.filling.record(v);
        if self.filling.count() >= self.window {
            self.last = Summary {
                p50: self.filling.quantile(0.5),
                p99: self.filling.quantile(0.99),
                max: self.filling.max(),
                count: self.filling.count(),
            };
            self.filling.clear();
        }
    }

    /// The last complete window, or the partial one before the first closes.
    pub fn summary(&self) -> Summary {
        if self.last.count == 0 {
            Summary {
                p50: self.filling.quantile(0.5),
                p99: self.filling.quantile(0.99),
                max: self.filling.max(),
                count: self.filling.count(),
            }
        } else {
            self.last
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn buckets_are_contiguous_and_ordered() {
        let mut prev_top = None::<u64>;
        for i in 0..BUCKETS - 1 {
            let top = bucket_top(i);
            if let Some(p) = prev_top {
                assert!(top > p, "bucket {i}");
                assert_eq!(bucket_of(p + 1), i, "first value of bucket {i}");
            }
            assert_eq!(bucket_of(top), i, "top of bucket {i}");
            prev_top = Some(top);
        }
    }

    #[test]
    fn quantiles_of_a_known_distribution() {
        let mut h = Histogram::default();
        for v in 1..=1000u64 {
            h.record(v * 1000); // 1 µs .. 1 ms
        }
        let p50 = h.quantile(0.5) as f64;
        let p99 = h.quantile(0.99) as f64;
        // True values 500 µs and 990 µs; buckets are 1/16 wide.
        assert!((p50 / 500_000.0 - 1.0).abs() <= 1.0 / 16.0, "{p50}");
        assert!((p99 / 990_000.0 - 1.0).abs() <= 1.0 / 16.0, "{p99}");
        assert_eq!(h.max(), 1_000_000);
        assert_eq!(Histogram::default().quantile(0.5), 0);
    }

    #[test]
    fn window_reports_the_last_complete_window() {
        let mut w = Window::new(100);
        for _ in 0..100 {
            w.record(5_000);
        }
        for _ in 0..50 {
            w.record(1_000_000);
        }
        let s = w.summary();
        assert_eq!(s.count, 100);
        assert_eq!(s.max, 5_000);
    }

    proptest! {
        #[test]
        fn quantile_bounds_the_true_value(mut xs in proptest::collection::vec(0u64..10_000_000_000, 1..300), q in 0.0f64..1.0) {
            let mut h = Histogram::default();
            for &x in &xs { h.record(x); }
            xs.sort_unstable();
            let rank = ((q * xs.len() as f64).ceil() as usize).max(1);
            let truth = xs[rank - 1];
            let est = h.quantile(q);
            prop_assert!(est >= truth, "est {est} < truth {truth}");
            prop_assert!(est as f64 <= truth as f64 * (1.0 + 1.0 / 16.0) + 1.0, "est {est} truth {truth}");
        }
    }
}
