//! Exponential back-off between automatic recovery attempts.

use std::time::{Duration, Instant};

/// When to try recovering again: the first attempt at once, then after 20 ms
/// doubling to 2 s. A successful recovery does not reset the delay, so a bus
/// that keeps failing right after each recovery is retried less and less
/// often; the delay resets once a recovery has held for [`Backoff::STABLE`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Backoff {
    next_try: Option<Instant>,
    delay: Duration,
    recovered_at: Option<Instant>,
}

impl Backoff {
    pub(crate) const MIN: Duration = Duration::from_millis(20);
    pub(crate) const MAX: Duration = Duration::from_secs(2);
    pub(crate) const STABLE: Duration = Duration::from_secs(10);

    pub(crate) const fn new() -> Self {
        Self {
            next_try: None,
            delay: Self::MIN,
            recovered_at: None,
        }
    }

    /// Whether an attempt is due now; arms the next one.
    pub(crate) fn due(&mut self) -> bool {
        self.due_at(Instant::now())
    }

    fn due_at(&mut self, now: Instant) -> bool {
        if self
            .recovered_at
            .is_some_and(|t| now.saturating_duration_since(t) >= Self::STABLE)
        {
            *self = Self::new();
        }
        match self.next_try {
            Some(t) if now < t => false,
            _ => {
                self.next_try = Some(now + self.delay);
                self.delay = (self.delay * 2).min(Self::MAX);
                true
            }
        }
    }

    /// An automatic recovery succeeded.
    pub(crate) fn recovered(&mut self) {
        self.recovered_at(Instant::now());
    }

    fn recovered_at(&mut self, t: Instant) {
        self.recovered_at = Some(t);
    }

    /// The caller reopened the bus: start afresh.
    pub(crate) fn reset(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_double_up_to_the_cap_and_reset_after_a_stable_recovery() {
        let t0 = Instant::now();
        let mut b = Backoff::new();
        assert!(b.due_at(t0), "first attempt at once");
        assert!(!b.due_at(t0 + Duration::from_millis(19)));
        assert!(b.due_at(t0 + Duration::from_millis(20)));
        // Attempts at 20, 60, 140, ... ms: each wait doubles, capped at 2 s.
        let mut t = t0 + Duration::from_millis(20);
        let mut wait = Duration::from_millis(40);
        for _ in 0..10 {
            assert!(!b.due_at(t + wait - Duration::from_millis(1)));
            t += wait;
            assert!(b.due_at(t));
            wait = (wait * 2).min(Backoff::MAX);
        }
        assert_eq!(wait, Backoff::MAX);
        // A recovery that fails again soon keeps the long delay...
        b.recovered_at(t);
        assert!(!b.due_at(t + Duration::from_secs(1)));
        // ...one that held for STABLE starts again from an immediate retry.
        assert!(b.due_at(t + Backoff::STABLE));
        assert!(!b.due_at(t + Backoff::STABLE + Duration::from_millis(19)));
        assert!(b.due_at(t + Backoff::STABLE + Duration::from_millis(20)));
    }
}
