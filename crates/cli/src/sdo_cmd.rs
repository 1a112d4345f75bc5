//! `canopen sdo read|write|upload|download`: SDO transfers (CiA 301 §7.2.4) through the
//! library's [`canopen::Sdo`]; this module parses the arguments and the value text, and prints.
//!
//! Values are typed by `--type`, else by the node's dictionary (`--eds NODE=FILE`); reads
//! without either print the bytes in hex.

use std::io::{IsTerminal, Write as _};
use std::path::PathBuf;
use std::process::ExitCode;

use canopen::{DataType, Network, NodeId, ObjectAddress, Value};
use clap::{Subcommand, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, parse_node, parse_u8, parse_u16};
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

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A value as the command prints it: the value's own text, except byte-typed objects as one
/// hex word (as `candump` prints data).
fn format_value(v: &Value) -> String {
    match v {
        Value::OctetString(b) | Value::Domain(b) => hex(b),
        other => other.to_string(),
    }
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

fn data_type_of(
    net: &Network,
    node: NodeId,
    entry: ObjectAddress,
    ty: Option<Ty>,
) -> Option<DataType> {
    ty.map(Ty::data_type).or_else(|| {
        net.node(node)
            .dictionary()
            .and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type))
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
pub(crate) fn run(cmd: SdoCommand, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match opts.open() {
        Ok(b) => b.into_network(),
        Err(e) => return fail(e),
    };
    match cmd {
        SdoCommand::Read {
            node,
            index,
            sub,
            ty,
            block,
        } => {
            let entry = ObjectAddress::new(index, sub);
            let dt = data_type_of(&net, node, entry, ty).unwrap_or(DataType::Domain);
            let value = match net.node(node).sdo().block(block).read_as(entry, dt) {
                Ok(v) => v,
                Err(e) => return fail(e),
            };
            if g.json {
                outln(
                    &json!({"node": node.get(), "index": index, "sub": sub,
                            "value": json_value(&value), "raw": hex(&value.to_le_bytes())})
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
            let entry = ObjectAddress::new(index, sub);
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
