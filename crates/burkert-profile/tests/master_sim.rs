//! Master against the simulated Bürkert device on the in-memory bus (virtual clock): every
//! `BurkertNode` operation and the device behaviour of the Bürkert manual (SPEC-NOTES §1).

use std::sync::{Arc, Mutex};

use burkert_profile::master::generic_od;
use burkert_profile::sim::LOCATE_DURATION;
use burkert_profile::{
    BitRate, BurkertDevice, BurkertNode, CanOperationStatus, LedColour, LedMode, Ne107Status,
    PredefinedColour, ResetCommand, ValveModeColours, ValvePosition, demo,
};
use can_frame::{CanFrame, Duration, Instant, NodeId};
use canopen::mem::{MemoryBus, StationId};
use canopen::transport::{Received, Transport};
use canopen::{Endpoint, Error, Network, NetworkEvent};
use canopen_nmt::DeviceState;
use canopen_pdo::Value as PdoValue;
use canopen_sdo::AbortCode;

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

struct Rig {
    bus: MemoryBus,
    net: Network,
    dev: StationId<BurkertDevice>,
    node: BurkertNode,
    tap: Endpoint,
}

impl Rig {
    fn new(id: u8) -> Self {
        let bus = MemoryBus::new();
        let tap = bus.endpoint();
        let net = Network::new(bus.endpoint());
        let dev = bus.attach(BurkertDevice::new(n(id)));
        let node = BurkertNode::new(net.add_node_with_dictionary(n(id), (**generic_od()).clone()));
        Rig {
            bus,
            net,
            dev,
            node,
            tap,
        }
    }

    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R {
        self.bus.with_station(self.dev, f).expect("device attached")
    }

    fn run(&self, ms: u64) {
        self.net.run_for(Duration::from_millis(ms)).unwrap();
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
        can_frame::CanId::Standard(s) => s.as_raw(),
        can_frame::CanId::Extended(_) => u16::MAX,
    }
}

fn abort(e: &Error) -> Option<u32> {
    e.server_abort().map(|c| c.get())
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
    let comm = r.node.read_communication().unwrap();
    assert_eq!(
        comm.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    assert_eq!(comm.address, Some(5));
    assert_eq!(comm.bit_rate, Some(BitRate::Kbit500));

    r.node.node().nmt().start().unwrap();
    r.run(10);
    assert_eq!(
        r.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::Operational)
    );
    r.node.node().nmt().stop().unwrap();
    r.run(10);
    // No SDO in Stopped: look at the device itself.
    assert_eq!(r.with(|d| d.state()), DeviceState::Stopped);
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 0x0A)), Some(4));
    r.node.node().nmt().enter_preoperational().unwrap();
    r.run(10);
    assert_eq!(
        r.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
}

#[test]
fn description_and_status_in_one_call() {
    let r = Rig::new(5);
    let before = r.with(|d| d.values().clone());
    let (desc, status) = r.node.read_description_and_status().unwrap();
    assert_eq!(desc.device_name.as_deref(), Some("Generic device"));
    assert_eq!(desc.manufacture_date.as_deref(), Some("2026-01-01"));
    assert_eq!(desc.software_version, Some(0x0001_0000));
    assert_eq!(desc.product_group, Some(0));
    assert_eq!(status.ne107, Some(Ne107Status::DiagnosisInactive));
    let t = status.temperature.unwrap();
    assert!((t.celsius() - 20.0).abs() < 1e-3, "{t}");
    assert_eq!(status.supply_voltage, Some(24.0));
    assert_eq!(status.boot_counter, Some(1));
    assert_eq!(
        status.trans_mem,
        Some(burkert_profile::TransMemStatus::Unknown)
    );
    // 9 + 17 reads, no side effects on the device's stored values.
    let after = r.with(|d| d.values().clone());
    assert_eq!(before.get(0x2000, 1), after.get(0x2000, 1));

    r.with(|d| d.raise(Ne107Status::Failure));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::Failure);
    let report = r.node.read_report().unwrap();
    assert_eq!(report.status.ne107, Some(Ne107Status::Failure));
    assert_eq!(report.led_indication().colour, PredefinedColour::Red.into());
}

