//! The commissioning workflow: find every unconfigured slave, give each a node-ID, store it, and
//! report (CiA 305 Fastscan, configure node-ID and store configuration).
//!
//! Slave by slave, as CiA 305 masters do (CANopenNode's "LSS all nodes", Lely's Fastscan
//! service followed by configure and store):
//! 1. Switch mode global (waiting), so that no slave an earlier session left in configuration
//!    state takes the node-ID meant for another one.
//! 2. Fastscan: the slave it finds enters configuration state, the only one in that state.
//! 3. Configure node-ID: from the table keyed by LSS address if the address is listed (as
//!    Fastscan reports it: parts the scan skips read 0), otherwise the lowest free node-ID of
//!    the pool.
//! 4. Store configuration (if asked).
//! 5. Switch mode global (waiting): the slave makes its new node-ID active (it had none) and
//!    resets its communication. Having a node-ID, it no longer answers Fastscan, so the next
//!    scan (back to 2) finds the next slave.
//!
//! Real slaves answer Fastscan in configuration state too, as long as they have no node-ID, so
//! configuring each slave before the next scan is what keeps it out of that scan. A slave left
//! without a node-ID (none to give, configure node-ID rejected or unanswered) would still
//! answer: from then on every scan is the successor search of [`DiscoverAll`](crate::DiscoverAll),
//! which finds the smallest address above the last one found, so the workflow never finds the
//! same slave twice and always ends.
//!
//! Node-IDs in use: the caller gives the node-IDs already on the bus
//! ([`AssignConfig::in_use`]: from a scan, the boot-ups and heartbeats heard) and reports
//! every boot-up or heartbeat it hears during the run ([`AssignAll::node_id_heard`]). None of
//! them is handed out: the pool skips it (reported once as [`MasterEvent::NodeIdInUse`] and
//! listed in [`AssignReport::skipped`]), a slave whose table entry names one is left
//! unconfigured ([`LssError::NodeIdInUse`]), and a slave configured with a node-ID heard
//! before it became active (the slave makes it active when it goes back to waiting state) is
//! configured again with the next free one. The node-IDs this run gave, heard as their
//! slaves boot, do not count.
//!
//! Failures stay per slave: a slave without a node-ID to give, or one that rejects or ignores
//! configure node-ID, is recorded with its error ([`AssignOutcome::Failed`]) and stays
//! unconfigured, and the workflow goes on with the next. Store configuration failing is
//! recorded as [`AssignOutcome::StoreFailed`]: the node-ID is configured and takes effect when
//! the slave returns to waiting state, but it is not persistent (many slaves do not support
//! store and answer error 1). Only a Fastscan that loses its slave, or more than [`MAX_SLAVES`]
//! slaves, ends the workflow early; the reason is in [`AssignReport::stopped`].

use canola_frame::{Instant, NodeId};
use heapless::Vec;

use crate::address::LssAddress;
use crate::error::{LssError, Service};
use crate::fastscan::{FastscanConfig, MAX_SLAVES, ScanCore, ScanStep};
use crate::machine::{Driven, Io, MasterEvent, Reply, driven_machine, timeout};
use crate::service::MasterConfig;
use crate::wire::{Mode, Request, Response, cs};

/// A set of node-IDs (1..=127), as a bit set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct NodeIdPool(u128);

impl NodeIdPool {
    /// No node-IDs.
    pub const EMPTY: NodeIdPool = NodeIdPool(0);

    /// Every node-ID in `first..=last`.
    pub fn range(first: NodeId, last: NodeId) -> Self {
        let mut p = Self::EMPTY;
        for id in first.get()..=last.get() {
            p.0 |= 1u128 << id;
        }
        p
    }

    /// All node-IDs 1..=127.
    pub fn all() -> Self {
        Self::range(NodeId::MIN, NodeId::MAX)
    }

    /// Adds a node-ID.
    pub fn insert(&mut self, id: NodeId) {
        self.0 |= 1u128 << id.get();
    }

    /// Removes a node-ID (one already in use on the bus, say); returns whether it was there.
    pub fn remove(&mut self, id: NodeId) -> bool {
        let had = self.contains(id);
        self.0 &= !(1u128 << id.get());
        had
    }

