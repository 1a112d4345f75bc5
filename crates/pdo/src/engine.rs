//! The sans-IO PDO engine (CiA 301 §7.2.2): consumes receive PDOs into an [`ObjectStore`] and
//! produces transmit PDOs from it, by transmission type, with inhibit time, event timer, SYNC
//! counter / SYNC start value, remote requests and receive deadlines.
//!
//! "Receive" and "transmit" are seen from the engine's owner. A master consumes the devices'
//! TPDOs, so it configures them here as receive PDOs ([`Engine::add_rpdo`] with the device's
//! TPDO COB-ID and mapping), and produces the devices' RPDOs as its transmit PDOs
//! ([`Engine::add_tpdo`]). A device simulator configures its own RPDOs and TPDOs unchanged.
//!
//! # Call order
//!
//! 1. Build: [`Engine::new`], then [`Engine::add_rpdo`] / [`Engine::add_tpdo`] (or
//!    [`Engine::set_rpdo`] / [`Engine::set_tpdo`] to reconfigure, e.g. after an SDO remap).
//! 2. Feed inputs as they happen, each with the current instant:
//!    - every received CAN frame: [`Engine::handle_frame`] (PDOs, remote requests for the
//!      engine's TPDOs, and SYNC on the configured SYNC COB-ID, default 0x080);
//!    - a SYNC the owner produced itself (no loop-back): [`Engine::handle_sync`];
//!    - application events: [`Engine::trigger`] for one TPDO, [`Engine::update`] after
//!      changing values in the store (change-of-state detection of event-driven and
//!      synchronous acyclic TPDOs);
//!    - the deadline from [`Engine::poll_timeout`] passing: [`Engine::handle_timeout`].
//! 3. After each input drain [`Engine::poll_transmit`] (frames to send) and
//!    [`Engine::poll_event`] (receptions, timeouts, length errors), then sleep until
//!    [`Engine::poll_timeout`].
//!
//! PDOs only run in NMT Operational: a device simulator calls [`Engine::set_enabled`] on NMT
//! state changes; a master leaves the engine enabled.
//!
//! # Behaviour by transmission type (transmit PDOs)
//!
//! | type    | sent when                                                                 |
//! |---------|---------------------------------------------------------------------------|
//! | 0       | on SYNC, if triggered or a mapped value changed since the last frame      |
//! | 1..=240 | on every n-th SYNC; with a SYNC start value and a counting SYNC, first on the SYNC whose counter equals it |
//! | 252     | data sampled on SYNC, sent on a remote request                            |
//! | 253     | data sampled and sent on a remote request                                 |
//! | 254/255 | on trigger, on a changed value ([`Engine::update`]), when the event timer expires, or on a remote request; never within the inhibit time after the previous frame (a due frame is postponed to the end of the inhibit time, with the values of that moment) |
//!
//! Receive PDOs of types 0..=240 take effect on the next SYNC, others immediately. A master that
//! mirrors a device's synchronous TPDO as its receive PDO and wants the values at once (not one
//! SYNC later) configures its receive PDO with type 254 or 255. A PDO with
//! fewer data bytes than its mapping is not processed ([`Event::LengthError`], EMCY 0x8210 on a
//! device); one with more is processed from its first bytes ([`Event::LengthExceeded`], EMCY
//! 0x8220). The receive deadline (event timer of a receive PDO) is armed by each reception and
//! reported once per lapse ([`Event::Timeout`]).
//!
//! The receive and transmit halves share the timers and the SYNC counter, so both stay in this
//! file; the state kept per PDO is in `slots`, the events and errors the engine reports in
//! `event`.

use canola_frame::{CanFrame, CanId, Instant};
use heapless::{Deque, Vec};

use crate::comm::{CommParams, TransmissionType};
use crate::dictionary::ObjectStore;
use crate::mapping::{Mapping, field_mask};
use crate::pack::{Unpacked, field, load_word};

mod event;
mod slots;

pub use event::{EngineError, Event, PdoRef};
use slots::{NO_KEY, Rx, Tx, config_key, key_of};

