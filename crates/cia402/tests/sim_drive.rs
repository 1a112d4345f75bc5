//! The simulated drive driven as a master would: objects written and read by index and
//! sub-index, controlwords from the planner, time in 1 ms steps.

use std::time::Duration;

use canola_cia402::mode::{HomingStatus, ModeOfOperation, ModeStatus};
use canola_cia402::objects::{self as obj, ErrorCode, QuickStopOption};
use canola_cia402::sim::{AccessError, Emcy, SimConfig, SimDrive, SimFault};
use canola_cia402::state::{PlanError, Planner, State};
use canola_cia402::words::Controlword;

const MS: Duration = Duration::from_millis(1);

/// Steps up to `max_ms` until `done`; returns the milliseconds taken.
fn run(sim: &mut SimDrive, max_ms: u32, done: impl Fn(&SimDrive) -> bool) -> Option<u32> {
    for ms in 0..max_ms {
        if done(sim) {
            return Some(ms);
        }
        sim.step(MS);
    }
    done(sim).then_some(max_ms)
}

/// Brings the drive to `target` with the planner, one controlword per 2 ms (two writes closer
/// than 1 ms may not be seen as an edge, yarp-devices #215).
fn go(sim: &mut SimDrive, planner: &Planner, target: State) -> Result<(), PlanError> {
    let mut last = None;
    for _ in 0..20 {
        match planner.next_step(sim.statusword(), last, target)? {
            None => return Ok(()),
            Some(step) => {
                if let Some(cw) = step.controlword {
                    sim.set_controlword(cw);
                    last = Some(cw);
                }
                run(sim, 200, |s| s.state() == step.expect);
                if step.transition.number() == 11 && sim.state() == State::SwitchOnDisabled {
                    return Ok(());
                }
            }
        }
    }
    panic!("{target} not reached, in {}", sim.state());
}

fn started() -> SimDrive {
    let mut sim = SimDrive::default();
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).expect("initialises");
    sim
}

fn set_mode(sim: &mut SimDrive, mode: ModeOfOperation) {
    sim.set(obj::MODES_OF_OPERATION, i64::from(mode.code()))
        .unwrap();
    run(sim, 10, |s| s.mode() == mode).expect("0x6061 confirms");
}

fn enabled(mode: ModeOfOperation) -> SimDrive {
    let mut sim = started();
    set_mode(&mut sim, mode);
    go(&mut sim, &Planner::default(), State::OperationEnabled).unwrap();
    sim
}

#[test]
fn power_on_shows_no_mode_and_reaches_switch_on_disabled() {
    let mut sim = SimDrive::default();
    assert_eq!(sim.state(), State::NotReadyToSwitchOn);
    assert_eq!(sim.statusword().raw() & 0x4F, 0x0000);
    // python-canopen #183: 0x6061 reads 0 after power-up; it decodes to "no mode".
    assert_eq!(sim.value(obj::MODES_OF_OPERATION_DISPLAY), 0);
    assert_eq!(sim.mode(), ModeOfOperation::NoMode);
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    let mut buf = [0u8; 4];
    assert_eq!(sim.read(0x6041, 0, &mut buf), Ok(2));
    assert_eq!(u16::from_le_bytes([buf[0], buf[1]]), 0x0250);
    assert_eq!(sim.read(0x1000, 0, &mut buf), Ok(4));
    assert_eq!(u32::from_le_bytes(buf), 0x0002_0192);
}

