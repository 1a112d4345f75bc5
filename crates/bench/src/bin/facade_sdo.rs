//! Expedited SDO reads through `canola::Network` on the in-memory bus, side by side with the
//! SDO client and server machines of `canola-sdo` wired back to back (the protocol's own
//! cost, the floor for the facade).
//!
//! Rows, each the best of three runs of COUNT reads of 0x1018:01 (UNSIGNED32, expedited) from a
//! `SimDevice` built from the Bürkert EDS, transfer gap zero:
//! * `machines back to back`: `Client` and `Server` in one thread, frames handed over directly;
//! * `SimDevice as a station, back to back`: the simulated device alone, request frames handed
//!   to it directly (what the device costs in the rows below);
//! * `Network, virtual clock`: the explicit stepping mode (the calling thread drives);
//! * `Network, real clock`: the same on a real-time bus, no background driver;
//! * `Network, real clock, driver thread`: the same with `Network::start_driver` running.
//!
//! ```text
//! cargo run --release -p canola-bench --bin facade_sdo [-- --count 20000] [--only machines|station|virtual|real|driver]
//! ```
//! `--only ROW` runs one row alone, once (for a profiler).
//! Prints wall-clock and process CPU nanoseconds per read (CPU time counts every thread of the
//! process: the driver's and the real-time bus's service thread; on a loaded machine it is the
//! steadier figure), the CPU time as a multiple of the floor's (`CPU x`, best runs of each), and
//! the same multiple measured in pairs (`paired x`: 15 short runs of the floor and the row back
//! to back, the median of their ratios; a shared machine's slow phases come and go within a
//! run and move both alike). Judges nothing (the machine is shared).

use std::time::Instant as WallClock;

/// Wall-clock and process CPU time (every thread: the driver's and the real-time bus's too).
#[derive(Clone, Copy)]
struct Cost {
    wall: f64,
    cpu: f64,
}

fn process_cpu_ns() -> f64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID)
        .map_or(0.0, |t| t.tv_sec() as f64 * 1e9 + t.tv_nsec() as f64)
}

/// Starts measuring; `per` ends it and divides by `count`.
struct Span(WallClock, f64);

impl Span {
    fn start() -> Self {
        Self(WallClock::now(), process_cpu_ns())
    }
    fn per(self, count: u32) -> Cost {
        Cost {
            wall: self.0.elapsed().as_nanos() as f64 / f64::from(count),
            cpu: (process_cpu_ns() - self.1) / f64::from(count),
        }
    }
}

use canola::mem::{BusConfig, ClockMode};
use canola::sdo::{
    AbortCode, Access, Client, ClientConfig, Event, Method, Multiplexer, ObjectAccess, ObjectInfo,
    Server, ServerConfig,
};
use canola::{CanFrame, CanId, Duration, Instant, MemoryBus, Network, NodeId, SimDevice, Station};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");
const VENDOR_ID: Multiplexer = Multiplexer::new(0x1018, 1);

/// The one object of the back-to-back server.
struct Identity;

impl ObjectAccess for Identity {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        match mux {
            VENDOR_ID => Ok(ObjectInfo::fixed(Access::ReadOnly, 4)),
            _ => Err(AbortCode::OBJECT_DOES_NOT_EXIST),
        }
    }
    fn read(&mut self, _: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let src = 0x39u32.to_le_bytes();
        let start = (offset as usize).min(src.len());
        let n = buf.len().min(src.len() - start);
        buf[..n].copy_from_slice(&src[start..start + n]);
        Ok(n)
    }
    fn write(&mut self, _: Multiplexer, _: u32, _: &[u8]) -> Result<(), AbortCode> {
        Err(AbortCode::READ_ONLY)
    }
    fn commit(&mut self, _: Multiplexer, _: u32) -> Result<(), AbortCode> {
        Ok(())
    }
}

/// Nanoseconds per read of `count` reads by the machines back to back.
fn machines(count: u32) -> Cost {
    let mut client: Client<Vec<u8>, &'static [u8]> = Client::new(ClientConfig::default());
    let mut server = Server::new(ServerConfig::default());
    let mut od = Identity;
    let now = Instant::ZERO;
    let mut sink = Vec::with_capacity(8);
    let t0 = Span::start();
    for _ in 0..count {
        sink.clear();
        client
            .start_upload(now, VENDOR_ID, std::mem::take(&mut sink), Method::Normal)
            .expect("the client is idle");
        loop {
            let mut moved = false;
            while let Some(f) = client.poll_transmit() {
                server.handle_request(now, &f, &mut od);
                moved = true;
            }
            while let Some(f) = server.poll_transmit() {
                client.handle_response(now, &f);
                moved = true;
            }
            if !moved {
                break;
            }
        }
        match client.poll_event() {
            Some(Event::Uploaded { sink: s, .. }) => {
                assert_eq!(s, 0x39u32.to_le_bytes());
                sink = s;
            }
            other => panic!("upload failed: {other:?}"),
        }
    }
    t0.per(count)
}