#[test]
fn reads_of_two_devices_from_two_threads() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for id in [5, 6] {
        bus.attach(BurkertDevice::new(n(id)));
        net.add_node_with_dictionary(n(id), (**generic_od()).clone());
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
    let r = Rig::new(5);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::White.into());

    let turquoise = LedColour::rgb(0, 255, 255);
    r.node.set_external_colour(turquoise).unwrap();
    r.node.set_led_mode(LedMode::FixedColour).unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x2122, 0)), Some(0x00FF_FF00));
    assert_eq!(r.with(|d| d.led().colour), turquoise);

    let colours = ValveModeColours {
        closed: PredefinedColour::Blue.into(),
        between: LedColour::rgb(255, 0, 255),
        open: PredefinedColour::Red.into(),
    };
    r.node.set_valve_colours(&colours).unwrap();
    r.node.set_led_mode(LedMode::Valve).unwrap();
    r.with(|d| d.set_valve_position(Some(ValvePosition::Between)));
    assert_eq!(r.with(|d| d.led().colour), LedColour::rgb(255, 0, 255));
    r.with(|d| d.set_valve_position(Some(ValvePosition::Open)));
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Red.into());

    let cfg = r.node.read_led_config().unwrap();
    assert_eq!(cfg.mode, LedMode::Valve);
    assert_eq!(cfg.valve, colours);
    assert_eq!(cfg.external, turquoise);

    r.node.set_led_mode(LedMode::Off).unwrap();
    assert_eq!(r.with(|d| d.led().colour), LedColour::OFF);

    // Undefined values are refused by the device, and the error names node, object, abort.
    let e = r.node.node().sdo().write((0x2120, 0), 5u32).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
    let text = e.to_string();
    assert!(text.contains("node 5"), "{text}");
    assert!(text.contains("0x2120"), "{text}");
    assert!(text.contains("0x06090030"), "{text}");
    let e = r
        .node
        .node()
        .sdo()
        .write((0x2122, 0), 0x1000_0007u32)
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
    assert_eq!(r.node.read_led_config().unwrap().mode, LedMode::Off);
}

#[test]
fn locating_runs_ten_seconds_and_needs_a_zero_before_restart() {
    let r = Rig::new(5);
    r.node.start_locating().unwrap();
    assert!(r.with(|d| d.locating()));
    assert!(r.with(|d| d.led().flashing));
    r.run(LOCATE_DURATION.as_millis() - 100);
    assert!(r.with(|d| d.locating()), "still flashing at 9.9 s");
    r.run(200);
    assert!(!r.with(|d| d.locating()), "stopped by itself after 10 s");
    assert!(r.node.locating().unwrap(), "the object still reads 1");

    // Writing 1 over the standing 1 starts nothing (the manual's rule) ...
    r.node.node().sdo().write((0x2101, 1), 1u8).unwrap();
    assert!(!r.with(|d| d.locating()));
    // ... BurkertNode::start_locating writes 0 first, so it does start.
    r.node.start_locating().unwrap();
    assert!(r.with(|d| d.locating()));
    r.node.stop_locating().unwrap();
    assert!(!r.with(|d| d.locating()));
    assert!(!r.node.locating().unwrap());
    let e = r.node.node().sdo().write((0x2101, 1), 2u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
}

#[test]
fn maintenance_shows_blue_unless_a_higher_priority_event_is_active() {
    let r = Rig::new(5);
    r.node.set_maintenance(true).unwrap();
    assert!(r.node.maintenance().unwrap());
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Blue.into());

    // A lower-priority event does not change it.
    r.with(|d| d.raise(Ne107Status::DiagnosisActive));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);

    r.with(|d| d.raise(Ne107Status::OutOfSpecification));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::OutOfSpecification);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Yellow.into());
    r.with(|d| d.raise(Ne107Status::Failure));
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Red.into());

    r.with(|d| {
        d.clear(Ne107Status::Failure);
        d.clear(Ne107Status::OutOfSpecification);
    });
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    r.node.set_maintenance(false).unwrap();
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::DiagnosisActive);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Green.into());
    r.with(|d| d.clear(Ne107Status::DiagnosisActive));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::DiagnosisInactive);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::White.into());
}