/// Default capacity `Q` of an engine's transmit and event queues: frames and events it buffers
/// between two drains of [`Engine::poll_transmit`] / [`Engine::poll_event`]. One SYNC can make
/// every transmit PDO send, so an engine with more than 32 transmit PDOs wants a larger `Q`.
pub const DEFAULT_QUEUE: usize = 32;

/// The configuration of one PDO: communication and mapping parameters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PdoConfig {
    /// Communication parameters.
    pub comm: CommParams,
    /// Mapping parameters.
    pub mapping: Mapping,
}

impl PdoConfig {
    /// Pairs communication and mapping parameters.
    pub fn new(comm: CommParams, mapping: Mapping) -> Self {
        Self { comm, mapping }
    }
}

/// A receive PDO of an engine (its position in the order of [`Engine::add_rpdo`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RpdoId(u16);

/// A transmit PDO of an engine (its position in the order of [`Engine::add_tpdo`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TpdoId(u16);

impl RpdoId {
    /// 0-based position.
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

impl TpdoId {
    /// 0-based position.
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

/// The PDO engine for up to `RX` receive and `TX` transmit PDOs, with queues of `Q` frames and
/// `Q` events (default [`DEFAULT_QUEUE`]). See the module docs for the
/// call order. Memory is fixed: about 1.1 KiB per PDO plus 1.5 KiB of queues (`Engine<4, 4>` is
/// about 10 KiB; keep large engines off small stacks). A master typically runs one engine per
/// node with four PDOs each way.
#[derive(Debug)]
pub struct Engine<const RX: usize, const TX: usize, const Q: usize = DEFAULT_QUEUE> {
    rx_keys: Vec<u32, RX>,
    rx: Vec<Rx, RX>,
    tx: Vec<Tx, TX>,
    sync_key: u32,
    enabled: bool,
    last_sync_counter: Option<u8>,
    transmit: Deque<CanFrame, Q>,
    events: Deque<Event, Q>,
    lost_frames: u32,
    lost_events: u32,
}

impl<const RX: usize, const TX: usize, const Q: usize> Default for Engine<RX, TX, Q> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const RX: usize, const TX: usize, const Q: usize> Engine<RX, TX, Q> {
    /// An enabled engine without PDOs, listening for SYNC on 0x080.
    pub const fn new() -> Self {
        Self {
            rx_keys: Vec::new(),
            rx: Vec::new(),
            tx: Vec::new(),
            sync_key: canola_frame::cob::SYNC as u32,
            enabled: true,
            last_sync_counter: None,
            transmit: Deque::new(),
            events: Deque::new(),
            lost_frames: 0,
            lost_events: 0,
        }
    }

    /// The SYNC COB-ID [`Engine::handle_frame`] recognises (object 0x1005); `None` to feed SYNC
    /// only through [`Engine::handle_sync`].
    pub fn set_sync_cob_id(&mut self, id: Option<CanId>) {
        self.sync_key = id.map_or(NO_KEY, key_of);
    }

    /// Adds a receive PDO. An invalid COB-ID (bit 31) or an empty mapping makes it inactive.
    pub fn add_rpdo(&mut self, config: PdoConfig) -> Result<RpdoId, EngineError> {
        let (key, can_id) = config_key(&config)?;
        let id = RpdoId(self.rx.len() as u16);
        self.rx
            .push(Rx {
                config,
                word: 0,
                received: false,
                pending: None,
                deadline: None,
                can_id,
            })
            .map_err(|_| EngineError::Full)?;
        // Same length as `rx`, so this cannot fail.
        let _ = self.rx_keys.push(key);
        Ok(id)
    }

    /// Adds a transmit PDO; its event timer starts at `now`.
    pub fn add_tpdo(&mut self, now: Instant, config: PdoConfig) -> Result<TpdoId, EngineError> {
        let (key, can_id) = config_key(&config)?;
        let id = TpdoId(self.tx.len() as u16);
        let mut tx = Tx::new(config, key, can_id);
        tx.reset(now);
        self.tx.push(tx).map_err(|_| EngineError::Full)?;
        Ok(id)
    }

