//! How a [`Value`] reads to a person: the value in CANopen terms, without the Rust variant
//! around it (`0`, `24.58`, `Bürkert`, `01 02 0A`, `2026-12-01 19:50:40.123`).
//!
//! | data type | `{}` | `{:#}` |
//! |---|---|---|
//! | BOOLEAN | `true`, `false` | same |
//! | INTEGERn | decimal: `-42` | same |
//! | UNSIGNEDn | decimal: `57` | hex, zero-padded to the type's width: `0x00000039` |
//! | REAL32/64 | shortest decimal that reads back to the same value: `24.58`, `-2000`, `NaN`, `inf`; with an exponent below 1e-5 and from 1e16: `1e-40` | same |
//! | VISIBLE_STRING, UNICODE_STRING | the text, unquoted; control characters escaped (see below) and bytes that are not UTF-8 replaced by U+FFFD `�` | the text in double quotes, control characters, inner quotes and backslashes escaped |
//! | OCTET_STRING, DOMAIN | hex bytes separated by spaces: `01 02 0A` (empty: nothing) | same |
//! | TIME_OF_DAY | date and time since the CiA 301 epoch, 1984-01-01: `2026-12-01 19:50:40.123` | same |
//! | TIME_DIFFERENCE | days and time: `3 d 04:05:06.007` | same |
//!
//! Control characters (Unicode category Cc: U+0000..U+001F, U+007F..U+009F) are the only
//! characters of a text that are escaped, as they would break a line or a terminal: tab, line
//! feed and carriage return as `\t`, `\n`, `\r`, every other one as `\x` and two upper-case
//! hex digits of its code point (`\x00`, `\x1B`, `\x85`). No other escape form is used.
//!
//! Strings print plain because that is what a device name or a serial number is to its
//! reader; the alternate form quotes them for output where an empty or space-padded string
//! must show. For the EDS text, see [`Value::to_eds_text`].

use core::fmt::{self, Write as _};

use super::Value;

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Boolean(b) => f.write_str(if *b { "true" } else { "false" }),
            Self::Real32(v) if exponent(f64::from(*v)) => write!(f, "{v:e}"),
            Self::Real64(v) if exponent(*v) => write!(f, "{v:e}"),
            Self::Real32(v) => write!(f, "{v}"),
            Self::Real64(v) => write!(f, "{v}"),
            Self::VisibleString(bytes) => {
                let chars = bytes.utf8_chunks().flat_map(|chunk| {
                    let bad = (!chunk.invalid().is_empty()).then_some(char::REPLACEMENT_CHARACTER);
                    chunk.valid().chars().chain(bad)
                });
                text(f, chars)
            }
            Self::UnicodeString(units) => text(
                f,
                char::decode_utf16(units.iter().copied())
                    .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER)),
            ),
            Self::OctetString(bytes) | Self::Domain(bytes) => {
                for (i, b) in bytes.iter().enumerate() {
                    if i > 0 {
                        f.write_char(' ')?;
                    }
                    write!(f, "{b:02X}")?;
                }
                Ok(())
            }
            Self::TimeOfDay { ms, days } => {
                let (y, m, d) = civil_from_days(i64::from(*days) + EPOCH_1984);
                write!(f, "{y:04}-{m:02}-{d:02} ")?;
                clock(f, *ms)
            }
            Self::TimeDifference { ms, days } => {
                write!(f, "{days} d ")?;
                clock(f, *ms)
            }
            v if v.data_type().is_signed() => write!(f, "{}", v.as_i128().unwrap_or(0)),
            v => {
                let n = v.as_i128().unwrap_or(0);
                if f.alternate() {
                    let digits = 2 * v.data_type().size().unwrap_or(1);
                    write!(f, "0x{n:0digits$X}")
                } else {
                    write!(f, "{n}")
                }
            }
        }
    }
}

/// Whether a float reads better with an exponent (`1e-40`, `3.4028235e38`) than in plain
/// decimal, which would run to dozens of digits.
fn exponent(v: f64) -> bool {
    v.is_finite() && v != 0.0 && !(1e-5..1e16).contains(&v.abs())
}

/// Writes text with control characters escaped; quoted (and `"`/`\` escaped) in the alternate
/// form.
fn text(f: &mut fmt::Formatter<'_>, chars: impl Iterator<Item = char>) -> fmt::Result {
    let quoted = f.alternate();
    if quoted {
        f.write_char('"')?;
    }
    for c in chars {
        match c {
            '"' | '\\' if quoted => {
                f.write_char('\\')?;
                f.write_char(c)?;
            }
            '\t' => f.write_str("\\t")?,
            '\n' => f.write_str("\\n")?,
            '\r' => f.write_str("\\r")?,
            c if c.is_control() => write!(f, "\\x{:02X}", u32::from(c))?,
            c => f.write_char(c)?,
        }
    }
    if quoted {
        f.write_char('"')?;
    }
    Ok(())
}

