//! Typed values of the CiA 301 basic data types (§7.1.4 and §7.1.6) and their two codecs:
//! little-endian bytes, as SDO and PDO carry them, and the CiA 306 EDS text of `DefaultValue`,
//! `LowLimit`, `HighLimit` and `ParameterValue` (§4.6.3.2), including `$NODEID` expressions.
//!
//! Both decoders are total: any input gives a value or a typed error, never a panic, and they
//! allocate at most the size of their input.

//! The EDS text codec lives in `text`, the display form in `display`.

mod convert;
mod display;
mod text;

use alloc::vec::Vec;

use crate::types::DataType;

pub use convert::{ConvertError, ValueType};
pub use text::{EdsValue, TextError, TextNotes};
pub(crate) use text::{parse_int_literal, trim};

/// A value of one CiA 301 basic data type.
///
/// Equality compares floats by their bit pattern, so a NaN equals itself and a decode-encode
/// round trip can be checked with `==`.
#[derive(Debug, Clone)]
pub enum Value {
    /// BOOLEAN.
    Boolean(bool),
    /// INTEGER8.
    Integer8(i8),
    /// INTEGER16.
    Integer16(i16),
    /// INTEGER24, sign-extended into an `i32`.
    Integer24(i32),
    /// INTEGER32.
    Integer32(i32),
    /// INTEGER40, sign-extended.
    Integer40(i64),
    /// INTEGER48, sign-extended.
    Integer48(i64),
    /// INTEGER56, sign-extended.
    Integer56(i64),
    /// INTEGER64.
    Integer64(i64),
    /// UNSIGNED8.
    Unsigned8(u8),
    /// UNSIGNED16.
    Unsigned16(u16),
    /// UNSIGNED24 (the upper 8 bits are zero).
    Unsigned24(u32),
    /// UNSIGNED32.
    Unsigned32(u32),
    /// UNSIGNED40.
    Unsigned40(u64),
    /// UNSIGNED48.
    Unsigned48(u64),
    /// UNSIGNED56.
    Unsigned56(u64),
    /// UNSIGNED64.
    Unsigned64(u64),
    /// REAL32.
    Real32(f32),
    /// REAL64.
    Real64(f64),
    /// VISIBLE_STRING, kept as the raw bytes (normally ASCII; EDS text is stored as UTF-8).
    /// Decoded from the bus up to the first NUL.
    VisibleString(Vec<u8>),
    /// OCTET_STRING.
    OctetString(Vec<u8>),
    /// UNICODE_STRING as UTF-16 code units.
    UnicodeString(Vec<u16>),
    /// TIME_OF_DAY: `ms` after midnight (bits 0..27; the 4 reserved bits are kept) and `days`
    /// since 1984-01-01.
    TimeOfDay {
        /// Milliseconds after midnight.
        ms: u32,
        /// Days since 1 January 1984.
        days: u16,
    },
    /// TIME_DIFFERENCE: same layout as TIME_OF_DAY.
    TimeDifference {
        /// Milliseconds.
        ms: u32,
        /// Days.
        days: u16,
    },
    /// DOMAIN: arbitrary bytes.
    Domain(Vec<u8>),
}

