//! Bit-level packing and unpacking of PDO data (CiA 301 §7.2.2.3 / §7.4.8 mapping).
//!
//! The data bytes of a PDO are read as one little-endian 64-bit word; the object at bit offset
//! `o` with length `n` is `(word >> o) & (2^n - 1)`. This covers mappings that are not byte
//! aligned, 1-bit booleans and the 24/40/48/56-bit integer types in one shift and one mask;
//! signed types are sign-extended from their mapped length.
//!
//! [`unpack`] does not copy the frame beyond that single 64-bit load and returns a view
//! ([`Unpacked`]) whose iterator yields typed [`RawValue`]s on demand. Both directions are total:
//! bytes and values either fit or give a typed error, never a panic.

use crate::mapping::{MappedObject, Mapping, ValueKind, field_mask};

/// A mapped object's value as the PDO data carries it: one variant per way of reading the bits
/// (a [`ValueKind`]), up to 64 bits, no allocation — the form the engine works in, on devices
/// without a heap too. Applications see values as the dictionary types them, as
/// `canola_od::Value` (`Unsigned16`, `VisibleString`, ...): `RawValue::to_value` (feature
/// `od`) converts, and the `canola` facade delivers received PDOs that way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RawValue {
    /// BOOLEAN.
    Bool(bool),
    /// Any UNSIGNEDn (and objects of unknown type).
    Unsigned(u64),
    /// Any INTEGERn, sign-extended.
    Signed(i64),
    /// REAL32.
    Real32(f32),
    /// REAL64.
    Real64(f64),
    /// Strings, OCTET_STRING, DOMAIN, time types: the raw bytes.
    Bytes(Bytes),
}

/// Up to eight raw bytes (a byte-typed mapped object).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Bytes {
    buf: [u8; 8],
    len: u8,
}

impl Bytes {
    /// Copies up to eight bytes; `None` if `data` is longer.
    pub fn new(data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let mut buf = [0; 8];
        buf[..data.len()].copy_from_slice(data);
        Some(Self {
            buf,
            len: data.len() as u8,
        })
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.buf[..self.len as usize]
    }
}

/// Why a value could not be packed, or data could not be unpacked.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PackError {
    /// The PDO data is shorter than the mapping (CiA 301 EMCY 0x8210 on a device).
    #[error("PDO has {actual} data bytes, the mapping needs {needed}")]
    TooShort {
        /// Bytes the mapping needs.
        needed: usize,
        /// Bytes received.
        actual: usize,
    },
    /// A different number of values than mapped objects.
    #[error("{actual} values for {expected} mapped objects")]
    ValueCount {
        /// Mapped objects.
        expected: usize,
        /// Values given.
        actual: usize,
    },
    /// The value's type does not match the mapped object's kind.
    #[error("value {position} has the wrong type for its mapped object")]
    WrongKind {
        /// Position in the mapping.
        position: usize,
    },
    /// The value does not fit the mapped length.
    #[error("value {position} does not fit in {bits} bits")]
    OutOfRange {
        /// Position in the mapping.
        position: usize,
        /// Mapped length.
        bits: u8,
    },
}

debug_as_display!(PackError);

/// Reads up to eight bytes as a little-endian word (missing bytes are zero).
#[inline]
pub(crate) fn load_word(data: &[u8]) -> u64 {
    if let Some(b) = data.first_chunk::<8>() {
        return u64::from_le_bytes(*b);
    }
    // Shorter PDOs: assemble byte by byte (no variable-length copy call on the hot path).
    let mut word = 0u64;
    for (i, &b) in data.iter().enumerate() {
        word |= (b as u64) << (8 * i);
    }
    word
}

/// The raw bits of one mapped object in a data word.
#[inline]
pub(crate) const fn field(word: u64, obj: &MappedObject) -> u64 {
    (word & obj.mask()) >> obj.offset
}

/// Sign-extends the low `bits` bits of `raw`.
#[inline]
pub const fn sign_extend(raw: u64, bits: u8) -> i64 {
    if bits == 0 || bits >= 64 {
        raw as i64
    } else {
        let shift = 64 - bits as u32;
        ((raw << shift) as i64) >> shift
    }
}

