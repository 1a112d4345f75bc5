//! The objects of CiA 402-2 (§6..§14 object dictionaries) as typed entries, with the multi-axis
//! offset of CiA 402-2 §5 (axis n at index + n × 0x800), and the value types of the option codes
//! 0x605A..0x605E, the error code 0x603F, supported drive modes 0x6502 and the interpolation time
//! period 0x60C2.
//!
//! Types and indices follow the majority of the sources (EPOS4, Beckhoff SSC, Toshiba, the
//! ros_canopen and Pilz EDS files: 0x6060 and 0x6098 are `INTEGER8`, 0x607C `INTEGER32`). A few
//! objects those sources do not list but
//! CiA 402-2 defines (vl 0x6043/0x6044, windows 0x606D/0x606E, 0x6072, 0x607F, 0x60F4, 0x60FD ...)
//! are here too; their indices and types are those of CiA 402-2.

use core::fmt;

use canola_od::{DataType, Entry};

use crate::mode::ModeOfOperation;

/// One profile object as data: name, index, sub-index and data type, for tables (the EDS check,
/// the simulator's dictionary).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct ObjectInfo {
    /// The CiA 402 name.
    pub name: &'static str,
    /// The index on axis 0.
    pub index: u16,
    /// The sub-index.
    pub sub_index: u8,
    /// The data type.
    pub data_type: DataType,
}

