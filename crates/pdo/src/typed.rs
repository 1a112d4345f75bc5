//! PDOs with a layout fixed at compile time: Rust structs with one named field per mapped object
//! (CiA 301 §7.2.2, mapping §7.4.8), as `canola-codegen` generates them from an EDS's default
//! mappings.
//!
//! [`TypedPdo`] is what a generated struct implements: its direction and number, its mapping
//! entries with their [`ValueKind`]s, its default COB-ID (`$NODEID` resolved when the node-ID is
//! known), and the conversion between its fields and the [`RawValue`]s of [`fn@pack`] and
//! [`unpack`]. The provided methods do the rest through this crate's packer, so generated code
//! holds no bit arithmetic: `Tpdo1::from_frame(&frame)` decodes a received PDO, `to_frame(node)`
//! builds one. [`PdoField`] converts each Rust field type to and from a [`RawValue`].
//!
//! Decoding is strict about the length: a PDO whose data length is not the mapping's is an
//! error ([`TypedPdoError::Length`]), since it means the device's mapping is not the one the
//! struct was generated from. Nothing here panics on any input.

use crate::comm::{Direction, PdoCobId};
use crate::mapping::{MAX_ENTRIES, Mapping, MappingEntry, MappingError, ValueKind};
use crate::pack::{PackError, RawValue, pack, unpack};
use canola_frame::CanId;
pub use canola_frame::{CanFrame, NodeId};
use canola_od::ObjectAddress;

/// A Rust type that carries the value of one mapped object.
pub trait PdoField: Sized {
    /// The value of a mapped object of this type.
    fn to_value(&self) -> RawValue;
    /// The field from a decoded value; `None` if the value has another kind or does not fit.
    fn from_value(value: RawValue) -> Option<Self>;
}

macro_rules! unsigned_field {
    ($($t:ty),*) => {$(
        impl PdoField for $t {
            fn to_value(&self) -> RawValue {
                RawValue::Unsigned(u64::from(*self))
            }
            fn from_value(value: RawValue) -> Option<Self> {
                match value {
                    RawValue::Unsigned(v) => <$t>::try_from(v).ok(),
                    _ => None,
                }
            }
        }
    )*};
}
macro_rules! signed_field {
    ($($t:ty),*) => {$(
        impl PdoField for $t {
            fn to_value(&self) -> RawValue {
                RawValue::Signed(i64::from(*self))
            }
            fn from_value(value: RawValue) -> Option<Self> {
                match value {
                    RawValue::Signed(v) => <$t>::try_from(v).ok(),
                    _ => None,
                }
            }
        }
    )*};
}
unsigned_field!(u8, u16, u32, u64);
signed_field!(i8, i16, i32, i64);

impl PdoField for bool {
    fn to_value(&self) -> RawValue {
        RawValue::Bool(*self)
    }
    fn from_value(value: RawValue) -> Option<Self> {
        match value {
            RawValue::Bool(b) => Some(b),
            _ => None,
        }
    }
}

impl PdoField for f32 {
    fn to_value(&self) -> RawValue {
        RawValue::Real32(*self)
    }
    fn from_value(value: RawValue) -> Option<Self> {
        match value {
            RawValue::Real32(v) => Some(v),
            _ => None,
        }
    }
}

impl PdoField for f64 {
    fn to_value(&self) -> RawValue {
        RawValue::Real64(*self)
    }
    fn from_value(value: RawValue) -> Option<Self> {
        match value {
            RawValue::Real64(v) => Some(v),
            _ => None,
        }
    }
}

