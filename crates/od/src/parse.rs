//! CiA 306 EDS/DCF parser: bytes in, [`ObjectDictionary`] plus diagnostics out.
//!
//! A hand-written line scanner (one pass over the text, then one pass over the sections; no
//! backtracking, so linear in the input). It reads CiA 306 v1.3 files: `[FileInfo]`,
//! `[DeviceInfo]`, `[DummyUsage]`, `[Comments]`, the three object lists, object and
//! `[xxxxsubN]` sections, `CompactSubObj` with `[xxxxName]`, `[xxxxValue]` and
//! `[xxxxDenotation]`, `[xxxxObjectLinks]`, `[DeviceComissioning]`, and keeps module and tool
//! sections verbatim.
//!
//! Real files deviate from the standard; each accepted deviation is reported as a
//! [`Severity::Warning`] with its line: CRLF is silent, but non-UTF-8 bytes (read as
//! Windows-1252), lower-case hex section names, `Sub` instead of `sub`, duplicate sections and
//! keys (merged, later value wins), key case and spaces, `#` comments, trailing whitespace,
//! quoted strings, C integer suffixes, unusual `EDSVersion` values all produce warnings. Input
//! that cannot be understood (a line that is not a section, key or comment; a non-numeric
//! `ObjectType` or `DataType`; a VAR without `DataType`) is a [`Severity::Error`], and the whole
//! parse fails with every error listed.

use alloc::borrow::Cow;
use alloc::boxed::Box;
use alloc::collections::BTreeMap;
use alloc::format;
use alloc::string::{String, ToString};
use alloc::vec::Vec;
use core::fmt;

use compact_str::{CompactString, format_compact};

use crate::diag::{Diagnostic, DiagnosticKind as K, Severity, Sink};
use crate::model::{
    BAUD_RATES_KBIT, DeviceCommissioning, DeviceInfo, FieldValue, FileInfo, Line, Object,
    ObjectDictionary, RawSection, SubObject, SubObjects,
};
use crate::types::{AccessType, DataType, ObjectCode};
use crate::value::{TextError, TextNotes, parse_int_literal};

/// A successfully parsed file: the model and the warnings.
#[derive(Debug, Clone)]
pub struct Parsed {
    /// The object dictionary.
    pub od: ObjectDictionary,
    /// Warnings, sorted by line.
    pub diagnostics: Vec<Diagnostic>,
}

/// A file that could not be understood: every error (and the warnings) with its line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// All diagnostics, sorted by line; at least one is an error.
    pub diagnostics: Vec<Diagnostic>,
}

impl ParseError {
    /// The errors only.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics
            .iter()
            .filter(|d| d.severity == Severity::Error)
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.errors().count();
        match self.errors().next() {
            Some(first) => write!(f, "{first} ({n} error(s) in total)"),
            None => f.write_str("parse failed"),
        }
    }
}

impl core::error::Error for ParseError {}

/// Parses an EDS or DCF file.
///
/// Never panics; memory is proportional to the input size.
pub fn parse(input: &[u8]) -> Result<Parsed, ParseError> {
    let mut sink = Sink::default();
    let text = decode(input, &mut sink);
    let scan = scan(&text, &mut sink);
    let sections = sections(&scan.entries, &scan.sections);
    let od = build(&sections, scan.subs, scan.built, &mut sink);
    if sink.has_errors() {
        Err(ParseError {
            diagnostics: sink.finish(),
        })
    } else {
        Ok(Parsed {
            od,
            diagnostics: sink.finish(),
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Decoding

/// Windows-1252 characters for bytes 0x80..=0x9F (undefined ones map to the C1 control).
const CP1252_80: [char; 32] = [
    '\u{20AC}', '\u{0081}', '\u{201A}', '\u{0192}', '\u{201E}', '\u{2026}', '\u{2020}', '\u{2021}',
    '\u{02C6}', '\u{2030}', '\u{0160}', '\u{2039}', '\u{0152}', '\u{008D}', '\u{017D}', '\u{008F}',
    '\u{0090}', '\u{2018}', '\u{2019}', '\u{201C}', '\u{201D}', '\u{2022}', '\u{2013}', '\u{2014}',
    '\u{02DC}', '\u{2122}', '\u{0161}', '\u{203A}', '\u{0153}', '\u{009D}', '\u{017E}', '\u{0178}',
];

fn decode<'a>(input: &'a [u8], sink: &mut Sink) -> Cow<'a, str> {
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

// ---------------------------------------------------------------------------------------------
// Scanning

#[derive(Debug, Clone, Copy)]
struct Entry<'a> {
    key: &'a str,
    value: &'a str,
    line: u32,
}

/// A section with its entries (borrowed from the scan's single entry list; copied only when a
/// duplicate section's keys have to be merged).
#[derive(Debug)]
struct Section<'e, 'a> {
    name: &'a str,
    kind: SectionKind,
    line: u32,
    entries: Cow<'e, [Entry<'a>]>,
}

/// A `[xxxxsubN]` section, built into a [`SubObject`] as soon as it ends so that its keys need
/// not be kept (sub sections are most of a file). Its diagnostics are held back until the
/// owning object decides whether the sub-object is used.
#[derive(Debug)]
struct SubRec<'a> {
    name: &'a str,
    line: u32,
    /// Byte span of the section's body (its first line is `line + 1`).
    first: (usize, usize),
    /// False when the section could not be read (its diagnostics say why).
    ok: bool,
    /// Rarely present, so kept out of line: diagnostics and repeated occurrences.
    rare: Option<Box<SubRare>>,
}

/// The uncommon parts of a [`SubRec`].
#[derive(Debug, Default)]
struct SubRare {
    /// Byte span and first line of further occurrences when the section repeats.
    more: Vec<(usize, usize, u32)>,
    diags: Vec<Diagnostic>,
}

impl SubRec<'_> {
    fn rare(&mut self) -> &mut SubRare {
        self.rare.get_or_insert_with(Default::default)
    }
}

/// The sub sections read so far, by (index, sub-index). They almost always come in increasing
/// order, so they are appended to a vector (a tenth of a map's memory and no look-ups); the
/// first one out of order turns the vector into a map.
enum SubRecs<'a> {
    Sorted(Vec<((u16, u8), SubRec<'a>)>),
    Map(BTreeMap<(u16, u8), SubRec<'a>>),
}

impl<'a> SubRecs<'a> {
    fn get(&self, key: (u16, u8)) -> Option<&SubRec<'a>> {
        match self {
            Self::Sorted(v) => v
                .binary_search_by_key(&key, |e| e.0)
                .ok()
                .and_then(|i| v.get(i))
                .map(|e| &e.1),
            Self::Map(m) => m.get(&key),
        }
    }

    fn get_mut(&mut self, key: (u16, u8)) -> Option<&mut SubRec<'a>> {
        match self {
            Self::Sorted(v) => match v.binary_search_by_key(&key, |e| e.0) {
                Ok(i) => v.get_mut(i).map(|e| &mut e.1),
                Err(_) => None,
            },
            Self::Map(m) => m.get_mut(&key),
        }
    }

    /// Adds a record for a key not present yet.
    fn insert(&mut self, key: (u16, u8), rec: SubRec<'a>) {
        match self {
            Self::Sorted(v) if v.last().is_none_or(|e| e.0 < key) => v.push((key, rec)),
            Self::Sorted(v) => {
                let mut m: BTreeMap<_, _> = core::mem::take(v).into_iter().collect();
                m.insert(key, rec);
                *self = Self::Map(m);
            }
            Self::Map(m) => {
                m.insert(key, rec);
            }
        }
    }

    fn into_sorted(self) -> Vec<((u16, u8), SubRec<'a>)> {
        match self {
            Self::Sorted(v) => v,
            Self::Map(m) => m.into_iter().collect(),
        }
    }
}

/// The sub section being read.
struct OpenSub<'a> {
    key: (u16, u8),
    /// Higher than every sub section before it (so certainly not a repetition).
    new_highest: bool,
    name: &'a str,
    line: u32,
    entries_start: usize,
    byte_start: usize,
}

/// A section as scanned: where its entries are in the entry list.
#[derive(Debug)]
struct Scanned<'a> {
    name: &'a str,
    kind: SectionKind,
    line: u32,
    first: (usize, usize),
    /// Further spans when the section appears more than once.
    more: Vec<(usize, usize)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum SectionKind {
    FileInfo,
    DeviceInfo,
    DummyUsage,
    Comments,
    Mandatory,
    Optional,
    Manufacturer,
    Commissioning,
    Object(u16),
    Sub(u16, u8),
    Names(u16),
    Values(u16),
    Denotations(u16),
    Links(u16),
    Other,
}

fn hex4(s: &str) -> Option<u16> {
    if s.len() == 4 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
        u16::from_str_radix(s, 16).ok()
    } else {
        None
    }
}

fn strip_prefix_ci<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    if head.eq_ignore_ascii_case(prefix) {
        s.get(prefix.len()..)
    } else {
        None
    }
}

