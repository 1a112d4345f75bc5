//! The simulated drive's object dictionary: which objects it has (the profile's table in
//! [`crate::objects`], the axis offset), reads and writes by index and sub-index with the SDO
//! abort a drive would answer, and (feature `pdo`) the drive as the PDO engine's object store.

use canola_od::DataType;

use crate::mode::ModeOfOperation;
use crate::objects::{self as obj, ObjectInfo, QuickStopOption};
use crate::state::State;
use crate::words::Controlword;

use super::{AccessError, SimDrive};

/// Objects the drive computes; a master cannot write them.
const READ_ONLY: &[u16] = &[
    0x603F, 0x6041, 0x6043, 0x6044, 0x6061, 0x6062, 0x6063, 0x6064, 0x606B, 0x606C, 0x6074, 0x6077,
    0x60F4, 0x60FD, 0x6502,
];

/// Records: their highest sub-index (read-only sub 0).
const RECORDS: &[(u16, u8)] = &[(0x607D, 2), (0x6099, 2), (0x60C1, 1), (0x60C2, 2)];

impl SimDrive {
    pub(super) fn slot(index: u16, sub: u8) -> Option<usize> {
        obj::ALL
            .iter()
            .position(|o| o.index == index && o.sub_index == sub)
    }

    pub(super) fn info(index: u16, sub: u8) -> Option<&'static ObjectInfo> {
        obj::ALL
            .iter()
            .find(|o| o.index == index && o.sub_index == sub)
    }

    pub(super) fn get<T>(&self, e: canola_od::Entry<T>) -> i64 {
        Self::slot(e.index(), e.sub_index()).map_or(0, |i| self.values[i])
    }

    pub(super) fn put<T>(&mut self, e: canola_od::Entry<T>, v: i64) {
        if let Some(i) = Self::slot(e.index(), e.sub_index()) {
            self.values[i] = v;
        }
    }

    /// Reads an object into `out` (little-endian); returns the length.
    pub fn read(&self, index: u16, sub: u8, out: &mut [u8]) -> Result<usize, AccessError> {
        let (index, base) = self.local(index)?;
        let (value, data_type) = match base {
            0x1000 if sub == 0 => (0x0002_0192, DataType::Unsigned32),
            0x1001 if sub == 0 => (i64::from(self.error_register), DataType::Unsigned8),
            _ => match RECORDS.iter().find(|(i, _)| *i == base) {
                Some((_, n)) if sub == 0 => (i64::from(*n), DataType::Unsigned8),
                _ => {
                    let info = self.lookup(index, base, sub)?;
                    (
                        self.values[Self::slot(base, sub).unwrap_or(0)],
                        info.data_type,
                    )
                }
            },
        };
        let len = data_type.size().unwrap_or(4);
        let bytes = value.to_le_bytes();
        let dst = out.get_mut(..len).ok_or(AccessError::Length(index, sub))?;
        dst.copy_from_slice(&bytes[..len]);
        Ok(len)
    }

    /// Writes an object from little-endian bytes, as an SDO download or an RPDO would.
    /// A controlword acts at once (state machine, set-point and homing edges); a mode change
    /// shows in 0x6061 after the next step.
    pub fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AccessError> {
        let (index, base) = self.local(index)?;
        if base < 0x6000 {
            return Err(match (base, sub) {
                (0x1000 | 0x1001, 0) => AccessError::ReadOnly(index, sub),
                (0x1000 | 0x1001, _) => AccessError::NoSubIndex(index, sub),
                _ => AccessError::NoObject(index),
            });
        }
        if sub == 0 && RECORDS.iter().any(|(i, _)| *i == base) {
            return Err(AccessError::ReadOnly(index, sub));
        }
        let info = self.lookup(index, base, sub)?;
        if READ_ONLY.contains(&base) {
            return Err(AccessError::ReadOnly(index, sub));
        }
        let size = info.data_type.size().unwrap_or(4);
        if data.len() != size {
            return Err(AccessError::Length(index, sub));
        }
        let mut raw = [0u8; 8];
        raw[..size].copy_from_slice(data);
        let unsigned = u64::from_le_bytes(raw);
        let value = if info.data_type.is_signed() {
            let shift = 64 - 8 * size as u32;
            ((unsigned << shift) as i64) >> shift
        } else {
            unsigned as i64
        };
        match base {
            0x6060 => {
                let mode = ModeOfOperation::from_code(value as i8);
                // Accepted: 0 (no mode) and the modes the drive runs, as listed in its 0x6502
                // (without 0x6502: every mode but vl, which is optional on a servo).
                let runs = mode.supported_bit().is_some();
                let listed = match self.config.supported_modes {
                    Some(s) => s.contains(mode),
                    None => mode != ModeOfOperation::Velocity,
                };
                let known = mode == ModeOfOperation::NoMode || runs;
                let listed = listed || mode == ModeOfOperation::NoMode;
                if !(known && listed) {
                    return Err(AccessError::ValueRange(index, sub));
                }
                let change = i64::from(mode.code()) != self.get(obj::MODES_OF_OPERATION);
                let enabled = self.machine.state() == State::OperationEnabled;
                let halt = Controlword::from_raw(self.get(obj::CONTROLWORD) as u16).halt();
                if change
                    && (self.config.refuse_mode_change_when_enabled && enabled
                        || self.config.refuse_mode_change_while_halt && halt)
                {
                    return Err(AccessError::DeviceState(index, sub));
                }
            }
            0x605A => self
                .machine
                .set_quick_stop_option(QuickStopOption(value as i16)),
            _ => {}
        }
        let previous = self.values[Self::slot(base, sub).unwrap_or(0)];
        self.values[Self::slot(base, sub).unwrap_or(0)] = value;
        if base == 0x6040 {
            self.on_controlword(
                Controlword::from_raw(previous as u16),
                Controlword::from_raw(value as u16),
            );
        }
        self.refresh();
        Ok(())
    }

    /// Writes the controlword (shorthand for a write of 0x6040).
    pub fn set_controlword(&mut self, cw: Controlword) {
        let index = obj::CONTROLWORD.index() + u16::from(self.config.axis) * obj::AXIS_OFFSET;
        let _ = self.write(index, 0, &cw.to_le_bytes());
    }

    /// Writes any profile entry on this drive's axis (shorthand for [`write`](Self::write)).
    pub fn set<T>(&mut self, entry: canola_od::Entry<T>, value: i64) -> Result<(), AccessError> {
        let index = entry.index() + u16::from(self.config.axis) * obj::AXIS_OFFSET;
        let size = entry.data_type().size().unwrap_or(4);
        self.write(index, entry.sub_index(), &value.to_le_bytes()[..size])
    }

    /// Reads any profile entry on this drive's axis as an integer.
    pub fn value<T>(&self, entry: canola_od::Entry<T>) -> i64 {
        self.get(entry)
    }

    fn local(&self, index: u16) -> Result<(u16, u16), AccessError> {
        if index < 0x6000 {
            return Ok((index, index));
        }
        match obj::axis_of(index) {
            Some((axis, base)) if axis == self.config.axis => Ok((index, base)),
            _ => Err(AccessError::NoObject(index)),
        }
    }

    fn lookup(&self, index: u16, base: u16, sub: u8) -> Result<&'static ObjectInfo, AccessError> {
        if base == 0x6502 && self.config.supported_modes.is_none() {
            return Err(AccessError::NoObject(index));
        }
        if base < 0x6000 && !(base == 0x1000 || base == 0x1001) {
            return Err(AccessError::NoObject(index));
        }
        Self::info(base, sub).ok_or_else(|| {
            if obj::ALL.iter().any(|o| o.index == base) {
                AccessError::NoSubIndex(index, sub)
            } else {
                AccessError::NoObject(index)
            }
        })
    }
}

