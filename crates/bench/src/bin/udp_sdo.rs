//! Expedited SDO reads over the UDP multicast bus (`canola::udp`, on this machine only) with the
//! background driver running, as the Python package and most programs use the network: the
//! latency of one read, request to answer.
//!
//! A `SimDevice` built from the Bürkert EDS is served by `run_station` on a second transport
//! of the same bus, in a thread of its own. The master is a `Network` with `start_driver`.
//! Two rows, each COUNT reads of 0x1018:01 (UNSIGNED32, expedited), transfer gap zero:
//! * `back to back`: one read after the other (the reading thread keeps the transport between
//!   reads, the driver steps aside);
//! * `paced`: a pause of PAUSE ms before each read, so the driver is back in its wait on the
//!   transport when the read is submitted (what a program polling a value sees); only the
//!   reads are timed.
//!
//! ```text
//! cargo build --workspace --all-features --bin udp_sdo
//! "$CARGO_TARGET_DIR"/debug/udp_sdo [--count 200] [--pause-ms 5] [--port 43199]
//! ```
//! Prints the mean, the median and the 99th percentile of the microseconds per read. Judges nothing (the machine is shared).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant as WallClock;

use canola::udp::UdpMulticast;
use canola::{Duration, Network, NodeId, SimDevice, run_station};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn usage() -> ! {
    eprintln!("usage: udp_sdo [--count N] [--pause-ms MS] [--port PORT]");
    std::process::exit(2)
}

/// Microseconds of each of `count` reads, `pause` before each.
fn reads(node: &canola::Node, count: u32, pause: std::time::Duration) -> Vec<f64> {
    (0..count)
        .map(|_| {
            if !pause.is_zero() {
                std::thread::sleep(pause);
            }
            let t0 = WallClock::now();
            let v = node.sdo().read((0x1018, 1)).wait().expect("read");
            let us = t0.elapsed().as_secs_f64() * 1e6;
            assert_eq!(v.len(), 4);
            us
        })
        .collect()
}

fn report(row: &str, mut us: Vec<f64>) {
    us.sort_by(f64::total_cmp);
    let mean = us.iter().sum::<f64>() / us.len() as f64;
    let median = us[us.len() / 2];
    let p99 = us[(us.len() * 99 / 100).min(us.len() - 1)];
    println!("{row:<14} {mean:>9.1} µs mean {median:>9.1} µs median {p99:>9.1} µs p99 per read");
}

fn main() {
    let (mut count, mut pause_ms, mut port) = (200u32, 5u64, 43199u16);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || {
            args.next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| usage())
        };
        match a.as_str() {
            "--count" => count = value() as u32,
            "--pause-ms" => pause_ms = value(),
            "--port" => port = value() as u16,
            _ => usage(),
        }
    }
    let group = std::net::SocketAddrV4::new(std::net::Ipv4Addr::new(239, 74, 163, 9), port);
    let id = NodeId::new(5).expect("node-ID");
    let stop = Arc::new(AtomicBool::new(false));
    let mut device_bus = UdpMulticast::open(group).expect("UDP multicast on loopback");
    let device = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut device = SimDevice::from_eds(id, EDS).expect("the Bürkert EDS parses");
            // No heartbeat: only SDO frames on the bus.
            device.values_mut().set(0x1017, 0, 0u16.to_le_bytes());
            run_station(&mut device_bus, &mut device, || {
                stop.load(Ordering::Relaxed)
            })
        })
    };
    let net = Network::new(UdpMulticast::open(group).expect("UDP multicast on loopback"));
    net.set_transfer_gap(Duration::ZERO);
    net.start_driver().expect("driver thread");
    let node = net.node(id);
    // Warm-up (and the device is up).
    reads(&node, 20, std::time::Duration::ZERO);
    println!("expedited SDO reads of 0x1018:01 over udp:{group}, driver running, {count} per row");
    report(
        "back to back",
        reads(&node, count, std::time::Duration::ZERO),
    );
    report(
        "paced",
        reads(&node, count, std::time::Duration::from_millis(pause_ms)),
    );
    net.stop_driver().expect("driver ended cleanly");
    stop.store(true, Ordering::Relaxed);
    device
        .join()
        .expect("device thread")
        .expect("device transport");
}
