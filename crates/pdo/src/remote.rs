//! Remote PDO configuration (CiA 301 §7.2.2.3 "PDO mapping" procedure, §7.4.8): the SDO writes a
//! master performs to give a node's PDO new communication and mapping parameters, produced as
//! data for the master's SDO client to execute in order.
//!
//! The CiA 301 procedure, which [`remap`] follows:
//! 1. destroy the PDO: COB-ID (comm sub 1) with bit 31 set (the new identifier may be written in
//!    the same step; identifiers may only change while the PDO is invalid);
//! 2. disable the mapping: mapping sub 0 = 0;
//! 3. write the entries, mapping sub 1..=n;
//! 4. enable the mapping: mapping sub 0 = n (the device checks the entries here and answers
//!    abort 0x0604_0041/0x0604_0042 if an object cannot be mapped or the PDO would be too long);
//! 5. communication parameters: transmission type (sub 2), inhibit time (sub 3), event timer
//!    (sub 5), SYNC start value (sub 6) — inhibit time may only change while the PDO is invalid;
//! 6. create the PDO: the COB-ID with bit 31 as wanted (normally clear).
//!
//! A node with static (read-only) mapping objects cannot do steps 2..4: [`remap`] then only
//! accepts a wanted mapping equal to the node's fixed one and leaves the mapping writes out;
//! anything else is [`RemapError::StaticMapping`], before any write is made.

use heapless::Vec;

use crate::comm::{
    COB_ID_INVALID, CommParams, Direction, MAX_PDOS_PER_DIRECTION, SUB_COB_ID, SUB_EVENT_TIMER,
    SUB_INHIBIT_TIME, SUB_SYNC_START, SUB_TRANSMISSION_TYPE,
};
use crate::fd::FdMapping;
use crate::mapping::{MAX_ENTRIES, Mapping};

/// Most steps one plan holds: COB-ID twice, sub 0 twice, 64 entries, four parameters.
pub const MAX_STEPS: usize = 2 + 2 + MAX_ENTRIES + 4;

/// One expedited SDO download: `value` (little-endian, 1..=4 bytes) into `index:subindex`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SdoWrite {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub subindex: u8,
    value: [u8; 4],
    len: u8,
}

impl SdoWrite {
    fn u8(index: u16, subindex: u8, v: u8) -> Self {
        Self {
            index,
            subindex,
            value: [v, 0, 0, 0],
            len: 1,
        }
    }

    fn u16(index: u16, subindex: u8, v: u16) -> Self {
        let b = v.to_le_bytes();
        Self {
            index,
            subindex,
            value: [b[0], b[1], 0, 0],
            len: 2,
        }
    }

    fn u32(index: u16, subindex: u8, v: u32) -> Self {
        Self {
            index,
            subindex,
            value: v.to_le_bytes(),
            len: 4,
        }
    }

    /// The bytes to write (UNSIGNED8/16/32 little-endian, sized as the object).
    pub fn value(&self) -> &[u8] {
        &self.value[..self.len as usize]
    }

    /// The value as an integer.
    pub fn value_u32(&self) -> u32 {
        u32::from_le_bytes(self.value)
    }
}

/// The ordered writes of a remote configuration.
pub type RemapSteps = Vec<SdoWrite, MAX_STEPS>;

/// What the master knows about the node's PDO objects (from its EDS/DCF).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RemoteObjects<'a> {
    /// Whether the mapping object is writable (dynamic mapping). `false` = static mapping.
    pub mapping_writable: bool,
    /// The node's current mapping entries, needed when the mapping is static.
    pub current_mapping: Option<&'a [u32]>,
    /// Whether the communication object has sub 3 (inhibit time).
    pub has_inhibit_time: bool,
    /// Whether it has sub 5 (event timer).
    pub has_event_timer: bool,
    /// Whether it has sub 6 (SYNC start value).
    pub has_sync_start: bool,
}