#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Shared {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn logbook_downloads_intact_with_progress() {
    let r = Rig::new(5);
    r.node.set_maintenance(true).unwrap();
    let expected = r.with(|d| d.logbook_xml());
    assert!(
        expected.len() > 2048 && expected.len() < 16 * 1024,
        "{}",
        expected.len()
    );
    let text = String::from_utf8(expected.clone()).unwrap();
    assert!(text.starts_with("<?xml"));
    assert!(text.contains("maintenance state entered"));
    assert!(text.trim_end().ends_with("</logbook>"));

    for block in [true, false] {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = seen.clone();
        let out = Shared::default();
        let len = r
            .node
            .download_logbook(out.clone(), block, move |p| {
                s2.lock().unwrap().push((p.done, p.total))
            })
            .unwrap();
        assert_eq!(len, expected.len() as u64);
        assert_eq!(*out.0.lock().unwrap(), expected, "block {block}");
        let seen = seen.lock().unwrap();
        assert!(seen.len() > 3, "{seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "monotonic");
        assert_eq!(seen.last().unwrap().1, Some(expected.len() as u64));
        assert_eq!(seen.last().unwrap().0, expected.len() as u64);
    }
    let mem = r.node.read_logbook(false, |_| {}).unwrap();
    assert_eq!(mem, expected);
}

#[test]
fn node_id_change_and_communication_reset() {
    let mut r = Rig::new(5);
    r.node.set_led_mode(LedMode::FixedColour).unwrap();
    let new = r.node.change_node_id(n(9)).unwrap();
    r.run(50);
    assert_eq!(r.with(|d| d.node()), n(9));
    let frames = r.tapped();
    assert!(
        frames
            .iter()
            .any(|(_, f)| raw_id(f) == 0x709 && f.data() == [0x00]),
        "boot-up under the new node-ID"
    );
    assert_eq!(new.id(), n(9));
    let comm = new.read_communication().unwrap();
    assert_eq!(comm.address, Some(9));
    assert_eq!(
        comm.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    // Profile settings survive, communication objects follow the new node-ID.
    assert_eq!(new.read_led_config().unwrap().mode, LedMode::FixedColour);
    assert_eq!(
        new.node().sdo().read((0x1800, 1)).unwrap(),
        0x189u32.to_le_bytes()
    );
    assert_eq!(new.node().sdo().read((0x2001, 4)).unwrap(), [0]);
    // The old ID is silent.
    let e = r
        .node
        .node()
        .sdo()
        .timeout(Duration::from_millis(100))
        .read((0x1000, 0))
        .unwrap_err();
    assert!(e.to_string().contains("no response"), "{e}");

    // NMT reset communication applies a stored node-ID too.
    new.set_node_id(n(12)).unwrap();
    new.node().nmt().reset_communication().unwrap();
    r.run(50);
    assert_eq!(r.with(|d| d.node()), n(12));
}

#[test]
fn device_reset_counts_a_boot_and_ends_locate_and_maintenance() {
    let r = Rig::new(5);
    r.node.set_maintenance(true).unwrap();
    r.node.start_locating().unwrap();
    r.node.reset(ResetCommand::Device).unwrap();
    r.run(20);
    let report = r.node.read_report().unwrap();
    assert_eq!(report.status.boot_counter, Some(2));
    assert!(!report.maintenance);
    assert!(!report.locating);
    assert!(!r.with(|d| d.locating()));
    assert_eq!(report.status.ne107, Some(Ne107Status::DiagnosisInactive));
    let log = String::from_utf8(r.node.read_logbook(true, |_| {}).unwrap()).unwrap();
    assert!(log.contains("device reset, node-ID 5"), "{log}");
    let e = r.node.node().sdo().write((0x2001, 4), 3u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
}

#[test]
fn bit_rate_change_is_written_and_checked() {
    let r = Rig::new(5);
    r.node.set_bit_rate(BitRate::Kbit125).unwrap();
    assert_eq!(
        r.node.read_communication().unwrap().bit_rate,
        Some(BitRate::Kbit125)
    );
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 1)), Some(4));
    // Not offered by Bürkert: refused before any write ...
    let e = r.node.set_bit_rate(BitRate::Kbit800).unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    // ... and by the device when written raw.
    let e = r.node.node().sdo().write((0x2001, 1), 5u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 1)), Some(4));
}

