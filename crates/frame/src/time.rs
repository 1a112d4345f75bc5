//! Microsecond time for the sans-IO protocol machines.
//!
//! The machines never read a clock: every input carries the current [`Instant`], and every
//! machine reports its next deadline as an `Instant`. A test drives them on a virtual clock by
//! passing whatever instants it likes; the master maps a monotonic OS clock onto these types
//! (see [`MonotonicClock`] under the `std` feature).
//!
//! Arithmetic saturates instead of overflowing: a deadline computed from a huge timeout is
//! "never" rather than a panic.

use core::fmt;
use core::ops::{Add, AddAssign, Sub};

/// A point in time, in microseconds since an arbitrary epoch chosen by the caller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Instant(u64);

/// A span of time in microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Duration(u64);

impl Instant {
    /// The epoch.
    pub const ZERO: Instant = Instant(0);
    /// The largest instant; used as "never".
    pub const MAX: Instant = Instant(u64::MAX);

    /// An instant `micros` microseconds after the epoch.
    pub const fn from_micros(micros: u64) -> Self {
        Self(micros)
    }

    /// An instant `millis` milliseconds after the epoch.
    pub const fn from_millis(millis: u64) -> Self {
        Self(millis.saturating_mul(1000))
    }

    /// Microseconds since the epoch.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Time from `earlier` to `self`, zero if `earlier` is later.
    pub const fn saturating_duration_since(self, earlier: Instant) -> Duration {
        Duration(self.0.saturating_sub(earlier.0))
    }

    /// `self + d`, or `None` on overflow.
    pub const fn checked_add(self, d: Duration) -> Option<Instant> {
        match self.0.checked_add(d.0) {
            Some(v) => Some(Instant(v)),
            None => None,
        }
    }
}

impl Duration {
    /// No time.
    pub const ZERO: Duration = Duration(0);
    /// The largest duration.
    pub const MAX: Duration = Duration(u64::MAX);

    /// From microseconds.
    pub const fn from_micros(micros: u64) -> Self {
        Self(micros)
    }

    /// From milliseconds (saturating).
    pub const fn from_millis(millis: u64) -> Self {
        Self(millis.saturating_mul(1000))
    }

    /// From seconds (saturating).
    pub const fn from_secs(secs: u64) -> Self {
        Self(secs.saturating_mul(1_000_000))
    }

    /// In microseconds.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// In whole milliseconds (rounded down).
    pub const fn as_millis(self) -> u64 {
        self.0 / 1000
    }

    /// Whether this is zero.
    pub const fn is_zero(self) -> bool {
        self.0 == 0
    }

    /// `self * n`, saturating.
    pub const fn saturating_mul(self, n: u64) -> Duration {
        Duration(self.0.saturating_mul(n))
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;
    /// Saturates at [`Instant::MAX`].
    fn add(self, d: Duration) -> Instant {
        Instant(self.0.saturating_add(d.0))
    }
}

impl AddAssign<Duration> for Instant {
    fn add_assign(&mut self, d: Duration) {
        *self = *self + d;
    }
}

impl Sub<Instant> for Instant {
    type Output = Duration;
    /// Saturates at zero.
    fn sub(self, earlier: Instant) -> Duration {
        self.saturating_duration_since(earlier)
    }
}

impl Sub<Duration> for Instant {
    type Output = Instant;
    /// Saturates at the epoch.
    fn sub(self, d: Duration) -> Instant {
        Instant(self.0.saturating_sub(d.0))
    }
}

impl Add for Duration {
    type Output = Duration;
    fn add(self, d: Duration) -> Duration {
        Duration(self.0.saturating_add(d.0))
    }
}

impl Sub for Duration {
    type Output = Duration;
    fn sub(self, d: Duration) -> Duration {
        Duration(self.0.saturating_sub(d.0))
    }
}

impl fmt::Display for Duration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_multiple_of(1000) {
            write!(f, "{} ms", self.0 / 1000)
        } else {
            write!(f, "{} µs", self.0)
        }
    }
}

impl fmt::Display for Instant {
    /// Seconds with six decimals, as candump's `-l` timestamps.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:06}", self.0 / 1_000_000, self.0 % 1_000_000)
    }
}

#[cfg(feature = "std")]
mod with_std {
    use super::{Duration, Instant};

    impl From<std::time::Duration> for Duration {
        fn from(d: std::time::Duration) -> Self {
            Duration(u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
        }
    }

    impl From<Duration> for std::time::Duration {
        fn from(d: Duration) -> Self {
            std::time::Duration::from_micros(d.0)
        }
    }

    /// Maps the operating system's monotonic clock onto [`Instant`], with the epoch at creation.
    #[derive(Debug, Clone, Copy)]
    pub struct MonotonicClock {
        start: std::time::Instant,
    }

    impl MonotonicClock {
        /// A clock whose epoch is now.
        pub fn new() -> Self {
            Self {
                start: std::time::Instant::now(),
            }
        }

        /// The current instant.
        pub fn now(&self) -> Instant {
            // Seconds and microseconds apart: no 128-bit arithmetic on this per-frame path.
            let d = self.start.elapsed();
            Instant(
                d.as_secs()
                    .saturating_mul(1_000_000)
                    .saturating_add(u64::from(d.subsec_micros())),
            )
        }

        /// The OS instant corresponding to `at` (for sleeping until a deadline).
        pub fn to_std(&self, at: Instant) -> std::time::Instant {
            self.start
                .checked_add(std::time::Duration::from_micros(at.0))
                .unwrap_or_else(|| self.start + std::time::Duration::from_secs(86_400 * 365))
        }
    }

    impl Default for MonotonicClock {
        fn default() -> Self {
            Self::new()
        }
    }
}

#[cfg(feature = "std")]
pub use with_std::MonotonicClock;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturating_arithmetic() {
        let t = Instant::from_millis(5);
        assert_eq!(t + Duration::from_millis(1), Instant::from_micros(6000));
        assert_eq!(Instant::MAX + Duration::from_secs(1), Instant::MAX);
        assert_eq!(Instant::ZERO - Instant::from_micros(5), Duration::ZERO);
        assert_eq!(t - Duration::from_secs(1), Instant::ZERO);
        assert_eq!(Duration::from_millis(500).as_millis(), 500);
        assert_eq!(
            Instant::from_micros(1_500_000).checked_add(Duration::MAX),
            None
        );
    }
}
