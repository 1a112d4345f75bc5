//! The master-against-simulator scenarios of the Bürkert profile, written once for both buses:
//! `crates/burkert/tests/master_sim.rs` runs them on the in-memory bus (virtual clock),
//! `crates/vcan-tests/tests/burkert_master.rs` on vcan0 in the QEMU rig (real clock; it includes
//! this file with `#[path]`).
//!
//! Each scenario drives `BurkertNode` operations against a `BurkertDevice` and checks both
//! sides: what the master decodes is compared with the device's own state, what it writes or
//! sends is looked up in the device. Waiting is done on the network's events (boot-up,
//! heartbeat states) or for a stretch of the network's clock, so the same code runs on a virtual
//! and on a real clock. What only one bus can show (exact heartbeat periods on the virtual clock,
//! real time passing while the device locates) stays in that bus's own file.

use std::io::Read;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};

use canola::{Error, Network, NetworkEvent};
use canola_burkert::master::{SensorTpdo, generic_od};
use canola_burkert::objects::{self, device_communication_object as comm};
use canola_burkert::{
    BitRate, BurkertDevice, BurkertNode, BusMode, CanOperationStatus, EdsVersion, LedColour,
    LedMode, Ne107Status, PredefinedColour, ResetCommand, Termination, TransMemStatus,
    ValveModeColours, ValvePosition, demo,
};
use canola_frame::{Duration, NodeId};
use canola_lss::{BitTiming, LssError, Procedure, ResponseError, Service};
use canola_nmt::{DeviceState, HeartbeatEvent, NmtState};
use canola_od::Value as OdValue;
use canola_pdo::{CommParams, TransmissionType, ValueKind};
use canola_sdo::AbortCode;

/// Node-ID `id` (1..=127).
pub(crate) fn node_id(id: u8) -> NodeId {
    NodeId::new(id).expect("node-ID 1..=127")
}

/// The SDO abort code the device answered with, if that is what `e` is.
pub(crate) fn abort(e: &Error) -> Option<AbortCode> {
    e.server_abort()
}

/// How a test reaches into the simulated device (to look at its state, raise NE 107 events,
/// pin sensors, set the valve position) while the bus serves it.
pub(crate) trait Device {
    /// Runs `f` on the device, between two of its steps.
    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R;
}

/// The master side of a rig: the network, its event stream and the profile view of the
/// device's node.
pub(crate) struct Master {
    /// The node-ID the device was started with.
    id: NodeId,
    pub(crate) net: Network,
    pub(crate) node: BurkertNode,
    events: Receiver<NetworkEvent>,
    /// Every event drained so far (for the assertion messages).
    seen: Vec<NetworkEvent>,
}

impl Master {
    /// The master for a device with node-ID `id` on `net`; subscribes to the network's events
    /// and watches the device's heartbeat (500 ms, the Bürkert EDS's 0x1017 default).
    pub(crate) fn new(net: Network, id: NodeId) -> Self {
        let events = net.subscribe();
        net.monitor_heartbeat(id, Duration::from_millis(2_000));
        let node = add_node(&net, id);
        Master {
            id,
            net,
            node,
            events,
            seen: Vec::new(),
        }
    }

    /// The node-ID the device was started with.
    pub(crate) fn id(&self) -> NodeId {
        self.id
    }

    /// Waits for the device's boot-up and its first Pre-Operational heartbeat.
    pub(crate) fn wait_ready(&mut self) {
        let id = self.id();
        self.wait_boot_up(id);
        self.wait_state(id, NmtState::PreOperational);
    }

    /// Drives the network for up to `limit` until an event satisfies `want`; returns it.
    pub(crate) fn wait_event(
        &mut self,
        limit: Duration,
        what: &str,
        want: impl Fn(&NetworkEvent) -> bool,
    ) -> NetworkEvent {
        let deadline = self.net.now() + limit;
        while self.net.now() < deadline {
            self.net
                .run_for(Duration::from_millis(50))
                .wait()
                .expect("drive the network");
            while let Ok(e) = self.events.try_recv() {
                let hit = want(&e);
                self.seen.push(e.clone());
                if hit {
                    return e;
                }
            }
        }
        panic!(
            "no {what} within {limit:?}; events seen: {:?}",
            self.seen.iter().rev().take(20).collect::<Vec<_>>()
        );
    }

    /// Waits for the boot-up message (heartbeat 0x00) of node `id`.
    pub(crate) fn wait_boot_up(&mut self, id: NodeId) {
        self.wait_event(Duration::from_secs(15), "boot-up", |e| {
            *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: id })
        });
    }

    /// Waits for a heartbeat of node `id` reporting `state`.
    pub(crate) fn wait_state(&mut self, id: NodeId, state: NmtState) {
        self.wait_event(
            Duration::from_secs(15),
            &format!("heartbeat {state:?} of node {id}"),
            |e| {
                matches!(e, NetworkEvent::Heartbeat(
                    HeartbeatEvent::StateChanged { node: n, to, .. }
                    | HeartbeatEvent::Recovered { node: n, state: to }) if *n == id && *to == state)
            },
        );
        assert_eq!(self.net.last_state(id), Some(state));
    }

    /// Drives the network for `d` and returns the events that arrived meanwhile.
    pub(crate) fn collect_for(&mut self, d: Duration) -> Vec<NetworkEvent> {
        let deadline = self.net.now() + d;
        let mut got = Vec::new();
        while self.net.now() < deadline {
            self.net
                .run_for(Duration::from_millis(50))
                .wait()
                .expect("drive the network");
            got.extend(self.events.try_iter());
        }
        self.seen.extend(got.iter().cloned());
        got
    }
}

