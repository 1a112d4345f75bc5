//! TPDOs received through `canola::Network` and delivered to a subscriber as decoded, typed
//! values: the master's CPU cost per frame, 64 nodes, side by side with the decode alone.
//!
//! The frames are those of the full-load test (`canola_bench::load`): per SYNC, every node
//! sends TPDO1 (sequence counter UNSIGNED32, INTEGER32) and TPDO2 (counter, REAL32). They are
//! built up front and handed to the master by a replay transport, as a socket with a full
//! receive queue would hand them over, so the figure is the master's own work: receive, route
//! to the node, decode through the node's dictionary, publish, and the subscriber's match on
//! the typed values (every counter and value is checked; a wrong or missing one fails the run).
//!
//! Rows (process CPU time per frame, best of three runs after a warm-up):
//! * `decode alone (canola-pdo unpack)`: the mapping applied to the frame bytes, nothing else —
//!   the floor;
//! * `Network, stepping, subscriber on the same thread`: the calling thread drives
//!   (`run_until(now)`) and drains the subscriber;
//! * `Network, stepping, PDO callback (on_pdo)`: the same checks in a callback given to
//!   `Network::on_pdo` (borrowed values, no event, no channel);
//! * `Network, stepping, batch subscriber (subscribe_pdos)`: the stepping row with the batch
//!   subscriber drained between steps (same checks, borrowed values as the callback's);
//! * `Network, driver thread, subscriber on another`: `Network::start_driver`, the subscriber
//!   blocks in `recv` on the main thread (the CPU of both threads counts);
//! * `Network, driver thread, batch subscriber on another`: the same with the batch
//!   subscriber blocked in `recv_timeout`.
//!
//! ```text
//! cargo run --release -p canola-bench --bin pdo_rx [-- --nodes 64 --syncs 2000]
//!     [--only stepping|driver|callback|batch|batch-driver]
//! ```
//! `--only` runs one row once (for a profiler).
//! python-canopen needs about 3.3 µs per frame with a callback (MACHINE-FACTS).

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::Receiver;

use canola::frame::time::MonotonicClock;
use canola::pdo::{Mapping, MappingEntry, RawValue, ValueKind, unpack};
use canola::{
    CanFrame, CanId, Instant, Network, NetworkEvent, NodeId, ObjectAddress, Received, Transport,
    TransportError, Value,
};
use canola_bench::load::{expected_i32, expected_real, master_dictionary};

fn process_cpu_ns() -> f64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID)
        .map_or(0.0, |t| t.tv_sec() as f64 * 1e9 + t.tv_nsec() as f64)
}

/// The frames of `syncs` SYNC periods of `nodes` load devices, in bus order.
fn frames(nodes: u8, syncs: u32) -> Vec<CanFrame> {
    let mut out = Vec::with_capacity(usize::from(nodes) * 2 * syncs as usize);
    for c in 1..=syncs {
        for tpdo in 0..2u16 {
            for n in 1..=nodes {
                let mut data = [0u8; 8];
                data[..4].copy_from_slice(&c.to_le_bytes());
                let second = if tpdo == 0 {
                    expected_i32(n, c).to_le_bytes()
                } else {
                    expected_real(c).to_le_bytes()
                };
                data[4..].copy_from_slice(&second);
                let id = CanId::standard(0x180 + 0x100 * tpdo + u16::from(n)).expect("COB-ID");
                out.push(CanFrame::new(id, &data).expect("8 bytes"));
            }
        }
    }
    out
}

/// Hands the prepared frames over as fast as they are asked for, then nothing (it sleeps
/// until the deadline, as a quiet socket would). Real clock.
struct Replay {
    frames: Arc<Vec<CanFrame>>,
    next: Arc<AtomicUsize>,
    clock: MonotonicClock,
}

impl Transport for Replay {
    fn send(&mut self, _: &CanFrame) -> Result<(), TransportError> {
        Ok(())
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        let i = self.next.load(Ordering::Relaxed);
        if let Some(frame) = self.frames.get(i) {
            self.next.store(i + 1, Ordering::Relaxed);
            return Ok(Some(Received::Frame {
                frame: *frame,
                at: self.clock.now(),
            }));
        }
        let now = self.clock.now();
        if deadline > now {
            let wait = (deadline.as_micros() - now.as_micros()).min(1000);
            std::thread::sleep(std::time::Duration::from_micros(wait));
        }
        Ok(None)
    }
    fn now(&self) -> Instant {
        self.clock.now()
    }
    fn has_pending(&self) -> bool {
        self.next.load(Ordering::Relaxed) < self.frames.len()
    }
}

