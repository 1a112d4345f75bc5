//! TIME (CiA 301 §7.2.6): the TIME_OF_DAY message and a sans-IO producer.
//!
//! Six data bytes, little-endian: milliseconds after midnight in bits 0..=27 of the first four
//! bytes (bits 28..=31 reserved, sent as 0 and ignored on reception), then the number of days since
//! 1984-01-01 as UNSIGNED16. 1984-01-01 is Unix day 5113 (14 years of 365 days plus the leap days
//! of 1972, 1976 and 1980).

use canola_frame::{CanFrame, Duration, Instant, Periodic};

use crate::error::{ConfigError, DecodeError};
use crate::util::{data_frame, service_data};

/// The default TIME COB-ID.
pub const TIME_COB_ID: u16 = canola_frame::cob::TIME;

/// 1984-01-01 as days since 1970-01-01.
pub const EPOCH_1984_UNIX_DAYS: u64 = 5113;

const MS_PER_DAY: u64 = 86_400_000;
const MS_MASK: u32 = 0x0FFF_FFFF;

/// A TIME_OF_DAY value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TimeOfDay {
    // Field order makes the derived ordering chronological.
    days: u16,
    millis: u32,
}

impl TimeOfDay {
    /// From days since 1984-01-01 and milliseconds after midnight. The milliseconds must fit the
    /// 28-bit field (values of a day or more are accepted, as received values may carry them).
    pub const fn new(days: u16, millis: u32) -> Result<Self, ConfigError> {
        if millis > MS_MASK {
            return Err(ConfigError::MillisOutOfRange(millis));
        }
        Ok(Self { days, millis })
    }

    /// Days since 1984-01-01.
    pub const fn days(&self) -> u16 {
        self.days
    }

    /// Milliseconds after midnight.
    pub const fn millis(&self) -> u32 {
        self.millis
    }

    /// Decodes the six data bytes. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        match *data {
            [m0, m1, m2, m3, d0, d1] => Ok(Self {
                millis: u32::from_le_bytes([m0, m1, m2, m3]) & MS_MASK,
                days: u16::from_le_bytes([d0, d1]),
            }),
            _ => Err(DecodeError::Length {
                message: "TIME",
                actual: data.len(),
            }),
        }
    }

    /// Decodes a frame, checking the COB-ID against `cob_id` (normally [`TIME_COB_ID`]).
    pub fn from_frame(frame: &CanFrame, cob_id: u16) -> Result<Self, DecodeError> {
        Self::parse(service_data(frame, cob_id, "TIME")?)
    }

    /// The six data bytes (reserved bits 0).
    pub fn emit(&self) -> [u8; 6] {
        let m = (self.millis & MS_MASK).to_le_bytes();
        let d = self.days.to_le_bytes();
        [m[0], m[1], m[2], m[3], d[0], d[1]]
    }

    /// The frame on `cob_id`.
    pub fn to_frame(&self, cob_id: u16) -> CanFrame {
        data_frame(cob_id, &self.emit())
    }

    /// From milliseconds since 1970-01-01 00:00 UTC. `None` before 1984 or after the 16-bit day
    /// counter runs out (2163-06-06).
    pub const fn from_unix_millis(ms: u64) -> Option<Self> {
        let day = ms / MS_PER_DAY;
        if day < EPOCH_1984_UNIX_DAYS || day - EPOCH_1984_UNIX_DAYS > u16::MAX as u64 {
            return None;
        }
        Some(Self {
            days: (day - EPOCH_1984_UNIX_DAYS) as u16,
            millis: (ms % MS_PER_DAY) as u32,
        })
    }

    /// Milliseconds since 1970-01-01 00:00 UTC.
    pub const fn to_unix_millis(&self) -> u64 {
        (self.days as u64 + EPOCH_1984_UNIX_DAYS) * MS_PER_DAY + self.millis as u64
    }

    /// From a system time. `None` outside the representable range (see
    /// [`from_unix_millis`](Self::from_unix_millis)).
    #[cfg(feature = "std")]
    pub fn from_system_time(t: std::time::SystemTime) -> Option<Self> {
        let since = t.duration_since(std::time::UNIX_EPOCH).ok()?;
        Self::from_unix_millis(u64::try_from(since.as_millis()).ok()?)
    }

    /// As a system time.
    #[cfg(feature = "std")]
    pub fn to_system_time(&self) -> std::time::SystemTime {
        std::time::UNIX_EPOCH + std::time::Duration::from_millis(self.to_unix_millis())
    }
}

