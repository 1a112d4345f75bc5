//! Heartbeat (CiA 301 §7.2.8.3.2.2): the master-side consumer for many nodes (object 0x1016)
//! and the device-side producer (object 0x1017).
//!
//! Consumer rules (0x1016): each entry names a node and a consumer heartbeat time in ms. The
//! timeout is armed only by a heartbeat: until the first one arrives nothing can be lost. A
//! boot-up message disarms it again (a freshly booted node may not produce heartbeats until it is
//! configured); the next heartbeat re-arms it. A consumer time of 0 tracks states but never
//! times out.

use canola_frame::{CanFrame, Duration, Instant, NodeId, Periodic, earliest, is_due};
use heapless::{Deque, Vec};

use crate::error::{CapacityError, DecodeError};
use crate::error_control::{ErrorControlFrame, Heartbeat};
use crate::state::NmtState;
use crate::util::push_dropping_oldest;

/// One sub-entry of object 0x1016: bits 16..=23 node-ID, bits 0..=15 heartbeat time in ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ConsumerHeartbeatEntry {
    /// The node-ID byte; 0 or above 127 means the entry is unused.
    pub node: u8,
    /// Consumer heartbeat time in ms; 0 means the entry is unused.
    pub time_ms: u16,
}

impl ConsumerHeartbeatEntry {
    /// Splits the UNSIGNED32 value (bits 24..=31 are reserved and ignored).
    pub const fn from_raw(raw: u32) -> Self {
        Self {
            node: (raw >> 16) as u8,
            time_ms: raw as u16,
        }
    }

    /// The UNSIGNED32 value.
    pub const fn to_raw(self) -> u32 {
        ((self.node as u32) << 16) | self.time_ms as u32
    }

    /// The node and timeout, if the entry is in use.
    pub fn active(self) -> Option<(NodeId, Duration)> {
        let node = NodeId::new(self.node).ok()?;
        (self.time_ms != 0).then(|| (node, Duration::from_millis(u64::from(self.time_ms))))
    }
}

/// What the heartbeat consumer reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeartbeatEvent {
    /// The node sent its boot-up message. It lost its configuration; the timeout is disarmed
    /// until its next heartbeat.
    BootUp {
        /// The node.
        node: NodeId,
    },
    /// A heartbeat carried a different state than the previous one (`from` is `None` for the
    /// first heartbeat ever seen, or the first after a boot-up).
    StateChanged {
        /// The node.
        node: NodeId,
        /// The previous state.
        from: Option<NmtState>,
        /// The new state.
        to: NmtState,
    },
    /// No heartbeat within the consumer time ("heartbeat event" of CiA 301).
    Lost {
        /// The node.
        node: NodeId,
        /// The last state the node reported.
        last_state: Option<NmtState>,
    },
    /// A heartbeat arrived again after [`Lost`](Self::Lost). A boot-up instead reports
    /// [`BootUp`](Self::BootUp) only.
    Recovered {
        /// The node.
        node: NodeId,
        /// The state in that heartbeat.
        state: NmtState,
    },
}

impl core::fmt::Display for HeartbeatEvent {
    /// `node 5 booted`, `node 5 Pre-operational -> Operational`, `node 5 heartbeat lost (last
    /// state Operational)`, `node 5 heartbeat back, Operational`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BootUp { node } => write!(f, "node {node} booted"),
            Self::StateChanged { node, from, to } => state_change(f, node, from, to),
            Self::Lost { node, last_state } => {
                write!(f, "node {node} heartbeat lost")?;
                last_state_text(f, last_state)
            }
            Self::Recovered { node, state } => write!(f, "node {node} heartbeat back, {state}"),
        }
    }
}

/// `node 5 Operational` or `node 5 Pre-operational -> Operational`.
pub(crate) fn state_change(
    f: &mut core::fmt::Formatter<'_>,
    node: NodeId,
    from: Option<NmtState>,
    to: NmtState,
) -> core::fmt::Result {
    match from {
        Some(from) => write!(f, "node {node} {from} -> {to}"),
        None => write!(f, "node {node} {to}"),
    }
}

