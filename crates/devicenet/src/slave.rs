//! A group 2 only slave of the Predefined Master/Slave Connection Set (DeviceNet volume 3),
//! sans-IO: feed [`Slave::handle_frame`] and [`Slave::handle_timeout`], drain
//! [`Slave::poll_transmit`] and [`Slave::poll_event`], call back at [`Slave::poll_timeout`].
//!
//! States:
//! - Network access: the Duplicate MAC ID check (two requests one [`SlaveConfig::dup_mac_wait`]
//!   apart; any check message for its MAC meanwhile is a duplicate: [`NetworkState::Faulted`],
//!   silent for good), then [`NetworkState::Online`], where it answers other stations' checks of
//!   its MAC with a response.
//! - Connections (Connection object instances 1 explicit and 2 polled I/O): non-existent until
//!   allocated; the explicit connection is established at once, the poll connection is
//!   configuring until its expected packet rate (attribute 9) is set, then established. Each
//!   times out after 4 × its expected packet rate without a message (0 = never): the explicit
//!   connection is then deleted, the poll connection goes to timed out (its watchdog action;
//!   [`Application::connection_timed_out`] is told) and polls are ignored until the rate is set
//!   again or the set is released and allocated anew. Once neither connection is in use the
//!   allocation ends and any master may allocate.
//! - A zero-length poll command is the master's idle indication ([`Application::idle`]); the
//!   slave still answers it.
//!
//! Served objects: Identity (class 1 instance 1, attributes 1..=7, read only), DeviceNet
//! (class 3 instance 1: 1 MAC ID, 2 baud rate, 5 allocation information; read only) and
//! Connection (class 5 instances 1 and 2: 1 state, 2 instance type, 7 produced and 8 consumed
//! connection size, 9 expected packet rate (settable), 12 watchdog timeout action). Any other
//! class goes to the [`Application`].
//!
//! Error codes where the specification leaves a choice (this slave's policy): allocation by a
//! second master is `ObjectStateConflict` with additional code 0x01; a connection type it does
//! not offer (bit-strobe, multicast, COS/cyclic) `ResourceUnavailable` 0x02; allocating what is
//! already allocated or releasing what is not `AlreadyInRequestedState`.

use canola_frame::{CanFrame, CanId, Duration, Instant};
use heapless::Deque;

use crate::explicit::{
    ALLOCATE, AllocationChoice, CLASS_CONNECTION, CLASS_DEVICENET, CLASS_IDENTITY,
    GET_ATTRIBUTE_SINGLE, Path, RELEASE, Request, Response, SET_ATTRIBUTE_SINGLE,
};
use crate::fragment::{MessageBuf, Reassembler, io_frames};
use crate::id::{MacId, Predefined};
use crate::identity::{DuplicateMacCheck, Identity};
use crate::link::{Link, LinkEvent, TX_LEN};
use crate::status::{CipError, GeneralStatus};

/// What the slave's device does with I/O data and with attributes outside the objects the slave
/// serves itself.
pub trait Application {
    /// The data of a (reassembled) poll command of the consumed size.
    fn consume(&mut self, now: Instant, data: &[u8]);
    /// The data of the poll response (truncated or zero-padded to the produced size).
    fn produce(&mut self, now: Instant, out: &mut MessageBuf);
    /// A zero-length poll command: the master is idle.
    fn idle(&mut self, _now: Instant) {}
    /// The poll connection timed out (the master is gone): go to the safe state.
    fn connection_timed_out(&mut self, _now: Instant) {}
    /// Get_Attribute_Single of another class.
    fn get_attribute(
        &mut self,
        _now: Instant,
        _path: Path,
        _out: &mut MessageBuf,
    ) -> Result<(), CipError> {
        Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
    }
    /// Set_Attribute_Single of another class.
    fn set_attribute(&mut self, _now: Instant, _path: Path, _data: &[u8]) -> Result<(), CipError> {
        Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
    }
    /// The application's own next deadline.
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
    /// Called when `poll_timeout` has passed.
    fn handle_timeout(&mut self, _now: Instant) {}
}

