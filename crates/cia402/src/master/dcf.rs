//! PDO mappings for the cyclic synchronous modes taken from a DCF: [`DcfPdos`] reads the PDOs a
//! device's configuration file sets up (communication objects 0x1400.. / 0x1800.. and mapping
//! objects 0x1600.. / 0x1A00.., each sub-object's `ParameterValue`, else its `DefaultValue`,
//! `$NODEID` resolved), and [`DcfPdos::for_mode`] finds the ones a mode runs on: the valid
//! synchronous RPDO that carries the mode's target and the valid TPDOs that carry its actual
//! value. [`Drive::start_cyclic_from_dcf`](crate::master::Drive::start_cyclic_from_dcf) writes
//! those to the device and streams through them.
//!
//! The file is read with the dictionary parser (`canola::od`) and the PDO parameters with the
//! PDO engine's own readers (`canola::pdo::CommParams::read_from`,
//! `canola::pdo::Mapping::from_raw_checked` against the file's dictionary), the same values a
//! CiA 302 boot of the file writes to the device.

use std::format;
use std::prelude::rust_2024::*;

use canola::NodeId;
use canola::od::ObjectDictionary;
use canola::pdo::{CommParams, Dictionary, Direction, Mapping, MappingEntry, OdView};

use crate::mode::ModeOfOperation;
use crate::objects as obj;

use super::drive::pdo_kind;

/// One PDO as a DCF configures it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DcfPdo {
    /// RPDO or TPDO (seen from the device).
    pub direction: Direction,
    /// The PDO number, 1-based (RPDO1 is 0x1400 / 0x1600).
    pub number: u16,
    /// The communication parameters (COB-ID, transmission type, inhibit time, event timer).
    pub comm: CommParams,
    /// The raw mapping entries (`index << 16 | sub-index << 8 | bits`) in PDO order.
    pub entries: Vec<u32>,
}

impl DcfPdo {
    /// Whether the COB-ID's bit 31 leaves the PDO valid.
    pub fn is_valid(&self) -> bool {
        self.comm.cob_id.is_valid()
    }

    /// The mapped objects: (index, sub-index, bits).
    pub fn objects(&self) -> impl Iterator<Item = (u16, u8, u8)> + '_ {
        self.entries.iter().map(|&e| {
            let m = MappingEntry(e);
            (m.index(), m.subindex(), m.bits())
        })
    }

    /// Whether `at` is mapped.
    pub fn maps(&self, at: (u16, u8)) -> bool {
        self.objects().any(|(i, s, _)| (i, s) == at)
    }

    fn name(&self) -> String {
        format!("{}{}", pdo_kind(self.direction), self.number)
    }

    /// `RPDO3 (COB-ID 0x405, type 1): 0x607A:00, 0x6040:00`, for error messages.
    fn describe(&self) -> String {
        let objects: Vec<String> = self
            .objects()
            .map(|(i, s, _)| format!("0x{i:04X}:{s:02X}"))
            .collect();
        let state = if self.is_valid() {
            format!(
                "COB-ID 0x{:03X}, type {}",
                self.comm.cob_id.0 & 0x1FFF_FFFF,
                self.comm.transmission_type.code()
            )
        } else {
            "not valid".to_string()
        };
        let objects = if objects.is_empty() {
            "nothing mapped".to_string()
        } else {
            objects.join(", ")
        };
        format!("{} ({state}): {objects}", self.name())
    }
}