impl core::fmt::Display for RawValue {
    /// The value as CANopen tools show it: `true`, `42`, `-7`, `24.58`, and byte-typed objects
    /// (strings, octet strings, time types) as their bytes in hex (`01 02 0a`).
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{b}"),
            Self::Unsigned(v) => write!(f, "{v}"),
            Self::Signed(v) => write!(f, "{v}"),
            Self::Real32(v) => write!(f, "{v}"),
            Self::Real64(v) => write!(f, "{v}"),
            Self::Bytes(b) => write!(f, "{}", canola_frame::HexBytes(b.as_slice())),
        }
    }
}

impl RawValue {
    /// Interprets the raw bits of a field of `bits` bits as `kind`.
    #[inline]
    pub fn from_raw(kind: ValueKind, raw: u64, bits: u8) -> Self {
        match kind {
            ValueKind::Boolean => Self::Bool(raw != 0),
            ValueKind::Unsigned => Self::Unsigned(raw),
            ValueKind::Signed => Self::Signed(sign_extend(raw, bits)),
            ValueKind::Real32 => Self::Real32(f32::from_bits(raw as u32)),
            ValueKind::Real64 => Self::Real64(f64::from_bits(raw)),
            ValueKind::Bytes => {
                let n = (bits as usize).div_ceil(8);
                let bytes = raw.to_le_bytes();
                Self::Bytes(Bytes::new(&bytes[..n.min(8)]).unwrap_or(Bytes { buf: bytes, len: 8 }))
            }
        }
    }

    /// The raw field bits of this value for an object of `kind` mapped with `bits` bits, or
    /// `None` if the value has another kind or does not fit.
    pub fn to_raw(&self, kind: ValueKind, bits: u8) -> Option<u64> {
        let mask = field_mask(bits);
        match (*self, kind) {
            (Self::Bool(b), ValueKind::Boolean) => Some(b as u64),
            (Self::Unsigned(v), ValueKind::Unsigned) => (v & !mask == 0).then_some(v),
            (Self::Signed(v), ValueKind::Signed) => {
                (sign_extend(v as u64 & mask, bits) == v).then_some(v as u64 & mask)
            }
            (Self::Real32(f), ValueKind::Real32) => {
                let raw = f.to_bits() as u64;
                (raw & !mask == 0).then_some(raw)
            }
            (Self::Real64(f), ValueKind::Real64) => {
                let raw = f.to_bits();
                (raw & !mask == 0).then_some(raw)
            }
            (Self::Bytes(b), ValueKind::Bytes) => {
                let raw = load_word(b.as_slice());
                (b.as_slice().len() == (bits as usize).div_ceil(8) && raw & !mask == 0)
                    .then_some(raw)
            }
            _ => None,
        }
    }

    /// The kind of object this value belongs to.
    pub const fn kind(&self) -> ValueKind {
        match self {
            Self::Bool(_) => ValueKind::Boolean,
            Self::Unsigned(_) => ValueKind::Unsigned,
            Self::Signed(_) => ValueKind::Signed,
            Self::Real32(_) => ValueKind::Real32,
            Self::Real64(_) => ValueKind::Real64,
            Self::Bytes(_) => ValueKind::Bytes,
        }
    }

    /// The value as an unsigned integer, if it is one (or a boolean).
    pub fn as_u64(&self) -> Option<u64> {
        match *self {
            Self::Unsigned(v) => Some(v),
            Self::Bool(b) => Some(b as u64),
            _ => None,
        }
    }

    /// The value as a signed integer, if it is an integer that fits.
    pub fn as_i64(&self) -> Option<i64> {
        match *self {
            Self::Signed(v) => Some(v),
            Self::Unsigned(v) => i64::try_from(v).ok(),
            _ => None,
        }
    }
}

/// A received PDO viewed through its mapping. Cheap to copy; values are decoded on demand.
#[derive(Debug, Clone, Copy)]
pub struct Unpacked<'a> {
    mapping: &'a Mapping,
    word: u64,
}

