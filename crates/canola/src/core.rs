//! The sans-IO heart of the master: every per-node protocol machine, the COB-ID router and the
//! request table, with no I/O and no clock.
//!
//! [`Network`](crate::Network) wraps one `Core` in a mutex and drives it from a transport
//! (STYLE habit 8: the blocking and async APIs are loops around this one core). The core follows
//! the sans-IO call order of the protocol crates: [`Core::handle_frame`] for every received frame,
//! [`Core::handle_timeout`] when [`Core::poll_timeout`] has passed, then drain
//! [`Core::take_transmit`].
//!
//! Routing (CiA 301 predefined connection set, §7.3.5):
//! * 0x581..=0x5FF SDO responses → the node's SDO client (`canola-sdo`);
//! * 0x701..=0x77F error control → the heartbeat consumer (`canola-nmt`);
//! * 0x081..=0x0FF EMCY → the EMCY consumer (`canola-nmt`);
//! * TPDO1..4 → PDO events; a TPDO the node was configured to send on another COB-ID
//!   (learnt from reading or saving its PDO parameters) is routed by that COB-ID;
//! * 0x7E4 LSS responses → LSS events.
//!
//! SDO requests queue per node and run one at a time per node; different nodes run in
//! parallel. A request is identified by a [`RequestId`]; its result is only ever stored under
//! that id, and the SDO client ignores responses whose multiplexer is not the running
//! transfer's, so a late answer to a cancelled request never completes another one.
//!
//! One cohesive machine: the routing, the request table and the per-node machines it feeds
//! belong together, so the file stays whole.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::io::Write;
use std::sync::Arc;
use std::sync::mpsc;

use canola_frame::cob::{FunctionCode, LSS_SLAVE_TO_MASTER};
use canola_frame::{CanFrame, CanId, CobId, Duration, Instant, NodeId, is_due};
use canola_nmt::{
    CommandSpecifier, EmcyConsumer, EmcyEvent, GuardingEvent, GuardingMaster, HeartbeatConsumer,
    HeartbeatEvent, NmtCommand, NmtState, NmtTarget, SyncConfig, SyncProducer,
};
use canola_od::{ObjectAddress, ObjectDictionary, Value};
use canola_sdo::{
    AbortCode, Client, ClientConfig, Event as SdoEvent, Method, Multiplexer, SdoCobIds,
};

use crate::error::{SdoError, SdoErrorKind};
use crate::pdo_subscriber::{PdoPublisher, PdoSubscriber, pdo_subscription};
use crate::transport::BusEvent;

/// Identifies one SDO request for its whole life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestId(pub(crate) u64);

/// How far a transfer is, for progress bars.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TransferProgress {
    /// The node.
    pub node: NodeId,
    /// The object.
    pub entry: ObjectAddress,
    /// Bytes done.
    pub done: u64,
    /// Total bytes, when known.
    pub total: Option<u64>,
}

/// A progress callback.
pub type ProgressFn = Box<dyn FnMut(TransferProgress) + Send>;

/// What a finished transfer produced: the uploaded bytes (empty for a download and for an
/// upload streamed into a writer) and the number of bytes transferred. Every kind of request
/// ends in the same shape, so each typed [`Pending`](crate::Pending) takes what it needs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Completion {
    pub(crate) data: Vec<u8>,
    pub(crate) transferred: u64,
}

/// Something that happened on the network, for subscribers.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum NetworkEvent {
    /// A heartbeat consumer event: boot-up, state change, loss, recovery.
    Heartbeat(HeartbeatEvent),
    /// A node guarding event (CiA 301 §7.2.8.3.2.1): boot-up, state change, loss, recovery,
    /// toggle error.
    Guarding(GuardingEvent),
    /// An emergency message.
    Emcy(EmcyEvent),
    /// A transmit PDO from a node that the master does not decode: a node without a
    /// dictionary, a TPDO outside its mapping, or data of another length than the mapping's.
    /// A decoded TPDO comes as [`PdoValues`](Self::PdoValues) instead (one event per frame
    /// either way; [`pdo_data`](Self::pdo_data) reads the bytes of both).
    Pdo {
        /// The producer (from the predefined connection set, or the node configured with the
        /// COB-ID).
        node: NodeId,
        /// TPDO number 1..=512 as the node numbers it (1..=4 in the predefined set).
        number: u8,
        /// The PDO data.
        data: PdoData,
        /// Reception time.
        at: Instant,
    },
    /// A frame from an LSS slave (COB-ID 0x7E4).
    Lss {
        /// The eight data bytes.
        data: [u8; 8],
        /// Reception time.
        at: Instant,
    },
    /// A node's transmit PDO decoded through its dictionary's mapping (nodes added with a
    /// dictionary; see [`Network::add_node_with_dictionary`](crate::Network::add_node_with_dictionary)).
    PdoValues {
        /// The producer.
        node: NodeId,
        /// TPDO number 1..=4.
        number: u8,
        /// The PDO data the values were decoded from.
        data: PdoData,
        /// The mapped objects and their values as the node's dictionary types them
        /// (`Value::Unsigned16` for an UNSIGNED16), in mapping order.
        values: Vec<(ObjectAddress, Value)>,
        /// Reception time.
        at: Instant,
    },
    /// A bus event from the transport.
    Bus(BusEvent),
    /// The transport failed while the background driver drove it; the driver has stopped
    /// (see [`Network::stop_driver`](crate::Network::stop_driver)).
    TransportFailed {
        /// The transport's error.
        error: String,
    },
}

impl NetworkEvent {
    /// The producer, TPDO number and data bytes of a received PDO, decoded or not.
    pub fn pdo_data(&self) -> Option<(NodeId, u8, &[u8])> {
        match self {
            Self::Pdo {
                node, number, data, ..
            }
            | Self::PdoValues {
                node, number, data, ..
            } => Some((*node, *number, data)),
            _ => None,
        }
    }
}

/// A received PDO as a callback sees it (see [`Network::on_pdo`](crate::Network::on_pdo)):
/// borrowed for the duration of the call, nothing copied or allocated for it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct PdoReceived<'a> {
    /// The producer.
    pub node: NodeId,
    /// TPDO number as the node numbers it.
    pub number: u8,
    /// The PDO data.
    pub data: &'a [u8],
    /// The mapped objects and their values as the node's dictionary types them, in mapping
    /// order; empty when the master does not decode this PDO (see [`NetworkEvent::Pdo`]).
    pub values: &'a [(ObjectAddress, Value)],
    /// Reception time.
    pub at: Instant,
}

/// Identifies a PDO callback for [`Network::remove_pdo_callback`](crate::Network::remove_pdo_callback).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoCallbackId(u64);

type PdoCallback = Box<dyn FnMut(&PdoReceived<'_>) + Send>;

/// The data bytes of a received PDO: up to eight, kept in place (no allocation per frame).
/// Reads as a byte slice.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoData {
    buf: [u8; 8],
    len: u8,
}

impl PdoData {
    /// The data of a classic CAN frame (at most eight bytes; more are cut off).
    pub fn new(data: &[u8]) -> Self {
        let len = data.len().min(8);
        let mut buf = [0; 8];
        // Full frames (the usual PDO) as one 8-byte copy, not a copy of a run-time length.
        match <[u8; 8]>::try_from(data) {
            Ok(full) => buf = full,
            Err(_) => buf[..len].copy_from_slice(&data[..len]),
        }
        Self {
            buf,
            len: len as u8,
        }
    }
}

impl core::ops::Deref for PdoData {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.buf[..usize::from(self.len)]
    }
}