/// The profile view of node `id` on `net`, with the generic Bürkert dictionary.
pub(crate) fn add_node(net: &Network, id: NodeId) -> BurkertNode {
    BurkertNode::new(net.add_node_with_dictionary(id, (**generic_od()).clone()))
}

/// Description, status, communication and the whole report: the generic EDS's defaults, then
/// values set in the device; a fault raised in the device in the status, report and LED colour.
pub(crate) fn description_status_communication_and_report(m: &mut Master, dev: &impl Device) {
    let id = m.id();
    assert_eq!(m.node.id(), id);
    assert_eq!(m.node.node().id(), id);

    // The whole description and status: 9 + 17 SDO reads submitted together, without side
    // effects on the device's stored values.
    let before = dev.with(|d| d.values().clone());
    let (desc, status) = m.node.read_description_and_status().unwrap();
    assert_eq!(desc.device_name.as_deref(), Some("Generic device"));
    assert_eq!(desc.manufacture_date.as_deref(), Some("2026-01-01"));
    assert_eq!(desc.software_version, Some(0x0001_0000));
    assert_eq!(desc.product_group, Some(0));
    assert_eq!(status.ne107, Some(Ne107Status::DiagnosisInactive));
    let t = status.temperature.expect("0x2004 sub 2");
    assert!((t.celsius() - 20.0).abs() < 1e-3, "{t}");
    let dev_t = dev
        .with(|d| d.values().get(0x2004, 2).map(<[u8]>::to_vec))
        .unwrap();
    assert_eq!(t.0.to_le_bytes().to_vec(), dev_t, "temperature in kelvin");
    assert_eq!(status.supply_voltage, Some(24.0));
    assert_eq!(status.boot_counter, Some(1));
    assert_eq!(status.trans_mem, Some(TransMemStatus::Unknown));
    assert!(status.time_since_boot_s.is_some());
    let after = dev.with(|d| d.values().clone());
    assert_eq!(before.get(0x2000, 1), after.get(0x2000, 1));

    // Values the device holds come back typed.
    dev.with(|d| {
        let v = d.values_mut();
        v.set(0x2000, 1, b"Type 8681 valve top".to_vec());
        v.set(0x2000, 2, 0x0012_3456u32.to_le_bytes().to_vec());
        v.set(0x2000, 7, 0x00C0_FFEEu32.to_le_bytes().to_vec());
        v.set(0x2000, 9, vec![7]);
        v.set(0x2004, 3, 23.5f32.to_le_bytes().to_vec());
    });
    let (desc, status) = m.node.read_description_and_status().unwrap();
    assert_eq!(desc.device_name.as_deref(), Some("Type 8681 valve top"));
    assert_eq!(desc.ident_number, Some(0x0012_3456));
    assert_eq!(desc.serial_number, Some(0x00C0_FFEE));
    assert_eq!(desc.product_group, Some(7));
    assert_eq!(desc.manufacture_date.as_deref(), Some("2026-01-01"));
    let dev_sw = dev.with(|d| d.values().get_u64(0x2000, 5)).unwrap();
    assert_eq!(desc.software_version.map(u64::from), Some(dev_sw));
    assert_eq!(status.supply_voltage, Some(23.5));
    assert_eq!(m.node.read_description().unwrap(), desc);
    let again = m.node.read_status().unwrap();
    assert_eq!(again.supply_voltage, Some(23.5));
    assert_eq!(again.boot_counter, Some(1));

    let c = m.node.read_communication().unwrap();
    assert_eq!(c.address, Some(id.get()));
    assert_eq!(c.bit_rate, Some(BitRate::Kbit500));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    let dev_eds = dev.with(|d| d.values().get_u64(0x2001, 0x0D)).unwrap();
    assert_eq!(c.eds_version, Some(EdsVersion::from_u8(dev_eds as u8)));

    // Generic typed access through the generated entries.
    assert_eq!(m.node.read(comm::ADDRESS).unwrap(), id.get());
    m.node.write(objects::LED_MODE, &4).unwrap();
    assert_eq!(dev.with(|d| d.values().get_u64(0x2120, 0)), Some(4));
    m.node.write(objects::LED_MODE, &0).unwrap();

    // A fault raised in the device shows in the status, the report and its LED colour.
    dev.with(|d| d.raise(Ne107Status::Failure));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::Failure);
    let report = m.node.read_report().unwrap();
    assert_eq!(report.description, desc);
    assert_eq!(report.status.ne107, Some(Ne107Status::Failure));
    assert_eq!(report.communication.address, Some(id.get()));
    assert_eq!(report.led.mode, LedMode::Namur);
    assert!(!report.locating);
    assert!(!report.maintenance);
    assert_eq!(report.led_indication().colour, PredefinedColour::Red.into());
    assert_eq!(report.led_indication(), dev.with(|d| d.led()));
    dev.with(|d| d.clear(Ne107Status::Failure));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::DiagnosisInactive);
}

