//! The data types of the ASCII mapping and their text forms (CiA 309-3), with the conversion to
//! and from the little-endian bytes an SDO transfers (CiA 301 §7.1).
//!
//! Text forms: integers in decimal (input also `0x` hex), `x8..x64` as `0x` and upper-case hex
//! digits, `b` as `0`/`1`, reals in the shortest form that reads back to the same value, `vs`
//! between double quotes with an inner quote doubled (input also a single unquoted word),
//! `os`/`us`/`d` in base64 (RFC 2045 alphabet, padded, one line), `t`/`td` as two decimal
//! numbers `<days> <ms>` (as Lely's gateway reads and prints them), and `hex` (non-standard,
//! CANopenNode) as byte pairs separated by spaces. Type names are taken in any letter case.
//! Parsing never panics: bad text is a [`ValueError`].

use core::fmt;

/// A data type name of the ASCII mapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataType {
    /// `b` BOOLEAN
    Bool,
    /// `i8` INTEGER8
    I8,
    /// `i16` INTEGER16
    I16,
    /// `i32` INTEGER32
    I32,
    /// `i64` INTEGER64
    I64,
    /// `u8` UNSIGNED8
    U8,
    /// `u16` UNSIGNED16
    U16,
    /// `u32` UNSIGNED32
    U32,
    /// `u64` UNSIGNED64
    U64,
    /// `x8` UNSIGNED8 shown in hex
    X8,
    /// `x16` UNSIGNED16 shown in hex
    X16,
    /// `x32` UNSIGNED32 shown in hex
    X32,
    /// `x64` UNSIGNED64 shown in hex
    X64,
    /// `r32` REAL32
    R32,
    /// `r64` REAL64
    R64,
    /// `t` TIME_OF_DAY
    TimeOfDay,
    /// `td` TIME_DIFFERENCE
    TimeDifference,
    /// `vs` VISIBLE_STRING
    VisibleString,
    /// `os` OCTET_STRING
    OctetString,
    /// `us` UNICODE_STRING
    UnicodeString,
    /// `d` DOMAIN
    Domain,
    /// `hex` raw bytes (non-standard, CANopenNode)
    Hex,
}

impl DataType {
    /// Every type, in the order of the help text.
    pub const ALL: [DataType; 22] = [
        Self::Bool,
        Self::I8,
        Self::I16,
        Self::I32,
        Self::I64,
        Self::U8,
        Self::U16,
        Self::U32,
        Self::U64,
        Self::X8,
        Self::X16,
        Self::X32,
        Self::X64,
        Self::R32,
        Self::R64,
        Self::TimeOfDay,
        Self::TimeDifference,
        Self::VisibleString,
        Self::OctetString,
        Self::UnicodeString,
        Self::Domain,
        Self::Hex,
    ];

    /// The name on the line.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Bool => "b",
            Self::I8 => "i8",
            Self::I16 => "i16",
            Self::I32 => "i32",
            Self::I64 => "i64",
            Self::U8 => "u8",
            Self::U16 => "u16",
            Self::U32 => "u32",
            Self::U64 => "u64",
            Self::X8 => "x8",
            Self::X16 => "x16",
            Self::X32 => "x32",
            Self::X64 => "x64",
            Self::R32 => "r32",
            Self::R64 => "r64",
            Self::TimeOfDay => "t",
            Self::TimeDifference => "td",
            Self::VisibleString => "vs",
            Self::OctetString => "os",
            Self::UnicodeString => "us",
            Self::Domain => "d",
            Self::Hex => "hex",
        }
    }

    /// The type for a name on the line.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|t| t.name().eq_ignore_ascii_case(name))
    }

    /// The size in bytes of a fixed-size type.
    pub const fn size(self) -> Option<usize> {
        Some(match self {
            Self::Bool | Self::I8 | Self::U8 | Self::X8 => 1,
            Self::I16 | Self::U16 | Self::X16 => 2,
            Self::I32 | Self::U32 | Self::X32 | Self::R32 => 4,
            Self::I64 | Self::U64 | Self::X64 | Self::R64 => 8,
            Self::TimeOfDay | Self::TimeDifference => 6,
            _ => return None,
        })
    }

    /// Whether an empty value is allowed (byte strings).
    pub(crate) const fn may_be_empty(self) -> bool {
        matches!(
            self,
            Self::OctetString | Self::UnicodeString | Self::Domain | Self::Hex
        )
    }

    /// The gateway type for a CiA 301 data type of a dictionary (`None`: no text form, use
    /// `hex`).
    pub fn from_od(dt: canola::od::DataType) -> Option<Self> {
        use canola::od::DataType as D;
        Some(match dt {
            D::Boolean => Self::Bool,
            D::Integer8 => Self::I8,
            D::Integer16 => Self::I16,
            D::Integer32 => Self::I32,
            D::Integer64 => Self::I64,
            D::Unsigned8 => Self::U8,
            D::Unsigned16 => Self::U16,
            D::Unsigned32 => Self::U32,
            D::Unsigned64 => Self::U64,
            D::Real32 => Self::R32,
            D::Real64 => Self::R64,
            D::TimeOfDay => Self::TimeOfDay,
            D::TimeDifference => Self::TimeDifference,
            D::VisibleString => Self::VisibleString,
            D::OctetString => Self::OctetString,
            D::UnicodeString => Self::UnicodeString,
            D::Domain => Self::Domain,
            _ => return None,
        })
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// TIME_OF_DAY and TIME_DIFFERENCE (CiA 301 §7.1.6.5): milliseconds (28 bits) and days.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Time {
    /// Days (since 1984-01-01 for a time of day).
    pub days: u16,
    /// Milliseconds (after midnight for a time of day), below 2^28.
    pub ms: u32,
}