#[test]
fn dictionary_access_errors_are_sdo_aborts() {
    let mut sim = started();
    let mut buf = [0u8; 8];
    assert_eq!(
        sim.write(0x6041, 0, &[0, 0])
            .map_err(AccessError::abort_code),
        Err(0x0601_0002)
    );
    assert_eq!(
        sim.write(0x6040, 0, &[0]).map_err(AccessError::abort_code),
        Err(0x0607_0010)
    );
    assert_eq!(
        sim.read(0x6123, 0, &mut buf)
            .map_err(AccessError::abort_code),
        Err(0x0602_0000)
    );
    assert_eq!(
        sim.read(0x607D, 3, &mut buf)
            .map_err(AccessError::abort_code),
        Err(0x0609_0011)
    );
    assert_eq!(sim.read(0x607D, 0, &mut buf), Ok(1));
    assert_eq!(buf[0], 2);
    // Mode 5 is reserved, vl is not in this drive's 0x6502.
    assert_eq!(
        sim.write(0x6060, 0, &[5]).map_err(AccessError::abort_code),
        Err(0x0609_0030)
    );
    assert_eq!(
        sim.write(0x6060, 0, &[2]).map_err(AccessError::abort_code),
        Err(0x0609_0030)
    );
    // Axis 1 objects do not exist on an axis-0 drive; an axis-1 drive has them at +0x800.
    assert!(sim.read(0x6841, 0, &mut buf).is_err());
    let mut axis1 = SimDrive::new(SimConfig {
        axis: 1,
        ..SimConfig::default()
    });
    assert_eq!(axis1.read(0x6841, 0, &mut buf), Ok(2));
    assert!(axis1.read(0x6041, 0, &mut buf).is_err());
    axis1.write(0x6860, 0, &[1]).unwrap();
    axis1.step(MS);
    assert_eq!(axis1.mode(), ModeOfOperation::ProfilePosition);
}

#[test]
fn profile_position_handshake_and_target_reached_from_bit_10() {
    let mut sim = enabled(ModeOfOperation::ProfilePosition);
    sim.set(obj::TARGET_POSITION, 20_000).unwrap();
    sim.set_controlword(Controlword::from_raw(0x000F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x001F));
    let pp = |s: &SimDrive| ModeStatus::decode(ModeOfOperation::ProfilePosition, s.statusword());
    assert!(matches!(
        pp(&sim),
        ModeStatus::ProfilePosition {
            set_point_acknowledge: true,
            ..
        }
    ));
    sim.set_controlword(Controlword::from_raw(0x000F));
    assert!(matches!(
        pp(&sim),
        ModeStatus::ProfilePosition {
            set_point_acknowledge: false,
            ..
        }
    ));
    sim.step(MS);
    // Moving: voltage enabled (bit 4) is set but target reached (bit 10) is not.
    assert!(sim.statusword().voltage_enabled());
    assert_eq!(pp(&sim).target_reached(), Some(false));
    let ms = run(&mut sim, 5_000, |s| s.statusword().target_reached()).expect("target reached");
    assert!(
        (sim.position() - 20_000.0).abs() <= 10.0,
        "at {}",
        sim.position()
    );
    // 20 000 counts at 10 000/s with 50 000/s² ramps: 2.2 s of profile plus the window time.
    assert!((2_150..2_400).contains(&ms), "{ms} ms");
    assert_eq!(
        sim.value(obj::POSITION_ACTUAL_VALUE),
        sim.position().round() as i64
    );

    // Relative, with change set immediately: the second set-point replaces the first at once.
    sim.set(obj::TARGET_POSITION, 50_000).unwrap();
    sim.set_controlword(Controlword::from_raw(0x005F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x004F));
    run(&mut sim, 300, |_| false);
    sim.set(obj::TARGET_POSITION, -10_000).unwrap();
    sim.set_controlword(Controlword::from_raw(0x007F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x006F));
    run(&mut sim, 10_000, |s| s.statusword().target_reached()).expect("second target");
    assert!(
        (sim.position() - 60_000.0).abs() <= 10.0,
        "at {}",
        sim.position()
    );
}

#[test]
fn profile_position_without_change_set_immediately_buffers_the_next_set_point() {
    let mut sim = enabled(ModeOfOperation::ProfilePosition);
    sim.set(obj::TARGET_POSITION, 5_000).unwrap();
    sim.set_controlword(Controlword::from_raw(0x001F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x000F));
    sim.step(MS);
    sim.set(obj::TARGET_POSITION, 0).unwrap();
    sim.set_controlword(Controlword::from_raw(0x001F));
    sim.step(MS);
    // The buffer is full: the acknowledge stays set until the first move has ended.
    sim.set_controlword(Controlword::from_raw(0x000F));
    assert!(sim.statusword().bit(12));
    let mut peak: f64 = 0.0;
    for _ in 0..5_000 {
        sim.step(MS);
        peak = peak.max(sim.position());
        if sim.statusword().target_reached() {
            break;
        }
    }
    assert!(
        peak > 4_990.0,
        "the first move finished first (peak {peak})"
    );
    assert!(sim.position().abs() <= 10.0);
    assert!(!sim.statusword().bit(12));
}

