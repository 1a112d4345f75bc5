//! A DeviceNet master of one group 2 only slave through the Predefined Master/Slave Connection
//! Set, sans-IO: feed [`Master::handle_frame`] and [`Master::handle_timeout`], drain
//! [`Master::poll_transmit`] and [`Master::poll_event`], call back at [`Master::poll_timeout`].
//!
//! Sequence after [`Master::start`]:
//! 1. Duplicate MAC ID check of its own MAC ID: two requests [`MasterConfig::dup_mac_wait`]
//!    apart; any check message for that MAC meanwhile is a duplicate
//!    ([`MasterState::Faulted`], [`MasterEvent::DuplicateMac`]). On line it answers other
//!    stations' checks of its MAC with a response.
//! 2. Connect: the unconnected Allocate_Master/Slave_Connection_Set (explicit + polled), the
//!    explicit connection's expected packet rate, the Identity object (attributes 1..=7, the
//!    product name fragmented), the poll connection's produced and consumed sizes (Connection
//!    object instance 2, attributes 7 and 8), and its expected packet rate, which establishes it:
//!    [`MasterEvent::Connected`].
//! 3. Connected: a poll command every [`MasterConfig::poll_cycle`] with [`Master::set_output`]'s
//!    data (I/O-fragmented when the consumed size is above 8; zero-length while
//!    [`Master::set_idle`]), each complete poll response is a [`MasterEvent::Input`]. The
//!    explicit connection is kept alive with a read of the Identity status every half explicit
//!    rate; application requests go through [`Master::get_attribute`] /
//!    [`Master::set_attribute`], one at a time.
//!    A slave that still holds the set for this MAC ID (the master restarted) answers the
//!    Allocate with "already in requested mode/state": the master releases the set and
//!    allocates again.
//! 4. Loss: no poll response within 4 × the poll rate, or an explicit request without answer,
//!    ends the connection ([`MasterEvent::ConnectionLost`]); the master connects again after
//!    [`MasterConfig::reconnect_delay`]. A refused step of the connect sequence is a
//!    [`MasterEvent::ConnectFailed`] with the slave's CIP status, retried the same way.

use canola_frame::{CanFrame, Duration, Instant};
use heapless::Deque;

use crate::explicit::{
    ALLOCATE, AllocationChoice, CLASS_CONNECTION, CLASS_DEVICENET, CLASS_IDENTITY, ExplicitFrame,
    Header, Path, Request, Response,
};
use crate::fragment::{FragmentByte, MessageBuf, Reassembler, io_frames};
use crate::id::{DnId, MacId, Predefined};
use crate::identity::{DuplicateMacCheck, Identity, attr};
use crate::link::{Link, LinkEvent, TX_LEN};

mod event;

use crate::status::{CipError, GeneralStatus};
pub use event::{ConnectError, ExplicitFailure, Handle, MasterError, MasterEvent};

/// Master settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MasterConfig {
    /// Own MAC ID (masters commonly use 0).
    pub mac: MacId,
    /// Own vendor ID and serial number for the Duplicate MAC ID check.
    pub vendor_id: u16,
    /// Own serial number.
    pub serial_number: u32,
    /// The slave.
    pub slave: MacId,
    /// Poll cycle; also the poll connection's expected packet rate (rounded up to ms).
    pub poll_cycle: Duration,
    /// Expected packet rate set on the explicit connection.
    pub explicit_rate: Duration,
    /// How long to wait for an explicit response (and for each fragment's acknowledgement).
    pub response_timeout: Duration,
    /// Wait after each Duplicate MAC ID request (1 s in the specification).
    pub dup_mac_wait: Duration,
    /// Wait before connecting again after a loss or a refusal.
    pub reconnect_delay: Duration,
}

impl MasterConfig {
    /// MAC 0 polling `slave` every 10 ms, with the specification's timings.
    pub fn new(slave: MacId) -> Self {
        Self {
            mac: MacId::from_bits(0),
            vendor_id: 0,
            serial_number: 1,
            slave,
            poll_cycle: Duration::from_millis(10),
            explicit_rate: Duration::from_millis(2500),
            response_timeout: Duration::from_millis(1000),
            dup_mac_wait: Duration::from_millis(1000),
            reconnect_delay: Duration::from_millis(1000),
        }
    }
}

