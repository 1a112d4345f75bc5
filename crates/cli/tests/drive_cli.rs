//! `canopen drive` against the simulated servo: in one process on the in-memory bus, and across
//! processes on the UDP bus with `canopen simulate eds/cia402-servo.eds` as the drive.

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/cia402-servo.eds");

#[test]
fn move_on_the_in_memory_bus_prints_the_position_until_target_reached() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--eds", &eds, "drive", "5", "move", "4000", "--enable"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines.last(),
        Some(&"target reached at position 4000"),
        "{out}"
    );
    let live: Vec<i32> = lines
        .iter()
        .filter_map(|l| l.strip_prefix("position "))
        .map(|p| p.parse().unwrap())
        .collect();
    assert!(
        live.len() >= 3 && live.windows(2).all(|w| w[0] <= w[1]),
        "{out}"
    );
    // Without --enable a fresh drive refuses, naming its state.
    let o = canopen(&["--eds", &eds, "drive", "5", "move", "4000"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("needs operation enabled"),
        "{}",
        stderr(&o)
    );
    // An unknown mode is a usage error, not a panic.
    let o = canopen(&["--eds", &eds, "drive", "5", "mode", "warp"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("not a mode"), "{}", stderr(&o));
}

#[test]
fn a_limit_switch_fault_names_its_code_and_emcy() {
    let eds = format!("5={EDS}");
    let o = canopen(&[
        "--eds",
        &eds,
        "--json",
        "drive",
        "5",
        "move",
        "250000",
        "--velocity",
        "200000",
        "--enable",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("0x8612") && err.contains("EMCY"), "{err}");
}

#[test]
fn drive_commands_over_the_udp_bus_against_canopen_simulate() {
    let iface = common::udp_bus(0);
    let mut sim = common::simulator(&iface, EDS, "5", "60");
    let run = |args: &[&str]| {
        let mut all = vec!["--iface", iface.as_str()];
        all.extend_from_slice(args);
        let o = canopen(&all);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        stdout(&o)
    };
    assert_eq!(run(&["drive", "5", "mode", "pp"]), "mode: pp (1)\n");
    // Already in pp: still a success.
    assert_eq!(run(&["drive", "5", "mode", "1"]), "mode: pp (1)\n");
    assert_eq!(run(&["drive", "5", "enable"]), "operation enabled\n");
    let out = run(&["drive", "5", "move", "3000", "--velocity", "20000"]);
    assert!(out.ends_with("target reached at position 3000\n"), "{out}");
    let out = run(&["drive", "5", "move", "-1000", "--relative"]);
    assert!(out.ends_with("target reached at position 2000\n"), "{out}");
    let status: serde_json::Value =
        serde_json::from_str(&run(&["--json", "drive", "5", "status"])).unwrap();
    assert_eq!(status["state"], "operation enabled");
    assert_eq!(status["mode_name"], "pp");
    assert_eq!(status["target_reached"], true);
    assert!(
        (status["position"].as_i64().unwrap() - 2000).abs() <= 10,
        "{status}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&run(&["--json", "drive", "5", "velocity", "5000"])).unwrap();
    assert_eq!(v["state"], "operation enabled");
    // 0x605A = 2 (the EDS default): the quick stop ends in switch on disabled.
    assert_eq!(run(&["drive", "5", "quick-stop"]), "switch on disabled\n");
    let r: serde_json::Value =
        serde_json::from_str(&run(&["--json", "drive", "5", "fault-reset"])).unwrap();
    assert_eq!(r["state"], "switch on disabled");
    assert_eq!(r["error_code"], "0x0000");
    assert_eq!(run(&["drive", "5", "disable"]), "switch on disabled\n");
    let _ = sim.kill();
    let _ = sim.wait();
}

/// `canopen drive 5 move ...` against `canopen simulate` on the UDP bus, ended by `signal` once
/// the drive moves: it must stop the drive, say so, and exit with 128 + the signal's number
/// (130 for SIGINT, 143 for SIGTERM).
fn move_ended_by(signal: nix::sys::signal::Signal, salt: u16) {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    let iface = common::udp_bus(salt);
    let mut sim = common::simulator(&iface, EDS, "5", "60");
    let mut mover = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            iface.as_str(),
            "drive",
            "5",
            "move",
            "1000000",
            "--velocity",
            "5000",
            "--enable",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Moving: the live position has left 0.
    let mut lines = BufReader::new(mover.stdout.take().unwrap()).lines();
    let moving = lines
        .by_ref()
        .map_while(Result::ok)
        .find(|l| l.strip_prefix("position ").is_some_and(|p| p != "0"));
    assert!(moving.is_some(), "the move never showed a position");
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(mover.id() as i32), signal).unwrap();
    let out = mover.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(128 + signal as i32), "{err}");
    let said = format!(
        "interrupted by {}: quick stop sent; the drive stopped in state \"switch on disabled\" at position",
        signal.as_str()
    );
    assert!(err.contains(&said), "{err}");
    // Stopped for good: switch on disabled (0x605A = 2), standing still, far from the target.
    let status = |args: &[&str]| -> serde_json::Value {
        let mut all = vec!["--iface", iface.as_str(), "--json"];
        all.extend_from_slice(args);
        let o = canopen(&all);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_str(&stdout(&o)).unwrap()
    };
    let a = status(&["drive", "5", "status"]);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let b = status(&["drive", "5", "status"]);
    assert_eq!(b["state"], "switch on disabled", "{b}");
    assert_eq!(b["velocity"], 0, "{b}");
    assert_eq!(a["position"], b["position"], "{a} {b}");
    assert!(b["position"].as_i64().unwrap() < 100_000, "{b}");
    let _ = sim.kill();
    let _ = sim.wait();
}

#[test]
fn ctrl_c_during_a_move_quick_stops_the_drive_and_exits_130() {
    move_ended_by(nix::sys::signal::Signal::SIGINT, 1);
}

#[test]
fn sigterm_during_a_move_quick_stops_the_drive_and_exits_143() {
    move_ended_by(nix::sys::signal::Signal::SIGTERM, 2);
}

#[test]
fn a_move_without_enable_names_the_state_and_hints_enable() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--eds", &eds, "drive", "5", "move", "4000"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("the drive is in state \"not ready to switch on\"")
            && err.contains("\nhint: give --enable to enable the drive first"),
        "{err}"
    );
    let o = canopen(&["--eds", &eds, "--json", "drive", "5", "move", "4000"]);
    let e: serde_json::Value = serde_json::from_str(stderr(&o).trim()).unwrap();
    assert_eq!(e["hint"], "give --enable to enable the drive first", "{e}");
}

