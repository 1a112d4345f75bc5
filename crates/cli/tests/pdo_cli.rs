//! `canopen pdo NODE show|map`: a simulated device's PDOs read with the names of its EDS (on the
//! in-memory bus); a TPDO of 96 bits mapped on the CANopen FD device of
//! `tests/vcan/fd-device.eds` in another process on the UDP bus, read back, and its CAN FD
//! frames seen carrying the new mapping after `nmt start`; the same mapping refused on a
//! classic device (in bits and bytes, exit 1, nothing written) and on a bus without CAN FD;
//! usage errors (exit 2) and errors as JSON.

use std::io::{BufRead as _, BufReader, Read as _};
use std::process::{Child, Command, Output, Stdio};

mod common;
use common::{canopen, stderr, stdout};

const FD_EDS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/vcan/fd-device.eds"
);
const CLASSIC_EDS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/vcan/test-device.eds"
);

/// Three 32-bit entries of the FD device: Temperature (REAL32), Value 1 and Value 2.
const ENTRIES_96: [&str; 3] = ["0x2101:00", "0x2100:01", "0x2100:02"];

/// A background process, killed when dropped.
struct Background(Child);

impl Drop for Background {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `canopen ARGS` on the in-memory bus, `--eds NODE=EDS` simulating the device.
fn in_memory(eds: &str, node: &str, args: &[&str]) -> Output {
    let spec = format!("{node}={eds}");
    let mut all = vec!["--eds", spec.as_str()];
    all.extend_from_slice(args);
    canopen(&all)
}

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: not JSON: {text}"))
}

