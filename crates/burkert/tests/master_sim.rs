//! Master against the simulated Bürkert device on the in-memory bus (virtual clock): every
//! `BurkertNode` operation and the device behaviour of the Bürkert manual (SPEC-NOTES §1).
//!
//! The scenarios both buses run are in `scenarios/mod.rs` (vcan0 runs them too, in
//! `crates/vcan-tests/tests/burkert_master.rs`); this file adds what the virtual clock can show
//! exactly (heartbeat period, locate duration, PDO counts) and the in-memory-only cases.

mod scenarios;

use canola::mem::{MemoryBus, StationId};
use canola::transport::{Received, Transport};
use canola::{Endpoint, Network};
use canola_burkert::sim::LOCATE_DURATION;
use canola_burkert::{BitRate, BurkertDevice, BurkertNode, CanOperationStatus, Ne107Status};
use canola_frame::{CanFrame, Duration, Instant};
use canola_od::Value as OdValue;
use scenarios::{Device, Master, add_node, node_id as n};

/// The simulated device attached to the in-memory bus (stepped by the bus's own loop).
struct Attached {
    bus: MemoryBus,
    id: StationId<BurkertDevice>,
}

impl Device for Attached {
    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R {
        self.bus.with_station(self.id, f).expect("device attached")
    }
}

/// The master and one simulated device on an in-memory bus, and a passive tap endpoint.
struct Rig {
    m: Master,
    dev: Attached,
    tap: Endpoint,
}

impl Rig {
    /// A device with node-ID `id`, booted up and Pre-Operational.
    fn new(id: u8) -> Self {
        let bus = MemoryBus::new();
        let tap = bus.endpoint();
        let net = Network::new(bus.endpoint());
        let station = bus.attach(BurkertDevice::new(n(id)));
        let mut m = Master::new(net, n(id));
        m.wait_ready();
        Rig {
            m,
            dev: Attached { bus, id: station },
            tap,
        }
    }

    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R {
        self.dev.with(f)
    }

    fn run(&self, ms: u64) {
        self.m
            .net
            .run_for(Duration::from_millis(ms))
            .wait()
            .unwrap();
    }

    /// Frames seen on the bus so far (by the passive tap endpoint).
    fn tapped(&mut self) -> Vec<(Instant, CanFrame)> {
        let mut v = Vec::new();
        while let Ok(Some(r)) = self.tap.try_recv() {
            if let Received::Frame { frame, at } = r {
                v.push((at, frame));
            }
        }
        v
    }
}

fn raw_id(f: &CanFrame) -> u16 {
    match f.id() {
        canola_frame::CanId::Standard(s) => s.as_raw(),
        canola_frame::CanId::Extended(_) => u16::MAX,
    }
}

#[test]
fn boots_pre_operational_with_500ms_heartbeat_and_operation_status_follows_nmt() {
    let mut r = Rig::new(5);
    r.run(2_020);
    let hb: Vec<_> = r
        .tapped()
        .into_iter()
        .filter(|(_, f)| raw_id(f) == 0x705)
        .collect();
    assert_eq!(hb[0].1.data(), [0x00], "boot-up first");
    assert!(hb.len() >= 5, "{hb:?}");
    for w in hb[1..].windows(2) {
        assert_eq!(w[1].1.data(), [0x7F], "pre-operational");
        assert_eq!((w[1].0 - w[0].0).as_millis(), 500, "heartbeat period");
    }
    let comm = r.m.node.read_communication().unwrap();
    assert_eq!(
        comm.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    assert_eq!(comm.address, Some(5));
    assert_eq!(comm.bit_rate, Some(BitRate::Kbit500));
    scenarios::operation_status_follows_nmt(&mut r.m, &r.dev);
}

#[test]
fn description_and_status_in_one_call() {
    let mut r = Rig::new(5);
    scenarios::description_status_communication_and_report(&mut r.m, &r.dev);
}

#[test]
fn reads_of_two_devices_from_two_threads() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for id in [5, 6] {
        bus.attach(BurkertDevice::new(n(id)));
        add_node(&net, n(id));
    }
    let handles: Vec<_> = [5, 6]
        .into_iter()
        .map(|id| {
            let node = BurkertNode::new(net.node(n(id)));
            std::thread::spawn(move || node.read_report().map(|r| r.communication.address))
        })
        .collect();
    let got: Vec<_> = handles
        .into_iter()
        .map(|h| h.join().unwrap().unwrap())
        .collect();
    assert_eq!(got, [Some(5), Some(6)]);
}

