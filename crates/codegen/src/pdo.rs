//! PDO structs from the file's default mappings ([`Config::pdo_structs`]): one struct per
//! RPDO (0x1600..=0x17FF) and TPDO (0x1A00..=0x1BFF) whose default mapping has entries, with a
//! named field per mapped object, implementing `canola_pdo::TypedPdo`. A mapping with no entries,
//! or without a value for its number of entries, gives no struct.
//!
//! The mapping is read and checked exactly as the master and the simulator read it
//! (`canola_pdo::Mapping::read_from` over `OdView`, CiA 301 §7.4.8): objects exist, are
//! mappable, readable for a TPDO and writable for an RPDO, mapped with their size; dummy entries
//! are of a supported type. A mapping that fails gives no struct and a note. The COB-ID is the
//! communication parameter's sub 1 (`$NODEID` kept as "add the node-ID"), or the predefined
//! connection set's for PDOs 1..=4 when the file has no communication parameter.

use std::fmt::Write as _;

use canola_od::{DataType, ObjectDictionary, Value};
use canola_pdo::{Direction, Mapping, OdView, ValueKind};

use crate::{Generator, doc_line, names};

/// The Rust type of a mapped object's field: the object's own integer width where it has one,
/// else one that holds the mapped bits.
fn field_type(kind: ValueKind, data_type: Option<DataType>, bits: u8) -> String {
    use DataType::*;
    let by_bits = |signed: bool| {
        let w = match bits {
            0..=8 => 8,
            9..=16 => 16,
            17..=32 => 32,
            _ => 64,
        };
        format!("{}{w}", if signed { 'i' } else { 'u' })
    };
    match kind {
        ValueKind::Boolean => "bool".to_owned(),
        ValueKind::Real32 => "f32".to_owned(),
        ValueKind::Real64 => "f64".to_owned(),
        ValueKind::Bytes => format!("[u8; {}]", (bits as usize).div_ceil(8)),
        ValueKind::Unsigned => match data_type {
            Some(Unsigned8) => "u8".to_owned(),
            Some(Unsigned16) => "u16".to_owned(),
            Some(Unsigned24 | Unsigned32) => "u32".to_owned(),
            Some(Unsigned40 | Unsigned48 | Unsigned56 | Unsigned64) => "u64".to_owned(),
            _ => by_bits(false),
        },
        ValueKind::Signed => match data_type {
            Some(Integer8) => "i8".to_owned(),
            Some(Integer16) => "i16".to_owned(),
            Some(Integer24 | Integer32) => "i32".to_owned(),
            Some(Integer40 | Integer48 | Integer56 | Integer64) => "i64".to_owned(),
            _ => by_bits(true),
        },
    }
}

/// A field's name: the object's name for a VAR, the sub-object's for an ARRAY or RECORD entry,
/// with the object's name in front when another mapped object has a sub-object of the same name
/// (`Sensor Value 1.Value` and `Sensor Value 2.Value` become `sensor_value_1_value`, ...).
fn field_name(od: &ObjectDictionary, mapping: &Mapping, addr: canola_od::ObjectAddress) -> String {
    let fallback = format!("obj_{:04x}_{}", addr.index, addr.sub_index);
    let short = |a: canola_od::ObjectAddress| {
        let obj = od.get(a.index)?;
        if obj.is_simple() {
            return Some(names::snake(&obj.name, &fallback));
        }
        Some(names::snake(&obj.sub(a.sub_index)?.name, &fallback))
    };
    let Some(mine) = short(addr) else {
        return fallback;
    };
    let shared = mapping
        .objects()
        .iter()
        .filter(|o| !o.is_dummy() && o.addr() != addr)
        .any(|o| short(o.addr()).as_deref() == Some(mine.as_str()));
    match od.get(addr.index) {
        Some(obj) if shared && !obj.is_simple() => {
            names::snake(&format!("{} {}", obj.name, mine), &fallback)
        }
        _ => mine,
    }
}