/// ` (last state Operational)`, or nothing when no state was seen.
pub(crate) fn last_state_text(
    f: &mut core::fmt::Formatter<'_>,
    last: Option<NmtState>,
) -> core::fmt::Result {
    match last {
        Some(s) => write!(f, " (last state {s})"),
        None => Ok(()),
    }
}

/// Capacity of the consumer's event queue.
pub const HEARTBEAT_EVENT_CAPACITY: usize = 64;

#[derive(Debug, Clone)]
struct Entry {
    node: NodeId,
    timeout: Duration,
    /// The last heartbeat's state; `None` before the first or after a boot-up.
    state: Option<NmtState>,
    booted: bool,
    deadline: Option<Instant>,
    lost: bool,
    /// When the last boot-up or heartbeat arrived.
    last_seen: Option<Instant>,
}

impl Entry {
    const fn new(node: NodeId, timeout: Duration) -> Self {
        Self {
            node,
            timeout,
            state: None,
            booted: false,
            deadline: None,
            lost: false,
            last_seen: None,
        }
    }
}

/// Monitors the heartbeats of up to `N` nodes (default: all 127).
///
/// Call order: [`monitor`](Self::monitor) each node; then for every received frame
/// [`handle_frame`](Self::handle_frame) (or [`handle_heartbeat`](Self::handle_heartbeat)); when
/// [`poll_timeout`](Self::poll_timeout) passes, [`handle_timeout`](Self::handle_timeout); after
/// each call drain [`poll_event`](Self::poll_event). Nothing is transmitted.
///
/// Events are queued up to [`HEARTBEAT_EVENT_CAPACITY`]. A timeout that finds the queue full is
/// left for the next `handle_timeout` (its deadline stays due), so loss events are never dropped;
/// events from frames drop the oldest event when the queue is full (counted in
/// [`dropped_events`](Self::dropped_events)).
///
/// The consumer is where a master keeps each node's NMT state: [`state`](Self::state) and
/// [`last_seen`](Self::last_seen). With [`observe_all`](Self::observe_all) it also tracks the
/// nodes nobody configured a consumer time for, from their first boot-up or heartbeat on.
#[derive(Debug, Clone)]
pub struct HeartbeatConsumer<const N: usize = 127> {
    entries: Vec<Entry, N>,
    events: Deque<HeartbeatEvent, HEARTBEAT_EVENT_CAPACITY>,
    dropped: u32,
    observe_all: bool,
}

impl<const N: usize> Default for HeartbeatConsumer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HeartbeatConsumer<N> {
    /// A consumer monitoring nothing.
    pub const fn new() -> Self {
        Self {
            entries: Vec::new(),
            events: Deque::new(),
            dropped: 0,
            observe_all: false,
        }
    }

    /// Whether to track nodes that are not monitored: a boot-up or heartbeat of a node without
    /// an entry adds one with consumer time 0 (as far as the capacity `N` allows), so its state
    /// is kept and its [`BootUp`](HeartbeatEvent::BootUp) and
    /// [`StateChanged`](HeartbeatEvent::StateChanged) events are reported; it never times out.
    /// Off by default. A master that also runs node guarding passes the answers of guarded
    /// nodes to the [`GuardingMaster`](crate::GuardingMaster) only: their toggle bit is not a
    /// heartbeat state.
    pub fn observe_all(&mut self, on: bool) {
        self.observe_all = on;
    }

    /// Monitors `node` with consumer time `timeout` (zero: track states, never time out).
    /// Replacing an existing entry keeps its state but disarms the timeout until the next
    /// heartbeat.
    pub fn monitor(&mut self, node: NodeId, timeout: Duration) -> Result<(), CapacityError> {
        if let Some(e) = self.entries.iter_mut().find(|e| e.node == node) {
            e.timeout = timeout;
            e.deadline = None;
            e.lost = false;
            return Ok(());
        }
        self.entries
            .push(Entry::new(node, timeout))
            .map_err(|_| CapacityError { capacity: N })
    }

    /// Applies one sub-entry of 0x1016: an active entry monitors its node, an unused one is
    /// ignored. Returns the node it configured.
    pub fn configure(
        &mut self,
        entry: ConsumerHeartbeatEntry,
    ) -> Result<Option<NodeId>, CapacityError> {
        match entry.active() {
            Some((node, t)) => self.monitor(node, t).map(|()| Some(node)),
            None => Ok(None),
        }
    }