/// Why the PDOs of a DCF cannot serve a mode.
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum DcfPdoError {
    /// The file is not a DCF the parser reads.
    #[error("the DCF does not parse: {0}")]
    Parse(canola::od::ParseError),
    /// A valid PDO of the file is not one a device could run (a mapped object the file does not
    /// have, not mappable, of another size, over 64 bits; a reserved transmission type).
    #[error("{}{number} in the DCF: {problem}", pdo_kind(*direction))]
    Pdo {
        /// RPDO or TPDO (seen from the device).
        direction: Direction,
        /// Its number, 1-based.
        number: u16,
        /// What is wrong with it: the object and the PDO reader's explanation.
        problem: String,
    },
    /// The mode is not one of the cyclic synchronous modes.
    #[error("mode {0} is not a cyclic synchronous mode (csp, csv, cst)")]
    NotCyclic(ModeOfOperation),
    /// The DCF maps an object the mode needs in no PDO that could carry it.
    #[error(
        "{} needs {object} (0x{index:04X}:{sub_index:02X}) in {}; the DCF maps it in none. Its {}s: {}",
        mode.short_name().unwrap_or("the mode"),
        carrier(*direction),
        pdo_kind(*direction),
        described(found)
    )]
    Missing {
        /// The mode.
        mode: ModeOfOperation,
        /// What the object is (`the target position`).
        object: &'static str,
        /// The object's index (axis offset included).
        index: u16,
        /// Its sub-index.
        sub_index: u8,
        /// Which PDOs must carry it: a valid synchronous RPDO, or a valid TPDO.
        direction: Direction,
        /// The PDOs of that direction the DCF has.
        found: Vec<DcfPdo>,
    },
}

/// `Debug` prints what `Display` prints (the stack's error convention).
impl core::fmt::Debug for DcfPdoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

fn carrier(direction: Direction) -> &'static str {
    match direction {
        Direction::Receive => "a valid synchronous RPDO",
        Direction::Transmit => "a valid TPDO",
    }
}

fn described(pdos: &[DcfPdo]) -> String {
    if pdos.is_empty() {
        "none".to_string()
    } else {
        pdos.iter()
            .map(DcfPdo::describe)
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// What one mode runs on, from a DCF ([`DcfPdos::for_mode`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModePdos {
    /// The mode.
    pub mode: ModeOfOperation,
    /// The target object (axis offset included).
    pub target: (u16, u8),
    /// Its size in bits.
    pub target_bits: u8,
    /// The valid synchronous RPDO carrying the target (the first such one).
    pub rpdo: DcfPdo,
    /// The valid TPDOs carrying the mode's actual value (0x6064, 0x606C or 0x6077).
    pub tpdos: Vec<DcfPdo>,
}

/// The PDOs a DCF configures for a device (see the module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DcfPdos {
    rpdos: Vec<DcfPdo>,
    tpdos: Vec<DcfPdo>,
}

impl DcfPdos {
    /// Parses DCF (or EDS) text and reads its PDOs for node `node` (what `$NODEID` stands for).
    pub fn parse(text: &[u8], node: NodeId) -> Result<Self, DcfPdoError> {
        let od = canola::od::parse(text).map_err(DcfPdoError::Parse)?.od;
        Self::from_dictionary(&od, node)
    }

    /// Reads the PDOs of a parsed DCF for node `node`. Every PDO whose communication object
    /// the file has is read; the valid ones (COB-ID bit 31 clear) are checked against the
    /// file's dictionary as a device would check them.
    pub fn from_dictionary(od: &ObjectDictionary, node: NodeId) -> Result<Self, DcfPdoError> {
        let view = OdView::new(od, node.get());
        let read = |direction: Direction| -> Result<Vec<DcfPdo>, DcfPdoError> {
            let mut out = Vec::new();
            for n in 0u16..512 {
                let comm_index = direction.comm_index(n);
                let map_index = comm_index + 0x200;
                if od.sub(comm_index, 1).is_none() {
                    continue;
                }
                let bad = |problem: String| DcfPdoError::Pdo {
                    direction,
                    number: n + 1,
                    problem,
                };
                let comm = CommParams::read_from(&view, comm_index)
                    .map_err(|e| bad(format!("0x{comm_index:04X}: {e}")))?;
                let count = match view.read_u32(map_index, 0) {
                    Ok(c) => c,
                    Err(_) if !comm.cob_id.is_valid() => 0,
                    Err(e) => return Err(bad(format!("0x{map_index:04X}: {e}"))),
                };
                let mut entries = Vec::new();
                if comm.cob_id.is_valid() {
                    if count > 64 {
                        return Err(bad(format!(
                            "0x{map_index:04X}:00 = {count}: not a number of entries"
                        )));
                    }
                    for sub in 1..=count as u8 {
                        entries.push(
                            view.read_u32(map_index, sub)
                                .map_err(|e| bad(format!("0x{map_index:04X}:{sub:02X}: {e}")))?,
                        );
                    }
                    Mapping::from_raw_checked(direction, &entries, &view)
                        .map_err(|e| bad(format!("mapping 0x{map_index:04X}: {e}")))?;
                    comm.validate().map_err(|e| bad(e.to_string()))?;
                } else {
                    // An invalid PDO's mapping is kept as far as it reads.
                    for sub in 1..=count.min(64) as u8 {
                        match view.read_u32(map_index, sub) {
                            Ok(e) => entries.push(e),
                            Err(_) => break,
                        }
                    }
                }
                out.push(DcfPdo {
                    direction,
                    number: n + 1,
                    comm,
                    entries,
                });
            }
            Ok(out)
        };
        Ok(Self {
            rpdos: read(Direction::Receive)?,
            tpdos: read(Direction::Transmit)?,
        })
    }