/// The `ValueKind` variant's name.
fn kind_name(kind: ValueKind) -> &'static str {
    match kind {
        ValueKind::Boolean => "Boolean",
        ValueKind::Unsigned => "Unsigned",
        ValueKind::Signed => "Signed",
        ValueKind::Real32 => "Real32",
        ValueKind::Real64 => "Real64",
        ValueKind::Bytes => "Bytes",
    }
}

/// The name of a dummy entry's data type.
fn dummy_name(index: u16) -> String {
    DataType::from_code(index)
        .name()
        .map_or_else(|| format!("data type {index:#06x}"), str::to_owned)
}

/// The default COB-ID: `(raw or offset, adds the node-ID, how the file writes it)`.
fn default_cob_id(od: &ObjectDictionary, dir: Direction, n: u16) -> Option<(u32, bool, String)> {
    let comm = dir.comm_index(n);
    if let Some(sub) = od.sub(comm, 1) {
        // A DCF's configured value when it has one (`ParameterValue=` may be empty), else the
        // default.
        let field = sub
            .parameter_value()
            .filter(|f| f.value.is_some())
            .or(sub.default_value.as_ref())?;
        let value = field.value.as_ref()?;
        let raw = match value.value {
            Value::Unsigned32(v) => v,
            ref other => u32::try_from(other.as_i128()?).ok()?,
        };
        return Some((raw, value.node_id_relative, doc_line(&field.text)));
    }
    if od.get(comm).is_some() || n >= 4 {
        return None;
    }
    // No communication parameter: the predefined connection set (CiA 301 §7.3.5).
    let base = match dir {
        Direction::Transmit => 0x180,
        Direction::Receive => 0x200,
    } + 0x100 * u32::from(n);
    Some((
        base,
        true,
        format!("$NODEID+{base:#X} (predefined connection set)"),
    ))
}

