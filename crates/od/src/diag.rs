//! Diagnostics of the parser and the linter: a severity, a line, a kind and a message a user
//! can act on. Rendered the way compilers do: `FILE:LINE: warning: message`.

use alloc::string::String;
use alloc::vec::Vec;
use core::fmt;

/// How bad a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The input was understood, but is not what CiA 306 prescribes (a tolerance), or the
    /// linter found an inconsistency.
    Warning,
    /// The input could not be understood.
    Error,
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Warning => "warning",
            Self::Error => "error",
        })
    }
}

/// What a diagnostic is about (stable for tools that filter; the message has the details).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum DiagnosticKind {
    /// A line that is neither a section header, a `key=value` pair nor a comment.
    Syntax,
    /// Bytes that are not UTF-8, read as Windows-1252.
    Encoding,
    /// Spelling tolerated that is more than form: `#` comments, quoted strings, C integer
    /// suffixes, a decimal number with a leading 0, section name variants (`DeviceCommissioning`),
    /// an unusual `EDSVersion`. Form-only deviations are [`DiagnosticKind::Style`].
    Spelling,
    /// A section or key given twice.
    Duplicate,
    /// A value that cannot be read for its key or data type.
    Value,
    /// A required key missing, or a key or section that does not belong where it is.
    Structure,
    /// `SubNumber` differs from the sub-objects present.
    SubNumber,
    /// Object lists and objects disagree.
    ObjectList,
    /// A default value outside `LowLimit`..`HighLimit`.
    Limits,
    /// A PDO mapping entry inconsistent with the mapped object.
    PdoMapping,
    /// An invalid access type, data type or object code.
    InvalidCode,
    /// A summary of further diagnostics of one kind that were not listed one by one.
    Suppressed,
    /// A deviation of form only, which changes nothing in how the file is read: key or
    /// section-name case, lower-case hex digits, `Sub` for `sub`, spaces around keys, trailing
    /// blanks, an AccessType in upper case. Tools may hide these (`eds check --no-style`).
    Style,
}

impl DiagnosticKind {
    /// A short lower-case name (`syntax`, `style`, ...), as messages and tools print the kind.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Syntax => "syntax",
            Self::Encoding => "encoding",
            Self::Spelling => "spelling",
            Self::Duplicate => "duplicate",
            Self::Value => "value",
            Self::Structure => "structure",
            Self::SubNumber => "sub-number",
            Self::ObjectList => "object-list",
            Self::Limits => "limits",
            Self::PdoMapping => "pdo-mapping",
            Self::InvalidCode => "invalid-code",
            Self::Suppressed => "suppressed",
            Self::Style => "style",
        }
    }
}

impl fmt::Display for DiagnosticKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One finding with its source line (1-based; 0 when not tied to a line).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// Warning or error.
    pub severity: Severity,
    /// Category.
    pub kind: DiagnosticKind,
    /// Line in the source file.
    pub line: u32,
    /// What is wrong and, where it helps, what to do.
    pub message: String,
}

impl Diagnostic {
    /// For a [`DiagnosticKind::Suppressed`] summary, how many diagnostics it stands for (its
    /// message starts with that number); `None` for every other diagnostic.
    pub fn suppressed_count(&self) -> Option<usize> {
        if self.kind != DiagnosticKind::Suppressed {
            return None;
        }
        let digits = self.message.split(' ').next()?;
        digits.parse().ok()
    }

    /// Formats as `FILE:LINE: severity: message`.
    pub fn render<'a>(&'a self, file: &'a str) -> impl fmt::Display + 'a {
        Rendered { d: self, file }
    }
}

struct Rendered<'a> {
    d: &'a Diagnostic,
    file: &'a str,
}

impl fmt::Display for Rendered<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {}: {}",
            self.file, self.d.line, self.d.severity, self.d.message
        )
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}: {}", self.line, self.severity, self.message)
    }
}