/// Slave settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Own MAC ID.
    pub mac: MacId,
    /// Identity object (vendor ID and serial number also go into the Duplicate MAC ID check).
    pub identity: Identity,
    /// Poll response size in bytes.
    pub produced_size: u16,
    /// Poll command size in bytes.
    pub consumed_size: u16,
    /// Baud rate code of the DeviceNet object (0 = 125, 1 = 250, 2 = 500 kbit/s).
    pub baud_rate: u8,
    /// Wait after each Duplicate MAC ID request (1 s in the specification).
    pub dup_mac_wait: Duration,
}

/// Network access state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NetworkState {
    /// Not started.
    Offline,
    /// Duplicate MAC ID check, request 1 or 2 sent.
    Checking(u8),
    /// On line.
    Online,
    /// A duplicate MAC ID was found.
    Faulted,
}

/// Connection object state (attribute 1 values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConnectionState {
    /// 0: not allocated.
    NonExistent,
    /// 1: allocated, expected packet rate not yet set.
    Configuring,
    /// 3: established.
    Established,
    /// 4: timed out.
    TimedOut,
}

impl ConnectionState {
    /// Attribute 1's value.
    pub const fn to_u8(self) -> u8 {
        match self {
            ConnectionState::NonExistent => 0,
            ConnectionState::Configuring => 1,
            ConnectionState::Established => 3,
            ConnectionState::TimedOut => 4,
        }
    }
}

/// Which predefined connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Connection {
    /// Instance 1.
    Explicit,
    /// Instance 2.
    Polled,
}

/// What the slave reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SlaveEvent {
    /// The Duplicate MAC ID check passed.
    Online,
    /// Another station uses this MAC ID (during the check: the slave is faulted).
    DuplicateMac(DuplicateMacCheck),
    /// A master allocated connections.
    Allocated {
        /// The master.
        master: MacId,
        /// What it allocated.
        choice: AllocationChoice,
    },
    /// Connections were released.
    Released(AllocationChoice),
    /// A connection's state changed.
    Connection(Connection, ConnectionState),
    /// A poll command of the wrong size was ignored.
    PollSizeMismatch {
        /// Bytes received.
        actual: usize,
        /// The consumed size.
        expected: u16,
    },
}

#[derive(Debug, Clone, Copy)]
struct Conn {
    state: ConnectionState,
    epr_ms: u16,
    deadline: Option<Instant>,
}

impl Conn {
    const NONE: Conn = Conn {
        state: ConnectionState::NonExistent,
        epr_ms: 0,
        deadline: None,
    };
    fn kick(&mut self, now: Instant) {
        self.deadline =
            (self.epr_ms != 0).then(|| now + Duration::from_millis(4 * self.epr_ms as u64));
    }
}

/// Default expected packet rate of the explicit connection after allocation (ms).
pub const EXPLICIT_DEFAULT_EPR_MS: u16 = 2500;

/// The slave machine around an [`Application`].
#[derive(Debug)]
pub struct Slave<A> {
    config: SlaveConfig,
    app: A,
    network: NetworkState,
    check_deadline: Option<Instant>,
    master: Option<MacId>,
    explicit: Conn,
    polled: Conn,
    link: Link,
    poll_rx: Reassembler,
    tx: Deque<CanFrame, TX_LEN>,
    events: Deque<SlaveEvent, 16>,
}

impl<A: Application> Slave<A> {
    /// A slave, offline until [`Slave::start`].
    pub fn new(config: SlaveConfig, app: A) -> Self {
        let link = Link::new(
            Predefined::SlaveExplicitResponse(config.mac).can_id(),
            MacId::from_bits(0),
            Duration::from_millis(1000),
        );
        Self {
            config,
            app,
            network: NetworkState::Offline,
            check_deadline: None,
            master: None,
            explicit: Conn::NONE,
            polled: Conn::NONE,
            link,
            poll_rx: Reassembler::new(),
            tx: Deque::new(),
            events: Deque::new(),
        }
    }

    /// Starts the Duplicate MAC ID check.
    pub fn start(&mut self, now: Instant) {
        self.network = NetworkState::Checking(1);
        self.send_check(false);
        self.check_deadline = Some(now + self.config.dup_mac_wait);
    }