macro_rules! objects {
    ($($(#[$doc:meta])* $konst:ident : $t:ty = ($index:expr, $sub:expr, $dt:ident, $name:expr);)*) => {
        $(
            $(#[$doc])*
            pub const $konst: Entry<$t> = Entry::new($index, $sub, DataType::$dt);
        )*
        /// Every profile object of this module, in index order.
        pub const ALL: &[ObjectInfo] = &[
            $(ObjectInfo { name: $name, index: $index, sub_index: $sub, data_type: DataType::$dt },)*
        ];
    };
}

objects! {
    /// 0x603F error code: the last fault (lower 16 bits of the last 0x1003 entry).
    ERROR_CODE: u16 = (0x603F, 0, Unsigned16, "Error code");
    /// 0x6040 controlword.
    CONTROLWORD: u16 = (0x6040, 0, Unsigned16, "Controlword");
    /// 0x6041 statusword.
    STATUSWORD: u16 = (0x6041, 0, Unsigned16, "Statusword");
    /// 0x6042 vl target velocity.
    VL_TARGET_VELOCITY: i16 = (0x6042, 0, Integer16, "vl target velocity");
    /// 0x6043 vl velocity demand.
    VL_VELOCITY_DEMAND: i16 = (0x6043, 0, Integer16, "vl velocity demand");
    /// 0x6044 vl velocity actual value.
    VL_VELOCITY_ACTUAL_VALUE: i16 = (0x6044, 0, Integer16, "vl velocity actual value");
    /// 0x605A quick stop option code.
    QUICK_STOP_OPTION_CODE: i16 = (0x605A, 0, Integer16, "Quick stop option code");
    /// 0x605B shutdown option code (transition 8).
    SHUTDOWN_OPTION_CODE: i16 = (0x605B, 0, Integer16, "Shutdown option code");
    /// 0x605C disable operation option code (transition 5).
    DISABLE_OPERATION_OPTION_CODE: i16 = (0x605C, 0, Integer16, "Disable operation option code");
    /// 0x605D halt option code (controlword bit 8).
    HALT_OPTION_CODE: i16 = (0x605D, 0, Integer16, "Halt option code");
    /// 0x605E fault reaction option code.
    FAULT_REACTION_OPTION_CODE: i16 = (0x605E, 0, Integer16, "Fault reaction option code");
    /// 0x6060 modes of operation (the request).
    MODES_OF_OPERATION: i8 = (0x6060, 0, Integer8, "Modes of operation");
    /// 0x6061 modes of operation display (what the drive runs).
    MODES_OF_OPERATION_DISPLAY: i8 = (0x6061, 0, Integer8, "Modes of operation display");
    /// 0x6062 position demand value.
    POSITION_DEMAND_VALUE: i32 = (0x6062, 0, Integer32, "Position demand value");
    /// 0x6063 position actual internal value.
    POSITION_ACTUAL_INTERNAL_VALUE: i32 = (0x6063, 0, Integer32, "Position actual internal value");
    /// 0x6064 position actual value.
    POSITION_ACTUAL_VALUE: i32 = (0x6064, 0, Integer32, "Position actual value");
    /// 0x6065 following error window (0xFFFFFFFF: monitoring off).
    FOLLOWING_ERROR_WINDOW: u32 = (0x6065, 0, Unsigned32, "Following error window");
    /// 0x6066 following error time out, ms.
    FOLLOWING_ERROR_TIME_OUT: u16 = (0x6066, 0, Unsigned16, "Following error time out");
    /// 0x6067 position window (target reached).
    POSITION_WINDOW: u32 = (0x6067, 0, Unsigned32, "Position window");
    /// 0x6068 position window time, ms.
    POSITION_WINDOW_TIME: u16 = (0x6068, 0, Unsigned16, "Position window time");
    /// 0x606B velocity demand value.
    VELOCITY_DEMAND_VALUE: i32 = (0x606B, 0, Integer32, "Velocity demand value");
    /// 0x606C velocity actual value.
    VELOCITY_ACTUAL_VALUE: i32 = (0x606C, 0, Integer32, "Velocity actual value");
    /// 0x606D velocity window (pv target reached).
    VELOCITY_WINDOW: u16 = (0x606D, 0, Unsigned16, "Velocity window");
    /// 0x606E velocity window time, ms.
    VELOCITY_WINDOW_TIME: u16 = (0x606E, 0, Unsigned16, "Velocity window time");
    /// 0x6071 target torque, per mille of rated torque.
    TARGET_TORQUE: i16 = (0x6071, 0, Integer16, "Target torque");
    /// 0x6072 max torque, per mille of rated torque.
    MAX_TORQUE: u16 = (0x6072, 0, Unsigned16, "Max torque");
    /// 0x6074 torque demand.
    TORQUE_DEMAND: i16 = (0x6074, 0, Integer16, "Torque demand");
    /// 0x6077 torque actual value.
    TORQUE_ACTUAL_VALUE: i16 = (0x6077, 0, Integer16, "Torque actual value");
    /// 0x607A target position.
    TARGET_POSITION: i32 = (0x607A, 0, Integer32, "Target position");
    /// 0x607C home offset.
    HOME_OFFSET: i32 = (0x607C, 0, Integer32, "Home offset");
    /// 0x607D:1 min software position limit.
    MIN_SOFTWARE_POSITION_LIMIT: i32 = (0x607D, 1, Integer32, "Min position limit");
    /// 0x607D:2 max software position limit.
    MAX_SOFTWARE_POSITION_LIMIT: i32 = (0x607D, 2, Integer32, "Max position limit");
    /// 0x607F max profile velocity.
    MAX_PROFILE_VELOCITY: u32 = (0x607F, 0, Unsigned32, "Max profile velocity");
    /// 0x6081 profile velocity.
    PROFILE_VELOCITY: u32 = (0x6081, 0, Unsigned32, "Profile velocity");
    /// 0x6083 profile acceleration.
    PROFILE_ACCELERATION: u32 = (0x6083, 0, Unsigned32, "Profile acceleration");
    /// 0x6084 profile deceleration.
    PROFILE_DECELERATION: u32 = (0x6084, 0, Unsigned32, "Profile deceleration");
    /// 0x6085 quick stop deceleration.
    QUICK_STOP_DECELERATION: u32 = (0x6085, 0, Unsigned32, "Quick stop deceleration");
    /// 0x6087 torque slope, per mille per second.
    TORQUE_SLOPE: u32 = (0x6087, 0, Unsigned32, "Torque slope");
    /// 0x6098 homing method.
    HOMING_METHOD: i8 = (0x6098, 0, Integer8, "Homing method");
    /// 0x6099:1 speed during search for switch.
    HOMING_SPEED_SWITCH: u32 = (0x6099, 1, Unsigned32, "Speed during search for switch");
    /// 0x6099:2 speed during search for zero.
    HOMING_SPEED_ZERO: u32 = (0x6099, 2, Unsigned32, "Speed during search for zero");
    /// 0x609A homing acceleration.
    HOMING_ACCELERATION: u32 = (0x609A, 0, Unsigned32, "Homing acceleration");
    /// 0x60B0 position offset (csp feed-forward).
    POSITION_OFFSET: i32 = (0x60B0, 0, Integer32, "Position offset");
    /// 0x60B1 velocity offset.
    VELOCITY_OFFSET: i32 = (0x60B1, 0, Integer32, "Velocity offset");
    /// 0x60B2 torque offset.
    TORQUE_OFFSET: i16 = (0x60B2, 0, Integer16, "Torque offset");
    /// 0x60C0 interpolation sub mode select (0 linear, negative manufacturer-specific).
    INTERPOLATION_SUB_MODE_SELECT: i16 = (0x60C0, 0, Integer16, "Interpolation sub mode select");
    /// 0x60C1:1 interpolation data record, first set-point.
    INTERPOLATION_DATA_RECORD: i32 = (0x60C1, 1, Integer32, "Interpolation data record 1");
    /// 0x60C2:1 interpolation time period value.
    INTERPOLATION_TIME_PERIOD_VALUE: u8 = (0x60C2, 1, Unsigned8, "Interpolation time period value");
    /// 0x60C2:2 interpolation time index (power-of-ten exponent of seconds).
    INTERPOLATION_TIME_INDEX: i8 = (0x60C2, 2, Integer8, "Interpolation time index");
    /// 0x60F4 following error actual value.
    FOLLOWING_ERROR_ACTUAL_VALUE: i32 = (0x60F4, 0, Integer32, "Following error actual value");
    /// 0x60FD digital inputs (bit 0 negative limit switch, 1 positive limit switch, 2 home switch).
    DIGITAL_INPUTS: u32 = (0x60FD, 0, Unsigned32, "Digital inputs");
    /// 0x60FF target velocity (pv, csv).
    TARGET_VELOCITY: i32 = (0x60FF, 0, Integer32, "Target velocity");
    /// 0x6502 supported drive modes.
    SUPPORTED_DRIVE_MODES: u32 = (0x6502, 0, Unsigned32, "Supported drive modes");
}

/// 0x6060 written as `INTEGER16`. The majority of sources (EPOS4, SSC, ros2_canopen, the Pilz
/// DCF, Technosoft) make 0x6060 `INTEGER8` ([`MODES_OF_OPERATION`]); the heig-vd canopen-stack
/// lists `INTEGER16`, and a Schneider LXM32M reportedly errors unless two bytes are written.
/// For such drives write this entry instead (the value range is still −128..127).
pub const MODES_OF_OPERATION_INTEGER16: Entry<i16> = Entry::new(0x6060, 0, DataType::Integer16);

/// The index offset between two axes of a multi-axis device (CiA 402-2 §5).
pub const AXIS_OFFSET: u16 = 0x800;

/// The highest axis number: axis 7 ends at 0x9FFF, the end of the profile area 0x6000..0x9FFF.
pub const MAX_AXIS: u8 = 7;

/// `entry` on axis `axis` (0 = the first axis, at the index of the tables): index + axis × 0x800.
/// Axes beyond [`MAX_AXIS`] return `None`.
pub const fn on_axis<T>(entry: Entry<T>, axis: u8) -> Option<Entry<T>> {
    if axis > MAX_AXIS {
        return None;
    }
    Some(Entry::new(
        entry.index() + axis as u16 * AXIS_OFFSET,
        entry.sub_index(),
        entry.data_type(),
    ))
}

/// The axis and axis-0 index of a profile index (0x6000..=0x9FFF); `None` outside the profile area.
pub const fn axis_of(index: u16) -> Option<(u8, u16)> {
    if index < 0x6000 || index > 0x9FFF {
        return None;
    }
    let axis = ((index - 0x6000) / AXIS_OFFSET) as u8;
    Some((axis, index - axis as u16 * AXIS_OFFSET))
}

/// The profile object at `index`/`sub` of any axis (index + axis × 0x800), from the table
/// [`ALL`]: its name, axis-0 index and data type. `None` for an object the table does not have.
pub fn find(index: u16, sub: u8) -> Option<&'static ObjectInfo> {
    let (_, base) = axis_of(index)?;
    ALL.iter().find(|o| o.index == base && o.sub_index == sub)
}

/// Whether a device type 0x1000 names the CiA 402 profile (its lower 16 bits are 402).
pub const fn is_drive_profile(device_type: u32) -> bool {
    device_type & 0xFFFF == 402
}

/// How a drive numbers quick stop option codes 5 and 6. SSC,
/// the JS decoder, Beckhoff, Synapticon and UDTStudio agree on [`Standard`](Self::Standard); a
/// Harmonic Drive SDK header swaps 5 and 6.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum QuickStopNumbering {
    /// 5 = slow-down ramp and stay, 6 = quick-stop ramp and stay (the majority).
    #[default]
    Standard,
    /// 5 = quick-stop ramp and stay, 6 = slow-down ramp and stay.
    SwappedFiveSix,
}

/// How the drive stops for a quick stop, halt, shutdown, disable operation or fault reaction.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum StopRamp {
    /// The drive function is disabled at once; the motor coasts.
    DisableDrive,
    /// Slow down on the slow-down ramp (profile deceleration 0x6084).
    SlowDownRamp,
    /// Slow down on the quick-stop ramp (0x6085).
    QuickStopRamp,
    /// Slow down on the current limit.
    CurrentLimit,
    /// Slow down on the voltage limit.
    VoltageLimit,
}