/// Collects diagnostics, listing at most a fixed number per severity and kind and summarising
/// the rest in one [`DiagnosticKind::Suppressed`] diagnostic of that severity, so that a file
/// with thousands of trailing spaces stays readable and a junk file's report stays small (its
/// memory too: a capped diagnostic is counted, not kept). Control characters in messages are
/// escaped, so input bytes never reach a terminal raw.
#[derive(Debug, Default)]
pub(crate) struct Sink {
    pub(crate) list: Vec<Diagnostic>,
    /// Per severity (warning, error) and kind: how many were reported, and the line of the
    /// first one not listed.
    counts: [[u32; KINDS]; 2],
    first_suppressed_line: [[u32; KINDS]; 2],
    /// Drop [`DiagnosticKind::Style`] warnings without counting them.
    pub(crate) quiet_style: bool,
    /// Report every finding but style in a communication object as an error.
    pub(crate) strict_communication: bool,
    /// The object whose sections are being read, if any.
    pub(crate) object: Option<u16>,
}

/// Whether `index` is in the communication profile area (CiA 301 §7.5: 0x1000..0x1FFF).
pub(crate) const fn is_communication_object(index: u16) -> bool {
    index >= 0x1000 && index <= 0x1FFF
}

/// How many diagnostics of one severity and kind are listed one by one.
pub(crate) const PER_KIND: u32 = 25;

impl Sink {
    pub(crate) fn warn(&mut self, kind: DiagnosticKind, line: u32, message: String) {
        self.add(Severity::Warning, kind, line, message);
    }

    pub(crate) fn error(&mut self, kind: DiagnosticKind, line: u32, message: String) {
        self.add(Severity::Error, kind, line, message);
    }

    fn add(&mut self, severity: Severity, kind: DiagnosticKind, line: u32, message: String) {
        if self.quiet_style && kind == DiagnosticKind::Style {
            return;
        }
        let severity = if self.strict_communication
            && kind != DiagnosticKind::Style
            && self.object.is_some_and(is_communication_object)
        {
            Severity::Error
        } else {
            severity
        };
        let sev = usize::from(severity == Severity::Error);
        let slot = (kind as usize).min(KINDS - 1);
        let n = &mut self.counts[sev][slot];
        *n = n.saturating_add(1);
        if *n <= PER_KIND {
            self.list.push(Diagnostic {
                severity,
                kind,
                line,
                message: escape_controls(message),
            });
        } else if *n == PER_KIND + 1 {
            self.first_suppressed_line[sev][slot] = line;
        }
    }

    /// Re-reports a diagnostic collected elsewhere (subject to the same caps).
    pub(crate) fn push(&mut self, d: Diagnostic) {
        self.add(d.severity, d.kind, d.line, d.message);
    }

    pub(crate) fn has_errors(&self) -> bool {
        self.counts[1].iter().any(|&n| n > 0)
    }

    pub(crate) fn finish(mut self) -> Vec<Diagnostic> {
        for (sev, severity) in [Severity::Warning, Severity::Error].into_iter().enumerate() {
            for (slot, kind) in ALL_KINDS.into_iter().enumerate() {
                let n = self.counts[sev][slot];
                if n > PER_KIND {
                    self.list.push(Diagnostic {
                        severity,
                        kind: DiagnosticKind::Suppressed,
                        line: self.first_suppressed_line[sev][slot],
                        message: alloc::format!(
                            "{} more {severity}s of kind {} not listed (the first at this line)",
                            n - PER_KIND,
                            kind.name()
                        ),
                    });
                }
            }
        }
        self.list.sort_by_key(|d| d.line);
        self.list
    }
}

/// The message with every control character (C0, DEL, C1) written as an escape, so that text
/// echoed from the input cannot move the cursor or ring the terminal's bell.
fn escape_controls(message: String) -> String {
    if !message.chars().any(char::is_control) {
        return message;
    }
    let mut out = String::with_capacity(message.len() + 8);
    for c in message.chars() {
        push_char(&mut out, c);
    }
    out
}

