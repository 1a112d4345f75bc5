//! Full bus load and soak on the in-memory bus (bus time on the virtual clock, 1 Mbit/s timing
//! model): `--nodes N` simulated nodes (default 64), each sending two 8-byte synchronous TPDOs
//! with a sequence counter per SYNC, at the SYNC period that loads the bus to `--load` (default
//! 0.95); the master (`canola::Network`) decodes them through each node's dictionary and its
//! subscriber checks every counter. See `canola_bench::load`.
//!
//! ```text
//! cargo run --release -p canola-bench --bin soak -- --nodes 64 --seconds 60 [--sdo]
//!     [--sdo-max BYTES] [--sdo-timeout-ms MS] [--load SHARE] [--stuffing] [--seed N] [--sample-ms MS]
//! ```
//!
//! `--sdo` adds SDO traffic to every node at once: each node in turn downloads a DOMAIN of
//! random size (1..=`--sdo-max`, default 256 bytes; expedited, segmented or block at random)
//! and uploads it back (segmented or block), the upload checked against what was written; the
//! response timeout is `--sdo-timeout-ms` (default 5000: SDO frames lose arbitration to every
//! PDO, and 64 clients at once share what the PDOs leave of the bus).
//!
//! Memory: the resident set size and the bytes allocated and not freed (this binary's counting
//! global allocator, `stats_alloc`) are sampled every `--sample-ms` of bus time (default 1000),
//! and the least-squares slope of both is printed. CPU: the driving thread's CPU time
//! (`CLOCK_THREAD_CPUTIME_ID`), which runs bus, simulators, master and subscriber; a second run
//! with the same devices and a bare endpoint in place of the master gives the bus and
//! simulators alone, and the difference per received frame is the master's share
//! (`cpu_per_frame`; with `--sdo` it includes the SDO work).
//!
//! Ends with the line
//! `soak: frames F, lost L, reordered R, rss_start S KiB, rss_end E KiB, cpu_per_frame C ns`;
//! exits 1 when a PDO was lost, reordered or decoded wrongly, an upload returned wrong data, or
//! a table with an entry per node, channel, request or subscriber (the master's, see
//! `canola::Occupancy`, and the subscriber's counters) reached a larger size in the second half
//! of the run than in the first.

use std::alloc::System;
use std::process::ExitCode;

use canola_bench::load::{self, LoadConfig, peak_rss_kib, slope};
use canola_frame::Duration;
use stats_alloc::{INSTRUMENTED_SYSTEM, StatsAlloc};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn live_bytes() -> Option<u64> {
    // `stats_alloc` already counts a reallocation's growth in `bytes_allocated` and its
    // shrinking in `bytes_deallocated`; `bytes_reallocated` is the same net change once more,
    // so adding it would count every grown-then-freed buffer as live.
    let s = GLOBAL.stats();
    Some(s.bytes_allocated.saturating_sub(s.bytes_deallocated) as u64)
}

