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
//!
//! The parser runs in stages, one module each:
//!
//! - `decode` — bytes to text (UTF-8, or Windows-1252 line by line);
//! - `lines` — the word-at-a-time line splitter the scanner reads with;
//! - `names` — section names to section kinds (`[1018sub2]`, `[DeviceInfo]`, ...);
//! - `section` — the records scanned: sections with their entries, sub sections built;
//! - `scan` — one pass over the lines: sections, their `key=value` entries, duplicates merged;
//!   sub sections are built into sub-objects as soon as they end;
//! - `keys` — the canonical keys of each kind of section and readers for their values;
//! - `build` — object sections and their sub-objects into the [`ObjectDictionary`];
//! - `info` — the information sections: file and device information, commissioning,
//!   comments, dummy usage and the object lists.

mod build;
mod decode;
mod info;
mod keys;
mod lines;
mod names;
mod scan;
mod section;

use alloc::vec::Vec;
use core::fmt;

use crate::diag::{Diagnostic, DiagnosticKind, DiagnosticKind as K, Severity, Sink};
use crate::model::ObjectDictionary;

/// A successfully parsed file: the model and the warnings.
#[derive(Debug, Clone)]
pub struct Parsed {
    /// The object dictionary.
    pub od: ObjectDictionary,
    /// Warnings, sorted by line.
    pub diagnostics: Vec<Diagnostic>,
}

/// A file that could not be understood: its errors (and the warnings) with their lines.
#[derive(Clone, PartialEq, Eq)]
pub struct ParseError {
    /// The diagnostics listed, sorted by line; at least one is an error. Beyond 25 of one
    /// severity and kind, one `Suppressed` diagnostic of that severity counts the rest.
    pub diagnostics: Vec<Diagnostic>,
}

debug_as_display!(ParseError);

impl ParseError {
    /// The errors listed (including the `Suppressed` summaries of errors not listed).
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics
            .iter()
            .filter(|d| d.severity == Severity::Error)
    }

    /// How many errors the file has, listed or not.
    pub fn error_count(&self) -> usize {
        self.errors()
            .map(|d| match d.kind {
                DiagnosticKind::Suppressed => d.suppressed_count().unwrap_or(0),
                _ => 1,
            })
            .sum()
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.error_count();
        match self.errors().next() {
            Some(first) => write!(f, "{first} ({n} error(s) in total)"),
            None => f.write_str("parse failed"),
        }
    }
}

impl core::error::Error for ParseError {}

/// How [`parse_with`] reports: which diagnostics it lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseOptions {
    style_warnings: bool,
    strict: bool,
}

impl Default for ParseOptions {
    fn default() -> Self {
        Self::new()
    }
}

impl ParseOptions {
    /// Everything reported (what [`parse`] does).
    pub const fn new() -> Self {
        Self {
            style_warnings: true,
            strict: false,
        }
    }

    /// Whether [`DiagnosticKind::Style`] warnings (form only: key and section-name case,
    /// lower-case hex, `Sub`, spaces around keys, trailing blanks) are reported. On by default.
    pub const fn style_warnings(mut self, on: bool) -> Self {
        self.style_warnings = on;
        self
    }

    /// Strict: a file with any finding in a communication object (0x1000..0x1FFF, the
    /// objects that configure the network: COB-IDs, PDO mappings, heartbeat, SDO channels)
    /// other than a [`DiagnosticKind::Style`] one is refused; each such finding is listed as
    /// an error. Off by default, where only a value of such an object that does not parse is
    /// an error and the rest are warnings.
    pub const fn strict(mut self, on: bool) -> Self {
        self.strict = on;
        self
    }
}

/// Parses an EDS or DCF file, reporting everything ([`parse_with`] with the default options).
pub fn parse(input: &[u8]) -> Result<Parsed, ParseError> {
    parse_with(input, ParseOptions::new())
}