fn push_char(out: &mut String, c: char) {
    use core::fmt::Write as _;
    match c {
        '\t' => out.push_str("\\t"),
        '\r' => out.push_str("\\r"),
        '\n' => out.push_str("\\n"),
        c if u32::from(c) < 0x80 && c.is_control() => {
            let _ = write!(out, "\\x{:02X}", u32::from(c));
        }
        c if c.is_control() => {
            let _ = write!(out, "\\u{{{:X}}}", u32::from(c));
        }
        c => out.push(c),
    }
}

/// Text from the input as a message shows it: at most [`ECHO_CHARS`] characters (then `…`),
/// control characters escaped. A 10,000-character section header is echoed as its start.
#[derive(Clone, Copy)]
pub(crate) struct Echo<'a>(pub(crate) &'a str);

/// How many characters of input text a message echoes.
pub(crate) const ECHO_CHARS: usize = 60;

impl fmt::Display for Echo<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use core::fmt::Write as _;
        for (i, c) in self.0.chars().enumerate() {
            if i == ECHO_CHARS {
                return f.write_char('…');
            }
            if c.is_control() {
                let mut s = String::new();
                push_char(&mut s, c);
                f.write_str(&s)?;
            } else {
                f.write_char(c)?;
            }
        }
        Ok(())
    }
}

const KINDS: usize = ALL_KINDS.len();

const ALL_KINDS: [DiagnosticKind; 13] = [
    DiagnosticKind::Syntax,
    DiagnosticKind::Encoding,
    DiagnosticKind::Spelling,
    DiagnosticKind::Duplicate,
    DiagnosticKind::Value,
    DiagnosticKind::Structure,
    DiagnosticKind::SubNumber,
    DiagnosticKind::ObjectList,
    DiagnosticKind::Limits,
    DiagnosticKind::PdoMapping,
    DiagnosticKind::InvalidCode,
    DiagnosticKind::Suppressed,
    DiagnosticKind::Style,
];

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::format;

    #[test]
    fn kinds_table_matches_discriminants() {
        for (i, k) in ALL_KINDS.into_iter().enumerate() {
            assert_eq!(k as usize, i, "{k:?}");
        }
    }

    #[test]
    fn errors_are_capped_with_a_count() {
        let mut sink = Sink::default();
        for line in 1..=1000 {
            sink.error(DiagnosticKind::Syntax, line, "bad".into());
            sink.warn(DiagnosticKind::Style, line, "style".into());
        }
        assert!(sink.has_errors());
        let list = sink.finish();
        assert_eq!(list.len(), 2 * PER_KIND as usize + 2);
        let counted: Vec<_> = list
            .iter()
            .filter_map(Diagnostic::suppressed_count)
            .collect();
        assert_eq!(counted, [975, 975]);
        let summaries: Vec<_> = list
            .iter()
            .filter(|d| d.kind == DiagnosticKind::Suppressed)
            .map(|d| (d.severity, d.line, d.message.as_str()))
            .collect();
        assert_eq!(
            summaries,
            [
                (
                    Severity::Warning,
                    26,
                    "975 more warnings of kind style not listed (the first at this line)"
                ),
                (
                    Severity::Error,
                    26,
                    "975 more errors of kind syntax not listed (the first at this line)"
                )
            ]
        );
    }

    #[test]
    fn echo_truncates_and_escapes() {
        let long = "x".repeat(10_000);
        let shown = format!("{}", Echo(&long));
        assert_eq!(shown.chars().count(), ECHO_CHARS + 1);
        assert!(shown.ends_with('…'));
        assert_eq!(
            format!("{}", Echo("a\x1b[2Jb\x07\u{85}")),
            "a\\x1B[2Jb\\x07\\u{85}"
        );
        let mut sink = Sink::default();
        sink.warn(DiagnosticKind::Syntax, 1, "raw \x1b byte".into());
        assert_eq!(sink.finish()[0].message, "raw \\x1B byte");
    }
}
