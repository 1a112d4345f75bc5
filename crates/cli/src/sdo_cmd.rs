//! `canopen sdo read|write|upload|download`: SDO transfers (CiA 301 §7.2.4) through the
//! library's [`canola::Sdo`], and `canopen usdo read|write`: USDO transfers (CANopen FD,
//! CiA 1301) through [`canola::Usdo`]; this module parses the arguments and the value text,
//! and prints.
//!
//! Values are typed by `--type`, else by the node's dictionary (`--eds NODE=FILE`), else, for
//! the communication profile (0x1000..0x1FFF), by the types CiA 301 gives its objects; a read
//! of an object of unknown type prints its bytes in hex and says so on stderr (`--json`:
//! `bytes`, no `value`).

use std::io::{IsTerminal, Write as _};
use std::path::PathBuf;
use std::process::ExitCode;

use canola::{DataType, Network, NodeId, ObjectAddress, Value};
use clap::{Subcommand, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, parse_node, parse_u8};
use crate::error::CliError;
use crate::outfile::OutFile;
use crate::{Global, outln};

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
    pub(crate) fn data_type(self) -> DataType {
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

/// How the SDO commands name an object (see `canopen sdo --help`).
const OBJECT_HELP: &str = "Object: index in hex (0x1017, as CANopen writes it) or decimal \
    (4119); with --eds NODE=FILE also its name from the dictionary (\"Producer heartbeat \
    time\", case-insensitive; \"OBJECT/SUB\" names a sub-object)";

/// SDO transfers. Objects are named by index (hex `0x1017`, CANopen's notation, or decimal)
/// and sub-index (default 0), or by their dictionary name with `--eds NODE=FILE`. Negative
/// values need no `--` (`sdo write 4 0x2120 1 -42 --type i64`); other values that start with
/// `-` go after `--`, and options may still follow them (`... 1 -- -0x10 -t i64`).
#[derive(Debug, Subcommand)]
pub(crate) enum SdoCommand {
    /// Read an object; prints the value alone (integers in decimal, `--hex` for unsigned ones
    /// in zero-padded hex).
    Read {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// Sub-index (default 0, or the sub-object a name selects).
        #[arg(value_parser = parse_u8)]
        sub: Option<u8>,
        /// Value type (default: from --eds, else bytes).
        #[arg(short = 't', long = "type", value_enum)]
        ty: Option<Ty>,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Write an object: `write NODE OBJECT [SUB] VALUE`. Negative numbers are values
    /// (`-42`); a value starting with another `-` (`-0x10`, or text) goes after `--`. Options
    /// may follow the value either way: `write 4 0x2120 1 -- -0x10 --type i64`.
    #[command(override_usage = "canopen sdo write [OPTIONS] <NODE> <OBJECT> [SUB] <VALUE>")]
    Write {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// `[SUB] VALUE`: the sub-index (default 0) and the value (integers decimal or 0x hex,
        /// negative ones as `-42`; bytes as hex).
        #[arg(num_args = 0..=2, value_names = ["SUB", "VALUE"],
              allow_negative_numbers = true)]
        args: Vec<String>,
        /// Value type (default: from --eds).
        #[arg(short = 't', long = "type", value_enum)]
        ty: Option<Ty>,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Upload an object into a file. The file appears when the upload succeeded: it is
    /// written under a temporary name beside it and renamed at the end.
    Upload {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// Sub-index (default 0).
        #[arg(value_parser = parse_u8)]
        sub: Option<u8>,
        /// Output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
    /// Download a file into an object: `download NODE OBJECT [SUB] FILE`.
    #[command(override_usage = "canopen sdo download [OPTIONS] <NODE> <OBJECT> [SUB] <FILE>")]
    Download {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// `[SUB] FILE`: the sub-index (default 0) and the input file.
        #[arg(num_args = 1..=2, required = true, value_names = ["SUB", "FILE"])]
        args: Vec<String>,
        /// Use block transfer.
        #[arg(long)]
        block: bool,
    },
}

/// USDO transfers (CANopen FD, CiA 1301) over CAN FD frames: the same objects and values as
/// `sdo`. The bus must carry CAN FD: on SocketCAN give `--fd` (an interface with MTU 72), on
/// the in-memory bus too (its `--eds` devices then serve USDO); the UDP bus carries CAN FD
/// frames without it. The node is taken as a CANopen FD device.
#[derive(Debug, Subcommand)]
pub(crate) enum UsdoCommand {
    /// Read an object; prints the value alone (as `sdo read`).
    Read {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// Sub-index (default 0, or the sub-object a name selects).
        #[arg(value_parser = parse_u8)]
        sub: Option<u8>,
        /// Value type (default: from --eds, else bytes).
        #[arg(short = 't', long = "type", value_enum)]
        ty: Option<Ty>,
    },
    /// Upload an object into a file (a DOMAIN, say), written whole or not at all (as `sdo
    /// upload`).
    Upload {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// Sub-index (default 0).
        #[arg(value_parser = parse_u8)]
        sub: Option<u8>,
        /// Output file.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Write an object: `write NODE OBJECT [SUB] VALUE` (values as `sdo write`).
    #[command(override_usage = "canopen usdo write [OPTIONS] <NODE> <OBJECT> [SUB] <VALUE>")]
    Write {
        /// Node-ID.
        #[arg(value_parser = parse_node)]
        node: NodeId,
        #[arg(help = OBJECT_HELP)]
        object: String,
        /// `[SUB] VALUE`: the sub-index (default 0) and the value.
        #[arg(num_args = 0..=2, value_names = ["SUB", "VALUE"],
              allow_negative_numbers = true)]
        args: Vec<String>,
        /// Value type (default: from --eds).
        #[arg(short = 't', long = "type", value_enum)]
        ty: Option<Ty>,
    },
}

/// `canopen usdo ...`
pub(crate) fn run_usdo(cmd: UsdoCommand, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match opts.open() {
        Ok(b) => b.into_network(),
        Err(e) => return fail(e),
    };
    let r = match cmd {
        UsdoCommand::Read {
            node,
            object,
            sub,
            ty,
        } => usdo_read(&net, node, &object, sub, ty, g),
        UsdoCommand::Upload {
            node,
            object,
            sub,
            output,
        } => usdo_upload(&net, node, &object, sub, &output, g),
        UsdoCommand::Write {
            node,
            object,
            args,
            ty,
        } => usdo_write(&net, node, &object, &args, ty, g),
    };
    r.unwrap_or_else(CliError::report)
}

fn usdo_read(
    net: &Network,
    node: NodeId,
    object: &str,
    sub: Option<u8>,
    ty: Option<Ty>,
    g: Global,
) -> Result<ExitCode, CliError> {
    let entry = address(net, node, object, sub)?;
    let n = net.node(node);
    n.set_fd(true);
    let bytes = n.usdo().read(entry).wait()?;
    let Some(dt) = data_type_of(net, node, entry, ty) else {
        if g.json {
            outln(&with(addr_json(node, entry), "bytes", json!(hex(&bytes))));
        } else if !too_long_for_terminal(&bytes, None, "usdo", node, entry) {
            outln(&hex(&bytes));
        }
        return Ok(ExitCode::SUCCESS);
    };
    let value = Value::from_le_bytes(dt, &bytes).map_err(|e| {
        CliError::Op(canola::Error::Value {
            node,
            entry,
            problem: canola::error::ValueProblem::Bytes(e),
        })
    })?;
    if !g.json && too_long_for_terminal(&bytes, Some(dt), "usdo", node, entry) {
        return Ok(ExitCode::SUCCESS);
    }
    if g.json {
        let mut v = addr_json(node, entry);
        v["raw"] = json!(hex(&bytes));
        outln(&with(v, "value", json_value(&value)));
    } else {
        outln(&format_value(&value, g.hex));
    }
    Ok(ExitCode::SUCCESS)
}

fn usdo_write(
    net: &Network,
    node: NodeId,
    object: &str,
    args: &[String],
    ty: Option<Ty>,
    g: Global,
) -> Result<ExitCode, CliError> {
    let (sub, value) = match sub_and_last(args, "the value to write") {
        Ok(v) => v,
        Err(e) => {
            let entry = address(net, node, object, None)?;
            return Err(e.at(node, entry));
        }
    };
    let entry = address(net, node, object, sub)?;
    let Some(dt) = data_type_of(net, node, entry, ty) else {
        return Err(no_type(node, entry));
    };
    let bytes = parse_value(dt, value).map_err(|e| e.into_usage().at(node, entry))?;
    let n = net.node(node);
    n.set_fd(true);
    n.usdo().write(entry, bytes).wait()?;
    if g.json {
        outln(&with(addr_json(node, entry), "ok", json!(true)));
    }
    Ok(ExitCode::SUCCESS)
}

fn usdo_upload(
    net: &Network,
    node: NodeId,
    object: &str,
    sub: Option<u8>,
    output: &std::path::Path,
    g: Global,
) -> Result<ExitCode, CliError> {
    let entry = address(net, node, object, sub)?;
    let n = net.node(node);
    n.set_fd(true);
    // Opened first: a file that cannot be written is said before the transfer.
    let file = OutFile::create(output)?;
    let bytes = n.usdo().read(entry).wait()?;
    let mut w = file.writer()?;
    w.write_all(&bytes)
        .and_then(|()| w.flush())
        .map_err(CliError::file(output))?;
    file.commit()?;
    if g.json {
        outln(&with(addr_json(node, entry), "bytes", json!(bytes.len())));
    } else {
        eprintln!("{} bytes written to {}", bytes.len(), output.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// Byte values longer than this are not printed in hex on a terminal.
const TERMINAL_BYTES: usize = 256;

/// Whether `bytes` (a value of type `dt`, `None` when unknown) are a byte value too long to
/// print in hex on a terminal: then a note on stderr gives their size and the `upload` of
/// `group` (`sdo`, `usdo`) that writes them to a file. Piped, they print whole.
fn too_long_for_terminal(
    bytes: &[u8],
    dt: Option<DataType>,
    group: &str,
    node: NodeId,
    entry: ObjectAddress,
) -> bool {
    let is_bytes = dt.is_none_or(|dt| matches!(dt, DataType::Domain | DataType::OctetString));
    if !is_bytes || bytes.len() <= TERMINAL_BYTES || !std::io::stdout().is_terminal() {
        return false;
    }
    let what = dt.map_or_else(|| "bytes".to_string(), |dt| format!("a {dt}"));
    let note = format!(
        "node {node}, object {entry}: {what} of {} bytes, not printed in hex on a terminal;          `canopen {group} upload {node} 0x{:04X} {} -o FILE` writes it to a file (or pipe the          output)",
        bytes.len(),
        entry.index,
        entry.sub_index
    );
    let mut fields = serde_json::Map::new();
    fields.insert("node".into(), node.get().into());
    fields.insert("index".into(), entry.index.into());
    fields.insert("sub".into(), entry.sub_index.into());
    fields.insert("size".into(), bytes.len().into());
    crate::bus::warn("note", &note, fields);
    true
}

/// Splits `[SUB] LAST` positionals; `what` names LAST in the message when it is missing.
fn sub_and_last<'a>(args: &'a [String], what: &str) -> Result<(Option<u8>, &'a str), CliError> {
    match args {
        [last] => Ok((None, last)),
        [sub, last] => Ok((Some(parse_u8(sub).map_err(CliError::into_usage)?), last)),
        [] => Err(CliError::usage(format!("{what} is missing"))),
        _ => Err(CliError::usage(format!("expected [SUB] and {what}"))),
    }
}

/// A write to an object of no known type (a usage error).
fn no_type(node: NodeId, entry: ObjectAddress) -> CliError {
    CliError::usage(format!("give --type (or --eds {node}=FILE)")).at(node, entry)
}

/// "a" or "an" before a data type's name, as it is read aloud (`an UNSIGNED16`, `a REAL32`).
fn article(dt: DataType) -> &'static str {
    let name = dt.to_string();
    if name.starts_with(['U', 'I', 'O']) {
        "an"
    } else {
        "a"
    }
}

/// The range an integer type holds, as `MIN..=MAX`.
fn integer_range(dt: DataType) -> Option<String> {
    let bits = dt.integer_bits()?;
    if dt == DataType::Boolean {
        return Some("0..=1".into());
    }
    Some(if dt.is_signed() {
        let max = (1i128 << (bits - 1)) - 1;
        format!("{}..={max}", -max - 1)
    } else {
        format!("0..={}", (1u128 << bits) - 1)
    })
}

/// The object address of `object` and `sub` on `node` (a usage error when it names none).
fn address(
    net: &Network,
    node: NodeId,
    object: &str,
    sub: Option<u8>,
) -> Result<ObjectAddress, CliError> {
    let od = net.node(node).dictionary();
    let r = crate::objaddr::resolve(object, od.as_deref()).map_err(CliError::into_usage)?;
    let sub = match (r.sub, sub) {
        (Some(named), Some(given)) if named != given => {
            return Err(CliError::usage(format!(
                "`{object}` is sub-index {named}, but sub-index {given} was given"
            )));
        }
        (named, given) => named.or(given).unwrap_or(0),
    };
    Ok(ObjectAddress::new(r.index, sub))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A value as the command prints it: the value's own text, except byte-typed objects as one
/// hex word (as `candump` prints data).
/// With `hex`, unsigned integers print zero-padded in hex (`0x00000039`).
pub(crate) fn format_value(v: &Value, hex_style: bool) -> String {
    match v {
        Value::OctetString(b) | Value::Domain(b) => hex(b),
        other if hex_style && is_unsigned(other) => format!("{other:#}"),
        other => other.to_string(),
    }
}

fn is_unsigned(v: &Value) -> bool {
    let dt = v.data_type();
    v.as_i128().is_some() && !dt.is_signed() && dt != DataType::Boolean
}

fn json_value(v: &Value) -> serde_json::Value {
    match v {
        Value::VisibleString(_) => json!(v.to_string()),
        Value::OctetString(b) | Value::Domain(b) => json!(hex(b)),
        Value::Real32(x) => json!(x),
        Value::Real64(x) => json!(x),
        other => match other.as_i128().and_then(|i| i64::try_from(i).ok()) {
            Some(i) => json!(i),
            None => json!(other.to_eds_text()),
        },
    }
}

fn out_of_range(text: &str, dt: DataType) -> CliError {
    CliError::Argument(match integer_range(dt) {
        Some(r) => format!("`{text}` is out of range for {dt} ({r})"),
        None => format!("`{text}` is out of range for {dt}"),
    })
}

pub(crate) fn parse_value(dt: DataType, text: &str) -> Result<Vec<u8>, CliError> {
    match dt {
        DataType::VisibleString => Ok(text.as_bytes().to_vec()),
        DataType::Domain | DataType::OctetString => {
            let t = text.trim_start_matches("0x");
            if !t.len().is_multiple_of(2) {
                return Err(CliError::Argument(format!(
                    "`{text}`: hex bytes need an even number of digits"
                )));
            }
            (0..t.len())
                .step_by(2)
                .map(|i| {
                    t.get(i..i + 2)
                        .and_then(|p| u8::from_str_radix(p, 16).ok())
                        .ok_or_else(|| CliError::Argument(format!("`{text}` is not hex")))
                })
                .collect()
        }
        DataType::Real32 => text
            .parse::<f32>()
            .map(|f| f.to_le_bytes().to_vec())
            .map_err(|_| CliError::Argument(format!("`{text}` is not a REAL32 value"))),
        DataType::Real64 => text
            .parse::<f64>()
            .map(|f| f.to_le_bytes().to_vec())
            .map_err(|_| CliError::Argument(format!("`{text}` is not a REAL64 value"))),
        dt => {
            let (neg, body) = match text.strip_prefix('-') {
                Some(b) => (true, b),
                None => (false, text),
            };
            let mag = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
                Some(h) => i128::from_str_radix(h, 16),
                None => body.parse::<i128>(),
            }
            .map_err(|e| match e.kind() {
                std::num::IntErrorKind::PosOverflow | std::num::IntErrorKind::NegOverflow
                    if dt.integer_bits().is_some() =>
                {
                    out_of_range(text, dt)
                }
                _ => CliError::Argument(format!("`{text}` is not {} {dt} value", article(dt))),
            })?;
            let v = if neg { -mag } else { mag };
            let value = Value::from_i128_wrapping(dt, v)
                .ok_or_else(|| CliError::Argument(format!("cannot write `{text}` as {dt}")))?;
            if value.as_i128() != Some(v) {
                return Err(out_of_range(text, dt));
            }
            Ok(value.to_le_bytes())
        }
    }
}

/// The type of `entry` on `node`: `--type`, else the node's dictionary, else the type CiA 301
/// gives a communication profile object (0x1017 UNSIGNED16 on every device).
fn data_type_of(
    net: &Network,
    node: NodeId,
    entry: ObjectAddress,
    ty: Option<Ty>,
) -> Option<DataType> {
    ty.map(Ty::data_type)
        .or_else(|| {
            net.node(node)
                .dictionary()
                .and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type))
        })
        .or_else(|| canola::od::profile::communication_type(entry.index, entry.sub_index))
        .or_else(|| crate::drive_cmd::profile_type(net, node, entry))
}

