//! `canopen lss ...`: the LSS master services of CiA 305.
//!
//! On the in-memory bus, `--unconfigured N` adds N simulated devices without a node-ID (the
//! Bürkert generic EDS, serial numbers 1001, 1002, ...) so the services have slaves to find.

use std::process::ExitCode;

use can_frame::NodeId;
use canopen::SimDevice;
use canopen_lss::{
    AssignConfig, BitRate, BitTiming, FastscanConfig, LssAddress, Mode, NodeIdPool, Procedure, Step,
};
use clap::{Args, Subcommand};
use serde_json::json;

use crate::bus::{BusOpts, open_network};
use crate::{Global, outln};

const BURKERT_EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

#[derive(Debug, Args)]
pub(crate) struct LssArgs {
    /// In-memory bus only: simulate this many unconfigured devices.
    #[arg(long, default_value_t = 0)]
    unconfigured: u32,
    #[command(subcommand)]
    command: LssCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum LssCommand {
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
    /// Configure node-ID of the slave(s) in configuration state (switch global, configure,
    /// store, switch back).
    ConfigureNodeId {
        /// The new node-ID.
        node_id: u8,
        /// Do not store the configuration.
        #[arg(long)]
        no_store: bool,
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
    /// Assign-all: find every unconfigured slave and give each a node-ID from FIRST..=LAST.
    AssignAll {
        /// First node-ID of the pool.
        #[arg(long, default_value_t = 2)]
        first: u8,
        /// Last node-ID of the pool.
        #[arg(long, default_value_t = 127)]
        last: u8,
    },
}

fn num(s: &str) -> Result<u32, String> {
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    }
    .map_err(|e| format!("`{s}`: {e}"))
}

fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::FAILURE
}

fn addr_json(a: &LssAddress) -> serde_json::Value {
    json!({"vendor_id": a.vendor_id, "product_code": a.product_code,
           "revision": a.revision_number, "serial": a.serial_number})
}

/// `canopen lss ...`
pub(crate) fn run(args: LssArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, mem) = match open_network(opts) {
        Ok(x) => x,
        Err(e) => return fail(e),
    };
    if args.unconfigured > 0 {
        let Some(mem) = mem.as_ref() else {
            return fail("--unconfigured only works on the in-memory bus");
        };
        let od = match canopen_od::parse(BURKERT_EDS) {
            Ok(p) => p.od,
            Err(e) => return fail(e),
        };
        for i in 0..args.unconfigured {
            let a = LssAddress::new(0x39, 0x0100_0001, 1, 1001 + i);
            mem.attach(SimDevice::unconfigured(od.clone(), a));
        }
    }
    let lss = net.lss();
    let proc1 = |step| Procedure::single(step);
    let result: Result<serde_json::Value, String> = match args.command {
        LssCommand::SwitchGlobal { mode } => {
            let m = match mode.as_str() {
                "config" | "configuration" => Mode::Configuration,
                "waiting" | "operation" => Mode::Waiting,
                other => return fail(format!("mode `{other}`: use config or waiting")),
            };
            lss.procedure(proc1(Step::SwitchModeGlobal(m)))
                .map(|_| json!({"ok": true}))
                .map_err(|e| e.to_string())
        }
        LssCommand::SwitchSelective {
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
                    .map(|_| json!({"ok": true}))
                    .map_err(|e| e.to_string()),
                _ => Err("address parts must be numbers (0x hex or decimal)".into()),
            }
        }
        LssCommand::ConfigureNodeId { node_id, no_store } => match NodeId::new(node_id) {
            Ok(n) => lss
                .procedure(Procedure::assign_node_id(n, !no_store))
                .map(|_| json!({"node_id": node_id}))
                .map_err(|e| e.to_string()),
            Err(e) => Err(e.to_string()),
        },
        LssCommand::SetBitRate { kbit, delay } => {
            match BitRate::ALL
                .into_iter()
                .find(|r| r.bits_per_second() == Some(kbit * 1000))
            {
                Some(rate) => lss
                    .procedure(Procedure::change_bit_rate(BitTiming::standard(rate), delay))
                    .map(|_| json!({"kbit": kbit}))
                    .map_err(|e| e.to_string()),
                None => Err(format!("{kbit} kbit/s is not in the CiA bit timing table")),
            }
        }
        LssCommand::Store => lss
            .procedure(proc1(Step::StoreConfiguration))
            .map(|_| json!({"ok": true}))
            .map_err(|e| e.to_string()),
        LssCommand::Inquire => lss
            .procedure(Procedure::inquire_all())
            .map(|r| json!({"identity": r.address().map(|a| addr_json(&a)), "node_id": r.node_id}))
            .map_err(|e| e.to_string()),
        LssCommand::IdentifyNonConfigured => lss
            .procedure(proc1(Step::IdentifyNonConfigured))
            .map(|r| json!({"present": r.present}))
            .map_err(|e| e.to_string()),
        LssCommand::Fastscan => lss
            .fastscan(FastscanConfig::default())
            .map(|a| json!({"found": a.as_ref().map(addr_json)}))
            .map_err(|e| e.to_string()),
        LssCommand::DiscoverAll => lss
            .discover_all(FastscanConfig::default())
            .map(|l| json!({"found": l.iter().map(addr_json).collect::<Vec<_>>()}))
            .map_err(|e| e.to_string()),
        LssCommand::AssignAll { first, last } => match (NodeId::new(first), NodeId::new(last)) {
            (Ok(f), Ok(l)) => lss
                .assign_all(AssignConfig::with_pool(NodeIdPool::range(f, l)))
                .map(|rep| {
                    if !g.json {
                        for e in &rep.entries {
                            outln(&e.to_string());
                        }
                    }
                    json!({"assigned": rep.assigned().map(|(a, n)| {
                        let mut v = addr_json(&a);
                        v["node_id"] = json!(n.get());
                        v
                    }).collect::<Vec<_>>()})
                })
                .map_err(|e| e.to_string()),
            _ => Err("node-IDs are 1..=127".into()),
        },
    };
    match result {
        Ok(v) => {
            // Text mode prints the JSON too, except for plain acknowledgements and the
            // assign-all report already printed line by line.
            if g.json || (v.get("assigned").is_none() && v != json!({"ok": true})) {
                outln(&v.to_string());
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
