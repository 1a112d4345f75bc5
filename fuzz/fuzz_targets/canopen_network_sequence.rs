//! Structure-aware sequences against the whole master: `Network` (stepping mode, virtual clock)
//! and a simulated device on the in-memory bus, driven by `arbitrary` operations: SDO requests
//! of every method and size (submitted, so several are in flight at once), cancels, drops, clock
//! steps, raw frames from a third station (anything on any identifier), NMT commands and device
//! power cycles.
//!
//! Checked: no panic anywhere; while nothing foreign has happened (no raw frame, no power cycle,
//! no NMT command), a write followed by a read of the same object returns the bytes written;
//! every request still pending at the end completes within its timeout and its bus time; and
//! after a final power cycle the stack still reads the device's type (0x1000), whatever came
//! before.
//!
//! Run with `-max_len=512` (fuzz/options/canopen_network_sequence.txt): a run takes at most 64
//! operations, a few bytes each, so longer inputs only add unused tail or long injected frames
//! (cut to 8 bytes anyway).
#![no_main]

use std::collections::VecDeque;
use std::sync::OnceLock;

use arbitrary::Arbitrary;
use canola::mem::StationId;
use canola::{
    BusConfig, CanFrame, CanId, Duration, Instant, MemoryBus, Method, Network, NodeId,
    ObjectDictionary, Pending, SimDevice, Station,
};
use libfuzzer_sys::fuzz_target;

const EDS: &[u8] = include_bytes!("../../tests/vcan/test-device.eds");
const NODE: u8 = 5;
/// VISIBLE_STRING, read-write, any length: the object the segmented and block transfers move.
const TEXT: (u16, u8) = (0x2001, 0);
/// Per-request timeout: short, so timeouts happen inside a run.
const TIMEOUT: Duration = Duration::from_millis(50);
const MAX_IN_FLIGHT: usize = 8;
/// The bus time of the longest transfer's own frames: the text object's 2047 bytes in 293
/// segments, each segment and its answer a frame of at most 135 bits (8 data bytes, worst-case
/// stuffing) at 1 Mbit/s, plus initiate and end. The response timeout bounds each wait for an
/// answer, not a whole transfer: eight segmented transfers of 2 KB take about 520 ms while
/// every answer comes in time.
const LONGEST_TRANSFER: Duration = Duration::from_micros((2047u64.div_ceil(7) + 2) * 2 * 135);
/// How far the final wait for the requests in flight drives at a time.
const SETTLE_SLICE: Duration = Duration::from_millis(5);

#[derive(Debug, Arbitrary)]
enum Op {
    /// Upload of one of a few objects (existing, missing, the text object).
    Read { object: u8, method: u8 },
    /// Download of `len` bytes to the text object, or of a raw value anywhere.
    Write {
        object: u8,
        method: u8,
        len: u16,
        salt: u8,
    },
    /// Blocking write then read of the text object, compared when the run is still clean.
    RoundTrip { method: u8, len: u16, salt: u8 },
    /// Cancels (sends the abort) or just drops one request in flight.
    Cancel { which: u8, drop_only: bool },
    /// Runs the network for this many microseconds of virtual time.
    Step(u16),
    /// A frame from a third station.
    Inject { id: u16, data: Vec<u8> },
    /// An NMT command to the device (or to all nodes).
    Nmt { command: u8, all: bool },
    /// The device is switched off and on again.
    PowerCycle,
}

/// A station that transmits whatever it is given.
#[derive(Default)]
struct Injector(VecDeque<CanFrame>);

impl Station for Injector {
    fn handle_frame(&mut self, _now: Instant, _frame: &CanFrame) {}
    fn handle_timeout(&mut self, _now: Instant) {}
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.0.pop_front()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
}

fn dictionary() -> &'static ObjectDictionary {
    static OD: OnceLock<ObjectDictionary> = OnceLock::new();
    OD.get_or_init(|| canola::od::parse(EDS).expect("the rig's EDS parses").od)
}

fn node() -> NodeId {
    NodeId::new(NODE).expect("valid node-ID")
}

fn device() -> SimDevice {
    SimDevice::new(node(), dictionary().clone())
}

fn method(m: u8) -> Method {
    match m % 3 {
        0 => Method::Normal,
        1 => Method::Segmented,
        _ => Method::Block,
    }
}

/// The text written: 0..=2047 bytes (so block transfers span several sub-blocks), with the top
/// bits of `len` shifting the length down (by 0..=7 bits): every length stays reachable, but
/// most transfers are short, so a run's time goes to more operations rather than to segments.
fn payload(len: u16, salt: u8) -> Vec<u8> {
    (0..(len & 0x7FF) >> (len >> 13))
        .map(|i| (i as u8).wrapping_mul(13).wrapping_add(salt) | 0x20)
        .collect()
}

fn object(o: u8) -> (u16, u8) {
    match o % 5 {
        0 => TEXT,
        1 => (0x1000, 0),
        2 => (0x1017, 0),
        3 => (0x1018, o % 6),
        _ => (0x5FFF, o),
    }
}

enum InFlight {
    Read(Pending<Vec<u8>>),
    Write(Pending<()>),
}

