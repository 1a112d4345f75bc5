//! `canopen burkert ...`: the Bürkert profile (SPEC-NOTES §1) of one node, through
//! `canola_burkert::BurkertNode`.
//!
//! The bus is the one the global flags choose (`--iface IFACE` for SocketCAN, else the in-memory
//! bus on a virtual clock). On the in-memory bus the node is simulated as a Bürkert device
//! (`canola_burkert::BurkertDevice`: locating, maintenance, NE 107, logbook), from
//! `--eds NODE=FILE` when given, else from the generic Bürkert EDS.

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use canola::{BusDictionary, Error, NodeId, ObjectDictionary};
use canola_burkert::demo::{led_swatch, progress_bar};
use canola_burkert::master::generic_od;
use canola_burkert::{BurkertDevice, BurkertNode, DeviceReport, LedColour, LedMode, Ne107Status};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, parse_node};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen burkert NODE ...` arguments.
#[derive(Debug, Args)]
pub(crate) struct BurkertArgs {
    #[command(subcommand)]
    command: BurkertCommand,
}

/// NE 107 events a simulated device can start with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Event {
    Failure,
    FunctionCheck,
    OutOfSpecification,
    MaintenanceRequired,
    DiagnosisActive,
}

impl Event {
    fn status(self) -> Ne107Status {
        match self {
            Self::Failure => Ne107Status::Failure,
            Self::FunctionCheck => Ne107Status::FunctionCheck,
            Self::OutOfSpecification => Ne107Status::OutOfSpecification,
            Self::MaintenanceRequired => Ne107Status::MaintenanceRequired,
            Self::DiagnosisActive => Ne107Status::DiagnosisActive,
        }
    }
}

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum OnOff {
    On,
    Off,
}

#[derive(Debug, Subcommand)]
enum BurkertCommand {
    /// Device description, NE 107 status, communication and the LED colour.
    Status {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
    },
    /// Start the locating function (the LED flashes for about 10 s).
    Locate {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Cancel a running locate instead.
        #[arg(long)]
        stop: bool,
    },
    /// Enter or leave the maintenance state (0x210A).
    Maintenance {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// on or off.
        #[arg(value_enum)]
        state: OnOff,
    },
    /// Set the LED mode (0x2120) and, optionally, the fixed colour (0x2122).
    Led {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// namur, valve, valve-warnings, fixed, off (or the numeric value).
        #[arg(long, value_parser = |s: &str| LedMode::from_name(s).map_err(|e| e.to_string()))]
        mode: LedMode,
        /// off, white, green, blue, yellow, orange, red (German names too) or #RRGGBB.
        #[arg(long, value_parser = |s: &str| LedColour::from_name(s).map_err(|e| e.to_string()))]
        colour: Option<LedColour>,
    },
    /// Run a simulated Bürkert device on the bus (`--iface` for SocketCAN; on the in-memory
    /// bus give --duration and the traffic is printed).
    Simulate {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// NE 107 events active from the start (repeatable).
        #[arg(long = "event", value_enum)]
        events: Vec<Event>,
        /// Stop after this many seconds (required on the in-memory bus).
        #[arg(long, value_parser = crate::bus::parse_seconds)]
        duration: Option<f64>,
    },
    /// Download the logbook (0x2003 sub 4, XML) into a file.
    Logbook {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Segmented transfer instead of block transfer.
        #[arg(long)]
        segmented: bool,
    },
}

impl BurkertCommand {
    fn node(&self) -> NodeId {
        match self {
            Self::Status { node }
            | Self::Locate { node, .. }
            | Self::Maintenance { node, .. }
            | Self::Led { node, .. }
            | Self::Logbook { node, .. }
            | Self::Simulate { node, .. } => *node,
        }
    }
}

/// The `--eds` dictionaries, with the generic Bürkert EDS for `node` when none is given for it.
fn dictionaries(opts: &BusOpts, node: NodeId) -> Result<Vec<(NodeId, ObjectDictionary)>, CliError> {
    let mut dictionaries = opts.dictionaries()?;
    if !dictionaries.iter().any(|(n, _)| *n == node) {
        dictionaries.push((node, (**generic_od()).clone()));
    }
    Ok(dictionaries)
}

/// `canopen burkert simulate NODE`: a `BurkertDevice` on SocketCAN (until --duration) or on
/// the in-memory bus (for --duration of virtual time, printing the traffic).
fn simulate(
    opts: &BusOpts,
    id: NodeId,
    events: &[Event],
    duration: Option<f64>,
    g: Global,
) -> ExitCode {
    let od = match dictionaries(opts, id).map(|d| d.into_iter().find(|(n, _)| *n == id)) {
        Ok(Some((_, od))) => od,
        Ok(None) => (**generic_od()).clone(),
        Err(e) => return fail(e),
    };
    // The device is the only station this command runs.
    let bus = match opts.open_with(Vec::new()) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let dictionary = BusDictionary::new().with_node(id, od.clone());
    let mut dev = BurkertDevice::with_dictionary(id, od);
    for e in events {
        dev.raise(e.status());
    }
    eprintln!(
        "simulating a Bürkert device, node {} (NE 107 status: {})",
        id.get(),
        dev.ne107()
    );
    crate::simulate::run_station(bus, dev, &dictionary, duration, g)
}

/// `canopen burkert ...`
pub(crate) fn run(args: BurkertArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let id = args.command.node();
    if let BurkertCommand::Simulate {
        events, duration, ..
    } = &args.command
    {
        return simulate(opts, id, events, *duration, g);
    }
    let (net, _mem) = match dictionaries(opts, id).and_then(|d| opts.open_with(d)) {
        Ok(bus) => bus.into_network(),
        Err(e) => return fail(e),
    };
    let dev = BurkertNode::new(net.node(id));
    let result = match args.command {
        BurkertCommand::Status { .. } => dev.read_report().map(|r| print_report(id, &r, g)),
        BurkertCommand::Locate { stop, .. } => {
            let r = if stop {
                dev.stop_locating()
            } else {
                dev.start_locating()
            };
            r.and_then(|()| dev.read_report()).map(|r| {
                if g.json {
                    outln(
                        &json!({"node": id.get(), "locating": r.locating,
                                  "led": led_json(&r)})
                        .to_string(),
                    );
                } else if stop {
                    outln(&format!("node {}: locating cancelled", id.get()));
                } else {
                    outln(&format!(
                        "node {}: locating started, the LED flashes for about 10 s: {}",
                        id.get(),
                        led_swatch(&r.led_indication(), ansi(g))
                    ));
                }
            })
        }
        BurkertCommand::Maintenance { state, .. } => dev
            .set_maintenance(state == OnOff::On)
            .and_then(|()| dev.read_report())
            .map(|r| {
                let ne = r.status.ne107.unwrap_or(Ne107Status::DiagnosisInactive);
                if g.json {
                    outln(
                        &json!({"node": id.get(), "maintenance": r.maintenance,
                                  "ne107": ne107_json(ne), "led": led_json(&r)})
                        .to_string(),
                    );
                } else {
                    outln(&format!(
                        "node {}: maintenance {}; NE 107 status {} ({}); LED {}",
                        id.get(),
                        if r.maintenance { "on" } else { "off" },
                        ne.to_raw(),
                        ne.meaning_en(),
                        led_swatch(&r.led_indication(), ansi(g))
                    ));
                }
            }),
        BurkertCommand::Led { mode, colour, .. } => colour
            .map_or(Ok(()), |c| dev.set_external_colour(c))
            .and_then(|()| dev.set_led_mode(mode))
            .and_then(|()| dev.read_report())
            .map(|r| {
                if g.json {
                    outln(&json!({"node": id.get(), "led": led_json(&r)}).to_string());
                } else {
                    outln(&format!(
                        "node {}: LED mode {}, fixed colour {}; LED {}",
                        id.get(),
                        r.led.mode,
                        r.led.external,
                        led_swatch(&r.led_indication(), ansi(g))
                    ));
                }
            }),
        BurkertCommand::Logbook {
            output, segmented, ..
        } => logbook(&dev, &output, !segmented, g),
        BurkertCommand::Simulate { .. } => Ok(()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// ANSI colour only for a terminal, never in JSON.
fn ansi(g: Global) -> bool {
    !g.json && std::io::stdout().is_terminal()
}

fn logbook(
    dev: &BurkertNode,
    output: &std::path::Path,
    block: bool,
    g: Global,
) -> Result<(), Error> {
    let out = crate::outfile::OutFile::create(output).map_err(std::io::Error::other)?;
    let file = out.writer().map_err(std::io::Error::other)?;
    let bar = std::io::stderr().is_terminal() && !g.json;
    let last = Arc::new(Mutex::new((0u64, None)));
    let l2 = last.clone();
    let n = dev.download_logbook(file, block, move |p| {
        if bar {
            eprint!("\r{}", progress_bar(p.done, p.total));
        }
        if let Ok(mut v) = l2.lock() {
            *v = (p.done, p.total);
        }
    })?;
    out.commit().map_err(std::io::Error::other)?;
    if bar {
        eprintln!();
    }
    if g.json {
        outln(
            &json!({"node": dev.id().get(), "bytes": n, "file": output.display().to_string(),
                    "transfer": if block { "block" } else { "segmented" }})
            .to_string(),
        );
    } else {
        outln(&format!(
            "node {}: logbook, {n} bytes, written to {}",
            dev.id().get(),
            output.display()
        ));
    }
    Ok(())
}

fn ne107_json(ne: Ne107Status) -> serde_json::Value {
    json!({"value": ne.to_raw(), "en": ne.meaning_en(), "de": ne.meaning_de(),
           "colour": ne.colour().map(|c| c.name())})
}

fn led_json(r: &DeviceReport) -> serde_json::Value {
    let ind = r.led_indication();
    let (red, green, blue) = ind.colour.approx_rgb();
    json!({
        "mode": r.led.mode.name(),
        "mode_value": r.led.mode.to_u32(),
        "colour": ind.colour.to_string(),
        "code": ind.colour.to_u32(),
        "rgb": format!("#{red:02X}{green:02X}{blue:02X}"),
        "flashing": ind.flashing,
        "external": r.led.external.to_string(),
        "valve": {"closed": r.led.valve.closed.to_string(),
                  "between": r.led.valve.between.to_string(),
                  "open": r.led.valve.open.to_string()},
    })
}

fn print_report(id: NodeId, r: &DeviceReport, g: Global) {
    let d = &r.description;
    let s = &r.status;
    let c = &r.communication;
    if g.json {
        outln(
            &json!({
                "node": id.get(),
                "description": {
                    "device_name": d.device_name, "ident_number": d.ident_number,
                    "manufacture_date": d.manufacture_date,
                    "software_ident_number": d.software_ident_number,
                    "software_version": d.software_version,
                    "hardware_version": d.hardware_version, "serial_number": d.serial_number,
                    "product_code": d.product_code, "product_group": d.product_group,
                },
                "status": {
                    "ne107": s.ne107.map(ne107_json),
                    "temperature_k": s.temperature.map(|t| t.0),
                    "temperature_c": s.temperature.map(|t| t.celsius()),
                    "supply_voltage": s.supply_voltage,
                    "operation_time_s": s.operation_time_s,
                    "boot_counter": s.boot_counter,
                    "time_since_boot_s": s.time_since_boot_s,
                    "transferable_memory": s.trans_mem.map(|t| t.meaning()),
                },
                "communication": {
                    "bit_rate_kbit": c.bit_rate.map(|b| b.kbits()),
                    "address": c.address,
                    "can_operation_status": c.can_operation_status.map(|x| x.to_string()),
                    "eds_version": c.eds_version.map(|v| v.to_string()),
                },
                "led": led_json(r),
                "locating": r.locating,
                "maintenance": r.maintenance,
            })
            .to_string(),
        );
        return;
    }
    let mut t = format!(
        "node {}: {}\n",
        id.get(),
        d.device_name.as_deref().unwrap_or("(no device name)")
    );
    let mut line = |k: &str, v: String| t.push_str(&format!("  {k:<16} {v}\n"));
    if let Some(v) = d.serial_number {
        line("serial number", g.u32(v));
    }
    if let Some(v) = d.software_version {
        line("software", g.u32(v));
    }
    if let Some(ne) = s.ne107 {
        line(
            "NE 107 status",
            format!("{} {} / {}", ne.to_raw(), ne.meaning_en(), ne.meaning_de()),
        );
    }
    line("LED", led_swatch(&r.led_indication(), ansi(g)));
    line("LED mode", r.led.mode.to_string());
    if let Some(v) = s.temperature {
        line("temperature", v.to_string());
    }
    if let Some(v) = s.supply_voltage {
        line("supply voltage", format!("{v:.2} V"));
    }
    if let Some(v) = s.boot_counter {
        line("boot counter", v.to_string());
    }
    if let Some(v) = c.can_operation_status {
        line("CAN status", v.to_string());
    }
    if let Some(v) = c.bit_rate {
        line("bit rate", v.to_string());
    }
    line("locating", if r.locating { "on" } else { "off" }.into());
    line(
        "maintenance",
        if r.maintenance { "on" } else { "off" }.into(),
    );
    crate::out(&t);
}