    /// Whether `id` is in the pool.
    pub fn contains(&self, id: NodeId) -> bool {
        self.0 & (1u128 << id.get()) != 0
    }

    /// How many node-IDs are left.
    pub fn len(&self) -> usize {
        self.0.count_ones() as usize
    }

    /// Whether none is left.
    pub fn is_empty(&self) -> bool {
        self.0 == 0
    }

    /// The node-IDs in the pool, lowest first.
    pub fn iter(&self) -> impl Iterator<Item = NodeId> + '_ {
        NodeId::all().filter(|id| self.contains(*id))
    }

    /// Takes the lowest node-ID out of the pool.
    pub fn take_lowest(&mut self) -> Option<NodeId> {
        if self.0 == 0 {
            return None;
        }
        let bit = self.0.trailing_zeros();
        self.0 &= !(1u128 << bit);
        NodeId::new(u8::try_from(bit).ok()?).ok()
    }
}

impl FromIterator<NodeId> for NodeIdPool {
    fn from_iter<I: IntoIterator<Item = NodeId>>(iter: I) -> Self {
        let mut p = Self::EMPTY;
        for id in iter {
            p.insert(id);
        }
        p
    }
}

/// The node-IDs to give: a table keyed by LSS address, then a pool.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AssignConfig {
    /// Fastscan timing.
    pub fastscan: FastscanConfig,
    /// Timeouts of configure node-ID and store configuration.
    pub services: MasterConfig,
    /// Node-IDs for slaves not in the table. Table node-IDs are taken out of it at start.
    pub pool: NodeIdPool,
    /// Fixed node-IDs for known slaves.
    pub table: Vec<(LssAddress, NodeId), MAX_SLAVES>,
    /// Node-IDs in use on the bus (found by a scan, boot-ups and heartbeats heard): never
    /// handed out, whether from the pool or the table.
    pub in_use: NodeIdPool,
    /// Send store configuration after each configure node-ID.
    pub store: bool,
}

impl AssignConfig {
    /// Node-IDs from `pool`, stored, default timing.
    pub fn with_pool(pool: NodeIdPool) -> Self {
        Self {
            fastscan: FastscanConfig::default(),
            services: MasterConfig::default(),
            pool,
            table: Vec::new(),
            in_use: NodeIdPool::EMPTY,
            store: true,
        }
    }
}

/// How one slave fared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AssignOutcome {
    /// Node-ID configured (and stored, when the workflow stores).
    Assigned,
    /// Node-ID configured (active once the slave is back in waiting state), but store
    /// configuration failed or is not supported: the node-ID is lost at the slave's next
    /// power-on.
    StoreFailed(LssError),
    /// The slave has no node-ID.
    Failed(LssError),
}

/// One found slave in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AssignEntry {
    /// Its LSS address.
    pub address: LssAddress,
    /// The node-ID chosen for it (`None` when none was left).
    pub node_id: Option<NodeId>,
    /// What happened.
    pub outcome: AssignOutcome,
}

impl core::fmt::Display for AssignEntry {
    /// One report line: `address: node-ID n`, with the error when there is one.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}: ", self.address)?;
        match (self.node_id, self.outcome) {
            (Some(id), AssignOutcome::Assigned) => write!(f, "node-ID {id}"),
            (Some(id), AssignOutcome::StoreFailed(e)) => {
                write!(f, "node-ID {id} assigned, not stored: {e}")
            }
            (Some(id), AssignOutcome::Failed(e)) => write!(f, "node-ID {id} failed: {e}"),
            (None, AssignOutcome::Failed(e)) => write!(f, "failed: {e}"),
            (None, _) => f.write_str("no node-ID"),
        }
    }
}

/// The workflow's result.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AssignReport {
    /// Every slave found, in the order found.
    pub entries: Vec<AssignEntry, MAX_SLAVES>,
    /// Why discovery ended before the bus had no unconfigured slave left.
    pub stopped: Option<LssError>,
    /// Node-IDs of the pool or the table not handed out because they are in use on the bus.
    pub skipped: NodeIdPool,
}

