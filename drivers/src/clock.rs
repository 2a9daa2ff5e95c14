//! Time sources for buses that simulate wire time.
//!
//! A [`Clock`] gives the time elapsed since an arbitrary origin. The daemon
//! and the in-process bus take their clock as a parameter so that system
//! tests can run on a [`ManualClock`] (faster than real time, reproducible)
//! and production on a [`MonotonicClock`].

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A monotonic time source.
pub trait Clock: Send + Sync {
    /// Time since this clock's origin; never decreases.
    fn now(&self) -> Duration;
    /// Whether this clock follows real time (then waiting for it makes sense).
    fn is_real_time(&self) -> bool;
}

/// Real time: `Instant` since the clock was made.
#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    origin: Instant,
}

impl MonotonicClock {
    /// A clock whose origin is now.
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
        }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }
    fn is_real_time(&self) -> bool {
        true
    }
}

/// Simulated time that moves only when told to. Clones share the same time.
#[derive(Debug, Clone, Default)]
pub struct ManualClock {
    nanos: Arc<AtomicU64>,
}

impl ManualClock {
    /// A clock at time zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// Moves time forward by `d`.
    pub fn advance(&self, d: Duration) {
        self.nanos
            .fetch_add(d.as_nanos().min(u64::MAX as u128) as u64, Ordering::SeqCst);
    }

    /// Moves time forward to `t` (no effect if `t` is in the past).
    pub fn advance_to(&self, t: Duration) {
        self.nanos
            .fetch_max(t.as_nanos().min(u64::MAX as u128) as u64, Ordering::SeqCst);
    }
}

impl Clock for ManualClock {
    fn now(&self) -> Duration {
        Duration::from_nanos(self.nanos.load(Ordering::SeqCst))
    }
    fn is_real_time(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_clock_moves_only_forward_and_is_shared() {
        let c = ManualClock::new();
        let c2 = c.clone();
        c.advance(Duration::from_millis(5));
        assert_eq!(c2.now(), Duration::from_millis(5));
        c2.advance_to(Duration::from_millis(3));
        assert_eq!(c.now(), Duration::from_millis(5));
        c2.advance_to(Duration::from_millis(9));
        assert_eq!(c.now(), Duration::from_millis(9));
        assert!(!c.is_real_time());
    }

    #[test]
    fn monotonic_clock_never_decreases() {
        let c = MonotonicClock::new();
        let a = c.now();
        let b = c.now();
        assert!(b >= a);
        assert!(c.is_real_time());
    }
}
