//! Codes of the object dictionary: CiA 301 §7.4.7 data type indices, CiA 301 §7.4.3 object codes
//! and the CiA 306 §4.6.3 access types. These need no allocator.
//!
//! [`DataType`] and [`ObjectCode`] are open enums: a code this crate does not name is kept as
//! `Other(code)`, so reading and writing a file never loses it.

use core::fmt;

/// A CiA 301 data type, identified by its index in the object dictionary (0x0001..=0x001B for
/// the basic types, 0x0020.. for the predefined complex types, 0x0040.. for device profile types).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DataType {
    /// BOOLEAN (0x0001).
    Boolean,
    /// INTEGER8 (0x0002).
    Integer8,
    /// INTEGER16 (0x0003).
    Integer16,
    /// INTEGER32 (0x0004).
    Integer32,
    /// UNSIGNED8 (0x0005).
    Unsigned8,
    /// UNSIGNED16 (0x0006).
    Unsigned16,
    /// UNSIGNED32 (0x0007).
    Unsigned32,
    /// REAL32 (0x0008), IEEE 754 single precision.
    Real32,
    /// VISIBLE_STRING (0x0009).
    VisibleString,
    /// OCTET_STRING (0x000A).
    OctetString,
    /// UNICODE_STRING (0x000B), UTF-16 code units.
    UnicodeString,
    /// TIME_OF_DAY (0x000C): milliseconds after midnight (28 bits) and days since 1984-01-01.
    TimeOfDay,
    /// TIME_DIFFERENCE (0x000D): same layout as TIME_OF_DAY.
    TimeDifference,
    /// DOMAIN (0x000F): an arbitrary block of bytes.
    Domain,
    /// INTEGER24 (0x0010).
    Integer24,
    /// REAL64 (0x0011), IEEE 754 double precision.
    Real64,
    /// INTEGER40 (0x0012).
    Integer40,
    /// INTEGER48 (0x0013).
    Integer48,
    /// INTEGER56 (0x0014).
    Integer56,
    /// INTEGER64 (0x0015).
    Integer64,
    /// UNSIGNED24 (0x0016).
    Unsigned24,
    /// UNSIGNED40 (0x0018).
    Unsigned40,
    /// UNSIGNED48 (0x0019).
    Unsigned48,
    /// UNSIGNED56 (0x001A).
    Unsigned56,
    /// UNSIGNED64 (0x001B).
    Unsigned64,
    /// Any other index (complex types such as PDO_COMMUNICATION_PARAMETER 0x0020, profile types,
    /// reserved codes). Kept so a file round-trips.
    Other(u16),
}

/// Every basic data type this crate encodes, in index order.
pub const BASIC_DATA_TYPES: [DataType; 25] = [
    DataType::Boolean,
    DataType::Integer8,
    DataType::Integer16,
    DataType::Integer32,
    DataType::Unsigned8,
    DataType::Unsigned16,
    DataType::Unsigned32,
    DataType::Real32,
    DataType::VisibleString,
    DataType::OctetString,
    DataType::UnicodeString,
    DataType::TimeOfDay,
    DataType::TimeDifference,
    DataType::Domain,
    DataType::Integer24,
    DataType::Real64,
    DataType::Integer40,
    DataType::Integer48,
    DataType::Integer56,
    DataType::Integer64,
    DataType::Unsigned24,
    DataType::Unsigned40,
    DataType::Unsigned48,
    DataType::Unsigned56,
    DataType::Unsigned64,
];

impl DataType {
    /// The data type for an object dictionary index; unknown codes become [`DataType::Other`].
    pub const fn from_code(code: u16) -> Self {
        match code {
            0x0001 => Self::Boolean,
            0x0002 => Self::Integer8,
            0x0003 => Self::Integer16,
            0x0004 => Self::Integer32,
            0x0005 => Self::Unsigned8,
            0x0006 => Self::Unsigned16,
            0x0007 => Self::Unsigned32,
            0x0008 => Self::Real32,
            0x0009 => Self::VisibleString,
            0x000A => Self::OctetString,
            0x000B => Self::UnicodeString,
            0x000C => Self::TimeOfDay,
            0x000D => Self::TimeDifference,
            0x000F => Self::Domain,
            0x0010 => Self::Integer24,
            0x0011 => Self::Real64,
            0x0012 => Self::Integer40,
            0x0013 => Self::Integer48,
            0x0014 => Self::Integer56,
            0x0015 => Self::Integer64,
            0x0016 => Self::Unsigned24,
            0x0018 => Self::Unsigned40,
            0x0019 => Self::Unsigned48,
            0x001A => Self::Unsigned56,
            0x001B => Self::Unsigned64,
            other => Self::Other(other),
        }
    }