/// Views `data` through `mapping`. Fails only when `data` is shorter than the mapping; extra
/// bytes are ignored (the receiver decides whether that is an error, see
/// [`crate::Event::LengthExceeded`]).
pub fn unpack<'a>(mapping: &'a Mapping, data: &[u8]) -> Result<Unpacked<'a>, PackError> {
    let needed = mapping.byte_len();
    if data.len() < needed {
        return Err(PackError::TooShort {
            needed,
            actual: data.len(),
        });
    }
    Ok(Unpacked {
        mapping,
        word: load_word(&data[..needed]),
    })
}

impl<'a> Unpacked<'a> {
    /// A view over an already loaded data word.
    pub(crate) fn from_word(mapping: &'a Mapping, word: u64) -> Self {
        Self { mapping, word }
    }

    /// The mapping.
    pub fn mapping(&self) -> &'a Mapping {
        self.mapping
    }

    /// The data as a little-endian word (bits past the mapping are zero).
    pub fn word(&self) -> u64 {
        self.word
    }

    /// The raw bits of the `i`-th mapped object.
    pub fn raw(&self, i: usize) -> Option<u64> {
        self.mapping.objects().get(i).map(|o| field(self.word, o))
    }

    /// The value of the `i`-th mapped object.
    pub fn get(&self, i: usize) -> Option<RawValue> {
        self.mapping
            .objects()
            .get(i)
            .map(|o| RawValue::from_raw(o.kind, field(self.word, o), o.bits()))
    }

    /// Every mapped object with its value, in PDO order (dummy entries included).
    pub fn iter(&self) -> impl Iterator<Item = (&'a MappedObject, RawValue)> + 'a {
        let word = self.word;
        self.mapping
            .objects()
            .iter()
            .map(move |o| (o, RawValue::from_raw(o.kind, field(word, o), o.bits())))
    }
}

