//! The Bürkert profile's master side (`burkert_profile::BurkertNode` over `canopen::Network` on
//! the SocketCAN transport) against the simulated Bürkert device
//! (`burkert_profile::BurkertDevice`, served by `canopen::run_station` on a second socket) over
//! the real kernel CAN stack: every `BurkertNode` operation, checked on both sides — what the
//! master decodes is compared with the device's own state, and what the master writes or sends
//! is looked up in the device.
//!
//! Ignored on the host; `tests/vcan/run-all` runs them in the QEMU guest with `--ignored
//! --test-threads=1` (the LSS services use switch-mode-global, which addresses every device on
//! the bus, so only one simulated device may be on `vcan0` at a time). Each test still uses its
//! own node-IDs.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

use burkert_profile::master::generic_od;
use burkert_profile::objects::{self, device_communication_object as comm};
use burkert_profile::sim::LOCATE_DURATION;
use burkert_profile::{
    BitRate, BurkertDevice, BurkertNode, BusMode, CanOperationStatus, EdsVersion, LedColour,
    LedMode, Ne107Status, PredefinedColour, ResetCommand, Termination, ValveModeColours,
    ValvePosition, demo,
};
use can_frame::{CanFrame, Duration, Instant, NodeId};
use canopen::socketcan::SocketCan;
use canopen::transport::Station;
use canopen::{Error, Network, NetworkEvent, TransportError, run_station};
use canopen_lss::{BitTiming, LssError, Procedure, ResponseError, Service};
use canopen_nmt::{DeviceState, HeartbeatEvent, NmtState};
use canopen_od::Value as OdValue;
use canopen_pdo::{CommParams, TransmissionType, Value as PdoValue, ValueKind};
use canopen_sdo::AbortCode;

fn node(id: u8) -> NodeId {
    NodeId::new(id).expect("node-ID 1..=127")
}

fn abort(e: &Error) -> Option<AbortCode> {
    e.server_abort()
}

/// The device behind a mutex, so the test can look into it (and raise NE 107 events, pin
/// sensors, set the valve position) while the station thread serves it.
struct SharedDevice(Arc<Mutex<BurkertDevice>>);

impl SharedDevice {
    fn lock(&self) -> MutexGuard<'_, BurkertDevice> {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl Station for SharedDevice {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.lock().handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.lock().handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.lock().poll_transmit()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.lock().poll_timeout()
    }
}

/// A [`BurkertDevice`] served on its own socket by a thread until dropped.
struct RunningDevice {
    dev: Arc<Mutex<BurkertDevice>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl RunningDevice {
    /// Starts serving `dev` on the rig's interface (boot-up message first).
    fn start(dev: BurkertDevice) -> Self {
        let mut transport =
            SocketCan::open(&vcan_tests::interface()).expect("open the device's socket");
        let dev = Arc::new(Mutex::new(dev));
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, mut station) = (stop.clone(), SharedDevice(dev.clone()));
        let thread = std::thread::spawn(move || {
            match run_station(&mut transport, &mut station, || {
                flag.load(Ordering::Relaxed)
            }) {
                Ok(()) => {}
                Err(TransportError::InterfaceDown) => panic!("vcan0 went down under the device"),
                Err(e) => panic!("the device's transport failed: {e}"),
            }
        });
        Self {
            dev,
            stop,
            thread: Some(thread),
        }
    }

    /// Runs `f` on the device (between two steps of the station loop).
    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R {
        f(&mut self
            .dev
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner))
    }
}

impl Drop for RunningDevice {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take()
            && t.join().is_err()
            && !std::thread::panicking()
        {
            panic!("the device's station thread panicked");
        }
    }
}

/// The master on its own socket, one simulated device on another, and the profile view.
struct Rig {
    net: Network,
    events: Receiver<NetworkEvent>,
    dev: RunningDevice,
    node: BurkertNode,
    /// Every event drained so far (for the assertion messages).
    seen: Vec<NetworkEvent>,
}