#[test]
fn software_limits_clamp_targets_and_set_bit_11() {
    let mut sim = enabled(ModeOfOperation::ProfilePosition);
    sim.set(obj::MIN_SOFTWARE_POSITION_LIMIT, -1_000).unwrap();
    sim.set(obj::MAX_SOFTWARE_POSITION_LIMIT, 1_000).unwrap();
    sim.set(obj::TARGET_POSITION, 3_000).unwrap();
    sim.set_controlword(Controlword::from_raw(0x001F));
    assert!(sim.statusword().internal_limit_active());
    sim.set_controlword(Controlword::from_raw(0x000F));
    run(&mut sim, 3_000, |s| s.statusword().target_reached()).unwrap();
    assert!((sim.position() - 1_000.0).abs() <= 10.0);
}

#[test]
fn profile_velocity_target_reached_and_speed_zero() {
    let mut sim = enabled(ModeOfOperation::ProfileVelocity);
    sim.set(obj::TARGET_VELOCITY, 8_000).unwrap();
    sim.step(MS);
    assert!(!sim.statusword().target_reached());
    run(&mut sim, 1_000, |s| s.statusword().target_reached()).expect("velocity reached");
    assert!((sim.velocity() - 8_000.0).abs() <= 10.0);
    assert_eq!(sim.value(obj::VELOCITY_ACTUAL_VALUE), 8_000);
    // Halt: the drive ramps to 0 and stays enabled; bit 12 says speed 0.
    sim.set_controlword(Controlword::from_raw(0x010F));
    run(&mut sim, 1_000, |s| s.statusword().bit(12)).expect("stands still");
    assert_eq!(sim.state(), State::OperationEnabled);
}

#[test]
fn profile_torque_follows_the_slope_and_the_motor_accelerates() {
    let mut sim = enabled(ModeOfOperation::ProfileTorque);
    sim.set(obj::TARGET_TORQUE, 100).unwrap();
    sim.step(MS);
    // Slope 10 000 ‰/s: 10 ‰ per ms.
    assert!((sim.torque() - 10.0).abs() < 0.5, "{}", sim.torque());
    run(&mut sim, 100, |s| s.statusword().target_reached()).expect("torque reached");
    assert_eq!(sim.value(obj::TORQUE_ACTUAL_VALUE), 100);
    let v = sim.velocity();
    run(&mut sim, 50, |_| false);
    assert!(sim.velocity() > v);
    // Max torque clamps the target.
    sim.set(obj::MAX_TORQUE, 50).unwrap();
    run(&mut sim, 50, |_| false);
    assert_eq!(sim.value(obj::TORQUE_ACTUAL_VALUE), 50);
}

#[test]
fn velocity_mode_needs_its_three_ramp_bits() {
    let mut sim = SimDrive::new(SimConfig {
        supported_modes: Some(obj::SupportedModes(0x03EF)),
        ..SimConfig::default()
    });
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    set_mode(&mut sim, ModeOfOperation::Velocity);
    go(&mut sim, &Planner::default(), State::OperationEnabled).unwrap();
    sim.set(obj::VL_TARGET_VELOCITY, 3_000).unwrap();
    run(&mut sim, 300, |_| false);
    assert_eq!(sim.velocity(), 0.0, "bits 4..6 clear: no ramp");
    sim.set_controlword(Controlword::from_raw(0x007F));
    run(&mut sim, 300, |_| false);
    assert_eq!(sim.value(obj::VL_VELOCITY_ACTUAL_VALUE), 3_000);
}

