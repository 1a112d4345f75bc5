//! Writers: CiA 306 EDS and DCF text, and the concise DCF binary of CiA 302-3 / object 0x1F22.
//!
//! [`write_eds`] writes every field of the model back, values as their source text, so
//! `parse(write_eds(parse(file)))` equals `parse(file)` (modulo [`Line`](crate::model::Line)s).
//! `CompactSubObj` objects come out with explicit `[xxxxsubN]` sections, which CiA 306 allows.
//!
//! [`write_dcf`] configures the dictionary for one node: every sub-object gets a
//! `ParameterValue` (its own or its `DefaultValue`) with `$NODEID` resolved, and
//! `[DeviceComissioning]` gets `NodeID` and `Baudrate`.
//!
//! [`concise_dcf`] encodes `u32 count`, then per entry `u16 index`, `u8 sub-index`, `u32 size`
//! and `size` data bytes, all little-endian.

use alloc::string::String;
use alloc::vec::Vec;
use core::fmt::Write as _;

use compact_str::CompactString;

use crate::model::{BAUD_RATES_KBIT, FieldValue, Object, ObjectDictionary, SubObject};
use crate::value::EdsValue;

const NL: &str = "\r\n";

struct Out(String);

impl Out {
    fn header(&mut self, name: core::fmt::Arguments<'_>) {
        if !self.0.is_empty() {
            self.0.push_str(NL);
        }
        let _ = write!(self.0, "[{name}]{NL}");
    }
    fn kv(&mut self, key: &str, value: core::fmt::Arguments<'_>) {
        let _ = write!(self.0, "{key}={value}{NL}");
    }
    fn s(&mut self, key: &str, value: &Option<String>) {
        if let Some(v) = value {
            self.kv(key, format_args!("{v}"));
        }
    }
    fn b(&mut self, key: &str, value: Option<bool>) {
        if let Some(v) = value {
            self.kv(key, format_args!("{}", u8::from(v)));
        }
    }
    fn extra(&mut self, extra: &[(CompactString, CompactString)]) {
        for (k, v) in extra {
            self.kv(k, format_args!("{v}"));
        }
    }
    fn list(&mut self, name: &str, count_key: &str, items: &[u16]) {
        self.header(format_args!("{name}"));
        self.kv(count_key, format_args!("{}", items.len()));
        for (i, index) in items.iter().enumerate() {
            self.kv(&alloc::format!("{}", i + 1), format_args!("0x{index:04X}"));
        }
    }
}

