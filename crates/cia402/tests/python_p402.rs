//! Cross-check against python-canopen's `BaseNode402` (canopen.profiles.p402, the real library):
//! its statusword masks, controlword commands, transition table, state-setter walk, homing
//! status table and mode codes, dumped by tests/py/p402_tables.py, against this crate's decoder,
//! commands, drive-side machine and planner, on all 65 536 statuswords and every command.
//!
//! python-canopen's known deviations are listed in [`deviations_of_python_canopen`] and asserted
//! to still be there, so a change on either side shows.
//!
//! Runs with `$CANOPEN_PYTHON` (python-canopen importable); without it the test prints that it
//! skipped, unless `CANOPEN_REQUIRE_PYTHON=1`.

use std::collections::HashMap;
use std::process::Command as Process;

use canola_cia402::device::{DeviceConfig, DeviceStateMachine};
use canola_cia402::mode::{HomingStatus, ModeOfOperation};
use canola_cia402::objects::QuickStopOption;
use canola_cia402::state::{Command, Planner, State, Transition};
use canola_cia402::words::{Controlword, Statusword};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/py/p402_tables.py");

fn python() -> Option<String> {
    let Ok(python) = std::env::var("CANOPEN_PYTHON") else {
        assert!(
            std::env::var("CANOPEN_REQUIRE_PYTHON").as_deref() != Ok("1"),
            "CANOPEN_REQUIRE_PYTHON=1 but CANOPEN_PYTHON is not set"
        );
        eprintln!("skipped: CANOPEN_PYTHON is not set (python-canopen cross-check)");
        return None;
    };
    let ok = Process::new(&python)
        .args(["-c", "import canopen.profiles.p402"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        return Some(python);
    }
    assert!(
        std::env::var("CANOPEN_REQUIRE_PYTHON").as_deref() != Ok("1"),
        "CANOPEN_REQUIRE_PYTHON=1 but {python} cannot import canopen.profiles.p402"
    );
    eprintln!("skipped: {python} cannot import canopen.profiles.p402");
    None
}

/// python-canopen's tables.
struct Tables {
    names: Vec<String>,
    masks: Vec<(String, u16, u16)>,
    states: Vec<u8>,
    commands: Vec<(String, u16)>,
    transitions: Vec<(State, State, u16)>,
    paths: Vec<(State, State, Vec<Option<u16>>, State)>,
    homing: Vec<(String, u16, u16)>,
    modes: Vec<(i8, String, u32)>,
}

fn state(name: &str) -> State {
    match name {
        "NOT READY TO SWITCH ON" => State::NotReadyToSwitchOn,
        "SWITCH ON DISABLED" => State::SwitchOnDisabled,
        "READY TO SWITCH ON" => State::ReadyToSwitchOn,
        "SWITCHED ON" => State::SwitchedOn,
        "OPERATION ENABLED" => State::OperationEnabled,
        "QUICK STOP ACTIVE" => State::QuickStopActive,
        "FAULT REACTION ACTIVE" => State::FaultReactionActive,
        "FAULT" => State::Fault,
        other => panic!("python-canopen state {other:?} unknown here"),
    }
}

fn load(python: &str) -> Tables {
    let out = Process::new(python)
        .arg(SCRIPT)
        .output()
        .expect("runs python");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let mut t = Tables {
        names: vec![],
        masks: vec![],
        states: vec![],
        commands: vec![],
        transitions: vec![],
        paths: vec![],
        homing: vec![],
        modes: vec![],
    };
    for line in text.lines() {
        let (kind, rest) = line.split_once(' ').unwrap();
        let f: Vec<&str> = rest.split('|').collect();
        let n = |s: &str| s.parse::<i64>().unwrap();
        match kind {
            "names" => t.names = f.iter().map(|s| s.to_string()).collect(),
            "mask" => t.masks.push((f[0].into(), n(f[1]) as u16, n(f[2]) as u16)),
            "states" => t.states = rest.bytes().collect(),
            "command" => t.commands.push((f[0].into(), n(f[1]) as u16)),
            "transition" if f[0] == "START" => {}
            "transition" => t
                .transitions
                .push((state(f[0]), state(f[1]), n(f[2]) as u16)),
            "path" => {
                let words = f[2]
                    .split_whitespace()
                    .map(|w| (w != "x").then(|| n(w) as u16))
                    .collect();
                t.paths.push((state(f[0]), state(f[1]), words, state(f[3])));
            }
            "homing" => t.homing.push((f[0].into(), n(f[1]) as u16, n(f[2]) as u16)),
            "mode" => t.modes.push((n(f[0]) as i8, f[1].into(), n(f[2]) as u32)),
            other => panic!("unknown line kind {other}"),
        }
    }
    assert_eq!(t.states.len(), 0x10000);
    t
}

#[test]
fn python_canopen_agrees_on_the_state_machine() {
    let Some(python) = python() else { return };
    let t = load(&python);

    // Masks and values: the same eight states.
    assert_eq!(t.masks.len(), 8);
    for (name, mask, value) in &t.masks {
        let s = state(name);
        assert_eq!((s.mask(), s.value()), (*mask, *value), "{name}");
    }
    // Every statusword decodes to the same state (or to none on both sides).
    let mut disagree = 0;
    for raw in 0..=u16::MAX {
        let theirs = match t.states[usize::from(raw)] {
            b'-' => None,
            c => Some(state(&t.names[usize::from(c - b'a')])),
        };
        let ours = State::decode(Statusword::from_raw(raw));
        if theirs != ours {
            disagree += 1;
            eprintln!("{raw:#06x}: python {theirs:?}, canola {ours:?}");
        }
    }
    assert_eq!(disagree, 0, "statuswords decoded differently");

    // Commands: python-canopen names commands by the state they lead to.
    let commands: HashMap<&str, u16> = t.commands.iter().map(|(n, c)| (n.as_str(), *c)).collect();
    assert_eq!(
        commands["DISABLE VOLTAGE"],
        Command::DisableVoltage.controlword().raw()
    );
    assert_eq!(
        commands["READY TO SWITCH ON"],
        Command::Shutdown.controlword().raw()
    );
    assert_eq!(
        commands["SWITCHED ON"],
        Command::SwitchOn.controlword().raw()
    );
    assert_eq!(
        commands["OPERATION ENABLED"],
        Command::EnableOperation.controlword().raw()
    );
    assert_eq!(
        commands["QUICK STOP ACTIVE"],
        Command::QuickStop.controlword().raw()
    );
    assert_eq!(
        commands["SWITCH ON DISABLED"],
        Command::FaultReset.controlword().raw()
    );

    // Transition table: each of python-canopen's entries is one of ours, the word decodes to a
    // command the transition accepts, and our drive-side machine takes it.
    let mut covered = [false; 17];
    for &(from, to, cw) in &t.transitions {
        let tr = Transition::ALL
            .into_iter()
            .find(|tr| tr.from() == Some(from) && tr.to() == to)
            .unwrap_or_else(|| panic!("python-canopen {from} -> {to} is no CiA 402 transition"));
        covered[usize::from(tr.number())] = true;
        if tr.is_automatic() {
            // Deviation D4, checked below.
            continue;
        }
        let cmd = Command::decode(Controlword::from_raw(cw), Controlword::from_raw(0)).unwrap();
        assert!(
            tr.accepts(cmd),
            "{tr}: python-canopen sends {cw:#06x} ({cmd})"
        );
        let cfg = DeviceConfig {
            quick_stop_option: QuickStopOption(6),
            ..DeviceConfig::default()
        };
        let mut drive = DeviceStateMachine::in_state(cfg, from);
        drive.on_controlword(Controlword::from_raw(cw));
        assert_eq!(drive.state(), to, "{tr} with {cw:#06x}");
    }
    let missing: Vec<usize> = (1..17).filter(|&n| !covered[n] && n != 13).collect();
    assert!(
        missing.is_empty(),
        "transitions python-canopen lacks: {missing:?}"
    );

    // The state setter's walks: the same controlwords as our planner, for a drive that keeps
    // quick stop active (0x605A = 6, python-canopen's silent assumption) and after a word with
    // bit 7 clear (python-canopen leaves the edge to earlier writes), with python-canopen's
    // words for automatic transitions left out (D4).
    let planner = Planner {
        quick_stop_option: QuickStopOption(6),
        ..Planner::default()
    };
    assert_eq!(t.paths.len(), 8 * 5);
    for (from, target, words, end) in &t.paths {
        assert_eq!(end, target, "python-canopen's walk {from} -> {target}");
        let theirs: Vec<u16> = words
            .iter()
            .zip(walk_states(*from, &t.transitions, words.len(), *target))
            .filter(|(_, at)| !matches!(at, State::NotReadyToSwitchOn | State::FaultReactionActive))
            .map(|(w, _)| w.expect("a table word"))
            .collect();
        let sw = Statusword::from_raw(from.value() | Statusword::VOLTAGE_ENABLED);
        let ours: Vec<u16> = planner
            .plan_after(sw, Some(Controlword::from_raw(0)), *target)
            .unwrap()
            .controlwords()
            .map(|c| c.raw())
            .collect();
        assert_eq!(ours, theirs, "{from} -> {target}");
    }
}

/// The states a python-canopen walk passes through (the state before each hop).
fn walk_states(
    from: State,
    table: &[(State, State, u16)],
    hops: usize,
    target: State,
) -> Vec<State> {
    let mut at = from;
    let mut out = vec![];
    for _ in 0..hops {
        out.push(at);
        let direct = table.iter().any(|(a, b, _)| *a == at && *b == target);
        at = if direct {
            target
        } else {
            match at {
                State::NotReadyToSwitchOn | State::QuickStopActive | State::Fault => {
                    State::SwitchOnDisabled
                }
                State::FaultReactionActive => State::Fault,
                State::SwitchOnDisabled => State::ReadyToSwitchOn,
                State::ReadyToSwitchOn => State::SwitchedOn,
                State::SwitchedOn | State::OperationEnabled => State::OperationEnabled,
            }
        };
    }
    out
}

#[test]
fn python_canopen_agrees_on_homing_status_and_modes() {
    let Some(python) = python() else { return };
    let t = load(&python);
    assert_eq!(t.homing.len(), 6);
    for (name, mask, value) in &t.homing {
        assert_eq!(*mask, HomingStatus::MASK);
        let ours = HomingStatus::decode(Statusword::from_raw(*value | 0x0237));
        let expected = match name.as_str() {
            "IN PROGRESS" => HomingStatus::InProgress,
            "INTERRUPTED" => HomingStatus::Interrupted,
            "ATTAINED" => HomingStatus::Attained,
            "TARGET REACHED" => HomingStatus::Completed,
            "ERROR VELOCITY IS NOT ZERO" => HomingStatus::ErrorMoving,
            "ERROR VELOCITY IS ZERO" => HomingStatus::ErrorStandstill,
            other => panic!("{other}"),
        };
        assert_eq!(ours, expected, "{name}");
    }
    assert_eq!(t.modes.len(), 10);
    for (code, name, bit) in &t.modes {
        let mode = ModeOfOperation::from_code(*code);
        let short = match name.as_str() {
            "NO MODE" => None,
            "PROFILED POSITION" => Some("pp"),
            "VELOCITY" => Some("vl"),
            "PROFILED VELOCITY" => Some("pv"),
            "PROFILED TORQUE" => Some("tq"),
            "HOMING" => Some("hm"),
            "INTERPOLATED POSITION" => Some("ip"),
            "CYCLIC SYNCHRONOUS POSITION" => Some("csp"),
            "CYCLIC SYNCHRONOUS VELOCITY" => Some("csv"),
            "CYCLIC SYNCHRONOUS TORQUE" => Some("cst"),
            other => panic!("{other}"),
        };
        assert_eq!(mode.short_name(), short, "{name}");
        assert_eq!(mode.supported_bit().unwrap_or(0), *bit, "{name}");
    }
}

/// python-canopen's known deviations from CiA 402, each asserted
/// against its tables so the list stays true.
#[test]
fn deviations_of_python_canopen() {
    let Some(python) = python() else { return };
    let t = load(&python);
    let path = |from: State, to: State| -> Vec<Option<u16>> {
        t.paths
            .iter()
            .find(|p| p.0 == from && p.1 == to)
            .unwrap()
            .2
            .clone()
    };
    let ours = |p: Planner, from: State, to: State| -> (Vec<u16>, State) {
        let plan = p.plan_from(from, to).unwrap();
        (
            plan.controlwords().map(|c| c.raw()).collect(),
            plan.end_state(from),
        )
    };
    let default = Planner::default();

    // D1, python-canopen #167: the walk to quick stop active sends 0x0002 and waits for quick
    // stop active, whatever 0x605A says. With the common default 0x605A = 2 the drive goes on
    // to switch on disabled; our plan says so.
    assert_eq!(
        path(State::OperationEnabled, State::QuickStopActive),
        [Some(0x0002)]
    );
    assert_eq!(
        ours(default, State::OperationEnabled, State::QuickStopActive),
        (vec![0x0002], State::SwitchOnDisabled)
    );

    // D2, python-canopen #169: quick stop active -> operation enabled is always 0x000F
    // (transition 16), which CiA 402 allows only with 0x605A 5..8 and drives may lack.
    assert_eq!(
        path(State::QuickStopActive, State::OperationEnabled),
        [Some(0x000F)]
    );
    assert_eq!(
        ours(default, State::QuickStopActive, State::OperationEnabled).0,
        [0x0000, 0x0006, 0x0007, 0x000F]
    );

    // D3, python-canopen's FIXME in reset_from_fault and #261: fault -> switch on disabled is
    // 0x0080 alone; the rising edge depends on whatever was written before. We clear bit 7
    // first unless the last word is known to have it clear.
    assert_eq!(path(State::Fault, State::SwitchOnDisabled), [Some(0x0080)]);
    assert_eq!(
        ours(default, State::Fault, State::SwitchOnDisabled).0,
        [0x0000, 0x0080]
    );

    // D4: the automatic transitions 0, 1 and 14 have controlword 0x0000 in its table (the
    // setter writes disable voltage and waits); they need no command.
    for (from, to, cw) in &t.transitions {
        if matches!(from, State::NotReadyToSwitchOn | State::FaultReactionActive) {
            assert_eq!(*cw, 0x0000, "{from} -> {to}");
            let tr = Transition::ALL
                .into_iter()
                .find(|tr| tr.from() == Some(*from) && tr.to() == *to)
                .unwrap();
            assert!(tr.is_automatic() && tr.command().is_none());
        }
    }

    // D5: its command 0x0080 is named "SWITCH ON DISABLED"; CiA 402 calls it fault reset.
    assert!(
        t.commands
            .iter()
            .any(|(n, c)| n == "SWITCH ON DISABLED" && *c == 0x0080)
    );

    // D6, python-canopen #183: CODE2NAME has no negative (manufacturer) codes, so an 0x6061 of
    // -1 has no name there; ours keeps it.
    assert!(!t.modes.iter().any(|(c, _, _)| *c < 0));
    assert_eq!(
        ModeOfOperation::from_code(-1),
        ModeOfOperation::Manufacturer(-1)
    );
}
