//! The sans-IO heart of the master: every per-node protocol machine, the COB-ID router and the
//! request table, with no I/O and no clock.
//!
//! [`Network`](crate::Network) wraps one `Core` in a mutex and drives it from a transport
//! (STYLE habit 8: the blocking and async APIs are loops around this one core). The core follows
//! the sans-IO call order of the protocol crates: [`Core::handle_frame`] for every received frame,
//! [`Core::handle_timeout`] when [`Core::poll_timeout`] has passed, then drain
//! [`Core::poll_transmit`].
//!
//! Routing (CiA 301 predefined connection set, §7.3.5):
//! * 0x581..=0x5FF SDO responses → the node's SDO client (`canopen-sdo`);
//! * 0x701..=0x77F error control → the heartbeat consumer (`canopen-nmt`);
//! * 0x081..=0x0FF EMCY → the EMCY consumer (`canopen-nmt`);
//! * TPDO1..4 → PDO events;
//! * 0x7E4 LSS responses → LSS events.
//!
//! SDO requests queue per node and run one at a time per node; different nodes run in
//! parallel. A request is identified by a [`RequestId`]; its result is only ever stored under
//! that id, and the SDO client ignores responses whose multiplexer is not the running
//! transfer's, so a late answer to a cancelled request never completes another one.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::io::Write;
use std::sync::Arc;
use std::sync::mpsc;

use can_frame::cob::{FunctionCode, LSS_SLAVE_TO_MASTER};
use can_frame::{CanFrame, CanId, CobId, Duration, Instant, NodeId};
use canopen_nmt::{
    CommandSpecifier, EmcyConsumer, EmcyEvent, GuardingEvent, GuardingMaster, HeartbeatConsumer,
    HeartbeatEvent, NmtCommand, NmtState, NmtTarget, SyncConfig, SyncProducer,
};
use canopen_od::ObjectDictionary;
use canopen_sdo::{AbortCode, Client, ClientConfig, Event as SdoEvent, Method, Multiplexer};

use crate::error::{SdoError, SdoErrorKind};
use crate::transport::BusEvent;

/// An object address: index and sub-index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Entry {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
}

impl Entry {
    /// The entry `index:sub`.
    pub const fn new(index: u16, sub: u8) -> Self {
        Self { index, sub }
    }
}

impl From<(u16, u8)> for Entry {
    fn from((index, sub): (u16, u8)) -> Self {
        Self { index, sub }
    }
}

impl core::fmt::Display for Entry {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:#06x}:{:02x}", self.index, self.sub)
    }
}

/// Identifies one SDO request for its whole life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestId(pub(crate) u64);

/// How far a transfer is, for progress bars.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TransferProgress {
    /// The node.
    pub node: NodeId,
    /// The object.
    pub entry: Entry,
    /// Bytes done.
    pub done: u64,
    /// Total bytes, when known.
    pub total: Option<u64>,
}

/// A progress callback.
pub type ProgressFn = Box<dyn FnMut(TransferProgress) + Send>;

/// What a successful request produced.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Completion {
    /// An upload into memory finished.
    Data(Vec<u8>),
    /// An upload into a writer finished; so many bytes were written.
    Streamed(u64),
    /// A download finished.
    Written,
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
    /// A transmit PDO from a node.
    Pdo {
        /// The producer (from the predefined connection set).
        node: NodeId,
        /// TPDO number 1..=4.
        number: u8,
        /// The PDO data.
        data: Vec<u8>,
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
        /// The mapped objects and their values, in mapping order.
        values: Vec<(Entry, canopen_pdo::Value)>,
        /// Reception time.
        at: Instant,
    },
    /// A bus event from the transport.
    Bus(BusEvent),
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

impl canopen_sdo::Sink for UpSink {
    fn write(&mut self, data: &[u8]) -> Result<(), canopen_sdo::Full> {
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
                    Err(canopen_sdo::Full)
                }
            },
        }
    }
}

/// A download's bytes.
pub(crate) struct DownSource(pub(crate) Vec<u8>);

impl canopen_sdo::Source for DownSource {
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
    pub(crate) entry: Entry,
    pub(crate) op: Op,
    pub(crate) method: Method,
    pub(crate) timeout: Duration,
    pub(crate) progress: Option<ProgressFn>,
}