/// 0x2001 sub 0x0A follows the NMT state the heartbeat reports.
pub(crate) fn operation_status_follows_nmt(m: &mut Master, dev: &impl Device) {
    let id = m.id();
    m.node.node().nmt().start().unwrap();
    m.wait_state(id, NmtState::Operational);
    assert_eq!(
        m.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::Operational)
    );
    m.node.node().nmt().stop().unwrap();
    m.wait_state(id, NmtState::Stopped);
    // No SDO in Stopped: look at the device itself.
    assert_eq!(dev.with(|d| d.state()), DeviceState::Stopped);
    assert_eq!(dev.with(|d| d.values().get_u64(0x2001, 0x0A)), Some(4));
    m.node.node().nmt().enter_preoperational().unwrap();
    m.wait_state(id, NmtState::PreOperational);
    assert_eq!(
        m.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
}

/// 0x2002: location, description, displayed name and static node-ID written and read back;
/// the manual's sub 0 = 4 accepted, another count refused.
pub(crate) fn user_configuration(m: &mut Master, dev: &impl Device) {
    let u = m.node.read_user_configuration().unwrap();
    assert_eq!(u.number_of_entries, 5);
    assert_eq!(u.static_node_id, Some(0));

    m.node
        .set_location("Hall 3, line 7, valve island A")
        .unwrap();
    m.node.set_user_description("dosing valve").unwrap();
    m.node.set_displayed_name("V-307").unwrap();
    m.node.set_static_node_id(Some(node_id(21))).unwrap();
    assert_eq!(
        dev.with(|d| d.values().get(0x2002, 2).map(<[u8]>::to_vec)),
        Some(b"Hall 3, line 7, valve island A".to_vec())
    );
    assert_eq!(dev.with(|d| d.values().get_u64(0x2002, 5)), Some(21));
    for entries in [5, 4] {
        // The manual's sub 0 = 4 is accepted as well.
        dev.with(|d| d.values_mut().set(0x2002, 0, vec![entries]));
        let u = m.node.read_user_configuration().unwrap();
        assert_eq!(u.number_of_entries, entries);
        assert_eq!(
            u.location.as_deref(),
            Some("Hall 3, line 7, valve island A")
        );
        assert_eq!(u.user_description.as_deref(), Some("dosing valve"));
        assert_eq!(u.displayed_name.as_deref(), Some("V-307"));
        assert_eq!(u.static_node_id, Some(21));
    }
    dev.with(|d| d.values_mut().set(0x2002, 0, vec![3]));
    let e = m.node.read_user_configuration().unwrap_err();
    assert!(e.to_string().contains("0x2002"), "{e}");
    dev.with(|d| d.values_mut().set(0x2002, 0, vec![5]));

    m.node.set_static_node_id(None).unwrap();
    assert_eq!(dev.with(|d| d.values().get_u64(0x2002, 5)), Some(0));
    assert_eq!(
        m.node.read_user_configuration().unwrap().static_node_id,
        Some(0)
    );
}

/// 0x2001 termination and bus mode: typed both ways, undefined values refused by the device,
/// one stored behind the master's back a typed error.
pub(crate) fn termination_and_bus_mode(m: &mut Master, dev: &impl Device) {
    m.node.set_termination(Termination::Active).unwrap();
    m.node.set_bus_mode(BusMode::CanOpen).unwrap();
    let c = m.node.read_communication().unwrap();
    assert_eq!(c.termination, Some(Termination::Active));
    assert_eq!(c.bus_mode, Some(BusMode::CanOpen));
    assert_eq!(dev.with(|d| d.values().get_u64(0x2001, 0x0B)), Some(1));
    assert_eq!(dev.with(|d| d.values().get_u64(0x2001, 3)), Some(0));
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2001, 0x0B), 2u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2001, 3), 7u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");

    dev.with(|d| d.values_mut().set(0x2001, 0x0B, vec![9]));
    let e = m.node.read_communication().unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    assert!(e.to_string().contains("termination value 9"), "{e}");
    dev.with(|d| d.values_mut().set(0x2001, 0x0B, vec![1]));
    assert_eq!(
        m.node.read_communication().unwrap().termination,
        Some(Termination::Active)
    );
}

/// Sensor and control values by SDO, typed by the EDS (REAL32) and equal to the device's; their
/// precisions.
pub(crate) fn values_and_precisions(m: &mut Master, dev: &impl Device) {
    dev.with(|d| {
        d.values_mut()
            .set(0x2503, 6, 0.125f32.to_le_bytes().to_vec());
        d.pin_sensor(1, 12.75);
    });
    assert_eq!(m.node.read_sensor_value(1).unwrap(), OdValue::Real32(12.75));
    assert_eq!(
        m.node.read_control_value(0).unwrap(),
        dev.with(|d| d.control_value_typed(0)).unwrap()
    );
    assert_eq!(m.node.read_sensor_precision(0).unwrap(), 0.01);
    assert_eq!(m.node.read_sensor_precision(3).unwrap(), 0.125);
    assert_eq!(m.node.read_control_precision(3).unwrap(), 0.01);
    let e = m.node.read_sensor_precision(9).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::OBJECT_DOES_NOT_EXIST), "{e}");
    assert!(matches!(
        m.node.read_sensor_precision(64).unwrap_err(),
        Error::Value { .. }
    ));
}