/// The transfer's progress bar on stderr, drawn only when stderr is a terminal; a transfer
/// that succeeds ends it at 100 %.
struct Bar {
    on: bool,
}

fn bar_line(done: u64, total: Option<u64>) -> String {
    match total {
        Some(t) if t > 0 => {
            let filled = (done.min(t) * 30 / t) as usize;
            format!(
                "\r[{}{}] {done}/{t} bytes {:>3} %",
                "#".repeat(filled),
                " ".repeat(30 - filled),
                done.min(t) * 100 / t
            )
        }
        _ => format!("\r{done} bytes"),
    }
}

impl Bar {
    fn new() -> Self {
        Self {
            on: std::io::stderr().is_terminal(),
        }
    }
    fn callback(&self) -> impl FnMut(canola::TransferProgress) + Send + 'static {
        let on = self.on;
        move |p| {
            if on {
                let _ = std::io::stderr().write_all(bar_line(p.done, p.total).as_bytes());
            }
        }
    }
    /// Ends the bar: full with the byte count of a transfer that succeeded.
    fn finish(&self, done: Option<u64>) {
        if self.on {
            if let Some(n) = done {
                let _ = std::io::stderr().write_all(bar_line(n, Some(n)).as_bytes());
            }
            eprintln!();
        }
    }
}