impl RemoteObjects<'_> {
    /// A node with writable mapping and every communication sub-index of the direction
    /// (RPDO: 1, 2, 5; TPDO: 1, 2, 3, 5, 6).
    pub const fn dynamic(direction: Direction) -> Self {
        let tx = matches!(direction, Direction::Transmit);
        Self {
            mapping_writable: true,
            current_mapping: None,
            has_inhibit_time: tx,
            has_event_timer: true,
            has_sync_start: tx,
        }
    }
}

/// Why no plan was produced.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RemapError {
    /// PDO numbers run 0..=511 per direction.
    #[error("PDO number {0} is outside 0..=511")]
    PdoNumber(u16),
    /// The mapping object is read-only and holds another mapping: this PDO cannot carry the
    /// wanted objects on this node (pick another PDO or accept its fixed mapping).
    #[error(
        "mapping object 0x{index:04X} is read-only (static mapping) and differs from the wanted mapping"
    )]
    StaticMapping {
        /// The mapping object.
        index: u16,
    },
    /// The mapping is read-only and the node's current mapping was not given.
    #[error("mapping object 0x{index:04X} is read-only and its current entries are unknown")]
    StaticMappingUnknown {
        /// The mapping object.
        index: u16,
    },
}

debug_as_display!(RemapError);

/// The writes that give PDO `number` (0-based: TPDO1 is `(Transmit, 0)`, object 0x1800/0x1A00)
/// of a node the wanted parameters, in the CiA 301 order (see the module docs).
pub fn remap(
    direction: Direction,
    number: u16,
    comm: &CommParams,
    mapping: &Mapping,
    node: &RemoteObjects<'_>,
) -> Result<RemapSteps, RemapError> {
    plan(
        direction,
        number,
        comm,
        &entries(mapping.raw_entries()),
        node,
    )
}

/// [`remap`] for a CAN FD PDO of up to 64 bytes (CANopen FD): the same writes in the same
/// order, with the entries of `mapping`.
pub fn remap_fd(
    direction: Direction,
    number: u16,
    comm: &CommParams,
    mapping: &FdMapping,
    node: &RemoteObjects<'_>,
) -> Result<RemapSteps, RemapError> {
    plan(
        direction,
        number,
        comm,
        &entries(mapping.raw_entries()),
        node,
    )
}

/// The raw entries of a mapping (at most 64, as both mapping types guarantee).
fn entries(raw: impl Iterator<Item = u32>) -> Vec<u32, MAX_ENTRIES> {
    let mut v = Vec::new();
    for e in raw {
        let _ = v.push(e);
    }
    v
}

/// The writes of [`remap`] for the raw mapping `entries`.
fn plan(
    direction: Direction,
    number: u16,
    comm: &CommParams,
    entries: &[u32],
    node: &RemoteObjects<'_>,
) -> Result<RemapSteps, RemapError> {
    if number >= MAX_PDOS_PER_DIRECTION {
        return Err(RemapError::PdoNumber(number));
    }
    let comm_index = direction.comm_index(number);
    let map_index = direction.mapping_index(number);
    let write_mapping = if node.mapping_writable {
        true
    } else {
        let current = node
            .current_mapping
            .ok_or(RemapError::StaticMappingUnknown { index: map_index })?;
        if current != entries {
            return Err(RemapError::StaticMapping { index: map_index });
        }
        false
    };

    let mut steps = RemapSteps::new();
    // At most MAX_STEPS pushes by construction; the results are ignored for that reason.
    let _ = steps.push(SdoWrite::u32(
        comm_index,
        SUB_COB_ID,
        comm.cob_id.0 | COB_ID_INVALID,
    ));
    if write_mapping {
        let _ = steps.push(SdoWrite::u8(map_index, 0, 0));
        for (sub, raw) in (1u8..).zip(entries) {
            let _ = steps.push(SdoWrite::u32(map_index, sub, *raw));
        }
        let _ = steps.push(SdoWrite::u8(map_index, 0, entries.len() as u8));
    }
    let _ = steps.push(SdoWrite::u8(
        comm_index,
        SUB_TRANSMISSION_TYPE,
        comm.transmission_type.code(),
    ));
    if node.has_inhibit_time {
        let _ = steps.push(SdoWrite::u16(
            comm_index,
            SUB_INHIBIT_TIME,
            comm.inhibit_time,
        ));
    }
    if node.has_event_timer {
        let _ = steps.push(SdoWrite::u16(comm_index, SUB_EVENT_TIMER, comm.event_timer));
    }
    if node.has_sync_start {
        let _ = steps.push(SdoWrite::u8(comm_index, SUB_SYNC_START, comm.sync_start));
    }
    let _ = steps.push(SdoWrite::u32(comm_index, SUB_COB_ID, comm.cob_id.0));
    Ok(steps)
}

