//! Modes of operation (0x6060 / 0x6061, `INTEGER8`) and the per-mode meaning of the
//! operation-mode-specific controlword and statusword bits, CiA 402-2 §6.3, §8..§12 and CiA 402-4.
//!
//! [`ModeOfOperation`] is an open enum: 0 (no mode, what many drives show after power-up),
//! the manufacturer-specific negative codes and the reserved codes decode without loss
//! (python-canopen #183 crashed on them).
//!
//! The views read statusword bits 10, 12 and 13 and write controlword bits 4..6, 8 and 9 as each
//! mode defines them:
//!
//! | mode | cw 4 | cw 5 | cw 6 | cw 9 | sw 10 | sw 12 | sw 13 |
//! |---|---|---|---|---|---|---|---|
//! | pp | new set-point | change set immediately | relative | change on set-point | target reached | set-point acknowledge | following error |
//! | vl | ramp enable | ramp unlock | use reference | – | – | – | – |
//! | pv | – | – | – | – | target reached | speed = 0 | (reserved; max slippage on some) |
//! | tq | – | – | – | – | target reached | – | – |
//! | hm | start homing | – | – | – | target reached | homing attained | homing error |
//! | ip | enable ip | – | – | – | target reached | ip mode active | – |
//! | csp/csv/cst | – | – | – | – | (vendor) | drive follows the command | following error (csp) |

use core::fmt;

use crate::words::{Controlword, Statusword};

/// A mode of operation code, 0x6060 (the request) and 0x6061 (what the drive runs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum ModeOfOperation {
    /// 0: no mode (the value many drives show before a mode is chosen).
    NoMode,
    /// 1: profile position (pp).
    ProfilePosition,
    /// 2: velocity (vl), the frequency-converter mode.
    Velocity,
    /// 3: profile velocity (pv).
    ProfileVelocity,
    /// 4: profile torque (tq).
    ProfileTorque,
    /// 6: homing (hm).
    Homing,
    /// 7: interpolated position (ip).
    InterpolatedPosition,
    /// 8: cyclic synchronous position (csp).
    CyclicSyncPosition,
    /// 9: cyclic synchronous velocity (csv).
    CyclicSyncVelocity,
    /// 10: cyclic synchronous torque (cst).
    CyclicSyncTorque,
    /// −128..−1: manufacturer-specific.
    Manufacturer(i8),
    /// 5 and 11..127: reserved by CiA 402.
    Reserved(i8),
}

impl ModeOfOperation {
    /// The standard modes 1..10 (without the reserved 5).
    pub const STANDARD: [ModeOfOperation; 9] = [
        Self::ProfilePosition,
        Self::Velocity,
        Self::ProfileVelocity,
        Self::ProfileTorque,
        Self::Homing,
        Self::InterpolatedPosition,
        Self::CyclicSyncPosition,
        Self::CyclicSyncVelocity,
        Self::CyclicSyncTorque,
    ];

    /// Decodes a 0x6060/0x6061 value; every code is kept.
    pub const fn from_code(code: i8) -> Self {
        match code {
            0 => Self::NoMode,
            1 => Self::ProfilePosition,
            2 => Self::Velocity,
            3 => Self::ProfileVelocity,
            4 => Self::ProfileTorque,
            6 => Self::Homing,
            7 => Self::InterpolatedPosition,
            8 => Self::CyclicSyncPosition,
            9 => Self::CyclicSyncVelocity,
            10 => Self::CyclicSyncTorque,
            c if c < 0 => Self::Manufacturer(c),
            c => Self::Reserved(c),
        }
    }

    /// The code, as written to 0x6060.
    pub const fn code(self) -> i8 {
        match self {
            Self::NoMode => 0,
            Self::ProfilePosition => 1,
            Self::Velocity => 2,
            Self::ProfileVelocity => 3,
            Self::ProfileTorque => 4,
            Self::Homing => 6,
            Self::InterpolatedPosition => 7,
            Self::CyclicSyncPosition => 8,
            Self::CyclicSyncVelocity => 9,
            Self::CyclicSyncTorque => 10,
            Self::Manufacturer(c) | Self::Reserved(c) => c,
        }
    }

