//! Building the model: object sections and their sub sections into [`Object`]s and
//! [`SubObject`]s (CiA 306 §4.6: `ObjectType`, `DataType`, `AccessType`, `PDOMapping`, the
//! value keys, `SubNumber`, `CompactSubObj` with the `[xxxxName]`, `[xxxxValue]` and
//! `[xxxxDenotation]` sections), and the dispatch of every scanned section to its reader.

use alloc::borrow::Cow;
use alloc::collections::BTreeMap;
use alloc::format;
use alloc::string::ToString;
use alloc::vec::Vec;

use compact_str::{CompactString, format_compact};

use super::info::{comments, commissioning, device_info, dummy_usage, file_info, object_list};
use super::keys::{
    KeyTable, Keys, Where, boolean, extra_owned, note_warnings, resolve_keys, uint, unquote,
};
use super::names::SectionKind;
use super::section::{Entry, Section, SubRec};
use crate::diag::{DiagnosticKind as K, Echo, Sink, is_communication_object};
use crate::model::{FieldValue, Line, Object, ObjectDictionary, RawSection, SubObject, SubObjects};
use crate::types::{AccessType, DataType, ObjectCode};
use crate::value::{TextError, TextNotes, parse_int_literal};

/// Reads one sub section into a [`SubObject`].
pub(super) fn build_sub(
    (index, s): (u16, u8),
    name: &str,
    line: u32,
    entries: &[Entry<'_>],
    sink: &mut Sink,
) -> Option<SubObject> {
    let sec = Section {
        name,
        kind: SectionKind::Sub(index, s),
        line,
        entries: Cow::Borrowed(entries),
    };
    let swhat = Where {
        index,
        sub: Some(s),
    };
    let sk = resolve_keys(&sec, &OBJ_KEYS, sink);
    let scode = object_code(sink, &sk, swhat)?;
    let sub = sub_object(sink, &sk, s, scode, line, swhat)?;
    if let Some((_, l)) = sk.slots[P_SUBNUMBER].or(sk.slots[P_COMPACT]) {
        sink.warn(
            K::Structure,
            l,
            format!("{swhat}: SubNumber/CompactSubObj on a sub-object ignored"),
        );
    }
    Some(sub)
}

pub(super) fn build(
    sections: &[Section<'_, '_>],
    subs: Vec<((u16, u8), SubRec<'_>)>,
    mut built: BTreeMap<u16, Vec<SubObject>>,
    sink: &mut Sink,
) -> ObjectDictionary {
    let mut od = ObjectDictionary::default();
    let mut objects: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut names: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut values: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut denotations: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut links: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    for sec in sections {
        match sec.kind {
            SectionKind::FileInfo => od.file_info = file_info(sec, sink),
            SectionKind::DeviceInfo => od.device_info = device_info(sec, sink),
            SectionKind::DummyUsage => od.dummy_usage = dummy_usage(sec, sink),
            SectionKind::Comments => od.comments = comments(sec, sink),
            SectionKind::Mandatory => {
                od.mandatory_objects = object_list(sec, sink);
                od.object_list_lines[0] = Line(sec.line);
            }
            SectionKind::Optional => {
                od.optional_objects = object_list(sec, sink);
                od.object_list_lines[1] = Line(sec.line);
            }
            SectionKind::Manufacturer => {
                od.manufacturer_objects = object_list(sec, sink);
                od.object_list_lines[2] = Line(sec.line);
            }
            SectionKind::Commissioning => {
                od.device_commissioning = Some(commissioning(sec, sink));
            }
            SectionKind::Object(i) => {
                objects.insert(i, sec);
            }
            SectionKind::Sub(..) => {}
            SectionKind::Names(i) => {
                names.insert(i, sec);
            }
            SectionKind::Values(i) => {
                values.insert(i, sec);
            }
            SectionKind::Denotations(i) => {
                denotations.insert(i, sec);
            }
            SectionKind::Links(i) => {
                links.insert(i, sec);
            }
            SectionKind::Other => {
                let module = is_module_section(sec.name);
                if !module {
                    sink.warn(
                        K::Structure,
                        sec.line,
                        format!(
                            "section [{}] is not defined by CiA 306; kept verbatim",
                            Echo(sec.name)
                        ),
                    );
                }
                od.other_sections.push(RawSection {
                    name: sec.name.to_string(),
                    entries: sec
                        .entries
                        .iter()
                        .map(|e| (e.key.into(), e.value.into()))
                        .collect(),
                    line: Line(sec.line),
                });
            }
        }
    }
    if od.file_info.eds_version.is_none() && objects.is_empty() {
        sink.warn(
            K::Structure,
            1,
            "no [FileInfo] EDSVersion and no objects: is this an EDS file?".into(),
        );
    }

    // Sub sections whose object is missing.
    // Sub sections are grouped by index: look each index up once.
    let mut last_index = None;
    for &((index, _), ref sec) in &subs {
        if last_index == Some(index) {
            continue;
        }
        last_index = Some(index);
        if !objects.contains_key(&index) {
            sink.warn(
                K::Structure,
                sec.line,
                format!(
                    "[{}] has no object section [{index:04X}]; ignored",
                    Echo(sec.name)
                ),
            );
        }
    }

    // Both maps are in index order: hand each object its sub sections in one merge pass.
    let mut subs = subs.into_iter().peekable();
    for (&index, sec) in &objects {
        let mut own_subs = Vec::new();
        while let Some(((i, _), _)) = subs.peek() {
            if *i > index {
                break;
            }
            if let Some(((i, s), rec)) = subs.next()
                && i == index
            {
                own_subs.push((s, rec));
            }
        }
        let own_built = built.remove(&index).unwrap_or_default();
        sink.object = Some(index);
        if let Some(mut obj) = object(index, sec, own_subs, own_built, sink) {
            if let Some(names_sec) = names.remove(&index) {
                apply_names(&mut obj, names_sec, sink);
            }
            if let Some(values_sec) = values.remove(&index) {
                apply_values(&mut obj, values_sec, sink);
            }
            if let Some(den_sec) = denotations.remove(&index) {
                apply_denotations(&mut obj, den_sec, sink);
            }
            if let Some(link_sec) = links.remove(&index) {
                obj.object_links = object_list(link_sec, sink);
            }
            od.objects.insert(index, obj);
        }
        sink.object = None;
    }
    for sec in names
        .values()
        .chain(values.values())
        .chain(denotations.values())
        .chain(links.values())
    {
        sink.warn(
            K::Structure,
            sec.line,
            format!(
                "[{}] refers to an object with no section; ignored",
                Echo(sec.name)
            ),
        );
    }
    od
}

pub(super) fn is_module_section(name: &str) -> bool {
    if name.eq_ignore_ascii_case("SupportedModules")
        || name.eq_ignore_ascii_case("ConnectedModules")
    {
        return true;
    }
    let b = name.as_bytes();
    b.len() > 2 && b[0].eq_ignore_ascii_case(&b'M') && b[1].is_ascii_digit()
}

pub(super) const OBJ_KEYS: KeyTable<15> = KeyTable::new([
    "ParameterName",
    "ObjectType",
    "DataType",
    "AccessType",
    "PDOMapping",
    "DefaultValue",
    "LowLimit",
    "HighLimit",
    "ParameterValue",
    "Denotation",
    "ObjFlags",
    "SubNumber",
    "CompactSubObj",
    "UploadFile",
    "DownloadFile",
]);
pub(super) const P_NAME: usize = 0;
pub(super) const P_OBJTYPE: usize = 1;
pub(super) const P_DATATYPE: usize = 2;
pub(super) const P_ACCESS: usize = 3;
pub(super) const P_PDO: usize = 4;
pub(super) const P_DEFAULT: usize = 5;
pub(super) const P_LOW: usize = 6;
pub(super) const P_HIGH: usize = 7;
pub(super) const P_PARAM: usize = 8;
pub(super) const P_DENOTATION: usize = 9;
pub(super) const P_FLAGS: usize = 10;
pub(super) const P_SUBNUMBER: usize = 11;
pub(super) const P_COMPACT: usize = 12;

pub(super) fn object_code(sink: &mut Sink, k: &Keys<'_, 15>, what: Where) -> Option<ObjectCode> {
    let Some((text, line)) = k.slots[P_OBJTYPE] else {
        return Some(ObjectCode::Var);
    };
    let mut notes = TextNotes::default();
    match parse_int_literal(text, &mut notes) {
        Some((v, _)) if (0..=0xFF).contains(&v) => {
            note_warnings(sink, line, "ObjectType", notes);
            let code = ObjectCode::from_code(v as u8);
            if let ObjectCode::Other(c) = code {
                sink.warn(
                    K::InvalidCode,
                    line,
                    format!("{what}: ObjectType=0x{c:X} is not a CiA 301 object code"),
                );
            }
            Some(code)
        }
        _ => {
            sink.error(
                K::Value,
                line,
                format!(
                    "{what}: ObjectType=`{}` is not a number; write 0x7 (VAR), 0x8 (ARRAY), 0x9 (RECORD) or 0x2 (DOMAIN)",
                    Echo(text)
                ),
            );
            None
        }
    }
}

/// Reads the value keys of a VAR object section or a sub-object section into a [`SubObject`].
pub(super) fn sub_object(
    sink: &mut Sink,
    k: &Keys<'_, 15>,
    sub_index: u8,
    code: ObjectCode,
    line: u32,
    what: Where,
) -> Option<SubObject> {
    let name = match k.slots[P_NAME] {
        Some(v) => unquote(sink, v, "ParameterName").into(),
        None => {
            sink.warn(K::Structure, line, format!("{what} has no ParameterName"));
            CompactString::default()
        }
    };
    let data_type = match k.slots[P_DATATYPE] {
        Some((text, dline)) => {
            let mut notes = TextNotes::default();
            match parse_int_literal(text, &mut notes) {
                Some((v, _)) if (0..=0xFFFF).contains(&v) => {
                    note_warnings(sink, dline, "DataType", notes);
                    DataType::from_code(v as u16)
                }
                _ => {
                    sink.error(
                        K::Value,
                        dline,
                        format!(
                            "{what}: DataType=`{}` is not a data type index; write e.g. 0x0007 for UNSIGNED32",
                            Echo(text)
                        ),
                    );
                    return None;
                }
            }
        }
        None if code == ObjectCode::Domain => DataType::Domain,
        None => {
            sink.error(
                K::Structure,
                line,
                format!("{what} has no DataType; add e.g. DataType=0x0007 (UNSIGNED32)"),
            );
            return None;
        }
    };
    let mut sub = SubObject::new(sub_index, name, data_type, AccessType::Ro);
    sub.object_code = code;
    sub.line = Line(line);
    match k.slots[P_ACCESS] {
        Some((text, aline)) => match AccessType::from_eds(text) {
            Some(a) => {
                if a.as_str() != text {
                    sink.warn(
                        K::Style,
                        aline,
                        format!(
                            "AccessType={text}: CiA 306 writes `{}` in lower case",
                            a.as_str()
                        ),
                    );
                }
                sub.access = a;
            }
            None => {
                sink.warn(
                    K::InvalidCode,
                    aline,
                    format!(
                        "{what}: AccessType=`{}` is none of ro, wo, rw, rwr, rww, const; treated as ro",
                        Echo(text)
                    ),
                );
                sub.extras_mut().access_raw = Some(text.to_string());
            }
        },
        None => {
            sink.warn(
                K::Structure,
                line,
                format!("{what} has no AccessType; treated as ro"),
            );
        }
    }
    if let Some(v) = k.slots[P_PDO] {
        sub.pdo_mapping = boolean(sink, v, "PDOMapping").unwrap_or(false);
    }
    let mut field = |slot: usize, label: &str| -> Option<FieldValue> {
        let (text, fline) = k.slots[slot]?;
        let (f, res) = FieldValue::from_text(data_type, text);
        match res {
            Ok(notes) => note_warnings(sink, fline, label, notes),
            Err(TextError::Empty) => {}
            Err(e) => unparsable(
                sink,
                what.index,
                fline,
                label,
                format!("{what}: {label}=`{}`: {e}", Echo(text)),
            ),
        }
        Some(f)
    };
    sub.default_value = field(P_DEFAULT, "DefaultValue");
    let (low, high) = (field(P_LOW, "LowLimit"), field(P_HIGH, "HighLimit"));
    let param = field(P_PARAM, "ParameterValue");
    let denotation = k.slots[P_DENOTATION].map(|(t, _)| t.to_string());
    if let Some(v) = k.slots[P_FLAGS] {
        sub.obj_flags = uint(sink, v, "ObjFlags", u64::from(u32::MAX)).map(|v| v as u32);
    }
    let files = [13, 14].map(|slot| k.slots[slot].zip(OBJ_KEYS.keys.get(slot)));
    let any_rare = low.is_some()
        || high.is_some()
        || param.is_some()
        || denotation.is_some()
        || files.iter().any(Option::is_some)
        || !k.extra.is_empty();
    if any_rare {
        let x = sub.extras_mut();
        x.low_limit = low;
        x.high_limit = high;
        x.parameter_value = param;
        x.denotation = denotation;
        for ((text, _), key) in files.into_iter().flatten() {
            x.extra.push(((*key).into(), text.into()));
        }
        x.extra.extend(extra_owned(&k.extra));
    }
    Some(sub)
}

pub(super) fn object(
    index: u16,
    sec: &Section<'_, '_>,
    sub_secs: Vec<(u8, SubRec<'_>)>,
    built: Vec<SubObject>,
    sink: &mut Sink,
) -> Option<Object> {
    let what = Where { index, sub: None };
    let k = resolve_keys(sec, &OBJ_KEYS, sink);
    let code = object_code(sink, &k, what)?;
    if code.is_simple() || matches!(code, ObjectCode::Other(_)) {
        let sub = sub_object(sink, &k, 0, ObjectCode::Var, sec.line, what)?;
        let mut obj = Object::var(index, sub);
        obj.object_code = code;
        obj.line = Line(sec.line);
        if let Some(v) = k.slots[P_SUBNUMBER] {
            obj.sub_number = uint(sink, v, "SubNumber", 255).map(|v| v as u8);
        }
        if k.slots[P_COMPACT].is_some() {
            sink.warn(
                K::Structure,
                sec.line,
                format!("{what}: CompactSubObj on a VAR ignored"),
            );
        }
        let mut first_ignored = true;
        for (_, s) in sub_secs {
            if first_ignored {
                sink.warn(
                    K::Structure,
                    s.line,
                    format!(
                        "[{}]: {what} is a {}, so its sub sections are ignored",
                        Echo(s.name),
                        code.name()
                    ),
                );
                first_ignored = false;
            }
        }
        return Some(obj);
    }

    let name = match k.slots[P_NAME] {
        Some(v) => unquote(sink, v, "ParameterName").into(),
        None => {
            sink.warn(
                K::Structure,
                sec.line,
                format!("{what} has no ParameterName"),
            );
            CompactString::default()
        }
    };
    let mut obj = Object::complex(index, name, code, []);
    obj.sub_number = None;
    obj.line = Line(sec.line);
    if let Some(v) = k.slots[P_SUBNUMBER] {
        obj.sub_number = uint(sink, v, "SubNumber", 255).map(|v| v as u8);
    }
    if let Some(v) = k.slots[P_FLAGS] {
        obj.obj_flags = uint(sink, v, "ObjFlags", u64::from(u32::MAX)).map(|v| v as u32);
    }
    let compact = match k.slots[P_COMPACT] {
        Some(v) => uint(sink, v, "CompactSubObj", 255).map(|v| v as u8),
        None => None,
    };
    let mut ok = true;
    if let Some(n) = compact.filter(|&n| n > 0) {
        // CiA 306 §4.5.2.3: sub-index 0 is the number of entries (UNSIGNED8, ro); sub-indices
        // 1..=n share DataType, AccessType, PDOMapping and values of the object section.
        let count = SubObject::new(0, "NrOfObjects", DataType::Unsigned8, AccessType::Ro)
            .with_default(crate::value::EdsValue::plain(
                crate::value::Value::Unsigned8(n),
            ));
        let mut count = count;
        count.line = Line(sec.line);
        obj.subs.insert(count);
        let mut proto_keys = Keys {
            slots: k.slots,
            extra: Vec::new(),
        };
        proto_keys.slots[P_OBJTYPE] = None;
        proto_keys.slots[P_SUBNUMBER] = None;
        proto_keys.slots[P_COMPACT] = None;
        proto_keys.slots[P_FLAGS] = None;
        match sub_object(sink, &proto_keys, 1, ObjectCode::Var, sec.line, what) {
            Some(proto) => {
                for i in 1..=n {
                    let mut s = proto.clone();
                    s.sub_index = i;
                    s.name = format_compact!("{}{}", obj.name, i);
                    obj.subs.insert(s);
                }
            }
            None => ok = false,
        }
        obj.extra = extra_owned(&k.extra);
    } else {
        // Keys describing values on an ARRAY/RECORD section are kept as they are.
        for slot in [
            P_DATATYPE,
            P_ACCESS,
            P_PDO,
            P_DEFAULT,
            P_LOW,
            P_HIGH,
            P_PARAM,
            P_DENOTATION,
            13,
            14,
        ] {
            if let (Some((text, _)), Some(key)) = (k.slots[slot], OBJ_KEYS.keys.get(slot)) {
                obj.extra.push(((*key).into(), text.into()));
            }
        }
        obj.extra.extend(extra_owned(&k.extra));
    }
    for (s, rec) in sub_secs {
        for d in rec.rare.map(|r| r.diags).unwrap_or_default() {
            sink.push(d);
        }
        ok &= rec.ok;
        if compact.is_some() && rec.ok && obj.subs.contains(s) {
            sink.warn(
                K::Duplicate,
                rec.line,
                format!(
                    "sub-object {index:04X}sub{s:X} also defined by CompactSubObj; the [{}] section wins",
                    Echo(rec.name)
                ),
            );
        }
    }
    if obj.subs.is_empty() {
        obj.subs = SubObjects::from(built);
    } else {
        for sub in built {
            obj.subs.insert(sub);
        }
    }
    ok.then_some(obj)
}

/// `[xxxxName]`: `NrOfEntries=n`, then `sub=name` lines.
pub(super) fn apply_names(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => s.name = value.into(),
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; name ignored",
                    Echo(sec.name)
                ),
            ),
        },
    );
}