impl AsRef<[u8]> for PdoData {
    fn as_ref(&self) -> &[u8] {
        self
    }
}

impl core::fmt::Debug for PdoData {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Debug::fmt(&**self, f)
    }
}

impl PartialEq<[u8]> for PdoData {
    fn eq(&self, other: &[u8]) -> bool {
        **self == *other
    }
}

impl<const N: usize> PartialEq<[u8; N]> for PdoData {
    fn eq(&self, other: &[u8; N]) -> bool {
        **self == other[..]
    }
}

impl PartialEq<Vec<u8>> for PdoData {
    fn eq(&self, other: &Vec<u8>) -> bool {
        **self == other[..]
    }
}

/// A subscriber other than an mpsc channel (the async API's event streams): it takes each
/// event as it is published and says whether it still wants more.
pub(crate) trait EventSink: Send {
    /// Takes one event; `false` when the subscriber is gone (it is then forgotten).
    fn deliver(&self, event: &NetworkEvent) -> bool;
}

/// Where an upload's bytes go: memory, or a writer (streamed as they arrive).
pub(crate) enum UpSink {
    Mem(Vec<u8>),
    Stream {
        w: Box<dyn Write + Send>,
        written: u64,
        error: Option<std::io::Error>,
    },
}

impl canola_sdo::Sink for UpSink {
    fn write(&mut self, data: &[u8]) -> Result<(), canola_sdo::Full> {
        match self {
            Self::Mem(v) => {
                v.extend_from_slice(data);
                Ok(())
            }
            Self::Stream { w, written, error } => match w.write_all(data) {
                Ok(()) => {
                    *written += data.len() as u64;
                    Ok(())
                }
                Err(e) => {
                    *error = Some(e);
                    Err(canola_sdo::Full)
                }
            },
        }
    }
}

/// A download's bytes.
pub(crate) struct DownSource(pub(crate) Vec<u8>);

impl canola_sdo::Source for DownSource {
    fn len(&self) -> u32 {
        u32::try_from(self.0.len()).unwrap_or(u32::MAX)
    }
    fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
        let start = (offset as usize).min(self.0.len());
        let n = out.len().min(self.0.len() - start);
        out[..n].copy_from_slice(&self.0[start..start + n]);
        n
    }
}

pub(crate) enum Op {
    Upload(UpSink),
    Download(DownSource),
}

/// One SDO request.
pub(crate) struct SdoRequest {
    pub(crate) node: NodeId,
    /// The server channel: the node's default one (0x600/0x580 + node-ID) or another.
    pub(crate) channel: SdoCobIds,
    pub(crate) entry: ObjectAddress,
    pub(crate) op: Op,
    pub(crate) method: Method,
    pub(crate) timeout: Duration,
    pub(crate) progress: Option<ProgressFn>,
}

enum ReqState {
    Queued(SdoRequest),
    Active {
        progress: Option<ProgressFn>,
        entry: ObjectAddress,
        node: NodeId,
        channel: usize,
    },
    Done(Outcome),
}

/// A finished request's result as the core keeps and hands it over: the error boxed, so that
/// the result moves through the waiting loop as a few words (an error is the rare case).
pub(crate) type Outcome = Result<Completion, Box<SdoError>>;

/// How many entries the master's tables hold at one moment, for soak tests (none may grow
/// while the traffic stays the same) and diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub struct Occupancy {
    /// Nodes the master knows.
    pub nodes: usize,
    /// SDO client channels over all nodes.
    pub sdo_channels: usize,
    /// Entries of the request table: queued, running, or finished and not yet taken.
    pub requests: usize,
    /// Requests waiting in the channels' queues.
    pub queued_requests: usize,
    /// Frames not yet handed to the transport.
    pub unsent_frames: usize,
    /// Nodes with a boot-up count.
    pub boot_counts: usize,
    /// Event subscribers.
    pub subscribers: usize,
}

/// A frame waiting to be handed to the transport.
pub(crate) struct Outgoing {
    pub(crate) frame: CanFrame,
    /// The SDO transfer the frame belongs to: node, channel index and the channel's transfer
    /// number (see [`Core::withdraw`]).
    transfer: Option<(NodeId, usize, u64)>,
}

/// One SDO client channel to a node's server (CiA 301 §7.2.4.2): its COB-IDs, its client
/// machine and its request queue. Requests on one channel run one at a time.
struct SdoChannel {
    ids: SdoCobIds,
    client: Client<UpSink, DownSource>,
    queue: VecDeque<RequestId>,
    active: Option<RequestId>,
    /// The next queued transfer may start at this time (see [`Core::settle`]).
    ready_at: Instant,
    /// Number of the running (or last) transfer, counting from 1.
    transfer: u64,
    /// Frames that transfer has queued so far.
    queued: usize,
    /// The server has answered the running transfer at least once.
    answered: bool,
    /// The running transfer's request has a progress callback (else the request table is not
    /// searched for one at every turn).
    reports_progress: bool,
    /// The node sent a boot-up while the transfer ran, before the server answered it: if the
    /// response timeout ends the transfer, the error is [`SdoErrorKind::NodeRebooted`].
    boot_seen: bool,
    /// The node sent a boot-up after its server had answered the transfer: it ends at once
    /// with [`SdoErrorKind::NodeRebooted`].
    rebooted: bool,
}

impl SdoChannel {
    fn new(ids: SdoCobIds) -> Self {
        Self {
            ids,
            client: Client::new(ClientConfig::default()),
            queue: VecDeque::new(),
            active: None,
            ready_at: Instant::ZERO,
            transfer: 0,
            queued: 0,
            answered: false,
            reports_progress: false,
            boot_seen: false,
            rebooted: false,
        }
    }

    /// Whether a queued request waits for the channel to become free.
    fn has_waiting(&self) -> bool {
        self.active.is_none() && !self.queue.is_empty()
    }
}

struct NodeSlot {
    od: Option<Arc<ObjectDictionary>>,
    /// The node's TPDOs mirrored as receive PDOs, and its RPDOs the master transmits.
    pdo: Option<crate::pdo_glue::NodePdos>,
    /// The node's SDO channels: the default one first, then those opened on other COB-IDs.
    channels: Vec<SdoChannel>,
}

impl NodeSlot {
    fn new(node: NodeId, od: Option<Arc<ObjectDictionary>>) -> Self {
        Self {
            pdo: od
                .as_deref()
                .map(|od| crate::pdo_glue::mirror_engine(od, node)),
            od,
            channels: vec![SdoChannel::new(SdoCobIds::default_for(node))],
        }
    }
}

/// The nodes by node-ID, indexed directly (node-IDs are 1..=127): a frame's node is found
/// without a search. Iterates in node-ID order.
struct NodeTable {
    slots: Vec<Option<Box<NodeSlot>>>,
    len: usize,
}

impl NodeTable {
    fn new() -> Self {
        Self {
            slots: (0..=127).map(|_| None).collect(),
            len: 0,
        }
    }

    fn get(&self, node: &NodeId) -> Option<&NodeSlot> {
        self.slots.get(usize::from(node.get()))?.as_deref()
    }

    fn get_mut(&mut self, node: &NodeId) -> Option<&mut NodeSlot> {
        self.slots.get_mut(usize::from(node.get()))?.as_deref_mut()
    }

    fn contains_key(&self, node: &NodeId) -> bool {
        self.get(node).is_some()
    }

    fn insert(&mut self, node: NodeId, slot: NodeSlot) {
        if let Some(s) = self.slots.get_mut(usize::from(node.get())) {
            self.len += usize::from(s.is_none());
            *s = Some(Box::new(slot));
        }
    }

