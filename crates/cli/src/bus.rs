//! The bus commands: `sdo`, `nmt`, `scan`, `monitor`, `simulate`, `record`, `replay`, `demo`.
//!
//! The bus is SocketCAN with `--iface IFACE`, else an in-memory bus on a virtual clock. On the
//! in-memory bus every `--eds NODE=FILE` node is also simulated (a `canopen::SimDevice` from that
//! file), so every command has a device to talk to without hardware.

use std::io::{IsTerminal, Write as _};
use std::path::PathBuf;
use std::process::ExitCode;

use can_frame::{CanFrame, Duration, NodeId};
use canopen::candump::{self, LogEntry, LogFrame};
use canopen::mem::MemoryBus;
use canopen::transport::{Received, Transport};
use canopen::{Entry, Error, Network, SimDevice};
use canopen_od::{DataType, ObjectDictionary, Value};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

use crate::{Global, outln};

/// Options of the bus commands.
#[derive(Debug, Clone, Args)]
pub(crate) struct BusOpts {
    /// SocketCAN interface (e.g. can0, vcan0); without it, an in-memory simulated bus.
    #[arg(long, global = true)]
    iface: Option<String>,
    /// Object dictionary of a node, NODE=FILE (repeatable). On the in-memory bus the node is
    /// also simulated from that file.
    #[arg(id = "node_eds", long = "eds", value_name = "NODE=FILE", global = true)]
    node_eds: Vec<String>,
}

impl BusOpts {
    /// The SocketCAN interface, if one was given.
    pub(crate) fn iface(&self) -> Option<&str> {
        self.iface.as_deref()
    }
}

fn parse_u16(s: &str) -> Result<u16, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u16::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|e| format!("`{s}`: {e}"))
}

fn parse_u8(s: &str) -> Result<u8, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u8::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|e| format!("`{s}`: {e}"))
}

fn parse_node(s: &str) -> Result<NodeId, String> {
    let v = parse_u8(s)?;
    NodeId::new(v).map_err(|e| e.to_string())
}

/// Value types for `--type`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Ty {
    U8,
    U16,
    U32,
    U64,
    I8,
    I16,
    I32,
    I64,
    F32,
    F64,
    Str,
    Bytes,
}

impl Ty {
    fn data_type(self) -> DataType {
        match self {
            Self::U8 => DataType::Unsigned8,
            Self::U16 => DataType::Unsigned16,
            Self::U32 => DataType::Unsigned32,
            Self::U64 => DataType::Unsigned64,
            Self::I8 => DataType::Integer8,
            Self::I16 => DataType::Integer16,
            Self::I32 => DataType::Integer32,
            Self::I64 => DataType::Integer64,
            Self::F32 => DataType::Real32,
            Self::F64 => DataType::Real64,
            Self::Str => DataType::VisibleString,
            Self::Bytes => DataType::Domain,
        }
    }
}

