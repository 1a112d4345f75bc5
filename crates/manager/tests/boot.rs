//! Boot and audit against simulated devices on the in-memory bus, with the failures real
//! devices produce: an absent mandatory slave, a wrong identity, a configuration write the
//! device refuses, an absent optional slave; and an audit over a transport that fails.

use std::path::Path;
use std::sync::atomic::Ordering;

use canola::od::AccessType;
use canola::transport::{Received, Transport, TransportError};
use canola::{MemoryBus, Network, NmtState, NodeId, SimDevice};
use canola_manager::boot::ConfigOutcome;
use canola_manager::simulate::{attach_slaves, factory_dictionary};
use canola_manager::{
    AuditOptions, BootErrorCode, BootEvent, BootStep, NetworkConfig, SlaveStatus, audit, boot,
    boot_with,
};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn load(name: &str) -> NetworkConfig {
    NetworkConfig::load(data(name)).expect("test description")
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

#[test]
fn three_slaves_boot_configure_and_start() {
    let config = load("three.toml");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let mut events = Vec::new();
    let report = boot_with(&net, &config, |e| events.push(e.clone()));
    assert!(report.mandatory_ok);
    for s in &report.slaves {
        assert_eq!(s.status, SlaveStatus::Operational, "{s:?}");
        assert_eq!(s.error_code, None);
        assert!(
            matches!(s.configuration, ConfigOutcome::Written(n) if n >= 3),
            "{s:?}"
        );
        assert!(s.error_control.as_deref().unwrap().starts_with("heartbeat"));
    }
    // The DCF's values are in the devices, $NODEID resolved per node.
    assert_eq!(u32_at(&net, 5, 0x2001, 0), 0x1005);
    assert_eq!(u32_at(&net, 6, 0x2001, 0), 0x1006);
    assert_eq!(u32_at(&net, 7, 0x2000, 0), 321);
    assert_eq!(u32_at(&net, 7, 0x1017, 0), 50);
    assert_eq!(u32_at(&net, 5, 0x1020, 1), 0x2A3F);
    // Parallel: the whole boot takes less network time than the slaves' boots one after another.
    let serial: u64 = report.slaves.iter().map(|s| s.elapsed.as_micros()).sum();
    assert!(report.elapsed.as_micros() < serial, "{report:?}");
    // Every slave reported every step, and the heartbeats now say Operational.
    for n in [5, 6, 7] {
        for step in [
            BootStep::DevicePresent,
            BootStep::Identity,
            BootStep::Configuration,
            BootStep::ErrorControl,
            BootStep::Start,
        ] {
            assert!(
                events.contains(&BootEvent::StepDone {
                    node: node(n),
                    step
                }),
                "node {n} {step:?}"
            );
        }
    }
    net.run_for(canola::Duration::from_millis(300))
        .wait()
        .unwrap();
    for n in [5, 6, 7] {
        assert_eq!(net.last_state(node(n)), Some(NmtState::Operational));
    }

    // A second boot finds 0x1020 in place on the stamped DCF's slaves and skips their configuration.
    let again = boot(&net, &config);
    assert_eq!(again.slaves[0].configuration, ConfigOutcome::Verified);
    assert_eq!(again.slaves[1].configuration, ConfigOutcome::Verified);
    assert!(matches!(
        again.slaves[2].configuration,
        ConfigOutcome::Written(_)
    ));
}

#[test]
fn absent_mandatory_slave_stops_the_start() {
    let config = load("three.toml");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[node(6)]);
    let report = boot(&net, &config);
    assert!(!report.mandatory_ok);
    let s = &report.slaves[1];
    assert_eq!(s.status, SlaveStatus::Absent);
    assert_eq!(s.error_code, Some(BootErrorCode::B));
    assert_eq!(s.step, Some(BootStep::DevicePresent));
    assert_eq!(s.object.unwrap().to_string(), "0x1000:00");
    assert_eq!(s.abort_code, Some(0x0504_0000));
    // No start-all: the others booted but stay pre-operational.
    assert_eq!(report.slaves[0].status, SlaveStatus::PreOperational);
    assert_eq!(report.slaves[2].status, SlaveStatus::PreOperational);
    net.run_for(canola::Duration::from_millis(300))
        .wait()
        .unwrap();
    assert_eq!(net.last_state(node(5)), Some(NmtState::PreOperational));
}

