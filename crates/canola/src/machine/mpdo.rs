//! The master machine's multiplexed PDOs (CiA 301 §7.2.3): MPDOs received on a node's COB-ID
//! and delivered like other PDOs, and DAM-MPDOs the master transmits to write a node's object.
//!
//! Received, on a COB-ID the application set up with [`Core::receive_mpdo`]:
//! - a SAM-MPDO (source address mode) is taken when its producer is that node and its object
//!   is covered by the master's scanner list for it (entries laid out as object scanner list
//!   entries 0x1FA0..=0x1FCF: block size, index, sub-index); the value is typed by the
//!   producer's dictionary;
//! - a DAM-MPDO (destination address mode) is taken when addressed to all nodes (0) or to the
//!   master's own node-ID (its USDO node-ID); the value is typed by the destination's
//!   dictionary when the master knows it.
//!
//! Either is delivered as a PDO of the node, with its TPDO number as the application gave it:
//! one value, its address, and the eight data bytes (byte 0 bit 7 tells DAM from SAM).

use canola_frame::{CanFrame, CanId, Instant, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary, Value};
use canola_pdo::{Mpdo, MpdoAddress, RawValue, ScannerEntry, ValueKind};

use super::Core;
use super::events::PdoData;
use super::sdo::Outgoing;

/// How the master takes the MPDOs on one COB-ID.
pub(crate) struct MpdoRoute {
    /// The producer.
    pub(crate) node: NodeId,
    /// Its TPDO number, as delivered.
    pub(crate) number: u8,
    /// The SAM-MPDO objects taken.
    pub(crate) scanner: Vec<ScannerEntry>,
}

impl Core {
    /// Takes the MPDOs on `can_id` as `node`'s TPDO `number` from now on (replacing what was
    /// set for that COB-ID), SAM-MPDOs for the objects `scanner` covers.
    pub(crate) fn receive_mpdo(
        &mut self,
        node: NodeId,
        number: u8,
        can_id: CanId,
        scanner: Vec<ScannerEntry>,
    ) {
        self.add_node(node, None);
        self.mpdo_routes.insert(
            can_id,
            MpdoRoute {
                node,
                number,
                scanner,
            },
        );
    }

    /// Stops taking MPDOs on `can_id`; `false` when none were taken there.
    pub(crate) fn stop_mpdo(&mut self, can_id: CanId) -> bool {
        self.mpdo_routes.remove(&can_id).is_some()
    }

    /// Queues a DAM-MPDO on `can_id` writing `value` (1..=4 bytes, little-endian) into
    /// `entry` of `node`.
    pub(crate) fn send_dam(
        &mut self,
        node: NodeId,
        can_id: CanId,
        entry: ObjectAddress,
        value: &[u8],
    ) -> Result<(), canola_pdo::MpdoError> {
        let mpdo = Mpdo::dam(
            Some(node),
            canola_pdo::ObjectAddress::new(entry.index, entry.sub_index),
            value,
        )?;
        self.tx.push_back(Outgoing {
            frame: mpdo.to_frame(can_id).into(),
            transfer: None,
        });
        Ok(())
    }

    /// A frame on a COB-ID set up for MPDOs (see the module docs).
    pub(super) fn handle_mpdo(&mut self, now: Instant, frame: &CanFrame) {
        let Some(route) = self.mpdo_routes.get(&frame.id()) else {
            return;
        };
        let Ok(mpdo) = Mpdo::parse(frame.data()) else {
            return;
        };
        let (node, number) = (route.node, route.number);
        let addr = ObjectAddress::new(mpdo.index, mpdo.subindex);
        let typing = match mpdo.address {
            MpdoAddress::Source(p) => {
                if p != node || !route.scanner.iter().any(|e| e.covers(mpdo.addr())) {
                    return;
                }
                self.nodes.get(&node).and_then(|s| s.od.clone())
            }
            MpdoAddress::Destination(None) => None,
            MpdoAddress::Destination(Some(d)) => {
                if d != self.usdo_node_id() {
                    return;
                }
                None
            }
        };
        let od = self.nodes.get(&node).and_then(|s| s.od.clone());
        let value = typed(typing.as_deref(), addr, mpdo.data);
        self.pdo_scratch.clear();
        self.pdo_scratch.push((addr, value));
        super::pdo_routes::deliver_values(
            &mut self.pdo_callbacks,
            &mut self.pdo_subs,
            &mut self.subs,
            &mut self.pdo_scratch,
            (node, number, PdoData::new(frame.data()), now),
            od.as_ref(),
        );
    }
}

/// The value of an MPDO's four data bytes, typed by `od` when it has the object with a type
/// of at most four bytes, else an UNSIGNED32.
fn typed(od: Option<&ObjectDictionary>, addr: ObjectAddress, data: [u8; 4]) -> Value {
    let raw = u64::from(u32::from_le_bytes(data));
    od.and_then(|od| od.sub(addr.index, addr.sub_index))
        .and_then(|s| {
            let ty = s.data_type;
            let bytes = ty.size().filter(|n| (1..=4).contains(n))?;
            let bits = (bytes * 8) as u8;
            let kind = ValueKind::from_data_type(ty.code());
            let mask = (1u64 << bits) - 1;
            RawValue::from_raw(kind, raw & mask, bits).to_value(ty).ok()
        })
        .unwrap_or(Value::Unsigned32(raw as u32))
}
