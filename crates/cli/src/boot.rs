//! `canopen boot bus.toml` and `canopen audit bus.toml`: the network manager
//! (`canola-manager`) from the command line. On SocketCAN (`--iface`) they drive the real
//! network; on the in-memory bus every slave of the description is simulated from its DCF/EDS,
//! fresh from the factory, except those named by `--absent NODE`.

use std::path::PathBuf;
use std::process::ExitCode;

use canola::NodeId;
use canola_manager::boot::ConfigOutcome;
use canola_manager::{
    AuditOptions, BootEvent, NetworkConfig, SlaveReport, SlaveStatus, SuperviseEvent, json,
};
use clap::Args;

use crate::bus::{self, BusOpts};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen boot`.
#[derive(Debug, Args)]
pub(crate) struct BootArgs {
    /// The network description (bus.toml).
    file: PathBuf,
    /// In-memory bus: leave this slave off the bus (repeatable).
    #[arg(long, value_name = "NODE", value_parser = bus::parse_node)]
    absent: Vec<NodeId>,
    /// Print every step of every slave as it happens (text output only).
    #[arg(long)]
    verbose: bool,
    /// Instead of booting, write the description as a CiA 302 master DCF (0x1F80, 0x1F81,
    /// 0x1F84..0x1F89, 0x1F22 concise DCFs) to this file.
    #[arg(long, value_name = "FILE")]
    write_master_dcf: Option<PathBuf>,
    /// After the boot, supervise the network this many seconds: boot slaves that send boot-up
    /// (late or reset ones), reset lost slaves marked `restart_on_loss`. The report printed is
    /// the one at the end.
    #[arg(long, value_name = "SECONDS", value_parser = bus::parse_seconds)]
    supervise: Option<f64>,
}

/// `canopen audit`.
#[derive(Debug, Args)]
pub(crate) struct AuditArgs {
    /// The network description (bus.toml).
    file: PathBuf,
    /// Write the DCF's value back where a device differs.
    #[arg(long)]
    fix: bool,
    /// Also compare read-only objects the DCF records.
    #[arg(long)]
    read_only: bool,
    /// In-memory bus: leave this slave off the bus (repeatable).
    #[arg(long, value_name = "NODE", value_parser = bus::parse_node)]
    absent: Vec<NodeId>,
}

/// The description and a network on the bus (simulated slaves on the in-memory bus).
fn open(
    opts: &BusOpts,
    file: &PathBuf,
    absent: &[NodeId],
) -> Result<(NetworkConfig, canola::Network, Option<canola::MemoryBus>), CliError> {
    let config = NetworkConfig::load(file)?;
    let devices = if opts.iface.is_some() {
        Vec::new()
    } else {
        canola_manager::simulate::devices(&config, absent)
    };
    let (net, memory) = opts.open_with(devices)?.into_network();
    Ok((config, net, memory))
}

fn ms(d: canola::Duration) -> String {
    format!("{:.1} ms", d.as_micros() as f64 / 1000.0)
}

fn slave_line(s: &SlaveReport) -> String {
    let mut line = format!("node {:>3}  {:<15}", s.node_id.get(), s.status.name());
    match s.error_code {
        Some(code) => {
            line.push_str(&format!(" error {code}: {}", code.meaning()));
            if let Some(step) = s.step {
                line.push_str(&format!("\n          at {}", step.name()));
            }
            if let Some(o) = s.object {
                line.push_str(&format!(", object {o}"));
            }
            if let Some(d) = &s.detail {
                line.push_str(&format!(": {d}"));
            }
        }
        None => {
            match s.configuration {
                ConfigOutcome::Written(n) => line.push_str(&format!(" configured ({n} values)")),
                ConfigOutcome::Verified => line.push_str(" configuration verified by 0x1020"),
                ConfigOutcome::NotRun => {}
            }
            if let Some(ec) = &s.error_control {
                line.push_str(&format!(", {ec}"));
            }
        }
    }
    line.push_str(&format!(
        "  [{}{}]",
        ms(s.elapsed),
        if s.mandatory { ", mandatory" } else { "" }
    ));
    line
}

/// Runs `canopen boot`. Fails (exit 1) when a mandatory slave did not boot.
pub(crate) fn run_boot(args: BootArgs, opts: &BusOpts, global: Global) -> ExitCode {
    if let Some(out) = &args.write_master_dcf {
        let config = match NetworkConfig::load(&args.file) {
            Ok(c) => c,
            Err(e) => return bus::fail(e),
        };
        let text = canola_manager::master_dcf::MasterObjects::write_master_dcf(&config);
        return match crate::outfile::write_whole(out, text.as_bytes()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => bus::fail(e),
        };
    }
    let (config, net, _memory) = match open(opts, &args.file, &args.absent) {
        Ok(x) => x,
        Err(e) => return bus::fail(e),
    };
    let verbose = args.verbose && !global.json;
    let report = canola_manager::boot_with(&net, &config, |ev| {
        if verbose {
            match ev {
                BootEvent::StepStarted { node, step } => {
                    outln(&format!("node {node}: {}...", step.name()))
                }
                BootEvent::StepDone { node, step } => {
                    outln(&format!("node {node}: {} done", step.name()))
                }
                BootEvent::StepFailed {
                    node,
                    step,
                    code,
                    detail,
                } => outln(&format!(
                    "node {node}: {} failed, error {code}: {detail}",
                    step.name()
                )),
                BootEvent::SlaveDone(_) => {}
            }
        }
    });
    let mut report = report;
    if let Some(secs) = args.supervise {
        let until = net.now() + bus::seconds(secs);
        let quiet = global.json;
        canola_manager::supervise(&net, &config, &mut report, until, |ev| {
            if quiet {
                return;
            }
            match ev {
                SuperviseEvent::Rebooting(n) => {
                    outln(&format!("node {n}: boot-up, booting it again"))
                }
                SuperviseEvent::Reset(n) => {
                    outln(&format!("node {n}: lost, NMT reset communication"))
                }
                SuperviseEvent::Lost(n) => outln(&format!("node {n}: lost")),
                SuperviseEvent::Boot(_) => {}
                SuperviseEvent::NotListed { node, code } => outln(&format!(
                    "node {node}: boot-up from a device not in the network (error {code}: {})",
                    code.meaning()
                )),
            }
        });
    }
    if global.json {
        outln(&json::boot_json(&report).to_string());
    } else {
        for s in &report.slaves {
            outln(&slave_line(s));
        }
        let count = |st: SlaveStatus| report.slaves.iter().filter(|s| s.status == st).count();
        outln(&format!(
            "boot: {} slaves: {} operational, {} pre-operational, {} failed, {} absent; mandatory slaves {}; {} bus time",
            report.slaves.len(),
            count(SlaveStatus::Operational),
            count(SlaveStatus::PreOperational),
            count(SlaveStatus::Failed),
            count(SlaveStatus::Absent),
            if report.mandatory_ok {
                "ok"
            } else {
                "FAILED (no start-all)"
            },
            ms(report.elapsed),
        ));
    }
    if report.mandatory_ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// Runs `canopen audit`. On the in-memory bus the simulated network is booted first (its
/// devices start from the factory). Fails (exit 1) when a device differs or an object could
/// not be read (after `--fix`: when a fix failed).
pub(crate) fn run_audit(args: AuditArgs, opts: &BusOpts, global: Global) -> ExitCode {
    let (config, net, memory) = match open(opts, &args.file, &args.absent) {
        Ok(x) => x,
        Err(e) => return bus::fail(e),
    };
    if memory.is_some() {
        let _ = canola_manager::boot(&net, &config);
    }
    let options = AuditOptions {
        read_only: args.read_only,
        fix: args.fix,
    };
    let report = canola_manager::audit(&net, &config, options);
    if global.json {
        outln(&json::audit_json(&report).to_string());
    } else {
        for s in &report.slaves {
            outln(&format!(
                "node {:>3}: {} objects checked, {} differ, {} unreadable",
                s.node_id.get(),
                s.checked,
                s.differences.len(),
                s.unreadable.len()
            ));
            for d in &s.differences {
                let value = |v: &canola::Value| crate::sdo_cmd::format_value(v, global.hex);
                let actual = d
                    .actual
                    .as_ref()
                    .map_or_else(|| hex_bytes(&d.actual_bytes), value);
                let fixed = match &d.fixed {
                    Some(Ok(())) => " (fixed)".to_owned(),
                    Some(Err(e)) => format!(" (fix failed: {e})"),
                    None => String::new(),
                };
                outln(&format!(
                    "  {} \"{}\" {}: expected {}, actual {actual}{fixed}",
                    d.object,
                    d.name,
                    d.data_type,
                    value(&d.expected)
                ));
            }
            for u in &s.unreadable {
                outln(&format!(
                    "  {} \"{}\": cannot read: {}",
                    u.object, u.name, u.error
                ));
            }
        }
    }
    let ok = if args.fix {
        report.slaves.iter().all(|s| {
            s.unreadable.is_empty()
                && s.differences
                    .iter()
                    .all(|d| matches!(d.fixed, Some(Ok(()))))
        })
    } else {
        report.is_clean()
    };
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// Bytes as CANopen tools write them: `01 02 0A`.
fn hex_bytes(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}