/// LED mode, external and valve-mode colours set by the master drive the device's LED; the
/// device refuses undefined values and the error names node, object and abort code.
pub(crate) fn led_mode_and_colours(m: &mut Master, dev: &impl Device) {
    assert_eq!(dev.with(|d| d.led().colour), PredefinedColour::White.into());

    let turquoise = LedColour::rgb(0, 255, 255);
    m.node.set_external_colour(turquoise).unwrap();
    m.node.set_led_mode(LedMode::FixedColour).unwrap();
    assert_eq!(
        dev.with(|d| d.values().get_u64(0x2122, 0)),
        Some(0x00FF_FF00)
    );
    assert_eq!(dev.with(|d| d.led().colour), turquoise);

    let colours = ValveModeColours {
        closed: PredefinedColour::Blue.into(),
        between: LedColour::rgb(255, 0, 255),
        open: PredefinedColour::Red.into(),
    };
    m.node.set_valve_colours(&colours).unwrap();
    m.node.set_led_mode(LedMode::Valve).unwrap();
    for (position, colour) in [
        (ValvePosition::Between, colours.between),
        (ValvePosition::Closed, colours.closed),
        (ValvePosition::Open, colours.open),
    ] {
        dev.with(|d| d.set_valve_position(Some(position)));
        assert_eq!(dev.with(|d| d.led().colour), colour, "{position:?}");
    }

    let cfg = m.node.read_led_config().unwrap();
    assert_eq!(cfg.mode, LedMode::Valve);
    assert_eq!(cfg.valve, colours);
    assert_eq!(cfg.external, turquoise);

    m.node.set_led_mode(LedMode::Off).unwrap();
    assert_eq!(dev.with(|d| d.led().colour), LedColour::OFF);

    let e = m
        .node
        .node()
        .sdo()
        .write((0x2120, 0), 5u32)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    let text = e.to_string();
    assert!(text.contains(&format!("node {}", m.id().get())), "{text}");
    assert!(text.contains("0x2120"), "{text}");
    assert!(text.contains("0x06090030"), "{text}");
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2122, 0), 0x1000_0007u32)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    assert_eq!(m.node.read_led_config().unwrap().mode, LedMode::Off);
}

/// Starts locating: the device flashes and 0x2101 sub 1 reads 1.
pub(crate) fn start_locating(m: &mut Master, dev: &impl Device) {
    m.node.start_locating().unwrap();
    assert!(dev.with(|d| d.locating()));
    assert!(dev.with(|d| d.led().flashing));
    assert!(m.node.locating().unwrap());
}

/// After locating ran out by itself: 0x2101 sub 1 still reads 1, a 1 written over it starts
/// nothing, `start_locating` (which writes 0 first) does; undefined values are refused.
pub(crate) fn locating_needs_a_zero_before_restart(m: &mut Master, dev: &impl Device) {
    assert!(!dev.with(|d| d.locating()));
    assert!(m.node.locating().unwrap(), "the object still reads 1");

    // A 1 written over the standing 1 starts nothing (the manual's rule) ...
    m.node.node().sdo().write((0x2101, 1), 1u8).wait().unwrap();
    assert!(!dev.with(|d| d.locating()));
    // ... start_locating sets it back to 0 first, so it does start.
    m.node.start_locating().unwrap();
    assert!(dev.with(|d| d.locating()));
    m.node.stop_locating().unwrap();
    assert!(!dev.with(|d| d.locating()));
    assert!(!m.node.locating().unwrap());
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2101, 1), 2u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
}

/// Maintenance drives NE 107 to "maintenance required" (blue) unless a higher-priority event
/// is active; a lower-priority one does not change it.
pub(crate) fn maintenance(m: &mut Master, dev: &impl Device) {
    m.node.set_maintenance(true).unwrap();
    assert!(m.node.maintenance().unwrap());
    assert!(dev.with(|d| d.maintenance()));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    assert_eq!(dev.with(|d| d.led().colour), PredefinedColour::Blue.into());

    dev.with(|d| d.raise(Ne107Status::DiagnosisActive));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);

    dev.with(|d| d.raise(Ne107Status::OutOfSpecification));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::OutOfSpecification);
    assert_eq!(
        dev.with(|d| d.led().colour),
        PredefinedColour::Yellow.into()
    );
    dev.with(|d| d.raise(Ne107Status::Failure));
    assert_eq!(dev.with(|d| d.led().colour), PredefinedColour::Red.into());

    dev.with(|d| {
        d.clear(Ne107Status::Failure);
        d.clear(Ne107Status::OutOfSpecification);
    });
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    m.node.set_maintenance(false).unwrap();
    assert!(!m.node.maintenance().unwrap());
    assert!(!dev.with(|d| d.maintenance()));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::DiagnosisActive);
    assert_eq!(dev.with(|d| d.led().colour), PredefinedColour::Green.into());
    dev.with(|d| d.clear(Ne107Status::DiagnosisActive));
    assert_eq!(m.node.ne107().unwrap(), Ne107Status::DiagnosisInactive);
    assert_eq!(dev.with(|d| d.led().colour), PredefinedColour::White.into());
    let e = m
        .node
        .node()
        .sdo()
        .write((0x210A, 1), 2u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
}