/// Classifies a section name. Returns the kind and, for tolerated spellings, a note.
/// The sections CiA 306 names, in their canonical spelling.
const NAMED_SECTIONS: [(&str, SectionKind); 8] = [
    ("FileInfo", SectionKind::FileInfo),
    ("DeviceInfo", SectionKind::DeviceInfo),
    ("DummyUsage", SectionKind::DummyUsage),
    ("Comments", SectionKind::Comments),
    ("MandatoryObjects", SectionKind::Mandatory),
    ("OptionalObjects", SectionKind::Optional),
    ("ManufacturerObjects", SectionKind::Manufacturer),
    ("DeviceComissioning", SectionKind::Commissioning),
];

fn classify(name: &str) -> (SectionKind, Option<String>) {
    use SectionKind as S;
    // Object sections are nearly all of a file, and no named section starts with four hex
    // digits: test for an index first.
    let Some(index) = name.get(..4).and_then(hex4) else {
        for (canon, kind) in NAMED_SECTIONS {
            if name.eq_ignore_ascii_case(canon) {
                let note = (name != canon)
                    .then(|| format!("section [{name}] should be spelled [{canon}]"));
                return (kind, note);
            }
        }
        if name.eq_ignore_ascii_case("DeviceCommissioning") {
            return (
                S::Commissioning,
                Some(format!(
                    "section [{name}]: CiA 306 spells it [DeviceComissioning]"
                )),
            );
        }
        return (S::Other, None);
    };
    let lower_hex = name
        .get(..4)
        .is_some_and(|h| h.bytes().any(|b| b.is_ascii_lowercase()));
    let rest = name.get(4..).unwrap_or("");
    let mut note = lower_hex.then(|| format!("section [{name}]: hex digits should be upper case"));
    let kind = if rest.is_empty() {
        S::Object(index)
    } else if let Some(sub) = strip_prefix_ci(rest, "sub") {
        if !rest.starts_with("sub") && note.is_none() {
            note = Some(format!(
                "section [{name}]: CiA 306 writes `sub` in lower case"
            ));
        }
        if sub.is_empty() || sub.len() > 4 || !sub.bytes().all(|b| b.is_ascii_hexdigit()) {
            return (S::Other, None);
        }
        match u16::from_str_radix(sub, 16)
            .ok()
            .and_then(|v| u8::try_from(v).ok())
        {
            Some(s) => {
                if sub.bytes().any(|b| b.is_ascii_lowercase()) && note.is_none() {
                    note = Some(format!("section [{name}]: hex digits should be upper case"));
                }
                S::Sub(index, s)
            }
            None => return (S::Other, None),
        }
    } else if rest.eq_ignore_ascii_case("Name") {
        S::Names(index)
    } else if rest.eq_ignore_ascii_case("Value") {
        S::Values(index)
    } else if rest.eq_ignore_ascii_case("Denotation") {
        S::Denotations(index)
    } else if rest.eq_ignore_ascii_case("ObjectLinks") {
        S::Links(index)
    } else {
        return (S::Other, None);
    };
    (kind, note)
}

/// Splits the text into sections, merging duplicates. Linear in the input.
fn scan<'a>(text: &'a str, sink: &mut Sink) -> Scan<'a> {
    let mut sections: Vec<Scanned<'a>> = Vec::new();
    let mut subs = SubRecs::Sorted(Vec::new());
    let mut built = Built::default();
    let mut open_sub: Option<OpenSub<'a>> = None;
    let mut offset = 0usize;
    // Holds the entries of every section but the sub sections, which are built and dropped
    // as they end.
    let mut entries: Vec<Entry<'a>> = Vec::with_capacity(1024);
    // Sections seen so far -> position in `sections`: by kind, and by upper-cased name for
    // the ones this crate does not interpret (`Other`).
    let mut seen: BTreeMap<SectionKind, usize> = BTreeMap::new();
    let mut seen_other: BTreeMap<String, usize> = BTreeMap::new();
    let mut current: Option<usize> = None;
    let mut hash_comment_reported = false;
    let mut highest_sub: Option<(u16, u8)> = None;
    let mut line_count = 0usize;
    // One byte loop per line finds both its end and its first `=` (lines are short, so this
    // beats a separate search for each).
    let mut lines = Lines { text, offset: 0 };
    while let Some((raw, eq)) = lines.next_line() {
        line_count += 1;
        let line_start = offset;
        offset += raw.len() + 1;
        let line_no = u32::try_from(line_count).unwrap_or(u32::MAX);
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        // Fast path: the usual `Key=Value` line, with nothing to trim and nothing to report,
        // split with four byte tests instead of the trimming and checks below.
        let plain = line.as_bytes();
        let fast = eq.filter(|&e| {
            let ok = |i: usize| plain.get(i).is_some_and(|&c| c > b' ');
            e > 0
                && e < plain.len()
                && plain
                    .first()
                    .is_some_and(|&c| c > b' ' && !matches!(c, b';' | b'#' | b'['))
                && ok(e - 1)
                && (e + 1 == plain.len() || (ok(e + 1) && ok(plain.len() - 1)))
        });
        let (key, value) = if let Some(e) = fast {
            // `=` is ASCII, so both cuts are character boundaries.
            (line.get(..e).unwrap_or(""), line.get(e + 1..).unwrap_or(""))
        } else {
            let trimmed = line.trim_ascii();
            if trimmed.is_empty() || trimmed.starts_with(';') {
                continue;
            }
            if trimmed.starts_with('#') {
                if !hash_comment_reported {
                    sink.warn(
                        K::Spelling,
                        line_no,
                        "`#` comment line; CiA 306 comments start with `;`".into(),
                    );
                    hash_comment_reported = true;
                }
                continue;
            }
            if let Some(body) = trimmed.strip_prefix('[') {
                if let Some(open) = open_sub.take() {
                    finish_sub(open, line_start, &mut entries, &mut subs, &mut built);
                }
                let Some(end) = body.bytes().position(|b| b == b']') else {
                    sink.error(
                        K::Syntax,
                        line_no,
                        format!("section header `{trimmed}` has no closing `]`"),
                    );
                    current = None;
                    continue;
                };
                let name_raw = &body[..end];
                let after = body[end + 1..].trim_ascii();
                if !after.is_empty() && !after.starts_with(';') {
                    sink.warn(
                        K::Syntax,
                        line_no,
                        format!("text `{after}` after section header [{name_raw}] ignored"),
                    );
                }
                let name = name_raw.trim_ascii();
                if name != name_raw {
                    sink.warn(
                        K::Spelling,
                        line_no,
                        format!("spaces inside section header [{name_raw}]"),
                    );
                }
                let (kind, note) = classify(name);
                if let Some(n) = note {
                    sink.warn(K::Spelling, line_no, n);
                }
                if let SectionKind::Sub(i, s) = kind {
                    // Sub sections usually come in increasing order: one beyond the highest seen
                    // so far cannot be a repetition, and needs no look-up.
                    let new_highest = highest_sub < Some((i, s));
                    if new_highest {
                        highest_sub = Some((i, s));
                    } else if let Some(rec) = subs.get((i, s)) {
                        sink.warn(
                            K::Duplicate,
                            line_no,
                            format!(
                                "section [{name}] appears again (first at line {}); keys are merged and later values win",
                                rec.line
                            ),
                        );
                    }
                    open_sub = Some(OpenSub {
                        key: (i, s),
                        new_highest,
                        name,
                        line: line_no,
                        entries_start: entries.len(),
                        byte_start: offset.min(text.len()),
                    });
                    current = None;
                    continue;
                }
                let other = (kind == SectionKind::Other).then(|| name.to_ascii_uppercase());
                let known = match &other {
                    Some(upper) => seen_other.get(upper),
                    None => seen.get(&kind),
                };
                if let Some(&pos) = known {
                    let first = sections.get(pos).map_or(0, |s| s.line);
                    sink.warn(
                        K::Duplicate,
                        line_no,
                        format!(
                            "section [{name}] appears again (first at line {first}); keys are merged and later values win"
                        ),
                    );
                    if let Some(sec) = sections.get_mut(pos) {
                        sec.more.push((entries.len(), entries.len()));
                    }
                    current = Some(pos);
                } else {
                    match other {
                        Some(upper) => seen_other.insert(upper, sections.len()),
                        None => seen.insert(kind, sections.len()),
                    };
                    current = Some(sections.len());
                    sections.push(Scanned {
                        name,
                        kind,
                        line: line_no,
                        first: (entries.len(), entries.len()),
                        more: Vec::new(),
                    });
                }
                continue;
            }
            let Some(eq) = eq.filter(|&e| e < line.len()) else {
                sink.error(
                    K::Syntax,
                    line_no,
                    format!(
                        "`{}` is neither a [section] header, a key=value pair nor a `;` comment",
                        truncate(trimmed)
                    ),
                );
                continue;
            };
            let key_raw = &line[..eq];
            let value_raw = &line[eq + 1..];
            let key = key_raw.trim_ascii();
            if key.is_empty() {
                sink.error(
                    K::Syntax,
                    line_no,
                    format!("`{}` has an empty key", truncate(trimmed)),
                );
                continue;
            }
            if key.len() != key_raw.len() {
                sink.warn(K::Spelling, line_no, format!("spaces around key `{key}`"));
            }
            let value = value_raw.trim_ascii();
            if value.len() != value_raw.len() {
                if value_raw.trim_ascii_end().len() != value_raw.len() {
                    sink.warn(
                        K::Spelling,
                        line_no,
                        format!("trailing whitespace after `{key}=` value"),
                    );
                } else {
                    sink.warn(K::Spelling, line_no, format!("spaces after `{key}=`"));
                }
            }
            (key, value)
        };
        if open_sub.is_some() {
            entries.push(Entry {
                key,
                value,
                line: line_no,
            });
            continue;
        }
        match current.and_then(|c| sections.get_mut(c)) {
            Some(sec) => {
                entries.push(Entry {
                    key,
                    value,
                    line: line_no,
                });
                // The span being filled is always the section's last one.
                let end = entries.len();
                match sec.more.last_mut() {
                    Some(span) => span.1 = end,
                    None => sec.first.1 = end,
                }
            }
            None => sink.error(
                K::Syntax,
                line_no,
                format!("key `{key}` before the first [section] header"),
            ),
        }
    }
    if let Some(open) = open_sub.take() {
        finish_sub(open, text.len(), &mut entries, &mut subs, &mut built);
    }
    let mut built = built.into_map();
    let mut subs = subs.into_sorted();
    rebuild_repeated(text, &mut subs, &mut built);
    Scan {
        entries,
        sections,
        subs,
        built,
    }
}

