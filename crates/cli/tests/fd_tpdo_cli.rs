//! `canopen --fd --json monitor` decoding a 64-byte TPDO (CANopen FD) of a simulated device in
//! another process over the UDP bus: the device of `tests/vcan/fd-device.eds` started, a value
//! written by USDO into one of the mapped objects, and the TPDO's CAN FD frame shown with that
//! value at its name, in JSON and in text.

use std::io::{BufRead as _, BufReader, Read as _};
use std::process::{Child, Command, Stdio};

mod common;
use common::{canopen, stderr};

const EDS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/vcan/fd-device.eds"
);

/// `canopen --fd simulate` of the FD test device as node 7 on `bus`, answering USDO.
fn fd_simulator(bus: &str) -> Child {
    let mut sim = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            bus,
            "--fd",
            "simulate",
            EDS,
            "--node-id",
            "7",
            "--duration",
            "30",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the simulator starts");
    for _ in 0..50 {
        let o = canopen(&[
            "--iface", bus, "--fd", "usdo", "read", "7", "0x1000", "--type", "u32",
        ]);
        if o.status.success() {
            return sim;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let _ = sim.kill();
    let _ = sim.wait();
    panic!("the FD simulator never answered on {bus}");
}

/// Starts `canopen --fd --eds 7=EDS [--json] monitor --duration 3` on `bus` and returns once
/// it shows its first frame (the device's heartbeat, every 100 ms): it is listening.
fn monitor(bus: &str, json: bool) -> (Child, BufReader<std::process::ChildStdout>, String) {
    let eds = format!("7={EDS}");
    let mut args = vec!["--iface", bus, "--fd", "--eds", eds.as_str()];
    if json {
        args.push("--json");
    }
    args.extend(["monitor", "--duration", "3"]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(&args)
        .stdout(Stdio::piped())
        .spawn()
        .expect("the monitor starts");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    out.read_line(&mut first).unwrap();
    assert!(!first.is_empty(), "the monitor showed nothing");
    (child, out, first)
}

/// Starts node 7 and writes `value` into 0x2100:05 (mapped into TPDO1) by USDO.
fn start_and_write(bus: &str, value: &str) {
    let o = canopen(&["--iface", bus, "--fd", "nmt", "start", "7"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let eds = format!("7={EDS}");
    let o = canopen(&[
        "--iface", bus, "--fd", "--eds", &eds, "usdo", "write", "7", "0x2100", "5", value,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The rest of the monitor's output once it ends.
fn finish(
    mut child: Child,
    mut out: BufReader<std::process::ChildStdout>,
    first: String,
) -> String {
    let mut text = first;
    out.read_to_string(&mut text).unwrap();
    assert!(child.wait().unwrap().success());
    text
}

#[test]
fn monitor_json_decodes_a_64_byte_tpdo_from_another_process() {
    let bus = common::udp_bus(0);
    let mut sim = fd_simulator(&bus);
    let (child, out, first) = monitor(&bus, true);
    start_and_write(&bus, "3735928559");
    let text = finish(child, out, first);
    let _ = sim.kill();
    let _ = sim.wait();

    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line JSON"))
        .collect();
    let tpdo = lines
        .iter()
        .find(|v| v["pdo"] == "TPDO1 node 7" && v["values"][4]["value"] == 3735928559u32)
        .unwrap_or_else(|| panic!("no TPDO1 with the written value in {text}"));
    // The CAN FD frame on 0x187: `##`, the flags digit, 64 bytes.
    let frame = tpdo["frame"].as_str().unwrap();
    let data = frame
        .strip_prefix("187##")
        .expect("a CAN FD frame on 0x187");
    assert_eq!(data.len(), 1 + 2 * 64, "{frame}");
    let values = tpdo["values"].as_array().unwrap();
    assert_eq!(values.len(), 17, "{tpdo}");
    let v5 = &values[4];
    assert_eq!(
        (&v5["index"], &v5["sub"], &v5["name"]),
        (
            &0x2100.into(),
            &5.into(),
            &"Measured values / Value 5".into()
        )
    );
    assert_eq!(values[0]["value"], 1);
    assert_eq!(values[14]["name"], "Temperature");
    assert_eq!(values[14]["value"], 21.5);
    assert_eq!(values[16]["name"], "Offset");
    assert_eq!(values[16]["value"], -5);
    assert!(
        tpdo["decoded"]
            .as_str()
            .unwrap()
            .contains("Measured values / Value 5 = 3735928559"),
        "{tpdo}"
    );
}

#[test]
fn monitor_text_decodes_a_64_byte_tpdo_from_another_process() {
    let bus = common::udp_bus(1);
    let mut sim = fd_simulator(&bus);
    let (child, out, first) = monitor(&bus, false);
    start_and_write(&bus, "4242");
    let text = finish(child, out, first);
    let _ = sim.kill();
    let _ = sim.wait();
    let line = text
        .lines()
        .find(|l| l.contains("187##") && l.contains("Value 5 = 4242"))
        .unwrap_or_else(|| panic!("no decoded TPDO1 in {text}"));
    assert!(
        line.contains("TPDO1 node 7: Measured values / Value 1 = 1, ")
            && line.ends_with("Temperature = 21.5, Status word = 1, Offset = -5"),
        "{line}"
    );
    // Every TPDO1 frame is decoded (the one on entering Operational too); the USDO frames
    // are not PDOs and stay undecoded.
    let tpdos: Vec<&str> = text.lines().filter(|l| l.contains(" 187##")).collect();
    assert!(tpdos.len() >= 2, "{text}");
    assert!(tpdos.iter().all(|l| l.contains("TPDO1 node 7: ")), "{text}");
}
