//! Full bus load on a real SocketCAN bus (vcan0 in the QEMU guest of `tests/vcan`): `--nodes N`
//! simulated nodes (default 64, [`canola_bench::load::LoadNode`]) in a child process of their
//! own (this binary run with `--simulate`, one socket), each sending two 8-byte synchronous
//! TPDOs with a sequence counter on every SYNC; the master (`canola::Network` over
//! `canola::socketcan::SocketCan`, background driver) produces the SYNC every `--period-us`
//! and its subscriber decodes the typed values and checks every counter.
//!
//! Every frame is accounted for. The simulator counts the PDOs it sent and the sends that
//! failed (the interface down); the kernel counts what it dropped: the master socket's
//! receive-queue overflow (`SO_RXQ_OVFL`, reported by the transport as `BusEvent::RxOverflow`
//! and in `SocketCanStats::rx_dropped`) and the per-CPU input backlog (`/proc/net/softnet_stat`,
//! second column; it drops frames of every kind before any socket sees them, a SYNC to the
//! simulator too, so its count bounds the PDOs it took). After the run the simulator sends one
//! marker frame (TPDO1 of node 127), so the drop counter the kernel attaches to it covers the
//! whole run. The run passes when sent − received − the overflow count lies within the
//! backlog's count (both 0 in a clean run), the counter gaps the subscriber saw (up to the
//! simulator's final counter) equal the failed sends plus those drops, and no counter went backwards or decoded wrongly: zero
//! silent loss.
//!
//! The simulator process runs on one CPU (the last, or `--sim-cpu N`): vcan hands a frame to
//! the receiving sockets through the input backlog of the CPU that sent it, so a sender that
//! migrates between CPUs can have frames of the new CPU delivered before those still queued on
//! the old one (seen in the two-vCPU guest: 36 counters out of order in 920,960 PDOs when
//! unpinned). A CAN controller's frames all arrive through one interrupt, in order.
//!
//! Losses that are counted are reported, not judged (the guest is emulated on a shared
//! machine).
//!
//! ```text
//! vcan_load [--iface vcan0] [--nodes 64] [--seconds 120] [--period-us 15000]
//!           [--rcvbuf BYTES | --kernel-rcvbuf] [--flap-at SECONDS] [--flap-ms 1000]
//!           [--sweep US,US,...] [--sim-cpu N]
//! ```
//! `--rcvbuf` asks for that receive buffer instead of the transport's default
//! (`canola::socketcan::DEFAULT_RECEIVE_BUFFER`); `--kernel-rcvbuf` leaves the kernel's.
//! `--flap-at S` takes the interface down S seconds into the run (`ip link set dev IFACE down`,
//! root) and up again `--flap-ms` later: the master must report `InterfaceDown` then
//! `InterfaceUp`, keep its driver running, and receive PDOs again after the link returned.
//! `--sweep` runs one trial of `--seconds` per SYNC period listed, shortest last, and stops at
//! the first that loses a frame or misses more than 5 % of its SYNCs: the last clean one is
//! the highest rate the guest sustained.
//!
//! Ends with the line `vcan_load: period P us, seconds S, sent N, received R, lost L
//! (rx-queue overflow O, backlog B, send failed F), silent 0, reordered 0, rate X frames/s`.

