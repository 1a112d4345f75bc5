//! The device side of NMT (CiA 301 §7.3.2): the NMT slave state machine with its boot-up
//! message, heartbeat producer (0x1017) and node-guarding responder (0x100C/0x100D), for
//! device simulators and firmware.
//!
//! States: Initialisation → (boot-up message) → Pre-operational; NMT commands then move the node
//! between Pre-operational, Operational and Stopped. Reset node and reset communication take it
//! back to Initialisation and are reported as events: the application resets its objects
//! (application and communication area, or communication area only), applies the restored
//! configuration and calls [`NmtSlave::boot`] again, which sends the boot-up message.

use canola_frame::{CanFrame, Instant, NodeId, earliest};
use heapless::Deque;

use crate::command::{CommandSpecifier, NMT_COB_ID, NmtCommand};
use crate::error::DecodeError;
use crate::error_control::{
    ErrorControlFrame, ErrorControlMessage, Heartbeat, error_control_cob_id,
};
use crate::guarding::{GuardingResponder, LifeGuardingEvent};
use crate::heartbeat::HeartbeatProducer;
use crate::state::{DeviceState, Service};
use crate::util::push_dropping_oldest;

/// Error-control configuration of a device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SlaveConfig {
    /// Producer heartbeat time (0x1017), ms; 0 = no heartbeat.
    pub heartbeat_ms: u16,
    /// Guard time (0x100C), ms.
    pub guard_time_ms: u16,
    /// Life time factor (0x100D).
    pub life_time_factor: u8,
}

/// What the NMT slave reports to the application.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlaveEvent {
    /// The NMT state changed.
    StateChanged {
        /// The previous state.
        from: DeviceState,
        /// The new state.
        to: DeviceState,
    },
    /// Reset node received: reset the application and communication objects, then call
    /// [`NmtSlave::boot`].
    ResetNode,
    /// Reset communication received: reset the communication objects (0x1000..=0x1FFF), then
    /// call [`NmtSlave::boot`].
    ResetCommunication,
    /// Life guarding event: the master stopped guarding within the node life time.
    LifeGuardingLost,
    /// Guarding requests arrive again after [`LifeGuardingLost`](Self::LifeGuardingLost).
    LifeGuardingResumed,
    /// An NMT command with an unknown command specifier addressed this node; it was ignored.
    UnknownCommand(u8),
}

impl core::fmt::Display for SlaveEvent {
    /// `Pre-operational -> Operational`, `Reset node`, `Reset communication`, `life guarding
    /// lost`, `life guarding resumed`, `unknown NMT command 0x03 ignored`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::StateChanged { from, to } => write!(f, "{from} -> {to}"),
            Self::ResetNode => f.write_str("Reset node"),
            Self::ResetCommunication => f.write_str("Reset communication"),
            Self::LifeGuardingLost => f.write_str("life guarding lost"),
            Self::LifeGuardingResumed => f.write_str("life guarding resumed"),
            Self::UnknownCommand(cs) => write!(f, "unknown NMT command {cs:#04x} ignored"),
        }
    }
}

const TX_CAPACITY: usize = 4;
const EVENT_CAPACITY: usize = 8;

/// A device's NMT slave.
///
/// Call order: [`boot`](Self::boot) once at power-on (and after each reset event); for every
/// received frame [`handle_frame`](Self::handle_frame); when [`poll_timeout`](Self::poll_timeout)
/// passes, [`handle_timeout`](Self::handle_timeout); after each call drain
/// [`poll_transmit`](Self::poll_transmit) and [`poll_event`](Self::poll_event). Ask
/// [`allows`](Self::allows) before using SDO, PDO, EMCY, SYNC or TIME.
#[derive(Debug, Clone)]
pub struct NmtSlave {
    node: NodeId,
    state: DeviceState,
    heartbeat: HeartbeatProducer,
    guarding: GuardingResponder,
    /// Error-control data bytes to send: boot-up, heartbeats, guarding answers.
    tx: Deque<ErrorControlMessage, TX_CAPACITY>,
    events: Deque<SlaveEvent, EVENT_CAPACITY>,
}

impl NmtSlave {
    /// A node in Initialisation.
    pub const fn new(node: NodeId, config: SlaveConfig) -> Self {
        Self {
            node,
            state: DeviceState::Initialising,
            heartbeat: HeartbeatProducer::new(node, config.heartbeat_ms),
            guarding: GuardingResponder::new(config.guard_time_ms, config.life_time_factor),
            tx: Deque::new(),
            events: Deque::new(),
        }
    }

    /// The node-ID.
    pub const fn node(&self) -> NodeId {
        self.node
    }

    /// Changes the node-ID (e.g. after LSS). Only possible in Initialisation, i.e. after a reset
    /// event and before [`boot`](Self::boot); returns whether it was applied.
    pub fn set_node(&mut self, node: NodeId) -> bool {
        if self.state != DeviceState::Initialising {
            return false;
        }
        self.node = node;
        let period = self.heartbeat.period().as_millis();
        self.heartbeat = HeartbeatProducer::new(node, u16::try_from(period).unwrap_or(u16::MAX));
        true
    }

