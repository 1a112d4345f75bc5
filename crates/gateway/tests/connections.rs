//! Many connections at once: every request answered with its own sequence number, a connection
//! that stops reading or vanishes costs the others nothing, over-long lines are refused, and
//! SDO requests to different nodes run in parallel, and a connection flooding a node delays
//! another connection's request to it by a bounded number of requests; a transport that fails
//! fails the running requests, and the gateway serves again once it works.

mod common;

use std::collections::HashMap;

use canola_gateway::Config;
use common::{Client, gateway};

/// Sends `n` pipelined reads spread over `nodes` (each node's 0x1017 holds 100 + node) and
/// checks every reply by its sequence number.
fn pipelined_reads(c: &mut Client, first_seq: u32, n: u32, nodes: &[u8]) {
    let mut want = HashMap::new();
    let mut text = String::new();
    for i in 0..n {
        let seq = first_seq + i;
        let node = nodes[i as usize % nodes.len()];
        text.push_str(&format!("[{seq}] {node} r 0x1017 0 u16\r\n"));
        want.insert(seq, format!("[{seq}] {}\r\n", 100 + u32::from(node)));
    }
    c.send(&text);
    for _ in 0..n {
        let line = c.line();
        let seq: u32 = line[1..line.find(']').unwrap()].parse().unwrap();
        assert_eq!(want.remove(&seq).as_deref(), Some(line.as_str()));
    }
    assert!(want.is_empty());
}

fn set_heartbeat_times(gw: &canola_gateway::Gateway, nodes: &[u8]) {
    let mut c = Client::connect(gw);
    for &n in nodes {
        let line = format!("[{n}] {n} w 0x1017 0 u16 {}\n", 100 + u32::from(n));
        assert_eq!(c.ask(&line, 1), format!("[{n}] OK\r\n"));
    }
}

#[test]
fn forty_connections_at_once() {
    let nodes: Vec<u8> = (1..=8).collect();
    let (gw, _bus) = gateway(&nodes, Config::default());
    set_heartbeat_times(&gw, &nodes);
    let threads: Vec<_> = (0..40)
        .map(|k| {
            let gw = gw.clone();
            let nodes = nodes.clone();
            std::thread::spawn(move || {
                let mut c = Client::connect(&gw);
                pipelined_reads(&mut c, k * 1000, 30, &nodes);
            })
        })
        .collect();
    for t in threads {
        t.join().unwrap();
    }
}

#[test]
fn a_stalled_or_vanished_connection_costs_the_others_nothing() {
    let nodes = [1u8, 2];
    let (gw, _bus) = gateway(&nodes, Config::default());
    set_heartbeat_times(&gw, &nodes);
    // Sends far more than the gateway takes at once and never reads.
    let mut stalled = Client::connect(&gw);
    let flood: String = (0..5000)
        .map(|i| format!("[{i}] 1 r 0x1008 0 vs\r\n"))
        .collect();
    let flood_thread = {
        let mut w = stalled.writer.try_clone().unwrap();
        std::thread::spawn(move || {
            use std::io::Write as _;
            // Blocks once the gateway stops reading this connection.
            let _ = w.write_all(flood.as_bytes());
        })
    };
    // Vanishes with requests in flight.
    {
        let mut gone = Client::connect(&gw);
        gone.send(
            &(0..50)
                .map(|i| format!("[{i}] 2 r 0x1008 0 vs\r\n"))
                .collect::<String>(),
        );
    }
    let mut fine = Client::connect(&gw);
    pipelined_reads(&mut fine, 1, 200, &nodes);
    // The stalled connection still gets its replies, in order per node, once it reads.
    let first = stalled.line();
    assert_eq!(first, "[0] \"Buerkert generic device\"\r\n");
    drop(stalled);
    let _ = flood_thread.join();
}

