//! Side-by-side SDO benchmark on a real SocketCAN bus (vcan0 in the QEMU guest of `tests/vcan`):
//! this master (`canopen::Network` over `canopen::socketcan::SocketCan`) and python-canopen's
//! `RemoteNode` (`crates/bench/py/remote_sdo_bench.py`, another process) run the same workload
//! one after the other against one simulated device (`canopen::SimDevice` from the rig's test
//! EDS, served on its own socket by a thread of this process): COUNT expedited reads of 0x1000,
//! a segmented and a block upload of SIZE bytes from 0x2001. Prints the times and the ratios.
//!
//! Exits non-zero only when a transfer fails or returns wrong data; the times are reported, never
//! judged (the guest is emulated and the machine is shared).
//!
//! ```text
//! vcan_sdo [--python PATH] [--iface vcan0] [--count 1000] [--size 65536] [--node-id 0x5c]
//!          [--pin-cpu N]
//! ```
//! `--pin-cpu N` runs everything (this process's threads and the python-canopen child) on CPU
//! N. In the two-vCPU TCG guest, waking a thread on the other vCPU takes milliseconds (QEMU
//! has to kick the halted vCPU's host thread, on a shared host), which then dominates every
//! request/response round trip of both clients alike; on one vCPU a wake-up is a context
//! switch, so the figures show the clients' own costs.
//! `--python` defaults to `$CANOPEN_PYTHON` (set by `tests/vcan/run-all`), the interface to
//! `$CANOPEN_VCAN_IFACE` or `vcan0`.

use std::io::BufRead;
use std::process::{Command, ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use can_frame::{Duration, NodeId};
use canopen::socketcan::SocketCan;
use canopen::{Network, Received, SimDevice, Transport, TransportError, run_station};
use canopen_bench::{BenchError, Measured, device, kib_per_s, run_workload};

struct Args {
    python: Option<String>,
    iface: String,
    count: u64,
    size: usize,
    node: u8,
    pin_cpu: Option<usize>,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        python: std::env::var("CANOPEN_PYTHON").ok(),
        iface: std::env::var("CANOPEN_VCAN_IFACE").unwrap_or_else(|_| "vcan0".into()),
        count: 1000,
        size: canopen_bench::LARGE_LEN,
        node: 0x5C,
        pin_cpu: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        let number = |v: String| -> Result<u64, String> {
            let parsed = match v.strip_prefix("0x") {
                Some(hex) => u64::from_str_radix(hex, 16),
                None => v.parse(),
            };
            parsed.map_err(|e| format!("{flag} {v}: {e}"))
        };
        match flag.as_str() {
            "--python" => a.python = Some(value()?),
            "--iface" => a.iface = value()?,
            "--count" => a.count = number(value()?)?,
            "--size" => a.size = number(value()?)? as usize,
            "--node-id" => {
                a.node = u8::try_from(number(value()?)?).map_err(|e| format!("--node-id: {e}"))?
            }
            "--pin-cpu" => a.pin_cpu = Some(number(value()?)? as usize),
            _ => return Err(format!("unknown argument {flag}")),
        }
    }
    Ok(a)
}

/// Transport calls, to show how a side drives its socket (blocking waits or polling).
#[derive(Debug, Default)]
struct Calls {
    sends: AtomicU64,
    recvs: AtomicU64,
    /// `recv_until` calls whose deadline had already passed (non-blocking polls).
    polls: AtomicU64,
    /// `recv_until` calls that returned nothing.
    empty: AtomicU64,
}

impl Calls {
    fn snapshot(&self) -> [u64; 4] {
        [&self.sends, &self.recvs, &self.polls, &self.empty].map(|c| c.load(Ordering::Relaxed))
    }
}

/// A transport that counts its calls.
struct Counting<T> {
    inner: T,
    calls: Arc<Calls>,
}

impl<T: Transport> Transport for Counting<T> {
    fn send(&mut self, frame: &can_frame::CanFrame) -> Result<(), TransportError> {
        self.calls.sends.fetch_add(1, Ordering::Relaxed);
        self.inner.send(frame)
    }

