//! How the SDO commands name an object: an index in hex (`0x1017`, CANopen's notation), a
//! decimal number, or, with the node's dictionary (`--eds NODE=FILE`), the object's name
//! (`"Producer heartbeat time"`, case-insensitive), optionally with the sub-object's name
//! after a slash or a dot (`"Identity object/Serial number"`, `"Identity object.Serial number"`,
//! as the library's `ObjectDictionary::find` takes them).
//!
//! A plain four-digit decimal below 0x1000 (`1017`) is almost always a hex index typed without
//! `0x`: it is still read as decimal, but a note on stderr (under `--json` a JSON warning
//! object) says what was read and what the user probably meant.

use canola::ObjectDictionary;

use crate::error::CliError;

/// What an object argument resolved to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Resolved {
    pub(crate) index: u16,
    /// The sub-index the name selected (a sub-object's name), if any.
    pub(crate) sub: Option<u8>,
}

/// The note printed for a decimal index that looks like a hex one typed without `0x`.
pub(crate) fn decimal_note(text: &str, index: u16) -> Option<String> {
    let looks_hex = text.len() == 4 && text.bytes().all(|b| b.is_ascii_digit());
    (looks_hex && index < 0x1000).then(|| {
        format!(
            "index `{text}` is decimal, object 0x{index:04X}; CANopen writes indices in hex: \
             for object 0x{text} write `0x{text}`"
        )
    })
}

fn same(a: &str, b: &str) -> bool {
    a.trim().eq_ignore_ascii_case(b.trim())
}

/// Resolves `text` (number or name) with the node's dictionary `od`, if there is one.
pub(crate) fn resolve(text: &str, od: Option<&ObjectDictionary>) -> Result<Resolved, CliError> {
    let starts_numeric = text.bytes().next().is_some_and(|b| b.is_ascii_digit());
    if starts_numeric {
        let index = crate::bus::parse_u16(text)?;
        if let Some(note) = decimal_note(text, index) {
            let mut fields = serde_json::Map::new();
            fields.insert("given".into(), text.into());
            fields.insert("index".into(), index.into());
            crate::bus::warn("note", &note, fields);
        }
        return Ok(Resolved { index, sub: None });
    }
    let Some(od) = od else {
        return Err(CliError::Argument(format!(
            "`{text}` is not an index (0x hex or decimal); to name objects give the node's \
             dictionary with --eds NODE=FILE"
        )));
    };
    let (object, sub) = split_name(od, text);
    let objects: Vec<_> = od
        .objects
        .values()
        .filter(|o| same(&o.name, object))
        .collect();
    match (objects.as_slice(), sub) {
        ([o], None) => Ok(Resolved {
            index: o.index,
            sub: None,
        }),
        ([o], Some(s)) => o
            .subs
            .values()
            .find(|x| same(&x.name, s))
            .map(|x| Resolved {
                index: o.index,
                sub: Some(x.sub_index),
            })
            .ok_or_else(|| {
                CliError::Argument(format!(
                    "object 0x{:04X} ({}) has no sub-object named `{s}`",
                    o.index, o.name
                ))
            }),
        ([], _) => {
            // A sub-object's name alone, if exactly one sub-object carries it.
            let subs: Vec<_> = od
                .objects
                .values()
                .flat_map(|o| o.subs.values().map(move |s| (o.index, s)))
                .filter(|(_, s)| same(&s.name, text))
                .collect();
            match subs.as_slice() {
                [(index, s)] => Ok(Resolved {
                    index: *index,
                    sub: Some(s.sub_index),
                }),
                [] => Err(CliError::Argument(format!(
                    "the dictionary has no object named `{text}`"
                ))),
                many => Err(CliError::Argument(format!(
                    "`{text}` names several sub-objects ({}): give the index",
                    list(
                        many.iter()
                            .map(|(i, s)| format!("0x{i:04X}sub{}", s.sub_index))
                    )
                ))),
            }
        }
        (many, _) => Err(CliError::Argument(format!(
            "`{text}` names several objects ({}): give the index",
            list(many.iter().map(|o| format!("0x{:04X}", o.index)))
        ))),
    }
}

/// The object's name and the sub-object's, the way the library reads them
/// ([`ObjectDictionary::find`]): the whole text when an object has that name, else split at the
/// first `/` or `.` (from the left) whose left part names an object.
fn split_name<'t>(od: &ObjectDictionary, text: &'t str) -> (&'t str, Option<&'t str>) {
    let names = |name: &str| od.objects.values().any(|o| same(&o.name, name));
    if names(text) {
        return (text, None);
    }
    text.match_indices(['/', '.'])
        .map(|(at, _)| (&text[..at], &text[at + 1..]))
        .find(|(object, _)| names(object))
        .map_or((text, None), |(object, sub)| (object, Some(sub)))
}

fn list(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_note_only_for_hex_looking_decimals() {
        assert!(decimal_note("1017", 1017).is_some());
        assert!(decimal_note("4119", 4119).is_none());
        assert!(decimal_note("0x1017", 0x1017).is_none());
        assert!(decimal_note("17", 17).is_none());
    }
}
