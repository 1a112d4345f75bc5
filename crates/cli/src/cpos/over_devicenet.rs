//! `canopen cpos` over DeviceNet: the options, the driver loop of the client's DeviceNet master
//! on a CAN transport, and `canopen cpos simulate` (the simulated cPos behind a DeviceNet
//! slave).

use canola::frame::is_due;
use std::process::ExitCode;

use canola::mem::MemoryBus;
use canola::transport::{Received, Station, Transport};
use canola::{CanFrame, Duration, Instant};
use canola_devicenet::explicit::Path;
use canola_devicenet::{MacId, Slave, SlaveEvent};
use canola_gemu::client::{Client, Event};
use canola_gemu::over_devicenet::{
    CposEvent, CposMaster, CposMasterConfig, CposSlave, ImageSizes, cpos_slave_config,
};
use clap::Args;
use serde_json::json;

use super::SimArgs;
use crate::Global;
use crate::error::CliError;

fn parse_mac(s: &str) -> Result<u8, CliError> {
    let v: u8 = s
        .parse()
        .map_err(|e| CliError::Argument(format!("`{s}`: {e}")))?;
    MacId::new(v)
        .map(MacId::get)
        .map_err(|e| CliError::Argument(e.to_string()))
}

fn parse_num(s: &str) -> Result<u8, CliError> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u8::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|e| CliError::Argument(format!("`{s}`: {e}")))
}

fn parse_path(s: &str) -> Result<Path, CliError> {
    let parts: Vec<&str> = s.split('/').collect();
    let [c, i, a] = parts[..] else {
        return Err(CliError::Argument(format!(
            "`{s}`: expected CLASS/INSTANCE/ATTRIBUTE, e.g. 0x64/1/1"
        )));
    };
    Ok(Path::new(parse_num(c)?, parse_num(i)?, parse_num(a)?))
}

/// DeviceNet options of `canopen cpos` (used with --iface, and by `cpos simulate`).
#[derive(Debug, Args)]
pub(crate) struct DnOpts {
    /// The cPos's DeviceNet MAC ID ("DeviceNet Adr", 63 as delivered).
    #[arg(long, global = true, default_value = "63", value_parser = parse_mac)]
    mac: u8,
    /// The master's own MAC ID.
    #[arg(long, global = true, default_value = "0", value_parser = parse_mac)]
    master_mac: u8,
    /// Poll cycle in ms (also the poll connection's expected packet rate; the cPos drops the
    /// connection after 4 cycles without a poll).
    #[arg(long, global = true, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    cycle_ms: u64,
    /// "Data send" bytes (master → cPos: 0, 2, 4, 5 or 13): the size expected at connect, or
    /// the simulated cPos's setting.
    #[arg(long, global = true, default_value_t = 13)]
    send: u16,
    /// "Data receive" bytes (cPos → master: 0, 2, 3 or 11), likewise.
    #[arg(long, global = true, default_value_t = 11)]
    receive: u16,
    /// Read external diagnostic codes from this attribute (CLASS/INSTANCE/ATTRIBUTE) after
    /// every answer; the simulated cPos serves them at 0x64/1/1. The manual does not say where a
    /// real cPos puts them.
    #[arg(long, global = true, value_name = "PATH", value_parser = parse_path)]
    diagnostic_attribute: Option<Path>,
    /// Give up connecting after this many seconds.
    #[arg(long, global = true, default_value_t = 10.0)]
    connect_timeout: f64,
    /// Without --iface: carry the image over DeviceNet on the in-memory bus to a simulated cPos
    /// (virtual clock; its diagnostics are read from 0x64/1/1), instead of handing it to the
    /// simulator in-process.
    #[arg(long, global = true)]
    pub(crate) over_devicenet: bool,
}

impl DnOpts {
    fn sizes(&self) -> Result<ImageSizes, CliError> {
        ImageSizes {
            send: self.send,
            receive: self.receive,
        }
        .check()
        .map_err(|e| CliError::Argument(e.to_string()))
    }
    fn mac(&self) -> MacId {
        MacId::from_bits(self.mac)
    }
}

/// The client's DeviceNet master on a CAN transport.
pub(crate) struct Link {
    master: CposMaster,
    transport: Box<dyn Transport>,
    /// The in-memory bus (kept alive) when the cPos is simulated on it.
    _memory: Option<MemoryBus>,
}

/// Opens `iface` as every bus command does (SocketCAN or `udp`, with the hint for an interface
/// that does not exist).
fn open(iface: &str) -> Result<Box<dyn Transport>, CliError> {
    crate::bus::open_transport(iface)
}

