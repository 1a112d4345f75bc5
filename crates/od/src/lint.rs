//! Consistency checks of an object dictionary, in the spirit of Lely's `dcfchk`: what a file
//! may say without being unreadable, but what makes it wrong for a device or a master.
//!
//! - `SubNumber` against the sub-objects present, and sub-index 0 of a RECORD against the
//!   highest sub-index (CiA 301 §7.4.3);
//! - objects missing from or extra to `[MandatoryObjects]`, `[OptionalObjects]`,
//!   `[ManufacturerObjects]` (CiA 306 §4.6.2), listed in the wrong list, mandatory objects
//!   0x1000/0x1001/0x1018 absent;
//! - `DefaultValue` outside `LowLimit`..`HighLimit`, `LowLimit` above `HighLimit`;
//! - PDO mapping entries (0x1600.., 0x1A00..; CiA 301 §7.5.2.36/38) naming objects that do not
//!   exist, are not `PDOMapping=1`, have a different size or wrong direction of access, dummy
//!   entries not allowed by `[DummyUsage]`, more than 64 bits; `PDOMapping=1` on types of
//!   variable size;
//! - COB-IDs of the PDOs (0x1400.., 0x1800..; sub-index 1), SYNC (0x1005), TIME (0x1012) and
//!   EMCY (0x1014) in a range CiA 301 restricts ([`canola_frame::cob::RESTRICTED`]), for
//!   every node-ID a `$NODEID` value can take; a PDO or EMCY marked not valid (bit 31) and
//!   29-bit identifiers are not checked. The SDO channels are left out: their default
//!   identifiers are the restricted ones;
//! - invalid access types, unknown data types and object codes;
//! - duplicate sections and keys (found by the parser; [`lint_source`] includes them).

use alloc::format;
use alloc::vec::Vec;

use crate::diag::{Diagnostic, DiagnosticKind as K, Echo, Sink};
use crate::model::{Object, ObjectDictionary, SubObject};
use crate::parse::{ParseError, parse};
use crate::types::{DataType, ObjectCode};

/// Parses `input` and lints it: every warning of the parser (what `eds check` reports)
/// followed by [`lint`]'s findings, sorted by line, each finding once.
pub fn lint_source(input: &[u8]) -> Result<Vec<Diagnostic>, ParseError> {
    let parsed = parse(input)?;
    // What the parser found (`eds check`'s findings), then the model's checks.
    let mut out: Vec<Diagnostic> = parsed.diagnostics;
    out.extend(lint(&parsed.od));
    out.sort_by_key(|d| d.line);
    let mut seen = alloc::collections::BTreeSet::new();
    out.retain(|d| seen.insert((d.line, d.message.clone())));
    Ok(out)
}

/// Checks the model; every finding is a warning with the line of the object concerned.
pub fn lint(od: &ObjectDictionary) -> Vec<Diagnostic> {
    let mut sink = Sink::default();
    for obj in od.objects.values() {
        sub_numbers(&mut sink, obj);
        for sub in obj.subs.values() {
            limits(&mut sink, obj, sub);
            codes(&mut sink, od, obj, sub);
        }
        if let ObjectCode::Other(c) = obj.object_code {
            sink.warn(
                K::InvalidCode,
                obj.line.0,
                format!(
                    "object 0x{:04X}: ObjectType=0x{c:X} is not a CiA 301 object code",
                    obj.index
                ),
            );
        }
    }
    object_lists(&mut sink, od);
    pdo_mappings(&mut sink, od);
    restricted_cob_ids(&mut sink, od);
    sink.finish()
}

