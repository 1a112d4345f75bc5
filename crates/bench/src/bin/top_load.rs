//! The cost of `canopen top` at full bus load: `--nodes N` simulated load devices (default 64,
//! the soak's traffic: two 8-byte synchronous TPDOs per node per SYNC at the SYNC period that
//! loads the bus to 95 %) on an in-memory bus on the host's clock (1 Mbit/s timing model), a
//! master `Network` on the view's tap, and the view's model and drawing (the CLI's own
//! `top/{tap,model,view,keys}.rs`, compiled in here) at `--fps` draws a second into a ratatui
//! test backend of `--size WxH` (default 120x40), for `--seconds` of real time.
//!
//! ```text
//! cargo run --release -p canola-bench --bin top_load -- --nodes 64 --seconds 30 [--fps 10]
//!     [--size 120x40] [--bitrate 1000000] [--no-view]
//! ```
//!
//! Prints the frames on the wire, the frames the model counted, the copies the tap had no room
//! for and the receive-queue overflows (lost = wire − counted, must be 0), the draws made, and
//! CPU as a share of one core: the whole process (`getrusage`: bus service thread, 64
//! simulators, master driver and the view) and the view's thread alone
//! (`CLOCK_THREAD_CPUTIME_ID`: taking the queued frames into the model and drawing).
//! `--no-view` drains the queue without model or drawing, for the process's cost without the
//! view. Exits 1 when a frame was lost.

use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration as StdDuration, Instant as StdInstant};

use canola::{BusConfig, ClockMode, MemoryBus, Network, NodeId};
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
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        nodes: 64,
        seconds: 30.0,
        fps: 10,
        size: (120, 40),
        bitrate: 1_000_000,
        view: true,
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
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !(1..=127).contains(&a.nodes) || a.fps == 0 || !(a.seconds.is_finite() && a.seconds > 0.0) {
        return Err("--nodes 1..=127, --fps and --seconds above 0".into());
    }
    Ok(a)
}

/// CPU seconds of the whole process, user and system.
fn process_cpu_seconds() -> f64 {
    use nix::sys::resource::{UsageWho, getrusage};
    getrusage(UsageWho::RUSAGE_SELF).map_or(0.0, |u| {
        let t = |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 / 1e6;
        t(u.user_time()) + t(u.system_time())
    })
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
    let (endpoint, rx, stats) = top::tap::tap(bus.endpoint());
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
         load), {} s real time, view {} at {} draws/s, {}x{}",
        a.nodes,
        period.as_micros(),
        a.bitrate,
        a.seconds,
        if a.view { "on" } else { "off" },
        a.fps,
        a.size.0,
        a.size.1
    );
    let mut terminal = Terminal::new(TestBackend::new(a.size.0, a.size.1)).expect("test backend");
    let mode = top::keys::Mode::Normal;
    let cpu0 = process_cpu_seconds();
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
            model.tick(net.now());
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
    let _ = net.stop_driver();
    if lost != 0 || lost_copies != 0 || overflowed != 0 {
        eprintln!("top_load: frames were lost");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