/// Splits text into lines like `str::split('\n')` (a final piece after the last newline, even
/// if empty), with the position of each line's first `=`. Reads eight bytes at a time and
/// finds both bytes in each word with bit arithmetic (lines are short: one pass over a line
/// beats two `memchr` calls, and both beat a byte loop, the parser's largest single cost once).
struct Lines<'a> {
    text: &'a str,
    /// Start of the next line; past the end when done.
    offset: usize,
}

/// `0x01` in every byte of a word.
const ONES: u64 = u64::from_le_bytes([1; 8]);

/// A word whose lowest set bit is the high bit of the first byte of `w` equal to `b`, or zero
/// when no byte is (bits above the first match may be set spuriously; they are never read).
const fn find_byte(w: u64, b: u8) -> u64 {
    let x = w ^ (ONES * b as u64);
    x.wrapping_sub(ONES) & !x & (ONES << 7)
}

impl<'a> Lines<'a> {
    fn next_line(&mut self) -> Option<(&'a str, Option<usize>)> {
        let rest = self.text.as_bytes().get(self.offset..)?;
        let mut eq = None;
        let mut i = 0;
        let end = loop {
            let Some(word) = rest.get(i..i + 8).and_then(|c| <[u8; 8]>::try_from(c).ok()) else {
                // Fewer than eight bytes left: byte by byte.
                let tail = rest.get(i..).unwrap_or(&[]);
                let nl = tail
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(rest.len(), |p| i + p);
                if eq.is_none() {
                    eq = rest
                        .get(i..nl)
                        .and_then(|t| t.iter().position(|&c| c == b'='));
                    eq = eq.map(|p| i + p);
                }
                break nl;
            };
            let w = u64::from_le_bytes(word);
            let nl = find_byte(w, b'\n');
            let nl_at = (nl != 0).then(|| i + (nl.trailing_zeros() / 8) as usize);
            if eq.is_none() {
                let e = find_byte(w, b'=');
                if e != 0 {
                    let at = i + (e.trailing_zeros() / 8) as usize;
                    if nl_at.is_none_or(|n| at < n) {
                        eq = Some(at);
                    }
                }
            }
            if let Some(n) = nl_at {
                break n;
            }
            i += 8;
        };
        // `\n` and `=` are ASCII, so both positions are character boundaries.
        let line = self.text.get(self.offset..self.offset + end).unwrap_or("");
        self.offset += end + 1;
        Some((line, eq))
    }
}

/// What [`scan`] returns: the entries of all sections but sub sections, and the built
/// sub-objects.
struct Scan<'a> {
    entries: Vec<Entry<'a>>,
    sections: Vec<Scanned<'a>>,
    /// In (index, sub-index) order.
    subs: Vec<((u16, u8), SubRec<'a>)>,
    /// The sub-objects read, per index, in file order: the vectors become the objects' storage.
    built: BTreeMap<u16, Vec<SubObject>>,
}

/// The sub-objects built so far, per index, in file order. The list being filled (sub
/// sections of one object usually follow each other) is kept out of the map, so that a map
/// look-up is needed only when the index changes.
#[derive(Default)]
struct Built {
    map: BTreeMap<u16, Vec<SubObject>>,
    current: Option<(u16, Vec<SubObject>)>,
}

impl Built {
    fn list(&mut self, index: u16) -> &mut Vec<SubObject> {
        match &mut self.current {
            Some((i, _)) if *i == index => {}
            current => {
                let list = self.map.remove(&index).unwrap_or_default();
                if let Some((i, done)) = current.replace((index, list)) {
                    self.map.insert(i, done);
                }
            }
        }
        &mut self.current.get_or_insert_with(|| (index, Vec::new())).1
    }

    fn into_map(mut self) -> BTreeMap<u16, Vec<SubObject>> {
        if let Some((i, list)) = self.current.take() {
            self.map.insert(i, list);
        }
        self.map
    }
}

/// Builds the sub-object of a sub section that just ended and drops its entries. A repeated
/// section is rebuilt from all its occurrences, re-read from the text.
fn finish_sub<'a>(
    open: OpenSub<'a>,
    byte_end: usize,
    entries: &mut Vec<Entry<'a>>,
    subs: &mut SubRecs<'a>,
    built: &mut Built,
) {
    let byte_end = byte_end.max(open.byte_start);
    let mut local = Sink::default();
    let index = open.key.0;
    let list = built.list(index);
    let existing = if open.new_highest {
        None
    } else {
        subs.get_mut(open.key)
    };
    match existing {
        None => {
            let own = entries.get(open.entries_start..).unwrap_or(&[]);
            let sub = build_sub(open.key, open.name, open.line, own, &mut local);
            let ok = sub.is_some();
            if let Some(sub) = sub {
                if list.is_empty() && sub.sub_index == 0 {
                    // Sub-index 0 usually gives the highest sub-index: size the list once.
                    let highest = sub.default_value.as_ref().and_then(|f| f.resolve(0));
                    if let Some(n) = highest
                        .and_then(|v| v.as_i128())
                        .filter(|n| (0..=255).contains(n))
                    {
                        list.reserve_exact(n as usize + 1);
                    }
                }
                list.push(sub);
            }
            let rare = (!local.list.is_empty()).then(|| {
                Box::new(SubRare {
                    more: Vec::new(),
                    diags: local.list,
                })
            });
            subs.insert(
                open.key,
                SubRec {
                    name: open.name,
                    line: open.line,
                    first: (open.byte_start, byte_end),
                    ok,
                    rare,
                },
            );
        }
        Some(rec) => {
            // Rebuilt once, from all occurrences, when the scan ends (`rebuild_repeated`).
            rec.rare()
                .more
                .push((open.byte_start, byte_end, open.line + 1));
        }
    }
    entries.truncate(open.entries_start);
}

/// Rebuilds every sub section that appeared more than once from all its occurrences (keys
/// merged, later values win). Each occurrence is re-read once, so this stays linear.
fn rebuild_repeated<'a>(
    text: &'a str,
    subs: &mut [((u16, u8), SubRec<'a>)],
    built: &mut BTreeMap<u16, Vec<SubObject>>,
) {
    for ((index, s), rec) in subs.iter_mut() {
        let (index, s) = (*index, *s);
        let Some(rare) = rec.rare.as_mut().filter(|r| !r.more.is_empty()) else {
            continue;
        };
        let mut all = Vec::new();
        let (a, b) = rec.first;
        rescan(text.get(a..b).unwrap_or(""), rec.line + 1, &mut all);
        for &(a, b, first_line) in &rare.more {
            rescan(text.get(a..b).unwrap_or(""), first_line, &mut all);
        }
        let mut local = Sink::default();
        let sub = build_sub((index, s), rec.name, rec.line, &all, &mut local);
        let list = built.entry(index).or_default();
        list.retain(|x| x.sub_index != s);
        rec.ok = sub.is_some();
        list.extend(sub);
        rare.diags = local.list;
    }
}

/// Re-reads the `key=value` lines of a section body (already reported on by [`scan`]).
fn rescan<'a>(body: &'a str, first_line: u32, out: &mut Vec<Entry<'a>>) {
    for (i, raw) in body.split('\n').enumerate() {
        let line = raw.trim_ascii();
        if line.is_empty() || line.starts_with(';') || line.starts_with('#') {
            continue;
        }
        if let Some((k, v)) = line.split_once('=') {
            let k = k.trim_ascii();
            if !k.is_empty() {
                out.push(Entry {
                    key: k,
                    value: v.trim_ascii(),
                    line: first_line.saturating_add(i as u32),
                });
            }
        }
    }
}