    /// The current state.
    pub const fn state(&self) -> DeviceState {
        self.state
    }

    /// Whether `service` may be used now.
    pub const fn allows(&self, service: Service) -> bool {
        self.state.allows(service)
    }

    /// Finishes initialisation: sends the boot-up message, enters Pre-operational and starts the
    /// heartbeat. Does nothing outside Initialisation.
    pub fn boot(&mut self, now: Instant) {
        if self.state != DeviceState::Initialising {
            return;
        }
        self.push_tx(Heartbeat::BOOT_UP.emit());
        self.guarding.reset();
        self.set_state(DeviceState::PreOperational);
        self.heartbeat.start(now);
    }

    /// Changes the producer heartbeat time (SDO write to 0x1017); the next heartbeat is due one
    /// new period from `now`.
    pub fn set_heartbeat_time(&mut self, now: Instant, ms: u16) {
        self.heartbeat.set_period(now, ms);
    }

    /// Changes guard time (0x100C) and life time factor (0x100D).
    pub fn set_guarding(&mut self, guard_time_ms: u16, life_time_factor: u8) {
        self.guarding.configure(guard_time_ms, life_time_factor);
    }

    fn push_tx(&mut self, byte: u8) {
        let msg = ErrorControlMessage {
            node: self.node,
            kind: ErrorControlFrame::Payload(byte),
        };
        push_dropping_oldest(&mut self.tx, msg);
    }

    fn push_event(&mut self, ev: SlaveEvent) {
        push_dropping_oldest(&mut self.events, ev);
    }

    fn set_state(&mut self, to: DeviceState) {
        let from = self.state;
        if from != to {
            self.state = to;
            self.heartbeat.set_state(to.wire());
            self.push_event(SlaveEvent::StateChanged { from, to });
        }
    }

    /// Takes a frame: NMT module control (0x000) and node-guarding requests for this node.
    /// `Ok(false)` for frames of other services, `Err` for a malformed NMT frame.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> Result<bool, DecodeError> {
        match frame.cob_id() {
            Some(NMT_COB_ID) => {
                let cmd = NmtCommand::from_frame(frame)?;
                self.handle_command(now, cmd);
                Ok(true)
            }
            Some(cob) if cob == error_control_cob_id(self.node) && frame.is_remote() => {
                self.handle_guard_request(now);
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// Applies an NMT command. Returns whether it addressed this node and was acted on (commands
    /// are ignored in Initialisation).
    pub fn handle_command(&mut self, _now: Instant, cmd: NmtCommand) -> bool {
        if !cmd.target.addresses(self.node) || self.state == DeviceState::Initialising {
            return false;
        }
        match cmd.command {
            CommandSpecifier::Start => self.set_state(DeviceState::Operational),
            CommandSpecifier::Stop => self.set_state(DeviceState::Stopped),
            CommandSpecifier::EnterPreOperational => self.set_state(DeviceState::PreOperational),
            CommandSpecifier::ResetNode | CommandSpecifier::ResetCommunication => {
                self.heartbeat.stop();
                self.guarding.reset();
                self.set_state(DeviceState::Initialising);
                self.push_event(if cmd.command == CommandSpecifier::ResetNode {
                    SlaveEvent::ResetNode
                } else {
                    SlaveEvent::ResetCommunication
                });
            }
            CommandSpecifier::Unknown(cs) => self.push_event(SlaveEvent::UnknownCommand(cs)),
        }
        true
    }

    /// Answers a node-guarding request (not in Initialisation).
    pub fn handle_guard_request(&mut self, now: Instant) {
        if self.state == DeviceState::Initialising {
            return;
        }
        let (answer, ev) = self.guarding.handle_request(now, self.state.wire());
        self.push_tx(answer.emit());
        if ev == Some(LifeGuardingEvent::Resumed) {
            self.push_event(SlaveEvent::LifeGuardingResumed);
        }
    }

    /// Sends the due heartbeat and reports a life guarding event.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.heartbeat.handle_timeout(now);
        if let Some(hb) = self.heartbeat.poll_transmit() {
            self.push_tx(hb.emit());
        }
        if self.guarding.handle_timeout(now) == Some(LifeGuardingEvent::Lost) {
            self.push_event(SlaveEvent::LifeGuardingLost);
        }
    }

    /// The next message to send: the boot-up message, a heartbeat or a node-guarding answer,
    /// all one byte on 0x700 + node.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<ErrorControlMessage> {
        self.tx.pop_front()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|m| m.to_frame())
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop_front()
    }

    /// The next heartbeat or life-time deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        earliest([self.heartbeat.poll_timeout(), self.guarding.poll_timeout()])
    }
}
