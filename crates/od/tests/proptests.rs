//! Property tests: value codecs round-trip for every data type (bytes and EDS text), and
//! randomly generated dictionaries survive write -> parse unchanged.

use canola_od::model::{FieldValue, Object, ObjectDictionary, SubObject};
use canola_od::{
    AccessType, BASIC_DATA_TYPES, DataType, EdsValue, ObjectCode, Value, parse, write_eds,
};
use proptest::prelude::*;

fn value_of(dt: DataType) -> BoxedStrategy<Value> {
    use DataType as D;
    // Text that fits on one EDS line (no CR/LF).
    let line_text = "[^\r\n]{0,24}";
    match dt {
        D::Boolean => any::<bool>().prop_map(Value::Boolean).boxed(),
        D::Integer8 => any::<i8>().prop_map(Value::Integer8).boxed(),
        D::Integer16 => any::<i16>().prop_map(Value::Integer16).boxed(),
        D::Integer24 => (-(1i32 << 23)..(1 << 23))
            .prop_map(Value::Integer24)
            .boxed(),
        D::Integer32 => any::<i32>().prop_map(Value::Integer32).boxed(),
        D::Integer40 => (-(1i64 << 39)..(1 << 39))
            .prop_map(Value::Integer40)
            .boxed(),
        D::Integer48 => (-(1i64 << 47)..(1 << 47))
            .prop_map(Value::Integer48)
            .boxed(),
        D::Integer56 => (-(1i64 << 55)..(1 << 55))
            .prop_map(Value::Integer56)
            .boxed(),
        D::Integer64 => any::<i64>().prop_map(Value::Integer64).boxed(),
        D::Unsigned8 => any::<u8>().prop_map(Value::Unsigned8).boxed(),
        D::Unsigned16 => any::<u16>().prop_map(Value::Unsigned16).boxed(),
        D::Unsigned24 => (0u32..(1 << 24)).prop_map(Value::Unsigned24).boxed(),
        D::Unsigned32 => any::<u32>().prop_map(Value::Unsigned32).boxed(),
        D::Unsigned40 => (0u64..(1 << 40)).prop_map(Value::Unsigned40).boxed(),
        D::Unsigned48 => (0u64..(1 << 48)).prop_map(Value::Unsigned48).boxed(),
        D::Unsigned56 => (0u64..(1 << 56)).prop_map(Value::Unsigned56).boxed(),
        D::Unsigned64 => any::<u64>().prop_map(Value::Unsigned64).boxed(),
        // Any bit pattern, NaNs and infinities included.
        D::Real32 => any::<u32>()
            .prop_map(|b| Value::Real32(f32::from_bits(b)))
            .boxed(),
        D::Real64 => any::<u64>()
            .prop_map(|b| Value::Real64(f64::from_bits(b)))
            .boxed(),
        // A VISIBLE_STRING on the bus ends at its first NUL, so none inside.
        D::VisibleString => r"[^\r\n\x00]{0,24}"
            .prop_map(|s| Value::VisibleString(s.into_bytes()))
            .boxed(),
        D::UnicodeString => line_text
            .prop_map(|s| Value::UnicodeString(s.encode_utf16().collect()))
            .boxed(),
        D::OctetString => proptest::collection::vec(any::<u8>(), 0..16)
            .prop_map(Value::OctetString)
            .boxed(),
        D::Domain => proptest::collection::vec(any::<u8>(), 0..16)
            .prop_map(Value::Domain)
            .boxed(),
        D::TimeOfDay => (any::<u32>(), any::<u16>())
            .prop_map(|(ms, days)| Value::TimeOfDay { ms, days })
            .boxed(),
        D::TimeDifference => (any::<u32>(), any::<u16>())
            .prop_map(|(ms, days)| Value::TimeDifference { ms, days })
            .boxed(),
        D::Other(_) => unreachable!("only basic types"),
    }
}

