//! Typed object dictionary entries: an index, a sub-index and the Rust type of the value together,
//! so `sdo().read(PRODUCER_HEARTBEAT_TIME)` yields a `u16` and cannot be written with a string.
//!
//! Generated code (see the `canola-codegen` crate) declares one `Entry` constant per sub-object.
//! This module needs no allocator; `String` and `Vec<u8>` values come with the `alloc` feature.
//!
//! The byte codec is CiA 301 §7.1: little-endian, integers of 24..56 bits in their exact width
//! (signed ones sign-extended on decode), BOOLEAN as one byte 0 or 1.

use core::fmt;
use core::marker::PhantomData;

use crate::address::ObjectAddress;
use crate::types::DataType;

/// One sub-object of a dictionary with the Rust type of its value: an [`ObjectAddress`] plus
/// the CiA 301 data type and the Rust type `T` that carries it.
pub struct Entry<T> {
    address: ObjectAddress,
    data_type: DataType,
    _value: PhantomData<fn() -> T>,
}

impl<T> Entry<T> {
    /// An entry at `index`/`sub_index` holding a value of `data_type`.
    pub const fn new(index: u16, sub_index: u8, data_type: DataType) -> Self {
        Self::at(ObjectAddress::new(index, sub_index), data_type)
    }

    /// An entry at `address` holding a value of `data_type`.
    pub const fn at(address: ObjectAddress, data_type: DataType) -> Self {
        Self {
            address,
            data_type,
            _value: PhantomData,
        }
    }

    /// Where the entry is: index and sub-index.
    pub const fn address(&self) -> ObjectAddress {
        self.address
    }

    /// The object index.
    pub const fn index(&self) -> u16 {
        self.address.index
    }

    /// The sub-index (0 for a VAR).
    pub const fn sub_index(&self) -> u8 {
        self.address.sub_index
    }

    /// The CiA 301 data type.
    pub const fn data_type(&self) -> DataType {
        self.data_type
    }
}

impl<T: EntryValue> Entry<T> {
    /// Decodes an SDO/PDO payload into the entry's type.
    pub fn decode(&self, bytes: &[u8]) -> Result<T, EntryError> {
        T::decode(self.data_type, bytes)
    }

    /// Decodes the data of an expedited SDO upload whose size the server did not indicate: a
    /// fixed-size type takes its own length from the front (see
    /// [`DataType::expedited_without_size`]).
    pub fn decode_unsized(&self, bytes: &[u8]) -> Result<T, EntryError> {
        T::decode(self.data_type, self.data_type.expedited_without_size(bytes))
    }

    /// Encodes a value into `out`, returning the number of bytes written.
    pub fn encode(&self, value: &T, out: &mut [u8]) -> Result<usize, EntryError> {
        value.encode(self.data_type, out)
    }
}

// Manual impls: `T` is only a marker, so an `Entry<String>` is as `Copy` as an `Entry<u8>`.
impl<T> Clone for Entry<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Entry<T> {}
impl<T> PartialEq for Entry<T> {
    fn eq(&self, other: &Self) -> bool {
        (self.address, self.data_type) == (other.address, other.data_type)
    }
}
impl<T> Eq for Entry<T> {}
impl<T> fmt::Debug for Entry<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Entry({}, {})", self.address, self.data_type)
    }
}
/// Displays the address: `0x1017:00`.
impl<T> fmt::Display for Entry<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.address.fmt(f)
    }
}

/// Why bytes do not fit an entry's type.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum EntryError {
    /// The payload length is not the data type's size.
    #[error("{data_type} takes {expected} bytes, got {actual}")]
    Length {
        /// The entry's data type.
        data_type: DataType,
        /// Its size in bytes.
        expected: usize,
        /// What arrived.
        actual: usize,
    },
    /// The Rust type cannot carry this data type (e.g. a `u8` entry of an INTEGER32 object).
    #[error("a {rust_type} cannot hold a {data_type}")]
    TypeMismatch {
        /// The entry's data type.
        data_type: DataType,
        /// The Rust type asked for.
        rust_type: &'static str,
    },
    /// The output buffer is too small.
    #[error("output buffer of {0} bytes is too small")]
    BufferTooSmall(usize),
    /// A BOOLEAN byte other than 0 or 1.
    #[error("BOOLEAN byte {0:#04x} is neither 0 nor 1")]
    Boolean(u8),
    /// A VISIBLE_STRING that is not text.
    #[error("string is not valid text")]
    Text,
}