/// Byte-typed objects (strings, OCTET_STRING, TIME_OF_DAY, ...) mapped with `8 * N` bits.
impl<const N: usize> PdoField for [u8; N] {
    fn to_value(&self) -> RawValue {
        // More than eight bytes cannot be mapped: the value keeps eight and the packer reports
        // it as not fitting its mapped length.
        let n = N.min(8);
        let raw = self[..n]
            .iter()
            .rev()
            .fold(0u64, |acc, &b| acc << 8 | u64::from(b));
        RawValue::from_raw(ValueKind::Bytes, raw, (n * 8) as u8)
    }
    fn from_value(value: RawValue) -> Option<Self> {
        match value {
            RawValue::Bytes(b) => b.as_slice().try_into().ok(),
            _ => None,
        }
    }
}

/// A PDO's default COB-ID as the EDS gives it: a fixed value, or an offset added to the
/// node-ID (`$NODEID+0x180`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DefaultCobId {
    /// The raw UNSIGNED32 (flag bits included), or the offset when `adds_node_id`.
    pub raw: u32,
    /// Whether the node-ID is added (`$NODEID` in the EDS).
    pub adds_node_id: bool,
}

impl DefaultCobId {
    /// The COB-ID for `node`.
    pub const fn resolve(self, node: NodeId) -> PdoCobId {
        if self.adds_node_id {
            PdoCobId(self.raw.wrapping_add(node.get() as u32))
        } else {
            PdoCobId(self.raw)
        }
    }
}

/// Why a typed PDO could not be decoded or encoded.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TypedPdoError {
    /// The struct's mapping is not a valid mapping (not for generated structs, whose mappings
    /// were checked when they were generated).
    #[error("the PDO's mapping is invalid: {0}")]
    Mapping(MappingError),
    /// The data length differs from the mapping's: the device maps something else.
    #[error("PDO has {actual} data bytes, its mapping has {expected}")]
    Length {
        /// Bytes of the mapping.
        expected: usize,
        /// Bytes received.
        actual: usize,
    },
    /// A remote (RTR) frame carries no data.
    #[error("a remote frame carries no PDO data")]
    Remote,
    /// A field's value does not fit its mapped length, or a decoded value its field.
    #[error(transparent)]
    Pack(PackError),
    /// A decoded value does not fit the field's Rust type.
    #[error("mapped object {address} (position {position}) does not fit its field")]
    Field {
        /// Position in the mapping.
        position: usize,
        /// The mapped object.
        address: ObjectAddress,
    },
    /// A list of decoded values lacks a mapped object.
    #[error("mapped object {0} is missing")]
    Missing(ObjectAddress),
    /// The PDO has no default COB-ID, or its COB-ID holds no valid CAN identifier.
    #[error("the PDO has no usable COB-ID")]
    NoCobId,
}

debug_as_display!(TypedPdoError);

impl From<MappingError> for TypedPdoError {
    fn from(e: MappingError) -> Self {
        Self::Mapping(e)
    }
}
impl From<PackError> for TypedPdoError {
    fn from(e: PackError) -> Self {
        Self::Pack(e)
    }
}

/// The field at `position` of positional `values` (PDO order, dummies included), converted to
/// its Rust type. Generated `from_values` bodies are one call of this per field.
pub fn field<T: PdoField>(
    values: &[RawValue],
    position: usize,
    raw: u32,
) -> Result<T, TypedPdoError> {
    let address = MappingEntry(raw).addr();
    let value = values
        .get(position)
        .copied()
        .ok_or(TypedPdoError::Missing(address))?;
    T::from_value(value).ok_or(TypedPdoError::Field { position, address })
}

/// A value of an `(address, value)` pair that [`TypedPdo::from_pairs`] takes: a [`RawValue`],
/// or (feature `od`) a `canola_od::Value` as the `canola` master publishes received PDOs.
pub trait PairValue {
    /// The value as a field of `kind`; `None` when it cannot be one.
    fn to_raw_value(&self, kind: ValueKind) -> Option<RawValue>;
}

impl PairValue for RawValue {
    fn to_raw_value(&self, _kind: ValueKind) -> Option<RawValue> {
        Some(*self)
    }
}

/// Decoded values in PDO order, dummies included.
pub type Values = heapless::Vec<RawValue, MAX_ENTRIES>;

