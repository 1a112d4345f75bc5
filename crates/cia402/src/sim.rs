//! A simulated CiA 402 servo drive, sans-IO: controlword and targets in (by object writes),
//! statusword, actual values and EMCY codes out, time advanced by [`SimDrive::step`].
//!
//! What it models, and after which real behaviour:
//! - the power drive state machine of [`crate::device`] (quick stop by 0x605A, transition 16,
//!   fault reset on the rising edge of bit 7); the stop ramps of quick stop (0x605A), halt
//!   (0x605D), fault reaction (0x605E), disable operation (0x605C) and shutdown (0x605B);
//! - motion: a trapezoidal profile generator (pp, pv, homing) with 0x6081/0x6083/0x6084, a
//!   linear interpolator (ip), direct cyclic targets with feed-forward offsets (csp, csv, cst),
//!   torque with slope 0x6087 (tq), vl with its three ramp bits; a position loop whose
//!   acceleration is limited by max torque 0x6072, so a demand the motor cannot follow builds a
//!   following error (0x60F4) that faults after 0x6065 / 0x6066;
//! - software position limits 0x607D (targets clamped, statusword bit 11) and two hardware limit
//!   switches (a fault 0x8612 when hit outside homing);
//! - homing methods 1..6, 17..22, 33, 34, 35, 37 with a home switch and an index pulse every
//!   [`SimConfig::index_pulse_spacing`] counts; other methods end in homing error;
//! - fault injection ([`SimFault`]): 0x603F, error register 0x1001 and an EMCY code, the fault
//!   reaction by 0x605E, then fault; an EMCY 0x0000 after the fault reset;
//! - a safe-torque-off input: with it active the drive does not switch on (statusword bit 4
//!   clear), and an enabled drive drops to switch on disabled with the motor coasting.
//!
//! The object-dictionary interface ([`SimDrive::read`], [`SimDrive::write`]) takes index and
//! sub-index (with the axis offset of [`SimConfig::axis`]) and little-endian bytes, and fails with
//! the SDO abort code a drive would answer, so a device simulator can put it behind its SDO
//! server and PDO mappings and call `step` once per tick or SYNC.

use std::collections::VecDeque;
use std::time::Duration;
use std::vec::Vec;

use canola_od::DataType;

use crate::device::{DeviceConfig, DeviceStateMachine};
use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::{
    self as obj, ErrorCode, ObjectInfo, OptionCode, QuickStopOption, StopRamp, SupportedModes,
};
use crate::state::{State, Transition};
use crate::words::{Controlword, Statusword};

/// The simulated drive's fixed properties.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// State machine behaviour where drives differ (0x605A's initial value included).
    pub device: DeviceConfig,
    /// The axis number: objects at index + axis × 0x800.
    pub axis: u8,
    /// 0x6502; `None` leaves the object out (ros2_canopen #299: drives without it).
    pub supported_modes: Option<SupportedModes>,
    /// Acceleration at 1000 ‰ (rated) torque, counts/s².
    pub acceleration_at_rated_torque: f64,
    /// Viscous friction, 1/s (deceleration per unit of velocity when no torque is applied).
    pub friction: f64,
    /// The home switch is active at positions ≥ this, counts.
    pub home_switch: f64,
    /// Index pulses at every multiple of this, counts (one motor revolution).
    pub index_pulse_spacing: f64,
    /// The negative limit switch is active at positions ≤ this; `None`: no switch.
    pub negative_limit_switch: Option<f64>,
    /// The positive limit switch is active at positions ≥ this; `None`: no switch.
    pub positive_limit_switch: Option<f64>,
    /// Time in not ready to switch on after power-on.
    pub init_time: Duration,
    /// Safe torque off active at power-on.
    pub safe_torque_off: bool,
    /// Refuse a write of a different mode to 0x6060 in operation enabled (ipa_canopen PR #29
    /// allows mode changes only in switch on disabled, ready to switch on and switched on).
    /// Off by default: python-canopen #244/#251 drives switch modes in any state.
    pub refuse_mode_change_when_enabled: bool,
    /// Refuse a write of a different mode to 0x6060 while the controlword holds halt (bit 8),
    /// as some drives do (ros_canopen #328, ros2_canopen #234).
    pub refuse_mode_change_while_halt: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            device: DeviceConfig::default(),
            axis: 0,
            supported_modes: Some(SupportedModes(0x03ED)),
            acceleration_at_rated_torque: 200_000.0,
            friction: 2.0,
            home_switch: 5_000.0,
            index_pulse_spacing: 4_096.0,
            negative_limit_switch: Some(-200_000.0),
            positive_limit_switch: Some(200_000.0),
            init_time: Duration::from_millis(10),
            safe_torque_off: false,
            refuse_mode_change_when_enabled: false,
            refuse_mode_change_while_halt: false,
        }
    }
}

/// A fault to inject.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SimFault {
    /// Following error (0x8611).
    FollowingError,
    /// Continuous over-current (0x2310).
    OverCurrent,
    /// A limit switch hit (0x8612, reference limit).
    LimitSwitch,
    /// Any code.
    Other(ErrorCode),
}

