//! `canopen nmt` (CiA 301 §7.2.8.3.1 module control) and `canopen scan` (the nodes that answer,
//! with their identity object), through [`canola::Nmt`] and [`canola::Network::scan`].

use std::process::ExitCode;

use canola::{CommandSpecifier, Duration};
use clap::ValueEnum;
use serde_json::json;

use crate::bus::{BusOpts, fail, open_network, parse_node};
use crate::{Global, outln};

/// NMT commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum NmtCmd {
    Start,
    Stop,
    Preop,
    Reset,
    ResetComm,
}

/// `canopen nmt CMD NODE|all`
pub(crate) fn run(cmd: NmtCmd, target: &str, opts: &BusOpts, g: Global) -> ExitCode {
    use CommandSpecifier as C;
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let cs = match cmd {
        NmtCmd::Start => C::Start,
        NmtCmd::Stop => C::Stop,
        NmtCmd::Preop => C::EnterPreOperational,
        NmtCmd::Reset => C::ResetNode,
        NmtCmd::ResetComm => C::ResetCommunication,
    };
    let r = if target.eq_ignore_ascii_case("all") {
        net.nmt_all(cs)
    } else {
        match parse_node(target) {
            Ok(node) => {
                let nmt = net.node(node).nmt();
                match cmd {
                    NmtCmd::Start => nmt.start(),
                    NmtCmd::Stop => nmt.stop(),
                    NmtCmd::Preop => nmt.enter_preoperational(),
                    NmtCmd::Reset => nmt.reset_node(),
                    NmtCmd::ResetComm => nmt.reset_communication(),
                }
            }
            Err(e) => return fail(e),
        }
    };
    match r {
        Ok(()) => {
            if g.json {
                outln(
                    &json!({"nmt": cmd.to_possible_value().map(|v| v.get_name().to_string()), "target": target})
                        .to_string(),
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// `canopen scan`
pub(crate) fn run_scan(opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let found = net.scan(Duration::from_millis(200));
    // Decimal like every command's values; `--hex` zero-padded hex.
    let fmt = |v: Option<u32>| v.map_or("-".to_string(), |v| g.u32(v));
    if g.json {
        let list: Vec<_> = found
            .iter()
            .map(|s| {
                let id = s.identity;
                json!({"node": s.node.get(), "vendor_id": id.vendor_id,
                       "product_code": id.product_code, "revision": id.revision,
                       "serial": id.serial})
            })
            .collect();
        outln(&serde_json::Value::Array(list).to_string());
    } else {
        outln("node  vendor-id   product     revision    serial");
        for s in &found {
            let id = s.identity;
            outln(&format!(
                "{:>4}  {:<10}  {:<10}  {:<10}  {}",
                s.node.get(),
                fmt(Some(id.vendor_id)),
                fmt(id.product_code),
                fmt(id.revision),
                fmt(id.serial)
            ));
        }
    }
    ExitCode::SUCCESS
}