/// A PDO with a fixed mapping and named, typed fields (implemented by generated code).
///
/// Required: the constants and the two conversions between the struct and positional
/// [`RawValue`]s. Provided: decoding from data bytes, frames and `(address, value)` lists, and
/// encoding to data bytes and frames, all through [`fn@pack`] and [`unpack`].
pub trait TypedPdo: Sized {
    /// Receive or transmit PDO, seen from the device.
    const DIRECTION: Direction;
    /// The PDO number, 1-based (TPDO1 has mapping 0x1A00).
    const NUMBER: u16;
    /// The mapping entries (`index << 16 | sub << 8 | bits`) with their kinds, in PDO order.
    const ENTRIES: &'static [(u32, ValueKind)];
    /// The default COB-ID, if the EDS gives one (or the predefined connection set does).
    const DEFAULT_COB_ID: Option<DefaultCobId>;

    /// The struct from decoded values in PDO order (dummies included).
    fn from_values(values: &[RawValue]) -> Result<Self, TypedPdoError>;

    /// The value of the mapped object at `position`; `None` for dummy entries (sent as zero).
    fn value_at(&self, position: usize) -> Option<RawValue>;

    /// The mapping as the packer takes it.
    fn mapping() -> Result<Mapping, TypedPdoError> {
        let mut m = Mapping::new();
        for &(raw, kind) in Self::ENTRIES {
            m.push(MappingEntry(raw), kind)?;
        }
        Ok(m)
    }

    /// The mapping parameter object (0x1600.. or 0x1A00..).
    fn mapping_index() -> u16 {
        Self::DIRECTION.mapping_index(Self::NUMBER.wrapping_sub(1))
    }

    /// The communication parameter object (0x1400.. or 0x1800..).
    fn comm_index() -> u16 {
        Self::DIRECTION.comm_index(Self::NUMBER.wrapping_sub(1))
    }

    /// Decodes the data bytes of a received PDO; their length must be the mapping's.
    fn from_data(data: &[u8]) -> Result<Self, TypedPdoError> {
        let mapping = Self::mapping()?;
        if data.len() != mapping.byte_len() {
            return Err(TypedPdoError::Length {
                expected: mapping.byte_len(),
                actual: data.len(),
            });
        }
        let unpacked = unpack(&mapping, data)?;
        let values: Values = unpacked.iter().map(|(_, v)| v).collect();
        Self::from_values(&values)
    }

    /// Decodes a received PDO frame (its identifier is not checked; see
    /// [`TypedPdo::cob_id`]).
    fn from_frame(frame: &CanFrame) -> Result<Self, TypedPdoError> {
        if frame.is_remote() {
            return Err(TypedPdoError::Remote);
        }
        Self::from_data(frame.data())
    }

    /// Decodes `(address, value)` pairs as the master publishes them for a node's TPDO, taking
    /// each mapped object by its address.
    fn from_pairs<V: PairValue>(pairs: &[(ObjectAddress, V)]) -> Result<Self, TypedPdoError> {
        let mut values = Values::new();
        for (position, &(raw, kind)) in Self::ENTRIES.iter().enumerate() {
            let entry = MappingEntry(raw);
            let value = if entry.is_dummy() {
                RawValue::from_raw(kind, 0, entry.bits())
            } else {
                let address = entry.addr();
                pairs
                    .iter()
                    .find(|(a, _)| *a == address)
                    .ok_or(TypedPdoError::Missing(address))?
                    .1
                    .to_raw_value(kind)
                    .ok_or(TypedPdoError::Field { position, address })?
            };
            // ENTRIES holds at most what a Mapping holds when `mapping()` succeeds.
            values.push(value).map_err(|_| {
                TypedPdoError::Mapping(MappingError::TooManyEntries(MAX_ENTRIES + 1))
            })?;
        }
        Self::from_values(&values)
    }