impl Rig {
    /// Starts a device with node-ID `id` (after `prepare` ran on it) and waits for its boot-up
    /// and its first Pre-Operational heartbeat.
    fn new(id: u8, prepare: impl FnOnce(&mut BurkertDevice)) -> Self {
        let net = Network::new(
            SocketCan::open(&vcan_tests::interface()).expect("open the master's socket"),
        );
        let events = net.subscribe();
        // The device's heartbeat is 500 ms (0x1017 default of the Bürkert EDS).
        net.monitor_heartbeat(node(id), Duration::from_millis(2_000));
        let node_view =
            BurkertNode::new(net.add_node_with_dictionary(node(id), (**generic_od()).clone()));
        let mut dev = BurkertDevice::new(node(id));
        prepare(&mut dev);
        let mut rig = Rig {
            net,
            events,
            dev: RunningDevice::start(dev),
            node: node_view,
            seen: Vec::new(),
        };
        rig.wait_boot_up(id);
        rig.wait_state(id, NmtState::PreOperational);
        rig
    }

    fn with<R>(&self, f: impl FnOnce(&mut BurkertDevice) -> R) -> R {
        self.dev.with(f)
    }

    /// Drives the network for up to `limit` until an event satisfies `want`; returns it.
    fn wait_event(
        &mut self,
        limit: Duration,
        what: &str,
        want: impl Fn(&NetworkEvent) -> bool,
    ) -> NetworkEvent {
        let deadline = self.net.now() + limit;
        while self.net.now() < deadline {
            self.net
                .run_for(Duration::from_millis(50))
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
    fn wait_boot_up(&mut self, id: u8) {
        self.wait_event(Duration::from_secs(15), "boot-up", |e| {
            *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(id) })
        });
    }

    /// Waits for a heartbeat of node `id` reporting `state`.
    fn wait_state(&mut self, id: u8, state: NmtState) {
        self.wait_event(
            Duration::from_secs(15),
            &format!("heartbeat {state:?} of node {id}"),
            |e| {
                matches!(e, NetworkEvent::Heartbeat(
                    HeartbeatEvent::StateChanged { node: n, to, .. }
                    | HeartbeatEvent::Recovered { node: n, state: to }) if n.get() == id && *to == state)
            },
        );
        assert_eq!(self.net.last_state(node(id)), Some(state));
    }

