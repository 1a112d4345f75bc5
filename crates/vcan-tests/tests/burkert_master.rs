//! The Bürkert profile's master side (`canola_burkert::BurkertNode` over `canola::Network` on
//! the SocketCAN transport) against the simulated Bürkert device
//! (`canola_burkert::BurkertDevice`, served by `canola::run_station` on a second socket) over
//! the real kernel CAN stack: every `BurkertNode` operation, checked on both sides — what the
//! master decodes is compared with the device's own state, and what the master writes or sends
//! is looked up in the device.
//!
//! The scenarios are the ones the in-memory bus runs (`cargo test -p canola-burkert --features
//! master`), written once in `crates/burkert/tests/scenarios/mod.rs`; this file adds the
//! real-bus rig and what only it shows (locate running its time on the real clock).
//!
//! Ignored on the host; `tests/vcan/run-all` runs them in the QEMU guest with `--ignored
//! --test-threads=1` (the LSS services use switch-mode-global, which addresses every device on
//! the bus, so only one simulated device may be on `vcan0` at a time). Each test still uses its
//! own node-IDs.

#[path = "../../burkert/tests/scenarios/mod.rs"]
mod scenarios;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

use canola::socketcan::SocketCan;
use canola::transport::Station;
use canola::{Network, TransportError, run_station};
use canola_burkert::BurkertDevice;
use canola_burkert::sim::LOCATE_DURATION;
use canola_frame::{CanFrame, Instant};
use canola_lss::Procedure;
use scenarios::{Device, Master, node_id as node};

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
}

impl Device for RunningDevice {
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

/// The master on its own socket and one simulated device on another.
struct Rig {
    m: Master,
    dev: RunningDevice,
}

impl Rig {
    /// Starts a device with node-ID `id` and waits for its boot-up and its first
    /// Pre-Operational heartbeat.
    fn new(id: u8) -> Self {
        let net = Network::new(
            SocketCan::open(&vcan_tests::interface()).expect("open the master's socket"),
        );
        let m = Master::new(net, node(id));
        let mut rig = Rig {
            m,
            dev: RunningDevice::start(BurkertDevice::new(node(id))),
        };
        rig.m.wait_ready();
        rig
    }
}

/// Tests that run shared scenarios, in order, on a fresh rig with their own node-ID:
/// `test_name(node-ID): scenario, ...;`.
macro_rules! scenario_tests {
    ($($name:ident($id:literal): $($scenario:ident),+;)+) => {$(
        #[test]
        #[ignore = "needs vcan0: run by tests/vcan/run-all"]
        fn $name() {
            let mut r = Rig::new($id);
            $(scenarios::$scenario(&mut r.m, &r.dev);)+
        }
    )+};
}

scenario_tests! {
    description_status_communication_and_report_in_one_call(0x61):
        description_status_communication_and_report, operation_status_follows_nmt;
    user_configuration_termination_bus_mode_values_and_precisions(0x62):
        user_configuration, termination_and_bus_mode, values_and_precisions;
    led_mode_and_colours_drive_the_device_led(0x63):
        led_mode_and_colours;
    logbook_downloads_intact_with_progress_block_and_segmented(0x65):
        logbook;
    bit_rate_through_0x2001_survives_a_communication_reset_and_lss_bit_timing_is_confirmed(0x66):
        bit_rate;
    device_reset_through_0x2001_sub_4_boots_and_ends_locate_and_maintenance(0x67):
        device_reset;
    sensor_values_mapped_to_tpdos_arrive_typed_when_operational(0x6D):
        sensor_values_in_tpdos;
    control_values_sent_by_rpdo_reach_the_device(0x6E):
        control_values_by_rpdo;
    demo_walkthrough_on_the_real_bus(0x6F):
        demo_walkthrough;
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn locating_runs_its_time_and_maintenance_shows_blue_unless_outranked() {
    let mut r = Rig::new(0x64);
    let started = std::time::Instant::now();
    scenarios::start_locating(&mut r.m, &r.dev);

    // The device stops flashing by itself, not before LOCATE_DURATION of its (real) clock.
    let limit = std::time::Duration::from_secs(60);
    while r.dev.with(|d| d.locating()) {
        assert!(started.elapsed() < limit, "still locating after {limit:?}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    assert!(
        started.elapsed() >= std::time::Duration::from_micros(LOCATE_DURATION.as_micros()),
        "stopped after {:?}",
        started.elapsed()
    );
    scenarios::locating_needs_a_zero_before_restart(&mut r.m, &r.dev);
    scenarios::maintenance(&mut r.m, &r.dev);
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn node_id_change_through_0x2001_answers_on_the_new_id() {
    let mut r = Rig::new(0x68);
    scenarios::node_id_change(&mut r.m, &r.dev, node(0x69), node(0x6A));
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn node_id_set_by_lss_becomes_active_at_nmt_reset_and_shows_in_0x2001() {
    let mut r = Rig::new(0x6B);
    // Selected by its LSS address (the in-memory test uses switch-mode-global).
    let address = r.dev.with(|d| d.sim().lss_address());
    let assign = Procedure::assign_node_id_selective(address, node(0x6C), false);
    scenarios::node_id_by_lss(&mut r.m, &r.dev, node(0x6C), assign);
}