    /// Packs the fields into `out`; returns the number of data bytes.
    fn pack(&self, out: &mut [u8; 8]) -> Result<usize, TypedPdoError> {
        let mapping = Self::mapping()?;
        let mut values = Values::new();
        for (position, object) in mapping.objects().iter().enumerate() {
            let value = match self.value_at(position) {
                Some(v) if !object.is_dummy() => v,
                _ => RawValue::from_raw(object.kind, 0, object.bits()),
            };
            values.push(value).map_err(|_| {
                TypedPdoError::Mapping(MappingError::TooManyEntries(MAX_ENTRIES + 1))
            })?;
        }
        Ok(pack(&mapping, &values, out)?)
    }

    /// The PDO's default COB-ID for `node`.
    fn cob_id(node: NodeId) -> Option<PdoCobId> {
        Self::DEFAULT_COB_ID.map(|c| c.resolve(node))
    }

    /// A data frame with the packed fields on the default COB-ID of `node`.
    fn to_frame(&self, node: NodeId) -> Result<CanFrame, TypedPdoError> {
        let id: CanId = Self::cob_id(node)
            .ok_or(TypedPdoError::NoCobId)?
            .can_id()
            .map_err(|_| TypedPdoError::NoCobId)?;
        let mut data = [0u8; 8];
        let n = self.pack(&mut data)?;
        CanFrame::new(id, &data[..n]).map_err(|_| TypedPdoError::NoCobId)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// What the generator emits for a TPDO mapping a BOOLEAN (1 bit), a 1-bit dummy, a
    /// 6-bit-aligned INTEGER24, an UNSIGNED8 dummy and a 2-byte VISIBLE_STRING.
    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    struct Sample {
        flag: bool,
        level: i32,
        tag: [u8; 2],
    }

    impl TypedPdo for Sample {
        const DIRECTION: Direction = Direction::Transmit;
        const NUMBER: u16 = 2;
        const ENTRIES: &'static [(u32, ValueKind)] = &[
            (0x2000_0101, ValueKind::Boolean),
            (0x0001_0001, ValueKind::Boolean),
            (0x2001_0018, ValueKind::Signed),
            (0x0005_0008, ValueKind::Unsigned),
            (0x2002_0010, ValueKind::Bytes),
        ];
        const DEFAULT_COB_ID: Option<DefaultCobId> = Some(DefaultCobId {
            raw: 0x280,
            adds_node_id: true,
        });
        fn from_values(values: &[RawValue]) -> Result<Self, TypedPdoError> {
            Ok(Self {
                flag: field(values, 0, 0x2000_0101)?,
                level: field(values, 2, 0x2001_0018)?,
                tag: field(values, 4, 0x2002_0010)?,
            })
        }
        fn value_at(&self, position: usize) -> Option<RawValue> {
            match position {
                0 => Some(self.flag.to_value()),
                2 => Some(self.level.to_value()),
                4 => Some(self.tag.to_value()),
                _ => None,
            }
        }
    }

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn frame_round_trip_with_dummies_and_bit_fields() {
        let s = Sample {
            flag: true,
            level: -2,
            tag: *b"OK",
        };
        let frame = s.to_frame(node(5)).unwrap();
        assert_eq!(frame.id(), CanId::standard(0x285).unwrap());
        // bit 0 flag, bit 1 dummy, bits 2..26 level, bits 26..34 dummy, bits 34..50 "OK":
        // 1 + 24 + 2 + 8 + 16 = 50 bits, 7 bytes.
        assert_eq!(frame.dlc(), 7);
        let raw = u64::from_le_bytes(*frame.data_padded());
        assert_eq!(raw & 1, 1);
        assert_eq!(raw >> 1 & 1, 0);
        assert_eq!(raw >> 2 & 0xFF_FFFF, 0xFF_FFFE);
        assert_eq!(raw >> 26 & 0xFF, 0);
        assert_eq!(raw >> 34 & 0xFFFF, u64::from(u16::from_le_bytes(*b"OK")));
        assert_eq!(Sample::from_frame(&frame), Ok(s));
        assert_eq!(
            (Sample::mapping_index(), Sample::comm_index()),
            (0x1A01, 0x1801)
        );
    }