/// The logbook XML (a few KiB, a DOMAIN) downloads intact by block and segmented transfer,
/// into a writer and into memory, with monotonic progress ending at the whole length.
pub(crate) fn logbook(m: &mut Master, dev: &impl Device) {
    m.node.set_maintenance(true).unwrap();
    m.node.set_maintenance(false).unwrap();
    let expected = dev.with(|d| d.logbook_xml());
    assert!(
        expected.len() > 2048 && expected.len() < 16 * 1024,
        "{}",
        expected.len()
    );
    let text = String::from_utf8(expected.clone()).unwrap();
    assert!(text.starts_with("<?xml"), "{text}");
    assert!(text.contains("maintenance state entered"), "{text}");
    assert!(text.contains("maintenance state left"), "{text}");
    assert!(text.trim_end().ends_with("</logbook>"), "{text}");
    let whole = expected.len() as u64;

    for block in [true, false] {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = seen.clone();
        // Into a pipe (the logbook fits its buffer); the upload drops the writer when done.
        let (mut pipe, out) = std::io::pipe().unwrap();
        let len = m
            .node
            .download_logbook(out, block, move |p| {
                s2.lock().unwrap().push((p.done, p.total));
            })
            .unwrap();
        assert_eq!(len, whole, "block {block}");
        let mut got = Vec::new();
        pipe.read_to_end(&mut got).unwrap();
        assert_eq!(got, expected, "block {block}");
        let seen = seen.lock().unwrap();
        assert!(seen.len() > 3, "block {block}: {seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "monotonic");
        assert_eq!(seen.last(), Some(&(whole, Some(whole))));
    }
    for block in [true, false] {
        let last = Arc::new(Mutex::new(None));
        let l2 = last.clone();
        let data = m
            .node
            .read_logbook(block, move |p| *l2.lock().unwrap() = Some(p.done))
            .unwrap();
        assert_eq!(data, expected, "block {block}");
        assert_eq!(*last.lock().unwrap(), Some(whole));
    }
}

/// The bit rate through 0x2001 sub 1: written and checked, refused when Bürkert does not offer
/// it, kept over a communication reset; LSS configure bit timing confirmed for a CiA table
/// rate and refused for another table.
pub(crate) fn bit_rate(m: &mut Master, dev: &impl Device) {
    let id = m.id();
    m.node.set_bit_rate(BitRate::Kbit125).unwrap();
    assert_eq!(
        m.node.read_communication().unwrap().bit_rate,
        Some(BitRate::Kbit125)
    );
    assert_eq!(dev.with(|d| d.values().get_u64(0x2001, 1)), Some(4));
    // Not offered by Bürkert: refused before any write, and by the device when written raw.
    let e = m.node.set_bit_rate(BitRate::Kbit800).unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    // A program finds the rule by its type, not by the words.
    let Error::Value {
        problem: canola::error::ValueProblem::Profile(rule),
        ..
    } = &e
    else {
        panic!("expected a Bürkert profile rule, got {e}");
    };
    assert_eq!(
        rule.downcast_ref::<canola_burkert::OutsideManual>(),
        Some(&canola_burkert::OutsideManual::BitRate(BitRate::Kbit800)),
        "{e}"
    );
    assert!(
        e.to_string().contains("is not offered by Bürkert devices"),
        "{e}"
    );
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2001, 1), 5u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    assert_eq!(dev.with(|d| d.values().get_u64(0x2001, 1)), Some(4));

    // The stored rate takes effect at a reset (neither bus has bit timing: the device
    // restarts, boots up again and still reports the stored rate).
    m.node.node().nmt().start().unwrap();
    m.wait_state(id, NmtState::Operational);
    m.node.reset(ResetCommand::Communication).unwrap();
    m.wait_ready();
    let c = m.node.read_communication().unwrap();
    assert_eq!(c.bit_rate, Some(BitRate::Kbit125));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    assert_eq!(m.node.node().sdo().read((0x2001, 4)).wait().unwrap(), [0]);
    let log = String::from_utf8(m.node.read_logbook(true, |_| {}).unwrap()).unwrap();
    assert!(log.contains("bit rate 125 kbit/s stored"), "{log}");
    let reset = format!("communication reset, node-ID {}", id.get());
    assert!(log.contains(&reset), "{log}");
    // A communication reset is no boot of the device.
    assert_eq!(m.node.read_status().unwrap().boot_counter, Some(1));

    // LSS (CiA 305): the device's LSS slave confirms configure bit timing for a CiA table rate
    // and refuses another table (error code 1).
    m.net
        .lss()
        .procedure(Procedure::change_bit_rate(
            canola_lss::BitRate::Kbit250.into(),
            20,
        ))
        .wait()
        .unwrap();
    // The device's two switch delays run from when it handled activate bit timing, the
    // master's from when it sent it: on a real bus the device may still be silent when the
    // procedure ends, so give it a moment before the next LSS request.
    m.collect_for(Duration::from_millis(200));
    let e = m
        .net
        .lss()
        .procedure(Procedure::change_bit_rate(
            BitTiming { table: 1, index: 0 },
            20,
        ))
        .wait()
        .unwrap_err();
    assert!(
        matches!(
            e,
            Error::Lss(LssError::Rejected {
                service: Service::ConfigureBitTiming,
                error: ResponseError::NotSupported,
            })
        ),
        "{e}"
    );
    // The refused procedure stopped before its switch-global(waiting) step: send it, then the
    // device still serves SDO on its node-ID.
    m.net
        .lss()
        .procedure(
            Procedure::new()
                .then(canola_lss::Step::SwitchModeGlobal(
                    canola_lss::Mode::Waiting,
                ))
                .unwrap(),
        )
        .wait()
        .unwrap();
    assert_eq!(m.node.read_communication().unwrap().address, Some(id.get()));
}