    /// The short name used in CiA 402 and on the command line (`pp`, `csp`, ...); `None` for
    /// no mode, reserved and manufacturer codes.
    pub const fn short_name(self) -> Option<&'static str> {
        Some(match self {
            Self::ProfilePosition => "pp",
            Self::Velocity => "vl",
            Self::ProfileVelocity => "pv",
            Self::ProfileTorque => "tq",
            Self::Homing => "hm",
            Self::InterpolatedPosition => "ip",
            Self::CyclicSyncPosition => "csp",
            Self::CyclicSyncVelocity => "csv",
            Self::CyclicSyncTorque => "cst",
            _ => return None,
        })
    }

    /// The mode from its short name (`pp`, `vl`, `pv`, `tq`, `hm`, `ip`, `csp`, `csv`, `cst`).
    pub fn from_short_name(name: &str) -> Option<Self> {
        Self::STANDARD
            .into_iter()
            .find(|m| m.short_name() == Some(name))
    }

    /// The bit of this mode in 0x6502 supported drive modes (bit = code − 1 for 1..=10).
    pub const fn supported_bit(self) -> Option<u32> {
        match self.code() {
            c @ 1..=10 if c != 5 => Some(1 << (c - 1)),
            _ => None,
        }
    }

    /// Whether this is one of the cyclic synchronous modes (8, 9, 10), whose targets come by
    /// synchronous RPDO at each SYNC with the period of 0x60C2.
    pub const fn is_cyclic(self) -> bool {
        matches!(
            self,
            Self::CyclicSyncPosition | Self::CyclicSyncVelocity | Self::CyclicSyncTorque
        )
    }
}

impl From<i8> for ModeOfOperation {
    fn from(code: i8) -> Self {
        Self::from_code(code)
    }
}

impl fmt::Display for ModeOfOperation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoMode => f.write_str("no mode (0)"),
            Self::Manufacturer(c) => write!(f, "manufacturer-specific ({c})"),
            Self::Reserved(c) => write!(f, "reserved ({c})"),
            m => write!(f, "{} ({})", m.short_name().unwrap_or("?"), m.code()),
        }
    }
}

/// The statusword read as the active mode defines bits 10, 12 and 13.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ModeStatus {
    /// Profile position.
    ProfilePosition {
        /// Bit 10: target position reached (with halt set: the axis stands still).
        target_reached: bool,
        /// Bit 12: the drive took the new set-point; the master may clear controlword bit 4.
        set_point_acknowledge: bool,
        /// Bit 13: following error.
        following_error: bool,
    },
    /// Profile velocity.
    ProfileVelocity {
        /// Bit 10: target velocity reached.
        target_reached: bool,
        /// Bit 12: speed is zero.
        speed_zero: bool,
        /// Bit 13: reserved on most drives (Danfoss, Roboteq: always 0); "maximum slippage
        /// reached" on some (ni-lab ePulse). Kept raw.
        bit13: bool,
    },
    /// Profile torque.
    ProfileTorque {
        /// Bit 10: target torque reached.
        target_reached: bool,
    },
    /// Velocity (vl): no mode-specific statusword bits.
    Velocity,
    /// Homing: bits 13, 12, 10 decoded together.
    Homing(HomingStatus),
    /// Interpolated position.
    InterpolatedPosition {
        /// Bit 10: target reached.
        target_reached: bool,
        /// Bit 12: ip mode active.
        ip_mode_active: bool,
    },
    /// Cyclic synchronous position, velocity or torque.
    CyclicSync {
        /// Bit 12: the drive follows the command value (the cyclic target is used).
        following_command: bool,
        /// Bit 13: following error (csp only; reserved in csv and cst).
        following_error: bool,
        /// Bit 10, whose meaning in the cyclic modes differs between vendors.
        bit10: bool,
    },
    /// No mode, reserved or manufacturer-specific: the raw bits 10, 12, 13.
    Other {
        /// Bit 10.
        bit10: bool,
        /// Bit 12.
        bit12: bool,
        /// Bit 13.
        bit13: bool,
    },
}

