//! The one adapter from the `canola-od` object dictionary model (an EDS or DCF file) to this
//! crate's [`Catalog`] and [`Dictionary`] (feature `od`).
//!
//! Every user of PDOs in the workspace goes through [`OdView`]: the master validates and types a
//! node's mappings against its EDS (`OdView::new`, default values with `$NODEID` resolved), and a
//! device simulator reads its PDO parameters from its current values
//! (`OdView::with_values` over a [`ValueSource`]):
//! `Mapping::read_from(&OdView::new(&od, node_id), direction, 0x1A00)`.
//!
//! Sizes as a PDO sees them: BOOLEAN is one bit (CiA 301's usual mapping length); mapping
//! validation also accepts a BOOLEAN mapped with 8 bits, as many devices do, and the mapping
//! entry's length decides how the value is packed. Fixed-size types have their size; strings and
//! domains the length of their (current, else default) value, at most 64 bits.

use canola_od::{BytesError, DataType, ObjectDictionary, Value};

use crate::dictionary::{Catalog, Dictionary, ObjectAddress, ObjectInfo, ReadError};
use crate::mapping::{MappedObject, ValueKind};
use crate::pack::RawValue;

impl RawValue {
    /// The value as the object dictionary types it: [`canola_od::Value`], the one value type
    /// of the workspace's applications, for an object of `data_type` (the mapped object's type
    /// in the node's dictionary, or [`MappedObject::data_type`] without one). Integers take the
    /// type's width (a 12-bit field of an UNSIGNED16 is an `Unsigned16`); byte-typed fields
    /// decode as the type's bytes. An error when the value cannot be of that type (a REAL32
    /// field for an UNSIGNED16, a BOOLEAN other than 0 or 1, a time type of other than 6 bytes).
    pub fn to_value(&self, data_type: DataType) -> Result<Value, BytesError> {
        let unsupported = || BytesError::Unsupported(data_type);
        match (*self, data_type) {
            // The usual process data first, without the detour through i128 (the receive hot
            // path; the casts truncate as `from_i128_wrapping` does).
            (Self::Unsigned(v), DataType::Unsigned8) => Ok(Value::Unsigned8(v as u8)),
            (Self::Unsigned(v), DataType::Unsigned16) => Ok(Value::Unsigned16(v as u16)),
            (Self::Unsigned(v), DataType::Unsigned32) => Ok(Value::Unsigned32(v as u32)),
            (Self::Signed(v), DataType::Integer8) => Ok(Value::Integer8(v as i8)),
            (Self::Signed(v), DataType::Integer16) => Ok(Value::Integer16(v as i16)),
            (Self::Signed(v), DataType::Integer32) => Ok(Value::Integer32(v as i32)),
            (Self::Bool(b), DataType::Boolean) => Ok(Value::Boolean(b)),
            (Self::Real32(f), DataType::Real32) => Ok(Value::Real32(f)),
            (Self::Real64(f), DataType::Real64) => Ok(Value::Real64(f)),
            (Self::Bytes(b), _) => Value::from_le_bytes(data_type, b.as_slice()),
            // A BOOLEAN mapped as unsigned bits (a mapping built from raw entries).
            (Self::Unsigned(v), DataType::Boolean) if v <= 1 => Ok(Value::Boolean(v == 1)),
            (Self::Unsigned(v), _) if data_type.integer_bits().is_some() => {
                Value::from_i128_wrapping(data_type, i128::from(v)).ok_or_else(unsupported)
            }
            (Self::Signed(v), _) if data_type.integer_bits().is_some() => {
                Value::from_i128_wrapping(data_type, i128::from(v)).ok_or_else(unsupported)
            }
            _ => Err(unsupported()),
        }
    }
}

impl RawValue {
    /// The field value of an object of `kind` holding `value` (the reverse of
    /// [`to_value`](Self::to_value)); `None` when `value` cannot be such a field (a string for
    /// an unsigned field, more than eight bytes).
    pub fn from_value(value: &Value, kind: ValueKind) -> Option<Self> {
        Some(match (kind, value) {
            (ValueKind::Boolean, Value::Boolean(b)) => Self::Bool(*b),
            (ValueKind::Boolean, v) => match v.as_i128()? {
                0 => Self::Bool(false),
                1 => Self::Bool(true),
                _ => return None,
            },
            (ValueKind::Real32, Value::Real32(f)) => Self::Real32(*f),
            (ValueKind::Real64, Value::Real64(f)) => Self::Real64(*f),
            (ValueKind::Unsigned, v) => Self::Unsigned(u64::try_from(v.as_i128()?).ok()?),
            (ValueKind::Signed, v) => Self::Signed(i64::try_from(v.as_i128()?).ok()?),
            (ValueKind::Bytes, v) => Self::Bytes(crate::pack::Bytes::new(&v.to_le_bytes())?),
            _ => return None,
        })
    }
}

