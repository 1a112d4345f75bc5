//! The cost of `canopen top` at full bus load: `--nodes N` simulated load devices (default 64,
//! the soak's traffic: two 8-byte synchronous TPDOs per node per SYNC at the SYNC period that
//! loads the bus to 95 %) on an in-memory bus on the host's clock (1 Mbit/s timing model), a
//! master `Network` on the view's tap, and the view's model and drawing (the CLI's own
//! `top/{tap,model,view,keys}.rs`, compiled in here) at `--fps` draws a second into a ratatui
//! test backend of `--size WxH` (default 120x40), for `--seconds` of real time.
//!
//! ```text
//! cargo run --release -p canola-bench --bin top_load -- --nodes 64 --seconds 30 [--fps 10]
//!     [--size 120x40] [--bitrate 1000000] [--no-view | --bare] [--no-coalescing]
//! ```
//!
//! Prints the frames on the wire, the frames the model counted, the copies the tap had no room
//! for and the receive-queue overflows (lost = wire − counted, must be 0), the draws made, and
//! CPU as a share of one core: the whole process (`getrusage`: bus service thread, 64
//! simulators, master driver and the view) and the view's thread alone
//! (`CLOCK_THREAD_CPUTIME_ID`: taking the queued frames into the model and drawing).
//! The CPU of each thread by name splits that into the bus and simulators, the master's driver
//! thread (with the tap) and the view. `--no-view` drains the queue without model or drawing;
//! `--bare` replaces master, tap and view by a plain endpoint that sends the SYNCs and receives
//! every frame on a thread of its own: the cost of receiving this bus in real time at all, the
//! floor under the master's. Both receive with the wake-up coalescing the view's tap sets
//! (`tap::RX_COALESCING`); `--no-coalescing` turns it off (one wake-up per frame, as before
//! it). Exits 1 when a frame was lost.

use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration as StdDuration, Instant as StdInstant};

use canola::{BusConfig, ClockMode, MemoryBus, Network, NodeId, RxCoalescing, Transport as _};
use canola_bench::load::{self, LoadNode};
use canola_bench::thread_cpu_seconds;
use canola_frame::Duration;
use ratatui::Terminal;
use ratatui::backend::TestBackend;

// The view's files, as the CLI builds them (they refer to each other as `super::...`: here
// the crate root).
#[allow(dead_code)]
#[path = "../../../cli/src/top/keys.rs"]
mod keys;
#[allow(dead_code)]
#[path = "../../../cli/src/top/model.rs"]
mod model;
#[allow(dead_code)]
#[path = "../../../cli/src/top/tap.rs"]
mod tap;
#[allow(dead_code)]
#[path = "../../../cli/src/top/view.rs"]
mod view;

/// The view's modules under one name.
mod top {
    pub(crate) use super::{keys, model, tap, view};
}

struct Args {
    nodes: u8,
    seconds: f64,
    fps: u32,
    size: (u16, u16),
    bitrate: u32,
    view: bool,
    bare: bool,
    coalescing: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        nodes: 64,
        seconds: 30.0,
        fps: 10,
        size: (120, 40),
        bitrate: 1_000_000,
        view: true,
        bare: false,
        coalescing: true,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value"));
        let bad = |e: &dyn std::fmt::Display| format!("{arg}: {e}");
        match arg.as_str() {
            "--nodes" => a.nodes = value()?.parse().map_err(|e| bad(&e))?,
            "--seconds" => a.seconds = value()?.parse().map_err(|e| bad(&e))?,
            "--fps" => a.fps = value()?.parse().map_err(|e| bad(&e))?,
            "--bitrate" => a.bitrate = value()?.parse().map_err(|e| bad(&e))?,
            "--size" => {
                let v = value()?;
                let (w, h) = v.split_once('x').ok_or(bad(&"give WxH"))?;
                a.size = (
                    w.parse().map_err(|e| bad(&e))?,
                    h.parse().map_err(|e| bad(&e))?,
                );
            }
            "--no-view" => a.view = false,
            "--bare" => a.bare = true,
            "--no-coalescing" => a.coalescing = false,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !(1..=127).contains(&a.nodes) || a.fps == 0 || !(a.seconds.is_finite() && a.seconds > 0.0) {
        return Err("--nodes 1..=127, --fps and --seconds above 0".into());
    }
    Ok(a)
}

/// `--bare`: the same bus and devices with a plain endpoint on a thread of its own in place of
/// master, tap and view: it sends the SYNCs and receives every frame, as any program receiving
/// this bus in real time must. Its CPU share is the floor under the master's.
fn bare(a: &Args, period: Duration) -> ExitCode {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        bitrate: Some(a.bitrate),
        ..BusConfig::default()
    });
    let od = load::load_dictionary();
    for n in 1..=a.nodes {
        bus.attach(LoadNode::new(NodeId::new(n).expect("1..=127"), od.clone()));
    }
    let mut ep = bus.endpoint();
    if a.coalescing {
        ep.set_rx_coalescing(coalescing());
    }
    let (seconds, coalesce) = (a.seconds, a.coalescing);
    let receiver = std::thread::Builder::new()
        .name("receiver".into())
        .spawn(move || -> Result<(u64, f64), canola::TransportError> {
            let id = |raw| canola::CanId::standard(raw).expect("valid identifier");
            ep.send(&canola::CanFrame::new(id(0x000), &[0x01, 0x00]).expect("valid"))?;
            let sync = canola::CanFrame::new(id(0x080), &[]).expect("valid");
            let start = ep.now();
            let end = start + Duration::from_micros((seconds * 1e6) as u64);
            let cpu0 = thread_cpu_seconds();
            let (mut next, mut frames) = (start, 0u64);
            loop {
                let now = ep.now();
                if now >= end {
                    break;
                }
                if now >= next {
                    ep.send(&sync)?;
                    frames += 1;
                    next += period;
                }
                if ep.recv_until(next.min(end))?.is_some() {
                    frames += 1;
                }
            }
            Ok((frames, thread_cpu_seconds() - cpu0))
        })
        .expect("a thread");
    match receiver.join() {
        Ok(Ok((frames, cpu))) => {
            println!(
                "bare receiver (receive coalescing {}): {frames} frames in {seconds} s, its \
                 thread {:.1} % of a core ({:.1} us per frame)",
                if coalesce { "on" } else { "off" },
                cpu * 100.0 / seconds,
                cpu * 1e6 / frames.max(1) as f64
            );
            ExitCode::SUCCESS
        }
        Ok(Err(e)) => {
            eprintln!("top_load: {e}");
            ExitCode::FAILURE
        }
        Err(_) => ExitCode::FAILURE,
    }
}