/// Nanoseconds per read of `count` reads handed to the simulated device directly.
fn station(count: u32) -> Cost {
    let id = NodeId::new(5).expect("node-ID");
    let mut device = SimDevice::from_eds(id, EDS).expect("the Bürkert EDS parses");
    device.values_mut().set(0x1017, 0, 0u16.to_le_bytes());
    let now = Instant::ZERO;
    device.handle_timeout(now);
    while device.poll_transmit().is_some() {}
    let request = CanFrame::new(
        CanId::standard(0x605).expect("COB-ID"),
        &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0],
    )
    .expect("frame");
    let t0 = Span::start();
    for _ in 0..count {
        device.handle_frame(now, &request);
        let response = device.poll_transmit().expect("a response");
        assert_eq!(response.data()[4], 0x39);
    }
    t0.per(count)
}

/// Nanoseconds per read of `count` reads through a `Network`.
fn network(count: u32, clock: ClockMode, driver: bool) -> Cost {
    let bus = MemoryBus::with_config(BusConfig {
        clock,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5).expect("node-ID");
    let mut device = SimDevice::from_eds(id, EDS).expect("the Bürkert EDS parses");
    // No heartbeat: only SDO frames on the bus.
    device.values_mut().set(0x1017, 0, 0u16.to_le_bytes());
    bus.attach(device);
    net.set_transfer_gap(Duration::ZERO);
    net.run_for(Duration::from_millis(10))
        .wait()
        .expect("boot-up");
    if driver {
        net.start_driver().expect("driver thread");
    }
    let node = net.node(id);
    let t0 = Span::start();
    for _ in 0..count {
        let v = node.sdo().read((0x1018, 1)).wait().expect("read");
        assert_eq!(v, 0x39u32.to_le_bytes());
    }
    let ns = t0.per(count);
    if driver {
        net.stop_driver().expect("driver ended cleanly");
    }
    ns
}

/// The best of three runs after a warm-up, by CPU time.
fn best(mut f: impl FnMut() -> Cost) -> Cost {
    f(); // warm-up
    (0..3)
        .map(|_| f())
        .min_by(|a, b| a.cpu.total_cmp(&b.cpu))
        .unwrap_or(Cost {
            wall: 0.0,
            cpu: 0.0,
        })
}

fn usage() -> ! {
    eprintln!("usage: facade_sdo [--count N] [--only machines|station|virtual|real|driver]");
    std::process::exit(2);
}

fn main() {
    let mut count = 20_000u32;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let v = args.next();
        match (a.as_str(), v.as_deref().and_then(|v| v.parse().ok())) {
            ("--count", Some(n)) if n > 0 => count = n,
            ("--only", _) => {
                let ns = match v.as_deref() {
                    Some("machines") => machines(count),
                    Some("station") => station(count),
                    Some("virtual") => network(count, ClockMode::Virtual, false),
                    Some("real") => network(count, ClockMode::RealTime, false),
                    Some("driver") => network(count, ClockMode::RealTime, true),
                    _ => usage(),
                };
                println!(
                    "{}: {:.0} ns wall, {:.0} ns CPU per read",
                    v.as_deref().unwrap_or_default(),
                    ns.wall,
                    ns.cpu
                );
                return;
            }
            _ => usage(),
        }
    }
    println!("expedited SDO reads of 0x1018:01, {count} per run, best of 3 by CPU time");
    println!(
        "{:<40} {:>9} {:>12} {:>7} {:>8}",
        "", "wall ns", "CPU ns", "CPU x", "paired x"
    );
    let floor = best(|| machines(count));
    let rows: [(&str, &dyn Fn(u32) -> Cost); 5] = [
        ("machines back to back (canola-sdo)", &machines),
        ("SimDevice as a station, back to back", &station),
        ("Network, virtual clock, stepping", &|n| {
            network(n, ClockMode::Virtual, false)
        }),
        ("Network, real clock, no driver", &|n| {
            network(n, ClockMode::RealTime, false)
        }),
        ("Network, real clock, driver thread", &|n| {
            network(n, ClockMode::RealTime, true)
        }),
    ];
    for (what, row) in rows {
        let c = best(|| row(count));
        let paired = paired_ratio((count / 10).max(1), row);
        println!(
            "{what:<40} {:>9.0} {:>12.0} {:>7.1} {:>8.1}",
            c.wall,
            c.cpu,
            c.cpu / floor.cpu,
            paired
        );
    }
}

/// Rounds for [`paired_ratio`].
const PAIRED_ROUNDS: usize = 15;

/// A row's CPU time as a multiple of the floor's, robust to a shared machine's slow phases
/// (which come and go within a run and can double every figure): short runs of the floor and
/// the row back to back, the ratio of each pair, the median of the ratios.
fn paired_ratio(count: u32, row: &dyn Fn(u32) -> Cost) -> f64 {
    let mut ratios: Vec<f64> = (0..PAIRED_ROUNDS)
        .map(|_| {
            let floor = machines(count);
            row(count).cpu / floor.cpu
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios[PAIRED_ROUNDS / 2]
}