/// Checks each decoded TPDO: counter in order per node and TPDO, the second value typed and
/// equal to what the device derived from the counter.
struct Checker {
    last: Vec<u32>,
    seen: usize,
}

impl Checker {
    fn new(nodes: u8) -> Self {
        Self {
            last: vec![0; usize::from(nodes) * 2 + 2],
            seen: 0,
        }
    }

    fn take(&mut self, e: &NetworkEvent) {
        let NetworkEvent::PdoValues {
            node,
            number,
            values,
            ..
        } = e
        else {
            return;
        };
        self.check(*node, *number, values);
    }

    fn check(&mut self, node: NodeId, number: u8, values: &[(ObjectAddress, Value)]) {
        let (Some((_, Value::Unsigned32(c))), Some((_, second))) = (values.first(), values.get(1))
        else {
            panic!("node {node} TPDO{number}: not the mapped types: {values:?}");
        };
        let c = *c;
        let ok = match (number, second) {
            (1, Value::Integer32(v)) => *v == expected_i32(node.get(), c),
            (2, Value::Real32(v)) => *v == expected_real(c),
            _ => false,
        };
        assert!(ok, "node {node} TPDO{number}: wrong value {second:?}");
        let slot = &mut self.last[usize::from(node.get()) * 2 + usize::from(number) - 2];
        assert_eq!(
            c,
            *slot + 1,
            "node {node} TPDO{number}: counter out of order"
        );
        *slot = c;
        self.seen += 1;
    }
}