impl AssignReport {
    /// The slaves that got a node-ID (stored or not), with it.
    pub fn assigned(&self) -> impl Iterator<Item = (LssAddress, NodeId)> + '_ {
        self.entries
            .iter()
            .filter_map(|e| match (e.outcome, e.node_id) {
                (AssignOutcome::Assigned | AssignOutcome::StoreFailed(_), Some(id)) => {
                    Some((e.address, id))
                }
                _ => None,
            })
    }
}

#[derive(Debug, Clone)]
enum Phase {
    Idle,
    /// Looking for the next slave.
    Scan(ScanCore),
    /// Configure node-ID to `found[index]`, the one slave in configuration state.
    Configure(usize, NodeId),
    Store(usize, NodeId),
}

/// The assign-all workflow machine; see the module docs. Output: the [`AssignReport`] (also
/// when discovery stopped early; see [`AssignReport::stopped`]).
#[derive(Debug, Clone)]
pub struct AssignAll {
    config: AssignConfig,
    pool: NodeIdPool,
    /// Node-IDs in use on the bus: the configured ones and those heard during the run.
    in_use: NodeIdPool,
    /// Node-IDs this run configured.
    given: NodeIdPool,
    io: Io<AssignReport, AssignEntry>,
    phase: Phase,
    found: Vec<LssAddress, MAX_SLAVES>,
    /// Whether a found slave is still unconfigured (and so still answers Fastscan).
    left_unconfigured: bool,
    report: AssignReport,
}

impl AssignAll {
    /// An idle machine.
    pub fn new(config: AssignConfig) -> Self {
        Self {
            pool: config.pool,
            in_use: config.in_use,
            given: NodeIdPool::EMPTY,
            config,
            io: Io::new(),
            phase: Phase::Idle,
            found: Vec::new(),
            left_unconfigured: false,
            report: AssignReport::default(),
        }
    }

    /// Starts the workflow. Fails with [`LssError::Busy`] while it runs, and with
    /// [`LssError::InvalidConfig`] when the table gives one node-ID or one address twice, when
    /// there is no node-ID to give at all (empty pool and empty table), or when the parts to
    /// skip leave no scan ([`FastscanConfig::validate`]).
    pub fn start(&mut self, now: Instant) -> Result<(), LssError> {
        if !matches!(self.phase, Phase::Idle) {
            return Err(LssError::Busy);
        }
        self.config.fastscan.validate()?;
        let table = &self.config.table;
        for (i, (a, id)) in table.iter().enumerate() {
            if table[i + 1..].iter().any(|(b, jd)| a == b || id == jd) {
                return Err(LssError::InvalidConfig(
                    "the node-ID table lists an address or a node-ID twice",
                ));
            }
        }
        if table.is_empty() && self.config.pool.is_empty() {
            return Err(LssError::InvalidConfig(
                "no node-ID to give: the pool and the table are empty",
            ));
        }
        self.pool = self.config.pool;
        for (_, id) in table {
            self.pool.remove(*id);
        }
        self.in_use = self.config.in_use;
        self.given = NodeIdPool::EMPTY;
        self.io.ex.clear();
        self.io.events.clear();
        self.found.clear();
        self.left_unconfigured = false;
        self.report = AssignReport::default();
        self.io.finished = false;
        self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        self.phase = Phase::Scan(ScanCore::start(&mut self.io.ex, now, self.config.fastscan));
        Ok(())
    }

    /// The caller heard a boot-up or heartbeat of node `id` during the run: unless this run
    /// gave it, it is in use, and no slave gets it from now on. Reported as
    /// [`MasterEvent::NodeIdInUse`] when the pool still held it.
    pub fn node_id_heard(&mut self, id: NodeId) {
        if self.given.contains(id) || self.in_use.contains(id) {
            return;
        }
        self.in_use.insert(id);
        if self.pool.remove(id) {
            self.skip(id);
        }
    }

    /// Reports a node-ID not handed out because it is in use.
    fn skip(&mut self, id: NodeId) {
        if !self.report.skipped.contains(id) {
            self.report.skipped.insert(id);
            self.io.events.push(MasterEvent::NodeIdInUse(id));
        }
    }

    /// The lowest node-ID of the pool that is not in use; those in use are skipped.
    fn take_free(&mut self) -> Option<NodeId> {
        loop {
            let id = self.pool.take_lowest()?;
            if !self.in_use.contains(id) {
                return Some(id);
            }
            self.skip(id);
        }
    }

