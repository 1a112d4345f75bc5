//! SYNC (CiA 301 §7.2.5): the message, its configuration (0x1005, 0x1006, 0x1019) and a
//! sans-IO producer.
//!
//! The SYNC message has no data, or one byte (the counter) when the synchronous counter overflow
//! value 0x1019 is 2..=240. The counter starts at 1, goes up by one with every SYNC, and the SYNC
//! after the one carrying the overflow value carries 1 again. It restarts at 1 whenever the
//! producer is (re)started.

use canola_frame::{CanFrame, Duration, Instant, Periodic};

use crate::error::{ConfigError, DecodeError};
use crate::util::{data_frame, service_data};

/// The default SYNC COB-ID (0x1005 default).
pub const SYNC_COB_ID: u16 = canola_frame::cob::SYNC;

/// A SYNC message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SyncMessage {
    /// The counter byte, if the producer sends one.
    pub counter: Option<u8>,
}

impl SyncMessage {
    /// Decodes the data bytes: none, or one counter byte. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        match *data {
            [] => Ok(Self { counter: None }),
            [c] => Ok(Self { counter: Some(c) }),
            _ => Err(DecodeError::Length {
                message: "SYNC",
                actual: data.len(),
            }),
        }
    }

    /// Decodes a frame, checking the COB-ID against `cob_id` (normally [`SYNC_COB_ID`]).
    pub fn from_frame(frame: &CanFrame, cob_id: u16) -> Result<Self, DecodeError> {
        Self::parse(service_data(frame, cob_id, "SYNC")?)
    }

    /// The frame on `cob_id`.
    pub fn to_frame(&self, cob_id: u16) -> CanFrame {
        match self.counter {
            Some(c) => data_frame(cob_id, &[c]),
            None => data_frame(cob_id, &[]),
        }
    }
}

impl core::fmt::Display for SyncMessage {
    /// `SYNC`, or `SYNC counter 7`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.counter {
            Some(c) => write!(f, "SYNC counter {c}"),
            None => f.write_str("SYNC"),
        }
    }
}

/// SYNC producer configuration, as held in the object dictionary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SyncConfig {
    /// 11-bit COB-ID (0x1005 bits 0..=10; default 0x080).
    pub cob_id: u16,
    /// Communication cycle period (0x1006, µs). Zero: no SYNC is produced.
    pub period: Duration,
    /// Synchronous counter overflow value (0x1019): 0 = no counter, else 2..=240.
    pub counter_overflow: u8,
}

impl SyncConfig {
    /// A configuration on the default COB-ID. Fails for the reserved overflow values 1 and
    /// 241..=255.
    pub fn new(period: Duration, counter_overflow: u8) -> Result<Self, ConfigError> {
        if counter_overflow == 1 || counter_overflow > 240 {
            return Err(ConfigError::ReservedSyncOverflow(counter_overflow));
        }
        Ok(Self {
            cob_id: SYNC_COB_ID,
            period,
            counter_overflow,
        })
    }

    /// From the raw objects 0x1005 (COB-ID SYNC), 0x1006 (period in µs) and 0x1019. The
    /// producer bit (30) of 0x1005 is not checked: whoever builds a producer wants one.
    pub fn from_objects(
        cob_id_sync: u32,
        period_us: u32,
        overflow: u8,
    ) -> Result<Self, ConfigError> {
        if cob_id_sync & (1 << 29) != 0 {
            return Err(ConfigError::ExtendedCobId(cob_id_sync));
        }
        let mut c = Self::new(Duration::from_micros(u64::from(period_us)), overflow)?;
        c.cob_id = (cob_id_sync & 0x7FF) as u16;
        Ok(c)
    }
}

/// Produces SYNC every period.
///
/// Call order: [`start`](Self::start) once; then whenever [`poll_timeout`](Self::poll_timeout)
/// passes, [`handle_timeout`](Self::handle_timeout) and drain
/// [`poll_transmit`](Self::poll_transmit). The first SYNC is due at the start instant. If
/// the caller is late by more than a period, the missed SYNCs are not sent in a burst; the next
/// one is due a period after the late one.
/// A SYNC that was not drained before the next one became due is replaced by it.
/// [`poll_transmit`](Self::poll_transmit) gives the [`SyncMessage`],
/// [`poll_transmit_frame`](Self::poll_transmit_frame) its frame on the configured COB-ID.
#[derive(Debug, Clone)]
pub struct SyncProducer {
    config: SyncConfig,
    /// The counter the next SYNC carries.
    counter: u8,
    timer: Periodic,
    pending: Option<SyncMessage>,
}