fn home(sim: &mut SimDrive, method: i8) -> HomingStatus {
    sim.set(obj::HOMING_METHOD, i64::from(method)).unwrap();
    sim.set_controlword(Controlword::from_raw(0x000F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x001F));
    run(sim, 60_000, |s| {
        !matches!(
            HomingStatus::decode(s.statusword()),
            HomingStatus::InProgress
        )
    });
    HomingStatus::decode(sim.statusword())
}

#[test]
fn homing_methods_find_switch_edges_and_index_pulses() {
    // Home switch active above 5 000, index pulses every 4 096, limit switches at ±200 000.
    for (method, start) in [
        (19, 0.0),
        (19, 9_000.0),
        (21, 9_000.0),
        (3, 0.0),
        (5, 0.0),
        (17, 0.0),
        (1, 0.0),
        (2, 0.0),
        (18, 0.0),
        (33, 1_000.0),
        (34, 1_000.0),
    ] {
        let mut sim = started();
        sim.set_position(start);
        // python-canopen #244: homing mode is selected in switch on disabled, before enabling,
        // and selecting it does not change the power state.
        set_mode(&mut sim, ModeOfOperation::Homing);
        assert_eq!(sim.state(), State::SwitchOnDisabled);
        go(&mut sim, &Planner::default(), State::OperationEnabled).unwrap();
        sim.set(obj::HOME_OFFSET, 100).unwrap();
        let status = home(&mut sim, method);
        assert_eq!(
            status,
            HomingStatus::Completed,
            "method {method} from {start}"
        );
        // The reference found becomes 0x607C; the drive stops just past it.
        assert!(
            (sim.position() - 100.0).abs() < 50.0,
            "method {method} from {start}: at {}",
            sim.position()
        );
        assert_eq!(sim.state(), State::OperationEnabled);
    }
}

#[test]
fn homing_on_current_position_and_unknown_methods() {
    let mut sim = enabled(ModeOfOperation::Homing);
    assert_eq!(
        HomingStatus::decode(sim.statusword()),
        HomingStatus::Interrupted
    );
    sim.set_position(1_234.0);
    sim.set(obj::HOME_OFFSET, -5).unwrap();
    assert_eq!(home(&mut sim, 35), HomingStatus::Completed);
    assert_eq!(sim.value(obj::POSITION_ACTUAL_VALUE), -5);
    assert_eq!(home(&mut sim, 37), HomingStatus::Completed);
    assert_eq!(home(&mut sim, 0), HomingStatus::ErrorStandstill);
    assert_eq!(home(&mut sim, 15), HomingStatus::ErrorStandstill);
    assert_eq!(home(&mut sim, -3), HomingStatus::ErrorStandstill);
    // Halt interrupts a running homing; the drive stops and stays enabled.
    sim.set(obj::HOMING_METHOD, 17).unwrap();
    sim.set_controlword(Controlword::from_raw(0x000F));
    sim.step(MS);
    sim.set_controlword(Controlword::from_raw(0x001F));
    run(&mut sim, 200, |_| false);
    assert_eq!(
        HomingStatus::decode(sim.statusword()),
        HomingStatus::InProgress
    );
    sim.set_controlword(Controlword::from_raw(0x011F));
    run(&mut sim, 1_000, |s| s.velocity() == 0.0).expect("stops");
    assert_eq!(
        HomingStatus::decode(sim.statusword()),
        HomingStatus::Interrupted
    );
    assert_eq!(sim.state(), State::OperationEnabled);
}

#[test]
fn interpolated_position_follows_its_set_points_with_bit_12() {
    let mut sim = enabled(ModeOfOperation::InterpolatedPosition);
    sim.set(obj::INTERPOLATION_TIME_PERIOD_VALUE, 2).unwrap();
    sim.set(obj::INTERPOLATION_DATA_RECORD, 0).unwrap();
    sim.set_controlword(Controlword::from_raw(0x001F));
    sim.step(MS);
    assert!(sim.statusword().bit(12), "ip mode active");
    for k in 1..=500 {
        sim.set(obj::INTERPOLATION_DATA_RECORD, k * 10).unwrap();
        sim.step(MS);
        sim.step(MS);
    }
    run(&mut sim, 100, |s| s.statusword().target_reached()).unwrap();
    assert!(
        (sim.position() - 5_000.0).abs() <= 10.0,
        "{}",
        sim.position()
    );
    sim.set_controlword(Controlword::from_raw(0x000F));
    assert!(!sim.statusword().bit(12));
}