struct Args {
    nodes: u8,
    seconds: f64,
    sdo: bool,
    sdo_max: usize,
    sdo_timeout_ms: u64,
    load: f64,
    stuffing: bool,
    seed: u64,
    sample_ms: u64,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        nodes: 64,
        seconds: 10.0,
        sdo: false,
        sdo_max: 256,
        sdo_timeout_ms: 5000,
        load: 0.95,
        stuffing: false,
        seed: 1,
        sample_ms: 1000,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value"));
        let bad = |e: &dyn std::fmt::Display| format!("{arg}: {e}");
        match arg.as_str() {
            "--nodes" => a.nodes = value()?.parse().map_err(|e| bad(&e))?,
            "--seconds" => a.seconds = value()?.parse().map_err(|e| bad(&e))?,
            "--sdo" => a.sdo = true,
            "--sdo-max" => a.sdo_max = value()?.parse().map_err(|e| bad(&e))?,
            "--sdo-timeout-ms" => a.sdo_timeout_ms = value()?.parse().map_err(|e| bad(&e))?,
            "--load" => a.load = value()?.parse().map_err(|e| bad(&e))?,
            "--stuffing" => a.stuffing = true,
            "--seed" => a.seed = value()?.parse().map_err(|e| bad(&e))?,
            "--sample-ms" => a.sample_ms = value()?.parse().map_err(|e| bad(&e))?,
            "--bench" => {} // passed by `cargo bench`
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !(1..=127).contains(&a.nodes) {
        return Err("--nodes takes 1..=127".into());
    }
    if !(a.load > 0.0 && a.load <= 1.0) {
        return Err("--load takes a share in (0, 1]".into());
    }
    Ok(a)
}

fn main() -> ExitCode {
    let a = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("soak: {e}");
            return ExitCode::from(2);
        }
    };
    let bus_time = Duration::from_micros((a.seconds * 1e6) as u64);
    let mut config = LoadConfig::full_load(a.nodes, bus_time);
    config.worst_case_stuffing = a.stuffing;
    config.sync_period = load::sync_period_for(a.nodes, config.bitrate, a.stuffing, a.load);
    config.sdo = a.sdo;
    config.sdo_max_len = a.sdo_max.max(1);
    config.sdo_timeout = Duration::from_millis(a.sdo_timeout_ms);
    config.seed = a.seed;
    config.sample_every = Duration::from_millis(a.sample_ms.max(1));
    println!(
        "soak: {} nodes, 2 x 8-byte TPDOs each per SYNC, SYNC period {} us, {} bit/s ({}), \
         {:.0} s of bus time{}",
        a.nodes,
        config.sync_period.as_micros(),
        config.bitrate,
        if a.stuffing {
            "worst-case stuff bits"
        } else {
            "no stuff bits"
        },
        a.seconds,
        if a.sdo {
            format!(", SDO traffic to every node (1..={} bytes)", a.sdo_max)
        } else {
            String::new()
        }
    );
    let wall = std::time::Instant::now();
    let r = match load::run(&config, &live_bytes) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("soak: the master failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    let wall = wall.elapsed().as_secs_f64();
    let mut base_config = config.clone();
    base_config.sdo = false;
    let (base_frames, base_cpu) = match load::baseline(&base_config) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("soak: the baseline run failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    let frames = r.frames.max(1) as f64;
    let total_ns = r.cpu_seconds * 1e9 / frames;
    let base_ns = base_cpu * 1e9 / base_frames.max(1) as f64;
    let master_ns = (total_ns - base_ns).max(0.0);
    println!(
        "SYNCs {}, PDOs sent {}, received {}, lost {}, reordered {}, counter gaps {}, \
         wrong values {}",
        r.syncs, r.sent, r.frames, r.lost, r.reordered, r.gaps, r.bad_values
    );
    println!(
        "bus: {} frames, load {:.2} % (wire busy / bus time)",
        r.bus_frames,
        r.bus_load * 100.0
    );
    println!(
        "CPU per received PDO: {total_ns:.0} ns in all (bus + {} simulators + master + \
         subscriber), {base_ns:.0} ns bus and simulators alone, master {master_ns:.0} ns; \
         {wall:.1} s wall for {:.0} s of bus time",
        a.nodes, a.seconds
    );
    if let Some(s) = &r.sdo {
        println!(
            "SDO: {} downloads and {} uploads checked, {} bytes, wrong data {}",
            s.writes_ok, s.reads_ok, s.bytes, s.wrong_data
        );
        for (text, n) in &s.errors {
            println!("  {n} x {text}");
        }
    }
    let rss: Vec<(f64, f64)> = r
        .samples
        .iter()
        .map(|s| (s.bus_seconds, s.rss_kib as f64))
        .collect();
    let live: Vec<(f64, f64)> = r
        .samples
        .iter()
        .filter_map(|s| Some((s.bus_seconds, s.live_bytes? as f64)))
        .collect();
    // The first samples include the warm-up (queues and tables reaching their working size):
    // the slope is fitted over the second half of the run.
    let half = |v: &[(f64, f64)]| v[v.len() / 2..].to_vec();
    let (min_live, max_live) = live
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    println!(
        "memory: {} samples; live heap {:.0}..{:.0} bytes, slope {:.3} bytes/s over the second \
         half ({:.3} over all); RSS slope {:.4} KiB/s (second half); peak RSS {} KiB",
        r.samples.len(),
        min_live,
        max_live,
        slope(&half(&live)),
        slope(&live),
        slope(&half(&rss)),
        peak_rss_kib()
    );
    // Bytes per hour of bus time, the figure a long soak is judged by.
    println!(
        "memory slope: live heap {:.0} bytes/hour, RSS {:.0} KiB/hour (bus time, second half)",
        slope(&half(&live)) * 3600.0,
        slope(&half(&rss)) * 3600.0
    );
    // No table may grow: a table with an entry per node, channel, request or subscriber must
    // not reach a larger size in the second half of the run than in the first (one that grows
    // with the run's length sets a new maximum late). The queues (requests waiting, frames
    // waiting for the transport or the wire) rise and fall with the traffic; their ranges are
    // printed, and each is bounded by construction (the transmit queue, one job per node).
    let mid = r.samples.len() / 2;
    let max_of = |part: &[load::Sample], k: usize| {
        part.iter()
            .map(|s| s.tables.named()[k].1)
            .max()
            .unwrap_or(0)
    };
    let mut grown = Vec::new();
    let names = load::Tables::default().named();
    let mut line = String::from("tables (largest, first half / second half):");
    for (k, (name, _)) in names.iter().enumerate() {
        let (a, b) = (max_of(&r.samples[..mid], k), max_of(&r.samples[mid..], k));
        line.push_str(&format!(" {name} {a}/{b},"));
        if b > a && load::Tables::KEYED.contains(name) {
            grown.push(*name);
        }
    }
    line.pop();
    println!("{line}");
    if !grown.is_empty() {
        println!("tables that grew: {}", grown.join(", "));
    }
    let first = r.samples.first().map_or(0, |s| s.rss_kib);
    let last = r.samples.last().map_or(0, |s| s.rss_kib);
    println!(
        "soak: frames {}, lost {}, reordered {}, rss_start {} KiB, rss_end {} KiB, \
         cpu_per_frame {:.0} ns",
        r.frames, r.lost, r.reordered, first, last, master_ns
    );
    let wrong = r.sdo.as_ref().map_or(0, |s| s.wrong_data);
    if r.lost != 0
        || r.reordered != 0
        || r.gaps != 0
        || r.bad_values != 0
        || wrong != 0
        || !grown.is_empty()
    {
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