impl SimFault {
    /// The 0x603F / EMCY code.
    pub const fn code(self) -> ErrorCode {
        match self {
            Self::FollowingError => ErrorCode::FOLLOWING_ERROR,
            Self::OverCurrent => ErrorCode::CONTINUOUS_OVER_CURRENT,
            Self::LimitSwitch => ErrorCode::REFERENCE_LIMIT,
            Self::Other(c) => c,
        }
    }
}

/// An emergency message the drive sends (CiA 301 §7.2.7): error code and error register.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Emcy {
    /// The error code; 0x0000 after a reset.
    pub code: ErrorCode,
    /// 0x1001 at the time.
    pub error_register: u8,
}

/// Why a read or write of the simulated dictionary fails, with its CiA 301 SDO abort code.
#[derive(Clone, Copy, PartialEq, Eq, Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AccessError {
    /// 0x06020000.
    #[error("object {0:#06x} does not exist")]
    NoObject(u16),
    /// 0x06090011.
    #[error("sub-index {1} of {0:#06x} does not exist")]
    NoSubIndex(u16, u8),
    /// 0x06010002.
    #[error("{0:#06x}:{1} is read-only")]
    ReadOnly(u16, u8),
    /// 0x06070010.
    #[error("{0:#06x}:{1} takes another length")]
    Length(u16, u8),
    /// 0x06090030.
    #[error("value out of range for {0:#06x}:{1}")]
    ValueRange(u16, u8),
    /// 0x08000022: not now, in the drive's present state.
    #[error("{0:#06x}:{1} cannot be written in the drive's present state")]
    DeviceState(u16, u8),
}

impl AccessError {
    /// The SDO abort code.
    pub const fn abort_code(self) -> u32 {
        match self {
            Self::NoObject(_) => 0x0602_0000,
            Self::NoSubIndex(..) => 0x0609_0011,
            Self::ReadOnly(..) => 0x0601_0002,
            Self::Length(..) => 0x0607_0010,
            Self::ValueRange(..) => 0x0609_0030,
            Self::DeviceState(..) => 0x0800_0022,
        }
    }
}

/// Objects the drive computes; a master cannot write them.
const READ_ONLY: &[u16] = &[
    0x603F, 0x6041, 0x6043, 0x6044, 0x6061, 0x6062, 0x6063, 0x6064, 0x606B, 0x606C, 0x6074, 0x6077,
    0x60F4, 0x60FD, 0x6502,
];

/// Records: their highest sub-index (read-only sub 0).
const RECORDS: &[(u16, u8)] = &[(0x607D, 2), (0x6099, 2), (0x60C1, 1), (0x60C2, 2)];

#[derive(Clone, Copy, PartialEq, Debug)]
enum HomingPhase {
    /// Search the switch at the fast speed in a direction (+1/−1) until the switch reads `until`.
    Search {
        dir: f64,
        until: bool,
        switch: Switch,
    },
    /// Creep at the slow speed until the switch reads `until`; then index or done.
    Creep {
        dir: f64,
        until: bool,
        switch: Switch,
        index: bool,
    },
    /// Creep to the next index pulse.
    Index { dir: f64 },
}

