//! The state the engine keeps per PDO: a receive PDO's last data, pending synchronous data and
//! deadline; a transmit PDO's last frame, inhibit time, event timer and SYNC count. Both are
//! matched to frames by a key made from the CAN identifier.

use canola_frame::{CanId, Duration, Instant};

use super::{EngineError, PdoConfig};

/// Matching key of a CAN identifier: the raw value, bit 31 set for 29-bit identifiers.
pub(super) const fn key_of(id: CanId) -> u32 {
    match id {
        CanId::Standard(s) => s.as_raw() as u32,
        CanId::Extended(e) => e.as_raw() | 1 << 31,
    }
}

/// Key of a PDO that takes part in nothing (invalid COB-ID or empty mapping). No identifier
/// has this key: an extended one is at most 0x9FFF_FFFF.
pub(super) const NO_KEY: u32 = u32::MAX;

pub(super) fn config_key(config: &PdoConfig) -> Result<(u32, Option<CanId>), EngineError> {
    config.comm.validate()?;
    let id = config.comm.cob_id.can_id()?;
    if !config.comm.cob_id.is_valid() || config.mapping.is_empty() {
        return Ok((NO_KEY, Some(id)));
    }
    Ok((key_of(id), Some(id)))
}

#[derive(Debug)]
pub(super) struct Rx {
    pub(super) config: PdoConfig,
    /// Last data that took effect.
    pub(super) word: u64,
    pub(super) received: bool,
    /// Synchronous PDO data waiting for the next SYNC.
    pub(super) pending: Option<u64>,
    pub(super) deadline: Option<Instant>,
    pub(super) can_id: Option<CanId>,
}

#[derive(Debug)]
pub(super) struct Tx {
    pub(super) config: PdoConfig,
    pub(super) can_id: Option<CanId>,
    pub(super) key: u32,
    pub(super) last_tx: Option<Instant>,
    pub(super) last_word: Option<u64>,
    /// Event-driven: a frame is due but the inhibit time has not passed.
    pub(super) pending: bool,
    pub(super) event_deadline: Option<Instant>,
    pub(super) sync_count: u8,
    pub(super) sync_started: bool,
    /// Type 0: an event happened since the last SYNC.
    pub(super) event_flag: bool,
    /// Type 252: data sampled at the last SYNC.
    pub(super) rtr_buffer: Option<u64>,
}

impl Tx {
    pub(super) fn new(config: PdoConfig, key: u32, can_id: Option<CanId>) -> Self {
        Self {
            config,
            can_id,
            key,
            last_tx: None,
            last_word: None,
            pending: false,
            event_deadline: None,
            sync_count: 0,
            sync_started: false,
            event_flag: false,
            rtr_buffer: None,
        }
    }

    pub(super) fn reset(&mut self, now: Instant) {
        self.last_tx = None;
        self.last_word = None;
        self.pending = false;
        self.sync_count = 0;
        self.sync_started = false;
        self.event_flag = false;
        self.rtr_buffer = None;
        self.event_deadline = self.timer_from(now);
    }

    pub(super) fn active(&self) -> bool {
        self.key != NO_KEY
    }

    pub(super) fn timer_from(&self, now: Instant) -> Option<Instant> {
        let et = self.config.comm.event_time();
        (self.active() && self.config.comm.transmission_type.is_event_driven() && !et.is_zero())
            .then(|| now + et)
    }

    pub(super) fn inhibit_end(&self) -> Option<Instant> {
        let inhibit: Duration = self.config.comm.inhibit();
        if inhibit.is_zero() || !self.config.comm.transmission_type.is_event_driven() {
            return None;
        }
        self.last_tx.map(|t| t + inhibit)
    }

    pub(super) fn inhibit_passed(&self, now: Instant) -> bool {
        self.inhibit_end().is_none_or(|end| now >= end)
    }
}
