//! The SYNC period's jitter on a real SocketCAN bus (vcan0 in the QEMU guest of `tests/vcan`),
//! this master against python-canopen, each producing a 1 kHz SYNC and eight csp RPDOs a cycle.
//!
//! * The drives: `--drives N` simulated CiA 402 servos (`canola_cia402::master::simulated_drive`
//!   from `eds/cia402-servo.eds`, nodes 1..=N) served from one socket by a child process (this
//!   binary run with `--serve`). Their TPDOs 2..4 (on every SYNC) are switched off by SDO, so
//!   the bus carries the SYNC, the RPDOs and TPDO1 (statusword on change, every 100 ms).
//!   The drives serve the set-up; their process is then stopped unless `--keep-drives` is
//!   given: under emulation, eight drive models taking 9 000 frames a second keep a vCPU busy
//!   and starve both senders alike (the windows then measure the guest's load, not the
//!   senders).
//! * This master, twice (each time with a drives' process of its own): `canola::Network` over
//!   `canola::socketcan::SocketCan` with its background driver thread, first with the
//!   transport's default waits (the socket's receive timeout, rounded up to the kernel's tick),
//!   then with precise waits (`SocketCan::with_precise_waits`: `ppoll`); each drive enabled and put in csp by `Drive::start_cyclic` (RPDO4 with
//!   0x607A alone, transmission type 1), the SYNC produced by `Network::start_sync`, so the PDO
//!   engine sends the eight RPDOs after every SYNC. An application thread sets a new target
//!   for every drive about once a millisecond (`CyclicStream::set_target`), as a csp
//!   application does.
//! * python-canopen 2.4.1 (`crates/bench/py/sync_rpdo_bench.py`, another process), after this
//!   master stopped: `network.sync.start(PERIOD)` and, per drive, RPDO4 with the same mapping
//!   and COB-ID sent by its periodic PDO transmit (`PdoMap.start(PERIOD)`). Both go through
//!   python-can's socketcan interface, whose periodic sends are kernel timers (CAN_BCM): the
//!   SYNC and each RPDO are separate timers, the RPDOs not tied to the SYNC.
//! * The receiver: `candump -L IFACE,080:7FF,500:7F0` (can-utils, another process): the
//!   kernel's receive timestamp of every SYNC and RPDO (SO_TIMESTAMP, microseconds). Each side
//!   runs `--warmup` seconds before its window of `--seconds` starts.
//!
//! Printed per side: the SYNCs in the window, the intervals between consecutive SYNCs (p50,
//! p99, max, min), how far they stray from the period (p99 and max of |interval − period|),
//! the RPDOs between two SYNCs (cycles with exactly one of every drive, the fewest and most;
//! frames in the order of their stamps, and how many the receiver got out of that order: vcan
//! delivers a frame from the input backlog of the vCPU that sent it),
//! and the CPU time per cycle of the sender (this process's threads but the one reading
//! candump's lines; python-canopen's whole process) and of the drives' process when it runs
//! (`/proc/PID/stat`).
//! The last line is `vcan_drives: canola p50 .. p99 .. max .. | canola precise p50 .. p99 ..
//! max .. | python-canopen p50 .. p99 .. max .. (µs)`.
//!
//! The figures are measured, not judged (the guest is emulated on a shared machine): the run
//! fails only when a side could not run, or its window holds fewer than 100 SYNCs.
//!
//! ```text
//! vcan_drives [--iface vcan0] [--drives 8] [--seconds 10] [--warmup 1] [--period-us 1000]
//!             [--python PATH] [--no-python] [--keep-drives] [--hold]
//! ```
//! `--hold` keeps this master's targets still (no application thread setting them), to show
//! what the application's `set_target` calls cost the SYNC.
//! `--python` defaults to `$CANOPEN_PYTHON` (set by `tests/vcan/run-all`), the interface to
//! `$CANOPEN_VCAN_IFACE` or `vcan0`.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration as StdDuration, Instant as StdInstant, SystemTime, UNIX_EPOCH};