use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::process::{Command, ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant as StdInstant;

use canola::socketcan::{SocketCan, SocketCanStats};
use canola::{
    BusEvent, CommandSpecifier, Network, NetworkEvent, Received, Station, Transport,
    TransportError, Value,
};
use canola_bench::load::{self, LoadNode, expected_i32, expected_real};
use canola_frame::{CanFrame, CanId, Duration, NodeId};

/// The node whose TPDO1 marks the end of the simulator's traffic (not one of the load nodes).
const MARKER_NODE: u8 = 127;

#[derive(Debug, Clone)]
struct Args {
    iface: String,
    nodes: u8,
    seconds: f64,
    period_us: u64,
    rcvbuf: Option<usize>,
    kernel_rcvbuf: bool,
    flap_at: Option<f64>,
    flap_ms: u64,
    sweep: Vec<u64>,
    sim_cpu: Option<usize>,
    simulate: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        iface: std::env::var("CANOPEN_VCAN_IFACE").unwrap_or_else(|_| "vcan0".into()),
        nodes: 64,
        seconds: 120.0,
        period_us: 15_000,
        rcvbuf: None,
        kernel_rcvbuf: false,
        flap_at: None,
        flap_ms: 1000,
        sweep: Vec::new(),
        sim_cpu: None,
        simulate: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value"));
        let bad = |e: &dyn std::fmt::Display| format!("{arg}: {e}");
        match arg.as_str() {
            "--iface" => a.iface = value()?,
            "--nodes" => a.nodes = value()?.parse().map_err(|e| bad(&e))?,
            "--seconds" => a.seconds = value()?.parse().map_err(|e| bad(&e))?,
            "--period-us" => a.period_us = value()?.parse().map_err(|e| bad(&e))?,
            "--rcvbuf" => a.rcvbuf = Some(value()?.parse().map_err(|e| bad(&e))?),
            "--kernel-rcvbuf" => a.kernel_rcvbuf = true,
            "--flap-at" => a.flap_at = Some(value()?.parse().map_err(|e| bad(&e))?),
            "--flap-ms" => a.flap_ms = value()?.parse().map_err(|e| bad(&e))?,
            "--sweep" => {
                a.sweep = value()?
                    .split(',')
                    .map(|p| p.trim().parse::<u64>().map_err(|e| bad(&e)))
                    .collect::<Result<_, _>>()?;
            }
            "--sim-cpu" => a.sim_cpu = Some(value()?.parse().map_err(|e| bad(&e))?),
            "--simulate" => a.simulate = true,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !(1..MARKER_NODE).contains(&a.nodes) {
        return Err(format!("--nodes takes 1..={}", MARKER_NODE - 1));
    }
    if a.period_us < 100 || a.sweep.iter().any(|p| *p < 100) {
        return Err("SYNC periods below 100 us are not supported".into());
    }
    if a.seconds.is_nan() || a.seconds <= 0.0 {
        return Err("--seconds must be positive".into());
    }
    Ok(a)
}

fn node(n: u8) -> NodeId {
    NodeId::new(n).expect("node-IDs 1..=127")
}

// ---------------------------------------------------------------------------------------------
// The simulator process.

/// What the simulator counted.
#[derive(Debug, Default)]
struct SimCounts {
    sent: u64,
    failed: u64,
    full_retries: u64,
    syncs: u64,
    rx_overflow: u64,
    down_events: u64,
    up_events: u64,
}

/// Sends `frame`, retrying while the transmit queue is full; counts a send that failed.
fn sim_send(t: &mut SocketCan, frame: &CanFrame, c: &mut SimCounts) -> Result<bool, String> {
    loop {
        match t.send(frame) {
            Ok(()) => return Ok(true),
            Err(TransportError::TxQueueFull) => {
                c.full_retries += 1;
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            Err(TransportError::InterfaceDown) => {
                c.failed += 1;
                return Ok(false);
            }
            Err(e) => return Err(format!("the simulator's send failed: {e}")),
        }
    }
}

/// `vcan_load --simulate`: the load nodes on one socket. Prints `READY`; on `stop` (or when
/// stdin closes) sends the marker frame and prints `DONE` with its counts.
fn simulate(args: &Args) -> Result<(), String> {
    // One CPU for the sender (see the module docs): vcan delivers through the backlog of the
    // CPU that sent, and a sender that moves between CPUs can have its frames overtake each
    // other.
    let cpus = std::thread::available_parallelism().map_or(1, usize::from);
    let cpu = args.sim_cpu.unwrap_or(cpus - 1);
    let mut set = nix::sched::CpuSet::new();
    set.set(cpu).map_err(|e| format!("--sim-cpu {cpu}: {e}"))?;
    nix::sched::sched_setaffinity(nix::unistd::Pid::from_raw(0), &set)
        .map_err(|e| format!("--sim-cpu {cpu}: {e}"))?;
    let mut t = SocketCan::open(&args.iface).map_err(|e| format!("open {}: {e}", args.iface))?;
    let od = load::load_dictionary();
    let mut nodes: Vec<LoadNode> = (1..=args.nodes)
        .map(|n| LoadNode::new(node(n), od.clone()))
        .collect();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    println!("READY");
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            match line {
                Ok(l) if l.trim() == "stop" => break,
                Ok(_) => {}
                Err(_) => break,
            }
        }
        flag.store(true, Ordering::SeqCst);
    });
    let mut c = SimCounts::default();
    let slice = Duration::from_millis(50);
    while !stop.load(Ordering::SeqCst) {
        let now = t.now();
        for n in &mut nodes {
            if canola_frame::is_due(n.poll_timeout(), now) {
                n.handle_timeout(now);
            }
        }
        let got = t
            .recv_until(now + slice)
            .map_err(|e| format!("the simulator's receive failed: {e}"))?;
        match got {
            Some(Received::Frame { frame, at }) => {
                if frame.cob_id() == Some(0x080) {
                    c.syncs += 1;
                }
                for n in &mut nodes {
                    n.handle_frame(at, &frame);
                }
            }
            Some(Received::Event(BusEvent::RxOverflow { dropped })) => c.rx_overflow += dropped,
            Some(Received::Event(BusEvent::InterfaceDown)) => c.down_events += 1,
            Some(Received::Event(BusEvent::InterfaceUp)) => c.up_events += 1,
            Some(Received::Event(_)) | None => {}
        }
        for n in &mut nodes {
            while let Some(f) = n.poll_transmit() {
                let pdo = f.cob_id().is_some_and(|id| (0x181..=0x4FF).contains(&id));
                if sim_send(&mut t, &f, &mut c)? && pdo {
                    c.sent += 1;
                }
            }
        }
    }
    let id = CanId::standard(0x180 + u16::from(MARKER_NODE)).expect("valid identifier");
    let marker = CanFrame::new(id, &c.sent.to_le_bytes()).expect("valid frame");
    while !sim_send(&mut t, &marker, &mut c)? {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    // Every node saw the same SYNCs: one final counter for all.
    let counter = nodes.first().map_or(0, LoadNode::counter);
    println!(
        "DONE sent={} failed={} full_retries={} syncs={} counter={counter} rx_overflow={} \
         down={} up={}",
        c.sent, c.failed, c.full_retries, c.syncs, c.rx_overflow, c.down_events, c.up_events
    );
    std::io::stdout().flush().map_err(|e| e.to_string())
}

/// The simulator child process.
struct Sim {
    child: std::process::Child,
    stdin: Option<std::process::ChildStdin>,
    lines: std::io::Lines<std::io::BufReader<std::process::ChildStdout>>,
}

impl Sim {
    fn start(args: &Args) -> Result<Self, String> {
        let exe = std::env::current_exe().map_err(|e| format!("where is this program: {e}"))?;
        let mut child = Command::new(exe)
            .arg("--simulate")
            .args(["--iface", &args.iface])
            .args(["--nodes", &args.nodes.to_string()])
            .args(
                args.sim_cpu
                    .map(|c| ["--sim-cpu".to_string(), c.to_string()])
                    .into_iter()
                    .flatten(),
            )
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("start the simulator: {e}"))?;
        let stdin = child.stdin.take();
        let out = child.stdout.take().ok_or("the simulator has no stdout")?;
        let mut lines = std::io::BufReader::new(out).lines();
        match lines.next() {
            Some(Ok(l)) if l == "READY" => Ok(Self {
                child,
                stdin,
                lines,
            }),
            other => {
                let _ = child.kill();
                let _ = child.wait();
                Err(format!("the simulator did not start: {other:?}"))
            }
        }
    }

    fn tell_stop(&mut self) -> Result<(), String> {
        let stdin = self
            .stdin
            .as_mut()
            .ok_or("the simulator's stdin is closed")?;
        writeln!(stdin, "stop").map_err(|e| format!("tell the simulator to stop: {e}"))
    }

    /// Waits for the `DONE` line and the exit; returns the counts.
    fn finish(mut self) -> Result<BTreeMap<String, u64>, String> {
        let line = loop {
            match self.lines.next() {
                Some(Ok(l)) if l.starts_with("DONE ") => break l,
                Some(Ok(_)) => {}
                other => return Err(format!("the simulator ended without counts: {other:?}")),
            }
        };
        drop(self.stdin.take());
        let _ = self.child.wait();
        Ok(line
            .split_whitespace()
            .skip(1)
            .filter_map(|kv| {
                let (k, v) = kv.split_once('=')?;
                Some((k.to_string(), v.parse().ok()?))
            })
            .collect())
    }

    /// CPU seconds of the child so far (`/proc/PID/stat` utime + stime).
    fn cpu_seconds(&self) -> f64 {
        proc_cpu_seconds(&format!("/proc/{}/stat", self.child.id()))
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        if self.stdin.is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// utime + stime of a `/proc/.../stat` file, seconds (clock ticks of 1/100 s).
fn proc_cpu_seconds(path: &str) -> f64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1;
            let f: Vec<&str> = rest.split_whitespace().collect();
            // After the name: state is field 3, utime 14 and stime 15 (1-based, in `stat`).
            let ticks = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
            Some(ticks as f64 / 100.0)
        })
        .unwrap_or(0.0)
}