/// Resets through 0x2001 sub 4: "no reset" does nothing; a device reset boots (counted), ends
/// locate and maintenance, keeps stored settings and is logged; undefined commands refused.
pub(crate) fn device_reset(m: &mut Master, dev: &impl Device) {
    let id = m.id();
    m.node.set_led_mode(LedMode::FixedColour).unwrap();
    m.node.set_maintenance(true).unwrap();
    m.node.start_locating().unwrap();
    m.node.node().nmt().start().unwrap();
    m.wait_state(id, NmtState::Operational);

    // "No reset" is written and nothing happens.
    m.node.reset(ResetCommand::None).unwrap();
    let quiet = m.collect_for(Duration::from_millis(700));
    let boot_up = NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: id });
    assert!(!quiet.contains(&boot_up), "{quiet:?}");
    assert!(m.node.maintenance().unwrap());

    m.node.reset(ResetCommand::Device).unwrap();
    m.wait_ready();
    let report = m.node.read_report().unwrap();
    assert_eq!(report.status.boot_counter, Some(2));
    assert!(!report.maintenance);
    assert!(!report.locating);
    assert_eq!(report.status.ne107, Some(Ne107Status::DiagnosisInactive));
    assert_eq!(
        report.communication.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    // Stored settings survive a device reset.
    assert_eq!(report.led.mode, LedMode::FixedColour);
    assert!(!dev.with(|d| d.locating()));
    assert_eq!(dev.with(|d| d.state()), DeviceState::PreOperational);
    let logged = format!("device reset, node-ID {}", id.get());
    for block in [true, false] {
        let log = String::from_utf8(m.node.read_logbook(block, |_| {}).unwrap()).unwrap();
        assert!(log.contains(&logged), "{log}");
    }
    let e = m
        .node
        .node()
        .sdo()
        .write((0x2001, 4), 3u8)
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
}

/// The node-ID changed through 0x2001 (`change_node_id`) to `new`: the device boots up and
/// answers there, profile settings survive, communication objects follow, the old node-ID is
/// silent; a node-ID stored with `set_node_id` (`newer`) applies at NMT reset communication.
pub(crate) fn node_id_change(m: &mut Master, dev: &impl Device, new: NodeId, newer: NodeId) {
    for id in [new, newer] {
        m.net.monitor_heartbeat(id, Duration::from_millis(2_000));
    }
    m.node.set_led_mode(LedMode::FixedColour).unwrap();

    let moved = m.node.change_node_id(new).unwrap();
    assert_eq!(moved.id(), new);
    m.wait_boot_up(new);
    assert_eq!(dev.with(|d| d.node()), new);
    let c = moved.read_communication().unwrap();
    assert_eq!(c.address, Some(new.get()));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    // Profile settings survive; communication objects follow the new node-ID.
    assert_eq!(moved.read_led_config().unwrap().mode, LedMode::FixedColour);
    assert_eq!(
        moved.node().sdo().read((0x1800, 1)).wait().unwrap(),
        (0x180u32 + u32::from(new.get())).to_le_bytes()
    );
    assert_eq!(moved.node().sdo().read((0x2001, 4)).wait().unwrap(), [0]);
    // The old node-ID is silent.
    let e = m
        .node
        .node()
        .sdo()
        .timeout(Duration::from_millis(300))
        .read((0x1000, 0))
        .wait()
        .unwrap_err();
    assert!(e.to_string().contains("no response"), "{e}");

    // NMT reset communication applies a node-ID stored with set_node_id too.
    moved.set_node_id(newer).unwrap();
    moved.node().nmt().reset_communication().unwrap();
    m.wait_boot_up(newer);
    assert_eq!(dev.with(|d| d.node()), newer);
    let again = add_node(&m.net, newer);
    assert_eq!(
        again.read_communication().unwrap().address,
        Some(newer.get())
    );
}

/// A node-ID `new` configured by the LSS `procedure`: pending until NMT reset communication,
/// then active and shown in 0x2001 with the stored settings; NMT reset node keeps it and the
/// settings, counts a boot and ends maintenance.
pub(crate) fn node_id_by_lss(m: &mut Master, dev: &impl Device, new: NodeId, procedure: Procedure) {
    let old = m.id();
    m.net.monitor_heartbeat(new, Duration::from_millis(2_000));
    m.node.set_led_mode(LedMode::Off).unwrap();
    m.net.lss().procedure(procedure).wait().unwrap();
    // Pending until a reset: still on the old node-ID.
    assert_eq!(
        m.node.read_communication().unwrap().address,
        Some(old.get())
    );
    m.node.node().nmt().reset_communication().unwrap();
    m.wait_boot_up(new);
    assert_eq!(dev.with(|d| d.node()), new);
    let moved = add_node(&m.net, new);
    let report = moved.read_report().unwrap();
    assert_eq!(report.communication.address, Some(new.get()));
    assert_eq!(report.led.mode, LedMode::Off);

    // NMT reset node keeps the node-ID and the stored settings, ends maintenance.
    moved.set_maintenance(true).unwrap();
    moved.node().nmt().reset_node().unwrap();
    m.wait_boot_up(new);
    let report = moved.read_report().unwrap();
    assert_eq!(report.communication.address, Some(new.get()));
    assert!(!report.maintenance);
    assert_eq!(report.status.boot_counter, Some(2));
    assert_eq!(report.led.mode, LedMode::Off);
}