/// The largest millisecond count the 28-bit field holds.
pub const TIME_MS_MAX: u32 = (1 << 28) - 1;

/// A typed value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `b`
    Bool(bool),
    /// `i8`
    I8(i8),
    /// `i16`
    I16(i16),
    /// `i32`
    I32(i32),
    /// `i64`
    I64(i64),
    /// `u8`
    U8(u8),
    /// `u16`
    U16(u16),
    /// `u32`
    U32(u32),
    /// `u64`
    U64(u64),
    /// `x8`
    X8(u8),
    /// `x16`
    X16(u16),
    /// `x32`
    X32(u32),
    /// `x64`
    X64(u64),
    /// `r32`
    R32(f32),
    /// `r64`
    R64(f64),
    /// `t`
    TimeOfDay(Time),
    /// `td`
    TimeDifference(Time),
    /// `vs` (no control characters but tab inside)
    VisibleString(String),
    /// `os`
    OctetString(Vec<u8>),
    /// `us` (the UTF-16LE bytes)
    UnicodeString(Vec<u8>),
    /// `d`
    Domain(Vec<u8>),
    /// `hex`
    Hex(Vec<u8>),
}

/// Why a value's text or bytes do not fit its type.
#[derive(Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValueError {
    /// The text is not a value of the type.
    #[error("`{text}` is not a {data_type} value")]
    Text {
        /// The type.
        data_type: DataType,
        /// The text (cut to 40 characters).
        text: String,
    },
    /// The text is a number, but outside the type's range.
    #[error("`{text}` is out of range for {data_type}")]
    Range {
        /// The type.
        data_type: DataType,
        /// The text (cut to 40 characters).
        text: String,
        /// Above the type's maximum (else below its minimum).
        above: bool,
    },
    /// The bytes do not have the type's size.
    #[error("{got} bytes for a {data_type} value of {want} bytes")]
    Length {
        /// The type.
        data_type: DataType,
        /// The type's size.
        want: usize,
        /// What came.
        got: usize,
    },
}

debug_as_display!(ValueError);

fn bad(data_type: DataType, text: &str) -> ValueError {
    ValueError::Text {
        data_type,
        text: text.chars().take(40).collect(),
    }
}

/// An unsigned number in decimal or `0x` hex.
pub(crate) fn parse_unsigned(text: &str) -> Option<u64> {
    match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(h) if !h.is_empty() && h.bytes().all(|b| b.is_ascii_hexdigit()) => {
            u64::from_str_radix(h, 16).ok()
        }
        Some(_) => None,
        None if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) => text.parse().ok(),
        None => None,
    }
}