fn sub_numbers(sink: &mut Sink, obj: &Object) {
    if obj.is_simple() {
        return;
    }
    let present = obj.subs.len();
    match obj.sub_number {
        None => sink.warn(
            K::SubNumber,
            obj.line.0,
            format!(
                "{} 0x{:04X} has no SubNumber ({present} sub-objects present)",
                obj.object_code.name(),
                obj.index
            ),
        ),
        Some(n) if usize::from(n) != present => sink.warn(
            K::SubNumber,
            obj.line.0,
            format!(
                "0x{:04X}: SubNumber={n} but {present} sub-objects are defined",
                obj.index
            ),
        ),
        _ => {}
    }
    let highest = obj.subs.highest().unwrap_or(0);
    // For a RECORD sub-index 0 is the highest sub-index supported (CiA 301 §7.4.3); for an ARRAY
    // and for the PDO mapping records it counts entries in use, which may be fewer.
    let mapping = matches!(obj.index, 0x1600..=0x17FF | 0x1A00..=0x1BFF);
    let record = obj.object_code == ObjectCode::Record && !mapping;
    if let Some(sub0) = obj.subs.get(0).filter(|_| record) {
        let v = sub0
            .default_value
            .as_ref()
            .and_then(|f| f.resolve(0))
            .and_then(|v| v.as_i128());
        if let Some(v) = v
            && v < i128::from(highest)
        {
            sink.warn(
                    K::SubNumber,
                    sub0.line.0,
                    format!(
                        "0x{:04X}:00 says the highest sub-index is {v}, but sub-index {highest} is defined",
                        obj.index
                    ),
                );
        }
    } else if present > 0 && obj.subs.get(0).is_none() {
        sink.warn(
            K::SubNumber,
            obj.line.0,
            format!(
                "0x{:04X}: {} without sub-index 0",
                obj.index,
                obj.object_code.name()
            ),
        );
    }
}

fn limits(sink: &mut Sink, obj: &Object, sub: &SubObject) {
    let num = |f: Option<&crate::model::FieldValue>| {
        f.and_then(|f| f.value.as_ref())
            .filter(|v| !v.node_id_relative)
            .and_then(|v| v.value.as_f64())
    };
    let (low, high) = (num(sub.low_limit()), num(sub.high_limit()));
    let what = || {
        if obj.is_simple() {
            format!("0x{:04X}", obj.index)
        } else {
            format!("0x{:04X}:{:02X}", obj.index, sub.sub_index)
        }
    };
    if let (Some(l), Some(h)) = (low, high)
        && l > h
    {
        sink.warn(
            K::Limits,
            sub.line.0,
            format!("{}: LowLimit {l} is above HighLimit {h}", what()),
        );
    }
    for (field, label) in [
        (sub.default_value.as_ref(), "DefaultValue"),
        (sub.parameter_value(), "ParameterValue"),
    ] {
        let Some(v) = num(field) else { continue };
        let text = field.map(|f| f.text.as_str()).unwrap_or("");
        if low.is_some_and(|l| v < l) || high.is_some_and(|h| v > h) {
            sink.warn(
                K::Limits,
                sub.line.0,
                format!(
                    "{}: {label}={} is outside LowLimit..HighLimit ({}..{})",
                    what(),
                    Echo(text),
                    Echo(sub.low_limit().map_or("-", |f| f.text.as_str())),
                    Echo(sub.high_limit().map_or("-", |f| f.text.as_str())),
                ),
            );
        }
    }
}

fn codes(sink: &mut Sink, od: &ObjectDictionary, obj: &Object, sub: &SubObject) {
    if let Some(raw) = sub.access_raw() {
        sink.warn(
            K::InvalidCode,
            sub.line.0,
            format!(
                "0x{:04X}:{:02X}: AccessType={raw} is none of ro, wo, rw, rwr, rww, const",
                obj.index, sub.sub_index
            ),
        );
    }
    if let DataType::Other(code) = sub.data_type {
        // Complex types 0x20..=0x25 (CiA 301) and types defined in the file itself are fine.
        let defined = (0x20..=0x25).contains(&code)
            || od.objects.get(&code).is_some_and(|d| {
                matches!(d.object_code, ObjectCode::DefType | ObjectCode::DefStruct)
            });
        if !defined {
            sink.warn(
                K::InvalidCode,
                sub.line.0,
                format!(
                    "0x{:04X}:{:02X}: DataType=0x{code:04X} is not a CiA 301 basic type nor defined in this file",
                    obj.index, sub.sub_index
                ),
            );
        }
    }
    if sub.pdo_mapping && sub.data_type.is_variable_size() {
        sink.warn(
            K::PdoMapping,
            sub.line.0,
            format!(
                "0x{:04X}:{:02X}: PDOMapping=1 on {}, whose size is not fixed",
                obj.index, sub.sub_index, sub.data_type
            ),
        );
    }
}