/// Quick stop option code 0x605A (`INTEGER16`), an open enum over every code.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct QuickStopOption(pub i16);

impl QuickStopOption {
    /// 2: slow down on the quick-stop ramp, then switch on disabled. The common default.
    pub const DEFAULT: Self = Self(2);

    /// The ramp of this code; `None` for manufacturer-specific (negative) and reserved codes.
    pub const fn ramp(self, numbering: QuickStopNumbering) -> Option<StopRamp> {
        Some(match (self.0, numbering) {
            (0, _) => StopRamp::DisableDrive,
            (1, _) => StopRamp::SlowDownRamp,
            (2, _) => StopRamp::QuickStopRamp,
            (3 | 7, _) => StopRamp::CurrentLimit,
            (4 | 8, _) => StopRamp::VoltageLimit,
            (5, QuickStopNumbering::Standard) | (6, QuickStopNumbering::SwappedFiveSix) => {
                StopRamp::SlowDownRamp
            }
            (6, QuickStopNumbering::Standard) | (5, QuickStopNumbering::SwappedFiveSix) => {
                StopRamp::QuickStopRamp
            }
            _ => return None,
        })
    }

    /// Whether the drive stays in quick stop active when the stop has finished (codes 5..8);
    /// codes 0..4 go on to switch on disabled by themselves (transition 12). Manufacturer and
    /// reserved codes are taken as "goes to switch on disabled", which a master must accept in
    /// any case.
    pub const fn stays_in_quick_stop(self) -> bool {
        matches!(self.0, 5..=8)
    }

