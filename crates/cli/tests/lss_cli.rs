//! `canopen lss` as a binary against simulated LSS slaves on the in-memory bus, with the bus
//! recorded to a candump log (`--record-bus`) to check what reached the wire, and on the UDP
//! bus against devices in other processes.

use std::process::Output;

mod common;
use common::{canopen, stderr, stdout};

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-lss-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs `canopen lss --record-bus LOG <args>` and returns the output and the `ID#DATA` frames
/// of the log.
fn recorded(name: &str, args: &[&str]) -> (Output, Vec<String>) {
    let log = tmp(name);
    let log_arg = log.to_str().unwrap();
    let mut all = vec!["lss", "--record-bus", log_arg];
    all.extend_from_slice(args);
    let o = canopen(&all);
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let frames = text
        .lines()
        .map(|l| l.rsplit(' ').next().unwrap_or_default().to_string())
        .collect();
    (o, frames)
}

#[test]
fn commands_that_only_transmit_put_their_frame_on_the_bus() {
    for (args, frame) in [
        (&["switch-global", "config"][..], "7E5#0401000000000000"),
        (&["switch-global", "waiting"][..], "7E5#0400000000000000"),
        (
            &["--unconfigured", "1", "switch-global", "config"][..],
            "7E5#0401000000000000",
        ),
    ] {
        let (o, frames) = recorded("switch.log", args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert_eq!(frames, [frame], "{args:?}");
    }
    // Bit rate change: switch global, configure bit timing (answered), activate, switch back.
    let (o, frames) = recorded(
        "rate.log",
        &["--unconfigured", "1", "set-bit-rate", "250", "--delay", "5"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        frames,
        [
            "7E5#0401000000000000",
            "7E5#1300030000000000",
            "7E4#1300000000000000",
            "7E5#1505000000000000",
            "7E5#0400000000000000",
        ]
    );
    // Store configuration of the slave in configuration state.
    let (o, frames) = recorded("store.log", &["--unconfigured", "1", "store"]);
    assert!(!o.status.success(), "nobody is in configuration state");
    assert_eq!(frames, ["7E5#1700000000000000"]);
}

#[test]
fn assign_all_of_1_2_20_real_slaves_finishes() {
    for n in [1u32, 2, 20] {
        let count = n.to_string();
        let o = canopen(&[
            "--json",
            "lss",
            "--unconfigured",
            &count,
            "--real-slaves",
            "assign-all",
            "--first",
            "10",
            "--last",
            "127",
        ]);
        assert!(o.status.success(), "{n}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        let ids: Vec<u64> = v["assigned"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["node_id"].as_u64().unwrap())
            .collect();
        assert_eq!(ids, (10..10 + u64::from(n)).collect::<Vec<_>>(), "{n}");
        assert!(v["stopped"].is_null());
        assert!(
            v["slaves"]
                .as_array()
                .unwrap()
                .iter()
                .all(|e| e["stored"] == true)
        );
    }
}

#[test]
fn discover_all_of_real_slaves_finishes_and_releases_them() {
    let (o, frames) = recorded(
        "discover.log",
        &[
            "--json",
            "--unconfigured",
            "3",
            "--real-slaves",
            "discover-all",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let serials: Vec<u64> = v["found"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["serial"].as_u64().unwrap())
        .collect();
    assert_eq!(serials, [1001, 1002, 1003]);
    assert_eq!(
        frames.last().map(String::as_str),
        Some("7E5#0400000000000000")
    );
}

#[test]
fn slaves_without_store_are_assigned_not_stored() {
    let o = canopen(&[
        "lss",
        "--unconfigured",
        "2",
        "--real-slaves",
        "--store-unsupported",
        "assign-all",
        "--first",
        "5",
        "--last",
        "9",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert_eq!(text.matches("assigned, not stored").count(), 2, "{text}");
    assert!(text.contains("node-ID 5 assigned") && text.contains("node-ID 6 assigned"));

    let o = canopen(&[
        "lss",
        "--unconfigured",
        "1",
        "--store-unsupported",
        "configure-node-id",
        "42",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("node-ID 42 assigned, not stored"),
        "{}",
        stdout(&o)
    );
    let o = canopen(&[
        "--json",
        "lss",
        "--unconfigured",
        "1",
        "--store-unsupported",
        "configure-node-id",
        "42",
    ]);
    assert_eq!(stdout(&o).trim(), r#"{"node_id":42,"stored":false}"#);
    let o = canopen(&[
        "--json",
        "lss",
        "--unconfigured",
        "1",
        "configure-node-id",
        "42",
    ]);
    assert_eq!(stdout(&o).trim(), r#"{"node_id":42,"stored":true}"#);
}

#[test]
fn an_empty_pool_is_a_usage_error() {
    let (o, frames) = recorded(
        "empty.log",
        &[
            "--unconfigured",
            "1",
            "assign-all",
            "--first",
            "10",
            "--last",
            "2",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("empty node-ID pool"), "{}", stderr(&o));
    assert!(frames.is_empty(), "nothing is sent: {frames:?}");
}

#[test]
fn step_timeout_is_documented_and_used() {
    let o = canopen(&["lss", "--help"]);
    let help = stdout(&o);
    assert!(help.contains("--step-timeout <MS>"), "{help}");
    let (o, frames) = recorded(
        "timeout.log",
        &["--step-timeout", "7", "--unconfigured", "1", "fastscan"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        frames.iter().filter(|f| f.starts_with("7E5#51")).count(),
        133
    );
    // Each Fastscan request waits out its window (7 ms) before the next one goes out.
    let log = std::fs::read_to_string(tmp("timeout.log")).unwrap();
    let times: Vec<f64> = log
        .lines()
        .filter(|l| l.contains(" 7E5#51"))
        .map(|l| l[1..l.find(')').unwrap()].parse().unwrap())
        .collect();
    for pair in times.windows(2) {
        let gap_us = ((pair[1] - pair[0]) * 1e6).round();
        assert_eq!(gap_us, 7000.0, "{times:?}");
    }
    let o = canopen(&["lss", "--step-timeout", "0", "fastscan"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn simulate_needs_an_interface() {
    let o = canopen(&["lss", "--unconfigured", "2", "simulate", "--duration", "1"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("give --iface"), "{}", stderr(&o));
}

#[test]
fn assign_all_leaves_out_node_ids_in_use_and_reports_them() {
    let args = [
        "lss",
        "--unconfigured",
        "3",
        "--real-slaves",
        "--running",
        "5,6",
        "assign-all",
        "--first",
        "4",
        "--last",
        "10",
    ];
    let o = canopen(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for id in [5, 6] {
        assert!(
            text.contains(&format!(
                "node-ID {id} is in use on the bus: not handed out"
            )),
            "{text}"
        );
    }
    let mut json_args = vec!["--json"];
    json_args.extend_from_slice(&args);
    let o = canopen(&json_args);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let ids: Vec<u64> = v["assigned"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["node_id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, [4, 7, 8], "{v}");
    assert_eq!(v["in_use"], serde_json::json!([5, 6]), "{v}");
}

/// The LSS address of the `n`th simulated unconfigured device (`--unconfigured`).
fn sim_address(n: u32) -> String {
    format!("0x39,0x01000001,1,{}", 1000 + n)
}

#[test]
fn configure_node_id_refuses_a_node_id_in_use_unless_forced() {
    let base = ["lss", "--unconfigured", "1", "--running", "5"];
    let mut args = base.to_vec();
    args.extend(["configure-node-id", "5"]);
    let o = canopen(&args);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("node-ID 5 is in use on the bus") && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
    // Forced, switch mode global would reach the running node's LSS slave as well: refused.
    args.push("--force");
    let o = canopen(&args);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("several LSS slaves are in configuration state"),
        "{}",
        stderr(&o)
    );
    // Forced onto the unconfigured slave picked by its address.
    let address = sim_address(1);
    args.extend(["--address", &address]);
    let o = canopen(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("node-ID 5 assigned"),
        "{}",
        stdout(&o)
    );
    // A free node-ID goes through without --force.
    let mut args = base.to_vec();
    args.extend(["configure-node-id", "7", "--address", &address]);
    let o = canopen(&args);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Switch mode global puts every LSS slave in configuration state (CiA 305), and each one
/// answers configure node-ID: with two unconfigured slaves `configure-node-id` would give both
/// node-ID 9. It configures nothing, puts them back in waiting state and says what to use.
#[test]
fn configure_node_id_refuses_several_slaves_in_configuration_state() {
    let (o, frames) = recorded(
        "several.log",
        &["--unconfigured", "2", "configure-node-id", "9"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(
        err.contains("several LSS slaves are in configuration state")
            && err.contains("nothing was configured")
            && err.contains("assign-all")
            && err.contains("--address"),
        "{err}"
    );
    assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    assert!(
        !frames.iter().any(|f| f.starts_with("7E5#11")),
        "no configure node-ID may be sent: {frames:?}"
    );
    // The LSS frames (before them: the SDO probe of node-ID 9 in use) start with switch mode
    // global to configuration and end with it back to waiting.
    let lss: Vec<&String> = frames.iter().filter(|f| f.starts_with("7E")).collect();
    assert_eq!(
        lss.first().map(|f| f.as_str()),
        Some("7E5#0401000000000000")
    );
    assert_eq!(lss.last().map(|f| f.as_str()), Some("7E5#0400000000000000"));
    // Under --json the error and the hint are fields.
    let o = canopen(&[
        "--json",
        "lss",
        "--unconfigured",
        "2",
        "configure-node-id",
        "9",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).unwrap();
    assert!(
        v["error"].as_str().unwrap().contains("several LSS slaves"),
        "{v}"
    );
    assert!(v["hint"].as_str().unwrap().contains("assign-all"), "{v}");
    // One of them picked by its address: only it is configured.
    let address = sim_address(2);
    let (o, frames) = recorded(
        "selective.log",
        &[
            "--unconfigured",
            "2",
            "configure-node-id",
            "9",
            "--address",
            &address,
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "node-ID 9 assigned and stored");
    assert_eq!(
        frames.iter().filter(|f| f.starts_with("7E4#1100")).count(),
        1,
        "one slave answers configure node-ID: {frames:?}"
    );
    // Switch mode selective ends with the serial number, 1002.
    assert!(
        frames.contains(&"7E5#43EA030000000000".to_string()),
        "{frames:?}"
    );
    // A malformed address is a usage error.
    let o = canopen(&[
        "lss",
        "--unconfigured",
        "1",
        "configure-node-id",
        "9",
        "--address",
        "0x39,1",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// `lss assign-all` on a live bus of other processes: nodes 5 and 6 running (`simulate`), two
/// unconfigured LSS slaves (`lss simulate`); 5 and 6 are not handed out.
#[test]
fn assign_all_on_a_live_udp_bus_leaves_the_running_nodes_alone() {
    const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");
    let iface = common::udp_bus(3);
    let mut children = vec![
        common::simulator(&iface, EDS, "5", "60"),
        common::simulator(&iface, EDS, "6", "60"),
    ];
    children.push(
        std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
            .args([
                "--iface",
                &iface,
                "lss",
                "--unconfigured",
                "2",
                "--real-slaves",
                "simulate",
                "--duration",
                "60",
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("lss simulate starts"),
    );
    // The LSS slaves answer once their process is up.
    let mut up = false;
    for _ in 0..50 {
        let o = canopen(&["--iface", &iface, "lss", "identify-non-configured"]);
        if stdout(&o).contains("an unconfigured slave answered") {
            up = true;
            break;
        }
    }
    assert!(up, "the LSS slaves never answered");
    let o = canopen(&[
        "--json",
        "--iface",
        &iface,
        "lss",
        "--step-timeout",
        "60",
        "assign-all",
        "--first",
        "4",
        "--last",
        "10",
    ]);
    let out = stdout(&o);
    let v: Result<serde_json::Value, _> = serde_json::from_str(&out);
    let o2 = canopen(&["--iface", &iface, "lss", "configure-node-id", "6"]);
    for c in &mut children {
        let _ = c.kill();
        let _ = c.wait();
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let v = v.unwrap();
    let ids: Vec<u64> = v["assigned"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["node_id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, [4, 7], "{v}");
    assert_eq!(v["in_use"], serde_json::json!([5, 6]), "{v}");
    // A single slave is not given node 6 either.
    assert_eq!(o2.status.code(), Some(1), "{}", stdout(&o2));
    assert!(
        stderr(&o2).contains("node-ID 6 is in use"),
        "{}",
        stderr(&o2)
    );
}