    /// The RPDOs the DCF has, valid or not.
    pub fn rpdos(&self) -> &[DcfPdo] {
        &self.rpdos
    }

    /// The TPDOs the DCF has, valid or not.
    pub fn tpdos(&self) -> &[DcfPdo] {
        &self.tpdos
    }

    /// The PDOs `mode` (csp, csv or cst) runs on for axis `axis`: the first valid synchronous
    /// RPDO (transmission type 0..=240) mapping the mode's target (0x607A, 0x60FF, 0x6071) and
    /// every valid TPDO mapping its actual value (0x6064, 0x606C, 0x6077). Either missing is
    /// [`DcfPdoError::Missing`], which lists the PDOs the DCF has.
    pub fn for_mode(&self, mode: ModeOfOperation, axis: u8) -> Result<ModePdos, DcfPdoError> {
        let (target, target_name, bits, actual, actual_name) = match mode {
            ModeOfOperation::CyclicSyncPosition => (
                obj::TARGET_POSITION.index(),
                "the target position",
                32,
                obj::POSITION_ACTUAL_VALUE.index(),
                "the position actual value",
            ),
            ModeOfOperation::CyclicSyncVelocity => (
                obj::TARGET_VELOCITY.index(),
                "the target velocity",
                32,
                obj::VELOCITY_ACTUAL_VALUE.index(),
                "the velocity actual value",
            ),
            ModeOfOperation::CyclicSyncTorque => (
                obj::TARGET_TORQUE.index(),
                "the target torque",
                16,
                obj::TORQUE_ACTUAL_VALUE.index(),
                "the torque actual value",
            ),
            m => return Err(DcfPdoError::NotCyclic(m)),
        };
        let offset = u16::from(axis.min(obj::MAX_AXIS)) * obj::AXIS_OFFSET;
        let target = (target + offset, 0u8);
        let actual = (actual + offset, 0u8);
        let rpdo = self
            .rpdos
            .iter()
            .find(|p| p.is_valid() && p.comm.transmission_type.is_synchronous() && p.maps(target))
            .ok_or_else(|| DcfPdoError::Missing {
                mode,
                object: target_name,
                index: target.0,
                sub_index: target.1,
                direction: Direction::Receive,
                found: self.rpdos.clone(),
            })?;
        let tpdos: Vec<DcfPdo> = self
            .tpdos
            .iter()
            .filter(|p| p.is_valid() && p.maps(actual))
            .cloned()
            .collect();
        if tpdos.is_empty() {
            return Err(DcfPdoError::Missing {
                mode,
                object: actual_name,
                index: actual.0,
                sub_index: actual.1,
                direction: Direction::Transmit,
                found: self.tpdos.clone(),
            });
        }
        Ok(ModePdos {
            mode,
            target,
            target_bits: bits,
            rpdo: rpdo.clone(),
            tpdos,
        })
    }
}
