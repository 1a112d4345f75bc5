//! The USDO client side of the master (CANopen FD, CiA 1301): the master's one
//! [`UsdoClient`] (from `canola-sdo`) serving every node marked CAN FD, USDO requests in the
//! same request table as SDO requests, and the CAN FD frames it sends and receives.
//!
//! * The client sends on 0x600 + the master's own node-ID ([`Core::set_usdo_node_id`], default
//!   [`DEFAULT_USDO_NODE_ID`]) with the destination node in the frame; servers answer on 0x580 +
//!   their node-ID with the master as destination (the layout `canola-sdo` documents in
//!   `usdo::assumed`). Responses arrive as [`BusEvent::FdFrame`](crate::BusEvent::FdFrame)s.
//! * Up to `MAX_SESSIONS` transfers run at once (one session each, across nodes); more wait in
//!   a queue in submission order.
//! * A request for a node that is not marked CAN FD, or on a bus that carries classic frames
//!   only, ends at once with an error that says so: nothing goes on the bus.
//! * The node's CAN FD mark comes from its dictionary ([`eds_marks_fd`]) or from the
//!   application.

use std::collections::VecDeque;

use canola_frame::{Duration, FdFrame, Instant, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary};
use canola_sdo::Multiplexer;
use canola_sdo::usdo::{DataType, UsdoClient, UsdoClientConfig, UsdoEvent};

use super::Core;
use super::events::{Completion, RequestId};
use super::sdo::{DownSource, OutFrame, Outgoing, ReqState, UpSink, UsdoOp, UsdoRequest};
use crate::error::{FdRefusal, SdoError, SdoErrorKind};

/// The master's own node-ID as a USDO client unless the application sets another: the
/// highest node-ID, which devices are least often given.
pub const DEFAULT_USDO_NODE_ID: u8 = 127;

/// The `[DeviceInfo]` key that marks a CANopen FD device in an EDS or DCF, read
/// case-insensitively with the value `1`. No public source establishes such a key (CiA 306 v1.3
/// predates CAN FD, and no EDS found carries one), so this one is the stack's own, kept in one
/// place: `CANopenFD=1`.
pub const EDS_FD_KEY: &str = "CANopenFD";

/// Whether a dictionary marks its device as CANopen FD ([`EDS_FD_KEY`]).
pub fn eds_marks_fd(od: &ObjectDictionary) -> bool {
    od.device_info
        .extra
        .iter()
        .any(|(k, v)| k.eq_ignore_ascii_case(EDS_FD_KEY) && v.trim() == "1")
}

/// Why `transport` carries no CAN FD frames (its `FdNotSupported` bus text), `None` when it
/// does.
pub(crate) fn classic_bus(transport: &dyn crate::Transport) -> Option<String> {
    match transport.fd_support() {
        Ok(()) => None,
        Err(crate::TransportError::FdNotSupported { bus }) => Some(bus),
        Err(e) => Some(e.to_string()),
    }
}

/// The master's USDO client with its bookkeeping.
pub(super) struct UsdoState {
    /// Created at the first request (with the node-ID and timeout then set).
    client: Option<UsdoClient<UpSink, DownSource>>,
    node_id: NodeId,
    timeout: Duration,
    /// Running transfers: server, session-ID, request.
    running: Vec<(NodeId, u8, RequestId)>,
    /// Requests waiting for a free session.
    queue: VecDeque<RequestId>,
    /// Why the bus carries no CAN FD frames (`None`: it does).
    classic_bus: Option<String>,
}

impl UsdoState {
    pub(super) fn new() -> Self {
        Self {
            client: None,
            node_id: NodeId::new(DEFAULT_USDO_NODE_ID).unwrap_or(NodeId::MAX),
            timeout: Duration::from_millis(canola_sdo::usdo::assumed::DEFAULT_TIMEOUT_MS),
            running: Vec::new(),
            queue: VecDeque::new(),
            classic_bus: None,
        }
    }

    fn client(&mut self) -> &mut UsdoClient<UpSink, DownSource> {
        let (node, timeout) = (self.node_id, self.timeout);
        self.client
            .get_or_insert_with(|| UsdoClient::new(node, UsdoClientConfig { timeout }))
    }

    pub(super) fn poll_timeout(&self) -> Option<Instant> {
        self.client.as_ref().and_then(|c| c.poll_timeout())
    }
}

