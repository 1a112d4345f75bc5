//! CiA 402 statusword decoder and state planner on random statuswords, quick stop option codes,
//! target states and last controlwords: no panic, every controlword a plan sends is one of the
//! command table's, and the drive-side machine fed with the plan ends where the plan says.
//! Chunks with the top bit of the first byte set instead write a random value to a random
//! profile object of the simulated drive and step it: no panic there either.
#![no_main]

use std::time::Duration;

use canola_cia402::device::{DeviceConfig, DeviceStateMachine};
use canola_cia402::mode::{HomingStatus, ModeOfOperation, ModeStatus};
use canola_cia402::objects::{self, QuickStopOption};
use canola_cia402::sim::SimDrive;
use canola_cia402::state::{Command, Plan, PlanError, Planner, State, StateMasks, VoltageCheck};
use canola_cia402::words::{Controlword, Statusword};
use libfuzzer_sys::fuzz_target;

fn planner_masks(flags: u8) -> StateMasks {
    if flags & 0x20 != 0 {
        StateMasks::BeckhoffSsc
    } else {
        StateMasks::Standard
    }
}

fn table(cw: Controlword) -> bool {
    Command::ALL.iter().any(|c| c.controlword() == cw)
}

fuzz_target!(|data: &[u8]| {
    let mut sim: Option<SimDrive> = None;
    for chunk in data.chunks(8) {
        let mut b = [0u8; 8];
        b[..chunk.len()].copy_from_slice(chunk);
        if b[0] & 0x80 != 0 {
            let sim = sim.get_or_insert_with(SimDrive::default);
            let o = objects::ALL[usize::from(b[1]) % objects::ALL.len()];
            let _ = sim.write(
                o.index,
                o.sub_index,
                &b[2..2 + usize::from(b[0] & 0x3).min(3) + 1],
            );
            let _ = sim.write(0x6040, 0, &[b[6], b[7] & 0x03]);
            sim.step(Duration::from_micros(u64::from(b[0] & 0x7C) * 50));
            let mut out = [0u8; 8];
            let _ = sim.read(o.index, o.sub_index, &mut out);
            let _ = State::decode(sim.statusword());
            continue;
        }
        let sw = Statusword::from_raw(u16::from_le_bytes([b[0], b[1]]));
        let qs = QuickStopOption(i16::from_le_bytes([b[2], b[3]]));
        let target = State::ALL[usize::from(b[4] & 7)];
        let flags = b[5];
        let last =
            (flags & 0x80 != 0).then(|| Controlword::from_raw(u16::from_le_bytes([b[6], b[7]])));

        let state = State::decode_with(sw, planner_masks(flags));
        for mode in (-3i8..=11).map(ModeOfOperation::from_code) {
            let _ = ModeStatus::decode(mode, sw).target_reached();
        }
        let _ = HomingStatus::decode(sw).bits();
        let _ = Command::decode(
            Controlword::from_raw(u16::from_le_bytes([b[6], b[7]])),
            Controlword::from_raw(sw.raw()),
        );

        let planner = Planner {
            quick_stop_option: qs,
            transition_16: flags & 1 != 0,
            fault_reset: flags & 2 != 0,
            voltage_check: match flags >> 2 & 3 {
                0 => VoltageCheck::Off,
                1 => VoltageCheck::BeforeSwitchOn,
                _ => VoltageCheck::Always,
            },
            state_masks: planner_masks(flags),
        };
        match planner.plan_after(sw, last, target) {
            Ok(plan) => {
                let from = state.expect("a plan needs a state");
                assert!(plan.steps().len() <= Plan::MAX_STEPS);
                let mut drive = DeviceStateMachine::in_state(
                    DeviceConfig {
                        quick_stop_option: qs,
                        transition_16: planner.transition_16,
                        enable_from_ready: flags & 0x10 != 0,
                    },
                    from,
                );
                if let Some(cw) = last {
                    drive.on_controlword(cw);
                    // The last word may itself have moved the drive; replan from there below.
                }
                let replanned = planner.plan_after(drive.statusword(), last, target);
                for step in plan.steps() {
                    if let Some(cw) = step.controlword {
                        assert!(table(cw), "{cw} outside the command table");
                    }
                }
                if let Ok(plan) = replanned {
                    for step in plan.steps() {
                        match step.controlword {
                            Some(cw) => {
                                assert!(table(cw));
                                drive.on_controlword(cw);
                            }
                            None => {
                                drive.settle();
                            }
                        }
                        assert_eq!(drive.state(), step.expect, "{step:?}");
                    }
                    assert_eq!(drive.state(), plan.end_state(drive.state()));
                }
            }
            Err(PlanError::UnknownState(s)) => assert!(state.is_none() && s == sw),
            Err(PlanError::NotCommandable(s)) => assert!(!s.is_commandable()),
            Err(PlanError::FaultResetNotAllowed(s)) => {
                assert!(
                    !planner.fault_reset && matches!(s, State::Fault | State::FaultReactionActive)
                )
            }
            Err(PlanError::VoltageNotEnabled { statusword, .. }) => {
                assert!(!statusword.voltage_enabled())
            }
            Err(_) => {}
        }
    }
});