fn object_lists(sink: &mut Sink, od: &ObjectDictionary) {
    let lists = [
        (&od.mandatory_objects, "MandatoryObjects"),
        (&od.optional_objects, "OptionalObjects"),
        (&od.manufacturer_objects, "ManufacturerObjects"),
    ];
    let expected = |index: u16| match index {
        0x1000 | 0x1001 | 0x1018 => 0,
        0x2000..=0x5FFF => 2,
        _ => 1,
    };
    let mut listed: alloc::collections::BTreeMap<u16, usize> = alloc::collections::BTreeMap::new();
    for (n, (list, name)) in lists.iter().enumerate() {
        let line = od.object_list_lines[n].0;
        for &index in list.iter() {
            if listed.insert(index, n).is_some() {
                sink.warn(
                    K::ObjectList,
                    line,
                    format!("[{name}]: 0x{index:04X} is listed more than once"),
                );
            }
            if !od.objects.contains_key(&index) {
                sink.warn(
                    K::ObjectList,
                    line,
                    format!("[{name}] lists 0x{index:04X}, but there is no [{index:04X}] section"),
                );
            } else if expected(index) != n {
                let want = lists.get(expected(index)).map_or("", |l| l.1);
                sink.warn(
                    K::ObjectList,
                    line,
                    format!("[{name}] lists 0x{index:04X}, which belongs in [{want}]"),
                );
            }
        }
    }
    for obj in od.objects.values() {
        if obj.index < 0x1000 {
            continue;
        }
        if !listed.contains_key(&obj.index) {
            let want = lists.get(expected(obj.index)).map_or("", |l| l.1);
            sink.warn(
                K::ObjectList,
                obj.line.0,
                format!(
                    "object 0x{:04X} is not listed in any object list; add it to [{want}]",
                    obj.index
                ),
            );
        }
    }
    for index in [0x1000u16, 0x1001, 0x1018] {
        if !od.objects.contains_key(&index) {
            sink.warn(
                K::ObjectList,
                od.object_list_lines[0].0,
                format!("mandatory object 0x{index:04X} (CiA 301) is missing"),
            );
        }
    }
}

/// The COB-IDs a device of this file would use, checked against CiA 301's restricted
/// identifiers.
fn restricted_cob_ids(sink: &mut Sink, od: &ObjectDictionary) {
    // (index, sub-index, whether bit 31 marks the object not valid).
    let pdos = od
        .objects
        .range(0x1400..=0x15FF)
        .chain(od.objects.range(0x1800..=0x19FF))
        .map(|(&i, _)| (i, 1, true));
    let fixed = [(0x1005, 0, false), (0x1012, 0, false), (0x1014, 0, true)];
    for (index, sub_index, valid_bit) in pdos.chain(fixed) {
        let Some(sub) = od.get(index).and_then(|o| o.sub(sub_index)) else {
            continue;
        };
        // The first node-ID (1..=127) whose value lands in a restricted range: a value
        // without $NODEID is the same for all.
        let hit = (1..=127u8).find_map(|node| {
            let v = sub.effective_value(node)?.as_i128()?;
            let cob = u32::try_from(v).ok()?;
            let disabled = valid_bit && cob & 0x8000_0000 != 0;
            let extended = cob & 0x2000_0000 != 0;
            let id = (cob & 0x7FF) as u16;
            (!disabled && !extended && canola_frame::is_restricted(id)).then_some((node, id))
        });
        if let Some((node, id)) = hit {
            let relative = sub.effective_value(node) != sub.effective_value(node % 127 + 1);
            let line = sub.line.0.max(od.get(index).map_or(0, |o| o.line.0));
            sink.warn(
                K::Value,
                line,
                format!(
                    "0x{index:04X}:{sub_index:02X}: COB-ID 0x{id:03X}{} is a CAN-ID CiA 301 \
                     restricts (restricted: 0x000, 0x001..0x07F, 0x101..0x180, 0x581..0x5FF, \
                     0x601..0x67F, 0x6E0..0x6FF, 0x701..0x77F, 0x780..0x7FF)",
                    if relative {
                        format!(" (for node-ID {node})")
                    } else {
                        alloc::string::String::new()
                    }
                ),
            );
        }
    }
}