    /// Sends configure node-ID with `node_id` to `found[index]`.
    fn configure(&mut self, now: Instant, index: usize, node_id: NodeId) {
        self.io.ex.ask(
            now,
            Request::ConfigureNodeId(node_id.get()),
            cs::CONFIGURE_NODE_ID,
            self.config.services.response_timeout,
            false,
        );
        self.phase = Phase::Configure(index, node_id);
    }

    /// `found[index]` is configured with `node_id` (and stored, or not: `outcome`). If the
    /// node-ID was heard on the bus meanwhile, configure the next free one instead.
    fn configured(&mut self, now: Instant, index: usize, node_id: NodeId, outcome: AssignOutcome) {
        if self.in_use.contains(node_id) {
            self.skip(node_id);
            match self.take_free() {
                Some(next) => self.configure(now, index, next),
                None => {
                    let e = LssError::NodeIdInUse(node_id.get());
                    self.record(index, Some(node_id), AssignOutcome::Failed(e));
                    // The slave holds a pending node-ID that must not become active: leave
                    // it unconfigured (CiA 305: 0xFF) before it goes back to waiting.
                    self.io
                        .ex
                        .send(Request::ConfigureNodeId(crate::wire::UNCONFIGURED_NODE_ID));
                    self.next_slave(now, index);
                }
            }
            return;
        }
        self.given.insert(node_id);
        self.record(index, Some(node_id), outcome);
        self.next_slave(now, index);
    }

    fn record(&mut self, index: usize, node_id: Option<NodeId>, outcome: AssignOutcome) {
        let Some(&address) = self.found.get(index) else {
            return;
        };
        if !matches!(
            outcome,
            AssignOutcome::Assigned | AssignOutcome::StoreFailed(_)
        ) {
            self.left_unconfigured = true;
        }
        let entry = AssignEntry {
            address,
            node_id,
            outcome,
        };
        // One entry per found slave, and `found` has the same capacity.
        let _ = self.report.entries.push(entry);
        self.io.events.push(MasterEvent::Progress(entry));
    }

    fn finish(&mut self, stopped: Option<LssError>) {
        self.report.stopped = stopped;
        self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        self.phase = Phase::Idle;
        self.io.finished = true;
        self.io.events.finish(Ok(self.report.clone()));
    }

    /// A slave was found and is in configuration state: configure it, or record why not.
    fn found(&mut self, now: Instant, address: LssAddress) {
        self.io.events.push(MasterEvent::Found(address));
        if self.found.push(address).is_err() {
            self.finish(Some(LssError::TooMany(MAX_SLAVES)));
            return;
        }
        let index = self.found.len() - 1;
        let listed = self
            .config
            .table
            .iter()
            .find(|(a, _)| *a == address)
            .map(|(_, id)| *id);
        if let Some(id) = listed.filter(|id| self.in_use.contains(*id)) {
            self.skip(id);
            let e = LssError::NodeIdInUse(id.get());
            self.record(index, Some(id), AssignOutcome::Failed(e));
            self.next_slave(now, index);
            return;
        }
        match listed.or_else(|| self.take_free()) {
            Some(node_id) => self.configure(now, index, node_id),
            None => {
                self.record(index, None, AssignOutcome::Failed(LssError::NoFreeNodeId));
                self.next_slave(now, index);
            }
        }
    }

    /// Done with `found[index]`: back to waiting state (which activates a new node-ID), then
    /// the next scan.
    fn next_slave(&mut self, now: Instant, index: usize) {
        self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        let fastscan = self.config.fastscan;
        let scan = match self.found.get(index) {
            Some(&last) if self.left_unconfigured => {
                ScanCore::start_above(&mut self.io.ex, now, fastscan, last)
            }
            _ => ScanCore::start(&mut self.io.ex, now, fastscan),
        };
        self.phase = Phase::Scan(scan);
    }