#[test]
fn cyclic_synchronous_position_velocity_torque() {
    let mut sim = enabled(ModeOfOperation::CyclicSyncPosition);
    assert!(sim.statusword().bit(12), "drive follows the command");
    // A 1 kHz stream of targets: a ramp of 5 counts per cycle.
    for k in 0..1_000 {
        sim.set(obj::TARGET_POSITION, k * 5).unwrap();
        sim.step(MS);
        assert!(!sim.statusword().bit(13), "no following error at cycle {k}");
    }
    assert!(
        (sim.position() - 4_995.0).abs() < 30.0,
        "{}",
        sim.position()
    );
    assert!((sim.velocity() - 5_000.0).abs() < 100.0);

    let mut sim = enabled(ModeOfOperation::CyclicSyncVelocity);
    sim.set(obj::TARGET_VELOCITY, 2_000).unwrap();
    sim.set(obj::VELOCITY_OFFSET, 500).unwrap();
    run(&mut sim, 100, |_| false);
    assert_eq!(sim.value(obj::VELOCITY_ACTUAL_VALUE), 2_500);

    let mut sim = enabled(ModeOfOperation::CyclicSyncTorque);
    sim.set(obj::TARGET_TORQUE, 40).unwrap();
    sim.set(obj::TORQUE_OFFSET, 2).unwrap();
    sim.step(MS);
    assert_eq!(sim.value(obj::TORQUE_ACTUAL_VALUE), 42);
}

#[test]
fn a_demand_beyond_the_torque_limit_builds_a_following_error_fault() {
    let mut sim = enabled(ModeOfOperation::CyclicSyncPosition);
    sim.set(obj::MAX_TORQUE, 20).unwrap();
    // A jump of 50 000 counts: at 2 % torque the motor lags far behind.
    sim.set(obj::TARGET_POSITION, 50_000).unwrap();
    let ms = run(&mut sim, 1_000, |s| s.state() == State::Fault).expect("faults");
    assert!(ms >= 50, "after the 50 ms time-out, not before ({ms})");
    assert_eq!(sim.value(obj::ERROR_CODE), 0x8611);
    assert_eq!(
        sim.poll_emcy(),
        Some(Emcy {
            code: ErrorCode::FOLLOWING_ERROR,
            error_register: 0x21
        })
    );
}

#[test]
fn injected_faults_give_603f_emcy_and_fault_then_reset_on_the_edge() {
    for (fault, code, register) in [
        (SimFault::OverCurrent, 0x2310, 0x03),
        (SimFault::FollowingError, 0x8611, 0x21),
        (SimFault::LimitSwitch, 0x8612, 0x21),
    ] {
        let mut sim = enabled(ModeOfOperation::ProfileVelocity);
        sim.set(obj::TARGET_VELOCITY, 5_000).unwrap();
        run(&mut sim, 300, |_| false);
        sim.inject_fault(fault);
        assert_eq!(sim.state(), State::FaultReactionActive);
        assert_eq!(
            sim.poll_emcy(),
            Some(Emcy {
                code: ErrorCode(code),
                error_register: register
            })
        );
        let mut buf = [0u8; 2];
        sim.read(0x603F, 0, &mut buf).unwrap();
        assert_eq!(u16::from_le_bytes(buf), code);
        // The reaction brakes on the quick-stop ramp (0x605E = 2), then fault.
        run(&mut sim, 1_000, |s| s.state() == State::Fault).expect("fault");
        assert_eq!(sim.velocity(), 0.0);
        // Bit 7 already high: no edge, no reset.
        sim.set_controlword(Controlword::from_raw(0x0080));
        sim.set_controlword(Controlword::from_raw(0x0080));
        sim.step(MS);
        assert_eq!(
            sim.state(),
            State::SwitchOnDisabled,
            "the first 0x0080 after 0x000F is an edge"
        );
        assert_eq!(
            sim.poll_emcy(),
            Some(Emcy {
                code: ErrorCode::NONE,
                error_register: 0
            })
        );
        assert_eq!(sim.value(obj::ERROR_CODE), 0);
    }
    let mut sim = started();
    sim.inject_fault(SimFault::OverCurrent);
    run(&mut sim, 10, |s| s.state() == State::Fault).unwrap();
    sim.set_controlword(Controlword::from_raw(0x0080));
    sim.step(MS);
    sim.inject_fault(SimFault::OverCurrent);
    run(&mut sim, 10, |s| s.state() == State::Fault).unwrap();
    sim.set_controlword(Controlword::from_raw(0x0080));
    assert_eq!(sim.state(), State::Fault, "bit 7 held: no new edge");
    go(&mut sim, &Planner::default(), State::SwitchOnDisabled).unwrap();
}