    /// The object dictionary index of this data type.
    pub const fn code(self) -> u16 {
        match self {
            Self::Boolean => 0x0001,
            Self::Integer8 => 0x0002,
            Self::Integer16 => 0x0003,
            Self::Integer32 => 0x0004,
            Self::Unsigned8 => 0x0005,
            Self::Unsigned16 => 0x0006,
            Self::Unsigned32 => 0x0007,
            Self::Real32 => 0x0008,
            Self::VisibleString => 0x0009,
            Self::OctetString => 0x000A,
            Self::UnicodeString => 0x000B,
            Self::TimeOfDay => 0x000C,
            Self::TimeDifference => 0x000D,
            Self::Domain => 0x000F,
            Self::Integer24 => 0x0010,
            Self::Real64 => 0x0011,
            Self::Integer40 => 0x0012,
            Self::Integer48 => 0x0013,
            Self::Integer56 => 0x0014,
            Self::Integer64 => 0x0015,
            Self::Unsigned24 => 0x0016,
            Self::Unsigned40 => 0x0018,
            Self::Unsigned48 => 0x0019,
            Self::Unsigned56 => 0x001A,
            Self::Unsigned64 => 0x001B,
            Self::Other(code) => code,
        }
    }

    /// Size in bytes on the bus for fixed-size types; `None` for strings, DOMAIN and unknown types.
    pub const fn size(self) -> Option<usize> {
        Some(match self {
            Self::Boolean | Self::Integer8 | Self::Unsigned8 => 1,
            Self::Integer16 | Self::Unsigned16 => 2,
            Self::Integer24 | Self::Unsigned24 => 3,
            Self::Integer32 | Self::Unsigned32 | Self::Real32 => 4,
            Self::Integer40 | Self::Unsigned40 => 5,
            Self::Integer48 | Self::Unsigned48 | Self::TimeOfDay | Self::TimeDifference => 6,
            Self::Integer56 | Self::Unsigned56 => 7,
            Self::Integer64 | Self::Unsigned64 | Self::Real64 => 8,
            _ => return None,
        })
    }

    /// The object's bytes in the data of an expedited SDO upload whose size the server did not
    /// indicate (CiA 301 §7.2.4.3.6, e = 1 and s = 0): the four data bytes hold the object from
    /// the first byte on and the rest is unspecified, so a fixed-size type shorter than what
    /// arrived takes its own length from the front. Anything else (a type without fixed size,
    /// fewer bytes than the type takes) is handed back whole, for the strict decoder to judge.
    pub fn expedited_without_size(self, bytes: &[u8]) -> &[u8] {
        match self.size() {
            Some(n) if n < bytes.len() => &bytes[..n],
            _ => bytes,
        }
    }

    /// Width in bits of an integer type (signed or unsigned, BOOLEAN counts as 8); `None` otherwise.
    pub const fn integer_bits(self) -> Option<u32> {
        match self {
            Self::Boolean => Some(8),
            Self::Integer8
            | Self::Integer16
            | Self::Integer24
            | Self::Integer32
            | Self::Integer40
            | Self::Integer48
            | Self::Integer56
            | Self::Integer64
            | Self::Unsigned8
            | Self::Unsigned16
            | Self::Unsigned24
            | Self::Unsigned32
            | Self::Unsigned40
            | Self::Unsigned48
            | Self::Unsigned56
            | Self::Unsigned64 => match self.size() {
                Some(n) => Some(n as u32 * 8),
                None => None,
            },
            _ => None,
        }
    }