    /// Replaces a receive PDO's configuration and forgets its state.
    pub fn set_rpdo(&mut self, id: RpdoId, config: PdoConfig) -> Result<(), EngineError> {
        let (key, can_id) = config_key(&config)?;
        let rx = self.rx.get_mut(id.index()).ok_or(EngineError::UnknownPdo)?;
        *rx = Rx {
            config,
            word: 0,
            received: false,
            pending: None,
            deadline: None,
            can_id,
        };
        if let Some(k) = self.rx_keys.get_mut(id.index()) {
            *k = key;
        }
        Ok(())
    }

    /// Replaces a transmit PDO's configuration and restarts it at `now`.
    pub fn set_tpdo(
        &mut self,
        now: Instant,
        id: TpdoId,
        config: PdoConfig,
    ) -> Result<(), EngineError> {
        let (key, can_id) = config_key(&config)?;
        let tx = self.tx.get_mut(id.index()).ok_or(EngineError::UnknownPdo)?;
        *tx = Tx::new(config, key, can_id);
        tx.reset(now);
        Ok(())
    }

    /// A receive PDO's configuration.
    pub fn rpdo(&self, id: RpdoId) -> Option<&PdoConfig> {
        self.rx.get(id.index()).map(|r| &r.config)
    }

    /// A transmit PDO's configuration.
    pub fn tpdo(&self, id: TpdoId) -> Option<&PdoConfig> {
        self.tx.get(id.index()).map(|t| &t.config)
    }

    /// The receive PDO listening on `id`, if any.
    pub fn rpdo_by_can_id(&self, id: CanId) -> Option<RpdoId> {
        let key = key_of(id);
        self.rx_keys
            .iter()
            .position(|&k| k == key)
            .map(|i| RpdoId(i as u16))
    }

    /// The data of a receive PDO's last reception that took effect, as typed values.
    pub fn received(&self, id: RpdoId) -> Option<Unpacked<'_>> {
        let rx = self.rx.get(id.index())?;
        rx.received
            .then(|| Unpacked::from_word(&rx.config.mapping, rx.word))
    }

    /// Starts (NMT Operational) or stops all PDOs. Starting resets every PDO's state and starts
    /// the event timers at `now`; stopping drops pending frames and deadlines.
    pub fn set_enabled(&mut self, now: Instant, enabled: bool) {
        self.enabled = enabled;
        for tx in self.tx.iter_mut() {
            tx.reset(now);
            if !enabled {
                tx.event_deadline = None;
            }
        }
        for rx in self.rx.iter_mut() {
            rx.pending = None;
            rx.deadline = None;
        }
        if !enabled {
            self.transmit.clear();
        }
    }

    /// Whether the engine runs.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// The counter of the last SYNC seen, if it carried one.
    pub fn last_sync_counter(&self) -> Option<u8> {
        self.last_sync_counter
    }

    /// Frames dropped because the transmit queue was full (drain it after every input).
    pub fn lost_frames(&self) -> u32 {
        self.lost_frames
    }

    /// Events dropped because the event queue was full (drain it after every input).
    pub fn lost_events(&self) -> u32 {
        self.lost_events
    }

    /// Handles one received frame. Returns whether it was for this engine (a receive PDO, a
    /// remote request for a transmit PDO, or SYNC). Never panics, whatever the frame holds.
    pub fn handle_frame<S: ObjectStore + ?Sized>(
        &mut self,
        now: Instant,
        frame: &CanFrame,
        store: &mut S,
    ) -> bool {
        if !self.enabled {
            return false;
        }
        let key = key_of(frame.id());
        if frame.is_remote() {
            return self.handle_rtr(now, key, store);
        }
        if let Some(i) = self.rx_keys.iter().position(|&k| k == key) {
            self.receive(now, i, frame.data(), store);
            return true;
        }
        if key == self.sync_key {
            match *frame.data() {
                [] => self.handle_sync(now, None, store),
                [c] => self.handle_sync(now, Some(c), store),
                _ => return false,
            }
            return true;
        }
        false
    }