/// Reads one sub section into a [`SubObject`].
fn build_sub(
    (index, s): (u16, u8),
    name: &str,
    line: u32,
    entries: &[Entry<'_>],
    sink: &mut Sink,
) -> Option<SubObject> {
    let sec = Section {
        name,
        kind: SectionKind::Sub(index, s),
        line,
        entries: Cow::Borrowed(entries),
    };
    let swhat = Where {
        index,
        sub: Some(s),
    };
    let sk = resolve_keys(&sec, &OBJ_KEYS, sink);
    let scode = object_code(sink, &sk, swhat)?;
    let sub = sub_object(sink, &sk, s, scode, line, swhat)?;
    if let Some((_, l)) = sk.slots[P_SUBNUMBER].or(sk.slots[P_COMPACT]) {
        sink.warn(
            K::Structure,
            l,
            format!("{swhat}: SubNumber/CompactSubObj on a sub-object ignored"),
        );
    }
    Some(sub)
}

/// Borrows each section's entries from the entry list (merging duplicate sections' spans).
fn sections<'e, 'a>(entries: &'e [Entry<'a>], scanned: &[Scanned<'a>]) -> Vec<Section<'e, 'a>> {
    scanned
        .iter()
        .map(|s| {
            let span = |(a, b): (usize, usize)| entries.get(a..b).unwrap_or(&[]);
            let entries = if s.more.is_empty() {
                Cow::Borrowed(span(s.first))
            } else {
                let mut all = span(s.first).to_vec();
                for &m in &s.more {
                    all.extend_from_slice(span(m));
                }
                Cow::Owned(all)
            };
            Section {
                name: s.name,
                kind: s.kind,
                line: s.line,
                entries,
            }
        })
        .collect()
}

fn truncate(s: &str) -> &str {
    match s.char_indices().nth(60) {
        Some((i, _)) => &s[..i],
        None => s,
    }
}

// ---------------------------------------------------------------------------------------------
// Building the model

/// Resolved keys of one section: canonical key slot -> (value, line), duplicates reported.
struct Keys<'a, const N: usize> {
    slots: [Option<(&'a str, u32)>; N],
    extra: Vec<(&'a str, &'a str, u32)>,
}

fn resolve_keys<'a, const N: usize>(
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
                        K::Spelling,
                        e.line,
                        format!("key `{}` should be spelled `{canon}`", e.key),
                    );
                }
                if let Some(Some((_, first))) = k.slots.get(i) {
                    sink.warn(
                        K::Duplicate,
                        e.line,
                        format!(
                            "key `{canon}` given again in [{}] (first at line {first}); this value wins",
                            sec.name
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
struct KeyTable<const N: usize> {
    keys: [&'static str; N],
    /// Hash slot -> position in `keys`, or `EMPTY`; linear probing.
    index: [u8; KeyTable::<0>::SLOTS],
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

    const fn new(keys: [&'static str; N]) -> Self {
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
    fn slot(&self, key: &str) -> Option<(usize, bool)> {
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
fn dedup_extra(extra: &mut Vec<(&str, &str, u32)>, section: &str, sink: &mut Sink) {
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
                    "key `{}` given again in [{section}] (first at line {}); this value wins",
                    extra[here].0, extra[first].2
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

fn extra_owned(extra: &[(&str, &str, u32)]) -> Vec<(String, String)> {
    extra
        .iter()
        .map(|(k, v, _)| ((*k).to_string(), (*v).to_string()))
        .collect()
}

/// Names an object or sub-object in messages; formatted only when a diagnostic is issued.
#[derive(Debug, Clone, Copy)]
struct Where {
    index: u16,
    sub: Option<u8>,
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
fn note_warnings(sink: &mut Sink, line: u32, what: &str, notes: TextNotes) {
    if notes.c_suffix || notes.leading_zero_decimal || notes.quoted {
        report_notes(sink, line, what, notes);
    }
}

#[cold]
fn report_notes(sink: &mut Sink, line: u32, what: &str, notes: TextNotes) {
    if notes.c_suffix {
        sink.warn(
            K::Spelling,
            line,
            format!("{what}: C integer suffix (LL/U) ignored"),
        );
    }
    if notes.leading_zero_decimal {
        sink.warn(
            K::Spelling,
            line,
            format!("{what}: leading 0 means octal in CiA 306, but the digits are decimal; read as decimal"),
        );
    }
    if notes.quoted {
        sink.warn(
            K::Spelling,
            line,
            format!("{what}: surrounding double quotes removed"),
        );
    }
}

/// An unsigned number for a structural key, or a warning.
fn uint(sink: &mut Sink, (text, line): (&str, u32), what: &str, max: u64) -> Option<u64> {
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
                format!("{what}=`{text}` is not a number in 0..={max}; ignored"),
            );
            None
        }
    }
}

fn boolean(sink: &mut Sink, (text, line): (&str, u32), what: &str) -> Option<bool> {
    uint(sink, (text, line), what, u64::MAX).map(|v| {
        if v > 1 {
            sink.warn(
                K::Value,
                line,
                format!("{what}={text}: expected 0 or 1; read as 1"),
            );
        }
        v != 0
    })
}

/// The text without surrounding double quotes (reported when present).
fn unquote<'t>(sink: &mut Sink, (text, line): (&'t str, u32), what: &str) -> &'t str {
    if text.len() >= 2 && text.starts_with('"') && text.ends_with('"') {
        sink.warn(
            K::Spelling,
            line,
            format!("{what}: surrounding double quotes removed"),
        );
        &text[1..text.len() - 1]
    } else {
        text
    }
}

fn build(
    sections: &[Section<'_, '_>],
    subs: Vec<((u16, u8), SubRec<'_>)>,
    mut built: BTreeMap<u16, Vec<SubObject>>,
    sink: &mut Sink,
) -> ObjectDictionary {
    let mut od = ObjectDictionary::default();
    let mut objects: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut names: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut values: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut denotations: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    let mut links: BTreeMap<u16, &Section<'_, '_>> = BTreeMap::new();
    for sec in sections {
        match sec.kind {
            SectionKind::FileInfo => od.file_info = file_info(sec, sink),
            SectionKind::DeviceInfo => od.device_info = device_info(sec, sink),
            SectionKind::DummyUsage => od.dummy_usage = dummy_usage(sec, sink),
            SectionKind::Comments => od.comments = comments(sec, sink),
            SectionKind::Mandatory => {
                od.mandatory_objects = object_list(sec, sink);
                od.object_list_lines[0] = Line(sec.line);
            }
            SectionKind::Optional => {
                od.optional_objects = object_list(sec, sink);
                od.object_list_lines[1] = Line(sec.line);
            }
            SectionKind::Manufacturer => {
                od.manufacturer_objects = object_list(sec, sink);
                od.object_list_lines[2] = Line(sec.line);
            }
            SectionKind::Commissioning => {
                od.device_commissioning = Some(commissioning(sec, sink));
            }
            SectionKind::Object(i) => {
                objects.insert(i, sec);
            }
            SectionKind::Sub(..) => {}
            SectionKind::Names(i) => {
                names.insert(i, sec);
            }
            SectionKind::Values(i) => {
                values.insert(i, sec);
            }
            SectionKind::Denotations(i) => {
                denotations.insert(i, sec);
            }
            SectionKind::Links(i) => {
                links.insert(i, sec);
            }
            SectionKind::Other => {
                let module = is_module_section(sec.name);
                if !module {
                    sink.warn(
                        K::Structure,
                        sec.line,
                        format!(
                            "section [{}] is not defined by CiA 306; kept verbatim",
                            sec.name
                        ),
                    );
                }
                od.other_sections.push(RawSection {
                    name: sec.name.to_string(),
                    entries: sec
                        .entries
                        .iter()
                        .map(|e| (e.key.to_string(), e.value.to_string()))
                        .collect(),
                    line: Line(sec.line),
                });
            }
        }
    }
    if od.file_info.eds_version.is_none() && objects.is_empty() {
        sink.warn(
            K::Structure,
            1,
            "no [FileInfo] EDSVersion and no objects: is this an EDS file?".into(),
        );
    }

    // Sub sections whose object is missing.
    // Sub sections are grouped by index: look each index up once.
    let mut last_index = None;
    for &((index, _), ref sec) in &subs {
        if last_index == Some(index) {
            continue;
        }
        last_index = Some(index);
        if !objects.contains_key(&index) {
            sink.warn(
                K::Structure,
                sec.line,
                format!(
                    "[{}] has no object section [{index:04X}]; ignored",
                    sec.name
                ),
            );
        }
    }

    // Both maps are in index order: hand each object its sub sections in one merge pass.
    let mut subs = subs.into_iter().peekable();
    for (&index, sec) in &objects {
        let mut own_subs = Vec::new();
        while let Some(((i, _), _)) = subs.peek() {
            if *i > index {
                break;
            }
            if let Some(((i, s), rec)) = subs.next()
                && i == index
            {
                own_subs.push((s, rec));
            }
        }
        let own_built = built.remove(&index).unwrap_or_default();
        if let Some(mut obj) = object(index, sec, own_subs, own_built, sink) {
            if let Some(names_sec) = names.remove(&index) {
                apply_names(&mut obj, names_sec, sink);
            }
            if let Some(values_sec) = values.remove(&index) {
                apply_values(&mut obj, values_sec, sink);
            }
            if let Some(den_sec) = denotations.remove(&index) {
                apply_denotations(&mut obj, den_sec, sink);
            }
            if let Some(link_sec) = links.remove(&index) {
                obj.object_links = object_list(link_sec, sink);
            }
            od.objects.insert(index, obj);
        }
    }
    for sec in names
        .values()
        .chain(values.values())
        .chain(denotations.values())
        .chain(links.values())
    {
        sink.warn(
            K::Structure,
            sec.line,
            format!(
                "[{}] refers to an object with no section; ignored",
                sec.name
            ),
        );
    }
    od
}

fn is_module_section(name: &str) -> bool {
    if name.eq_ignore_ascii_case("SupportedModules")
        || name.eq_ignore_ascii_case("ConnectedModules")
    {
        return true;
    }
    let b = name.as_bytes();
    b.len() > 2 && b[0].eq_ignore_ascii_case(&b'M') && b[1].is_ascii_digit()
}

const OBJ_KEYS: KeyTable<15> = KeyTable::new([
    "ParameterName",
    "ObjectType",
    "DataType",
    "AccessType",
    "PDOMapping",
    "DefaultValue",
    "LowLimit",
    "HighLimit",
    "ParameterValue",
    "Denotation",
    "ObjFlags",
    "SubNumber",
    "CompactSubObj",
    "UploadFile",
    "DownloadFile",
]);
const P_NAME: usize = 0;
const P_OBJTYPE: usize = 1;
const P_DATATYPE: usize = 2;
const P_ACCESS: usize = 3;
const P_PDO: usize = 4;
const P_DEFAULT: usize = 5;
const P_LOW: usize = 6;
const P_HIGH: usize = 7;
const P_PARAM: usize = 8;
const P_DENOTATION: usize = 9;
const P_FLAGS: usize = 10;
const P_SUBNUMBER: usize = 11;
const P_COMPACT: usize = 12;

fn object_code(sink: &mut Sink, k: &Keys<'_, 15>, what: Where) -> Option<ObjectCode> {
    let Some((text, line)) = k.slots[P_OBJTYPE] else {
        return Some(ObjectCode::Var);
    };
    let mut notes = TextNotes::default();
    match parse_int_literal(text, &mut notes) {
        Some((v, _)) if (0..=0xFF).contains(&v) => {
            note_warnings(sink, line, "ObjectType", notes);
            let code = ObjectCode::from_code(v as u8);
            if let ObjectCode::Other(c) = code {
                sink.warn(
                    K::InvalidCode,
                    line,
                    format!("{what}: ObjectType=0x{c:X} is not a CiA 301 object code"),
                );
            }
            Some(code)
        }
        _ => {
            sink.error(
                K::Value,
                line,
                format!(
                    "{what}: ObjectType=`{}` is not a number; write 0x7 (VAR), 0x8 (ARRAY), 0x9 (RECORD) or 0x2 (DOMAIN)",
                    truncate(text)
                ),
            );
            None
        }
    }
}

/// Reads the value keys of a VAR object section or a sub-object section into a [`SubObject`].
fn sub_object(
    sink: &mut Sink,
    k: &Keys<'_, 15>,
    sub_index: u8,
    code: ObjectCode,
    line: u32,
    what: Where,
) -> Option<SubObject> {
    let name = match k.slots[P_NAME] {
        Some(v) => unquote(sink, v, "ParameterName").into(),
        None => {
            sink.warn(K::Structure, line, format!("{what} has no ParameterName"));
            CompactString::default()
        }
    };
    let data_type = match k.slots[P_DATATYPE] {
        Some((text, dline)) => {
            let mut notes = TextNotes::default();
            match parse_int_literal(text, &mut notes) {
                Some((v, _)) if (0..=0xFFFF).contains(&v) => {
                    note_warnings(sink, dline, "DataType", notes);
                    DataType::from_code(v as u16)
                }
                _ => {
                    sink.error(
                        K::Value,
                        dline,
                        format!(
                            "{what}: DataType=`{}` is not a data type index; write e.g. 0x0007 for UNSIGNED32",
                            truncate(text)
                        ),
                    );
                    return None;
                }
            }
        }
        None if code == ObjectCode::Domain => DataType::Domain,
        None => {
            sink.error(
                K::Structure,
                line,
                format!("{what} has no DataType; add e.g. DataType=0x0007 (UNSIGNED32)"),
            );
            return None;
        }
    };
    let mut sub = SubObject::new(sub_index, name, data_type, AccessType::Ro);
    sub.object_code = code;
    sub.line = Line(line);
    match k.slots[P_ACCESS] {
        Some((text, aline)) => match AccessType::from_eds(text) {
            Some(a) => {
                if a.as_str() != text {
                    sink.warn(
                        K::Spelling,
                        aline,
                        format!(
                            "AccessType={text}: CiA 306 writes `{}` in lower case",
                            a.as_str()
                        ),
                    );
                }
                sub.access = a;
            }
            None => {
                sink.warn(
                    K::InvalidCode,
                    aline,
                    format!(
                        "{what}: AccessType=`{}` is none of ro, wo, rw, rwr, rww, const; treated as ro",
                        truncate(text)
                    ),
                );
                sub.extras_mut().access_raw = Some(text.to_string());
            }
        },
        None => {
            sink.warn(
                K::Structure,
                line,
                format!("{what} has no AccessType; treated as ro"),
            );
        }
    }
    if let Some(v) = k.slots[P_PDO] {
        sub.pdo_mapping = boolean(sink, v, "PDOMapping").unwrap_or(false);
    }
    let mut field = |slot: usize, label: &str| -> Option<FieldValue> {
        let (text, fline) = k.slots[slot]?;
        let (f, res) = FieldValue::from_text(data_type, text);
        match res {
            Ok(notes) => note_warnings(sink, fline, label, notes),
            Err(TextError::Empty) => {}
            Err(e) => sink.warn(
                K::Value,
                fline,
                format!(
                    "{what}: {label}=`{}`: {e}; kept as text only",
                    truncate(text)
                ),
            ),
        }
        Some(f)
    };
    sub.default_value = field(P_DEFAULT, "DefaultValue");
    let (low, high) = (field(P_LOW, "LowLimit"), field(P_HIGH, "HighLimit"));
    let param = field(P_PARAM, "ParameterValue");
    let denotation = k.slots[P_DENOTATION].map(|(t, _)| t.to_string());
    if let Some(v) = k.slots[P_FLAGS] {
        sub.obj_flags = uint(sink, v, "ObjFlags", u64::from(u32::MAX)).map(|v| v as u32);
    }
    let files = [13, 14].map(|slot| k.slots[slot].zip(OBJ_KEYS.keys.get(slot)));
    let any_rare = low.is_some()
        || high.is_some()
        || param.is_some()
        || denotation.is_some()
        || files.iter().any(Option::is_some)
        || !k.extra.is_empty();
    if any_rare {
        let x = sub.extras_mut();
        x.low_limit = low;
        x.high_limit = high;
        x.parameter_value = param;
        x.denotation = denotation;
        for ((text, _), key) in files.into_iter().flatten() {
            x.extra.push(((*key).to_string(), text.to_string()));
        }
        x.extra.extend(extra_owned(&k.extra));
    }
    Some(sub)
}

fn object(
    index: u16,
    sec: &Section<'_, '_>,
    sub_secs: Vec<(u8, SubRec<'_>)>,
    built: Vec<SubObject>,
    sink: &mut Sink,
) -> Option<Object> {
    let what = Where { index, sub: None };
    let k = resolve_keys(sec, &OBJ_KEYS, sink);
    let code = object_code(sink, &k, what)?;
    if code.is_simple() || matches!(code, ObjectCode::Other(_)) {
        let sub = sub_object(sink, &k, 0, ObjectCode::Var, sec.line, what)?;
        let mut obj = Object::var(index, sub);
        obj.object_code = code;
        obj.line = Line(sec.line);
        if let Some(v) = k.slots[P_SUBNUMBER] {
            obj.sub_number = uint(sink, v, "SubNumber", 255).map(|v| v as u8);
        }
        if k.slots[P_COMPACT].is_some() {
            sink.warn(
                K::Structure,
                sec.line,
                format!("{what}: CompactSubObj on a VAR ignored"),
            );
        }
        let mut first_ignored = true;
        for (_, s) in sub_secs {
            if first_ignored {
                sink.warn(
                    K::Structure,
                    s.line,
                    format!(
                        "[{}]: {what} is a {}, so its sub sections are ignored",
                        s.name,
                        code.name()
                    ),
                );
                first_ignored = false;
            }
        }
        return Some(obj);
    }

    let name = match k.slots[P_NAME] {
        Some(v) => unquote(sink, v, "ParameterName").into(),
        None => {
            sink.warn(
                K::Structure,
                sec.line,
                format!("{what} has no ParameterName"),
            );
            CompactString::default()
        }
    };
    let mut obj = Object::complex(index, name, code, []);
    obj.sub_number = None;
    obj.line = Line(sec.line);
    if let Some(v) = k.slots[P_SUBNUMBER] {
        obj.sub_number = uint(sink, v, "SubNumber", 255).map(|v| v as u8);
    }
    if let Some(v) = k.slots[P_FLAGS] {
        obj.obj_flags = uint(sink, v, "ObjFlags", u64::from(u32::MAX)).map(|v| v as u32);
    }
    let compact = match k.slots[P_COMPACT] {
        Some(v) => uint(sink, v, "CompactSubObj", 255).map(|v| v as u8),
        None => None,
    };
    let mut ok = true;
    if let Some(n) = compact.filter(|&n| n > 0) {
        // CiA 306 §4.5.2.3: sub-index 0 is the number of entries (UNSIGNED8, ro); sub-indices
        // 1..=n share DataType, AccessType, PDOMapping and values of the object section.
        let count = SubObject::new(0, "NrOfObjects", DataType::Unsigned8, AccessType::Ro)
            .with_default(crate::value::EdsValue::plain(
                crate::value::Value::Unsigned8(n),
            ));
        let mut count = count;
        count.line = Line(sec.line);
        obj.subs.insert(count);
        let mut proto_keys = Keys {
            slots: k.slots,
            extra: Vec::new(),
        };
        proto_keys.slots[P_OBJTYPE] = None;
        proto_keys.slots[P_SUBNUMBER] = None;
        proto_keys.slots[P_COMPACT] = None;
        proto_keys.slots[P_FLAGS] = None;
        match sub_object(sink, &proto_keys, 1, ObjectCode::Var, sec.line, what) {
            Some(proto) => {
                for i in 1..=n {
                    let mut s = proto.clone();
                    s.sub_index = i;
                    s.name = format_compact!("{}{}", obj.name, i);
                    obj.subs.insert(s);
                }
            }
            None => ok = false,
        }
        obj.extra = extra_owned(&k.extra);
    } else {
        // Keys describing values on an ARRAY/RECORD section are kept as they are.
        for slot in [
            P_DATATYPE,
            P_ACCESS,
            P_PDO,
            P_DEFAULT,
            P_LOW,
            P_HIGH,
            P_PARAM,
            P_DENOTATION,
            13,
            14,
        ] {
            if let (Some((text, _)), Some(key)) = (k.slots[slot], OBJ_KEYS.keys.get(slot)) {
                obj.extra.push(((*key).to_string(), text.to_string()));
            }
        }
        obj.extra.extend(extra_owned(&k.extra));
    }
    for (s, rec) in sub_secs {
        for d in rec.rare.map(|r| r.diags).unwrap_or_default() {
            sink.push(d);
        }
        ok &= rec.ok;
        if compact.is_some() && rec.ok && obj.subs.contains(s) {
            sink.warn(
                K::Duplicate,
                rec.line,
                format!(
                    "sub-object {index:04X}sub{s:X} also defined by CompactSubObj; the [{}] section wins",
                    rec.name
                ),
            );
        }
    }
    if obj.subs.is_empty() {
        obj.subs = SubObjects::from(built);
    } else {
        for sub in built {
            obj.subs.insert(sub);
        }
    }
    ok.then_some(obj)
}

/// `[xxxxName]`: `NrOfEntries=n`, then `sub=name` lines.
fn apply_names(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => s.name = value.into(),
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; name ignored",
                    sec.name
                ),
            ),
        },
    );
}

/// `[xxxxValue]`: `NrOfEntries=n`, then `sub=value` lines (DCF `ParameterValue`).
fn apply_values(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => {
                let (f, res) = FieldValue::from_text(s.data_type, value);
                match res {
                    Ok(notes) => note_warnings(sink, line, "value", notes),
                    Err(TextError::Empty) => {}
                    Err(e) => sink.warn(
                        K::Value,
                        line,
                        format!(
                            "[{}] {sub}=`{}`: {e}; kept as text only",
                            sec.name,
                            truncate(value)
                        ),
                    ),
                }
                s.extras_mut().parameter_value = Some(f);
            }
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; value ignored",
                    sec.name
                ),
            ),
        },
    );
}