debug_as_display!(EntryError);

/// A Rust type that can carry the value of an object dictionary entry.
pub trait EntryValue: Sized {
    /// Decodes little-endian bytes of `data_type`.
    fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError>;
    /// Encodes into `out`; returns the length written.
    fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError>;
}

fn fixed_len(
    data_type: DataType,
    rust_type: &'static str,
    allowed: &[DataType],
) -> Result<usize, EntryError> {
    if !allowed.contains(&data_type) {
        return Err(EntryError::TypeMismatch {
            data_type,
            rust_type,
        });
    }
    data_type.size().ok_or(EntryError::TypeMismatch {
        data_type,
        rust_type,
    })
}

fn check_len(data_type: DataType, expected: usize, actual: usize) -> Result<(), EntryError> {
    if expected == actual {
        Ok(())
    } else {
        Err(EntryError::Length {
            data_type,
            expected,
            actual,
        })
    }
}

fn read_le(bytes: &[u8]) -> u64 {
    bytes.iter().rev().fold(0u64, |acc, &b| acc << 8 | b as u64)
}

fn write_le(v: u64, len: usize, out: &mut [u8]) -> Result<usize, EntryError> {
    let dst = out.get_mut(..len).ok_or(EntryError::BufferTooSmall(len))?;
    for (i, b) in dst.iter_mut().enumerate() {
        *b = (v >> (8 * i)) as u8;
    }
    Ok(len)
}

macro_rules! unsigned_entry {
    ($t:ty, [$($dt:ident),+]) => {
        impl EntryValue for $t {
            fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
                let len = fixed_len(data_type, stringify!($t), &[$(DataType::$dt),+])?;
                check_len(data_type, len, bytes.len())?;
                Ok(read_le(bytes) as $t)
            }
            fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
                let len = fixed_len(data_type, stringify!($t), &[$(DataType::$dt),+])?;
                write_le(*self as u64, len, out)
            }
        }
    };
}

macro_rules! signed_entry {
    ($t:ty, [$($dt:ident),+]) => {
        impl EntryValue for $t {
            fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
                let len = fixed_len(data_type, stringify!($t), &[$(DataType::$dt),+])?;
                check_len(data_type, len, bytes.len())?;
                let shift = 64 - 8 * len as u32;
                Ok(((read_le(bytes) << shift) as i64 >> shift) as $t)
            }
            fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
                let len = fixed_len(data_type, stringify!($t), &[$(DataType::$dt),+])?;
                write_le(*self as i64 as u64, len, out)
            }
        }
    };
}

unsigned_entry!(u8, [Unsigned8]);
unsigned_entry!(u16, [Unsigned16]);
unsigned_entry!(u32, [Unsigned24, Unsigned32]);
unsigned_entry!(u64, [Unsigned40, Unsigned48, Unsigned56, Unsigned64]);
signed_entry!(i8, [Integer8]);
signed_entry!(i16, [Integer16]);
signed_entry!(i32, [Integer24, Integer32]);
signed_entry!(i64, [Integer40, Integer48, Integer56, Integer64]);

impl EntryValue for bool {
    fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
        let len = fixed_len(data_type, "bool", &[DataType::Boolean])?;
        check_len(data_type, len, bytes.len())?;
        match bytes.first() {
            Some(0) => Ok(false),
            Some(1) => Ok(true),
            Some(&b) => Err(EntryError::Boolean(b)),
            None => Err(EntryError::Length {
                data_type,
                expected: 1,
                actual: 0,
            }),
        }
    }
    fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
        fixed_len(data_type, "bool", &[DataType::Boolean])?;
        write_le(*self as u64, 1, out)
    }
}