#[test]
fn absent_optional_slave_does_not_stop_the_others() {
    let config = load("three.toml");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[node(7)]);
    let report = boot(&net, &config);
    assert!(report.mandatory_ok);
    assert_eq!(report.slaves[2].status, SlaveStatus::Absent);
    assert_eq!(report.slaves[2].error_code, Some(BootErrorCode::B));
    assert_eq!(report.slaves[0].status, SlaveStatus::Operational);
    assert_eq!(report.slaves[1].status, SlaveStatus::Operational);
    net.run_for(canola::Duration::from_millis(300))
        .wait()
        .unwrap();
    assert_eq!(net.last_state(node(6)), Some(NmtState::Operational));
}

#[test]
fn wrong_identity_gives_its_code() {
    let config = parse(
        r#"
[master]
sdo_timeout_ms = 100
[[slave]]
node_id = 5
dcf = "valve.dcf"
mandatory = true
[slave.identity]
vendor_id = 0x40
[[slave]]
node_id = 6
dcf = "valve.dcf"
[slave.identity]
vendor_id = 0x39
product_code = 0x9999
[[slave]]
node_id = 8
dcf = "valve.dcf"
[slave.identity]
device_type = 0x0192
[[slave]]
node_id = 9
dcf = "valve.dcf"
[slave.identity]
serial = 0x1002
"#,
    );
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    let codes: Vec<_> = report.slaves.iter().map(|s| s.error_code).collect();
    use BootErrorCode::*;
    assert_eq!(codes, [Some(D), Some(M), Some(C), Some(O)]);
    let s = &report.slaves[0];
    assert_eq!(s.status, SlaveStatus::Failed);
    assert_eq!(s.step, Some(BootStep::Identity));
    assert_eq!(s.object.unwrap().to_string(), "0x1018:01");
    assert!(s.detail.as_deref().unwrap().contains("0x00000039"));
    assert!(!report.mandatory_ok);
    // Nothing was configured on a device that is not the one expected.
    assert_eq!(u32_at(&net, 5, 0x2001, 0), 0);
}

#[test]
fn configuration_write_refused_gives_j_with_the_abort() {
    let config = load("three.toml");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    // Node 6's firmware has 0x2002 read-only where its DCF says rw.
    for s in &config.slaves {
        let mut od = factory_dictionary(&s.dictionary);
        if s.node_id == node(6) {
            od.sub_mut(0x2002, 0).unwrap().access = AccessType::Ro;
        }
        bus.attach(SimDevice::new(s.node_id, od));
    }
    let report = boot(&net, &config);
    let s = &report.slaves[1];
    assert_eq!(s.status, SlaveStatus::Failed);
    assert_eq!(s.error_code, Some(BootErrorCode::J));
    assert_eq!(s.step, Some(BootStep::Configuration));
    assert_eq!(s.object.unwrap().to_string(), "0x2002:00");
    assert_eq!(s.abort_code, Some(0x0601_0002));
    assert!(s.detail.as_deref().unwrap().contains("0x06010002"), "{s:?}");
    assert!(!report.mandatory_ok);
}

#[test]
fn audit_finds_a_changed_value_and_fix_repairs_it() {
    let config = load("three.toml");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let stations = attach_slaves(&bus, &config, &[]);
    assert!(boot(&net, &config).mandatory_ok);
    let clean = audit(&net, &config, AuditOptions::default());
    assert!(clean.is_clean(), "{clean:?}");
    assert!(clean.slaves.iter().all(|s| s.checked >= 3));

    // Someone changes node 6's close delay behind the master's back.
    let (_, id6) = stations[1];
    let now = bus.now();
    bus.with_station(id6, |d| d.set_value(now, 0x2001, 0, 77u32.to_le_bytes()));
    let report = audit(&net, &config, AuditOptions::default());
    assert!(!report.is_clean());
    assert!(report.slaves[0].differences.is_empty());
    let d = &report.slaves[1].differences;
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].object.to_string(), "0x2001:00");
    assert_eq!(d[0].name, "Close Delay");
    assert_eq!(d[0].expected.to_string(), "4102");
    assert_eq!(d[0].actual.as_ref().unwrap().to_string(), "77");

    let fixed = audit(
        &net,
        &config,
        AuditOptions {
            fix: true,
            ..AuditOptions::default()
        },
    );
    assert_eq!(fixed.slaves[1].differences[0].fixed, Some(Ok(())));
    assert!(audit(&net, &config, AuditOptions::default()).is_clean());
}