use canola::socketcan::SocketCan;
use canola::{CommandSpecifier, Network, SimDevice, Station, Transport, run_station};
use canola_bench::drives::SERVO_EDS;
use canola_cia402::ModeOfOperation;
use canola_cia402::master::{CyclicStream, Drive, simulated_drive};
use canola_cia402::sim::SimDrive;
use canola_frame::{CanFrame, CanId, Duration, Instant, NodeId};

/// The RPDO the targets travel in (COB-ID 0x500 + node).
const TARGET_RPDO: u16 = 4;
/// The frame that tells the receiver is listening (inside its filter, no drive's RPDO).
const PROBE_ID: u16 = 0x50F;
/// The name of the thread that parses candump's lines (its CPU is not the sender's).
const READER_THREAD: &str = "candump-reader";

struct Args {
    iface: String,
    drives: u8,
    seconds: f64,
    warmup: f64,
    period_us: u64,
    python: Option<String>,
    no_python: bool,
    keep_drives: bool,
    hold: bool,
    serve: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        iface: std::env::var("CANOPEN_VCAN_IFACE").unwrap_or_else(|_| "vcan0".into()),
        drives: 8,
        seconds: 10.0,
        warmup: 1.0,
        period_us: 1000,
        python: std::env::var("CANOPEN_PYTHON").ok(),
        no_python: false,
        keep_drives: false,
        hold: false,
        serve: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        let bad = |e: &dyn std::fmt::Display| format!("{flag}: {e}");
        match flag.as_str() {
            "--iface" => a.iface = value()?,
            "--drives" => a.drives = value()?.parse().map_err(|e| bad(&e))?,
            "--seconds" => a.seconds = value()?.parse().map_err(|e| bad(&e))?,
            "--warmup" => a.warmup = value()?.parse().map_err(|e| bad(&e))?,
            "--period-us" => a.period_us = value()?.parse().map_err(|e| bad(&e))?,
            "--python" => a.python = Some(value()?),
            "--no-python" => a.no_python = true,
            "--keep-drives" => a.keep_drives = true,
            "--hold" => a.hold = true,
            "--serve" => a.serve = true,
            _ => return Err(format!("unknown argument {flag}")),
        }
    }
    if !(1..=15).contains(&a.drives) {
        return Err("--drives must be 1..=15 (RPDO4 COB-IDs 0x501..=0x50F)".into());
    }
    if !(a.seconds.is_finite() && a.seconds > 0.0 && a.warmup.is_finite() && a.warmup >= 0.0) {
        return Err("--seconds must be positive, --warmup not negative".into());
    }
    if a.period_us == 0 {
        return Err("--period-us must be positive".into());
    }
    Ok(a)
}

/// Several simulated devices on one socket: every frame goes to each, each fires its own
/// timers, their frames go out in turn.
struct Stations(Vec<SimDevice>);

impl Station for Stations {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        for s in &mut self.0 {
            s.handle_frame(now, frame);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        for s in &mut self.0 {
            if s.poll_timeout().is_some_and(|t| t <= now) {
                s.handle_timeout(now);
            }
        }
    }

    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.0.iter_mut().find_map(|s| s.poll_transmit())
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.0.iter().filter_map(|s| s.poll_timeout()).min()
    }
}

/// `vcan_drives --serve`: the simulated drives on one socket until stdin closes. Prints `READY`
/// once the socket is open.
fn serve(args: &Args) -> Result<(), String> {
    let mut transport = SocketCan::open(&args.iface)
        .map_err(|e| format!("open {} for the drives: {e}", args.iface))?;
    let mut devices = Vec::new();
    for n in 1..=args.drives {
        let id = NodeId::new(n).map_err(|e| e.to_string())?;
        let (device, _model) =
            simulated_drive(id, SERVO_EDS, SimDrive::default()).map_err(|e| e.to_string())?;
        devices.push(device);
    }
    let mut stations = Stations(devices);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    println!("READY");
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            if line.is_err() {
                break;
            }
        }
        flag.store(true, Ordering::Relaxed);
    });
    run_station(&mut transport, &mut stations, || {
        stop.load(Ordering::Relaxed)
    })
    .map_err(|e| format!("the drives' transport failed: {e}"))
}

