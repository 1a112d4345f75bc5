//! The LSS job the master machine runs (CiA 305): any `canola-lss` master machine with its
//! output type erased ([`LssJob`]), and what a finished one produced ([`LssOutcome`]). One job
//! runs at a time, as LSS has one channel per bus (COB-IDs 0x7E5/0x7E4).

use canola_frame::{CanFrame, Instant, NodeId};
use canola_lss::{
    AssignAll, AssignReport, DiscoverAll, Fastscan, LssAddress, LssError, LssMachine, LssMaster,
    MasterEvent, ServiceReport,
};

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

/// A machine output the network's core can carry as an [`LssOutcome`].
pub(crate) trait LssOutput: Sized {
    /// What the public API returns.
    type Value;
    fn into_outcome(self) -> LssOutcome;
    fn from_outcome(outcome: LssOutcome) -> Option<Self::Value>;
}

impl LssOutput for ServiceReport {
    type Value = ServiceReport;
    fn into_outcome(self) -> LssOutcome {
        LssOutcome::Service(self)
    }
    fn from_outcome(outcome: LssOutcome) -> Option<Self::Value> {
        match outcome {
            LssOutcome::Service(r) => Some(r),
            _ => None,
        }
    }
}

impl LssOutput for Option<LssAddress> {
    type Value = Option<LssAddress>;
    fn into_outcome(self) -> LssOutcome {
        LssOutcome::Fastscan(self)
    }
    fn from_outcome(outcome: LssOutcome) -> Option<Self::Value> {
        match outcome {
            LssOutcome::Fastscan(r) => Some(r),
            _ => None,
        }
    }
}

impl LssOutput for canola_lss::fastscan::AddressList {
    type Value = Vec<LssAddress>;
    fn into_outcome(self) -> LssOutcome {
        LssOutcome::Discovered(self.into_iter().collect())
    }
    fn from_outcome(outcome: LssOutcome) -> Option<Self::Value> {
        match outcome {
            LssOutcome::Discovered(r) => Some(r),
            _ => None,
        }
    }
}

impl LssOutput for AssignReport {
    type Value = AssignReport;
    fn into_outcome(self) -> LssOutcome {
        LssOutcome::Assigned(Box::new(self))
    }
    fn from_outcome(outcome: LssOutcome) -> Option<Self::Value> {
        match outcome {
            LssOutcome::Assigned(r) => Some(*r),
            _ => None,
        }
    }
}

/// A machine that wants to know the node-IDs heard on the bus while it runs (assign-all keeps
/// them out of its pool); the others ignore them.
pub(crate) trait HearsNodeIds {
    /// A boot-up, heartbeat or guarding answer of node `id` arrived.
    fn node_id_heard(&mut self, _id: NodeId) {}
}

impl HearsNodeIds for LssMaster {}
impl HearsNodeIds for Fastscan {}
impl HearsNodeIds for DiscoverAll {}
impl HearsNodeIds for AssignAll {
    fn node_id_heard(&mut self, id: NodeId) {
        AssignAll::node_id_heard(self, id);
    }
}

/// An LSS master machine with its output type erased, as the network's core holds it.
pub(crate) trait LssJob: Send {
    /// A node-ID heard on the bus (see [`HearsNodeIds`]).
    fn node_id_heard(&mut self, id: NodeId);
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame);
    fn handle_timeout(&mut self, now: Instant);
    fn poll_transmit(&mut self) -> Option<CanFrame>;
    fn poll_timeout(&self) -> Option<Instant>;
    /// The final result, once the machine is done.
    fn poll(&mut self) -> Option<Result<LssOutcome, LssError>>;
}

impl<M> LssJob for M
where
    M: LssMachine + HearsNodeIds + Send,
    M::Output: LssOutput,
{
    fn node_id_heard(&mut self, id: NodeId) {
        HearsNodeIds::node_id_heard(self, id);
    }
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        LssMachine::handle_frame(self, now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        LssMachine::handle_timeout(self, now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.poll_transmit_frame()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        LssMachine::poll_timeout(self)
    }
    fn poll(&mut self) -> Option<Result<LssOutcome, LssError>> {
        // Progress events (found slaves, bit rate switches) are not needed here: the result
        // carries everything the blocking API returns.
        while let Some(ev) = self.poll_event() {
            if let MasterEvent::Done(r) = ev {
                return Some(r.map(LssOutput::into_outcome));
            }
        }
        None
    }
}