    /// True for the signed integer types INTEGER8..INTEGER64.
    pub const fn is_signed(self) -> bool {
        matches!(
            self,
            Self::Integer8
                | Self::Integer16
                | Self::Integer24
                | Self::Integer32
                | Self::Integer40
                | Self::Integer48
                | Self::Integer56
                | Self::Integer64
        )
    }

    /// True for types that a PDO can never map because their size is not fixed.
    pub const fn is_variable_size(self) -> bool {
        matches!(
            self,
            Self::VisibleString | Self::OctetString | Self::UnicodeString | Self::Domain
        )
    }

    /// The CiA 301 name, e.g. `"UNSIGNED16"`; `None` for [`DataType::Other`].
    pub const fn name(self) -> Option<&'static str> {
        Some(match self {
            Self::Boolean => "BOOLEAN",
            Self::Integer8 => "INTEGER8",
            Self::Integer16 => "INTEGER16",
            Self::Integer32 => "INTEGER32",
            Self::Unsigned8 => "UNSIGNED8",
            Self::Unsigned16 => "UNSIGNED16",
            Self::Unsigned32 => "UNSIGNED32",
            Self::Real32 => "REAL32",
            Self::VisibleString => "VISIBLE_STRING",
            Self::OctetString => "OCTET_STRING",
            Self::UnicodeString => "UNICODE_STRING",
            Self::TimeOfDay => "TIME_OF_DAY",
            Self::TimeDifference => "TIME_DIFFERENCE",
            Self::Domain => "DOMAIN",
            Self::Integer24 => "INTEGER24",
            Self::Real64 => "REAL64",
            Self::Integer40 => "INTEGER40",
            Self::Integer48 => "INTEGER48",
            Self::Integer56 => "INTEGER56",
            Self::Integer64 => "INTEGER64",
            Self::Unsigned24 => "UNSIGNED24",
            Self::Unsigned40 => "UNSIGNED40",
            Self::Unsigned48 => "UNSIGNED48",
            Self::Unsigned56 => "UNSIGNED56",
            Self::Unsigned64 => "UNSIGNED64",
            Self::Other(_) => return None,
        })
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(n) => f.write_str(n),
            None => write!(f, "data type 0x{:04X}", self.code()),
        }
    }
}

/// A CiA 301 object code (the EDS key `ObjectType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ObjectCode {
    /// NULL (0x0): an object with no data fields.
    Null,
    /// DOMAIN (0x2): a large variable amount of data.
    Domain,
    /// DEFTYPE (0x5): a type definition (e.g. UNSIGNED16 at index 0x0006).
    DefType,
    /// DEFSTRUCT (0x6): a record type definition.
    DefStruct,
    /// VAR (0x7): a single value.
    Var,
    /// ARRAY (0x8): sub-indices 1.. of one data type, sub-index 0 is the count.
    Array,
    /// RECORD (0x9): sub-indices of possibly different data types.
    Record,
    /// Any other code, kept so a file round-trips.
    Other(u8),
}

impl ObjectCode {
    /// The object code for its numeric value.
    pub const fn from_code(code: u8) -> Self {
        match code {
            0x0 => Self::Null,
            0x2 => Self::Domain,
            0x5 => Self::DefType,
            0x6 => Self::DefStruct,
            0x7 => Self::Var,
            0x8 => Self::Array,
            0x9 => Self::Record,
            other => Self::Other(other),
        }
    }

    /// The numeric object code.
    pub const fn code(self) -> u8 {
        match self {
            Self::Null => 0x0,
            Self::Domain => 0x2,
            Self::DefType => 0x5,
            Self::DefStruct => 0x6,
            Self::Var => 0x7,
            Self::Array => 0x8,
            Self::Record => 0x9,
            Self::Other(c) => c,
        }
    }

    /// True when the object's data lives in sub-index 0 alone (VAR, DOMAIN, DEFTYPE, NULL).
    pub const fn is_simple(self) -> bool {
        matches!(self, Self::Var | Self::Domain | Self::DefType | Self::Null)
    }

