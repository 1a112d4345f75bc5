//! The bus commands run as a binary against devices simulated on the in-memory bus.

use std::process::Output;

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn with_node5(args: &[&str]) -> Output {
    let eds = format!("5={EDS}");
    let mut all = vec!["--eds", eds.as_str()];
    all.extend_from_slice(args);
    canopen(&all)
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn sdo_read_prints_the_value_alone() {
    let o = with_node5(&["sdo", "read", "5", "0x1017", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500\n");
    let o = with_node5(&["sdo", "read", "5", "0x1008", "0"]);
    assert_eq!(stdout(&o), "Buerkert generic device\n");
    let o = with_node5(&["sdo", "read", "5", "0x1018", "1", "--type", "u32"]);
    assert_eq!(stdout(&o), "57\n");
    let o = with_node5(&["sdo", "read", "5", "0x1017", "0", "--type", "bytes"]);
    assert_eq!(stdout(&o), "f401\n");
    let o = with_node5(&["--json", "sdo", "read", "5", "4119", "0"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["value"], 500);
    assert_eq!(v["index"], 0x1017);
}

#[test]
fn sdo_read_failure_exits_nonzero_with_the_abort_code() {
    let o = with_node5(&["sdo", "read", "5", "0x1234", "0"]);
    assert!(!o.status.success());
    assert!(stdout(&o).is_empty());
    let e = stderr(&o);
    assert!(e.contains("0x06020000"), "{e}");
    assert!(e.contains("Object does not exist"), "{e}");
    assert!(e.contains("node 5"), "{e}");
    // No device at all: a timeout, explained.
    let o = with_node5(&["sdo", "read", "9", "0x1000", "0"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("timeout"), "{}", stderr(&o));
}

#[test]
fn sdo_write_checks_types_and_reports_refusals() {
    let o = with_node5(&["sdo", "write", "5", "0x1017", "0", "250"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = with_node5(&["sdo", "write", "5", "0x1017", "0", "70000"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("out of range"), "{}", stderr(&o));
    let o = with_node5(&["sdo", "write", "5", "0x1008", "0", "new name"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("0x06010002"), "{}", stderr(&o));
    // A manufacturer-specific object's type comes from --type or the EDS alone.
    let o = canopen(&["sdo", "write", "5", "0x2000", "0", "1"]);
    assert!(stderr(&o).contains("--type"), "{}", stderr(&o));
}

#[test]
fn sdo_upload_and_download_files() {
    let out = tmp("name.bin");
    let o = with_node5(&[
        "sdo",
        "upload",
        "5",
        "0x1008",
        "0",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), b"Buerkert generic device");
    let input = tmp("desc.txt");
    std::fs::write(&input, "x".repeat(2000)).unwrap();
    for block in [false, true] {
        let mut args = vec![
            "sdo",
            "download",
            "5",
            "0x2002",
            "3",
            input.to_str().unwrap(),
        ];
        if block {
            args.push("--block");
        }
        let o = with_node5(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

#[test]
fn nmt_and_scan() {
    for cmd in ["start", "stop", "preop", "reset", "reset-comm"] {
        let o = with_node5(&["nmt", cmd, "5"]);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
    }
    assert!(with_node5(&["nmt", "start", "all"]).status.success());
    assert!(!with_node5(&["nmt", "start", "200"]).status.success());
    let eds6 = format!("6={EDS}");
    let o = with_node5(&["--eds", &eds6, "--json", "scan"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let nodes: Vec<_> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["node"].clone())
        .collect();
    assert_eq!(nodes, [5, 6]);
    assert_eq!(v[0]["vendor_id"], 0x39);
}

#[test]
fn monitor_simulate_record_replay() {
    let o = with_node5(&["monitor", "--duration", "1.2"]);
    let text = stdout(&o);
    assert!(text.contains("boot-up node 5"), "{text}");
    assert!(text.contains("heartbeat node 5 Pre-operational"), "{text}");

    let o = canopen(&["simulate", EDS, "--node-id", "7", "--duration", "1.1"]);
    let text = stdout(&o);
    assert!(text.contains("boot-up node 7"), "{text}");
    assert_eq!(text.matches("heartbeat node 7").count(), 2, "{text}");

    let log = tmp("rec.log");
    let o = with_node5(&["record", "-o", log.to_str().unwrap(), "--duration", "1.1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rec = std::fs::read_to_string(&log).unwrap();
    assert_eq!(rec.lines().count(), 3, "{rec}");
    assert!(
        rec.lines().next().unwrap().ends_with(" mem0 705#00"),
        "{rec}"
    );
    let o = with_node5(&["--json", "replay", log.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["sent"], 3);
    std::fs::write(&log, "(1.0) can0 123#zz\n").unwrap();
    let o = canopen(&["replay", log.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("line 1"), "{}", stderr(&o));
}

#[test]
fn demo_walks_through_commissioning() {
    let o = canopen(&["demo"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for want in [
        "boot-up node 5",
        "vendor-ID 0x00000039",
        "0x1017 now reads 100 ms",
        "heartbeat node 6 Operational",
        "read back: \"Hall 3 / line 7 / valve island A\"",
        "SDO initiate block upload request 0x2003:04",
        "0x06020000 (Object does not exist in the object dictionary)",
        "event: node 6 Operational -> Stopped",
        "assigned 00000039:01000001:00000001:00123456: node-ID 7",
        "node 6 TPDO3: 0x2004:01 = ",
        "0x2004:01 reads 2 = maintenance required",
        "the device is locating (LED flashing): true",
        "node 5 TPDO1: 0x2500:01 = 21.75",
    ] {
        assert!(text.contains(want), "missing {want:?} in\n{text}");
    }
    // No Rust Debug output reaches the reader.
    for debug in ["Some(", "Unsigned(", "Real32(", " { ", "NmtCommand"] {
        assert!(!text.contains(debug), "Debug text {debug:?} in\n{text}");
    }
}

#[test]
fn lss_services_against_unconfigured_devices() {
    let o = canopen(&[
        "lss",
        "--unconfigured",
        "3",
        "assign-all",
        "--first",
        "20",
        "--last",
        "30",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for id in [20, 21, 22] {
        assert!(text.contains(&format!("node-ID {id}")), "{text}");
    }
    let o = canopen(&["--json", "lss", "--unconfigured", "1", "fastscan"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["found"]["serial"], 1001);
    let o = canopen(&["--json", "lss", "--unconfigured", "2", "discover-all"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["found"].as_array().unwrap().len(), 2);
    let o = canopen(&[
        "--json",
        "lss",
        "--unconfigured",
        "1",
        "identify-non-configured",
    ]);
    assert_eq!(stdout(&o).trim(), r#"{"present":true}"#);
    let o = canopen(&["--json", "lss", "identify-non-configured"]);
    assert_eq!(stdout(&o).trim(), r#"{"present":false}"#);
    // Global switch and configure node-ID of the one unconfigured device.
    let o = canopen(&["lss", "--unconfigured", "1", "configure-node-id", "42"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = canopen(&["lss", "--unconfigured", "1", "set-bit-rate", "250"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = canopen(&["lss", "set-bit-rate", "333"]);
    assert!(!o.status.success());
}