fn pdo_mappings(sink: &mut Sink, od: &ObjectDictionary) {
    for obj in od
        .objects
        .range(0x1600..=0x17FF)
        .chain(od.objects.range(0x1A00..=0x1BFF))
        .map(|(_, o)| o)
    {
        let receive = obj.index < 0x1800;
        let count = obj
            .subs
            .get(0)
            .and_then(|s| s.effective_value(1))
            .and_then(|v| v.as_i128())
            .unwrap_or(0);
        let mut total_bits = 0u32;
        for sub in obj
            .subs
            .values()
            .filter(|s| s.sub_index >= 1 && i128::from(s.sub_index) <= count)
        {
            let Some(entry) = sub.effective_value(1).and_then(|v| v.as_i128()) else {
                continue;
            };
            if entry == 0 {
                continue;
            }
            let entry = entry as u32;
            let (index, sub_index, bits) = ((entry >> 16) as u16, (entry >> 8) as u8, entry & 0xFF);
            total_bits += bits;
            let here = format!(
                "0x{:04X}:{:02X} maps 0x{index:04X}:{sub_index:02X} ({bits} bits)",
                obj.index, sub.sub_index
            );
            if index < 0x20 && od.objects.get(&index).is_none_or(|o| o.is_simple()) {
                // A dummy entry: data type index as object index (CiA 301 §7.5.2.36).
                if od.dummy_usage.get(&index) != Some(&true) {
                    sink.warn(K::PdoMapping, sub.line.0, format!("{here}: a dummy entry, but [DummyUsage] does not enable Dummy{index:04X}"));
                }
                let size = DataType::from_code(index).size().map(|s| s as u32 * 8);
                if size.is_some_and(|s| s != bits) {
                    sink.warn(
                        K::PdoMapping,
                        sub.line.0,
                        format!("{here}: the dummy type has {} bits", size.unwrap_or(0)),
                    );
                }
                continue;
            }
            let Some(target) = od.sub(index, sub_index) else {
                sink.warn(K::PdoMapping, sub.line.0, format!("{here}: no such object"));
                continue;
            };
            if !target.pdo_mapping {
                sink.warn(
                    K::PdoMapping,
                    sub.line.0,
                    format!("{here}: the target has PDOMapping=0"),
                );
            }
            if let Some(size) = target.data_type.size()
                && size as u32 * 8 != bits
            {
                sink.warn(
                    K::PdoMapping,
                    sub.line.0,
                    format!(
                        "{here}: the target is {} ({} bits)",
                        target.data_type,
                        size * 8
                    ),
                );
            }
            if receive && !target.access.is_writable() {
                sink.warn(
                    K::PdoMapping,
                    sub.line.0,
                    format!(
                        "{here}: an RPDO writes the target, but it is {}",
                        target.access
                    ),
                );
            }
            if !receive && !target.access.is_readable() {
                sink.warn(
                    K::PdoMapping,
                    sub.line.0,
                    format!(
                        "{here}: a TPDO reads the target, but it is {}",
                        target.access
                    ),
                );
            }
        }
        if total_bits > 64 {
            sink.warn(
                K::PdoMapping,
                obj.line.0,
                format!(
                    "0x{:04X} maps {total_bits} bits; a PDO carries at most 64",
                    obj.index
                ),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_each_kind_with_lines() {
        let src = "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n\
[OptionalObjects]\nSupportedObjects=1\n1=0x1A00\n\
[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n\
[1001]\nParameterName=Error register\nDataType=0x0005\nAccessType=ro\nPDOMapping=1\n\
[1A00]\nParameterName=TPDO1 mapping\nObjectType=0x9\nSubNumber=4\n\
[1A00sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=2\n\
[1A00sub1]\nParameterName=e1\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x10000020\n\
[1A00sub2]\nParameterName=e2\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x20000010\n\
[2000]\nParameterName=Speed\nDataType=0x0006\nAccessType=bogus\nDefaultValue=500\nLowLimit=0\nHighLimit=100\n";
        let d = lint_source(src.as_bytes()).unwrap();
        let has = |kind: K, line: u32| d.iter().any(|x| x.kind == kind && x.line == line);
        assert!(has(K::SubNumber, 18), "{d:#?}"); // SubNumber=4, 3 sub-objects
        assert!(has(K::PdoMapping, 27), "{d:#?}"); // maps 1000sub0, which has PDOMapping=0
        assert!(has(K::PdoMapping, 32), "{d:#?}"); // maps 2000sub0, which has PDOMapping=0
        assert!(has(K::Limits, 37), "{d:#?}"); // 500 outside 0..100
        assert!(has(K::InvalidCode, 37), "{d:#?}"); // AccessType=bogus
        assert!(has(K::ObjectList, 37), "{d:#?}"); // 2000 not listed
        assert!(has(K::ObjectList, 1), "{d:#?}"); // 1018 missing
    }
}