#[test]
fn cia402_objects_are_typed_without_an_eds_on_a_profile_402_node() {
    let iface = common::udp_bus(3);
    let mut sim = common::simulator(&iface, EDS, "5", "30");
    let run = |args: &[&str]| {
        let mut all = vec!["--iface", iface.as_str()];
        all.extend_from_slice(args);
        canopen(&all)
    };
    // A drive leaves not ready to switch on by itself after its start-up and ignores a
    // controlword until then (CiA 402): asked until it shows switch on disabled.
    let until = |state: &str| {
        let mut status = String::new();
        for _ in 0..100 {
            status = stdout(&run(&["drive", "5", "status"]));
            if status.starts_with(&format!("state: {state}\n")) {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        status
    };
    let status = until("switch on disabled");
    assert!(
        status.starts_with("state: switch on disabled\n"),
        "{status}"
    );
    // 0x1000 says profile 402: 0x6040 is an UNSIGNED16, 0x6081 an UNSIGNED32, 0x607A an
    // INTEGER32, as the CiA 402 tables say.
    let o = run(&["sdo", "write", "5", "0x6040", "0", "6"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["sdo", "write", "5", "0x6081", "0", "20000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["sdo", "read", "5", "0x6081"]);
    assert_eq!(stdout(&o), "20000\n", "{}", stderr(&o));
    assert_eq!(stderr(&o), "");
    let o = run(&["sdo", "write", "5", "0x607A", "0", "-1500"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["sdo", "read", "5", "0x607A"]);
    assert_eq!(stdout(&o), "-1500\n", "{}", stderr(&o));
    let o = run(&["--hex", "sdo", "read", "5", "0x6041"]);
    assert!(stdout(&o).starts_with("0x"), "{}", stdout(&o));
    assert_eq!(stdout(&o).trim().len(), 6, "an UNSIGNED16: {}", stdout(&o));
    // The shutdown written above took the drive to ready to switch on.
    let status = until("ready to switch on");
    assert!(
        status.starts_with("state: ready to switch on\n"),
        "{status}"
    );
    let _ = sim.kill();
    let _ = sim.wait();
}
