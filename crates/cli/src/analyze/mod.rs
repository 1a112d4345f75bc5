//! `canopen analyze LOG`: a candump log judged. One streaming pass ([`judge::Analyzer`])
//! gives a summary (duration, frames, bus load, the nodes), a timeline (NMT commands, boot-ups,
//! state changes, LSS) and a problem list with levels; `--check` fails on an error-level
//! problem, `--json` gives all of it as one JSON document, `--frames` decodes every frame
//! instead (as `canopen monitor` shows them, without replaying the log in real time).

mod judge;

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use canola::BusDictionary;
use canola::candump::{self, LogEntry, ReadError};
use clap::Args;
use serde_json::json;

use crate::bus::{BusOpts, fail};
use crate::error::CliError;
use crate::{Global, outln};

use judge::{Analyzer, Config, Level, Problem};

/// `canopen analyze` arguments.
#[derive(Debug, Args)]
pub(crate) struct AnalyzeArgs {
    /// candump log (`candump -l`/`-L`, `canopen record`); `-` reads standard input.
    log: PathBuf,
    /// Exit with status 1 when the problem list has an error-level problem (for CI).
    #[arg(long)]
    check: bool,
    /// Decode every frame instead of judging the log: one line per frame as `canopen monitor`
    /// prints it (with `--json` one JSON object per line), at once, not in recorded time.
    #[arg(long, conflicts_with = "check")]
    frames: bool,
    /// Bit rate of the bus, for the bus load (bit/s; `500k`, `1M` accepted).
    #[arg(long, default_value = "500k", value_parser = parse_bitrate)]
    bitrate: u32,
    /// Bus load above this percentage in any second is a problem.
    #[arg(long, default_value_t = 70.0, value_name = "PERCENT")]
    load_threshold: f64,
    /// An SDO answer later than this is reported as late (milliseconds).
    #[arg(long, default_value_t = 500, value_name = "MS")]
    sdo_timeout: u64,
}

/// `500000`, `500k`, `1M`.
fn parse_bitrate(s: &str) -> Result<u32, String> {
    let (digits, scale) = match s.strip_suffix(['k', 'K']) {
        Some(d) => (d, 1_000),
        None => match s.strip_suffix('M') {
            Some(d) => (d, 1_000_000),
            None => (s, 1),
        },
    };
    match digits
        .parse::<u32>()
        .ok()
        .and_then(|v| v.checked_mul(scale))
    {
        Some(v) if (10_000..=8_000_000).contains(&v) => Ok(v),
        _ => Err(format!(
            "`{s}`: a bit rate from 10k to 8M bit/s (500000, 500k, 1M)"
        )),
    }
}

/// Runs `canopen analyze`.
pub(crate) fn run(args: &AnalyzeArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let mut dictionary = BusDictionary::new();
    match opts.dictionaries() {
        Ok(ds) => {
            for (n, od) in ds {
                dictionary.add_node(n, od);
            }
        }
        Err(e) => return fail(e.into_usage()),
    }
    let input: Box<dyn BufRead> = if args.log.as_os_str() == "-" {
        Box::new(std::io::BufReader::new(std::io::stdin()))
    } else {
        match std::fs::File::open(&args.log) {
            Ok(f) => Box::new(std::io::BufReader::with_capacity(1 << 16, f)),
            Err(e) => return fail(CliError::file(&args.log)(e)),
        }
    };
    if args.frames {
        return frames(input, &args.log, dictionary, g);
    }
    if !(args.load_threshold.is_finite() && args.load_threshold >= 0.0) {
        return fail(CliError::usage(format!(
            "--load-threshold {}: give a percentage, 0 or more",
            args.load_threshold
        )));
    }
    let mut a = Analyzer::new(Config {
        bitrate: args.bitrate,
        load_threshold: args.load_threshold,
        sdo_timeout_us: args.sdo_timeout.saturating_mul(1000),
        dictionary,
    });
    let mut reader = candump::Reader::new(input);
    while let Some(entry) = reader.next() {
        match entry {
            Ok(LogEntry {
                timestamp_us,
                frame,
                ..
            }) => a.frame(reader.line(), timestamp_us, &frame),
            Err(ReadError::Line { line, error }) => {
                a.bad_line(line, format!("line {line}: {error}"))
            }
            Err(source) => {
                return fail(CliError::Log {
                    path: args.log.clone(),
                    source,
                    nothing_sent: false,
                });
            }
        }
    }
    a.finish();
    if g.json {
        outln(&report_json(&a, &args.log, args.bitrate).to_string());
    } else {
        outln(report_text(&a, &args.log, args.bitrate).trim_end());
    }
    if args.check && a.has_errors() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// `--frames`: every frame decoded, in log order, as `monitor` prints it. Lines that do not
/// read are reported on stderr with their numbers (exit 1 at the end).
fn frames(input: Box<dyn BufRead>, path: &Path, dictionary: BusDictionary, g: Global) -> ExitCode {
    let mut monitor = canola::Monitor::new(dictionary.clone());
    let mut bad = 0u64;
    for entry in candump::Reader::new(input) {
        match entry {
            Ok(e) => outln(&crate::traffic::log_line(
                &mut monitor,
                &dictionary,
                &e,
                g.json,
            )),
            Err(source @ ReadError::Line { .. }) => {
                bad += 1;
                let e = CliError::Log {
                    path: path.to_owned(),
                    source,
                    nothing_sent: false,
                };
                crate::bus::warn("error", &e.to_string(), serde_json::Map::new());
            }
            Err(source) => {
                return fail(CliError::Log {
                    path: path.to_owned(),
                    source,
                    nothing_sent: false,
                });
            }
        }
    }
    if bad > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// Seconds since the first frame.
fn rel(a: &Analyzer, us: u64) -> f64 {
    us.saturating_sub(a.first_us.unwrap_or(0)) as f64 / 1e6
}

fn counts(a: &Analyzer) -> (usize, usize, usize) {
    let n = |l| a.problems.iter().filter(|p| p.level == l).count();
    (n(Level::Error), n(Level::Warning), n(Level::Info))
}

fn report_text(a: &Analyzer, path: &Path, bitrate: u32) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "{}", path.display());
    let _ = writeln!(
        s,
        "summary: {:.3} s, {} frames ({} CAN FD, {} error frames), {} bad lines",
        a.duration_us() as f64 / 1e6,
        a.frames,
        a.fd_frames,
        a.error_frames,
        a.bad_lines
    );
    let _ = writeln!(
        s,
        "bus load at {} kbit/s: mean {:.1} %, peak {:.1} % (second from {:.0} s)",
        bitrate / 1000,
        a.load_mean(),
        a.load_peak,
        rel(a, a.load_peak_at_us)
    );
    let nodes: Vec<_> = a.nodes().collect();
    if !nodes.is_empty() {
        let _ = writeln!(s, "\nnodes:");
    }
    for n in nodes {
        let state = n.state.map_or("-".into(), judge::state_name);
        let hb = match (n.heartbeat_ms, n.heartbeat_from) {
            (Some(ms), Some(from)) => format!("heartbeat {ms} ms ({})", from.name()),
            _ => "no heartbeat".into(),
        };
        let mut who = String::new();
        if let Some(v) = n.vendor_id {
            let _ = write!(who, "  vendor {v:#010x}");
        }
        if let Some(p) = n.product_code {
            let _ = write!(who, "  product {p:#010x}");
        }
        if let Some(name) = &n.name {
            let _ = write!(who, "  {name}");
        }
        let _ = writeln!(
            s,
            "  {:>3}  {state:<15} {hb:<26} boot-ups {}  EMCY {}  frames {}{who}",
            n.node, n.boot_ups, n.emcys, n.frames
        );
    }
    if !a.timeline.is_empty() {
        let _ = writeln!(s, "\ntimeline:");
    }
    for e in &a.timeline {
        let _ = writeln!(
            s,
            "  {:>12.6}  line {:<7} {}",
            rel(a, e.time_us),
            e.line,
            e.text
        );
    }
    if a.timeline_dropped > 0 {
        let _ = writeln!(s, "  ... and {} more events", a.timeline_dropped);
    }
    let (errors, warnings, infos) = counts(a);
    let _ = writeln!(
        s,
        "\nproblems: {errors} error(s), {warnings} warning(s), {infos} note(s)"
    );
    for p in &a.problems {
        let _ = writeln!(s, "{}", problem_text(a, p));
    }
    if a.problems_dropped > 0 {
        let _ = writeln!(s, "  ... and {} more problems", a.problems_dropped);
    }
    s
}

