//! The bus every bus command runs on, chosen by the global flags every subcommand shares
//! ([`BusOpts`]): SocketCAN with `--iface IFACE`, else an in-memory bus on a virtual clock. On
//! the in-memory bus every `--eds NODE=FILE` node is also simulated (a Bürkert device when the
//! file carries the Bürkert profile, the simulated servo for a CiA 402 drive, the generic
//! simulator otherwise), so every command has a
//! device to talk to without hardware.
//!
//! Also the argument parsers the bus commands share, the warning printer, what SIGINT, SIGTERM
//! and SIGHUP do ([`handle_signals`]: files a command registered are removed before the process
//! ends) and the watch on an slcan adapter that never said anything ([`silent_adapter`]).

use std::process::ExitCode;

use canola::candump::FdFrame;
use canola::mem::MemoryBus;
use canola::transport::{BusEvent, Received, Transport};
use canola::{BusDictionary, CanFrame, Duration, Instant, Network, NodeId, ObjectDictionary};
use clap::Args;

use crate::error::CliError;

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
) -> Result<T, std::num::ParseIntError>
where
    T: std::str::FromStr<Err = std::num::ParseIntError>,
{
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => radix16(h),
        None => s.parse(),
    }
}

/// An object index: `0x` hex or decimal, at most 0xFFFF.
pub(crate) fn parse_u16(s: &str) -> Result<u16, CliError> {
    parse_number(s, |h| u16::from_str_radix(h, 16)).map_err(|e| {
        CliError::Argument(format!(
            "`{s}` is not an object index (0x0000..0xFFFF): `{s}`: {e}"
        ))
    })
}

/// A sub-index: `0x` hex or decimal.
pub(crate) fn parse_u8(s: &str) -> Result<u8, CliError> {
    parse_number(s, |h| u8::from_str_radix(h, 16))
        .map_err(|e| CliError::Argument(format!("`{s}`: {e}")))
}

/// A node-ID 1..=127: `0x` hex or decimal.
pub(crate) fn parse_node(s: &str) -> Result<NodeId, CliError> {
    Ok(NodeId::new(parse_u8(s)?)?)
}

/// `NODE=FILE`: the node and its parsed dictionary.
pub(crate) fn load_eds(spec: &str) -> Result<(NodeId, ObjectDictionary), CliError> {
    let (node, file) = spec
        .split_once('=')
        .ok_or_else(|| CliError::Argument(format!("--eds {spec}: expected NODE=FILE")))?;
    let node = parse_node(node)?;
    Ok((node, read_dictionary(std::path::Path::new(file))?))
}