/// The calendar date `days` after 1984-01-01 (proleptic Gregorian): year, month, day.
fn civil_date(days: u16) -> (u32, u8, u8) {
    const fn leap(y: u32) -> bool {
        y.is_multiple_of(4) && (!y.is_multiple_of(100) || y.is_multiple_of(400))
    }
    let mut year = 1984;
    let mut rest = u32::from(days);
    loop {
        let len = if leap(year) { 366 } else { 365 };
        if rest < len {
            break;
        }
        rest -= len;
        year += 1;
    }
    let feb = if leap(year) { 29 } else { 28 };
    let mut month = 1;
    for len in [31, feb, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31] {
        if rest < len {
            break;
        }
        rest -= len;
        month += 1;
    }
    (year, month, rest as u8 + 1)
}

impl core::fmt::Display for TimeOfDay {
    /// `TIME 2000-01-01 12:00:00.000 UTC`. Milliseconds of a day or more (the 28-bit field
    /// allows them) show as hours past 23.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (y, m, d) = civil_date(self.days);
        let ms = self.millis;
        write!(
            f,
            "TIME {y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}.{:03} UTC",
            ms / 3_600_000,
            ms / 60_000 % 60,
            ms / 1000 % 60,
            ms % 1000
        )
    }
}

/// Produces TIME messages from a wall-clock reference the caller sets.
///
/// The producer never reads a clock: [`set_clock`](Self::set_clock) tells it the Unix time at a
/// monotonic instant, and it extrapolates from there. Call order: `set_clock`; then
/// [`publish`](Self::publish) for a one-off message and/or a period in [`new`](Self::new) plus
/// [`handle_timeout`](Self::handle_timeout) when [`poll_timeout`](Self::poll_timeout) passes;
/// drain [`poll_transmit`](Self::poll_transmit) (the [`TimeOfDay`]) or
/// [`poll_transmit_frame`](Self::poll_transmit_frame) (its frame) after each.
#[derive(Debug, Clone)]
pub struct TimeProducer {
    cob_id: u16,
    timer: Periodic,
    reference: Option<(Instant, u64)>,
    pending: Option<TimeOfDay>,
}

impl TimeProducer {
    /// A producer on `cob_id` (normally [`TIME_COB_ID`]); `period` zero means only
    /// [`publish`](Self::publish) sends.
    pub const fn new(cob_id: u16, period: Duration) -> Self {
        Self {
            cob_id,
            timer: Periodic::new(period),
            reference: None,
            pending: None,
        }
    }

    /// Sets the wall clock: at `now`, the time is `unix_millis` ms after 1970-01-01 UTC. Starts the
    /// periodic transmission (first message due at `now`) if a period is set.
    pub fn set_clock(&mut self, now: Instant, unix_millis: u64) {
        self.reference = Some((now, unix_millis));
        if !self.timer.is_running() {
            self.timer.start_at(now);
        }
    }

    /// The time of day at `now`, if the clock is set and in range.
    pub fn time_at(&self, now: Instant) -> Option<TimeOfDay> {
        let (at, ms) = self.reference?;
        let elapsed = if now >= at {
            ms.saturating_add((now - at).as_millis())
        } else {
            ms.saturating_sub((at - now).as_millis())
        };
        TimeOfDay::from_unix_millis(elapsed)
    }

    /// Queues a TIME message for `now`. Returns false if the clock is not set or out of range.
    pub fn publish(&mut self, now: Instant) -> bool {
        match self.time_at(now) {
            Some(t) => {
                self.pending = Some(t);
                true
            }
            None => false,
        }
    }

    /// Sends the periodic message that is due, if any.
    pub fn handle_timeout(&mut self, now: Instant) {
        if self.timer.fire(now) {
            self.publish(now);
        }
    }