fn problem_text(a: &Analyzer, p: &Problem) -> String {
    let node = p.node.map_or(String::new(), |n| format!("node {n}  "));
    let line = p.line.map_or(String::new(), |l| format!(" (line {l})"));
    let again = if p.repeats > 0 {
        format!(" [{} more like it]", p.repeats)
    } else {
        String::new()
    };
    format!(
        "  {:<7} {:>12.6}  {node}{}{line}: {}{again}\n          {}",
        p.level.name(),
        rel(a, p.time_us),
        p.kind.name(),
        p.seen,
        p.meaning
    )
}

fn report_json(a: &Analyzer, path: &Path, bitrate: u32) -> serde_json::Value {
    let (errors, warnings, infos) = counts(a);
    let nodes: Vec<_> = a
        .nodes()
        .map(|n| {
            json!({
                "node": n.node,
                "state": n.state.map(judge::state_name),
                "heartbeat_ms": n.heartbeat_ms,
                "heartbeat_from": n.heartbeat_from.map(|f| f.name()),
                "boot_ups": n.boot_ups,
                "emcys": n.emcys,
                "frames": n.frames,
                "vendor_id": n.vendor_id,
                "product_code": n.product_code,
                "name": n.name,
            })
        })
        .collect();
    let timeline: Vec<_> = a
        .timeline
        .iter()
        .map(|e| {
            json!({"time": rel(a, e.time_us), "timestamp": e.time_us as f64 / 1e6,
                   "line": e.line, "node": e.node, "event": e.text})
        })
        .collect();
    let problems: Vec<_> = a
        .problems
        .iter()
        .map(|p| {
            json!({
                "time": rel(a, p.time_us),
                "timestamp": p.time_us as f64 / 1e6,
                "line": p.line,
                "node": p.node,
                "level": p.level.name(),
                "kind": p.kind.name(),
                "seen": p.seen,
                "meaning": p.meaning,
                "repeats": p.repeats,
            })
        })
        .collect();
    json!({
        "log": path.display().to_string(),
        "summary": {
            "start": a.first_us.map(|f| f as f64 / 1e6),
            "duration": a.duration_us() as f64 / 1e6,
            "frames": a.frames,
            "fd_frames": a.fd_frames,
            "error_frames": a.error_frames,
            "bad_lines": a.bad_lines,
            "bitrate": bitrate,
            "load_mean": a.load_mean(),
            "load_peak": a.load_peak,
            "load_peak_at": rel(a, a.load_peak_at_us),
        },
        "nodes": nodes,
        "timeline": timeline,
        "timeline_omitted": a.timeline_dropped,
        "problems": problems,
        "problems_omitted": a.problems_dropped,
        "counts": {"error": errors, "warning": warnings, "info": infos},
    })
}