impl SyncProducer {
    /// A stopped producer.
    pub const fn new(config: SyncConfig) -> Self {
        Self {
            config,
            counter: 1,
            timer: Periodic::new(config.period),
            pending: None,
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &SyncConfig {
        &self.config
    }

    /// Replaces the configuration (e.g. after an SDO write to 0x1006 or 0x1019) and restarts at
    /// `now` if the producer was running.
    pub fn reconfigure(&mut self, now: Instant, config: SyncConfig) {
        let running = self.timer.is_running();
        self.config = config;
        self.timer = Periodic::new(config.period);
        if running {
            self.start(now);
        }
    }

    /// Starts producing; the counter restarts at 1 and the first SYNC is due at `now`.
    /// A zero period leaves the producer stopped.
    pub fn start(&mut self, now: Instant) {
        self.counter = 1;
        self.timer.start_at(now);
    }

    /// Stops producing (a queued, not yet polled SYNC is dropped).
    pub fn stop(&mut self) {
        self.timer.stop();
        self.pending = None;
    }

    /// Whether the producer is running.
    pub const fn is_running(&self) -> bool {
        self.timer.is_running()
    }

    /// Sends the SYNC that is due, if any.
    pub fn handle_timeout(&mut self, now: Instant) {
        if !self.timer.fire(now) {
            return;
        }
        let counter = if self.config.counter_overflow >= 2 {
            let c = self.counter;
            self.counter = if c >= self.config.counter_overflow {
                1
            } else {
                c + 1
            };
            Some(c)
        } else {
            None
        };
        self.pending = Some(SyncMessage { counter });
    }

    /// The next SYNC to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<SyncMessage> {
        self.pending.take()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on the configured COB-ID.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|m| m.to_frame(self.config.cob_id))
    }

    /// When the next SYNC is due.
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
    fn byte_vectors() {
        assert_eq!(SyncMessage::parse(&[]), Ok(SyncMessage { counter: None }));
        assert_eq!(
            SyncMessage::parse(&[7]),
            Ok(SyncMessage { counter: Some(7) })
        );
        assert!(SyncMessage::parse(&[1, 2]).is_err());
        assert_eq!(
            SyncMessage::default().to_frame(SYNC_COB_ID).to_string(),
            "080#"
        );
        assert_eq!(
            SyncMessage { counter: Some(240) }
                .to_frame(SYNC_COB_ID)
                .to_string(),
            "080#F0"
        );
        assert_eq!(SyncMessage::default().to_string(), "SYNC");
        assert_eq!(
            SyncMessage { counter: Some(7) }.to_string(),
            "SYNC counter 7"
        );
        assert_eq!(
            SyncMessage::from_frame(&data_frame(0x81, &[]), SYNC_COB_ID),
            Err(DecodeError::WrongCobId(0x81))
        );
    }

    #[test]
    fn config_validation() {
        assert_eq!(
            SyncConfig::new(Duration::from_millis(10), 1),
            Err(ConfigError::ReservedSyncOverflow(1))
        );
        assert!(SyncConfig::new(Duration::from_millis(10), 241).is_err());
        assert!(SyncConfig::new(Duration::from_millis(10), 240).is_ok());
        assert!(SyncConfig::new(Duration::from_millis(10), 0).is_ok());
        let c = SyncConfig::from_objects(0x4000_0081, 1000, 0).unwrap();
        assert_eq!((c.cob_id, c.period), (0x81, Duration::from_millis(1)));
        assert!(SyncConfig::from_objects(0x2000_0080, 1000, 0).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn round_trip(data in proptest::collection::vec(any::<u8>(), 0..=1)) {
            let m = SyncMessage::parse(&data).unwrap();
            let f = m.to_frame(SYNC_COB_ID);
            prop_assert_eq!(f.data(), &data[..]);
            prop_assert_eq!(SyncMessage::from_frame(&m.to_frame(SYNC_COB_ID), SYNC_COB_ID), Ok(m));
        }
    }
}