impl EntryValue for f32 {
    fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
        let len = fixed_len(data_type, "f32", &[DataType::Real32])?;
        check_len(data_type, len, bytes.len())?;
        Ok(f32::from_bits(read_le(bytes) as u32))
    }
    fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
        fixed_len(data_type, "f32", &[DataType::Real32])?;
        write_le(self.to_bits() as u64, 4, out)
    }
}

impl EntryValue for f64 {
    fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
        let len = fixed_len(data_type, "f64", &[DataType::Real64])?;
        check_len(data_type, len, bytes.len())?;
        Ok(f64::from_bits(read_le(bytes)))
    }
    fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
        fixed_len(data_type, "f64", &[DataType::Real64])?;
        write_le(self.to_bits(), 8, out)
    }
}

/// TIME_OF_DAY and TIME_DIFFERENCE as their six raw bytes (ms after midnight in 28 bits, days
/// since 1984-01-01 in 16 bits).
impl EntryValue for [u8; 6] {
    fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
        fixed_len(
            data_type,
            "[u8; 6]",
            &[DataType::TimeOfDay, DataType::TimeDifference],
        )?;
        bytes.try_into().map_err(|_| EntryError::Length {
            data_type,
            expected: 6,
            actual: bytes.len(),
        })
    }
    fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
        fixed_len(
            data_type,
            "[u8; 6]",
            &[DataType::TimeOfDay, DataType::TimeDifference],
        )?;
        let dst = out.get_mut(..6).ok_or(EntryError::BufferTooSmall(6))?;
        dst.copy_from_slice(self);
        Ok(6)
    }
}

/// The value type of generated entries whose data type has no allocation-free Rust type
/// (strings and DOMAIN in a crate built without an allocator, and unknown data types). Such an
/// entry still names its index, sub-index and data type; its bytes are the caller's to interpret.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Opaque;

/// The owned string type of generated VISIBLE_STRING / UNICODE_STRING entries.
#[cfg(feature = "alloc")]
pub type OwnedString = alloc::string::String;

/// The owned byte type of generated OCTET_STRING / DOMAIN entries.
#[cfg(feature = "alloc")]
pub type OwnedBytes = alloc::vec::Vec<u8>;

/// One sub-object of a static (allocation-free) object dictionary, as the code generator emits
/// it for a device: metadata plus the default value's little-endian bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StaticSubObject {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub_index: u8,
    /// ParameterName.
    pub name: &'static str,
    /// Data type.
    pub data_type: DataType,
    /// Access type.
    pub access: crate::types::AccessType,
    /// Whether the sub-object may be mapped into a PDO.
    pub pdo_mapping: bool,
    /// The default value's bytes (for `$NODEID` defaults: the offset, see `default_adds_node_id`).
    pub default: Option<&'static [u8]>,
    /// The default is `$NODEID + default`: add the node-ID before use.
    pub default_adds_node_id: bool,
}

#[cfg(feature = "alloc")]
mod with_alloc {
    use alloc::string::String;
    use alloc::vec::Vec;

    use super::{EntryError, EntryValue};
    use crate::types::DataType;

    fn copy_out(src: &[u8], out: &mut [u8]) -> Result<usize, EntryError> {
        let dst = out
            .get_mut(..src.len())
            .ok_or(EntryError::BufferTooSmall(src.len()))?;
        dst.copy_from_slice(src);
        Ok(src.len())
    }

