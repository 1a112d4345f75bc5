//! The CiA 306 EDS text of values (§4.6.3.2): `DefaultValue`, `LowLimit`, `HighLimit` and
//! `ParameterValue` in decimal, `0x` hex or `0` octal, floats, strings, hex byte strings and
//! the time types, with `$NODEID` expressions; and the canonical text the writer emits.
//!
//! The decoder is total: any text gives a value or a typed error, never a panic.

use alloc::string::String;
use alloc::vec::Vec;
use core::fmt::Write as _;

use super::Value;
use crate::types::DataType;

/// Why EDS text could not be decoded into a value of the expected data type.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TextError {
    /// The text is empty (or only `$NODEID+` with nothing after it).
    #[error("empty value")]
    Empty,
    /// Not an integer literal (decimal, `0x` hex or `0` octal).
    #[error("not an integer for {0} (expected decimal, 0x hex or 0-prefixed octal)")]
    InvalidInteger(DataType),
    /// The number does not fit the data type.
    #[error("value out of range for {0}")]
    OutOfRange(DataType),
    /// Not a floating point number or `0x` bit pattern.
    #[error("not a number for {0}")]
    InvalidFloat(DataType),
    /// Not pairs of hex digits.
    #[error("{0} expects pairs of hex digits")]
    InvalidHex(DataType),
    /// A `$NODEID` expression of a form other than `$NODEID`, `$NODEID+N` or `N+$NODEID`.
    #[error("unsupported $NODEID expression (use $NODEID+N or N+$NODEID)")]
    InvalidNodeIdExpression,
    /// `$NODEID` in a value whose type is not an integer.
    #[error("$NODEID is only allowed in integer values, not {0}")]
    NodeIdNotAllowed(DataType),
    /// TIME_OF_DAY / TIME_DIFFERENCE text that is neither `DAYS MS` nor one 48-bit integer.
    #[error("{0} expects `DAYS MS` or one 48-bit integer")]
    InvalidTime(DataType),
    /// The data type has no value encoding.
    #[error("{0} has no basic value encoding")]
    Unsupported(DataType),
}

debug_as_display!(TextError);

/// Non-standard spellings that [`EdsValue::parse`] accepted; the parser reports each as a warning.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TextNotes {
    /// A C integer suffix such as `LL`, `ULL` or `U` was dropped.
    pub c_suffix: bool,
    /// A number with a leading `0` contained the digit 8 or 9 and was read as decimal, not octal.
    pub leading_zero_decimal: bool,
    /// A string value was wrapped in double quotes, which were removed.
    pub quoted: bool,
    /// A REAL value was written as a `0x` bit pattern.
    pub float_bit_pattern: bool,
    /// A signed value was written as an unsigned hex/octal bit pattern (e.g. `0xFFFF` for -1).
    pub twos_complement: bool,
}

impl TextNotes {
    /// True when nothing non-standard was seen.
    pub fn is_clean(&self) -> bool {
        *self == Self::default()
    }
}

/// A value as an EDS/DCF file gives it: a typed [`Value`], possibly relative to the node-ID
/// (`$NODEID+0x180`: `value` holds 0x180 and `node_id_relative` is true).
#[derive(Debug, Clone, PartialEq)]
pub struct EdsValue {
    /// The value, or the offset added to the node-ID when `node_id_relative`.
    pub value: Value,
    /// True when the text contained `$NODEID`.
    pub node_id_relative: bool,
}

impl EdsValue {
    /// A plain value.
    pub fn plain(value: Value) -> Self {
        Self {
            value,
            node_id_relative: false,
        }
    }

    /// Decodes EDS text for `data_type`. Accepts decimal, `0x` hex, `0`-prefixed octal, a sign,
    /// C integer suffixes (`LL`, `ULL`), floats or `0x` float bit patterns, quoted strings, hex
    /// byte strings, and `$NODEID`, `$NODEID+N`, `N+$NODEID` in any case and spacing.
    pub fn parse(data_type: DataType, text: &str) -> Result<(Self, TextNotes), TextError> {
        let mut notes = TextNotes::default();
        let text = trim(text);
        if let Some(pos) = find_node_id(text) {
            if data_type.integer_bits().is_none() || data_type == DataType::Boolean {
                return Err(TextError::NodeIdNotAllowed(data_type));
            }
            let before = text.get(..pos).unwrap_or("").trim();
            let after = text.get(pos + NODEID.len()..).unwrap_or("").trim();
            let literal = match (before.is_empty(), after.is_empty()) {
                (true, true) => "0",
                (true, false) => after
                    .strip_prefix('+')
                    .ok_or(TextError::InvalidNodeIdExpression)?,
                (false, true) => before
                    .strip_suffix('+')
                    .ok_or(TextError::InvalidNodeIdExpression)?,
                (false, false) => return Err(TextError::InvalidNodeIdExpression),
            };
            if literal.contains(['$', '+']) {
                return Err(TextError::InvalidNodeIdExpression);
            }
            let literal = literal.trim();
            if literal.is_empty() {
                return Err(TextError::Empty);
            }
            let value = parse_integer(data_type, literal, &mut notes)?;
            return Ok((
                Self {
                    value,
                    node_id_relative: true,
                },
                notes,
            ));
        }
        let value = parse_text(data_type, text, &mut notes)?;
        Ok((Self::plain(value), notes))
    }

