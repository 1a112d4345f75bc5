//! `canopen nmt` (CiA 301 §7.2.8.3.1 module control, and `nmt state`: every node's last state
//! and heartbeat age) and `canopen scan` (the nodes that answer, with their identity object),
//! through [`canola::Nmt`] and [`canola::Network::scan`].
//!
//! `--wait` makes a command wait for what confirms it (CiA 301 §7.2.8.3.2: the node reports
//! its state by heartbeat, and a reset by its boot-up message): a heartbeat with the new state
//! after start, stop and preop, the boot-up after reset and reset-comm. A node that sends no
//! heartbeat (producer heartbeat time 0x1017 at 0) cannot confirm a state: the wait ends with
//! an error saying what was heard from the node.

use std::process::ExitCode;

use canola::{CommandSpecifier, Duration, Network, NmtState, NodeId};
use clap::{Args, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, open_network, parse_node, seconds};
use crate::error::CliError;
use crate::{Global, outln};

/// NMT commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum NmtCmd {
    /// Every node heard: its last NMT state and the age of its last heartbeat.
    State,
    Start,
    Stop,
    Preop,
    Reset,
    ResetComm,
}

/// `canopen nmt ...`
#[derive(Debug, Args)]
pub(crate) struct NmtArgs {
    /// The command.
    #[arg(value_enum)]
    command: NmtCmd,
    /// Node-ID, node-IDs (`5,6`) or `all` (not with `state`).
    target: Option<String>,
    /// Wait until the node confirms: a heartbeat with the new state (start, stop, preop) or
    /// its boot-up (reset, reset-comm).
    #[arg(long)]
    wait: bool,
    /// How long --wait waits, in ms.
    #[arg(long, value_name = "MS", default_value_t = 3000, value_parser = clap::value_parser!(u64).range(1..=3_600_000))]
    timeout: u64,
    /// `state`: how long to listen for heartbeats, in seconds.
    #[arg(long, value_name = "SECS", default_value_t = 2.0)]
    listen: f64,
}

/// A state in the words the CLI prints (one word, lower case).
fn state_name(s: NmtState) -> String {
    match s {
        NmtState::Unknown(v) => format!("unknown(0x{v:02X})"),
        other => other.to_string().to_lowercase(),
    }
}

/// `canopen nmt CMD NODE|all` and `canopen nmt state`
pub(crate) fn run(args: NmtArgs, opts: &BusOpts, g: Global) -> ExitCode {
    use CommandSpecifier as C;
    let cs = match args.command {
        NmtCmd::State => {
            if args.target.is_some() || args.wait {
                return CliError::usage(
                    "nmt state takes no node and no --wait: it lists every node",
                )
                .report();
            }
            return run_state(args.listen, opts, g);
        }
        NmtCmd::Start => C::Start,
        NmtCmd::Stop => C::Stop,
        NmtCmd::Preop => C::EnterPreOperational,
        NmtCmd::Reset => C::ResetNode,
        NmtCmd::ResetComm => C::ResetCommunication,
    };
    let Some(target) = args.target.as_deref() else {
        return CliError::usage("give the node-ID or `all`: e.g. `nmt start 5`").report();
    };
    let all = target.eq_ignore_ascii_case("all");
    if all && args.wait {
        return CliError::usage(
            "--wait needs node-IDs (`nmt start 5 --wait`, `nmt reset 5,6 --wait`): with `all` \
             the master does not know which nodes to wait for",
        )
        .report();
    }
    let mut nodes = Vec::new();
    if !all {
        for part in target.split(',') {
            match parse_node(part.trim()) {
                Ok(n) if !nodes.contains(&n) => nodes.push(n),
                Ok(_) => {}
                Err(e) => return e.into_usage().report(),
            }
        }
    }
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let name = args
        .command
        .to_possible_value()
        .map(|v| v.get_name().to_string());
    if all {
        return match net.nmt_all(cs) {
            Ok(()) => {
                if g.json {
                    outln(&json!({"nmt": name, "target": target}).to_string());
                }
                ExitCode::SUCCESS
            }
            Err(e) => fail(e),
        };
    }
    // One command per node, all sent before any wait.
    for &node in &nodes {
        let nmt = net.node(node).nmt();
        let sent = match args.command {
            NmtCmd::Start => nmt.start(),
            NmtCmd::Stop => nmt.stop(),
            NmtCmd::Preop => nmt.enter_preoperational(),
            NmtCmd::Reset => nmt.reset_node(),
            NmtCmd::ResetComm => nmt.reset_communication(),
            NmtCmd::State => Ok(()),
        };
        if let Err(e) = sent {
            return fail(e);
        }
    }
    if !args.wait {
        if g.json {
            outln(&json!({"nmt": name, "target": target}).to_string());
        }
        return ExitCode::SUCCESS;
    }
    // One deadline for all: each node's wait gets what is left of it.
    let deadline = net.now() + Duration::from_millis(args.timeout);
    let mut confirmed = Vec::new();
    let mut missing = Vec::new();
    for &node in &nodes {
        let nmt = net.node(node).nmt();
        let left = deadline.saturating_duration_since(net.now());
        let (want, r) = match args.command {
            NmtCmd::Reset | NmtCmd::ResetComm => ("boot-up".to_string(), nmt.wait_for_bootup(left)),
            cmd => {
                let state = match cmd {
                    NmtCmd::Start => NmtState::Operational,
                    NmtCmd::Stop => NmtState::Stopped,
                    _ => NmtState::PreOperational,
                };
                (state_name(state), nmt.wait_for_state(state, left))
            }
        };
        match r.wait() {
            Ok(()) => confirmed.push((node, want)),
            Err(canola::Error::Timeout { .. }) => {
                missing.push(unconfirmed(&net, node, &want, args.timeout))
            }
            Err(e) => return fail(e),
        }
    }
    if g.json && missing.is_empty() {
        let list: Vec<_> = confirmed
            .iter()
            .map(|(n, w)| json!({"node": n.get(), "state": w}))
            .collect();
        outln(&json!({"nmt": name, "target": target, "nodes": list}).to_string());
    } else if !g.json {
        for (n, w) in &confirmed {
            outln(&format!("node {n}: {w}"));
        }
    }
    if missing.is_empty() {
        ExitCode::SUCCESS
    } else {
        fail(CliError::Unconfirmed(missing))
    }
}