    /// Drives the network for `d` and returns the events that arrived meanwhile.
    fn collect_for(&mut self, d: Duration) -> Vec<NetworkEvent> {
        let deadline = self.net.now() + d;
        let mut got = Vec::new();
        while self.net.now() < deadline {
            self.net
                .run_for(Duration::from_millis(50))
                .expect("drive the network");
            got.extend(self.events.try_iter());
        }
        self.seen.extend(got.iter().cloned());
        got
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn description_status_communication_and_report_in_one_call() {
    let mut r = Rig::new(0x61, |d| {
        let v = d.values_mut();
        v.set(0x2000, 1, b"Type 8681 valve top".to_vec());
        v.set(0x2000, 2, 0x0012_3456u32.to_le_bytes().to_vec());
        v.set(0x2000, 7, 0x00C0_FFEEu32.to_le_bytes().to_vec());
        v.set(0x2000, 9, vec![7]);
        v.set(0x2004, 3, 23.5f32.to_le_bytes().to_vec());
    });
    assert_eq!(r.node.id(), node(0x61));
    assert_eq!(r.node.node().id(), node(0x61));

    // The whole description and status: 9 + 17 SDO reads submitted together.
    let (desc, status) = r.node.read_description_and_status().unwrap();
    assert_eq!(desc.device_name.as_deref(), Some("Type 8681 valve top"));
    assert_eq!(desc.ident_number, Some(0x0012_3456));
    assert_eq!(desc.serial_number, Some(0x00C0_FFEE));
    assert_eq!(desc.product_group, Some(7));
    assert_eq!(desc.manufacture_date.as_deref(), Some("2026-01-01"));
    let dev_sw = r.with(|d| d.values().get_u64(0x2000, 5)).unwrap();
    assert_eq!(desc.software_version.map(u64::from), Some(dev_sw));
    assert_eq!(status.ne107, Some(Ne107Status::DiagnosisInactive));
    assert_eq!(status.supply_voltage, Some(23.5));
    assert_eq!(status.boot_counter, Some(1));
    let t = status.temperature.expect("0x2004 sub 2");
    let dev_t = r
        .with(|d| d.values().get(0x2004, 2).map(<[u8]>::to_vec))
        .unwrap();
    assert_eq!(t.0.to_le_bytes().to_vec(), dev_t, "temperature in kelvin");
    assert!(status.time_since_boot_s.is_some());
    assert_eq!(r.node.read_description().unwrap(), desc);
    let again = r.node.read_status().unwrap();
    assert_eq!(again.supply_voltage, Some(23.5));
    assert_eq!(again.boot_counter, Some(1));

    let c = r.node.read_communication().unwrap();
    assert_eq!(c.address, Some(0x61));
    assert_eq!(c.bit_rate, Some(BitRate::Kbit500));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    let dev_eds = r.with(|d| d.values().get_u64(0x2001, 0x0D)).unwrap();
    assert_eq!(c.eds_version, Some(EdsVersion::from_u8(dev_eds as u8)));

    // Generic typed access through the generated entries.
    assert_eq!(r.node.read(comm::ADDRESS).unwrap(), 0x61);
    r.node.write(objects::LED_MODE, &4).unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x2120, 0)), Some(4));
    r.node.write(objects::LED_MODE, &0).unwrap();

    // A fault raised in the device shows in the status, the report and its LED colour.
    r.with(|d| d.raise(Ne107Status::Failure));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::Failure);
    let report = r.node.read_report().unwrap();
    assert_eq!(report.description, desc);
    assert_eq!(report.status.ne107, Some(Ne107Status::Failure));
    assert_eq!(report.communication.address, Some(0x61));
    assert_eq!(report.led.mode, LedMode::Namur);
    assert!(!report.locating);
    assert!(!report.maintenance);
    assert_eq!(report.led_indication().colour, PredefinedColour::Red.into());
    assert_eq!(report.led_indication(), r.with(|d| d.led()));
    r.with(|d| d.clear(Ne107Status::Failure));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::DiagnosisInactive);

    // 0x2001 sub 0x0A follows the NMT state the heartbeat reports.
    r.node.node().nmt().start().unwrap();
    r.wait_state(0x61, NmtState::Operational);
    assert_eq!(
        r.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::Operational)
    );
    r.node.node().nmt().stop().unwrap();
    r.wait_state(0x61, NmtState::Stopped);
    assert_eq!(r.with(|d| d.state()), DeviceState::Stopped);
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 0x0A)), Some(4));
    r.node.node().nmt().enter_preoperational().unwrap();
    r.wait_state(0x61, NmtState::PreOperational);
    assert_eq!(
        r.node.read_communication().unwrap().can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn user_configuration_termination_bus_mode_values_and_precisions() {
    let r = Rig::new(0x62, |d| {
        d.values_mut()
            .set(0x2503, 6, 0.125f32.to_le_bytes().to_vec());
    });
    let u = r.node.read_user_configuration().unwrap();
    assert_eq!(u.number_of_entries, 5);
    assert_eq!(u.static_node_id, Some(0));

    r.node
        .set_location("Hall 3, line 7, valve island A")
        .unwrap();
    r.node.set_user_description("dosing valve, vcan0").unwrap();
    r.node.set_displayed_name("V-307").unwrap();
    r.node.set_static_node_id(Some(node(21))).unwrap();
    let u = r.node.read_user_configuration().unwrap();
    assert_eq!(
        u.location.as_deref(),
        Some("Hall 3, line 7, valve island A")
    );
    assert_eq!(u.user_description.as_deref(), Some("dosing valve, vcan0"));
    assert_eq!(u.displayed_name.as_deref(), Some("V-307"));
    assert_eq!(u.static_node_id, Some(21));
    assert_eq!(
        r.with(|d| d.values().get(0x2002, 2).map(<[u8]>::to_vec)),
        Some(b"Hall 3, line 7, valve island A".to_vec())
    );
    assert_eq!(r.with(|d| d.values().get_u64(0x2002, 5)), Some(21));
    r.node.set_static_node_id(None).unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x2002, 5)), Some(0));

    r.node.set_termination(Termination::Active).unwrap();
    r.node.set_bus_mode(BusMode::CanOpen).unwrap();
    let c = r.node.read_communication().unwrap();
    assert_eq!(c.termination, Some(Termination::Active));
    assert_eq!(c.bus_mode, Some(BusMode::CanOpen));
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 0x0B)), Some(1));
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 3)), Some(0));
    let e = r.node.node().sdo().write((0x2001, 0x0B), 2u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");

    // Sensor and control values by SDO, typed by the EDS (REAL32), equal to the device's.
    r.with(|d| d.pin_sensor(1, 12.75));
    assert_eq!(r.node.read_sensor_value(1).unwrap(), OdValue::Real32(12.75));
    assert_eq!(
        r.node.read_control_value(0).unwrap(),
        r.with(|d| d.control_value_typed(0)).unwrap()
    );
    assert_eq!(r.node.read_sensor_precision(3).unwrap(), 0.125);
    assert_eq!(r.node.read_control_precision(3).unwrap(), 0.01);
    let e = r.node.read_sensor_precision(9).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::OBJECT_DOES_NOT_EXIST), "{e}");
    assert!(matches!(
        r.node.read_sensor_precision(64).unwrap_err(),
        Error::Value { .. }
    ));
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn led_mode_and_colours_drive_the_device_led() {
    let r = Rig::new(0x63, |_| {});
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
    r.with(|d| d.set_valve_position(Some(ValvePosition::Closed)));
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Blue.into());

    let cfg = r.node.read_led_config().unwrap();
    assert_eq!(cfg.mode, LedMode::Valve);
    assert_eq!(cfg.valve, colours);
    assert_eq!(cfg.external, turquoise);

    r.node.set_led_mode(LedMode::Off).unwrap();
    assert_eq!(r.with(|d| d.led().colour), LedColour::OFF);

    // Undefined values are refused by the device with abort 0x06090030.
    let e = r.node.node().sdo().write((0x2120, 0), 5u32).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    let e = r
        .node
        .node()
        .sdo()
        .write((0x2122, 0), 0x1000_0007u32)
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    assert_eq!(r.node.read_led_config().unwrap().mode, LedMode::Off);
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn locating_runs_its_time_and_maintenance_shows_blue_unless_outranked() {
    let r = Rig::new(0x64, |_| {});
    let started = std::time::Instant::now();
    r.node.start_locating().unwrap();
    assert!(r.with(|d| d.locating()));
    assert!(r.with(|d| d.led().flashing));
    assert!(r.node.locating().unwrap());

    // The device stops flashing by itself, not before LOCATE_DURATION of its (real) clock.
    let limit = std::time::Duration::from_secs(60);
    while r.with(|d| d.locating()) {
        assert!(started.elapsed() < limit, "still locating after {limit:?}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    assert!(
        started.elapsed() >= std::time::Duration::from_micros(LOCATE_DURATION.as_micros()),
        "stopped after {:?}",
        started.elapsed()
    );
    assert!(r.node.locating().unwrap(), "the object still reads 1");

    // A 1 written over the standing 1 starts nothing (the manual's rule) ...
    r.node.node().sdo().write((0x2101, 1), 1u8).unwrap();
    assert!(!r.with(|d| d.locating()));
    // ... start_locating sets it back to 0 first, so it does start.
    r.node.start_locating().unwrap();
    assert!(r.with(|d| d.locating()));
    r.node.stop_locating().unwrap();
    assert!(!r.with(|d| d.locating()));
    assert!(!r.node.locating().unwrap());

    r.node.set_maintenance(true).unwrap();
    assert!(r.node.maintenance().unwrap());
    assert!(r.with(|d| d.maintenance()));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Blue.into());
    r.with(|d| d.raise(Ne107Status::OutOfSpecification));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::OutOfSpecification);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::Yellow.into());
    r.with(|d| d.clear(Ne107Status::OutOfSpecification));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::MaintenanceRequired);
    r.node.set_maintenance(false).unwrap();
    assert!(!r.node.maintenance().unwrap());
    assert!(!r.with(|d| d.maintenance()));
    assert_eq!(r.node.ne107().unwrap(), Ne107Status::DiagnosisInactive);
    assert_eq!(r.with(|d| d.led().colour), PredefinedColour::White.into());
    let e = r.node.node().sdo().write((0x210A, 1), 2u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
}

