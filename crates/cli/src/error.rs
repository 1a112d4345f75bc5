//! The errors of the `canopen` command and how they are reported.
//!
//! Every command returns [`CliError`] for what went wrong: the variant keeps what failed (the
//! bus that would not open, the master operation, the file and its line, the argument) and
//! [`CliError::report`] prints it once on stderr and gives the exit code: `error: TEXT` (with
//! a hint on a line of its own, `hint: ...`), or under `--json` one JSON object with `error`,
//! `hint`, for an SDO failure `node`, `index`, `sub`, `name`, `abort_code` and `meaning`, for
//! a value or PDO mapping the master refused `node`, `index` and `sub`, for a file that failed
//! `file`, and for an EDS/DCF that does not parse also `line` (of its first error),
//! `error_count` and `errors` (`{file, line, severity, message}` as `eds check --json`).
//!
//! The exit code follows one rule: 2 when the command line itself is wrong (an argument that
//! does not parse or is out of range, one that is missing or too many, options that do not fit
//! together or with the bus, a name the dictionary does not have), as clap's own errors;
//! 1 when something the command line names fails (a file, the bus, a device, the system).
//! Under `--json` clap's errors print as JSON too ([`report_clap`]).

use std::fmt;
use std::path::PathBuf;
use std::process::ExitCode;

use canola::{NodeId, ObjectAddress};
use serde_json::{Map, Value as Json, json};