    fn len(&self) -> usize {
        self.len
    }

    fn iter(&self) -> impl Iterator<Item = (NodeId, &NodeSlot)> {
        self.slots.iter().enumerate().filter_map(|(i, s)| {
            let node = NodeId::new(u8::try_from(i).ok()?).ok()?;
            Some((node, s.as_deref()?))
        })
    }

    fn values(&self) -> impl Iterator<Item = &NodeSlot> {
        self.slots.iter().filter_map(|s| s.as_deref())
    }

    fn values_mut(&mut self) -> impl Iterator<Item = &mut NodeSlot> {
        self.slots.iter_mut().filter_map(|s| s.as_deref_mut())
    }
}

/// The request table: entries in id order (ids only grow, so a new one goes at the back), and
/// most leave from the front, as requests run in submission order per channel. A few entries
/// live in it at a time, so a binary search over a ring buffer beats a tree, which allocates a
/// node whenever the table goes from empty to one entry — once per blocking request.
struct RequestTable {
    entries: VecDeque<(RequestId, ReqState)>,
}

impl RequestTable {
    fn new() -> Self {
        Self {
            entries: VecDeque::new(),
        }
    }

    fn position(&self, id: RequestId) -> Option<usize> {
        // Mostly the oldest, else one of the next: look at those before searching.
        if self.entries.front().is_some_and(|(i, _)| *i == id) {
            return Some(0);
        }
        if let Some(i) = self.entries.iter().take(4).position(|(i, _)| *i == id) {
            return Some(i);
        }
        self.entries.binary_search_by_key(&id, |(i, _)| *i).ok()
    }

    fn get(&self, id: &RequestId) -> Option<&ReqState> {
        let i = self.position(*id)?;
        self.entries.get(i).map(|(_, s)| s)
    }

    fn get_mut(&mut self, id: &RequestId) -> Option<&mut ReqState> {
        let i = self.position(*id)?;
        self.entries.get_mut(i).map(|(_, s)| s)
    }

    /// Adds a request with an id above every id in the table.
    fn push(&mut self, id: RequestId, state: ReqState) {
        debug_assert!(self.entries.back().is_none_or(|(last, _)| *last < id));
        self.entries.push_back((id, state));
    }

    fn remove(&mut self, id: &RequestId) -> Option<ReqState> {
        let i = self.position(*id)?;
        self.entries.remove(i).map(|(_, s)| s)
    }

    /// Removes a finished request's entry and hands its result over.
    fn take_result(&mut self, id: RequestId) -> Taken {
        let Some(i) = self.position(id) else {
            return Taken::Unknown;
        };
        if !matches!(self.entries.get(i), Some((_, ReqState::Done(_)))) {
            return Taken::Running;
        }
        // Mostly the oldest entry: a pop is cheaper than a general removal.
        let entry = if i == 0 {
            self.entries.pop_front()
        } else {
            self.entries.remove(i)
        };
        match entry {
            Some((_, ReqState::Done(r))) => Taken::Done(r),
            _ => Taken::Unknown,
        }
    }

    fn len(&self) -> usize {
        self.entries.len()
    }
}

/// What [`Core::take_result`] found for a request.
pub(crate) enum Taken {
    /// Still queued or running.
    Running,
    /// Finished; the result is handed over (and forgotten by the core).
    Done(Outcome),
    /// Not in the table: cancelled, or its result was taken already.
    Unknown,
}

/// The abort code sent when a caller cancels a running transfer: "general error" (CiA 301
/// has no dedicated code for a client giving up).
pub const CANCEL_ABORT: AbortCode = AbortCode(0x0800_0000);

/// The event subscribers: channels and sinks.
#[derive(Default)]
struct Subscribers {
    channels: Vec<mpsc::Sender<NetworkEvent>>,
    sinks: Vec<Box<dyn EventSink>>,
    /// Events for the channels held back while a batch of received frames is handled (see
    /// [`Core::hold_events`]); the buffer is kept between batches.
    held: Vec<NetworkEvent>,
    holding: bool,
}

impl Subscribers {
    fn is_empty(&self) -> bool {
        self.channels.is_empty() && self.sinks.is_empty()
    }

    /// Hands `ev` to every subscriber (or holds it for the channels) and forgets the sinks
    /// that are gone.
    fn deliver(&mut self, ev: NetworkEvent) {
        self.sinks.retain(|s| s.deliver(&ev));
        if self.holding && !self.channels.is_empty() {
            self.held.push(ev);
        } else {
            Self::send_to(&mut self.channels, ev);
        }
    }

    /// Sends `ev` to every channel (the last one gets it without a copy) and forgets those
    /// that are gone.
    fn send_to(channels: &mut Vec<mpsc::Sender<NetworkEvent>>, ev: NetworkEvent) {
        let n = channels.len();
        let mut ev = Some(ev);
        let mut seen = 0;
        channels.retain(|s| {
            seen += 1;
            let e = if seen == n { ev.take() } else { ev.clone() };
            e.is_none_or(|e| s.send(e).is_ok())
        });
    }
}

/// The master's protocol state. See the module docs for the call order.
pub(crate) struct Core {
    now: Instant,
    nodes: NodeTable,
    requests: RequestTable,
    next_request: u64,
    /// Frames not yet handed to the transport (a full transmit queue keeps them here).
    tx: VecDeque<Outgoing>,
    heartbeat: HeartbeatConsumer,
    guarding: Box<GuardingMaster>,
    emcy: EmcyConsumer,
    sync: Option<SyncProducer>,
    /// Boot-up messages received per node: a waiter compares counts, so a boot-up stays seen
    /// even when a heartbeat follows it in the same step.
    boots: BTreeMap<NodeId, u64>,
    subs: Subscribers,
    /// Quiet time between two transfers to the same node, so that a late or duplicated
    /// response to the finished transfer reaches an idle client (which ignores it) rather
    /// than the next transfer.
    pub(crate) settle: Duration,
    lss: Option<Box<dyn crate::lss::LssJob>>,
    lss_result: Option<Result<crate::lss::LssOutcome, canola_lss::LssError>>,
    /// Response COB-IDs of the SDO channels opened on other than the default identifiers,
    /// with their node and channel index (default channels route by function code).
    sdo_routes: HashMap<CanId, (NodeId, usize)>,
    /// Nodes' TPDOs configured on COB-IDs other than their predefined ones, by COB-ID.
    pdo_routes: HashMap<CanId, NodeId>,
    /// No node's PDO engine has a deadline before this (a lower bound: a deadline that moved
    /// later is found out when this one passes, so a received PDO costs no scan of all nodes).
    pdo_next: Option<Instant>,
    /// The SDO channels that may have a timer: a request queued or running since the channel
    /// was last found idle. The timer scans walk this set, not every node's channels, so a
    /// step costs the same with 2 nodes as with 127 when only PDOs flow.
    sdo_busy: Vec<(NodeId, usize)>,
    pdo_callbacks: Vec<(PdoCallbackId, PdoCallback)>,
    next_callback: u64,
    /// The values of the PDO being received (kept, so a reception that only callbacks see
    /// allocates nothing).
    pdo_scratch: Vec<(ObjectAddress, Value)>,
    /// The batch subscribers' ends (see [`crate::PdoSubscriber`]), handed over at each
    /// [`release_events`](Self::release_events).
    pdo_subs: Vec<PdoPublisher>,
}

