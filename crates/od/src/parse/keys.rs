//! Key tables and value readers. Each kind of section has a table of its canonical keys
//! (CiA 306 spells them in CamelCase; real files in every case) with a hash index built at
//! compile time; a section's entries are resolved into slots once, duplicates and unusual
//! spellings reported. The readers turn a key's text into a number, a flag or a string,
//! reporting what they tolerated.

use alloc::format;
use alloc::vec::Vec;
use core::fmt;

use super::section::Section;
use crate::diag::{DiagnosticKind as K, Echo, Sink};
use crate::model::Extra;
use crate::value::{TextNotes, parse_int_literal};

/// Resolved keys of one section: canonical key slot -> (value, line), duplicates reported.
pub(super) struct Keys<'a, const N: usize> {
    pub(super) slots: [Option<(&'a str, u32)>; N],
    pub(super) extra: Vec<(&'a str, &'a str, u32)>,
}

pub(super) fn resolve_keys<'a, const N: usize>(
    sec: &Section<'_, 'a>,
    table: &KeyTable<N>,
    sink: &mut Sink,
) -> Keys<'a, N> {
    let mut k = Keys {
        slots: [None; N],
        extra: Vec::new(),
    };
    for e in sec.entries.iter() {
        match table.slot(e.key) {
            Some((i, exact)) => {
                let canon = table.keys.get(i).copied().unwrap_or("");
                if !exact {
                    sink.warn(
                        K::Style,
                        e.line,
                        format!("key `{}` should be spelled `{canon}`", Echo(e.key)),
                    );
                }
                if let Some(Some((_, first))) = k.slots.get(i) {
                    sink.warn(
                        K::Duplicate,
                        e.line,
                        format!(
                            "key `{canon}` given again in [{}] (first at line {first}); this value wins",
                            Echo(sec.name)
                        ),
                    );
                }
                if let Some(s) = k.slots.get_mut(i) {
                    *s = Some((e.value, e.line));
                }
            }
            None => k.extra.push((e.key, e.value, e.line)),
        }
    }
    dedup_extra(&mut k.extra, sec.name, sink);
    k
}

/// The canonical keys of one kind of section with a small hash index built at compile time,
/// so that a key is found with one hash and (almost always) one comparison. Keys match
/// ignoring ASCII case, as real files spell them in every case.
pub(super) struct KeyTable<const N: usize> {
    pub(super) keys: [&'static str; N],
    /// Hash slot -> position in `keys`, or `EMPTY`; linear probing.
    pub(super) index: [u8; KeyTable::<0>::SLOTS],
}

impl<const N: usize> KeyTable<N> {
    const SLOTS: usize = 64;
    const EMPTY: u8 = u8::MAX;

    /// The hash slot of a key: a fingerprint that is the same for all ASCII case spellings
    /// (length, first, second and last bytes with bit 5 set, which lower-cases letters and
    /// may merge some other bytes: that only costs a comparison), mixed and cut to six bits.
    const fn hash(key: &[u8]) -> usize {
        let n = key.len();
        if n == 0 {
            return 0;
        }
        let len = if n > 255 { 255 } else { n as u32 };
        let second = if n > 1 { key[1] } else { 0 };
        let sig = len
            | ((key[0] | 0x20) as u32) << 8
            | ((second | 0x20) as u32) << 16
            | ((key[n - 1] | 0x20) as u32) << 24;
        (sig.wrapping_mul(0x9E37_79B1) >> 26) as usize
    }