/// A child process that speaks in lines.
struct Peer {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: std::io::Lines<BufReader<ChildStdout>>,
    what: &'static str,
}

impl Peer {
    fn spawn(mut cmd: Command, what: &'static str) -> Result<Self, String> {
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("start {what}: {e}"))?;
        let stdin = child.stdin.take();
        let stdout = child.stdout.take().ok_or("no stdout")?;
        Ok(Self {
            child,
            stdin,
            lines: BufReader::new(stdout).lines(),
            what,
        })
    }

    /// Waits for a line equal to `word` (other lines are printed).
    fn expect(&mut self, word: &str) -> Result<(), String> {
        loop {
            match self.lines.next() {
                Some(Ok(l)) if l.trim() == word => return Ok(()),
                Some(Ok(l)) => println!("  {}: {l}", self.what),
                other => return Err(format!("{} ended before {word}: {other:?}", self.what)),
            }
        }
    }

    fn say(&mut self, line: &str) -> Result<(), String> {
        let stdin = self.stdin.as_mut().ok_or("stdin closed")?;
        writeln!(stdin, "{line}").map_err(|e| format!("tell {} {line}: {e}", self.what))
    }

    fn cpu_seconds(&self) -> f64 {
        proc_cpu_seconds(&format!("/proc/{}/stat", self.child.id()))
    }

    fn finish(mut self) {
        drop(self.stdin.take());
        let _ = self.child.wait();
    }
}

/// CPU seconds of a process (`/proc/PID/stat` utime + stime, all its threads).
fn proc_cpu_seconds(path: &str) -> f64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1;
            let f: Vec<&str> = rest.split_whitespace().collect();
            let ticks = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
            Some(ticks as f64 / 100.0)
        })
        .unwrap_or(0.0)
}

/// CPU seconds of this process's threads but the candump reader (`/proc/self/task/*/stat`).
fn own_cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .flatten()
        .filter(|t| {
            std::fs::read_to_string(t.path().join("comm"))
                .map_or(true, |c| c.trim() != READER_THREAD)
        })
        .map(|t| proc_cpu_seconds(&t.path().join("stat").to_string_lossy()))
        .sum()
}

/// Microseconds since the epoch on the clock candump's timestamps use.
fn wall_us() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as i64)
}

/// `candump -L` on the SYNC and the RPDO4 range, its lines parsed by a thread.
struct Receiver {
    child: Child,
    reader: Option<std::thread::JoinHandle<()>>,
    frames: Arc<Mutex<Vec<(i64, u16)>>>,
}

