//! `canopen analyze`: logs recorded from simulated devices on the in-memory bus (virtual
//! clock, 500 kbit/s timing) with injected faults, judged through the binary. Each fault must be
//! found with its node and at the time it happened.
//!
//! The devices are the stack's simulated CiA 301 devices (`canola::SimDevice`) from the shipped
//! EDS files: the Bürkert one has a heartbeat producer time of 500 ms (0x1017), sends its
//! boot-up when attached and EMCY when told to, as CANopenNode devices do. The master side is a
//! plain endpoint that sends what a master sends (NMT, SDO, SYNC); a slow or absent SDO server
//! is an endpoint that answers late or not at all.

mod common;

use std::path::PathBuf;

use canola::candump::{LogEntry, LogFrame, format_line};
use canola::mem::{Endpoint, MemoryBus, StationId};
use canola::nmt::{Emcy, EmcyCode, ErrorRegister};
use canola::transport::{Received, Transport};
use canola::{BusConfig, CanFrame, CanId, Duration, NodeId, SimDevice};
use common::{canopen, stderr, stdout};
use serde_json::Value;

const BURKERT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");
const SERVO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/cia402-servo.eds");
/// The log's time base: candump writes seconds since the Unix epoch.
const EPOCH_US: u64 = 1_700_000_000_000_000;

/// An in-memory bus with a master endpoint and a recording tap.
struct Rig {
    bus: MemoryBus,
    master: Endpoint,
    tap: Endpoint,
    lines: Vec<String>,
}

impl Rig {
    fn new() -> Self {
        let bus = MemoryBus::with_config(BusConfig {
            bitrate: Some(500_000),
            ..BusConfig::default()
        });
        let tap = bus.endpoint();
        let master = bus.endpoint();
        Self {
            bus,
            master,
            tap,
            lines: Vec::new(),
        }
    }

    fn device(&mut self, node: u8, eds: &str) -> StationId<SimDevice> {
        let text = std::fs::read(eds).unwrap();
        let dev = SimDevice::from_eds(NodeId::new(node).unwrap(), &text).unwrap();
        let id = self.bus.attach(dev);
        self.record();
        id
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        self.master
            .send(&CanFrame::new(CanId::standard(id).unwrap(), data).unwrap())
            .unwrap();
        self.run(1);
    }

    fn run(&mut self, ms: u64) {
        self.bus.run_for(Duration::from_millis(ms));
        self.record();
    }

    fn now_us(&self) -> u64 {
        self.bus.now().as_micros()
    }

    fn record(&mut self) {
        while let Ok(Some(r)) = self.tap.try_recv() {
            if let Received::Frame { frame, at } = r {
                self.lines.push(format_line(&LogEntry {
                    timestamp_us: EPOCH_US + at.as_micros(),
                    interface: "can0".into(),
                    frame: LogFrame::Can(frame),
                    len8_dlc: None,
                }));
            }
        }
    }

    /// NMT start of every node.
    fn start_all(&mut self) {
        self.send(0x000, &[0x01, 0x00]);
    }

    fn write(&self, name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("canopen-analyze-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        let mut text = self.lines.join("\n");
        text.push('\n');
        std::fs::write(&path, text).unwrap();
        path
    }
}

/// `canopen analyze --json ARGS... LOG`: the report.
fn analyze(log: &std::path::Path, extra: &[&str]) -> Value {
    let mut args = vec!["analyze", "--json"];
    args.extend_from_slice(extra);
    let log = log.to_str().unwrap();
    args.push(log);
    let out = canopen(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_str(&stdout(&out)).unwrap_or_else(|e| panic!("{e}: {}", stdout(&out)))
}

fn problems<'a>(report: &'a Value, kind: &str) -> Vec<&'a Value> {
    report["problems"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["kind"] == kind)
        .collect()
}

fn secs(us: u64) -> f64 {
    us as f64 / 1e6
}

