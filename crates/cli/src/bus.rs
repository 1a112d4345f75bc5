//! The bus every bus command runs on, chosen by the global flags every subcommand shares
//! ([`BusOpts`]): SocketCAN with `--iface IFACE`, else an in-memory bus on a virtual clock. On
//! the in-memory bus every `--eds NODE=FILE` node is also simulated (a Bürkert device when the
//! file carries the Bürkert profile, the simulated servo for a CiA 402 drive, the generic
//! simulator otherwise), so every command has a
//! device to talk to without hardware.
//!
//! Also the argument parsers the bus commands share and their one error printer.

use std::process::ExitCode;

use canola::candump::FdFrame;
use canola::mem::MemoryBus;
use canola::transport::{BusEvent, Received, Transport};
use canola::{BusDictionary, CanFrame, Duration, Instant, Network, NodeId, ObjectDictionary};
use clap::Args;

/// Options of the bus commands (global: they may stand before or after the subcommand).
#[derive(Debug, Clone, Args)]
pub(crate) struct BusOpts {
    /// The bus: a SocketCAN interface (can0, vcan0); `slcan:PATH[@BITRATE]`, a USB
    /// serial-line adapter (CANable with slcan firmware, USBtin, CANUSB: slcan:/dev/ttyACM0@500k,
    /// slcan:COM3); or `udp[:GROUP[:PORT]]`, a bus over UDP multicast between processes on this
    /// machine in python-can's `udp_multicast` format (default 239.74.163.2:43113; nothing
    /// leaves the machine). `udp[:GROUP[:PORT]]@IFACE` puts it on that interface's LAN
    /// segment, where anyone can read and inject frames. Without it, an in-memory simulated
    /// bus inside this process.
    #[arg(long, global = true, value_name = "IFACE")]
    pub(crate) iface: Option<String>,
    /// Object dictionary of a node, NODE=FILE (repeatable). On the in-memory bus the node is
    /// also simulated from that file.
    #[arg(id = "node_eds", long = "eds", value_name = "NODE=FILE", global = true)]
    pub(crate) node_eds: Vec<String>,
    /// Open the bus for CAN FD (CANopen FD: `usdo`, FD frames): a SocketCAN interface must
    /// carry CAN FD (MTU 72), else the command fails with `FD not supported on IFACE`; the
    /// in-memory bus then carries CAN FD and its `--eds` devices serve USDO.
    #[arg(long, global = true)]
    pub(crate) fd: bool,
}

/// An unsigned number in CANopen's notation: `0x` hex or decimal.
fn parse_number<T>(
    s: &str,
    radix16: fn(&str) -> Result<T, std::num::ParseIntError>,
) -> Result<T, String>
where
    T: std::str::FromStr<Err = std::num::ParseIntError>,
{
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => radix16(h),
        None => s.parse(),
    };
    r.map_err(|e| format!("`{s}`: {e}"))
}

/// An object index: `0x` hex or decimal, at most 0xFFFF.
pub(crate) fn parse_u16(s: &str) -> Result<u16, String> {
    parse_number(s, |h| u16::from_str_radix(h, 16))
        .map_err(|e| format!("`{s}` is not an object index (0x0000..0xFFFF): {e}"))
}

/// A sub-index: `0x` hex or decimal.
pub(crate) fn parse_u8(s: &str) -> Result<u8, String> {
    parse_number(s, |h| u8::from_str_radix(h, 16))
}

/// A node-ID 1..=127: `0x` hex or decimal.
pub(crate) fn parse_node(s: &str) -> Result<NodeId, String> {
    NodeId::new(parse_u8(s)?).map_err(|e| e.to_string())
}

/// `NODE=FILE`: the node and its parsed dictionary.
pub(crate) fn load_eds(spec: &str) -> Result<(NodeId, ObjectDictionary), String> {
    let (node, file) = spec
        .split_once('=')
        .ok_or_else(|| format!("--eds {spec}: expected NODE=FILE"))?;
    let node = parse_node(node)?;
    Ok((node, read_dictionary(std::path::Path::new(file))?))
}

/// Parses an EDS/DCF file; errors name the file (and the line, from the parser).
pub(crate) fn read_dictionary(path: &std::path::Path) -> Result<ObjectDictionary, String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    canola::od::parse(&text)
        .map(|p| p.od)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The bus as a transport, the in-memory bus behind it (if that is the bus), and the