    fn recv_until(
        &mut self,
        deadline: can_frame::Instant,
    ) -> Result<Option<Received>, TransportError> {
        self.calls.recvs.fetch_add(1, Ordering::Relaxed);
        if deadline <= self.inner.now() {
            self.calls.polls.fetch_add(1, Ordering::Relaxed);
        }
        let r = self.inner.recv_until(deadline);
        if matches!(r, Ok(None)) {
            self.calls.empty.fetch_add(1, Ordering::Relaxed);
        }
        r
    }

    fn now(&self) -> can_frame::Instant {
        self.inner.now()
    }
}

/// The simulated device served on its own socket by a thread until dropped.
struct RunningSim {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<Result<(), TransportError>>>,
}

impl RunningSim {
    fn start(iface: &str, mut dev: SimDevice, calls: Arc<Calls>) -> Result<Self, TransportError> {
        // Opened here, so the device's socket receives from the moment this returns.
        let mut transport = Counting {
            inner: SocketCan::open(iface)?,
            calls,
        };
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            run_station(&mut transport, &mut dev, || flag.load(Ordering::Relaxed))
        });
        Ok(Self {
            stop,
            thread: Some(thread),
        })
    }

    fn stop(mut self) -> Result<(), BenchError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(Err(e))) => Err(BenchError(format!("the simulator's transport failed: {e}"))),
            Some(Err(_)) => Err(BenchError("the simulator thread panicked".into())),
            _ => Ok(()),
        }
    }
}