/// Parses an EDS or DCF file.
///
/// Never panics; memory is proportional to the input size. An empty file, or one without a
/// single `[section]`, is an error. At most 25 diagnostics of each severity and kind are
/// listed, followed by one [`DiagnosticKind::Suppressed`]
/// diagnostic counting the rest; text from the input is echoed shortened to 60 characters with
/// control characters escaped.
pub fn parse_with(input: &[u8], options: ParseOptions) -> Result<Parsed, ParseError> {
    let mut sink = Sink::default();
    sink.quiet_style = !options.style_warnings;
    sink.strict_communication = options.strict;
    let text = decode::decode(input, &mut sink);
    let scan = scan::scan(&text, &mut sink);
    let sections = scan::sections(&scan.entries, &scan.sections);
    if sections.is_empty() && scan.subs.is_empty() {
        // Nothing an EDS reader would look at: not a pass with zero objects.
        let message = if text.trim_ascii().is_empty() {
            "the file is empty: an EDS or DCF file has [FileInfo], [DeviceInfo] and object sections"
        } else {
            "no [section] header in the file: not an EDS or DCF file"
        };
        sink.error(K::Structure, 1, message.into());
    }
    let od = build::build(&sections, scan.subs, scan.built, &mut sink);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{AccessType, DataType};
    use crate::value::Value;
    use alloc::format;
    use alloc::string::{String, ToString};

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

    #[test]
    fn empty_or_sectionless_input_is_an_error() {
        for src in [
            "",
            "\n\n  \r\n",
            "; only a comment\n",
            "Key=Value\n",
            "\u{feff}",
        ] {
            let e = parse(src.as_bytes()).expect_err(src);
            assert!(
                e.errors().any(|d| d.kind == K::Structure && d.line == 1),
                "{src:?}: {e}"
            );
        }
        // One section is enough to be read (with warnings).
        assert!(parse(b"[FileInfo]\nEDSVersion=4.0\n").is_ok());
    }

    #[test]
    fn junk_reports_are_bounded() {
        // Thousands of bad lines, some with control bytes and a very long section name.
        let mut src = alloc::vec::Vec::new();
        src.extend_from_slice(b"[");
        src.extend(core::iter::repeat_n(b'N', 10_000));
        src.extend_from_slice(b"]\n[1000]\nDataType=zz\x1b[2J\n");
        for i in 0..5000u32 {
            src.extend_from_slice(format!("junk line {i} \x07\n").as_bytes());
        }
        let e = parse(&src).unwrap_err();
        let errors = e.errors().count();
        assert!(errors <= 30, "{errors} errors listed");
        let summary = e
            .diagnostics
            .iter()
            .find(|d| d.kind == K::Suppressed && d.severity == Severity::Error)
            .expect("a count of the errors not listed");
        assert!(summary.message.starts_with("4975 more errors"), "{summary}");
        for d in &e.diagnostics {
            assert!(d.message.chars().count() < 300, "{d}");
            assert!(!d.message.chars().any(char::is_control), "{d}");
        }
        assert_eq!(e.error_count(), 5001);
        assert!(e.to_string().contains("5001 error(s) in total"), "{e}");
    }

    #[test]
    fn style_warnings_can_be_silenced() {
        let src = b"[fileinfo]\nedsversion=4.0 \n[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=RO\n[1018]\nParameterName=x\nObjectType=0x9\n[1018Sub0]\nParameterName=n\nDataType=5\nAccessType=ro\nDefaultValue=1LL\n";
        let all = parse(src).unwrap().diagnostics;
        let style = all.iter().filter(|d| d.kind == K::Style).count();
        assert_eq!(style, 5, "{all:#?}");
        let quiet = parse_with(src, ParseOptions::new().style_warnings(false))
            .unwrap()
            .diagnostics;
        assert_eq!(quiet.len(), all.len() - style);
        assert!(quiet.iter().any(|d| d.kind == K::Spelling), "{quiet:#?}");
    }
}