#[test]
fn running_into_a_limit_switch_faults_with_reference_limit() {
    let mut sim = enabled(ModeOfOperation::ProfileVelocity);
    sim.set_position(199_000.0);
    sim.set(obj::TARGET_VELOCITY, 20_000).unwrap();
    run(&mut sim, 1_000, |s| s.state() == State::Fault).expect("fault");
    assert_eq!(sim.value(obj::ERROR_CODE), 0x8612);
    assert_eq!(sim.value(obj::DIGITAL_INPUTS) & 0x2, 0x2);
}

#[test]
fn quick_stop_ends_by_605a() {
    // python-canopen #167: 0x605A = 2 goes through quick stop active to switch on disabled.
    let mut sim = enabled(ModeOfOperation::ProfileVelocity);
    sim.set(obj::TARGET_VELOCITY, 10_000).unwrap();
    run(&mut sim, 500, |_| false);
    sim.set_controlword(Controlword::from_raw(0x0002));
    assert_eq!(sim.state(), State::QuickStopActive);
    assert_eq!(sim.statusword().raw() & 0x6F, 0x07);
    run(&mut sim, 1_000, |s| s.state() != State::QuickStopActive).unwrap();
    assert_eq!(sim.state(), State::SwitchOnDisabled);
    assert_eq!(sim.velocity(), 0.0);

    // 0x605A = 6 stays, and transition 16 (0x000F) re-enables.
    let mut sim = enabled(ModeOfOperation::ProfileVelocity);
    sim.set(obj::QUICK_STOP_OPTION_CODE, 6).unwrap();
    sim.set(obj::TARGET_VELOCITY, 10_000).unwrap();
    run(&mut sim, 500, |_| false);
    sim.set_controlword(Controlword::from_raw(0x0002));
    run(&mut sim, 1_000, |s| s.velocity() == 0.0).unwrap();
    run(&mut sim, 100, |_| false);
    assert_eq!(sim.state(), State::QuickStopActive);
    let planner = Planner {
        quick_stop_option: QuickStopOption(6),
        ..Planner::default()
    };
    go(&mut sim, &planner, State::OperationEnabled).unwrap();
    assert_eq!(sim.state(), State::OperationEnabled);
}

#[test]
fn transition_16_missing_is_planned_around() {
    // python-canopen #169: a drive without transition 16 ignores 0x000F in quick stop active.
    let mut cfg = SimConfig::default();
    cfg.device.transition_16 = false;
    cfg.device.quick_stop_option = QuickStopOption(6);
    let mut sim = SimDrive::new(cfg);
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    set_mode(&mut sim, ModeOfOperation::ProfileVelocity);
    let planner = Planner {
        quick_stop_option: QuickStopOption(6),
        transition_16: false,
        ..Planner::default()
    };
    go(&mut sim, &planner, State::OperationEnabled).unwrap();
    sim.set_controlword(Controlword::from_raw(0x0002));
    run(&mut sim, 100, |_| false);
    sim.set_controlword(Controlword::from_raw(0x000F));
    run(&mut sim, 10, |_| false);
    assert_eq!(
        sim.state(),
        State::QuickStopActive,
        "0x000F alone does not leave"
    );
    go(&mut sim, &planner, State::OperationEnabled).unwrap();
    assert_eq!(sim.state(), State::OperationEnabled);
}

