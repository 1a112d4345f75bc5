//! Node guarding and life guarding (CiA 301 §7.2.8.3.2.1): the master's poller for many nodes
//! (objects 0x100C guard time and 0x100D life time factor of each node) and the device's
//! responder.
//!
//! The master sends a remote frame on 0x700 + node-ID every guard time; the node answers with
//! its state and a toggle bit that is 0 in the first answer after the guarding protocol starts and
//! alternates afterwards. Node life time = guard time × life time factor: if no valid answer
//! arrives within it, the master reports the node lost ("node guarding event"); if no request
//! arrives within it, the device reports a "life guarding event".

use canola_frame::{CanFrame, Duration, Instant, NodeId, Periodic, earliest, is_due};
use heapless::{Deque, Vec};

use crate::error::{CapacityError, DecodeError};
use crate::error_control::{ErrorControlFrame, ErrorControlMessage, GuardResponse};
use crate::heartbeat::{last_state_text, state_change};
use crate::state::NmtState;
use crate::util::push_dropping_oldest;

/// What the guarding master reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuardingEvent {
    /// The node sent a boot-up message; the next answer must carry toggle bit 0.
    BootUp {
        /// The node.
        node: NodeId,
    },
    /// A valid answer carried a different state than the previous one.
    StateChanged {
        /// The node.
        node: NodeId,
        /// The previous state (`None` for the first answer, or the first after a boot-up).
        from: Option<NmtState>,
        /// The new state.
        to: NmtState,
    },
    /// No valid answer within the node life time.
    Lost {
        /// The node.
        node: NodeId,
        /// The last state the node reported.
        last_state: Option<NmtState>,
    },
    /// A valid answer arrived after [`Lost`](Self::Lost).
    Recovered {
        /// The node.
        node: NodeId,
        /// The state in that answer.
        state: NmtState,
    },
    /// An answer carried the same toggle bit as the previous one (a lost or repeated answer).
    /// The answer does not count as a sign of life; the next one is expected to alternate
    /// from it.
    ToggleError {
        /// The node.
        node: NodeId,
        /// The toggle bit that was expected.
        expected: bool,
    },
}

impl core::fmt::Display for GuardingEvent {
    /// `node 5 booted`, `node 5 Pre-operational -> Operational`, `node 5 node guarding lost
    /// (last state Operational)`, `node 5 answers again, Operational`, `node 5 toggle bit
    /// error (expected 1)`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BootUp { node } => write!(f, "node {node} booted"),
            Self::StateChanged { node, from, to } => state_change(f, node, from, to),
            Self::Lost { node, last_state } => {
                write!(f, "node {node} node guarding lost")?;
                last_state_text(f, last_state)
            }
            Self::Recovered { node, state } => write!(f, "node {node} answers again, {state}"),
            Self::ToggleError { node, expected } => write!(
                f,
                "node {node} toggle bit error (expected {})",
                u8::from(expected)
            ),
        }
    }
}

/// Capacity of the guarding master's event queue.
pub const GUARDING_EVENT_CAPACITY: usize = 64;

#[derive(Debug, Clone)]
struct Entry {
    node: NodeId,
    /// The guarding requests, every guard time.
    poll: Periodic,
    life_time: Duration,
    life_deadline: Option<Instant>,
    expected_toggle: Option<bool>,
    state: Option<NmtState>,
    lost: bool,
}

/// Guards up to `N` nodes (default: all 127).
///
/// Call order: [`guard`](Self::guard) each node; when [`poll_timeout`](Self::poll_timeout)
/// passes, [`handle_timeout`](Self::handle_timeout), then drain
/// [`poll_transmit`](Self::poll_transmit) (the remote requests) and [`poll_event`](Self::poll_event);
/// for every received frame [`handle_frame`](Self::handle_frame) and drain the events.
/// [`poll_transmit_frame`](Self::poll_transmit_frame) gives the requests as remote frames.
///
/// The first request goes out at the instant `guard` is called; the life time counts from there.
/// Until the first answer either toggle value is accepted (the node may still be guarded by an
/// earlier session of the master); after a boot-up the next answer must carry 0.
#[derive(Debug, Clone)]
pub struct GuardingMaster<const N: usize = 127> {
    entries: Vec<Entry, N>,
    /// Nodes a guarding request is due for.
    tx: Deque<NodeId, N>,
    events: Deque<GuardingEvent, GUARDING_EVENT_CAPACITY>,
    dropped: u32,
}

impl<const N: usize> Default for GuardingMaster<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> GuardingMaster<N> {
    /// A master guarding nothing.
    pub const fn new() -> Self {
        Self {
            entries: Vec::new(),
            tx: Deque::new(),
            events: Deque::new(),
            dropped: 0,
        }
    }