impl InFlight {
    fn is_done(&self) -> bool {
        match self {
            InFlight::Read(p) => p.is_done(),
            InFlight::Write(p) => p.is_done(),
        }
    }
    fn finish(self) {
        // The outcome may be anything but a hang or a panic.
        match self {
            InFlight::Read(p) => drop(p.wait()),
            InFlight::Write(p) => drop(p.wait()),
        }
    }
}

fuzz_target!(|ops: Vec<Op>| {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let mut dev: StationId<SimDevice> = bus.attach(device());
    let injector = bus.attach(Injector::default());
    let _ = net.run_for(Duration::from_millis(2)).wait();
    let sdo = || net.node(node()).sdo().timeout(TIMEOUT);
    let mut clean = true;
    let mut in_flight: Vec<InFlight> = Vec::new();

    for op in ops.into_iter().take(64) {
        match op {
            Op::Read {
                object: o,
                method: m,
            } => {
                if in_flight.len() < MAX_IN_FLIGHT {
                    in_flight.push(InFlight::Read(
                        sdo().method(method(m)).submit_read(object(o)),
                    ));
                }
            }
            Op::Write {
                object: o,
                method: m,
                len,
                salt,
            } => {
                if in_flight.len() < MAX_IN_FLIGHT {
                    let at = object(o);
                    let data = if at == TEXT {
                        payload(len, salt)
                    } else {
                        vec![salt; (len % 5) as usize]
                    };
                    in_flight.push(InFlight::Write(
                        sdo().method(method(m)).submit_write(at, data),
                    ));
                }
            }
            Op::RoundTrip {
                method: m,
                len,
                salt,
            } => {
                // Settle what is in flight first: a queued request must not interleave.
                for p in in_flight.drain(..) {
                    p.finish();
                }
                let data = payload(len, salt);
                let m = method(m);
                let wrote = sdo().method(m).write(TEXT, data.clone()).wait();
                let read = sdo().method(m).read(TEXT).wait();
                if clean {
                    assert!(wrote.is_ok(), "clean write failed: {wrote:?}");
                    let read = read.expect("clean read failed");
                    assert_eq!(read, data, "read back differs from what was written");
                }
            }
            Op::Cancel { which, drop_only } => {
                if !in_flight.is_empty() {
                    let p = in_flight.swap_remove(which as usize % in_flight.len());
                    match (p, drop_only) {
                        (p, true) => drop(p),
                        (InFlight::Read(p), false) => p.cancel(),
                        (InFlight::Write(p), false) => p.cancel(),
                    }
                }
            }
            Op::Step(us) => {
                let _ = net.run_for(Duration::from_micros(u64::from(us))).wait();
            }
            Op::Inject { id, data } => {
                let id = CanId::standard(id & 0x7FF).expect("11-bit identifier");
                let len = data.len().min(8);
                if let Ok(frame) = CanFrame::new(id, &data[..len]) {
                    clean = false;
                    bus.with_station(injector, |s| s.0.push_back(frame));
                }
            }
            Op::Nmt { command, all } => {
                clean = false;
                let target = if all { 0 } else { NODE };
                let cs = [0x01, 0x02, 0x80, 0x81, 0x82][command as usize % 5];
                let id = CanId::standard(0x000).expect("NMT identifier");
                if let Ok(frame) = CanFrame::new(id, &[cs, target]) {
                    bus.with_station(injector, |s| s.0.push_back(frame));
                }
            }
            Op::PowerCycle => {
                clean = false;
                let _ = bus.detach(dev);
                dev = bus.attach(device());
            }
        }
    }

    // Everything still in flight ends within its timeout and its own bus time (plus queueing
    // behind the others).
    // Driven in slices until the allowance is over or nothing is left to happen: every request
    // done, none queued or running in the master (dropped ones included), no frame waiting in
    // the master, on the bus or at the third station. The rest of the allowance would only
    // step an idle bus, so stopping there gives the verdict of running all of it.
    let allowance =
        net.now() + (TIMEOUT + LONGEST_TRANSFER).saturating_mul(MAX_IN_FLIGHT as u64 + 2);
    loop {
        let _ = net
            .run_until((net.now() + SETTLE_SLICE).min(allowance))
            .wait();
        let o = net.occupancy();
        let settled = in_flight.iter().all(InFlight::is_done)
            && o.requests <= in_flight.len()
            && o.queued_requests == 0
            && o.unsent_frames == 0
            && bus.pending_frames() == 0
            && bus.with_station(injector, |s| s.0.is_empty()) != Some(false);
        if settled || net.now() >= allowance {
            break;
        }
    }
    for p in &in_flight {
        assert!(p.is_done(), "a request outlived every timeout");
    }
    for p in in_flight {
        p.finish();
    }

    // The stack is still usable: a fresh device answers.
    let _ = bus.detach(dev);
    bus.attach(device());
    let _ = net.run_for(Duration::from_millis(5)).wait();
    let r = net
        .node(node())
        .sdo()
        .timeout(TIMEOUT)
        .read((0x1000, 0))
        .wait();
    assert!(
        r.is_ok(),
        "the master is unusable after the sequence: {r:?}"
    );
});