enum ReqState {
    Queued(SdoRequest),
    Active {
        progress: Option<ProgressFn>,
        entry: Entry,
        node: NodeId,
    },
    Done(Result<Completion, SdoError>),
}

struct NodeSlot {
    od: Option<Arc<ObjectDictionary>>,
    /// The node's TPDOs mirrored as receive PDOs, with their TPDO numbers.
    pdo: Option<crate::pdo::Mirror>,
    client: Client<UpSink, DownSource>,
    queue: VecDeque<RequestId>,
    active: Option<RequestId>,
    /// The next queued transfer may start at this time (see [`Core::settle`]).
    ready_at: Instant,
}

impl NodeSlot {
    fn new(node: NodeId, od: Option<Arc<ObjectDictionary>>) -> Self {
        Self {
            pdo: od.as_deref().map(|od| crate::pdo::mirror_engine(od, node)),
            od,
            client: Client::new(ClientConfig::default()),
            queue: VecDeque::new(),
            active: None,
            ready_at: Instant::ZERO,
        }
    }
}

/// The abort code sent when a caller cancels a running transfer: "general error" (CiA 301
/// has no dedicated code for a client giving up).
pub const CANCEL_ABORT: AbortCode = AbortCode(0x0800_0000);

/// The master's protocol state. See the module docs for the call order.
pub(crate) struct Core {
    now: Instant,
    nodes: BTreeMap<NodeId, NodeSlot>,
    requests: HashMap<RequestId, ReqState>,
    next_request: u64,
    tx: VecDeque<CanFrame>,
    heartbeat: HeartbeatConsumer,
    guarding: Box<GuardingMaster>,
    emcy: EmcyConsumer,
    sync: Option<SyncProducer>,
    states: BTreeMap<NodeId, NmtState>,
    subscribers: Vec<mpsc::Sender<NetworkEvent>>,
    /// Quiet time between two transfers to the same node, so that a late or duplicated
    /// response to the finished transfer reaches an idle client (which ignores it) rather
    /// than the next transfer.
    pub(crate) settle: Duration,
    lss: Option<Box<dyn crate::lss::LssJob>>,
    lss_result: Option<Result<crate::lss::LssOutcome, canopen_lss::LssError>>,
}

fn sdo_tx_frame(node: NodeId, data: [u8; 8]) -> CanFrame {
    // 0x600 + node is at most 0x67F, always a valid 11-bit identifier.
    let id = CanId::standard(FunctionCode::SdoRx.cob_id(node)).unwrap_or(CanId::Standard(
        can_frame::StandardId::new(0x600).unwrap_or(ZERO_ID),
    ));
    CanFrame::from_array(id, data)
}

const ZERO_ID: can_frame::StandardId = match can_frame::StandardId::new(0) {
    Ok(id) => id,
    Err(_) => panic!("0 is a valid identifier"),
};

impl Core {
    pub(crate) fn new() -> Self {
        Self {
            now: Instant::ZERO,
            nodes: BTreeMap::new(),
            requests: HashMap::new(),
            next_request: 1,
            tx: VecDeque::new(),
            heartbeat: HeartbeatConsumer::new(),
            guarding: Box::new(GuardingMaster::new()),
            emcy: EmcyConsumer::new(),
            sync: None,
            states: BTreeMap::new(),
            subscribers: Vec::new(),
            settle: Duration::from_millis(1),
            lss: None,
            lss_result: None,
        }
    }

    pub(crate) fn set_now(&mut self, now: Instant) {
        self.now = self.now.max(now);
    }

    pub(crate) fn add_node(&mut self, node: NodeId, od: Option<Arc<ObjectDictionary>>) {
        match self.nodes.get_mut(&node) {
            Some(slot) => {
                if let Some(od) = od {
                    slot.pdo = Some(crate::pdo::mirror_engine(&od, node));
                    slot.od = Some(od);
                }
            }
            None => {
                self.nodes.insert(node, NodeSlot::new(node, od));
            }
        }
    }

    pub(crate) fn dictionary(&self, node: NodeId) -> Option<Arc<ObjectDictionary>> {
        self.nodes.get(&node).and_then(|s| s.od.clone())
    }