#[test]
fn sensor_values_arrive_in_tpdos_when_operational() {
    let r = Rig::new(5);
    r.with(|d| d.pin_sensor(2, 42.5));
    // Three REAL32 need 96 bits: refused before anything is written.
    let e = r
        .node
        .map_sensor_values_to_tpdo(1, &[0, 1, 2], None)
        .unwrap_err();
    assert!(e.to_string().contains("64"), "{e}");
    let tpdo = r.node.map_sensor_values_to_tpdo(1, &[2, 3], None).unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 1)), Some(0x2502_0120));
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 2)), Some(0x2503_0120));
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 0)), Some(2));
    assert_eq!(tpdo.cob_id() & 0x7FF, 0x185);

    let events = r.net.subscribe();
    r.run(3_000);
    let pdos = |rx: &std::sync::mpsc::Receiver<NetworkEvent>| -> Vec<Vec<(u8, PdoValue)>> {
        rx.try_iter()
            .filter_map(|ev| tpdo.from_event(&ev))
            .map(|res| {
                res.unwrap()
                    .into_iter()
                    .map(|s| (s.sensor, s.value))
                    .collect()
            })
            .collect()
    };
    assert!(pdos(&events).is_empty(), "no PDOs in pre-operational");

    r.node.node().nmt().start().unwrap();
    r.run(3_000);
    let got = pdos(&events);
    // Event-driven with inhibit time 500 ms and changing values: about one every 500 ms.
    assert!((4..=7).contains(&got.len()), "{}", got.len());
    for values in &got {
        assert_eq!(values[0], (2, PdoValue::Real32(42.5)));
        let PdoValue::Real32(v) = values[1].1 else {
            panic!("{values:?}")
        };
        assert_eq!(values[1].0, 3);
        assert!((45.0..=55.0).contains(&v), "{v}");
    }
    assert_ne!(
        got[0][1],
        got[got.len() - 1][1],
        "sensor 3 changes over time"
    );
    // The same value by SDO.
    assert_eq!(
        r.node.read_sensor_value(2).unwrap(),
        canopen_od::Value::Real32(42.5)
    );
}

#[test]
fn control_values_sent_by_rpdo_reach_the_device() {
    let r = Rig::new(5);
    let rpdo = r.node.map_control_values_to_rpdo(1, &[1, 0], None).unwrap();
    assert_eq!(rpdo.cob_id() & 0x7FF, 0x205);
    assert_eq!(r.with(|d| d.values().get_u64(0x1600, 1)), Some(0x2541_0120));
    let values = [PdoValue::Real32(-3.25), PdoValue::Real32(1.5)];

    // Pre-operational: ignored.
    r.node.send_control_values(&rpdo, &values).unwrap();
    r.run(10);
    assert_eq!(r.with(|d| d.control_value(1)), Some(0.0));
    assert_eq!(r.with(|d| d.control_value(0)), Some(0.0));

    r.node.node().nmt().start().unwrap();
    r.run(10);
    r.node.send_control_values(&rpdo, &values).unwrap();
    r.run(10);
    assert_eq!(r.with(|d| d.control_value(1)), Some(-3.25));
    assert_eq!(r.with(|d| d.control_value(0)), Some(1.5));
    assert_eq!(
        r.node.read_control_value(1).unwrap(),
        canopen_od::Value::Real32(-3.25)
    );
    // A wrong value type is a local error.
    assert!(
        r.node
            .send_control_values(&rpdo, &[PdoValue::Bool(true)])
            .is_err()
    );
}

