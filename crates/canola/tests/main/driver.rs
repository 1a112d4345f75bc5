//! The background driver: a network on a real-time bus that runs with no call from the
//! application, stops when asked or dropped, and reports a dead transport.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Duration as StdDuration;

use canola::mem::{BusConfig, ClockMode, Endpoint, MemoryBus};
use canola::transport::{Received, Transport, TransportError, TransportWaker};
use canola::{Error, HeartbeatEvent, Network, NetworkEvent, SimDevice, TransportFailure};
use canola_frame::{CanFrame, Duration, Instant, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn real_time_bus() -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    })
}

/// Collects the heartbeats of `node` that arrive within `within` (real time) while the
/// application makes no call on the network.
fn heartbeats(rx: &std::sync::mpsc::Receiver<NetworkEvent>, within: StdDuration) -> usize {
    let end = std::time::Instant::now() + within;
    let mut count = 0;
    while let Some(left) = end.checked_duration_since(std::time::Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(NetworkEvent::Heartbeat(_)) => count += 1,
            Ok(_) => {}
            Err(_) => break,
        }
    }
    count
}

#[test]
fn events_flow_with_no_call_from_the_application() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    net.node(n(5))
        .sdo()
        .write((0x1017, 0), 20u16)
        .wait()
        .unwrap();
    // Monitored: every heartbeat past the first is silent unless the state changes, so watch
    // loss and recovery instead: a consumer time shorter than the period loses and regains.
    net.monitor_heartbeat(n(5), Duration::from_millis(10));
    let rx = net.subscribe();

    // Without a driver nothing is received while the application sleeps.
    std::thread::sleep(StdDuration::from_millis(150));
    assert!(rx.try_recv().is_err(), "no driver, no events");

    net.start_driver().unwrap();
    assert!(net.is_driven());
    let seen = heartbeats(&rx, StdDuration::from_millis(400));
    assert!(
        seen >= 4,
        "heartbeat events while the application sleeps: {seen}"
    );

    // Requests still work (the waiting thread drives, the driver steps aside).
    for _ in 0..50 {
        assert_eq!(
            net.node(n(5)).sdo().read((0x1018, 1)).wait().unwrap(),
            0x39u32.to_le_bytes()
        );
    }

    net.stop_driver().unwrap();
    assert!(!net.is_driven());
    std::thread::sleep(StdDuration::from_millis(60));
    while rx.try_recv().is_ok() {}
    assert_eq!(heartbeats(&rx, StdDuration::from_millis(150)), 0);

    // The explicit mode goes on.
    net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert!(rx.try_iter().count() > 0);
}

#[test]
fn the_driver_ends_with_the_last_handle() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    net.start_driver().unwrap();
    let weak_probe = net.subscribe();
    drop(net);
    // The driver held only a weak handle: the core (and its subscriber list) is gone.
    assert!(matches!(
        weak_probe.recv_timeout(StdDuration::from_secs(2)),
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected)
    ));
}

/// An endpoint whose receive fails for good once `dead` is set.
struct Dying {
    ep: Endpoint,
    dead: Arc<AtomicBool>,
}

impl Transport for Dying {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.ep.send(frame)
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        if self.dead.load(Ordering::SeqCst) {
            return Err(TransportError::Closed);
        }
        self.ep.recv_until(deadline)
    }
    fn now(&self) -> Instant {
        self.ep.now()
    }
}

#[test]
fn a_dead_transport_is_an_event_and_an_error() {
    let bus = real_time_bus();
    let dead = Arc::new(AtomicBool::new(false));
    let net = Network::new(Dying {
        ep: bus.endpoint(),
        dead: dead.clone(),
    });
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    let rx = net.subscribe();
    net.start_driver().unwrap();
    let boot = rx.recv_timeout(StdDuration::from_secs(2)).unwrap();
    assert_eq!(
        boot,
        NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: n(5) })
    );
    dead.store(true, Ordering::SeqCst);
    let failed = rx
        .iter()
        .find(|e| matches!(e, NetworkEvent::TransportFailed { .. }))
        .expect("the failure is published");
    assert_eq!(
        failed,
        NetworkEvent::TransportFailed {
            bus: None,
            failure: TransportFailure::Closed,
        }
    );
    assert!(!net.is_driven());
    match net.stop_driver() {
        Err(Error::Driver { bus: None, failure }) => {
            assert_eq!(failure, TransportFailure::Closed)
        }
        other => panic!("expected the driver's error, got {other:?}"),
    }
    // A request now fails with the transport's error instead of hanging.
    let e = net.node(n(5)).sdo().read((0x1018, 1)).wait().unwrap_err();
    assert!(e.to_string().contains("closed"), "{e}");
}