impl Drop for RunningSim {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// This master's run. The network (and its socket) is gone when this returns, so it does not
/// cost the guest anything during python-canopen's run.
fn master(args: &Args, node: NodeId, calls: Arc<Calls>) -> Result<[Measured; 3], BenchError> {
    let net = Network::new(Counting {
        inner: SocketCan::open(&args.iface)
            .map_err(|e| BenchError(format!("open {}: {e}", args.iface)))?,
        calls,
    });
    // vcan0 neither drops nor duplicates: no pause between transfers to one node (see
    // Network::set_transfer_gap); python-canopen has none either.
    net.set_transfer_gap(Duration::ZERO);
    let n = net.node(node);
    // Heartbeat off: only SDO frames on the bus during both runs. Also proves the device serves.
    n.sdo().write((0x1017, 0), 0u16)?;
    let stats = || (0, 0.0);
    let settle = || Ok(net.run_for(Duration::from_millis(20))?);
    run_workload(&n, args.count, args.size, &stats, &settle)
}

/// python-canopen's run: elapsed and CPU seconds of its three parts.
fn python(args: &Args, python: &str) -> Result<[(f64, f64); 3], BenchError> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/py/remote_sdo_bench.py");
    let mut child = Command::new(python)
        .arg("-u")
        .arg(script)
        .args(["--iface", &args.iface])
        .args(["--node-id", &args.node.to_string()])
        .args(["--count", &args.count.to_string()])
        .args(["--size", &args.size.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| BenchError(format!("start {python} {script}: {e}")))?;
    let mut result = None;
    if let Some(out) = child.stdout.take() {
        for line in std::io::BufReader::new(out).lines() {
            let Ok(line) = line else { break };
            println!("python-canopen: {line}");
            if let Some(rest) = line.strip_prefix("RESULT ") {
                result = Some(parse_result(rest)?);
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| BenchError(format!("wait for python: {e}")))?;
    match (status.success(), result) {
        (true, Some(r)) => Ok(r),
        (true, None) => Err(BenchError("python-canopen printed no RESULT line".into())),
        (false, _) => Err(BenchError(format!("python-canopen failed: {status}"))),
    }
}

fn parse_result(rest: &str) -> Result<[(f64, f64); 3], BenchError> {
    let mut out = [f64::NAN; 6];
    for field in rest.split_whitespace() {
        let (key, value) = field
            .split_once('=')
            .ok_or_else(|| BenchError(format!("bad RESULT field {field}")))?;
        let slot = match key {
            "expedited" => 0,
            "segmented" => 1,
            "block" => 2,
            "expedited_cpu" => 3,
            "segmented_cpu" => 4,
            "block_cpu" => 5,
            _ => continue,
        };
        out[slot] = value
            .parse()
            .map_err(|e| BenchError(format!("bad RESULT value {field}: {e}")))?;
    }
    if out.iter().any(|v| v.is_nan()) {
        return Err(BenchError(format!("incomplete RESULT line: {rest}")));
    }
    Ok([(out[0], out[3]), (out[1], out[4]), (out[2], out[5])])
}

fn run(args: &Args) -> Result<(), BenchError> {
    let python_path = args.python.clone().ok_or_else(|| {
        BenchError("no python: pass --python or set CANOPEN_PYTHON (run-all sets it)".into())
    })?;
    let node = NodeId::new(args.node).map_err(|_| BenchError("node-ID 1..=127".into()))?;
    if let Some(cpu) = args.pin_cpu {
        // Before any thread or child exists: they inherit the affinity.
        let mut set = nix::sched::CpuSet::new();
        set.set(cpu)
            .map_err(|e| BenchError(format!("--pin-cpu {cpu}: {e}")))?;
        nix::sched::sched_setaffinity(nix::unistd::Pid::from_raw(0), &set)
            .map_err(|e| BenchError(format!("--pin-cpu {cpu}: {e}")))?;
    }
    let sim_calls = Arc::new(Calls::default());
    let master_calls = Arc::new(Calls::default());
    let sim = RunningSim::start(&args.iface, device(node, args.size), sim_calls.clone())
        .map_err(|e| BenchError(format!("open {} for the simulator: {e}", args.iface)))?;
    println!(
        "vcan SDO benchmark on {}: {} expedited reads of 0x1000, {}-byte segmented and block \
         uploads of 0x2001 from the simulated device {:#04x}{}",
        args.iface,
        args.count,
        args.size,
        args.node,
        match args.pin_cpu {
            Some(cpu) => format!(", everything on CPU {cpu}"),
            None => String::new(),
        }
    );
    let sim0 = sim_calls.snapshot();
    let rust = master(args, node, master_calls.clone())?;
    let sim1 = sim_calls.snapshot();
    println!("canopen-rs master: done");
    let py = python(args, &python_path)?;
    sim.stop()?;
    let sim2 = sim_calls.snapshot();
    let diff = |a: [u64; 4], b: [u64; 4]| {
        let d: Vec<u64> = a.iter().zip(b).map(|(a, b)| b - a).collect();
        format!(
            "{} sends, {} receives ({} non-blocking, {} empty)",
            d[0], d[1], d[2], d[3]
        )
    };
    println!(
        "transport calls: master {}; simulator during the master's run {}, during \
         python-canopen's run {}",
        diff([0; 4], master_calls.snapshot()),
        diff(sim0, sim1),
        diff(sim1, sim2)
    );

    println!(
        "\n{:<17} | {:>9} {:>12} {:>8} | {:>9} {:>12} {:>8} | {:>8} {:>8}",
        "workload",
        "rs time",
        "rs rate",
        "rs cpu",
        "py time",
        "py rate",
        "py cpu",
        "time x",
        "cpu x"
    );
    for (m, (py_s, py_cpu)) in rust.iter().zip(py) {
        let rate = |s: f64| {
            if m.transfers > 1 {
                format!("{:.0}/s", m.transfers as f64 / s)
            } else {
                format!("{:.1} KiB/s", kib_per_s(m.bytes, s))
            }
        };
        println!(
            "{:<17} | {:>8.3}s {:>12} {:>7.3}s | {:>8.3}s {:>12} {:>7.3}s | {:>7.1}x {:>7.1}x",
            m.label,
            m.seconds,
            rate(m.seconds),
            m.cpu_seconds,
            py_s,
            rate(py_s),
            py_cpu,
            py_s / m.seconds,
            py_cpu / m.cpu_seconds
        );
    }
    println!(
        "rs = canopen-rs master (blocking API; cpu = CPU time of the thread that drives it), py = \
         python-canopen 2.4.1 RemoteNode (cpu = CPU time of its process, receive thread \
         included); time = wall-clock, both against the same SimDevice on {}; x = python / rs",
        args.iface
    );
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("vcan_sdo: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vcan_sdo: FAILED: {e}");
            ExitCode::FAILURE
        }
    }
}