/// A linear segment of ip or csp: from the demand when a new set-point arrived to that
/// set-point, in one interpolation period 0x60C2 (CiA 402-2 §11, §14: the drive spreads each
/// set-point over the period the master sends them in).
#[derive(Clone, Copy, PartialEq, Debug)]
struct Segment {
    from: f64,
    to: f64,
    elapsed: f64,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Switch {
    NegativeLimit,
    PositiveLimit,
    Home,
}

/// The simulated drive. See the module documentation.
#[derive(Clone, Debug)]
pub struct SimDrive {
    config: SimConfig,
    machine: DeviceStateMachine,
    values: Vec<i64>,
    error_register: u8,
    since_power_on: Duration,
    emcy: VecDeque<Emcy>,
    // Motion, in counts and seconds. `position` is in the drive's coordinates; the shaft (where
    // the switches and index pulses are) is at `position - frame`, which homing shifts.
    position: f64,
    frame: f64,
    velocity: f64,
    torque: f64,
    demand_position: f64,
    demand_velocity: f64,
    following_error_time: f64,
    in_window_time: f64,
    limit_active: bool,
    // Profile position.
    pp_target: f64,
    pp_pending: Option<f64>,
    set_point_ack: bool,
    pp_moving: bool,
    // Homing.
    homing: Option<HomingPhase>,
    homing_status: HomingStatus,
    // ip and csp: the segment toward the latest set-point.
    segment: Option<Segment>,
    // How the motor stops after leaving operation enabled (0x605B / 0x605C).
    disable_ramp: StopRamp,
}

impl Default for SimDrive {
    fn default() -> Self {
        Self::new(SimConfig::default())
    }
}

impl SimDrive {
    /// A drive at power-on: not ready to switch on for [`SimConfig::init_time`], then switch on
    /// disabled; no mode (0x6061 = 0); at position 0.
    pub fn new(config: SimConfig) -> Self {
        let mut machine = DeviceStateMachine::new(config.device);
        machine.set_power(!config.safe_torque_off);
        let mut sim = Self {
            machine,
            values: std::vec![0; obj::ALL.len()],
            error_register: 0,
            since_power_on: Duration::ZERO,
            emcy: VecDeque::new(),
            position: 0.0,
            frame: 0.0,
            velocity: 0.0,
            torque: 0.0,
            demand_position: 0.0,
            demand_velocity: 0.0,
            following_error_time: 0.0,
            in_window_time: 0.0,
            limit_active: false,
            pp_target: 0.0,
            pp_pending: None,
            set_point_ack: false,
            pp_moving: false,
            homing: None,
            homing_status: HomingStatus::Interrupted,
            segment: None,
            disable_ramp: StopRamp::DisableDrive,
            config,
        };
        sim.put(
            obj::QUICK_STOP_OPTION_CODE,
            i64::from(sim.config.device.quick_stop_option.0),
        );
        sim.put(obj::DISABLE_OPERATION_OPTION_CODE, 1);
        sim.put(obj::HALT_OPTION_CODE, 1);
        sim.put(obj::FAULT_REACTION_OPTION_CODE, 2);
        sim.put(obj::FOLLOWING_ERROR_WINDOW, 10_000);
        sim.put(obj::FOLLOWING_ERROR_TIME_OUT, 50);
        sim.put(obj::POSITION_WINDOW, 10);
        sim.put(obj::POSITION_WINDOW_TIME, 5);
        sim.put(obj::VELOCITY_WINDOW, 10);
        sim.put(obj::MAX_TORQUE, 1000);
        sim.put(obj::MAX_PROFILE_VELOCITY, 200_000);
        sim.put(obj::PROFILE_VELOCITY, 10_000);
        sim.put(obj::PROFILE_ACCELERATION, 50_000);
        sim.put(obj::PROFILE_DECELERATION, 50_000);
        sim.put(obj::QUICK_STOP_DECELERATION, 150_000);
        sim.put(obj::TORQUE_SLOPE, 10_000);
        sim.put(obj::HOMING_ACCELERATION, 50_000);
        sim.put(obj::INTERPOLATION_TIME_PERIOD_VALUE, 1);
        sim.put(obj::HOMING_SPEED_SWITCH, 5_000);
        sim.put(obj::HOMING_SPEED_ZERO, 500);
        sim.put(obj::INTERPOLATION_TIME_INDEX, -3);
        sim.put(
            obj::SUPPORTED_DRIVE_MODES,
            i64::from(sim.config.supported_modes.map_or(0, |m| m.0)),
        );
        sim.refresh();
        sim
    }

    fn slot(index: u16, sub: u8) -> Option<usize> {
        obj::ALL
            .iter()
            .position(|o| o.index == index && o.sub_index == sub)
    }

    fn info(index: u16, sub: u8) -> Option<&'static ObjectInfo> {
        obj::ALL
            .iter()
            .find(|o| o.index == index && o.sub_index == sub)
    }

    fn get<T>(&self, e: canola_od::Entry<T>) -> i64 {
        Self::slot(e.index(), e.sub_index()).map_or(0, |i| self.values[i])
    }

