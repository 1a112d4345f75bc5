//! LSS master services on the [`Network`] (CiA 305): the `canola-lss` machines driven by the
//! network's loop. One LSS job runs at a time (LSS has one channel per bus, COB-IDs 0x7E5/0x7E4).
//!
//! Every service goes through one driver, `Lss::run`: it starts the machine, hands it to the
//! network's core (which feeds it frames and timeouts), waits for its result, and flushes what
//! the machine queued last, so that a service that only transmits (switch mode global,
//! activate bit timing) has its frame on the bus when the call returns.

use canola_frame::{Instant, NodeId};

use crate::error::Error;
use crate::network::operation;
use crate::network::{Network, Operation, Sdo};

// The CiA 305 vocabulary (addresses, bit timings, node-ID pools, the wire messages and the slave
// machine), so `canola::lss` is the one LSS import of an application.
pub use canola_lss::*;

pub use crate::machine::lss::LssOutcome;
use crate::machine::lss::LssOutput;

/// LSS master services of a network.
#[derive(Debug, Clone)]
pub struct Lss {
    pub(crate) net: Network,
}

impl Network {
    /// The LSS master (CiA 305).
    pub fn lss(&self) -> Lss {
        Lss { net: self.clone() }
    }
}

impl Lss {
    /// The one driver: starts `machine`, runs it on the network until it is done, flushes its
    /// last frames and returns its result.
    fn run<M>(
        &self,
        mut machine: M,
        start: impl FnOnce(&mut M, Instant) -> Result<(), LssError> + Send + 'static,
    ) -> Operation<'static, <M::Output as LssOutput>::Value>
    where
        M: LssMachine + crate::machine::lss::HearsNodeIds + Send + 'static,
        M::Output: LssOutput,
        <M::Output as LssOutput>::Value: Send,
    {
        let net = self.net.clone();
        Operation::new(async move {
            operation::catch_up(net.shared())?;
            let now = net.now();
            start(&mut machine, now).map_err(Error::Lss)?;
            net.core().start_lss(Box::new(machine));
            let result = operation::until(net.shared(), None, |c| c.take_lss_result()).await?;
            // A machine that ends on a request without an answer (switch mode global) finishes
            // when it queues it: put it on the bus before returning.
            operation::flush(net.shared()).await?;
            let outcome = result.map_err(Error::Lss)?;
            // Another thread's LSS job started meanwhile replaces this one, and its result of
            // another kind is what arrived.
            M::Output::from_outcome(outcome).ok_or(Error::Lss(LssError::Busy))
        })
    }

