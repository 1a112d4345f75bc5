//! The planner's plans fed to the drive-side state machine: from every state, with every quick
//! stop option code and both drive behaviours where drives differ, every commandable target is
//! reached (or, for quick stop active with 0x605A 0..4, the drive ends in switch on disabled as
//! CiA 402 says), and every controlword sent is one of the command table's.

use canola_cia402::device::{DeviceConfig, DeviceStateMachine};
use canola_cia402::objects::QuickStopOption;
use canola_cia402::state::{Command, PlanError, Planner, State};
use proptest::prelude::*;

fn any_state() -> impl Strategy<Value = State> {
    prop::sample::select(State::ALL.to_vec())
}

fn any_target() -> impl Strategy<Value = State> {
    prop::sample::select(
        State::ALL
            .into_iter()
            .filter(|s| s.is_commandable())
            .collect::<Vec<_>>(),
    )
}

fn table_word(raw: u16) -> bool {
    Command::ALL.iter().any(|c| c.controlword().raw() == raw)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn whole_plans_reach_the_target(
        from in any_state(),
        target in any_target(),
        qs in any::<i16>(),
        t16 in any::<bool>(),
        enable_from_ready in any::<bool>(),
    ) {
        let option = QuickStopOption(qs);
        let planner = Planner { quick_stop_option: option, transition_16: t16, ..Planner::default() };
        let mut drive = DeviceStateMachine::in_state(
            DeviceConfig { quick_stop_option: option, transition_16: t16, enable_from_ready },
            from,
        );
        let plan = planner.plan_from(from, target).unwrap();
        for step in plan.steps() {
            match step.controlword {
                Some(cw) => {
                    prop_assert!(table_word(cw.raw()), "{cw} not in the table");
                    drive.on_controlword(cw);
                }
                // An automatic transition: the master waits, the drive gets there by itself.
                None => {
                    drive.settle();
                }
            }
            prop_assert_eq!(drive.state(), step.expect, "step {:?}", step);
        }
        let expected = if target == State::QuickStopActive && from != target && !option.stays_in_quick_stop() {
            State::SwitchOnDisabled
        } else {
            target
        };
        prop_assert_eq!(drive.state(), expected);
        prop_assert_eq!(plan.end_state(from), expected);
    }

    #[test]
    fn replanning_from_each_statusword_reaches_the_target_or_names_the_blocker(
        from in any_state(),
        target in any_target(),
        qs in -2i16..10,
        power in any::<bool>(),
        previous_cw in any::<u16>(),
    ) {
        let option = QuickStopOption(qs);
        let planner = Planner { quick_stop_option: option, ..Planner::default() };
        let mut drive = DeviceStateMachine::in_state(
            DeviceConfig { quick_stop_option: option, ..DeviceConfig::default() },
            from,
        );
        // Whatever the master sent before must not spoil the fault reset edge.
        drive.on_controlword(canola_cia402::Controlword::from_raw(previous_cw));
        drive.set_power(power);
        let mut done = false;
        let mut last = Some(canola_cia402::Controlword::from_raw(previous_cw));
        for _ in 0..16 {
            match planner.next_step(drive.statusword(), last, target) {
                Ok(None) => { done = true; break; }
                Ok(Some(step)) => {
                    if let Some(cw) = step.controlword {
                        prop_assert!(table_word(cw.raw()));
                        drive.on_controlword(cw);
                        last = Some(cw);
                    }
                    drive.settle();
                    if step.transition.number() == 11 && !option.stays_in_quick_stop() {
                        prop_assert_eq!(drive.state(), State::SwitchOnDisabled);
                        prop_assert_eq!(target, State::QuickStopActive);
                        done = true;
                        break;
                    }
                }
                Err(PlanError::VoltageNotEnabled { state, .. }) => {
                    prop_assert!(!power, "voltage reported missing with power on");
                    prop_assert_eq!(state, drive.state());
                    prop_assert!(matches!(target, State::SwitchedOn | State::OperationEnabled | State::QuickStopActive));
                    done = true;
                    break;
                }
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
        prop_assert!(done, "no end in 16 steps from {from} to {target}");
    }
}