    pub(crate) fn object_name(&self, node: NodeId, entry: Entry) -> Option<String> {
        let od = self.nodes.get(&node)?.od.as_ref()?;
        let obj = od.get(entry.index)?;
        match obj.sub(entry.sub) {
            Some(sub) if !obj.is_simple() => Some(format!("{} / {}", obj.name, sub.name)),
            _ => Some(obj.name.to_string()),
        }
    }

    pub(crate) fn subscribe(&mut self) -> mpsc::Receiver<NetworkEvent> {
        let (tx, rx) = mpsc::channel();
        self.subscribers.push(tx);
        rx
    }

    fn publish(&mut self, ev: NetworkEvent) {
        self.subscribers.retain(|s| s.send(ev.clone()).is_ok());
    }

    pub(crate) fn last_state(&self, node: NodeId) -> Option<NmtState> {
        self.states.get(&node).copied()
    }

    /// Queues an NMT command (COB-ID 0x000).
    pub(crate) fn nmt(&mut self, cmd: CommandSpecifier, target: NmtTarget) {
        self.tx.push_back(NmtCommand::new(cmd, target).to_frame());
    }

    pub(crate) fn send_raw(&mut self, frame: CanFrame) {
        self.tx.push_back(frame);
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
            self.tx.push_back(f);
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

    /// The master's view of a node's TPDO `number` (1-based) after a remap: received frames
    /// decode with `config` from now on.
    pub(crate) fn mirror_tpdo(&mut self, node: NodeId, number: u8, config: canopen_pdo::PdoConfig) {
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let (engine, numbers) = slot
            .pdo
            .get_or_insert_with(|| (Box::new(crate::pdo::PdoEngine::new()), Vec::new()));
        match numbers.iter().find(|(n, _)| *n == number) {
            Some((_, id)) => {
                let _ = engine.set_rpdo(*id, config);
            }
            None => {
                if let Ok(id) = engine.add_rpdo(config) {
                    numbers.push((number, id));
                }
            }
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
    ) -> Option<Result<crate::lss::LssOutcome, canopen_lss::LssError>> {
        self.lss_result.take()
    }

    fn pump_lss(&mut self) {
        if let Some(job) = &mut self.lss {
            while let Some(f) = job.poll_transmit() {
                self.tx.push_back(f);
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
        self.add_node(node, None);
        self.requests.insert(id, ReqState::Queued(req));
        if let Some(slot) = self.nodes.get_mut(&node) {
            slot.queue.push_back(id);
        }
        self.pump_node(node);
        id
    }

    /// Whether the request ended (and its result waits to be taken).
    pub(crate) fn is_done(&self, id: RequestId) -> bool {
        matches!(self.requests.get(&id), Some(ReqState::Done(_)) | None)
    }

    /// Takes a finished request's result. `None` while it runs.
    pub(crate) fn take_result(&mut self, id: RequestId) -> Option<Result<Completion, SdoError>> {
        match self.requests.get(&id) {
            Some(ReqState::Done(_)) => match self.requests.remove(&id) {
                Some(ReqState::Done(r)) => Some(r),
                _ => None,
            },
            Some(_) => None,
            None => Some(Err(SdoError {
                node: NodeId::MIN,
                entry: Entry::new(0, 0),
                name: None,
                kind: SdoErrorKind::Cancelled,
            })),
        }
    }

    /// Cancels a request: a queued one is dropped, a running one is aborted on the bus (the
    /// node is free for the next request at once). Its result is discarded.
    /// The node and object a request in flight is for.
    pub(crate) fn request_target(&self, id: RequestId) -> Option<(NodeId, Entry)> {
        match self.requests.get(&id)? {
            ReqState::Queued(req) => Some((req.node, req.entry)),
            ReqState::Active { node, entry, .. } => Some((*node, *entry)),
            ReqState::Done(_) => None,
        }
    }

    pub(crate) fn cancel(&mut self, id: RequestId) {
        let Some(state) = self.requests.remove(&id) else {
            return;
        };
        match state {
            ReqState::Queued(req) => {
                if let Some(slot) = self.nodes.get_mut(&req.node) {
                    slot.queue.retain(|q| *q != id);
                }
            }
            ReqState::Active { node, .. } => {
                let now = self.now;
                if let Some(slot) = self.nodes.get_mut(&node) {
                    slot.client.abort(now, CANCEL_ABORT);
                }
                self.pump_node(node);
            }
            ReqState::Done(_) => {}
        }
    }

    /// Sends what the node's client has, completes its finished transfer, starts the next.
    fn pump_node(&mut self, node: NodeId) {
        // Each turn either finishes a transfer or starts one, so the loop ends when the queue
        // is empty or a transfer runs.
        loop {
            let Some(slot) = self.nodes.get_mut(&node) else {
                return;
            };
            while let Some(data) = slot.client.poll_transmit() {
                self.tx.push_back(sdo_tx_frame(node, data));
            }
            if let (Some(active), Some(p)) = (slot.active, slot.client.progress())
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
            if let Some(ev) = slot.client.poll_event() {
                let finished = slot.active.take();
                let result = match ev {
                    SdoEvent::Uploaded { sink, .. } => match sink {
                        UpSink::Mem(v) => Ok(Completion::Data(v)),
                        UpSink::Stream { written, .. } => Ok(Completion::Streamed(written)),
                    },
                    SdoEvent::Downloaded { .. } => Ok(Completion::Written),
                    SdoEvent::Failed { error, buffer } => Err(match buffer {
                        canopen_sdo::Buffer::Sink(UpSink::Stream { error: Some(e), .. }) => {
                            SdoErrorKind::Io(e.to_string())
                        }
                        _ => SdoErrorKind::Transfer(error.kind),
                    }),
                };
                // A cancelled request is no longer in the table: its result is dropped here.
                if let Some(id) = finished
                    && let Some(ReqState::Active { entry, .. }) = self.requests.get(&id)
                {
                    let entry = *entry;
                    let result = result.map_err(|kind| SdoError {
                        node,
                        entry,
                        name: None,
                        kind,
                    });
                    self.requests.insert(id, ReqState::Done(result));
                }
                slot.ready_at = self.now + self.settle;
                continue;
            }
            if slot.active.is_some() || !slot.client.is_idle() || slot.ready_at > self.now {
                return;
            }
            let Some(next) = slot.queue.pop_front() else {
                return;
            };
            let Some(ReqState::Queued(req)) = self.requests.remove(&next) else {
                continue;
            };
            let SdoRequest {
                entry,
                op,
                method,
                timeout,
                progress,
                ..
            } = req;
            let cfg = slot.client.config().with_timeout(timeout);
            slot.client.set_config(cfg);
            let mux = Multiplexer::new(entry.index, entry.sub);
            let now = self.now;
            let started = match op {
                Op::Upload(sink) => slot.client.start_upload(now, mux, sink, method).is_ok(),
                Op::Download(src) => slot.client.start_download(now, mux, src, method).is_ok(),
            };
            let state = if started {
                slot.active = Some(next);
                ReqState::Active {
                    progress,
                    entry,
                    node,
                }
            } else {
                ReqState::Done(Err(SdoError {
                    node,
                    entry,
                    name: None,
                    kind: SdoErrorKind::Busy,
                }))
            };
            self.requests.insert(next, state);
        }
    }

    /// Feeds one received frame.
    pub(crate) fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.set_now(now);
        let Some(raw) = frame.cob_id() else {
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
        let Some(cob) = CobId::classify(raw) else {
            return;
        };
        let Some(node) = cob.node else {
            return;
        };
        match cob.function {
            FunctionCode::SdoTx => {
                if let Some(slot) = self.nodes.get_mut(&node) {
                    slot.client.handle_response(now, frame.data());
                    self.pump_node(node);
                }
            }
            FunctionCode::NmtErrorControl => {
                let previous = self.states.get(&node).copied();
                let state = frame
                    .data()
                    .first()
                    .filter(|_| !frame.is_remote() && frame.data().len() == 1)
                    .map(|b| NmtState::from_u8(b & 0x7F));
                if let Some(s) = state {
                    self.states.insert(node, s);
                }
                let guarded = self.guarding.handle_frame(now, frame).unwrap_or(false);
                self.drain_guarding();
                let monitored = self.heartbeat.handle_frame(now, frame).unwrap_or(false) || guarded;
                self.drain_heartbeat();
                // Nodes nobody monitors still report boot-up and state changes.
                match state {
                    Some(_) if monitored => {}
                    Some(NmtState::BootUp) => {
                        self.publish(NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node }))
                    }
                    Some(to) if previous != Some(to) && previous != Some(NmtState::BootUp) => self
                        .publish(NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged {
                            node,
                            from: previous,
                            to,
                        })),
                    Some(to) if previous == Some(NmtState::BootUp) => {
                        self.publish(NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged {
                            node,
                            from: None,
                            to,
                        }))
                    }
                    _ => {}
                }
            }
            FunctionCode::Emcy => {
                let _ = self.emcy.handle_frame(now, frame);
                while let Some(ev) = self.emcy.poll_event() {
                    self.publish(NetworkEvent::Emcy(ev));
                }
            }
            FunctionCode::Tpdo(n) if !frame.is_remote() => {
                self.publish(NetworkEvent::Pdo {
                    node,
                    number: n.get(),
                    data: frame.data().to_vec(),
                    at: now,
                });
                let mut decoded = Vec::new();
                if let Some(slot) = self.nodes.get_mut(&node)
                    && let Some((engine, numbers)) = &mut slot.pdo
                    && engine.handle_frame(now, frame, &mut canopen_pdo::NullStore)
                {
                    while let Some(ev) = engine.poll_event() {
                        if let canopen_pdo::Event::Received { pdo, .. } = ev
                            && let Some(values) = engine.received(pdo)
                        {
                            let number = numbers
                                .iter()
                                .find(|(_, id)| *id == pdo)
                                .map_or(n.get(), |(num, _)| *num);
                            let values = values
                                .iter()
                                .map(|(obj, v)| {
                                    let a = obj.addr();
                                    (Entry::new(a.index, a.subindex), v)
                                })
                                .collect();
                            decoded.push((number, values));
                        }
                    }
                }
                for (number, values) in decoded {
                    self.publish(NetworkEvent::PdoValues {
                        node,
                        number,
                        values,
                        at: now,
                    });
                }
            }
            _ => {}
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
        if self.heartbeat.poll_timeout().is_some_and(|t| t <= now) {
            self.heartbeat.handle_timeout(now);
            self.drain_heartbeat();
        }
        if self.guarding.poll_timeout().is_some_and(|t| t <= now) {
            self.guarding.handle_timeout(now);
            self.drain_guarding();
        }
        if let Some(job) = &mut self.lss
            && job.poll_timeout().is_some_and(|t| t <= now)
        {
            job.handle_timeout(now);
            self.pump_lss();
        }
        if let Some(sync) = &mut self.sync
            && sync.poll_timeout().is_some_and(|t| t <= now)
        {
            sync.handle_timeout(now);
            while let Some(f) = sync.poll_transmit_frame() {
                self.tx.push_back(f);
            }
        }
        let due: Vec<NodeId> = self
            .nodes
            .iter()
            .filter(|(_, s)| {
                s.client.poll_timeout().is_some_and(|t| t <= now)
                    || (s.active.is_none() && !s.queue.is_empty() && s.ready_at <= now)
            })
            .map(|(n, _)| *n)
            .collect();
        for node in due {
            if let Some(slot) = self.nodes.get_mut(&node)
                && slot.client.poll_timeout().is_some_and(|t| t <= now)
            {
                slot.client.handle_timeout(now);
            }
            self.pump_node(node);
        }
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
        for slot in self.nodes.values() {
            consider(slot.client.poll_timeout());
            if slot.active.is_none() && !slot.queue.is_empty() {
                consider(Some(slot.ready_at));
            }
        }
        t
    }

    /// The next frame to send.
    pub(crate) fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.tx.pop_front()
    }

    /// Fills in the object name of an error from the node's dictionary.
    pub(crate) fn name_error(&self, mut e: SdoError) -> SdoError {
        if e.name.is_none() {
            e.name = self.object_name(e.node, e.entry);
        }
        e
    }
}