/// Checks a PDO mapping object (0x1600.., 0x1A00..) in the device: sub 0 counts `entries`,
/// sub 1.. hold them, and their lengths add up to `bit_len` (what the master computed).
pub(crate) fn assert_mapped(dev: &impl Device, index: u16, entries: &[u32], bit_len: u32) {
    let count = entries.len() as u64;
    assert_eq!(dev.with(|d| d.values().get_u64(index, 0)), Some(count));
    for (sub, entry) in (1..).zip(entries) {
        let got = dev.with(|d| d.values().get_u64(index, sub));
        assert_eq!(got, Some(u64::from(*entry)), "{index:#06x} sub {sub}");
    }
    assert_eq!(entries.iter().map(|e| e & 0xFF).sum::<u32>(), bit_len);
}

/// The typed sensor readings of `tpdo` among `events`, in arrival order.
pub(crate) fn readings(tpdo: &SensorTpdo, events: &[NetworkEvent]) -> Vec<Vec<(u8, OdValue)>> {
    events
        .iter()
        .filter_map(|e| tpdo.from_event(e))
        .map(|res| {
            res.expect("decode the TPDO")
                .into_iter()
                .map(|s| (s.sensor, s.value))
                .collect()
        })
        .collect()
}

/// Sensor values mapped to TPDOs (event-driven, and on every SYNC) arrive typed when
/// Operational, none before; a new value goes out and reads the same by SDO. Returns the
/// readings of the event-driven TPDO1 in the first 3 s Operational (a count the virtual clock
/// can bound exactly).
pub(crate) fn sensor_values_in_tpdos(m: &mut Master, dev: &impl Device) -> usize {
    let id = m.id();
    dev.with(|d| d.pin_sensor(2, 42.5));
    // Three REAL32 need 96 bits: refused locally before anything is written.
    let e = m
        .node
        .map_sensor_values_to_tpdo(1, &[0, 1, 2], None)
        .unwrap_err();
    assert!(e.to_string().contains("64"), "{e}");
    let tpdo1 = m.node.map_sensor_values_to_tpdo(1, &[2, 3], None).unwrap();
    assert_eq!(tpdo1.number(), 1);
    assert_eq!(tpdo1.sensors(), [2, 3]);
    assert_eq!(tpdo1.cob_id() & 0x7FF, 0x180 + u32::from(id.get()));
    assert_eq!(tpdo1.mapping().bit_len(), 64);
    let bits = tpdo1.mapping().bit_len();
    assert_mapped(dev, 0x1A00, &[0x2502_0120, 0x2503_0120], bits);
    assert_eq!(dev.with(|d| d.values().get_u64(0x1800, 3)), Some(5000));
    // TPDO2: sensor 0 on every SYNC, with the caller's communication parameters.
    let tpdo2 = m
        .node
        .map_sensor_values_to_tpdo(
            2,
            &[0],
            Some(
                CommParams::event_driven(0x280 + u16::from(id.get()))
                    .with_transmission_type(TransmissionType::SyncCyclic(1)),
            ),
        )
        .unwrap();
    assert_eq!(dev.with(|d| d.values().get_u64(0x1801, 2)), Some(1));

    let quiet = m.collect_for(Duration::from_millis(3_000));
    assert!(
        readings(&tpdo1, &quiet).is_empty(),
        "no PDOs pre-operational"
    );

    m.node.node().nmt().start().unwrap();
    m.wait_state(id, NmtState::Operational);
    m.net.start_sync(Duration::from_millis(100));
    let got = m.collect_for(Duration::from_millis(3_000));
    let t1 = readings(&tpdo1, &got);
    let t2 = readings(&tpdo2, &got);
    assert!(t1.len() >= 3, "TPDO1: {t1:?}");
    for values in &t1 {
        assert_eq!(values[0], (2, OdValue::Real32(42.5)), "{values:?}");
        assert_eq!(values[1].0, 3);
        let OdValue::Real32(v) = values[1].1 else {
            panic!("{values:?}")
        };
        assert!((45.0..=55.0).contains(&v), "sensor 3: {v}");
    }
    assert_ne!(t1[0][1], t1[t1.len() - 1][1], "sensor 3 changes over time");
    assert!(t2.len() >= 5, "TPDO2 (SYNC): {t2:?}");
    for values in &t2 {
        let [(0, OdValue::Real32(v))] = values.as_slice() else {
            panic!("{values:?}")
        };
        assert!((15.0..=25.0).contains(v), "sensor 0: {v}");
    }
    m.net.stop_sync();
    // The same value by SDO.
    assert_eq!(m.node.read_sensor_value(2).unwrap(), OdValue::Real32(42.5));

    // A new value in the device goes out in the TPDO and reads the same by SDO.
    dev.with(|d| d.pin_sensor(2, -7.75));
    let later = m.collect_for(Duration::from_millis(2_500));
    let later = readings(&tpdo1, &later);
    assert_eq!(
        later.last().map(|v| v[0].clone()),
        Some((2, OdValue::Real32(-7.75))),
        "{later:?}"
    );
    assert_eq!(m.node.read_sensor_value(2).unwrap(), OdValue::Real32(-7.75));
    // And the last sensor 3 value sent is the device's (it changes every 100 ms, so compare
    // with what the device holds as of the SDO read within one sine step).
    let OdValue::Real32(sent) = later.last().unwrap()[1].1 else {
        panic!("{later:?}")
    };
    let OdValue::Real32(now) = m.node.read_sensor_value(3).unwrap() else {
        panic!("REAL32")
    };
    assert!((sent - now).abs() < 5.0, "sent {sent}, now {now}");
    t1.len()
}