impl Receiver {
    /// Starts candump and waits until it shows a probe frame sent on `probe`.
    fn start(iface: &str, probe: &mut SocketCan) -> Result<Self, String> {
        let mut child = Command::new("candump")
            .arg("-L")
            .arg(format!("{iface},080:7FF,500:7F0"))
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("start candump: {e}"))?;
        let stdout = child.stdout.take().ok_or("candump: no stdout")?;
        let frames: Arc<Mutex<Vec<(i64, u16)>>> = Arc::default();
        let sink = frames.clone();
        let reader = std::thread::Builder::new()
            .name(READER_THREAD.into())
            .spawn(move || {
                for line in BufReader::new(stdout).lines() {
                    let Ok(line) = line else { break };
                    if let Some(f) = parse_candump(&line) {
                        sink.lock().unwrap_or_else(|p| p.into_inner()).push(f);
                    }
                }
            })
            .map_err(|e| format!("start the candump reader: {e}"))?;
        let mut me = Self {
            child,
            reader: Some(reader),
            frames,
        };
        let probe_frame = CanFrame::new(CanId::standard(PROBE_ID).map_err(|e| e.to_string())?, &[])
            .map_err(|e| e.to_string())?;
        let deadline = StdInstant::now() + StdDuration::from_secs(20);
        loop {
            probe
                .send(&probe_frame)
                .map_err(|e| format!("send the probe: {e}"))?;
            std::thread::sleep(StdDuration::from_millis(20));
            if me.lock().iter().any(|(_, id)| *id == PROBE_ID) {
                return Ok(me);
            }
            if StdInstant::now() > deadline {
                me.stop();
                return Err("candump showed no probe frame within 20 s".into());
            }
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(i64, u16)>> {
        self.frames.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Stops candump; returns what it received.
    fn stop(&mut self) -> Vec<(i64, u16)> {
        // candump is this program's own child, ended by its id.
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        std::mem::take(&mut *self.lock())
    }
}

/// `(1701590000.123456) vcan0 080#` → (microseconds, identifier).
fn parse_candump(line: &str) -> Option<(i64, u16)> {
    let (stamp, rest) = line.strip_prefix('(')?.split_once(')')?;
    let (secs, frac) = stamp.split_once('.')?;
    if frac.len() != 6 {
        return None;
    }
    let us = secs.parse::<i64>().ok()? * 1_000_000 + frac.parse::<i64>().ok()?;
    let frame = rest.split_whitespace().nth(1)?;
    let id = u16::from_str_radix(frame.split_once('#')?.0, 16).ok()?;
    Some((us, id))
}

/// What one side's window showed.
#[derive(Debug)]
struct Figures {
    syncs: usize,
    p50: i64,
    p99: i64,
    max: i64,
    min: i64,
    dev_p99: i64,
    dev_max: i64,
    cycles: usize,
    complete: usize,
    rpdos: (usize, usize),
    /// Frames the receiver got before one stamped earlier.
    reordered: usize,
    cpu_per_cycle_us: f64,
    /// `None`: the drives' process was not running.
    drives_cpu_per_cycle_us: Option<f64>,
}

fn percentile(sorted: &[i64], p: usize) -> i64 {
    sorted[(sorted.len() - 1) * p / 100]
}

/// The figures of the frames in `[from, to]` (microseconds).
fn figures(
    frames: &[(i64, u16)],
    window: (i64, i64),
    drives: u8,
    period_us: i64,
    (cpu, drives_cpu): (f64, Option<f64>),
) -> Result<Figures, String> {
    let mut inside: Vec<&(i64, u16)> = frames
        .iter()
        .filter(|(t, _)| (window.0..=window.1).contains(t))
        .collect();
    // The kernel stamps a vcan frame on the CPU that sent it and delivers it from that CPU's
    // input backlog: frames sent from two vCPUs can reach the receiver out of order. Their
    // stamps give the order they were sent in.
    let reordered = inside.windows(2).filter(|w| w[1].0 < w[0].0).count();
    inside.sort_by_key(|(t, _)| *t);
    let syncs: Vec<i64> = inside
        .iter()
        .filter(|(_, id)| *id == 0x080)
        .map(|(t, _)| *t)
        .collect();
    if syncs.len() < 100 {
        return Err(format!(
            "only {} SYNCs in the window of {} ms",
            syncs.len(),
            (window.1 - window.0) / 1000
        ));
    }
    let mut intervals: Vec<i64> = syncs.windows(2).map(|w| w[1] - w[0]).collect();
    let mut deviations: Vec<i64> = intervals.iter().map(|i| (i - period_us).abs()).collect();
    intervals.sort_unstable();
    deviations.sort_unstable();
    // RPDOs of the drives between two SYNCs.
    let drive_ids = 0x501..=0x500 + u16::from(drives);
    let mut per_cycle: Vec<Vec<u16>> = Vec::new();
    for (_, id) in &inside {
        if *id == 0x080 {
            per_cycle.push(Vec::new());
        } else if drive_ids.contains(id)
            && let Some(c) = per_cycle.last_mut()
        {
            c.push(*id);
        }
    }
    per_cycle.pop(); // the last one is cut by the window
    let complete = per_cycle
        .iter()
        .filter(|c| {
            let mut ids = (*c).clone();
            ids.sort_unstable();
            ids.iter().copied().eq(drive_ids.clone())
        })
        .count();
    let counts = per_cycle.iter().map(Vec::len);
    let rpdos = (counts.clone().min().unwrap_or(0), counts.max().unwrap_or(0));
    Ok(Figures {
        syncs: syncs.len(),
        p50: percentile(&intervals, 50),
        p99: percentile(&intervals, 99),
        max: *intervals.last().unwrap_or(&0),
        min: *intervals.first().unwrap_or(&0),
        dev_p99: percentile(&deviations, 99),
        dev_max: *deviations.last().unwrap_or(&0),
        cycles: per_cycle.len(),
        complete,
        rpdos,
        reordered,
        cpu_per_cycle_us: cpu * 1e6 / syncs.len() as f64,
        drives_cpu_per_cycle_us: drives_cpu.map(|c| c * 1e6 / syncs.len() as f64),
    })
}

fn node(n: u8) -> Result<NodeId, String> {
    NodeId::new(n).map_err(|e| e.to_string())
}

/// This master's run: its figures and the drives' last targets.
fn run_canola(
    args: &Args,
    sim: &mut Option<Peer>,
    precise: bool,
    probe: &mut SocketCan,
) -> Result<(Figures, Vec<i32>), String> {
    let t = SocketCan::open(&args.iface)
        .map_err(|e| format!("open {}: {e}", args.iface))?
        .with_precise_waits(precise);
    let net = Network::new(t);
    net.start_driver().map_err(|e| e.to_string())?;
    let period = Duration::from_micros(args.period_us);
    let mut drives = Vec::new();
    for n in 1..=args.drives {
        let d = Drive::new(net.node(node(n)?));
        // TPDO2..4 (on every SYNC) off: the bus carries the SYNC and the RPDOs.
        for (tpdo, base) in [(0x1801u16, 0x280u32), (0x1802, 0x380), (0x1803, 0x480)] {
            d.node()
                .sdo()
                .write((tpdo, 1u8), 0x8000_0000 | (base + u32::from(n)))
                .wait()
                .map_err(|e| format!("node {n}: TPDO off: {e}"))?;
        }
        drives.push(d);
    }
    net.nmt_all(CommandSpecifier::Start)
        .map_err(|e| e.to_string())?;
    for d in &drives {
        d.enable()
            .wait()
            .map_err(|e| format!("node {}: enable: {e}", d.node().id()))?;
    }
    // The streams are set up before the SYNC starts: under emulation the drives' process
    // answers SDO requests late while it takes 9 000 frames a second.
    let streams: Vec<CyclicStream> = drives
        .iter()
        .map(|d| {
            d.start_cyclic(ModeOfOperation::CyclicSyncPosition, TARGET_RPDO, period)
                .wait()
        })
        .collect::<Result<_, _>>()
        .map_err(|e| format!("start_cyclic: {e}"))?;
    let starts: Vec<i32> = drives
        .iter()
        .map(|d| d.position().wait())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("position: {e}"))?;
    net.start_sync(period);
    println!(
        "canola ({} waits): {} drives enabled, csp streams on RPDO{TARGET_RPDO}, SYNC every {} µs",
        if precise { "precise" } else { "default" },
        drives.len(),
        args.period_us
    );
    if !args.keep_drives
        && let Some(p) = sim.take()
    {
        p.finish();
        println!("the drives' process stopped after the set-up (--keep-drives keeps it)");
    }
    let sim = sim.as_ref();
    let mut rx = Receiver::start(&args.iface, probe)?;
    // The application: a new target for every drive about once a period.
    let stop = AtomicBool::new(false);
    let period_std = StdDuration::from_micros(args.period_us);
    let result = std::thread::scope(|s| {
        let app = s.spawn(|| -> Result<i32, String> {
            let mut k = 0i32;
            while !stop.load(Ordering::Relaxed) {
                if args.hold {
                    std::thread::sleep(StdDuration::from_millis(10));
                    continue;
                }
                k = k.wrapping_add(1);
                for (stream, start) in streams.iter().zip(&starts) {
                    stream
                        .set_target(start.wrapping_add(k % 20_000))
                        .map_err(|e| format!("set_target: {e}"))?;
                }
                std::thread::sleep(period_std);
            }
            Ok(k % 20_000)
        });
        std::thread::sleep(StdDuration::from_secs_f64(args.warmup));
        let from = wall_us();
        let cpu0 = (own_cpu_seconds(), sim.map(Peer::cpu_seconds));
        std::thread::sleep(StdDuration::from_secs_f64(args.seconds));
        let cpu = (
            own_cpu_seconds() - cpu0.0,
            sim.map(Peer::cpu_seconds).zip(cpu0.1).map(|(b, a)| b - a),
        );
        let to = wall_us();
        stop.store(true, Ordering::Relaxed);
        let app = app.join().map_err(|_| "the application thread panicked")?;
        app.map(|k| ((from, to), cpu, k))
    });
    let frames = rx.stop();
    net.stop_sync();
    for s in streams {
        s.stop().map_err(|e| e.to_string())?;
    }
    if !net.is_driven() {
        return Err("the background driver stopped".into());
    }
    let (window, cpu, k) = result?;
    let last = starts.iter().map(|s| s.wrapping_add(k)).collect();
    Ok((
        figures(&frames, window, args.drives, args.period_us as i64, cpu)?,
        last,
    ))
}

/// python-canopen's run, sending `targets` (the drives hold them: no jump).
fn run_python(
    args: &Args,
    sim: Option<&Peer>,
    python: &str,
    targets: &[i32],
    probe: &mut SocketCan,
) -> Result<Figures, String> {
    let mut cmd = Command::new(python);
    cmd.arg("crates/bench/py/sync_rpdo_bench.py")
        .args(["--iface", &args.iface])
        .args(["--drives", &args.drives.to_string()])
        .args(["--period", &format!("{}", args.period_us as f64 / 1e6)])
        .args(["--eds", "eds/cia402-servo.eds"])
        .arg("--targets")
        .arg(
            targets
                .iter()
                .map(i32::to_string)
                .collect::<Vec<_>>()
                .join(","),
        );
    let mut py = Peer::spawn(cmd, "python-canopen")?;
    py.expect("READY")?;
    let mut rx = Receiver::start(&args.iface, probe)?;
    py.say("start")?;
    py.expect("STARTED")?;
    std::thread::sleep(StdDuration::from_secs_f64(args.warmup));
    let from = wall_us();
    let cpu0 = (py.cpu_seconds(), sim.map(Peer::cpu_seconds));
    std::thread::sleep(StdDuration::from_secs_f64(args.seconds));
    let cpu = (
        py.cpu_seconds() - cpu0.0,
        sim.map(Peer::cpu_seconds).zip(cpu0.1).map(|(b, a)| b - a),
    );
    let to = wall_us();
    py.say("stop")?;
    py.expect("STOPPED")?;
    py.finish();
    let frames = rx.stop();
    figures(&frames, (from, to), args.drives, args.period_us as i64, cpu)
}

fn print_table(period_us: u64, rows: &[(&str, &Figures)]) {
    println!();
    println!(
        "SYNC intervals on the receiver (kernel timestamps, µs; period {period_us} µs), RPDOs per cycle, sender CPU:"
    );
    println!(
        "| sender | SYNCs | p50 | p99 | max | min | p99 |Δ| | max |Δ| | cycles with every RPDO | RPDOs per cycle | received out of order | sender CPU per cycle | drives' CPU per cycle |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, f) in rows {
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} of {} | {}..{} | {} | {:.0} µs | {} |",
            f.syncs,
            f.p50,
            f.p99,
            f.max,
            f.min,
            f.dev_p99,
            f.dev_max,
            f.complete,
            f.cycles,
            f.rpdos.0,
            f.rpdos.1,
            f.reordered,
            f.cpu_per_cycle_us,
            f.drives_cpu_per_cycle_us
                .map_or("stopped".into(), |c| format!("{c:.0} µs"))
        );
    }
}