impl Core {
    /// Sets the master's own node-ID as a USDO client (its CAN-ID is 0x600 + it). Takes effect
    /// when no USDO transfer runs; returns whether it did.
    pub(crate) fn set_usdo_node_id(&mut self, node: NodeId) -> bool {
        if !self.usdo.running.is_empty() || !self.usdo.queue.is_empty() {
            return false;
        }
        self.usdo.node_id = node;
        self.usdo.client = None;
        true
    }

    /// The master's own node-ID as a USDO client.
    pub(crate) fn usdo_node_id(&self) -> NodeId {
        self.usdo.node_id
    }

    /// Sets the USDO response timeout (for transfers started from now on, once none runs).
    pub(crate) fn set_usdo_timeout(&mut self, timeout: Duration) {
        self.usdo.timeout = timeout;
        if self.usdo.running.is_empty() {
            self.usdo.client = None;
        }
    }

    /// Tells the core whether the bus carries CAN FD: `None` when it does, else why not (the
    /// transport's [`FdNotSupported`](crate::TransportError::FdNotSupported) bus text).
    pub(crate) fn set_classic_bus(&mut self, why: Option<String>) {
        self.usdo.classic_bus = why;
    }

    /// Why the bus carries no CAN FD frames, if it does not.
    pub(crate) fn classic_bus(&self) -> Option<&str> {
        self.usdo.classic_bus.as_deref()
    }

    /// Marks `node` as a CANopen FD device (or not).
    pub(crate) fn set_node_fd(&mut self, node: NodeId, fd: bool) {
        if !self.nodes.contains_key(&node) {
            self.add_node(node, None);
        }
        if let Some(slot) = self.nodes.get_mut(&node) {
            slot.fd = Some(fd);
        }
    }

    /// Whether `node` is marked CANopen FD: by the application, else by its dictionary.
    pub(crate) fn node_fd(&self, node: NodeId) -> bool {
        self.nodes.get(&node).is_some_and(|s| {
            s.fd.unwrap_or_else(|| s.od.as_deref().is_some_and(eds_marks_fd))
        })
    }

    /// Queues a raw CAN FD frame.
    pub(crate) fn send_raw_fd(&mut self, frame: FdFrame) {
        self.tx.push_back(Outgoing {
            frame: OutFrame::Fd(Box::new(frame)),
            transfer: None,
        });
    }

    /// Queues a USDO request; it starts when a session is free.
    pub(super) fn submit_usdo(&mut self, id: RequestId, req: UsdoRequest) {
        let (node, entry) = (req.node, req.entry);
        let refuse = |kind| {
            ReqState::Done(Err(Box::new(SdoError {
                node,
                entry,
                name: None,
                kind,
            })))
        };
        if let Some(bus) = &self.usdo.classic_bus {
            let state = refuse(SdoErrorKind::FdNotSupported(FdRefusal::ClassicBus {
                bus: bus.clone(),
            }));
            self.requests.push(id, state);
            return;
        }
        if !self.node_fd(node) {
            let state = refuse(SdoErrorKind::FdNotSupported(FdRefusal::NodeNotFd));
            self.requests.push(id, state);
            return;
        }
        self.requests.push(id, ReqState::QueuedUsdo(req));
        self.usdo.queue.push_back(id);
        self.pump_usdo();
    }