/// A TPDO mapping (object `index`, 0x1A00..) naming an object that is not PDO-mappable is
/// refused by the device when the mapping is enabled.
pub(crate) fn non_mappable_refused(m: &Master, index: u16) {
    let sdo = || m.node.node().sdo();
    sdo().write((index, 0), 0u8).wait().unwrap();
    sdo().write((index, 1), 0x2500_0620u32).wait().unwrap(); // precision: not PDO-mappable
    let e = sdo().write((index, 0), 1u8).wait().unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::NOT_MAPPABLE), "{e}");
}

/// Control values mapped to RPDOs reach the device when Operational and are ignored before; a
/// wrong value type is a local error and sends nothing.
pub(crate) fn control_values_by_rpdo(m: &mut Master, dev: &impl Device) {
    let id = m.id();
    let rpdo = m.node.map_control_values_to_rpdo(1, &[1, 0], None).unwrap();
    assert_eq!(rpdo.number(), 1);
    assert_eq!(rpdo.controls(), [1, 0]);
    assert_eq!(rpdo.cob_id() & 0x7FF, 0x200 + u32::from(id.get()));
    assert_eq!(rpdo.kinds(), [ValueKind::Real32, ValueKind::Real32]);
    assert_eq!(rpdo.mapping().bit_len(), 64);
    let bits = rpdo.mapping().bit_len();
    assert_mapped(dev, 0x1600, &[0x2541_0120, 0x2540_0120], bits);
    let rpdo2 = m
        .node
        .map_control_values_to_rpdo(
            2,
            &[3],
            Some(CommParams::event_driven(0x300 + u16::from(id.get()))),
        )
        .unwrap();
    assert_eq!(dev.with(|d| d.values().get_u64(0x1401, 2)), Some(255));
    // A mapping the device cannot carry is refused by the device.
    non_mappable_refused(m, 0x1A03);

    let values = [OdValue::Real32(-3.25), OdValue::Real32(1.5)];
    let frame = rpdo.encode(&values).unwrap();
    assert_eq!(frame.data().len(), 8);

    // Pre-operational: ignored (the SDO read after it is answered after the RPDO was handled:
    // one bus, one order).
    m.node.send_control_values(&rpdo, &values).unwrap();
    assert_eq!(m.node.read_control_value(1).unwrap(), OdValue::Real32(0.0));
    assert_eq!(dev.with(|d| d.control_value(1)), Some(0.0));
    assert_eq!(dev.with(|d| d.control_value(0)), Some(0.0));

    m.node.node().nmt().start().unwrap();
    m.wait_state(id, NmtState::Operational);
    m.node.send_control_values(&rpdo, &values).unwrap();
    m.node
        .send_control_values(&rpdo2, &[OdValue::Real32(99.5)])
        .unwrap();
    assert_eq!(
        m.node.read_control_value(1).unwrap(),
        OdValue::Real32(-3.25)
    );
    assert_eq!(m.node.read_control_value(0).unwrap(), OdValue::Real32(1.5));
    assert_eq!(m.node.read_control_value(3).unwrap(), OdValue::Real32(99.5));
    assert_eq!(dev.with(|d| d.control_value(1)), Some(-3.25));
    assert_eq!(dev.with(|d| d.control_value(0)), Some(1.5));
    assert_eq!(dev.with(|d| d.control_value(3)), Some(99.5));

    // A wrong value type is a local error; nothing is sent.
    let e = m
        .node
        .send_control_values(&rpdo, &[OdValue::Boolean(true)])
        .unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    assert_eq!(dev.with(|d| d.control_value(1)), Some(-3.25));
}

/// The `canopen demo` walkthrough: status with the LED colour (plain and drawn with ANSI
/// colours), a locate, a logbook download with progress.
pub(crate) fn demo_walkthrough(m: &mut Master, dev: &impl Device) {
    let mut out = Vec::new();
    let summary = demo::run_with(
        &m.net,
        m.id(),
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
    assert!(!text.contains('\x1b'), "{text}");
    assert!(dev.with(|d| d.locating()));
    let log = String::from_utf8(summary.logbook.clone()).unwrap();
    assert!(log.starts_with("<?xml"), "{log}");
    assert!(log.contains("locating started"), "{log}");
    let len = summary.logbook.len() as u64;
    assert_eq!(summary.progress.last(), Some(&(len, Some(len))));

    let mut out = Vec::new();
    demo::run(&m.net, m.id(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("\x1b[48;2;255;255;255m"), "{text}");
}