    pub(super) const fn new(keys: [&'static str; N]) -> Self {
        assert!(N < Self::SLOTS / 2, "key table too large for its index");
        let mut index = [Self::EMPTY; KeyTable::<0>::SLOTS];
        let mut i = 0;
        while i < N {
            let mut h = Self::hash(keys[i].as_bytes());
            while index[h] != Self::EMPTY {
                h = (h + 1) % Self::SLOTS;
            }
            index[h] = i as u8;
            i += 1;
        }
        Self { keys, index }
    }

    /// The position of `key` in the table and whether it is spelled exactly so.
    pub(super) fn slot(&self, key: &str) -> Option<(usize, bool)> {
        let key = key.as_bytes();
        let mut h = Self::hash(key);
        // The index is at most half full, so an empty slot ends every probe sequence.
        loop {
            let i = usize::from(*self.index.get(h)?);
            let canon = self.keys.get(i)?.as_bytes();
            // Exact spelling first: the usual case, and a plain (vectorised) comparison.
            if canon == key {
                return Some((i, true));
            }
            if canon.eq_ignore_ascii_case(key) {
                return Some((i, false));
            }
            h = (h + 1) % Self::SLOTS;
        }
    }
}

/// Merges repeated unknown keys (ignoring ASCII case): the first position keeps the last value.
/// Sorting keeps this O(n log n) however many keys a section has.
pub(super) fn dedup_extra(extra: &mut Vec<(&str, &str, u32)>, section: &str, sink: &mut Sink) {
    if extra.len() < 2 {
        return;
    }
    let lower = |k: &str| {
        k.bytes()
            .map(|b| b.to_ascii_lowercase())
            .collect::<Vec<u8>>()
    };
    let mut order: Vec<(Vec<u8>, usize)> = extra
        .iter()
        .enumerate()
        .map(|(i, e)| (lower(e.0), i))
        .collect();
    order.sort();
    let mut drop = alloc::vec![false; extra.len()];
    let mut group_first = 0usize;
    for w in 1..order.len() {
        if order[w].0 == order[group_first].0 {
            let (first, here) = (order[group_first].1, order[w].1);
            sink.warn(
                K::Duplicate,
                extra[here].2,
                format!(
                    "key `{}` given again in [{}] (first at line {}); this value wins",
                    Echo(extra[here].0),
                    Echo(section),
                    extra[first].2
                ),
            );
            extra[first] = extra[here];
            drop[here] = true;
        } else {
            group_first = w;
        }
    }
    let mut i = 0;
    extra.retain(|_| {
        i += 1;
        !drop[i - 1]
    });
}

pub(super) fn extra_owned(extra: &[(&str, &str, u32)]) -> Extra {
    extra
        .iter()
        .map(|(k, v, _)| ((*k).into(), (*v).into()))
        .collect()
}

/// Names an object or sub-object in messages; formatted only when a diagnostic is issued.
#[derive(Debug, Clone, Copy)]
pub(super) struct Where {
    pub(super) index: u16,
    pub(super) sub: Option<u8>,
}

impl fmt::Display for Where {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.sub {
            Some(s) => write!(f, "sub-object {:04X}sub{s:X}", self.index),
            None => write!(f, "object {:04X}", self.index),
        }
    }
}

/// Reports the non-standard spellings a value was read with (usually none: checked inline).
#[inline]
pub(super) fn note_warnings(sink: &mut Sink, line: u32, what: &str, notes: TextNotes) {
    if notes.c_suffix || notes.leading_zero_decimal || notes.quoted {
        report_notes(sink, line, what, notes);
    }
}

#[cold]
pub(super) fn report_notes(sink: &mut Sink, line: u32, what: &str, notes: TextNotes) {
    if notes.c_suffix {
        sink.warn(
            K::Spelling,
            line,
            format!("{}: C integer suffix (LL/U) ignored", Echo(what)),
        );
    }
    if notes.leading_zero_decimal {
        sink.warn(
            K::Spelling,
            line,
            format!(
                "{}: leading 0 means octal in CiA 306, but the digits are decimal; read as decimal",
                Echo(what)
            ),
        );
    }
    if notes.quoted {
        sink.warn(
            K::Spelling,
            line,
            format!("{}: surrounding double quotes removed", Echo(what)),
        );
    }
}

/// An unsigned number for a structural key, or a warning.
pub(super) fn uint(
    sink: &mut Sink,
    (text, line): (&str, u32),
    what: &str,
    max: u64,
) -> Option<u64> {
    let mut notes = TextNotes::default();
    match parse_int_literal(text, &mut notes) {
        Some((v, _)) if v >= 0 && v as u64 <= max => {
            note_warnings(sink, line, what, notes);
            Some(v as u64)
        }
        _ => {
            sink.warn(
                K::Value,
                line,
                format!(
                    "{}=`{}` is not a number in 0..={max}; ignored",
                    Echo(what),
                    Echo(text)
                ),
            );
            None
        }
    }
}

pub(super) fn boolean(sink: &mut Sink, (text, line): (&str, u32), what: &str) -> Option<bool> {
    uint(sink, (text, line), what, u64::MAX).map(|v| {
        if v > 1 {
            sink.warn(
                K::Value,
                line,
                format!("{}={}: expected 0 or 1; read as 1", Echo(what), Echo(text)),
            );
        }
        v != 0
    })
}

/// The text without surrounding double quotes (reported when present).
pub(super) fn unquote<'t>(sink: &mut Sink, (text, line): (&'t str, u32), what: &str) -> &'t str {
    if text.len() >= 2 && text.starts_with('"') && text.ends_with('"') {
        sink.warn(
            K::Spelling,
            line,
            format!("{}: surrounding double quotes removed", Echo(what)),
        );
        &text[1..text.len() - 1]
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::super::build::OBJ_KEYS;
    use super::super::info::{COMM_KEYS, FILE_KEYS};

    #[test]
    fn key_slots_ignore_case_only() {
        for (i, key) in OBJ_KEYS.keys.iter().enumerate() {
            assert_eq!(OBJ_KEYS.slot(key), Some((i, true)));
            let upper = key.to_ascii_uppercase();
            assert_eq!(OBJ_KEYS.slot(&upper), Some((i, false)));
            let lower = key.to_ascii_lowercase();
            assert_eq!(OBJ_KEYS.slot(&lower), Some((i, false)));
        }
        for (i, key) in FILE_KEYS.keys.iter().enumerate() {
            assert_eq!(FILE_KEYS.slot(key), Some((i, true)));
        }
        for (i, key) in COMM_KEYS.keys.iter().enumerate() {
            assert_eq!(COMM_KEYS.slot(key), Some((i, true)));
        }
        // Same length, first, second and last letters as `DataType`, different middle.
        assert_eq!(OBJ_KEYS.slot("DaXaTyXe"), None);
        assert_eq!(OBJ_KEYS.slot(""), None);
        assert_eq!(OBJ_KEYS.slot("ParameterName "), None);
        assert_eq!(OBJ_KEYS.slot("Parameter_Name"), None);
    }
}