/// The in-memory bus behind a switch: once `failing` is set, every send fails (bus-off) or
/// every receive does (the transport closed).
struct Failing {
    bus: canola::Endpoint,
    failing: std::sync::Arc<std::sync::atomic::AtomicU8>,
}

const SENDS_FAIL: u8 = 1;
const RECEIVES_FAIL: u8 = 2;

impl Transport for Failing {
    fn send(&mut self, frame: &canola::CanFrame) -> Result<(), TransportError> {
        match self.failing.load(Ordering::SeqCst) {
            SENDS_FAIL => Err(TransportError::BusOff),
            _ => self.bus.send(frame),
        }
    }

    fn recv_until(
        &mut self,
        deadline: canola::Instant,
    ) -> Result<Option<Received>, TransportError> {
        match self.failing.load(Ordering::SeqCst) {
            RECEIVES_FAIL => Err(TransportError::Closed),
            _ => self.bus.recv_until(deadline),
        }
    }

    fn now(&self) -> canola::Instant {
        self.bus.now()
    }
}

#[test]
fn audit_over_a_failed_transport_ends_with_every_object_unreadable() {
    let config = load("three.toml");
    for mode in [SENDS_FAIL, RECEIVES_FAIL] {
        let bus = MemoryBus::new();
        let failing = std::sync::Arc::new(std::sync::atomic::AtomicU8::new(0));
        let net = Network::new(Failing {
            bus: bus.endpoint(),
            failing: failing.clone(),
        });
        attach_slaves(&bus, &config, &[]);
        assert!(boot(&net, &config).mandatory_ok);
        failing.store(mode, Ordering::SeqCst);
        let report = audit(&net, &config, AuditOptions::default());
        for s in &report.slaves {
            assert!(s.differences.is_empty(), "{s:?}");
            assert_eq!(s.unreadable.len(), s.checked, "{s:?}");
            for u in &s.unreadable {
                // Nothing arrives once receiving fails: the transport's failure, not a timeout.
                if mode == RECEIVES_FAIL {
                    assert!(u.error.contains("transport is closed"), "{u:?}");
                }
            }
        }
    }
}

#[test]
fn node_guarding_when_no_heartbeat() {
    let config = parse(
        r#"
[master]
sdo_timeout_ms = 100
[[slave]]
node_id = 9
eds = "valve-nostamp.dcf"
mandatory = true
[slave.values]
"0x100C" = 50
"0x100D" = 3
"#,
    );
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    let s = &report.slaves[0];
    assert_eq!(s.status, SlaveStatus::Operational, "{s:?}");
    assert_eq!(s.error_control.as_deref(), Some("guarding 50 ms x 3"));
}

#[test]
fn sixteen_slaves_with_the_failures_of_a_real_line() {
    let mut text = String::from("[master]\nsdo_timeout_ms = 100\nboot_timeout_ms = 200\n");
    for n in 2..=17u8 {
        text.push_str(&format!(
            "[[slave]]\nnode_id = {n}\ndcf = \"valve.dcf\"\nmandatory = {}\n",
            n != 3 && n != 4
        ));
        if n == 3 {
            text.push_str("[slave.identity]\nvendor_id = 0x40\n");
        }
    }
    let config = parse(&text);
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for s in &config.slaves {
        let n = s.node_id.get();
        // 4 is absent; 5's firmware refuses a write; 6 is configured already (0x1020 matches).
        let od = match n {
            4 => continue,
            5 => {
                let mut od = factory_dictionary(&s.dictionary);
                od.sub_mut(0x2002, 0).unwrap().access = AccessType::Ro;
                od
            }
            6 => s.dictionary.clone(),
            _ => factory_dictionary(&s.dictionary),
        };
        bus.attach(SimDevice::new(s.node_id, od));
    }
    let report = boot(&net, &config);
    let by = |n: u8| report.slaves.iter().find(|s| s.node_id == node(n)).unwrap();
    assert_eq!(by(3).error_code, Some(BootErrorCode::D));
    assert_eq!(by(3).status, SlaveStatus::Failed);
    assert_eq!(by(4).status, SlaveStatus::Absent);
    assert_eq!(by(5).error_code, Some(BootErrorCode::J));
    assert_eq!(by(5).abort_code, Some(0x0601_0002));
    // Node 5 is mandatory: no start-all, every booted slave stays pre-operational.
    assert!(!report.mandatory_ok);
    assert_eq!(by(6).configuration, ConfigOutcome::Verified);
    for n in (2..=17).filter(|n| ![3, 4, 5].contains(n)) {
        assert_eq!(by(n).status, SlaveStatus::PreOperational, "node {n}");
        assert_eq!(by(n).error_code, None);
    }
    // In parallel: the boot took about one slave's time, not sixteen.
    let longest = report.slaves.iter().map(|s| s.elapsed).max().unwrap();
    assert!(
        report.elapsed.as_micros() <= longest.as_micros() + 1_000,
        "{report:?}"
    );
}

