//! The timer vocabulary of the sans-IO machines: a periodic timer for producers (SYNC, TIME,
//! heartbeat, node-guarding polls), the "is this deadline due" test a driver makes before
//! `handle_timeout`, and the earliest of several deadlines for `poll_timeout`.
//!
//! A machine keeps its deadlines as `Option<Instant>` (`None`: nothing armed) or as
//! [`Periodic`] timers, reports the earliest with [`earliest`], and its driver calls
//! `handle_timeout(now)` when [`is_due`] holds for that deadline:
//!
//! ```
//! use canola_frame::{Duration, Instant, Periodic, earliest, is_due};
//!
//! let mut sync = Periodic::new(Duration::from_millis(10));
//! sync.start_at(Instant::ZERO);
//! let response_timeout = Some(Instant::from_millis(4));
//! let next = earliest([sync.deadline(), response_timeout]);
//! assert_eq!(next, Some(Instant::ZERO));
//! assert!(is_due(next, Instant::ZERO));
//! assert!(sync.fire(Instant::ZERO));
//! assert_eq!(sync.deadline(), Some(Instant::from_millis(10)));
//! ```

use crate::time::{Duration, Instant};

/// Whether a machine's deadline has come: `Some(t)` with `t <= now`. `None` (nothing armed) is
/// never due. The guard before every `handle_timeout(now)` call.
pub fn is_due(deadline: Option<Instant>, now: Instant) -> bool {
    deadline.is_some_and(|t| t <= now)
}

/// The earliest of several optional deadlines (`None` when none is armed).
pub fn earliest(deadlines: impl IntoIterator<Item = Option<Instant>>) -> Option<Instant> {
    deadlines.into_iter().flatten().min()
}

/// A timer due every `period`: the tail every periodic producer shares.
///
/// [`start_at`](Self::start_at) arms it for a first instant; each [`fire`](Self::fire) at or
/// after the deadline moves the deadline one period on from the old one, so the rhythm does not
/// drift with the caller's lateness, but never into the past: a caller that slept through
/// several periods gets one firing, not a burst. A zero period never arms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Periodic {
    period: Duration,
    next: Option<Instant>,
}

impl Periodic {
    /// A stopped timer with `period`.
    pub const fn new(period: Duration) -> Self {
        Self { period, next: None }
    }

    /// Arms the timer: first due at `first` (nothing happens with a zero period).
    pub fn start_at(&mut self, first: Instant) {
        self.next = (!self.period.is_zero()).then_some(first);
    }

    /// Disarms the timer.
    pub fn stop(&mut self) {
        self.next = None;
    }

    /// Changes the period; a running timer keeps its next deadline (call
    /// [`start_at`](Self::start_at) to restart the rhythm). A zero period stops it.
    pub fn set_period(&mut self, period: Duration) {
        self.period = period;
        if period.is_zero() {
            self.next = None;
        }
    }

    /// The period.
    pub const fn period(&self) -> Duration {
        self.period
    }

    /// Whether the timer is armed.
    pub const fn is_running(&self) -> bool {
        self.next.is_some()
    }

    /// The next deadline, if armed.
    pub const fn deadline(&self) -> Option<Instant> {
        self.next
    }

    /// If the deadline has come at `now`: moves it one period on (see the type's docs) and
    /// returns true. Otherwise returns false and changes nothing.
    pub fn fire(&mut self, now: Instant) -> bool {
        match self.next {
            Some(due) if due <= now => {
                let next = due + self.period;
                self.next = Some(if next <= now { now + self.period } else { next });
                true
            }
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Instant {
        Instant::from_millis(v)
    }

    #[test]
    fn due_and_earliest() {
        assert!(!is_due(None, Instant::MAX));
        assert!(is_due(Some(ms(5)), ms(5)));
        assert!(!is_due(Some(ms(5)), ms(4)));
        assert_eq!(
            earliest([None, Some(ms(7)), Some(ms(3)), None]),
            Some(ms(3))
        );
        assert_eq!(earliest([None, None]), None);
        assert_eq!(earliest(core::iter::empty()), None);
    }

    #[test]
    fn periodic_keeps_its_rhythm_without_bursts() {
        let mut t = Periodic::new(Duration::from_millis(10));
        assert!(!t.fire(ms(100)), "stopped");
        t.start_at(ms(0));
        assert!(t.fire(ms(0)));
        assert!(!t.fire(ms(9)));
        // Late by 3 ms: the next one is still due at 20, not 23.
        assert!(t.fire(ms(13)));
        assert_eq!(t.deadline(), Some(ms(20)));
        // Asleep for several periods: one firing, then a period from now.
        assert!(t.fire(ms(55)));
        assert_eq!(t.deadline(), Some(ms(65)));
        assert!(!t.fire(ms(55)));
        t.set_period(Duration::ZERO);
        assert!(!t.is_running());
        t.start_at(ms(70));
        assert_eq!(t.deadline(), None, "a zero period never arms");
        t.set_period(Duration::from_millis(1));
        t.start_at(ms(70));
        t.stop();
        assert!(!t.fire(ms(80)));
    }
}
