//! The SDO side of the simulated Bürkert device: the writes to its profile objects checked
//! with this crate's typed decoders (locating, maintenance, the communication settings in
//! 0x2001, the LED objects), the reads it answers from its live state, a PDO mapping checked
//! when it is enabled, and the timers and NMT state changes the hook follows.

use std::prelude::rust_2024::*;
use std::{format, vec};

use std::sync::{Arc, Mutex};

use canola::{DeviceHook, HookActions, Values};
use canola_frame::{Instant, NodeId};
use canola_nmt::DeviceState;
use canola_od::ObjectDictionary;
use canola_pdo::{Direction, Mapping, MappingError, OdView};
use canola_sdo::AbortCode;

use super::{LOCATE_DURATION, Shared, lock, operation_status};
use crate::colour::LedColour;
use crate::comm::{BitRate, BusMode, ResetCommand, Termination};
use crate::led::LedMode;

/// The SDO side of the Bürkert behaviour.
pub(super) struct BurkertHook {
    pub(super) shared: Arc<Mutex<Shared>>,
}

/// Any undefined value of a typed object is refused the same way.
fn invalid<E>(_: E) -> AbortCode {
    AbortCode::INVALID_VALUE
}

fn one_byte(value: &[u8]) -> Result<u8, AbortCode> {
    match value {
        [b] => Ok(*b),
        _ => Err(AbortCode::LENGTH_MISMATCH),
    }
}

fn u32_of(value: &[u8]) -> Result<u32, AbortCode> {
    value
        .try_into()
        .map(u32::from_le_bytes)
        .map_err(|_| AbortCode::LENGTH_MISMATCH)
}

impl BurkertHook {
    /// Checks a mapping about to be enabled (sub 0 = `count`) against the dictionary.
    fn check_mapping(
        od: &ObjectDictionary,
        values: &Values,
        index: u16,
        count: u8,
    ) -> Result<(), AbortCode> {
        let direction = if index >= 0x1A00 {
            Direction::Transmit
        } else {
            Direction::Receive
        };
        let raw: Vec<u32> = (1..=count)
            .map(|sub| values.get_u64(index, sub).unwrap_or(0) as u32)
            .collect();
        let dict = OdView::with_values(od, values);
        match Mapping::from_raw_checked(direction, &raw, &dict) {
            Ok(_) => Ok(()),
            Err(MappingError::TooLong(_) | MappingError::TooManyEntries(_)) => {
                Err(AbortCode::PDO_LENGTH_EXCEEDED)
            }
            Err(
                MappingError::NotMappable(_)
                | MappingError::NoSuchObject(_)
                | MappingError::AccessDenied { .. },
            ) => Err(AbortCode::NOT_MAPPABLE),
            Err(_) => Err(AbortCode::PARAMETER_INCOMPATIBILITY),
        }
    }
}

impl DeviceHook for BurkertHook {
    fn on_write(
        &mut self,
        now: Instant,
        values: &mut Values,
        index: u16,
        sub: u8,
        value: &[u8],
        _actions: &mut HookActions,
    ) -> Result<(), AbortCode> {
        let mut s = lock(&self.shared);
        s.now = now;
        match (index, sub) {
            (0x2101, 1) => match one_byte(value)? {
                0 => {
                    if s.locate_latched {
                        s.log("master", "locating set back to 0");
                    }
                    s.locate_latched = false;
                    s.locate_until = None;
                }
                1 if !s.locate_latched => {
                    s.locate_latched = true;
                    s.locate_until = Some(now + LOCATE_DURATION);
                    s.log("master", "locating started");
                }
                // Still 1: the manual wants a 0 first; nothing restarts.
                1 => {}
                _ => return Err(AbortCode::INVALID_VALUE),
            },
            (0x210A, 1) => {
                let on = match one_byte(value)? {
                    0 => false,
                    1 => true,
                    _ => return Err(AbortCode::INVALID_VALUE),
                };
                if on != s.maintenance {
                    s.maintenance = on;
                    s.log(
                        "master",
                        if on {
                            "maintenance state entered"
                        } else {
                            "maintenance state left"
                        },
                    );
                }
                values.set(0x2004, 1, vec![s.ne107().to_raw()]);
            }
            (0x2120, 0) => {
                LedMode::from_u32(u32_of(value)?).map_err(invalid)?;
            }
            (0x2121, 1..=3) | (0x2122, 0) => {
                LedColour::from_u32(u32_of(value)?).map_err(invalid)?;
            }
            (0x2001, 1) => {
                let rate = BitRate::from_code(one_byte(value)?).map_err(invalid)?;
                if !rate.offered_by_burkert() {
                    return Err(AbortCode::INVALID_VALUE);
                }
                s.log("master", format!("bit rate {rate} stored"));
            }
            (0x2001, 2) => {
                let id = one_byte(value)?;
                NodeId::new(id).map_err(|_| AbortCode::INVALID_VALUE)?;
                s.log("master", format!("node-ID {id} stored"));
            }
            (0x2001, 3) => {
                BusMode::from_u8(one_byte(value)?).map_err(invalid)?;
            }
            (0x2001, 4) => match ResetCommand::from_u8(one_byte(value)?).map_err(invalid)? {
                ResetCommand::None => {}
                r => s.pending_reset = Some(r),
            },
            (0x2001, 0x0B) => {
                Termination::from_u8(one_byte(value)?).map_err(invalid)?;
            }
            (0x1400..=0x1BFF, _) => {
                let is_mapping = matches!(index, 0x1600..=0x17FF | 0x1A00..=0x1BFF);
                if is_mapping && sub == 0 {
                    let count = one_byte(value)?;
                    if count > 0 {
                        let od = s.od.clone();
                        Self::check_mapping(&od, values, index, count)?;
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn on_read(
        &mut self,
        now: Instant,
        values: &Values,
        index: u16,
        sub: u8,
    ) -> Option<Result<Vec<u8>, AbortCode>> {
        let mut s = lock(&self.shared);
        s.now = now;
        match (index, sub) {
            (0x2003, 4) => Some(Ok(s.logbook_xml(values))),
            (0x2004, 1) => Some(Ok(vec![s.ne107().to_raw()])),
            (0x2001, 0x0A) => Some(Ok(vec![operation_status(s.state).to_u8()])),
            (0x2004, 0x12) => {
                let secs = now.saturating_duration_since(s.booted_at).as_micros() / 1_000_000;
                Some(Ok((secs as u32).to_le_bytes().to_vec()))
            }
            (0x2004, 4) => {
                let secs = now.as_micros() / 1_000_000;
                Some(Ok((secs as u32).to_le_bytes().to_vec()))
            }
            _ => None,
        }
    }

    fn on_timeout(&mut self, now: Instant, _values: &mut Values, _actions: &mut HookActions) {
        let mut s = lock(&self.shared);
        s.now = now;
        if s.locate_until.is_some_and(|t| t <= now) {
            s.locate_until = None;
            s.log("device", "locating ended (LED flashing stopped)");
        }
    }

    fn poll_timeout(&self) -> Option<Instant> {
        lock(&self.shared).locate_until
    }

    fn on_state(&mut self, now: Instant, state: DeviceState, values: &mut Values) {
        let mut s = lock(&self.shared);
        s.now = now;
        s.state = state;
        values.set(0x2001, 0x0A, vec![operation_status(state).to_u8()]);
    }
}
