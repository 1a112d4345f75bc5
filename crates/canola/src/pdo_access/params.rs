//! A node's PDO parameters as the master reads and changes them (CiA 301 §7.4.8): one
//! [`PdoParameters`] per PDO (communication and mapping object) and the [`PdoSet`] of a
//! direction, with the checks a change must pass before it is saved.

use std::sync::Arc;

use canola_frame::{CanId, Duration, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::{
    Catalog, CommParams, Direction, Mapping, MappingEntry, OdView, PdoCobId, TransmissionType,
};

use crate::error::Error;
use crate::typed::ObjectKey;

/// One mapped object of a PDO: its address and mapped length, with its name when the node has
/// a dictionary that describes it (`"Sensor Value 1.Value"`, as [`ObjectDictionary::find`]
/// resolves names).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MappedVariable {
    /// The mapped object (a data type index 0x0001..=0x0007 for a dummy entry).
    pub addr: ObjectAddress,
    /// The mapped length in bits.
    pub bits: u8,
    /// The object's name in the node's dictionary.
    pub name: Option<String>,
}

impl MappedVariable {
    /// The raw mapping entry, `index << 16 | subindex << 8 | bits`.
    pub fn entry(&self) -> u32 {
        MappingEntry::new(self.addr.index, self.addr.sub_index, self.bits).0
    }
}

/// Which optional sub-indices of the communication object the node has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Present {
    pub(super) inhibit_time: bool,
    pub(super) event_timer: bool,
    pub(super) sync_start: bool,
    pub(super) mapping_writable: bool,
}

/// The communication and mapping parameters of one PDO of a node, as read by
/// [`Tpdos::read`](crate::Tpdos::read) / [`Rpdos::read`](crate::Rpdos::read). Change the public fields (or use the setters) and save
/// the set with `save()`.
#[derive(Debug, Clone)]
pub struct PdoParameters {
    pub(super) direction: Direction,
    pub(super) number: u16,
    /// Communication parameters. `inhibit_time` is in units of 100 µs and `event_timer` in ms,
    /// as on the bus; sub-indices the node does not have read as 0 and are not written.
    pub comm: CommParams,
    /// The mapped objects in PDO order.
    pub mapped: Vec<MappedVariable>,
    pub(super) present: Present,
    /// Sub 0 of the mapping object when it selects an MPDO (0xFE, 0xFF).
    pub(super) mpdo: Option<u8>,
    /// What the node holds (as read or last saved): `save` writes only what differs.
    pub(super) saved: (CommParams, Vec<u32>),
    pub(super) node: NodeId,
    pub(super) od: Option<Arc<ObjectDictionary>>,
}

impl PartialEq for PdoParameters {
    fn eq(&self, other: &Self) -> bool {
        (self.direction, self.number, self.comm, &self.mapped)
            == (other.direction, other.number, other.comm, &other.mapped)
    }
}

impl PdoParameters {
    /// TPDO or RPDO (seen from the node).
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// The PDO number, 1-based (TPDO1 is object 0x1800 / 0x1A00).
    pub fn number(&self) -> u16 {
        self.number
    }

    /// Whether the PDO exists (COB-ID bit 31 clear).
    pub fn is_enabled(&self) -> bool {
        self.comm.cob_id.is_valid()
    }

