//! `canopen store NODE` and `canopen restore NODE`: store parameters (0x1010) and restore
//! default parameters (0x1011) of CiA 301 §7.5.2.13/14, through
//! [`canola::Node::store_parameters_of`] and [`canola::Node::restore_defaults_of`].

use std::process::ExitCode;

use canola::{NodeId, ParameterGroup};
use clap::{Args, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, open_network, parse_node};
use crate::{Global, outln};

/// Which parameters: the sub-index of 0x1010/0x1011.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Group {
    /// Sub-index 1: all parameters.
    All,
    /// Sub-index 2: communication parameters (0x1000..0x1FFF).
    Communication,
    /// Sub-index 3: application parameters (0x6000..0x9FFF).
    Application,
    /// Sub-index 4: manufacturer-specific parameters (0x2000..0x5FFF).
    Manufacturer,
}

impl Group {
    fn parameters(self) -> ParameterGroup {
        match self {
            Self::All => ParameterGroup::All,
            Self::Communication => ParameterGroup::Communication,
            Self::Application => ParameterGroup::Application,
            Self::Manufacturer => ParameterGroup::Manufacturer,
        }
    }
}

/// `store NODE [--group G]` / `restore NODE [--group G]`.
#[derive(Debug, Args)]
pub(crate) struct StoreArgs {
    /// Node-ID.
    #[arg(value_parser = parse_node)]
    node: NodeId,
    /// Which parameters (default: all, sub-index 1).
    #[arg(long, value_enum, default_value = "all")]
    group: Group,
}

/// `canopen store` (`restore` false) or `canopen restore` (`restore` true).
pub(crate) fn run(args: StoreArgs, restore: bool, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let node = net.node(args.node);
    let group = args.group.parameters();
    let r = if restore {
        node.restore_defaults_of(group)
    } else {
        node.store_parameters_of(group)
    };
    if let Err(e) = r.wait() {
        return fail(e);
    }
    let name = args
        .group
        .to_possible_value()
        .map(|v| v.get_name().to_string())
        .unwrap_or_default();
    let index = if restore { 0x1011 } else { 0x1010 };
    if g.json {
        let done = if restore { "restored" } else { "stored" };
        outln(
            &json!({"node": args.node.get(), "index": index, "sub": group.sub_index(), done: name})
                .to_string(),
        );
    } else if restore {
        eprintln!(
            "node {}: {name} parameters restored to their defaults (0x{index:04X}:{:02X}); \
             they take effect at the next reset (`canopen nmt reset {}`)",
            args.node,
            group.sub_index(),
            args.node
        );
    } else {
        eprintln!(
            "node {}: {name} parameters stored (0x{index:04X}:{:02X})",
            args.node,
            group.sub_index()
        );
    }
    ExitCode::SUCCESS
}