    /// The value with `$NODEID` replaced by `node_id` (wrapping within the data type's width).
    pub fn resolve(&self, node_id: u8) -> Value {
        if !self.node_id_relative {
            return self.value.clone();
        }
        match self.value.as_i128() {
            Some(v) => Value::from_i128_wrapping(self.value.data_type(), v + i128::from(node_id))
                .unwrap_or_else(|| self.value.clone()),
            None => self.value.clone(),
        }
    }

    /// The canonical EDS text: `$NODEID+0x180` for node-relative values, else
    /// [`Value::to_eds_text`].
    pub fn to_eds_text(&self) -> String {
        if self.node_id_relative {
            let mut s = String::from("$NODEID+");
            s.push_str(&self.value.to_eds_text());
            s
        } else {
            self.value.to_eds_text()
        }
    }
}

/// `str::trim`, skipped when the text visibly has nothing to trim (the parser hands over
/// trimmed text, so this is the common case).
pub(crate) fn trim(text: &str) -> &str {
    match (text.as_bytes().first(), text.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => text,
        _ => text.trim(),
    }
}

const NODEID: &str = "$NODEID";

fn find_node_id(text: &str) -> Option<usize> {
    // A plain byte test: values are short, and `str::contains(char)` sets up a searcher.
    if !text.as_bytes().contains(&b'$') {
        return None;
    }
    let b = text.as_bytes();
    if b.len() < NODEID.len() {
        return None;
    }
    (0..=b.len() - NODEID.len()).find(|&i| {
        b.get(i..i + NODEID.len())
            .is_some_and(|w| w.eq_ignore_ascii_case(NODEID.as_bytes()))
    })
}

/// Splits sign, radix and digits of an integer literal and returns the signed magnitude.
pub(crate) fn parse_int_literal(text: &str, notes: &mut TextNotes) -> Option<(i128, bool)> {
    let mut s = trim(text);
    let negative = if let Some(r) = s.strip_prefix('-') {
        s = r.trim_start();
        true
    } else if let Some(r) = s.strip_prefix('+') {
        s = r.trim_start();
        false
    } else {
        false
    };
    // C suffixes: U, L, UL, LL, ULL in any case (never hex digits, so safe to strip first).
    let unsuffixed = match s.as_bytes().last() {
        Some(b'u' | b'U' | b'l' | b'L') => s.trim_end_matches(['u', 'U', 'l', 'L']),
        _ => s,
    };
    if unsuffixed.len() != s.len() {
        notes.c_suffix = true;
        s = unsuffixed;
    }
    let (mut radix, mut digits) =
        if let Some(r) = s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
            (16, r)
        } else if s.len() > 1 && s.starts_with('0') {
            (8, &s[1..])
        } else {
            (10, s)
        };
    if digits.is_empty() {
        return None;
    }
    if radix == 8 && digits.bytes().any(|c| c == b'8' || c == b'9') {
        // A leading zero in front of a decimal number ("09"): read as decimal.
        notes.leading_zero_decimal = true;
        radix = 10;
        digits = s;
    }
    let acc = match radix {
        16 => digits_value::<16>(digits)?,
        10 => digits_value::<10>(digits)?,
        _ => digits_value::<8>(digits)?,
    };
    let mag = i128::from(acc);
    Some((if negative { -mag } else { mag }, radix != 10))
}

