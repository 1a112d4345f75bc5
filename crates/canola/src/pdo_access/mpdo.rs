//! A node's multiplexed PDOs from the master (CiA 301 §7.2.3): [`Node::mpdo`](crate::Node::mpdo) →
//! [`Mpdos`]. [`Mpdos::receive`] takes the MPDOs the node sends on a COB-ID (SAM-MPDOs
//! through the master's scanner list, DAM-MPDOs addressed to the master or to all nodes) and
//! delivers each value like a PDO's; [`Mpdos::dam`] gives a [`DamSender`] that writes the
//! node's objects with DAM-MPDOs. Nothing here waits.

use canola_frame::CanId;
use canola_pdo::{PdoCobId, ScannerEntry};

use crate::error::Error;
use crate::network::request::NodeRef;
use crate::typed::{ObjectKey, WriteValue};

use super::transmit::encode;

/// A node's MPDOs ([`Node::mpdo`](crate::Node::mpdo)).
#[derive(Debug, Clone)]
pub struct Mpdos {
    pub(crate) node: NodeRef,
}

impl Mpdos {
    /// Takes the MPDOs the node sends on `cob_id` (a COB-ID as in sub 1 of 0x1800..: 11-bit,
    /// or 29-bit with bit 29 set) as its TPDO `number` from now on: a SAM-MPDO of this node
    /// when an entry of `scanner` covers its object (entries as in the object scanner list
    /// 0x1FA0..: block size, index, sub-index), a DAM-MPDO when addressed to all nodes or to
    /// the master's own node-ID ([`Network::set_usdo_node_id`](crate::Network::set_usdo_node_id)).
    /// Each arrives as a PDO with one value: [`NetworkEvent::PdoValues`](crate::NetworkEvent::PdoValues),
    /// the [`on_pdo`](crate::Network::on_pdo) callbacks, the [`PdoSubscriber`](crate::PdoSubscriber)s.
    pub fn receive(&self, number: u8, cob_id: u32, scanner: &[ScannerEntry]) -> Result<(), Error> {
        let can_id = self.can_id(0x1800 + u16::from(number.saturating_sub(1)), cob_id)?;
        let scanner = scanner.iter().copied().filter(|e| !e.is_unused()).collect();
        self.node
            .net
            .core()
            .receive_mpdo(self.node.id, number, can_id, scanner);
        Ok(())
    }

    /// Stops taking MPDOs on `cob_id`; `false` when none were taken there.
    pub fn stop_receiving(&self, cob_id: u32) -> bool {
        PdoCobId(cob_id)
            .can_id()
            .is_ok_and(|id| self.node.net.core().stop_mpdo(id))
    }

    /// A sender of DAM-MPDOs to the node on `cob_id` (the COB-ID of the node's RPDO whose
    /// mapping count is 0xFF).
    pub fn dam(&self, cob_id: u32) -> Result<DamSender, Error> {
        Ok(DamSender {
            node: self.node.clone(),
            can_id: self.can_id(0x1400, cob_id)?,
        })
    }

    fn can_id(&self, index: u16, cob_id: u32) -> Result<CanId, Error> {
        let entry = canola_od::ObjectAddress::new(index, 1);
        if let Some(can_id) = crate::restricted_cob_id(index, 1, cob_id) {
            return Err(Error::RestrictedCobId {
                node: self.node.id,
                entry,
                can_id,
            });
        }
        PdoCobId(cob_id).can_id().map_err(|e| Error::Value {
            node: self.node.id,
            entry,
            problem: crate::error::ValueProblem::MpdoCobId { cob_id, error: e },
        })
    }
}

/// Writes a node's objects with DAM-MPDOs ([`Mpdos::dam`]). Never waits: each write is one
/// frame, sent as [`Network::send`](crate::Network::send) sends.
#[derive(Debug, Clone)]
pub struct DamSender {
    pub(crate) node: NodeRef,
    can_id: CanId,
}

impl DamSender {
    /// The CAN identifier the MPDOs go out on.
    pub fn can_id(&self) -> CanId {
        self.can_id
    }

    /// Writes `value` into the node's object `key` (by name or address; at most 4 bytes,
    /// converted to the object's type in the node's dictionary, else an integer, float or
    /// bytes of up to 4 bytes) with one DAM-MPDO addressed to the node.
    pub fn write<'k>(
        &self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(), Error> {
        self.node.net.shared().catch_up_on_runtime()?;
        let addr = self.node.sdo().resolve(key)?;
        let od = self.node.dictionary();
        let bits = match od
            .as_deref()
            .and_then(|od| od.sub(addr.index, addr.sub_index))
            .map(|s| s.data_type.size())
        {
            Some(Some(n @ 1..=4)) => n as u8 * 8,
            Some(_) => {
                return Err(Error::Value {
                    node: self.node.id,
                    entry: addr,
                    problem: crate::error::ValueProblem::MpdoObjectSize,
                });
            }
            None => 32,
        };
        let bytes =
            encode(od.as_deref(), addr, bits, value.into()).map_err(|problem| Error::Value {
                node: self.node.id,
                entry: addr,
                problem,
            })?;
        let now = self.node.net.now();
        {
            let mut core = self.node.net.core();
            core.set_now(now);
            core.send_dam(self.node.id, self.can_id, addr, &bytes)
                .map_err(|e| Error::Value {
                    node: self.node.id,
                    entry: addr,
                    problem: crate::error::ValueProblem::Mpdo(e),
                })?;
        }
        self.node.net.shared().send_queued_now()
    }
}
