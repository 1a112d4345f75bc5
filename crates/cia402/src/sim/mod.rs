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
//!
//! This file holds the drive's configuration, its errors, the controlword's effects (state
//! machine, set-point and homing edges), [`SimDrive::step`] and the statusword it computes; the
//! motion is in `motion`, homing in `homing`, the object dictionary in `objects`.

use std::collections::VecDeque;
use std::time::Duration;
use std::vec::Vec;

use crate::device::{DeviceConfig, DeviceStateMachine};
use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::{self as obj, ErrorCode, OptionCode, StopRamp, SupportedModes};
use crate::state::{State, Transition};
use crate::words::{Controlword, Statusword};

mod homing;
mod motion;
mod objects;

use homing::{HomingPhase, Switch};
use motion::Segment;

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
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
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

/// `Debug` prints what `Display` prints (the stack's error convention).
impl core::fmt::Debug for AccessError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
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