/// `hh:mm:ss.mmm` of the 28-bit milliseconds field (the 4 reserved bits are not shown).
fn clock(f: &mut fmt::Formatter<'_>, ms: u32) -> fmt::Result {
    let ms = ms & 0x0FFF_FFFF;
    let (s, ms) = (ms / 1000, ms % 1000);
    write!(
        f,
        "{:02}:{:02}:{:02}.{ms:03}",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

/// 1984-01-01 in days since 1970-01-01.
const EPOCH_1984: i64 = 5113;

/// The proleptic Gregorian date of a day number counted from 1970-01-01 (the well-known
/// era-based conversion: 400-year eras of 146 097 days, years starting on 1 March).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::format;
    use alloc::string::String;
    use alloc::vec;

    fn show(v: &Value) -> (String, String) {
        (format!("{v}"), format!("{v:#}"))
    }

    #[test]
    fn numbers() {
        assert_eq!(
            show(&Value::Unsigned32(57)),
            ("57".into(), "0x00000039".into())
        );
        assert_eq!(show(&Value::Unsigned8(0)), ("0".into(), "0x00".into()));
        assert_eq!(
            show(&Value::Unsigned24(0x12_3456)),
            ("1193046".into(), "0x123456".into())
        );
        assert_eq!(show(&Value::Integer16(-42)), ("-42".into(), "-42".into()));
        assert_eq!(
            format!("{}", Value::Integer64(i64::MIN)),
            "-9223372036854775808"
        );
        assert_eq!(
            format!("{}", Value::Unsigned64(u64::MAX)),
            "18446744073709551615"
        );
        assert_eq!(format!("{}", Value::Real32(24.58)), "24.58");
        assert_eq!(format!("{}", Value::Real64(-2e3)), "-2000");
        assert_eq!(format!("{}", Value::Real32(f32::NAN)), "NaN");
        assert_eq!(format!("{}", Value::Real32(f32::MAX)), "3.4028235e38");
        assert_eq!(format!("{}", Value::Real64(-1e-40)), "-1e-40");
        assert_eq!(format!("{}", Value::Real64(0.00001)), "0.00001");
        assert_eq!(format!("{}", Value::Boolean(true)), "true");
    }

    #[test]
    fn strings_and_bytes() {
        let name = Value::VisibleString("Bürkert 8605".as_bytes().to_vec());
        assert_eq!(
            show(&name),
            ("Bürkert 8605".into(), "\"Bürkert 8605\"".into())
        );
        let odd = Value::VisibleString(b"a\"b\n\x07\xff".to_vec());
        assert_eq!(
            show(&odd),
            (
                "a\"b\\n\\x07\u{FFFD}".into(),
                "\"a\\\"b\\n\\x07\u{FFFD}\"".into()
            )
        );
        assert_eq!(
            show(&Value::VisibleString(vec![])),
            ("".into(), "\"\"".into())
        );
        let wide = Value::UnicodeString("Ω=1".encode_utf16().collect());
        assert_eq!(format!("{wide}"), "Ω=1");
        assert_eq!(
            format!("{}", Value::OctetString(vec![0x01, 0x02, 0x0A])),
            "01 02 0A"
        );
        assert_eq!(format!("{}", Value::Domain(vec![])), "");
    }

    #[test]
    fn times() {
        // Day 0 of CiA 301 is 1984-01-01; 2026-12-01 is day 15675.
        let t = Value::TimeOfDay { ms: 0, days: 0 };
        assert_eq!(format!("{t}"), "1984-01-01 00:00:00.000");
        let t = Value::TimeOfDay {
            ms: 71_440_123,
            days: 15_675,
        };
        assert_eq!(format!("{t}"), "2026-12-01 19:50:40.123");
        let t = Value::TimeOfDay {
            ms: 0,
            days: u16::MAX,
        };
        assert_eq!(format!("{t}"), "2163-06-06 00:00:00.000");
        let d = Value::TimeDifference {
            ms: 4 * 3_600_000 + 5 * 60_000 + 6_007,
            days: 3,
        };
        assert_eq!(format!("{d}"), "3 d 04:05:06.007");
    }
}