    /// Whether transition 16 (quick stop active → operation enabled) can exist with this code:
    /// only while the drive stays in quick stop active (5..8).
    pub const fn allows_transition_16(self) -> bool {
        self.stays_in_quick_stop()
    }
}

impl Default for QuickStopOption {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Option codes 0x605B (shutdown), 0x605C (disable operation), 0x605D (halt) and 0x605E (fault
/// reaction), `INTEGER16`: the stop ramp a code selects.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct OptionCode(pub i16);

/// How a drive numbers the fault reaction option code 0x605E. The majority (SSC, Harmonic)
/// uses 0..4 like 0x605A; Technosoft uses −1 no action, 0 disable drive, 2 quick-stop ramp.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum FaultReactionNumbering {
    /// 0 disable, 1 slow-down ramp, 2 quick-stop ramp, 3 current limit, 4 voltage limit.
    #[default]
    Standard,
    /// Technosoft: −1 no action (`None`), 0 disable, 1 reserved, 2 quick-stop ramp.
    Technosoft,
}

impl OptionCode {
    /// The ramp of a shutdown (0x605B) or disable operation (0x605C) code: 0 disable drive,
    /// 1 slow-down ramp; others are manufacturer-specific or reserved (`None`).
    pub const fn shutdown_ramp(self) -> Option<StopRamp> {
        match self.0 {
            0 => Some(StopRamp::DisableDrive),
            1 => Some(StopRamp::SlowDownRamp),
            _ => None,
        }
    }

    /// The ramp of a halt code (0x605D): 1 slow-down, 2 quick-stop, 3 current, 4 voltage limit.
    /// Code 0 is disputed (Harmonic: disable drive; others: reserved) and gives `None`.
    pub const fn halt_ramp(self) -> Option<StopRamp> {
        match self.0 {
            1 => Some(StopRamp::SlowDownRamp),
            2 => Some(StopRamp::QuickStopRamp),
            3 => Some(StopRamp::CurrentLimit),
            4 => Some(StopRamp::VoltageLimit),
            _ => None,
        }
    }