    /// Runs a procedure of LSS services (e.g. [`Procedure::assign_node_id`],
    /// [`Procedure::change_bit_rate`], [`Procedure::inquire_all`]).
    pub fn procedure(&self, procedure: Procedure) -> Operation<'static, ServiceReport> {
        self.procedure_with(MasterConfig::default(), procedure)
    }

    /// [`procedure`](Self::procedure) with other response timeouts.
    pub fn procedure_with(
        &self,
        config: MasterConfig,
        procedure: Procedure,
    ) -> Operation<'static, ServiceReport> {
        self.run(LssMaster::new(config), |m, now| m.start(now, procedure))
    }

    /// Fastscan: finds one unconfigured slave and leaves it in configuration state.
    pub fn fastscan(&self, config: FastscanConfig) -> Operation<'static, Option<LssAddress>> {
        self.run(Fastscan::new(config), |m, now| m.start(now))
    }

    /// Finds every unconfigured slave, in ascending LSS address order.
    pub fn discover_all(&self, config: FastscanConfig) -> Operation<'static, Vec<LssAddress>> {
        self.run(DiscoverAll::new(config), |m, now| m.start(now))
    }

    /// The commissioning workflow: find every unconfigured slave and give each a node-ID.
    ///
    /// It never hands out a node-ID in use on the bus. Before the first slave, the node-IDs of
    /// the pool and the table are checked ([`nodes_in_use`](Self::nodes_in_use): heard since
    /// the network started, or answering an SDO read within
    /// `config.services.response_timeout`) and joined to `config.in_use`; during the run,
    /// every boot-up, heartbeat and guarding answer heard takes its node-ID out too. Each
    /// node-ID of the pool or the table found in use is listed in
    /// [`AssignReport::skipped`], the conflicts to report.
    pub fn assign_all(&self, mut config: AssignConfig) -> Operation<'static, AssignReport> {
        let lss = self.clone();
        Operation::new(async move {
            let candidates = Self::candidates(&config);
            let found = lss
                .nodes_in_use(candidates, config.services.response_timeout)
                .await?;
            for id in found.iter() {
                config.in_use.insert(id);
            }
            let in_use = config.in_use;
            let mut report = lss
                .run(AssignAll::new(config), |m, now| m.start(now))
                .await?;
            list_conflicts(&mut report, candidates, in_use);
            Ok(report)
        })
    }

    /// The node-IDs of `candidates` in use on the bus: those heard since the network started
    /// (a boot-up, heartbeat or guarding answer), and those whose node answers an SDO read of
    /// its device type (0x1000) within `timeout` (an abort is an answer too). All the reads
    /// run at once, so this takes about one `timeout`.
    pub fn nodes_in_use(
        &self,
        candidates: NodeIdPool,
        timeout: impl Into<canola_frame::Duration>,
    ) -> Operation<'static, NodeIdPool> {
        let lss = self.clone();
        let timeout = timeout.into();
        Operation::new(async move {
            operation::catch_up(lss.net.shared())?;
            let (mut in_use, pending) = lss.probe(candidates, timeout);
            let (ids, reqs): (Vec<NodeId>, Vec<operation::Req>) = pending.into_iter().unzip();
            let results = operation::wait_requests(lss.net.shared(), reqs).await;
            for (id, r) in ids.into_iter().zip(results) {
                if answered(r.map(|c| c.data))? || lss.heard(id) {
                    in_use.insert(id);
                }
            }
            Ok(in_use)
        })
    }

    /// Whether anything was heard from node `id` since the network started.
    pub(crate) fn heard(&self, id: NodeId) -> bool {
        self.net.last_state(id).is_some() || self.net.last_heartbeat(id).is_some()
    }

    /// The node-IDs of `candidates` heard already, and SDO reads of 0x1000 submitted to the
    /// others.
    pub(crate) fn probe(
        &self,
        candidates: NodeIdPool,
        timeout: canola_frame::Duration,
    ) -> (NodeIdPool, Vec<(NodeId, operation::Req)>) {
        let in_use: NodeIdPool = candidates.iter().filter(|id| self.heard(*id)).collect();
        let pending = candidates
            .iter()
            .filter(|id| !in_use.contains(*id))
            .filter_map(|id| {
                let read = Sdo::new(self.net.clone(), id).timeout(timeout);
                Some((id, read.submit_read((0x1000, 0)).into_req()?))
            })
            .collect();
        (in_use, pending)
    }

    /// Joins the node-IDs in use on the bus to `config.in_use` (see
    /// [`assign_all`](Self::assign_all)); returns the node-IDs of the pool and the table.
    pub(crate) fn candidates(config: &AssignConfig) -> NodeIdPool {
        let mut candidates = config.pool;
        for (_, id) in &config.table {
            candidates.insert(*id);
        }
        candidates
    }
}

/// Whether a probe read was answered (data, an abort, or a broken answer: a node is there).
/// A failed transport is an error: nothing can be said.
pub(crate) fn answered(r: Result<Vec<u8>, crate::SdoError>) -> Result<bool, Error> {
    use crate::error::SdoErrorKind;
    use canola_sdo::ErrorKind;
    match r {
        Ok(_) => Ok(true),
        Err(e) => match e.kind {
            SdoErrorKind::Transfer(ErrorKind::ServerAbort(_) | ErrorKind::Protocol(_)) => Ok(true),
            SdoErrorKind::Transport(_) => Err(Error::Sdo(e)),
            _ => Ok(false),
        },
    }
}