/// A writer whose bytes the test can look at after the download.
#[derive(Clone, Default)]
struct SharedBuf(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for SharedBuf {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn logbook_downloads_intact_with_progress_block_and_segmented() {
    let r = Rig::new(0x65, |_| {});
    r.node.set_maintenance(true).unwrap();
    r.node.set_maintenance(false).unwrap();
    let expected = r.with(|d| d.logbook_xml());
    let text = String::from_utf8(expected.clone()).unwrap();
    assert!(text.contains("maintenance state left"), "{text}");
    assert!(expected.len() > 2048, "{}", expected.len());

    for block in [true, false] {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = seen.clone();
        let out = SharedBuf::default();
        let len = r
            .node
            .download_logbook(out.clone(), block, move |p| {
                s2.lock().unwrap().push((p.done, p.total));
            })
            .unwrap();
        assert_eq!(len, expected.len() as u64, "block {block}");
        assert_eq!(*out.0.lock().unwrap(), expected, "block {block}");
        let seen = seen.lock().unwrap();
        assert!(seen.len() > 3, "block {block}: {seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "monotonic");
        assert_eq!(
            seen.last(),
            Some(&(expected.len() as u64, Some(expected.len() as u64)))
        );
    }
    for block in [true, false] {
        let last = Arc::new(Mutex::new(None));
        let l2 = last.clone();
        let data = r
            .node
            .read_logbook(block, move |p| *l2.lock().unwrap() = Some(p.done))
            .unwrap();
        assert_eq!(data, expected, "block {block}");
        assert_eq!(*last.lock().unwrap(), Some(expected.len() as u64));
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn bit_rate_through_0x2001_survives_a_communication_reset_and_lss_bit_timing_is_confirmed() {
    let mut r = Rig::new(0x66, |_| {});
    r.node.set_bit_rate(BitRate::Kbit125).unwrap();
    assert_eq!(
        r.node.read_communication().unwrap().bit_rate,
        Some(BitRate::Kbit125)
    );
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 1)), Some(4));
    // Not offered by Bürkert: refused before any write, and by the device when written raw.
    let e = r.node.set_bit_rate(BitRate::Kbit800).unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    let e = r.node.node().sdo().write((0x2001, 1), 5u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
    assert_eq!(r.with(|d| d.values().get_u64(0x2001, 1)), Some(4));

    // The stored rate takes effect at a reset (vcan0 has no bit timing: the device restarts,
    // boots up again and still reports the stored rate).
    r.node.node().nmt().start().unwrap();
    r.wait_state(0x66, NmtState::Operational);
    r.node.reset(ResetCommand::Communication).unwrap();
    r.wait_boot_up(0x66);
    r.wait_state(0x66, NmtState::PreOperational);
    let c = r.node.read_communication().unwrap();
    assert_eq!(c.bit_rate, Some(BitRate::Kbit125));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    assert_eq!(r.node.node().sdo().read((0x2001, 4)).unwrap(), [0]);
    let log = String::from_utf8(r.node.read_logbook(true, |_| {}).unwrap()).unwrap();
    assert!(log.contains("bit rate 125 kbit/s stored"), "{log}");
    assert!(log.contains("communication reset, node-ID 102"), "{log}");
    // A communication reset is no boot of the device.
    assert_eq!(r.node.read_status().unwrap().boot_counter, Some(1));

    // LSS (CiA 305): the device's LSS slave confirms configure bit timing for a CiA table rate
    // and refuses another table (error code 1) over the real bus.
    r.net
        .lss()
        .procedure(Procedure::change_bit_rate(
            canopen_lss::BitRate::Kbit250.into(),
            20,
        ))
        .unwrap();
    let e = r
        .net
        .lss()
        .procedure(Procedure::change_bit_rate(
            BitTiming { table: 1, index: 0 },
            20,
        ))
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
    r.net
        .lss()
        .procedure(
            Procedure::new()
                .then(canopen_lss::Step::SwitchModeGlobal(
                    canopen_lss::Mode::Waiting,
                ))
                .unwrap(),
        )
        .unwrap();
    assert_eq!(r.node.read_communication().unwrap().address, Some(0x66));
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn device_reset_through_0x2001_sub_4_boots_and_ends_locate_and_maintenance() {
    let mut r = Rig::new(0x67, |_| {});
    r.node.set_led_mode(LedMode::FixedColour).unwrap();
    r.node.set_maintenance(true).unwrap();
    r.node.start_locating().unwrap();
    r.node.node().nmt().start().unwrap();
    r.wait_state(0x67, NmtState::Operational);

    // "No reset" is written and nothing happens.
    r.node.reset(ResetCommand::None).unwrap();
    let quiet = r.collect_for(Duration::from_millis(700));
    let boot_up = NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(0x67) });
    assert!(!quiet.contains(&boot_up), "{quiet:?}");
    assert!(r.node.maintenance().unwrap());

    r.node.reset(ResetCommand::Device).unwrap();
    r.wait_boot_up(0x67);
    r.wait_state(0x67, NmtState::PreOperational);
    let report = r.node.read_report().unwrap();
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
    assert!(!r.with(|d| d.locating()));
    assert_eq!(r.with(|d| d.state()), DeviceState::PreOperational);
    let log = String::from_utf8(r.node.read_logbook(false, |_| {}).unwrap()).unwrap();
    assert!(log.contains("device reset, node-ID 103"), "{log}");
    let e = r.node.node().sdo().write((0x2001, 4), 3u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::INVALID_VALUE), "{e}");
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn node_id_change_through_0x2001_answers_on_the_new_id() {
    let mut r = Rig::new(0x68, |_| {});
    r.net
        .monitor_heartbeat(node(0x69), Duration::from_millis(2_000));
    r.net
        .monitor_heartbeat(node(0x6A), Duration::from_millis(2_000));
    r.node.set_led_mode(LedMode::FixedColour).unwrap();

    let new = r.node.change_node_id(node(0x69)).unwrap();
    assert_eq!(new.id(), node(0x69));
    r.wait_boot_up(0x69);
    assert_eq!(r.with(|d| d.node()), node(0x69));
    let c = new.read_communication().unwrap();
    assert_eq!(c.address, Some(0x69));
    assert_eq!(
        c.can_operation_status,
        Some(CanOperationStatus::PreOperational)
    );
    // Profile settings survive; communication objects follow the new node-ID.
    assert_eq!(new.read_led_config().unwrap().mode, LedMode::FixedColour);
    assert_eq!(
        new.node().sdo().read((0x1800, 1)).unwrap(),
        (0x180u32 + 0x69).to_le_bytes()
    );
    // The old node-ID is silent.
    let e = r
        .node
        .node()
        .sdo()
        .timeout(Duration::from_millis(300))
        .read((0x1000, 0))
        .unwrap_err();
    assert!(e.to_string().contains("no response"), "{e}");

    // NMT reset communication applies a node-ID stored with set_node_id too.
    new.set_node_id(node(0x6A)).unwrap();
    new.node().nmt().reset_communication().unwrap();
    r.wait_boot_up(0x6A);
    assert_eq!(r.with(|d| d.node()), node(0x6A));
    let newer = BurkertNode::new(
        r.net
            .add_node_with_dictionary(node(0x6A), (**generic_od()).clone()),
    );
    assert_eq!(newer.read_communication().unwrap().address, Some(0x6A));
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn node_id_set_by_lss_becomes_active_at_nmt_reset_and_shows_in_0x2001() {
    let mut r = Rig::new(0x6B, |_| {});
    r.net
        .monitor_heartbeat(node(0x6C), Duration::from_millis(2_000));
    r.node.set_led_mode(LedMode::Off).unwrap();
    let address = r.with(|d| d.sim().lss_address());
    r.net
        .lss()
        .procedure(Procedure::assign_node_id_selective(
            address,
            node(0x6C),
            false,
        ))
        .unwrap();
    // Pending until a reset: still on the old node-ID.
    assert_eq!(r.node.read_communication().unwrap().address, Some(0x6B));
    r.node.node().nmt().reset_communication().unwrap();
    r.wait_boot_up(0x6C);
    let new = BurkertNode::new(
        r.net
            .add_node_with_dictionary(node(0x6C), (**generic_od()).clone()),
    );
    let report = new.read_report().unwrap();
    assert_eq!(report.communication.address, Some(0x6C));
    assert_eq!(report.led.mode, LedMode::Off);
    assert_eq!(r.with(|d| d.node()), node(0x6C));
}

/// The typed sensor readings of `tpdo` among `events`, in arrival order.
fn readings(
    tpdo: &burkert_profile::master::SensorTpdo,
    events: &[NetworkEvent],
) -> Vec<Vec<(u8, PdoValue)>> {
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

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn sensor_values_mapped_to_tpdos_arrive_typed_when_operational() {
    let id = 0x6D;
    let mut r = Rig::new(id, |d| d.pin_sensor(2, 42.5));

    // Three REAL32 need 96 bits: refused locally before anything is written.
    let e = r
        .node
        .map_sensor_values_to_tpdo(1, &[0, 1, 2], None)
        .unwrap_err();
    assert!(e.to_string().contains("64"), "{e}");
    let tpdo1 = r.node.map_sensor_values_to_tpdo(1, &[2, 3], None).unwrap();
    assert_eq!(tpdo1.number(), 1);
    assert_eq!(tpdo1.sensors(), [2, 3]);
    assert_eq!(tpdo1.cob_id() & 0x7FF, 0x180 + u32::from(id));
    assert_eq!(tpdo1.mapping().bit_len(), 64);
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 0)), Some(2));
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 1)), Some(0x2502_0120));
    assert_eq!(r.with(|d| d.values().get_u64(0x1A00, 2)), Some(0x2503_0120));
    assert_eq!(r.with(|d| d.values().get_u64(0x1800, 3)), Some(5000));
    // TPDO2: sensor 0 on every SYNC, with the caller's communication parameters.
    let tpdo2 = r
        .node
        .map_sensor_values_to_tpdo(
            2,
            &[0],
            Some(
                CommParams::event_driven(0x280 + u16::from(id))
                    .with_transmission_type(TransmissionType::SyncCyclic(1)),
            ),
        )
        .unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x1801, 2)), Some(1));

    let quiet = r.collect_for(Duration::from_millis(1_500));
    assert!(
        readings(&tpdo1, &quiet).is_empty(),
        "no PDOs pre-operational"
    );

    r.node.node().nmt().start().unwrap();
    r.wait_state(id, NmtState::Operational);
    r.net.start_sync(Duration::from_millis(100));
    let got = r.collect_for(Duration::from_millis(3_000));
    let t1 = readings(&tpdo1, &got);
    let t2 = readings(&tpdo2, &got);
    assert!(t1.len() >= 3, "TPDO1: {t1:?}");
    for values in &t1 {
        assert_eq!(values[0], (2, PdoValue::Real32(42.5)), "{values:?}");
        assert_eq!(values[1].0, 3);
        let PdoValue::Real32(v) = values[1].1 else {
            panic!("{values:?}")
        };
        assert!((45.0..=55.0).contains(&v), "sensor 3: {v}");
    }
    assert!(t2.len() >= 5, "TPDO2 (SYNC): {t2:?}");
    for values in &t2 {
        let [(0, PdoValue::Real32(v))] = values.as_slice() else {
            panic!("{values:?}")
        };
        assert!((15.0..=25.0).contains(v), "sensor 0: {v}");
    }
    r.net.stop_sync();

    // A new value in the device goes out in the TPDO and reads the same by SDO.
    r.with(|d| d.pin_sensor(2, -7.75));
    let got = r.collect_for(Duration::from_millis(2_500));
    let t1 = readings(&tpdo1, &got);
    assert_eq!(
        t1.last().map(|v| v[0]),
        Some((2, PdoValue::Real32(-7.75))),
        "{t1:?}"
    );
    assert_eq!(r.node.read_sensor_value(2).unwrap(), OdValue::Real32(-7.75));
    // And the last sensor 3 value sent is the device's (it changes every 100 ms, so compare
    // with what the device holds as of the SDO read within one sine step).
    let PdoValue::Real32(sent) = t1.last().unwrap()[1].1 else {
        panic!("{t1:?}")
    };
    let OdValue::Real32(now) = r.node.read_sensor_value(3).unwrap() else {
        panic!("REAL32")
    };
    assert!((sent - now).abs() < 5.0, "sent {sent}, now {now}");
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn control_values_sent_by_rpdo_reach_the_device() {
    let id = 0x6E;
    let mut r = Rig::new(id, |_| {});
    let rpdo = r.node.map_control_values_to_rpdo(1, &[1, 0], None).unwrap();
    assert_eq!(rpdo.number(), 1);
    assert_eq!(rpdo.controls(), [1, 0]);
    assert_eq!(rpdo.cob_id() & 0x7FF, 0x200 + u32::from(id));
    assert_eq!(rpdo.kinds(), [ValueKind::Real32, ValueKind::Real32]);
    assert_eq!(rpdo.mapping().bit_len(), 64);
    assert_eq!(r.with(|d| d.values().get_u64(0x1600, 0)), Some(2));
    assert_eq!(r.with(|d| d.values().get_u64(0x1600, 1)), Some(0x2541_0120));
    assert_eq!(r.with(|d| d.values().get_u64(0x1600, 2)), Some(0x2540_0120));
    let rpdo2 = r
        .node
        .map_control_values_to_rpdo(
            2,
            &[3],
            Some(CommParams::event_driven(0x300 + u16::from(id))),
        )
        .unwrap();
    assert_eq!(r.with(|d| d.values().get_u64(0x1401, 2)), Some(255));
    // A mapping the device cannot carry is refused by the device.
    let sdo = || r.node.node().sdo();
    sdo().write((0x1A03, 0), 0u8).unwrap();
    sdo().write((0x1A03, 1), 0x2500_0620u32).unwrap(); // precision: not PDO-mappable
    let e = sdo().write((0x1A03, 0), 1u8).unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::NOT_MAPPABLE), "{e}");

    let values = [PdoValue::Real32(-3.25), PdoValue::Real32(1.5)];
    let frame = rpdo.encode(&values).unwrap();
    assert_eq!(frame.data().len(), 8);

    // Pre-operational: ignored (the SDO read after it is answered after the RPDO was handled:
    // one socket, one order).
    r.node.send_control_values(&rpdo, &values).unwrap();
    assert_eq!(r.node.read_control_value(1).unwrap(), OdValue::Real32(0.0));
    assert_eq!(r.with(|d| d.control_value(1)), Some(0.0));

    r.node.node().nmt().start().unwrap();
    r.wait_state(id, NmtState::Operational);
    r.node.send_control_values(&rpdo, &values).unwrap();
    r.node
        .send_control_values(&rpdo2, &[PdoValue::Real32(99.5)])
        .unwrap();
    assert_eq!(
        r.node.read_control_value(1).unwrap(),
        OdValue::Real32(-3.25)
    );
    assert_eq!(r.node.read_control_value(0).unwrap(), OdValue::Real32(1.5));
    assert_eq!(r.node.read_control_value(3).unwrap(), OdValue::Real32(99.5));
    assert_eq!(r.with(|d| d.control_value(1)), Some(-3.25));
    assert_eq!(r.with(|d| d.control_value(0)), Some(1.5));
    assert_eq!(r.with(|d| d.control_value(3)), Some(99.5));

    // A wrong value type is a local error; nothing is sent.
    let e = r
        .node
        .send_control_values(&rpdo, &[PdoValue::Bool(true)])
        .unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
    assert_eq!(r.with(|d| d.control_value(1)), Some(-3.25));
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn demo_walkthrough_on_the_real_bus() {
    let r = Rig::new(0x6F, |_| {});
    let mut out = Vec::new();
    let summary = demo::run_with(
        &r.net,
        node(0x6F),
        &mut out,
        demo::Options {
            ansi: false,
            block: true,
        },
    )
    .unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("Generic device"), "{text}");
    assert!(text.contains("Locate started"), "{text}");
    assert!(text.contains("(flashing)"), "{text}");
    assert!(r.with(|d| d.locating()));
    let log = String::from_utf8(summary.logbook.clone()).unwrap();
    assert!(log.starts_with("<?xml"), "{log}");
    assert!(log.contains("locating started"), "{log}");
    let len = summary.logbook.len() as u64;
    assert_eq!(summary.progress.last(), Some(&(len, Some(len))));
}