    /// The ramp of a fault reaction code (0x605E) in the given numbering.
    pub const fn fault_reaction_ramp(self, numbering: FaultReactionNumbering) -> Option<StopRamp> {
        match (numbering, self.0) {
            (_, 0) => Some(StopRamp::DisableDrive),
            (FaultReactionNumbering::Standard, 1) => Some(StopRamp::SlowDownRamp),
            (_, 2) => Some(StopRamp::QuickStopRamp),
            (FaultReactionNumbering::Standard, 3) => Some(StopRamp::CurrentLimit),
            (FaultReactionNumbering::Standard, 4) => Some(StopRamp::VoltageLimit),
            _ => None,
        }
    }
}

/// Error code 0x603F (and the EMCY error code the drive sends with it), CiA 301 Table 21 and
/// CiA 402-2 Annex; unknown codes keep their value and print in hex.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct ErrorCode(pub u16);

impl ErrorCode {
    /// 0x0000: no error.
    pub const NONE: Self = Self(0x0000);
    /// 0x2310: continuous over-current.
    pub const CONTINUOUS_OVER_CURRENT: Self = Self(0x2310);
    /// 0x3210: DC link over-voltage.
    pub const DC_LINK_OVER_VOLTAGE: Self = Self(0x3210);
    /// 0x3220: DC link under-voltage.
    pub const DC_LINK_UNDER_VOLTAGE: Self = Self(0x3220);
    /// 0x4310: drive excess temperature.
    pub const EXCESS_TEMPERATURE_DRIVE: Self = Self(0x4310);
    /// 0x8611: positioning controller, following error.
    pub const FOLLOWING_ERROR: Self = Self(0x8611);
    /// 0x8612: positioning controller, reference limit (a limit switch was hit).
    pub const REFERENCE_LIMIT: Self = Self(0x8612);

    const NAMES: &'static [(u16, &'static str)] = &[
        (0x0000, "no error"),
        (0x2310, "continuous over-current"),
        (0x3210, "DC link over-voltage"),
        (0x3220, "DC link under-voltage"),
        (0x4310, "drive excess temperature"),
        (0x8611, "following error"),
        (0x8612, "reference limit"),
    ];

    /// The name of a known code.
    pub fn name(self) -> Option<&'static str> {
        Self::NAMES
            .iter()
            .find(|(c, _)| *c == self.0)
            .map(|(_, n)| *n)
    }

    /// The CiA 301 error register (0x1001) bit this code sets besides bit 0 (generic error):
    /// current 0x02, voltage 0x04, temperature 0x08, device profile 0x20.
    pub const fn error_register_bit(self) -> u8 {
        match self.0 >> 12 {
            0x0 => 0,
            0x2 => 0x02,
            0x3 => 0x04,
            0x4 => 0x08,
            _ => 0x20,
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(n) => write!(f, "{:#06x} ({n})", self.0),
            None => write!(f, "{:#06x}", self.0),
        }
    }
}

/// Supported drive modes 0x6502 (`UNSIGNED32`): bit = mode − 1 for modes 1..10; bits 16..31
/// manufacturer-specific. The object is optional (ros2_canopen #299): a master must not require it.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct SupportedModes(pub u32);

impl SupportedModes {
    /// Whether `mode` is listed.
    pub const fn contains(self, mode: ModeOfOperation) -> bool {
        match mode.supported_bit() {
            Some(bit) => self.0 & bit != 0,
            None => false,
        }
    }
    /// This set with `mode` added (no change for modes without a bit).
    #[must_use]
    pub const fn with(self, mode: ModeOfOperation) -> Self {
        match mode.supported_bit() {
            Some(bit) => Self(self.0 | bit),
            None => self,
        }
    }
    /// The standard modes listed.
    pub fn iter(self) -> impl Iterator<Item = ModeOfOperation> {
        ModeOfOperation::STANDARD
            .into_iter()
            .filter(move |m| self.contains(*m))
    }
}

/// Interpolation time period 0x60C2: `value` × 10^`index` seconds.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct InterpolationPeriod {
    /// 0x60C2:1.
    pub value: u8,
    /// 0x60C2:2, the power-of-ten exponent (−3 for milliseconds).
    pub index: i8,
}

impl InterpolationPeriod {
    /// The period in nanoseconds; `None` when it is not a whole number of nanoseconds or does
    /// not fit.
    pub fn as_nanos(self) -> Option<u64> {
        let exp = i32::from(self.index) + 9;
        if exp < 0 {
            let div = 10u64.checked_pow(exp.unsigned_abs())?;
            return u64::from(self.value)
                .is_multiple_of(div)
                .then(|| u64::from(self.value) / div);
        }
        u64::from(self.value).checked_mul(10u64.checked_pow(exp as u32)?)
    }