/// The value of a digit string in base `RADIX` (a constant, so the multiplication is a shift or
/// a cheap constant product). Values beyond `u64::MAX` are refused: checked arithmetic fails
/// exactly then.
fn digits_value<const RADIX: u32>(digits: &str) -> Option<u64> {
    let mut acc: u64 = 0;
    for c in digits.bytes() {
        let d = match c {
            b'0'..=b'9' => c - b'0',
            b'a'..=b'f' => c - b'a' + 10,
            b'A'..=b'F' => c - b'A' + 10,
            _ => return None,
        };
        if u32::from(d) >= RADIX {
            return None;
        }
        acc = acc
            .checked_mul(u64::from(RADIX))?
            .checked_add(u64::from(d))?;
    }
    Some(acc)
}

fn parse_integer(dt: DataType, text: &str, notes: &mut TextNotes) -> Result<Value, TextError> {
    let Some(bits) = dt.integer_bits() else {
        return Err(TextError::Unsupported(dt));
    };
    let (mut v, radix_not_decimal) =
        parse_int_literal(text, notes).ok_or(TextError::InvalidInteger(dt))?;
    if dt == DataType::Boolean {
        return match v {
            0 => Ok(Value::Boolean(false)),
            1 => Ok(Value::Boolean(true)),
            _ => Err(TextError::OutOfRange(dt)),
        };
    }
    if dt.is_signed() {
        let max = (1i128 << (bits - 1)) - 1;
        let min = -(1i128 << (bits - 1));
        if v > max && radix_not_decimal && v < (1i128 << bits) {
            v -= 1i128 << bits;
            notes.twos_complement = true;
        }
        if v < min || v > max {
            return Err(TextError::OutOfRange(dt));
        }
    } else if v < 0 || v >= (1i128 << bits) {
        return Err(TextError::OutOfRange(dt));
    }
    Value::from_i128_wrapping(dt, v).ok_or(TextError::Unsupported(dt))
}

fn parse_text(dt: DataType, text: &str, notes: &mut TextNotes) -> Result<Value, TextError> {
    match dt {
        DataType::Real32 | DataType::Real64 => {
            if text.is_empty() {
                return Err(TextError::Empty);
            }
            if text.starts_with("0x") || text.starts_with("0X") {
                notes.float_bit_pattern = true;
                let (bits, _) =
                    parse_int_literal(text, notes).ok_or(TextError::InvalidFloat(dt))?;
                return if dt == DataType::Real32 {
                    u32::try_from(bits)
                        .map(|b| Value::Real32(f32::from_bits(b)))
                        .map_err(|_| TextError::OutOfRange(dt))
                } else {
                    u64::try_from(bits)
                        .map(|b| Value::Real64(f64::from_bits(b)))
                        .map_err(|_| TextError::OutOfRange(dt))
                };
            }
            if dt == DataType::Real32 {
                text.parse::<f32>()
                    .map(Value::Real32)
                    .map_err(|_| TextError::InvalidFloat(dt))
            } else {
                text.parse::<f64>()
                    .map(Value::Real64)
                    .map_err(|_| TextError::InvalidFloat(dt))
            }
        }
        DataType::VisibleString => Ok(Value::VisibleString(
            unquote(text, notes).as_bytes().to_vec(),
        )),
        DataType::UnicodeString => Ok(Value::UnicodeString(
            unquote(text, notes).encode_utf16().collect(),
        )),
        DataType::OctetString => parse_hex_bytes(dt, text).map(Value::OctetString),
        DataType::Domain => parse_hex_bytes(dt, text).map(Value::Domain),
        DataType::TimeOfDay | DataType::TimeDifference => {
            let (ms, days) = parse_time(dt, text, notes)?;
            Ok(if dt == DataType::TimeOfDay {
                Value::TimeOfDay { ms, days }
            } else {
                Value::TimeDifference { ms, days }
            })
        }
        DataType::Other(_) => Err(TextError::Unsupported(dt)),
        _ => {
            if text.is_empty() {
                return Err(TextError::Empty);
            }
            parse_integer(dt, text, notes)
        }
    }
}

fn unquote<'a>(text: &'a str, notes: &mut TextNotes) -> &'a str {
    if text.len() >= 2 && text.starts_with('"') && text.ends_with('"') {
        notes.quoted = true;
        &text[1..text.len() - 1]
    } else {
        text
    }
}

fn parse_hex_bytes(dt: DataType, text: &str) -> Result<Vec<u8>, TextError> {
    let t = text
        .strip_prefix("0x")
        .or_else(|| text.strip_prefix("0X"))
        .unwrap_or(text);
    let mut out = Vec::with_capacity(t.len() / 2);
    let mut hi: Option<u8> = None;
    for c in t.bytes() {
        if c == b' ' || c == b'\t' {
            continue;
        }
        let d = (c as char).to_digit(16).ok_or(TextError::InvalidHex(dt))? as u8;
        match hi.take() {
            None => hi = Some(d),
            Some(h) => out.push(h << 4 | d),
        }
    }
    if hi.is_some() {
        return Err(TextError::InvalidHex(dt));
    }
    Ok(out)
}