fn network(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> (Network, Receiver<NetworkEvent>) {
    let replay = Replay {
        frames: frames.clone(),
        next: Arc::new(AtomicUsize::new(0)),
        clock: MonotonicClock::new(),
    };
    let net = Network::new(replay);
    let od = master_dictionary();
    for n in 1..=nodes {
        net.add_node_with_dictionary(NodeId::new(n).expect("node-ID"), od.clone());
    }
    let rx = net.subscribe();
    (net, rx)
}

fn stepping(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> f64 {
    let (net, rx) = network(nodes, frames);
    let mut check = Checker::new(nodes);
    let t0 = process_cpu_ns();
    while check.seen < frames.len() {
        net.run_until(net.now()).wait().expect("replay never fails");
        for e in rx.try_iter() {
            check.take(&e);
        }
    }
    (process_cpu_ns() - t0) / frames.len() as f64
}

fn callback(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> f64 {
    let (net, rx) = network(nodes, frames);
    drop(rx); // no event subscriber: the callback alone
    let seen = Arc::new(AtomicUsize::new(0));
    let mut check = Checker::new(nodes);
    let count = seen.clone();
    net.on_pdo(move |p| {
        check.check(p.node, p.number, p.values);
        count.store(check.seen, Ordering::Relaxed);
    });
    let t0 = process_cpu_ns();
    while seen.load(Ordering::Relaxed) < frames.len() {
        net.run_until(net.now()).wait().expect("replay never fails");
    }
    (process_cpu_ns() - t0) / frames.len() as f64
}

/// The batch subscriber (`Network::subscribe_pdos`), drained on the stepping thread.
fn batch_stepping(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> f64 {
    let (net, rx) = network(nodes, frames);
    drop(rx);
    let mut pdos = net.subscribe_pdos();
    let mut check = Checker::new(nodes);
    let t0 = process_cpu_ns();
    while check.seen < frames.len() {
        net.run_until(net.now()).wait().expect("replay never fails");
        if let Ok(batch) = pdos.try_recv() {
            for p in batch {
                check.check(p.node, p.number, p.values);
            }
        }
    }
    (process_cpu_ns() - t0) / frames.len() as f64
}

/// The batch subscriber blocked in `recv_timeout` on the main thread, the driver thread
/// receiving.
fn batch_driver(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> f64 {
    let (net, rx) = network(nodes, frames);
    drop(rx);
    let mut pdos = net.subscribe_pdos();
    let mut check = Checker::new(nodes);
    let t0 = process_cpu_ns();
    net.start_driver().expect("driver thread");
    while check.seen < frames.len() {
        let batch = pdos
            .recv_timeout(std::time::Duration::from_secs(10))
            .expect("every frame arrives");
        for p in batch {
            check.check(p.node, p.number, p.values);
        }
    }
    let ns = (process_cpu_ns() - t0) / frames.len() as f64;
    net.stop_driver().expect("driver ended cleanly");
    ns
}

fn driver(nodes: u8, frames: &Arc<Vec<CanFrame>>) -> f64 {
    let (net, rx) = network(nodes, frames);
    let mut check = Checker::new(nodes);
    let t0 = process_cpu_ns();
    net.start_driver().expect("driver thread");
    while check.seen < frames.len() {
        let e = rx
            .recv_timeout(std::time::Duration::from_secs(10))
            .expect("every frame arrives");
        check.take(&e);
    }
    let ns = (process_cpu_ns() - t0) / frames.len() as f64;
    net.stop_driver().expect("driver ended cleanly");
    ns
}

fn decode_alone(nodes: u8, frames: &[CanFrame]) -> f64 {
    let m1 = Mapping::new()
        .with(MappingEntry::new(0x2000, 1, 32), ValueKind::Unsigned)
        .and_then(|m| m.with(MappingEntry::new(0x2000, 2, 32), ValueKind::Signed))
        .expect("mapping");
    let m2 = Mapping::new()
        .with(MappingEntry::new(0x2000, 1, 32), ValueKind::Unsigned)
        .and_then(|m| m.with(MappingEntry::new(0x2000, 3, 32), ValueKind::Real32))
        .expect("mapping");
    let mut sum = 0u64;
    let t0 = process_cpu_ns();
    for f in frames {
        let m = if f.id().as_raw() < 0x280 { &m1 } else { &m2 };
        let u = unpack(m, f.data()).expect("8 bytes");
        for (_, v) in u.iter() {
            if let RawValue::Unsigned(c) = v {
                sum = sum.wrapping_add(c);
            }
        }
    }
    let ns = (process_cpu_ns() - t0) / frames.len() as f64;
    let syncs = frames.len() as u64 / (2 * u64::from(nodes));
    assert_eq!(sum, 2 * u64::from(nodes) * syncs * (syncs + 1) / 2);
    ns
}

fn best(mut f: impl FnMut() -> f64) -> f64 {
    f();
    (0..3).map(|_| f()).fold(f64::MAX, f64::min)
}

fn main() {
    let (mut nodes, mut syncs, mut only) = (64u8, 2000u32, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let v = args.next();
        let n = v.as_deref().and_then(|v| v.parse::<u32>().ok());
        match (a.as_str(), n) {
            ("--nodes", Some(n)) if (1..=127).contains(&n) => nodes = n as u8,
            ("--syncs", Some(n)) if n > 0 => syncs = n,
            ("--only", _)
                if matches!(
                    v.as_deref(),
                    Some("stepping" | "driver" | "callback" | "batch" | "batch-driver")
                ) =>
            {
                only = v
            }
            _ => {
                eprintln!(
                    "usage: pdo_rx [--nodes 1..=127] [--syncs N] [--only stepping|driver|callback|batch|batch-driver]"
                );
                std::process::exit(2);
            }
        }
    }
    let frames = Arc::new(frames(nodes, syncs));
    // One row alone, once (for a profiler).
    match only.as_deref() {
        Some("stepping") => return println!("stepping: {:.0} ns", stepping(nodes, &frames)),
        Some("driver") => return println!("driver: {:.0} ns", driver(nodes, &frames)),
        Some("callback") => return println!("callback: {:.0} ns", callback(nodes, &frames)),
        Some("batch") => return println!("batch: {:.0} ns", batch_stepping(nodes, &frames)),
        Some("batch-driver") => {
            return println!("batch-driver: {:.0} ns", batch_driver(nodes, &frames));
        }
        _ => {}
    }
    println!(
        "{} TPDOs of {nodes} nodes (2 per node and SYNC, {syncs} SYNCs), decoded and checked; \
         process CPU per frame, best of 3",
        frames.len()
    );
    let floor = best(|| decode_alone(nodes, &frames));
    let rows = [
        ("decode alone (canola-pdo unpack)", floor),
        (
            "Network, stepping, subscriber on the same thread",
            best(|| stepping(nodes, &frames)),
        ),
        (
            "Network, stepping, PDO callback (on_pdo)",
            best(|| callback(nodes, &frames)),
        ),
        (
            "Network, stepping, batch subscriber (subscribe_pdos)",
            best(|| batch_stepping(nodes, &frames)),
        ),
        (
            "Network, driver thread, subscriber on another",
            best(|| driver(nodes, &frames)),
        ),
        (
            "Network, driver thread, batch subscriber on another",
            best(|| batch_driver(nodes, &frames)),
        ),
    ];
    println!("{:<50} {:>10} {:>8}", "", "CPU ns", "x floor");
    for (what, ns) in rows {
        println!("{what:<50} {ns:>10.0} {:>8.1}", ns / floor);
    }
}