impl Link {
    /// Opens `iface`, goes on line and connects to the cPos; fails if that does not happen
    /// within the connect timeout or the cPos's sizes do not fit.
    pub(crate) fn connect(opts: &DnOpts, iface: &str) -> Result<Self, CliError> {
        Self::connect_on(opts, open(iface)?, None, opts.diagnostic_attribute)
    }

    /// A simulated cPos at --mac on a fresh in-memory bus, and the master connected to it.
    pub(crate) fn connect_simulated(opts: &DnOpts, sim: &SimArgs) -> Result<Self, CliError> {
        let bus = MemoryBus::new();
        let endpoint = bus.endpoint();
        let config = cpos_slave_config(opts.mac(), opts.sizes()?, 0x1436_0000 | opts.mac as u32);
        let mut slave = Slave::new(config, CposSlave::new(sim.simulator()));
        slave.start(bus.now());
        bus.attach(SimStation {
            slave,
            json: false,
            quiet: true,
        });
        let diag = opts
            .diagnostic_attribute
            .or(Some(canola_gemu::over_devicenet::SIM_DIAGNOSTIC_PATH));
        Self::connect_on(opts, Box::new(endpoint), Some(bus), diag)
    }

    fn connect_on(
        opts: &DnOpts,
        transport: Box<dyn Transport>,
        memory: Option<MemoryBus>,
        diagnostics: Option<Path>,
    ) -> Result<Self, CliError> {
        let mut config = CposMasterConfig::new(opts.mac());
        config.master.mac = MacId::from_bits(opts.master_mac);
        config.master.poll_cycle = Duration::from_millis(opts.cycle_ms);
        config.expected_sizes = Some(opts.sizes()?);
        config.diagnostics = diagnostics;
        let mut master = CposMaster::new(config);
        master.start(transport.now());
        let mut link = Self {
            master,
            transport,
            _memory: memory,
        };
        let limit = link.now() + Duration::from_micros((opts.connect_timeout * 1e6) as u64);
        let mut last_failure = None;
        while !link.master.is_connected() {
            if link.now() >= limit {
                return Err(CliError::Device(match last_failure {
                    Some(e) => format!("no DeviceNet connection to MAC {}: {e}", opts.mac),
                    None => format!("no DeviceNet connection to MAC {} (no answer)", opts.mac),
                }));
            }
            let until = link.now() + Duration::from_millis(50);
            for e in link.step(until) {
                match e {
                    CposEvent::SizeMismatch(e) => {
                        return Err(CliError::Device(format!("MAC {}: {e}", opts.mac)));
                    }
                    CposEvent::DuplicateMac(c) => {
                        return Err(CliError::Device(format!(
                            "another station uses the master's MAC ID {} ({c})",
                            opts.master_mac
                        )));
                    }
                    CposEvent::ConnectFailed(e) => last_failure = Some(e.to_string()),
                    _ => {}
                }
            }
        }
        if !link.master.has_channel() {
            let sizes = link.master.sizes().map_or(String::new(), |s| s.to_string());
            return Err(CliError::Device(format!(
                "the cPos at MAC {} is set to {sizes}: no parameter channel (it needs send 13 / receive 11)",
                opts.mac
            )));
        }
        Ok(link)
    }

    pub(crate) fn now(&self) -> Instant {
        self.transport.now()
    }

    pub(crate) fn client(&mut self) -> &mut Client {
        self.master.client_mut()
    }

    /// Sends, receives and fires timers until `until`; returns the DeviceNet events. A failing
    /// transport ends the process (nothing can be done without the bus).
    fn step(&mut self, until: Instant) -> Vec<CposEvent> {
        let mut out = Vec::new();
        loop {
            while let Some(f) = self.master.poll_transmit() {
                if let Err(e) = self.transport.send(&f) {
                    // As every error: JSON under --json.
                    let _ = CliError::System {
                        what: "cannot send".into(),
                        source: std::io::Error::other(e.to_string()),
                    }
                    .report();
                    std::process::exit(1);
                }
            }
            let now = self.transport.now();
            if now >= until {
                return out;
            }
            let deadline = self.master.poll_timeout().map_or(until, |t| t.min(until));
            match self.transport.recv_until(deadline) {
                Ok(Some(Received::Frame { frame, at })) => self.master.handle_frame(at, &frame),
                Ok(_) => {}
                Err(e) => {
                    let _ = CliError::System {
                        what: "cannot receive".into(),
                        source: std::io::Error::other(e.to_string()),
                    }
                    .report();
                    std::process::exit(1);
                }
            }
            let now = self.transport.now();
            if is_due(self.master.poll_timeout(), now) {
                self.master.handle_timeout(now);
            }
            while let Some(e) = self.master.poll_event() {
                out.push(e);
            }
        }
    }

