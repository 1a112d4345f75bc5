//! Throughput and latency of expedited SDO reads through the gateway (TCP on loopback) against
//! the same load through the library directly: 8 clients, each 1000 reads of 0x1017:0 spread
//! over 8 simulated nodes on the in-memory bus (virtual clock, so the bus itself costs no wall
//! time and the figures are the software's). Each load runs closed-loop (one request in flight
//! per client) and pipelined (8 in flight per client). With `--real-time` the bus runs on a real
//! clock instead, as SocketCAN does: the figures then include how soon the driving thread sees
//! a frame or a new request.
//!
//! `cargo run --release -p canola-gateway --example bench [-- --clients N --reads N --real-time]`

use std::collections::{HashMap, VecDeque};
use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use canola::frame::NodeId;
use canola::{BusConfig, ClockMode, MemoryBus, Network, Pending, SimDevice};
use canola_gateway::{Config, Gateway};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");
const NODES: u8 = 8;

fn network(real_time: bool) -> (Network, MemoryBus) {
    let bus = if real_time {
        MemoryBus::with_config(BusConfig {
            clock: ClockMode::RealTime,
            ..BusConfig::default()
        })
    } else {
        MemoryBus::new()
    };
    let net = Network::new(bus.endpoint());
    for n in 1..=NODES {
        bus.attach(SimDevice::from_eds(NodeId::new(n).unwrap(), EDS).unwrap());
    }
    (net, bus)
}

fn node_for(client: usize, i: usize) -> u8 {
    ((client + i) % usize::from(NODES)) as u8 + 1
}

/// Per-request latencies of one client.
struct Run {
    latencies: Vec<Duration>,
}

fn library_client(net: &Network, client: usize, reads: usize, window: usize) -> Run {
    let mut latencies = Vec::with_capacity(reads);
    let mut in_flight: VecDeque<(Instant, Pending)> = VecDeque::new();
    let mut next = 0;
    while latencies.len() < reads {
        while next < reads && in_flight.len() < window {
            let node = NodeId::new(node_for(client, next)).unwrap();
            in_flight.push_back((
                Instant::now(),
                net.node(node).sdo().submit_read((0x1017, 0)),
            ));
            next += 1;
        }
        let (t, p) = in_flight.pop_front().unwrap();
        let r = p.wait().expect("read");
        assert_eq!(r, 500u16.to_le_bytes());
        latencies.push(t.elapsed());
    }
    Run { latencies }
}

fn gateway_client(port: u16, client: usize, reads: usize, window: usize) -> Run {
    let stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
    stream.set_nodelay(true).unwrap();
    let mut w = stream.try_clone().unwrap();
    let mut r = BufReader::new(stream);
    let mut sent: HashMap<u32, Instant> = HashMap::new();
    let mut latencies = Vec::with_capacity(reads);
    let mut next = 0;
    let mut line = String::new();
    while latencies.len() < reads {
        let mut batch = String::new();
        while next < reads && sent.len() < window {
            let seq = next as u32;
            batch.push_str(&format!(
                "[{seq}] {} r 0x1017 0 u16\n",
                node_for(client, next)
            ));
            sent.insert(seq, Instant::now());
            next += 1;
        }
        if !batch.is_empty() {
            w.write_all(batch.as_bytes()).unwrap();
        }
        line.clear();
        r.read_line(&mut line).unwrap();
        let (seq, value) = line[1..].split_once("] ").expect("a reply");
        assert_eq!(value, "500\r\n", "{line}");
        let t = sent
            .remove(&seq.parse().unwrap())
            .expect("a request of ours");
        latencies.push(t.elapsed());
    }
    Run { latencies }
}

struct Row {
    name: String,
    rate: f64,
    p50: Duration,
    p90: Duration,
    p99: Duration,
    max: Duration,
}

fn measure(name: &str, clients: usize, run: impl Fn(usize) -> Run + Sync) -> Row {
    let start = Instant::now();
    let runs: Vec<Run> = std::thread::scope(|s| {
        let run = &run;
        let handles: Vec<_> = (0..clients).map(|c| s.spawn(move || run(c))).collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let wall = start.elapsed();
    let mut all: Vec<Duration> = runs.into_iter().flat_map(|r| r.latencies).collect();
    all.sort();
    let pct = |p: f64| all[((all.len() as f64 * p) as usize).min(all.len() - 1)];
    Row {
        name: name.into(),
        rate: all.len() as f64 / wall.as_secs_f64(),
        p50: pct(0.50),
        p90: pct(0.90),
        p99: pct(0.99),
        max: *all.last().unwrap(),
    }
}

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let clients = arg("--clients", 8);
    let reads = arg("--reads", 1000);
    let real_time = std::env::args().any(|a| a == "--real-time");
    let mut rows = Vec::new();
    for window in [1, 8] {
        let (net, _bus) = network(real_time);
        // Warm up: every node's SDO client once.
        library_client(&net, 0, usize::from(NODES), 1);
        rows.push(measure(
            &format!("library, {window} in flight"),
            clients,
            |c| library_client(&net, c, reads, window),
        ));

        let (net, _bus) = network(real_time);
        let gateway = Gateway::new(net, Config::default());
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        gateway.serve_tcp(listener);
        gateway_client(port, 0, usize::from(NODES), 1);
        rows.push(measure(
            &format!("gateway TCP, {window} in flight"),
            clients,
            |c| gateway_client(port, c, reads, window),
        ));
    }
    println!(
        "{clients} clients x {reads} expedited reads of 0x1017:0 over {NODES} simulated nodes, in-memory bus ({} clock)",
        if real_time { "real" } else { "virtual" }
    );
    println!(
        "{:<30} {:>12} {:>9} {:>9} {:>9} {:>9}",
        "per client", "requests/s", "p50 µs", "p90 µs", "p99 µs", "max µs"
    );
    for r in &rows {
        println!(
            "{:<30} {:>12.0} {:>9} {:>9} {:>9} {:>9}",
            r.name,
            r.rate,
            r.p50.as_micros(),
            r.p90.as_micros(),
            r.p99.as_micros(),
            r.max.as_micros()
        );
    }
}