    /// Sets COB-ID bit 31: `false` makes the PDO not exist.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.comm.cob_id = self.comm.cob_id.with_valid(enabled);
    }

    /// The CAN identifier of the COB-ID (an error when its bits do not form one).
    pub fn can_id(&self) -> Result<CanId, Error> {
        self.comm
            .cob_id
            .can_id()
            .map_err(|e| self.error(crate::error::PdoProblem::Comm(e)))
    }

    /// Puts the PDO on another identifier, keeping the valid and RTR bits (bit 29 follows the
    /// identifier's format).
    pub fn set_can_id(&mut self, id: CanId) {
        let flags = self.comm.cob_id.0 & 0xC000_0000;
        self.comm.cob_id = match id {
            CanId::Standard(s) => PdoCobId(flags | u32::from(s.as_raw())),
            CanId::Extended(e) => PdoCobId(flags | canola_pdo::comm::COB_ID_EXTENDED | e.as_raw()),
        };
    }

    /// Whether remote requests are allowed (COB-ID bit 30 clear).
    pub fn rtr_allowed(&self) -> bool {
        self.comm.cob_id.rtr_allowed()
    }

    /// The transmission type.
    pub fn transmission_type(&self) -> TransmissionType {
        self.comm.transmission_type
    }

    /// Sets the transmission type.
    pub fn set_transmission_type(&mut self, t: TransmissionType) {
        self.comm.transmission_type = t;
    }

    /// The inhibit time (sub 3).
    pub fn inhibit_time(&self) -> Duration {
        self.comm.inhibit()
    }

    /// Sets the inhibit time: a multiple of 100 µs up to 6.5535 s, on a node that has sub 3.
    pub fn set_inhibit_time(&mut self, d: impl Into<Duration>) -> Result<(), Error> {
        if !self.present.inhibit_time {
            return Err(self.error(crate::error::PdoProblem::NoInhibitTime));
        }
        self.comm.inhibit_time = inhibit_units(d.into()).map_err(|m| self.error(m))?;
        Ok(())
    }

    /// The event timer (sub 5; zero = off).
    pub fn event_timer(&self) -> Duration {
        self.comm.event_time()
    }

    /// Sets the event timer: whole milliseconds up to 65.535 s, on a node that has sub 5.
    pub fn set_event_timer(&mut self, d: impl Into<Duration>) -> Result<(), Error> {
        if !self.present.event_timer {
            return Err(self.error(crate::error::PdoProblem::NoEventTimer));
        }
        self.comm.event_timer = event_millis(d.into()).map_err(|m| self.error(m))?;
        Ok(())
    }

    /// Whether the node has an inhibit time (sub 3) for this PDO.
    pub fn has_inhibit_time(&self) -> bool {
        self.present.inhibit_time
    }

    /// Whether the node has an event timer (sub 5) for this PDO.
    pub fn has_event_timer(&self) -> bool {
        self.present.event_timer
    }

    /// Whether the node has a SYNC start value (sub 6) for this PDO.
    pub fn has_sync_start(&self) -> bool {
        self.present.sync_start
    }

    /// Whether the mapping is an MPDO (mapping sub 0 = 0xFE or 0xFF); `mapped` is empty then.
    pub fn mpdo(&self) -> Option<u8> {
        self.mpdo
    }

    /// Removes every mapped object.
    pub fn clear(&mut self) {
        self.mapped.clear();
        self.mpdo = None;
    }

    /// Maps one more object, by name (`"Sensor Value 1.Value"`) or address, with its size from
    /// the node's dictionary. Without a dictionary use [`map_entry`](Self::map_entry).
    pub fn map<'k>(&mut self, key: impl Into<ObjectKey<'k>>) -> Result<(), Error> {
        let Some(od) = self.od.clone() else {
            return Err(Error::UnknownObject {
                node: self.node,
                name: String::new(),
                reason: crate::error::Unresolved::NoDictionary,
            });
        };
        let key = key.into();
        let addr = match key {
            ObjectKey::Address(a) => a,
            ObjectKey::Name(name) => od.find(name).ok_or_else(|| Error::UnknownObject {
                node: self.node,
                name: name.into(),
                reason: crate::error::Unresolved::NotFound,
            })?,
        };
        let info = OdView::new(&od, self.node.get())
            .object_info(addr)
            .ok_or_else(|| Error::Value {
                node: self.node,
                entry: addr,
                problem: crate::error::ValueProblem::NotDescribed,
            })?;
        let bits = u8::try_from(info.bits).map_err(|_| Error::Value {
            node: self.node,
            entry: addr,
            problem: crate::error::ValueProblem::TooWideForPdo {
                bits: u32::from(info.bits),
            },
        })?;
        self.map_entry(addr, bits);
        Ok(())
    }

    /// Maps one more object with `bits` as its length (a dummy entry: a data type index
    /// 0x0001..=0x0007 as `addr.index`). The mapping is checked when it is saved.
    pub fn map_entry(&mut self, addr: ObjectAddress, bits: u8) {
        let name = self.od.as_deref().and_then(|od| name_of(od, addr));
        self.mapped.push(MappedVariable { addr, bits, name });
        self.mpdo = None;
    }

    /// Whether the parameters differ from what the node holds (as read or last saved).
    pub fn is_changed(&self) -> bool {
        let (comm, entries) = &self.saved;
        *comm != self.comm || !entries.iter().copied().eq(self.raw_entries())
    }

    pub(super) fn raw_entries(&self) -> impl Iterator<Item = u32> + '_ {
        self.mapped.iter().map(MappedVariable::entry)
    }

    /// The mapping as the PDO engine takes it, checked against the node's dictionary when it
    /// has one (objects exist, are mappable with the access the direction needs, sizes match).
    pub fn mapping(&self) -> Result<Mapping, Error> {
        let raw: Vec<u32> = self.raw_entries().collect();
        let mapping = match self.od.as_deref() {
            Some(od) => {
                Mapping::from_raw_checked(self.direction, &raw, &OdView::new(od, self.node.get()))
            }
            None => Mapping::from_raw(&raw),
        };
        mapping.map_err(|e| self.error(crate::error::PdoProblem::Mapping(e)))
    }

    /// The mapping under the CAN FD limits (up to 64 bytes, CANopen FD), checked as
    /// [`mapping`](Self::mapping) is. `save()` uses it for a PDO of more than 8 bytes on a node
    /// marked CANopen FD on a CAN FD bus.
    pub fn fd_mapping(&self) -> Result<canola_pdo::FdMapping, Error> {
        let raw: Vec<u32> = self.raw_entries().collect();
        let mapping = match self.od.as_deref() {
            Some(od) => canola_pdo::FdMapping::from_raw_checked(
                self.direction,
                &raw,
                &OdView::new(od, self.node.get()),
            ),
            None => canola_pdo::FdMapping::from_raw(&raw),
        };
        mapping.map_err(|e| self.error(crate::error::PdoProblem::Mapping(e)))
    }

    /// The mapping for decoding and encoding: checked when possible, else with every object
    /// read as unsigned (a node may report a mapping its dictionary does not allow).
    pub(super) fn mapping_lenient(&self) -> Option<Mapping> {
        self.mapping().ok().or_else(|| {
            let raw: Vec<u32> = self.raw_entries().collect();
            Mapping::from_raw(&raw).ok()
        })
    }

    /// The mapping under the CAN FD limits (up to 64 bytes), checked as
    /// [`mapping`](Self::mapping) when possible, else with every object read as unsigned.
    pub(super) fn fd_mapping_lenient(&self) -> Option<canola_pdo::FdMapping> {
        let raw: Vec<u32> = self.raw_entries().collect();
        self.od
            .as_deref()
            .and_then(|od| {
                canola_pdo::FdMapping::from_raw_checked(
                    self.direction,
                    &raw,
                    &OdView::new(od, self.node.get()),
                )
                .ok()
            })
            .or_else(|| canola_pdo::FdMapping::from_raw(&raw).ok())
    }

    pub(super) fn comm_index(&self) -> u16 {
        self.direction.comm_index(self.number - 1)
    }

    pub(super) fn error(&self, problem: crate::error::PdoProblem) -> Error {
        Error::Value {
            node: self.node,
            entry: ObjectAddress::new(self.comm_index(), 0),
            problem: crate::error::ValueProblem::Pdo {
                direction: self.direction,
                number: self.number,
                problem,
            },
        }
    }
}