/// Whether `text` is written as an integer (decimal or `0x` hex, an optional sign) of any
/// size, and if so whether it is negative.
fn integer_shape(text: &str) -> Option<bool> {
    let (negative, body) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let digits = match body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
        Some(h) => !h.is_empty() && h.bytes().all(|b| b.is_ascii_hexdigit()),
        None => !body.is_empty() && body.bytes().all(|b| b.is_ascii_digit()),
    };
    digits.then_some(negative)
}

fn parse_signed(text: &str) -> Option<i64> {
    match text.strip_prefix('-') {
        Some(rest) => {
            let v = parse_unsigned(rest)?;
            if v == 1 << 63 {
                Some(i64::MIN)
            } else {
                i64::try_from(v).ok().map(|v| -v)
            }
        }
        None => parse_unsigned(text.strip_prefix('+').unwrap_or(text))
            .and_then(|v| i64::try_from(v).ok()),
    }
}

impl Value {
    /// The value's type.
    pub fn data_type(&self) -> DataType {
        match self {
            Self::Bool(_) => DataType::Bool,
            Self::I8(_) => DataType::I8,
            Self::I16(_) => DataType::I16,
            Self::I32(_) => DataType::I32,
            Self::I64(_) => DataType::I64,
            Self::U8(_) => DataType::U8,
            Self::U16(_) => DataType::U16,
            Self::U32(_) => DataType::U32,
            Self::U64(_) => DataType::U64,
            Self::X8(_) => DataType::X8,
            Self::X16(_) => DataType::X16,
            Self::X32(_) => DataType::X32,
            Self::X64(_) => DataType::X64,
            Self::R32(_) => DataType::R32,
            Self::R64(_) => DataType::R64,
            Self::TimeOfDay(_) => DataType::TimeOfDay,
            Self::TimeDifference(_) => DataType::TimeDifference,
            Self::VisibleString(_) => DataType::VisibleString,
            Self::OctetString(_) => DataType::OctetString,
            Self::UnicodeString(_) => DataType::UnicodeString,
            Self::Domain(_) => DataType::Domain,
            Self::Hex(_) => DataType::Hex,
        }
    }

    /// Reads the text form of a value of type `dt` (the whole text: one token, a quoted
    /// string, or for `t`/`td`/`hex` several).
    pub fn parse(dt: DataType, text: &str) -> Result<Self, ValueError> {
        let err = || bad(dt, text);
        // A number the type cannot hold is a range error, anything else not a number a text
        // error.
        let range = |above: bool| ValueError::Range {
            data_type: dt,
            text: text.chars().take(40).collect(),
            above,
        };
        let not_held = || match integer_shape(text) {
            Some(negative) => range(!negative),
            None => err(),
        };
        let int = |min: i64, max: i64| match parse_signed(text) {
            Some(v) if v < min => Err(range(false)),
            Some(v) if v > max => Err(range(true)),
            Some(v) => Ok(v),
            None => Err(not_held()),
        };
        let uint = |max: u64| match parse_unsigned(text) {
            Some(v) if v > max => Err(range(true)),
            Some(v) => Ok(v),
            None => Err(not_held()),
        };
        Ok(match dt {
            DataType::Bool => match text {
                "0" | "false" | "FALSE" => Self::Bool(false),
                "1" | "true" | "TRUE" => Self::Bool(true),
                _ => return Err(err()),
            },
            DataType::I8 => Self::I8(int(i8::MIN.into(), i8::MAX.into())? as i8),
            DataType::I16 => Self::I16(int(i16::MIN.into(), i16::MAX.into())? as i16),
            DataType::I32 => Self::I32(int(i32::MIN.into(), i32::MAX.into())? as i32),
            DataType::I64 => Self::I64(int(i64::MIN, i64::MAX)?),
            DataType::U8 => Self::U8(uint(u8::MAX.into())? as u8),
            DataType::U16 => Self::U16(uint(u16::MAX.into())? as u16),
            DataType::U32 => Self::U32(uint(u32::MAX.into())? as u32),
            DataType::U64 => Self::U64(uint(u64::MAX)?),
            DataType::X8 => Self::X8(uint(u8::MAX.into())? as u8),
            DataType::X16 => Self::X16(uint(u16::MAX.into())? as u16),
            DataType::X32 => Self::X32(uint(u32::MAX.into())? as u32),
            DataType::X64 => Self::X64(uint(u64::MAX)?),
            DataType::R32 => Self::R32(parse_real(text).ok_or_else(err)?),
            DataType::R64 => Self::R64(parse_real(text).ok_or_else(err)?),
            DataType::TimeOfDay => Self::TimeOfDay(parse_time(text).ok_or_else(err)?),
            DataType::TimeDifference => Self::TimeDifference(parse_time(text).ok_or_else(err)?),
            DataType::VisibleString => Self::VisibleString(parse_vs(text).ok_or_else(err)?),
            DataType::OctetString => Self::OctetString(base64_decode(text).ok_or_else(err)?),
            DataType::UnicodeString => Self::UnicodeString(base64_decode(text).ok_or_else(err)?),
            DataType::Domain => Self::Domain(base64_decode(text).ok_or_else(err)?),
            DataType::Hex => Self::Hex(parse_hex(text).ok_or_else(err)?),
        })
    }