/// `canopen sdo ...`
pub(crate) fn run(cmd: SdoCommand, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match opts.open() {
        Ok(b) => b.into_network(),
        Err(e) => return fail(e),
    };
    run_on(&net, cmd, g).unwrap_or_else(CliError::report)
}

/// Why a command failed: the master's error (with its fields), bad input (a usage error,
/// exit 2), or a local failure such as a file that cannot be opened (exit 1).
fn addr_json(node: NodeId, entry: ObjectAddress) -> serde_json::Value {
    json!({"node": node.get(), "index": entry.index, "sub": entry.sub_index})
}

fn with(mut base: serde_json::Value, key: &str, v: serde_json::Value) -> String {
    base[key] = v;
    base.to_string()
}

fn run_on(net: &Network, cmd: SdoCommand, g: Global) -> Result<ExitCode, CliError> {
    match cmd {
        SdoCommand::Read {
            node,
            object,
            sub,
            ty,
            block,
        } => {
            let entry = address(net, node, &object, sub)?;
            let Some(dt) = data_type_of(net, node, entry, ty) else {
                let bytes = net.node(node).sdo().block(block).read(entry).wait()?;
                let note = format!(
                    "node {node}, object {entry}: type unknown (not a CiA 301 communication \
                     object; give --type or --eds {node}=FILE), printed as its bytes in hex"
                );
                let mut fields = serde_json::Map::new();
                fields.insert("node".into(), node.get().into());
                fields.insert("index".into(), entry.index.into());
                fields.insert("sub".into(), entry.sub_index.into());
                crate::bus::warn("note", &note, fields);
                if g.json {
                    outln(&with(addr_json(node, entry), "bytes", json!(hex(&bytes))));
                } else if !too_long_for_terminal(&bytes, None, "sdo", node, entry) {
                    outln(&hex(&bytes));
                }
                return Ok(ExitCode::SUCCESS);
            };
            let value = net
                .node(node)
                .sdo()
                .block(block)
                .read_as(entry, dt)
                .wait()?;
            if !g.json && too_long_for_terminal(&value.to_le_bytes(), Some(dt), "sdo", node, entry)
            {
                return Ok(ExitCode::SUCCESS);
            }
            if g.json {
                let mut v = addr_json(node, entry);
                v["raw"] = json!(hex(&value.to_le_bytes()));
                outln(&with(v, "value", json_value(&value)));
            } else {
                outln(&format_value(&value, g.hex));
            }
        }
        SdoCommand::Write {
            node,
            object,
            args,
            ty,
            block,
        } => {
            let (sub, value) = match sub_and_last(&args, "the value to write") {
                Ok(v) => v,
                Err(e) => {
                    let entry = address(net, node, &object, None)?;
                    return Err(e.at(node, entry));
                }
            };
            let entry = address(net, node, &object, sub)?;
            let Some(dt) = data_type_of(net, node, entry, ty) else {
                return Err(no_type(node, entry));
            };
            let bytes = parse_value(dt, value).map_err(|e| e.into_usage().at(node, entry))?;
            net.node(node)
                .sdo()
                .block(block)
                .write(entry, bytes)
                .wait()?;
            if g.json {
                outln(&with(addr_json(node, entry), "ok", json!(true)));
            }
        }
        SdoCommand::Upload {
            node,
            object,
            sub,
            output,
            block,
        } => {
            let entry = address(net, node, &object, sub)?;
            let file = OutFile::create(&output)?;
            let bar = Bar::new();
            let r = net
                .node(node)
                .sdo()
                .block(block)
                .on_progress(bar.callback())
                .upload_to(entry, std::io::BufWriter::new(file.writer()?))
                .wait();
            bar.finish(r.as_ref().ok().copied());
            let n = r?;
            file.commit()?;
            if g.json {
                outln(&with(addr_json(node, entry), "bytes", json!(n)));
            } else {
                eprintln!("{n} bytes written to {}", output.display());
            }
        }
        SdoCommand::Download {
            node,
            object,
            args,
            block,
        } => {
            let (sub, file) = sub_and_last(&args, "the input file")?;
            let entry = address(net, node, &object, sub)?;
            let f = std::fs::File::open(file).map_err(CliError::file(file))?;
            let bar = Bar::new();
            let r = net
                .node(node)
                .sdo()
                .block(block)
                .on_progress(bar.callback())
                .download_from(entry, f)
                .wait();
            bar.finish(r.as_ref().ok().copied());
            let n = r?;
            if g.json {
                outln(&with(addr_json(node, entry), "bytes", json!(n)));
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