impl crate::typed::PairValue for Value {
    fn to_raw_value(&self, kind: ValueKind) -> Option<RawValue> {
        RawValue::from_value(self, kind)
    }
}

impl MappedObject {
    /// The data type a value of this object has when no dictionary tells: from its kind and
    /// mapped length (BOOLEAN; the UNSIGNEDn or INTEGERn as wide as its bytes; REAL32, REAL64;
    /// OCTET_STRING for byte-typed fields).
    pub fn data_type(&self) -> DataType {
        kind_data_type(self.kind, self.bits())
    }

    /// The data type to type this object's values with: `declared` (its type in a dictionary)
    /// when that agrees with how the mapping decodes it, else [`data_type`](Self::data_type).
    pub fn value_type(&self, declared: Option<DataType>) -> DataType {
        kind_value_type(self.kind, self.bits(), declared)
    }
}

impl crate::fd::FdMappedObject {
    /// As [`MappedObject::data_type`].
    pub fn data_type(&self) -> DataType {
        kind_data_type(self.kind, self.bits())
    }

    /// As [`MappedObject::value_type`].
    pub fn value_type(&self, declared: Option<DataType>) -> DataType {
        kind_value_type(self.kind, self.bits(), declared)
    }
}

fn kind_data_type(kind: ValueKind, bits: u8) -> DataType {
    let bytes = bits.div_ceil(8);
    match kind {
        ValueKind::Boolean => DataType::Boolean,
        ValueKind::Real32 => DataType::Real32,
        ValueKind::Real64 => DataType::Real64,
        ValueKind::Bytes => DataType::OctetString,
        ValueKind::Unsigned => match bytes {
            0 | 1 => DataType::Unsigned8,
            2 => DataType::Unsigned16,
            3 => DataType::Unsigned24,
            4 => DataType::Unsigned32,
            5 => DataType::Unsigned40,
            6 => DataType::Unsigned48,
            7 => DataType::Unsigned56,
            _ => DataType::Unsigned64,
        },
        ValueKind::Signed => match bytes {
            0 | 1 => DataType::Integer8,
            2 => DataType::Integer16,
            3 => DataType::Integer24,
            4 => DataType::Integer32,
            5 => DataType::Integer40,
            6 => DataType::Integer48,
            7 => DataType::Integer56,
            _ => DataType::Integer64,
        },
    }
}

fn kind_value_type(kind: ValueKind, bits: u8, declared: Option<DataType>) -> DataType {
    match declared {
        Some(t)
            if ValueKind::from_data_type(t.code()) == kind
                && (kind != ValueKind::Bytes
                    || t.size().is_none_or(|n| n * 8 == usize::from(bits))) =>
        {
            t
        }
        _ => kind_data_type(kind, bits),
    }
}

/// Current object values as little-endian bytes (CiA 301 §7.1), for a view over a running
/// device rather than a file's defaults.
pub trait ValueSource {
    /// The current value of `index:subindex`, if the object has one.
    fn value(&self, index: u16, subindex: u8) -> Option<&[u8]>;
}

/// A read-only view of an object dictionary model for one node: metadata from the model, values
/// from a [`ValueSource`] when one is given, else the DCF `ParameterValue` or `DefaultValue`
/// (`$NODEID` resolved to the node-ID).
#[derive(Clone, Copy)]
pub struct OdView<'a> {
    od: &'a ObjectDictionary,
    values: Values<'a>,
}

/// Where an [`OdView`] takes values from.
#[derive(Clone, Copy)]
enum Values<'a> {
    /// The file's values, as node `node_id`.
    Defaults { node_id: u8 },
    /// A running device's values.
    Current(&'a dyn ValueSource),
}