    /// Starts (or restarts) guarding `node` with its guard time (0x100C) and life time factor
    /// (0x100D). A zero guard time stops guarding the node; a life time factor of 0 is taken as 1.
    pub fn guard(
        &mut self,
        now: Instant,
        node: NodeId,
        guard_time: Duration,
        life_time_factor: u8,
    ) -> Result<(), CapacityError> {
        if guard_time.is_zero() {
            self.remove(node);
            return Ok(());
        }
        let life_time = guard_time.saturating_mul(u64::from(life_time_factor.max(1)));
        let mut poll = Periodic::new(guard_time);
        poll.start_at(now);
        let entry = Entry {
            node,
            poll,
            life_time,
            life_deadline: Some(now + life_time),
            expected_toggle: None,
            state: None,
            lost: false,
        };
        if let Some(e) = self.entries.iter_mut().find(|e| e.node == node) {
            *e = Entry {
                state: e.state,
                ..entry
            };
            return Ok(());
        }
        self.entries
            .push(entry)
            .map_err(|_| CapacityError { capacity: N })
    }

    /// Stops guarding `node`. Returns whether it was guarded.
    pub fn remove(&mut self, node: NodeId) -> bool {
        match self.entries.iter().position(|e| e.node == node) {
            Some(i) => {
                self.entries.swap_remove(i);
                true
            }
            None => false,
        }
    }

    /// The last state `node` reported.
    pub fn state(&self, node: NodeId) -> Option<NmtState> {
        self.entries.iter().find(|e| e.node == node)?.state
    }

    /// Whether `node` is currently considered lost.
    pub fn is_lost(&self, node: NodeId) -> bool {
        self.entries.iter().any(|e| e.node == node && e.lost)
    }

    /// Takes a frame. `Ok(false)`: not an answer from a guarded node (remote frames, which are
    /// the master's own requests, are ignored); `Ok(true)`: handled; `Err`: malformed.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> Result<bool, DecodeError> {
        let (node, kind) = match ErrorControlFrame::from_frame(frame) {
            Ok(x) => x,
            Err(DecodeError::WrongCobId(_)) => return Ok(false),
            Err(e) => {
                let ours = frame.cob_id().is_some_and(|c| {
                    self.entries
                        .iter()
                        .any(|e| u16::from(e.node.get()) + 0x700 == c)
                });
                return if ours { Err(e) } else { Ok(false) };
            }
        };
        match kind {
            ErrorControlFrame::GuardRequest => Ok(false),
            ErrorControlFrame::Payload(b) => Ok(self.handle_response(now, node, b)),
        }
    }

    /// Takes the data byte of an answer (or boot-up) from `node`. Returns false if `node` is
    /// not guarded.
    pub fn handle_response(&mut self, now: Instant, node: NodeId, byte: u8) -> bool {
        let Some(e) = self.entries.iter_mut().find(|e| e.node == node) else {
            return false;
        };
        let mut out: [Option<GuardingEvent>; 2] = [None, None];
        if byte == NmtState::BootUp.to_u8() {
            e.state = None;
            e.expected_toggle = Some(false);
            e.lost = false;
            e.life_deadline = Some(now + e.life_time);
            out[0] = Some(GuardingEvent::BootUp { node });
        } else {
            let r = GuardResponse::from_byte(byte);
            match e.expected_toggle {
                Some(expected) if expected != r.toggle => {
                    out[0] = Some(GuardingEvent::ToggleError { node, expected });
                }
                _ => {
                    if e.lost {
                        e.lost = false;
                        out[0] = Some(GuardingEvent::Recovered {
                            node,
                            state: r.state,
                        });
                    }
                    if e.state != Some(r.state) {
                        out[1] = Some(GuardingEvent::StateChanged {
                            node,
                            from: e.state,
                            to: r.state,
                        });
                    }
                    e.state = Some(r.state);
                    e.life_deadline = Some(now + e.life_time);
                }
            }
            e.expected_toggle = Some(!r.toggle);
        }
        for ev in out.into_iter().flatten() {
            if push_dropping_oldest(&mut self.events, ev) {
                self.dropped = self.dropped.saturating_add(1);
            }
        }
        true
    }

    /// Sends the due requests and reports nodes whose life time ran out.
    pub fn handle_timeout(&mut self, now: Instant) {
        for e in self.entries.iter_mut() {
            if e.poll.fire(now) {
                // A full queue means the caller is not draining; skip this poll rather than
                // queue stale requests.
                let _ = self.tx.push_back(e.node);
            }
            if is_due(e.life_deadline, now) && !self.events.is_full() {
                e.life_deadline = None;
                e.lost = true;
                let _ = self.events.push_back(GuardingEvent::Lost {
                    node: e.node,
                    last_state: e.state,
                });
            }
        }
    }

    /// The next guarding request to send (an [`ErrorControlMessage`] whose kind is
    /// [`ErrorControlFrame::GuardRequest`]).
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<ErrorControlMessage> {
        self.tx.pop_front().map(|node| ErrorControlMessage {
            node,
            kind: ErrorControlFrame::GuardRequest,
        })
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame: the remote frame on 0x700 + node.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|m| m.to_frame())
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<GuardingEvent> {
        self.events.pop_front()
    }

    /// The earliest poll or life-time deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        // Asked at every step of a master, mostly with nothing guarded.
        if self.entries.is_empty() {
            return None;
        }
        earliest(
            self.entries
                .iter()
                .flat_map(|e| [e.poll.deadline(), e.life_deadline]),
        )
    }

    /// How many frame events were dropped because the queue was full.
    pub const fn dropped_events(&self) -> u32 {
        self.dropped
    }
}

