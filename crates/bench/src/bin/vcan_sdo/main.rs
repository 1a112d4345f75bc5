//! Side-by-side SDO benchmark on a real SocketCAN bus (vcan0 in the QEMU guest of `tests/vcan`):
//! this master (`canola::Network` over `canola::socketcan::SocketCan`) and python-canopen's
//! `RemoteNode` (`crates/bench/py/remote_sdo_bench.py`, another process) run the same workload
//! one after the other against one simulated device (`canola::SimDevice` from the rig's test
//! EDS, served by `canola::run_station` on its own socket in a child process, this binary run
//! with `--serve`): COUNT expedited reads of 0x1000, a segmented and a block upload of SIZE
//! bytes from 0x2001. Prints the times and the ratios, then where a request/response round trip
//! goes (client CPU, simulator CPU, rest) for this master, python-canopen and a raw-socket
//! client (the least any client can do, as the floor this simulator and kernel allow).
//!
//! Exits non-zero only when a transfer fails or returns wrong data; the times are reported, never
//! judged (the guest is emulated and the machine is shared).
//!
//! ```text
//! vcan_sdo [--python PATH] [--iface vcan0] [--count 1000] [--size 65536] [--node-id 0x5c]
//!          [--pin-cpu N] [--sim-thread] [--sim-normal] [--no-python]
//! ```
//! `--no-python` skips python-canopen's run (this master and the raw client only).
//! `--pin-cpu N` runs everything (this process's threads, the simulator and the python-canopen
//! child) on CPU N. In the two-vCPU TCG guest, waking a thread on the other vCPU takes
//! milliseconds (QEMU has to kick the halted vCPU's host thread, on a shared host), which then
//! dominates every request/response round trip of both clients alike; on one vCPU a wake-up is
//! a context switch, so the figures show the clients' own costs.
//!
//! The simulator runs in a process of its own so that every client pays the same switch between
//! address spaces per frame (under TCG that flushes QEMU's software TLB, which costs the next
//! instructions much more than on hardware). `--sim-thread` serves it from a thread of this
//! process instead, to show that difference: this master and the raw client then switch
//! between threads of one address space, python-canopen still between processes.
//!
//! The simulator process runs at real-time priority (`chrt -f 1`, SCHED_FIFO; root in the rig's
//! guest) unless `--sim-normal` is given or that fails. On one CPU a device and its client
//! otherwise share the CPU fairly: a client that uses less CPU than the device is woken ahead
//! of it and preempts it in the middle of a block-upload sub-block (127 frames sent in one go),
//! and every such switch costs a TLB flush. A real device does not share its CPU with the
//! master; at real-time priority the simulator is never preempted by a client's wake-up, for
//! every client alike.
//! `--python` defaults to `$CANOPEN_PYTHON` (set by `tests/vcan/run-all`), the interface to
//! `$CANOPEN_VCAN_IFACE` or `vcan0`.

use std::io::BufRead;
use std::process::{Command, ExitCode, Stdio};
use std::sync::Arc;

use canola::Network;
use canola::socketcan::SocketCan;
use canola_bench::{BenchError, Measured, context_switches, kib_per_s, run_workload};
use canola_frame::{Duration, NodeId};

mod sim;

use sim::{Calls, Counting, Sim, serve};

struct Args {
    python: Option<String>,
    iface: String,
    count: u64,
    size: usize,
    node: u8,
    pin_cpu: Option<usize>,
    /// Serve the simulated device on stdin/stdout commands (the child process).
    serve: bool,
    sim_thread: bool,
    sim_normal: bool,
    no_python: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        python: std::env::var("CANOPEN_PYTHON").ok(),
        iface: std::env::var("CANOPEN_VCAN_IFACE").unwrap_or_else(|_| "vcan0".into()),
        count: 1000,
        size: canola_bench::LARGE_LEN,
        node: 0x5C,
        pin_cpu: None,
        serve: false,
        sim_thread: false,
        sim_normal: false,
        no_python: false,
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
            "--serve" => a.serve = true,
            "--sim-thread" => a.sim_thread = true,
            "--no-python" => a.no_python = true,
            "--sim-normal" => a.sim_normal = true,
            _ => return Err(format!("unknown argument {flag}")),
        }
    }
    Ok(a)
}