#[test]
fn over_long_lines_are_refused_and_the_connection_goes_on() {
    let (gw, _bus) = gateway(&[4], Config::default());
    let mut c = Client::connect(&gw);
    let long = format!("[7] 4 w 0x2000 0 vs \"{}\"\r\n", "x".repeat(10_000));
    assert_eq!(c.ask(&long, 1), "[7] ERROR:600\r\n");
    let no_end = format!("[8] {}", "y".repeat(5000));
    c.send(&no_end);
    assert_eq!(
        c.ask("\n[9] 4 r 0x1017 0 u16\r\n", 2),
        "[8] ERROR:600\r\n[9] 500\r\n"
    );
    // Bytes that are not UTF-8 are a syntax error.
    c.send("[10] 4 r \u{0}");
    c.writer
        .try_clone()
        .map(|mut w| {
            use std::io::Write as _;
            w.write_all(&[0xFF, 0xFE, b'\n']).unwrap();
        })
        .unwrap();
    assert_eq!(c.line(), "[10] ERROR:101\r\n");
}

#[test]
fn sdo_to_different_nodes_runs_in_parallel() {
    use canola::transport::{Received, Transport};
    use canola::{BusConfig, ClockMode, MemoryBus, Network};

    // Nobody answers at nodes 20..=27, so each read ends with the SDO timeout and its abort.
    // In parallel, all eight requests are on the bus before the first abort; one after another,
    // each abort would come before the next request. A real-time bus, so that the requests'
    // submission is not raced by a virtual clock jumping ahead.
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let mut tap = bus.endpoint();
    let gw = canola_gateway::Gateway::new(Network::new(bus.endpoint()), Config::default());
    let mut c = Client::connect(&gw);
    assert_eq!(c.ask("[1] set sdo_timeout 400\n", 1), "[1] OK\r\n");
    let text: String = (20..28)
        .map(|n| format!("[{n}] {n} r 0x1000 0 u32\n"))
        .collect();
    c.send(&text);
    for _ in 20..28 {
        assert!(c.line().ends_with("] ERROR:0x05040000\r\n"));
    }
    let mut kinds = Vec::new();
    while let Ok(Some(r)) = tap.recv_until(tap.now()) {
        if let Received::Frame { frame, .. } = r {
            let id = frame.id().as_raw();
            if (0x600 + 20..0x600 + 28).contains(&id) {
                // 0x40: initiate upload; 0x80: abort.
                kinds.push((id - 0x600, frame.data()[0]));
            }
        }
    }
    assert_eq!(kinds.len(), 16, "{kinds:x?}");
    assert!(kinds[..8].iter().all(|&(_, cs)| cs == 0x40), "{kinds:x?}");
    assert!(kinds[8..].iter().all(|&(_, cs)| cs == 0x80), "{kinds:x?}");
}