    /// The bytes an SDO download sends.
    pub fn to_le_bytes(&self) -> Vec<u8> {
        match self {
            Self::Bool(b) => vec![u8::from(*b)],
            Self::I8(v) => v.to_le_bytes().to_vec(),
            Self::I16(v) => v.to_le_bytes().to_vec(),
            Self::I32(v) => v.to_le_bytes().to_vec(),
            Self::I64(v) => v.to_le_bytes().to_vec(),
            Self::U8(v) | Self::X8(v) => v.to_le_bytes().to_vec(),
            Self::U16(v) | Self::X16(v) => v.to_le_bytes().to_vec(),
            Self::U32(v) | Self::X32(v) => v.to_le_bytes().to_vec(),
            Self::U64(v) | Self::X64(v) => v.to_le_bytes().to_vec(),
            Self::R32(v) => v.to_le_bytes().to_vec(),
            Self::R64(v) => v.to_le_bytes().to_vec(),
            Self::TimeOfDay(t) | Self::TimeDifference(t) => {
                let mut b = (t.ms & TIME_MS_MAX).to_le_bytes().to_vec();
                b.extend_from_slice(&t.days.to_le_bytes());
                b
            }
            Self::VisibleString(s) => s.as_bytes().to_vec(),
            Self::OctetString(b) | Self::UnicodeString(b) | Self::Domain(b) | Self::Hex(b) => {
                b.clone()
            }
        }
    }

    /// Decodes uploaded bytes as type `dt`. Fixed-size types need exactly their size; a visible
    /// string ends at its first NUL, and bytes that are not UTF-8 are replaced.
    pub fn from_le_bytes(dt: DataType, bytes: &[u8]) -> Result<Self, ValueError> {
        if let Some(want) = dt.size()
            && bytes.len() != want
        {
            return Err(ValueError::Length {
                data_type: dt,
                want,
                got: bytes.len(),
            });
        }
        let a = |n: usize| {
            let mut x = [0u8; 8];
            x[..n].copy_from_slice(&bytes[..n]);
            x
        };
        let u = |n| u64::from_le_bytes(a(n));
        Ok(match dt {
            DataType::Bool => Self::Bool(bytes[0] != 0),
            DataType::I8 => Self::I8(bytes[0] as i8),
            DataType::I16 => Self::I16(u(2) as u16 as i16),
            DataType::I32 => Self::I32(u(4) as u32 as i32),
            DataType::I64 => Self::I64(u(8) as i64),
            DataType::U8 => Self::U8(bytes[0]),
            DataType::U16 => Self::U16(u(2) as u16),
            DataType::U32 => Self::U32(u(4) as u32),
            DataType::U64 => Self::U64(u(8)),
            DataType::X8 => Self::X8(bytes[0]),
            DataType::X16 => Self::X16(u(2) as u16),
            DataType::X32 => Self::X32(u(4) as u32),
            DataType::X64 => Self::X64(u(8)),
            DataType::R32 => Self::R32(f32::from_bits(u(4) as u32)),
            DataType::R64 => Self::R64(f64::from_bits(u(8))),
            DataType::TimeOfDay | DataType::TimeDifference => {
                let t = Time {
                    ms: (u(4) as u32) & TIME_MS_MAX,
                    days: u16::from_le_bytes([bytes[4], bytes[5]]),
                };
                if dt == DataType::TimeOfDay {
                    Self::TimeOfDay(t)
                } else {
                    Self::TimeDifference(t)
                }
            }
            DataType::VisibleString => {
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                let s = String::from_utf8_lossy(&bytes[..end]);
                // A line protocol cannot carry line ends inside a value.
                Self::VisibleString(s.replace(['\r', '\n'], " "))
            }
            DataType::OctetString => Self::OctetString(bytes.to_vec()),
            DataType::UnicodeString => Self::UnicodeString(bytes.to_vec()),
            DataType::Domain => Self::Domain(bytes.to_vec()),
            DataType::Hex => Self::Hex(bytes.to_vec()),
        })
    }
}