impl Core {
    pub(crate) fn new() -> Self {
        Self {
            now: Instant::ZERO,
            nodes: NodeTable::new(),
            requests: RequestTable::new(),
            next_request: 1,
            tx: VecDeque::new(),
            heartbeat: {
                // The consumer keeps every node's NMT state (monitored or not); the core keeps
                // no copy of its own.
                let mut h = HeartbeatConsumer::new();
                h.observe_all(true);
                h
            },
            guarding: Box::new(GuardingMaster::new()),
            emcy: EmcyConsumer::new(),
            sync: None,
            boots: BTreeMap::new(),
            subs: Subscribers::default(),
            settle: Duration::from_millis(1),
            lss: None,
            lss_result: None,
            sdo_routes: HashMap::new(),
            pdo_routes: HashMap::new(),
            pdo_next: None,
            sdo_busy: Vec::new(),
            pdo_callbacks: Vec::new(),
            next_callback: 0,
            pdo_scratch: Vec::new(),
            pdo_subs: Vec::new(),
        }
    }

    /// The index of `node`'s channel on `ids`, opened (and routed) on first use.
    fn channel_index(&mut self, node: NodeId, ids: SdoCobIds) -> usize {
        if !self.nodes.contains_key(&node) {
            self.add_node(node, None);
        }
        let Some(slot) = self.nodes.get_mut(&node) else {
            return 0;
        };
        if let Some(i) = slot.channels.iter().position(|c| c.ids == ids) {
            return i;
        }
        slot.channels.push(SdoChannel::new(ids));
        let i = slot.channels.len() - 1;
        self.sdo_routes.insert(ids.response, (node, i));
        i
    }

    pub(crate) fn set_now(&mut self, now: Instant) {
        self.now = self.now.max(now);
    }

    pub(crate) fn add_node(&mut self, node: NodeId, od: Option<Arc<ObjectDictionary>>) {
        let with_dictionary = od.is_some();
        match self.nodes.get_mut(&node) {
            Some(slot) => {
                if let Some(od) = od {
                    slot.pdo
                        .get_or_insert_with(crate::pdo_glue::NodePdos::new)
                        .mirror_dictionary(&od, node);
                    slot.od = Some(od);
                }
            }
            None => {
                self.nodes.insert(node, NodeSlot::new(node, od));
            }
        }
        // A dictionary may put TPDOs on COB-IDs outside the predefined set.
        if with_dictionary {
            self.route_pdos();
        }
    }

    pub(crate) fn dictionary(&self, node: NodeId) -> Option<Arc<ObjectDictionary>> {
        self.nodes.get(&node).and_then(|s| s.od.clone())
    }

    pub(crate) fn object_name(&self, node: NodeId, entry: ObjectAddress) -> Option<String> {
        let od = self.nodes.get(&node)?.od.as_ref()?;
        let obj = od.get(entry.index)?;
        match obj.sub(entry.sub_index) {
            Some(sub) if !obj.is_simple() => Some(format!("{} / {}", obj.name, sub.name)),
            _ => Some(obj.name.to_string()),
        }
    }

    pub(crate) fn subscribe(&mut self) -> mpsc::Receiver<NetworkEvent> {
        let (tx, rx) = mpsc::channel();
        self.subs.channels.push(tx);
        rx
    }

    pub(crate) fn subscribe_pdos(&mut self) -> PdoSubscriber {
        let (publisher, subscriber) = pdo_subscription();
        self.pdo_subs.push(publisher);
        subscriber
    }

    pub(crate) fn add_pdo_callback(&mut self, f: PdoCallback) -> PdoCallbackId {
        let id = PdoCallbackId(self.next_callback);
        self.next_callback += 1;
        self.pdo_callbacks.push((id, f));
        id
    }

    pub(crate) fn remove_pdo_callback(&mut self, id: PdoCallbackId) -> bool {
        let before = self.pdo_callbacks.len();
        self.pdo_callbacks.retain(|(i, _)| *i != id);
        self.pdo_callbacks.len() != before
    }

    /// Adds a subscriber that takes events by reference (see [`EventSink`]).
    #[cfg(feature = "tokio")]
    pub(crate) fn add_sink(&mut self, sink: Box<dyn EventSink>) {
        self.subs.sinks.push(sink);
    }

    pub(crate) fn publish(&mut self, ev: NetworkEvent) {
        self.subs.deliver(ev);
    }

    /// Holds the channel subscribers' events back until [`release_events`](Self::release_events):
    /// a receiver blocked on its channel then wakes once for a batch of frames, not once per
    /// frame (the wake-up, not the event, is the cost on another thread).
    pub(crate) fn hold_events(&mut self) {
        self.subs.holding = !self.subs.channels.is_empty();
    }

    /// Sends the events held back since [`hold_events`](Self::hold_events), in order. `more`:
    /// a background driver steps again at once for frames the transport holds already (the
    /// batch subscribers may wait to be woken, see [`PdoPublisher::flush`]).
    pub(crate) fn release_events(&mut self, more: bool) {
        if !self.pdo_subs.is_empty() {
            self.pdo_subs.retain_mut(|p| p.flush(more));
        }
        let subs = &mut self.subs;
        if !core::mem::take(&mut subs.holding) {
            return;
        }
        for ev in subs.held.drain(..) {
            Subscribers::send_to(&mut subs.channels, ev);
        }
    }

    /// Wakes the waiting batch subscribers: a background driver that stops may have left PDOs
    /// in their batches without waking them (see [`PdoPublisher::flush`]).
    pub(crate) fn wake_pdo_subscribers(&self) {
        for p in &self.pdo_subs {
            p.wake();
        }
    }

    pub(crate) fn last_state(&self, node: NodeId) -> Option<NmtState> {
        self.guarding
            .state(node)
            .or_else(|| self.heartbeat.state(node))
    }

    /// When the latest heartbeat or boot-up of `node` arrived.
    pub(crate) fn last_heartbeat(&self, node: NodeId) -> Option<Instant> {
        self.heartbeat.last_seen(node)
    }

    /// How many boot-up messages `node` has sent since the network started.
    pub(crate) fn boot_count(&self, node: NodeId) -> u64 {
        self.boots.get(&node).copied().unwrap_or(0)
    }

    /// The time of the latest frame or timer the core was given.
    pub(crate) fn now(&self) -> Instant {
        self.now
    }

    /// Queues an NMT command (COB-ID 0x000).
    pub(crate) fn nmt(&mut self, cmd: CommandSpecifier, target: NmtTarget) {
        self.queue(NmtCommand::new(cmd, target).to_frame());
    }

    pub(crate) fn send_raw(&mut self, frame: CanFrame) {
        self.queue(frame);
    }

    fn queue(&mut self, frame: CanFrame) {
        self.tx.push_back(Outgoing {
            frame,
            transfer: None,
        });
    }

    /// Queues a periodic frame (SYNC, a guarding request) unless one with its identifier still
    /// waits for the transport: while the transmit queue is full, a periodic producer must not
    /// pile up copies, and a late copy says nothing the waiting one does not. An `urgent` frame
    /// goes ahead of everything queued: the SYNC is the time base of the synchronous PDOs and
    /// must not wait behind SDO frames for room in the transmit queue.
    fn queue_periodic(&mut self, frame: CanFrame, urgent: bool) {
        if self.tx.iter().any(|o| o.frame.id() == frame.id()) {
            return;
        }
        let o = Outgoing {
            frame,
            transfer: None,
        };
        if urgent {
            self.tx.push_front(o);
        } else {
            self.tx.push_back(o);
        }
    }