#[test]
fn safe_torque_off_at_start_up_keeps_the_drive_from_switching_on() {
    // ros2_canopen #421/#422: STO low at start-up. The drive reaches ready to switch on, the
    // planner names the blocker instead of timing out, and the drive enables once STO is off.
    let mut sim = SimDrive::new(SimConfig {
        safe_torque_off: true,
        ..SimConfig::default()
    });
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    let planner = Planner::default();
    go(&mut sim, &planner, State::ReadyToSwitchOn).unwrap();
    assert!(!sim.statusword().voltage_enabled());
    let err = go(&mut sim, &planner, State::OperationEnabled).unwrap_err();
    assert!(
        matches!(
            err,
            PlanError::VoltageNotEnabled {
                state: State::ReadyToSwitchOn,
                ..
            }
        ),
        "{err}"
    );
    // Sending switch on anyway changes nothing.
    sim.set_controlword(Controlword::from_raw(0x0007));
    run(&mut sim, 20, |_| false);
    assert_eq!(sim.state(), State::ReadyToSwitchOn);
    sim.set_safe_torque_off(false);
    go(&mut sim, &planner, State::OperationEnabled).unwrap();
    // STO while enabled: the drive drops to switch on disabled and the motor coasts.
    sim.set_safe_torque_off(true);
    assert_eq!(sim.state(), State::SwitchOnDisabled);
}

#[test]
fn no_6502_and_a_mode_already_set() {
    // ros2_canopen #299: no 0x6502; the mode is still set and confirmed through 0x6061.
    let mut sim = SimDrive::new(SimConfig {
        supported_modes: None,
        ..SimConfig::default()
    });
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    let mut buf = [0u8; 4];
    assert_eq!(
        sim.read(0x6502, 0, &mut buf)
            .map_err(AccessError::abort_code),
        Err(0x0602_0000)
    );
    set_mode(&mut sim, ModeOfOperation::CyclicSyncPosition);
    // ros2_canopen #445: writing the mode that is already set is accepted and changes nothing.
    sim.set(obj::MODES_OF_OPERATION, 8).unwrap();
    sim.step(MS);
    assert_eq!(sim.mode(), ModeOfOperation::CyclicSyncPosition);
}

#[test]
fn homing_method_3_puts_the_home_offset_on_the_index_pulse_below_the_switch_edge() {
    // Method 3 from below the switch: up to the switch (5 000), back off it, then the next index
    // pulse downwards: 4 096. That pulse becomes 0x607C = 100, so the switch edge is at 1 004.
    let mut sim = started();
    set_mode(&mut sim, ModeOfOperation::Homing);
    go(&mut sim, &Planner::default(), State::OperationEnabled).unwrap();
    sim.set(obj::HOME_OFFSET, 100).unwrap();
    assert_eq!(home(&mut sim, 3), HomingStatus::Completed);
    set_mode(&mut sim, ModeOfOperation::ProfilePosition);
    for (target, switch) in [(994, false), (1_014, true)] {
        sim.set(obj::TARGET_POSITION, target).unwrap();
        sim.set_controlword(Controlword::from_raw(0x003F));
        sim.step(MS);
        sim.set_controlword(Controlword::from_raw(0x002F));
        run(&mut sim, 3_000, |s| s.statusword().target_reached()).unwrap();
        assert_eq!(
            sim.value(obj::DIGITAL_INPUTS) & 0x4 != 0,
            switch,
            "at {target}"
        );
    }
}

