//! The boot error codes of the keep-alive check and the software check (CiA 302-2 E, G, H, I,
//! L), each reached against simulated devices on the in-memory bus: a keep-alive slave found
//! operational (L) or silent (E); a software check that is not configured or whose slave has
//! no 0x1F52 (G); a version that differs with no update allowed (H); a program download that
//! fails (I) or updates the slave.

use std::path::Path;

use canola::transport::{Received, Transport};
use canola::{AbortCode, Duration, MemoryBus, Network, NmtState, NodeId, SimDevice};
use canola_manager::boot::{ConfigOutcome, SlaveReport};
use canola_manager::simulate::{BootLoader, attach_slaves, device, factory_dictionary};
use canola_manager::{
    BootErrorCode, BootEvent, BootStep, NetworkConfig, SlaveStatus, SoftwareOutcome, boot,
    boot_with, json,
};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn parse(text: &str) -> NetworkConfig {
    NetworkConfig::parse(text, &data("inline.toml")).expect("test description")
}

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn u32_at(net: &Network, n: u8, index: u16, sub: u8) -> u32 {
    let b = net.node(node(n)).sdo().read((index, sub)).wait().unwrap();
    let mut a = [0; 4];
    a[..b.len()].copy_from_slice(&b);
    u32::from_le_bytes(a)
}

fn by(report: &canola_manager::BootReport, n: u8) -> &SlaveReport {
    report.slaves.iter().find(|s| s.node_id == node(n)).unwrap()
}

/// The NMT commands (command, target) the master sent since the tap was opened.
fn nmt_commands(bus: &MemoryBus, tap: &mut canola::Endpoint) -> Vec<(u8, u8)> {
    let mut out = Vec::new();
    while let Ok(Some(r)) = tap.recv_until(bus.now()) {
        if let Received::Frame { frame, .. } = r
            && frame.id().as_raw() == 0
            && frame.data().len() == 2
        {
            out.push((frame.data()[0], frame.data()[1]));
        }
    }
    out
}

const MASTER: &str = "[master]\nsdo_timeout_ms = 100\nboot_timeout_ms = 500\n";