/// The master's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MasterState {
    /// Not started.
    Offline,
    /// Duplicate MAC ID check, request 1 or 2 sent.
    Checking(u8),
    /// On line, waiting to connect (again).
    Disconnected,
    /// Running the connect sequence.
    Connecting,
    /// Polling.
    Connected,
    /// A duplicate MAC ID was found; silent for good.
    Faulted,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Release,
    Allocate,
    ExplicitRate,
    Identity(u8),
    Produced,
    Consumed,
    PollRate,
    KeepAlive,
    App(Handle),
}

impl Step {
    fn name(self) -> &'static str {
        match self {
            Step::Release => "Release_Master/Slave_Connection_Set",
            Step::Allocate => "Allocate_Master/Slave_Connection_Set",
            Step::ExplicitRate => "explicit connection expected packet rate",
            Step::Identity(_) => "Identity object",
            Step::Produced => "produced connection size",
            Step::Consumed => "consumed connection size",
            Step::PollRate => "poll connection expected packet rate",
            Step::KeepAlive => "keep-alive",
            Step::App(_) => "request",
        }
    }
}

#[derive(Debug, Clone)]
struct Queued {
    handle: Handle,
    set: bool,
    path: Path,
    data: MessageBuf,
}

/// The master machine.
#[derive(Debug)]
pub struct Master {
    config: MasterConfig,
    state: MasterState,
    deadline: Option<Instant>,
    link: Link,
    xid: bool,
    in_flight: Option<(Step, Instant)>,
    queue: Deque<Queued, 8>,
    next_handle: u32,
    identity: Identity,
    produced: u16,
    consumed: u16,
    output: MessageBuf,
    idle: bool,
    next_poll: Option<Instant>,
    poll_deadline: Option<Instant>,
    last_explicit: Instant,
    poll_rx: Reassembler,
    tx: Deque<CanFrame, TX_LEN>,
    events: Deque<MasterEvent, 32>,
}

impl Master {
    /// A master, offline until [`Master::start`].
    pub fn new(config: MasterConfig) -> Self {
        let link = Link::new(
            Predefined::MasterExplicitRequest(config.slave).can_id(),
            config.mac,
            config.response_timeout,
        );
        Self {
            config,
            state: MasterState::Offline,
            deadline: None,
            link,
            xid: false,
            in_flight: None,
            queue: Deque::new(),
            next_handle: 0,
            identity: Identity::default(),
            produced: 0,
            consumed: 0,
            output: MessageBuf::new(),
            idle: false,
            next_poll: None,
            poll_deadline: None,
            last_explicit: Instant::ZERO,
            poll_rx: Reassembler::new(),
            tx: Deque::new(),
            events: Deque::new(),
        }
    }

    /// Starts the Duplicate MAC ID check; the master connects when it passes.
    pub fn start(&mut self, now: Instant) {
        self.state = MasterState::Checking(1);
        self.send_check(false);
        self.deadline = Some(now + self.config.dup_mac_wait);
    }