/// The single write that destroys PDO `number` (COB-ID with bit 31 set), keeping `cob_id`'s
/// other bits.
pub fn disable(
    direction: Direction,
    number: u16,
    cob_id: crate::comm::PdoCobId,
) -> Result<SdoWrite, RemapError> {
    if number >= MAX_PDOS_PER_DIRECTION {
        return Err(RemapError::PdoNumber(number));
    }
    Ok(SdoWrite::u32(
        direction.comm_index(number),
        SUB_COB_ID,
        cob_id.0 | COB_ID_INVALID,
    ))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;
    use std::vec::Vec;

    use super::*;
    use crate::comm::{PdoCobId, TransmissionType};

    fn steps_as_tuples(s: &RemapSteps) -> Vec<(u16, u8, Vec<u8>)> {
        s.iter()
            .map(|w| (w.index, w.subindex, w.value().to_vec()))
            .collect()
    }

    #[test]
    fn an_fd_pdo_of_64_bytes_is_remapped_in_the_same_order() {
        let comm = CommParams {
            cob_id: PdoCobId(0x185),
            transmission_type: TransmissionType::EventProfile,
            inhibit_time: 0,
            event_timer: 0,
            sync_start: 0,
        };
        // Sixteen UNSIGNED32: 512 bits, too long for a classic PDO.
        let raw: Vec<u32> = (1..=16u32).map(|s| 0x2100_0020 | (s << 8)).collect();
        assert_eq!(
            Mapping::from_raw(&raw),
            Err(crate::MappingError::TooLong(96)),
            "the classic limit is hit at the third entry"
        );
        let fd = FdMapping::from_raw(&raw).unwrap();
        let node = RemoteObjects::dynamic(Direction::Transmit);
        let s = remap_fd(Direction::Transmit, 0, &comm, &fd, &node).unwrap();
        let t = steps_as_tuples(&s);
        assert_eq!(t[0], (0x1800, 1, [0x85, 0x01, 0x00, 0x80].to_vec()));
        assert_eq!(t[1], (0x1A00, 0, [0].to_vec()));
        for (i, raw) in raw.iter().enumerate() {
            assert_eq!(t[2 + i], (0x1A00, i as u8 + 1, raw.to_le_bytes().to_vec()));
        }
        assert_eq!(t[18], (0x1A00, 0, [16].to_vec()));
        assert_eq!(
            t.last(),
            Some(&(0x1800, 1, [0x85, 0x01, 0x00, 0x00].to_vec()))
        );
        // A classic mapping gives the same writes through either function.
        let classic = Mapping::from_raw(&raw[..2]).unwrap();
        assert_eq!(
            remap(Direction::Transmit, 0, &comm, &classic, &node),
            remap_fd(
                Direction::Transmit,
                0,
                &comm,
                &FdMapping::from(&classic),
                &node
            )
        );
        // The error says bits and bytes.
        assert_eq!(
            crate::MappingError::TooLong(96).to_string(),
            "the mapped objects need 96 bits (12 bytes); a classic CAN PDO carries at most 64 \
             bits (8 bytes)"
        );
    }

    #[test]
    fn dynamic_tpdo_remap_in_cia301_order() {
        let comm = CommParams {
            cob_id: PdoCobId(0x4000_0285),
            transmission_type: TransmissionType::EventProfile,
            inhibit_time: 100,
            event_timer: 500,
            sync_start: 0,
        };
        let mapping = Mapping::from_raw(&[0x6000_0108, 0x6401_0110]).unwrap();
        let s = remap(
            Direction::Transmit,
            1,
            &comm,
            &mapping,
            &RemoteObjects::dynamic(Direction::Transmit),
        )
        .unwrap();
        assert_eq!(
            steps_as_tuples(&s),
            [
                (0x1801, 1, [0x85, 0x02, 0x00, 0xC0].to_vec()),
                (0x1A01, 0, [0].to_vec()),
                (0x1A01, 1, [0x08, 0x01, 0x00, 0x60].to_vec()),
                (0x1A01, 2, [0x10, 0x01, 0x01, 0x64].to_vec()),
                (0x1A01, 0, [2].to_vec()),
                (0x1801, 2, [0xFF].to_vec()),
                (0x1801, 3, [100, 0].to_vec()),
                (0x1801, 5, [0xF4, 0x01].to_vec()),
                (0x1801, 6, [0].to_vec()),
                (0x1801, 1, [0x85, 0x02, 0x00, 0x40].to_vec()),
            ]
        );
    }

    #[test]
    fn rpdo_remap_leaves_out_tpdo_only_subs() {
        let comm = CommParams::event_driven(0x205);
        let mapping = Mapping::from_raw(&[0x6200_0108]).unwrap();
        let s = remap(
            Direction::Receive,
            0,
            &comm,
            &mapping,
            &RemoteObjects::dynamic(Direction::Receive),
        )
        .unwrap();
        let subs: Vec<(u16, u8)> = s.iter().map(|w| (w.index, w.subindex)).collect();
        assert_eq!(
            subs,
            [
                (0x1400, 1),
                (0x1600, 0),
                (0x1600, 1),
                (0x1600, 0),
                (0x1400, 2),
                (0x1400, 5),
                (0x1400, 1)
            ]
        );
        assert_eq!(s[0].value_u32(), 0xC000_0205);
        assert_eq!(s[6].value_u32(), 0x4000_0205);
    }

    #[test]
    fn static_mapping() {
        let comm = CommParams::event_driven(0x185);
        let fixed = [0x6000_0108u32];
        let same = Mapping::from_raw(&fixed).unwrap();
        let other = Mapping::from_raw(&[0x6000_0208]).unwrap();
        let node = RemoteObjects {
            mapping_writable: false,
            current_mapping: Some(&fixed),
            ..RemoteObjects::dynamic(Direction::Transmit)
        };
        let s = remap(Direction::Transmit, 0, &comm, &same, &node).unwrap();
        assert!(s.iter().all(|w| w.index == 0x1800), "no mapping writes");
        assert_eq!(s.len(), 6);
        assert_eq!(
            remap(Direction::Transmit, 0, &comm, &other, &node),
            Err(RemapError::StaticMapping { index: 0x1A00 })
        );
        let unknown = RemoteObjects {
            current_mapping: None,
            ..node
        };
        assert_eq!(
            remap(Direction::Transmit, 0, &comm, &same, &unknown),
            Err(RemapError::StaticMappingUnknown { index: 0x1A00 })
        );
    }

    #[test]
    fn full_mapping_fits_and_numbers_are_checked() {
        let entries = [0x6000_0101u32; 64];
        let mapping = Mapping::from_raw(&entries).unwrap();
        let comm = CommParams::event_driven(0x185);
        let s = remap(
            Direction::Transmit,
            511,
            &comm,
            &mapping,
            &RemoteObjects::dynamic(Direction::Transmit),
        )
        .unwrap();
        assert_eq!(s.len(), MAX_STEPS);
        assert_eq!(s[0].index, 0x19FF);
        assert_eq!(s[1].index, 0x1BFF);
        assert_eq!(
            remap(
                Direction::Transmit,
                512,
                &comm,
                &mapping,
                &RemoteObjects::dynamic(Direction::Transmit)
            ),
            Err(RemapError::PdoNumber(512))
        );
        assert_eq!(
            disable(Direction::Receive, 2, PdoCobId(0x405)).map(|w| (w.index, w.value_u32())),
            Ok((0x1402, 0x8000_0405))
        );
    }
}
