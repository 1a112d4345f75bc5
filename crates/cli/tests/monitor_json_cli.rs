//! `canopen --json monitor`: each frame one JSON object, a PDO the node's EDS maps with its
//! values decoded as JSON (object, name, value as a JSON number). Against a simulated device
//! in another process on the UDP bus.

use std::io::Read as _;
use std::process::{Command, Stdio};

mod common;
use common::stderr;

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

#[test]
fn monitor_json_decodes_pdo_values() {
    let iface = common::udp_bus(0);
    let mut sim = common::simulator(&iface, EDS, "5", "30");
    let eds = format!("5={EDS}");
    let mut monitor = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--json",
            "--iface",
            &iface,
            "--eds",
            &eds,
            "monitor",
            "--duration",
            "2",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let o = common::canopen(&["--iface", &iface, "nmt", "start", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut text = String::new();
    monitor
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    assert!(monitor.wait().unwrap().success());
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line JSON"))
        .collect();
    let tpdo1 = lines
        .iter()
        .find(|v| v["pdo"] == "TPDO1 node 5")
        .unwrap_or_else(|| panic!("no TPDO1 in {text}"));
    let first = &tpdo1["values"][0];
    assert_eq!(first["index"], 0x2500, "{tpdo1}");
    assert_eq!(first["sub"], 1);
    assert_eq!(first["name"], "Sensor Value 1 / Value");
    assert!(first["value"].is_number(), "{tpdo1}");
    // Other frames keep the text description.
    assert!(lines.iter().all(|v| v["decoded"].is_string()));
    let _ = sim.kill();
    let _ = sim.wait();
}