impl core::fmt::Debug for OdView<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut d = f.debug_struct("OdView");
        match self.values {
            Values::Defaults { node_id } => d.field("defaults_for_node", &node_id),
            Values::Current(_) => d.field("values", &"current"),
        };
        d.finish_non_exhaustive()
    }
}

impl<'a> OdView<'a> {
    /// A view of `od`'s default values as node `node_id`.
    pub fn new(od: &'a ObjectDictionary, node_id: u8) -> Self {
        Self {
            od,
            values: Values::Defaults { node_id },
        }
    }

    /// A view of `od`'s metadata with a device's current `values`.
    pub fn with_values(od: &'a ObjectDictionary, values: &'a dyn ValueSource) -> Self {
        Self {
            od,
            values: Values::Current(values),
        }
    }

    /// The length in bytes of the object's value: the current one, else the default.
    fn value_len(&self, index: u16, subindex: u8) -> Option<usize> {
        match self.values {
            Values::Current(v) => v.value(index, subindex).map(<[u8]>::len),
            Values::Defaults { node_id } => self
                .od
                .sub(index, subindex)?
                .effective_value(node_id)
                .map(|v| v.to_le_bytes().len()),
        }
    }
}

/// Size in bits of an entry as a PDO sees it: BOOLEAN is one bit, fixed-size types their size,
/// strings and domains the length of their value (at most 64 bits; 64 when there is none).
fn bits_of(data_type: DataType, value_len: Option<usize>) -> u16 {
    match data_type {
        DataType::Boolean => 1,
        t => match t.size() {
            Some(bytes) if !t.is_variable_size() => (bytes * 8) as u16,
            _ => value_len.map_or(64, |n| (n.min(8) * 8) as u16),
        },
    }
}

impl Catalog for OdView<'_> {
    fn object_info(&self, addr: ObjectAddress) -> Option<ObjectInfo> {
        let sub = self.od.sub(addr.index, addr.sub_index)?;
        let value_len = match sub.data_type.size() {
            Some(_) if !sub.data_type.is_variable_size() => None,
            _ => self.value_len(addr.index, addr.sub_index),
        };
        Some(ObjectInfo {
            data_type: sub.data_type.code(),
            bits: bits_of(sub.data_type, value_len),
            pdo_mappable: sub.pdo_mapping,
            readable: sub.access.is_readable(),
            writable: sub.access.is_writable(),
        })
    }

    /// The EDS `[DummyUsage]` section decides; a file without the section accepts the seven
    /// dummy types (many EDS files leave it out).
    fn dummy_supported(&self, data_type: u16) -> bool {
        if self.od.dummy_usage.is_empty() {
            return (0x0001..=0x0007).contains(&data_type);
        }
        self.od
            .dummy_usage
            .get(&data_type)
            .copied()
            .unwrap_or(false)
    }
}

impl Dictionary for OdView<'_> {
    fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError> {
        let not_an_integer = ReadError::NotAnInteger { index, subindex };
        let sub = self
            .od
            .sub(index, subindex)
            .ok_or(ReadError::NoSuchObject { index, subindex })?;
        match self.values {
            Values::Current(values) => {
                // PDO parameters are UNSIGNED8..UNSIGNED32: up to four little-endian bytes.
                if sub.data_type.is_signed() || sub.data_type.is_variable_size() {
                    return Err(not_an_integer);
                }
                let bytes = values
                    .value(index, subindex)
                    .ok_or(ReadError::NoSuchObject { index, subindex })?;
                if bytes.len() > 4 {
                    return Err(not_an_integer);
                }
                let mut word = [0u8; 4];
                word[..bytes.len()].copy_from_slice(bytes);
                Ok(u32::from_le_bytes(word))
            }
            Values::Defaults { node_id } => sub
                .effective_value(node_id)
                .and_then(|v| v.as_i128())
                .and_then(|v| u32::try_from(v).ok())
                .ok_or(not_an_integer),
        }
    }
}

#[cfg(test)]
mod tests {
    use canola_od::{AccessType, EdsValue, Object, ObjectCode, SubObject, Value as OdValue};
    use std::prelude::rust_2024::*;

    use super::*;
    use crate::comm::{CommParams, Direction, TransmissionType};
    use crate::mapping::{Mapping, MappingError};