/// What a [`Sleepy`] endpoint counts.
#[derive(Default)]
struct Waits {
    /// A blocking wait is in progress.
    waiting: AtomicBool,
    /// The waker was called (it is taken by the next wait).
    woken: AtomicBool,
    /// Waits the waker ended.
    ended_by_wake: AtomicU32,
    /// Waits that ran out the endpoint's patience (their deadline long passed).
    ran_out: AtomicU32,
}

/// An endpoint whose blocking waits ignore their deadline: they end at a frame, at its
/// waker, or after `PATIENCE` (wall clock), so a request submitted while the driver waits
/// leaves only if the network wakes the transport.
struct Sleepy {
    ep: Endpoint,
    waits: Arc<Waits>,
}

const PATIENCE: StdDuration = StdDuration::from_secs(3);

impl Transport for Sleepy {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.ep.send(frame)
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        if deadline <= self.ep.now() {
            return self.ep.recv_until(deadline);
        }
        self.waits.waiting.store(true, Ordering::SeqCst);
        let end = std::time::Instant::now() + PATIENCE;
        let r = loop {
            if self.waits.woken.swap(false, Ordering::SeqCst) {
                self.waits.ended_by_wake.fetch_add(1, Ordering::SeqCst);
                break Ok(None);
            }
            if std::time::Instant::now() >= end {
                self.waits.ran_out.fetch_add(1, Ordering::SeqCst);
                break Ok(None);
            }
            let slice = self.ep.now() + Duration::from_micros(500);
            match self.ep.recv_until(slice) {
                Ok(None) => {}
                got => break got,
            }
        };
        self.waits.waiting.store(false, Ordering::SeqCst);
        r
    }
    fn now(&self) -> Instant {
        self.ep.now()
    }
    fn has_pending(&self) -> bool {
        self.ep.has_pending()
    }
    fn waker(&self) -> Option<TransportWaker> {
        let waits = self.waits.clone();
        Some(TransportWaker::new(move || {
            waits.woken.store(true, Ordering::SeqCst)
        }))
    }
}

#[test]
fn a_request_submitted_while_the_driver_waits_wakes_the_transport() {
    let bus = real_time_bus();
    let waits = Arc::new(Waits::default());
    let net = Network::new(Sleepy {
        ep: bus.endpoint(),
        waits: waits.clone(),
    });
    let mut device = SimDevice::from_eds(n(5), EDS).unwrap();
    // No heartbeat: nothing on the bus ends the driver's wait.
    device.values_mut().set(0x1017, 0, 0u16.to_le_bytes());
    bus.attach(device);
    net.start_driver().unwrap();
    for _ in 0..5 {
        // The driver holds the transport in a wait that only a wake (or the patience) ends.
        let mut polls = 0;
        while !waits.waiting.load(Ordering::SeqCst) {
            polls += 1;
            assert!(polls < 10_000, "the driver never waited");
            std::thread::sleep(StdDuration::from_millis(1));
        }
        assert_eq!(
            net.node(n(5)).sdo().read((0x1018, 1)).wait().unwrap(),
            0x39u32.to_le_bytes()
        );
    }
    // Every request left through a wake, none waited for the end of the driver's wait.
    assert!(waits.ended_by_wake.load(Ordering::SeqCst) >= 5);
    assert_eq!(waits.ran_out.load(Ordering::SeqCst), 0);
    // Stopping the driver wakes it too.
    net.stop_driver().unwrap();
    assert_eq!(waits.ran_out.load(Ordering::SeqCst), 0);
}

#[cfg(feature = "tokio")]
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_driver_runs_on_the_callers_runtime() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    let rx = net.subscribe();
    net.start_driver_on_runtime();
    assert!(net.is_driven());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    let boot = tokio::task::spawn_blocking(move || rx.recv_timeout(StdDuration::from_secs(2)))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(
        boot,
        NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: n(5) })
    );
    assert_eq!(
        net.node(n(5)).sdo().read((0x1018, 1)).await.unwrap(),
        0x39u32.to_le_bytes()
    );
    net.stop_driver().unwrap();
    assert!(!net.is_driven());
}