/// `[xxxxDenotation]`: `NrOfEntries=n`, then `sub=denotation` lines.
fn apply_denotations(obj: &mut Object, sec: &Section<'_, '_>, sink: &mut Sink) {
    for_numbered(
        sec,
        sink,
        "NrOfEntries",
        |sub, value, line, sink| match obj.subs.get_mut(sub) {
            Some(s) => s.extras_mut().denotation = Some(value.to_string()),
            None => sink.warn(
                K::Structure,
                line,
                format!(
                    "[{}]: sub-index {sub} does not exist; denotation ignored",
                    sec.name
                ),
            ),
        },
    );
}

/// Calls `f(n, value, line)` for each `n=value` key (n decimal or 0x hex, 0..=255) of a
/// numbered section; checks the count key.
fn for_numbered(
    sec: &Section<'_, '_>,
    sink: &mut Sink,
    count_key: &str,
    mut f: impl FnMut(u8, &str, u32, &mut Sink),
) {
    let mut count: Option<(u64, u32)> = None;
    let mut seen = 0u64;
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case(count_key) {
            count = uint(sink, (e.value, e.line), count_key, u64::MAX).map(|c| (c, e.line));
            continue;
        }
        let mut notes = TextNotes::default();
        match parse_int_literal(e.key, &mut notes) {
            Some((n, _)) if (0..=255).contains(&n) => {
                seen += 1;
                f(n as u8, e.value, e.line, sink);
            }
            _ => sink.warn(
                K::Structure,
                e.line,
                format!(
                    "[{}]: key `{}` is not a sub-index; ignored",
                    sec.name, e.key
                ),
            ),
        }
    }
    if let Some((c, line)) = count
        && c != seen
    {
        sink.warn(
            K::Structure,
            line,
            format!("[{}]: {count_key}={c} but {seen} entries follow", sec.name),
        );
    }
}

