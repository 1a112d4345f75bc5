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