/// The receive coalescing the view's tap sets.
fn coalescing() -> RxCoalescing {
    RxCoalescing::new(top::tap::RX_COALESCING)
}

/// CPU seconds of the whole process, user and system.
fn process_cpu_seconds() -> f64 {
    use nix::sys::resource::{UsageWho, getrusage};
    getrusage(UsageWho::RUSAGE_SELF).map_or(0.0, |u| {
        let t = |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 / 1e6;
        t(u.user_time()) + t(u.system_time())
    })
}

/// CPU seconds of each thread of this process by name (`/proc/self/task/*/stat`, Linux; the
/// kernel counts in USER_HZ, 100 a second): `memory-bus` steps the bus and the simulators,
/// `canopen-driver` is the master, `top_load` the view.
fn thread_cpu_by_name() -> std::collections::BTreeMap<String, f64> {
    let mut out = std::collections::BTreeMap::new();
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return out;
    };
    for t in tasks.flatten() {
        let Ok(stat) = std::fs::read_to_string(t.path().join("stat")) else {
            continue;
        };
        let (Some(open), Some(close)) = (stat.find('('), stat.rfind(')')) else {
            continue;
        };
        let name = stat[open + 1..close].to_owned();
        // After the name: state is field 3; utime and stime are fields 14 and 15.
        let fields: Vec<&str> = stat[close + 1..].split_whitespace().collect();
        let ticks = |i: usize| fields.get(i - 3).and_then(|f| f.parse::<f64>().ok());
        if let (Some(u), Some(s)) = (ticks(14), ticks(15)) {
            *out.entry(name).or_insert(0.0) += (u + s) / 100.0;
        }
    }
    out
}