    /// Stops monitoring `node`. Returns whether it was monitored.
    pub fn remove(&mut self, node: NodeId) -> bool {
        match self.entries.iter().position(|e| e.node == node) {
            Some(i) => {
                self.entries.swap_remove(i);
                true
            }
            None => false,
        }
    }

    /// The last reported state of `node` (`None` if unmonitored or nothing received yet).
    pub fn state(&self, node: NodeId) -> Option<NmtState> {
        let e = self.entries.iter().find(|e| e.node == node)?;
        if e.booted && e.state.is_none() {
            Some(NmtState::BootUp)
        } else {
            e.state
        }
    }

    /// Whether `node` is currently considered lost.
    pub fn is_lost(&self, node: NodeId) -> bool {
        self.entries.iter().any(|e| e.node == node && e.lost)
    }

    /// When the last boot-up or heartbeat of `node` arrived (`None` if it is not tracked or
    /// nothing arrived yet).
    pub fn last_seen(&self, node: NodeId) -> Option<Instant> {
        self.entries.iter().find(|e| e.node == node)?.last_seen
    }

    /// The consumer time of `node`: `Some(Duration::ZERO)` for a node whose state is only
    /// tracked, `None` for a node without an entry.
    pub fn consumer_time(&self, node: NodeId) -> Option<Duration> {
        self.entries
            .iter()
            .find(|e| e.node == node)
            .map(|e| e.timeout)
    }

