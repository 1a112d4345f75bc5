//! Rust identifiers from EDS ParameterNames: sanitised, never a keyword, collisions resolved.

use std::collections::HashMap;

const KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "gen", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut",
    "pub", "ref", "return", "self", "Self", "static", "struct", "super", "trait", "true", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "try", "typeof", "unsized", "virtual", "yield",
];

/// Splits a ParameterName into lower-case ASCII words. Non-ASCII letters and punctuation separate
/// words; camelCase boundaries (`ErrorRegister`, `COBIDSync`) split too.
fn words(name: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut cur = String::new();
    let chars: Vec<char> = name.chars().collect();
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_ascii_alphanumeric() {
            if !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
            continue;
        }
        if c.is_ascii_uppercase() && !cur.is_empty() {
            let prev = chars[i - 1];
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            if prev.is_ascii_lowercase() || (prev.is_ascii_uppercase() && next_lower) {
                out.push(std::mem::take(&mut cur));
            }
        }
        cur.push(c.to_ascii_lowercase());
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// `snake_case` identifier for a module; `fallback` when the name has no usable character.
pub(crate) fn snake(name: &str, fallback: &str) -> String {
    fix(words(name).join("_"), fallback)
}

/// `SCREAMING_SNAKE_CASE` identifier for a constant.
pub(crate) fn screaming(name: &str, fallback: &str) -> String {
    fix(
        words(name).join("_").to_ascii_uppercase(),
        &fallback.to_ascii_uppercase(),
    )
}

/// English ordinals for names that start with one (`1st mapped object` → `FIRST_MAPPED_OBJECT`).
const ORDINALS: [&str; 20] = [
    "first",
    "second",
    "third",
    "fourth",
    "fifth",
    "sixth",
    "seventh",
    "eighth",
    "ninth",
    "tenth",
    "eleventh",
    "twelfth",
    "thirteenth",
    "fourteenth",
    "fifteenth",
    "sixteenth",
    "seventeenth",
    "eighteenth",
    "nineteenth",
    "twentieth",
];

/// An identifier that starts with a digit: a leading ordinal up to 20th is spelled out, anything
/// else gets the fallback's first word in front (`24V supply` → `OBJ_24V_SUPPLY`). Never a
/// leading underscore, which Rust reads as "unused on purpose".
fn leading_digit(ident: String, fallback: &str) -> String {
    let (first, rest) = ident.split_once('_').unwrap_or((&ident, ""));
    let digits = first.bytes().take_while(u8::is_ascii_digit).count();
    let (number, suffix) = first.split_at(digits);
    let ordinal = ["st", "nd", "rd", "th"]
        .iter()
        .any(|s| suffix.eq_ignore_ascii_case(s))
        .then(|| number.parse::<usize>().ok())
        .flatten()
        .and_then(|n| ORDINALS.get(n.checked_sub(1)?));
    let upper = first.bytes().any(|b| b.is_ascii_uppercase());
    let head = match ordinal {
        Some(word) if upper => word.to_ascii_uppercase(),
        Some(word) => (*word).to_owned(),
        None => {
            let word = fallback
                .split('_')
                .next()
                .filter(|w| !w.is_empty())
                .unwrap_or("n");
            return format!("{word}_{ident}");
        }
    };
    if rest.is_empty() {
        head
    } else {
        format!("{head}_{rest}")
    }
}

fn fix(mut ident: String, fallback: &str) -> String {
    if ident.is_empty() {
        ident = fallback.to_owned();
    }
    if ident.starts_with(|c: char| c.is_ascii_digit()) {
        ident = leading_digit(ident, fallback);
    }
    if KEYWORDS.contains(&ident.as_str()) {
        ident.push('_');
    }
    ident
}

/// Hands out unique identifiers within one scope: the first taker of a name keeps it, later ones
/// get the `disambiguator` appended (e.g. the index or sub-index), then a counter if still taken.
#[derive(Default)]
pub(crate) struct Scope {
    taken: HashMap<String, ()>,
}

impl Scope {
    pub(crate) fn reserve(&mut self, name: &str) {
        self.taken.insert(name.to_owned(), ());
    }

    pub(crate) fn unique(&mut self, base: String, disambiguator: &str) -> String {
        let mut candidate = base.clone();
        if self.taken.contains_key(&candidate) {
            candidate = format!("{base}_{disambiguator}");
            let mut n = 2;
            while self.taken.contains_key(&candidate) {
                candidate = format!("{base}_{disambiguator}_{n}");
                n += 1;
            }
        }
        self.taken.insert(candidate.clone(), ());
        candidate
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sanitising() {
        assert_eq!(
            screaming("Producer Heartbeat Time", "x"),
            "PRODUCER_HEARTBEAT_TIME"
        );
        assert_eq!(snake("Identity Object", "x"), "identity_object");
        assert_eq!(snake("ErrorRegister", "x"), "error_register");
        assert_eq!(snake("COBIDSync", "x"), "cobid_sync");
        assert_eq!(snake("Operation Time_[s]", "x"), "operation_time_s");
        assert_eq!(snake("Temperatur in °C (µs)", "x"), "temperatur_in_c_s");
        assert_eq!(snake("3rd value", "x"), "third_value");
        assert_eq!(
            screaming("1st mapped object in RxPDO 1", "sub_1"),
            "FIRST_MAPPED_OBJECT_IN_RX_PDO_1"
        );
        assert_eq!(screaming("24V supply", "obj_2000"), "OBJ_24V_SUPPLY");
        assert_eq!(screaming("21st entry", "sub_21"), "SUB_21ST_ENTRY");
        assert_eq!(screaming("7", "sub_7"), "SUB_7");
        assert_eq!(snake("0x10 words", "obj_2001"), "obj_0x10_words");
        assert_eq!(snake("type", "x"), "type_");
        assert_eq!(snake("€€", "obj_2000"), "obj_2000");
        assert_eq!(screaming("Call/Cancel", "x"), "CALL_CANCEL");
    }

    #[test]
    fn collisions() {
        let mut s = Scope::default();
        assert_eq!(
            s.unique("PDO_MAPPING_ENTRY".into(), "1"),
            "PDO_MAPPING_ENTRY"
        );
        assert_eq!(
            s.unique("PDO_MAPPING_ENTRY".into(), "2"),
            "PDO_MAPPING_ENTRY_2"
        );
        assert_eq!(
            s.unique("PDO_MAPPING_ENTRY".into(), "2"),
            "PDO_MAPPING_ENTRY_2_2"
        );
        s.reserve("INDEX");
        assert_eq!(s.unique("INDEX".into(), "3"), "INDEX_3");
    }
}