/// Writes the dictionary as an EDS (or, when it carries `ParameterValue`s and
/// `[DeviceComissioning]`, a DCF) file.
pub fn write_eds(od: &ObjectDictionary) -> String {
    let mut o = Out(String::with_capacity(64 + od.objects.len() * 256));
    let fi = &od.file_info;
    o.header(format_args!("FileInfo"));
    o.s("FileName", &fi.file_name);
    o.s("FileVersion", &fi.file_version);
    o.s("FileRevision", &fi.file_revision);
    o.s("EDSVersion", &fi.eds_version);
    o.s("Description", &fi.description);
    o.s("CreationTime", &fi.creation_time);
    o.s("CreationDate", &fi.creation_date);
    o.s("CreatedBy", &fi.created_by);
    o.s("ModificationTime", &fi.modification_time);
    o.s("ModificationDate", &fi.modification_date);
    o.s("ModifiedBy", &fi.modified_by);
    o.extra(&fi.extra);

    let di = &od.device_info;
    o.header(format_args!("DeviceInfo"));
    o.s("VendorName", &di.vendor_name);
    if let Some(v) = di.vendor_number {
        o.kv("VendorNumber", format_args!("0x{v:08X}"));
    }
    o.s("ProductName", &di.product_name);
    if let Some(v) = di.product_number {
        o.kv("ProductNumber", format_args!("0x{v:08X}"));
    }
    if let Some(v) = di.revision_number {
        o.kv("RevisionNumber", format_args!("0x{v:08X}"));
    }
    o.s("OrderCode", &di.order_code);
    for (rate, supported) in BAUD_RATES_KBIT.iter().zip(di.baud_rates.iter()) {
        o.b(&alloc::format!("BaudRate_{rate}"), *supported);
    }
    o.b("SimpleBootUpMaster", di.simple_boot_up_master);
    o.b("SimpleBootUpSlave", di.simple_boot_up_slave);
    if let Some(v) = di.granularity {
        o.kv("Granularity", format_args!("{v}"));
    }
    if let Some(v) = di.dynamic_channels_supported {
        o.kv("DynamicChannelsSupported", format_args!("{v}"));
    }
    o.b("GroupMessaging", di.group_messaging);
    if let Some(v) = di.nr_of_rx_pdo {
        o.kv("NrOfRXPDO", format_args!("{v}"));
    }
    if let Some(v) = di.nr_of_tx_pdo {
        o.kv("NrOfTXPDO", format_args!("{v}"));
    }
    o.b("LSS_Supported", di.lss_supported);
    if let Some(v) = di.compact_pdo {
        o.kv("CompactPDO", format_args!("0x{v:02X}"));
    }
    o.extra(&di.extra);

    if !od.dummy_usage.is_empty() {
        o.header(format_args!("DummyUsage"));
        for (dt, used) in &od.dummy_usage {
            o.kv(
                &alloc::format!("Dummy{dt:04X}"),
                format_args!("{}", u8::from(*used)),
            );
        }
    }
    if !od.comments.is_empty() {
        o.header(format_args!("Comments"));
        o.kv("Lines", format_args!("{}", od.comments.len()));
        for (i, line) in od.comments.iter().enumerate() {
            o.kv(&alloc::format!("Line{}", i + 1), format_args!("{line}"));
        }
    }
    o.list(
        "MandatoryObjects",
        "SupportedObjects",
        &od.mandatory_objects,
    );
    o.list("OptionalObjects", "SupportedObjects", &od.optional_objects);
    o.list(
        "ManufacturerObjects",
        "SupportedObjects",
        &od.manufacturer_objects,
    );

    if let Some(dc) = &od.device_commissioning {
        o.header(format_args!("DeviceComissioning"));
        if let Some(v) = dc.node_id {
            o.kv("NodeID", format_args!("{v}"));
        }
        o.s("NodeName", &dc.node_name);
        if let Some(v) = dc.baudrate {
            o.kv("Baudrate", format_args!("{v}"));
        }
        if let Some(v) = dc.net_number {
            o.kv("NetNumber", format_args!("{v}"));
        }
        o.s("NetworkName", &dc.network_name);
        o.b("CANopenManager", dc.canopen_manager);
        if let Some(v) = dc.lss_serial_number {
            o.kv("LSS_SerialNumber", format_args!("0x{v:08X}"));
        }
        o.extra(&dc.extra);
    }

    for obj in od.objects.values() {
        write_object(&mut o, obj);
    }
    for sec in &od.other_sections {
        o.header(format_args!("{}", sec.name));
        o.extra(&sec.entries);
    }
    o.0
}

fn write_object(o: &mut Out, obj: &Object) {
    o.header(format_args!("{:04X}", obj.index));
    o.kv("ParameterName", format_args!("{}", obj.name));
    o.kv("ObjectType", format_args!("0x{:X}", obj.object_code.code()));
    if let Some(n) = obj.sub_number {
        o.kv("SubNumber", format_args!("0x{n:X}"));
    }
    if let Some(f) = obj.obj_flags {
        o.kv("ObjFlags", format_args!("0x{f:X}"));
    }
    let simple = obj.is_simple() || matches!(obj.object_code, crate::types::ObjectCode::Other(_));
    if simple {
        if let Some(sub) = obj.subs.get(0) {
            write_sub_fields(o, sub);
        }
        o.extra(&obj.extra);
    } else {
        o.extra(&obj.extra);
        for sub in obj.subs.values() {
            o.header(format_args!("{:04X}sub{:X}", obj.index, sub.sub_index));
            o.kv("ParameterName", format_args!("{}", sub.name));
            o.kv("ObjectType", format_args!("0x{:X}", sub.object_code.code()));
            write_sub_fields(o, sub);
        }
    }
    if !obj.object_links.is_empty() {
        o.list(
            &alloc::format!("{:04X}ObjectLinks", obj.index),
            "ObjectLinks",
            &obj.object_links,
        );
    }
}