    #[test]
    fn errors_not_panics() {
        assert_eq!(
            Sample::from_data(&[0; 8]),
            Err(TypedPdoError::Length {
                expected: 7,
                actual: 8
            })
        );
        assert_eq!(
            Sample::from_data(&[0; 3]),
            Err(TypedPdoError::Length {
                expected: 7,
                actual: 3
            })
        );
        let rtr = CanFrame::remote(CanId::standard(0x285).unwrap(), 7).unwrap();
        assert_eq!(Sample::from_frame(&rtr), Err(TypedPdoError::Remote));
        // INTEGER24 holds -2^23..2^23-1.
        let big = Sample {
            level: 1 << 23,
            ..Sample::default()
        };
        assert_eq!(
            big.pack(&mut [0; 8]),
            Err(TypedPdoError::Pack(PackError::OutOfRange {
                position: 2,
                bits: 24
            }))
        );
        assert_eq!(
            Sample::from_pairs(&[(ObjectAddress::new(0x2000, 1), RawValue::Bool(true))]),
            Err(TypedPdoError::Missing(ObjectAddress::new(0x2001, 0)))
        );
    }

    #[test]
    fn from_pairs_takes_objects_by_address() {
        let pairs = [
            (ObjectAddress::new(0x2002, 0), b"AB".to_value()),
            (ObjectAddress::new(0x2001, 0), RawValue::Signed(7)),
            (ObjectAddress::new(0x2000, 1), RawValue::Bool(false)),
        ];
        assert_eq!(
            Sample::from_pairs(&pairs),
            Ok(Sample {
                flag: false,
                level: 7,
                tag: *b"AB"
            })
        );
        // A value of the wrong kind for its field is an error naming the object.
        let wrong = [
            (ObjectAddress::new(0x2002, 0), b"AB".to_value()),
            (ObjectAddress::new(0x2001, 0), RawValue::Unsigned(7)),
            (ObjectAddress::new(0x2000, 1), RawValue::Bool(false)),
        ];
        assert_eq!(
            Sample::from_pairs(&wrong),
            Err(TypedPdoError::Field {
                position: 2,
                address: ObjectAddress::new(0x2001, 0)
            })
        );
    }

    #[test]
    fn fields_convert_both_ways() {
        assert_eq!(u8::from_value(RawValue::Unsigned(256)), None);
        assert_eq!(u16::from_value(RawValue::Unsigned(65535)), Some(65535));
        assert_eq!(i8::from_value(RawValue::Signed(-129)), None);
        assert_eq!(i64::from_value(RawValue::Signed(i64::MIN)), Some(i64::MIN));
        assert_eq!(f32::from_value(1.5f32.to_value()), Some(1.5));
        assert_eq!(f64::from_value(RawValue::Real32(1.5)), None);
        assert_eq!(<[u8; 3]>::from_value(b"ab".to_value()), None);
        assert_eq!(
            <[u8; 6]>::from_value([1, 2, 3, 4, 5, 6].to_value()),
            Some([1, 2, 3, 4, 5, 6])
        );
        assert_eq!(bool::from_value(RawValue::Unsigned(1)), None);
        let c = DefaultCobId {
            raw: 0x8000_0180,
            adds_node_id: true,
        };
        assert_eq!(c.resolve(node(3)), PdoCobId(0x8000_0183));
    }

    proptest! {
        #[test]
        fn any_data_decodes_or_errs(data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            if let Ok(s) = Sample::from_data(&data) {
                let mut out = [0u8; 8];
                let n = s.pack(&mut out).unwrap();
                // Dummy bits are sent as zero; everything else survives.
                prop_assert_eq!(Sample::from_data(&out[..n]), Ok(s));
            }
        }
    }
}