impl ModeStatus {
    /// Reads `sw` as `mode` defines it.
    pub const fn decode(mode: ModeOfOperation, sw: Statusword) -> Self {
        let b10 = sw.bit(10);
        let b12 = sw.bit(12);
        let b13 = sw.bit(13);
        match mode {
            ModeOfOperation::ProfilePosition => Self::ProfilePosition {
                target_reached: b10,
                set_point_acknowledge: b12,
                following_error: b13,
            },
            ModeOfOperation::ProfileVelocity => Self::ProfileVelocity {
                target_reached: b10,
                speed_zero: b12,
                bit13: b13,
            },
            ModeOfOperation::ProfileTorque => Self::ProfileTorque {
                target_reached: b10,
            },
            ModeOfOperation::Velocity => Self::Velocity,
            ModeOfOperation::Homing => Self::Homing(HomingStatus::decode(sw)),
            ModeOfOperation::InterpolatedPosition => Self::InterpolatedPosition {
                target_reached: b10,
                ip_mode_active: b12,
            },
            ModeOfOperation::CyclicSyncPosition => Self::CyclicSync {
                following_command: b12,
                following_error: b13,
                bit10: b10,
            },
            ModeOfOperation::CyclicSyncVelocity | ModeOfOperation::CyclicSyncTorque => {
                Self::CyclicSync {
                    following_command: b12,
                    following_error: false,
                    bit10: b10,
                }
            }
            _ => Self::Other {
                bit10: b10,
                bit12: b12,
                bit13: b13,
            },
        }
    }

    /// Bit 10 where the mode defines it as "target reached" (pp, pv, tq, hm, ip); `None` in the
    /// other modes.
    pub const fn target_reached(self) -> Option<bool> {
        match self {
            Self::ProfilePosition { target_reached, .. }
            | Self::ProfileVelocity { target_reached, .. }
            | Self::ProfileTorque { target_reached }
            | Self::InterpolatedPosition { target_reached, .. } => Some(target_reached),
            Self::Homing(h) => Some(matches!(
                h,
                HomingStatus::Completed | HomingStatus::Interrupted | HomingStatus::ErrorStandstill
            )),
            _ => None,
        }
    }
}

/// Homing status from statusword bits 13, 12, 10 (mask 0x3400), CiA 402-2 §10.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum HomingStatus {
    /// 0x0000: homing in progress.
    InProgress,
    /// 0x0400: homing interrupted or not started.
    Interrupted,
    /// 0x1000: homing attained, target not reached.
    Attained,
    /// 0x1400: homing completed successfully.
    Completed,
    /// 0x2000: homing error, velocity not zero.
    ErrorMoving,
    /// 0x2400: homing error, velocity zero.
    ErrorStandstill,
    /// 0x3000 or 0x3400: bits 12 and 13 together, which CiA 402 reserves.
    Reserved(u16),
}

impl HomingStatus {
    /// The statusword bits that code the homing status.
    pub const MASK: u16 = 0x3400;

    /// Decodes bits 13, 12, 10 of `sw`.
    pub const fn decode(sw: Statusword) -> Self {
        match sw.raw() & Self::MASK {
            0x0000 => Self::InProgress,
            0x0400 => Self::Interrupted,
            0x1000 => Self::Attained,
            0x1400 => Self::Completed,
            0x2000 => Self::ErrorMoving,
            0x2400 => Self::ErrorStandstill,
            other => Self::Reserved(other),
        }
    }

    /// The bits this status sets in a statusword (the inverse of [`decode`](Self::decode)).
    pub const fn bits(self) -> u16 {
        match self {
            Self::InProgress => 0x0000,
            Self::Interrupted => 0x0400,
            Self::Attained => 0x1000,
            Self::Completed => 0x1400,
            Self::ErrorMoving => 0x2000,
            Self::ErrorStandstill => 0x2400,
            Self::Reserved(b) => b & Self::MASK,
        }
    }

    /// Whether homing has ended with an error.
    pub const fn is_error(self) -> bool {
        matches!(self, Self::ErrorMoving | Self::ErrorStandstill)
    }
}

impl fmt::Display for HomingStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InProgress => f.write_str("in progress"),
            Self::Interrupted => f.write_str("interrupted or not started"),
            Self::Attained => f.write_str("attained, target not reached"),
            Self::Completed => f.write_str("completed"),
            Self::ErrorMoving => f.write_str("error, still moving"),
            Self::ErrorStandstill => f.write_str("error, at standstill"),
            Self::Reserved(bits) => write!(f, "reserved bits {bits:#06x}"),
        }
    }
}

/// Profile position controlword bits (4, 5, 6, 8, 9), CiA 402-2 §12.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct ProfilePositionControl {
    /// Bit 4: new set-point; the drive acts on its rising edge.
    pub new_set_point: bool,
    /// Bit 5: change set immediately (1: interrupt the running move and start the new one).
    pub change_set_immediately: bool,
    /// Bit 6: the target is relative (1) or absolute (0).
    pub relative: bool,
    /// Bit 8: halt.
    pub halt: bool,
    /// Bit 9: change on set-point (1: go on at profile velocity into the next set-point).
    pub change_on_set_point: bool,
}