/// `[MandatoryObjects]`-style lists and `[xxxxObjectLinks]`: `SupportedObjects=n` or
/// `ObjectLinks=n`, then `1=0x1000` ...
fn object_list(sec: &Section<'_, '_>, sink: &mut Sink) -> Vec<u16> {
    let mut count: Option<(u64, u32)> = None;
    let mut items: BTreeMap<u64, (u16, u32)> = BTreeMap::new();
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case("SupportedObjects")
            || e.key.eq_ignore_ascii_case("ObjectLinks")
        {
            count = uint(sink, (e.value, e.line), e.key, u64::MAX).map(|c| (c, e.line));
            continue;
        }
        let mut notes = TextNotes::default();
        let Some((n, _)) = parse_int_literal(e.key, &mut notes).filter(|(n, _)| *n >= 0) else {
            sink.warn(
                K::Structure,
                e.line,
                format!(
                    "[{}]: key `{}` is not a list position; ignored",
                    sec.name, e.key
                ),
            );
            continue;
        };
        let Some(index) = uint(sink, (e.value, e.line), "object index", 0xFFFF) else {
            continue;
        };
        if let Some((_, first)) = items.insert(n as u64, (index as u16, e.line)) {
            sink.warn(
                K::Duplicate,
                e.line,
                format!(
                    "[{}]: position {n} given again (first at line {first}); this value wins",
                    sec.name
                ),
            );
        }
    }
    if let Some((c, line)) = count
        && c != items.len() as u64
    {
        sink.warn(
            K::ObjectList,
            line,
            format!(
                "[{}]: count says {c} but {} entries follow",
                sec.name,
                items.len()
            ),
        );
    }
    items.into_values().map(|(i, _)| i).collect()
}