    /// The exact representation of a period of `micros` microseconds with the largest
    /// exponent, as a master writes it to match 0x1006; `None` when no `u8` value fits.
    pub fn from_micros(micros: u64) -> Option<Self> {
        if micros == 0 {
            return Some(Self {
                value: 0,
                index: -3,
            });
        }
        let mut value = micros;
        let mut index: i8 = -6;
        while value.is_multiple_of(10) && index < 0 {
            value /= 10;
            index += 1;
        }
        let value = u8::try_from(value).ok()?;
        Some(Self { value, index })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_and_axes() {
        assert_eq!(
            (CONTROLWORD.index(), CONTROLWORD.data_type()),
            (0x6040, DataType::Unsigned16)
        );
        assert_eq!(MODES_OF_OPERATION.data_type(), DataType::Integer8);
        let sw1 = on_axis(STATUSWORD, 1).unwrap();
        assert_eq!(sw1.index(), 0x6841);
        assert_eq!(
            on_axis(MAX_SOFTWARE_POSITION_LIMIT, 2).unwrap().address(),
            (0x707D, 2).into()
        );
        assert_eq!(on_axis(STATUSWORD, 8), None);
        assert_eq!(axis_of(0x6841), Some((1, 0x6041)));
        assert_eq!(axis_of(0x1000), None);
        let mut last = 0;
        for o in ALL {
            let key = u32::from(o.index) << 8 | u32::from(o.sub_index);
            assert!(key > last, "{o:?} out of order");
            last = key;
        }
    }

    #[test]
    fn quick_stop_codes() {
        for code in 0..=4 {
            assert!(!QuickStopOption(code).stays_in_quick_stop());
        }
        for code in 5..=8 {
            assert!(QuickStopOption(code).allows_transition_16());
        }
        assert_eq!(
            QuickStopOption(5).ramp(QuickStopNumbering::Standard),
            Some(StopRamp::SlowDownRamp)
        );
        assert_eq!(
            QuickStopOption(5).ramp(QuickStopNumbering::SwappedFiveSix),
            Some(StopRamp::QuickStopRamp)
        );
        assert_eq!(QuickStopOption(-1).ramp(QuickStopNumbering::Standard), None);
        assert!(!QuickStopOption(-1).stays_in_quick_stop());
        assert_eq!(
            OptionCode(1).fault_reaction_ramp(FaultReactionNumbering::Technosoft),
            None
        );
        assert_eq!(
            OptionCode(1).fault_reaction_ramp(FaultReactionNumbering::Standard),
            Some(StopRamp::SlowDownRamp)
        );
    }

    #[test]
    fn interpolation_period() {
        let p = InterpolationPeriod {
            value: 50,
            index: -3,
        };
        assert_eq!(p.as_nanos(), Some(50_000_000));
        assert_eq!(
            InterpolationPeriod::from_micros(1000),
            Some(InterpolationPeriod {
                value: 1,
                index: -3
            })
        );
        assert_eq!(
            InterpolationPeriod::from_micros(250),
            Some(InterpolationPeriod {
                value: 25,
                index: -5
            })
        );
        assert_eq!(InterpolationPeriod::from_micros(257), None);
        assert_eq!(
            InterpolationPeriod {
                value: 5,
                index: -12
            }
            .as_nanos(),
            None
        );
        assert_eq!(
            InterpolationPeriod {
                value: 255,
                index: 127
            }
            .as_nanos(),
            None
        );
    }

    #[test]
    fn supported_modes_and_error_codes() {
        let s = SupportedModes(0x03ED);
        assert!(
            s.contains(ModeOfOperation::ProfilePosition) && !s.contains(ModeOfOperation::Velocity)
        );
        assert_eq!(s.iter().count(), 8);
        assert_eq!(
            SupportedModes::default().with(ModeOfOperation::Homing).0,
            0x20
        );
        assert_eq!(
            std::format!("{}", ErrorCode::FOLLOWING_ERROR),
            "0x8611 (following error)"
        );
        assert_eq!(std::format!("{}", ErrorCode(0xFF01)), "0xff01");
        assert_eq!(
            ErrorCode::CONTINUOUS_OVER_CURRENT.error_register_bit(),
            0x02
        );
    }
}