#[test]
fn mapping_a_non_mappable_object_is_refused_by_the_device() {
    let r = Rig::new(5);
    let sdo = || r.node.node().sdo();
    sdo().write((0x1A01, 1), 0x2500_0620u32).unwrap(); // precision: not PDO-mappable
    let e = sdo().write((0x1A01, 0), 1u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::NOT_MAPPABLE.get()));
}

#[test]
fn demo_walkthrough() {
    let r = Rig::new(5);
    let mut out = Vec::new();
    let summary = demo::run_with(
        &r.net,
        n(5),
        &mut out,
        demo::Options {
            ansi: false,
            block: true,
        },
    )
    .unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("Generic device"), "{text}");
    assert!(text.contains("diagnosis inactive"), "{text}");
    assert!(text.contains("white / weiß"), "{text}");
    assert!(text.contains("Locate started"), "{text}");
    assert!(text.contains("(flashing)"), "{text}");
    assert!(text.contains("##############################]"), "{text}");
    assert!(!text.contains('\x1b'));
    assert!(summary.logbook.starts_with(b"<?xml"));
    let len = summary.logbook.len() as u64;
    assert_eq!(summary.progress.last(), Some(&(len, Some(len))));
    assert!(r.with(|d| d.locating()));

    let mut out = Vec::new();
    demo::run(&r.net, n(5), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("\x1b[48;2;255;255;255m"), "{text}");
}

#[test]
fn user_configuration_and_precisions() {
    let r = Rig::new(5);
    let u = r.node.read_user_configuration().unwrap();
    assert_eq!(u.number_of_entries, 5);
    assert_eq!(u.static_node_id, Some(0));
    r.node
        .set_location("Hall 3, line 7, valve island A")
        .unwrap();
    r.node.set_user_description("dosing valve").unwrap();
    r.node.set_displayed_name("V-307").unwrap();
    r.node.set_static_node_id(Some(n(21))).unwrap();
    // The manual's sub 0 = 4 is accepted as well.
    r.with(|d| d.values_mut().set(0x2002, 0, vec![4]));
    let u = r.node.read_user_configuration().unwrap();
    assert_eq!(u.number_of_entries, 4);
    assert_eq!(
        u.location.as_deref(),
        Some("Hall 3, line 7, valve island A")
    );
    assert_eq!(u.user_description.as_deref(), Some("dosing valve"));
    assert_eq!(u.displayed_name.as_deref(), Some("V-307"));
    assert_eq!(u.static_node_id, Some(21));
    r.with(|d| d.values_mut().set(0x2002, 0, vec![3]));
    let e = r.node.read_user_configuration().unwrap_err();
    assert!(e.to_string().contains("0x2002"), "{e}");

    assert_eq!(r.node.read_sensor_precision(0).unwrap(), 0.01);
    assert_eq!(r.node.read_control_precision(3).unwrap(), 0.01);
    let e = r.node.read_sensor_precision(9).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::OBJECT_DOES_NOT_EXIST.get()));
    assert!(r.node.read_sensor_precision(64).is_err());
}

#[test]
fn termination_and_bus_mode_are_typed_both_ways() {
    use burkert_profile::{BusMode, Termination};
    let r = Rig::new(5);
    r.node.set_termination(Termination::Active).unwrap();
    r.node.set_bus_mode(BusMode::CanOpen).unwrap();
    let c = r.node.read_communication().unwrap();
    assert_eq!(c.termination, Some(Termination::Active));
    assert_eq!(c.bus_mode, Some(BusMode::CanOpen));
    let e = r.node.node().sdo().write((0x2001, 0x0B), 2u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
    let e = r.node.node().sdo().write((0x2001, 3), 7u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE.get()));
    // A value the manual does not define, stored behind the master's back, is a typed error.
    r.with(|d| d.values_mut().set(0x2001, 0x0B, vec![9]));
    let e = r.node.read_communication().unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    assert!(e.to_string().contains("termination value 9"), "{e}");
}