fn comments(sec: &Section<'_, '_>, sink: &mut Sink) -> Vec<String> {
    let mut lines: BTreeMap<u64, String> = BTreeMap::new();
    let mut declared = None;
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case("Lines") {
            declared = uint(sink, (e.value, e.line), "Lines", u64::MAX).map(|c| (c, e.line));
        } else if let Some(n) = strip_prefix_ci(e.key, "Line").and_then(|n| n.parse::<u64>().ok()) {
            lines.insert(n, e.value.to_string());
        } else {
            sink.warn(
                K::Structure,
                e.line,
                format!("[Comments]: key `{}` ignored", e.key),
            );
        }
    }
    if let Some((c, line)) = declared
        && c != lines.len() as u64
    {
        sink.warn(
            K::Structure,
            line,
            format!(
                "[Comments]: Lines={c} but {} LineN keys follow",
                lines.len()
            ),
        );
    }
    lines.into_values().collect()
}

fn dummy_usage(sec: &Section<'_, '_>, sink: &mut Sink) -> BTreeMap<u16, bool> {
    let mut out = BTreeMap::new();
    for e in sec.entries.iter() {
        match strip_prefix_ci(e.key, "Dummy").and_then(hex4) {
            Some(dt) => {
                if let Some(b) = boolean(sink, (e.value, e.line), e.key) {
                    out.insert(dt, b);
                }
            }
            None => sink.warn(
                K::Structure,
                e.line,
                format!("[DummyUsage]: key `{}` ignored", e.key),
            ),
        }
    }
    out
}

const FILE_KEYS: KeyTable<11> = KeyTable::new([
    "FileName",
    "FileVersion",
    "FileRevision",
    "EDSVersion",
    "Description",
    "CreationTime",
    "CreationDate",
    "CreatedBy",
    "ModificationTime",
    "ModificationDate",
    "ModifiedBy",
]);

fn file_info(sec: &Section<'_, '_>, sink: &mut Sink) -> FileInfo {
    let k = resolve_keys(sec, &FILE_KEYS, sink);
    let s = |i: usize| k.slots[i].map(|(t, _)| t.to_string());
    if let Some((v, line)) = k.slots[3]
        && v != "4.0"
    {
        sink.warn(
            K::Spelling,
            line,
            format!("EDSVersion={v}: CiA 306 v1.3 files say 4.0; read as 4.0"),
        );
    }
    FileInfo {
        file_name: s(0),
        file_version: s(1),
        file_revision: s(2),
        eds_version: s(3),
        description: s(4),
        creation_time: s(5),
        creation_date: s(6),
        created_by: s(7),
        modification_time: s(8),
        modification_date: s(9),
        modified_by: s(10),
        extra: extra_owned(&k.extra),
    }
}

const DEVICE_KEYS: KeyTable<23> = KeyTable::new([
    "VendorName",
    "VendorNumber",
    "ProductName",
    "ProductNumber",
    "RevisionNumber",
    "OrderCode",
    "BaudRate_10",
    "BaudRate_20",
    "BaudRate_50",
    "BaudRate_125",
    "BaudRate_250",
    "BaudRate_500",
    "BaudRate_800",
    "BaudRate_1000",
    "SimpleBootUpMaster",
    "SimpleBootUpSlave",
    "Granularity",
    "DynamicChannelsSupported",
    "GroupMessaging",
    "NrOfRXPDO",
    "NrOfTXPDO",
    "LSS_Supported",
    "CompactPDO",
]);

fn device_info(sec: &Section<'_, '_>, sink: &mut Sink) -> DeviceInfo {
    let k = resolve_keys(sec, &DEVICE_KEYS, sink);
    let mut extra = extra_owned(&k.extra);
    // A known key whose value cannot be read is kept verbatim so the file round-trips.
    let mut num = |i: usize, max: u64| -> Option<u64> {
        let v = k.slots[i]?;
        let r = uint(sink, v, DEVICE_KEYS.keys[i], max);
        if r.is_none() {
            extra.push((DEVICE_KEYS.keys[i].to_string(), v.0.to_string()));
        }
        r
    };
    let vendor_number = num(1, u64::from(u32::MAX)).map(|v| v as u32);
    let product_number = num(3, u64::from(u32::MAX)).map(|v| v as u32);
    let revision_number = num(4, u64::from(u32::MAX)).map(|v| v as u32);
    let mut baud_rates = [None; 8];
    for (j, b) in baud_rates.iter_mut().enumerate() {
        *b = num(6 + j, u64::MAX).map(|v| v != 0);
    }
    let simple_boot_up_master = num(14, u64::MAX).map(|v| v != 0);
    let simple_boot_up_slave = num(15, u64::MAX).map(|v| v != 0);
    let granularity = num(16, 64).map(|v| v as u8);
    let dynamic_channels_supported = num(17, 255).map(|v| v as u8);
    let group_messaging = num(18, u64::MAX).map(|v| v != 0);
    let nr_of_rx_pdo = num(19, 512).map(|v| v as u16);
    let nr_of_tx_pdo = num(20, 512).map(|v| v as u16);
    let lss_supported = num(21, u64::MAX).map(|v| v != 0);
    let compact_pdo = num(22, 255).map(|v| v as u8);
    let vendor_name = k.slots[0].map(|v| unquote(sink, v, "VendorName").to_string());
    let product_name = k.slots[2].map(|v| unquote(sink, v, "ProductName").to_string());
    let order_code = k.slots[5].map(|v| unquote(sink, v, "OrderCode").to_string());
    let _ = BAUD_RATES_KBIT;
    DeviceInfo {
        vendor_name,
        vendor_number,
        product_name,
        product_number,
        revision_number,
        order_code,
        baud_rates,
        simple_boot_up_master,
        simple_boot_up_slave,
        granularity,
        dynamic_channels_supported,
        group_messaging,
        nr_of_rx_pdo,
        nr_of_tx_pdo,
        lss_supported,
        compact_pdo,
        extra,
    }
}

const COMM_KEYS: KeyTable<7> = KeyTable::new([
    "NodeID",
    "NodeName",
    "Baudrate",
    "NetNumber",
    "NetworkName",
    "CANopenManager",
    "LSS_SerialNumber",
]);