fn main() -> ExitCode {
    let a = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("top_load: {e}");
            return ExitCode::from(2);
        }
    };
    let period = load::sync_period_for(a.nodes, a.bitrate, false, 0.95);
    if a.bare {
        return bare(&a, period);
    }
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        bitrate: Some(a.bitrate),
        ..BusConfig::default()
    });
    let od = load::load_dictionary();
    let master_od = load::master_dictionary();
    let nodes: Vec<NodeId> = (1..=a.nodes)
        .map(|n| NodeId::new(n).expect("1..=127"))
        .collect();
    for n in &nodes {
        bus.attach(LoadNode::new(*n, od.clone()));
    }
    let (mut endpoint, rx, stats) = top::tap::tap(bus.endpoint());
    if !a.coalescing {
        endpoint.set_rx_coalescing(RxCoalescing::OFF);
    }
    let net = Network::new(endpoint);
    let dictionaries: Vec<_> = nodes.iter().map(|n| (*n, master_od.clone())).collect();
    for (n, od) in &dictionaries {
        net.add_node_with_dictionary(*n, od.clone());
    }
    if let Err(e) = net.start_driver() {
        eprintln!("top_load: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = net.nmt_all(canola::CommandSpecifier::Start) {
        eprintln!("top_load: {e}");
        return ExitCode::FAILURE;
    }
    std::thread::sleep(StdDuration::from_millis(200));
    let mut model = top::model::Model::new(&dictionaries, a.bitrate);
    for seen in rx.try_iter() {
        model.ingest(&seen);
    }
    let counted0 = model.bus.frames;
    let wire0 = bus.stats().frames;
    println!(
        "top_load: {} nodes, 2 x 8-byte TPDOs each per SYNC, SYNC period {} us ({} bit/s, 95 % \
         load), {} s real time, view {} at {} draws/s, {}x{}, receive coalescing {}",
        a.nodes,
        period.as_micros(),
        a.bitrate,
        a.seconds,
        if a.view { "on" } else { "off" },
        a.fps,
        a.size.0,
        a.size.1,
        if a.coalescing {
            format!("{} ms", top::tap::RX_COALESCING.as_millis())
        } else {
            "off".into()
        }
    );
    let mut terminal = Terminal::new(TestBackend::new(a.size.0, a.size.1)).expect("test backend");
    let mode = top::keys::Mode::Normal;
    let cpu0 = process_cpu_seconds();
    let threads0 = thread_cpu_by_name();
    let view0 = thread_cpu_seconds();
    let wall0 = StdInstant::now();
    net.start_sync(Duration::from_micros(period.as_micros()));
    let frame_period = StdDuration::from_secs(1) / a.fps;
    let end = wall0 + StdDuration::from_secs_f64(a.seconds);
    let mut next = wall0;
    let (mut draws, mut drained, mut peak_fps, mut peak_load) = (0u64, 0u64, 0u64, 0f64);
    let mut take = |model: &mut top::model::Model, view: bool| {
        for seen in rx.try_iter() {
            drained += 1;
            if view {
                model.ingest(&seen);
            }
        }
    };
    while StdInstant::now() < end {
        take(&mut model, a.view);
        if a.view {
            model.tick(stats.now().unwrap_or_else(|| net.now()));
            peak_fps = peak_fps.max(model.bus.fps);
            peak_load = peak_load.max(model.bus.load);
            let screen = top::view::Screen {
                title: "in-memory bus, load devices",
                selected: nodes.first().copied(),
                filter: "",
                mode: &mode,
                status: "",
                paused: false,
                color: true,
                lost: stats.lost.load(Ordering::Relaxed),
                replay: None,
            };
            if let Err(e) = terminal.draw(|f| top::view::draw(f, &model, &screen)) {
                eprintln!("top_load: draw: {e}");
                return ExitCode::FAILURE;
            }
            draws += 1;
        }
        next += frame_period;
        let now = StdInstant::now();
        if next < now {
            next = now + frame_period;
        }
        std::thread::sleep(next.saturating_duration_since(now));
    }
    let view_cpu = thread_cpu_seconds() - view0;
    let cpu = process_cpu_seconds() - cpu0;
    let threads1 = thread_cpu_by_name();
    let wall = wall0.elapsed().as_secs_f64();
    net.stop_sync();
    std::thread::sleep(StdDuration::from_millis(300));
    take(&mut model, a.view);
    let wire = bus.stats().frames - wire0;
    let lost_copies = stats.lost.load(Ordering::Relaxed);
    let counted = if a.view {
        model.bus.frames - counted0
    } else {
        drained
    };
    let overflowed = model.bus.overflowed;
    let lost = wire as i64 - counted as i64;
    println!(
        "frames on the wire {wire} ({:.0}/s), counted by the view {counted}, lost {lost} \
         (tap queue full {lost_copies}, receive queue overflows {overflowed})",
        wire as f64 / wall
    );
    if a.view {
        println!(
            "view: {draws} draws ({:.1}/s), peak {peak_fps} frames/s and {peak_load:.1} % load \
             shown",
            draws as f64 / wall
        );
    }
    println!(
        "CPU: process {:.1} % of a core (bus, {} simulators, master, view), view thread {:.1} % \
         of a core ({:.1} s wall)",
        cpu * 100.0 / wall,
        a.nodes,
        view_cpu * 100.0 / wall,
        wall
    );
    let share = |name: &str| {
        let t =
            threads1.get(name).copied().unwrap_or(0.0) - threads0.get(name).copied().unwrap_or(0.0);
        t * 100.0 / wall
    };
    let (bus_share, master_share) = (share("memory-bus"), share("canopen-driver"));
    println!(
        "CPU by thread: bus and simulators {bus_share:.1} %, master (driver thread, tap) \
         {master_share:.1} %, view {:.1} %; master and view together {:.1} % of a core",
        view_cpu * 100.0 / wall,
        master_share + view_cpu * 100.0 / wall
    );
    let _ = net.stop_driver();
    if lost != 0 || lost_copies != 0 || overflowed != 0 {
        eprintln!("top_load: frames were lost");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