    /// VISIBLE_STRING (bytes as text; a trailing NUL padding is dropped) and UNICODE_STRING
    /// (UTF-16LE).
    impl EntryValue for String {
        fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
            match data_type {
                DataType::VisibleString => {
                    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                    // VISIBLE_STRING is ISO 646 in CiA 301; devices send Latin-1 too, so map
                    // each byte to the code point of the same value rather than fail.
                    Ok(bytes[..end].iter().map(|&b| b as char).collect())
                }
                DataType::UnicodeString => {
                    let units = bytes
                        .chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]]));
                    char::decode_utf16(units)
                        .collect::<Result<String, _>>()
                        .map_err(|_| EntryError::Text)
                }
                _ => Err(EntryError::TypeMismatch {
                    data_type,
                    rust_type: "String",
                }),
            }
        }
        fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
            match data_type {
                DataType::VisibleString => {
                    let bytes: Vec<u8> = self
                        .chars()
                        .map(|c| u8::try_from(u32::from(c)).map_err(|_| EntryError::Text))
                        .collect::<Result<_, _>>()?;
                    copy_out(&bytes, out)
                }
                DataType::UnicodeString => {
                    let bytes: Vec<u8> = self.encode_utf16().flat_map(u16::to_le_bytes).collect();
                    copy_out(&bytes, out)
                }
                _ => Err(EntryError::TypeMismatch {
                    data_type,
                    rust_type: "String",
                }),
            }
        }
    }

    /// OCTET_STRING and DOMAIN as raw bytes.
    impl EntryValue for Vec<u8> {
        fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, EntryError> {
            match data_type {
                DataType::OctetString | DataType::Domain => Ok(bytes.to_vec()),
                _ => Err(EntryError::TypeMismatch {
                    data_type,
                    rust_type: "Vec<u8>",
                }),
            }
        }
        fn encode(&self, data_type: DataType, out: &mut [u8]) -> Result<usize, EntryError> {
            match data_type {
                DataType::OctetString | DataType::Domain => copy_out(self, out),
                _ => Err(EntryError::TypeMismatch {
                    data_type,
                    rust_type: "Vec<u8>",
                }),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEARTBEAT: Entry<u16> = Entry::new(0x1017, 0, DataType::Unsigned16);

    #[test]
    fn heartbeat_entry() {
        assert_eq!(HEARTBEAT.decode(&[0xF4, 0x01]), Ok(500));
        let mut buf = [0u8; 8];
        assert_eq!(HEARTBEAT.encode(&500, &mut buf), Ok(2));
        assert_eq!(&buf[..2], &[0xF4, 0x01]);
        assert_eq!(
            HEARTBEAT.decode(&[1, 2, 3]),
            Err(EntryError::Length {
                data_type: DataType::Unsigned16,
                expected: 2,
                actual: 3
            })
        );
    }

    #[test]
    fn odd_widths_sign_extend() {
        let e: Entry<i32> = Entry::new(0x2000, 1, DataType::Integer24);
        assert_eq!(e.decode(&[0xFF, 0xFF, 0xFF]), Ok(-1));
        assert_eq!(e.decode(&[0xFF, 0xFF, 0x7F]), Ok(0x7F_FFFF));
        let mut buf = [0u8; 3];
        assert_eq!(e.encode(&-2, &mut buf), Ok(3));
        assert_eq!(buf, [0xFE, 0xFF, 0xFF]);
        let e: Entry<u64> = Entry::new(0x2000, 2, DataType::Unsigned40);
        assert_eq!(e.decode(&[1, 2, 3, 4, 5]), Ok(0x05_0403_0201));
        let e: Entry<i64> = Entry::new(0x2000, 3, DataType::Integer56);
        assert_eq!(e.decode(&[0, 0, 0, 0, 0, 0, 0x80]), Ok(-(1i64 << 55)));
    }

    #[test]
    fn mismatches_are_errors() {
        let e: Entry<u8> = Entry::new(0x1000, 0, DataType::Unsigned32);
        assert!(matches!(
            e.decode(&[0; 4]),
            Err(EntryError::TypeMismatch { .. })
        ));
        let b: Entry<bool> = Entry::new(0x2000, 1, DataType::Boolean);
        assert_eq!(b.decode(&[2]), Err(EntryError::Boolean(2)));
        let mut small = [0u8; 1];
        assert_eq!(
            HEARTBEAT.encode(&1, &mut small),
            Err(EntryError::BufferTooSmall(2))
        );
    }

    #[cfg(feature = "alloc")]
    #[test]
    fn strings_and_bytes() {
        use alloc::string::String;
        use alloc::vec::Vec;
        let name: Entry<String> = Entry::new(0x1008, 0, DataType::VisibleString);
        assert_eq!(name.decode(b"valve\0\0").as_deref(), Ok("valve"));
        let dom: Entry<Vec<u8>> = Entry::new(0x2003, 4, DataType::Domain);
        assert_eq!(dom.decode(&[1, 2, 3]), Ok(alloc::vec![1, 2, 3]));
    }
}