/// Reports a value that does not parse. In a communication object (0x1000..0x1FFF) a
/// DefaultValue or ParameterValue configures the network (a COB-ID, a mapping, a heartbeat
/// time): a device or master using the file would have no value, or fall back to 0, which as
/// a COB-ID is the NMT identifier; so there it is an error. Elsewhere, and for the limits, the
/// text is kept and the finding is a warning.
fn unparsable(sink: &mut Sink, index: u16, line: u32, label: &str, message: alloc::string::String) {
    if is_communication_object(index) && matches!(label, "DefaultValue" | "ParameterValue") {
        sink.error(
            K::Value,
            line,
            format!("{message}; a value of a communication object (0x1000..0x1FFF) must parse"),
        );
    } else {
        sink.warn(K::Value, line, format!("{message}; kept as text only"));
    }
}

/// `[xxxxValue]`: `NrOfEntries=n`, then `sub=value` lines (DCF `ParameterValue`).
pub(super) fn apply_values(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => {
                let (f, res) = FieldValue::from_text(s.data_type, value);
                match res {
                    Ok(notes) => note_warnings(sink, line, "value", notes),
                    Err(TextError::Empty) => {}
                    Err(e) => unparsable(
                        sink,
                        obj.index,
                        line,
                        "ParameterValue",
                        format!("[{}] {sub}=`{}`: {e}", Echo(sec.name), Echo(value)),
                    ),
                }
                s.extras_mut().parameter_value = Some(f);
            }
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; value ignored",
                    Echo(sec.name)
                ),
            ),
        },
    );
}

