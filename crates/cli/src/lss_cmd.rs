//! `canopen lss ...`: the LSS master services of CiA 305.
//!
//! On the in-memory bus, `--unconfigured N` adds N simulated devices without a node-ID (the
//! Bürkert generic EDS, serial numbers 1001, 1002, ...) so the services have slaves to find;
//! `--real-slaves` makes them answer Fastscan in LSS configuration state as real slaves do,
//! `--store-unsupported` makes them refuse store configuration (error 1), `--running IDS` adds
//! configured devices running with those node-IDs (the nodes of a live network), and
//! `--record-bus FILE` writes every frame the bus carried to a candump log.
//!
//! Node-IDs in use are never given: `assign-all` leaves out and reports those heard or
//! answering before the run and those heard during it ([`canola::Lss::assign_all`]), and
//! `configure-node-id` refuses one in use unless `--force`. Nor is one node-ID given to several
//! slaves: `configure-node-id` configures only when exactly one slave answers after switch
//! mode global (every LSS slave enters configuration state), or the one picked by `--address`.

use canola::frame::is_due;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use canola::candump::{LogEntry, LogFrame, Writer};
use canola::lss::{
    AssignConfig, AssignOutcome, BitRate, BitTiming, FastscanConfig, LssAddress, Mode, NodeIdPool,
    Procedure, SlaveConfig, Step, StoreSupport,
};
use canola::{CanFrame, Duration, Instant, NodeId};
use canola::{MemoryBus, SimDevice, Station};
use clap::{Args, Subcommand};
use serde_json::json;

use crate::bus::{BusOpts, fail, open_network};
use crate::error::CliError;
use crate::{Global, outln};

const BURKERT_EDS: &[u8] = canola_burkert::GENERIC_EDS.as_bytes();

#[derive(Debug, Args)]
pub(crate) struct LssArgs {
    /// In-memory bus only: simulate this many unconfigured devices.
    #[arg(long, default_value_t = 0)]
    unconfigured: u32,
    /// In-memory bus only: the simulated devices answer Fastscan in LSS configuration state
    /// too, as real slaves do.
    #[arg(long)]
    real_slaves: bool,
    /// In-memory bus only: the simulated devices do not support store configuration (they
    /// answer error 1, as some real slaves do).
    #[arg(long)]
    store_unsupported: bool,
    /// In-memory bus only: write every frame the bus carried to FILE (candump log format).
    #[arg(long, value_name = "FILE")]
    record_bus: Option<std::path::PathBuf>,
    /// In-memory bus only: also simulate configured devices running (Operational, sending
    /// heartbeats) with these node-IDs, e.g. `5,6`: the nodes already on a live network.
    #[arg(long, value_name = "IDS", value_delimiter = ',', value_parser = clap::value_parser!(u8).range(1..=127))]
    running: Vec<u8>,
    /// Fastscan (fastscan, discover-all, assign-all): how long to wait for an answer at each
    /// step, in ms. A scan takes about 133 steps per slave, each silent one costs this timeout
    /// (one slave: about 2 s at 25 ms); raise it for slow slaves, emulated or loaded buses.
    #[arg(long, value_name = "MS", default_value_t = 25, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    step_timeout: u64,
    #[command(subcommand)]
    command: LssCommand,
}

/// A station on the in-memory bus that keeps every frame it sees, as candump log lines.
struct Recorder(Arc<Mutex<Vec<LogEntry>>>);

impl Station for Recorder {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        let entry = LogEntry {
            timestamp_us: now.as_micros(),
            interface: "mem".into(),
            frame: LogFrame::Can(*frame),
            len8_dlc: None,
        };
        self.0.lock().unwrap_or_else(|p| p.into_inner()).push(entry);
    }
    fn handle_timeout(&mut self, _now: Instant) {}
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        None
    }
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
}

