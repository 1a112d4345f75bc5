//! `canopen monitor`, `record` and `replay`: the bus's traffic decoded in CiA vocabulary
//! ([`canopen::describe`]), written to a candump log, or sent again from one.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use canopen::candump::{self, LogEntry, LogFrame};
use canopen::{Duration, Monitor};
use serde_json::json;

use crate::bus::{BusOpts, fail};
use crate::{Global, outln};

/// `canopen monitor`
pub(crate) fn run_monitor(opts: &BusOpts, duration: Option<f64>, g: Global) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let mut monitor = Monitor::new(bus.bus_dictionary());
    let r = bus.pump(duration, |frame, at| {
        if g.json {
            outln(
                &json!({"time": at.as_micros() as f64 / 1e6, "frame": frame.to_string(),
                        "decoded": monitor.what(frame)})
                .to_string(),
            );
        } else {
            outln(&format!("{at}  {}", monitor.describe(frame)));
        }
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// `FILE` with a temporary name beside it: `record` writes there and renames on success, so a
/// failing run leaves an existing `FILE` as it was.
fn temp_beside(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "record".into());
    output.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// `canopen record -o FILE`
pub(crate) fn run_record(opts: &BusOpts, output: &Path, duration: Option<f64>) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let temp = temp_beside(output);
    let file = match std::fs::File::create(&temp) {
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
    let mut frames = 0u64;
    let r = bus.pump(duration, |frame, at| {
        let entry = LogEntry {
            timestamp_us: epoch + (at - start).as_micros(),
            interface: iface.clone(),
            frame: LogFrame::Can(*frame),
        };
        match w.write(&entry) {
            Ok(()) => frames += 1,
            Err(e) => {
                err.get_or_insert(e);
            }
        }
    });
    let flushed = w.flush();
    let result = match (r, err, flushed) {
        (Err(e), _, _) => Err(e),
        (_, Some(e), _) | (_, _, Err(e)) => Err(format!("{}: {e}", output.display())),
        (Ok(()), None, Ok(())) => {
            std::fs::rename(&temp, output).map_err(|e| format!("{}: {e}", output.display()))
        }
    };
    match result {
        Ok(()) => {
            eprintln!("{frames} frames recorded to {}", output.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            let _ = std::fs::remove_file(&temp);
            fail(e)
        }
    }
}

/// `canopen replay FILE`: reads and checks the whole log first, so a bad line sends nothing.
/// CAN FD frames are skipped (the transports carry classic frames), with a warning and their
/// count.
pub(crate) fn run_replay(opts: &BusOpts, file: &Path, g: Global) -> ExitCode {
    let f = match std::fs::File::open(file) {
        Ok(f) => f,
        Err(e) => return fail(format!("{}: {e}", file.display())),
    };
    let mut frames = Vec::new();
    let mut fd = 0u64;
    let mut other = 0u64;
    for entry in candump::Reader::new(std::io::BufReader::new(f)) {
        match entry {
            Ok(LogEntry {
                timestamp_us,
                frame: LogFrame::Can(frame),
                ..
            }) => frames.push((timestamp_us, frame)),
            Ok(LogEntry {
                frame: LogFrame::Fd(_),
                ..
            }) => fd += 1,
            Ok(_) => other += 1,
            Err(e) => return fail(format!("{}: {e} (nothing was sent)", file.display())),
        }
    }
    if fd > 0 {
        eprintln!(
            "warning: {}: skipping {fd} CAN FD frame(s): this bus carries classic CAN frames only",
            file.display()
        );
    }
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let mut first: Option<u64> = None;
    let start = bus.transport.now();
    let mut sent = 0u64;
    for (timestamp_us, frame) in frames {
        let t0 = *first.get_or_insert(timestamp_us);
        let due = start + Duration::from_micros(timestamp_us.saturating_sub(t0));
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
        outln(&json!({"sent": sent, "skipped_fd": fd, "skipped_error_frames": other}).to_string());
    } else {
        eprintln!("{sent} frames replayed");
    }
    ExitCode::SUCCESS
}
