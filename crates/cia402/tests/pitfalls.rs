//! The CiA 402 mistakes masters are known to make, as tests of this
//! crate at the profile layer. Where a pitfall is about the master's waiting, PDO caching or
//! SDO fallbacks (python-canopen #168, #178, #554, ros2_canopen #298) it needs the Drive API
//! over the facade and is not tested here.
//!
//! | pitfall | test |
//! |---|---|
//! | python-canopen #167, quick stop end state by 0x605A | `quick_stop_end_state_for_every_option_code` |
//! | python-canopen #169, transition 16 optional | `sim_drive::transition_16_missing_is_planned_around` |
//! | python-canopen #183, 0x6061 = 0 or unknown | `mode_display_zero_negative_and_reserved`, `sim_drive::power_on_shows_no_mode_...` |
//! | python-canopen #244, homing from switch on disabled | `sim_drive::homing_methods_...`, `mode_change_keeps_the_power_state` |
//! | ros2_canopen #299, no 0x6502 | `sim_drive::no_6502_and_a_mode_already_set` |
//! | ros2_canopen #445, mode already set | `sim_drive::no_6502_and_a_mode_already_set` |
//! | ros2_canopen #421/#422, STO low at start-up | `sim_drive::safe_torque_off_at_start_up_...` |
//! | OpenCAN #51, target reached from bit 10, t5/t16, enable from fault | `target_reached_is_bit_10_for_every_statusword`, `enabling_from_fault_needs_the_reset_edge` |

use std::time::Duration;

use canola_cia402::mode::{ModeOfOperation, ModeStatus};
use canola_cia402::objects::{self as obj, QuickStopOption};
use canola_cia402::sim::{SimConfig, SimDrive, SimFault};
use canola_cia402::state::{Planner, State, Transition};
use canola_cia402::words::{Controlword, Statusword};

const MS: Duration = Duration::from_millis(1);

fn enabled(cfg: SimConfig, mode: ModeOfOperation) -> SimDrive {
    let mut sim = SimDrive::new(cfg);
    for _ in 0..20 {
        sim.step(MS);
    }
    sim.set(obj::MODES_OF_OPERATION, i64::from(mode.code()))
        .unwrap();
    for cw in [0x06, 0x07, 0x0F] {
        sim.set_controlword(Controlword::from_raw(cw));
        sim.step(MS);
    }
    assert_eq!(sim.state(), State::OperationEnabled);
    sim
}

#[test]
fn quick_stop_end_state_for_every_option_code() {
    // python-canopen #167: after 0x0002 a master must accept quick stop active or switch on
    // disabled, by 0x605A; the planner's end state says which.
    for code in -1..=9 {
        let mut sim = enabled(SimConfig::default(), ModeOfOperation::ProfileVelocity);
        sim.set(obj::QUICK_STOP_OPTION_CODE, code).unwrap();
        sim.set(obj::TARGET_VELOCITY, 20_000).unwrap();
        for _ in 0..500 {
            sim.step(MS);
        }
        let option = QuickStopOption(code as i16);
        let planner = Planner {
            quick_stop_option: option,
            ..Planner::default()
        };
        let plan = planner
            .plan(sim.statusword(), State::QuickStopActive)
            .unwrap();
        for cw in plan.controlwords() {
            sim.set_controlword(cw);
        }
        assert_eq!(
            sim.state(),
            State::QuickStopActive,
            "605A={code}: quick stop active first"
        );
        for _ in 0..2_000 {
            sim.step(MS);
        }
        if code != 0 {
            // 0 disables the drive function: the motor coasts and may still turn.
            assert_eq!(sim.velocity(), 0.0, "605A={code}");
        }
        assert_eq!(
            sim.state(),
            plan.end_state(State::OperationEnabled),
            "605A={code}"
        );
        let stays = (5..=8).contains(&code);
        assert_eq!(sim.state() == State::QuickStopActive, stays, "605A={code}");
    }
}