/// The drive's objects as the PDO engine's store: RPDOs write through [`SimDrive::write`]
/// (a controlword acts at once), TPDOs read through [`SimDrive::read`].
#[cfg(feature = "pdo")]
impl canola_pdo::ObjectStore for SimDrive {
    fn read(
        &mut self,
        addr: canola_od::ObjectAddress,
        out: &mut [u8],
    ) -> Result<(), canola_pdo::StoreError> {
        let mut buf = [0u8; 8];
        let n = SimDrive::read(self, addr.index, addr.sub_index, &mut buf).map_err(store_error)?;
        let dst = out.len().min(n);
        out.fill(0);
        out[..dst].copy_from_slice(&buf[..dst]);
        Ok(())
    }

    fn write(
        &mut self,
        addr: canola_od::ObjectAddress,
        data: &[u8],
    ) -> Result<(), canola_pdo::StoreError> {
        SimDrive::write(self, addr.index, addr.sub_index, data).map_err(store_error)
    }
}

#[cfg(feature = "pdo")]
fn store_error(e: AccessError) -> canola_pdo::StoreError {
    match e {
        AccessError::NoObject(_) | AccessError::NoSubIndex(..) => {
            canola_pdo::StoreError::NoSuchObject
        }
        AccessError::ReadOnly(..) => canola_pdo::StoreError::AccessDenied,
        AccessError::ValueRange(..) => canola_pdo::StoreError::ValueRange,
        other => canola_pdo::StoreError::Other(other.abort_code()),
    }
}