fn write_sub_fields(o: &mut Out, sub: &SubObject) {
    o.kv("DataType", format_args!("0x{:04X}", sub.data_type.code()));
    match sub.access_raw() {
        Some(raw) => o.kv("AccessType", format_args!("{raw}")),
        None => o.kv("AccessType", format_args!("{}", sub.access.as_str())),
    }
    let field = |o: &mut Out, key: &str, f: Option<&FieldValue>| {
        if let Some(f) = f {
            o.kv(key, format_args!("{}", f.text));
        }
    };
    field(o, "DefaultValue", sub.default_value.as_ref());
    o.kv("PDOMapping", format_args!("{}", u8::from(sub.pdo_mapping)));
    field(o, "LowLimit", sub.low_limit());
    field(o, "HighLimit", sub.high_limit());
    field(o, "ParameterValue", sub.parameter_value());
    if let Some(d) = sub.denotation() {
        o.kv("Denotation", format_args!("{d}"));
    }
    if let Some(f) = sub.obj_flags {
        o.kv("ObjFlags", format_args!("0x{f:X}"));
    }
    o.extra(sub.extra());
}

/// The dictionary configured for one node: every sub-object with a `ParameterValue` (its own
/// or else its `DefaultValue`) with `$NODEID` resolved for `node_id`, and `[DeviceComissioning]`
/// with `NodeID` and, when given, `Baudrate` in kbit/s.
pub fn configure_for_node(
    od: &ObjectDictionary,
    node_id: u8,
    baudrate_kbit: Option<u16>,
) -> ObjectDictionary {
    let mut od = od.clone();
    for obj in od.objects.values_mut() {
        for sub in obj.subs.values_mut() {
            let source = sub.parameter_value().or(sub.default_value.as_ref());
            let resolved = match source {
                Some(f) => match &f.value {
                    Some(v) if v.node_id_relative => {
                        Some(FieldValue::from_value(EdsValue::plain(v.resolve(node_id))))
                    }
                    _ => Some(f.clone()),
                },
                None => None,
            };
            if resolved.is_some() {
                sub.extras_mut().parameter_value = resolved;
            }
        }
    }
    let dc = od.device_commissioning.get_or_insert_with(Default::default);
    dc.node_id = Some(node_id);
    if baudrate_kbit.is_some() {
        dc.baudrate = baudrate_kbit;
    }
    od
}

/// Writes a DCF for `node_id` (see [`configure_for_node`]).
pub fn write_dcf(od: &ObjectDictionary, node_id: u8, baudrate_kbit: Option<u16>) -> String {
    write_eds(&configure_for_node(od, node_id, baudrate_kbit))
}

/// One entry of a concise DCF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConciseEntry {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub_index: u8,
    /// The value's little-endian bytes.
    pub data: Vec<u8>,
}

/// Which sub-objects go into a concise DCF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConciseSelection {
    /// Writable sub-objects with an explicit `ParameterValue` (what a DCF configures).
    #[default]
    ParameterValues,
    /// Writable sub-objects with a `ParameterValue` or, failing that, a `DefaultValue`.
    ParameterOrDefaultValues,
}

/// The concise DCF (object 0x1F22 format) for `node_id`: entries in index order, values with
/// `$NODEID` resolved. Sub-objects whose value text could not be typed are skipped.
pub fn concise_dcf(od: &ObjectDictionary, node_id: u8, selection: ConciseSelection) -> Vec<u8> {
    let mut entries = Vec::new();
    for obj in od.objects.values() {
        for sub in obj.subs.values() {
            if !sub.access.is_writable() || sub.access_raw().is_some() {
                continue;
            }
            let field = match selection {
                ConciseSelection::ParameterValues => sub.parameter_value(),
                ConciseSelection::ParameterOrDefaultValues => {
                    sub.parameter_value().or(sub.default_value.as_ref())
                }
            };
            if let Some(v) = field.and_then(|f| f.resolve(node_id)) {
                entries.push(ConciseEntry {
                    index: obj.index,
                    sub_index: sub.sub_index,
                    data: v.to_le_bytes(),
                });
            }
        }
    }
    encode_concise(&entries)
}

/// Encodes entries in the concise DCF format.
pub fn encode_concise(entries: &[ConciseEntry]) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 + entries.iter().map(|e| 7 + e.data.len()).sum::<usize>());
    out.extend_from_slice(&(entries.len() as u32).to_le_bytes());
    for e in entries {
        out.extend_from_slice(&e.index.to_le_bytes());
        out.push(e.sub_index);
        out.extend_from_slice(&(e.data.len() as u32).to_le_bytes());
        out.extend_from_slice(&e.data);
    }
    out
}

/// Why concise DCF bytes could not be decoded.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ConciseError {
    /// The data ended inside entry `entry` (0-based; `None` for the count).
    #[error("concise DCF truncated {}", TruncatedIn(*entry))]
    Truncated {
        /// The entry being read.
        entry: Option<u32>,
    },
    /// Bytes after the last announced entry.
    #[error("{0} bytes after the last entry")]
    TrailingBytes(usize),
}