    /// Takes back the frames of an SDO transfer that failed and are still waiting for the
    /// transport. If none of its frames left, the server never heard of the transfer and its
    /// abort goes too; otherwise the abort (command byte 0x80, no other client frame starts
    /// so) stays, so the server ends its side, and only the data frames behind it go. Without
    /// this, a client that times out while its frames wait for a busy bus queues an abort and
    /// the next transfer behind them, the queue grows for as long as the bus is overloaded,
    /// and the server gets the stale requests long after the client gave up.
    ///
    /// With `server_forgot` (the server rebooted) every waiting frame goes, the abort too.
    fn withdraw(&mut self, tag: (NodeId, usize, u64), queued: usize, server_forgot: bool) {
        let waiting = self.tx.iter().filter(|o| o.transfer == Some(tag)).count();
        if waiting == 0 {
            return;
        }
        let keep_abort = waiting < queued && !server_forgot;
        self.tx.retain(|o| {
            o.transfer != Some(tag) || (keep_abort && o.frame.data().first() == Some(&0x80))
        });
    }

    /// A boot-up message from `node`: its SDO servers start idle. A transfer the server has
    /// answered can no longer complete: it ends with [`SdoErrorKind::NodeRebooted`] at once
    /// (rather than with the response timeout, or with the abort the rebooted server answers
    /// the next segment with). A transfer not answered yet may have been sent to the server
    /// after its reboot (a boot-up can lose arbitration to the device's first SDO response,
    /// or wait behind it), so it goes on; if it then times out, the error is `NodeRebooted`.
    /// Either way without an abort: the server has no transfer to abort, and the abort
    /// service is unconfirmed (CiA 301), so one reaching an idle server changes nothing and
    /// would only cost bus time. The transfer's frames still waiting for the transport are
    /// withdrawn; queued requests start on the rebooted server as usual.
    fn end_transfers_on_boot(&mut self, node: NodeId) {
        let now = self.now;
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let mut running = Vec::new();
        for (i, c) in slot.channels.iter_mut().enumerate() {
            if c.active.is_none() {
                continue;
            }
            if c.answered {
                // The client's abort path ends the transfer; its abort frame is withdrawn
                // with the rest (see `pump_channel`).
                c.rebooted = c.client.abort(now, CANCEL_ABORT);
                running.push(i);
            } else {
                c.boot_seen = true;
            }
        }
        for ch in running {
            self.pump_channel(node, ch);
        }
    }

    pub(crate) fn monitor_heartbeat(&mut self, node: NodeId, timeout: Duration) -> bool {
        self.heartbeat.monitor(node, timeout).is_ok()
    }

    pub(crate) fn guard_node(&mut self, node: NodeId, guard_time: Duration, factor: u8) -> bool {
        let now = self.now;
        let ok = self.guarding.guard(now, node, guard_time, factor).is_ok();
        self.drain_guarding();
        ok
    }

    fn drain_guarding(&mut self) {
        while let Some(f) = self.guarding.poll_transmit_frame() {
            self.queue_periodic(f, false);
        }
        while let Some(ev) = self.guarding.poll_event() {
            self.publish(NetworkEvent::Guarding(ev));
        }
    }

    pub(crate) fn start_sync(&mut self, config: SyncConfig) {
        let mut p = SyncProducer::new(config);
        p.start(self.now);
        self.sync = Some(p);
    }

    pub(crate) fn stop_sync(&mut self) {
        self.sync = None;
    }

    /// The master's view of a node's TPDO `number` (1-based) after a remap or a read of its
    /// parameters: received frames decode with `config` from now on, from its COB-ID.
    pub(crate) fn mirror_tpdo(&mut self, node: NodeId, number: u8, config: canola_pdo::PdoConfig) {
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let pdos = slot.pdo.get_or_insert_with(crate::pdo_glue::NodePdos::new);
        pdos.mirror_tpdo(number, config, slot.od.as_deref());
        Self::pdo_touched(pdos, &mut self.pdo_next);
        self.route_pdos();
    }

    /// Rebuilds the COB-ID routes of TPDOs outside the predefined connection set.
    fn route_pdos(&mut self) {
        self.pdo_routes.clear();
        for (node, slot) in self.nodes.iter() {
            let Some(pdos) = &slot.pdo else {
                continue;
            };
            for (_, id) in &pdos.tpdos {
                let Some(config) = pdos.engine.rpdo(*id) else {
                    continue;
                };
                if !config.comm.cob_id.is_valid() || config.mapping.is_empty() {
                    continue;
                }
                let Ok(can_id) = config.comm.cob_id.can_id() else {
                    continue;
                };
                let predefined = can_id
                    .as_standard()
                    .and_then(CobId::classify)
                    .is_some_and(|c| {
                        matches!(c.function, FunctionCode::Tpdo(_)) && c.node == Some(node)
                    });
                if !predefined {
                    self.pdo_routes.insert(can_id, node);
                }
            }
        }
    }

    /// Starts transmitting `node`'s RPDO `number` with `config` (see
    /// [`NodePdos::start_rpdo`](crate::pdo_glue::NodePdos::start_rpdo)).
    pub(crate) fn start_rpdo(
        &mut self,
        node: NodeId,
        number: u16,
        config: canola_pdo::PdoConfig,
    ) -> Result<(), canola_pdo::EngineError> {
        let now = self.now;
        self.add_node(node, None);
        let Some(slot) = self.nodes.get_mut(&node) else {
            return Err(canola_pdo::EngineError::UnknownPdo);
        };
        let pdos = slot.pdo.get_or_insert_with(crate::pdo_glue::NodePdos::new);
        let r = pdos.start_rpdo(now, number, config);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        r
    }