    fn put<T>(&mut self, e: canola_od::Entry<T>, v: i64) {
        if let Some(i) = Self::slot(e.index(), e.sub_index()) {
            self.values[i] = v;
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The state.
    pub fn state(&self) -> State {
        self.machine.state()
    }

    /// The statusword 0x6041.
    pub fn statusword(&self) -> Statusword {
        Statusword::from_raw(self.get(obj::STATUSWORD) as u16)
    }

    /// The mode running (0x6061).
    pub fn mode(&self) -> ModeOfOperation {
        ModeOfOperation::from_code(self.get(obj::MODES_OF_OPERATION_DISPLAY) as i8)
    }

    /// The exact simulated position, counts (0x6064 is it rounded).
    pub fn position(&self) -> f64 {
        self.position
    }

    /// The exact simulated velocity, counts/s.
    pub fn velocity(&self) -> f64 {
        self.velocity
    }

    /// Torque, ‰ of rated torque.
    pub fn torque(&self) -> f64 {
        self.torque
    }

    /// Puts the motor shaft at `shaft` counts from where the switches are measured (for
    /// setting up a test: homing from a given place); the actual position follows.
    pub fn set_position(&mut self, shaft: f64) {
        let position = shaft + self.frame;
        self.position = position;
        self.demand_position = position;
        self.pp_target = position;
        self.refresh();
    }

    /// Sets the safe-torque-off input.
    pub fn set_safe_torque_off(&mut self, active: bool) {
        self.machine.set_power(!active);
        self.refresh();
    }

    /// Injects a fault: transition 13, 0x603F and 0x1001 set, an EMCY queued. No effect in
    /// fault or fault reaction active.
    pub fn inject_fault(&mut self, fault: SimFault) {
        self.raise(fault.code());
    }

    /// The next EMCY the drive sends.
    pub fn poll_emcy(&mut self) -> Option<Emcy> {
        self.emcy.pop_front()
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

    fn raise(&mut self, code: ErrorCode) {
        if self.machine.fault().is_some() {
            self.put(obj::ERROR_CODE, i64::from(code.0));
            self.error_register = 0x01 | code.error_register_bit();
            self.emcy.push_back(Emcy {
                code,
                error_register: self.error_register,
            });
            self.homing = None;
            self.refresh();
        }
    }

    fn on_controlword(&mut self, previous: Controlword, cw: Controlword) {
        let taken = self.machine.on_controlword(cw);
        for t in taken.iter() {
            if t == Transition::T15 {
                self.put(obj::ERROR_CODE, 0);
                self.error_register = 0;
                self.emcy.push_back(Emcy {
                    code: ErrorCode::NONE,
                    error_register: 0,
                });
            }
            // Leaving operation enabled: transition 5 brakes as 0x605C says, 8 as 0x605B says,
            // the others (9, and 10 and 7 with nothing moving) disable the drive function.
            self.disable_ramp = match t {
                Transition::T5 => OptionCode(self.get(obj::DISABLE_OPERATION_OPTION_CODE) as i16)
                    .shutdown_ramp()
                    .unwrap_or(StopRamp::DisableDrive),
                Transition::T8 => OptionCode(self.get(obj::SHUTDOWN_OPTION_CODE) as i16)
                    .shutdown_ramp()
                    .unwrap_or(StopRamp::DisableDrive),
                _ => StopRamp::DisableDrive,
            };
            if t.to() == State::OperationEnabled {
                // Enabling starts from where the motor is: no jump to an old demand.
                self.demand_position = self.position;
                self.demand_velocity = self.velocity;
                self.pp_target = self.position;
                self.pp_moving = false;
                self.pp_pending = None;
                self.segment = None;
            }
        }
        if self.machine.state() != State::OperationEnabled {
            return;
        }
        let rising4 = cw.bit(4) && !previous.bit(4);
        match self.mode() {
            ModeOfOperation::ProfilePosition => {
                if rising4 && !self.set_point_ack {
                    let raw = self.get(obj::TARGET_POSITION) as f64;
                    let target = if cw.bit(6) { self.pp_target + raw } else { raw };
                    let target = self.clamp_to_limits(target);
                    if cw.bit(5) || !self.pp_moving {
                        self.pp_target = target;
                        self.pp_moving = true;
                        self.in_window_time = 0.0;
                    } else {
                        self.pp_pending = Some(target);
                    }
                    self.set_point_ack = true;
                } else if !cw.bit(4) && self.pp_pending.is_none() {
                    self.set_point_ack = false;
                }
            }
            ModeOfOperation::Homing => {
                if rising4 {
                    self.start_homing();
                } else if !cw.bit(4) && self.homing.is_some() {
                    // Clearing bit 4 aborts homing.
                    self.homing = None;
                    self.homing_status = HomingStatus::Interrupted;
                }
            }
            _ => {}
        }
    }

    fn clamp_to_limits(&mut self, target: f64) -> f64 {
        let (min, max) = self.soft_limits();
        if min < max && !(min..=max).contains(&target) {
            self.limit_active = true;
            return target.clamp(min, max);
        }
        target
    }

    fn soft_limits(&self) -> (f64, f64) {
        (
            self.get(obj::MIN_SOFTWARE_POSITION_LIMIT) as f64,
            self.get(obj::MAX_SOFTWARE_POSITION_LIMIT) as f64,
        )
    }

    fn switch(&self, s: Switch, at: f64) -> bool {
        let at = at - self.frame;
        match s {
            Switch::NegativeLimit => self.config.negative_limit_switch.is_some_and(|l| at <= l),
            Switch::PositiveLimit => self.config.positive_limit_switch.is_some_and(|l| at >= l),
            Switch::Home => at >= self.config.home_switch,
        }
    }

    fn start_homing(&mut self) {
        let method = self.get(obj::HOMING_METHOD) as i8;
        let home = self.switch(Switch::Home, self.position);
        use HomingPhase::*;
        let phase = match method {
            35 | 37 => {
                self.homed_at(self.position);
                return;
            }
            1 => Search {
                dir: -1.0,
                until: true,
                switch: Switch::NegativeLimit,
            },
            2 => Search {
                dir: 1.0,
                until: true,
                switch: Switch::PositiveLimit,
            },
            17 => Search {
                dir: -1.0,
                until: true,
                switch: Switch::NegativeLimit,
            },
            18 => Search {
                dir: 1.0,
                until: true,
                switch: Switch::PositiveLimit,
            },
            // Home switch methods: approach the switch edge; the edge is then found at the slow
            // speed from the side the method names (3, 4, 19, 20 positive switch; 5, 6, 21, 22
            // negative side, modelled on the same switch).
            3 | 4 | 19 | 20 if !home => Search {
                dir: 1.0,
                until: true,
                switch: Switch::Home,
            },
            3 | 4 | 19 | 20 => Creep {
                dir: -1.0,
                until: false,
                switch: Switch::Home,
                index: method < 17,
            },
            5 | 6 | 21 | 22 if home => Search {
                dir: -1.0,
                until: false,
                switch: Switch::Home,
            },
            5 | 6 | 21 | 22 => Creep {
                dir: 1.0,
                until: true,
                switch: Switch::Home,
                index: method < 17,
            },
            33 => Index { dir: -1.0 },
            34 => Index { dir: 1.0 },
            _ => {
                self.homing = None;
                self.homing_status = HomingStatus::ErrorStandstill;
                return;
            }
        };
        self.homing = Some(phase);
        self.homing_status = HomingStatus::InProgress;
    }

    fn homed_at(&mut self, edge: f64) {
        // The found reference becomes the home offset; the overshoot past it is kept.
        let offset = self.get(obj::HOME_OFFSET) as f64;
        let shift = offset - edge;
        self.position += shift;
        self.frame += shift;
        self.demand_position = self.position;
        self.pp_target = self.position;
        self.velocity = 0.0;
        self.demand_velocity = 0.0;
        self.homing = None;
        self.homing_status = HomingStatus::Completed;
    }

    fn homing_step(&mut self, before: f64) {
        let Some(phase) = self.homing else { return };
        let method = self.get(obj::HOMING_METHOD) as i8;
        let p = self.position;
        let uses = |s: Switch| match s {
            Switch::NegativeLimit => matches!(method, 1 | 17),
            Switch::PositiveLimit => matches!(method, 2 | 18),
            Switch::Home => false,
        };
        for s in [Switch::NegativeLimit, Switch::PositiveLimit] {
            if self.switch(s, p) && !uses(s) {
                // A limit switch on the way: homing error, the drive stops.
                self.homing = None;
                self.homing_status = HomingStatus::ErrorMoving;
                return;
            }
        }
        use HomingPhase::*;
        match phase {
            Search { dir, until, switch } => {
                if self.switch(switch, p) == until {
                    let index = method < 17;
                    self.homing = Some(Creep {
                        dir: -dir,
                        until: !until,
                        switch,
                        index,
                    });
                }
            }
            Creep {
                dir,
                until,
                switch,
                index,
            } => {
                if self.switch(switch, p) == until {
                    if index {
                        self.homing = Some(Index { dir });
                    } else {
                        self.homed_at(p);
                    }
                }
            }
            Index { .. } => {
                let s = self.config.index_pulse_spacing;
                let (a, b) = (
                    ((before - self.frame) / s).floor(),
                    ((p - self.frame) / s).floor(),
                );
                if a != b {
                    self.homed_at(a.max(b) * s + self.frame);
                }
            }
        }
    }

    /// Advances the simulation by `dt`: automatic transitions, the active mode's motion, the
    /// limits and monitors, then the statusword and actual values.
    pub fn step(&mut self, dt: Duration) {
        let t = dt.as_secs_f64();
        if t <= 0.0 {
            return;
        }
        self.since_power_on += dt;
        if self.machine.state() == State::NotReadyToSwitchOn
            && self.since_power_on >= self.config.init_time
        {
            self.machine.initialised();
        }
        let cw = Controlword::from_raw(self.get(obj::CONTROLWORD) as u16);
        // The mode switch shows in 0x6061 one step after the write of 0x6060.
        let requested = self.get(obj::MODES_OF_OPERATION);
        if requested != self.get(obj::MODES_OF_OPERATION_DISPLAY) {
            self.put(obj::MODES_OF_OPERATION_DISPLAY, requested);
            self.homing = None;
            self.homing_status = HomingStatus::Interrupted;
            self.demand_position = self.position;
            self.demand_velocity = self.velocity;
            self.pp_target = self.position;
            self.pp_moving = false;
            self.segment = None;
        }
        let before = self.position;
        self.limit_active = false;
        match self.machine.state() {
            State::OperationEnabled if cw.halt() => {
                if self.homing.take().is_some() {
                    // Halt interrupts homing (CiA 402-2 §10: controlword bit 8 in hm).
                    self.homing_status = HomingStatus::Interrupted;
                }
                let ramp = OptionCode(self.get(obj::HALT_OPTION_CODE) as i16).halt_ramp();
                self.stop(ramp.unwrap_or(StopRamp::SlowDownRamp), t);
            }
            State::OperationEnabled => self.run_mode(cw, t),
            State::QuickStopActive => {
                let ramp = self
                    .machine
                    .config()
                    .quick_stop_option
                    .ramp(Default::default())
                    .unwrap_or(StopRamp::QuickStopRamp);
                // "Disable drive function" ends the quick stop at once; the motor coasts on.
                if self.stop(ramp, t) || ramp == StopRamp::DisableDrive {
                    self.machine.quick_stop_done();
                }
            }
            State::FaultReactionActive => {
                let code = OptionCode(self.get(obj::FAULT_REACTION_OPTION_CODE) as i16);
                let ramp = code
                    .fault_reaction_ramp(Default::default())
                    .unwrap_or(StopRamp::DisableDrive);
                if self.stop(ramp, t) || ramp == StopRamp::DisableDrive {
                    self.machine.fault_reaction_done();
                }
            }
            _ => {
                if self.stop(self.disable_ramp, t) {
                    self.disable_ramp = StopRamp::DisableDrive;
                }
            }
        }
        if self.homing.is_some() {
            self.homing_step(before);
        }
        self.monitor(before, t);
        self.refresh();
    }

    /// Brakes on `ramp`; true once standing still.
    fn stop(&mut self, ramp: StopRamp, t: f64) -> bool {
        let max = self.max_acceleration();
        let decel = match ramp {
            StopRamp::DisableDrive => {
                // No torque: the motor coasts down against friction.
                self.torque = 0.0;
                self.velocity -= self.velocity * (self.config.friction * t).min(1.0);
                if self.velocity.abs() < 1.0 {
                    self.velocity = 0.0;
                }
                self.position += self.velocity * t;
                self.demand_position = self.position;
                self.demand_velocity = self.velocity;
                return self.velocity == 0.0;
            }
            StopRamp::SlowDownRamp => self.get(obj::PROFILE_DECELERATION) as f64,
            StopRamp::QuickStopRamp => self.get(obj::QUICK_STOP_DECELERATION) as f64,
            StopRamp::CurrentLimit | StopRamp::VoltageLimit => max,
        }
        .min(max)
        .max(1.0);
        let dv = decel * t;
        let v = if self.velocity.abs() <= dv {
            0.0
        } else {
            self.velocity - dv * self.velocity.signum()
        };
        self.torque = (v - self.velocity) / t / self.config.acceleration_at_rated_torque * 1000.0;
        self.velocity = v;
        self.position += v * t;
        self.demand_position = self.position;
        self.demand_velocity = v;
        v == 0.0
    }

    fn max_acceleration(&self) -> f64 {
        self.get(obj::MAX_TORQUE) as f64 / 1000.0 * self.config.acceleration_at_rated_torque
    }

    /// The trapezoid toward `target` on the demand side.
    fn profile_to(&mut self, target: f64, speed: f64, acc: f64, dec: f64, t: f64) -> bool {
        let dist = target - self.demand_position;
        let reachable = (2.0 * dec.max(1.0) * dist.abs()).sqrt();
        let wanted = dist.signum() * speed.min(reachable);
        self.ramp_demand_velocity(wanted, acc, dec, t);
        let next = self.demand_position + self.demand_velocity * t;
        if (target - next).signum() != dist.signum() || dist == 0.0 || (dist.abs() < 1e-6) {
            self.demand_position = target;
            self.demand_velocity = 0.0;
            return true;
        }
        self.demand_position = next;
        false
    }

    fn ramp_demand_velocity(&mut self, wanted: f64, acc: f64, dec: f64, t: f64) {
        let v = self.demand_velocity;
        let speeding_up = wanted.abs() > v.abs() && wanted.signum() == v.signum() || v == 0.0;
        let limit = if speeding_up { acc } else { dec }.max(1.0) * t;
        self.demand_velocity = v + (wanted - v).clamp(-limit, limit);
    }

    /// The position loop: the motor follows the demand with an acceleration limited by 0x6072.
    fn follow_position(&mut self, t: f64) {
        let gain = (0.5 / t).min(200.0);
        // What is left to the demand after this step's feed-forward move.
        let error = self.demand_position - self.position - self.demand_velocity * t;
        // Proportional near the demand; far from it no faster than the motor can still brake
        // from (v² = 2·a·e), so a saturated loop closes in without overshooting.
        let braking = (2.0 * self.max_acceleration() * error.abs()).sqrt();
        let correction = error.signum() * (gain * error.abs()).min(braking);
        self.drive_velocity(self.demand_velocity + correction, t);
    }

    fn drive_velocity(&mut self, wanted: f64, t: f64) {
        let max = self.max_acceleration();
        let a = ((wanted - self.velocity) / t).clamp(-max, max);
        self.torque = a / self.config.acceleration_at_rated_torque * 1000.0;
        self.velocity += a * t;
        self.position += self.velocity * t;
    }

    fn run_mode(&mut self, cw: Controlword, t: f64) {
        let speed_limit = self.get(obj::MAX_PROFILE_VELOCITY) as f64;
        let profile_speed = (self.get(obj::PROFILE_VELOCITY) as f64).min(speed_limit);
        let acc = self.get(obj::PROFILE_ACCELERATION) as f64;
        let dec = self.get(obj::PROFILE_DECELERATION) as f64;
        match self.mode() {
            ModeOfOperation::ProfilePosition => {
                if self.pp_moving && self.profile_to(self.pp_target, profile_speed, acc, dec, t) {
                    self.pp_moving = false;
                    if let Some(next) = self.pp_pending.take() {
                        self.pp_target = next;
                        self.pp_moving = true;
                        self.in_window_time = 0.0;
                        if !cw.bit(4) {
                            self.set_point_ack = false;
                        }
                    }
                }
                self.follow_position(t);
            }
            ModeOfOperation::ProfileVelocity => {
                let target =
                    (self.get(obj::TARGET_VELOCITY) as f64).clamp(-speed_limit, speed_limit);
                self.ramp_demand_velocity(target, acc, dec, t);
                self.demand_position += self.demand_velocity * t;
                self.drive_velocity(self.demand_velocity, t);
                self.demand_position = self.position;
            }
            ModeOfOperation::Velocity => {
                // vl follows 0x6042 only with ramp enable, unlock and use reference (bits 4..6).
                let target = if cw.contains(0x0070) {
                    self.get(obj::VL_TARGET_VELOCITY) as f64
                } else {
                    0.0
                };
                self.ramp_demand_velocity(target, acc, dec, t);
                self.drive_velocity(self.demand_velocity, t);
                self.demand_position = self.position;
            }
            ModeOfOperation::ProfileTorque | ModeOfOperation::CyclicSyncTorque => {
                let max = self.get(obj::MAX_TORQUE) as f64;
                let mut target = self.get(obj::TARGET_TORQUE) as f64;
                if self.mode() == ModeOfOperation::CyclicSyncTorque {
                    target += self.get(obj::TORQUE_OFFSET) as f64;
                    self.torque = target.clamp(-max, max);
                } else {
                    let slope = (self.get(obj::TORQUE_SLOPE) as f64).max(1.0) * t;
                    self.torque += (target.clamp(-max, max) - self.torque).clamp(-slope, slope);
                }
                let a = self.torque / 1000.0 * self.config.acceleration_at_rated_torque
                    - self.config.friction * self.velocity;
                self.velocity += a * t;
                self.position += self.velocity * t;
                self.demand_position = self.position;
                self.demand_velocity = self.velocity;
            }
            ModeOfOperation::Homing => match self.homing {
                Some(phase) => {
                    let (fast, slow) = (
                        self.get(obj::HOMING_SPEED_SWITCH) as f64,
                        self.get(obj::HOMING_SPEED_ZERO) as f64,
                    );
                    let wanted = match phase {
                        HomingPhase::Search { dir, .. } => dir * fast,
                        HomingPhase::Creep { dir, .. } | HomingPhase::Index { dir } => dir * slow,
                    };
                    let a = self.get(obj::HOMING_ACCELERATION) as f64;
                    self.ramp_demand_velocity(wanted, a, a, t);
                    self.drive_velocity(self.demand_velocity, t);
                    self.demand_position = self.position;
                }
                None => self.hold(t),
            },
            ModeOfOperation::InterpolatedPosition => {
                if cw.bit(4) {
                    let set_point =
                        self.clamp_to_limits(self.get(obj::INTERPOLATION_DATA_RECORD) as f64);
                    self.interpolate(set_point, t);
                    self.follow_position(t);
                } else {
                    self.segment = None;
                    self.hold(t);
                }
            }
            ModeOfOperation::CyclicSyncPosition => {
                let target =
                    self.get(obj::TARGET_POSITION) as f64 + self.get(obj::POSITION_OFFSET) as f64;
                let target = self.clamp_to_limits(target);
                self.interpolate(target, t);
                self.follow_position(t);
            }
            ModeOfOperation::CyclicSyncVelocity => {
                let v =
                    self.get(obj::TARGET_VELOCITY) as f64 + self.get(obj::VELOCITY_OFFSET) as f64;
                self.demand_velocity = v.clamp(-speed_limit, speed_limit);
                self.drive_velocity(self.demand_velocity, t);
                self.demand_position = self.position;
            }
            _ => self.hold(t),
        }
    }

    /// The interpolation period 0x60C2 in seconds (at least one step).
    fn interpolation_period(&self, t: f64) -> f64 {
        crate::objects::InterpolationPeriod {
            value: self.get(obj::INTERPOLATION_TIME_PERIOD_VALUE) as u8,
            index: self.get(obj::INTERPOLATION_TIME_INDEX) as i8,
        }
        .as_nanos()
        .map_or(t, |n| (n as f64 / 1e9).max(t))
    }

    /// Moves the demand along the segment toward `set_point`, starting a new segment when the
    /// set-point changed.
    fn interpolate(&mut self, set_point: f64, t: f64) {
        let period = self.interpolation_period(t);
        let mut seg = match self.segment {
            Some(seg) if seg.to == set_point => seg,
            _ => Segment {
                from: self.demand_position,
                to: set_point,
                elapsed: 0.0,
            },
        };
        seg.elapsed += t;
        let f = (seg.elapsed / period).min(1.0);
        let next = seg.from + (seg.to - seg.from) * f;
        // The velocity of this step, the feed-forward of the position loop.
        self.demand_velocity = (next - self.demand_position) / t;
        self.demand_position = next;
        self.segment = Some(seg);
    }

    fn hold(&mut self, t: f64) {
        self.demand_velocity = 0.0;
        self.follow_position(t);
    }

    /// Software limits for velocity and torque modes, limit switches, following error.
    fn monitor(&mut self, before: f64, t: f64) {
        let (min, max) = self.soft_limits();
        if min < max && !(min..=max).contains(&self.position) {
            self.limit_active = true;
            if self.mode().supported_bit().is_some()
                && !matches!(self.mode(), ModeOfOperation::Homing)
            {
                self.position = self.position.clamp(min, max);
                self.velocity = 0.0;
                self.demand_position = self.position;
                self.demand_velocity = 0.0;
            }
        }
        let homing = self.homing.is_some();
        for s in [Switch::NegativeLimit, Switch::PositiveLimit] {
            if self.switch(s, self.position)
                && !self.switch(s, before)
                && !homing
                && self.machine.state() == State::OperationEnabled
            {
                self.raise(ErrorCode::REFERENCE_LIMIT);
            }
        }
        let window = self.get(obj::FOLLOWING_ERROR_WINDOW) as u32;
        let error = self.demand_position - self.position;
        if window != u32::MAX
            && error.abs() > f64::from(window)
            && self.machine.state() == State::OperationEnabled
        {
            self.following_error_time += t;
            let limit = self.get(obj::FOLLOWING_ERROR_TIME_OUT) as f64 / 1000.0;
            if self.following_error_time > limit {
                self.raise(ErrorCode::FOLLOWING_ERROR);
            }
        } else {
            self.following_error_time = 0.0;
        }
        let window = self.get(obj::POSITION_WINDOW) as f64;
        if (self.pp_target - self.position).abs() <= window && !self.pp_moving {
            self.in_window_time += t;
        } else {
            self.in_window_time = 0.0;
        }
    }

    /// Recomputes the statusword and the actual values from the model.
    fn refresh(&mut self) {
        let mut sw = self.machine.statusword().raw();
        let cw = Controlword::from_raw(self.get(obj::CONTROLWORD) as u16);
        let enabled = self.machine.state() == State::OperationEnabled;
        let standing = self.velocity.abs() < 1.0;
        let window = self.get(obj::FOLLOWING_ERROR_WINDOW) as u32;
        let following_error =
            window != u32::MAX && (self.demand_position - self.position).abs() > f64::from(window);
        if self.limit_active {
            sw |= Statusword::INTERNAL_LIMIT_ACTIVE;
        }
        let (b10, b12, b13) = match self.mode() {
            ModeOfOperation::ProfilePosition => {
                let window_time = self.get(obj::POSITION_WINDOW_TIME) as f64 / 1000.0;
                let reached = if cw.halt() {
                    standing
                } else {
                    !self.pp_moving
                        && self.pp_pending.is_none()
                        && self.in_window_time >= window_time
                        && standing
                };
                (reached, self.set_point_ack, following_error)
            }
            ModeOfOperation::ProfileVelocity => {
                let target = if cw.halt() {
                    0.0
                } else {
                    self.get(obj::TARGET_VELOCITY) as f64
                };
                let window = self.get(obj::VELOCITY_WINDOW) as f64;
                ((self.velocity - target).abs() <= window, standing, false)
            }
            ModeOfOperation::ProfileTorque => {
                let target = if cw.halt() {
                    0.0
                } else {
                    self.get(obj::TARGET_TORQUE) as f64
                };
                ((self.torque - target).abs() < 1.0, false, false)
            }
            ModeOfOperation::Homing => {
                let bits = self.homing_status.bits();
                let bits = if self.homing_status.is_error() && standing {
                    HomingStatus::ErrorStandstill.bits()
                } else {
                    bits
                };
                (bits & 0x0400 != 0, bits & 0x1000 != 0, bits & 0x2000 != 0)
            }
            ModeOfOperation::InterpolatedPosition => {
                let set_point = self.get(obj::INTERPOLATION_DATA_RECORD) as f64;
                (
                    (set_point - self.position).abs() <= self.get(obj::POSITION_WINDOW) as f64,
                    enabled && cw.bit(4),
                    false,
                )
            }
            ModeOfOperation::CyclicSyncPosition => (false, enabled, following_error),
            ModeOfOperation::CyclicSyncVelocity | ModeOfOperation::CyclicSyncTorque => {
                (false, enabled, false)
            }
            _ => (false, false, false),
        };
        sw |= u16::from(b10) << 10 | u16::from(b12) << 12 | u16::from(b13) << 13;
        self.put(obj::STATUSWORD, i64::from(sw));
        let p = self.position.round() as i64;
        self.put(obj::POSITION_ACTUAL_VALUE, p);
        self.put(obj::POSITION_ACTUAL_INTERNAL_VALUE, p);
        self.put(
            obj::POSITION_DEMAND_VALUE,
            self.demand_position.round() as i64,
        );
        self.put(obj::VELOCITY_ACTUAL_VALUE, self.velocity.round() as i64);
        self.put(
            obj::VELOCITY_DEMAND_VALUE,
            self.demand_velocity.round() as i64,
        );
        let vl = self.velocity.round().clamp(-32768.0, 32767.0) as i64;
        self.put(obj::VL_VELOCITY_ACTUAL_VALUE, vl);
        self.put(
            obj::VL_VELOCITY_DEMAND,
            self.demand_velocity.round().clamp(-32768.0, 32767.0) as i64,
        );
        let torque = self.torque.round().clamp(-32768.0, 32767.0) as i64;
        self.put(obj::TORQUE_ACTUAL_VALUE, torque);
        self.put(obj::TORQUE_DEMAND, torque);
        self.put(
            obj::FOLLOWING_ERROR_ACTUAL_VALUE,
            (self.demand_position - self.position).round() as i64,
        );
        let inputs = u32::from(self.switch(Switch::NegativeLimit, self.position))
            | u32::from(self.switch(Switch::PositiveLimit, self.position)) << 1
            | u32::from(self.switch(Switch::Home, self.position)) << 2;
        self.put(obj::DIGITAL_INPUTS, i64::from(inputs));
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