    /// Runs until `until`, appending the client's events.
    pub(crate) fn pump(&mut self, until: Instant, events: &mut Vec<(Instant, Event)>) {
        for e in self.step(until) {
            let now = self.now();
            match e {
                CposEvent::Client(e) => events.push((now, e)),
                CposEvent::ConnectionLost => {
                    eprintln!("note: DeviceNet connection lost, reconnecting")
                }
                CposEvent::Connected { .. } => eprintln!("note: DeviceNet reconnected"),
                CposEvent::BadImage(e) => eprintln!("warning: bad image from the cPos: {e}"),
                _ => {}
            }
        }
    }
}

impl Drop for Link {
    /// Releases the connection set, so the next command connects at once.
    fn drop(&mut self) {
        let now = self.transport.now();
        self.master.disconnect(now);
        while let Some(f) = self.master.poll_transmit() {
            let _ = self.transport.send(&f);
        }
    }
}

/// The simulated cPos's DeviceNet slave as a station, printing its events.
struct SimStation {
    slave: Slave<CposSlave>,
    json: bool,
    quiet: bool,
}

impl SimStation {
    fn report(&mut self, now: Instant) {
        while let Some(e) = self.slave.poll_event() {
            if self.quiet {
                continue;
            }
            let text = match &e {
                SlaveEvent::Online => "on line (Duplicate MAC ID check passed)".to_owned(),
                SlaveEvent::DuplicateMac(c) => format!("duplicate MAC ID: {c}"),
                SlaveEvent::Allocated { master, choice } => {
                    format!("allocated by {master}: {choice}")
                }
                SlaveEvent::Released(c) => format!("released: {c}"),
                SlaveEvent::Connection(c, s) => format!("{c:?} connection: {s:?}"),
                SlaveEvent::PollSizeMismatch { actual, expected } => {
                    format!("poll command of {actual} bytes ignored (expected {expected})")
                }
            };
            if self.json {
                crate::outln(
                    &json!({ "time": now.as_micros() as f64 / 1e6, "event": text }).to_string(),
                );
            } else {
                crate::outln(&format!("{now}  {text}"));
            }
        }
    }
}

impl Station for SimStation {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.slave.handle_frame(now, frame);
        self.report(now);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.slave.handle_timeout(now);
        self.report(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.slave.poll_transmit()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.slave.poll_timeout()
    }
}

/// `canopen cpos simulate`.
pub(crate) fn simulate(
    sim: &SimArgs,
    opts: &DnOpts,
    iface: Option<&str>,
    duration: Option<f64>,
    global: Global,
) -> ExitCode {
    let fail = |e: CliError| e.report();
    let sizes = match opts.sizes() {
        Ok(s) => s,
        Err(e) => return fail(e),
    };
    let config = cpos_slave_config(opts.mac(), sizes, 0x1436_0000 | opts.mac as u32);
    let mut station = SimStation {
        slave: Slave::new(config, CposSlave::new(sim.simulator())),
        json: global.json,
        quiet: false,
    };
    match iface {
        Some(iface) => {
            let mut transport = match open(iface) {
                Ok(t) => t,
                Err(e) => return fail(e),
            };
            station.slave.start(transport.now());
            if !global.json {
                crate::outln(&format!(
                    "simulated GEMÜ 1436 cPos on {iface}: DeviceNet MAC {}, {sizes}",
                    opts.mac
                ));
            }
            // Runs until killed, or for --duration.
            let started = std::time::Instant::now();
            let limit = duration.map(std::time::Duration::from_secs_f64);
            let r = canola::transport::run_station(&mut *transport, &mut station, || {
                limit.is_some_and(|l| started.elapsed() >= l)
            });
            match r {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => fail(CliError::Transport(e)),
            }
        }
        None => {
            let Some(d) = duration else {
                return fail(CliError::Argument(
                    "--duration is required on the in-memory bus".into(),
                ));
            };
            let bus = MemoryBus::new();
            station.slave.start(bus.now());
            bus.attach(station);
            bus.run_for(Duration::from_micros((d * 1e6) as u64));
            ExitCode::SUCCESS
        }
    }
}