/// Why a command failed.
#[derive(Debug)]
pub(crate) enum CliError {
    /// `--iface` names no bus, or the bus would not open (the library's error names the bus and
    /// carries its hints).
    Bus(canola::OpenError),
    /// The open bus failed to send or receive.
    Transport(canola::TransportError),
    /// An slcan adapter did not answer a command about itself.
    Adapter {
        /// The `--iface` text.
        iface: String,
        /// What the adapter link reported.
        source: canola::slcan::LinkError,
    },
    /// A master operation failed (NMT, SDO, LSS, a wait); an SDO failure gives its node,
    /// object and abort code as JSON fields, a timed-out one a hint, a refused value its node
    /// and object.
    Op(canola::Error),
    /// A CiA 402 drive command failed other than by an SDO transfer.
    Drive(canola_cia402::master::DriveError),
    /// An EDS/DCF file that does not load: the file and the parser's error with its line.
    Dictionary {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        source: canola::od::ParseError,
    },
    /// An EDS built into the command that does not parse.
    BuiltinDictionary(canola::od::ParseError),
    /// A network description (`bus.toml`) that does not load.
    NetworkConfig(canola_manager::config::ConfigError),
    /// A candump log with a line that does not read.
    Log {
        /// The log file.
        path: PathBuf,
        /// The reader's error (with the line).
        source: canola::candump::ReadError,
        /// Said when a replay stopped before sending anything.
        nothing_sent: bool,
    },
    /// A file that could not be opened, read or written.
    File {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// Another system resource that failed: a socket to listen on, the terminal, signals.
    System {
        /// What was being done, or the resource (`tcp:5000`, `cannot draw`).
        what: String,
        /// What the system said.
        source: std::io::Error,
    },
    /// The terminal failed to give its events.
    Terminal(std::io::Error),
    /// The walkthrough (`canopen demo`) stopped.
    Demo(Box<dyn std::error::Error + Send + Sync>),
    /// A node-ID out of 1..=127.
    NodeId(canola::frame::NodeIdError),
    /// A value given on the command line (an option, a token file) that the library refused.
    Rejected {
        /// The option or source of the value (`--allow`, `the write token from FILE`).
        what: String,
        /// The library's reason.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// An argument that does not parse or names nothing, or options that do not fit together
    /// or with the bus.
    Argument(String),
    /// A failure about one object of one node (the node and object lead the text).
    Object {
        /// The node.
        node: NodeId,
        /// The object.
        entry: ObjectAddress,
        /// What went wrong.
        source: Box<CliError>,
    },
    /// A device's answer that does not fit: the wrong type or length, an unexpected reply, a
    /// connection refused or never made.
    Device(String),
    /// Nodes that did not confirm what was asked of them in time, one reason each.
    Unconfirmed(Vec<String>),
    /// A command line that is wrong as a whole (exit code 2).
    Usage(Box<CliError>),
    /// An error with what the user may do about it (`hint: ...` after its text, under
    /// `--json` in `hint`); the exit code and JSON fields are the error's.
    Hinted {
        /// The error.
        source: Box<CliError>,
        /// What to do.
        hint: String,
    },
    /// The process was ended by a signal (its files removed first).
    #[cfg_attr(not(unix), allow(dead_code))]
    Interrupted {
        /// The signal's name (`SIGINT`).
        signal: &'static str,
    },
}

impl CliError {
    /// A command line that is wrong as a whole, said in `text` (exit code 2).
    pub(crate) fn usage(text: impl Into<String>) -> Self {
        Self::Usage(Box::new(Self::Argument(text.into())))
    }

    /// This error as a usage error (exit code 2).
    pub(crate) fn into_usage(self) -> Self {
        match self {
            e @ Self::Usage(_) => e,
            e => Self::Usage(Box::new(e)),
        }
    }

    /// This error with a hint (see [`CliError::Hinted`]).
    pub(crate) fn with_hint(self, hint: impl Into<String>) -> Self {
        Self::Hinted {
            source: Box::new(self),
            hint: hint.into(),
        }
    }

    /// A failure about `entry` on `node`.
    pub(crate) fn at(self, node: NodeId, entry: ObjectAddress) -> Self {
        match self {
            Self::Usage(inner) => Self::Usage(Box::new(inner.at(node, entry))),
            e => Self::Object {
                node,
                entry,
                source: Box::new(e),
            },
        }
    }

    /// A file error at `path`.
    pub(crate) fn file(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| Self::File { path, source }
    }

    /// Whether the command line itself is wrong (see the module docs): the argument errors,
    /// node-IDs out of range, values the library refused, and errors marked as usage errors.
    pub(crate) fn is_usage(&self) -> bool {
        match self {
            Self::Hinted { source, .. } => source.is_usage(),
            _ => matches!(
                self,
                Self::Usage(_) | Self::Argument(_) | Self::NodeId(_) | Self::Rejected { .. }
            ),
        }
    }

    /// The exit code: 2 for a usage error, else 1.
    pub(crate) fn exit_code(&self) -> ExitCode {
        if self.is_usage() {
            ExitCode::from(2)
        } else {
            ExitCode::FAILURE
        }
    }

    /// The JSON fields beyond `error` and `hint`: an SDO failure's node, object and abort code.
    fn fields(&self) -> Map<String, Json> {
        let mut fields = Map::new();
        match self {
            Self::Op(canola::Error::Sdo(s)) => {
                fields.insert("node".into(), json!(s.node.get()));
                fields.insert("index".into(), json!(s.entry.index));
                fields.insert("sub".into(), json!(s.entry.sub_index));
                if let Some(name) = &s.name {
                    fields.insert("name".into(), json!(name));
                }
                if let Some(code) = s.abort_code() {
                    fields.insert("abort_code".into(), json!(format!("{:#010x}", code.get())));
                    fields.insert(
                        "meaning".into(),
                        json!(code.description().unwrap_or("unknown abort code")),
                    );
                }
            }
            // A value or configuration the master refused for one object of one node (a PDO
            // mapping too long for the frame, a value of the wrong type).
            Self::Op(canola::Error::Value { node, entry, .. }) => {
                fields.insert("node".into(), json!(node.get()));
                fields.insert("index".into(), json!(entry.index));
                fields.insert("sub".into(), json!(entry.sub_index));
            }
            Self::Dictionary { path, source } => {
                let file = path.display().to_string();
                if let Some(first) = source.errors().next() {
                    fields.insert("line".into(), json!(first.line));
                }
                fields.insert("file".into(), json!(file));
                fields.insert("error_count".into(), json!(source.error_count()));
                fields.insert(
                    "errors".into(),
                    crate::eds::diagnostics_json(
                        &file,
                        &source.diagnostics,
                        canola::od::Severity::Error,
                    ),
                );
            }
            Self::File { path, .. } | Self::Log { path, .. } => {
                fields.insert("file".into(), json!(path.display().to_string()));
            }
            Self::Usage(inner) | Self::Hinted { source: inner, .. } => return inner.fields(),
            Self::Interrupted { signal } => {
                fields.insert("signal".into(), json!(signal));
            }
            _ => {}
        }
        fields
    }

    /// Prints the error on stderr (see the module docs) and gives the exit code.
    pub(crate) fn report(self) -> ExitCode {
        let mut fields = self.fields();
        if json() && self.is_usage() {
            fields.insert("usage".into(), true.into());
        }
        print(&self.to_string(), fields);
        self.exit_code()
    }
}

/// Reports a command line clap refused, or prints the help or version it asked for: as clap
/// does, or under `--json` (when `json`) an error as one JSON object on stderr: `error` (clap's
/// message without its `error: `), `usage` true, `kind` (clap's kind of error, kebab-case:
/// `invalid-value`, `unknown-argument`, `missing-required-argument`, ...), `argument` (the
/// argument it is about, when clap names one), `value` (the value refused, when there is one),
/// `hint` (clap's suggestion, when it has one). Help and version print as text and exit 0.
pub(crate) fn report_clap(e: &clap::Error, json: bool) -> ExitCode {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if !json || !e.use_stderr() {
        let _ = e.print();
        return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    }
    let text = e.render().to_string();
    let body = text.strip_prefix("error: ").unwrap_or(&text);
    // clap's message ends at the first blank line; its tips and usage follow.
    let message = body.split("\n\n").next().unwrap_or(body).trim();
    let mut fields = Map::new();
    let mut tips = Vec::new();
    for line in body.lines() {
        if let Some(tip) = line.trim().strip_prefix("tip: ") {
            tips.push(tip.to_owned());
        }
    }
    let kind = match e.kind() {
        ErrorKind::InvalidValue => "invalid-value",
        ErrorKind::UnknownArgument => "unknown-argument",
        ErrorKind::InvalidSubcommand => "invalid-subcommand",
        ErrorKind::NoEquals => "no-equals",
        ErrorKind::ValueValidation => "value-validation",
        ErrorKind::TooManyValues => "too-many-values",
        ErrorKind::TooFewValues => "too-few-values",
        ErrorKind::WrongNumberOfValues => "wrong-number-of-values",
        ErrorKind::ArgumentConflict => "argument-conflict",
        ErrorKind::MissingRequiredArgument => "missing-required-argument",
        ErrorKind::MissingSubcommand => "missing-subcommand",
        ErrorKind::InvalidUtf8 => "invalid-utf8",
        _ => "usage",
    };
    fields.insert("usage".into(), true.into());
    fields.insert("kind".into(), kind.into());
    let text_of = |c: Option<&ContextValue>| match c {
        Some(ContextValue::String(s)) => Some(s.clone()),
        Some(ContextValue::Strings(v)) => Some(v.join(", ")),
        _ => None,
    };
    if let Some(arg) = text_of(e.get(ContextKind::InvalidArg)) {
        fields.insert("argument".into(), arg.into());
    }
    if let Some(value) = text_of(e.get(ContextKind::InvalidValue)) {
        fields.insert("value".into(), value.into());
    }
    if !tips.is_empty() {
        fields.insert("hint".into(), tips.join("; ").into());
    }
    fields.insert("error".into(), message.into());
    eprintln!("{}", Json::Object(fields));
    ExitCode::from(2)
}

/// Whether errors print as JSON (`--json`); set once by `main`.
static JSON: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Makes [`CliError::report`] (and warnings) print JSON.
pub(crate) fn set_json(on: bool) {
    JSON.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// Whether errors and warnings print as JSON.
pub(crate) fn json() -> bool {
    JSON.load(std::sync::atomic::Ordering::Relaxed)
}

/// Prints `error: TEXT`, or under `--json` the object of `fields` with `error` and `hint` (a
/// text `...\nhint: ...` gives the two, each once).
fn print(text: &str, mut fields: Map<String, Json>) {
    if json() {
        let (error, hint) = match text.split_once("\nhint: ") {
            Some((e, h)) => (e, Some(h)),
            None => (text, None),
        };
        fields.insert("error".into(), error.into());
        if let Some(h) = hint {
            fields.insert("hint".into(), h.into());
        }
        eprintln!("{}", Json::Object(fields));
    } else {
        eprintln!("error: {text}");
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bus(e) => write!(f, "{e}"),
            Self::Transport(e) => write!(f, "{e}"),
            Self::Adapter { iface, source } => write!(f, "{iface}: {source}"),
            Self::Op(e) => {
                write!(f, "{e}")?;
                if let canola::Error::Sdo(s) = e
                    && matches!(
                        s.kind,
                        canola::SdoErrorKind::Transfer(canola::sdo::ErrorKind::Timeout)
                    )
                {
                    write!(
                        f,
                        "\nhint: nothing answered. Is node {} on this bus (`canopen scan` lists \
                         the nodes that answer), powered, at the same bit rate? On the in-memory \
                         bus only `--eds NODE=FILE` nodes exist.",
                        s.node
                    )?;
                }
                Ok(())
            }
            Self::Drive(e) => write!(f, "{e}"),
            Self::Dictionary { path, source } => write!(f, "{}: {source}", path.display()),
            Self::BuiltinDictionary(e) => write!(f, "{e}"),
            Self::NetworkConfig(e) => write!(f, "{e}"),
            Self::Log {
                path,
                source,
                nothing_sent,
            } => {
                write!(f, "{}: {source}", path.display())?;
                if *nothing_sent {
                    f.write_str(" (nothing was sent)")?;
                }
                Ok(())
            }
            Self::File { path, source } => write!(f, "{}: {source}", path.display()),
            Self::System { what, source } => write!(f, "{what}: {source}"),
            Self::Terminal(e) => write!(f, "{e}"),
            Self::Demo(e) => write!(f, "demo failed: {e}"),
            Self::NodeId(e) => write!(f, "{e}"),
            Self::Rejected { what, source } => write!(f, "{what}: {source}"),
            Self::Argument(text) | Self::Device(text) => f.write_str(text),
            Self::Object {
                node,
                entry,
                source,
            } => write!(f, "node {node}, object {entry}: {source}"),
            Self::Unconfirmed(reasons) => f.write_str(&reasons.join("; ")),
            Self::Usage(inner) => write!(f, "{inner}"),
            Self::Hinted { source, hint } => write!(f, "{source}\nhint: {hint}"),
            Self::Interrupted { signal } => write!(f, "interrupted by {signal}"),
        }
    }
}

impl std::error::Error for CliError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Bus(e) => Some(e),
            Self::Transport(e) => Some(e),
            Self::Adapter { source, .. } => Some(source),
            Self::Op(e) => Some(e),
            Self::Drive(e) => Some(e),
            Self::Dictionary { source, .. } | Self::BuiltinDictionary(source) => Some(source),
            Self::NetworkConfig(e) => Some(e),
            Self::Log { source, .. } => Some(source),
            Self::File { source, .. } | Self::System { source, .. } => Some(source),
            Self::Terminal(e) => Some(e),
            Self::Demo(e) => Some(e.as_ref()),
            Self::NodeId(e) => Some(e),
            Self::Rejected { source, .. } => Some(source.as_ref()),
            Self::Object { source, .. } | Self::Usage(source) | Self::Hinted { source, .. } => {
                Some(source.as_ref())
            }
            Self::Argument(_)
            | Self::Device(_)
            | Self::Unconfirmed(_)
            | Self::Interrupted { .. } => None,
        }
    }
}