impl ProfilePositionControl {
    /// Reads the pp bits of a controlword.
    pub const fn decode(cw: Controlword) -> Self {
        Self {
            new_set_point: cw.bit(4),
            change_set_immediately: cw.bit(5),
            relative: cw.bit(6),
            halt: cw.bit(8),
            change_on_set_point: cw.bit(9),
        }
    }
    /// `cw` with its mode bits (4..6, 8, 9) replaced by these.
    pub const fn apply(self, cw: Controlword) -> Controlword {
        let raw = (cw.raw() & !Controlword::MODE_BITS)
            | (self.new_set_point as u16) << 4
            | (self.change_set_immediately as u16) << 5
            | (self.relative as u16) << 6
            | (self.halt as u16) << 8
            | (self.change_on_set_point as u16) << 9;
        Controlword::from_raw(raw)
    }
}

/// Velocity mode (vl) controlword bits, CiA 402-2 §13: the drive follows 0x6042 only with
/// all three of bits 4, 5, 6 set.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct VelocityControl {
    /// Bit 4: ramp function generator enable.
    pub ramp_enable: bool,
    /// Bit 5: ramp unlock.
    pub ramp_unlock: bool,
    /// Bit 6: use reference.
    pub use_reference: bool,
    /// Bit 8: halt.
    pub halt: bool,
}

impl Default for VelocityControl {
    /// Ramp enabled, unlocked, reference used, no halt: the drive follows its target velocity.
    fn default() -> Self {
        Self {
            ramp_enable: true,
            ramp_unlock: true,
            use_reference: true,
            halt: false,
        }
    }
}

impl VelocityControl {
    /// Reads the vl bits of a controlword.
    pub const fn decode(cw: Controlword) -> Self {
        Self {
            ramp_enable: cw.bit(4),
            ramp_unlock: cw.bit(5),
            use_reference: cw.bit(6),
            halt: cw.bit(8),
        }
    }
    /// `cw` with its mode bits replaced by these.
    pub const fn apply(self, cw: Controlword) -> Controlword {
        let raw = (cw.raw() & !Controlword::MODE_BITS)
            | (self.ramp_enable as u16) << 4
            | (self.ramp_unlock as u16) << 5
            | (self.use_reference as u16) << 6
            | (self.halt as u16) << 8;
        Controlword::from_raw(raw)
    }
}

/// Controlword bits of the modes that use at most bit 4 and halt: homing (bit 4 = start
/// homing, rising edge), interpolated position (bit 4 = enable ip), and pv, tq and the
/// cyclic modes (bit 4 unused, left clear).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct StartHaltControl {
    /// Bit 4: start homing (hm, rising edge) or enable ip mode (ip).
    pub start: bool,
    /// Bit 8: halt.
    pub halt: bool,
}

impl StartHaltControl {
    /// Reads bits 4 and 8 of a controlword.
    pub const fn decode(cw: Controlword) -> Self {
        Self {
            start: cw.bit(4),
            halt: cw.bit(8),
        }
    }
    /// `cw` with its mode bits replaced by these (bits 5, 6, 9 cleared).
    pub const fn apply(self, cw: Controlword) -> Controlword {
        let raw = (cw.raw() & !Controlword::MODE_BITS)
            | (self.start as u16) << 4
            | (self.halt as u16) << 8;
        Controlword::from_raw(raw)
    }
}

/// A homing method code (0x6098, `INTEGER8`), CiA 402-2 §10; open, keeping every value.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct HomingMethod(pub i8);

impl HomingMethod {
    /// 0: no homing method assigned.
    pub const NONE: Self = Self(0);
    /// 1: negative limit switch and index pulse.
    pub const NEGATIVE_LIMIT_INDEX: Self = Self(1);
    /// 2: positive limit switch and index pulse.
    pub const POSITIVE_LIMIT_INDEX: Self = Self(2);
    /// 17: negative limit switch.
    pub const NEGATIVE_LIMIT: Self = Self(17);
    /// 18: positive limit switch.
    pub const POSITIVE_LIMIT: Self = Self(18);
    /// 33: index pulse in the negative direction.
    pub const NEGATIVE_INDEX: Self = Self(33);
    /// 34: index pulse in the positive direction.
    pub const POSITIVE_INDEX: Self = Self(34);
    /// 35: the current position is the home position (37 in newer editions).
    pub const CURRENT_POSITION: Self = Self(35);
    /// 37: the current position is the home position (CiA 402 v4 renumbering of 35).
    pub const CURRENT_POSITION_37: Self = Self(37);

