//! LSS master services on the [`Network`] (CiA 305): the `canola-lss` machines driven by the
//! network's loop. One LSS job runs at a time (LSS has one channel per bus, COB-IDs 0x7E5/0x7E4).
//!
//! Every service goes through one driver, `Lss::run`: it starts the machine, hands it to the
//! network's core (which feeds it frames and timeouts), waits for its result, and flushes what
//! the machine queued last, so that a service that only transmits (switch mode global,
//! activate bit timing) has its frame on the bus when the call returns.

use canola_frame::Instant;

use crate::error::Error;
use crate::network::Network;

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
        start: impl FnOnce(&mut M, Instant) -> Result<(), LssError>,
    ) -> Result<<M::Output as LssOutput>::Value, Error>
    where
        M: LssMachine + Send + 'static,
        M::Output: LssOutput,
    {
        let now = self.net.now();
        start(&mut machine, now).map_err(Error::Lss)?;
        self.net.core().start_lss(Box::new(machine));
        let result = self.net.wait_for(|c| c.take_lss_result())?;
        // A machine that ends on a request without an answer (switch mode global) finishes
        // when it queues it: put it on the bus before returning.
        self.net.flush()?;
        let outcome = result.map_err(Error::Lss)?;
        // Another thread's LSS job started meanwhile replaces this one, and its result of
        // another kind is what arrived.
        M::Output::from_outcome(outcome).ok_or(Error::Lss(LssError::Busy))
    }

    /// Runs a procedure of LSS services (e.g. [`Procedure::assign_node_id`],
    /// [`Procedure::change_bit_rate`], [`Procedure::inquire_all`]).
    pub fn procedure(&self, procedure: Procedure) -> Result<ServiceReport, Error> {
        self.procedure_with(MasterConfig::default(), procedure)
    }

    /// [`procedure`](Self::procedure) with other response timeouts.
    pub fn procedure_with(
        &self,
        config: MasterConfig,
        procedure: Procedure,
    ) -> Result<ServiceReport, Error> {
        self.run(LssMaster::new(config), |m, now| m.start(now, procedure))
    }

    /// Fastscan: finds one unconfigured slave and leaves it in configuration state.
    pub fn fastscan(&self, config: FastscanConfig) -> Result<Option<LssAddress>, Error> {
        self.run(Fastscan::new(config), |m, now| m.start(now))
    }

    /// Finds every unconfigured slave, in ascending LSS address order.
    pub fn discover_all(&self, config: FastscanConfig) -> Result<Vec<LssAddress>, Error> {
        self.run(DiscoverAll::new(config), |m, now| m.start(now))
    }

    /// The commissioning workflow: find every unconfigured slave and give each a node-ID.
    pub fn assign_all(&self, config: AssignConfig) -> Result<AssignReport, Error> {
        self.run(AssignAll::new(config), |m, now| m.start(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MemoryBus, SimDevice};
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
            let report = net.lss().assign_all(AssignConfig::with_pool(pool)).unwrap();
            assert_eq!(report.stopped, None);
            let assigned: Vec<_> = report.assigned().collect();
            assert_eq!(assigned.len(), n as usize, "{report:?}");
            net.run_for(Duration::from_millis(10)).unwrap();
            for (a, id) in assigned {
                let serial = net.node(id).sdo().read((0x1018, 4)).unwrap();
                assert_eq!(serial, a.serial_number.to_le_bytes());
            }
            // Nobody is left to find.
            let again = net.lss().discover_all(FastscanConfig::default()).unwrap();
            assert!(again.is_empty(), "{again:?}");
        }
    }

    #[test]
    fn discover_all_of_real_slaves_ends_and_finds_each_once() {
        let (_bus, net) = bus(5, StoreSupport::Supported);
        let found = net.lss().discover_all(FastscanConfig::default()).unwrap();
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
            .unwrap();
        assert_eq!(report.stored, Some(false));
        net.run_for(Duration::from_millis(10)).unwrap();
        let serial = net.node(id).sdo().read((0x1018, 4)).unwrap();
        assert_eq!(serial, address(0).serial_number.to_le_bytes());
    }

    #[test]
    fn a_switch_is_on_the_bus_when_the_call_returns() {
        let (bus, net) = bus(0, StoreSupport::Supported);
        let mut tap = bus.endpoint();
        net.lss()
            .procedure(Procedure::single(Step::SwitchModeGlobal(
                Mode::Configuration,
            )))
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