/// The report of assign-all lists every node-ID of `candidates` in use as skipped, reached by
/// the pool or not.
pub(crate) fn list_conflicts(
    report: &mut AssignReport,
    candidates: NodeIdPool,
    in_use: NodeIdPool,
) {
    for id in candidates.iter().filter(|id| in_use.contains(*id)) {
        report.skipped.insert(id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MemoryBus, Network, Nmt, SimDevice};
    use canola_frame::{Duration, NodeId};
    use canola_lss::{Mode, NodeIdPool, SlaveConfig, Step, StoreSupport};

    const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

    fn address(i: u32) -> LssAddress {
        // Serial numbers far apart in their bits, so that successor searches climb.
        LssAddress::new(0x39, 0x0100_0001, 1, 1001 + i * 0x0101_0101)
    }

    /// `n` simulated real slaves (answering Fastscan in configuration state) on a new bus.
    fn bus(n: u32, store: StoreSupport) -> (MemoryBus, Network) {
        let od = canola_od::parse(EDS).unwrap().od;
        let bus = MemoryBus::new();
        let net = Network::new(bus.endpoint());
        for i in 0..n {
            let mut slave = SlaveConfig::unconfigured_real(address(i));
            slave.store = store;
            bus.attach(SimDevice::unconfigured_with(od.clone(), slave));
        }
        (bus, net)
    }

    #[test]
    fn assign_all_of_1_2_20_real_slaves_then_each_answers_sdo() {
        for n in [1, 2, 20] {
            let (_bus, net) = bus(n, StoreSupport::Supported);
            let pool = NodeIdPool::range(NodeId::new(2).unwrap(), NodeId::MAX);
            let report = net
                .lss()
                .assign_all(AssignConfig::with_pool(pool))
                .wait()
                .unwrap();
            assert_eq!(report.stopped, None);
            let assigned: Vec<_> = report.assigned().collect();
            assert_eq!(assigned.len(), n as usize, "{report:?}");
            net.run_for(Duration::from_millis(10)).wait().unwrap();
            for (a, id) in assigned {
                let serial = net.node(id).sdo().read((0x1018, 4)).wait().unwrap();
                assert_eq!(serial, a.serial_number.to_le_bytes());
            }
            // Nobody is left to find.
            let again = net
                .lss()
                .discover_all(FastscanConfig::default())
                .wait()
                .unwrap();
            assert!(again.is_empty(), "{again:?}");
        }
    }

    /// A node that starts sending heartbeats (node-ID `id`, Operational) `after` the bus
    /// starts: a node that appears while assign-all runs.
    struct LateNode {
        id: u8,
        next: Instant,
        out: Option<canola_frame::CanFrame>,
    }

    impl crate::Station for LateNode {
        fn handle_frame(&mut self, _now: Instant, _frame: &canola_frame::CanFrame) {}
        fn handle_timeout(&mut self, now: Instant) {
            if now >= self.next {
                let id = canola_frame::CanId::standard(0x700 + u16::from(self.id)).unwrap();
                self.out = Some(canola_frame::CanFrame::new(id, &[0x05]).unwrap());
                self.next = now + Duration::from_millis(50);
            }
        }
        fn poll_transmit(&mut self) -> Option<canola_frame::CanFrame> {
            self.out.take()
        }
        fn poll_timeout(&self) -> Option<Instant> {
            Some(self.next)
        }
    }

    #[test]
    fn assign_all_does_not_hand_out_node_ids_in_use() {
        let (bus, net) = bus(3, StoreSupport::Supported);
        // Nodes 5 and 6 running: booted, started, sending heartbeats.
        for id in [5, 6] {
            bus.attach(SimDevice::from_eds(NodeId::new(id).unwrap(), EDS).unwrap());
        }
        net.run_for(Duration::from_millis(10)).wait().unwrap();
        Nmt::all(&net).start().unwrap();
        net.run_for(Duration::from_millis(10)).wait().unwrap();
        let pool = NodeIdPool::range(NodeId::new(4).unwrap(), NodeId::new(10).unwrap());
        let report = net
            .lss()
            .assign_all(AssignConfig::with_pool(pool))
            .wait()
            .unwrap();
        let given: Vec<u8> = report.assigned().map(|(_, id)| id.get()).collect();
        assert_eq!(given, [4, 7, 8], "{report:?}");
        let skipped: Vec<u8> = report.skipped.iter().map(|id| id.get()).collect();
        assert_eq!(skipped, [5, 6], "{report:?}");
        // The running nodes still answer as themselves.
        for id in [5, 6] {
            let n = NodeId::new(id).unwrap();
            assert_eq!(net.last_state(n), Some(canola_nmt::NmtState::Operational));
        }
    }

    #[cfg(feature = "tokio")]
    #[tokio::test(start_paused = true)]
    async fn assign_all_async_does_not_hand_out_node_ids_in_use() {
        let (bus, net) = bus(2, StoreSupport::Supported);
        bus.attach(SimDevice::from_eds(NodeId::new(5).unwrap(), EDS).unwrap());
        let pool = NodeIdPool::range(NodeId::new(4).unwrap(), NodeId::new(10).unwrap());
        let report = net
            .lss()
            .assign_all(AssignConfig::with_pool(pool))
            .await
            .unwrap();
        let given: Vec<u8> = report.assigned().map(|(_, id)| id.get()).collect();
        assert_eq!(given, [4, 6], "{report:?}");
        let skipped: Vec<u8> = report.skipped.iter().map(|id| id.get()).collect();
        assert_eq!(skipped, [5], "{report:?}");
    }

    #[test]
    fn assign_all_does_not_hand_out_a_node_id_that_appears_during_the_run() {
        let (bus, net) = bus(3, StoreSupport::Supported);
        // Node 5 only starts sending heartbeats after the scan for node-IDs in use, while
        // the slaves are being found (a Fastscan of one slave takes well over 100 ms).
        bus.attach(LateNode {
            id: 5,
            next: net.now() + Duration::from_millis(400),
            out: None,
        });
        let pool = NodeIdPool::range(NodeId::new(4).unwrap(), NodeId::new(10).unwrap());
        let report = net
            .lss()
            .assign_all(AssignConfig::with_pool(pool))
            .wait()
            .unwrap();
        let given: Vec<u8> = report.assigned().map(|(_, id)| id.get()).collect();
        assert_eq!(given, [4, 6, 7], "{report:?}");
        assert!(
            report.skipped.contains(NodeId::new(5).unwrap()),
            "{report:?}"
        );
    }

    #[test]
    fn discover_all_of_real_slaves_ends_and_finds_each_once() {
        let (_bus, net) = bus(5, StoreSupport::Supported);
        let found = net
            .lss()
            .discover_all(FastscanConfig::default())
            .wait()
            .unwrap();
        let want: Vec<_> = (0..5).map(address).collect();
        assert_eq!(found, want);
    }

    #[test]
    fn a_slave_without_store_is_assigned_not_stored() {
        let (_bus, net) = bus(1, StoreSupport::NotSupported);
        let id = NodeId::new(9).unwrap();
        let report = net
            .lss()
            .procedure(Procedure::assign_node_id(id, true))
            .wait()
            .unwrap();
        assert_eq!(report.stored, Some(false));
        net.run_for(Duration::from_millis(10)).wait().unwrap();
        let serial = net.node(id).sdo().read((0x1018, 4)).wait().unwrap();
        assert_eq!(serial, address(0).serial_number.to_le_bytes());
    }

    /// Switch mode global reaches every slave: the assignment of one node-ID refuses when
    /// several answer, configures none of them and leaves them in waiting state.
    #[test]
    fn assign_node_id_refuses_several_slaves() {
        let (_bus, net) = bus(2, StoreSupport::Supported);
        let id = NodeId::new(9).unwrap();
        let r = net
            .lss()
            .procedure(Procedure::assign_node_id(id, true))
            .wait();
        assert!(
            matches!(r, Err(Error::Lss(LssError::SeveralSlaves { .. }))),
            "{r:?}"
        );
        net.run_for(Duration::from_millis(10)).wait().unwrap();
        assert!(net.node(id).sdo().read((0x1018, 4)).wait().is_err());
        // Both still unconfigured and found by Fastscan (in waiting state, as found).
        let found = net
            .lss()
            .discover_all(FastscanConfig::default())
            .wait()
            .unwrap();
        assert_eq!(found, [address(0), address(1)]);
    }

    #[test]
    fn a_switch_is_on_the_bus_when_the_call_returns() {
        let (bus, net) = bus(0, StoreSupport::Supported);
        let mut tap = bus.endpoint();
        net.lss()
            .procedure(Procedure::single(Step::SwitchModeGlobal(
                Mode::Configuration,
            )))
            .wait()
            .unwrap();
        use crate::transport::{Received, Transport};
        let now = tap.now();
        match tap.recv_until(now + Duration::from_millis(1)) {
            Ok(Some(Received::Frame { frame, .. })) => {
                assert_eq!(frame.cob_id(), Some(0x7E5));
                assert_eq!(frame.data(), [4, 1, 0, 0, 0, 0, 0, 0]);
            }
            other => panic!("{other:?}"),
        }
    }
}
