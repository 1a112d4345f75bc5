//! The sans-IO heart of the master: every per-node protocol machine, the COB-ID router and the
//! request table, with no I/O and no clock.
//!
//! [`Network`](crate::Network) wraps one `Core` in a mutex and drives it from a transport
//! (the blocking and async APIs are loops around this one core). The core follows
//! the sans-IO call order of the protocol crates: [`Core::handle_frame`] for every received frame,
//! [`Core::handle_timeout`] when [`Core::poll_timeout`] has passed, then drain
//! [`Core::take_transmit`].
//!
//! Routing (CiA 301 predefined connection set, §7.3.5):
//! * 0x581..=0x5FF SDO responses → the node's SDO client (`canola-sdo`);
//! * 0x701..=0x77F error control → the heartbeat consumer or the guarding master
//!   (`canola-nmt`), boot-ups counted (`life`);
//! * 0x081..=0x0FF EMCY → the EMCY consumer (`canola-nmt`), the latest kept per node (`life`);
//! * TPDO1..4 → PDO events; a TPDO the node was configured to send on another COB-ID
//!   (learnt from reading or saving its PDO parameters) is routed by that COB-ID;
//! * 0x7E4 LSS responses → LSS events.
//!
//! SDO requests queue per node and run one at a time per node; different nodes run in
//! parallel. A request is identified by a [`RequestId`]; its result is only ever stored under
//! that id, and the SDO client ignores responses whose multiplexer is not the running
//! transfer's, so a late answer to a cancelled request never completes another one.
//!
//! Who owns what: this file the `Core` state, the routing of received frames, the timers and
//! the transmit queue; `life` the boot-up, EMCY and sign-of-life bookkeeping and the NMT
//! commands; `sdo` and `sdo_client` the request table and the SDO channels; `pdo`,
//! `pdo_routes` and `mpdo` the PDOs; `usdo` the USDO client; `lss` the LSS jobs; `events` and
//! `subscribers` what the master publishes and to whom; `nodes` the per-node slots.

pub(crate) mod events;
mod life;
pub(crate) mod lss;
mod mpdo;
mod nodes;
pub(crate) mod pdo;
mod pdo_routes;
mod sdo;
mod sdo_client;
mod subscribers;
pub(crate) mod usdo;

#[cfg(feature = "tokio")]
use events::EventSink;
pub use events::{
    CANCEL_ABORT, NetworkEvent, Occupancy, PdoCallbackId, PdoData, PdoReceived, ProgressFn,
    TransferProgress,
};
pub(crate) use events::{Completion, RequestId};
pub(crate) use sdo::{
    DownSource, Op, Outcome, Outgoing, Request, SdoRequest, Taken, UpSink, UsdoOp, UsdoRequest,
};

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::Arc;
use std::sync::mpsc;

use canola_frame::cob::{FunctionCode, LSS_SLAVE_TO_MASTER};
use canola_frame::{CanFrame, CanId, CobId, Duration, Instant, NodeId, is_due};
use canola_nmt::{EmcyConsumer, GuardingMaster, HeartbeatConsumer, SyncConfig, SyncProducer};
use canola_od::{ObjectAddress, ObjectDictionary, Value};

