//! `canopen adapter info`: what a serial-line CAN adapter says about itself (version `V`,
//! serial number `N`, status flags `F`) and what the stack knows of it (whether it
//! acknowledges commands, the bit rate it was opened with, CAN FD).

use std::process::ExitCode;

use clap::Subcommand;

use crate::bus::{BusOpts, fail};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen adapter ...`.
#[derive(Debug, Subcommand)]
pub(crate) enum AdapterCommand {
    /// Version, serial number and status flags of an slcan adapter (`--iface slcan:PATH`).
    Info,
}

/// Runs an adapter command.
pub(crate) fn run(cmd: AdapterCommand, opts: &BusOpts, global: Global) -> ExitCode {
    match cmd {
        AdapterCommand::Info => info(opts, global),
    }
}

/// The status flag names (CAN232 bit order; advisory, firmwares differ).
const FLAGS: [(u8, &str); 7] = [
    (
        canola::slcan::StatusFlags::RX_FIFO_FULL,
        "receive FIFO full",
    ),
    (
        canola::slcan::StatusFlags::TX_FIFO_FULL,
        "transmit FIFO full",
    ),
    (canola::slcan::StatusFlags::ERROR_WARNING, "error warning"),
    (canola::slcan::StatusFlags::DATA_OVERRUN, "data overrun"),
    (canola::slcan::StatusFlags::ERROR_PASSIVE, "error passive"),
    (
        canola::slcan::StatusFlags::ARBITRATION_LOST,
        "arbitration lost",
    ),
    (canola::slcan::StatusFlags::BUS_ERROR, "bus error"),
];

fn info(opts: &BusOpts, global: Global) -> ExitCode {
    let Some(iface) = opts.iface.as_deref() else {
        return fail(CliError::Argument(
            "adapter info needs --iface slcan:PATH[@BITRATE]".into(),
        ));
    };
    let spec = match canola::BusSpec::parse(iface) {
        Ok(s) => s,
        Err(e) => return fail(e),
    };
    let mut adapter = match spec.open_slcan() {
        Ok(a) => a,
        Err(e) => return fail(e),
    };
    let info = match adapter.info() {
        Ok(i) => i,
        Err(source) => {
            return fail(CliError::Adapter {
                iface: iface.to_owned(),
                source,
            });
        }
    };
    let config = adapter.link().config().clone();
    let _ = adapter.close();
    use canola::slcan::BitrateTable;
    // S7 and S9 differ between firmwares (see canola-slcan's README).
    let bitrate = config.bitrate.map(|b| {
        let lawicel = b.bps(BitrateTable::Lawicel);
        let canable = b.bps(BitrateTable::Canable);
        (
            lawicel.filter(|_| lawicel == canable),
            b.code(),
            lawicel,
            canable,
        )
    });
    let flags: Vec<&str> = info.status.map_or_else(Vec::new, |s| {
        FLAGS
            .iter()
            .filter(|(bit, _)| s.contains(*bit))
            .map(|(_, name)| *name)
            .collect()
    });
    // slcan has no query for CAN FD; a data bit rate given, or a version text naming FD,
    // is what there is to go on.
    let fd = if config.data_bitrate.is_some() {
        "yes (data bit rate set)"
    } else if info
        .version
        .as_deref()
        .is_some_and(|v| v.to_ascii_uppercase().contains("FD"))
    {
        "likely (the version text names FD)"
    } else {
        "unknown (slcan has no query for it)"
    };
    if global.json {
        let v = serde_json::json!({
            "adapter": iface,
            "path": config.path,
            "version": info.version,
            "hardware_version": info.hw_sw.map(|(h, _)| h),
            "software_version": info.hw_sw.map(|(_, s)| s),
            "serial": info.serial,
            "status": info.status.map(|s| s.0),
            "status_flags": flags,
            "acknowledges": info.acknowledges,
            "bitrate": bitrate.and_then(|(bps, ..)| bps),
            "bitrate_code": bitrate.map(|(_, code, ..)| code),
            "can_fd": fd,
        });
        outln(&v.to_string());
        return ExitCode::SUCCESS;
    }
    let none = "no answer";
    outln(&format!("adapter   {iface}"));
    outln(&format!(
        "version   {}",
        match (&info.version, info.hw_sw) {
            (Some(v), Some((h, s))) => format!("{v} (hardware {h}, software {s})"),
            (Some(v), None) => v.clone(),
            (None, _) => none.into(),
        }
    ));
    outln(&format!(
        "serial    {}",
        info.serial.as_deref().unwrap_or(none)
    ));
    outln(&format!(
        "status    {}",
        match info.status {
            Some(s) if flags.is_empty() => format!("{:#04x} (no flag set)", s.0),
            Some(s) => format!("{:#04x} ({})", s.0, flags.join(", ")),
            None => none.into(),
        }
    ));
    outln(&format!(
        "replies   {}",
        if info.acknowledges {
            "acknowledges commands with CR/BEL (Lawicel style)"
        } else {
            "does not acknowledge commands (CANable style)"
        }
    ));
    outln(&format!(
        "bitrate   {}",
        match bitrate {
            Some((Some(bps), code, ..)) => format!("{bps} bit/s (S{code})"),
            Some((None, code, lawicel, canable)) => format!(
                "S{code}: {} bit/s on Lawicel firmware, {} bit/s on CANable",
                lawicel.unwrap_or(0),
                canable.unwrap_or(0)
            ),
            None => "the adapter's own setting (give slcan:PATH@BITRATE to set it)".into(),
        }
    ));
    outln(&format!("can fd    {fd}"));
    ExitCode::SUCCESS
}