#[test]
fn connections_beyond_the_limit_are_refused_over_tcp() {
    use std::io::{BufRead, BufReader, Write};
    let (gw, _bus) = gateway(
        &[4],
        Config {
            max_connections: 2,
            ..Config::default()
        },
    );
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    gw.serve_tcp(listener);
    let connect = || {
        let s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
            .unwrap();
        (s.try_clone().unwrap(), BufReader::new(s))
    };
    let ask = |c: &mut (std::net::TcpStream, BufReader<std::net::TcpStream>), req: &str| {
        c.0.write_all(req.as_bytes()).unwrap();
        let mut l = String::new();
        c.1.read_line(&mut l).unwrap();
        l
    };
    let mut first = connect();
    let mut second = connect();
    assert_eq!(ask(&mut first, "[1] 4 r 0x1017 0 u16\n"), "[1] 500\r\n");
    assert_eq!(ask(&mut second, "[1] 4 r 0x1017 0 u16\n"), "[1] 500\r\n");
    let mut third = connect();
    let mut l = String::new();
    third.1.read_line(&mut l).unwrap();
    assert_eq!(l, "ERROR:600\r\n");
    l.clear();
    assert_eq!(third.1.read_line(&mut l).unwrap(), 0, "closed");
    // Once one leaves, a new connection is served.
    // Once one leaves (its thread ends shortly after), a new connection is served.
    drop(first);
    let mut served = false;
    for _ in 0..100 {
        let mut next = connect();
        // A refused connection hears ERROR:600 at once; a served one hears nothing unasked.
        next.0
            .set_read_timeout(Some(std::time::Duration::from_millis(300)))
            .unwrap();
        let mut l = String::new();
        match next.1.read_line(&mut l) {
            Ok(_) => assert_eq!(l, "ERROR:600\r\n"),
            Err(_) => {
                next.0
                    .set_read_timeout(Some(std::time::Duration::from_secs(30)))
                    .unwrap();
                assert_eq!(ask(&mut next, "[2] 4 r 0x1017 0 u16\n"), "[2] 500\r\n");
                served = true;
                break;
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(served);
}

/// Records, in bus order, every SDO upload the devices serve: (node, index).
struct ServedLog {
    node: u8,
    log: std::sync::Arc<std::sync::Mutex<Vec<(u8, u16)>>>,
}

impl canola::DeviceHook for ServedLog {
    fn on_read(
        &mut self,
        _now: canola::frame::Instant,
        _values: &canola::Values,
        index: u16,
        _sub: u8,
    ) -> Option<Result<Vec<u8>, canola::AbortCode>> {
        self.log.lock().unwrap().push((self.node, index));
        None
    }
}

/// Fairness through the TCP server: one connection floods node 5 with reads of 0x1017; another
/// connection's single read of node 5 (0x1018) is served after at most two of the flood's
/// reads (the one under way and the one the round-robin turn had already chosen), and its
/// single read of node 6 (another queue) is not held behind the flood. The order comes from
/// the devices' log of served uploads, not from any clock. The bus runs in real time at
/// 125 kbit/s, so that the flood lasts long enough for the other connection to join it.
#[test]
fn a_flooding_connection_delays_another_by_a_bounded_number_of_requests() {
    use std::io::{BufRead, BufReader, Write};
    use std::sync::{Arc, Mutex};

    const FLOOD: usize = 300;
    let log = Arc::new(Mutex::new(Vec::new()));
    let bus = canola::MemoryBus::with_config(canola::BusConfig {
        clock: canola::ClockMode::RealTime,
        bitrate: Some(125_000),
        ..canola::BusConfig::default()
    });
    let od = canola::od::parse(common::EDS).unwrap().od;
    for node in [5u8, 6] {
        let dev = canola::SimDevice::new(canola::frame::NodeId::new(node).unwrap(), od.clone())
            .with_hook(ServedLog {
                node,
                log: log.clone(),
            });
        bus.attach(dev);
    }
    let gw = canola_gateway::Gateway::new(canola::Network::new(bus.endpoint()), Config::default());
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    gw.serve_tcp(listener);
    let connect = || {
        let s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(std::time::Duration::from_secs(60)))
            .unwrap();
        (s.try_clone().unwrap(), BufReader::new(s))
    };
    let line = |r: &mut BufReader<std::net::TcpStream>| {
        let mut l = String::new();
        r.read_line(&mut l).unwrap();
        l
    };

    let (mut flood_w, mut flood_r) = connect();
    let flood: String = (0..FLOOD)
        .map(|i| format!("[{i}] 5 r 0x1017 0 u16\n"))
        .collect();
    let writer = std::thread::spawn(move || flood_w.write_all(flood.as_bytes()).unwrap());
    // The flood is under way once its first reply is in.
    assert_eq!(line(&mut flood_r), "[0] 500\r\n");
    let reader = std::thread::spawn(move || {
        for _ in 1..FLOOD {
            assert!(line(&mut flood_r).ends_with(" 500\r\n"));
        }
    });

    let (mut w, mut r) = connect();
    let flood_reads = |log: &[(u8, u16)]| log.iter().filter(|e| **e == (5, 0x1017)).count();
    // Each queued request is followed by one the reader answers itself: when that reply is
    // in, the queued one is in its queue, and the flood reads served so far are a lower bound
    // of those served before it was queued.
    w.write_all(b"[1] 5 r 0x1018 1 u32\n[2] set sdo_timeout 500\n")
        .unwrap();
    let mut replies = vec![line(&mut r)];
    let before_5 = flood_reads(&log.lock().unwrap());
    w.write_all(b"[3] 6 r 0x1018 1 u32\n[4] set sdo_timeout 500\n")
        .unwrap();
    replies.push(line(&mut r));
    let before_6 = flood_reads(&log.lock().unwrap());
    replies.push(line(&mut r));
    replies.push(line(&mut r));
    replies.sort();
    assert_eq!(
        replies,
        ["[1] 57\r\n", "[2] OK\r\n", "[3] 57\r\n", "[4] OK\r\n"]
    );
    writer.join().unwrap();
    reader.join().unwrap();

    let log = log.lock().unwrap();
    assert_eq!(flood_reads(&log), FLOOD);
    let served_at = |entry: (u8, u16)| {
        let at = log.iter().position(|e| *e == entry).unwrap();
        flood_reads(&log[..at])
    };
    let between_5 = served_at((5, 0x1018)).saturating_sub(before_5);
    let between_6 = served_at((6, 0x1018)).saturating_sub(before_6);
    // Node 5's queue: the read under way and the one already chosen, no more, while most of
    // the flood still waited (a queue that served a connection's waiting requests first would
    // have served the whole flood in between: the connection keeps its queue full).
    let after_5 = FLOOD - served_at((5, 0x1018));
    assert!(
        between_5 <= 2 && after_5 > 100,
        "{between_5} flood reads in between, {after_5} after"
    );
    // Node 6's queue runs beside node 5's: what is served meanwhile only reflects how the two
    // workers share the bus, far below the backlog a shared queue would put first.
    let after_6 = FLOOD - served_at((6, 0x1018));
    assert!(
        between_6 <= 8 && after_6 > 100,
        "{between_6} flood reads in between, {after_6} after"
    );
}

/// An in-memory bus endpoint whose reception fails while `down` is set.
struct Failing {
    ep: canola::mem::Endpoint,
    down: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl canola::transport::Transport for Failing {
    fn send(&mut self, frame: &canola::frame::CanFrame) -> Result<(), canola::TransportError> {
        self.ep.send(frame)
    }
    fn recv_until(
        &mut self,
        deadline: canola::frame::Instant,
    ) -> Result<Option<canola::transport::Received>, canola::TransportError> {
        if self.down.load(std::sync::atomic::Ordering::SeqCst) {
            return Err(canola::TransportError::InterfaceDown);
        }
        self.ep.recv_until(deadline)
    }
    fn now(&self) -> canola::frame::Instant {
        self.ep.now()
    }
}

#[test]
fn a_failing_transport_fails_the_running_requests_and_serving_resumes() {
    use std::sync::atomic::{AtomicBool, Ordering};

    let bus = canola::MemoryBus::new();
    let device =
        |n| canola::SimDevice::from_eds(canola::frame::NodeId::new(n).unwrap(), common::EDS);
    let stations = [
        bus.attach(device(5).unwrap()),
        bus.attach(device(6).unwrap()),
    ];
    let down = std::sync::Arc::new(AtomicBool::new(false));
    let transport = Failing {
        ep: bus.endpoint(),
        down: down.clone(),
    };
    let gw = canola_gateway::Gateway::new(canola::Network::new(transport), Config::default());
    let mut c = Client::connect(&gw);
    assert_eq!(c.ask("[1] 5 r 0x1017 0 u16\n", 1), "[1] 500\r\n");
    // The devices leave too, so that no answer to a failed request is left for later ones.
    let devices = stations.map(|s| bus.detach(s).unwrap());
    down.store(true, Ordering::SeqCst);
    // Both fail (102: not processed due to internal state), neither hangs.
    let mut failed = c.ask("[2] 5 r 0x1017 0 u16\n[3] 6 r 0x1017 0 u16\n", 2);
    failed = failed.replace("[3]", "[2]");
    assert_eq!(failed, "[2] ERROR:102\r\n[2] ERROR:102\r\n");
    down.store(false, Ordering::SeqCst);
    for d in devices {
        bus.attach(d);
    }
    assert_eq!(
        c.ask("[4] 6 w 0x1017 0 u16 300\n[5] 6 r 0x1017 0 u16\n", 2),
        "[4] OK\r\n[5] 300\r\n"
    );
}