fn parse_time(dt: DataType, text: &str, notes: &mut TextNotes) -> Result<(u32, u16), TextError> {
    if text.is_empty() {
        return Err(TextError::Empty);
    }
    let mut parts = text.split_ascii_whitespace();
    let first = parts.next().ok_or(TextError::Empty)?;
    match (parts.next(), parts.next()) {
        (Some(second), None) => {
            let days = parse_int_literal(first, notes)
                .ok_or(TextError::InvalidTime(dt))?
                .0;
            let ms = parse_int_literal(second, notes)
                .ok_or(TextError::InvalidTime(dt))?
                .0;
            let days = u16::try_from(days).map_err(|_| TextError::OutOfRange(dt))?;
            let ms = u32::try_from(ms).map_err(|_| TextError::OutOfRange(dt))?;
            Ok((ms, days))
        }
        (None, _) => {
            let raw = parse_int_literal(first, notes)
                .ok_or(TextError::InvalidTime(dt))?
                .0;
            if !(0..1i128 << 48).contains(&raw) {
                return Err(TextError::OutOfRange(dt));
            }
            Ok(((raw & 0xFFFF_FFFF) as u32, (raw >> 32) as u16))
        }
        _ => Err(TextError::InvalidTime(dt)),
    }
}

impl Value {
    /// Canonical EDS text: decimal for signed integers and BOOLEAN, `0x` hex for unsigned
    /// integers, shortest round-trip decimal for floats (a `0x` bit pattern for NaN), the text for
    /// strings (quoted when it has surrounding spaces or quotes), hex bytes for OCTET_STRING and
    /// DOMAIN, `DAYS MS` for the time types. [`EdsValue::parse`] reads it back to an equal value.
    pub fn to_eds_text(&self) -> String {
        let mut s = String::new();
        match self {
            Self::Boolean(b) => s.push(if *b { '1' } else { '0' }),
            Self::Real32(v) if v.is_nan() => {
                let _ = write!(s, "0x{:08X}", v.to_bits());
            }
            Self::Real64(v) if v.is_nan() => {
                let _ = write!(s, "0x{:016X}", v.to_bits());
            }
            Self::Real32(v) => {
                let _ = write!(s, "{v:?}");
            }
            Self::Real64(v) => {
                let _ = write!(s, "{v:?}");
            }
            Self::VisibleString(b) => push_quoted(&mut s, &String::from_utf8_lossy(b)),
            Self::UnicodeString(u) => push_quoted(&mut s, &String::from_utf16_lossy(u)),
            Self::OctetString(b) | Self::Domain(b) => {
                for x in b {
                    let _ = write!(s, "{x:02X}");
                }
            }
            Self::TimeOfDay { ms, days } | Self::TimeDifference { ms, days } => {
                let _ = write!(s, "{days} {ms}");
            }
            v if v.data_type().is_signed() => {
                let _ = write!(s, "{}", v.as_i128().unwrap_or(0));
            }
            v => {
                let _ = write!(s, "0x{:X}", v.as_i128().unwrap_or(0));
            }
        }
        s
    }
}

