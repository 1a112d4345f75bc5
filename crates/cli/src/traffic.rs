//! `canopen monitor`, `record` and `replay`: the bus's traffic decoded in CiA vocabulary
//! ([`canopen::describe`]), written to a candump log, or sent again from one.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use canopen::candump::{self, LogEntry, LogFrame};
use canopen::{CanId, Duration, Monitor};
use serde_json::json;

use crate::bus::{BusOpts, fail};
use crate::{Global, outln};

/// One candump-style receive filter: `ID:MASK` passes a frame whose identifier matches `ID` in
/// the bits of `MASK`, `ID~MASK` one that does not. Three hex digits (or a value up to 0x7FF)
/// filter 11-bit frames, eight digits (or a larger value) 29-bit frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Filter {
    id: u32,
    mask: u32,
    extended: bool,
    inverse: bool,
}

impl Filter {
    fn matches(&self, id: CanId) -> bool {
        let (raw, ext) = match id {
            CanId::Standard(_) => (id.as_raw(), false),
            CanId::Extended(_) => (id.as_raw(), true),
        };
        let hit = ext == self.extended && raw & self.mask == self.id & self.mask;
        hit != self.inverse
    }
}

/// Parses `ID:MASK` or `ID~MASK` (hex, as candump writes them).
pub(crate) fn parse_filter(s: &str) -> Result<Filter, String> {
    let (id, mask, inverse) = match (s.split_once(':'), s.split_once('~')) {
        (Some((i, m)), None) => (i, m, false),
        (None, Some((i, m))) => (i, m, true),
        _ => {
            return Err(format!(
                "filter `{s}`: expected ID:MASK or ID~MASK in hex (candump's syntax)"
            ));
        }
    };
    let hex = |t: &str| {
        let t = t.strip_prefix("0x").unwrap_or(t);
        if t.is_empty() || t.len() > 8 {
            return None;
        }
        u32::from_str_radix(t, 16).ok()
    };
    let (Some(idv), Some(maskv)) = (hex(id), hex(mask)) else {
        return Err(format!("filter `{s}`: ID and MASK are hex numbers"));
    };
    let extended = id.trim_start_matches("0x").len() == 8 || idv > 0x7FF;
    if idv > 0x1FFF_FFFF {
        return Err(format!("filter `{s}`: identifier above 0x1FFFFFFF"));
    }
    Ok(Filter {
        id: idv,
        mask: maskv & if extended { 0x1FFF_FFFF } else { 0x7FF },
        extended,
        inverse,
    })
}

/// Whether `id` passes `filters`: any of them (none given: all frames), as candump does.
fn passes(filters: &[Filter], id: CanId) -> bool {
    filters.is_empty() || filters.iter().any(|f| f.matches(id))
}

/// `canopen monitor [FILTER...]` (`--devicenet`: the frames read as DeviceNet, CAN's other
/// application layer on the same wire, e.g. for the GEMÜ cPos)
pub(crate) fn run_monitor(
    opts: &BusOpts,
    duration: Option<f64>,
    filters: &[Filter],
    devicenet: bool,
    g: Global,
) -> ExitCode {
    let mut bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let mut monitor = Monitor::new(bus.bus_dictionary());
    let r = bus.pump(duration, |frame, at| {
        if !passes(filters, frame.id()) {
            return;
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    #[test]
    fn filters_as_candump_reads_them() {
        let f = parse_filter("705:7FF").unwrap();
        assert!(f.matches(sid(0x705)) && !f.matches(sid(0x706)));
        let f = parse_filter("700:780").unwrap();
        assert!(f.matches(sid(0x705)) && f.matches(sid(0x77F)) && !f.matches(sid(0x605)));
        let f = parse_filter("705~7FF").unwrap();
        assert!(!f.matches(sid(0x705)) && f.matches(sid(0x706)));
        let f = parse_filter("00000705:1FFFFFFF").unwrap();
        assert!(!f.matches(sid(0x705)));
        assert!(f.matches(CanId::extended(0x705).unwrap()));
        assert!(parse_filter("12345678:0").unwrap().extended);
        for bad in [
            "705",
            "705:",
            ":7FF",
            "zz:7FF",
            "705:7FF~1",
            "3FFFFFFFF:0",
            "40000000:0",
        ] {
            assert!(parse_filter(bad).is_err(), "{bad}");
        }
        let two = [
            parse_filter("705:7FF").unwrap(),
            parse_filter("706:7FF").unwrap(),
        ];
        assert!(passes(&two, sid(0x706)) && !passes(&two, sid(0x707)));
        assert!(passes(&[], sid(0x707)));
    }
}