/// Lets the in-memory bus deliver what was handed to it (and nothing the master still holds
/// back), then writes the recorded frames to `path`.
fn write_record(
    mem: &MemoryBus,
    log: &Mutex<Vec<LogEntry>>,
    path: &std::path::Path,
) -> Result<(), CliError> {
    mem.run_for(Duration::from_millis(1));
    let entries = std::mem::take(&mut *log.lock().unwrap_or_else(|p| p.into_inner()));
    let out = crate::outfile::OutFile::create(path)?;
    let mut w = Writer::new(std::io::BufWriter::new(out.writer()?));
    for e in &entries {
        w.write(e).map_err(CliError::file(path))?;
    }
    w.flush().map_err(CliError::file(path))?;
    out.commit()
}

#[derive(Debug, Subcommand)]
pub(crate) enum LssCommand {
    #[command(flatten)]
    Master(MasterCommand),
    /// Run the --unconfigured devices (default 1) as LSS slaves on the interface (--iface),
    /// until stopped or for --duration seconds: the peers for the other commands in another
    /// process.
    Simulate {
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
    },
}

/// The LSS master's commands.
#[derive(Debug, Subcommand)]
pub(crate) enum MasterCommand {
    /// Switch mode global: `config` or `waiting`.
    SwitchGlobal {
        /// `config` or `waiting`.
        mode: String,
    },
    /// Switch mode selective to the slave with this address.
    SwitchSelective {
        /// Vendor-ID.
        vendor: String,
        /// Product code.
        product: String,
        /// Revision number.
        revision: String,
        /// Serial number.
        serial: String,
    },
    /// Configure node-ID of the one LSS slave on the bus (switch global, configure, store,
    /// switch back), or of the slave with --address; a slave without store support is
    /// reported "assigned, not stored".
    ///
    /// Switch global puts every LSS slave in configuration state, configured or not, and each
    /// would take the node-ID: unless exactly one answers an inquiry of its LSS address,
    /// nothing is configured (use `assign-all`, or pick one slave with --address). A node-ID
    /// in use on the bus (heard, or answering an SDO read of 0x1000) is refused: two nodes
    /// with one node-ID break both.
    ConfigureNodeId {
        /// The new node-ID.
        node_id: u8,
        /// Configure only the slave with this LSS address (switch mode selective), so other
        /// slaves may be on the bus; `discover-all` lists the unconfigured slaves' addresses.
        #[arg(long, value_name = "VENDOR,PRODUCT,REVISION,SERIAL")]
        address: Option<String>,
        /// Do not store the configuration.
        #[arg(long)]
        no_store: bool,
        /// Configure the node-ID even when a node on the bus uses it.
        #[arg(long)]
        force: bool,
    },
    /// Change the bit rate of the slave(s) in configuration state (kbit/s: 1000, 800, 500,
    /// 250, 125, 100, 50, 20, 10).
    SetBitRate {
        /// Bit rate in kbit/s.
        kbit: u32,
        /// Switch delay in ms.
        #[arg(long, default_value_t = 100)]
        delay: u16,
    },
    /// Store configuration.
    Store,
    /// Inquire identity and node-ID of the slave in configuration state.
    Inquire,
    /// Is any unconfigured slave on the bus?
    IdentifyNonConfigured,
    /// Fastscan: find one unconfigured slave.
    Fastscan,
    /// Find every unconfigured slave.
    DiscoverAll,
    /// Assign-all: find every unconfigured slave and give each a node-ID from FIRST..=LAST
    /// (configure, store, back to waiting, one slave at a time; a slave that does not support
    /// store is reported "assigned, not stored"). Node-IDs in use on the bus (heard, or
    /// answering an SDO read, before or during the run) are not handed out; each is reported.
    AssignAll {
        /// First node-ID of the pool.
        #[arg(long, default_value_t = 2)]
        first: u8,
        /// Last node-ID of the pool.
        #[arg(long, default_value_t = 127)]
        last: u8,
    },
}

fn num(s: &str) -> Result<u32, std::num::ParseIntError> {
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    }
}

/// An LSS address in text, in the number style of every command (`--hex`).
fn addr_text(a: &LssAddress, g: Global) -> String {
    format!(
        "vendor-id {}, product {}, revision {}, serial {}",
        g.u32(a.vendor_id),
        g.u32(a.product_code),
        g.u32(a.revision_number),
        g.u32(a.serial_number)
    )
}