#[test]
fn show_prints_the_default_tpdo1_with_names_from_the_eds() {
    let o = in_memory(CLASSIC_EDS, "5", &["pdo", "5", "show", "tpdo", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o),
        "TPDO1 (0x1800, 0x1A00): COB-ID 0x00000185 (0x185, valid)\n  transmission type 254 \
         (event-driven, manufacturer-specific), inhibit time 0.0 ms, event timer 100 ms\n  \
         0x2000:00  32 bits  Test value\n  1 object(s), 32 bits (4 bytes)\n"
    );

    // Every PDO, RPDOs first: RPDO1 maps two objects.
    let o = in_memory(CLASSIC_EDS, "5", &["pdo", "5", "show"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.starts_with(
            "RPDO1 (0x1400, 0x1600): COB-ID 0x00000205 (0x205, valid)\n  transmission type 254"
        ),
        "{text}"
    );
    assert!(text.contains("  0x2003:00  32 bits  Setpoint\n  0x2002:02  16 bits  Test array / Element 2\n  2 object(s), 48 bits (6 bytes)\nTPDO1"), "{text}");

    // The 64-byte TPDO1 of the FD device, as JSON.
    let o = in_memory(FD_EDS, "7", &["--fd", "--json", "pdo", "7", "show", "tpdo"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&stdout(&o));
    assert_eq!(v["node"], 7);
    let pdo = &v["pdos"][0];
    assert_eq!(pdo["pdo"], "TPDO1");
    assert_eq!(pdo["cob_id"], 0x187);
    assert_eq!(pdo["can_id"], 0x187);
    assert_eq!(pdo["valid"], true);
    assert_eq!(pdo["transmission_type"], 254);
    assert_eq!(pdo["event_timer_ms"], 100);
    assert_eq!(pdo["inhibit_time_ms"], 0.0);
    assert_eq!(pdo["sync_start"], serde_json::Value::Null);
    assert_eq!(
        (pdo["bits"].as_u64(), pdo["bytes"].as_u64()),
        (Some(512), Some(64))
    );
    let mapped = pdo["mapped"].as_array().unwrap();
    assert_eq!(mapped.len(), 17);
    assert_eq!(
        (
            &mapped[0]["index"],
            &mapped[0]["sub"],
            &mapped[0]["bits"],
            &mapped[0]["name"]
        ),
        (
            &0x2100.into(),
            &1.into(),
            &32.into(),
            &"Measured values / Value 1".into()
        )
    );
    assert_eq!(mapped[14]["name"], "Temperature");
}

#[test]
fn show_of_a_pdo_the_node_does_not_have_fails() {
    let o = in_memory(CLASSIC_EDS, "5", &["pdo", "5", "show", "tpdo", "9"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("node 5: no TPDO9 (read the PDOs its --eds dictionary lists: TPDO1)"),
        "{}",
        stderr(&o)
    );
}

/// `canopen --fd simulate EDS` as `node` on `bus`, answering SDO.
fn simulator(bus: &str, eds: &str, node: &str) -> Background {
    let sim = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            bus,
            "--fd",
            "simulate",
            eds,
            "--node-id",
            node,
            "--duration",
            "30",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the simulator starts");
    let sim = Background(sim);
    for _ in 0..50 {
        if canopen(&["--iface", bus, "sdo", "read", node, "0x1000"])
            .status
            .success()
        {
            return sim;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    panic!("the simulator never answered on {bus}");
}

#[test]
fn a_96_bit_tpdo_is_mapped_on_the_fd_device_read_back_and_sent() {
    let bus = common::udp_bus(0);
    let _sim = simulator(&bus, FD_EDS, "7");
    let eds = format!("7={FD_EDS}");
    let on_bus = |args: &[&str]| {
        let mut all = vec!["--iface", bus.as_str()];
        all.extend_from_slice(args);
        canopen(&all)
    };

    // Mapped in pre-operational (where the simulator starts), by the EDS's lengths, with a new
    // event timer; the UDP bus carries CAN FD without --fd.
    let mut args = vec!["--eds", eds.as_str(), "pdo", "7", "map", "tpdo", "1"];
    args.extend(ENTRIES_96);
    args.extend(["--event-timer", "50"]);
    let o = on_bus(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "node 7: TPDO1 mapped and valid with 3 object(s), 96 bits (12 bytes)\n"
    );

    // Read back with names, and without the EDS (lengths only).
    let o = on_bus(&["--eds", &eds, "pdo", "7", "show", "tpdo", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o),
        "TPDO1 (0x1800, 0x1A00): COB-ID 0x00000187 (0x187, valid)\n  transmission type 254 \
         (event-driven, manufacturer-specific), inhibit time 0.0 ms, event timer 50 ms\n  \
         0x2101:00  32 bits  Temperature\n  0x2100:01  32 bits  Measured values / Value 1\n  \
         0x2100:02  32 bits  Measured values / Value 2\n  3 object(s), 96 bits (12 bytes)\n"
    );
    let o = on_bus(&["--json", "pdo", "7", "show", "tpdo", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&stdout(&o));
    let entries: Vec<(u64, u64, u64)> = v["pdos"][0]["mapped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            assert!(m["name"].is_null(), "{m}");
            (
                m["index"].as_u64().unwrap(),
                m["sub"].as_u64().unwrap(),
                m["bits"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(entries, [(0x2101, 0, 32), (0x2100, 1, 32), (0x2100, 2, 32)]);
    assert_eq!(v["pdos"][0]["bytes"], 12);

    // Started, the device sends the new TPDO1 as a CAN FD frame of 12 bytes: 21.5 as a
    // REAL32, then 1 and 2.
    let mut monitor = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            &bus,
            "--fd",
            "--json",
            "monitor",
            "--duration",
            "2",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .expect("the monitor starts");
    let mut out = BufReader::new(monitor.stdout.take().unwrap());
    let mut text = String::new();
    // Its first line (the device's heartbeat): it is listening.
    out.read_line(&mut text).unwrap();
    assert!(!text.is_empty(), "the monitor showed nothing");
    let o = on_bus(&["nmt", "start", "7"]);
    assert!(o.status.success(), "{}", stderr(&o));
    out.read_to_string(&mut text).unwrap();
    assert!(monitor.wait().unwrap().success());
    let want = format!("187##1{}{}{}", "0000ac41", "01000000", "02000000");
    let tpdos: Vec<String> = text
        .lines()
        .map(|l| json(l)["frame"].as_str().unwrap().to_string())
        .filter(|f| f.starts_with("187##"))
        .collect();
    assert!(
        tpdos.len() >= 2,
        "the first TPDO and its event timer: {text}"
    );
    assert!(
        tpdos.iter().all(|f| f.eq_ignore_ascii_case(&want)),
        "{tpdos:?}"
    );
}

#[test]
fn a_96_bit_tpdo_is_refused_on_a_classic_device_and_nothing_is_written() {
    let bus = common::udp_bus(1);
    let _sim = simulator(&bus, CLASSIC_EDS, "5");
    let eds = format!("5={CLASSIC_EDS}");
    let on_bus = |args: &[&str]| {
        let mut all = vec!["--iface", bus.as_str(), "--eds", eds.as_str()];
        all.extend_from_slice(args);
        canopen(&all)
    };
    let before = on_bus(&["pdo", "5", "show", "tpdo", "1"]);
    assert!(before.status.success(), "{}", stderr(&before));

    let map = [
        "pdo",
        "5",
        "map",
        "tpdo",
        "1",
        "0x2000:00",
        "0x2003:00",
        "0x2000:00/32",
    ];
    let o = on_bus(&map);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    for part in [
        "error: node 5, object 0x1800:00: TPDO1: ",
        "96 bits (12 bytes)",
        "64 bits (8 bytes) of a classic CAN frame",
        "node 5 is not marked CANopen FD",
    ] {
        assert!(err.contains(part), "{part}: {err}");
    }
    let hint = err.lines().nth(1).unwrap_or_default();
    assert!(
        hint.starts_with("hint: a node is marked CANopen FD by CANopenFD=1"),
        "{err}"
    );

    // Under --json, the same as one JSON object naming node and object.
    let mut json_map = vec!["--json"];
    json_map.extend(map);
    let o = on_bus(&json_map);
    assert_eq!(o.status.code(), Some(1));
    let v = json(&stderr(&o));
    assert_eq!(
        (&v["node"], &v["index"], &v["sub"]),
        (&5.into(), &0x1800.into(), &0.into())
    );
    let text = v["error"].as_str().unwrap();
    assert!(
        text.contains("TPDO1") && text.contains("96 bits (12 bytes)"),
        "{v}"
    );
    assert!(v.get("usage").is_none(), "{v}");
    assert!(v["hint"].as_str().unwrap().contains("CANopenFD=1"), "{v}");

    // Nothing was written.
    let after = on_bus(&["pdo", "5", "show", "tpdo", "1"]);
    assert_eq!(stdout(&after), stdout(&before));
    // 64 bits fit.
    let o = on_bus(&["pdo", "5", "map", "tpdo", "1", "0x2000:00", "0x2003:00"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("64 bits (8 bytes)"), "{}", stderr(&o));
}

#[test]
fn a_bus_without_can_fd_refuses_the_fd_device_s_96_bits() {
    // The in-memory bus without --fd carries classic frames only.
    let mut args = vec!["pdo", "7", "map", "tpdo", "1"];
    args.extend(ENTRIES_96);
    let o = in_memory(FD_EDS, "7", &args);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("TPDO1")
            && err.contains("96 bits (12 bytes)")
            && err.contains("carries no CAN FD"),
        "{err}"
    );
    assert!(err.contains("\nhint: give --fd for a CAN FD bus"), "{err}");
    // With --fd it is mapped.
    let mut fd = vec!["--fd"];
    fd.extend(&args);
    let o = in_memory(FD_EDS, "7", &fd);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn usage_errors_exit_2_and_print_json_under_json() {
    for bad in ["0x2000", "0x2000:xy", "0x2000:00/0", "0x2000:00/bits"] {
        let o = in_memory(CLASSIC_EDS, "5", &["pdo", "5", "map", "tpdo", "1", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains(bad), "{bad}: {}", stderr(&o));
    }
    let o = in_memory(
        CLASSIC_EDS,
        "5",
        &["--json", "pdo", "5", "map", "tpdo", "1", "0x2000"],
    );
    assert_eq!(o.status.code(), Some(2));
    let v = json(&stderr(&o));
    assert_eq!(v["usage"], true);
    assert!(
        v["error"].as_str().unwrap().contains("not a mapping entry"),
        "{v}"
    );

    // Without a dictionary an entry needs its length; said before anything is sent.
    let o = canopen(&["pdo", "5", "map", "tpdo", "1", "0x2000:00"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("give 0x2000:00/BITS, or give --eds 5=FILE"),
        "{}",
        stderr(&o)
    );
    // No entry, a reserved transmission type, an object the dictionary does not have.
    for args in [
        &["pdo", "5", "map", "tpdo", "1"][..],
        &[
            "pdo",
            "5",
            "map",
            "tpdo",
            "1",
            "0x2000:00",
            "--transmission-type",
            "245",
        ],
        &["pdo", "5", "map", "tpdo", "1", "0x2100:00"],
    ] {
        let o = in_memory(CLASSIC_EDS, "5", args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}