/// `[xxxxDenotation]`: `NrOfEntries=n`, then `sub=denotation` lines.
pub(super) fn apply_denotations(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => s.extras_mut().denotation = Some(value.to_string()),
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; denotation ignored",
                    Echo(sec.name)
                ),
            ),
        },
    );
}

/// Calls `f(n, value, line)` for each `n=value` key (n decimal or 0x hex, 0..=255) of a
/// numbered section; checks the count key.
pub(super) fn for_numbered(
    sec: &Section<'_, '_>,
    sink: &mut Sink,
    count_key: &str,
    mut f: impl FnMut(u8, &str, u32, &mut Sink),
) {
    let mut count: Option<(u64, u32)> = None;
    let mut seen = 0u64;
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case(count_key) {
            count = uint(sink, (e.value, e.line), count_key, u64::MAX).map(|c| (c, e.line));
            continue;
        }
        let mut notes = TextNotes::default();
        match parse_int_literal(e.key, &mut notes) {
            Some((n, _)) if (0..=255).contains(&n) => {
                seen += 1;
                f(n as u8, e.value, e.line, sink);
            }
            _ => sink.warn(
                K::Structure,
                e.line,
                format!(
                    "[{}]: key `{}` is not a sub-index; ignored",
                    Echo(sec.name),
                    Echo(e.key)
                ),
            ),
        }
    }
    if let Some((c, line)) = count
        && c != seen
    {
        sink.warn(
            K::Structure,
            line,
            format!(
                "[{}]: {count_key}={c} but {seen} entries follow",
                Echo(sec.name)
            ),
        );
    }
}