impl Generator<'_> {
    /// Every RPDO, then every TPDO, with a non-empty valid default mapping.
    pub(crate) fn pdos(&mut self, od: &ObjectDictionary) {
        // Node-ID 1 for the view: mapping entries rarely depend on it, and COB-IDs are taken
        // from the file separately, `$NODEID` kept.
        let view = OdView::new(od, 1);
        for (dir, prefix) in [(Direction::Receive, "Rpdo"), (Direction::Transmit, "Tpdo")] {
            for n in 0..512u16 {
                let index = dir.mapping_index(n);
                // No object, or no value for the number of entries: the file gives no default
                // mapping.
                if od
                    .sub(index, 0)
                    .and_then(|s| s.effective_value(1))
                    .is_none()
                {
                    continue;
                }
                let name = format!("{prefix}{}", n + 1);
                match Mapping::read_from(&view, dir, index) {
                    Ok(m) if m.is_empty() => {}
                    Ok(m) => self.pdo_struct(od, dir, n, &name, &m),
                    Err(e) => self.notes.push(format!(
                        "no struct {name}: the default mapping at {index:#06X} is not valid: {e}"
                    )),
                }
            }
        }
    }

    fn pdo_struct(
        &mut self,
        od: &ObjectDictionary,
        dir: Direction,
        n: u16,
        name: &str,
        mapping: &Mapping,
    ) {
        let pdo = self.cfg.pdo_crate_path.clone();
        let index = dir.mapping_index(n);
        let cob = default_cob_id(od, dir, n);
        let (what, by) = match dir {
            Direction::Transmit => ("transmit", "the device sends it, the master receives it"),
            Direction::Receive => ("receive", "the master sends it, the device receives it"),
        };
        // (field name, Rust type, position, object) for each mapped object that is not a dummy.
        let mut scope = names::Scope::default();
        let mut fields = Vec::new();
        let mut layout = Vec::new();
        for (position, o) in mapping.objects().iter().enumerate() {
            let bits = format!(
                "bits {}..{}",
                o.offset,
                u32::from(o.offset) + u32::from(o.bits())
            );
            if o.is_dummy() {
                layout.push(format!("{bits}: dummy {}", dummy_name(o.entry.index())));
                continue;
            }
            let addr = o.addr();
            let (title, data_type) = match od.get(addr.index) {
                Some(obj) => match obj.sub(addr.sub_index) {
                    Some(sub) if obj.is_simple() => (obj.name.to_string(), Some(sub.data_type)),
                    Some(sub) => (format!("{}.{}", obj.name, sub.name), Some(sub.data_type)),
                    None => (addr.to_string(), None),
                },
                None => (addr.to_string(), None),
            };
            let field = scope.unique(
                field_name(od, mapping, addr),
                &format!("{:04x}_{}", addr.index, addr.sub_index),
            );
            let ty = field_type(o.kind, data_type, o.bits());
            layout.push(format!("{bits}: `{field}`"));
            fields.push((field, ty, position, *o, title, data_type));
        }

        let out = &mut self.out;
        let number = n + 1;
        let _ = writeln!(
            out,
            "/// {} ({what} PDO {number}, mapping `{index:#06X}`): {by}.",
            name.to_ascii_uppercase()
        );
        let _ = writeln!(out, "///");
        match &cob {
            Some((_, _, text)) => {
                let _ = writeln!(
                    out,
                    "/// Default COB-ID `{}`; {} data bytes.",
                    text.replace('`', "'"),
                    mapping.byte_len()
                );
            }
            None => {
                let _ = writeln!(
                    out,
                    "/// No default COB-ID in the file; {} data bytes.",
                    mapping.byte_len()
                );
            }
        }
        let _ = writeln!(out, "/// Layout, from bit 0 of data byte 0:");
        for line in &layout {
            let _ = writeln!(out, "/// - {line}");
        }
        let _ = writeln!(out, "#[allow(dead_code)]");
        let _ = writeln!(out, "#[derive(Debug, Clone, Copy, PartialEq, Default)]");
        let _ = writeln!(out, "pub struct {name} {{");
        for (field, ty, _, o, title, data_type) in &fields {
            let type_name = data_type
                .and_then(|t| t.name())
                .unwrap_or("unknown data type");
            let _ = writeln!(
                out,
                "    /// {} (`{}`, {type_name}, {} bit{} from bit {}).",
                doc_line(title),
                o.addr(),
                o.bits(),
                if o.bits() == 1 { "" } else { "s" },
                o.offset
            );
            let _ = writeln!(out, "    pub {field}: {ty},");
        }
        let _ = writeln!(out, "}}\n");

        // The trait: constants and the two conversions.
        let _ = writeln!(out, "impl {pdo}::TypedPdo for {name} {{");
        let direction = match dir {
            Direction::Transmit => "Transmit",
            Direction::Receive => "Receive",
        };
        let _ = writeln!(
            out,
            "    const DIRECTION: {pdo}::Direction = {pdo}::Direction::{direction};"
        );
        let _ = writeln!(out, "    const NUMBER: u16 = {number};");
        let _ = writeln!(
            out,
            "    const ENTRIES: &'static [(u32, {pdo}::ValueKind)] = &["
        );
        for o in mapping.objects() {
            let _ = writeln!(
                out,
                "        ({:#010X}, {pdo}::ValueKind::{}),",
                o.entry.0,
                kind_name(o.kind)
            );
        }
        let _ = writeln!(out, "    ];");
        match &cob {
            Some((raw, adds, _)) => {
                let _ = writeln!(
                    out,
                    "    const DEFAULT_COB_ID: Option<{pdo}::DefaultCobId> = Some({pdo}::DefaultCobId {{ raw: {raw:#X}, adds_node_id: {adds} }});"
                );
            }
            None => {
                let _ = writeln!(
                    out,
                    "    const DEFAULT_COB_ID: Option<{pdo}::DefaultCobId> = None;"
                );
            }
        }
        let _ = writeln!(
            out,
            "    fn from_values(values: &[{pdo}::RawValue]) -> Result<Self, {pdo}::TypedPdoError> {{"
        );
        if fields.is_empty() {
            let _ = writeln!(out, "        let _ = values;");
        }
        let _ = writeln!(out, "        Ok(Self {{");
        for (field, _, position, o, ..) in &fields {
            let _ = writeln!(
                out,
                "            {field}: {pdo}::typed::field(values, {position}, {:#010X})?,",
                o.entry.0
            );
        }
        let _ = writeln!(out, "        }})\n    }}");
        let _ = writeln!(
            out,
            "    fn value_at(&self, position: usize) -> Option<{pdo}::RawValue> {{"
        );
        if fields.is_empty() {
            let _ = writeln!(out, "        let _ = position;\n        None");
        } else {
            let _ = writeln!(out, "        match position {{");
            for (field, _, position, ..) in &fields {
                let _ = writeln!(
                    out,
                    "            {position} => Some({pdo}::PdoField::to_value(&self.{field})),"
                );
            }
            let _ = writeln!(out, "            _ => None,\n        }}");
        }
        let _ = writeln!(out, "    }}\n}}\n");

        // Inherent forwarding methods: no trait import needed at the call site.
        let err = format!("{pdo}::TypedPdoError");
        let trait_ = format!("<Self as {pdo}::TypedPdo>");
        let _ = writeln!(out, "#[allow(dead_code)]");
        let _ = writeln!(out, "impl {name} {{");
        let _ = writeln!(
            out,
            "    /// The data bytes of a {}: {}.\n    pub const DATA_LEN: usize = {};",
            name.to_ascii_uppercase(),
            mapping.byte_len(),
            mapping.byte_len()
        );
        let methods: [(&str, String, String); 6] = [
            (
                "Decodes a received PDO frame's data (its length must be `DATA_LEN`; the identifier is not checked, see `cob_id`).",
                format!("pub fn from_frame(frame: &{pdo}::typed::CanFrame) -> Result<Self, {err}>"),
                format!("{trait_}::from_frame(frame)"),
            ),
            (
                "Decodes the data bytes of a PDO (exactly `DATA_LEN` of them).",
                format!("pub fn from_data(data: &[u8]) -> Result<Self, {err}>"),
                format!("{trait_}::from_data(data)"),
            ),
            (
                "Takes the fields by address from decoded `(address, value)` pairs, as the master publishes a TPDO.",
                format!(
                    "pub fn from_pairs<V: {pdo}::PairValue>(pairs: &[({pdo}::ObjectAddress, V)]) -> Result<Self, {err}>"
                ),
                format!("{trait_}::from_pairs(pairs)"),
            ),
            (
                "Packs the fields into `out` (dummy bits zero); returns the number of data bytes.",
                format!("pub fn pack(&self, out: &mut [u8; 8]) -> Result<usize, {err}>"),
                format!("{pdo}::TypedPdo::pack(self, out)"),
            ),
            (
                "A data frame with the packed fields on the default COB-ID of `node`.",
                format!(
                    "pub fn to_frame(self, node: {pdo}::typed::NodeId) -> Result<{pdo}::typed::CanFrame, {err}>"
                ),
                format!("{pdo}::TypedPdo::to_frame(&self, node)"),
            ),
            (
                "The default COB-ID for `node` (`$NODEID` resolved), if the file gives one.",
                format!("pub fn cob_id(node: {pdo}::typed::NodeId) -> Option<{pdo}::PdoCobId>"),
                format!("{trait_}::cob_id(node)"),
            ),
        ];
        for (doc, sig, body) in methods {
            let _ = write!(
                out,
                "\n    /// {doc}\n    {sig} {{\n        {body}\n    }}\n"
            );
        }
        let _ = writeln!(out, "}}\n");
    }
}