fn commissioning(sec: &Section<'_, '_>, sink: &mut Sink) -> DeviceCommissioning {
    let k = resolve_keys(sec, &COMM_KEYS, sink);
    let mut extra = extra_owned(&k.extra);
    let mut num = |i: usize, max: u64| -> Option<u64> {
        let v = k.slots[i]?;
        let r = uint(sink, v, COMM_KEYS.keys[i], max);
        if r.is_none() {
            extra.push((COMM_KEYS.keys[i].to_string(), v.0.to_string()));
        }
        r
    };
    let node_id = num(0, 255).map(|v| v as u8);
    let baudrate = num(2, 0xFFFF).map(|v| v as u16);
    let net_number = num(3, u64::from(u32::MAX)).map(|v| v as u32);
    let canopen_manager = num(5, u64::MAX).map(|v| v != 0);
    let lss_serial_number = num(6, u64::from(u32::MAX)).map(|v| v as u32);
    DeviceCommissioning {
        node_id,
        node_name: k.slots[1].map(|(t, _)| t.to_string()),
        baudrate,
        net_number,
        network_name: k.slots[4].map(|(t, _)| t.to_string()),
        canopen_manager,
        lss_serial_number,
        extra,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Value;

    #[test]
    fn lines_split_like_str_split() {
        // What `Lines` must give: `str::split('\n')` with each piece's first `=`.
        fn check(text: &str) {
            let mut lines = Lines { text, offset: 0 };
            let mut got = Vec::new();
            while let Some(l) = lines.next_line() {
                got.push(l);
            }
            let want: Vec<(&str, Option<usize>)> =
                text.split('\n').map(|l| (l, l.find('='))).collect();
            assert_eq!(got, want, "{text:?}");
        }
        for text in [
            "",
            "\n",
            "a",
            "a\n",
            "a=b\r\nc\n\n=d=e\nf",
            "k=v\n[x]\n\u{e9}=\u{fc}\n",
            "ParameterName=Producer heartbeat time\r\nDataType=0x0006\r\n[1017]\r\n",
            "0123456789abcdef=0123456789\n=\n01234567=\n0123456\n=0123456789abcdef",
        ] {
            check(text);
        }
        // Every text of up to ten bytes over `a`, `=` and a newline: the word-at-a-time search
        // must agree at every alignment.
        let mut text = String::new();
        for len in 0..=10u32 {
            for mut n in 0..3usize.pow(len) {
                text.clear();
                for _ in 0..len {
                    text.push(['a', '=', '\n'][n % 3]);
                    n /= 3;
                }
                check(&text);
            }
        }
        // Longer texts, so that lines and their `=` cross word boundaries at every offset and
        // some lines run over many words: pseudo-random (xorshift) over the same bytes, with
        // newlines and `=` signs dense or rare.
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        for round in 0..4000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let len = (seed % 300) as usize;
            let (p_nl, p_eq) = [(3, 3), (40, 5), (3, 90), (150, 150)][round % 4];
            text.clear();
            let mut r = seed;
            for _ in 0..len {
                r ^= r << 13;
                r ^= r >> 7;
                r ^= r << 17;
                let c = if r.is_multiple_of(p_nl) {
                    '\n'
                } else if (r >> 20).is_multiple_of(p_eq) {
                    '='
                } else {
                    'a'
                };
                text.push(c);
            }
            check(&text);
        }
    }

    #[test]
    fn sub_sections_out_of_order_and_repeated() {
        // 0x2001 before 0x2000, sub 2 before sub 1, and [2000sub1] given twice: every
        // sub-object lands in its object, the later keys win and the repetition is reported.
        let src = "[2001]\nParameterName=B\nObjectType=0x8\nSubNumber=2\n\
            [2001sub1]\nParameterName=b1\nDataType=0x0005\nAccessType=rw\n\
            [2000]\nParameterName=A\nObjectType=0x9\nSubNumber=3\n\
            [2000sub2]\nParameterName=a2\nDataType=0x0006\nAccessType=ro\n\
            [2000sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\n\
            [2000sub1]\nParameterName=a1\nDataType=0x0007\nAccessType=ro\n\
            [2001sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\n\
            [2000sub1]\nAccessType=rw\nDefaultValue=7\n";
        let p = parse(src.as_bytes()).unwrap();
        let a = p.od.get(0x2000).unwrap();
        assert_eq!(a.subs.keys().collect::<Vec<_>>(), [0, 1, 2]);
        let a1 = a.sub(1).unwrap();
        assert_eq!((a1.name.as_str(), a1.access), ("a1", AccessType::Rw));
        assert_eq!(a1.default_value.as_ref().unwrap().text, "7");
        let b = p.od.get(0x2001).unwrap();
        assert_eq!(b.subs.keys().collect::<Vec<_>>(), [0, 1]);
        let dup: Vec<_> = p
            .diagnostics
            .iter()
            .filter(|d| d.message.contains("appears again"))
            .map(|d| d.line)
            .collect();
        assert_eq!(dup, [30]);
    }

    #[test]
    fn named_sections_are_classified_before_indices() {
        for (name, kind) in NAMED_SECTIONS {
            assert_eq!(classify(name), (kind, None), "{name}");
            assert_eq!(classify(&name.to_ascii_lowercase()).0, kind, "{name}");
        }
        for (name, kind) in [
            ("DeviceCommissioning", SectionKind::Commissioning),
            ("1018", SectionKind::Object(0x1018)),
            ("1018sub3", SectionKind::Sub(0x1018, 3)),
            ("DEADName", SectionKind::Names(0xDEAD)),
            ("Dead", SectionKind::Object(0xDEAD)),
            ("ToolInfo", SectionKind::Other),
        ] {
            assert_eq!(classify(name).0, kind, "{name}");
        }
    }

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

    const MINI: &str = "[FileInfo]\r\nEDSVersion=4.0\r\n[DeviceInfo]\r\nVendorNumber=0x123\r\nBaudRate_250=1\r\n\
[1017]\r\nParameterName=Producer heartbeat time\r\nObjectType=0x7\r\nDataType=0x0006\r\nAccessType=rw\r\nDefaultValue=1000\r\nPDOMapping=0\r\n\
[1018]\r\nParameterName=Identity\r\nObjectType=0x9\r\nSubNumber=2\r\n\
[1018sub0]\r\nParameterName=n\r\nDataType=0x0005\r\nAccessType=ro\r\nDefaultValue=1\r\n\
[1018sub1]\r\nParameterName=Vendor-ID\r\nDataType=0x0007\r\nAccessType=ro\r\nDefaultValue=0x123";

    #[test]
    fn minimal_file() {
        let p = parse(MINI.as_bytes()).unwrap();
        assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
        let hb = p.od.sub(0x1017, 0).unwrap();
        assert_eq!(hb.data_type, DataType::Unsigned16);
        assert_eq!(hb.access, AccessType::Rw);
        assert_eq!(
            hb.default_value.as_ref().unwrap().resolve(1),
            Some(Value::Unsigned16(1000))
        );
        assert_eq!(p.od.get(0x1018).unwrap().subs.len(), 2);
        assert_eq!(p.od.device_info.vendor_number, Some(0x123));
        assert_eq!(p.od.device_info.baud_rates[4], Some(true));
        assert_eq!(p.od.sub(0x1017, 0).unwrap().line.0, 6);
    }

    #[test]
    fn tolerances_warn_with_lines() {
        let src = "[FileInfo]\nEDSVersion=4\n[1000]\n ParameterName = Device type\t\nDataType=0x0007\nAccessType=RO\n# hash comment\n[1000]\nDefaultValue=0x1234LL\n[1800]\nObjectType=0x9\nParameterName=x\n[1800Sub1]\nParameterName=y\nDataType=7\nAccessType=rw";
        let p = parse(src.as_bytes()).unwrap();
        let lines: Vec<u32> = p.diagnostics.iter().map(|d| d.line).collect();
        for l in [2, 4, 6, 7, 8, 9, 13] {
            assert!(
                lines.contains(&l),
                "no warning on line {l}: {:#?}",
                p.diagnostics
            );
        }
        assert!(
            p.diagnostics
                .iter()
                .all(|d| d.severity == Severity::Warning)
        );
        assert_eq!(
            p.od.sub(0x1000, 0)
                .unwrap()
                .default_value
                .as_ref()
                .unwrap()
                .resolve(0),
            Some(Value::Unsigned32(0x1234))
        );
        assert!(p.od.sub(0x1800, 1).is_some());
    }

    #[test]
    fn errors_have_lines() {
        let src = "[1000]\nParameterName=a\nObjectType=0x007 # VAR\n[1001]\nParameterName=b\nAccessType=ro\ngarbage line\n";
        let e = parse(src.as_bytes()).unwrap_err();
        let errs: Vec<u32> = e.errors().map(|d| d.line).collect();
        assert_eq!(errs, [3, 4, 7]);
    }

    #[test]
    fn compact_sub_obj_expands() {
        let src = "[1016]\nParameterName=Consumer heartbeat time\nObjectType=0x8\nDataType=0x0007\nAccessType=rw\nCompactSubObj=3\nDefaultValue=0\n[1016Value]\nNrOfEntries=1\n2=0x00050064\n[1016Name]\nNrOfEntries=1\n1=first\n";
        let p = parse(src.as_bytes()).unwrap();
        let o = p.od.get(0x1016).unwrap();
        assert_eq!(o.subs.len(), 4);
        assert_eq!(
            o.sub(0).unwrap().default_value.as_ref().unwrap().resolve(0),
            Some(Value::Unsigned8(3))
        );
        assert_eq!(o.sub(1).unwrap().name, "first");
        assert_eq!(
            o.sub(2).unwrap().parameter_value().unwrap().resolve(0),
            Some(Value::Unsigned32(0x0005_0064))
        );
    }

    #[test]
    fn duplicate_sub_sections_merge_and_ignored_subs_do_not_fail() {
        let src = "[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=ro\n\
[1000sub1]\nParameterName=ignored, and broken\nDataType=oops\n\
[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=1\n\
[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
[1018sub0]\nDefaultValue=4\n";
        let p = parse(src.as_bytes()).unwrap();
        let sub0 = p.od.sub(0x1018, 0).unwrap();
        assert_eq!(sub0.name, "n");
        assert_eq!(sub0.default_value.as_ref().unwrap().text, "4");
        assert!(
            p.diagnostics
                .iter()
                .any(|d| d.kind == K::Duplicate && d.line == 17)
        );
        assert!(
            p.diagnostics
                .iter()
                .any(|d| d.kind == K::Duplicate && d.line == 18)
        );
        assert!(
            p.diagnostics
                .iter()
                .any(|d| d.kind == K::Structure && d.line == 5)
        );
    }

    /// Inputs that a naive merge of repeated sections or keys would handle in quadratic time.
    /// (No time is asserted; a quadratic parser makes this test take minutes instead of
    /// milliseconds.)
    #[test]
    fn repetition_stays_linear() {
        let mut src = String::from("[1018]\nParameterName=Identity\nObjectType=0x9\n");
        for i in 0..20_000 {
            src.push_str(&format!(
                "[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue={}\nX{i}=1\nY=2\n",
                i % 200
            ));
        }
        let p = parse(src.as_bytes()).unwrap();
        let sub0 = p.od.sub(0x1018, 0).unwrap();
        assert_eq!(sub0.default_value.as_ref().unwrap().text, "199");
        // 20 000 distinct unknown keys merged, plus the last `Y`.
        assert_eq!(sub0.extra().len(), 20_001);
    }

    #[test]
    fn latin1_bytes_never_fail() {
        let src = b"[Comments]\nLines=1\nLine1=Sch\x94naich\n";
        let p = parse(src).unwrap();
        assert_eq!(p.od.comments, ["Sch\u{201D}naich"]);
        let enc: Vec<u32> = p
            .diagnostics
            .iter()
            .filter(|d| d.kind == K::Encoding)
            .map(|d| d.line)
            .collect();
        assert_eq!(enc, [3]);
    }
}
