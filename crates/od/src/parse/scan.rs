//! The scanner: one pass over the lines of the text, splitting it into sections and their
//! `key=value` entries (CiA 306 §4.2: `[section]` headers, `key=value` lines, `;` comments).
//!
//! Sections given more than once are merged (later keys win, reported as duplicates). Sub
//! sections (`[xxxxsubN]`, most of a file) are built into sub-objects as soon as they end, so
//! their entries need not be kept; every other section's entries stay in one list, borrowed
//! from the text. Linear in the input: a repeated sub section is re-read once at the end.

use alloc::borrow::Cow;
use alloc::boxed::Box;
use alloc::collections::BTreeMap;
use alloc::format;
use alloc::string::String;
use alloc::vec::Vec;

use super::build::build_sub;
use super::lines::Lines;
use super::names::{SectionKind, classify};
use super::section::{Entry, Section, SubRare, SubRec, SubRecs};
use crate::diag::{DiagnosticKind as K, Echo, Sink};
use crate::model::SubObject;

/// The sub section being read.
pub(super) struct OpenSub<'a> {
    pub(super) key: (u16, u8),
    /// Higher than every sub section before it (so certainly not a repetition).
    pub(super) new_highest: bool,
    pub(super) name: &'a str,
    pub(super) line: u32,
    pub(super) entries_start: usize,
    pub(super) byte_start: usize,
}

/// A section as scanned: where its entries are in the entry list.
#[derive(Debug)]
pub(super) struct Scanned<'a> {
    pub(super) name: &'a str,
    pub(super) kind: SectionKind,
    pub(super) line: u32,
    pub(super) first: (usize, usize),
    /// Further spans when the section appears more than once.
    pub(super) more: Vec<(usize, usize)>,
}

/// Splits the text into sections, merging duplicates. Linear in the input.
pub(super) fn scan<'a>(text: &'a str, sink: &mut Sink) -> Scan<'a> {
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
                        format!(
                            "text `{}` after section header [{}] ignored",
                            Echo(after),
                            Echo(name_raw)
                        ),
                    );
                }
                let name = name_raw.trim_ascii();
                if name != name_raw {
                    sink.warn(
                        K::Style,
                        line_no,
                        format!("spaces inside section header [{}]", Echo(name_raw)),
                    );
                }
                let (kind, note) = classify(name);
                if let Some((k, n)) = note {
                    sink.warn(k, line_no, n);
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
                                "section [{}] appears again (first at line {}); keys are merged and later values win",
                                Echo(name),
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
                            "section [{}] appears again (first at line {first}); keys are merged and later values win",
                            Echo(name)
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
                        Echo(trimmed)
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
                    format!("`{}` has an empty key", Echo(trimmed)),
                );
                continue;
            }
            if key.len() != key_raw.len() {
                sink.warn(
                    K::Style,
                    line_no,
                    format!("spaces around key `{}`", Echo(key)),
                );
            }
            let value = value_raw.trim_ascii();
            if value.len() != value_raw.len() {
                if value_raw.trim_ascii_end().len() != value_raw.len() {
                    sink.warn(
                        K::Style,
                        line_no,
                        format!("trailing whitespace after `{}=` value", Echo(key)),
                    );
                } else {
                    sink.warn(K::Style, line_no, format!("spaces after `{}=`", Echo(key)));
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
                format!("key `{}` before the first [section] header", Echo(key)),
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

/// What [`scan`] returns: the entries of all sections but sub sections, and the built
/// sub-objects.
pub(super) struct Scan<'a> {
    pub(super) entries: Vec<Entry<'a>>,
    pub(super) sections: Vec<Scanned<'a>>,
    /// In (index, sub-index) order.
    pub(super) subs: Vec<((u16, u8), SubRec<'a>)>,
    /// The sub-objects read, per index, in file order: the vectors become the objects' storage.
    pub(super) built: BTreeMap<u16, Vec<SubObject>>,
}

/// The sub-objects built so far, per index, in file order. The list being filled (sub
/// sections of one object usually follow each other) is kept out of the map, so that a map
/// look-up is needed only when the index changes.
#[derive(Default)]
pub(super) struct Built {
    pub(super) map: BTreeMap<u16, Vec<SubObject>>,
    pub(super) current: Option<(u16, Vec<SubObject>)>,
}

impl Built {
    pub(super) fn list(&mut self, index: u16) -> &mut Vec<SubObject> {
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

    pub(super) fn into_map(mut self) -> BTreeMap<u16, Vec<SubObject>> {
        if let Some((i, list)) = self.current.take() {
            self.map.insert(i, list);
        }
        self.map
    }
}

/// Builds the sub-object of a sub section that just ended and drops its entries. A repeated
/// section is rebuilt from all its occurrences, re-read from the text.
pub(super) fn finish_sub<'a>(
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
pub(super) fn rebuild_repeated<'a>(
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
pub(super) fn rescan<'a>(body: &'a str, first_line: u32, out: &mut Vec<Entry<'a>>) {
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

/// Borrows each section's entries from the entry list (merging duplicate sections' spans).
pub(super) fn sections<'e, 'a>(
    entries: &'e [Entry<'a>],
    scanned: &[Scanned<'a>],
) -> Vec<Section<'e, 'a>> {
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