    fn var(
        index: u16,
        t: DataType,
        access: AccessType,
        mappable: bool,
        v: Option<OdValue>,
    ) -> Object {
        let mut s = SubObject::new(0, "x", t, access).with_pdo_mapping(mappable);
        if let Some(v) = v {
            s = s.with_default(EdsValue::plain(v));
        }
        Object::var(index, s)
    }

    #[test]
    fn reads_tpdo_parameters_from_a_model() {
        let mut od = ObjectDictionary::default();
        od.insert(var(0x6000, DataType::Unsigned8, AccessType::Ro, true, None));
        od.insert(var(0x6401, DataType::Integer16, AccessType::Ro, true, None));
        od.insert(var(
            0x6200,
            DataType::Unsigned8,
            AccessType::Rww,
            true,
            None,
        ));
        od.insert(var(
            0x2000,
            DataType::Unsigned32,
            AccessType::Rw,
            false,
            None,
        ));
        let record = |index: u16, subs: &[(u8, DataType, OdValue)]| {
            Object::complex(
                index,
                "pdo parameter",
                ObjectCode::Record,
                subs.iter().map(|(sub, t, v)| {
                    SubObject::new(*sub, "p", *t, AccessType::Rw)
                        .with_default(EdsValue::plain(v.clone()))
                }),
            )
        };
        od.insert(record(
            0x1800,
            &[
                (0, DataType::Unsigned8, OdValue::Unsigned8(5)),
                (1, DataType::Unsigned32, OdValue::Unsigned32(0x4000_0185)),
                (2, DataType::Unsigned8, OdValue::Unsigned8(254)),
                (3, DataType::Unsigned16, OdValue::Unsigned16(50)),
                (5, DataType::Unsigned16, OdValue::Unsigned16(1000)),
            ],
        ));
        od.insert(record(
            0x1A00,
            &[
                (0, DataType::Unsigned8, OdValue::Unsigned8(2)),
                (1, DataType::Unsigned32, OdValue::Unsigned32(0x6000_0008)),
                (2, DataType::Unsigned32, OdValue::Unsigned32(0x6401_0010)),
            ],
        ));

        let view = OdView::new(&od, 5);
        let c = CommParams::read_from(&view, 0x1800).unwrap();
        assert_eq!(c.transmission_type, TransmissionType::EventManufacturer);
        assert_eq!((c.inhibit_time, c.event_timer, c.sync_start), (50, 1000, 0));
        let m = Mapping::read_from(&view, Direction::Transmit, 0x1A00).unwrap();
        assert_eq!(m.bit_len(), 24);
        assert_eq!(
            Mapping::read_from(&view, Direction::Receive, 0x1A00),
            Err(MappingError::AccessDenied {
                addr: ObjectAddress::new(0x6000, 0),
                direction: Direction::Receive
            })
        );
        assert_eq!(
            Mapping::from_raw_checked(Direction::Transmit, &[0x2000_0020], &view),
            Err(MappingError::NotMappable(ObjectAddress::new(0x2000, 0)))
        );
        assert!(Mapping::from_raw_checked(Direction::Receive, &[0x6200_0008], &view).is_ok());
        od.dummy_usage.insert(0x0005, false);
        let view = OdView::new(&od, 5);
        assert_eq!(
            Mapping::from_raw_checked(Direction::Receive, &[0x0005_0008], &view),
            Err(MappingError::DummyNotSupported(5))
        );
    }

    struct Current(Vec<((u16, u8), Vec<u8>)>);
    impl ValueSource for Current {
        fn value(&self, index: u16, subindex: u8) -> Option<&[u8]> {
            self.0
                .iter()
                .find(|(a, _)| *a == (index, subindex))
                .map(|(_, v)| v.as_slice())
        }
    }