use crate::pdo_subscriber::PdoPublisher;
use crate::transport::BusEvent;
use events::PdoCallback;
use nodes::{NodeSlot, NodeTable};
use sdo::RequestTable;
use subscribers::Subscribers;

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
    /// Per node, the boot-ups already accounted for: those before `add_node`, before the last
    /// NMT command to it, or consumed by a wait. A wait returns for a later one, whichever
    /// handle waits (a handle made after the boot-up arrived included).
    boots_taken: BTreeMap<NodeId, u64>,
    /// Each node's latest EMCY (one per node: bounded by the node-IDs).
    emcys: BTreeMap<NodeId, canola_nmt::EmcyEvent>,
    /// Per node, how many state changes and recoveries its heartbeat or node guarding
    /// reported: a wait for a sign of life compares counts.
    life_reports: BTreeMap<NodeId, u64>,
    subs: Subscribers,
    /// Quiet time between two transfers to the same node, so that a late or duplicated
    /// response to the finished transfer reaches an idle client (which ignores it) rather
    /// than the next transfer.
    pub(crate) settle: Duration,
    lss: Option<Box<dyn crate::machine::lss::LssJob>>,
    lss_result: Option<Result<crate::machine::lss::LssOutcome, canola_lss::LssError>>,
    /// Response COB-IDs of the SDO channels opened on other than the default identifiers,
    /// with their node and channel index (default channels route by function code).
    sdo_routes: HashMap<CanId, (NodeId, usize)>,
    /// Nodes' TPDOs configured on COB-IDs other than their predefined ones, by COB-ID.
    pdo_routes: HashMap<CanId, NodeId>,
    /// COB-IDs the master takes MPDOs on (see `machine::mpdo`).
    mpdo_routes: HashMap<CanId, mpdo::MpdoRoute>,
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
    /// The USDO client (CANopen FD) and its requests.
    usdo: Box<usdo::UsdoState>,
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
            boots_taken: BTreeMap::new(),
            emcys: BTreeMap::new(),
            life_reports: BTreeMap::new(),
            subs: Subscribers::default(),
            settle: Duration::from_millis(1),
            lss: None,
            lss_result: None,
            sdo_routes: HashMap::new(),
            pdo_routes: HashMap::new(),
            mpdo_routes: HashMap::new(),
            pdo_next: None,
            sdo_busy: Vec::new(),
            pdo_callbacks: Vec::new(),
            next_callback: 0,
            pdo_scratch: Vec::new(),
            pdo_subs: Vec::new(),
            usdo: Box::new(usdo::UsdoState::new()),
        }
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
                        .get_or_insert_with(crate::machine::pdo::NodePdos::new)
                        .mirror_dictionary(&od, node);
                    slot.od = Some(od);
                }
            }
            None => {
                self.nodes.insert(node, NodeSlot::new(node, od));
                // Boot-ups count from here.
                self.take_boots(node, self.boot_count(node));
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
        self.nodes.get(&node)?.od.as_ref()?.display_name(entry)
    }

    pub(crate) fn subscribe(&mut self) -> mpsc::Receiver<NetworkEvent> {
        let (tx, rx) = mpsc::channel();
        self.subs.channels.push(tx);
        rx
    }

    /// Adds a subscriber that takes events by reference (see [`EventSink`]).
    #[cfg(feature = "tokio")]
    pub(crate) fn add_sink(&mut self, sink: Box<dyn EventSink>) {
        self.subs.sinks.push(sink);
    }

    pub(crate) fn publish(&mut self, ev: NetworkEvent) {
        self.count_life_report(&ev);
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

    /// The time of the latest frame or timer the core was given.
    pub(crate) fn now(&self) -> Instant {
        self.now
    }

    pub(crate) fn send_raw(&mut self, frame: CanFrame) {
        self.queue(frame);
    }

    fn queue(&mut self, frame: CanFrame) {
        self.tx.push_back(Outgoing {
            frame: frame.into(),
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
            frame: frame.into(),
            transfer: None,
        };
        if urgent {
            self.tx.push_front(o);
        } else {
            self.tx.push_back(o);
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

    /// Starts an LSS job (replacing a running one).
    pub(crate) fn start_lss(&mut self, job: Box<dyn crate::machine::lss::LssJob>) {
        self.lss_result = None;
        self.lss = Some(job);
        self.pump_lss();
    }

    pub(crate) fn take_lss_result(
        &mut self,
    ) -> Option<Result<crate::machine::lss::LssOutcome, canola_lss::LssError>> {
        self.lss_result.take()
    }

    fn pump_lss(&mut self) {
        if let Some(job) = &mut self.lss {
            while let Some(f) = job.poll_transmit() {
                self.tx.push_back(Outgoing {
                    frame: f.into(),
                    transfer: None,
                });
            }
            if let Some(r) = job.poll() {
                self.lss_result = Some(r);
                self.lss = None;
            }
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
            }) => self.handle_error_control(now, node, frame),
            Some(CobId {
                function: FunctionCode::Emcy,
                node: Some(_),
            }) => self.handle_emcy(now, frame),
            _ if frame.is_remote() => {}
            _ if !self.mpdo_routes.is_empty() && self.mpdo_routes.contains_key(&frame.id()) => {
                self.handle_mpdo(now, frame);
            }
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

    /// Feeds a bus event; a CAN FD frame goes to the USDO client first (when it is a
    /// response to it), and to the subscribers as every event does.
    pub(crate) fn handle_bus_event(&mut self, ev: BusEvent) {
        if let BusEvent::FdFrame { frame, at } = &ev {
            self.handle_fd_frame(*at, frame);
        }
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
        self.usdo_timeout(now);
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
        // A retain by hand, cheaper than `Vec::retain` over the one or two busy channels there
        // mostly are (see `crates/bench/README.md`, "Figures behind design choices").
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
        consider(self.usdo.poll_timeout());
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
}