#[test]
fn mode_display_zero_negative_and_reserved() {
    // python-canopen #183: 0x6061 may read 0, a negative (manufacturer) or reserved code.
    for (code, mode) in [
        (0, ModeOfOperation::NoMode),
        (-1, ModeOfOperation::Manufacturer(-1)),
        (-128, ModeOfOperation::Manufacturer(-128)),
        (5, ModeOfOperation::Reserved(5)),
        (11, ModeOfOperation::Reserved(11)),
        (127, ModeOfOperation::Reserved(127)),
    ] {
        let m = ModeOfOperation::from_code(code);
        assert_eq!(m, mode);
        assert_eq!(m.code(), code);
        assert_eq!(m.supported_bit(), None);
        // Statusword bits in an unknown mode are kept raw, not guessed.
        assert!(matches!(
            ModeStatus::decode(m, Statusword::from_raw(0x3637)),
            ModeStatus::Other {
                bit10: true,
                bit12: true,
                bit13: true
            }
        ));
    }
    let sim = SimDrive::default();
    assert_eq!(sim.mode(), ModeOfOperation::NoMode);
}

#[test]
fn mode_change_keeps_the_power_state() {
    // python-canopen #244/#251: changing the mode must not change the power state implicitly.
    let mut sim = enabled(SimConfig::default(), ModeOfOperation::ProfilePosition);
    sim.set(obj::MODES_OF_OPERATION, 3).unwrap();
    sim.step(MS);
    assert_eq!(
        (sim.state(), sim.mode()),
        (State::OperationEnabled, ModeOfOperation::ProfileVelocity)
    );
    sim.set(obj::MODES_OF_OPERATION, 6).unwrap();
    sim.step(MS);
    assert_eq!(
        (sim.state(), sim.mode()),
        (State::OperationEnabled, ModeOfOperation::Homing)
    );
}

#[test]
fn target_reached_is_bit_10_for_every_statusword() {
    // OpenCAN #51 tested bit 4 (voltage enabled). For every statusword in every mode that
    // defines target reached, it is bit 10 and nothing else.
    for raw in 0..=u16::MAX {
        let sw = Statusword::from_raw(raw);
        for mode in [
            ModeOfOperation::ProfilePosition,
            ModeOfOperation::ProfileVelocity,
            ModeOfOperation::ProfileTorque,
            ModeOfOperation::InterpolatedPosition,
        ] {
            assert_eq!(
                ModeStatus::decode(mode, sw).target_reached(),
                Some(raw & 0x0400 != 0)
            );
        }
    }
}

#[test]
fn enabling_from_fault_needs_the_reset_edge() {
    // OpenCAN #51: enable() from fault returned success without a fault reset. The drive
    // ignores enable operation in fault; the plan starts with the reset edge (transition 15).
    let mut sim = enabled(SimConfig::default(), ModeOfOperation::ProfilePosition);
    sim.inject_fault(SimFault::OverCurrent);
    for _ in 0..100 {
        sim.step(MS);
    }
    assert_eq!(sim.state(), State::Fault);
    for cw in [0x06, 0x07, 0x0F] {
        sim.set_controlword(Controlword::from_raw(cw));
        sim.step(MS);
    }
    assert_eq!(sim.state(), State::Fault);
    let plan = Planner::default()
        .plan(sim.statusword(), State::OperationEnabled)
        .unwrap();
    assert_eq!(plan.steps()[0].transition, Transition::T15);
    let words: Vec<u16> = plan.controlwords().map(|c| c.raw()).collect();
    assert_eq!(words, [0x00, 0x80, 0x06, 0x07, 0x0F]);
    // The transition table has 5 (0x0007 in operation enabled) and 16 (0x000F in quick stop
    // active with 0x605A 5..8), which OpenCAN #51 lacked.
    assert_eq!(
        Transition::T5.command().map(|c| c.controlword().raw()),
        Some(0x0007)
    );
    assert_eq!(
        Transition::T16.command().map(|c| c.controlword().raw()),
        Some(0x000F)
    );
    for cw in plan.controlwords() {
        sim.set_controlword(cw);
        sim.step(MS);
    }
    assert_eq!(sim.state(), State::OperationEnabled);
}