    #[test]
    fn boolean_maps_with_one_bit_or_one_byte() {
        let mut od = ObjectDictionary::default();
        od.insert(var(0x6000, DataType::Boolean, AccessType::Ro, true, None));
        let view = OdView::new(&od, 5);
        for (raw, bits) in [(0x6000_0001, 1), (0x6000_0008, 8)] {
            let m = Mapping::from_raw_checked(Direction::Transmit, &[raw], &view).unwrap();
            assert_eq!(m.objects()[0].kind, crate::ValueKind::Boolean);
            assert_eq!(m.bit_len(), bits);
        }
        assert!(matches!(
            Mapping::from_raw_checked(Direction::Transmit, &[0x6000_0002], &view),
            Err(MappingError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn current_values_override_defaults() {
        let mut od = ObjectDictionary::default();
        od.insert(var(
            0x1800,
            DataType::Unsigned32,
            AccessType::Rw,
            false,
            Some(OdValue::Unsigned32(0x185)),
        ));
        od.insert(var(
            0x2001,
            DataType::VisibleString,
            AccessType::Ro,
            true,
            None,
        ));
        assert_eq!(OdView::new(&od, 5).read_u32(0x1800, 0), Ok(0x185));
        let current = Current(vec![
            ((0x1800, 0), vec![0x86, 0x01]),
            ((0x2001, 0), vec![b'a'; 3]),
        ]);
        let view = OdView::with_values(&od, &current);
        assert_eq!(view.read_u32(0x1800, 0), Ok(0x186));
        assert_eq!(
            view.object_info(ObjectAddress::new(0x2001, 0))
                .map(|i| i.bits),
            Some(24)
        );
        assert_eq!(
            view.read_u32(0x2001, 0),
            Err(ReadError::NotAnInteger {
                index: 0x2001,
                subindex: 0
            })
        );
    }

    /// Every fixed-size type: a value as the dictionary types it goes into a field of the
    /// type's kind and width and comes back the same; the field's natural type is the type.
    #[test]
    fn values_round_trip_through_raw_fields() {
        use proptest::prelude::*;
        use proptest::test_runner::TestRunner;
        let types = [
            DataType::Boolean,
            DataType::Integer8,
            DataType::Integer16,
            DataType::Integer24,
            DataType::Integer32,
            DataType::Integer40,
            DataType::Integer48,
            DataType::Integer56,
            DataType::Integer64,
            DataType::Unsigned8,
            DataType::Unsigned16,
            DataType::Unsigned24,
            DataType::Unsigned32,
            DataType::Unsigned40,
            DataType::Unsigned48,
            DataType::Unsigned56,
            DataType::Unsigned64,
        ];
        let mut runner = TestRunner::default();
        for ty in types {
            let bits = u8::try_from(ty.size().unwrap() * 8).unwrap();
            let bits = if ty == DataType::Boolean { 1 } else { bits };
            let kind = ValueKind::from_data_type(ty.code());
            let object = crate::mapping::Mapping::new()
                .with(crate::MappingEntry::new(0x2000, 1, bits), kind)
                .unwrap()
                .objects()[0];
            assert_eq!(object.data_type(), ty);
            assert_eq!(object.value_type(Some(ty)), ty);
            runner
                .run(&any::<i128>(), |x| {
                    let Some(v) = Value::from_i128_wrapping(ty, x) else {
                        return Ok(());
                    };
                    let v = if ty == DataType::Boolean {
                        Value::Boolean(x & 1 == 1)
                    } else {
                        v
                    };
                    let raw = RawValue::from_value(&v, kind).expect("fits its own field");
                    prop_assert_eq!(raw.to_value(ty).unwrap(), v);
                    Ok(())
                })
                .unwrap();
        }
        let f = Value::Real32(-2.5);
        let raw = RawValue::from_value(&f, ValueKind::Real32).unwrap();
        assert_eq!(raw.to_value(DataType::Real32).unwrap(), f);
        let s = Value::VisibleString(b"ab".to_vec());
        let raw = RawValue::from_value(&s, ValueKind::Bytes).unwrap();
        assert_eq!(raw.to_value(DataType::VisibleString).unwrap(), s);
        // Kinds and types that do not agree are errors, not guesses.
        assert!(
            RawValue::Real32(1.0)
                .to_value(DataType::Unsigned16)
                .is_err()
        );
        assert!(RawValue::from_value(&s, ValueKind::Unsigned).is_none());
        assert!(RawValue::from_value(&Value::Unsigned8(2), ValueKind::Boolean).is_none());
        // A declared type of another kind gives way to the field's own.
        let u16_field = crate::mapping::Mapping::new()
            .with(crate::MappingEntry::new(0x2000, 1, 16), ValueKind::Unsigned)
            .unwrap()
            .objects()[0];
        assert_eq!(
            u16_field.value_type(Some(DataType::Real32)),
            DataType::Unsigned16
        );
    }
}
