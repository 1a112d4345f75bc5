//! `canopen monitor`, `record` and `replay`: the bus's traffic decoded in CiA vocabulary
//! ([`canola::describe()`]), written to a candump log, or sent again from one.

use std::path::Path;
use std::process::ExitCode;

use canola::candump::{self, LogEntry, LogFrame};
use canola::{CanId, Duration, Monitor};
use serde_json::json;

use crate::bus::{BusOpts, Traffic, fail};
use crate::error::CliError;
use crate::outfile::OutFile;
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

/// Why a candump-style filter does not parse (the filter as given, and what is wrong with it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum FilterError {
    /// Neither `ID:MASK` nor `ID~MASK`.
    Syntax(String),
    /// ID or MASK is not a hex number of at most 8 digits.
    NotHex(String),
    /// The identifier does not fit 29 bits.
    IdentifierTooLarge(String),
}

impl std::fmt::Display for FilterError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Syntax(s) => write!(
                f,
                "filter `{s}`: expected ID:MASK or ID~MASK in hex (candump's syntax)"
            ),
            Self::NotHex(s) => write!(f, "filter `{s}`: ID and MASK are hex numbers"),
            Self::IdentifierTooLarge(s) => write!(f, "filter `{s}`: identifier above 0x1FFFFFFF"),
        }
    }
}

impl std::error::Error for FilterError {}