    /// Reconfigures a transmitted RPDO with the node's new COB-ID and mapping, keeping the
    /// master's transmission parameters; nothing when it is not transmitted.
    pub(crate) fn retarget_rpdo(
        &mut self,
        node: NodeId,
        number: u16,
        comm: canola_pdo::CommParams,
        mapping: canola_pdo::Mapping,
    ) -> Result<(), canola_pdo::EngineError> {
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return Ok(());
        };
        let Some(id) = pdos.rpdo_id(number) else {
            return Ok(());
        };
        let Some(old) = pdos.engine.tpdo(id).cloned() else {
            return Ok(());
        };
        let mut config = canola_pdo::PdoConfig::new(old.comm, mapping);
        config.comm.cob_id = comm.cob_id;
        let now = self.now;
        let r = pdos.start_rpdo(now, number, config);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        r
    }

    /// Stops transmitting `node`'s RPDO `number`; `false` when it was not transmitted.
    pub(crate) fn stop_rpdo(&mut self, node: NodeId, number: u16) -> bool {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return false;
        };
        let stopped = pdos.stop_rpdo(now, number);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        stopped
    }

    /// Sets mapped values of `node`'s transmitted RPDOs (little-endian, sized as mapped) and
    /// lets the engine see the change: event-driven RPDOs go out now or after their inhibit
    /// time, synchronous acyclic ones at the next SYNC.
    pub(crate) fn set_rpdo_values(&mut self, node: NodeId, values: &[(ObjectAddress, Vec<u8>)]) {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return;
        };
        for (addr, bytes) in values {
            pdos.image.set(*addr, bytes);
        }
        pdos.engine.update(now, &mut pdos.image);
        Self::drain_pdos(pdos, &mut self.tx, &mut self.pdo_next);
    }

    /// The length in bits of `addr` in `node`'s transmitted RPDO `number`: `None` when that
    /// RPDO is not transmitted, `Some(Err(()))` when it does not map `addr`.
    pub(crate) fn rpdo_bits(
        &self,
        node: NodeId,
        number: u16,
        addr: ObjectAddress,
    ) -> Option<Result<u8, ()>> {
        self.nodes.get(&node)?.pdo.as_ref()?.rpdo_bits(number, addr)
    }

    /// An application event for `node`'s transmitted RPDO `number`.
    pub(crate) fn trigger_rpdo(&mut self, node: NodeId, number: u16) -> bool {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return false;
        };
        let Some(id) = pdos.rpdo_id(number) else {
            return false;
        };
        let ok = pdos.engine.trigger(now, id, &mut pdos.image).is_ok();
        Self::drain_pdos(pdos, &mut self.tx, &mut self.pdo_next);
        ok
    }

    /// Queues a node engine's frames; its events other than receptions (deadlines, store
    /// failures) have no subscriber yet and are dropped.
    fn drain_pdos(
        pdos: &mut crate::pdo_glue::NodePdos,
        tx: &mut VecDeque<Outgoing>,
        bound: &mut Option<Instant>,
    ) {
        while let Some(frame) = pdos.engine.poll_transmit() {
            tx.push_back(Outgoing {
                frame,
                transfer: None,
            });
        }
        while pdos.engine.poll_event().is_some() {}
        Self::pdo_touched(pdos, bound);
    }

    /// After an input to a node's engine: its next deadline, and the core's bound lowered to
    /// it.
    fn pdo_touched(pdos: &mut crate::pdo_glue::NodePdos, bound: &mut Option<Instant>) {
        pdos.next = pdos.engine.poll_timeout();
        if let Some(t) = pdos.next {
            *bound = Some(bound.map_or(t, |b| b.min(t)));
        }
    }

    /// Starts an LSS job (replacing a running one).
    pub(crate) fn start_lss(&mut self, job: Box<dyn crate::lss::LssJob>) {
        self.lss_result = None;
        self.lss = Some(job);
        self.pump_lss();
    }

    pub(crate) fn take_lss_result(
        &mut self,
    ) -> Option<Result<crate::lss::LssOutcome, canola_lss::LssError>> {
        self.lss_result.take()
    }

    fn pump_lss(&mut self) {
        if let Some(job) = &mut self.lss {
            while let Some(f) = job.poll_transmit() {
                self.tx.push_back(Outgoing {
                    frame: f,
                    transfer: None,
                });
            }
            if let Some(r) = job.poll() {
                self.lss_result = Some(r);
                self.lss = None;
            }
        }
    }

    /// Queues an SDO request; it starts when the node's earlier requests are done.
    pub(crate) fn submit(&mut self, req: SdoRequest) -> RequestId {
        let id = RequestId(self.next_request);
        self.next_request += 1;
        let node = req.node;
        let ch = self.channel_index(node, req.channel);
        let now = self.now;
        let Some(c) = self
            .nodes
            .get_mut(&node)
            .and_then(|s| s.channels.get_mut(ch))
        else {
            self.requests.push(id, ReqState::Queued(req));
            return id;
        };
        if !self.sdo_busy.contains(&(node, ch)) {
            self.sdo_busy.push((node, ch));
        }
        // A free channel starts the request at once, as `pump_channel` would from the queue.
        let state = if c.queue.is_empty()
            && c.active.is_none()
            && c.client.is_idle()
            && c.ready_at <= now
        {
            Self::start(c, now, id, req, ch)
        } else {
            c.queue.push_back(id);
            ReqState::Queued(req)
        };
        self.requests.push(id, state);
        self.pump_channel(node, ch);
        id
    }

    /// Whether the request ended (and its result waits to be taken).
    pub(crate) fn is_done(&self, id: RequestId) -> bool {
        matches!(self.requests.get(&id), Some(ReqState::Done(_)) | None)
    }

    /// Takes a finished request's result. `None` while it runs.
    pub(crate) fn take_result(&mut self, id: RequestId) -> Taken {
        self.requests.take_result(id)
    }

    /// Cancels a request: a queued one is dropped, a running one is aborted on the bus (the
    /// channel is free for the next request at once). Its result is discarded.
    pub(crate) fn cancel(&mut self, id: RequestId) {
        let Some(state) = self.requests.remove(&id) else {
            return;
        };
        match state {
            ReqState::Queued(req) => {
                if let Some(slot) = self.nodes.get_mut(&req.node) {
                    for c in &mut slot.channels {
                        c.queue.retain(|q| *q != id);
                    }
                }
            }
            ReqState::Active { node, channel, .. } => {
                let now = self.now;
                if let Some(c) = self
                    .nodes
                    .get_mut(&node)
                    .and_then(|s| s.channels.get_mut(channel))
                {
                    c.client.abort(now, CANCEL_ABORT);
                }
                self.pump_channel(node, channel);
            }
            ReqState::Done(_) => {}
        }
    }

    /// Sends what the channel's client has, completes its finished transfer, starts the next.
    fn pump_channel(&mut self, node: NodeId, ch: usize) {
        // Each turn either finishes a transfer or starts one, so the loop ends when the queue
        // is empty or a transfer runs.
        loop {
            let Some(c) = self
                .nodes
                .get_mut(&node)
                .and_then(|s| s.channels.get_mut(ch))
            else {
                return;
            };
            while let Some(data) = c.client.poll_transmit() {
                c.queued += 1;
                self.tx.push_back(Outgoing {
                    frame: c.ids.request_frame(data),
                    transfer: Some((node, ch, c.transfer)),
                });
            }
            if c.reports_progress
                && let (Some(active), Some(p)) = (c.active, c.client.progress())
                && let Some(ReqState::Active {
                    progress: Some(cb),
                    entry,
                    ..
                }) = self.requests.get_mut(&active)
            {
                cb(TransferProgress {
                    node,
                    entry: *entry,
                    done: u64::from(p.done),
                    total: p.total.map(u64::from),
                });
            }
            if let Some(ev) = c.client.poll_event() {
                let finished = c.active.take();
                let failed =
                    matches!(ev, SdoEvent::Failed { .. }).then_some((c.transfer, c.queued));
                let boot_seen = core::mem::take(&mut c.boot_seen);
                let timed_out = matches!(
                    &ev,
                    SdoEvent::Failed { error, .. } if error.kind == canola_sdo::ErrorKind::Timeout
                );
                let rebooted = core::mem::take(&mut c.rebooted) || (boot_seen && timed_out);
                let result = match ev {
                    SdoEvent::Uploaded { sink, .. } => match sink {
                        UpSink::Mem(data) => Ok(Completion {
                            transferred: data.len() as u64,
                            data,
                        }),
                        // A buffered writer may hold the tail still: flush it, and a failing
                        // flush fails the upload (the bytes did not all arrive).
                        UpSink::Stream { mut w, written, .. } => match w.flush() {
                            Ok(()) => Ok(Completion {
                                data: Vec::new(),
                                transferred: written,
                            }),
                            Err(e) => Err(SdoErrorKind::Io(format!("flushing the output: {e}"))),
                        },
                    },
                    SdoEvent::Downloaded { source, .. } => Ok(Completion {
                        data: Vec::new(),
                        transferred: source.0.len() as u64,
                    }),
                    SdoEvent::Failed { .. } if rebooted => Err(SdoErrorKind::NodeRebooted),
                    SdoEvent::Failed { error, buffer } => Err(match buffer {
                        canola_sdo::Buffer::Sink(UpSink::Stream { error: Some(e), .. }) => {
                            SdoErrorKind::Io(e.to_string())
                        }
                        _ => SdoErrorKind::Transfer(error.kind),
                    }),
                };
                c.ready_at = self.now + self.settle;
                if let Some((transfer, queued)) = failed {
                    self.withdraw((node, ch, transfer), queued, rebooted);
                }
                // A cancelled request is no longer in the table: its result is dropped here.
                if let Some(id) = finished
                    && let Some(state) = self.requests.get_mut(&id)
                    && let ReqState::Active { entry, .. } = state
                {
                    let entry = *entry;
                    let result = result.map_err(|kind| {
                        Box::new(SdoError {
                            node,
                            entry,
                            name: None,
                            kind,
                        })
                    });
                    *state = ReqState::Done(result);
                }
                continue;
            }
            if c.active.is_some() || !c.client.is_idle() || c.ready_at > self.now {
                return;
            }
            let Some(next) = c.queue.pop_front() else {
                return;
            };
            // Changed in place: a request is looked up once while it starts.
            let Some(slot) = self.requests.get_mut(&next) else {
                continue;
            };
            let req = match core::mem::replace(slot, ReqState::Done(Ok(Completion::default()))) {
                ReqState::Queued(req) => req,
                other => {
                    *slot = other;
                    continue;
                }
            };
            *slot = Self::start(c, self.now, next, req, ch);
        }
    }

    /// Starts request `id` on channel `ch` (free and ready); its new state.
    fn start(
        c: &mut SdoChannel,
        now: Instant,
        id: RequestId,
        req: SdoRequest,
        ch: usize,
    ) -> ReqState {
        let SdoRequest {
            node,
            entry,
            op,
            method,
            timeout,
            progress,
            ..
        } = req;
        c.transfer += 1;
        c.queued = 0;
        c.answered = false;
        c.reports_progress = progress.is_some();
        c.boot_seen = false;
        let cfg = c.client.config().with_timeout(timeout);
        c.client.set_config(cfg);
        let mux = Multiplexer::new(entry.index, entry.sub_index);
        let started = match op {
            Op::Upload(sink) => c.client.start_upload(now, mux, sink, method).is_ok(),
            Op::Download(src) => c.client.start_download(now, mux, src, method).is_ok(),
        };
        if started {
            c.active = Some(id);
            ReqState::Active {
                progress,
                entry,
                node,
                channel: ch,
            }
        } else {
            ReqState::Done(Err(Box::new(SdoError {
                node,
                entry,
                name: None,
                kind: SdoErrorKind::Busy,
            })))
        }
    }

    /// Feeds one received frame.
    pub(crate) fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.set_now(now);
        let Some(raw) = frame.cob_id() else {
            // 29-bit identifiers: only PDOs configured on them.
            if let Some(&node) = self.pdo_routes.get(&frame.id())
                && !frame.is_remote()
            {
                self.handle_tpdo(now, node, None, frame);
            }
            return;
        };
        if raw == LSS_SLAVE_TO_MASTER {
            if let Some(job) = &mut self.lss {
                job.handle_frame(now, frame);
                self.pump_lss();
            }
            let mut data = [0u8; 8];
            data[..frame.data().len()].copy_from_slice(frame.data());
            self.publish(NetworkEvent::Lss { data, at: now });
            return;
        }
        if !self.sdo_routes.is_empty()
            && let Some(&(node, ch)) = self.sdo_routes.get(&frame.id())
        {
            self.handle_sdo_response(now, node, ch, frame);
            return;
        }
        let cob = CobId::classify(raw);
        match cob {
            Some(CobId {
                function: FunctionCode::SdoTx,
                node: Some(node),
            }) if !frame.is_remote() => {
                self.handle_sdo_response(now, node, 0, frame);
            }
            Some(CobId {
                function: FunctionCode::NmtErrorControl,
                node: Some(node),
            }) => {
                if !frame.is_remote() && frame.data() == [0] {
                    *self.boots.entry(node).or_default() += 1;
                    self.end_transfers_on_boot(node);
                }
                // A guarded node's answers go to the guarding master alone (their toggle bit
                // is no heartbeat state); every other node's frames to the heartbeat consumer,
                // which reports boot-ups and state changes of unmonitored nodes too.
                let guarded = self.guarding.handle_frame(now, frame).unwrap_or(false);
                self.drain_guarding();
                if !guarded {
                    let _ = self.heartbeat.handle_frame(now, frame);
                    self.drain_heartbeat();
                }
            }
            Some(CobId {
                function: FunctionCode::Emcy,
                node: Some(_),
            }) => {
                let _ = self.emcy.handle_frame(now, frame);
                while let Some(ev) = self.emcy.poll_event() {
                    self.publish(NetworkEvent::Emcy(ev));
                }
            }
            _ if frame.is_remote() => {}
            // A TPDO configured on another COB-ID than its predefined one.
            _ if !self.pdo_routes.is_empty() && self.pdo_routes.contains_key(&frame.id()) => {
                if let Some(&node) = self.pdo_routes.get(&frame.id()) {
                    self.handle_tpdo(now, node, None, frame);
                }
            }
            Some(CobId {
                function: FunctionCode::Tpdo(n),
                node: Some(node),
            }) => self.handle_tpdo(now, node, Some(n.get()), frame),
            _ => {}
        }
    }

    /// A TPDO of `node` (`predefined`: its number in the predefined connection set, when it
    /// came on such a COB-ID): the raw event, then the values decoded through the mirror.
    fn handle_tpdo(
        &mut self,
        now: Instant,
        node: NodeId,
        predefined: Option<u8>,
        frame: &CanFrame,
    ) {
        let data = PdoData::new(frame.data());
        let mut number = None;
        let mut decoded = false;
        if let Some(slot) = self.nodes.get_mut(&node)
            && let Some(pdos) = &mut slot.pdo
            && pdos
                .engine
                .handle_frame(now, frame, &mut canola_pdo::NullStore)
        {
            // The mirror arms no receive deadlines (see `pdo_glue::mirrored`), so a reception
            // leaves the engine's timers as they were.
            while let Some(ev) = pdos.engine.poll_event() {
                match ev {
                    canola_pdo::Event::Received { pdo, .. } => {
                        let Some(n) = number.or_else(|| pdos.tpdo_number(pdo)).or(predefined)
                        else {
                            continue;
                        };
                        number = Some(n);
                        if pdos.received_values(pdo, &mut self.pdo_scratch) {
                            decoded = true;
                            let seen = PdoReceived {
                                node,
                                number: n,
                                data: &data,
                                values: &self.pdo_scratch,
                                at: now,
                            };
                            for (_, f) in &mut self.pdo_callbacks {
                                f(&seen);
                            }
                            if let Some((last, others)) = self.pdo_subs.split_last_mut() {
                                for s in others {
                                    s.push(node, n, data, now, &self.pdo_scratch);
                                }
                                if self.subs.is_empty() {
                                    // No event takes the values: the last subscriber does,
                                    // without a copy of each (the scratch keeps its room).
                                    last.push_moving(node, n, data, now, &mut self.pdo_scratch);
                                    continue;
                                }
                                last.push(node, n, data, now, &self.pdo_scratch);
                            }
                            if !self.subs.is_empty() {
                                // The event takes the values as they are (no copy of each
                                // value); the scratch starts again with room for as many.
                                let room = self.pdo_scratch.len();
                                let values = core::mem::replace(
                                    &mut self.pdo_scratch,
                                    Vec::with_capacity(room),
                                );
                                let ev = NetworkEvent::PdoValues {
                                    node,
                                    number: n,
                                    data,
                                    values,
                                    at: now,
                                };
                                self.subs.deliver(ev);
                            }
                        }
                    }
                    canola_pdo::Event::LengthError { pdo, .. }
                    | canola_pdo::Event::LengthExceeded { pdo, .. } => {
                        number = number.or_else(|| pdos.tpdo_number(pdo));
                    }
                    _ => {}
                }
            }
        }
        if decoded {
            return;
        }
        let Some(number) = number.or(predefined) else {
            return;
        };
        let seen = PdoReceived {
            node,
            number,
            data: &data,
            values: &[],
            at: now,
        };
        for (_, f) in &mut self.pdo_callbacks {
            f(&seen);
        }
        for s in &mut self.pdo_subs {
            s.push(node, number, data, now, &[]);
        }
        self.publish(NetworkEvent::Pdo {
            node,
            number,
            data,
            at: now,
        });
    }

    /// A response on an SDO channel's server → client identifier.
    fn handle_sdo_response(&mut self, now: Instant, node: NodeId, ch: usize, frame: &CanFrame) {
        if let Some(c) = self
            .nodes
            .get_mut(&node)
            .and_then(|s| s.channels.get_mut(ch))
        {
            c.answered |= c.active.is_some();
            c.client.handle_response(now, frame.data());
            self.pump_channel(node, ch);
        }
    }

    fn drain_heartbeat(&mut self) {
        while let Some(ev) = self.heartbeat.poll_event() {
            self.publish(NetworkEvent::Heartbeat(ev));
        }
    }

    pub(crate) fn handle_bus_event(&mut self, ev: BusEvent) {
        self.publish(NetworkEvent::Bus(ev));
    }

    /// Fires every timer that is due at `now`.
    pub(crate) fn handle_timeout(&mut self, now: Instant) {
        self.set_now(now);
        if is_due(self.heartbeat.poll_timeout(), now) {
            self.heartbeat.handle_timeout(now);
            self.drain_heartbeat();
        }
        if is_due(self.guarding.poll_timeout(), now) {
            self.guarding.handle_timeout(now);
            self.drain_guarding();
        }
        if let Some(job) = &mut self.lss
            && is_due(job.poll_timeout(), now)
        {
            job.handle_timeout(now);
            self.pump_lss();
        }
        if let Some(sync) = &mut self.sync
            && is_due(sync.poll_timeout(), now)
        {
            sync.handle_timeout(now);
            while let Some(f) = self.sync.as_mut().and_then(|s| s.poll_transmit_frame()) {
                // The master's own SYNC drives the synchronous RPDOs it transmits: they follow
                // the SYNC frame on the bus (the SYNC goes to the front of the queue).
                let counter = f.data().first().copied();
                self.queue_periodic(f, true);
                for pdos in self.nodes.values_mut().filter_map(|s| s.pdo.as_mut()) {
                    if !pdos.rpdos.is_empty() {
                        pdos.engine.handle_sync(now, counter, &mut pdos.image);
                        Self::drain_pdos(pdos, &mut self.tx, &mut self.pdo_next);
                    }
                }
            }
        }
        if is_due(self.pdo_next, now) {
            let mut next = None;
            for pdos in self.nodes.values_mut().filter_map(|s| s.pdo.as_mut()) {
                if is_due(pdos.next, now) {
                    pdos.engine.handle_timeout(now, &mut pdos.image);
                }
                Self::drain_pdos(pdos, &mut self.tx, &mut next);
            }
            self.pdo_next = next;
        }
        let mut due = Vec::new();
        // A retain by hand: `Vec::retain` costs several times this loop over the one or two
        // busy channels there mostly are.
        let mut i = 0;
        while let Some(&(node, ch)) = self.sdo_busy.get(i) {
            let keep = self
                .nodes
                .get(&node)
                .and_then(|s| s.channels.get(ch))
                .is_some_and(|c| {
                    let timer = c.client.poll_timeout();
                    if is_due(timer, now) || (c.has_waiting() && c.ready_at <= now) {
                        due.push((node, ch));
                    }
                    // Idle: nothing queued or running, no timer. It comes back with its next
                    // request.
                    timer.is_some()
                        || c.active.is_some()
                        || !c.queue.is_empty()
                        || !c.client.is_idle()
                });
            if keep {
                i += 1;
            } else {
                self.sdo_busy.remove(i);
            }
        }
        for (node, ch) in due {
            if let Some(c) = self
                .nodes
                .get_mut(&node)
                .and_then(|s| s.channels.get_mut(ch))
                && is_due(c.client.poll_timeout(), now)
            {
                c.client.handle_timeout(now);
            }
            self.pump_channel(node, ch);
        }
    }

    /// [`handle_timeout`](Self::handle_timeout) then [`poll_timeout`](Self::poll_timeout): the
    /// earliest instant a timer wants next. Mostly nothing is due, and one look at the
    /// timers then does for both (everything `handle_timeout` fires is a deadline
    /// `poll_timeout` reports).
    pub(crate) fn handle_timeout_and_poll(&mut self, now: Instant) -> Option<Instant> {
        self.set_now(now);
        let next = self.poll_timeout();
        if !is_due(next, now) {
            return next;
        }
        self.handle_timeout(now);
        self.poll_timeout()
    }

    /// The earliest instant a timer wants [`handle_timeout`](Self::handle_timeout).
    pub(crate) fn poll_timeout(&self) -> Option<Instant> {
        let mut t = self.heartbeat.poll_timeout();
        let mut consider = |x: Option<Instant>| {
            if let Some(x) = x {
                t = Some(t.map_or(x, |t| t.min(x)));
            }
        };
        consider(self.sync.as_ref().and_then(|s| s.poll_timeout()));
        consider(self.guarding.poll_timeout());
        consider(self.lss.as_ref().and_then(|j| j.poll_timeout()));
        consider(self.pdo_next);
        let busy = self
            .sdo_busy
            .iter()
            .filter_map(|(n, ch)| self.nodes.get(n).and_then(|s| s.channels.get(*ch)));
        for c in busy {
            consider(c.client.poll_timeout());
            if c.has_waiting() {
                consider(Some(c.ready_at));
            }
        }
        t
    }

    /// The sizes of the tables (see [`Occupancy`]).
    pub(crate) fn occupancy(&self) -> Occupancy {
        let channels = || self.nodes.values().flat_map(|s| &s.channels);
        Occupancy {
            nodes: self.nodes.len(),
            sdo_channels: channels().count(),
            requests: self.requests.len(),
            queued_requests: channels().map(|c| c.queue.len()).sum(),
            unsent_frames: self.tx.len(),
            boot_counts: self.boots.len(),
            subscribers: self.subs.channels.len(),
        }
    }

    /// Moves every frame waiting to be sent, in order, to the end of `out`.
    pub(crate) fn take_transmit(&mut self, out: &mut VecDeque<Outgoing>) {
        // Mostly empty (asked twice a step).
        if !self.tx.is_empty() {
            crate::move_all(&mut self.tx, out);
        }
    }

    /// Puts back frames the transport did not take (its transmit queue was full), ahead of
    /// anything queued since, so the order on the bus stays the order queued.
    pub(crate) fn unsend(&mut self, rest: impl DoubleEndedIterator<Item = Outgoing>) {
        for o in rest.rev() {
            self.tx.push_front(o);
        }
    }

    /// Fills in the object name of an error from the node's dictionary.
    pub(crate) fn name_error(&self, mut e: SdoError) -> SdoError {
        if e.name.is_none() {
            e.name = self.object_name(e.node, e.entry);
        }
        e
    }
}