#[test]
fn ne107_status_is_pdo_mappable_and_sent_on_change() {
    let r = Rig::new(5);
    let sdo = || r.node.node().sdo();
    // TPDO2 carries 0x2004 sub 1 (UNSIGNED8), the CiA 301 remap sequence by hand.
    sdo().write((0x1801, 1), 0x8000_0285u32).unwrap();
    sdo().write((0x1A01, 0), 0u8).unwrap();
    sdo().write((0x1A01, 1), 0x2004_0108u32).unwrap();
    sdo().write((0x1A01, 0), 1u8).unwrap();
    sdo().write((0x1801, 1), 0x0000_0285u32).unwrap();
    let events = r.net.subscribe();
    r.node.node().nmt().start().unwrap();
    r.run(100);
    r.with(|d| d.raise(Ne107Status::FunctionCheck));
    r.run(600);
    let tpdo2: Vec<Vec<u8>> = events
        .try_iter()
        .filter_map(|ev| match ev {
            NetworkEvent::Pdo {
                number: 2, data, ..
            } => Some(data),
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
    for line in burkert_profile::GENERIC_EDS.lines() {
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
    let od = canopen_od::parse(text.as_bytes()).unwrap().od;
    assert_eq!(
        od.sub(0x2501, 1).unwrap().data_type,
        canopen_od::DataType::Integer16
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
    net.run_for(Duration::from_millis(700)).unwrap();
    let got: Vec<_> = events
        .try_iter()
        .filter_map(|e| tpdo.from_event(&e))
        .map(Result::unwrap)
        .collect();
    assert!(!got.is_empty());
    for values in &got {
        assert_eq!(values[0].sensor, 1);
        assert_eq!(values[0].value, PdoValue::Signed(32), "31.6 rounded");
        assert_eq!(values[1].sensor, 0);
        assert!(matches!(values[1].value, PdoValue::Real32(_)));
    }
    assert_eq!(
        node.read_sensor_value(1).unwrap(),
        canopen_od::Value::Integer16(32)
    );
}

#[test]
fn node_id_set_by_lss_becomes_active_at_nmt_reset_and_shows_in_0x2001() {
    let r = Rig::new(5);
    r.node.set_led_mode(LedMode::Off).unwrap();
    r.net
        .lss()
        .procedure(canopen_lss::Procedure::assign_node_id(n(20), false))
        .unwrap();
    r.node.node().nmt().reset_communication().unwrap();
    r.run(50);
    assert_eq!(r.with(|d| d.node()), n(20));
    let new = BurkertNode::new(
        r.net
            .add_node_with_dictionary(n(20), (**generic_od()).clone()),
    );
    assert_eq!(new.read_communication().unwrap().address, Some(20));
    assert_eq!(new.read_led_config().unwrap().mode, LedMode::Off);

    // NMT reset node keeps the node-ID and the stored settings, ends maintenance.
    new.set_maintenance(true).unwrap();
    new.node().nmt().reset_node().unwrap();
    r.run(50);
    let report = new.read_report().unwrap();
    assert_eq!(report.communication.address, Some(20));
    assert!(!report.maintenance);
    assert_eq!(report.status.boot_counter, Some(2));
    assert_eq!(report.led.mode, LedMode::Off);
}

#[test]
fn a_silent_node_fails_with_node_and_object_named() {
    let r = Rig::new(5);
    let ghost = BurkertNode::new(
        r.net
            .add_node_with_dictionary(n(9), (**generic_od()).clone()),
    );
    let e = ghost.read_description_and_status().unwrap_err();
    let text = e.to_string();
    assert!(text.contains("node 9"), "{text}");
    assert!(text.contains("0x2000"), "{text}");
    assert!(text.contains("no response"), "{text}");
    // The device on node 5 was not disturbed.
    assert_eq!(r.node.read_communication().unwrap().address, Some(5));
}