impl PartialEq for Value {
    fn eq(&self, other: &Self) -> bool {
        use Value::*;
        match (self, other) {
            (Real32(a), Real32(b)) => a.to_bits() == b.to_bits(),
            (Real64(a), Real64(b)) => a.to_bits() == b.to_bits(),
            (Boolean(a), Boolean(b)) => a == b,
            (Integer8(a), Integer8(b)) => a == b,
            (Integer16(a), Integer16(b)) => a == b,
            (Integer24(a), Integer24(b)) | (Integer32(a), Integer32(b)) => a == b,
            (Integer40(a), Integer40(b))
            | (Integer48(a), Integer48(b))
            | (Integer56(a), Integer56(b))
            | (Integer64(a), Integer64(b)) => a == b,
            (Unsigned8(a), Unsigned8(b)) => a == b,
            (Unsigned16(a), Unsigned16(b)) => a == b,
            (Unsigned24(a), Unsigned24(b)) | (Unsigned32(a), Unsigned32(b)) => a == b,
            (Unsigned40(a), Unsigned40(b))
            | (Unsigned48(a), Unsigned48(b))
            | (Unsigned56(a), Unsigned56(b))
            | (Unsigned64(a), Unsigned64(b)) => a == b,
            (VisibleString(a), VisibleString(b))
            | (OctetString(a), OctetString(b))
            | (Domain(a), Domain(b)) => a == b,
            (UnicodeString(a), UnicodeString(b)) => a == b,
            (TimeOfDay { ms: a, days: c }, TimeOfDay { ms: b, days: d })
            | (TimeDifference { ms: a, days: c }, TimeDifference { ms: b, days: d }) => {
                a == b && c == d
            }
            _ => false,
        }
    }
}

/// Why bytes could not be decoded into a [`Value`].
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum BytesError {
    /// A fixed-size type received the wrong number of bytes.
    #[error("{data_type} takes {expected} bytes, got {actual}")]
    WrongLength {
        /// The type being decoded.
        data_type: DataType,
        /// Its size.
        expected: usize,
        /// The number of bytes given.
        actual: usize,
    },
    /// A BOOLEAN byte other than 0 or 1.
    #[error("BOOLEAN must be 0 or 1, got 0x{0:02X}")]
    InvalidBoolean(u8),
    /// UNICODE_STRING with an odd number of bytes.
    #[error("UNICODE_STRING needs an even number of bytes, got {0}")]
    OddUnicodeLength(usize),
    /// The data type has no value encoding (complex or unknown type).
    #[error("{0} has no basic value encoding")]
    Unsupported(DataType),
}

debug_as_display!(BytesError);

fn le_int(bytes: &[u8], signed: bool) -> i128 {
    let mut v: u64 = 0;
    for (i, b) in bytes.iter().enumerate() {
        v |= u64::from(*b) << (8 * i);
    }
    let bits = bytes.len() as u32 * 8;
    if signed && bits > 0 && bits < 64 && v & (1 << (bits - 1)) != 0 {
        i128::from(v) - (1i128 << bits)
    } else if signed && bits == 64 {
        i128::from(v as i64)
    } else {
        i128::from(v)
    }
}

impl Value {
    /// The data type of this value.
    pub fn data_type(&self) -> DataType {
        match self {
            Self::Boolean(_) => DataType::Boolean,
            Self::Integer8(_) => DataType::Integer8,
            Self::Integer16(_) => DataType::Integer16,
            Self::Integer24(_) => DataType::Integer24,
            Self::Integer32(_) => DataType::Integer32,
            Self::Integer40(_) => DataType::Integer40,
            Self::Integer48(_) => DataType::Integer48,
            Self::Integer56(_) => DataType::Integer56,
            Self::Integer64(_) => DataType::Integer64,
            Self::Unsigned8(_) => DataType::Unsigned8,
            Self::Unsigned16(_) => DataType::Unsigned16,
            Self::Unsigned24(_) => DataType::Unsigned24,
            Self::Unsigned32(_) => DataType::Unsigned32,
            Self::Unsigned40(_) => DataType::Unsigned40,
            Self::Unsigned48(_) => DataType::Unsigned48,
            Self::Unsigned56(_) => DataType::Unsigned56,
            Self::Unsigned64(_) => DataType::Unsigned64,
            Self::Real32(_) => DataType::Real32,
            Self::Real64(_) => DataType::Real64,
            Self::VisibleString(_) => DataType::VisibleString,
            Self::OctetString(_) => DataType::OctetString,
            Self::UnicodeString(_) => DataType::UnicodeString,
            Self::TimeOfDay { .. } => DataType::TimeOfDay,
            Self::TimeDifference { .. } => DataType::TimeDifference,
            Self::Domain(_) => DataType::Domain,
        }
    }