/// A device's life-guarding report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LifeGuardingEvent {
    /// No guarding request within the node life time (after the first request).
    Lost,
    /// A request arrived again after [`Lost`](Self::Lost).
    Resumed,
}

impl core::fmt::Display for LifeGuardingEvent {
    /// `life guarding lost`, `life guarding resumed`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Lost => "life guarding lost",
            Self::Resumed => "life guarding resumed",
        })
    }
}

/// A device's side of node guarding: answers requests with the toggle bit and watches the
/// master's life time.
///
/// Life guarding is active when both the guard time (0x100C) and the life time factor (0x100D)
/// are non-zero, and starts with the first request. Call [`reset`](Self::reset) on reset
/// communication and at boot.
#[derive(Debug, Clone)]
pub struct GuardingResponder {
    guard_time: Duration,
    life_time_factor: u8,
    toggle: bool,
    deadline: Option<Instant>,
    lost: bool,
}

impl GuardingResponder {
    /// A responder with guard time (ms) and life time factor.
    pub const fn new(guard_time_ms: u16, life_time_factor: u8) -> Self {
        Self {
            guard_time: Duration::from_millis(guard_time_ms as u64),
            life_time_factor,
            toggle: false,
            deadline: None,
            lost: false,
        }
    }

    /// Changes guard time and life time factor (SDO writes to 0x100C / 0x100D). Takes effect with
    /// the next request.
    pub fn configure(&mut self, guard_time_ms: u16, life_time_factor: u8) {
        self.guard_time = Duration::from_millis(u64::from(guard_time_ms));
        self.life_time_factor = life_time_factor;
        if self.life_time().is_none() {
            self.deadline = None;
        }
    }

    /// The node life time, if life guarding is enabled.
    pub fn life_time(&self) -> Option<Duration> {
        let t = self
            .guard_time
            .saturating_mul(u64::from(self.life_time_factor));
        (!t.is_zero()).then_some(t)
    }

    /// Back to the initial condition: next answer carries toggle 0, life guarding inactive.
    pub fn reset(&mut self) {
        self.toggle = false;
        self.deadline = None;
        self.lost = false;
    }

    /// Answers a request while the device is in `state`. Returns the answer and
    /// [`LifeGuardingEvent::Resumed`] if the master had been lost.
    pub fn handle_request(
        &mut self,
        now: Instant,
        state: NmtState,
    ) -> (GuardResponse, Option<LifeGuardingEvent>) {
        let answer = GuardResponse {
            toggle: self.toggle,
            state,
        };
        self.toggle = !self.toggle;
        self.deadline = self.life_time().map(|t| now + t);
        let ev = core::mem::take(&mut self.lost).then_some(LifeGuardingEvent::Resumed);
        (answer, ev)
    }

    /// Reports [`LifeGuardingEvent::Lost`] once when the life time has run out.
    pub fn handle_timeout(&mut self, now: Instant) -> Option<LifeGuardingEvent> {
        if is_due(self.deadline, now) {
            self.deadline = None;
            self.lost = true;
            return Some(LifeGuardingEvent::Lost);
        }
        None
    }

    /// When the life time runs out.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.deadline
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn responder_toggles_and_watches_life_time() {
        let mut r = GuardingResponder::new(100, 3);
        assert_eq!(r.life_time(), Some(Duration::from_millis(300)));
        assert_eq!(r.poll_timeout(), None, "inactive before the first request");
        let t0 = Instant::from_millis(1000);
        let (a, ev) = r.handle_request(t0, NmtState::PreOperational);
        assert_eq!((a.emit(), ev), (0x7F, None));
        let (a, _) = r.handle_request(t0 + Duration::from_millis(100), NmtState::Operational);
        assert_eq!(a.emit(), 0x85);
        let (a, _) = r.handle_request(t0 + Duration::from_millis(200), NmtState::Operational);
        assert_eq!(a.emit(), 0x05);
        assert_eq!(r.poll_timeout(), Some(t0 + Duration::from_millis(500)));
        assert_eq!(r.handle_timeout(t0 + Duration::from_millis(499)), None);
        assert_eq!(
            r.handle_timeout(t0 + Duration::from_millis(500)),
            Some(LifeGuardingEvent::Lost)
        );
        assert_eq!(
            r.handle_timeout(t0 + Duration::from_millis(900)),
            None,
            "reported once"
        );
        let (a, ev) = r.handle_request(t0 + Duration::from_millis(1000), NmtState::Stopped);
        assert_eq!((a.emit(), ev), (0x84, Some(LifeGuardingEvent::Resumed)));
        r.reset();
        let (a, _) = r.handle_request(t0, NmtState::Stopped);
        assert_eq!(a.emit(), 0x04, "toggle restarts at 0");
        r.configure(0, 3);
        assert_eq!(r.life_time(), None);
        assert_eq!(r.poll_timeout(), None);
    }
}
