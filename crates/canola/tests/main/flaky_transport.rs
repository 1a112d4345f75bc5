//! A transport that fails intermittently: a wrapper around an in-memory bus endpoint whose
//! every Nth send or receive returns an error while the calls in between work. The outcomes,
//! each checked exactly:
//! - blocking SDO requests (every method) while every 7th send fails with `TxQueueFull` (the
//!   kernel's `ENOBUFS`): back-pressure, the frame is sent again a moment later, so every
//!   request returns the correct value.
//! - the same with every 7th send failing with an operating-system error: each request returns
//!   the correct value, or ends with `SdoErrorKind::Transport` carrying the transport's words;
//!   one failed send ends exactly one request (the one being waited on), and the next request
//!   works. Never wrong data, never a hang.
//! - the same with every 11th receive failing with an operating-system error.
//! - the background driver: transient send errors (`TxQueueFull`) keep it driving (heartbeat
//!   events keep arriving); an operating-system error on receive ends it with
//!   `NetworkEvent::TransportFailed` and `stop_driver`'s error, after which blocking calls drive
//!   the network themselves and work once the transport does.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration as StdDuration;

use canola::mem::{BusConfig, ClockMode, Endpoint, MemoryBus};
use canola::transport::{Received, Transport, TransportError};
use canola::{Error, HeartbeatEvent, Method, Network, NetworkEvent, SdoErrorKind, SimDevice};
use canola_frame::{CanFrame, Duration, Instant, NodeId};

const EDS: &[u8] = include_bytes!("../../../../tests/vcan/test-device.eds");
const NODE: u8 = 5;

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

/// Which calls fail: every `send_every`th send and every `recv_every`th receive (0: none).
#[derive(Debug, Clone, Copy, Default)]
struct Plan {
    send_every: u64,
    recv_every: u64,
    /// Whether a failing receive is an operating-system error (else `TxQueueFull`-like
    /// transient errors are only injected on send).
    recv_io: bool,
    /// Whether a failing send is an operating-system error (else `TxQueueFull`).
    send_io: bool,
}

/// Counts of what the wrapper did.
#[derive(Debug, Default)]
struct Counts {
    send_failures: AtomicU64,
    recv_failures: AtomicU64,
}

/// The wrapper: an endpoint plus a failure plan that the test may change at any time.
struct Flaky {
    ep: Endpoint,
    plan: Arc<Mutex<Plan>>,
    counts: Arc<Counts>,
    sends: u64,
    recvs: u64,
}

impl Flaky {
    fn new(ep: Endpoint, plan: Plan) -> (Self, Arc<Mutex<Plan>>, Arc<Counts>) {
        let plan = Arc::new(Mutex::new(plan));
        let counts = Arc::new(Counts::default());
        let t = Self {
            ep,
            plan: plan.clone(),
            counts: counts.clone(),
            sends: 0,
            recvs: 0,
        };
        (t, plan, counts)
    }
}

impl Transport for Flaky {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let plan = *self.plan.lock().unwrap();
        self.sends += 1;
        if plan.send_every > 0 && self.sends.is_multiple_of(plan.send_every) {
            self.counts.send_failures.fetch_add(1, Ordering::SeqCst);
            return Err(if plan.send_io {
                TransportError::Io(std::io::Error::other("injected send failure"))
            } else {
                TransportError::TxQueueFull
            });
        }
        self.ep.send(frame)
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        let plan = *self.plan.lock().unwrap();
        self.recvs += 1;
        if plan.recv_every > 0 && self.recvs.is_multiple_of(plan.recv_every) {
            self.counts.recv_failures.fetch_add(1, Ordering::SeqCst);
            return Err(if plan.recv_io {
                TransportError::Io(std::io::Error::other("injected receive failure"))
            } else {
                TransportError::InterfaceDown
            });
        }
        self.ep.recv_until(deadline)
    }

    fn now(&self) -> Instant {
        self.ep.now()
    }
}