fn push_quoted(s: &mut String, text: &str) {
    let needs = text.starts_with(char::is_whitespace)
        || text.ends_with(char::is_whitespace)
        || (text.starts_with('"') && text.ends_with('"') && text.len() >= 2);
    if needs {
        s.push('"');
        s.push_str(text);
        s.push('"');
    } else {
        s.push_str(text);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec;

    #[test]
    fn int_literal_limits() {
        let mut n = TextNotes::default();
        let max = i128::from(u64::MAX);
        assert_eq!(
            parse_int_literal("0xFFFFFFFFFFFFFFFF", &mut n),
            Some((max, true))
        );
        assert_eq!(
            parse_int_literal("18446744073709551615", &mut n),
            Some((max, false))
        );
        assert_eq!(parse_int_literal("0x10000000000000000", &mut n), None);
        assert_eq!(parse_int_literal("18446744073709551616", &mut n), None);
        assert_eq!(parse_int_literal("-0x1f", &mut n), Some((-31, true)));
        assert_eq!(parse_int_literal("017", &mut n), Some((15, true)));
        assert_eq!(parse_int_literal("0x1G", &mut n), None);
        assert_eq!(parse_int_literal("12a", &mut n), None);
        assert_eq!(parse_int_literal("0x", &mut n), None);
        assert!(n.is_clean());
        assert_eq!(parse_int_literal(" 5LL ", &mut n), Some((5, false)));
        assert!(n.c_suffix);
    }

    fn p(dt: DataType, t: &str) -> EdsValue {
        EdsValue::parse(dt, t).unwrap().0
    }

    #[test]
    fn integer_forms() {
        assert_eq!(
            p(DataType::Unsigned16, "0x1A").value,
            Value::Unsigned16(0x1A)
        );
        assert_eq!(p(DataType::Unsigned16, "26").value, Value::Unsigned16(26));
        assert_eq!(p(DataType::Unsigned16, "032").value, Value::Unsigned16(26));
        assert_eq!(p(DataType::Integer8, "-0x7f").value, Value::Integer8(-127));
        assert_eq!(p(DataType::Integer16, "0xFFFF").value, Value::Integer16(-1));
        assert_eq!(
            p(DataType::Integer24, "-8388608").value,
            Value::Integer24(-8_388_608)
        );
        let (v, n) = EdsValue::parse(DataType::Unsigned64, "0x1234567890ABCDEFLL").unwrap();
        assert_eq!(v.value, Value::Unsigned64(0x1234_5678_90AB_CDEF));
        assert!(n.c_suffix);
        let (v, n) = EdsValue::parse(DataType::Unsigned8, "09").unwrap();
        assert_eq!(v.value, Value::Unsigned8(9));
        assert!(n.leading_zero_decimal);
        assert_eq!(
            EdsValue::parse(DataType::Unsigned8, "256"),
            Err(TextError::OutOfRange(DataType::Unsigned8))
        );
        assert_eq!(
            EdsValue::parse(DataType::Unsigned8, "-1"),
            Err(TextError::OutOfRange(DataType::Unsigned8))
        );
        assert_eq!(
            EdsValue::parse(DataType::Unsigned8, "0x"),
            Err(TextError::InvalidInteger(DataType::Unsigned8))
        );
        assert_eq!(
            EdsValue::parse(DataType::Unsigned8, ""),
            Err(TextError::Empty)
        );
    }

    #[test]
    fn node_id_expressions() {
        for t in [
            "$NODEID+0x180",
            "0x180+$NODEID",
            "$NodeID + 0x180",
            " 0x180 + $nodeid\t",
        ] {
            let v = p(DataType::Unsigned32, t);
            assert!(v.node_id_relative, "{t}");
            assert_eq!(v.value, Value::Unsigned32(0x180));
            assert_eq!(v.resolve(5), Value::Unsigned32(0x185));
        }
        assert_eq!(
            p(DataType::Unsigned8, "$NODEID").resolve(9),
            Value::Unsigned8(9)
        );
        assert_eq!(
            EdsValue::parse(DataType::Unsigned32, "$NODEID*2"),
            Err(TextError::InvalidNodeIdExpression)
        );
        assert_eq!(
            EdsValue::parse(DataType::Real32, "$NODEID+1"),
            Err(TextError::NodeIdNotAllowed(DataType::Real32))
        );
        assert_eq!(
            p(DataType::Unsigned32, "$NODEID+0x180").to_eds_text(),
            "$NODEID+0x180"
        );
    }

    #[test]
    fn floats_strings_times() {
        assert_eq!(p(DataType::Real32, "1.5").value, Value::Real32(1.5));
        assert_eq!(
            p(DataType::Real32, "0x40490FDB").value,
            Value::Real32(f32::from_bits(0x4049_0FDB))
        );
        assert_eq!(p(DataType::Real64, "-2e3").value, Value::Real64(-2000.0));
        assert_eq!(
            p(DataType::VisibleString, "\"Hello, World!\"").value,
            Value::VisibleString(b"Hello, World!".to_vec())
        );
        assert_eq!(
            p(DataType::OctetString, "0123456789abcdef").value,
            Value::OctetString(vec![0x01, 0x23, 0x45, 0x67, 0x89, 0xAB, 0xCD, 0xEF])
        );
        assert_eq!(
            p(DataType::TimeOfDay, "365 43200000").value,
            Value::TimeOfDay {
                ms: 43_200_000,
                days: 365
            }
        );
        assert!(EdsValue::parse(DataType::OctetString, "abc").is_err());
    }
}