/// One line of the assign-all report.
fn entry_text(e: &canola::lss::AssignEntry, g: Global) -> String {
    let what = match (e.node_id, e.outcome) {
        (Some(id), AssignOutcome::Assigned) => format!("node-ID {id}"),
        (Some(id), AssignOutcome::StoreFailed(err)) => {
            format!("node-ID {id} assigned, not stored: {err}")
        }
        (Some(id), AssignOutcome::Failed(err)) => format!("node-ID {id} failed: {err}"),
        (None, AssignOutcome::Failed(err)) => format!("failed: {err}"),
        (None, _) => "no node-ID".into(),
    };
    format!("{}: {what}", addr_text(&e.address, g))
}

/// How long a node-ID check waits for an SDO answer.
const IN_USE_TIMEOUT_MS: u64 = 100;

/// Refuses `id` when a node on the bus uses it (heard, or answering an SDO read), unless
/// `force`.
fn in_use_check(lss: &canola::Lss, id: NodeId, force: bool) -> Result<(), CliError> {
    if force {
        return Ok(());
    }
    let one: NodeIdPool = std::iter::once(id).collect();
    let in_use = lss
        .nodes_in_use(one, Duration::from_millis(IN_USE_TIMEOUT_MS))
        .wait()?;
    if in_use.contains(id) {
        // What the bus says, not a wrong command line: exit 1.
        return Err(CliError::Device(format!(
            "node-ID {id} is in use on the bus (a node answers or was heard with it): \
             not configured; give --force to configure it anyway"
        )));
    }
    Ok(())
}

/// An LSS address given as `VENDOR,PRODUCT,REVISION,SERIAL` (0x hex or decimal each).
fn parse_address(text: &str) -> Result<LssAddress, CliError> {
    let parts: Vec<Result<u32, _>> = text.split(',').map(|p| num(p.trim())).collect();
    match parts[..] {
        [Ok(v), Ok(p), Ok(r), Ok(s)] => Ok(LssAddress::new(v, p, r, s)),
        _ => Err(CliError::usage(format!(
            "--address {text}: give VENDOR,PRODUCT,REVISION,SERIAL, four numbers (0x hex or \
             decimal)"
        ))),
    }
}

/// Several slaves answered after switch mode global: nothing was configured; say what to do.
fn several_slaves(e: canola::Error) -> CliError {
    match e {
        canola::Error::Lss(canola::lss::LssError::SeveralSlaves { .. }) => {
            CliError::Device(format!(
                "{e}; nothing was configured and the slaves are back in waiting state\n\
                 hint: give each unconfigured slave a node-ID with `canopen lss assign-all`, or \
                 configure one by its LSS address (switch mode selective) with \
                 `canopen lss configure-node-id N --address VENDOR,PRODUCT,REVISION,SERIAL` \
                 (`canopen lss discover-all` lists the unconfigured slaves' addresses)"
            ))
        }
        e => CliError::from(e),
    }
}

const NONE_ANSWERED: &str = "no unconfigured slave answered";

fn addr_json(a: &LssAddress) -> serde_json::Value {
    json!({"vendor_id": a.vendor_id, "product_code": a.product_code,
           "revision": a.revision_number, "serial": a.serial_number})
}