    fn react(&mut self, now: Instant, reply: Reply) {
        let services = self.config.services;
        match core::mem::replace(&mut self.phase, Phase::Idle) {
            Phase::Idle => {}
            Phase::Scan(mut scan) => match scan.step(&mut self.io.ex, now, reply) {
                ScanStep::Continue => self.phase = Phase::Scan(scan),
                ScanStep::Found(a) => self.found(now, a),
                ScanStep::NoneLeft => self.finish(None),
                ScanStep::Lost(part) => self.finish(Some(LssError::FastscanLost { part })),
            },
            Phase::Configure(index, node_id) => {
                let service = Service::ConfigureNodeId;
                let result = match reply {
                    Reply::Answer(Response::ConfigureNodeId(s)) => s
                        .result()
                        .map_err(|error| LssError::Rejected { service, error }),
                    _ => Err(timeout(service, services.response_timeout)),
                };
                match result {
                    Ok(()) if self.config.store => {
                        self.io.ex.ask(
                            now,
                            Request::StoreConfiguration,
                            cs::STORE_CONFIGURATION,
                            services.store_timeout,
                            false,
                        );
                        self.phase = Phase::Store(index, node_id);
                    }
                    Ok(()) => self.configured(now, index, node_id, AssignOutcome::Assigned),
                    Err(e) => {
                        self.record(index, Some(node_id), AssignOutcome::Failed(e));
                        self.next_slave(now, index);
                    }
                }
            }
            Phase::Store(index, node_id) => {
                let service = Service::StoreConfiguration;
                let outcome = match reply {
                    Reply::Answer(Response::StoreConfiguration(s)) => match s.result() {
                        Ok(()) => AssignOutcome::Assigned,
                        Err(error) => {
                            AssignOutcome::StoreFailed(LssError::Rejected { service, error })
                        }
                    },
                    _ => AssignOutcome::StoreFailed(timeout(service, services.store_timeout)),
                };
                self.configured(now, index, node_id, outcome);
            }
        }
    }
}

driven_machine!(AssignAll, AssignReport, AssignEntry);

impl Driven for AssignAll {
    type Output = AssignReport;
    type Progress = AssignEntry;

    fn io(&self) -> &Io<Self::Output, Self::Progress> {
        &self.io
    }

    fn io_mut(&mut self) -> &mut Io<Self::Output, Self::Progress> {
        &mut self.io
    }

    fn on_reply(&mut self, now: Instant, reply: Reply) {
        self.react(now, reply);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn pool_hands_out_lowest_first() {
        let mut p = NodeIdPool::range(id(10), id(12));
        assert_eq!(p.len(), 3);
        assert!(p.remove(id(10)));
        assert!(!p.remove(id(10)));
        assert_eq!(p.take_lowest(), Some(id(11)));
        assert_eq!(p.take_lowest(), Some(id(12)));
        assert_eq!(p.take_lowest(), None);
        assert!(p.is_empty());
        let mut all = NodeIdPool::all();
        assert_eq!(all.len(), 127);
        assert!(!all.contains(id(1)) || all.take_lowest() == Some(id(1)));
        all.insert(id(1));
        assert!(all.contains(id(1)));
    }

    #[test]
    fn entries_print_as_report_lines() {
        use std::string::ToString;
        let address = LssAddress::new(0x78, 1, 2, 3);
        let ok = AssignEntry {
            address,
            node_id: Some(id(5)),
            outcome: AssignOutcome::Assigned,
        };
        assert_eq!(
            ok.to_string(),
            "00000078:00000001:00000002:00000003: node-ID 5"
        );
        let none = AssignEntry {
            address,
            node_id: None,
            outcome: AssignOutcome::Failed(LssError::NoFreeNodeId),
        };
        assert_eq!(
            none.to_string(),
            "00000078:00000001:00000002:00000003: failed: no free node-ID left for the slave"
        );
    }

    #[test]
    fn duplicate_table_entries_are_refused() {
        let mut c = AssignConfig::with_pool(NodeIdPool::all());
        let a = LssAddress::new(1, 2, 3, 4);
        let b = LssAddress::new(1, 2, 3, 5);
        c.table.push((a, id(5))).unwrap();
        c.table.push((b, id(5))).unwrap();
        let mut m = AssignAll::new(c);
        assert!(matches!(
            m.start(Instant::ZERO),
            Err(LssError::InvalidConfig(_))
        ));
    }
}