#[test]
fn led_mode_and_colours_drive_the_device_led() {
    let mut r = Rig::new(5);
    scenarios::led_mode_and_colours(&mut r.m, &r.dev);
}

#[test]
fn locating_runs_ten_seconds_and_needs_a_zero_before_restart() {
    let mut r = Rig::new(5);
    scenarios::start_locating(&mut r.m, &r.dev);
    r.run(LOCATE_DURATION.as_millis() - 100);
    assert!(r.with(|d| d.locating()), "still flashing at 9.9 s");
    r.run(200);
    assert!(!r.with(|d| d.locating()), "stopped by itself after 10 s");
    scenarios::locating_needs_a_zero_before_restart(&mut r.m, &r.dev);
}

#[test]
fn maintenance_shows_blue_unless_a_higher_priority_event_is_active() {
    let mut r = Rig::new(5);
    scenarios::maintenance(&mut r.m, &r.dev);
}

#[test]
fn logbook_downloads_intact_with_progress() {
    let mut r = Rig::new(5);
    scenarios::logbook(&mut r.m, &r.dev);
}

#[test]
fn node_id_change_and_communication_reset() {
    let mut r = Rig::new(5);
    scenarios::node_id_change(&mut r.m, &r.dev, n(9), n(12));
}

#[test]
fn device_reset_counts_a_boot_and_ends_locate_and_maintenance() {
    let mut r = Rig::new(5);
    scenarios::device_reset(&mut r.m, &r.dev);
}

#[test]
fn bit_rate_change_is_written_and_checked() {
    let mut r = Rig::new(5);
    scenarios::bit_rate(&mut r.m, &r.dev);
}

#[test]
fn sensor_values_arrive_in_tpdos_when_operational() {
    let mut r = Rig::new(5);
    let sent = scenarios::sensor_values_in_tpdos(&mut r.m, &r.dev);
    // Event-driven with inhibit time 500 ms and changing values: about one every 500 ms.
    assert!((4..=7).contains(&sent), "{sent}");
}

#[test]
fn control_values_sent_by_rpdo_reach_the_device() {
    let mut r = Rig::new(5);
    scenarios::control_values_by_rpdo(&mut r.m, &r.dev);
}

#[test]
fn mapping_a_non_mappable_object_is_refused_by_the_device() {
    let r = Rig::new(5);
    scenarios::non_mappable_refused(&r.m, 0x1A01);
}

#[test]
fn demo_walkthrough() {
    let mut r = Rig::new(5);
    scenarios::demo_walkthrough(&mut r.m, &r.dev);
}

#[test]
fn user_configuration_and_precisions() {
    let mut r = Rig::new(5);
    scenarios::user_configuration(&mut r.m, &r.dev);
    scenarios::values_and_precisions(&mut r.m, &r.dev);
}

#[test]
fn termination_and_bus_mode_are_typed_both_ways() {
    let mut r = Rig::new(5);
    scenarios::termination_and_bus_mode(&mut r.m, &r.dev);
}

#[test]
fn ne107_status_is_pdo_mappable_and_sent_on_change() {
    let r = Rig::new(5);
    let sdo = || r.m.node.node().sdo();
    // TPDO2 carries 0x2004 sub 1 (UNSIGNED8), the CiA 301 remap sequence by hand.
    sdo().write((0x1801, 1), 0x8000_0285u32).wait().unwrap();
    sdo().write((0x1A01, 0), 0u8).wait().unwrap();
    sdo().write((0x1A01, 1), 0x2004_0108u32).wait().unwrap();
    sdo().write((0x1A01, 0), 1u8).wait().unwrap();
    sdo().write((0x1801, 1), 0x0000_0285u32).wait().unwrap();
    let events = r.m.net.subscribe();
    r.m.node.node().nmt().start().unwrap();
    r.run(100);
    r.with(|d| d.raise(Ne107Status::FunctionCheck));
    r.run(600);
    let tpdo2: Vec<Vec<u8>> = events
        .try_iter()
        .filter_map(|ev| match ev.pdo_data() {
            Some((_, 2, data)) => Some(data.to_vec()),
            _ => None,
        })
        .collect();
    assert!(tpdo2.contains(&vec![4]), "{tpdo2:?}");
    assert_eq!(tpdo2.last(), Some(&vec![4]));
}