    /// The next TIME message to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<TimeOfDay> {
        self.pending.take()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on the producer's COB-ID.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|t| t.to_frame(self.cob_id))
    }

    /// When the next periodic message is due.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.timer.deadline()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;
    use proptest::prelude::*;

    #[test]
    fn epoch() {
        // 1984-01-01 00:00:00 UTC is Unix 441763200 s.
        assert_eq!(EPOCH_1984_UNIX_DAYS * 86_400, 441_763_200);
        let t = TimeOfDay::from_unix_millis(441_763_200_000).unwrap();
        assert_eq!((t.days(), t.millis()), (0, 0));
        assert_eq!(TimeOfDay::from_unix_millis(441_763_199_999), None);
        // 2000-01-01 12:00:00 UTC = Unix 946728000 s: 5844 days after 1984-01-01, 43200000 ms.
        let t = TimeOfDay::from_unix_millis(946_728_000_000).unwrap();
        assert_eq!((t.days(), t.millis()), (5844, 43_200_000));
        assert_eq!(t.to_unix_millis(), 946_728_000_000);
        // 2024-02-29 23:59:59.999 UTC = Unix 1709251199.999 s.
        let t = TimeOfDay::from_unix_millis(1_709_251_199_999).unwrap();
        assert_eq!((t.days(), t.millis()), (14_669, 86_399_999));
        // The last representable day.
        let last = TimeOfDay::new(u16::MAX, 0).unwrap().to_unix_millis();
        assert!(TimeOfDay::from_unix_millis(last + MS_PER_DAY).is_none());
    }

    #[cfg(feature = "std")]
    #[test]
    fn system_time() {
        let st = std::time::UNIX_EPOCH + std::time::Duration::from_secs(946_728_000);
        let t = TimeOfDay::from_system_time(st).unwrap();
        assert_eq!(t.days(), 5844);
        assert_eq!(t.to_system_time(), st);
    }

    #[test]
    fn byte_vector() {
        // 2000-01-01 12:00: ms 43200000 = 0x0293_2E00, days 5844 = 0x16D4.
        let t = TimeOfDay::new(5844, 43_200_000).unwrap();
        assert_eq!(t.emit(), [0x00, 0x2E, 0x93, 0x02, 0xD4, 0x16]);
        assert_eq!(t.to_frame(TIME_COB_ID).to_string(), "100#002E9302D416");
        // Reserved high bits are ignored on reception.
        assert_eq!(
            TimeOfDay::parse(&[0x00, 0x2E, 0x93, 0xF2, 0xD4, 0x16]),
            Ok(t)
        );
        assert!(TimeOfDay::parse(&[0; 5]).is_err());
        assert!(TimeOfDay::parse(&[0; 8]).is_err());
        assert_eq!(
            TimeOfDay::new(0, 0x1000_0000),
            Err(ConfigError::MillisOutOfRange(0x1000_0000))
        );
    }

    #[test]
    fn texts() {
        let text = |ms: u64| TimeOfDay::from_unix_millis(ms).unwrap().to_string();
        assert_eq!(text(441_763_200_000), "TIME 1984-01-01 00:00:00.000 UTC");
        assert_eq!(text(946_728_000_000), "TIME 2000-01-01 12:00:00.000 UTC");
        assert_eq!(text(1_709_251_199_999), "TIME 2024-02-29 23:59:59.999 UTC");
        assert_eq!(text(1_709_251_200_000), "TIME 2024-03-01 00:00:00.000 UTC");
        assert_eq!(text(4_107_542_400_000), "TIME 2100-03-01 00:00:00.000 UTC");
        assert_eq!(
            TimeOfDay::new(u16::MAX, 0).unwrap().to_string(),
            "TIME 2163-06-06 00:00:00.000 UTC"
        );
        assert_eq!(
            TimeOfDay::new(0, 0x0FFF_FFFF).unwrap().to_string(),
            "TIME 1984-01-01 74:33:55.455 UTC"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn date_text_agrees_with_day_count(days in any::<u16>()) {
            // Day 0 of a month follows the last day of the one before: the dates of
            // consecutive days differ by one day.
            let (y0, m0, d0) = civil_date(days.saturating_sub(1));
            let (y1, m1, d1) = civil_date(days);
            if days > 0 {
                prop_assert!(
                    (y1, m1, d1) > (y0, m0, d0)
                        && (d1 == d0 + 1 || (d1 == 1 && (m1 == m0 + 1 || (m1 == 1 && y1 == y0 + 1))))
                );
            }
        }
    }

    #[test]
    fn producer_extrapolates() {
        let mut p = TimeProducer::new(TIME_COB_ID, Duration::from_secs(1));
        assert!(!p.publish(Instant::ZERO));
        assert_eq!(p.poll_timeout(), None);
        let t0 = Instant::from_millis(5_000);
        p.set_clock(t0, 946_728_000_000);
        assert_eq!(p.poll_timeout(), Some(t0));
        p.handle_timeout(t0);
        let f = p.poll_transmit_frame().unwrap();
        assert_eq!(f.data(), &[0x00, 0x2E, 0x93, 0x02, 0xD4, 0x16]);
        assert_eq!(p.poll_timeout(), Some(Instant::from_millis(6_000)));
        p.handle_timeout(Instant::from_millis(6_000));
        let t = TimeOfDay::from_frame(&p.poll_transmit_frame().unwrap(), TIME_COB_ID).unwrap();
        assert_eq!(t.millis(), 43_201_000);
        assert_eq!(p.poll_transmit_frame(), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn round_trip(days in any::<u16>(), millis in 0u32..=0x0FFF_FFFF) {
            let t = TimeOfDay::new(days, millis).unwrap();
            prop_assert_eq!(TimeOfDay::parse(&t.emit()), Ok(t));
        }

        #[test]
        fn unix_round_trip(days in any::<u16>(), millis in 0u32..86_400_000) {
            let t = TimeOfDay::new(days, millis).unwrap();
            prop_assert_eq!(TimeOfDay::from_unix_millis(t.to_unix_millis()), Some(t));
        }
    }
}