impl fmt::Display for Value {
    /// The text form (see the module docs).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bool(b) => write!(f, "{}", u8::from(*b)),
            Self::I8(v) => write!(f, "{v}"),
            Self::I16(v) => write!(f, "{v}"),
            Self::I32(v) => write!(f, "{v}"),
            Self::I64(v) => write!(f, "{v}"),
            Self::U8(v) => write!(f, "{v}"),
            Self::U16(v) => write!(f, "{v}"),
            Self::U32(v) => write!(f, "{v}"),
            Self::U64(v) => write!(f, "{v}"),
            Self::X8(v) => write!(f, "0x{v:02X}"),
            Self::X16(v) => write!(f, "0x{v:04X}"),
            Self::X32(v) => write!(f, "0x{v:08X}"),
            Self::X64(v) => write!(f, "0x{v:016X}"),
            Self::R32(v) => write!(f, "{v:?}"),
            Self::R64(v) => write!(f, "{v:?}"),
            Self::TimeOfDay(t) | Self::TimeDifference(t) => write!(f, "{} {}", t.days, t.ms),
            Self::VisibleString(s) => {
                f.write_str("\"")?;
                for part in s.split('"').enumerate() {
                    if part.0 > 0 {
                        f.write_str("\"\"")?;
                    }
                    f.write_str(part.1)?;
                }
                f.write_str("\"")
            }
            Self::OctetString(b) | Self::UnicodeString(b) | Self::Domain(b) => {
                f.write_str(&base64_encode(b))
            }
            Self::Hex(b) => {
                for (i, x) in b.iter().enumerate() {
                    if i > 0 {
                        f.write_str(" ")?;
                    }
                    write!(f, "{x:02X}")?;
                }
                Ok(())
            }
        }
    }
}

fn parse_real<T: core::str::FromStr>(text: &str) -> Option<T> {
    // Rust's float syntax, without the words it also takes ("infinity", "nan") spelled
    // differently from its own output: the output forms are "inf", "-inf" and "NaN".
    if text.is_empty()
        || !text
            .bytes()
            .all(|b| b.is_ascii_digit() || b"+-.eE".contains(&b))
            && !matches!(text, "inf" | "-inf" | "NaN")
    {
        return None;
    }
    text.parse().ok()
}

fn parse_time(text: &str) -> Option<Time> {
    let mut it = text.split_ascii_whitespace();
    let days = parse_unsigned(it.next()?)?;
    let ms = parse_unsigned(it.next()?)?;
    if it.next().is_some() || days > u64::from(u16::MAX) || ms > u64::from(TIME_MS_MAX) {
        return None;
    }
    Some(Time {
        days: days as u16,
        ms: ms as u32,
    })
}

/// A quoted string with doubled inner quotes, or one word without quotes or whitespace.
fn parse_vs(text: &str) -> Option<String> {
    // Visible characters and blanks only: a NUL or a line end cannot travel in a line.
    if text.contains(|c: char| c.is_control() && c != '\t') {
        return None;
    }
    match text.strip_prefix('"') {
        Some(rest) => {
            let body = rest.strip_suffix('"')?;
            let mut out = String::with_capacity(body.len());
            let mut chars = body.chars();
            while let Some(c) = chars.next() {
                if c == '"' {
                    // Only a doubled quote may stand inside.
                    if chars.next() != Some('"') {
                        return None;
                    }
                }
                out.push(c);
            }
            Some(out)
        }
        None if !text.is_empty() && !text.contains(|c: char| c.is_whitespace() || c == '"') => {
            Some(text.to_owned())
        }
        None => None,
    }
}