debug_as_display!(ConciseError);

/// Where concise DCF data ended, in words.
struct TruncatedIn(Option<u32>);

impl core::fmt::Display for TruncatedIn {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.0 {
            Some(entry) => write!(f, "in entry {entry}"),
            None => f.write_str("in the entry count"),
        }
    }
}

/// Decodes a concise DCF. Never panics; allocates at most the input size.
pub fn decode_concise(bytes: &[u8]) -> Result<Vec<ConciseEntry>, ConciseError> {
    let take = |b: &mut &[u8], n: usize, entry: Option<u32>| -> Result<Vec<u8>, ConciseError> {
        if b.len() < n {
            return Err(ConciseError::Truncated { entry });
        }
        let (h, t) = b.split_at(n);
        *b = t;
        Ok(h.to_vec())
    };
    let mut b = bytes;
    let c = take(&mut b, 4, None)?;
    let count = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    let mut out = Vec::new();
    for i in 0..count {
        let h = take(&mut b, 7, Some(i))?;
        let size = u32::from_le_bytes([h[3], h[4], h[5], h[6]]) as usize;
        let data = take(&mut b, size, Some(i))?;
        out.push(ConciseEntry {
            index: u16::from_le_bytes([h[0], h[1]]),
            sub_index: h[2],
            data,
        });
    }
    if !b.is_empty() {
        return Err(ConciseError::TrailingBytes(b.len()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse::parse;
    use crate::value::Value;
    use alloc::vec;

    const SRC: &str = "[1017]\nParameterName=Producer heartbeat time\nDataType=0x0006\nAccessType=rw\nDefaultValue=1000\n\
[1400]\nParameterName=RPDO1 communication\nObjectType=0x9\nSubNumber=2\n\
[1400sub0]\nParameterName=n\nDataType=0x0005\nAccessType=const\nDefaultValue=1\n\
[1400sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x200\n";

    #[test]
    fn eds_round_trip() {
        let a = parse(SRC.as_bytes()).unwrap().od;
        let text = write_eds(&a);
        let b = parse(text.as_bytes()).unwrap();
        assert_eq!(a, b.od);
    }

    #[test]
    fn dcf_resolves_node_id() {
        let a = parse(SRC.as_bytes()).unwrap().od;
        let dcf = parse(write_dcf(&a, 5, Some(250)).as_bytes()).unwrap().od;
        let cob = dcf
            .sub(0x1400, 1)
            .unwrap()
            .parameter_value()
            .cloned()
            .unwrap();
        assert_eq!(cob.text, "0x205");
        assert_eq!(dcf.device_commissioning.as_ref().unwrap().node_id, Some(5));
        assert_eq!(
            dcf.device_commissioning.as_ref().unwrap().baudrate,
            Some(250)
        );
        // The default keeps its $NODEID form.
        assert!(
            dcf.sub(0x1400, 1)
                .unwrap()
                .default_value
                .as_ref()
                .unwrap()
                .value
                .as_ref()
                .unwrap()
                .node_id_relative
        );
    }

    #[test]
    fn concise_bytes() {
        let a = parse(SRC.as_bytes()).unwrap().od;
        let bytes = concise_dcf(&a, 5, ConciseSelection::ParameterOrDefaultValues);
        // 2 entries: 1017/0 = 1000 (u16), 1400/1 = 0x205 (u32); 1400/0 is const.
        assert_eq!(
            bytes,
            vec![
                2, 0, 0, 0, 0x17, 0x10, 0, 2, 0, 0, 0, 0xE8, 0x03, 0x00, 0x14, 1, 4, 0, 0, 0, 0x05,
                0x02, 0, 0
            ]
        );
        let e = decode_concise(&bytes).unwrap();
        assert_eq!(e[1].data, Value::Unsigned32(0x205).to_le_bytes());
        assert_eq!(
            decode_concise(&bytes[..10]),
            Err(ConciseError::Truncated { entry: Some(0) })
        );
        assert_eq!(
            decode_concise(&[0xFF, 0xFF, 0xFF, 0xFF]),
            Err(ConciseError::Truncated { entry: Some(0) })
        );
        assert!(concise_dcf(&a, 5, ConciseSelection::ParameterValues).starts_with(&[0, 0, 0, 0]));
    }
}
