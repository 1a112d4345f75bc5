//! Bytes to text. CiA 306 files are ASCII; UTF-8 is taken as it is (a byte-order mark is
//! dropped), and a line that is not UTF-8 is read as Windows-1252, the code page of most
//! configuration tools that write such files, with a warning on that line.

use alloc::borrow::Cow;
use alloc::string::String;

use crate::diag::{DiagnosticKind as K, Sink};

/// Windows-1252 characters for bytes 0x80..=0x9F (undefined ones map to the C1 control).
pub(super) const CP1252_80: [char; 32] = [
    '\u{20AC}', '\u{0081}', '\u{201A}', '\u{0192}', '\u{201E}', '\u{2026}', '\u{2020}', '\u{2021}',
    '\u{02C6}', '\u{2030}', '\u{0160}', '\u{2039}', '\u{0152}', '\u{008D}', '\u{017D}', '\u{008F}',
    '\u{0090}', '\u{2018}', '\u{2019}', '\u{201C}', '\u{201D}', '\u{2022}', '\u{2013}', '\u{2014}',
    '\u{02DC}', '\u{2122}', '\u{0161}', '\u{203A}', '\u{0153}', '\u{009D}', '\u{017E}', '\u{0178}',
];

pub(super) fn decode<'a>(input: &'a [u8], sink: &mut Sink) -> Cow<'a, str> {
    let input = input.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(input);
    if let Ok(s) = core::str::from_utf8(input) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(input.len() + input.len() / 8);
    for (i, line) in input.split(|&b| b == b'\n').enumerate() {
        if i > 0 {
            out.push('\n');
        }
        match core::str::from_utf8(line) {
            Ok(s) => out.push_str(s),
            Err(_) => {
                sink.warn(
                    K::Encoding,
                    i as u32 + 1,
                    "line is not valid UTF-8; read as Windows-1252 (save the file as UTF-8 or ASCII)"
                        .into(),
                );
                for &b in line {
                    out.push(match b {
                        0x80..=0x9F => CP1252_80[usize::from(b - 0x80)],
                        _ => char::from(b),
                    });
                }
            }
        }
    }
    Cow::Owned(out)
}