/// Frames the kernel dropped on input for `iface` (`/sys/class/net/IFACE/statistics/rx_dropped`:
/// the input backlog's drops of its frames among them).
fn interface_rx_dropped(iface: &str) -> u64 {
    std::fs::read_to_string(format!("/sys/class/net/{iface}/statistics/rx_dropped"))
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(0)
}

/// Frames the kernel's per-CPU input backlog dropped, summed over the CPUs (second column of
/// `/proc/net/softnet_stat`, hexadecimal).
fn backlog_drops() -> u64 {
    std::fs::read_to_string("/proc/net/softnet_stat")
        .map(|s| {
            s.lines()
                .filter_map(|l| u64::from_str_radix(l.split_whitespace().nth(1)?, 16).ok())
                .sum()
        })
        .unwrap_or(0)
}

fn set_link(iface: &str, up: bool) -> Result<(), String> {
    let state = if up { "up" } else { "down" };
    let status = Command::new("ip")
        .args(["link", "set", "dev", iface, state])
        .status()
        .map_err(|e| format!("run ip: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("ip link set dev {iface} {state}: {status}"))
    }
}

// ---------------------------------------------------------------------------------------------
// The master.

/// What the subscriber saw.
#[derive(Debug, Default)]
struct Tally {
    received: u64,
    reordered: u64,
    gaps: u64,
    bad_values: u64,
    overflow_events: u64,
    overflow_dropped: u64,
    /// Bus events in order (interface down/up), with the PDO count at the time.
    link_events: Vec<(BusEvent, u64)>,
    other_bus_events: u64,
    transport_failed: Option<canola::error::TransportFailure>,
    marker: bool,
    last: BTreeMap<(u8, u8), u32>,
}

impl Tally {
    fn take(&mut self, nodes: u8, event: NetworkEvent) {
        match event {
            NetworkEvent::PdoValues {
                node,
                number,
                values,
                ..
            } if node.get() <= nodes => {
                self.received += 1;
                let (Some((_, Value::Unsigned32(c))), Some((_, second))) =
                    (values.first(), values.get(1))
                else {
                    self.bad_values += 1;
                    return;
                };
                let c = *c;
                let ok = match (number, second) {
                    (1, Value::Integer32(v)) => *v == expected_i32(node.get(), c),
                    (2, Value::Real32(v)) => *v == expected_real(c),
                    _ => false,
                };
                if !ok {
                    self.bad_values += 1;
                }
                match self.last.insert((node.get(), number), c) {
                    Some(prev) if c <= prev => self.reordered += 1,
                    Some(prev) => self.gaps += u64::from(c - prev - 1),
                    None => self.gaps += u64::from(c.saturating_sub(1)),
                }
            }
            NetworkEvent::Pdo { node, .. } if node.get() == MARKER_NODE => self.marker = true,
            NetworkEvent::Bus(BusEvent::RxOverflow { dropped }) => {
                self.overflow_events += 1;
                self.overflow_dropped += dropped;
            }
            NetworkEvent::Bus(e @ (BusEvent::InterfaceDown | BusEvent::InterfaceUp)) => {
                self.link_events.push((e, self.received));
            }
            NetworkEvent::Bus(_) => self.other_bus_events += 1,
            NetworkEvent::TransportFailed { failure, .. } => self.transport_failed = Some(failure),
            _ => {}
        }
    }

    /// Counts as gaps the counters after the last one received, up to the simulator's final
    /// counter: PDOs dropped at the end of the run leave no later PDO to show their gap.
    fn trailing(&mut self, nodes: u8, last_counter: u32) {
        for n in 1..=nodes {
            for number in [1, 2] {
                let last = self.last.get(&(n, number)).copied().unwrap_or(0);
                self.gaps += u64::from(last_counter.saturating_sub(last));
            }
        }
    }
}

/// The outcome of one run.
#[derive(Debug)]
struct Outcome {
    sent: u64,
    received: u64,
    rxq_dropped: u64,
    backlog: u64,
    send_failed: u64,
    clean: bool,
    syncs_short: bool,
}

fn run(args: &Args, period_us: u64) -> Result<Outcome, String> {
    let sim = Sim::start(args)?;
    let mut t = SocketCan::open_default_buffer(&args.iface)
        .map_err(|e| format!("open {}: {e}", args.iface))?;
    let kernel_default = t.receive_buffer().map_err(|e| e.to_string())?;
    if !args.kernel_rcvbuf {
        let ask = args
            .rcvbuf
            .unwrap_or(canola::socketcan::DEFAULT_RECEIVE_BUFFER);
        let got = t.set_receive_buffer(ask).map_err(|e| e.to_string())?;
        println!(
            "receive buffer: asked for {ask} bytes, the kernel reports {got} \
             (its default {kernel_default})"
        );
    } else {
        println!("receive buffer: the kernel's default, {kernel_default} bytes");
    }
    let stats: SocketCanStats = t.stats();
    let net = Network::new(t);
    let od = load::master_dictionary();
    for n in 1..=args.nodes {
        net.add_node_with_dictionary(node(n), od.clone());
    }
    let events = net.subscribe();
    net.start_driver().map_err(|e| e.to_string())?;
    net.nmt_all(CommandSpecifier::Start)
        .map_err(|e| e.to_string())?;
    std::thread::sleep(std::time::Duration::from_millis(300));
    let mut tally = Tally::default();
    for e in events.try_iter() {
        tally.take(args.nodes, e);
    }
    let backlog0 = backlog_drops();
    let iface_dropped0 = interface_rx_dropped(&args.iface);
    let cpu0 = proc_cpu_seconds("/proc/self/stat");
    let sim_cpu0 = sim.cpu_seconds();
    let start = StdInstant::now();
    net.start_sync(Duration::from_micros(period_us));
    let total = std::time::Duration::from_secs_f64(args.seconds);
    let flap_at = args.flap_at.map(std::time::Duration::from_secs_f64);
    let mut flap_thread = None;
    let mut next_report = std::time::Duration::from_secs(30);
    while start.elapsed() < total {
        if let Some(at) = flap_at
            && flap_thread.is_none()
            && start.elapsed() >= at
        {
            let (iface, ms) = (args.iface.clone(), args.flap_ms);
            println!(
                "link: down at {:.1} s ({} PDOs received so far)",
                start.elapsed().as_secs_f64(),
                tally.received
            );
            flap_thread = Some(std::thread::spawn(move || {
                set_link(&iface, false)?;
                std::thread::sleep(std::time::Duration::from_millis(ms));
                set_link(&iface, true)
            }));
        }
        if start.elapsed() >= next_report {
            println!(
                "  {:.0} s: {} PDOs received, {} dropped (rx queue)",
                start.elapsed().as_secs_f64(),
                tally.received,
                stats.rx_dropped()
            );
            next_report += std::time::Duration::from_secs(30);
        }
        // The subscriber takes what arrived every 10 ms: a receiver blocked on the channel
        // would be woken for every event, which costs a context switch per PDO.
        std::thread::sleep(std::time::Duration::from_millis(10));
        for e in events.try_iter() {
            tally.take(args.nodes, e);
        }
    }
    net.stop_sync();
    let wall = start.elapsed().as_secs_f64();
    if let Some(h) = flap_thread {
        h.join().map_err(|_| "the link thread panicked")??;
    }
    let master_cpu = proc_cpu_seconds("/proc/self/stat") - cpu0;
    let sim_cpu = sim.cpu_seconds() - sim_cpu0;
    // Let the last SYNC's PDOs arrive, then the marker.
    std::thread::sleep(std::time::Duration::from_millis(200));
    let mut sim = sim;
    sim.tell_stop()?;
    let deadline = StdInstant::now() + std::time::Duration::from_secs(30);
    while !tally.marker && StdInstant::now() < deadline {
        if let Ok(e) = events.recv_timeout(std::time::Duration::from_millis(100)) {
            tally.take(args.nodes, e);
        }
    }
    for e in events.try_iter() {
        tally.take(args.nodes, e);
    }
    let counts = sim.finish()?;
    let driven = net.is_driven();
    let _ = net.stop_driver();
    let backlog = backlog_drops() - backlog0;
    let iface_dropped = interface_rx_dropped(&args.iface) - iface_dropped0;
    let get = |k: &str| counts.get(k).copied().unwrap_or(0);
    let (sent, send_failed, syncs) = (get("sent"), get("failed"), get("syncs"));
    tally.trailing(
        args.nodes,
        u32::try_from(get("counter")).unwrap_or(u32::MAX),
    );
    let rxq = stats.rx_dropped();
    // The backlog drops every kind of frame (a SYNC to the simulator too), so its count bounds
    // the PDOs it took; the socket's overflow counter is the master's PDOs exactly.
    let missing = sent as i64 - tally.received as i64;
    let backlog_pdos = (missing - rxq as i64).clamp(0, backlog as i64) as u64;
    let counted = rxq + backlog_pdos;
    let silent = missing - counted as i64;
    let expected_syncs = (wall * 1e6 / period_us as f64) as u64;
    println!(
        "master: {} PDOs decoded in {:.1} s ({:.0} frames/s); SYNCs {} of {} expected; \
         counter gaps {}, reordered {}, wrong values {}; rx-queue overflow events {} \
         ({} frames; transport statistic {}), other bus events {}",
        tally.received,
        wall,
        tally.received as f64 / wall,
        syncs,
        expected_syncs,
        tally.gaps,
        tally.reordered,
        tally.bad_values,
        tally.overflow_events,
        tally.overflow_dropped,
        rxq,
        tally.other_bus_events
    );
    println!(
        "simulator: {} PDOs sent, {} sends failed, {} transmit-queue-full retries, \
         {} SYNCs seen, its own rx overflow {}, interface down/up events {}/{}",
        sent,
        send_failed,
        get("full_retries"),
        syncs,
        get("rx_overflow"),
        get("down"),
        get("up")
    );
    println!(
        "CPU: master process {:.1} s ({:.1} us per frame), simulator {:.1} s ({:.1} us per \
         frame)",
        master_cpu,
        master_cpu * 1e6 / tally.received.max(1) as f64,
        sim_cpu,
        sim_cpu * 1e6 / sent.max(1) as f64
    );
    let mut clean = true;
    let mut fail = |why: String| {
        println!("FAIL: {why}");
        clean = false;
    };
    if !tally.marker {
        fail("the end marker never arrived".into());
    }
    if silent != 0 {
        fail(format!(
            "{silent} frames lost without a count (sent {sent}, received {}, counted {counted})",
            tally.received
        ));
    }
    if tally.gaps != send_failed + counted {
        fail(format!(
            "counter gaps {} but failed sends + counted drops = {}",
            tally.gaps,
            send_failed + counted
        ));
    }
    if tally.overflow_dropped != rxq {
        fail(format!(
            "the RxOverflow events sum to {} but the statistic says {rxq}",
            tally.overflow_dropped
        ));
    }
    if tally.reordered != 0 || tally.bad_values != 0 {
        fail("a counter went backwards or a value decoded wrongly".into());
    }
    if let Some(e) = &tally.transport_failed {
        fail(format!("the driver ended: {e}"));
    }
    if !driven {
        fail("the background driver stopped".into());
    }
    if args.flap_at.is_some() {
        let kinds: Vec<&BusEvent> = tally.link_events.iter().map(|(e, _)| e).collect();
        println!(
            "link events: {}",
            tally
                .link_events
                .iter()
                .map(|(e, n)| format!("{e} (after {n} PDOs)"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if kinds != [&BusEvent::InterfaceDown, &BusEvent::InterfaceUp] {
            fail(format!(
                "expected InterfaceDown then InterfaceUp, got {kinds:?}"
            ));
        }
        let after_up = tally
            .link_events
            .last()
            .map_or(0, |(_, n)| tally.received - n);
        println!("PDOs received after the link returned: {after_up}");
        if after_up == 0 {
            fail("no PDO after the link returned".into());
        }
    }
    let syncs_short = (syncs as f64) < 0.95 * expected_syncs as f64;
    println!(
        "kernel input backlog: {backlog} frames dropped (all kinds; {iface_dropped} counted on \
         {}), {backlog_pdos} of them PDOs",
        args.iface
    );
    println!(
        "vcan_load: period {period_us} us, seconds {wall:.1}, sent {sent}, received {}, lost {} \
         (rx-queue overflow {rxq}, backlog {backlog_pdos}, send failed {send_failed}), silent \
         {silent}, reordered {}, rate {:.0} frames/s",
        tally.received,
        sent - tally.received,
        tally.reordered,
        sent as f64 / wall
    );
    Ok(Outcome {
        sent,
        received: tally.received,
        rxq_dropped: rxq,
        backlog: backlog_pdos,
        send_failed,
        clean,
        syncs_short,
    })
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("vcan_load: {e}");
            return ExitCode::from(2);
        }
    };
    if args.simulate {
        return match simulate(&args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("vcan_load --simulate: {e}");
                ExitCode::FAILURE
            }
        };
    }
    let periods = if args.sweep.is_empty() {
        vec![args.period_us]
    } else {
        args.sweep.clone()
    };
    let wire_us = f64::from(load::bits_per_sync(args.nodes, false));
    let mut best = None;
    for p in periods {
        println!(
            "--- {} nodes, 2 x 8-byte TPDOs each per SYNC, SYNC every {p} us ({:.0} PDOs/s; \
             {:.0} % of a 1 Mbit/s bus), {:.0} s{}",
            args.nodes,
            2.0 * f64::from(args.nodes) * 1e6 / p as f64,
            wire_us / p as f64 * 100.0,
            args.seconds,
            args.flap_at.map_or(String::new(), |s| format!(
                ", link down at {s} s for {} ms",
                args.flap_ms
            ))
        );
        let o = match run(&args, p) {
            Ok(o) => o,
            Err(e) => {
                println!("vcan_load: the run failed: {e}");
                return ExitCode::FAILURE;
            }
        };
        if !o.clean {
            return ExitCode::FAILURE;
        }
        let lossless = o.sent == o.received && o.send_failed == 0;
        if args.sweep.is_empty() {
            break;
        }
        if !lossless || o.syncs_short {
            println!(
                "sweep: {p} us not sustained ({} lost: {} rx-queue, {} backlog; SYNCs short: {})",
                o.sent - o.received,
                o.rxq_dropped,
                o.backlog,
                o.syncs_short
            );
            break;
        }
        best = Some(p);
    }
    if !args.sweep.is_empty() {
        match best {
            Some(p) => println!(
                "sweep: highest rate sustained without loss: SYNC every {p} us, {:.0} PDOs/s",
                2.0 * f64::from(args.nodes) * 1e6 / p as f64
            ),
            None => println!("sweep: no period sustained without loss"),
        }
    }
    ExitCode::SUCCESS
}
