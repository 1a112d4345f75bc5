//! Values as real devices send them: an expedited SDO upload without the size indicated
//! (CiA 301 §7.2.4.3.6, e = 1, s = 0: four data bytes, the ones past the object unspecified).

use canola_od::{BytesError, DataType, Entry, EntryError, Value};

/// `42 00 20 01 05 A5 A5 A5` answering a read of an UNSIGNED8: the value is the first byte.
#[test]
fn unsized_expedited_upload_takes_the_type_length() {
    let bytes = [0x05, 0xA5, 0xA5, 0xA5];
    // The strict decoder keeps refusing: four bytes are not an UNSIGNED8.
    assert_eq!(
        Value::from_le_bytes(DataType::Unsigned8, &bytes),
        Err(BytesError::WrongLength {
            data_type: DataType::Unsigned8,
            expected: 1,
            actual: 4
        })
    );
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Unsigned8, &bytes),
        Ok(Value::Unsigned8(5))
    );
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Integer16, &[0xFE, 0xFF, 0x12, 0x34]),
        Ok(Value::Integer16(-2))
    );
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Boolean, &[1, 0xFF, 0xFF, 0xFF]),
        Ok(Value::Boolean(true))
    );
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Unsigned24, &[1, 2, 3, 4]),
        Ok(Value::Unsigned24(0x03_0201))
    );
    // Four bytes of a four-byte type, as always.
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Unsigned32, &[1, 2, 3, 4]),
        Ok(Value::Unsigned32(0x0403_0201))
    );
    // Fewer bytes than the type takes stay an error: nothing is made up.
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::Unsigned32, &[1, 2]),
        Err(BytesError::WrongLength {
            data_type: DataType::Unsigned32,
            expected: 4,
            actual: 2
        })
    );
    // Types without a fixed length keep every byte.
    assert_eq!(
        Value::from_le_bytes_unsized(DataType::OctetString, &[1, 2, 3, 4]),
        Ok(Value::OctetString(vec![1, 2, 3, 4]))
    );
    assert_eq!(
        DataType::Unsigned16.expedited_without_size(&[1, 2, 3, 4]),
        &[1, 2]
    );
    assert_eq!(
        DataType::Domain.expedited_without_size(&[1, 2, 3, 4]),
        &[1, 2, 3, 4]
    );
}

/// The typed path (generated entries): the same rule.
#[test]
fn unsized_expedited_upload_of_typed_entries() {
    let u8_entry: Entry<u8> = Entry::new(0x2000, 1, DataType::Unsigned8);
    let bytes = [0x2A, 0, 0, 0];
    assert_eq!(
        u8_entry.decode(&bytes),
        Err(EntryError::Length {
            data_type: DataType::Unsigned8,
            expected: 1,
            actual: 4
        })
    );
    assert_eq!(u8_entry.decode_unsized(&bytes), Ok(42));
    let u16_entry: Entry<u16> = Entry::new(0x1017, 0, DataType::Unsigned16);
    assert_eq!(
        u16_entry.decode_unsized(&[0xE8, 0x03, 0x99, 0x99]),
        Ok(1000)
    );
}

/// A VISIBLE_STRING read from CANopenNode's demo device ends in its C string's NUL (901 bytes
/// for a 900-character text): the value is the text up to the first NUL, as python-canopen
/// and CANopenNode's own tools read it.
#[test]
fn visible_string_ends_at_the_first_nul() {
    let mut bytes = vec![b'x'; 900];
    bytes.push(0);
    match Value::from_le_bytes(DataType::VisibleString, &bytes) {
        Ok(Value::VisibleString(text)) => {
            assert_eq!(text.len(), 900);
            assert!(text.iter().all(|&b| b == b'x'));
        }
        other => panic!("expected a VISIBLE_STRING, got {other:?}"),
    }
    assert_eq!(
        Value::from_le_bytes(DataType::VisibleString, b"CANopenNode\0\0\0garbage"),
        Ok(Value::VisibleString(b"CANopenNode".to_vec()))
    );
    assert_eq!(
        Value::from_le_bytes(DataType::VisibleString, b"\0"),
        Ok(Value::VisibleString(Vec::new()))
    );
    // OCTET_STRING and DOMAIN keep every byte.
    assert_eq!(
        Value::from_le_bytes(DataType::OctetString, b"a\0b"),
        Ok(Value::OctetString(b"a\0b".to_vec()))
    );
    // The typed path reads it the same way.
    let name: Entry<String> = Entry::new(0x1008, 0, DataType::VisibleString);
    assert_eq!(name.decode(b"abc\0").unwrap(), "abc");
}

/// Text prints as text; a control character is written in one way, `\n`, `\r`, `\t` or `\xHH`,
/// never in Rust's `\u{..}` escape form.
#[test]
fn text_escapes_control_characters_one_way() {
    let odd = Value::VisibleString(b"a\x00b\n\x07\x1b\x7f\tz\r".to_vec());
    let shown = odd.to_string();
    assert_eq!(shown, r"a\x00b\n\x07\x1B\x7F\tz\r");
    assert!(!shown.contains("\\u{"));
    assert_eq!(format!("{odd:#}"), r#""a\x00b\n\x07\x1B\x7F\tz\r""#);
    let wide = Value::UnicodeString("a\u{0}\u{85}b".encode_utf16().collect());
    assert_eq!(wide.to_string(), r"a\x00\x85b");
}