/// The inhibit time in units of 100 µs.
pub(super) fn inhibit_units(d: Duration) -> Result<u16, crate::error::PdoProblem> {
    let us = d.as_micros();
    if !us.is_multiple_of(100) {
        return Err(crate::error::PdoProblem::InhibitTimeNotMultiple(d));
    }
    u16::try_from(us / 100).map_err(|_| crate::error::PdoProblem::InhibitTimeTooLong(d))
}

/// The event timer in ms.
pub(super) fn event_millis(d: Duration) -> Result<u16, crate::error::PdoProblem> {
    let us = d.as_micros();
    if !us.is_multiple_of(1000) {
        return Err(crate::error::PdoProblem::EventTimerNotWholeMs(d));
    }
    u16::try_from(us / 1000).map_err(|_| crate::error::PdoProblem::EventTimerTooLong(d))
}

pub(super) fn name_of(od: &ObjectDictionary, addr: ObjectAddress) -> Option<String> {
    od.sub(addr.index, addr.sub_index)
        .map(|_| crate::typed::object_name(od, addr))
}

/// Every PDO of one direction a node has, as read by SDO. Indexed by PDO number.
#[derive(Debug, Clone, PartialEq)]
pub struct PdoSet {
    pub(super) direction: Direction,
    pub(super) pdos: Vec<PdoParameters>,
}

impl PdoSet {
    /// TPDOs or RPDOs (seen from the node).
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// PDO `number` (1-based), if the node has it.
    pub fn get(&self, number: u16) -> Option<&PdoParameters> {
        self.pdos.iter().find(|p| p.number == number)
    }

    /// PDO `number` (1-based), to change it.
    pub fn get_mut(&mut self, number: u16) -> Option<&mut PdoParameters> {
        self.pdos.iter_mut().find(|p| p.number == number)
    }

    /// The PDOs in number order.
    pub fn iter(&self) -> impl Iterator<Item = &PdoParameters> {
        self.pdos.iter()
    }

    /// How many PDOs the node has in this direction.
    pub fn len(&self) -> usize {
        self.pdos.len()
    }

    /// Whether the node has none.
    pub fn is_empty(&self) -> bool {
        self.pdos.is_empty()
    }
}