/// This master's run. The network (and its socket) is gone when this returns, so it does not
/// cost the guest anything during python-canopen's run.
fn master(
    args: &Args,
    node: NodeId,
    calls: Arc<Calls>,
    sim: &Sim,
) -> Result<[Measured; 3], BenchError> {
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
    n.sdo().write((0x1017, 0), 0u16).wait()?;
    let stats = || (0, 0.0);
    let settle = || Ok(net.run_for(Duration::from_millis(20)).wait()?);
    run_workload(&n, args.count, args.size, &stats, &|| sim.usage(), &settle)
}

/// One part of a run: elapsed and CPU seconds and context switches of the client, the same of
/// the simulator.
#[derive(Debug, Clone, Copy, Default)]
struct Part {
    seconds: f64,
    cpu: f64,
    switches: u64,
    sim_cpu: f64,
    sim_switches: u64,
}

impl Part {
    fn of(m: &Measured) -> Self {
        Self {
            seconds: m.seconds,
            cpu: m.cpu_seconds,
            switches: m.switches,
            sim_cpu: m.peer_cpu_seconds,
            sim_switches: m.peer_switches,
        }
    }
}

/// Context switches of all threads of process `pid`.
fn process_switches(pid: u32) -> u64 {
    std::fs::read_dir(format!("/proc/{pid}/task")).map_or(0, |tasks| {
        tasks
            .flatten()
            .map(|t| context_switches(&format!("{}/status", t.path().display())))
            .sum()
    })
}

/// The smallest SDO client there is, as the floor any client meets against this simulator on
/// this kernel: one blocking `write` and one blocking `read` per request on a plain SocketCAN
/// socket (the `socketcan` crate), no timers, no clock reads, no other work. It runs the
/// expedited and the segmented part of the workload (CiA 301 §7.2.4.3.2/.3/.4 frames written out
/// by hand), checking the data.
fn raw_client(args: &Args, node: u8, sim: &Sim) -> Result<[Part; 2], BenchError> {
    use socketcan::{EmbeddedFrame, Socket, StandardId};
    let io = |e: std::io::Error| BenchError(format!("raw client: {e}"));
    let socket = socketcan::CanSocket::open(&args.iface).map_err(io)?;
    // Set once: a missing answer ends the run instead of hanging it.
    socket
        .set_read_timeout(std::time::Duration::from_secs(5))
        .map_err(io)?;
    let request = |data: [u8; 8]| -> Result<[u8; 8], BenchError> {
        let id = StandardId::new(0x600 + u16::from(node)).expect("0x600 + node-ID fits 11 bits");
        let frame = socketcan::CanFrame::new(id, &data).expect("8 bytes fit");
        socket.write_frame(&frame).map_err(io)?;
        loop {
            let got = socket.read_frame().map_err(io)?;
            if socketcan::Frame::raw_id(&got) == 0x580 + u32::from(node) {
                let mut out = [0u8; 8];
                let d = got.data();
                out[..d.len()].copy_from_slice(d);
                return Ok(out);
            }
        }
    };
    let upload_initiate = |(index, sub): (u16, u8)| {
        let i = index.to_le_bytes();
        request([0x40, i[0], i[1], sub, 0, 0, 0, 0])
    };
    let own = "/proc/thread-self/status";
    let measure = |f: &mut dyn FnMut() -> Result<(), BenchError>| -> Result<Part, BenchError> {
        let (sim_cpu0, sim_switches0) = sim.usage();
        let switches0 = context_switches(own);
        let (t0, cpu0) = (
            std::time::Instant::now(),
            canola_bench::thread_cpu_seconds(),
        );
        f()?;
        let (seconds, cpu) = (
            t0.elapsed().as_secs_f64(),
            canola_bench::thread_cpu_seconds() - cpu0,
        );
        let switches = context_switches(own) - switches0;
        let (sim_cpu1, sim_switches1) = sim.usage();
        Ok(Part {
            seconds,
            cpu,
            switches,
            sim_cpu: sim_cpu1 - sim_cpu0,
            sim_switches: sim_switches1 - sim_switches0,
        })
    };
    let expedited = measure(&mut || {
        for _ in 0..args.count {
            let r = upload_initiate(canola_bench::EXPEDITED_ENTRY)?;
            if r[0] & 0xE3 != 0x43 || r[4..] != canola_bench::EXPEDITED_VALUE.to_le_bytes() {
                return Err(BenchError(format!("raw client: expedited answer {r:02x?}")));
            }
        }
        Ok(())
    })?;
    let want = canola_bench::payload(args.size);
    let segmented = measure(&mut || {
        let r = upload_initiate(canola_bench::LARGE_ENTRY)?;
        if r[0] != 0x41 || u32::from_le_bytes([r[4], r[5], r[6], r[7]]) as usize != want.len() {
            return Err(BenchError(format!("raw client: initiate answer {r:02x?}")));
        }
        let mut got = Vec::with_capacity(want.len());
        let mut toggle = 0u8;
        loop {
            let r = request([0x60 | toggle, 0, 0, 0, 0, 0, 0, 0])?;
            if r[0] & 0xF0 != toggle {
                return Err(BenchError(format!("raw client: segment answer {r:02x?}")));
            }
            let unused = usize::from((r[0] >> 1) & 7);
            got.extend_from_slice(&r[1..8 - unused]);
            if r[0] & 1 != 0 {
                break;
            }
            toggle ^= 0x10;
        }
        if got != want {
            return Err(BenchError("raw client: segmented data differ".into()));
        }
        Ok(())
    })?;
    Ok([expedited, segmented])
}