    /// State.
    pub fn state(&self) -> MasterState {
        self.state
    }
    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }
    /// The slave's identity as read at connect (default before).
    pub fn identity(&self) -> &Identity {
        &self.identity
    }
    /// The poll connection's (produced, consumed) sizes as read at connect.
    pub fn sizes(&self) -> (u16, u16) {
        (self.produced, self.consumed)
    }

    /// The poll command data (sent from the next cycle on).
    pub fn set_output(&mut self, data: &[u8]) {
        self.output.clear();
        let _ = self.output.extend_from_slice(data);
    }

    /// Idle: send zero-length poll commands (the slave keeps its outputs safe).
    pub fn set_idle(&mut self, idle: bool) {
        self.idle = idle;
    }

    /// Releases the connection set (unconnected Release) and stays disconnected until
    /// [`Master::connect`].
    pub fn disconnect(&mut self, now: Instant) {
        if matches!(self.state, MasterState::Connected | MasterState::Connecting) {
            self.release_request();
        }
        self.drop_connection(now);
        self.state = MasterState::Disconnected;
        self.deadline = None;
    }

    /// Connects (again) now, if on line and not connected.
    pub fn connect(&mut self, now: Instant) {
        if self.state == MasterState::Disconnected {
            self.begin_connect(now);
        }
    }

    fn event(&mut self, e: MasterEvent) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    fn send_check(&mut self, response: bool) {
        let m = DuplicateMacCheck {
            response,
            port: 0,
            vendor_id: self.config.vendor_id,
            serial_number: self.config.serial_number,
        };
        if let Ok(f) = CanFrame::new(
            Predefined::DuplicateMacCheck(self.config.mac).can_id(),
            &m.emit(),
        ) {
            let _ = self.tx.push_back(f);
        }
    }

    fn send_unconnected(&mut self, message: &[u8]) {
        self.xid = !self.xid;
        let f = ExplicitFrame::Whole {
            header: Header {
                fragmented: false,
                xid: self.xid,
                mac: self.config.mac,
            },
            message,
        };
        if let Some(b) = f.emit()
            && let Ok(frame) = CanFrame::new(
                Predefined::UnconnectedRequest(self.config.slave).can_id(),
                &b,
            )
        {
            let _ = self.tx.push_back(frame);
        }
    }

    fn release_request(&mut self) {
        let mut m = MessageBuf::new();
        let _ = Request::Release {
            class: CLASS_DEVICENET,
            instance: 1,
            choice: AllocationChoice::EXPLICIT.union(AllocationChoice::POLLED),
        }
        .emit(&mut m);
        self.send_unconnected(&m);
    }

    fn begin_connect(&mut self, now: Instant) {
        self.state = MasterState::Connecting;
        self.deadline = None;
        self.link.reset();
        self.identity = Identity::default();
        let mut m = MessageBuf::new();
        let _ = Request::Allocate {
            class: CLASS_DEVICENET,
            instance: 1,
            choice: AllocationChoice::EXPLICIT.union(AllocationChoice::POLLED),
            allocator: self.config.mac,
        }
        .emit(&mut m);
        self.send_unconnected(&m);
        self.in_flight = Some((Step::Allocate, now + self.config.response_timeout));
    }

    fn rate_ms(d: Duration) -> u16 {
        d.as_micros().div_ceil(1000).min(u16::MAX as u64) as u16
    }

    fn request(&mut self, now: Instant, step: Step, r: Request<'_>) {
        let mut m = MessageBuf::new();
        if r.emit(&mut m).is_err() {
            return;
        }
        self.xid = !self.xid;
        let mut tx = core::mem::take(&mut self.tx);
        self.link.send(now, &m, self.xid, &mut tx);
        self.tx = tx;
        self.last_explicit = now;
        self.in_flight = Some((step, now + self.config.response_timeout));
    }

    fn next_step(&mut self, now: Instant, step: Step) {
        let conn = |a| Path::new(CLASS_CONNECTION, 2, a);
        match step {
            Step::Allocate => {
                let ms = Self::rate_ms(self.config.explicit_rate);
                self.request(
                    now,
                    Step::ExplicitRate,
                    Request::SetAttributeSingle(
                        Path::new(CLASS_CONNECTION, 1, 9),
                        &ms.to_le_bytes(),
                    ),
                )
            }
            Step::ExplicitRate => self.request(
                now,
                Step::Identity(1),
                Request::GetAttributeSingle(Path::new(CLASS_IDENTITY, 1, 1)),
            ),
            Step::Identity(n) if n < attr::PRODUCT_NAME => self.request(
                now,
                Step::Identity(n + 1),
                Request::GetAttributeSingle(Path::new(CLASS_IDENTITY, 1, n + 1)),
            ),
            Step::Identity(_) => {
                self.request(now, Step::Produced, Request::GetAttributeSingle(conn(7)))
            }
            Step::Produced => {
                self.request(now, Step::Consumed, Request::GetAttributeSingle(conn(8)))
            }
            Step::Consumed => {
                let ms = Self::rate_ms(self.config.poll_cycle);
                self.request(
                    now,
                    Step::PollRate,
                    Request::SetAttributeSingle(conn(9), &ms.to_le_bytes()),
                )
            }
            Step::PollRate => {
                self.state = MasterState::Connected;
                self.next_poll = Some(now);
                self.poll_deadline = Some(now + self.poll_timeout_span());
                self.poll_rx.reset();
                let e = MasterEvent::Connected {
                    identity: self.identity.clone(),
                    produced_size: self.produced,
                    consumed_size: self.consumed,
                };
                self.event(e);
                self.dispatch(now);
            }
            Step::KeepAlive | Step::App(_) => self.dispatch(now),
            Step::Release => {}
        }
    }

    fn poll_timeout_span(&self) -> Duration {
        Duration::from_millis(4 * Self::rate_ms(self.config.poll_cycle).max(1) as u64)
    }

    fn dispatch(&mut self, now: Instant) {
        if self.state != MasterState::Connected || self.in_flight.is_some() {
            return;
        }
        let Some(q) = self.queue.pop_front() else {
            return;
        };
        let r = if q.set {
            Request::SetAttributeSingle(q.path, &q.data)
        } else {
            Request::GetAttributeSingle(q.path)
        };
        // `r` borrows `q`; copy the message out first.
        let mut m = MessageBuf::new();
        let _ = r.emit(&mut m);
        self.xid = !self.xid;
        let mut tx = core::mem::take(&mut self.tx);
        self.link.send(now, &m, self.xid, &mut tx);
        self.tx = tx;
        self.last_explicit = now;
        self.in_flight = Some((Step::App(q.handle), now + self.config.response_timeout));
    }

    fn enqueue(
        &mut self,
        now: Instant,
        set: bool,
        path: Path,
        data: &[u8],
    ) -> Result<Handle, MasterError> {
        if self.state != MasterState::Connected {
            return Err(MasterError::NotConnected);
        }
        let mut d = MessageBuf::new();
        d.extend_from_slice(data)
            .map_err(|_| MasterError::TooLong)?;
        let handle = Handle(self.next_handle);
        self.queue
            .push_back(Queued {
                handle,
                set,
                path,
                data: d,
            })
            .map_err(|_| MasterError::QueueFull)?;
        self.next_handle = self.next_handle.wrapping_add(1);
        self.dispatch(now);
        Ok(handle)
    }

    /// Queues a Get_Attribute_Single.
    pub fn get_attribute(&mut self, now: Instant, path: Path) -> Result<Handle, MasterError> {
        self.enqueue(now, false, path, &[])
    }

    /// Queues a Set_Attribute_Single.
    pub fn set_attribute(
        &mut self,
        now: Instant,
        path: Path,
        data: &[u8],
    ) -> Result<Handle, MasterError> {
        self.enqueue(now, true, path, data)
    }

    fn drop_connection(&mut self, _now: Instant) {
        if let Some((Step::App(h), _)) = self.in_flight.take() {
            self.event(MasterEvent::ExplicitDone {
                handle: h,
                result: Err(ExplicitFailure::NotConnected),
            });
        }
        while let Some(q) = self.queue.pop_front() {
            self.event(MasterEvent::ExplicitDone {
                handle: q.handle,
                result: Err(ExplicitFailure::NotConnected),
            });
        }
        self.link.reset();
        self.next_poll = None;
        self.poll_deadline = None;
        self.poll_rx.reset();
    }

    fn lost(&mut self, now: Instant) {
        self.drop_connection(now);
        self.event(MasterEvent::ConnectionLost);
        self.state = MasterState::Disconnected;
        self.deadline = Some(now + self.config.reconnect_delay);
    }

    fn connect_failed(&mut self, now: Instant, e: ConnectError) {
        self.in_flight = None;
        self.link.reset();
        self.event(MasterEvent::ConnectFailed(e));
        self.state = MasterState::Disconnected;
        self.deadline = Some(now + self.config.reconnect_delay);
    }

    fn handle_response(&mut self, now: Instant, msg: &[u8]) {
        let Some((step, _)) = self.in_flight else {
            return;
        };
        let Ok(r) = Response::parse(msg) else {
            return;
        };
        self.in_flight = None;
        let connecting = self.state == MasterState::Connecting;
        match (step, r) {
            (Step::App(handle), Response::Success { data, .. }) => {
                let d = MessageBuf::from_slice(data).unwrap_or_default();
                self.event(MasterEvent::ExplicitDone {
                    handle,
                    result: Ok(d),
                });
            }
            (Step::App(handle), Response::Error(e)) => self.event(MasterEvent::ExplicitDone {
                handle,
                result: Err(ExplicitFailure::Refused(e)),
            }),
            (Step::KeepAlive, Response::Success { data, .. }) => {
                let _ = self.identity.set_attribute(attr::STATUS, data);
            }
            (Step::KeepAlive, Response::Error(_)) => {}
            // The slave still holds the set for this MAC ID (this master restarted, or its
            // release was lost): release it and allocate again.
            (
                Step::Allocate,
                Response::Error(CipError {
                    general: GeneralStatus::AlreadyInRequestedState,
                    ..
                }),
            ) if connecting => {
                self.release_request();
                self.in_flight = Some((Step::Release, now + self.config.response_timeout));
                return;
            }
            (Step::Release, _) => return self.begin_connect(now),
            (_, Response::Error(error)) if connecting => {
                return self.connect_failed(
                    now,
                    ConnectError::Refused {
                        step: step.name(),
                        error,
                    },
                );
            }
            (Step::Allocate, Response::Success { service, .. }) if service != ALLOCATE => {
                return self.connect_failed(now, ConnectError::Malformed { step: step.name() });
            }
            // Only the 8/8 message body format (0) is spoken here.
            (Step::Allocate, Response::Success { data, .. })
                if data.first().map(|b| b & 0x0F) != Some(0) =>
            {
                return self.connect_failed(
                    now,
                    ConnectError::UnsupportedBodyFormat(data.first().map_or(0xFF, |b| b & 0x0F)),
                );
            }
            (Step::Identity(n), Response::Success { data, .. }) => {
                if let Err(e) = self.identity.set_attribute(n, data) {
                    return self.connect_failed(now, ConnectError::Identity(e));
                }
            }
            (Step::Produced | Step::Consumed, Response::Success { data, .. }) => {
                let Ok(b) = <[u8; 2]>::try_from(data) else {
                    return self.connect_failed(now, ConnectError::Malformed { step: step.name() });
                };
                if step == Step::Produced {
                    self.produced = u16::from_le_bytes(b);
                } else {
                    self.consumed = u16::from_le_bytes(b);
                }
            }
            _ => {}
        }
        if connecting || matches!(step, Step::App(_) | Step::KeepAlive) {
            self.next_step(now, step);
        }
    }

    /// Feeds a received frame.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        if frame.is_remote() {
            return;
        }
        let Some(p) = DnId::of(frame.id()).and_then(Predefined::from_id) else {
            return;
        };
        let data = frame.data();
        match p {
            Predefined::DuplicateMacCheck(m) if m == self.config.mac => {
                let Ok(check) = DuplicateMacCheck::parse(data) else {
                    return;
                };
                match self.state {
                    MasterState::Checking(_) => {
                        self.state = MasterState::Faulted;
                        self.deadline = None;
                        self.tx.clear();
                        self.event(MasterEvent::DuplicateMac(check));
                    }
                    MasterState::Offline | MasterState::Faulted => {}
                    _ if !check.response => self.send_check(true),
                    _ => self.event(MasterEvent::DuplicateMac(check)),
                }
            }
            Predefined::SlaveExplicitResponse(m)
                if m == self.config.slave
                    && matches!(self.state, MasterState::Connecting | MasterState::Connected) =>
            {
                // The header names the master; another master's traffic is not ours.
                if data
                    .first()
                    .is_some_and(|&h| Header::from_u8(h).mac != self.config.mac)
                {
                    return;
                }
                let mut tx = core::mem::take(&mut self.tx);
                let ev = self.link.handle(now, data, &mut tx);
                self.tx = tx;
                if let Some(LinkEvent::Message(m, _)) = ev {
                    self.handle_response(now, &m);
                }
            }
            Predefined::SlavePollResponse(m)
                if m == self.config.slave && self.state == MasterState::Connected =>
            {
                let mut whole = MessageBuf::new();
                if self.produced > 8 && !data.is_empty() {
                    match self
                        .poll_rx
                        .push(FragmentByte::from_u8(data[0]), &data[1..])
                    {
                        Ok(Some(m)) => {
                            let _ = whole.extend_from_slice(m);
                        }
                        _ => return,
                    }
                } else {
                    let _ = whole.extend_from_slice(data);
                }
                self.poll_deadline = Some(now + self.poll_timeout_span());
                self.event(MasterEvent::Input(whole));
            }
            _ => {}
        }
    }

    /// Fires due timers.
    pub fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|t| now >= t) {
            self.deadline = None;
            match self.state {
                MasterState::Checking(1) => {
                    self.state = MasterState::Checking(2);
                    self.send_check(false);
                    self.deadline = Some(now + self.config.dup_mac_wait);
                }
                MasterState::Checking(_) => {
                    self.event(MasterEvent::Online);
                    self.begin_connect(now);
                }
                MasterState::Disconnected => self.begin_connect(now),
                _ => {}
            }
        }
        if self.link.handle_timeout(now) == Some(LinkEvent::SendFailed)
            && let Some((step, _)) = self.in_flight
        {
            self.in_flight = Some((step, now));
        }
        if let Some((step, t)) = self.in_flight
            && now >= t
        {
            self.in_flight = None;
            match (self.state, step) {
                (MasterState::Connecting, _) => {
                    self.connect_failed(now, ConnectError::Timeout { step: step.name() })
                }
                (_, Step::App(handle)) => {
                    self.event(MasterEvent::ExplicitDone {
                        handle,
                        result: Err(ExplicitFailure::Timeout),
                    });
                    self.lost(now);
                }
                _ => self.lost(now),
            }
        }
        if self.state == MasterState::Connected {
            if self.poll_deadline.is_some_and(|t| now >= t) {
                return self.lost(now);
            }
            if self.in_flight.is_none()
                && self.queue.is_empty()
                && now >= self.last_explicit + half(self.config.explicit_rate)
            {
                self.request(
                    now,
                    Step::KeepAlive,
                    Request::GetAttributeSingle(Path::new(CLASS_IDENTITY, 1, attr::STATUS)),
                );
            }
            if self.next_poll.is_some_and(|t| now >= t) {
                self.send_poll();
                let mut next = self.next_poll.unwrap_or(now) + self.config.poll_cycle;
                if next <= now {
                    next = now + self.config.poll_cycle;
                }
                self.next_poll = Some(next);
            }
        }
    }

    fn send_poll(&mut self) {
        let id = Predefined::MasterPollCommand(self.config.slave).can_id();
        let size = self.consumed as usize;
        let mut data = self.output.clone();
        data.truncate(size);
        while data.len() < size && data.push(0).is_ok() {}
        if self.idle {
            data.clear();
        }
        for f in io_frames(&data, size) {
            if let Ok(frame) = CanFrame::new(id, &f) {
                let _ = self.tx.push_back(frame);
            }
        }
    }

    /// The next deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        let keepalive = (self.state == MasterState::Connected && self.in_flight.is_none())
            .then(|| self.last_explicit + half(self.config.explicit_rate));
        [
            self.deadline,
            self.in_flight.map(|(_, t)| t),
            self.link.poll_timeout(),
            self.next_poll,
            self.poll_deadline,
            keepalive,
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// The next frame to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.tx.pop_front()
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<MasterEvent> {
        self.events.pop_front()
    }
}

fn half(d: Duration) -> Duration {
    Duration::from_micros(d.as_micros() / 2)
}