/// Why a wait for `want` from `node` ended without it: what was heard from the node.
fn unconfirmed(net: &Network, node: NodeId, want: &str, ms: u64) -> String {
    let heard = match (net.last_state(node), net.last_heartbeat(node)) {
        (Some(s), Some(at)) => format!(
            "its last heartbeat, {} ms ago, says {}",
            (net.now() - at).as_millis(),
            state_name(s)
        ),
        (Some(s), None) => format!("it last reported {}", state_name(s)),
        _ => format!(
            "nothing heard from node {node}: is it on the bus, and does it send heartbeats \
             (producer heartbeat time 0x1017 not 0)?"
        ),
    };
    format!("node {node} did not confirm {want} within {ms} ms: {heard}")
}

/// `canopen nmt state`: listens for `listen` seconds, then lists every node heard.
fn run_state(listen: f64, opts: &BusOpts, g: Global) -> ExitCode {
    if !listen.is_finite() || !(0.0..=3600.0).contains(&listen) {
        return CliError::usage(format!("--listen {listen}: give a number of seconds")).report();
    }
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    if let Err(e) = net.run_for(seconds(listen)).wait() {
        return fail(e);
    }
    let now = net.now();
    let nodes: Vec<_> = NodeId::all()
        .filter_map(|n| {
            let state = net.last_state(n)?;
            let age = net.last_heartbeat(n).map(|at| (now - at).as_millis());
            Some((n, state, age))
        })
        .collect();
    if nodes.is_empty()
        && let Some(e) = crate::bus::silent_adapter()
    {
        return fail(e);
    }
    if g.json {
        let list: Vec<_> = nodes
            .iter()
            .map(|(n, s, age)| json!({"node": n.get(), "state": state_name(*s), "heartbeat_age_ms": age}))
            .collect();
        outln(&serde_json::Value::Array(list).to_string());
    } else {
        outln("node  state            heartbeat age (ms)");
        for (n, s, age) in &nodes {
            let age = age.map_or("-".to_string(), |a| a.to_string());
            outln(&format!("{:>4}  {:<15}  {age}", n.get(), state_name(*s)));
        }
    }
    ExitCode::SUCCESS
}

/// `canopen scan`
pub(crate) fn run_scan(opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let found = match net.scan(Duration::from_millis(200)).wait() {
        Ok(found) => found,
        Err(e) => return fail(e),
    };
    // An adapter that said nothing at all is no proof of an empty bus.
    if found.is_empty()
        && let Some(e) = crate::bus::silent_adapter()
    {
        return fail(e);
    }
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