/// python-canopen's run: elapsed and CPU seconds of its three parts.
fn python(args: &Args, python: &str, sim: &Sim) -> Result<[Part; 3], BenchError> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/py/remote_sdo_bench.py");
    let mut child = Command::new(python)
        .arg("-u")
        .arg(script)
        .args(["--iface", &args.iface])
        .args(["--node-id", &args.node.to_string()])
        .args(["--count", &args.count.to_string()])
        .args(["--size", &args.size.to_string()])
        .arg("--marks")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| BenchError(format!("start {python} {script}: {e}")))?;
    let mut result = None;
    // Per part: simulator CPU, simulator switches, python's switches (all its threads), from
    // readings at each part's start and end (the lines come just outside the timed code).
    let mut begin = [(0.0f64, 0u64, 0u64); 3];
    let mut usage = [(0.0f64, 0u64, 0u64); 3];
    let pid = child.id();
    let read = || {
        let (cpu, sw) = sim.usage();
        (cpu, sw, process_switches(pid))
    };
    let slot = |name: &str| {
        ["expedited", "segmented", "block"]
            .iter()
            .position(|n| *n == name)
    };
    if let Some(out) = child.stdout.take() {
        for line in std::io::BufReader::new(out).lines() {
            let Ok(line) = line else { break };
            if let Some(i) = line.strip_prefix("BEGIN ").and_then(slot) {
                begin[i] = read();
                continue;
            }
            if let Some(i) = line.strip_prefix("END ").and_then(slot) {
                let (a, b) = (begin[i], read());
                usage[i] = (b.0 - a.0, b.1 - a.1, b.2 - a.2);
                continue;
            }
            println!("python-canopen: {line}");
            if let Some(rest) = line.strip_prefix("RESULT ") {
                result = Some(parse_result(rest)?);
            }
        }
    }
    let result = result.map(|r: [(f64, f64); 3]| {
        [0, 1, 2].map(|i| Part {
            seconds: r[i].0,
            cpu: r[i].1,
            switches: usage[i].2,
            sim_cpu: usage[i].0,
            sim_switches: usage[i].1,
        })
    });
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
    let python_path = match (&args.python, args.no_python) {
        (_, true) => None,
        (Some(p), false) => Some(p.clone()),
        (None, false) => {
            return Err(BenchError(
                "no python: pass --python or set CANOPEN_PYTHON (run-all sets it), or \
                 --no-python"
                    .into(),
            ));
        }
    };
    let node = NodeId::new(args.node).map_err(|_| BenchError("node-ID 1..=127".into()))?;
    if let Some(cpu) = args.pin_cpu {
        // Before any thread or child exists: they inherit the affinity.
        let mut set = nix::sched::CpuSet::new();
        set.set(cpu)
            .map_err(|e| BenchError(format!("--pin-cpu {cpu}: {e}")))?;
        nix::sched::sched_setaffinity(nix::unistd::Pid::from_raw(0), &set)
            .map_err(|e| BenchError(format!("--pin-cpu {cpu}: {e}")))?;
    }
    let master_calls = Arc::new(Calls::default());
    let mut sim = Sim::start(args)?;
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
    println!(
        "the simulator runs in {}",
        match &sim {
            Sim::Thread { .. } => "a thread of this process (--sim-thread)",
            Sim::Process { .. } if sim.is_fifo() => {
                "a process of its own at real-time priority (SCHED_FIFO 1)"
            }
            Sim::Process { .. } => "a process of its own (SCHED_OTHER)",
        }
    );
    let sim0 = sim.calls()?;
    let rust = master(args, node, master_calls.clone(), &sim)?;
    let sim1 = sim.calls()?;
    println!("canopen-rs master: done");
    let raw = raw_client(args, args.node, &sim)?;
    println!("raw-socket client: done");
    let sim2 = sim.calls()?;
    let py = match &python_path {
        Some(path) => Some(python(args, path, &sim)?),
        None => None,
    };
    let sim3 = sim.calls()?;
    sim.stop()?;
    let diff = |a: [u64; 3], b: [u64; 3]| {
        format!(
            "{} sends, {} receives ({} empty)",
            b[0] - a[0],
            b[1] - a[1],
            b[2] - a[2]
        )
    };
    println!(
        "transport calls: master {}; simulator during the master's run {}, during \
         python-canopen's run {}",
        diff([0; 3], master_calls.snapshot()),
        diff(sim0, sim1),
        diff(sim2, sim3)
    );

    if let Some(py) = py {
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
        for (m, p) in rust.iter().zip(py) {
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
                p.seconds,
                rate(p.seconds),
                p.cpu,
                p.seconds / m.seconds,
                p.cpu / m.cpu_seconds
            );
        }
        println!(
            "rs = canopen-rs master (blocking API; cpu = CPU time of the thread that drives it), \
             py = python-canopen 2.4.1 RemoteNode (cpu = CPU time of its process, receive thread \
             included); time = wall-clock, both against the same SimDevice on {}; x = python / rs",
            args.iface
        );
    }

    // Where the time goes, per request/response round trip (expedited: per read; segmented:
    // per segment, the initiate counted as one more) and per segment of the block upload.
    let units = [
        args.count as f64,
        args.size.div_ceil(7) as f64 + 1.0,
        args.size.div_ceil(7) as f64,
    ];
    println!(
        "\nper unit          | {:<34} | {:<34} | {:<34}",
        "expedited read", "segmented: segment round trip", "block upload: segment"
    );
    let head = format!(
        "{:>7} {:>7} {:>7} {:>5} {:>5}",
        "wall", "client", "sim", "c sw", "s sw"
    );
    println!("{:<17} | {head} | {head} | {head}", "client (us, n)");
    let mut rows: Vec<(&str, Vec<Part>)> = vec![
        ("canopen-rs", rust.iter().map(Part::of).collect()),
        ("raw socket", raw.to_vec()),
    ];
    if let Some(py) = py {
        rows.push(("python-canopen", py.to_vec()));
    }
    for (name, parts) in &rows {
        let mut line = format!("{name:<17}");
        for (p, n) in parts.iter().zip(units) {
            let us = |s: f64| s * 1e6 / n;
            line += &format!(
                " | {:>7.1} {:>7.1} {:>7.1} {:>5.2} {:>5.2}",
                us(p.seconds),
                us(p.cpu),
                us(p.sim_cpu),
                p.switches as f64 / n,
                p.sim_switches as f64 / n
            );
        }
        println!("{line}");
    }
    println!(
        "wall = elapsed, client / sim = CPU time of the client's thread(s) / of the simulator \
         (schedstat), c sw / s sw = their context switches (voluntary and involuntary), all per \
         unit. raw socket = the least any client can do (one blocking write and read per \
         request, nothing else; no block upload)."
    );
    let floor = [raw[0].seconds, raw[1].seconds];
    let mut line = format!(
        "against the raw-socket floor: canopen-rs takes {:.2}x its time expedited, {:.2}x \
         segmented",
        rust[0].seconds / floor[0],
        rust[1].seconds / floor[1]
    );
    if let Some(py) = py {
        line += &format!(
            "; python-canopen {:.1}x and {:.1}x (so no client can be more than that much faster \
             than python-canopen here)",
            py[0].seconds / floor[0],
            py[1].seconds / floor[1]
        );
    }
    println!("{line}");
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
    let result = if args.serve { serve(&args) } else { run(&args) };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vcan_sdo: FAILED: {e}");
            ExitCode::FAILURE
        }
    }
}
