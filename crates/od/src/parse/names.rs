//! Section names (CiA 306 §4.3 to §4.6): the named sections in their canonical spelling,
//! object sections `[xxxx]`, sub sections `[xxxxsubN]`, and the `Name`, `Value`,
//! `Denotation` and `ObjectLinks` sections of an object, each classified into a kind with a
//! note when a tolerated spelling was used.

use alloc::format;
use alloc::string::String;

use crate::diag::DiagnosticKind;

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum SectionKind {
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

#[inline]
pub(super) fn hex4(s: &str) -> Option<u16> {
    if s.len() == 4 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
        u16::from_str_radix(s, 16).ok()
    } else {
        None
    }
}

#[inline]
pub(super) fn strip_prefix_ci<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    if head.eq_ignore_ascii_case(prefix) {
        s.get(prefix.len()..)
    } else {
        None
    }
}

/// Classifies a section name. Returns the kind and, for tolerated spellings, a note.
/// The sections CiA 306 names, in their canonical spelling.
pub(super) const NAMED_SECTIONS: [(&str, SectionKind); 8] = [
    ("FileInfo", SectionKind::FileInfo),
    ("DeviceInfo", SectionKind::DeviceInfo),
    ("DummyUsage", SectionKind::DummyUsage),
    ("Comments", SectionKind::Comments),
    ("MandatoryObjects", SectionKind::Mandatory),
    ("OptionalObjects", SectionKind::Optional),
    ("ManufacturerObjects", SectionKind::Manufacturer),
    ("DeviceComissioning", SectionKind::Commissioning),
];

#[inline]
pub(super) fn classify(name: &str) -> (SectionKind, Option<(DiagnosticKind, String)>) {
    use SectionKind as S;
    // Object sections are nearly all of a file, and no named section starts with four hex
    // digits: test for an index first.
    let Some(index) = name.get(..4).and_then(hex4) else {
        for (canon, kind) in NAMED_SECTIONS {
            if name.eq_ignore_ascii_case(canon) {
                let note = (name != canon).then(|| {
                    (
                        DiagnosticKind::Style,
                        format!("section [{name}] should be spelled [{canon}]"),
                    )
                });
                return (kind, note);
            }
        }
        if name.eq_ignore_ascii_case("DeviceCommissioning") {
            return (
                S::Commissioning,
                Some((
                    DiagnosticKind::Spelling,
                    format!("section [{name}]: CiA 306 spells it [DeviceComissioning]"),
                )),
            );
        }
        return (S::Other, None);
    };
    let lower_hex = name
        .get(..4)
        .is_some_and(|h| h.bytes().any(|b| b.is_ascii_lowercase()));
    let rest = name.get(4..).unwrap_or("");
    let style = |text: String| Some((DiagnosticKind::Style, text));
    let mut note = if lower_hex {
        style(format!("section [{name}]: hex digits should be upper case"))
    } else {
        None
    };
    let kind = if rest.is_empty() {
        S::Object(index)
    } else if let Some(sub) = strip_prefix_ci(rest, "sub") {
        if !rest.starts_with("sub") && note.is_none() {
            note = style(format!(
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
                    note = style(format!("section [{name}]: hex digits should be upper case"));
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