    fn receive<S: ObjectStore + ?Sized>(
        &mut self,
        now: Instant,
        i: usize,
        data: &[u8],
        store: &mut S,
    ) {
        let Some(rx) = self.rx.get_mut(i) else {
            return;
        };
        let pdo = RpdoId(i as u16);
        let needed = rx.config.mapping.byte_len();
        if data.len() < needed {
            push_event(
                &mut self.events,
                &mut self.lost_events,
                Event::LengthError {
                    pdo,
                    expected: needed as u8,
                    actual: data.len() as u8,
                },
            );
            return;
        }
        let word = load_word(&data[..needed]);
        let et = rx.config.comm.event_time();
        if !et.is_zero() {
            rx.deadline = Some(now + et);
        }
        if data.len() > needed {
            push_event(
                &mut self.events,
                &mut self.lost_events,
                Event::LengthExceeded {
                    pdo,
                    expected: needed as u8,
                    actual: data.len() as u8,
                },
            );
        }
        if rx.config.comm.transmission_type.is_synchronous() {
            rx.pending = Some(word);
        } else {
            self.apply(i, word, store);
        }
    }

    /// Makes received data take effect: store writes, change mask, event.
    fn apply<S: ObjectStore + ?Sized>(&mut self, i: usize, word: u64, store: &mut S) {
        let Some(rx) = self.rx.get_mut(i) else {
            return;
        };
        let pdo = RpdoId(i as u16);
        let objects = rx.config.mapping.objects();
        let diff = if rx.received {
            word ^ rx.word
        } else {
            u64::MAX
        };
        let mut changed = 0u64;
        if diff != 0 {
            for (n, o) in objects.iter().enumerate() {
                changed |= u64::from(diff & o.mask() != 0) << n;
            }
        }
        for o in objects {
            if o.is_dummy() {
                continue;
            }
            let bytes = field(word, o).to_le_bytes();
            if let Err(error) = store.write(o.addr(), &bytes[..o.byte_len()]) {
                push_event(
                    &mut self.events,
                    &mut self.lost_events,
                    Event::StoreFailed {
                        pdo: PdoRef::Rx(pdo),
                        addr: o.addr(),
                        error,
                    },
                );
            }
        }
        rx.word = word;
        rx.received = true;
        push_event(
            &mut self.events,
            &mut self.lost_events,
            Event::Received { pdo, changed },
        );
    }

    fn handle_rtr<S: ObjectStore + ?Sized>(
        &mut self,
        now: Instant,
        key: u32,
        store: &mut S,
    ) -> bool {
        let Some(i) = self.tx.iter().position(|t| t.key == key) else {
            return false;
        };
        let Some(tx) = self.tx.get(i) else {
            return false;
        };
        if !tx.config.comm.cob_id.rtr_allowed() {
            return true;
        }
        match tx.config.comm.transmission_type {
            TransmissionType::RtrSync => {
                if let Some(word) = tx.rtr_buffer {
                    self.emit(now, i, word);
                }
            }
            TransmissionType::RtrEvent => {
                if let Some(word) = self.sample(i, store) {
                    self.emit(now, i, word);
                }
            }
            TransmissionType::EventManufacturer | TransmissionType::EventProfile => {
                self.event_due(now, i, store);
            }
            _ => {}
        }
        true
    }