    /// The nodes with an entry (monitored or only tracked), in no particular order.
    pub fn nodes(&self) -> impl Iterator<Item = NodeId> + '_ {
        self.entries.iter().map(|e| e.node)
    }

    /// Takes a frame. `Ok(false)`: not a heartbeat of a monitored (or tracked) node (remote frames are node
    /// guarding, not heartbeat); `Ok(true)`: handled; `Err`: a malformed frame on a monitored
    /// node's error-control COB-ID.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> Result<bool, DecodeError> {
        let Ok((node, kind)) = ErrorControlFrame::from_frame(frame) else {
            if let Some(cob @ 0x701..=0x77F) = frame.cob_id()
                && self
                    .entries
                    .iter()
                    .any(|e| u16::from(e.node.get()) == cob & 0x7F)
            {
                return Err(DecodeError::Length {
                    message: "heartbeat",
                    actual: frame.dlc(),
                });
            }
            return Ok(false);
        };
        match kind {
            ErrorControlFrame::Payload(b) => Ok(self.handle_heartbeat(
                now,
                node,
                Heartbeat {
                    state: NmtState::from_u8(b),
                },
            )),
            ErrorControlFrame::GuardRequest => Ok(false),
        }
    }

    /// Takes a decoded heartbeat of `node`. Returns false if `node` is not monitored (nor
    /// tracked, see [`observe_all`](Self::observe_all)).
    pub fn handle_heartbeat(&mut self, now: Instant, node: NodeId, hb: Heartbeat) -> bool {
        let i = match self.entries.iter().position(|e| e.node == node) {
            Some(i) => i,
            None if self.observe_all => {
                if self.entries.push(Entry::new(node, Duration::ZERO)).is_err() {
                    return false;
                }
                self.entries.len() - 1
            }
            None => return false,
        };
        let e = &mut self.entries[i];
        e.last_seen = Some(now);
        let mut out: [Option<HeartbeatEvent>; 2] = [None, None];
        if hb.is_boot_up() {
            e.booted = true;
            e.state = None;
            e.deadline = None;
            e.lost = false;
            out[0] = Some(HeartbeatEvent::BootUp { node });
        } else {
            if e.lost {
                e.lost = false;
                out[0] = Some(HeartbeatEvent::Recovered {
                    node,
                    state: hb.state,
                });
            }
            if e.state != Some(hb.state) {
                out[1] = Some(HeartbeatEvent::StateChanged {
                    node,
                    from: e.state,
                    to: hb.state,
                });
            }
            e.state = Some(hb.state);
            e.deadline = (!e.timeout.is_zero()).then(|| now + e.timeout);
        }
        for ev in out.into_iter().flatten() {
            self.push_dropping_oldest(ev);
        }
        true
    }

    fn push_dropping_oldest(&mut self, ev: HeartbeatEvent) {
        if push_dropping_oldest(&mut self.events, ev) {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// Reports every node whose consumer time has run out (as far as the event queue allows).
    pub fn handle_timeout(&mut self, now: Instant) {
        for e in self.entries.iter_mut() {
            if self.events.is_full() {
                return;
            }
            if is_due(e.deadline, now) {
                e.deadline = None;
                e.lost = true;
                let _ = self.events.push_back(HeartbeatEvent::Lost {
                    node: e.node,
                    last_state: e.state,
                });
            }
        }
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<HeartbeatEvent> {
        self.events.pop_front()
    }

    /// The earliest armed heartbeat deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        earliest(self.entries.iter().map(|e| e.deadline))
    }

    /// How many frame events were dropped because the queue was full.
    pub const fn dropped_events(&self) -> u32 {
        self.dropped
    }
}

/// Produces a device's heartbeat every producer heartbeat time (0x1017, ms; 0 = off).
///
/// Call order: [`start`](Self::start) right after the boot-up message; keep the state current with
/// [`set_state`](Self::set_state); when [`poll_timeout`](Self::poll_timeout) passes,
/// [`handle_timeout`](Self::handle_timeout) and drain [`poll_transmit`](Self::poll_transmit).
/// The boot-up message counts as the first heartbeat, so the first one is due one period after
/// `start`. [`poll_transmit`](Self::poll_transmit) gives the [`Heartbeat`],
/// [`poll_transmit_frame`](Self::poll_transmit_frame) its frame on 0x700 + node.
#[derive(Debug, Clone)]
pub struct HeartbeatProducer {
    node: NodeId,
    timer: Periodic,
    state: NmtState,
    running: bool,
    pending: Option<Heartbeat>,
}

impl HeartbeatProducer {
    /// A stopped producer for `node` with producer time `period_ms`.
    pub const fn new(node: NodeId, period_ms: u16) -> Self {
        Self {
            node,
            timer: Periodic::new(Duration::from_millis(period_ms as u64)),
            state: NmtState::PreOperational,
            running: false,
            pending: None,
        }
    }

    /// Starts producing (no effect with period 0).
    pub fn start(&mut self, now: Instant) {
        self.running = true;
        self.timer.start_at(now + self.timer.period());
    }

    /// Stops producing.
    pub fn stop(&mut self) {
        self.running = false;
        self.timer.stop();
        self.pending = None;
    }

    /// Changes the producer time (an SDO write to 0x1017). If the producer has been started, the
    /// next heartbeat is due one new period from `now` (0 pauses it until a non-zero time).
    pub fn set_period(&mut self, now: Instant, period_ms: u16) {
        self.timer
            .set_period(Duration::from_millis(u64::from(period_ms)));
        if self.running {
            self.start(now);
        }
    }

    /// The producer time.
    pub const fn period(&self) -> Duration {
        self.timer.period()
    }

    /// The state the next heartbeat reports.
    pub fn set_state(&mut self, state: NmtState) {
        self.state = state;
    }

    /// Sends the heartbeat that is due, if any.
    pub fn handle_timeout(&mut self, now: Instant) {
        if self.timer.fire(now) {
            self.pending = Some(Heartbeat { state: self.state });
        }
    }

    /// The next heartbeat to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<Heartbeat> {
        self.pending.take()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on 0x700 + node.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|hb| hb.to_frame(self.node))
    }

    /// When the next heartbeat is due.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.timer.deadline()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn event_texts() {
        extern crate std;
        use crate::{DeviceState, LifeGuardingEvent};
        use crate::{Emcy, EmcyCode, EmcyEvent, ErrorRegister, GuardingEvent, SlaveEvent};
        use std::string::ToString;
        let node = NodeId::new(5).unwrap();
        let op = NmtState::Operational;
        let t = |e: HeartbeatEvent| e.to_string();
        assert_eq!(t(HeartbeatEvent::BootUp { node }), "node 5 booted");
        assert_eq!(
            t(HeartbeatEvent::StateChanged {
                node,
                from: Some(NmtState::PreOperational),
                to: op
            }),
            "node 5 Pre-operational -> Operational"
        );
        assert_eq!(
            t(HeartbeatEvent::StateChanged {
                node,
                from: None,
                to: op
            }),
            "node 5 Operational"
        );
        assert_eq!(
            t(HeartbeatEvent::Lost {
                node,
                last_state: Some(op)
            }),
            "node 5 heartbeat lost (last state Operational)"
        );
        assert_eq!(
            t(HeartbeatEvent::Lost {
                node,
                last_state: None
            }),
            "node 5 heartbeat lost"
        );
        assert_eq!(
            t(HeartbeatEvent::Recovered { node, state: op }),
            "node 5 heartbeat back, Operational"
        );
        assert_eq!(
            GuardingEvent::ToggleError {
                node,
                expected: true
            }
            .to_string(),
            "node 5 toggle bit error (expected 1)"
        );
        assert_eq!(
            GuardingEvent::Lost {
                node,
                last_state: Some(NmtState::Stopped)
            }
            .to_string(),
            "node 5 node guarding lost (last state Stopped)"
        );
        assert_eq!(
            SlaveEvent::StateChanged {
                from: DeviceState::Initialising,
                to: DeviceState::PreOperational
            }
            .to_string(),
            "Initialisation -> Pre-operational"
        );
        assert_eq!(
            SlaveEvent::UnknownCommand(3).to_string(),
            "unknown NMT command 0x03 ignored"
        );
        assert_eq!(LifeGuardingEvent::Lost.to_string(), "life guarding lost");
        assert_eq!(
            EmcyEvent {
                node,
                at: Instant::ZERO,
                emcy: Emcy::new(EmcyCode::DEVICE_HARDWARE, ErrorRegister::GENERIC)
            }
            .to_string(),
            "node 5: EMCY 0x5000 (device hardware), error register 0x01 (generic)"
        );
    }

    #[test]
    fn producers_speak_typed_messages_and_frame_them() {
        use crate::{
            Emcy, EmcyCode, EmcyProducer, ErrorControlFrame, ErrorControlMessage, ErrorRegister,
            GuardingMaster, NmtSlave, SYNC_COB_ID, SlaveConfig, SyncConfig, SyncMessage,
            SyncProducer, TIME_COB_ID, TimeOfDay, TimeProducer,
        };
        let node = NodeId::new(5).unwrap();
        let t0 = Instant::from_millis(10);

        let mut hb = HeartbeatProducer::new(node, 100);
        hb.start(t0);
        hb.handle_timeout(t0 + Duration::from_millis(100));
        assert_eq!(
            hb.poll_transmit(),
            Some(Heartbeat {
                state: NmtState::PreOperational
            })
        );
        hb.handle_timeout(t0 + Duration::from_millis(200));
        assert_eq!(
            hb.poll_transmit_frame(),
            Some(
                Heartbeat {
                    state: NmtState::PreOperational
                }
                .to_frame(node)
            )
        );

        let mut sync = SyncProducer::new(SyncConfig::new(Duration::from_millis(1), 3).unwrap());
        sync.start(t0);
        sync.handle_timeout(t0);
        assert_eq!(sync.poll_transmit(), Some(SyncMessage { counter: Some(1) }));
        sync.handle_timeout(t0 + Duration::from_millis(1));
        assert_eq!(
            sync.poll_transmit_frame(),
            Some(SyncMessage { counter: Some(2) }.to_frame(SYNC_COB_ID))
        );

        let mut time = TimeProducer::new(TIME_COB_ID, Duration::ZERO);
        time.set_clock(t0, 946_728_000_000);
        assert!(time.publish(t0));
        assert_eq!(
            time.poll_transmit(),
            TimeOfDay::from_unix_millis(946_728_000_000)
        );

        let emcy = Emcy::new(EmcyCode::GENERIC, ErrorRegister::GENERIC);
        let mut p = EmcyProducer::new(0x085, 0);
        p.signal(t0, emcy).unwrap();
        p.signal(t0, emcy).unwrap();
        assert_eq!(p.poll_transmit(), Some(emcy));
        assert_eq!(p.poll_transmit_frame(), Some(emcy.to_frame(0x085)));

        let mut g = GuardingMaster::<4>::new();
        g.guard(t0, node, Duration::from_millis(100), 3).unwrap();
        g.handle_timeout(t0);
        let request = g.poll_transmit().unwrap();
        assert_eq!(
            request,
            ErrorControlMessage {
                node,
                kind: ErrorControlFrame::GuardRequest
            }
        );
        assert_eq!(request.to_frame(), crate::guard_request(node));

        let mut dev = NmtSlave::new(node, SlaveConfig::default());
        dev.boot(t0);
        assert_eq!(
            dev.poll_transmit(),
            Some(ErrorControlMessage {
                node,
                kind: ErrorControlFrame::Payload(0)
            })
        );
    }

    #[test]
    fn observe_all_tracks_unmonitored_nodes() {
        extern crate std;
        let n5 = NodeId::new(5).unwrap();
        let n6 = NodeId::new(6).unwrap();
        let ms = Instant::from_millis;
        let hb = |state| Heartbeat { state };
        let mut c = HeartbeatConsumer::<8>::new();
        assert!(!c.handle_heartbeat(ms(1), n5, hb(NmtState::Operational)));
        assert_eq!(
            (c.state(n5), c.last_seen(n5)),
            (None, None),
            "off by default"
        );

        c.observe_all(true);
        assert!(c.handle_heartbeat(ms(10), n5, Heartbeat::BOOT_UP));
        assert_eq!(c.poll_event(), Some(HeartbeatEvent::BootUp { node: n5 }));
        assert_eq!(c.state(n5), Some(NmtState::BootUp));
        assert!(c.handle_heartbeat(ms(20), n5, hb(NmtState::PreOperational)));
        assert_eq!(
            c.poll_event(),
            Some(HeartbeatEvent::StateChanged {
                node: n5,
                from: None,
                to: NmtState::PreOperational
            })
        );
        assert!(c.handle_heartbeat(ms(30), n5, hb(NmtState::PreOperational)));
        assert_eq!(c.poll_event(), None, "same state, no event");
        assert_eq!(c.last_seen(n5), Some(ms(30)));
        assert_eq!(c.consumer_time(n5), Some(Duration::ZERO));
        assert_eq!(c.poll_timeout(), None, "a tracked node never times out");
        c.handle_timeout(ms(100_000));
        assert_eq!(c.poll_event(), None);

        // Monitoring it later keeps the state; the next heartbeat arms the timeout.
        c.monitor(n5, Duration::from_millis(100)).unwrap();
        assert_eq!(c.state(n5), Some(NmtState::PreOperational));
        assert!(c.handle_heartbeat(ms(40), n5, hb(NmtState::Operational)));
        assert_eq!(
            c.poll_event(),
            Some(HeartbeatEvent::StateChanged {
                node: n5,
                from: Some(NmtState::PreOperational),
                to: NmtState::Operational
            })
        );
        assert_eq!(c.poll_timeout(), Some(ms(140)));

        let frame = Heartbeat {
            state: NmtState::Stopped,
        }
        .to_frame(n6);
        assert_eq!(c.handle_frame(ms(50), &frame), Ok(true));
        assert_eq!(c.state(n6), Some(NmtState::Stopped));
        let mut nodes: std::vec::Vec<u8> = c.nodes().map(NodeId::get).collect();
        nodes.sort_unstable();
        assert_eq!(nodes, [5, 6]);
    }

    #[test]
    fn object_1016_entries() {
        let e = ConsumerHeartbeatEntry::from_raw(0x0005_01F4);
        assert_eq!(
            e,
            ConsumerHeartbeatEntry {
                node: 5,
                time_ms: 500
            }
        );
        assert_eq!(e.to_raw(), 0x0005_01F4);
        assert_eq!(
            e.active(),
            Some((NodeId::new(5).unwrap(), Duration::from_millis(500)))
        );
        assert_eq!(ConsumerHeartbeatEntry::from_raw(0x0000_01F4).active(), None);
        assert_eq!(ConsumerHeartbeatEntry::from_raw(0x0005_0000).active(), None);
        assert_eq!(ConsumerHeartbeatEntry::from_raw(0x0080_0100).active(), None);
    }
}
