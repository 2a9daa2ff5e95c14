//! Time on the bus: one nanosecond count for the daemon's loop clock, the
//! simulated node's firmware clock, watchdog timeouts and heartbeat periods.
//!
//! [`Nanos`] is both an instant on a monotonic clock (nanoseconds since that
//! clock's origin) and a span between two instants, as the `u64` it wraps
//! was before. It prints and parses as the plain integer, so logs that
//! record times (`session.log`'s `P <ns> …`) read exactly as before.
//!
//! ```
//! use anguilla_protocol::time::Nanos;
//! use std::time::Duration;
//! let t = Nanos::from_millis(20);
//! assert_eq!(t.as_nanos(), 20_000_000);
//! assert_eq!(t + Nanos::from_nanos(5), Nanos::from_nanos(20_000_005));
//! assert_eq!(Nanos::ZERO.saturating_sub(t), Nanos::ZERO);
//! assert_eq!(Duration::from(t), Duration::from_millis(20));
//! assert_eq!(t.to_string(), "20000000");
//! assert_eq!("20000000".parse::<Nanos>()?, t);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt;
use core::ops::{Add, AddAssign, Div, Mul, Sub, SubAssign};
use core::str::FromStr;
use std::time::Duration;

/// A count of nanoseconds on a monotonic clock: an instant or a span.
///
/// Arithmetic behaves as `u64` arithmetic does (`+` and `-` panic on
/// overflow in debug builds); use [`Nanos::saturating_sub`] and
/// [`Nanos::checked_add`] where the operands may cross.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[repr(transparent)]
pub struct Nanos(u64);

impl Nanos {
    /// The clock's origin, or an empty span.
    pub const ZERO: Nanos = Nanos(0);
    /// The largest representable time (about 584 years).
    pub const MAX: Nanos = Nanos(u64::MAX);

    /// `ns` nanoseconds.
    pub const fn from_nanos(ns: u64) -> Nanos {
        Nanos(ns)
    }

    /// `ms` milliseconds; saturates at [`Nanos::MAX`].
    pub const fn from_millis(ms: u64) -> Nanos {
        Nanos(ms.saturating_mul(1_000_000))
    }

    /// `s` seconds, truncated to whole nanoseconds, as the `as u64` cast it
    /// replaces: negative and NaN give zero, too large gives [`Nanos::MAX`].
    pub fn from_secs_f64(s: f64) -> Nanos {
        Nanos((s * 1e9) as u64)
    }

    /// The count in nanoseconds.
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// The count in seconds.
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 / 1e9
    }

    /// `self - earlier`, or zero if `earlier` is later.
    pub const fn saturating_sub(self, earlier: Nanos) -> Nanos {
        Nanos(self.0.saturating_sub(earlier.0))
    }

    /// `self + span`, or `None` on overflow.
    pub const fn checked_add(self, span: Nanos) -> Option<Nanos> {
        match self.0.checked_add(span.0) {
            Some(ns) => Some(Nanos(ns)),
            None => None,
        }
    }

    /// `self - span`, or `None` if `span` is larger.
    pub const fn checked_sub(self, span: Nanos) -> Option<Nanos> {
        match self.0.checked_sub(span.0) {
            Some(ns) => Some(Nanos(ns)),
            None => None,
        }
    }

    /// `self + span`, saturating at [`Nanos::MAX`].
    pub const fn saturating_add(self, span: Nanos) -> Nanos {
        Nanos(self.0.saturating_add(span.0))
    }
}

impl Add for Nanos {
    type Output = Nanos;
    fn add(self, rhs: Nanos) -> Nanos {
        Nanos(self.0 + rhs.0)
    }
}

impl AddAssign for Nanos {
    fn add_assign(&mut self, rhs: Nanos) {
        self.0 += rhs.0;
    }
}

impl Sub for Nanos {
    type Output = Nanos;
    fn sub(self, rhs: Nanos) -> Nanos {
        Nanos(self.0 - rhs.0)
    }
}

impl SubAssign for Nanos {
    fn sub_assign(&mut self, rhs: Nanos) {
        self.0 -= rhs.0;
    }
}

/// A span repeated `n` times.
impl Mul<u64> for Nanos {
    type Output = Nanos;
    fn mul(self, n: u64) -> Nanos {
        Nanos(self.0 * n)
    }
}

/// A span repeated `n` times.
impl Mul<Nanos> for u64 {
    type Output = Nanos;
    fn mul(self, span: Nanos) -> Nanos {
        Nanos(self * span.0)
    }
}

/// How many whole `span`s fit in `self` (panics if `span` is zero).
impl Div for Nanos {
    type Output = u64;
    fn div(self, span: Nanos) -> u64 {
        self.0 / span.0
    }
}

/// Saturates at [`Nanos::MAX`] (a `Duration` can be about 2^34 times longer).
impl From<Duration> for Nanos {
    fn from(d: Duration) -> Nanos {
        Nanos(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
    }
}

impl From<Nanos> for Duration {
    fn from(t: Nanos) -> Duration {
        Duration::from_nanos(t.0)
    }
}

/// The plain integer, as logs have always written it.
impl fmt::Display for Nanos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

/// Parses the plain integer [`Display`](fmt::Display) writes.
impl FromStr for Nanos {
    type Err = core::num::ParseIntError;
    fn from_str(s: &str) -> Result<Nanos, Self::Err> {
        s.parse().map(Nanos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constructors_agree() {
        assert_eq!(Nanos::from_millis(3), Nanos::from_nanos(3_000_000));
        assert_eq!(Nanos::from_secs_f64(0.003), Nanos::from_nanos(3_000_000));
        assert_eq!(Nanos::from_secs_f64(-1.0), Nanos::ZERO);
        assert_eq!(Nanos::from_secs_f64(f64::NAN), Nanos::ZERO);
        assert_eq!(Nanos::from_secs_f64(1e30), Nanos::MAX);
        assert_eq!(Nanos::from_millis(u64::MAX), Nanos::MAX);
    }

    #[test]
    fn arithmetic_is_u64_arithmetic() {
        let a = Nanos::from_nanos(7);
        let b = Nanos::from_nanos(5);
        assert_eq!((a - b).as_nanos(), 2);
        assert_eq!(b.saturating_sub(a), Nanos::ZERO);
        assert_eq!(Nanos::MAX.checked_add(a), None);
        assert_eq!(b.checked_sub(a), None);
        assert_eq!(a.checked_add(b), Some(Nanos::from_nanos(12)));
        assert_eq!(a * 3, Nanos::from_nanos(21));
        assert_eq!(3 * a, a * 3);
        assert_eq!(Nanos::from_nanos(22) / a, 3);
    }

    #[test]
    fn duration_round_trip_and_text() {
        let t = Nanos::from_nanos(1_234_567_890);
        assert_eq!(Nanos::from(Duration::from(t)), t);
        assert_eq!(Nanos::from(Duration::MAX), Nanos::MAX);
        assert_eq!(t.to_string(), "1234567890");
        assert_eq!("1234567890".parse::<Nanos>(), Ok(t));
        assert!("-1".parse::<Nanos>().is_err());
    }
}