#[test]
fn boot_from_a_master_dcf_with_concise_dcfs() {
    // The master DCF of three.toml, then a description that lists only node 5 and takes the
    // rest (6 and 7 with their concise DCFs, identity, mandatory flags, start policy) from it.
    let full = load("three.toml");
    let dir = std::env::temp_dir().join(format!("canopen-manager-master-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("master.dcf"),
        canola_manager::master_dcf::MasterObjects::write_master_dcf(&full),
    )
    .unwrap();
    let text = format!(
        "[master]\ndcf = \"master.dcf\"\nsdo_timeout_ms = 100\n[[slave]]\nnode_id = 5\ndcf = \"{}\"\n",
        data("valve.dcf").display()
    );
    std::fs::write(dir.join("bus.toml"), text).unwrap();
    let config = NetworkConfig::load(dir.join("bus.toml")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(config.slaves.len(), 3);
    assert!(
        config.slaves[0].mandatory,
        "0x1F81 says node 5 is mandatory"
    );
    assert_eq!(config.slaves[0].identity.product_code, Some(0x1234));
    assert_eq!(config.slaves[1].node_id, node(6));
    assert!(config.slaves[1].mandatory);
    assert!(!config.slaves[2].mandatory);

    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    // The devices are the real ones (from their full DCFs), fresh from the factory.
    attach_slaves(&bus, &full, &[]);
    let report = boot(&net, &config);
    for s in &report.slaves {
        assert_eq!(s.status, SlaveStatus::Operational, "{s:?}");
    }
    assert_eq!(u32_at(&net, 6, 0x2001, 0), 0x1006);
    assert_eq!(u32_at(&net, 7, 0x2000, 0), 321);
    assert!(audit(&net, &config, AuditOptions::default()).is_clean());
}

#[test]
fn error_control_none_and_asked_for_but_off() {
    let config = parse(
        r#"
[master]
sdo_timeout_ms = 100
start = "individually"
[[slave]]
node_id = 9
eds = "valve-nostamp.dcf"
error_control = "none"
[[slave]]
node_id = 10
eds = "valve-nostamp.dcf"
error_control = "heartbeat"
"#,
    );
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    assert_eq!(report.slaves[0].status, SlaveStatus::Operational);
    assert_eq!(report.slaves[0].error_control, None);
    // Heartbeat asked for, but the slave's 0x1017 is 0: no heartbeat can come (error K).
    assert_eq!(report.slaves[1].error_code, Some(BootErrorCode::K));
    assert_eq!(report.slaves[1].object.unwrap().to_string(), "0x1017:00");
}

#[test]
fn boots_on_a_real_clock_too() {
    // The host's clock, as on SocketCAN: the boot loop drives the bus in real time. Generous
    // timeouts: a loaded machine must not make a present slave look absent.
    let mut config = load("three.toml");
    config.master.sdo_timeout = canola::Duration::from_millis(1000);
    config.master.boot_timeout = canola::Duration::from_millis(1000);
    config.master.heartbeat_consumer_percent = 500;
    let bus = MemoryBus::with_config(canola::BusConfig {
        clock: canola::ClockMode::RealTime,
        bitrate: Some(1_000_000),
        ..canola::BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[node(7)]);
    let report = boot(&net, &config);
    assert_eq!(
        report.slaves[0].status,
        SlaveStatus::Operational,
        "{report:?}"
    );
    assert_eq!(
        report.slaves[1].status,
        SlaveStatus::Operational,
        "{report:?}"
    );
    assert_eq!(report.slaves[2].status, SlaveStatus::Absent, "{report:?}");
}

#[test]
fn late_optional_slave_is_booted_and_a_lost_one_restarted() {
    use canola::transport::{Received, Transport};
    use canola_manager::{SuperviseEvent, supervise};
    let mut config = load("three.toml");
    config.slaves[1].restart_on_loss = true;
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut tap = bus.endpoint();
    let stations = attach_slaves(&bus, &config, &[node(7)]);
    let mut report = boot(&net, &config);
    assert_eq!(report.slaves[2].status, SlaveStatus::Absent);

    // Node 7 is switched on late; node 6 drops off the bus; node 40, which the description
    // does not list, boots.
    bus.attach(SimDevice::new(
        node(7),
        factory_dictionary(&config.slaves[2].dictionary),
    ));
    bus.attach(SimDevice::new(
        node(40),
        factory_dictionary(&config.slaves[2].dictionary),
    ));
    bus.detach(stations[1].1).unwrap();
    let mut seen = Vec::new();
    let until = net.now() + canola::Duration::from_millis(400);
    supervise(&net, &config, &mut report, until, |e| seen.push(e.clone()));
    assert!(
        seen.contains(&SuperviseEvent::Rebooting(node(7))),
        "{seen:?}"
    );
    assert_eq!(
        report.slaves[2].status,
        SlaveStatus::Operational,
        "{report:?}"
    );
    assert_eq!(u32_at(&net, 7, 0x2000, 0), 321);
    assert!(seen.contains(&SuperviseEvent::Reset(node(6))), "{seen:?}");
    assert_eq!(report.slaves[1].status, SlaveStatus::Absent);
    // The unlisted device: error A, not booted, not in the report.
    assert!(
        seen.contains(&SuperviseEvent::NotListed {
            node: node(40),
            code: canola_manager::BootErrorCode::A,
        }),
        "{seen:?}"
    );
    assert!(!seen.contains(&SuperviseEvent::Rebooting(node(40))));
    assert!(report.slaves.iter().all(|r| r.node_id != node(40)));
    // The reset went over the bus: NMT reset communication (0x82) to node 6.
    let mut reset = false;
    while let Ok(Some(r)) = tap.recv_until(bus.now()) {
        if let Received::Frame { frame, .. } = r {
            reset |= frame.id().as_raw() == 0 && frame.data() == [0x82, 6];
        }
    }
    assert!(reset);

    // Node 6 comes back (its boot-up after the reset): booted again.
    bus.attach(SimDevice::new(
        node(6),
        factory_dictionary(&config.slaves[1].dictionary),
    ));
    let until = net.now() + canola::Duration::from_millis(400);
    supervise(&net, &config, &mut report, until, |_| {});
    assert_eq!(
        report.slaves[1].status,
        SlaveStatus::Operational,
        "{report:?}"
    );
    assert_eq!(u32_at(&net, 6, 0x2001, 0), 0x1006);
}

/// A saturated bus: the slaves' configuration writes keep the 1 Mbit/s wire busy, so a
/// request waits in the transmit queue longer than the SDO timeout, times out before it is on
/// the wire, and its answer comes late, during the next transfer to that slave. A late answer
/// must not fail that transfer: every slave boots (before the SDO client dropped late answers
/// of another kind, slaves failed with J and abort 0x05040001 at 0x1017).
#[test]
fn a_saturated_bus_does_not_fail_slaves_with_late_answers() {
    let slaves = 64u8;
    let mut text = String::from("[master]\nsdo_timeout_ms = 100\n");
    for n in 2..2 + slaves {
        text.push_str(&format!(
            "[[slave]]\nnode_id = {n}\neds = \"valve-nostamp.dcf\"\nmandatory = true\n\
             error_control = \"none\"\n[slave.values]\n\"0x1017\" = 0\n"
        ));
    }
    let mut config = parse(&text);
    for s in &mut config.slaves {
        for index in 0x2100u16..0x2100 + 37 {
            let mut sub = canola::od::SubObject::new(
                0,
                format!("Parameter {index:#06x}"),
                canola::DataType::Unsigned32,
                AccessType::Rw,
            );
            sub.default_value =
                Some(canola::od::FieldValue::from_text(canola::DataType::Unsigned32, "0").0);
            sub.extras_mut().parameter_value = Some(
                canola::od::FieldValue::from_text(
                    canola::DataType::Unsigned32,
                    &(u32::from(index) * 3).to_string(),
                )
                .0,
            );
            s.dictionary.insert(canola::od::Object::var(index, sub));
        }
    }
    let bus = MemoryBus::with_config(canola::BusConfig {
        bitrate: Some(1_000_000),
        ..canola::BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    for s in &config.slaves {
        bus.attach(SimDevice::new(s.node_id, factory_dictionary(&s.dictionary)));
    }
    let report = boot(&net, &config);
    let failed: Vec<_> = report.slaves.iter().filter(|s| !s.booted()).collect();
    assert!(failed.is_empty(), "{} failed: {failed:?}", failed.len());
}