    /// Whether CiA 402 defines this method (1..=14, 17..=30, 33..=35, 37); negative methods
    /// are manufacturer-specific, 15, 16, 31, 32 and 36 are reserved.
    pub const fn is_standard(self) -> bool {
        matches!(self.0, 1..=14 | 17..=30 | 33..=35 | 37)
    }
    /// Whether the method is manufacturer-specific (negative).
    pub const fn is_manufacturer(self) -> bool {
        self.0 < 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mode_code_round_trips() {
        for code in i8::MIN..=i8::MAX {
            assert_eq!(ModeOfOperation::from_code(code).code(), code);
        }
        assert_eq!(ModeOfOperation::from_code(0), ModeOfOperation::NoMode);
        assert_eq!(
            ModeOfOperation::from_code(-1),
            ModeOfOperation::Manufacturer(-1)
        );
        assert_eq!(ModeOfOperation::from_code(5), ModeOfOperation::Reserved(5));
        assert_eq!(
            ModeOfOperation::from_short_name("csp"),
            Some(ModeOfOperation::CyclicSyncPosition)
        );
        assert_eq!(
            ModeOfOperation::ProfilePosition.supported_bit(),
            Some(0x001)
        );
        assert_eq!(
            ModeOfOperation::CyclicSyncTorque.supported_bit(),
            Some(0x200)
        );
        assert_eq!(ModeOfOperation::Reserved(5).supported_bit(), None);
    }

    #[test]
    fn homing_status_table_of_the_spec() {
        for (bits, st) in [
            (0x0000, HomingStatus::InProgress),
            (0x0400, HomingStatus::Interrupted),
            (0x1000, HomingStatus::Attained),
            (0x1400, HomingStatus::Completed),
            (0x2000, HomingStatus::ErrorMoving),
            (0x2400, HomingStatus::ErrorStandstill),
        ] {
            assert_eq!(
                HomingStatus::decode(Statusword::from_raw(bits | 0x0237)),
                st
            );
            assert_eq!(st.bits(), bits);
        }
        assert_eq!(
            HomingStatus::decode(Statusword::from_raw(0x3400)),
            HomingStatus::Reserved(0x3400)
        );
    }

    #[test]
    fn bits_10_12_13_per_mode() {
        let sw = Statusword::from_raw(0x1437);
        assert_eq!(
            ModeStatus::decode(ModeOfOperation::ProfilePosition, sw),
            ModeStatus::ProfilePosition {
                target_reached: true,
                set_point_acknowledge: true,
                following_error: false
            }
        );
        assert_eq!(
            ModeStatus::decode(ModeOfOperation::ProfileVelocity, sw),
            ModeStatus::ProfileVelocity {
                target_reached: true,
                speed_zero: true,
                bit13: false
            }
        );
        assert_eq!(
            ModeStatus::decode(ModeOfOperation::Homing, sw),
            ModeStatus::Homing(HomingStatus::Completed)
        );
        assert_eq!(
            ModeStatus::decode(ModeOfOperation::CyclicSyncVelocity, sw).target_reached(),
            None
        );
        // Target reached is bit 10, never bit 4 (voltage enabled): 0x0037 has bit 4 and not 10.
        let moving = Statusword::from_raw(0x0037);
        assert_eq!(
            ModeStatus::decode(ModeOfOperation::ProfilePosition, moving).target_reached(),
            Some(false)
        );
    }

    #[test]
    fn pp_control_bits() {
        let cw = ProfilePositionControl {
            new_set_point: true,
            change_set_immediately: true,
            relative: true,
            halt: false,
            change_on_set_point: false,
        }
        .apply(Controlword::from_raw(0x000F));
        assert_eq!(cw.raw(), 0x007F);
        assert!(ProfilePositionControl::decode(cw).relative);
        assert_eq!(
            VelocityControl::default()
                .apply(Controlword::from_raw(0x010F))
                .raw(),
            0x007F
        );
        assert_eq!(
            StartHaltControl {
                start: true,
                halt: false
            }
            .apply(Controlword::from_raw(0x000F))
            .raw(),
            0x001F
        );
    }
}
