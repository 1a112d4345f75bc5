//! The simulated drive's motion: the stop ramps (quick stop, halt, fault reaction, disable), the
//! trapezoidal profile generator, the position loop limited by max torque, each mode's motion
//! (pp, vl, pv, tq, ip, csp, csv, cst; homing in [`super::homing`]), the linear interpolator of
//! ip and csp, and the monitors (software limits, limit switches, following error).

use crate::mode::ModeOfOperation;
use crate::objects::{self as obj, ErrorCode, StopRamp};
use crate::state::State;
use crate::words::Controlword;

use super::{HomingPhase, SimDrive, Switch};

/// A linear segment of ip or csp: from the demand when a new set-point arrived to that
/// set-point, in one interpolation period 0x60C2 (CiA 402-2 §11, §14: the drive spreads each
/// set-point over the period the master sends them in).
#[derive(Clone, Copy, PartialEq, Debug)]
pub(super) struct Segment {
    from: f64,
    to: f64,
    elapsed: f64,
}

impl SimDrive {
    pub(super) fn clamp_to_limits(&mut self, target: f64) -> f64 {
        let (min, max) = self.soft_limits();
        if min < max && !(min..=max).contains(&target) {
            self.limit_active = true;
            return target.clamp(min, max);
        }
        target
    }

    pub(super) fn soft_limits(&self) -> (f64, f64) {
        (
            self.get(obj::MIN_SOFTWARE_POSITION_LIMIT) as f64,
            self.get(obj::MAX_SOFTWARE_POSITION_LIMIT) as f64,
        )
    }

    /// Brakes on `ramp`; true once standing still.
    pub(super) fn stop(&mut self, ramp: StopRamp, t: f64) -> bool {
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

    pub(super) fn max_acceleration(&self) -> f64 {
        self.get(obj::MAX_TORQUE) as f64 / 1000.0 * self.config.acceleration_at_rated_torque
    }

    /// The trapezoid toward `target` on the demand side.
    pub(super) fn profile_to(
        &mut self,
        target: f64,
        speed: f64,
        acc: f64,
        dec: f64,
        t: f64,
    ) -> bool {
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

    pub(super) fn ramp_demand_velocity(&mut self, wanted: f64, acc: f64, dec: f64, t: f64) {
        let v = self.demand_velocity;
        let speeding_up = wanted.abs() > v.abs() && wanted.signum() == v.signum() || v == 0.0;
        let limit = if speeding_up { acc } else { dec }.max(1.0) * t;
        self.demand_velocity = v + (wanted - v).clamp(-limit, limit);
    }

    /// The position loop: the motor follows the demand with an acceleration limited by 0x6072.
    pub(super) fn follow_position(&mut self, t: f64) {
        let gain = (0.5 / t).min(200.0);
        // What is left to the demand after this step's feed-forward move.
        let error = self.demand_position - self.position - self.demand_velocity * t;
        // Proportional near the demand; far from it no faster than the motor can still brake
        // from (v² = 2·a·e), so a saturated loop closes in without overshooting.
        let braking = (2.0 * self.max_acceleration() * error.abs()).sqrt();
        let correction = error.signum() * (gain * error.abs()).min(braking);
        self.drive_velocity(self.demand_velocity + correction, t);
    }

    pub(super) fn drive_velocity(&mut self, wanted: f64, t: f64) {
        let max = self.max_acceleration();
        let a = ((wanted - self.velocity) / t).clamp(-max, max);
        self.torque = a / self.config.acceleration_at_rated_torque * 1000.0;
        self.velocity += a * t;
        self.position += self.velocity * t;
    }

    pub(super) fn run_mode(&mut self, cw: Controlword, t: f64) {
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
    pub(super) fn interpolation_period(&self, t: f64) -> f64 {
        crate::objects::InterpolationPeriod {
            value: self.get(obj::INTERPOLATION_TIME_PERIOD_VALUE) as u8,
            index: self.get(obj::INTERPOLATION_TIME_INDEX) as i8,
        }
        .as_nanos()
        .map_or(t, |n| (n as f64 / 1e9).max(t))
    }

    /// Moves the demand along the segment toward `set_point`, starting a new segment when the
    /// set-point changed.
    pub(super) fn interpolate(&mut self, set_point: f64, t: f64) {
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

    pub(super) fn hold(&mut self, t: f64) {
        self.demand_velocity = 0.0;
        self.follow_position(t);
    }

    /// Software limits for velocity and torque modes, limit switches, following error.
    pub(super) fn monitor(&mut self, before: f64, t: f64) {
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
}
