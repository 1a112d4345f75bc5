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
    /// Spelling tolerated: key case, spaces around keys, lower-case hex section names, `#`
    /// comments, trailing whitespace, quoted strings, C suffixes, section name variants.
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

/// Collects diagnostics, listing at most a fixed number per kind of warning and summarising
/// the rest, so a file with thousands of trailing spaces stays readable. Errors are never capped.
#[derive(Debug, Default)]
pub(crate) struct Sink {
    pub(crate) list: Vec<Diagnostic>,
    counts: [u32; 12],
    first_suppressed_line: [u32; 12],
}

const PER_KIND: u32 = 25;

fn kind_slot(kind: DiagnosticKind) -> usize {
    kind as usize
}

impl Sink {
    pub(crate) fn warn(&mut self, kind: DiagnosticKind, line: u32, message: String) {
        let slot = kind_slot(kind).min(11);
        self.counts[slot] += 1;
        if self.counts[slot] <= PER_KIND {
            self.list.push(Diagnostic {
                severity: Severity::Warning,
                kind,
                line,
                message,
            });
        } else if self.counts[slot] == PER_KIND + 1 {
            self.first_suppressed_line[slot] = line;
        }
    }

    pub(crate) fn error(&mut self, kind: DiagnosticKind, line: u32, message: String) {
        self.list.push(Diagnostic {
            severity: Severity::Error,
            kind,
            line,
            message,
        });
    }

    /// Re-reports a diagnostic collected elsewhere (subject to the same per-kind cap).
    pub(crate) fn push(&mut self, d: Diagnostic) {
        match d.severity {
            Severity::Warning => self.warn(d.kind, d.line, d.message),
            Severity::Error => self.error(d.kind, d.line, d.message),
        }
    }

    pub(crate) fn has_errors(&self) -> bool {
        self.list.iter().any(|d| d.severity == Severity::Error)
    }

    pub(crate) fn finish(mut self) -> Vec<Diagnostic> {
        for slot in 0..12 {
            let n = self.counts[slot];
            if n > PER_KIND {
                self.list.push(Diagnostic {
                    severity: Severity::Warning,
                    kind: DiagnosticKind::Suppressed,
                    line: self.first_suppressed_line[slot],
                    message: alloc::format!(
                        "{} more warnings like the above (kind {:?}) not listed",
                        n - PER_KIND,
                        ALL_KINDS
                            .get(slot)
                            .copied()
                            .unwrap_or(DiagnosticKind::Suppressed)
                    ),
                });
            }
        }
        self.list.sort_by_key(|d| d.line);
        self.list
    }
}

const ALL_KINDS: [DiagnosticKind; 12] = [
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
];