/// Starts the simulated drives' process and waits until it serves.
fn spawn_drives(args: &Args) -> Result<Peer, String> {
    let exe = std::env::current_exe().map_err(|e| format!("where is this program: {e}"))?;
    let mut cmd = Command::new(exe);
    cmd.arg("--serve")
        .args(["--iface", &args.iface])
        .args(["--drives", &args.drives.to_string()]);
    let mut sim = Peer::spawn(cmd, "drives")?;
    sim.expect("READY")?;
    Ok(sim)
}

fn run(args: &Args) -> Result<(), String> {
    let mut probe =
        SocketCan::open(&args.iface).map_err(|e| format!("open {}: {e}", args.iface))?;
    println!(
        "{} simulated drives; window {} s after {} s of warm-up per run",
        args.drives, args.seconds, args.warmup
    );
    // This master twice, each with drives of its own: the transport's default waits, then
    // precise waits.
    let mut sim = None;
    let mut canola = Vec::new();
    let mut targets = vec![0; usize::from(args.drives)];
    for precise in [false, true] {
        if let Some(s) = sim.take() {
            Peer::finish(s);
        }
        sim = Some(spawn_drives(args)?);
        let (figures, last) = run_canola(args, &mut sim, precise, &mut probe)
            .map_err(|e| format!("canola (precise waits {precise}): {e}"))?;
        canola.push(figures);
        targets = last;
    }
    let python = match (&args.python, args.no_python) {
        (_, true) => None,
        (Some(p), false) => Some(run_python(args, sim.as_ref(), p, &targets, &mut probe)),
        (None, false) => Some(Err(
            "no python: pass --python PATH or set CANOPEN_PYTHON (or --no-python)".into(),
        )),
    };
    if let Some(s) = sim {
        s.finish();
    }
    let python = python
        .transpose()
        .map_err(|e| format!("python-canopen: {e}"))?;
    let mut rows = vec![
        ("canola, driver thread, default waits", &canola[0]),
        ("canola, driver thread, precise waits", &canola[1]),
    ];
    if let Some(p) = &python {
        rows.push(("python-canopen 2.4.1 (CAN_BCM timers)", p));
    }
    print_table(args.period_us, &rows);
    let line = |f: &Figures| format!("p50 {} p99 {} max {}", f.p50, f.p99, f.max);
    let mut summary = format!(
        "vcan_drives: canola {} | canola precise {}",
        line(&canola[0]),
        line(&canola[1])
    );
    if let Some(p) = &python {
        summary += &format!(" | python-canopen {}", line(p));
    }
    println!("{summary} (µs)");
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("vcan_drives: {e}");
            return ExitCode::from(2);
        }
    };
    let result = if args.serve { serve(&args) } else { run(&args) };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vcan_drives: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_lines_give_stamp_and_identifier() {
        assert_eq!(
            parse_candump("(1701590000.123456) vcan0 080#"),
            Some((1_701_590_000_123_456, 0x080))
        );
        assert_eq!(
            parse_candump("(1701590000.000010) vcan0 505#E8030000"),
            Some((1_701_590_000_000_010, 0x505))
        );
        assert_eq!(parse_candump("(1701590000.12345) vcan0 080#"), None);
        assert_eq!(parse_candump("garbage"), None);
        assert_eq!(parse_candump("(1.000000) vcan0 XYZ#00"), None);
    }

    /// SYNCs every 1000 µs but one 1500 µs late, two drives' RPDOs after each SYNC except in
    /// one cycle that misses drive 2; one frame delivered out of its stamp's order.
    #[test]
    fn figures_sort_by_stamp_and_count_complete_cycles() {
        let mut frames = Vec::new();
        let mut t = 0i64;
        for k in 0..200 {
            t += if k == 100 { 1500 } else { 1000 };
            frames.push((t, 0x080));
            frames.push((t + 100, 0x501));
            if k != 50 {
                frames.push((t + 200, 0x502));
            }
        }
        frames.swap(10, 11); // received out of order
        let f = figures(&frames, (0, t + 300), 2, 1000, (0.2, None)).unwrap();
        assert_eq!(f.syncs, 200);
        assert_eq!((f.p50, f.max, f.min), (1000, 1500, 1000));
        assert_eq!((f.dev_max, f.reordered), (500, 1));
        // 199 cycles between SYNCs; the one of k = 50 lacks drive 2.
        assert_eq!((f.cycles, f.complete, f.rpdos), (199, 198, (1, 2)));
        assert!((f.cpu_per_cycle_us - 1000.0).abs() < 1e-9);
        // Too few SYNCs is an error, not figures.
        assert!(figures(&frames[..30], (0, t), 2, 1000, (0.0, None)).is_err());
    }
}