#[test]
fn cyclic_position_spreads_each_set_point_over_the_interpolation_period() {
    // 0x60C2 = 10 × 10^-3 s: a set-point 100 counts away is reached in 10 ms, half-way at 5 ms.
    let mut sim = enabled(ModeOfOperation::CyclicSyncPosition);
    sim.set(obj::INTERPOLATION_TIME_PERIOD_VALUE, 10).unwrap();
    sim.set(obj::TARGET_POSITION, 100).unwrap();
    for _ in 0..5 {
        sim.step(MS);
    }
    assert_eq!(sim.value(obj::POSITION_DEMAND_VALUE), 50);
    assert_eq!(sim.value(obj::VELOCITY_DEMAND_VALUE), 10_000);
    for _ in 0..5 {
        sim.step(MS);
    }
    assert_eq!(sim.value(obj::POSITION_DEMAND_VALUE), 100);
    // The same in steps of 100 µs, as a finer simulator clock would run it.
    let mut sim = enabled(ModeOfOperation::CyclicSyncPosition);
    sim.set(obj::TARGET_POSITION, 30).unwrap();
    for _ in 0..5 {
        sim.step(Duration::from_micros(100));
    }
    assert_eq!(sim.value(obj::POSITION_DEMAND_VALUE), 15);
}

#[test]
fn disable_operation_and_shutdown_brake_by_605c_and_605b() {
    // 0x605C = 1 (the default): transition 5 brakes on the slow-down ramp (0x6084 = 50 000/s²,
    // 0.2 s from 10 000/s); 0x605B = 0: transition 8 lets the motor coast (friction only).
    let mut stop_times = vec![];
    for cw in [0x0007u16, 0x0006] {
        let mut sim = enabled(ModeOfOperation::ProfileVelocity);
        sim.set(obj::TARGET_VELOCITY, 10_000).unwrap();
        run(&mut sim, 1_000, |s| s.statusword().target_reached()).unwrap();
        sim.set_controlword(Controlword::from_raw(cw));
        stop_times.push(run(&mut sim, 10_000, |s| s.velocity() == 0.0).expect("stops"));
    }
    assert!((195..=210).contains(&stop_times[0]), "{stop_times:?}");
    assert!(stop_times[1] > 1_000, "{stop_times:?}");
}

#[test]
fn communication_objects_outside_the_profile() {
    let mut sim = started();
    assert_eq!(
        sim.write(0x1000, 0, &[0; 4])
            .map_err(AccessError::abort_code),
        Err(0x0601_0002)
    );
    assert_eq!(
        sim.write(0x2000, 0, &[0]).map_err(AccessError::abort_code),
        Err(0x0602_0000)
    );
    assert_eq!(
        sim.write(0x1001, 1, &[0]).map_err(AccessError::abort_code),
        Err(0x0609_0011)
    );
    assert_eq!(
        sim.write(0x607D, 0, &[2]).map_err(AccessError::abort_code),
        Err(0x0601_0002)
    );
}

#[test]
fn drives_that_refuse_mode_changes_when_enabled_or_halted() {
    let cfg = SimConfig {
        refuse_mode_change_when_enabled: true,
        ..SimConfig::default()
    };
    let mut sim = SimDrive::new(cfg);
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    set_mode(&mut sim, ModeOfOperation::ProfilePosition);
    go(&mut sim, &Planner::default(), State::OperationEnabled).unwrap();
    let refused = sim
        .set(obj::MODES_OF_OPERATION, 3)
        .map_err(AccessError::abort_code);
    assert_eq!(refused, Err(0x0800_0022));
    // The same mode again is no change and is accepted (ros2_canopen #445).
    sim.set(obj::MODES_OF_OPERATION, 1).unwrap();
    go(&mut sim, &Planner::default(), State::SwitchedOn).unwrap();
    set_mode(&mut sim, ModeOfOperation::ProfileVelocity);

    let cfg = SimConfig {
        refuse_mode_change_while_halt: true,
        ..SimConfig::default()
    };
    let mut sim = SimDrive::new(cfg);
    run(&mut sim, 100, |s| s.state() == State::SwitchOnDisabled).unwrap();
    sim.set_controlword(Controlword::from_raw(0x0100));
    assert!(sim.set(obj::MODES_OF_OPERATION, 1).is_err());
    sim.set_controlword(Controlword::from_raw(0x0000));
    set_mode(&mut sim, ModeOfOperation::ProfilePosition);
}
