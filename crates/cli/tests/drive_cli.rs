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