    /// The application.
    pub fn app(&self) -> &A {
        &self.app
    }
    /// The application, mutable.
    pub fn app_mut(&mut self) -> &mut A {
        &mut self.app
    }
    /// Network access state.
    pub fn network_state(&self) -> NetworkState {
        self.network
    }
    /// A connection's state.
    pub fn connection_state(&self, c: Connection) -> ConnectionState {
        match c {
            Connection::Explicit => self.explicit.state,
            Connection::Polled => self.polled.state,
        }
    }
    /// The allocating master.
    pub fn master(&self) -> Option<MacId> {
        self.master
    }
    /// The configuration.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    fn event(&mut self, e: SlaveEvent) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    fn send_check(&mut self, response: bool) {
        let m = DuplicateMacCheck {
            response,
            port: 0,
            vendor_id: self.config.identity.vendor_id,
            serial_number: self.config.identity.serial_number,
        };
        if let Ok(f) = CanFrame::new(
            Predefined::DuplicateMacCheck(self.config.mac).can_id(),
            &m.emit(),
        ) {
            let _ = self.tx.push_back(f);
        }
    }

    /// Feeds a received frame.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        if frame.is_remote() {
            return;
        }
        let Some(id) = crate::id::DnId::of(frame.id()) else {
            return;
        };
        let Some(p) = Predefined::from_id(id) else {
            return;
        };
        let me = self.config.mac;
        let data = frame.data();
        match p {
            Predefined::DuplicateMacCheck(m) if m == me => {
                let Ok(check) = DuplicateMacCheck::parse(data) else {
                    return;
                };
                match self.network {
                    NetworkState::Checking(_) => {
                        self.network = NetworkState::Faulted;
                        self.check_deadline = None;
                        self.tx.clear();
                        self.event(SlaveEvent::DuplicateMac(check));
                    }
                    NetworkState::Online if !check.response => self.send_check(true),
                    NetworkState::Online => self.event(SlaveEvent::DuplicateMac(check)),
                    _ => {}
                }
            }
            _ if self.network != NetworkState::Online => {}
            Predefined::UnconnectedRequest(m) if m == me => {
                if let Ok(crate::explicit::ExplicitFrame::Whole { header, message }) =
                    crate::explicit::ExplicitFrame::parse(data)
                {
                    let mut msg = MessageBuf::new();
                    if msg.extend_from_slice(message).is_ok() {
                        self.unconnected(now, header.mac, header.xid, &msg);
                    }
                }
            }
            Predefined::MasterExplicitRequest(m)
                if m == me && self.explicit.state == ConnectionState::Established =>
            {
                self.explicit.kick(now);
                let mut tx = core::mem::take(&mut self.tx);
                let ev = self.link.handle(now, data, &mut tx);
                self.tx = tx;
                if let Some(LinkEvent::Message(msg, xid)) = ev {
                    let mut out = MessageBuf::new();
                    self.serve(now, &msg, &mut out);
                    let mut tx = core::mem::take(&mut self.tx);
                    self.link.send(now, &out, xid, &mut tx);
                    self.tx = tx;
                }
            }
            Predefined::MasterPollCommand(m) if m == me => self.poll(now, data),
            _ => {}
        }
    }

    fn poll(&mut self, now: Instant, data: &[u8]) {
        if self.polled.state != ConnectionState::Established {
            return;
        }
        let consumed = self.config.consumed_size;
        let mut whole = MessageBuf::new();
        if data.is_empty() {
            self.poll_rx.reset();
            self.polled.kick(now);
            self.app.idle(now);
        } else {
            if consumed > 8 {
                let (fb, rest) = (crate::fragment::FragmentByte::from_u8(data[0]), &data[1..]);
                match self.poll_rx.push(fb, rest) {
                    Ok(Some(m)) => {
                        let _ = whole.extend_from_slice(m);
                    }
                    _ => return,
                }
            } else {
                let _ = whole.extend_from_slice(data);
            }
            if whole.len() != consumed as usize {
                self.event(SlaveEvent::PollSizeMismatch {
                    actual: whole.len(),
                    expected: consumed,
                });
                return;
            }
            self.polled.kick(now);
            self.app.consume(now, &whole);
        }
        let mut out = MessageBuf::new();
        self.app.produce(now, &mut out);
        let size = self.config.produced_size as usize;
        out.truncate(size);
        while out.len() < size && out.push(0).is_ok() {}
        let id = Predefined::SlavePollResponse(self.config.mac).can_id();
        for f in io_frames(&out, size) {
            if let Ok(frame) = CanFrame::new(id, &f) {
                let _ = self.tx.push_back(frame);
            }
        }
    }

    fn respond_unconnected(&mut self, master: MacId, xid: bool, r: Response<'_>) {
        let mut out = MessageBuf::new();
        if r.emit(&mut out).is_err() {
            return;
        }
        let h = crate::explicit::Header {
            fragmented: false,
            xid,
            mac: master,
        };
        let f = crate::explicit::ExplicitFrame::Whole {
            header: h,
            message: &out,
        };
        if let Some(bytes) = f.emit()
            && let Ok(frame) = CanFrame::new(
                Predefined::SlaveExplicitResponse(self.config.mac).can_id(),
                &bytes,
            )
        {
            let _ = self.tx.push_back(frame);
        }
    }

    fn unconnected(&mut self, now: Instant, from: MacId, xid: bool, msg: &[u8]) {
        let r = match Request::parse(msg) {
            Ok(Request::Allocate { .. } | Request::Release { .. }) => {
                let mut out = MessageBuf::new();
                self.serve(now, msg, &mut out);
                let mut copy = MessageBuf::new();
                let _ = copy.extend_from_slice(&out);
                match Response::parse(&copy) {
                    Ok(r) => {
                        self.respond_unconnected(from, xid, r);
                        return;
                    }
                    Err(_) => return,
                }
            }
            _ => Response::Error(CipError::new(GeneralStatus::ServiceNotSupported)),
        };
        self.respond_unconnected(from, xid, r);
    }

    fn allocate(
        &mut self,
        now: Instant,
        class: u8,
        instance: u8,
        choice: AllocationChoice,
        allocator: MacId,
    ) -> Result<(), CipError> {
        if class != CLASS_DEVICENET || instance != 1 {
            return Err(CipError::new(GeneralStatus::PathDestinationUnknown));
        }
        if let Some(m) = self.master
            && m != allocator
        {
            return Err(CipError {
                general: GeneralStatus::ObjectStateConflict,
                additional: 0x01,
            });
        }
        let offered = AllocationChoice::EXPLICIT.union(AllocationChoice::POLLED);
        if choice.0 & !offered.0 != 0 || choice.0 == 0 {
            return Err(CipError {
                general: GeneralStatus::ResourceUnavailable,
                additional: 0x02,
            });
        }
        let e = choice.contains(AllocationChoice::EXPLICIT);
        let p = choice.contains(AllocationChoice::POLLED);
        if (e && self.explicit.state != ConnectionState::NonExistent)
            || (p && self.polled.state != ConnectionState::NonExistent)
        {
            return Err(CipError::new(GeneralStatus::AlreadyInRequestedState));
        }
        self.master = Some(allocator);
        self.link = Link::new(
            Predefined::SlaveExplicitResponse(self.config.mac).can_id(),
            allocator,
            self.link.ack_timeout,
        );
        if e {
            self.explicit = Conn {
                state: ConnectionState::Established,
                epr_ms: EXPLICIT_DEFAULT_EPR_MS,
                deadline: None,
            };
            self.explicit.kick(now);
            self.event(SlaveEvent::Connection(
                Connection::Explicit,
                ConnectionState::Established,
            ));
        }
        if p {
            self.polled = Conn {
                state: ConnectionState::Configuring,
                epr_ms: 0,
                deadline: None,
            };
            self.poll_rx.reset();
            self.event(SlaveEvent::Connection(
                Connection::Polled,
                ConnectionState::Configuring,
            ));
        }
        self.event(SlaveEvent::Allocated {
            master: allocator,
            choice,
        });
        Ok(())
    }

    fn release(&mut self, choice: AllocationChoice) -> Result<(), CipError> {
        let e = choice.contains(AllocationChoice::EXPLICIT);
        let p = choice.contains(AllocationChoice::POLLED);
        let offered = AllocationChoice::EXPLICIT.union(AllocationChoice::POLLED);
        if choice.0 & !offered.0 != 0 {
            return Err(CipError {
                general: GeneralStatus::ResourceUnavailable,
                additional: 0x02,
            });
        }
        if (e && self.explicit.state == ConnectionState::NonExistent)
            || (p && self.polled.state == ConnectionState::NonExistent)
        {
            return Err(CipError::new(GeneralStatus::AlreadyInRequestedState));
        }
        if e {
            self.explicit = Conn::NONE;
            self.link.reset();
        }
        if p {
            self.polled = Conn::NONE;
        }
        self.event(SlaveEvent::Released(choice));
        self.end_allocation_if_unused();
        Ok(())
    }

    fn end_allocation_if_unused(&mut self) {
        let unused = |s| matches!(s, ConnectionState::NonExistent | ConnectionState::TimedOut);
        if self.explicit.state == ConnectionState::NonExistent && unused(self.polled.state) {
            self.master = None;
            self.polled = Conn::NONE;
        }
    }

    /// Performs one explicit request and writes the response message into `out`.
    fn serve(&mut self, now: Instant, msg: &[u8], out: &mut MessageBuf) {
        let mut data = MessageBuf::new();
        let result: Result<u8, CipError> = match Request::parse(msg) {
            Err(_) => Err(CipError::new(GeneralStatus::NotEnoughData)),
            Ok(Request::Allocate {
                class,
                instance,
                choice,
                allocator,
            }) => self
                .allocate(now, class, instance, choice, allocator)
                .map(|()| {
                    // Message body format 0: 8-bit class, 8-bit instance.
                    let _ = data.push(0);
                    ALLOCATE
                }),
            Ok(Request::Release { choice, .. }) => self.release(choice).map(|()| RELEASE),
            Ok(Request::GetAttributeSingle(path)) => self
                .get(now, path, &mut data)
                .map(|()| GET_ATTRIBUTE_SINGLE),
            Ok(Request::SetAttributeSingle(path, value)) => {
                let mut v = MessageBuf::new();
                let _ = v.extend_from_slice(value);
                self.set(now, path, &v, &mut data)
                    .map(|()| SET_ATTRIBUTE_SINGLE)
            }
            Ok(Request::Other { .. }) => Err(CipError::new(GeneralStatus::ServiceNotSupported)),
        };
        let r = match &result {
            Ok(service) => Response::Success {
                service: *service,
                data: &data,
            },
            Err(e) => Response::Error(*e),
        };
        let _ = r.emit(out);
    }

    fn conn(&self, instance: u8) -> Result<(Connection, Conn), CipError> {
        let c = match instance {
            1 => (Connection::Explicit, self.explicit),
            2 => (Connection::Polled, self.polled),
            _ => return Err(CipError::new(GeneralStatus::ObjectDoesNotExist)),
        };
        if c.1.state == ConnectionState::NonExistent {
            return Err(CipError::new(GeneralStatus::ObjectDoesNotExist));
        }
        Ok(c)
    }

    fn get(&mut self, now: Instant, path: Path, out: &mut MessageBuf) -> Result<(), CipError> {
        let unsupported = || CipError::new(GeneralStatus::AttributeNotSupported);
        let put = |out: &mut MessageBuf, b: &[u8]| {
            out.extend_from_slice(b)
                .map_err(|_| CipError::new(GeneralStatus::ReplyDataTooLarge))
        };
        match (path.class, path.instance) {
            (CLASS_IDENTITY, 1) => {
                let v = self
                    .config
                    .identity
                    .attribute(path.attribute)
                    .ok_or_else(unsupported)?;
                put(out, &v)
            }
            (CLASS_DEVICENET, 1) => match path.attribute {
                1 => put(out, &[self.config.mac.get()]),
                2 => put(out, &[self.config.baud_rate]),
                5 => {
                    let choice = (self.explicit.state != ConnectionState::NonExistent) as u8
                        | ((self.polled.state != ConnectionState::NonExistent) as u8) << 1;
                    put(out, &[choice, self.master.map_or(0xFF, MacId::get)])
                }
                _ => Err(unsupported()),
            },
            (CLASS_CONNECTION, i) => {
                let (kind, c) = self.conn(i)?;
                match path.attribute {
                    1 => put(out, &[c.state.to_u8()]),
                    2 => put(out, &[(kind == Connection::Polled) as u8]),
                    7 | 8 => {
                        let size = match (kind, path.attribute) {
                            (Connection::Explicit, _) => crate::fragment::MAX_MESSAGE as u16,
                            (Connection::Polled, 7) => self.config.produced_size,
                            (Connection::Polled, _) => self.config.consumed_size,
                        };
                        put(out, &size.to_le_bytes())
                    }
                    9 => put(out, &c.epr_ms.to_le_bytes()),
                    // Watchdog timeout action: 0 transition to timed out, 1 auto delete.
                    12 => put(out, &[(kind == Connection::Explicit) as u8]),
                    _ => Err(unsupported()),
                }
            }
            (CLASS_IDENTITY | CLASS_DEVICENET, _) => {
                Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
            }
            _ => self.app.get_attribute(now, path, out),
        }
    }

    fn set(
        &mut self,
        now: Instant,
        path: Path,
        value: &[u8],
        out: &mut MessageBuf,
    ) -> Result<(), CipError> {
        match (path.class, path.instance) {
            (CLASS_CONNECTION, i) => {
                let (kind, _) = self.conn(i)?;
                if path.attribute != 9 {
                    return Err(CipError::new(GeneralStatus::AttributeNotSettable));
                }
                let v: [u8; 2] = value.try_into().map_err(|_| {
                    CipError::new(if value.len() < 2 {
                        GeneralStatus::NotEnoughData
                    } else {
                        GeneralStatus::TooMuchData
                    })
                })?;
                let epr = u16::from_le_bytes(v);
                let c = match kind {
                    Connection::Explicit => &mut self.explicit,
                    Connection::Polled => &mut self.polled,
                };
                c.epr_ms = epr;
                c.kick(now);
                let changed = c.state != ConnectionState::Established;
                c.state = ConnectionState::Established;
                if changed {
                    self.event(SlaveEvent::Connection(kind, ConnectionState::Established));
                }
                // The response carries the rate actually used (this slave keeps it as asked).
                let _ = out.extend_from_slice(&v);
                Ok(())
            }
            (CLASS_IDENTITY, 1) if (1..=7).contains(&path.attribute) => {
                Err(CipError::new(GeneralStatus::AttributeNotSettable))
            }
            (CLASS_DEVICENET, 1) if matches!(path.attribute, 1 | 2 | 5) => {
                Err(CipError::new(GeneralStatus::AttributeNotSettable))
            }
            (CLASS_IDENTITY | CLASS_DEVICENET, 1) => {
                Err(CipError::new(GeneralStatus::AttributeNotSupported))
            }
            (CLASS_IDENTITY | CLASS_DEVICENET, _) => {
                Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
            }
            _ => self.app.set_attribute(now, path, value),
        }
    }

    /// Fires due timers.
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(t) = self.check_deadline
            && now >= t
        {
            match self.network {
                NetworkState::Checking(1) => {
                    self.network = NetworkState::Checking(2);
                    self.send_check(false);
                    self.check_deadline = Some(now + self.config.dup_mac_wait);
                }
                NetworkState::Checking(_) => {
                    self.network = NetworkState::Online;
                    self.check_deadline = None;
                    self.event(SlaveEvent::Online);
                }
                _ => self.check_deadline = None,
            }
        }
        if self.explicit.deadline.is_some_and(|t| now >= t) {
            self.explicit = Conn::NONE;
            self.link.reset();
            self.event(SlaveEvent::Connection(
                Connection::Explicit,
                ConnectionState::NonExistent,
            ));
            self.end_allocation_if_unused();
        }
        if self.polled.deadline.is_some_and(|t| now >= t) {
            self.polled.state = ConnectionState::TimedOut;
            self.polled.deadline = None;
            self.poll_rx.reset();
            self.app.connection_timed_out(now);
            self.event(SlaveEvent::Connection(
                Connection::Polled,
                ConnectionState::TimedOut,
            ));
            self.end_allocation_if_unused();
        }
        let _ = self.link.handle_timeout(now);
        if self.app.poll_timeout().is_some_and(|t| now >= t) {
            self.app.handle_timeout(now);
        }
    }

    /// The next deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        [
            self.check_deadline,
            self.explicit.deadline,
            self.polled.deadline,
            self.link.poll_timeout(),
            self.app.poll_timeout(),
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
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop_front()
    }
}

/// The identifier the slave's poll responses use (for tests and tools).
pub fn poll_response_id(mac: MacId) -> CanId {
    Predefined::SlavePollResponse(mac).can_id()
}
