//! LSS master services on the [`Network`] (CiA 305): the `canopen-lss` machines driven by the
//! network's loop. One LSS job runs at a time (LSS has one channel per bus, COB-IDs 0x7E5/0x7E4).

use canopen_lss::{
    AssignAll, AssignConfig, AssignReport, DiscoverAll, Fastscan, FastscanConfig, LssAddress,
    LssError, LssMachine, LssMaster, MasterConfig, MasterEvent, Procedure, ServiceReport,
};

use can_frame::{CanFrame, Instant};

use crate::error::Error;
use crate::network::Network;

/// What a finished LSS job produced.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum LssOutcome {
    /// A procedure of services.
    Service(ServiceReport),
    /// Fastscan: the address of one unconfigured slave, if any answered.
    Fastscan(Option<LssAddress>),
    /// Every unconfigured slave's address.
    Discovered(Vec<LssAddress>),
    /// The assign-all workflow's report.
    Assigned(Box<AssignReport>),
}

/// An LSS master machine with its output type erased.
pub(crate) trait LssJob: Send {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame);
    fn handle_timeout(&mut self, now: Instant);
    fn poll_transmit(&mut self) -> Option<CanFrame>;
    fn poll_timeout(&self) -> Option<Instant>;
    /// Progress events as text, and the final result.
    fn poll(&mut self) -> Option<Result<LssOutcome, LssError>>;
}

struct Job<M, F> {
    machine: M,
    convert: F,
}

impl<M, F> LssJob for Job<M, F>
where
    M: LssMachine + Send,
    F: FnMut(M::Output) -> LssOutcome + Send,
{
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.machine.handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.machine.handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.machine.poll_transmit_frame()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.machine.poll_timeout()
    }
    fn poll(&mut self) -> Option<Result<LssOutcome, LssError>> {
        while let Some(ev) = self.machine.poll_event() {
            if let MasterEvent::Done(r) = ev {
                return Some(r.map(&mut self.convert));
            }
        }
        None
    }
}

/// LSS master services of a network.
#[derive(Debug, Clone)]
pub struct Lss {
    net: Network,
}

impl Network {
    /// The LSS master (CiA 305).
    pub fn lss(&self) -> Lss {
        Lss { net: self.clone() }
    }
}

impl Lss {
    fn run<M>(
        &self,
        mut machine: M,
        start: impl FnOnce(&mut M, Instant) -> Result<(), LssError>,
        convert: impl FnMut(M::Output) -> LssOutcome + Send + 'static,
    ) -> Result<LssOutcome, Error>
    where
        M: LssMachine + Send + 'static,
    {
        let now = self.net.now();
        start(&mut machine, now).map_err(Error::Lss)?;
        self.net
            .core()
            .start_lss(Box::new(Job { machine, convert }));
        self.net
            .wait_for(|c| c.take_lss_result())
            .and_then(|r| r.map_err(Error::Lss))
    }

    /// Runs a procedure of LSS services (e.g. [`Procedure::assign_node_id`],
    /// [`Procedure::change_bit_rate`], [`Procedure::inquire_all`]).
    pub fn procedure(&self, procedure: Procedure) -> Result<ServiceReport, Error> {
        match self.run(
            LssMaster::new(MasterConfig::default()),
            |m, now| m.start(now, procedure),
            LssOutcome::Service,
        )? {
            LssOutcome::Service(r) => Ok(r),
            _ => Err(Error::Timeout("LSS procedure gave no report".into())),
        }
    }

    /// Fastscan: finds one unconfigured slave and leaves it in configuration state.
    pub fn fastscan(&self, config: FastscanConfig) -> Result<Option<LssAddress>, Error> {
        match self.run(
            Fastscan::new(config),
            |m, now| m.start(now),
            LssOutcome::Fastscan,
        )? {
            LssOutcome::Fastscan(r) => Ok(r),
            _ => Ok(None),
        }
    }

    /// Finds every unconfigured slave.
    pub fn discover_all(&self, config: FastscanConfig) -> Result<Vec<LssAddress>, Error> {
        match self.run(
            DiscoverAll::new(config),
            |m, now| m.start(now),
            |list| LssOutcome::Discovered(list.into_iter().collect()),
        )? {
            LssOutcome::Discovered(r) => Ok(r),
            _ => Ok(Vec::new()),
        }
    }

    /// The commissioning workflow: find every unconfigured slave and give each a node-ID.
    pub fn assign_all(&self, config: AssignConfig) -> Result<AssignReport, Error> {
        match self.run(
            AssignAll::new(config),
            |m, now| m.start(now),
            |r| LssOutcome::Assigned(Box::new(r)),
        )? {
            LssOutcome::Assigned(r) => Ok(*r),
            _ => Err(Error::Timeout("assign-all gave no report".into())),
        }
    }
}