/// dictionaries of the nodes.
pub(crate) struct Bus {
    pub(crate) transport: Box<dyn Transport>,
    pub(crate) memory: Option<MemoryBus>,
    pub(crate) dictionaries: Vec<(NodeId, ObjectDictionary)>,
}

impl BusOpts {
    /// The `--eds` dictionaries.
    pub(crate) fn dictionaries(&self) -> Result<Vec<(NodeId, ObjectDictionary)>, String> {
        let mut out: Vec<(NodeId, ObjectDictionary)> = Vec::new();
        for spec in &self.node_eds {
            let (node, od) = load_eds(spec)?;
            if out.iter().any(|(n, _)| *n == node) {
                return Err(format!(
                    "--eds {spec}: node {node} already has a dictionary (one --eds per node)"
                ));
            }
            out.push((node, od));
        }
        Ok(out)
    }

    /// Opens the bus with the `--eds` dictionaries.
    pub(crate) fn open(&self) -> Result<Bus, String> {
        self.open_with(self.dictionaries()?)
    }

    /// Opens the bus with the `--eds` dictionaries to watch its traffic: on SocketCAN CAN FD
    /// frames are received too (see [`Bus::pump`]).
    pub(crate) fn open_watching(&self) -> Result<Bus, String> {
        self.open_inner(self.dictionaries()?, true)
    }

    /// Opens the bus with `dictionaries`; on the in-memory bus each node is simulated.
    pub(crate) fn open_with(
        &self,
        dictionaries: Vec<(NodeId, ObjectDictionary)>,
    ) -> Result<Bus, String> {
        self.open_inner(dictionaries, false)
    }

    /// Opens the bus to watch it live (`canopen top`): CAN FD frames received on SocketCAN; the
    /// in-memory bus runs on the host's clock at `bitrate` bit/s (its timing model), with the
    /// `--eds` nodes simulated on it.
    pub(crate) fn open_live(&self, bitrate: u32) -> Result<Bus, String> {
        let dictionaries = self.dictionaries()?;
        if self.iface.is_some() {
            return self.open_inner(dictionaries, true);
        }
        let bus = MemoryBus::with_config(canola::BusConfig {
            clock: canola::ClockMode::RealTime,
            bitrate: Some(bitrate),
            ..canola::BusConfig::default()
        });
        let endpoint = bus.endpoint();
        for (node, od) in &dictionaries {
            bus.attach(crate::sim_device::simulated_device(*node, od.clone()));
        }
        Ok(Bus {
            transport: Box::new(endpoint),
            memory: Some(bus),
            dictionaries,
        })
    }

    fn open_inner(
        &self,
        dictionaries: Vec<(NodeId, ObjectDictionary)>,
        fd: bool,
    ) -> Result<Bus, String> {
        match &self.iface {
            Some(iface) if self.fd => {
                let t = open_transport_fd(iface)?;
                Ok(Bus {
                    transport: t,
                    memory: None,
                    dictionaries,
                })
            }
            Some(iface) => {
                let t = open_transport_with(iface, fd)?;
                Ok(Bus {
                    transport: t,
                    memory: None,
                    dictionaries,
                })
            }
            None => {
                let bus = MemoryBus::with_config(canola::BusConfig {
                    fd: self.fd,
                    ..canola::BusConfig::default()
                });
                // The master's endpoint first, so it sees the devices' boot-up messages.
                let endpoint = bus.endpoint();
                for (node, od) in &dictionaries {
                    let mut device = crate::sim_device::simulated_device(*node, od.clone());
                    if self.fd {
                        device.set_fd(true);
                    }
                    bus.attach(device);
                }
                Ok(Bus {
                    transport: Box::new(endpoint),
                    memory: Some(bus),
                    dictionaries,
                })
            }
        }
    }
}

/// Opens the bus (see [`BusOpts`]) and a network on it.
pub(crate) fn open_network(opts: &BusOpts) -> Result<(Network, Option<MemoryBus>), String> {
    opts.open().map(Bus::into_network)
}

impl Bus {
    /// A network on the bus with every dictionary's node added. The memory bus is returned to
    /// keep its simulated devices alive.
    pub(crate) fn into_network(self) -> (Network, Option<MemoryBus>) {
        let net = Network::new(self.transport);
        for (node, od) in self.dictionaries {
            net.add_node_with_dictionary(node, od);
        }
        (net, self.memory)
    }

    /// What `describe` needs to name objects and decode PDOs.
    pub(crate) fn bus_dictionary(&self) -> BusDictionary {
        let mut d = BusDictionary::new();
        for (node, od) in &self.dictionaries {
            d.add_node(*node, od.clone());
        }
        d
    }