    /// The integer value of an integer or BOOLEAN value; `None` for other types.
    pub fn as_i128(&self) -> Option<i128> {
        Some(match *self {
            Self::Boolean(b) => i128::from(b),
            Self::Integer8(v) => v.into(),
            Self::Integer16(v) => v.into(),
            Self::Integer24(v) | Self::Integer32(v) => v.into(),
            Self::Integer40(v) | Self::Integer48(v) | Self::Integer56(v) | Self::Integer64(v) => {
                v.into()
            }
            Self::Unsigned8(v) => v.into(),
            Self::Unsigned16(v) => v.into(),
            Self::Unsigned24(v) | Self::Unsigned32(v) => v.into(),
            Self::Unsigned40(v)
            | Self::Unsigned48(v)
            | Self::Unsigned56(v)
            | Self::Unsigned64(v) => v.into(),
            _ => return None,
        })
    }

    /// A float or integer value as `f64` (for comparisons against limits); `None` otherwise.
    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Self::Real32(v) => Some(v.into()),
            Self::Real64(v) => Some(v),
            _ => self.as_i128().map(|v| v as f64),
        }
    }

    /// An integer value of `data_type` from `v`, wrapped to the type's width (two's complement
    /// for signed types). `None` when `data_type` is not an integer type or BOOLEAN.
    pub fn from_i128_wrapping(data_type: DataType, v: i128) -> Option<Self> {
        let bits = data_type.integer_bits()?;
        let mask = if bits >= 128 {
            !0u128
        } else {
            (1u128 << bits) - 1
        };
        let u = (v as u128) & mask;
        let s = if data_type.is_signed() && bits < 128 && u & (1u128 << (bits - 1)) != 0 {
            (u as i128) - (1i128 << bits)
        } else {
            u as i128
        };
        Some(match data_type {
            DataType::Boolean => Self::Boolean(u != 0),
            DataType::Integer8 => Self::Integer8(s as i8),
            DataType::Integer16 => Self::Integer16(s as i16),
            DataType::Integer24 => Self::Integer24(s as i32),
            DataType::Integer32 => Self::Integer32(s as i32),
            DataType::Integer40 => Self::Integer40(s as i64),
            DataType::Integer48 => Self::Integer48(s as i64),
            DataType::Integer56 => Self::Integer56(s as i64),
            DataType::Integer64 => Self::Integer64(s as i64),
            DataType::Unsigned8 => Self::Unsigned8(u as u8),
            DataType::Unsigned16 => Self::Unsigned16(u as u16),
            DataType::Unsigned24 => Self::Unsigned24(u as u32),
            DataType::Unsigned32 => Self::Unsigned32(u as u32),
            DataType::Unsigned40 => Self::Unsigned40(u as u64),
            DataType::Unsigned48 => Self::Unsigned48(u as u64),
            DataType::Unsigned56 => Self::Unsigned56(u as u64),
            DataType::Unsigned64 => Self::Unsigned64(u as u64),
            _ => return None,
        })
    }

    /// Decodes the little-endian bytes of an SDO or PDO payload.
    pub fn from_le_bytes(data_type: DataType, bytes: &[u8]) -> Result<Self, BytesError> {
        if let Some(expected) = data_type.size()
            && bytes.len() != expected
        {
            return Err(BytesError::WrongLength {
                data_type,
                expected,
                actual: bytes.len(),
            });
        }
        Ok(match data_type {
            DataType::Boolean => match bytes.first().copied().unwrap_or(0) {
                0 => Self::Boolean(false),
                1 => Self::Boolean(true),
                b => return Err(BytesError::InvalidBoolean(b)),
            },
            DataType::Real32 => Self::Real32(f32::from_bits(le_int(bytes, false) as u32)),
            DataType::Real64 => Self::Real64(f64::from_bits(le_int(bytes, false) as u64)),
            // Up to the first NUL: devices built on C keep the terminator of their string
            // in the object (CANopenNode's demo sends 901 bytes for a 900-character text), and
            // python-canopen and CANopenNode's tools read the text so.
            DataType::VisibleString => {
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                Self::VisibleString(bytes[..end].to_vec())
            }
            DataType::OctetString => Self::OctetString(bytes.to_vec()),
            DataType::Domain => Self::Domain(bytes.to_vec()),
            DataType::UnicodeString => {
                if !bytes.len().is_multiple_of(2) {
                    return Err(BytesError::OddUnicodeLength(bytes.len()));
                }
                Self::UnicodeString(
                    bytes
                        .chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]]))
                        .collect(),
                )
            }
            DataType::TimeOfDay | DataType::TimeDifference => {
                let ms = le_int(bytes.get(..4).unwrap_or(&[]), false) as u32;
                let days = le_int(bytes.get(4..6).unwrap_or(&[]), false) as u16;
                if data_type == DataType::TimeOfDay {
                    Self::TimeOfDay { ms, days }
                } else {
                    Self::TimeDifference { ms, days }
                }
            }
            DataType::Other(_) => return Err(BytesError::Unsupported(data_type)),
            dt => Self::from_i128_wrapping(dt, le_int(bytes, dt.is_signed()))
                .ok_or(BytesError::Unsupported(dt))?,
        })
    }

    /// Decodes the data of an expedited SDO upload whose size the server did not indicate
    /// (e = 1, s = 0): a fixed-size type takes its own length from the front of the four bytes
    /// (see [`DataType::expedited_without_size`]). Use [`from_le_bytes`](Self::from_le_bytes)
    /// for every payload whose length was told: there a length other than the type's stays
    /// an error.
    pub fn from_le_bytes_unsized(data_type: DataType, bytes: &[u8]) -> Result<Self, BytesError> {
        Self::from_le_bytes(data_type, data_type.expedited_without_size(bytes))
    }

    /// Appends the little-endian encoding to `out`.
    pub fn write_le_bytes(&self, out: &mut Vec<u8>) {
        let size = self.data_type().size();
        match self {
            Self::Real32(v) => out.extend_from_slice(&v.to_bits().to_le_bytes()),
            Self::Real64(v) => out.extend_from_slice(&v.to_bits().to_le_bytes()),
            Self::VisibleString(b) | Self::OctetString(b) | Self::Domain(b) => {
                out.extend_from_slice(b)
            }
            Self::UnicodeString(u) => {
                for c in u {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
            Self::TimeOfDay { ms, days } | Self::TimeDifference { ms, days } => {
                out.extend_from_slice(&ms.to_le_bytes());
                out.extend_from_slice(&days.to_le_bytes());
            }
            _ => {
                let v = self.as_i128().unwrap_or(0) as u128;
                let n = size.unwrap_or(0);
                out.extend_from_slice(&v.to_le_bytes()[..n]);
            }
        }
    }

    /// The little-endian encoding.
    pub fn to_le_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.data_type().size().unwrap_or(8));
        self.write_le_bytes(&mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec;

    #[test]
    fn bytes_vectors() {
        // CiA 301: little-endian; UNSIGNED24 0x123456 is 56 34 12.
        assert_eq!(
            Value::Unsigned24(0x12_3456).to_le_bytes(),
            vec![0x56, 0x34, 0x12]
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Integer24, &[0xFF, 0xFF, 0xFF]),
            Ok(Value::Integer24(-1))
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Integer40, &[0, 0, 0, 0, 0x80]),
            Ok(Value::Integer40(-(1 << 39)))
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Unsigned16, &[1]),
            Err(BytesError::WrongLength {
                data_type: DataType::Unsigned16,
                expected: 2,
                actual: 1
            })
        );
        assert_eq!(
            Value::TimeOfDay { ms: 1, days: 2 }.to_le_bytes(),
            vec![1, 0, 0, 0, 2, 0]
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Boolean, &[2]),
            Err(BytesError::InvalidBoolean(2))
        );
    }
}