/// The generic EDS with some sections removed (and their object-list lines).
fn eds_without(sections: &[&str]) -> Vec<u8> {
    let mut out = String::new();
    let mut skip = false;
    for line in canola_burkert::GENERIC_EDS.lines() {
        if line.starts_with('[') {
            skip = sections.iter().any(|s| line == format!("[{s}]"));
        }
        if !skip {
            out.push_str(line);
            out.push('\n');
        }
    }
    out.into_bytes()
}

#[test]
fn sub_objects_a_device_lacks_are_none_and_integer_sensors_follow_the_eds() {
    // No battery voltage, no actuator supply voltage; sensor 1 is an INTEGER16.
    let mut text = String::from_utf8(eds_without(&["2004sub10", "2004sub13"])).unwrap();
    text = text.replace(
        "[2501sub1]\nParameterName=Value\nObjectType=0x7\nDataType=0x0008",
        "[2501sub1]\nParameterName=Value\nObjectType=0x7\nDataType=0x0003",
    );
    let od = canola_od::parse(text.as_bytes()).unwrap().od;
    assert_eq!(
        od.sub(0x2501, 1).unwrap().data_type,
        canola_od::DataType::Integer16
    );
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let dev = bus.attach(BurkertDevice::with_dictionary(n(5), od.clone()));
    let node = BurkertNode::new(net.add_node_with_dictionary(n(5), od));
    let status = node.read_status().unwrap();
    assert_eq!(status.battery_voltage, None);
    assert_eq!(status.actuator_voltage, None);
    assert_eq!(status.supply_voltage, Some(24.0));

    bus.with_station(dev, |d| d.pin_sensor(1, 31.6)).unwrap();
    let tpdo = node.map_sensor_values_to_tpdo(1, &[1, 0], None).unwrap();
    assert_eq!(tpdo.mapping().bit_len(), 16 + 32);
    let events = net.subscribe();
    node.node().nmt().start().unwrap();
    net.run_for(Duration::from_millis(700)).wait().unwrap();
    let got: Vec<_> = events
        .try_iter()
        .filter_map(|e| tpdo.from_event(&e))
        .map(Result::unwrap)
        .collect();
    assert!(!got.is_empty());
    for values in &got {
        assert_eq!(values[0].sensor, 1);
        assert_eq!(values[0].value, OdValue::Integer16(32), "31.6 rounded");
        assert_eq!(values[1].sensor, 0);
        assert!(matches!(values[1].value, OdValue::Real32(_)));
    }
    assert_eq!(
        node.read_sensor_value(1).unwrap(),
        canola_od::Value::Integer16(32)
    );
}

#[test]
fn node_id_set_by_lss_becomes_active_at_nmt_reset_and_shows_in_0x2001() {
    let mut r = Rig::new(5);
    let assign = canola_lss::Procedure::assign_node_id(n(20), false);
    scenarios::node_id_by_lss(&mut r.m, &r.dev, n(20), assign);
}

#[test]
fn a_silent_node_fails_with_node_and_object_named() {
    let r = Rig::new(5);
    let ghost = add_node(&r.m.net, n(9));
    let e = ghost.read_description_and_status().unwrap_err();
    let text = e.to_string();
    assert!(text.contains("node 9"), "{text}");
    assert!(text.contains("0x2000"), "{text}");
    assert!(text.contains("no response"), "{text}");
    // The device on node 5 was not disturbed.
    assert_eq!(r.m.node.read_communication().unwrap().address, Some(5));
}