/// What a run of requests gave.
#[derive(Debug, Default)]
struct Outcome {
    ok: u64,
    transport_errors: u64,
    /// Other clean errors (a timeout, an abort) with their text.
    other_errors: Vec<String>,
}

impl Outcome {
    fn take<T: PartialEq + core::fmt::Debug>(
        &mut self,
        got: Result<T, canola::SdoError>,
        want: &T,
        transport_text: &str,
    ) -> bool {
        match got {
            Ok(v) => {
                assert_eq!(&v, want, "wrong data after {} requests", self.ok);
                self.ok += 1;
                true
            }
            Err(e) => {
                match &e.kind {
                    SdoErrorKind::Transport(failure) => {
                        assert_eq!(failure.to_string(), transport_text, "{e}");
                        self.transport_errors += 1;
                    }
                    _ => self.other_errors.push(e.to_string()),
                }
                false
            }
        }
    }
}

/// Runs a mix of SDO requests to one device over a flaky transport: writes of 0x2001 (a
/// string) by every method, each followed by a read by every method that must return the
/// last value written successfully.
fn requests_over(plan: Plan, transport_text: &str) -> (Outcome, Arc<Counts>) {
    let bus = MemoryBus::new();
    let (t, plan_handle, counts) = Flaky::new(bus.endpoint(), Plan::default());
    let net = Network::new(t);
    bus.attach(SimDevice::from_eds(n(NODE), EDS).unwrap());
    net.run_for(Duration::from_millis(10)).wait().unwrap();
    *plan_handle.lock().unwrap() = plan;

    let node = net.node(n(NODE));
    let sdo = || node.sdo().timeout(Duration::from_millis(200));
    let mut out = Outcome::default();
    let mut value = b"hello".to_vec();
    let methods = [Method::Normal, Method::Segmented, Method::Block];
    for i in 0..240u32 {
        let method = methods[(i % 3) as usize];
        if i % 2 == 0 {
            let len = 1 + (i as usize * 37) % 300;
            let new: Vec<u8> = (0..len)
                .map(|k| b'a' + ((k + i as usize) % 26) as u8)
                .collect();
            let got = sdo()
                .method(method)
                .submit_write((0x2001, 0), new.clone())
                .wait();
            if out.take(got, &(), transport_text) {
                value = new;
            }
        } else {
            let got = sdo()
                .block(method == Method::Block)
                .submit_read((0x2001, 0))
                .wait();
            out.take(got, &value, transport_text);
        }
    }
    // The faults end: the next request works.
    *plan_handle.lock().unwrap() = Plan::default();
    let last = sdo()
        .read((0x2001, 0))
        .wait()
        .expect("a request after the faults");
    assert_eq!(last.to_vec(), value);
    (out, counts)
}

#[test]
fn every_seventh_send_refused_for_a_full_queue_is_sent_again_and_every_request_works() {
    let (out, counts) = requests_over(
        Plan {
            send_every: 7,
            ..Plan::default()
        },
        "the transmit queue is full",
    );
    let failures = counts.send_failures.load(Ordering::SeqCst);
    eprintln!("{out:?}, {failures} sends refused");
    assert!(failures > 20, "{failures}");
    assert_eq!(out.ok, 240, "back-pressure loses no request: {out:?}");
    assert_eq!(out.transport_errors, 0, "{out:?}");
    assert!(out.other_errors.is_empty(), "{:?}", out.other_errors);
}

#[test]
fn every_seventh_send_failing_ends_one_request_each_with_the_transport_error() {
    let (out, counts) = requests_over(
        Plan {
            send_every: 7,
            send_io: true,
            ..Plan::default()
        },
        "CAN I/O error: injected send failure",
    );
    let failures = counts.send_failures.load(Ordering::SeqCst);
    eprintln!("{out:?}, {failures} sends failed");
    assert!(out.ok > 50, "{out:?}");
    assert!(failures > 20, "{failures}");
    assert_eq!(
        out.transport_errors, failures,
        "one failed send ends exactly one request: {out:?}"
    );
    assert!(out.other_errors.is_empty(), "{:?}", out.other_errors);
}