#[derive(Debug, Subcommand)]
pub(crate) enum SdoCommand {
    /// Read an object; prints the value alone.
    Read {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Index (0x hex or decimal).
        #[arg(value_parser = parse_u16)]
        index: u16,
        /// Sub-index.
        #[arg(value_parser = parse_u8)]
        sub: u8,
        /// Value type (default: from --eds, else bytes).
        #[arg(long = "type", value_enum)]
        ty: Option<Ty>,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Write an object.
    Write {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Index.
        #[arg(value_parser = parse_u16)]
        index: u16,
        /// Sub-index.
        #[arg(value_parser = parse_u8)]
        sub: u8,
        /// The value (integers decimal or 0x hex; bytes as hex).
        value: String,
        /// Value type (default: from --eds).
        #[arg(long = "type", value_enum)]
        ty: Option<Ty>,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Upload an object into a file.
    Upload {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Index.
        #[arg(value_parser = parse_u16)]
        index: u16,
        /// Sub-index.
        #[arg(value_parser = parse_u8)]
        sub: u8,
        /// Output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Download a file into an object.
    Download {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        /// Index.
        #[arg(value_parser = parse_u16)]
        index: u16,
        /// Sub-index.
        #[arg(value_parser = parse_u8)]
        sub: u8,
        /// Input file.
        file: PathBuf,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
}

/// NMT commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum NmtCmd {
    Start,
    Stop,
    Preop,
    Reset,
    ResetComm,
}

/// The bus as a transport plus the simulated devices on it.
struct Bus {
    transport: Box<dyn Transport>,
    memory: Option<MemoryBus>,
    dictionaries: Vec<(NodeId, ObjectDictionary)>,
}

fn load_eds(spec: &str) -> Result<(NodeId, ObjectDictionary), String> {
    let (node, file) = spec
        .split_once('=')
        .ok_or_else(|| format!("--eds {spec}: expected NODE=FILE"))?;
    let node = parse_node(node)?;
    let text = std::fs::read(file).map_err(|e| format!("{file}: {e}"))?;
    let od = canopen_od::parse(&text)
        .map_err(|e| format!("{file}: {e}"))?
        .od;
    Ok((node, od))
}

fn open(opts: &BusOpts) -> Result<Bus, String> {
    let dictionaries = opts
        .node_eds
        .iter()
        .map(|s| load_eds(s))
        .collect::<Result<Vec<_>, _>>()?;
    match &opts.iface {
        Some(iface) => {
            let t =
                canopen::socketcan::SocketCan::open(iface).map_err(|e| format!("{iface}: {e}"))?;
            Ok(Bus {
                transport: Box::new(t),
                memory: None,
                dictionaries,
            })
        }
        None => {
            let bus = MemoryBus::new();
            // The master's endpoint first, so it sees the devices' boot-up messages.
            let endpoint = bus.endpoint();
            for (node, od) in &dictionaries {
                bus.attach(SimStation::for_dictionary(*node, od.clone()));
            }
            Ok(Bus {
                transport: Box::new(endpoint),
                memory: Some(bus),
                dictionaries,
            })
        }
    }
}

/// Opens the bus (see [`BusOpts`]) and a network on it.
pub(crate) fn open_network(opts: &BusOpts) -> Result<(Network, Option<MemoryBus>), String> {
    open(opts).map(network)
}

fn network(bus: Bus) -> (Network, Option<MemoryBus>) {
    let net = Network::new(bus.transport);
    for (node, od) in bus.dictionaries {
        net.add_node_with_dictionary(node, od);
    }
    (net, bus.memory)
}

fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::FAILURE
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn format_value(v: &Value) -> String {
    match v {
        Value::VisibleString(b) => String::from_utf8_lossy(b).into_owned(),
        Value::OctetString(b) | Value::Domain(b) => hex(b),
        Value::Real32(x) => x.to_string(),
        Value::Real64(x) => x.to_string(),
        other => match other.as_i128() {
            Some(i) => i.to_string(),
            None => other.to_eds_text(),
        },
    }
}

fn json_value(v: &Value) -> serde_json::Value {
    match v {
        Value::VisibleString(b) => json!(String::from_utf8_lossy(b)),
        Value::OctetString(b) | Value::Domain(b) => json!(hex(b)),
        Value::Real32(x) => json!(x),
        Value::Real64(x) => json!(x),
        other => match other.as_i128().and_then(|i| i64::try_from(i).ok()) {
            Some(i) => json!(i),
            None => json!(other.to_eds_text()),
        },
    }
}

fn parse_value(dt: DataType, text: &str) -> Result<Vec<u8>, String> {
    match dt {
        DataType::VisibleString => Ok(text.as_bytes().to_vec()),
        DataType::Domain | DataType::OctetString => {
            let t = text.trim_start_matches("0x");
            if !t.len().is_multiple_of(2) {
                return Err(format!("`{text}`: hex bytes need an even number of digits"));
            }
            (0..t.len())
                .step_by(2)
                .map(|i| {
                    t.get(i..i + 2)
                        .and_then(|p| u8::from_str_radix(p, 16).ok())
                        .ok_or_else(|| format!("`{text}` is not hex"))
                })
                .collect()
        }
        DataType::Real32 => text
            .parse::<f32>()
            .map(|f| f.to_le_bytes().to_vec())
            .map_err(|e| format!("`{text}`: {e}")),
        DataType::Real64 => text
            .parse::<f64>()
            .map(|f| f.to_le_bytes().to_vec())
            .map_err(|e| format!("`{text}`: {e}")),
        dt => {
            let (neg, body) = match text.strip_prefix('-') {
                Some(b) => (true, b),
                None => (false, text),
            };
            let mag = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
                Some(h) => i128::from_str_radix(h, 16),
                None => body.parse::<i128>(),
            }
            .map_err(|e| format!("`{text}`: {e}"))?;
            let v = if neg { -mag } else { mag };
            let value = Value::from_i128_wrapping(dt, v)
                .ok_or_else(|| format!("cannot write `{text}` as {dt:?}"))?;
            if value.as_i128() != Some(v) {
                return Err(format!("`{text}` is out of range for {dt:?}"));
            }
            Ok(value.to_le_bytes())
        }
    }
}

fn data_type_of(net: &Network, node: NodeId, entry: Entry, ty: Option<Ty>) -> Option<DataType> {
    ty.map(Ty::data_type).or_else(|| {
        net.node(node)
            .dictionary()
            .and_then(|od| od.sub(entry.index, entry.sub).map(|s| s.data_type))
    })
}

struct Bar {
    on: bool,
}

impl Bar {
    fn new() -> Self {
        Self {
            on: std::io::stderr().is_terminal(),
        }
    }
    fn callback(&self) -> impl FnMut(canopen::TransferProgress) + Send + 'static {
        let on = self.on;
        move |p| {
            if !on {
                return;
            }
            let line = match p.total {
                Some(t) if t > 0 => {
                    let filled = (p.done * 30 / t) as usize;
                    format!(
                        "\r[{}{}] {}/{} bytes",
                        "#".repeat(filled),
                        " ".repeat(30 - filled.min(30)),
                        p.done,
                        t
                    )
                }
                _ => format!("\r{} bytes", p.done),
            };
            let _ = std::io::stderr().write_all(line.as_bytes());
        }
    }
    fn finish(&self) {
        if self.on {
            eprintln!();
        }
    }
}

/// `canopen sdo ...`
pub(crate) fn run_sdo(cmd: SdoCommand, opts: &BusOpts, g: Global) -> ExitCode {
    let bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let (net, _mem) = network(bus);
    match cmd {
        SdoCommand::Read {
            node,
            index,
            sub,
            ty,
            block,
        } => {
            let entry = Entry::new(index, sub);
            let bytes = match net.node(node).sdo().block(block).read(entry) {
                Ok(b) => b,
                Err(e) => return fail(e),
            };
            let dt = data_type_of(&net, node, entry, ty).unwrap_or(DataType::Domain);
            let value = match Value::from_le_bytes(dt, &bytes) {
                Ok(v) => v,
                Err(e) => return fail(format!("node {node}, object {entry}: {e}")),
            };
            if g.json {
                outln(
                    &json!({"node": node.get(), "index": index, "sub": sub,
                            "value": json_value(&value), "raw": hex(&bytes)})
                    .to_string(),
                );
            } else {
                outln(&format_value(&value));
            }
            ExitCode::SUCCESS
        }
        SdoCommand::Write {
            node,
            index,
            sub,
            value,
            ty,
            block,
        } => {
            let entry = Entry::new(index, sub);
            let Some(dt) = data_type_of(&net, node, entry, ty) else {
                return fail(format!(
                    "node {node}, object {entry}: give --type (or --eds {node}=FILE)"
                ));
            };
            let bytes = match parse_value(dt, &value) {
                Ok(b) => b,
                Err(e) => return fail(e),
            };
            match net.node(node).sdo().block(block).write(entry, bytes) {
                Ok(()) => {
                    if g.json {
                        outln(
                            &json!({"node": node.get(), "index": index, "sub": sub, "ok": true})
                                .to_string(),
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        SdoCommand::Upload {
            node,
            index,
            sub,
            output,
            block,
        } => {
            let file = match std::fs::File::create(&output) {
                Ok(f) => f,
                Err(e) => return fail(format!("{}: {e}", output.display())),
            };
            let bar = Bar::new();
            let r = net
                .node(node)
                .sdo()
                .block(block)
                .on_progress(bar.callback())
                .upload_to((index, sub), std::io::BufWriter::new(file));
            bar.finish();
            match r {
                Ok(n) => {
                    if g.json {
                        outln(
                            &json!({"node": node.get(), "index": index, "sub": sub, "bytes": n})
                                .to_string(),
                        );
                    } else {
                        eprintln!("{n} bytes written to {}", output.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        SdoCommand::Download {
            node,
            index,
            sub,
            file,
            block,
        } => {
            let f = match std::fs::File::open(&file) {
                Ok(f) => f,
                Err(e) => return fail(format!("{}: {e}", file.display())),
            };
            let bar = Bar::new();
            let r = net
                .node(node)
                .sdo()
                .block(block)
                .on_progress(bar.callback())
                .download_from((index, sub), f);
            bar.finish();
            match r {
                Ok(n) => {
                    if g.json {
                        outln(
                            &json!({"node": node.get(), "index": index, "sub": sub, "bytes": n})
                                .to_string(),
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
    }
}

/// `canopen nmt CMD NODE|all`
pub(crate) fn run_nmt(cmd: NmtCmd, target: &str, opts: &BusOpts, g: Global) -> ExitCode {
    use canopen_nmt::CommandSpecifier as C;
    let bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let (net, _mem) = network(bus);
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
                    &json!({"nmt": format!("{cmd:?}").to_lowercase(), "target": target})
                        .to_string(),
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// Reads the identity object (0x1018 sub 1..=4) of every node that answers.
fn scan_nodes(net: &Network, timeout: Duration) -> Vec<(NodeId, [Option<u32>; 4])> {
    let pending: Vec<_> = NodeId::all()
        .map(|n| {
            (
                n,
                net.node(n).sdo().timeout(timeout).submit_read((0x1018, 1)),
            )
        })
        .collect();
    let mut found = Vec::new();
    for (n, p) in pending {
        if let Ok(canopen::Completion::Data(v)) = p.wait() {
            let mut ident = [None; 4];
            ident[0] = v
                .get(..4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            for s in 2..=4u8 {
                if let Ok(v) = net.node(n).sdo().timeout(timeout).read((0x1018, s))
                    && let Some(b) = v.get(..4)
                {
                    ident[usize::from(s) - 1] = Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                }
            }
            found.push((n, ident));
        }
    }
    found
}

/// `canopen scan`
pub(crate) fn run_scan(opts: &BusOpts, g: Global) -> ExitCode {
    let bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let (net, _mem) = network(bus);
    let found = scan_nodes(&net, Duration::from_millis(200));
    let fmt = |v: Option<u32>| v.map_or("-".to_string(), |v| format!("{v:#010x}"));
    if g.json {
        let list: Vec<_> = found
            .iter()
            .map(|(n, id)| {
                json!({"node": n.get(), "vendor_id": id[0], "product_code": id[1],
                       "revision": id[2], "serial": id[3]})
            })
            .collect();
        outln(&serde_json::Value::Array(list).to_string());
    } else {
        outln("node  vendor-id   product     revision    serial");
        for (n, id) in &found {
            outln(&format!(
                "{:>4}  {}  {}  {}  {}",
                n.get(),
                fmt(id[0]),
                fmt(id[1]),
                fmt(id[2]),
                fmt(id[3])
            ));
        }
    }
    ExitCode::SUCCESS
}

/// One line of decoded traffic (CiA 301 predefined connection set, CiA 305 LSS).
pub(crate) fn decode(frame: &CanFrame) -> String {
    use can_frame::cob::FunctionCode as F;
    let Some(raw) = frame.cob_id() else {
        return format!("{frame}  (extended identifier)");
    };
    let d = frame.data();
    let what = match can_frame::CobId::classify(raw) {
        Some(c) => match (c.function, c.node) {
            (F::Nmt, _) => match canopen_nmt::NmtCommand::parse(d) {
                Ok(cmd) => format!("NMT {cmd:?}"),
                Err(e) => format!("NMT (bad: {e})"),
            },
            (F::Sync, _) => "SYNC".into(),
            (F::Time, _) => "TIME".into(),
            (F::Emcy, Some(n)) => match canopen_nmt::Emcy::parse(d) {
                Ok(e) => format!(
                    "EMCY node {n}: {} ({}), error register {}",
                    e.code,
                    e.code.description().unwrap_or("unknown"),
                    e.register
                ),
                Err(e) => format!("EMCY node {n} (bad: {e})"),
            },
            (F::Tpdo(p), Some(n)) => format!("TPDO{} node {n}: {}", p.get(), hex(d)),
            (F::Rpdo(p), Some(n)) => format!("RPDO{} node {n}: {}", p.get(), hex(d)),
            (F::SdoRx, Some(n)) => format!("SDO request to node {n}: {}", sdo_text(d, true)),
            (F::SdoTx, Some(n)) => format!("SDO response from node {n}: {}", sdo_text(d, false)),
            (F::NmtErrorControl, Some(n)) if frame.is_remote() => {
                format!("node guarding request to node {n}")
            }
            (F::NmtErrorControl, Some(n)) => match d.first() {
                Some(0) => format!("boot-up of node {n}"),
                Some(b) => format!(
                    "heartbeat node {n}: {}",
                    canopen_nmt::NmtState::from_u8(b & 0x7F)
                ),
                None => format!("error control node {n}: empty"),
            },
            (F::LssMasterToSlave, _) => match canopen_lss::Request::from_frame(frame) {
                Ok(r) => format!("LSS request {r:?}"),
                Err(e) => format!("LSS request (bad: {e})"),
            },
            (F::LssSlaveToMaster, _) => match canopen_lss::Response::from_frame(frame) {
                Ok(r) => format!("LSS response {r:?}"),
                Err(e) => format!("LSS response (bad: {e})"),
            },
            _ => hex(d),
        },
        None => hex(d),
    };
    format!("{frame:<28} {what}")
}

fn sdo_text(d: &[u8], request: bool) -> String {
    let Some(&cmd) = d.first() else {
        return "empty".into();
    };
    let mux = if d.len() >= 4 {
        format!("{:#06x}:{:02x}", u16::from_le_bytes([d[1], d[2]]), d[3])
    } else {
        String::new()
    };
    if cmd == 0x80 && d.len() >= 8 {
        let code = canopen_sdo::AbortCode(u32::from_le_bytes([d[4], d[5], d[6], d[7]]));
        return format!("abort {mux} {}", canopen::describe_abort(code));
    }
    let ccs = cmd >> 5;
    let initiate = |name: &str| format!("{name} {mux}");
    match (request, ccs) {
        (true, 1) => initiate("initiate download"),
        (true, 2) => initiate("initiate upload"),
        (true, 0) => format!(
            "download segment (toggle {}, last {})",
            (cmd >> 4) & 1,
            cmd & 1
        ),
        (true, 3) => format!("upload segment request (toggle {})", (cmd >> 4) & 1),
        (true, 5) if cmd & 0x03 == 0 => initiate("initiate block upload"),
        (true, 5) => format!("block upload command {:#04x}", cmd),
        (true, 6) if cmd & 0x01 == 0 => initiate("initiate block download"),
        (true, 6) => "end block download".into(),
        (false, 3) => initiate("initiate download response"),
        (false, 2) => initiate("initiate upload response"),
        (false, 1) => format!("download segment response (toggle {})", (cmd >> 4) & 1),
        (false, 6) if cmd & 0x01 == 0 => initiate("initiate block upload response"),
        (false, 5) if cmd & 0x03 == 0 => initiate("initiate block download response"),
        (false, 5) if cmd & 0x03 == 2 => format!(
            "block download ack (seq {})",
            d.get(1).copied().unwrap_or(0)
        ),
        (false, 5) => "end block download response".into(),
        // Upload segments and block segments share the other codes; without transfer state
        // they read as data.
        (false, _) => format!("segment data (command byte {cmd:#04x})"),
        (true, _) => format!("data/block segment (command byte {cmd:#04x})"),
    }
}

/// Runs the in-memory bus (and its simulated devices) or the real one for `secs`, handing each
/// received frame to `f`.
fn pump(
    bus: &mut Bus,
    secs: Option<f64>,
    mut f: impl FnMut(&CanFrame, can_frame::Instant),
) -> Result<(), String> {
    let start = bus.transport.now();
    let end = secs.map(|s| start + Duration::from_micros((s * 1e6) as u64));
    if end.is_none() && bus.memory.is_some() {
        return Err("on the in-memory bus give --duration SECONDS".into());
    }
    loop {
        let now = bus.transport.now();
        let deadline = end.unwrap_or(now + Duration::from_millis(200));
        if end.is_some_and(|e| now >= e) {
            return Ok(());
        }
        match bus.transport.recv_until(deadline) {
            Ok(Some(Received::Frame { frame, at })) => f(&frame, at),
            Ok(Some(Received::Event(e))) => eprintln!("bus: {e}"),
            Ok(None) => {}
            Err(e) => return Err(e.to_string()),
        }
    }
}

/// `canopen monitor`
pub(crate) fn run_monitor(
    opts: &BusOpts,
    duration: Option<f64>,
    devicenet: bool,
    g: Global,
) -> ExitCode {
    let mut bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let pdos = PdoDecoder::from_dictionaries(&bus.dictionaries);
    let r = pump(&mut bus, duration, |frame, at| {
        let text = if devicenet {
            devicenet::decode(frame).to_string()
        } else {
            pdos.decode(frame).unwrap_or_else(|| decode(frame))
        };
        if g.json {
            outln(&json!({"time": at.as_micros() as f64 / 1e6, "frame": frame.to_string(), "decoded": text}).to_string());
        } else {
            outln(&format!("{at}  {text}"));
        }
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// Decodes PDO frames through the mappings of the `--eds` dictionaries: for every node with a
/// dictionary, each TPDO (0x1800/0x1A00..) and RPDO (0x1400/0x1600..) whose COB-ID is valid,
/// with the mapped objects named from the dictionary.
struct PdoDecoder {
    by_cob_id: std::collections::HashMap<u16, PdoLayout>,
}

struct PdoLayout {
    label: String,
    mapping: canopen_pdo::Mapping,
    names: Vec<String>,
}

impl PdoDecoder {
    fn from_dictionaries(dictionaries: &[(NodeId, canopen_od::ObjectDictionary)]) -> Self {
        use canopen_pdo::{CommParams, Direction, Mapping};
        let mut by_cob_id = std::collections::HashMap::new();
        for (node, od) in dictionaries {
            let view = canopen_pdo::od::OdView::new(od, node.get());
            for (kind, comm_base, map_base, direction) in [
                ("TPDO", 0x1800u16, 0x1A00u16, Direction::Transmit),
                ("RPDO", 0x1400, 0x1600, Direction::Receive),
            ] {
                for n in 0..512u16 {
                    let (Ok(comm), Ok(mapping)) = (
                        CommParams::read_from(&view, comm_base + n),
                        Mapping::read_from(&view, direction, map_base + n),
                    ) else {
                        continue;
                    };
                    let Ok(can_frame::CanId::Standard(id)) = comm.cob_id.can_id() else {
                        continue;
                    };
                    if !comm.cob_id.is_valid() || mapping.is_empty() {
                        continue;
                    }
                    let names = mapping
                        .objects()
                        .iter()
                        .map(|o| {
                            let (i, s) = (o.entry.index(), o.entry.subindex());
                            match (od.get(i), od.sub(i, s)) {
                                (Some(obj), Some(sub)) if !obj.is_simple() => {
                                    format!("{} / {}", obj.name, sub.name)
                                }
                                (Some(obj), _) => obj.name.to_string(),
                                _ => format!("{i:#06x}:{s:02x}"),
                            }
                        })
                        .collect();
                    let label = format!("{kind}{} node {node}", n + 1);
                    by_cob_id.insert(
                        id.as_raw(),
                        PdoLayout {
                            label,
                            mapping,
                            names,
                        },
                    );
                }
            }
        }
        Self { by_cob_id }
    }

    fn decode(&self, frame: &CanFrame) -> Option<String> {
        let layout = self.by_cob_id.get(&frame.cob_id()?)?;
        if frame.is_remote() {
            return None;
        }
        let values = match canopen_pdo::unpack(&layout.mapping, frame.data()) {
            Ok(v) => v,
            Err(e) => {
                return Some(format!(
                    "{}: {} (does not fit its mapping: {e})",
                    layout.label,
                    hex(frame.data())
                ));
            }
        };
        let fields: Vec<String> = values
            .iter()
            .zip(&layout.names)
            .map(|((_, v), name)| format!("{name} = {}", pdo_value(&v)))
            .collect();
        Some(format!("{}: {}", layout.label, fields.join(", ")))
    }
}

fn pdo_value(v: &canopen_pdo::Value) -> String {
    use canopen_pdo::Value as V;
    match v {
        V::Bool(b) => b.to_string(),
        V::Unsigned(u) => u.to_string(),
        V::Signed(i) => i.to_string(),
        V::Real32(f) => f.to_string(),
        V::Real64(f) => f.to_string(),
        V::Bytes(b) => format!("{b:?}"),
    }
}

/// `canopen record -o FILE`
pub(crate) fn run_record(opts: &BusOpts, output: &PathBuf, duration: Option<f64>) -> ExitCode {
    let mut bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let file = match std::fs::File::create(output) {
        Ok(f) => f,
        Err(e) => return fail(format!("{}: {e}", output.display())),
    };
    let iface = opts.iface.clone().unwrap_or_else(|| "mem0".into());
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let start = bus.transport.now();
    let mut w = candump::Writer::new(std::io::BufWriter::new(file));
    let mut err = None;
    let r = pump(&mut bus, duration, |frame, at| {
        let entry = LogEntry {
            timestamp_us: epoch + (at - start).as_micros(),
            interface: iface.clone(),
            frame: LogFrame::Can(*frame),
        };
        if let Err(e) = w.write(&entry) {
            err = Some(e);
        }
    });
    let _ = w.flush();
    match (r, err) {
        (Ok(()), None) => ExitCode::SUCCESS,
        (Err(e), _) => fail(e),
        (_, Some(e)) => fail(e),
    }
}

/// `canopen replay FILE`
pub(crate) fn run_replay(opts: &BusOpts, file: &PathBuf, g: Global) -> ExitCode {
    let mut bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let f = match std::fs::File::open(file) {
        Ok(f) => f,
        Err(e) => return fail(format!("{}: {e}", file.display())),
    };
    let mut first: Option<u64> = None;
    let start = bus.transport.now();
    let mut sent = 0u64;
    for entry in candump::Reader::new(std::io::BufReader::new(f)) {
        let entry = match entry {
            Ok(e) => e,
            Err(e) => return fail(format!("{}: {e}", file.display())),
        };
        let LogFrame::Can(frame) = entry.frame else {
            continue;
        };
        let t0 = *first.get_or_insert(entry.timestamp_us);
        let due = start + Duration::from_micros(entry.timestamp_us.saturating_sub(t0));
        // Keep the recorded spacing (receiving meanwhile, so simulated devices run).
        while bus.transport.now() < due {
            if let Err(e) = bus.transport.recv_until(due) {
                return fail(e);
            }
        }
        if let Err(e) = bus.transport.send(&frame) {
            return fail(e);
        }
        sent += 1;
    }
    if g.json {
        outln(&json!({"sent": sent}).to_string());
    } else {
        eprintln!("{sent} frames replayed");
    }
    ExitCode::SUCCESS
}

/// A simulated device for a dictionary: the Bürkert device (locating, NE 107, logbook, resets
/// through 0x2001) when the dictionary carries the Bürkert profile, the generic simulator otherwise.
pub(crate) enum SimStation {
    /// Any EDS.
    Generic(Box<SimDevice>),
    /// An EDS with the Bürkert profile objects.
    Burkert(Box<burkert_profile::BurkertDevice>),
}

impl SimStation {
    pub(crate) fn for_dictionary(node: NodeId, od: canopen_od::ObjectDictionary) -> Self {
        // The profile's device description, communication, status and locating objects.
        let burkert = [(0x2000, 1), (0x2001, 4), (0x2004, 1), (0x2101, 1)]
            .iter()
            .all(|&(i, s)| od.sub(i, s).is_some());
        if burkert {
            Self::Burkert(Box::new(burkert_profile::BurkertDevice::with_dictionary(
                node, od,
            )))
        } else {
            Self::Generic(Box::new(SimDevice::new(node, od)))
        }
    }

    fn station(&mut self) -> &mut dyn canopen::Station {
        match self {
            Self::Generic(d) => d.as_mut(),
            Self::Burkert(d) => d.as_mut(),
        }
    }
}

impl canopen::Station for SimStation {
    fn handle_frame(&mut self, now: can_frame::Instant, frame: &can_frame::CanFrame) {
        self.station().handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: can_frame::Instant) {
        self.station().handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<can_frame::CanFrame> {
        self.station().poll_transmit()
    }
    fn poll_timeout(&self) -> Option<can_frame::Instant> {
        match self {
            Self::Generic(d) => d.poll_timeout(),
            Self::Burkert(d) => d.poll_timeout(),
        }
    }
    fn handle_bus_event(&mut self, now: can_frame::Instant, event: &canopen::BusEvent) {
        self.station().handle_bus_event(now, event);
    }
}

/// `canopen simulate EDS --node-id N`
pub(crate) fn run_simulate(
    opts: &BusOpts,
    eds: &PathBuf,
    node: NodeId,
    duration: Option<f64>,
    g: Global,
) -> ExitCode {
    let text = match std::fs::read(eds) {
        Ok(t) => t,
        Err(e) => return fail(format!("{}: {e}", eds.display())),
    };
    let mut dev = match canopen_od::parse(&text) {
        Ok(parsed) => SimStation::for_dictionary(node, parsed.od),
        Err(e) => return fail(format!("{}: {e}", eds.display())),
    };
    let mut bus = match open(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    if opts.iface.is_none() && duration.is_none() {
        return fail("on the in-memory bus give --duration SECONDS");
    }
    eprintln!("simulating node {node} from {}", eds.display());
    if let Some(mem) = bus.memory.as_ref() {
        let secs = duration.unwrap_or(0.0);
        let mut tap = mem.endpoint();
        mem.attach(dev);
        mem.run_for(Duration::from_micros((secs * 1e6) as u64));
        while let Ok(Some(Received::Frame { frame, at })) = tap.try_recv() {
            if g.json {
                outln(
                    &json!({"time": at.as_micros() as f64 / 1e6, "frame": frame.to_string()})
                        .to_string(),
                );
            } else {
                outln(&format!("{at}  {}", decode(&frame)));
            }
        }
        return ExitCode::SUCCESS;
    }
    let started = std::time::Instant::now();
    let limit = duration.map(std::time::Duration::from_secs_f64);
    let r = canopen::run_station(&mut bus.transport, &mut dev, || {
        limit.is_some_and(|l| started.elapsed() >= l)
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// Convenience for the demo: an SDO error printed the way the CLI prints it.
pub(crate) fn explain(e: &Error) -> String {
    e.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn burkert(node: u8) -> (NodeId, canopen_od::ObjectDictionary) {
        let eds = include_bytes!("../../../eds/burkert-generic.eds");
        (
            NodeId::new(node).unwrap(),
            canopen_od::parse(eds).unwrap().od,
        )
    }

    #[test]
    fn monitor_decodes_pdos_through_the_eds_mapping() {
        let pdos = PdoDecoder::from_dictionaries(&[burkert(5)]);
        // TPDO1 of node 5 (0x185) maps sensor values 1 and 2, both REAL32.
        let mut data = [0u8; 8];
        data[..4].copy_from_slice(&1.5f32.to_le_bytes());
        data[4..].copy_from_slice(&(-2.25f32).to_le_bytes());
        let frame = CanFrame::new(can_frame::CanId::standard(0x185).unwrap(), &data).unwrap();
        assert_eq!(
            pdos.decode(&frame).as_deref(),
            Some("TPDO1 node 5: Sensor Value 1 / Value = 1.5, Sensor Value 2 / Value = -2.25")
        );
        // TPDO3 (0x385) carries the NE 107 status byte.
        let frame = CanFrame::new(can_frame::CanId::standard(0x385).unwrap(), &[2]).unwrap();
        assert_eq!(
            pdos.decode(&frame).as_deref(),
            Some("TPDO3 node 5: Device Status Object / Device Status NamurNe107 = 2")
        );
        // RPDO1 of node 5 (0x205) maps control values 1 and 2.
        let frame = CanFrame::new(can_frame::CanId::standard(0x205).unwrap(), &data).unwrap();
        assert!(
            pdos.decode(&frame)
                .unwrap()
                .starts_with("RPDO1 node 5: Control Value 1 / Value = 1.5")
        );
        // A frame too short for its mapping is reported, not decoded.
        let short = CanFrame::new(can_frame::CanId::standard(0x185).unwrap(), &[1, 2]).unwrap();
        assert!(
            pdos.decode(&short)
                .unwrap()
                .contains("does not fit its mapping")
        );
        // Nodes without a dictionary fall back to the generic decoder.
        let other = CanFrame::new(can_frame::CanId::standard(0x186).unwrap(), &[1]).unwrap();
        assert_eq!(pdos.decode(&other), None);
    }
}