#[test]
fn a_node_that_stops_is_found_where_its_heartbeat_ends() {
    let mut rig = Rig::new();
    rig.device(5, BURKERT);
    let six = rig.device(6, BURKERT);
    rig.start_all();
    rig.run(2_000);
    let gone = rig.now_us();
    rig.bus.detach(six);
    rig.run(2_000);
    let log = rig.write("stops.log");
    // With the EDS the producer time is the dictionary's (0x1017 = 500 ms).
    let burkert6 = format!("6={BURKERT}");
    let report = analyze(&log, &["--eds", &burkert6]);
    let lost = problems(&report, "heartbeat-lost");
    assert_eq!(lost.len(), 1, "{report:#}");
    let p = lost[0];
    assert_eq!(p["node"], 6);
    assert_eq!(p["level"], "error");
    // Due one producer time after the last heartbeat, which came before the node went.
    let t = p["time"].as_f64().unwrap();
    assert!(
        t > secs(gone) && t <= secs(gone) + 0.51,
        "{t} vs {}",
        secs(gone)
    );
    assert!(p["seen"].as_str().unwrap().contains("500 ms (eds)"), "{p}");
    let six = report["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["node"] == 6)
        .unwrap();
    assert_eq!(six["heartbeat_from"], "eds");
    // Without it the period is observed, and the same loss is found.
    let report = analyze(&log, &[]);
    let lost = problems(&report, "heartbeat-lost");
    assert_eq!(lost.len(), 1, "{report:#}");
    assert_eq!(lost[0]["node"], 6);
    assert!(lost[0]["seen"].as_str().unwrap().contains("(observed)"));
    // --check fails on it; without --check the exit status is 0.
    let out = canopen(&["analyze", "--check", log.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", stdout(&out));
    let text = stdout(&out);
    assert!(text.contains("heartbeat-lost"), "{text}");
    assert!(text.contains("node 6"), "{text}");
}

#[test]
fn a_node_that_reboots_and_one_that_loops_are_found() {
    let mut rig = Rig::new();
    let five = rig.device(5, BURKERT);
    rig.start_all();
    rig.run(1_500);
    // Node 5 loses power and comes back: a boot-up nobody asked for.
    rig.bus.detach(five);
    rig.run(100);
    let reboot = rig.now_us();
    let mut five = rig.device(5, BURKERT);
    rig.run(3_000);
    // Then it resets again and again, every two seconds.
    let mut loop_at = 0;
    for i in 0..3 {
        rig.bus.detach(five);
        rig.run(100);
        if i == 2 {
            loop_at = rig.now_us();
        }
        five = rig.device(5, BURKERT);
        rig.run(1_900);
    }
    let log = rig.write("reboot.log");
    let report = analyze(&log, &[]);
    let unexpected = problems(&report, "unexpected-boot-up");
    assert!(!unexpected.is_empty(), "{report:#}");
    assert_eq!(unexpected[0]["node"], 5);
    assert_eq!(unexpected[0]["level"], "warning");
    let t = unexpected[0]["time"].as_f64().unwrap();
    assert!((t - secs(reboot)).abs() < 0.01, "{t} vs {}", secs(reboot));
    let looping = problems(&report, "boot-up-loop");
    assert_eq!(looping.len(), 1, "{report:#}");
    assert_eq!(looping[0]["node"], 5);
    assert_eq!(looping[0]["level"], "error");
    let t = looping[0]["time"].as_f64().unwrap();
    // The third boot-up within 30 s is the one after the first reset of the loop.
    assert!(t <= secs(loop_at) + 0.01, "{t} vs {}", secs(loop_at));
    // The timeline has every boot-up and the NMT start.
    let timeline = report["timeline"].as_array().unwrap();
    let boots = timeline
        .iter()
        .filter(|e| e["event"] == "boot-up node 5")
        .count();
    assert_eq!(boots, 5, "{timeline:#?}");
    assert!(timeline.iter().any(|e| {
        e["event"]
            .as_str()
            .unwrap()
            .starts_with("NMT Start remote node")
    }));
}

#[test]
fn an_emcy_is_found_with_its_meaning_and_a_drive_one_with_cia_402s() {
    let mut rig = Rig::new();
    let five = rig.device(5, BURKERT);
    let three = rig.device(3, SERVO);
    rig.start_all();
    rig.run(1_000);
    let at = rig.bus.now();
    rig.bus.with_station(five, |d| {
        d.signal_emcy(at, Emcy::new(EmcyCode(0x5000), ErrorRegister(0x01)))
    });
    rig.run(500);
    let at3 = rig.bus.now();
    rig.bus.with_station(three, |d| {
        d.signal_emcy(at3, Emcy::new(EmcyCode(0x8611), ErrorRegister(0x21)))
    });
    rig.run(500);
    let log = rig.write("emcy.log");
    let servo = format!("3={SERVO}");
    let report = analyze(&log, &["--eds", &servo]);
    let emcy = problems(&report, "emcy");
    assert_eq!(emcy.len(), 2, "{report:#}");
    assert_eq!(emcy[0]["node"], 5);
    assert!((emcy[0]["time"].as_f64().unwrap() - secs(at.as_micros())).abs() < 0.01);
    let m = emcy[0]["meaning"].as_str().unwrap();
    assert!(m.contains("device hardware") && m.contains("0x01"), "{m}");
    assert_eq!(emcy[1]["node"], 3);
    let m = emcy[1]["meaning"].as_str().unwrap();
    assert!(m.contains("CiA 402: following error"), "{m}");
    assert!((emcy[1]["time"].as_f64().unwrap() - secs(at3.as_micros())).abs() < 0.01);
}

#[test]
fn sdo_answers_late_and_never_and_aborts_are_found() {
    let mut rig = Rig::new();
    rig.device(5, BURKERT);
    let mut slow = rig.bus.endpoint();
    rig.run(100);
    // Node 9 is a slow server: it answers a read of 0x1000 after 800 ms.
    let asked = rig.now_us();
    rig.send(0x609, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    rig.run(800);
    slow.send(
        &CanFrame::new(
            CanId::standard(0x589).unwrap(),
            &[0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x02, 0x00],
        )
        .unwrap(),
    )
    .unwrap();
    rig.run(100);
    // Node 10 never answers.
    let silent = rig.now_us();
    rig.send(0x60A, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    rig.run(1_000);
    // Node 5 refuses a read of an object it does not have.
    rig.send(0x605, &[0x40, 0x00, 0x60, 0x01, 0, 0, 0, 0]);
    rig.run(100);
    let log = rig.write("sdo.log");
    let report = analyze(&log, &[]);
    let late = problems(&report, "sdo-late");
    assert_eq!(late.len(), 1, "{report:#}");
    assert_eq!(late[0]["node"], 9);
    assert!(
        late[0]["seen"].as_str().unwrap().contains("answered 80"),
        "{}",
        late[0]
    );
    assert!(late[0]["time"].as_f64().unwrap() > secs(asked) + 0.8);
    let never = problems(&report, "sdo-unanswered");
    assert_eq!(never.len(), 1, "{report:#}");
    assert_eq!(never[0]["node"], 10);
    assert_eq!(never[0]["level"], "error");
    assert!((never[0]["time"].as_f64().unwrap() - secs(silent)).abs() < 0.01);
    let abort = problems(&report, "sdo-abort");
    assert_eq!(abort.len(), 1, "{report:#}");
    assert_eq!(abort[0]["node"], 5);
    assert!(
        abort[0]["meaning"]
            .as_str()
            .unwrap()
            .contains("does not exist"),
        "{}",
        abort[0]
    );
    // A timeout longer than the slow answer: not late.
    let report = analyze(&log, &["--sdo-timeout", "1000"]);
    assert!(problems(&report, "sdo-late").is_empty());
}

#[test]
fn a_duplicated_node_id_is_found() {
    let mut rig = Rig::new();
    rig.device(7, BURKERT);
    rig.start_all();
    rig.run(1_200);
    // A second device configured to node-ID 7 is powered up next to the first.
    let second = rig.now_us();
    rig.device(7, BURKERT);
    rig.run(6_000);
    let log = rig.write("duplicate.log");
    // Found by their heartbeats: one Operational, the other Pre-operational, no NMT between.
    let report = analyze(&log, &[]);
    let dup = problems(&report, "duplicate-node-id");
    assert_eq!(dup.len(), 1, "{report:#}");
    assert_eq!(dup[0]["node"], 7);
    assert_eq!(dup[0]["level"], "error");
    let seen = dup[0]["seen"].as_str().unwrap();
    assert!(
        seen.contains("heartbeats of node 7 change between"),
        "{seen}"
    );
    let t = dup[0]["time"].as_f64().unwrap();
    assert!(t > secs(second) && t < secs(second) + 2.0, "{t}");
    // Both Pre-operational (no NMT start): found by their count against the EDS's producer
    // time (500 ms: twice the heartbeats it allows).
    let mut rig = Rig::new();
    rig.device(7, BURKERT);
    rig.run(200);
    rig.device(7, BURKERT);
    rig.run(8_000);
    let log = rig.write("duplicate-preop.log");
    let burkert7 = format!("7={BURKERT}");
    let report = analyze(&log, &["--eds", &burkert7]);
    let dup = problems(&report, "duplicate-node-id");
    assert_eq!(dup.len(), 1, "{report:#}");
    assert_eq!(dup[0]["node"], 7);
    let seen = dup[0]["seen"].as_str().unwrap();
    assert!(seen.contains("heartbeats of node 7 in"), "{seen}");
}

#[test]
fn a_lost_sync_producer_is_found() {
    let mut rig = Rig::new();
    rig.device(5, BURKERT);
    rig.start_all();
    for _ in 0..100 {
        rig.send(0x080, &[]);
        rig.run(9);
    }
    let last_sync = rig.now_us();
    rig.run(1_000);
    let log = rig.write("sync.log");
    let report = analyze(&log, &[]);
    let lost = problems(&report, "sync-lost");
    assert_eq!(lost.len(), 1, "{report:#}");
    assert_eq!(lost[0]["level"], "error");
    let t = lost[0]["time"].as_f64().unwrap();
    assert!(
        t > secs(last_sync) - 0.02 && t < secs(last_sync) + 0.05,
        "{t}"
    );
    assert!(problems(&report, "sync-period").is_empty(), "{report:#}");
    assert!(problems(&report, "heartbeat-lost").is_empty(), "{report:#}");
}

#[test]
fn bad_and_cut_lines_are_reported_with_their_numbers_never_a_panic() {
    let mut rig = Rig::new();
    rig.device(5, BURKERT);
    rig.run(1_200);
    let mut text = rig.lines[..2].join("\n");
    text.push_str("\nnot a candump line\n(1700000000.5) can0 7zz#00\n\u{0}\u{ff}garbage\n");
    text.push_str(&rig.lines[2..].join("\n"));
    // The last line cut after its first data byte (no line end).
    text.push_str("\n(1700000002.000000) can0 185#2E");
    let path = std::env::temp_dir().join(format!("canopen-analyze-bad-{}.log", std::process::id()));
    std::fs::write(&path, &text).unwrap();
    let report = analyze(&path, &[]);
    let bad: Vec<_> = problems(&report, "bad-line")
        .iter()
        .map(|p| p["line"].as_u64().unwrap())
        .collect();
    let last = text.lines().count() as u64;
    assert_eq!(bad, [3, 4, 5, last], "{report:#}");
    assert_eq!(report["summary"]["bad_lines"], 4);
    let cut = problems(&report, "bad-line")[3]["seen"].as_str().unwrap();
    assert!(cut.contains("cut"), "{cut}");
    // The good frames still count.
    assert_eq!(
        report["summary"]["frames"].as_u64().unwrap(),
        rig.lines.len() as u64
    );
    let out = canopen(&["analyze", "--check", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    // Binary junk of any kind: a report, no panic.
    let junk: Vec<u8> = (0..4000u32).map(|i| (i * 7919 % 251) as u8).collect();
    std::fs::write(&path, junk).unwrap();
    let out = canopen(&["analyze", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("bad-line"));
}

#[test]
fn a_raw_dlc_above_8_shows_in_frames_and_a_bad_one_is_a_bad_line_with_its_number() {
    // As `candump -8` writes a classic frame whose DLC is 12 (8 bytes carried), then a line
    // whose raw DLC is not above 8.
    let text = "(1700000000.000000) can0 185#1122334455667788_C\n\
                (1700000000.001000) can0 185#1122334455667788_8\n\
                (1700000000.002000) can0 185#1122334455667788\n";
    let path = std::env::temp_dir().join(format!("canopen-analyze-dlc-{}.log", std::process::id()));
    std::fs::write(&path, text).unwrap();
    let log = path.to_str().unwrap();

    let out = canopen(&["analyze", "--frames", log]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let lines: Vec<_> = stdout(&out).lines().map(str::to_owned).collect();
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(
        lines[0].contains(" 185#1122334455667788_C "),
        "{}",
        lines[0]
    );
    assert!(!lines[1].contains('_'), "{}", lines[1]);
    assert!(
        stderr(&out).contains(": line 2: bad raw DLC `_8`"),
        "{}",
        stderr(&out)
    );

    let out = canopen(&["analyze", "--frames", "--json", log]);
    let first: Value = serde_json::from_str(stdout(&out).lines().next().unwrap()).unwrap();
    assert_eq!(first["frame"], "185#1122334455667788_C");
    assert_eq!(first["len8_dlc"], 12);
    let third: Value = serde_json::from_str(stdout(&out).lines().nth(1).unwrap()).unwrap();
    assert_eq!(third["frame"], "185#1122334455667788");
    assert!(third.get("len8_dlc").is_none(), "{third}");

    let report = analyze(&path, &[]);
    assert_eq!(report["summary"]["frames"], 2, "{report:#}");
    let bad = problems(&report, "bad-line");
    assert_eq!(bad.len(), 1, "{report:#}");
    assert_eq!(bad[0]["line"], 2);
    assert!(
        bad[0]["seen"].as_str().unwrap().contains("bad raw DLC"),
        "{report:#}"
    );
}