/// Parses an EDS/DCF file; errors name the file (and the line, from the parser).
pub(crate) fn read_dictionary(path: &std::path::Path) -> Result<ObjectDictionary, CliError> {
    let text = std::fs::read(path).map_err(CliError::file(path))?;
    canola::od::parse(&text)
        .map(|p| p.od)
        .map_err(|source| CliError::Dictionary {
            path: path.to_owned(),
            source,
        })
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
    pub(crate) fn dictionaries(&self) -> Result<Vec<(NodeId, ObjectDictionary)>, CliError> {
        let mut out: Vec<(NodeId, ObjectDictionary)> = Vec::new();
        for spec in &self.node_eds {
            let (node, od) = load_eds(spec)?;
            if out.iter().any(|(n, _)| *n == node) {
                return Err(CliError::Argument(format!(
                    "--eds {spec}: node {node} already has a dictionary (one --eds per node)"
                )));
            }
            out.push((node, od));
        }
        Ok(out)
    }

    /// Opens the bus with the `--eds` dictionaries.
    pub(crate) fn open(&self) -> Result<Bus, CliError> {
        self.open_with(self.dictionaries()?)
    }

    /// Opens the bus with the `--eds` dictionaries to watch its traffic: on SocketCAN CAN FD
    /// frames are received too (see [`Bus::pump`]).
    pub(crate) fn open_watching(&self) -> Result<Bus, CliError> {
        self.open_inner(self.dictionaries()?, true)
    }

    /// Opens the bus with `dictionaries`; on the in-memory bus each node is simulated.
    pub(crate) fn open_with(
        &self,
        dictionaries: Vec<(NodeId, ObjectDictionary)>,
    ) -> Result<Bus, CliError> {
        self.open_inner(dictionaries, false)
    }

    /// Opens the bus to watch it live (`canopen top`): CAN FD frames received on SocketCAN; the
    /// in-memory bus runs on the host's clock at `bitrate` bit/s (its timing model), with the
    /// `--eds` nodes simulated on it.
    pub(crate) fn open_live(&self, bitrate: u32) -> Result<Bus, CliError> {
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
    ) -> Result<Bus, CliError> {
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
pub(crate) fn open_network(opts: &BusOpts) -> Result<(Network, Option<MemoryBus>), CliError> {
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
    ) -> Result<(), CliError> {
        let start = self.transport.now();
        let end = secs.map(|s| start + seconds(s));
        if end.is_none() && self.memory.is_some() {
            return Err(CliError::Argument(
                "on the in-memory bus give --duration SECONDS".into(),
            ));
        }
        loop {
            let now = self.transport.now();
            let deadline = end.map_or(now + Duration::from_millis(200), |e| {
                e.min(now + Duration::from_millis(200))
            });
            if end.is_some_and(|e| now >= e) || stop_requested() {
                return Ok(());
            }
            match self.transport.recv_until(deadline) {
                Ok(Some(Received::Frame { frame, at })) => f(Traffic::Can(&frame), at),
                Ok(Some(Received::Event(BusEvent::FdFrame { frame, at }))) => {
                    f(Traffic::Fd(&frame), at)
                }
                Ok(Some(Received::Event(e))) => eprintln!("bus: {e}"),
                Ok(None) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }
}

/// The number of the first SIGINT or SIGTERM that arrived after [`stop_on_signals`] (0: none).
static STOP: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);

/// Set by [`stop_on_signals`]: the first signal sets [`STOP`] instead of ending the process.
#[cfg(unix)]
static GRACEFUL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set by [`signals_end_normally`]: a signal ends the process with status 0 and this text.
static NORMAL_END: std::sync::Mutex<Option<&'static str>> = std::sync::Mutex::new(None);

/// Whether the signal thread runs (see [`handle_signals`]).
#[cfg(unix)]
static HANDLED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();

/// Whether SIGINT or SIGTERM arrived after [`stop_on_signals`].
pub(crate) fn stop_requested() -> bool {
    STOP.load(std::sync::atomic::Ordering::Relaxed) != 0
}

/// The exit status of a command [`stop_requested`] ended: 128 + the signal's number (130 for
/// SIGINT, 143 for SIGTERM, as a shell reports a process that signal ended), and its name.
pub(crate) fn stopped_by() -> (u8, &'static str) {
    match STOP.load(std::sync::atomic::Ordering::Relaxed) {
        15 => (143, "SIGTERM"),
        1 => (129, "SIGHUP"),
        _ => (130, "SIGINT"),
    }
}

/// Takes SIGINT, SIGTERM and SIGHUP in a thread of their own (`sigwait`), so that the files
/// the command registered with [`remove_on_signal`] (temporary output files, the gateway's
/// Unix sockets) are removed before the process ends: with `error: interrupted by SIGINT` and
/// exit status 128 + the signal's number (130 for SIGINT, 143 for SIGTERM), or as
/// [`stop_on_signals`] and [`signals_end_normally`] ask. `main` calls it first, before any
/// other thread starts: the signals are blocked in the calling thread and so in every thread
/// started later. Calling it again does nothing.
#[cfg(unix)]
pub(crate) fn handle_signals() -> Result<(), CliError> {
    use nix::sys::signal::{SigSet, Signal};
    let mut failed = None;
    HANDLED.get_or_init(|| {
        let mut set = SigSet::empty();
        set.add(Signal::SIGINT);
        set.add(Signal::SIGTERM);
        set.add(Signal::SIGHUP);
        if let Err(e) = set.thread_block() {
            failed = Some(e);
            return false;
        }
        std::thread::spawn(move || {
            while let Ok(signal) = set.wait() {
                on_signal(signal);
            }
        });
        true
    });
    match failed {
        Some(e) => Err(CliError::System {
            what: "cannot block SIGINT".into(),
            source: e.into(),
        }),
        None => Ok(()),
    }
}

/// What a signal does (see [`handle_signals`]).
#[cfg(unix)]
fn on_signal(signal: nix::sys::signal::Signal) {
    use std::sync::atomic::Ordering::Relaxed;
    if GRACEFUL.load(Relaxed)
        && STOP
            .compare_exchange(0, signal as i32, Relaxed, Relaxed)
            .is_ok()
    {
        return;
    }
    remove_registered();
    let normal = *NORMAL_END.lock().unwrap_or_else(|e| e.into_inner());
    let name = signal.as_str();
    if let Some(who) = normal {
        if crate::error::json() {
            eprintln!("{}", serde_json::json!({ "stopped": who, "signal": name }));
        } else {
            eprintln!("{who}: stopped by {name}");
        }
        std::process::exit(0);
    }
    // A command that stops on the first signal has said what it does; this is the second.
    if !GRACEFUL.load(Relaxed) {
        let _ = CliError::Interrupted { signal: name }.report();
    }
    std::process::exit(128 + signal as i32);
}

/// Makes Ctrl-C (SIGINT) and SIGTERM (and SIGHUP) end [`Bus::pump`] at its next turn (within
/// 200 ms), and set [`stop_requested`] for the loops of other commands, instead of ending the
/// process, so `record` can still put its file in place and a drive can be stopped; a second
/// signal ends the process (exit status 128 + its number, 130 for SIGINT) after removing the
/// files registered with [`remove_on_signal`].
#[cfg(unix)]
pub(crate) fn stop_on_signals() -> Result<(), CliError> {
    GRACEFUL.store(true, std::sync::atomic::Ordering::Relaxed);
    handle_signals()
}

/// Makes a signal the normal end of a command that runs until stopped (the gateway): the files
/// registered with [`remove_on_signal`] are removed, `WHO: stopped by SIGTERM` is printed
/// (under `--json` `{"stopped": WHO, "signal": "SIGTERM"}`), and the exit status is 0.
pub(crate) fn signals_end_normally(who: &'static str) {
    *NORMAL_END.lock().unwrap_or_else(|e| e.into_inner()) = Some(who);
}

/// Elsewhere signals end the process as usual.
#[cfg(not(unix))]
pub(crate) fn handle_signals() -> Result<(), CliError> {
    Ok(())
}

/// Elsewhere Ctrl-C ends the process as usual (`record` may then leave its file unwritten).
#[cfg(not(unix))]
pub(crate) fn stop_on_signals() -> Result<(), CliError> {
    Ok(())
}

/// A file to remove when the process ends by a signal: what [`remove_on_signal`] registered.
struct Registered {
    key: u64,
    path: std::path::PathBuf,
    /// Device and inode of the file when it was registered: another file that took its place
    /// since is left alone.
    id: Option<(u64, u64)>,
}

static REGISTERED: std::sync::Mutex<Vec<Registered>> = std::sync::Mutex::new(Vec::new());
static NEXT_KEY: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Device and inode of `path` (the file itself, not what a link points to).
fn file_id(path: &std::path::Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        std::fs::symlink_metadata(path)
            .ok()
            .map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// Removes `path` if it is still the file that was registered.
fn remove_if_same(path: &std::path::Path, id: Option<(u64, u64)>) {
    if id.is_none() || file_id(path) == id {
        let _ = std::fs::remove_file(path);
    }
}

/// Removes every registered file (the process is ending by a signal).
#[cfg(unix)]
fn remove_registered() {
    let list = REGISTERED.lock().unwrap_or_else(|e| e.into_inner());
    for r in list.iter() {
        remove_if_same(&r.path, r.id);
    }
}

/// Registers `path` (which exists now) for removal when the process ends by a signal (see
/// [`handle_signals`]). Dropping the guard takes the registration back and leaves the file;
/// [`SignalGuard::remove`] removes it too.
pub(crate) fn remove_on_signal(path: &std::path::Path) -> SignalGuard {
    let key = NEXT_KEY.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    REGISTERED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(Registered {
            key,
            path: path.to_owned(),
            id: file_id(path),
        });
    SignalGuard { key }
}

/// A file registered with [`remove_on_signal`]; dropped, it is no longer removed.
#[derive(Debug)]
pub(crate) struct SignalGuard {
    key: u64,
}

impl SignalGuard {
    /// Removes the file now (if it is still the one registered) and takes the registration
    /// back.
    pub(crate) fn remove(self) {
        let list = REGISTERED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(r) = list.iter().find(|r| r.key == self.key) {
            remove_if_same(&r.path, r.id);
        }
        // Before `self` takes the registration back.
        drop(list);
    }
}

impl Drop for SignalGuard {
    fn drop(&mut self) {
        REGISTERED
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .retain(|r| r.key != self.key);
    }
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
pub(crate) fn parse_seconds(s: &str) -> Result<f64, CliError> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(_) => Err(CliError::Argument(format!(
            "`{s}`: give a finite number of seconds, 0 or more (leave the flag out to run until stopped)"
        ))),
        Err(e) => Err(CliError::Argument(format!("`{s}`: {e}"))),
    }
}

/// `secs` seconds (negative counts as none).
pub(crate) fn seconds(secs: f64) -> Duration {
    Duration::from_micros((secs.max(0.0) * 1e6) as u64)
}

/// Opens `--iface IFACE` (every form [`canola::BusSpec`] parses: SocketCAN, UDP, slcan).
pub(crate) fn open_transport(iface: &str) -> Result<Box<dyn Transport>, CliError> {
    open_transport_with(iface, false)
}

/// Opens `--iface IFACE` for CAN FD (`--fd`): a classic-only bus is the library's
/// `FD not supported on ...` error.
pub(crate) fn open_transport_fd(iface: &str) -> Result<Box<dyn Transport>, CliError> {
    let spec = canola::BusSpec::parse(iface)?;
    if let Some(w) = spec.warning() {
        eprintln!("warning: {w}");
    }
    Ok(spec.open_fd()?)
}

/// [`open_transport`], on SocketCAN receiving CAN FD frames too when `fd`. Errors are the
/// library's: they name the bus and carry its hints. An slcan adapter is watched (see
/// [`silent_adapter`]).
fn open_transport_with(iface: &str, fd: bool) -> Result<Box<dyn Transport>, CliError> {
    let spec = canola::BusSpec::parse(iface)?;
    if let Some(w) = spec.warning() {
        eprintln!("warning: {w}");
    }
    if let canola::BusSpec::Slcan(_) = &spec {
        let adapter = spec.open_slcan()?;
        *SLCAN.lock().unwrap_or_else(|e| e.into_inner()) = Some(SlcanWatch {
            name: iface.to_owned(),
            acknowledges: adapter.link().acknowledges(),
            stats: adapter.stats(),
        });
        return Ok(Box::new(adapter));
    }
    Ok(spec.open_with(fd)?)
}

/// What is known of the slcan adapter the command opened: whether it acknowledged the commands
/// that opened it, and its counters (frames received).
struct SlcanWatch {
    name: String,
    acknowledges: bool,
    stats: canola::slcan::SlcanStats,
}

static SLCAN: std::sync::Mutex<Option<SlcanWatch>> = std::sync::Mutex::new(None);

/// An error when the bus is an slcan adapter that acknowledged none of the commands that opened
/// it and sent no frame at all since: a silent serial device looks just like an empty bus, so
/// a command that lists what it heard (`scan`, `nmt state`) says so instead of printing an
/// empty list.
pub(crate) fn silent_adapter() -> Option<CliError> {
    let watch = SLCAN.lock().unwrap_or_else(|e| e.into_inner());
    let w = watch.as_ref()?;
    if w.acknowledges || w.stats.frames_rx() > 0 {
        return None;
    }
    Some(CliError::Device(format!(
        "{}: the adapter acknowledged no command and no frame arrived, so nothing was heard \
             from the bus\nhint: either what is at this path is not an slcan adapter that \
             answers (another device, a serial speed the adapter does not use, an adapter not \
             powered) or it is one that never acknowledges (CANable slcan firmware) on a bus \
             where no node sent anything (nodes off, another bit rate: give slcan:PATH@BITRATE, \
             no termination); `canopen adapter info --iface {}` shows what it answers",
        w.name, w.name
    )))
}

/// Reports `e` (see [`CliError::report`]) and gives the exit code.
pub(crate) fn fail(e: impl Into<CliError>) -> ExitCode {
    e.into().report()
}

/// Prints a warning on stderr: `PREFIX: TEXT` (`warning`, `note`), under `--json` one JSON
/// object `{"warning": TEXT, ...fields}` (the kind in `"level"`), so a script reading stderr
/// line by line as JSON gets JSON.
pub(crate) fn warn(
    prefix: &str,
    text: &str,
    mut fields: serde_json::Map<String, serde_json::Value>,
) {
    if crate::error::json() {
        fields.insert("warning".into(), text.into());
        fields.insert("level".into(), prefix.into());
        eprintln!("{}", serde_json::Value::Object(fields));
    } else {
        eprintln!("{prefix}: {text}");
    }
}