/// Parses `ID:MASK` or `ID~MASK` (hex, as candump writes them).
pub(crate) fn parse_filter(s: &str) -> Result<Filter, FilterError> {
    let (id, mask, inverse) = match (s.split_once(':'), s.split_once('~')) {
        (Some((i, m)), None) => (i, m, false),
        (None, Some((i, m))) => (i, m, true),
        _ => return Err(FilterError::Syntax(s.to_owned())),
    };
    let hex = |t: &str| {
        let t = t.strip_prefix("0x").unwrap_or(t);
        if t.is_empty() || t.len() > 8 {
            return None;
        }
        u32::from_str_radix(t, 16).ok()
    };
    let (Some(idv), Some(maskv)) = (hex(id), hex(mask)) else {
        return Err(FilterError::NotHex(s.to_owned()));
    };
    let extended = id.trim_start_matches("0x").len() == 8 || idv > 0x7FF;
    if idv > 0x1FFF_FFFF {
        return Err(FilterError::IdentifierTooLarge(s.to_owned()));
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

/// A PDO value as a JSON value: numbers as numbers, bytes as hex text.
fn raw_json(v: &canola::pdo::RawValue) -> serde_json::Value {
    use canola::pdo::RawValue as R;
    match v {
        R::Bool(b) => json!(b),
        R::Unsigned(u) => json!(u),
        R::Signed(i) => json!(i),
        R::Real32(x) => json!(x),
        R::Real64(x) => json!(x),
        R::Bytes(b) => json!(
            b.as_slice()
                .iter()
                .map(|x| format!("{x:02x}"))
                .collect::<String>()
        ),
    }
}

/// `canopen monitor [FILTER...]` (`--devicenet`: the frames read as DeviceNet, CAN's other
/// application layer on the same wire, e.g. for the GEMÜ cPos). CAN FD frames are shown in
/// candump's syntax; those that are PDOs an EDS maps (CANopen FD, up to 64 bytes) decoded as
/// classic ones are, the others not decoded.
pub(crate) fn run_monitor(
    opts: &BusOpts,
    duration: Option<f64>,
    filters: &[Filter],
    devicenet: bool,
    g: Global,
) -> ExitCode {
    // Before the bus opens (its transport may start threads): Ctrl-C ends the monitor with
    // everything shown so far written out, and exit status 0.
    if let Err(e) = crate::bus::stop_on_signals() {
        return fail(e);
    }
    let mut bus = match opts.open_watching() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let dictionary = bus.bus_dictionary();
    let mut monitor = Monitor::new(dictionary.clone());
    let r = bus.pump(duration, |traffic, at| {
        if !passes(filters, traffic.id()) {
            return;
        }
        let (shown, what) = match traffic {
            Traffic::Can(frame) if devicenet => (
                frame.to_string(),
                canola_devicenet::decode(frame).to_string(),
            ),
            Traffic::Can(frame) => (frame.to_string(), monitor.what(frame)),
            Traffic::Fd(frame) => (
                candump::format_frame(&LogFrame::Fd(*frame)),
                monitor.what_fd(frame),
            ),
        };
        let pdo = || match traffic {
            Traffic::Can(_) if devicenet => None,
            Traffic::Can(frame) => dictionary.decode_pdo(frame),
            Traffic::Fd(frame) => dictionary.decode_fd_pdo(frame),
        };
        outln(&shown_line(at.as_micros(), &shown, &what, pdo, g.json));
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// One frame as `monitor` prints it: `SECONDS  FRAME  WHAT`, or with `json` one JSON object
/// (`time`, `frame`, `decoded`; for a PDO an EDS maps also `pdo` and its `values`).
fn shown_line(
    time_us: u64,
    shown: &str,
    what: &str,
    pdo: impl FnOnce() -> Option<Result<canola::DecodedPdo, canola::pdo::PackError>>,
    json: bool,
) -> String {
    if !json {
        return format!(
            "{}.{:06}  {shown:<28} {what}",
            time_us / 1_000_000,
            time_us % 1_000_000
        );
    }
    shown_json(time_us, shown, what, pdo).to_string()
}

/// [`shown_line`]'s JSON object.
fn shown_json(
    time_us: u64,
    shown: &str,
    what: &str,
    pdo: impl FnOnce() -> Option<Result<canola::DecodedPdo, canola::pdo::PackError>>,
) -> serde_json::Value {
    let mut line = json!({"time": time_us as f64 / 1e6, "frame": shown, "decoded": what});
    // A PDO an EDS maps: its values as JSON values too.
    if let Some(Ok(pdo)) = pdo() {
        line["pdo"] = json!(pdo.label);
        line["values"] = pdo
            .values
            .iter()
            .map(|v| {
                json!({"index": v.address.index, "sub": v.address.sub_index,
                       "name": v.name, "value": raw_json(&v.value)})
            })
            .collect();
    }
    line
}

/// One frame of a log decoded as `monitor` decodes a frame on the bus (the same decoder, the
/// same line), at its time stamp: for `canopen analyze --frames`. A classic frame's raw DLC
/// above 8 (`candump -8`) shows as the log writes it (`123#1122334455667788_C`), and under
/// `--json` also as `len8_dlc`.
pub(crate) fn log_line(
    monitor: &mut Monitor,
    dictionary: &canola::BusDictionary,
    entry: &LogEntry,
    json: bool,
) -> String {
    let (time_us, frame) = (entry.timestamp_us, &entry.frame);
    let shown = candump::format_frame_len8(frame, entry.len8_dlc);
    match frame {
        LogFrame::Can(f) => {
            let what = monitor.what(f);
            let pdo = || dictionary.decode_pdo(f);
            match entry.raw_dlc() {
                Some(dlc) if json => {
                    let mut line = shown_json(time_us, &shown, &what, pdo);
                    line["len8_dlc"] = json!(dlc);
                    line.to_string()
                }
                _ => shown_line(time_us, &shown, &what, pdo, json),
            }
        }
        LogFrame::Fd(f) => {
            let what = monitor.what_fd(f);
            shown_line(time_us, &shown, &what, || dictionary.decode_fd_pdo(f), json)
        }
        LogFrame::Error { class, data } => {
            let what = format!(
                "CAN error frame: class {class:#x}, data {}",
                canola::frame::HexBytes(data)
            );
            shown_line(time_us, &shown, &what, || None, json)
        }
    }
}

/// `canopen record -o FILE`: every frame, CAN FD frames in candump's FD syntax (`123##1...`),
/// until `--duration` or Ctrl-C. The file appears when recording ends well (see [`OutFile`]).
pub(crate) fn run_record(opts: &BusOpts, output: &Path, duration: Option<f64>) -> ExitCode {
    // Before the bus opens (its transport may start threads): Ctrl-C ends the recording.
    if let Err(e) = crate::bus::stop_on_signals() {
        return fail(e);
    }
    let mut bus = match opts.open_watching() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let out = match OutFile::create(output) {
        Ok(f) => f,
        Err(e) => return fail(e),
    };
    let file = match out.writer() {
        Ok(f) => f,
        Err(e) => return fail(e),
    };
    let iface = opts.iface.clone().unwrap_or_else(|| "mem0".into());
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let start = bus.transport.now();
    let mut w = candump::Writer::new(std::io::BufWriter::new(file));
    let mut err = None;
    let (mut frames, mut fd) = (0u64, 0u64);
    if duration.is_none() && bus.memory.is_some() {
        return fail(CliError::Argument(
            "on the in-memory bus give --duration SECONDS".into(),
        ));
    }
    eprintln!("recording {iface} to {}", output.display());
    let r = bus.pump(duration, |traffic, at| {
        let (frame, is_fd) = match traffic {
            Traffic::Can(f) => (LogFrame::Can(*f), false),
            Traffic::Fd(f) => (LogFrame::Fd(*f), true),
        };
        let entry = LogEntry {
            timestamp_us: epoch + (at - start).as_micros(),
            interface: iface.clone(),
            frame,
            // The transports do not report a classic frame's raw DLC.
            len8_dlc: None,
        };
        match w.write(&entry) {
            Ok(()) => {
                frames += 1;
                fd += u64::from(is_fd);
            }
            Err(e) => {
                err.get_or_insert(e);
            }
        }
    });
    let flushed = w.flush();
    let result = match (r, err, flushed) {
        (Err(e), _, _) => Err(e),
        (_, Some(e), _) | (_, _, Err(e)) => Err(CliError::file(output)(e)),
        (Ok(()), None, Ok(())) => out.commit(),
    };
    match result {
        Ok(()) => {
            let of_them = if fd > 0 {
                format!(" ({fd} of them CAN FD)")
            } else {
                String::new()
            };
            eprintln!("{frames} frames{of_them} recorded to {}", output.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// `canopen replay FILE`: reads and checks the whole log first, so a bad line sends nothing.
/// CAN FD frames are sent when the bus carries CAN FD (a SocketCAN interface with MTU 72, the
/// UDP bus, the in-memory bus with `--fd`); on a classic-only bus they are skipped, with a
/// warning that says why and their count.
pub(crate) fn run_replay(opts: &BusOpts, file: &Path, g: Global) -> ExitCode {
    let f = match std::fs::File::open(file) {
        Ok(f) => f,
        Err(e) => return fail(CliError::file(file)(e)),
    };
    let mut frames = Vec::new();
    let mut fd = 0u64;
    let mut other = 0u64;
    for entry in candump::Reader::new(std::io::BufReader::new(f)) {
        match entry {
            Ok(LogEntry {
                timestamp_us,
                frame: frame @ (LogFrame::Can(_) | LogFrame::Fd(_)),
                ..
            }) => {
                fd += u64::from(matches!(frame, LogFrame::Fd(_)));
                frames.push((timestamp_us, frame));
            }
            Ok(_) => other += 1,
            Err(source) => {
                return fail(CliError::Log {
                    path: file.to_owned(),
                    source,
                    nothing_sent: true,
                });
            }
        }
    }
    let mut bus = match opts.open_watching() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let classic = bus.transport.fd_support().err();
    let skipped_fd = if classic.is_some() { fd } else { 0 };
    if let Some(why) = &classic
        && fd > 0
    {
        let mut fields = serde_json::Map::new();
        fields.insert("skipped_fd".into(), fd.into());
        crate::bus::warn(
            "warning",
            &format!("{}: skipping {fd} CAN FD frame(s): {why}", file.display()),
            fields,
        );
    }
    let mut first: Option<u64> = None;
    let start = bus.transport.now();
    let mut sent = 0u64;
    let mut sent_fd = 0u64;
    for (timestamp_us, frame) in frames {
        if classic.is_some() && matches!(frame, LogFrame::Fd(_)) {
            continue;
        }
        let t0 = *first.get_or_insert(timestamp_us);
        let due = start + Duration::from_micros(timestamp_us.saturating_sub(t0));
        // Keep the recorded spacing (receiving meanwhile, so simulated devices run).
        while bus.transport.now() < due {
            if let Err(e) = bus.transport.recv_until(due) {
                return fail(e);
            }
        }
        let r = match &frame {
            LogFrame::Fd(f) => {
                sent_fd += 1;
                bus.transport.send_fd(f)
            }
            LogFrame::Can(f) => bus.transport.send(f),
            LogFrame::Error { .. } => Ok(()),
        };
        if let Err(e) = r {
            return fail(e);
        }
        sent += 1;
    }
    if g.json {
        outln(
            &json!({"sent": sent, "sent_fd": sent_fd, "skipped_fd": skipped_fd, "skipped_error_frames": other})
                .to_string(),
        );
    } else {
        let mut notes = Vec::new();
        if sent_fd > 0 {
            notes.push(format!("{sent_fd} of them CAN FD"));
        }
        if skipped_fd > 0 {
            notes.push(format!("{skipped_fd} CAN FD frames skipped"));
        }
        if other > 0 {
            notes.push(format!("{other} error frames skipped"));
        }
        if notes.is_empty() {
            eprintln!("{sent} frames replayed");
        } else {
            eprintln!("{sent} frames replayed ({})", notes.join(", "));
        }
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