    /// Runs the bus for `secs` (without, until a signal [`stop_on_signals`] took, or forever;
    /// not on the in-memory bus), handing each received frame
    /// to `f` (CAN FD frames too, on a bus opened with [`BusOpts::open_watching`]); other bus
    /// events are printed. The in-memory bus needs a duration.
    pub(crate) fn pump(
        &mut self,
        secs: Option<f64>,
        mut f: impl FnMut(Traffic<'_>, Instant),
    ) -> Result<(), String> {
        let start = self.transport.now();
        let end = secs.map(|s| start + seconds(s));
        if end.is_none() && self.memory.is_some() {
            return Err("on the in-memory bus give --duration SECONDS".into());
        }
        loop {
            let now = self.transport.now();
            let deadline = end.map_or(now + Duration::from_millis(200), |e| {
                e.min(now + Duration::from_millis(200))
            });
            if end.is_some_and(|e| now >= e) || STOP.load(std::sync::atomic::Ordering::Relaxed) {
                return Ok(());
            }
            match self.transport.recv_until(deadline) {
                Ok(Some(Received::Frame { frame, at })) => f(Traffic::Can(&frame), at),
                Ok(Some(Received::Event(BusEvent::FdFrame { frame, at }))) => {
                    f(Traffic::Fd(&frame), at)
                }
                Ok(Some(Received::Event(e))) => eprintln!("bus: {e}"),
                Ok(None) => {}
                Err(e) => return Err(e.to_string()),
            }
        }
    }
}

/// Set when SIGINT or SIGTERM arrived after [`stop_on_signals`].
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether SIGINT or SIGTERM arrived after [`stop_on_signals`].
pub(crate) fn stop_requested() -> bool {
    STOP.load(std::sync::atomic::Ordering::Relaxed)
}

/// Makes Ctrl-C (SIGINT) and SIGTERM end [`Bus::pump`] at its next turn (within 200 ms)
/// instead of killing the process, so `record` can still put its file in place; a second
/// signal ends the process (exit status 130). Call it before any other thread starts: the
/// signals are blocked in this thread (and so in every thread started later) and taken by a
/// thread of their own with `sigwait`.
#[cfg(unix)]
pub(crate) fn stop_on_signals() -> Result<(), String> {
    use nix::sys::signal::{SigSet, Signal};
    let mut set = SigSet::empty();
    set.add(Signal::SIGINT);
    set.add(Signal::SIGTERM);
    set.thread_block()
        .map_err(|e| format!("cannot block SIGINT: {e}"))?;
    std::thread::spawn(move || {
        while set.wait().is_ok() {
            if STOP.swap(true, std::sync::atomic::Ordering::Relaxed) {
                std::process::exit(130);
            }
        }
    });
    Ok(())
}

/// Elsewhere Ctrl-C ends the process as usual (`record` may then leave its file unwritten).
#[cfg(not(unix))]
pub(crate) fn stop_on_signals() -> Result<(), String> {
    Ok(())
}

/// A frame [`Bus::pump`] received.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Traffic<'a> {
    /// A classic data or remote frame.
    Can(&'a CanFrame),
    /// A CAN FD frame.
    Fd(&'a FdFrame),
}

impl Traffic<'_> {
    /// The frame's identifier.
    pub(crate) fn id(self) -> canola::CanId {
        match self {
            Self::Can(f) => f.id(),
            Self::Fd(f) => f.id(),
        }
    }
}

/// `--duration SECONDS`: a finite number of seconds, not negative.
pub(crate) fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(_) => Err(format!(
            "`{s}`: give a finite number of seconds, 0 or more (leave the flag out to run until stopped)"
        )),
        Err(e) => Err(format!("`{s}`: {e}")),
    }
}

/// `secs` seconds (negative counts as none).
pub(crate) fn seconds(secs: f64) -> Duration {
    Duration::from_micros((secs.max(0.0) * 1e6) as u64)
}

/// Opens `--iface IFACE` (every form [`canola::BusSpec`] parses: SocketCAN, UDP, slcan).
pub(crate) fn open_transport(iface: &str) -> Result<Box<dyn Transport>, String> {
    open_transport_with(iface, false)
}

