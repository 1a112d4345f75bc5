//! `canopen monitor`, `record` and `replay`: the bus's traffic decoded in CiA vocabulary
//! ([`canopen::describe`]), written to a candump log, or sent again from one.

use std::path::PathBuf;
use std::process::ExitCode;

use canopen::candump::{self, LogEntry, LogFrame};
use canopen::{Duration, Monitor};
use serde_json::json;

use crate::bus::{BusOpts, fail};
use crate::{Global, outln};

/// `canopen monitor` (`--devicenet`: the frames read as DeviceNet, CAN's other application
/// layer on the same wire, e.g. for the GEMÜ cPos)
pub(crate) fn run_monitor(
    opts: &BusOpts,
    duration: Option<f64>,
    devicenet: bool,
    g: Global,
) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let mut monitor = Monitor::new(bus.bus_dictionary());
    let r = bus.pump(duration, |frame, at| {
        let what = if devicenet {
            devicenet::decode(frame).to_string()
        } else {
            monitor.what(frame)
        };
        if g.json {
            outln(
                &json!({"time": at.as_micros() as f64 / 1e6, "frame": frame.to_string(),
                        "decoded": what})
                .to_string(),
            );
        } else {
            let shown = frame.to_string();
            outln(&format!("{at}  {shown:<28} {what}"));
        }
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// `canopen record -o FILE`
pub(crate) fn run_record(opts: &BusOpts, output: &PathBuf, duration: Option<f64>) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let file = match std::fs::File::create(output) {
        Ok(f) => f,
        Err(e) => return fail(format!("{}: {e}", output.display())),
    };
    let iface = opts.iface.clone().unwrap_or_else(|| "mem0".into());
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let start = bus.transport.now();
    let mut w = candump::Writer::new(std::io::BufWriter::new(file));
    let mut err = None;
    let r = bus.pump(duration, |frame, at| {
        let entry = LogEntry {
            timestamp_us: epoch + (at - start).as_micros(),
            interface: iface.clone(),
            frame: LogFrame::Can(*frame),
        };
        if let Err(e) = w.write(&entry) {
            err = Some(e);
        }
    });
    let _ = w.flush();
    match (r, err) {
        (Ok(()), None) => ExitCode::SUCCESS,
        (Err(e), _) => fail(e),
        (_, Some(e)) => fail(e),
    }
}

/// `canopen replay FILE`
pub(crate) fn run_replay(opts: &BusOpts, file: &PathBuf, g: Global) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let f = match std::fs::File::open(file) {
        Ok(f) => f,
        Err(e) => return fail(format!("{}: {e}", file.display())),
    };
    let mut first: Option<u64> = None;
    let start = bus.transport.now();
    let mut sent = 0u64;
    for entry in candump::Reader::new(std::io::BufReader::new(f)) {
        let entry = match entry {
            Ok(e) => e,
            Err(e) => return fail(format!("{}: {e}", file.display())),
        };
        let LogFrame::Can(frame) = entry.frame else {
            continue;
        };
        let t0 = *first.get_or_insert(entry.timestamp_us);
        let due = start + Duration::from_micros(entry.timestamp_us.saturating_sub(t0));
        // Keep the recorded spacing (receiving meanwhile, so simulated devices run).
        while bus.transport.now() < due {
            if let Err(e) = bus.transport.recv_until(due) {
                return fail(e);
            }
        }
        if let Err(e) = bus.transport.send(&frame) {
            return fail(e);
        }
        sent += 1;
    }
    if g.json {
        outln(&json!({"sent": sent}).to_string());
    } else {
        eprintln!("{sent} frames replayed");
    }
    ExitCode::SUCCESS
}
