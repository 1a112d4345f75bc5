//! The records the scanner hands to the builders: a section with its `key=value` entries, and
//! a sub section (`[xxxxsubN]`) already built into a sub-object (CiA 306 §4.2). They sit below
//! both the scanner and the builders, which each read them.

use alloc::borrow::Cow;
use alloc::boxed::Box;
use alloc::collections::BTreeMap;
use alloc::vec::Vec;

use super::names::SectionKind;
use crate::diag::Diagnostic;

/// One `key=value` line of a section, borrowed from the text.
#[derive(Debug, Clone, Copy)]
pub(super) struct Entry<'a> {
    pub(super) key: &'a str,
    pub(super) value: &'a str,
    pub(super) line: u32,
}

/// A section with its entries (borrowed from the scan's single entry list; copied only when a
/// duplicate section's keys have to be merged).
#[derive(Debug)]
pub(super) struct Section<'e, 'a> {
    pub(super) name: &'a str,
    pub(super) kind: SectionKind,
    pub(super) line: u32,
    pub(super) entries: Cow<'e, [Entry<'a>]>,
}

/// A `[xxxxsubN]` section, built into a [`SubObject`] as soon as it ends so that its keys need
/// not be kept (sub sections are most of a file). Its diagnostics are held back until the
/// owning object decides whether the sub-object is used.
#[derive(Debug)]
pub(super) struct SubRec<'a> {
    pub(super) name: &'a str,
    pub(super) line: u32,
    /// Byte span of the section's body (its first line is `line + 1`).
    pub(super) first: (usize, usize),
    /// False when the section could not be read (its diagnostics say why).
    pub(super) ok: bool,
    /// Rarely present, so kept out of line: diagnostics and repeated occurrences.
    pub(super) rare: Option<Box<SubRare>>,
}

/// The uncommon parts of a [`SubRec`].
#[derive(Debug, Default)]
pub(super) struct SubRare {
    /// Byte span and first line of further occurrences when the section repeats.
    pub(super) more: Vec<(usize, usize, u32)>,
    pub(super) diags: Vec<Diagnostic>,
}

impl SubRec<'_> {
    pub(super) fn rare(&mut self) -> &mut SubRare {
        self.rare.get_or_insert_with(Default::default)
    }
}

/// The sub sections read so far, by (index, sub-index). They almost always come in increasing
/// order, so they are appended to a vector (a tenth of a map's memory and no look-ups); the
/// first one out of order turns the vector into a map.
pub(super) enum SubRecs<'a> {
    Sorted(Vec<((u16, u8), SubRec<'a>)>),
    Map(BTreeMap<(u16, u8), SubRec<'a>>),
}

impl<'a> SubRecs<'a> {
    pub(super) fn get(&self, key: (u16, u8)) -> Option<&SubRec<'a>> {
        match self {
            Self::Sorted(v) => v
                .binary_search_by_key(&key, |e| e.0)
                .ok()
                .and_then(|i| v.get(i))
                .map(|e| &e.1),
            Self::Map(m) => m.get(&key),
        }
    }

    pub(super) fn get_mut(&mut self, key: (u16, u8)) -> Option<&mut SubRec<'a>> {
        match self {
            Self::Sorted(v) => match v.binary_search_by_key(&key, |e| e.0) {
                Ok(i) => v.get_mut(i).map(|e| &mut e.1),
                Err(_) => None,
            },
            Self::Map(m) => m.get_mut(&key),
        }
    }

    /// Adds a record for a key not present yet.
    pub(super) fn insert(&mut self, key: (u16, u8), rec: SubRec<'a>) {
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

    pub(super) fn into_sorted(self) -> Vec<((u16, u8), SubRec<'a>)> {
        match self {
            Self::Sorted(v) => v,
            Self::Map(m) => m.into_iter().collect(),
        }
    }
}