#[test]
fn keep_alive_slave_found_operational_is_left_running_with_l() {
    let config = parse(&format!(
        "{MASTER}
[[slave]]
node_id = 5
dcf = \"valve.dcf\"
mandatory = true
keep_alive = true
[[slave]]
node_id = 6
dcf = \"valve.dcf\"
mandatory = true
keep_alive = true
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    // Both run with their configuration (heartbeat 100 ms); node 5 is operational already,
    // node 6 pre-operational.
    for s in &config.slaves {
        bus.attach(SimDevice::new(s.node_id, s.dictionary.clone()));
    }
    net.run_for(Duration::from_millis(50)).wait().unwrap();
    net.node(node(5)).nmt().start().unwrap();
    net.run_for(Duration::from_millis(250)).wait().unwrap();
    assert_eq!(net.last_state(node(5)), Some(NmtState::Operational));

    let mut tap = bus.endpoint();
    let mut events = Vec::new();
    let report = boot_with(&net, &config, |e| events.push(e.clone()));
    let s5 = by(&report, 5);
    assert_eq!(s5.error_code, Some(BootErrorCode::L), "{s5:?}");
    assert_eq!(s5.status, SlaveStatus::Operational);
    assert_eq!(s5.step, Some(BootStep::NodeState));
    assert_eq!(s5.configuration, ConfigOutcome::NotRun);
    assert_eq!(s5.error_control.as_deref(), Some("heartbeat 150 ms"));
    // L is no failure: the mandatory slave counts as booted and the network starts.
    assert!(report.mandatory_ok, "{report:?}");
    assert!(!events.iter().any(|e| matches!(
        e,
        BootEvent::StepFailed { node: n, .. } if *n == node(5)
    )));

    // Node 6 was not operational: reset communication, then booted as usual.
    let s6 = by(&report, 6);
    assert_eq!(s6.error_code, None, "{s6:?}");
    assert_eq!(s6.status, SlaveStatus::Operational);
    assert_eq!(s6.configuration, ConfigOutcome::Verified);
    let sent = nmt_commands(&bus, &mut tap);
    assert!(sent.contains(&(0x82, 6)), "{sent:?}");
    // Node 5 was never reset.
    assert!(
        !sent.iter().any(|&(cs, n)| n == 5 && cs >= 0x81),
        "{sent:?}"
    );
    for step in [BootStep::NodeState, BootStep::ErrorControl] {
        assert!(events.contains(&BootEvent::StepDone {
            node: node(5),
            step
        }));
    }

    let j = json::slave_json(s5);
    assert_eq!(j["status"], "operational");
    assert_eq!(j["error_code"], "L");
    assert_eq!(j["step"], "node-state");
}

#[test]
fn keep_alive_slave_without_heartbeat_gives_e() {
    let config = parse(&format!(
        "{MASTER}
[[slave]]
node_id = 5
dcf = \"valve.dcf\"
keep_alive = true
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    // Fresh from the factory: 0x1017 is 0, no heartbeat, though its DCF says 100 ms.
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    let s = by(&report, 5);
    assert_eq!(s.error_code, Some(BootErrorCode::E), "{s:?}");
    assert_eq!(s.status, SlaveStatus::Failed);
    assert_eq!(s.step, Some(BootStep::NodeState));
    assert_eq!(s.object.unwrap().to_string(), "0x1017:00");
    // Nothing was written to a slave whose state is unknown.
    assert_eq!(u32_at(&net, 5, 0x2001, 0), 0);
}

#[test]
fn software_check_not_configured_or_inconsistent_gives_g() {
    let config = parse(&format!(
        "{MASTER}
# The check asked for without the expected date and time.
[[slave]]
node_id = 5
dcf = \"valve-boot.dcf\"
[slave.software]
update = true
program = \"valve-v2.bin\"
# A slave without the software objects (0x1F52).
[[slave]]
node_id = 6
dcf = \"valve.dcf\"
[slave.software]
date = 15000
time = 43200000
# An update needed and allowed, but no program.
[[slave]]
node_id = 7
dcf = \"valve-boot.dcf\"
[slave.software]
date = \"2026-03-01\"
time = \"10:00\"
update = true
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    for n in [5, 6, 7] {
        let s = by(&report, n);
        assert_eq!(s.error_code, Some(BootErrorCode::G), "{s:?}");
        assert_eq!(s.step, Some(BootStep::Software));
        assert_eq!(s.status, SlaveStatus::Failed);
    }
    assert_eq!(by(&report, 5).object.unwrap().to_string(), "0x1F53:05");
    assert_eq!(by(&report, 6).object.unwrap().to_string(), "0x1F52:01");
    assert_eq!(
        by(&report, 6).abort_code,
        Some(AbortCode::OBJECT_DOES_NOT_EXIST.get())
    );
    let s7 = by(&report, 7);
    assert_eq!(s7.object.unwrap().to_string(), "0x1F58:07");
    assert!(
        s7.detail
            .as_deref()
            .unwrap()
            .contains("date 15000 time 43200000, expected date 15400 time 36000000"),
        "{s7:?}"
    );
}

#[test]
fn software_differs_without_update_allowed_gives_h() {
    let config = parse(&format!(
        "{MASTER}
[[slave]]
node_id = 5
dcf = \"valve-boot.dcf\"
[slave.software]
date = 15400
time = 36000000
program = \"valve-v2.bin\"
# Update allowed, but a keep-alive slave is never updated.
[[slave]]
node_id = 6
dcf = \"valve-boot.dcf\"
keep_alive = true
[slave.software]
date = 15400
time = 36000000
update = true
program = \"valve-v2.bin\"
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(device(
        node(5),
        factory_dictionary(&config.slaves[0].dictionary),
    ));
    bus.attach(device(node(6), config.slaves[1].dictionary.clone()));
    let report = boot(&net, &config);
    for n in [5, 6] {
        let s = by(&report, n);
        assert_eq!(s.error_code, Some(BootErrorCode::H), "{s:?}");
        assert_eq!(s.step, Some(BootStep::Software));
        assert_eq!(s.object.unwrap().to_string(), "0x1F52:01");
        // The old program still runs; the configuration was not touched.
        assert_eq!(u32_at(&net, n, 0x1F52, 1), 15000);
    }
    assert!(
        by(&report, 5)
            .detail
            .as_deref()
            .unwrap()
            .contains("not allowed")
    );
    assert!(
        by(&report, 6)
            .detail
            .as_deref()
            .unwrap()
            .contains("keep-alive")
    );
    assert_eq!(u32_at(&net, 5, 0x2001, 0), 0);
}

#[test]
fn program_download_updates_the_software() {
    let config = parse(&format!(
        "{MASTER}
[[slave]]
node_id = 5
dcf = \"valve-boot.dcf\"
mandatory = true
[slave.software]
date = \"2026-03-01\"
time = \"10:00:00.000\"
update = true
program = \"valve-v2.bin\"
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    assert_eq!(u32_at(&net, 5, 0x1F52, 1), 15000);
    let mut events = Vec::new();
    let report = boot_with(&net, &config, |e| events.push(e.clone()));
    let s = by(&report, 5);
    assert_eq!(s.status, SlaveStatus::Operational, "{s:?}");
    assert_eq!(s.error_code, None);
    assert_eq!(s.software, SoftwareOutcome::Updated);
    assert!(matches!(s.configuration, ConfigOutcome::Written(_)));
    assert_eq!(u32_at(&net, 5, 0x1F52, 1), 15400);
    assert_eq!(u32_at(&net, 5, 0x1F52, 2), 36_000_000);
    assert_eq!(u32_at(&net, 5, 0x1F51, 1), 1, "the new program runs");
    assert!(events.contains(&BootEvent::StepDone {
        node: node(5),
        step: BootStep::Software
    }));
    assert_eq!(json::slave_json(s)["software"], "updated");

    // The next boot finds the version in place: no second download.
    let again = boot(&net, &config);
    assert_eq!(again.slaves[0].software, SoftwareOutcome::Verified);
}

#[test]
fn program_download_failure_gives_i() {
    let config = parse(&format!(
        "{MASTER}
[[slave]]
node_id = 5
dcf = \"valve-boot.dcf\"
[slave.software]
date = 15400
time = 36000000
update = true
program = \"valve-v2.bin\"
# The program downloads, but is not the version expected.
[[slave]]
node_id = 6
dcf = \"valve-boot.dcf\"
[slave.software]
date = 15401
time = 36000000
update = true
program = \"valve-v2.bin\"
"
    ));
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od5 = factory_dictionary(&config.slaves[0].dictionary);
    let flash_fails = BootLoader::for_dictionary(&od5, node(5))
        .unwrap()
        .refusing(AbortCode::HARDWARE_ERROR);
    bus.attach(SimDevice::new(node(5), od5).with_hook(flash_fails));
    bus.attach(device(
        node(6),
        factory_dictionary(&config.slaves[1].dictionary),
    ));
    let report = boot(&net, &config);
    let s5 = by(&report, 5);
    assert_eq!(s5.error_code, Some(BootErrorCode::I), "{s5:?}");
    assert_eq!(s5.step, Some(BootStep::Software));
    assert_eq!(s5.object.unwrap().to_string(), "0x1F50:01");
    assert_eq!(s5.abort_code, Some(AbortCode::HARDWARE_ERROR.get()));
    assert!(
        s5.detail.as_deref().unwrap().contains("program data"),
        "{s5:?}"
    );
    let s6 = by(&report, 6);
    assert_eq!(s6.error_code, Some(BootErrorCode::I), "{s6:?}");
    assert_eq!(s6.object.unwrap().to_string(), "0x1F52:01");
    assert!(
        s6.detail
            .as_deref()
            .unwrap()
            .contains("after the program download")
    );
    assert_eq!(u32_at(&net, 6, 0x1F52, 1), 15400);
}