/// Hex bytes as CANopenNode reads them: blank-separated groups of digits, each group read two
/// digits to a byte from the left, a last single digit a byte of its own (`01 2 30 456789`:
/// 01 02 30 45 67 89).
fn parse_hex(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 2);
    for group in text.split([' ', '\t']).filter(|g| !g.is_empty()) {
        if !group.bytes().all(|b| b.is_ascii_hexdigit()) {
            return None;
        }
        for pair in group.as_bytes().chunks(2) {
            out.push(u8::from_str_radix(core::str::from_utf8(pair).ok()?, 16).ok()?);
        }
    }
    Some(out)
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Base64 (RFC 2045 alphabet, `=` padding, no line breaks).
pub fn base64_encode(data: &[u8]) -> String {
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(B64[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Decodes base64 (padded, the RFC 2045 alphabet). `None` for anything else, including
/// non-zero bits after the last byte, so every decoded value has one text form.
pub fn base64_decode(text: &str) -> Option<Vec<u8>> {
    let t = text.as_bytes();
    if !t.len().is_multiple_of(4) {
        return None;
    }
    let val = |c: u8| B64.iter().position(|&x| x == c).map(|p| p as u32);
    let mut out = Vec::with_capacity(t.len() / 4 * 3);
    for (i, q) in t.chunks(4).enumerate() {
        let last = i + 1 == t.len() / 4;
        let pad = q.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 || (pad > 0 && !last) {
            return None;
        }
        let mut n = 0u32;
        for &c in &q[..4 - pad] {
            n = (n << 6) | val(c)?;
        }
        n <<= 6 * pad as u32;
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        let keep = 3 - pad;
        if bytes[keep..].iter().any(|&b| b != 0) {
            return None;
        }
        out.extend_from_slice(&bytes[..keep]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_rfc4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64_encode(plain.as_bytes()), coded);
            assert_eq!(base64_decode(coded).unwrap(), plain.as_bytes());
        }
        assert_eq!(base64_decode("Zg="), None);
        assert_eq!(base64_decode("Zh=="), None, "non-zero trailing bits");
        assert_eq!(base64_decode("Zg==Zg=="), None);
        assert_eq!(base64_decode("Z!=="), None);
    }

    #[test]
    fn text_forms() {
        let p = |dt, t| Value::parse(dt, t).unwrap().to_string();
        assert_eq!(p(DataType::I16, "-300"), "-300");
        assert_eq!(p(DataType::U32, "0x10"), "16");
        assert_eq!(p(DataType::X16, "255"), "0x00FF");
        assert_eq!(p(DataType::VisibleString, "word"), "\"word\"");
        assert_eq!(
            p(DataType::VisibleString, "\"say \"\"hi\"\"\""),
            "\"say \"\"hi\"\"\""
        );
        assert_eq!(p(DataType::R32, "0.1"), "0.1");
        assert_eq!(p(DataType::Hex, "0102 ff"), "01 02 FF");
        // CANopenNode's grouping (its SDO tutorial writes ten bytes this way).
        assert_eq!(
            p(DataType::Hex, "01 2 30 456789 0A b0 0 ff"),
            "01 02 30 45 67 89 0A B0 00 FF"
        );
        assert!(Value::parse(DataType::Hex, "0g").is_err());
        assert_eq!(p(DataType::TimeOfDay, "14000 3600000"), "14000 3600000");
        assert!(Value::parse(DataType::U8, "256").is_err());
        assert!(Value::parse(DataType::I8, "-129").is_err());
        assert_eq!(
            Value::parse(DataType::I64, "-9223372036854775808").unwrap(),
            Value::I64(i64::MIN)
        );
        assert!(Value::parse(DataType::VisibleString, "\"a\"b\"").is_err());
        assert!(Value::parse(DataType::R64, "infinity").is_err());
    }

    #[test]
    fn bytes() {
        let v = Value::parse(DataType::I16, "-2").unwrap();
        assert_eq!(v.to_le_bytes(), [0xFE, 0xFF]);
        assert_eq!(
            Value::from_le_bytes(DataType::I16, &[0xFE, 0xFF]).unwrap(),
            v
        );
        assert!(Value::from_le_bytes(DataType::U32, &[1, 2]).is_err());
        assert_eq!(
            Value::from_le_bytes(DataType::VisibleString, b"ab\0c").unwrap(),
            Value::VisibleString("ab".into())
        );
    }
}