#[test]
fn every_eleventh_receive_failing_ends_one_request_each_with_the_transport_error() {
    let (out, counts) = requests_over(
        Plan {
            recv_every: 11,
            recv_io: true,
            ..Plan::default()
        },
        "CAN I/O error: injected receive failure",
    );
    let failures = counts.recv_failures.load(Ordering::SeqCst);
    eprintln!("{out:?}, {failures} receives failed");
    assert!(out.ok > 50, "{out:?}");
    assert!(failures > 20, "{failures}");
    assert_eq!(
        out.transport_errors, failures,
        "one failed receive ends exactly one request: {out:?}"
    );
    assert!(out.other_errors.is_empty(), "{:?}", out.other_errors);
}

/// Heartbeat events within `within` of real time.
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
fn the_driver_rides_out_transient_send_errors_and_stops_cleanly_on_an_io_error() {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let (t, plan, counts) = Flaky::new(bus.endpoint(), Plan::default());
    let net = Network::new(t);
    bus.attach(SimDevice::from_eds(n(NODE), EDS).unwrap());
    // A consumer time shorter than the 20 ms heartbeat period: every heartbeat is a loss and a
    // recovery, so events flow as long as the driver receives.
    net.node(n(NODE))
        .sdo()
        .write((0x1017, 0), 20u16)
        .wait()
        .unwrap();
    net.monitor_heartbeat(n(NODE), Duration::from_millis(10));
    let rx = net.subscribe();
    net.start_driver().unwrap();

    // Transient: every 3rd send fails with TxQueueFull (the driver sends guarding-free
    // traffic only when asked, so requests make the sends).
    *plan.lock().unwrap() = Plan {
        send_every: 3,
        ..Plan::default()
    };
    for _ in 0..30 {
        let _ = net.node(n(NODE)).sdo().read((0x1018, 1)).wait();
    }
    assert!(counts.send_failures.load(Ordering::SeqCst) >= 10);
    assert!(
        net.is_driven(),
        "a transient send error must not end the driver"
    );
    let seen = heartbeats(&rx, StdDuration::from_millis(300));
    assert!(
        seen >= 4,
        "the driver went on receiving: {seen} heartbeat events"
    );

    // An operating-system error on receive ends the driver, cleanly and visibly.
    *plan.lock().unwrap() = Plan {
        recv_every: 5,
        recv_io: true,
        ..Plan::default()
    };
    let failed = rx
        .iter()
        .find(|e| matches!(e, NetworkEvent::TransportFailed { .. }))
        .expect("the failure is published");
    let NetworkEvent::TransportFailed { bus: None, failure } = failed else {
        panic!("expected the transport's failure, got {failed:?}");
    };
    assert_eq!(failure.io_kind(), Some(std::io::ErrorKind::Other));
    assert_eq!(
        failure.to_string(),
        "CAN I/O error: injected receive failure"
    );
    assert!(!net.is_driven());
    match net.stop_driver() {
        Err(e @ Error::Driver { .. }) => assert_eq!(
            e.to_string(),
            "the network's driver stopped: CAN I/O error: injected receive failure"
        ),
        other => panic!("expected the driver's error, got {other:?}"),
    }

    // The transport works again: blocking calls drive the network themselves.
    *plan.lock().unwrap() = Plan::default();
    let v = net
        .node(n(NODE))
        .sdo()
        .read((0x1018, 1))
        .wait()
        .expect("a read after the driver ended");
    assert_eq!(v, 0x0ABCu32.to_le_bytes());
    // A restarted driver runs again.
    net.start_driver().unwrap();
    assert!(net.is_driven());
    let again = rx
        .iter()
        .find(|e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::Recovered { .. })));
    assert!(again.is_some());
}