/// `canopen lss ...`
pub(crate) fn run(args: LssArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let master = match args.command {
        LssCommand::Simulate { duration } => return simulate(opts, &args, duration),
        LssCommand::Master(m) => m,
    };
    if let MasterCommand::AssignAll { first, last } = master
        && first > last
    {
        return CliError::usage(format!(
            "empty node-ID pool: --first {first} is above --last {last}"
        ))
        .report();
    }
    let (net, mem) = match open_network(opts) {
        Ok(x) => x,
        Err(e) => return fail(e),
    };
    let simulated = args.unconfigured > 0
        || args.real_slaves
        || args.store_unsupported
        || !args.running.is_empty();
    if mem.is_none() && (simulated || args.record_bus.is_some()) {
        return fail(CliError::Argument(
            "--unconfigured, --real-slaves, --store-unsupported, --running and --record-bus only work on the in-memory bus".into(),
        ));
    }
    let log = Arc::new(Mutex::new(Vec::new()));
    if let (Some(mem), Some(_)) = (mem.as_ref(), args.record_bus.as_ref()) {
        mem.attach(Recorder(log.clone()));
    }
    if let Some(mem) = mem.as_ref() {
        match devices(args.unconfigured, args.real_slaves, args.store_unsupported) {
            Ok(devices) => {
                for d in devices {
                    mem.attach(d);
                }
            }
            Err(e) => return fail(e),
        }
        if let Err(e) = running(mem, &net, &args.running) {
            return fail(e);
        }
    }
    let code = command(&net, master, args.step_timeout, g);
    if let (Some(mem), Some(path)) = (mem.as_ref(), args.record_bus.as_ref())
        && let Err(e) = write_record(mem, &log, path)
    {
        return fail(e);
    }
    code
}

/// `count` simulated unconfigured devices (the Bürkert generic EDS, serial numbers 1001, 1002,
/// ...), answering Fastscan in configuration state when `real_slaves`.
fn devices(
    count: u32,
    real_slaves: bool,
    store_unsupported: bool,
) -> Result<Vec<SimDevice>, CliError> {
    if count == 0 {
        return Ok(Vec::new());
    }
    let od = canola::od::parse(BURKERT_EDS)
        .map_err(CliError::BuiltinDictionary)?
        .od;
    Ok((0..count)
        .map(|i| {
            let a = LssAddress::new(0x39, 0x0100_0001, 1, 1001 + i);
            let mut slave = SlaveConfig::unconfigured(a);
            slave.fastscan_in_configuration = real_slaves;
            if store_unsupported {
                slave.store = StoreSupport::NotSupported;
            }
            SimDevice::unconfigured_with(od.clone(), slave)
        })
        .collect())
}

/// Attaches configured devices (the Bürkert generic EDS) with node-IDs `ids` and starts them
/// (NMT start), so that they run and send heartbeats as the nodes of a live network do.
fn running(mem: &MemoryBus, net: &canola::Network, ids: &[u8]) -> Result<(), CliError> {
    if ids.is_empty() {
        return Ok(());
    }
    for &id in ids {
        let node = NodeId::new(id)?;
        let dev = SimDevice::from_eds(node, BURKERT_EDS).map_err(CliError::BuiltinDictionary)?;
        mem.attach(dev);
    }
    // Boot-ups, then NMT start of each, then their first heartbeats.
    net.run_for(Duration::from_millis(10)).wait()?;
    for &id in ids {
        let node = NodeId::new(id)?;
        net.node(node).nmt().start()?;
    }
    Ok(net.run_for(Duration::from_millis(10)).wait()?)
}

/// Several simulated devices as one station on one socket.
struct Devices(Vec<SimDevice>);

impl Station for Devices {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        for d in &mut self.0 {
            d.handle_frame(now, frame);
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        for d in &mut self.0 {
            if is_due(d.poll_timeout(), now) {
                d.handle_timeout(now);
            }
        }
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.0.iter_mut().find_map(|d| d.poll_transmit())
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.0.iter().filter_map(|d| d.poll_timeout()).min()
    }
}