    /// Starts waiting requests while sessions are free, sends what the client has, completes
    /// finished transfers.
    pub(super) fn pump_usdo(&mut self) {
        let now = self.now;
        loop {
            // Finished transfers first: they free sessions.
            while let Some(ev) = self.usdo.client.as_mut().and_then(|c| c.poll_event()) {
                self.usdo_finished(ev);
            }
            let Some(client) = self.usdo.client.as_mut() else {
                if self.usdo.queue.is_empty() {
                    return;
                }
                self.usdo.client();
                continue;
            };
            while let Some(f) = client.poll_transmit_frame() {
                self.tx.push_back(Outgoing {
                    frame: OutFrame::Fd(Box::new(f)),
                    transfer: None,
                });
            }
            if self.usdo.running.len() >= canola_sdo::usdo::MAX_SESSIONS {
                return;
            }
            let Some(next) = self.usdo.queue.pop_front() else {
                return;
            };
            let Some(slot) = self.requests.get_mut(&next) else {
                continue;
            };
            let req = match core::mem::replace(slot, ReqState::Done(Ok(Completion::default()))) {
                ReqState::QueuedUsdo(req) => req,
                other => {
                    *slot = other;
                    continue;
                }
            };
            let UsdoRequest { node, entry, op } = req;
            let mux = Multiplexer::new(entry.index, entry.sub_index);
            let client = self.usdo.client();
            let started = match op {
                UsdoOp::Upload(sink) => client.start_upload(now, node, mux, sink).ok(),
                UsdoOp::Download(src, t) => {
                    client.start_download(now, node, mux, DataType(t), src).ok()
                }
            };
            let state = match started {
                Some(session) => {
                    self.usdo.running.push((node, session, next));
                    ReqState::UsdoActive {
                        node,
                        entry,
                        session,
                    }
                }
                None => ReqState::Done(Err(Box::new(SdoError {
                    node,
                    entry,
                    name: None,
                    kind: SdoErrorKind::Busy,
                }))),
            };
            if let Some(slot) = self.requests.get_mut(&next) {
                *slot = state;
            }
        }
    }

    /// A transfer's end: its request's result (a cancelled request is no longer in the table).
    fn usdo_finished(&mut self, ev: UsdoEvent<UpSink, DownSource>) {
        let (server, session, result) = match ev {
            UsdoEvent::Uploaded {
                server,
                session,
                sink,
                ..
            } => {
                let data = match sink {
                    UpSink::Mem(v) => v,
                    UpSink::Stream { .. } => Vec::new(),
                };
                let r = Ok(Completion {
                    transferred: data.len() as u64,
                    data,
                    unsized_expedited: false,
                });
                (server, session, r)
            }
            UsdoEvent::Downloaded {
                server,
                session,
                source,
                ..
            } => (
                server,
                session,
                Ok(Completion {
                    data: Vec::new(),
                    transferred: source.0.len() as u64,
                    unsized_expedited: false,
                }),
            ),
            UsdoEvent::Failed { error, .. } => (
                error.server,
                error.session,
                Err(SdoErrorKind::Usdo(error.kind)),
            ),
        };
        let Some(pos) = self
            .usdo
            .running
            .iter()
            .position(|(n, s, _)| n.get() == server && *s == session)
        else {
            return;
        };
        let (node, _, id) = self.usdo.running.swap_remove(pos);
        if let Some(state) = self.requests.get_mut(&id)
            && let ReqState::UsdoActive { entry, .. } = state
        {
            let entry = *entry;
            *state = ReqState::Done(result.map_err(|kind| {
                Box::new(SdoError {
                    node,
                    entry,
                    name: None,
                    kind,
                })
            }));
        }
    }

    /// Cancels a running USDO transfer (an abort goes to the server).
    pub(super) fn cancel_usdo(&mut self, node: NodeId, session: u8) {
        if let Some(c) = self.usdo.client.as_mut() {
            c.abort(node, session);
        }
        self.pump_usdo();
    }

    /// Drops a waiting USDO request.
    pub(super) fn unqueue_usdo(&mut self, id: RequestId) {
        self.usdo.queue.retain(|q| *q != id);
    }

    /// A CAN FD frame from the bus: a USDO response for the master's client, if it is one,
    /// else a PDO.
    pub(super) fn handle_fd_frame(&mut self, now: Instant, frame: &FdFrame) {
        self.set_now(now);
        if let Some(client) = self.usdo.client.as_mut()
            && client.handle_frame(now, frame)
        {
            self.pump_usdo();
            return;
        }
        self.handle_fd_pdo(now, frame);
    }

    /// Fires the USDO client's response timeout.
    pub(super) fn usdo_timeout(&mut self, now: Instant) {
        if let Some(c) = self.usdo.client.as_mut()
            && canola_frame::is_due(c.poll_timeout(), now)
        {
            c.handle_timeout(now);
            self.pump_usdo();
        }
    }
}

/// The data type byte a USDO download announces for `entry` of a node with dictionary `od`:
/// the object's CiA 301 type code, DOMAIN when unknown.
pub(crate) fn data_type_of(od: Option<&ObjectDictionary>, entry: ObjectAddress) -> u8 {
    od.and_then(|od| od.sub(entry.index, entry.sub_index))
        .and_then(|s| u8::try_from(s.data_type.code()).ok())
        .unwrap_or(DataType::DOMAIN.0)
}