/// Packs `values` (one per mapped object, dummies included: pass any value of the dummy's kind
/// or zero) into `out`; returns the number of data bytes.
pub fn pack(mapping: &Mapping, values: &[RawValue], out: &mut [u8; 8]) -> Result<usize, PackError> {
    if values.len() != mapping.len() {
        return Err(PackError::ValueCount {
            expected: mapping.len(),
            actual: values.len(),
        });
    }
    let mut word = 0u64;
    for (position, (o, v)) in mapping.objects().iter().zip(values).enumerate() {
        if v.kind() != o.kind {
            return Err(PackError::WrongKind { position });
        }
        let raw = v.to_raw(o.kind, o.bits()).ok_or(PackError::OutOfRange {
            position,
            bits: o.bits(),
        })?;
        word |= raw << o.offset;
    }
    *out = word.to_le_bytes();
    Ok(mapping.byte_len())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::mapping::{MAX_ENTRIES, MappingEntry};
    use proptest::prelude::*;

    fn m(entries: &[(u32, ValueKind)]) -> Mapping {
        let mut m = Mapping::new();
        for &(raw, kind) in entries {
            m.push(MappingEntry(raw), kind).unwrap();
        }
        m
    }

    #[test]
    fn byte_aligned_u16_quad() {
        let map = m(&[
            (0x6401_0110, ValueKind::Unsigned),
            (0x6401_0210, ValueKind::Unsigned),
            (0x6401_0310, ValueKind::Unsigned),
            (0x6401_0410, ValueKind::Unsigned),
        ]);
        let data = [0x34, 0x12, 0x78, 0x56, 0xBC, 0x9A, 0xF0, 0xDE];
        let u = unpack(&map, &data).unwrap();
        let vals: Vec<RawValue> = u.iter().map(|(_, v)| v).collect();
        assert_eq!(
            vals,
            [
                RawValue::Unsigned(0x1234),
                RawValue::Unsigned(0x5678),
                RawValue::Unsigned(0x9ABC),
                RawValue::Unsigned(0xDEF0)
            ]
        );
        let mut out = [0; 8];
        assert_eq!(pack(&map, &vals, &mut out), Ok(8));
        assert_eq!(out, data);
    }

    #[test]
    fn bits_not_byte_aligned() {
        // bool, bool, 4-bit unsigned, 10-bit signed, INTEGER24, UNSIGNED8:
        // bit 0, bit 1, bits 2..6, bits 6..16, bits 16..40, bits 40..48.
        let map = m(&[
            (0x2000_0101, ValueKind::Boolean),
            (0x2000_0201, ValueKind::Boolean),
            (0x2000_0304, ValueKind::Unsigned),
            (0x2000_040A, ValueKind::Signed),
            (0x2000_0518, ValueKind::Signed),
            (0x2000_0608, ValueKind::Unsigned),
        ]);
        let vals = [
            RawValue::Bool(true),
            RawValue::Bool(false),
            RawValue::Unsigned(0xB),
            RawValue::Signed(-2),
            RawValue::Signed(-0x12_3456),
            RawValue::Unsigned(0xA5),
        ];
        let mut out = [0; 8];
        assert_eq!(pack(&map, &vals, &mut out), Ok(6));
        // byte 0: b0=1, b1=0, b2..5 = 1011, b6..7 = low two bits of -2 (0b10) -> 0b1010_1101
        // byte 1: the other 8 bits of the 10-bit -2 (all ones) -> 0xFF
        // bytes 2..5: -0x123456 in 24 bits = 0xEDCBAA, little-endian AA CB ED; byte 5 = A5.
        assert_eq!(out, [0xAD, 0xFF, 0xAA, 0xCB, 0xED, 0xA5, 0, 0]);
        let back: Vec<RawValue> = unpack(&map, &out[..6])
            .unwrap()
            .iter()
            .map(|(_, v)| v)
            .collect();
        assert_eq!(back, vals);
    }

    #[test]
    fn wide_integers_sign_extend() {
        let map = m(&[
            (0x2000_0128, ValueKind::Signed),   // INTEGER40
            (0x2000_0218, ValueKind::Unsigned), // UNSIGNED24
        ]);
        let data = [0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x56, 0x34, 0x12];
        let u = unpack(&map, &data).unwrap();
        assert_eq!(u.get(0), Some(RawValue::Signed(-1)));
        assert_eq!(u.get(1), Some(RawValue::Unsigned(0x12_3456)));
        let map = m(&[
            (0x2000_0138, ValueKind::Signed),
            (0x2000_0208, ValueKind::Unsigned),
        ]);
        let data = [0, 0, 0, 0, 0, 0, 0x80, 7];
        assert_eq!(
            unpack(&map, &data).unwrap().get(0),
            Some(RawValue::Signed(-(1 << 55)))
        );
        let map = m(&[(0x2000_0130, ValueKind::Unsigned)]);
        assert_eq!(
            unpack(&map, &[1, 2, 3, 4, 5, 6]).unwrap().get(0),
            Some(RawValue::Unsigned(0x0605_0403_0201))
        );
    }

    #[test]
    fn reals_and_bytes() {
        let map = m(&[
            (0x2000_0120, ValueKind::Real32),
            (0x2001_0020, ValueKind::Bytes),
        ]);
        let vals = [
            RawValue::Real32(1.5),
            RawValue::Bytes(Bytes::new(b"ABCD").unwrap()),
        ];
        let mut out = [0; 8];
        pack(&map, &vals, &mut out).unwrap();
        assert_eq!(out, [0x00, 0x00, 0xC0, 0x3F, b'A', b'B', b'C', b'D']);
        let back: Vec<RawValue> = unpack(&map, &out).unwrap().iter().map(|(_, v)| v).collect();
        assert_eq!(back, vals);
    }

    #[test]
    fn errors_not_panics() {
        let map = m(&[
            (0x2000_0108, ValueKind::Unsigned),
            (0x2000_0208, ValueKind::Signed),
        ]);
        assert_eq!(
            unpack(&map, &[1]).map(|u| u.word()),
            Err(PackError::TooShort {
                needed: 2,
                actual: 1
            })
        );
        let mut out = [0; 8];
        assert_eq!(
            pack(
                &map,
                &[RawValue::Unsigned(256), RawValue::Signed(0)],
                &mut out
            ),
            Err(PackError::OutOfRange {
                position: 0,
                bits: 8
            })
        );
        assert_eq!(
            pack(
                &map,
                &[RawValue::Unsigned(1), RawValue::Signed(128)],
                &mut out
            ),
            Err(PackError::OutOfRange {
                position: 1,
                bits: 8
            })
        );
        assert_eq!(
            pack(
                &map,
                &[RawValue::Unsigned(1), RawValue::Bool(true)],
                &mut out
            ),
            Err(PackError::WrongKind { position: 1 })
        );
        assert_eq!(
            pack(&map, &[RawValue::Unsigned(1)], &mut out),
            Err(PackError::ValueCount {
                expected: 2,
                actual: 1
            })
        );
        // Data longer than the mapping is not an unpack error.
        assert!(unpack(&map, &[1, 2, 3, 4, 5, 6, 7, 8]).is_ok());
    }

    fn arb_object() -> impl Strategy<Value = (ValueKind, u8)> {
        prop_oneof![
            Just((ValueKind::Boolean, 1)),
            (1u8..=64).prop_map(|b| (ValueKind::Unsigned, b)),
            (1u8..=64).prop_map(|b| (ValueKind::Signed, b)),
            Just((ValueKind::Real32, 32)),
            Just((ValueKind::Real64, 64)),
            (1u8..=8).prop_map(|n| (ValueKind::Bytes, n * 8)),
        ]
    }

    /// A random mapping of at most 64 bits and a random value for each object.
    fn arb_mapping_and_values() -> impl Strategy<Value = (Mapping, Vec<RawValue>)> {
        proptest::collection::vec(arb_object(), 1..=MAX_ENTRIES)
            .prop_flat_map(|objs| {
                let mut map = Mapping::new();
                for (i, (kind, bits)) in objs.into_iter().enumerate() {
                    if map
                        .push(MappingEntry::new(0x2000, i as u8, bits), kind)
                        .is_err()
                    {
                        break;
                    }
                }
                let seeds = proptest::collection::vec(any::<u64>(), map.len());
                (Just(map), seeds)
            })
            .prop_map(|(map, seeds)| {
                let vals = map
                    .objects()
                    .iter()
                    .zip(seeds)
                    .map(|(o, s)| {
                        let raw = s & field_mask(o.bits());
                        RawValue::from_raw(o.kind, raw, o.bits())
                    })
                    .collect();
                (map, vals)
            })
            .prop_filter("mapping is not empty", |(m, _)| !m.is_empty())
    }

    fn same(a: &RawValue, b: &RawValue) -> bool {
        match (a, b) {
            (RawValue::Real32(x), RawValue::Real32(y)) => x.to_bits() == y.to_bits(),
            (RawValue::Real64(x), RawValue::Real64(y)) => x.to_bits() == y.to_bits(),
            _ => a == b,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn pack_then_unpack_is_identity((map, vals) in arb_mapping_and_values()) {
            let mut out = [0u8; 8];
            let n = pack(&map, &vals, &mut out).unwrap();
            prop_assert_eq!(n, map.byte_len());
            let back: Vec<RawValue> = unpack(&map, &out[..n]).unwrap().iter().map(|(_, v)| v).collect();
            prop_assert_eq!(back.len(), vals.len());
            for (a, b) in back.iter().zip(&vals) {
                prop_assert!(same(a, b), "{:?} != {:?}", a, b);
            }
        }

        #[test]
        fn unpack_then_pack_is_identity((map, _vals) in arb_mapping_and_values(), data in any::<[u8; 8]>()) {
            let n = map.byte_len();
            let vals: Vec<RawValue> = unpack(&map, &data[..n]).unwrap().iter().map(|(_, v)| v).collect();
            let mut out = [0u8; 8];
            pack(&map, &vals, &mut out).unwrap();
            // Only the mapped bits survive; bits past the mapping are zero.
            let mask = field_mask(map.bit_len() as u8);
            prop_assert_eq!(u64::from_le_bytes(out), u64::from_le_bytes(data) & mask);
        }
    }
}