    /// Handles a SYNC (counter from its data byte, if the producer sends one): synchronous
    /// receive PDOs take effect, synchronous transmit PDOs are sent or sampled.
    pub fn handle_sync<S: ObjectStore + ?Sized>(
        &mut self,
        now: Instant,
        counter: Option<u8>,
        store: &mut S,
    ) {
        if !self.enabled {
            return;
        }
        self.last_sync_counter = counter;
        for i in 0..self.rx.len() {
            if let Some(word) = self.rx.get_mut(i).and_then(|r| r.pending.take()) {
                self.apply(i, word, store);
            }
        }
        for i in 0..self.tx.len() {
            let Some(tx) = self.tx.get_mut(i) else {
                continue;
            };
            if !tx.active() {
                continue;
            }
            match tx.config.comm.transmission_type {
                TransmissionType::SyncAcyclic => {
                    let flagged = tx.event_flag;
                    let last = tx.last_word;
                    if let Some(word) = self.sample(i, store)
                        && (flagged || last != Some(word))
                    {
                        self.emit(now, i, word);
                    }
                }
                TransmissionType::SyncCyclic(n) => {
                    let start = tx.config.comm.sync_start;
                    let due = if start != 0 && counter.is_some() && !tx.sync_started {
                        if counter == Some(start) {
                            tx.sync_started = true;
                            tx.sync_count = 0;
                            true
                        } else {
                            false
                        }
                    } else {
                        tx.sync_count = tx.sync_count.saturating_add(1);
                        if tx.sync_count >= n {
                            tx.sync_count = 0;
                            true
                        } else {
                            false
                        }
                    };
                    if due && let Some(word) = self.sample(i, store) {
                        self.emit(now, i, word);
                    }
                }
                TransmissionType::RtrSync => {
                    let word = self.sample(i, store);
                    if let Some(tx) = self.tx.get_mut(i) {
                        tx.rtr_buffer = word.or(tx.rtr_buffer);
                    }
                }
                _ => {}
            }
        }
    }

    /// An application event for one transmit PDO: an event-driven PDO is sent now (or at the
    /// end of its inhibit time), a synchronous acyclic one on the next SYNC. Other types ignore
    /// it.
    pub fn trigger<S: ObjectStore + ?Sized>(
        &mut self,
        now: Instant,
        id: TpdoId,
        store: &mut S,
    ) -> Result<(), EngineError> {
        let i = id.index();
        let tx = self.tx.get_mut(i).ok_or(EngineError::UnknownPdo)?;
        if !self.enabled || !tx.active() {
            return Ok(());
        }
        match tx.config.comm.transmission_type {
            TransmissionType::SyncAcyclic => tx.event_flag = true,
            t if t.is_event_driven() => self.event_due(now, i, store),
            _ => {}
        }
        Ok(())
    }

    /// Change-of-state detection: samples every event-driven and synchronous acyclic transmit
    /// PDO and treats a difference from its last frame as an application event. Call it after
    /// changing values in the store.
    pub fn update<S: ObjectStore + ?Sized>(&mut self, now: Instant, store: &mut S) {
        if !self.enabled {
            return;
        }
        for i in 0..self.tx.len() {
            let Some(tx) = self.tx.get(i) else {
                continue;
            };
            let t = tx.config.comm.transmission_type;
            if !tx.active()
                || tx.pending
                || !(t.is_event_driven() || t == TransmissionType::SyncAcyclic)
            {
                continue;
            }
            let last = tx.last_word;
            let Some(word) = self.sample(i, store) else {
                continue;
            };
            if last == Some(word) {
                continue;
            }
            if t == TransmissionType::SyncAcyclic {
                if let Some(tx) = self.tx.get_mut(i) {
                    tx.event_flag = true;
                }
            } else if self.tx.get(i).is_some_and(|tx| tx.inhibit_passed(now)) {
                self.emit(now, i, word);
            } else if let Some(tx) = self.tx.get_mut(i) {
                tx.pending = true;
            }
        }
    }

    /// Asks the producer of a receive PDO for it: queues a remote frame on its COB-ID (for
    /// devices' TPDOs of type 252/253 with RTR allowed).
    pub fn request(&mut self, id: RpdoId) -> Result<(), EngineError> {
        let rx = self.rx.get(id.index()).ok_or(EngineError::UnknownPdo)?;
        let Some(can_id) = rx.can_id.filter(|_| rx.config.comm.cob_id.is_valid()) else {
            return Err(EngineError::NotValid);
        };
        if let Ok(frame) = CanFrame::remote(can_id, rx.config.mapping.byte_len()) {
            push_frame(&mut self.transmit, &mut self.lost_frames, frame);
        }
        Ok(())
    }