fn any_value() -> impl Strategy<Value = Value> {
    (0..BASIC_DATA_TYPES.len()).prop_flat_map(|i| value_of(BASIC_DATA_TYPES[i]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn bytes_round_trip(v in any_value()) {
        let dt = v.data_type();
        let bytes = v.to_le_bytes();
        if let Some(n) = dt.size() {
            prop_assert_eq!(bytes.len(), n);
        }
        prop_assert_eq!(Value::from_le_bytes(dt, &bytes), Ok(v));
    }

    /// The display form has no control characters, shows integers as the decimal of their
    /// value, and numbers parse back (floats to the same bits, save NaN payloads).
    #[test]
    fn display_is_plain_text(v in any_value()) {
        let shown = v.to_string();
        let alt = format!("{v:#}");
        prop_assert!(!shown.chars().chain(alt.chars()).any(char::is_control), "{:?}", shown);
        match &v {
            Value::Real32(f) if !f.is_nan() => prop_assert_eq!(shown.parse::<f32>().map(f32::to_bits), Ok(f.to_bits())),
            Value::Real64(f) if !f.is_nan() => prop_assert_eq!(shown.parse::<f64>().map(f64::to_bits), Ok(f.to_bits())),
            Value::Boolean(_) => {}
            _ => if let Some(n) = v.as_i128() {
                prop_assert_eq!(shown.parse::<i128>(), Ok(n));
            }
        }
    }

    #[test]
    fn bytes_decode_is_lossless(i in 0..BASIC_DATA_TYPES.len(), raw in proptest::collection::vec(any::<u8>(), 0..12)) {
        let dt = BASIC_DATA_TYPES[i];
        if let Ok(v) = Value::from_le_bytes(dt, &raw) {
            if dt == DataType::VisibleString {
                // The text up to the first NUL.
                let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
                prop_assert_eq!(v.to_le_bytes(), &raw[..end]);
            } else {
                prop_assert_eq!(v.to_le_bytes(), raw);
            }
        }
    }

    #[test]
    fn text_round_trip(v in any_value(), relative in any::<bool>()) {
        let dt = v.data_type();
        let relative = relative && dt.integer_bits().is_some() && dt != DataType::Boolean;
        let ev = EdsValue { value: v, node_id_relative: relative };
        let text = ev.to_eds_text();
        let (back, _) = EdsValue::parse(dt, &text).map_err(|e| TestCaseError::fail(format!("{text:?}: {e}")))?;
        prop_assert_eq!(back, ev);
    }

    #[test]
    fn integer_spellings(v in any::<u32>(), node in 1u8..=127) {
        let dt = DataType::Unsigned32;
        for text in [format!("{v}"), format!("0x{v:x}"), format!("0X{v:08X}"), format!("0{v:o}"), format!("{v}ULL")] {
            let (ev, _) = EdsValue::parse(dt, &text).unwrap();
            prop_assert_eq!(ev.value, Value::Unsigned32(v));
        }
        let offset = v % 0x800;
        for text in [format!("$NODEID+0x{offset:X}"), format!("0x{offset:X} + $nodeid"), format!("$NodeID + {offset}")] {
            let (ev, _) = EdsValue::parse(dt, &text).unwrap();
            prop_assert_eq!(ev.resolve(node), Value::Unsigned32(offset + u32::from(node)));
        }
    }

    #[test]
    fn signed_spellings(v in any::<i16>()) {
        let (ev, _) = EdsValue::parse(DataType::Integer16, &format!("{v}")).unwrap();
        prop_assert_eq!(ev.value.clone(), Value::Integer16(v));
        // Two's complement hex is accepted for signed types.
        let (ev2, _) = EdsValue::parse(DataType::Integer16, &format!("0x{:04X}", v as u16)).unwrap();
        prop_assert_eq!(ev2.value, Value::Integer16(v));
    }

    #[test]
    fn text_decoder_is_total(i in 0..BASIC_DATA_TYPES.len(), text in "\\PC{0,40}") {
        let _ = EdsValue::parse(BASIC_DATA_TYPES[i], &text);
    }
}

// ---------------------------------------------------------------------------------------------
// Random dictionaries

fn name() -> impl Strategy<Value = String> {
    "[A-Za-z][A-Za-z0-9 _.()-]{0,20}[A-Za-z0-9]"
}

fn access() -> impl Strategy<Value = AccessType> {
    prop_oneof![
        Just(AccessType::Ro),
        Just(AccessType::Wo),
        Just(AccessType::Rw),
        Just(AccessType::Rwr),
        Just(AccessType::Rww),
        Just(AccessType::Const),
    ]
}

fn field(dt: DataType) -> impl Strategy<Value = Option<FieldValue>> {
    let relative_ok = dt.integer_bits().is_some() && dt != DataType::Boolean;
    proptest::option::of((value_of(dt), any::<bool>()).prop_map(move |(v, rel)| {
        FieldValue::from_value(EdsValue {
            value: v,
            node_id_relative: rel && relative_ok,
        })
    }))
}

fn sub(sub_index: u8) -> impl Strategy<Value = SubObject> {
    (
        0..BASIC_DATA_TYPES.len(),
        name(),
        access(),
        any::<bool>(),
        any::<Option<u32>>(),
        proptest::option::of(name()),
    )
        .prop_flat_map(move |(i, n, a, pdo, flags, denotation)| {
            let dt = BASIC_DATA_TYPES[i];
            (field(dt), field(dt), field(dt), field(dt)).prop_map(move |(d, lo, hi, pv)| {
                let mut s = SubObject::new(sub_index, n.clone(), dt, a);
                s.pdo_mapping = pdo;
                s.default_value = d;
                s.obj_flags = flags;
                // Always allocated here, even when every field is empty: a parsed model has
                // none then, and the two must compare equal.
                let x = s.extras_mut();
                x.low_limit = lo;
                x.high_limit = hi;
                x.parameter_value = pv;
                x.denotation = denotation.clone();
                s
            })
        })
}

fn object(index: u16) -> impl Strategy<Value = Object> {
    prop_oneof![
        sub(0).prop_map(move |s| Object::var(index, s)),
        (name(), 1usize..6, any::<bool>()).prop_flat_map(move |(n, count, record)| {
            let subs: Vec<_> = (0..count as u8).map(sub).collect();
            subs.prop_map(move |subs| {
                let code = if record {
                    ObjectCode::Record
                } else {
                    ObjectCode::Array
                };
                Object::complex(index, n.clone(), code, subs)
            })
        }),
    ]
}

fn dictionary() -> impl Strategy<Value = ObjectDictionary> {
    (
        proptest::collection::btree_set(0x1000u16..0x6000, 1..12),
        proptest::option::of(name()),
        any::<Option<u32>>(),
        any::<[Option<bool>; 8]>(),
        proptest::collection::vec(name(), 0..3),
        proptest::option::of((1u8..=127, any::<u16>())),
    )
        .prop_flat_map(
            |(indices, vendor, number, bauds, comments, commissioning)| {
                let objects: Vec<_> = indices.iter().map(|&i| object(i)).collect();
                objects.prop_map(move |objects| {
                    let mut od = ObjectDictionary::default();
                    od.file_info.eds_version = Some("4.0".into());
                    od.device_info.vendor_name = vendor.clone();
                    od.device_info.vendor_number = number;
                    od.device_info.baud_rates = bauds;
                    od.comments = comments.clone();
                    if let Some((node, baud)) = commissioning {
                        let dc = od.device_commissioning.get_or_insert_with(Default::default);
                        dc.node_id = Some(node);
                        dc.baudrate = Some(baud);
                    }
                    for o in objects {
                        od.insert(o);
                    }
                    od.rebuild_object_lists();
                    od
                })
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn generated_models_round_trip(od in dictionary()) {
        let text = write_eds(&od);
        let parsed = parse(text.as_bytes()).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        prop_assert_eq!(&parsed.od, &od, "{}", text);
        // And once more: the writer is stable.
        prop_assert_eq!(write_eds(&parsed.od), text);
    }
}
