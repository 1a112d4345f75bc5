//! The per-node PDO handles: [`Tpdos`] and [`Rpdos`] ([`Node::tpdo`](crate::Node::tpdo), [`Node::rpdo`](crate::Node::rpdo)) read
//! and save a direction's PDOs; [`Rpdos::start`] transmits an RPDO from the master.

use canola_pdo::{CommParams, Direction, PdoConfig};

use crate::error::Error;
use crate::network::Operation;
use crate::network::request::NodeRef;

use super::params::{PdoParameters, PdoSet, event_millis, inhibit_units};
use super::sequence::{read_set, save_set};
use super::transmit::{RpdoSender, Transmission};

/// A node's transmit PDOs ([`Node::tpdo`](crate::Node::tpdo)).
#[derive(Debug, Clone)]
pub struct Tpdos {
    pub(crate) node: NodeRef,
}

impl Tpdos {
    /// Reads every TPDO's parameters by SDO (the PDOs the node's dictionary lists; without a
    /// dictionary TPDO1..4, those that exist). The master decodes each valid TPDO from its
    /// COB-ID and with its mapping from now on.
    pub fn read(&self) -> Operation<'static, PdoSet> {
        let node = self.node.clone();
        Operation::new(async move { read_set(&node, Direction::Transmit).await })
    }

    /// Writes the TPDOs changed since they were read (see the module docs for the sequence);
    /// the master's decoding follows. Stops at the first failure (the PDOs saved before it
    /// stay saved, the failed one is left invalid on the node as the sequence leaves it).
    pub fn save<'a>(&self, set: &'a mut PdoSet) -> Operation<'a, ()> {
        let node = self.node.clone();
        Operation::new(async move { save_set(&node, Direction::Transmit, set).await })
    }
}

/// A node's receive PDOs ([`Node::rpdo`](crate::Node::rpdo)).
#[derive(Debug, Clone)]
pub struct Rpdos {
    pub(crate) node: NodeRef,
}

impl Rpdos {
    /// Reads every RPDO's parameters by SDO (the PDOs the node's dictionary lists; without a
    /// dictionary RPDO1..4, those that exist). RPDOs the master transmits follow the COB-ID
    /// and mapping read.
    pub fn read(&self) -> Operation<'static, PdoSet> {
        let node = self.node.clone();
        Operation::new(async move { read_set(&node, Direction::Receive).await })
    }

    /// Writes the RPDOs changed since they were read (as [`Tpdos::save`]); RPDOs the master
    /// transmits follow the new COB-ID and mapping.
    pub fn save<'a>(&self, set: &'a mut PdoSet) -> Operation<'a, ()> {
        let node = self.node.clone();
        Operation::new(async move { save_set(&node, Direction::Receive, set).await })
    }

    /// Transmits the node's RPDO `pdo` (its COB-ID and mapping, from [`read`](Self::read))
    /// from the master as `how` says, until [`RpdoSender::stop`]. Mapped values start at zero;
    /// set them through the returned sender. Starting an RPDO that is being transmitted
    /// replaces its transmission parameters. The master's engine holds four transmitted RPDOs
    /// per node. Nothing waits: the first frame is sent as [`Network::send`](crate::Network::send) says.
    ///
    /// [`Network::send`](crate::Network::send): crate::Network::send
    pub fn start(&self, pdo: &PdoParameters, how: Transmission) -> Result<RpdoSender, Error> {
        self.node.net.shared().catch_up_on_runtime()?;
        let sender = self.engage(pdo, how)?;
        self.node.net.shared().send_queued_now()?;
        Ok(sender)
    }

    /// [`start`](Self::start) without sending: the RPDO is in the master's engine, its first
    /// frame queued.
    fn engage(&self, pdo: &PdoParameters, how: Transmission) -> Result<RpdoSender, Error> {
        if pdo.direction != Direction::Receive {
            return Err(pdo.error(crate::error::PdoProblem::NotAnRpdo));
        }
        if !pdo.is_enabled() {
            return Err(pdo.error(crate::error::PdoProblem::NotValid));
        }
        // The master would send on it: on 0x000 every frame would be an NMT command.
        let index = pdo.comm_index();
        if let Some(can_id) = crate::restricted_cob_id(index, 1, pdo.comm.cob_id.0) {
            return Err(Error::RestrictedCobId {
                node: self.node.id,
                entry: canola_od::ObjectAddress::new(index, 1),
                can_id,
            });
        }
        if pdo.mapping_lenient().is_none()
            && let Some(fd) = pdo.fd_mapping_lenient()
        {
            return self.engage_fd(pdo, how, fd);
        }
        let mapping = pdo
            .mapping_lenient()
            .ok_or_else(|| pdo.error(crate::error::PdoProblem::DoesNotFit))?;
        if mapping.is_empty() {
            return Err(pdo.error(crate::error::PdoProblem::NothingMapped));
        }
        let comm = CommParams {
            cob_id: pdo.comm.cob_id,
            transmission_type: how.transmission_type,
            inhibit_time: inhibit_units(how.inhibit_time).map_err(|m| pdo.error(m))?,
            event_timer: event_millis(how.event_timer).map_err(|m| pdo.error(m))?,
            sync_start: 0,
        };
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        core.start_rpdo(self.node.id, pdo.number, PdoConfig::new(comm, mapping))
            .map_err(|e| pdo.error(crate::error::PdoProblem::Engine(e)))?;
        Ok(RpdoSender {
            node: self.node.clone(),
            number: pdo.number,
        })
    }

    /// [`engage`](Self::engage) for an RPDO of more than 8 bytes (CANopen FD): sent as CAN FD
    /// frames, which needs a CAN FD bus and a node marked CANopen FD, and event-driven (on a
    /// changed value or a trigger).
    fn engage_fd(
        &self,
        pdo: &PdoParameters,
        how: Transmission,
        mapping: canola_pdo::FdMapping,
    ) -> Result<RpdoSender, Error> {
        let needs_fd = |refusal| {
            pdo.error(crate::error::PdoProblem::NeedsFd {
                bits: mapping.bit_len(),
                node: self.node.id,
                refusal,
            })
        };
        if let Some(bus) = self.node.net.core().classic_bus() {
            return Err(needs_fd(crate::error::FdRefusal::ClassicBus {
                bus: bus.to_string(),
            }));
        }
        if !self.node.is_fd() {
            return Err(needs_fd(crate::error::FdRefusal::NodeNotFd));
        }
        if !how.transmission_type.is_event_driven()
            || !how.inhibit_time.is_zero()
            || !how.event_timer.is_zero()
        {
            return Err(pdo.error(crate::error::PdoProblem::FdNotEventDriven));
        }
        let can_id = pdo
            .comm
            .cob_id
            .can_id()
            .map_err(|e| pdo.error(crate::error::PdoProblem::Comm(e)))?;
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        core.start_fd_rpdo(self.node.id, pdo.number, can_id, mapping);
        Ok(RpdoSender {
            node: self.node.clone(),
            number: pdo.number,
        })
    }
}