impl From<canola::OpenError> for CliError {
    fn from(e: canola::OpenError) -> Self {
        Self::Bus(e)
    }
}

impl From<canola::TransportError> for CliError {
    fn from(e: canola::TransportError) -> Self {
        Self::Transport(e)
    }
}

impl From<canola::Error> for CliError {
    fn from(e: canola::Error) -> Self {
        Self::Op(e)
    }
}

impl From<canola_cia402::master::DriveError> for CliError {
    /// An SDO failure stays one (its JSON fields), the rest is the drive's.
    fn from(e: canola_cia402::master::DriveError) -> Self {
        match e {
            canola_cia402::master::DriveError::Sdo(e) => Self::Op(e),
            e => Self::Drive(e),
        }
    }
}

impl From<canola_manager::config::ConfigError> for CliError {
    fn from(e: canola_manager::config::ConfigError) -> Self {
        Self::NetworkConfig(e)
    }
}

impl From<canola::frame::NodeIdError> for CliError {
    fn from(e: canola::frame::NodeIdError) -> Self {
        Self::NodeId(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usage_errors_exit_2_and_read_as_their_cause() {
        let e = CliError::usage("give the node-ID");
        assert_eq!(e.to_string(), "give the node-ID");
        assert_eq!(e.exit_code(), ExitCode::from(2));
        // One rule: an argument that is wrong is a usage error too; what a device says is not.
        let e = CliError::Argument("x".into());
        assert_eq!(e.exit_code(), ExitCode::from(2));
        assert_eq!(CliError::Device("x".into()).exit_code(), ExitCode::FAILURE);
        let node = NodeId::new(5).unwrap();
        let e = e.into_usage().at(node, ObjectAddress::new(0x1017, 0));
        assert!(matches!(&e, CliError::Usage(inner) if matches!(**inner, CliError::Object { .. })));
        assert_eq!(e.to_string(), "node 5, object 0x1017:00: x");
    }

    #[test]
    fn a_file_error_names_the_file() {
        let e = CliError::file("/x/y")(std::io::Error::from(std::io::ErrorKind::NotFound));
        assert!(e.to_string().starts_with("/x/y: "), "{e}");
    }
}