    /// Handles the passing of deadlines: postponed event-driven frames, event timers, receive
    /// deadlines. Calling it early or often is harmless.
    pub fn handle_timeout<S: ObjectStore + ?Sized>(&mut self, now: Instant, store: &mut S) {
        if !self.enabled {
            return;
        }
        for i in 0..self.tx.len() {
            let Some(tx) = self.tx.get_mut(i) else {
                continue;
            };
            let timer_due = tx.event_deadline.is_some_and(|d| d <= now);
            if timer_due {
                tx.event_deadline = None;
                tx.pending = true;
            }
            if tx.pending && tx.inhibit_passed(now) {
                match self.sample(i, store) {
                    Some(word) => self.emit(now, i, word),
                    None => {
                        // The store refused: retry at the next event time, not in a loop.
                        if let Some(tx) = self.tx.get_mut(i) {
                            tx.pending = false;
                            tx.event_deadline = tx.timer_from(now);
                        }
                    }
                }
            }
        }
        for (i, rx) in self.rx.iter_mut().enumerate() {
            if let Some(deadline) = rx.deadline
                && deadline <= now
            {
                rx.deadline = None;
                push_event(
                    &mut self.events,
                    &mut self.lost_events,
                    Event::Timeout {
                        pdo: RpdoId(i as u16),
                        deadline,
                    },
                );
            }
        }
    }

    /// The next frame to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.transmit.pop_front()
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// When [`Engine::handle_timeout`] must be called next, if ever.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        if !self.enabled {
            return None;
        }
        let tx = self.tx.iter().filter_map(|t| {
            let postponed = if t.pending {
                Some(t.inhibit_end().unwrap_or(Instant::ZERO))
            } else {
                None
            };
            match (postponed, t.event_deadline) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            }
        });
        let rx = self.rx.iter().filter_map(|r| r.deadline);
        tx.chain(rx).min()
    }

    /// An event-driven frame is due: send it now or when the inhibit time has passed.
    fn event_due<S: ObjectStore + ?Sized>(&mut self, now: Instant, i: usize, store: &mut S) {
        let Some(tx) = self.tx.get_mut(i) else {
            return;
        };
        if tx.inhibit_passed(now) {
            if let Some(word) = self.sample(i, store) {
                self.emit(now, i, word);
            }
        } else {
            tx.pending = true;
        }
    }

    /// Reads the mapped objects of transmit PDO `i` from the store into a data word.
    fn sample<S: ObjectStore + ?Sized>(&mut self, i: usize, store: &mut S) -> Option<u64> {
        let tx = self.tx.get(i)?;
        let mut word = 0u64;
        for o in tx.config.mapping.objects() {
            if o.is_dummy() {
                continue;
            }
            let mut buf = [0u8; 8];
            let n = o.byte_len().min(8);
            if let Err(error) = store.read(o.addr(), &mut buf[..n]) {
                push_event(
                    &mut self.events,
                    &mut self.lost_events,
                    Event::StoreFailed {
                        pdo: PdoRef::Tx(TpdoId(i as u16)),
                        addr: o.addr(),
                        error,
                    },
                );
                return None;
            }
            word |= (u64::from_le_bytes(buf) & field_mask(o.bits())) << o.offset;
        }
        Some(word)
    }

    /// Queues transmit PDO `i` with `word` and restarts its timers.
    fn emit(&mut self, now: Instant, i: usize, word: u64) {
        let Some(tx) = self.tx.get_mut(i) else {
            return;
        };
        let Some(can_id) = tx.can_id else {
            return;
        };
        let len = tx.config.mapping.byte_len();
        let bytes = word.to_le_bytes();
        tx.last_tx = Some(now);
        tx.last_word = Some(word);
        tx.pending = false;
        tx.event_flag = false;
        tx.event_deadline = tx.timer_from(now);
        if let Ok(frame) = CanFrame::new(can_id, &bytes[..len.min(8)]) {
            push_frame(&mut self.transmit, &mut self.lost_frames, frame);
        }
    }
}

#[inline]
fn push_event<const Q: usize>(q: &mut Deque<Event, Q>, lost: &mut u32, e: Event) {
    if q.push_back(e).is_err() {
        *lost = lost.saturating_add(1);
    }
}

#[inline]
fn push_frame<const Q: usize>(q: &mut Deque<CanFrame, Q>, lost: &mut u32, f: CanFrame) {
    if q.push_back(f).is_err() {
        *lost = lost.saturating_add(1);
    }
}