    /// The CiA 301 name, e.g. `"RECORD"`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Null => "NULL",
            Self::Domain => "DOMAIN",
            Self::DefType => "DEFTYPE",
            Self::DefStruct => "DEFSTRUCT",
            Self::Var => "VAR",
            Self::Array => "ARRAY",
            Self::Record => "RECORD",
            Self::Other(_) => "unknown object code",
        }
    }
}

impl fmt::Display for ObjectCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (0x{:X})", self.name(), self.code())
    }
}

/// A CiA 306 access type (the EDS key `AccessType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AccessType {
    /// `ro`: read only.
    Ro,
    /// `wo`: write only.
    Wo,
    /// `rw`: read and write.
    Rw,
    /// `rwr`: read and write, mappable into a TPDO (process input).
    Rwr,
    /// `rww`: read and write, mappable into an RPDO (process output).
    Rww,
    /// `const`: read only and never changes.
    Const,
}

impl AccessType {
    /// Parses the EDS spelling, ignoring ASCII case; `None` for anything else.
    pub fn from_eds(text: &str) -> Option<Self> {
        // The spellings CiA 306 uses, as nearly every file writes them.
        match text {
            "ro" => return Some(Self::Ro),
            "rw" => return Some(Self::Rw),
            "wo" => return Some(Self::Wo),
            "const" => return Some(Self::Const),
            "rwr" => return Some(Self::Rwr),
            "rww" => return Some(Self::Rww),
            _ => {}
        }
        let t = text.trim();
        Some(if t.eq_ignore_ascii_case("ro") {
            Self::Ro
        } else if t.eq_ignore_ascii_case("wo") {
            Self::Wo
        } else if t.eq_ignore_ascii_case("rw") {
            Self::Rw
        } else if t.eq_ignore_ascii_case("rwr") {
            Self::Rwr
        } else if t.eq_ignore_ascii_case("rww") {
            Self::Rww
        } else if t.eq_ignore_ascii_case("const") {
            Self::Const
        } else {
            return None;
        })
    }

    /// The lower-case EDS spelling.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Ro => "ro",
            Self::Wo => "wo",
            Self::Rw => "rw",
            Self::Rwr => "rwr",
            Self::Rww => "rww",
            Self::Const => "const",
        }
    }

    /// True when an SDO upload is allowed.
    pub const fn is_readable(self) -> bool {
        !matches!(self, Self::Wo)
    }

    /// True when an SDO download is allowed.
    pub const fn is_writable(self) -> bool {
        matches!(self, Self::Wo | Self::Rw | Self::Rwr | Self::Rww)
    }
}

impl fmt::Display for AccessType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_type_codes_round_trip() {
        for code in 0..=0x00FFu16 {
            assert_eq!(DataType::from_code(code).code(), code);
        }
        assert_eq!(DataType::from_code(0x0010), DataType::Integer24);
        assert_eq!(DataType::from_code(0x0011), DataType::Real64);
        assert_eq!(DataType::from_code(0x0016), DataType::Unsigned24);
        assert_eq!(DataType::from_code(0x001B), DataType::Unsigned64);
        assert_eq!(DataType::from_code(0x000E), DataType::Other(0x000E));
        assert_eq!(DataType::from_code(0x0017), DataType::Other(0x0017));
    }

    #[test]
    fn object_codes_round_trip() {
        for code in 0..=255u8 {
            assert_eq!(ObjectCode::from_code(code).code(), code);
        }
        assert_eq!(ObjectCode::from_code(7), ObjectCode::Var);
        assert_eq!(ObjectCode::from_code(2), ObjectCode::Domain);
    }

    #[test]
    fn access_types_parse_any_case() {
        assert_eq!(AccessType::from_eds("Const"), Some(AccessType::Const));
        assert_eq!(AccessType::from_eds(" RW\t"), Some(AccessType::Rw));
        assert_eq!(AccessType::from_eds("rwr"), Some(AccessType::Rwr));
        assert_eq!(AccessType::from_eds("UNKNOWN"), None);
    }

    #[test]
    fn sizes() {
        assert_eq!(DataType::Unsigned24.size(), Some(3));
        assert_eq!(DataType::TimeOfDay.size(), Some(6));
        assert_eq!(DataType::Domain.size(), None);
        assert_eq!(DataType::Integer40.integer_bits(), Some(40));
    }
}