/// `canopen --iface IF lss --unconfigured N simulate`
fn simulate(opts: &BusOpts, args: &LssArgs, duration: Option<f64>) -> ExitCode {
    let Some(iface) = opts.iface.as_deref() else {
        return fail(CliError::Argument(
            "lss simulate runs the devices on an interface: give --iface".into(),
        ));
    };
    let limit = match duration {
        Some(d) if d.is_finite() && d >= 0.0 => Some(std::time::Duration::from_secs_f64(d)),
        Some(d) => {
            return fail(CliError::Argument(format!(
                "--duration {d}: give a number of seconds"
            )));
        }
        None => None,
    };
    let mut devices = match devices(
        args.unconfigured.max(1),
        args.real_slaves,
        args.store_unsupported,
    ) {
        Ok(d) => Devices(d),
        Err(e) => return fail(e),
    };
    let mut transport = match crate::bus::open_transport(iface) {
        Ok(t) => t,
        Err(e) => return fail(e),
    };
    eprintln!(
        "simulating {} unconfigured LSS slave(s) on {iface}{}",
        devices.0.len(),
        if args.real_slaves {
            " (answering Fastscan in configuration state)"
        } else {
            ""
        }
    );
    let started = std::time::Instant::now();
    match canola::run_station(&mut transport, &mut devices, || {
        limit.is_some_and(|l| started.elapsed() >= l)
    }) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

fn command(
    net: &canola::Network,
    command: MasterCommand,
    step_timeout: u64,
    g: Global,
) -> ExitCode {
    let lss = net.lss();
    let fastscan = FastscanConfig {
        response_timeout: Duration::from_millis(step_timeout),
        ..FastscanConfig::default()
    };
    let proc1 = |step| Procedure::single(step);
    let result: Result<serde_json::Value, CliError> = match command {
        MasterCommand::SwitchGlobal { mode } => {
            let m = match mode.as_str() {
                "config" | "configuration" => Mode::Configuration,
                "waiting" | "operation" => Mode::Waiting,
                other => {
                    return fail(CliError::Argument(format!(
                        "mode `{other}`: use config or waiting"
                    )));
                }
            };
            lss.procedure(proc1(Step::SwitchModeGlobal(m)))
                .wait()
                .map(|_| json!({"ok": true}))
                .map_err(CliError::from)
        }
        MasterCommand::SwitchSelective {
            vendor,
            product,
            revision,
            serial,
        } => {
            let parts = [&vendor, &product, &revision, &serial].map(|s| num(s));
            match parts {
                [Ok(v), Ok(p), Ok(r), Ok(s)] => lss
                    .procedure(proc1(Step::SwitchModeSelective(LssAddress::new(
                        v, p, r, s,
                    ))))
                    .wait()
                    .map(|_| json!({"ok": true}))
                    .map_err(CliError::from),
                _ => Err(CliError::Argument(
                    "address parts must be numbers (0x hex or decimal)".into(),
                )),
            }
        }
        MasterCommand::ConfigureNodeId {
            node_id,
            address,
            no_store,
            force,
        } => match (NodeId::new(node_id), address.as_deref().map(parse_address)) {
            (Err(e), _) => Err(e.into()),
            (_, Some(Err(e))) => Err(e),
            (Ok(n), address) => match in_use_check(&lss, n, force) {
                Err(e) => Err(e),
                Ok(()) => lss
                    .procedure(match address {
                        Some(Ok(a)) => Procedure::assign_node_id_selective(a, n, !no_store),
                        _ => Procedure::assign_node_id(n, !no_store),
                    })
                    .wait()
                    .map(|r| {
                        let stored = r.stored == Some(true);
                        if !g.json {
                            outln(&match r.stored {
                                Some(true) => format!("node-ID {node_id} assigned and stored"),
                                Some(false) => format!(
                                    "node-ID {node_id} assigned, not stored: the slave does not \
                                     support store configuration (it takes effect now, and is \
                                     lost at power-off)"
                                ),
                                None => {
                                    format!("node-ID {node_id} assigned, not stored (--no-store)")
                                }
                            });
                        }
                        json!({"node_id": node_id, "stored": stored})
                    })
                    .map_err(several_slaves),
            },
        },
        MasterCommand::SetBitRate { kbit, delay } => {
            match BitRate::ALL
                .into_iter()
                .find(|r| r.bits_per_second() == Some(kbit * 1000))
            {
                Some(rate) => lss
                    .procedure(Procedure::change_bit_rate(BitTiming::standard(rate), delay))
                    .wait()
                    .map(|_| {
                        if !g.json {
                            outln(&format!("bit rate {kbit} kbit/s configured"));
                        }
                        json!({"kbit": kbit})
                    })
                    .map_err(CliError::from),
                None => Err(CliError::Argument(format!(
                    "{kbit} kbit/s is not in the CiA bit timing table"
                ))),
            }
        }
        MasterCommand::Store => lss
            .procedure(proc1(Step::StoreConfiguration))
            .wait()
            .map(|_| json!({"ok": true}))
            .map_err(CliError::from),
        MasterCommand::Inquire => lss
            .procedure(Procedure::inquire_all())
            .wait()
            .map(|r| {
                if !g.json {
                    let id = r
                        .address()
                        .map_or("identity incomplete".into(), |a| addr_text(&a, g));
                    let node = r.node_id.map_or("-".into(), |n| n.to_string());
                    outln(&format!("{id}, node-ID {node}"));
                }
                json!({"identity": r.address().map(|a| addr_json(&a)), "node_id": r.node_id})
            })
            .map_err(CliError::from),
        MasterCommand::IdentifyNonConfigured => lss
            .procedure(proc1(Step::IdentifyNonConfigured))
            .wait()
            .map(|r| {
                if !g.json {
                    outln(if r.present == Some(true) {
                        "an unconfigured slave answered"
                    } else {
                        NONE_ANSWERED
                    });
                }
                json!({"present": r.present})
            })
            .map_err(CliError::from),
        MasterCommand::Fastscan => lss
            .fastscan(fastscan)
            .wait()
            .map(|a| {
                if !g.json {
                    outln(&a.as_ref().map_or(NONE_ANSWERED.into(), |a| {
                        format!("found {}", addr_text(a, g))
                    }));
                }
                json!({"found": a.as_ref().map(addr_json)})
            })
            .map_err(CliError::from),
        MasterCommand::DiscoverAll => lss
            .discover_all(fastscan)
            .wait()
            .map(|l| {
                if !g.json {
                    if l.is_empty() {
                        outln(NONE_ANSWERED);
                    }
                    for a in &l {
                        outln(&format!("found {}", addr_text(a, g)));
                    }
                }
                json!({"found": l.iter().map(addr_json).collect::<Vec<_>>()})
            })
            .map_err(CliError::from),
        MasterCommand::AssignAll { first, last } => match (NodeId::new(first), NodeId::new(last)) {
            (Ok(f), Ok(l)) => {
                let mut config = AssignConfig::with_pool(NodeIdPool::range(f, l));
                config.fastscan = fastscan;
                lss.assign_all(config)
                    .wait()
                    .map(|rep| {
                        if !g.json {
                            for id in rep.skipped.iter() {
                                outln(&format!(
                                    "node-ID {id} is in use on the bus: not handed out"
                                ));
                            }
                            for e in &rep.entries {
                                outln(&entry_text(e, g));
                            }
                            if let Some(why) = &rep.stopped {
                                outln(&format!("stopped early: {why}"));
                            }
                        }
                        let entries = rep.entries.iter().map(|e| {
                            let mut v = addr_json(&e.address);
                            v["node_id"] = json!(e.node_id.map(|n| n.get()));
                            let (assigned, stored, error) = match e.outcome {
                                AssignOutcome::Assigned => (true, true, None),
                                AssignOutcome::StoreFailed(err) => (true, false, Some(err)),
                                AssignOutcome::Failed(err) => (false, false, Some(err)),
                            };
                            v["assigned"] = json!(assigned);
                            v["stored"] = json!(stored);
                            v["error"] = json!(error.map(|e| e.to_string()));
                            v
                        });
                        json!({
                            "assigned": rep.assigned().map(|(a, n)| {
                                let mut v = addr_json(&a);
                                v["node_id"] = json!(n.get());
                                v
                            }).collect::<Vec<_>>(),
                            "slaves": entries.collect::<Vec<_>>(),
                            "stopped": rep.stopped.map(|e| e.to_string()),
                            "in_use": rep.skipped.iter().map(|n| n.get()).collect::<Vec<_>>(),
                        })
                    })
                    .map_err(CliError::from)
            }
            _ => Err(CliError::Argument("node-IDs are 1..=127".into())),
        },
    };
    match result {
        Ok(v) => {
            // Text mode printed its lines already (plain acknowledgements print nothing).
            if g.json {
                outln(&v.to_string());
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