/// Opens `--iface IFACE` for CAN FD (`--fd`): a classic-only bus is the library's
/// `FD not supported on ...` error.
pub(crate) fn open_transport_fd(iface: &str) -> Result<Box<dyn Transport>, String> {
    let spec = canola::BusSpec::parse(iface).map_err(|e| e.to_string())?;
    if let Some(w) = spec.warning() {
        eprintln!("warning: {w}");
    }
    spec.open_fd().map_err(|e| e.to_string())
}

/// [`open_transport`], on SocketCAN receiving CAN FD frames too when `fd`. Errors are the
/// library's: they name the bus and carry its hints.
fn open_transport_with(iface: &str, fd: bool) -> Result<Box<dyn Transport>, String> {
    let spec = canola::BusSpec::parse(iface).map_err(|e| e.to_string())?;
    if let Some(w) = spec.warning() {
        eprintln!("warning: {w}");
    }
    spec.open_with(fd).map_err(|e| e.to_string())
}

/// Whether errors print as JSON (`--json`); set once by `main`.
static JSON_ERRORS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Makes [`fail`] print JSON.
pub(crate) fn json_errors(on: bool) {
    JSON_ERRORS.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// Prints `error: ...` (under `--json` one JSON object `{"error": ...}` on stderr) and gives
/// the failure exit code.
pub(crate) fn fail(e: impl std::fmt::Display) -> ExitCode {
    fail_fields(&e.to_string(), serde_json::Map::new())
}

/// [`fail`] with extra JSON fields.
///
/// A text with a hint (`...\nhint: ...`) gives under `--json` the error and the hint as two
/// fields, each once.
fn fail_fields(text: &str, mut fields: serde_json::Map<String, serde_json::Value>) -> ExitCode {
    if JSON_ERRORS.load(std::sync::atomic::Ordering::Relaxed) {
        let (error, hint) = match text.split_once("\nhint: ") {
            Some((e, h)) => (e, Some(h)),
            None => (text, None),
        };
        fields.insert("error".into(), error.into());
        if let Some(h) = hint {
            fields.insert("hint".into(), h.into());
        }
        eprintln!("{}", serde_json::Value::Object(fields));
    } else {
        eprintln!("error: {text}");
    }
    ExitCode::FAILURE
}

/// Prints a warning on stderr: `PREFIX: TEXT` (`warning`, `note`), under `--json` one JSON
/// object `{"warning": TEXT, ...fields}` (the kind in `"level"`), so a script reading stderr
/// line by line as JSON gets JSON.
pub(crate) fn warn(
    prefix: &str,
    text: &str,
    mut fields: serde_json::Map<String, serde_json::Value>,
) {
    if JSON_ERRORS.load(std::sync::atomic::Ordering::Relaxed) {
        fields.insert("warning".into(), text.into());
        fields.insert("level".into(), prefix.into());
        eprintln!("{}", serde_json::Value::Object(fields));
    } else {
        eprintln!("{prefix}: {text}");
    }
}

/// A usage error found after parsing (exit code 2, as clap's), printed as [`fail`] does.
pub(crate) fn fail_usage(e: impl std::fmt::Display) -> ExitCode {
    let _ = fail(e);
    ExitCode::from(2)
}

/// Reports a failed master operation: SDO failures carry node, object, abort code and its
/// meaning as JSON fields, and a timeout a hint.
pub(crate) fn fail_op(e: &canola::Error) -> ExitCode {
    use canola::{Error, SdoErrorKind};
    use serde_json::json;
    let mut fields = serde_json::Map::new();
    let mut text = e.to_string();
    if let Error::Sdo(s) = e {
        fields.insert("node".into(), json!(s.node.get()));
        fields.insert("index".into(), json!(s.entry.index));
        fields.insert("sub".into(), json!(s.entry.sub_index));
        if let Some(name) = &s.name {
            fields.insert("name".into(), json!(name));
        }
        if let Some(code) = s.abort_code() {
            fields.insert("abort_code".into(), json!(format!("{:#010x}", code.get())));
            fields.insert(
                "meaning".into(),
                json!(code.description().unwrap_or("unknown abort code")),
            );
        }
        if matches!(
            s.kind,
            SdoErrorKind::Transfer(canola::sdo::ErrorKind::Timeout)
        ) {
            let hint = format!(
                "hint: nothing answered. Is node {} on this bus (`canopen scan` lists the nodes \
                 that answer), powered, at the same bit rate? On the in-memory bus only \
                 `--eds NODE=FILE` nodes exist.",
                s.node
            );
            text = format!("{text}\n{hint}");
        }
    }
    fail_fields(&text, fields)
}
