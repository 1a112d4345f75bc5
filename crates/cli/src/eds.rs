//! `canopen eds ...`: check, show, convert and generate code from CiA 306 EDS/DCF files.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use canola::od::{Diagnostic, ObjectDictionary, ParseOptions, Severity};
use clap::{Args, Subcommand};
use serde_json::{Value as Json, json};

use crate::Global;
use crate::error::CliError;

/// What the parser reports (every subcommand that reads a file prints its diagnostics).
#[derive(Debug, Clone, Copy, Args)]
pub(crate) struct Report {
    /// Hide style-only warnings (key and section-name case, lower-case hex digits, `Sub` for
    /// `sub`, spaces around keys, trailing blanks): deviations that change nothing in how the
    /// file is read.
    #[arg(long)]
    no_style: bool,
}

impl Report {
    fn options(self) -> ParseOptions {
        ParseOptions::new().style_warnings(!self.no_style)
    }
}

#[derive(Debug, Subcommand)]
pub(crate) enum EdsCommand {
    /// Parse files; exit 0 when all parse. Warnings and errors go to stderr as FILE:LINE (at
    /// most 25 of each kind, then a count of the rest). An empty file, or one without a single
    /// [section], fails.
    Check {
        /// EDS or DCF files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        #[command(flatten)]
        report: Report,
    },
    /// Consistency checks (SubNumber, object lists, limits, PDO mappings, codes, duplicates):
    /// findings on stderr as FILE:LINE: warning: ..., exit 1 when there are any.
    Lint {
        /// EDS or DCF file.
        file: PathBuf,
    },
    /// Print the objects of a file as a table (or JSON with --json).
    Show {
        /// EDS or DCF file.
        file: PathBuf,
        #[command(flatten)]
        report: Report,
    },
    /// Write a DCF for a node: `$NODEID` resolved into ParameterValue, `[DeviceComissioning]` set.
    ToDcf {
        /// EDS file.
        file: PathBuf,
        /// Node-ID, 1..=127.
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=127))]
        node_id: u8,
        /// Bit rate in kbit/s for `[DeviceComissioning]`.
        #[arg(long)]
        baudrate: Option<u16>,
        /// Output file (default: stdout).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        report: Report,
    },
    /// Generate typed Rust entries (what `canola_codegen::compile_eds` writes in build.rs).
    Codegen {
        /// EDS file.
        file: PathBuf,
        /// Also emit a static, allocation-free dictionary of every sub-object.
        #[arg(long)]
        static_dictionary: bool,
        /// Also emit one struct per default PDO mapping (`Tpdo1`, `Rpdo1`, ...; needs canola-pdo).
        #[arg(long)]
        pdo_structs: bool,
        /// The preset for an application on the `canola` crate: paths through `::canola`,
        /// PDO structs and the typed node client (`client::Device`).
        #[arg(long)]
        for_canola: bool,
        /// Output file (default: stdout).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        report: Report,
    },
}

pub(crate) fn run(cmd: EdsCommand, global: Global) -> ExitCode {
    match cmd {
        EdsCommand::Check { files, report } => check(&files, report, global),
        EdsCommand::Lint { file } => lint(&file, global),
        EdsCommand::Show { file, report } => with_od(&file, report, global, |od| show(od, global)),
        EdsCommand::ToDcf {
            file,
            node_id,
            baudrate,
            output,
            report,
        } => with_od(&file, report, global, |od| {
            emit(
                output.as_deref(),
                &canola::od::write_dcf(od, node_id, baudrate),
            )
        }),
        EdsCommand::Codegen {
            file,
            static_dictionary,
            pdo_structs,
            for_canola,
            output,
            report,
        } => with_od(&file, report, global, |od| {
            let name = file.file_name().map_or_else(
                || file.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            let mut config = if for_canola {
                canola_codegen::Config::for_canola()
            } else {
                canola_codegen::Config::new()
            };
            config.static_dictionary(static_dictionary);
            if pdo_structs {
                config.pdo_structs(true);
            }
            let (code, notes) = config.generate_with_notes(od, &name);
            for note in notes {
                eprintln!("{}: warning: codegen: {note}", file.display());
            }
            emit(output.as_deref(), &code)
        }),
    }
}

/// Why a file did not load: it could not be read, or it did not parse.
enum Failed {
    Read(std::io::Error),
    Parse(canola::od::ParseError),
}

impl Failed {
    /// The diagnostics as `FILE:LINE: ...` lines (a read error as `FILE: error: ...`).
    fn lines(&self, name: &str) -> Vec<String> {
        match self {
            Self::Read(e) => vec![format!("{name}: error: {e}")],
            Self::Parse(e) => e
                .diagnostics
                .iter()
                .map(|d| d.render(name).to_string())
                .collect(),
        }
    }

    /// How many errors the file has, listed or not.
    fn errors(&self) -> usize {
        match self {
            Self::Read(_) => 1,
            Self::Parse(e) => e.error_count(),
        }
    }

    /// The diagnostics themselves (none when the file could not be read).
    fn diagnostics(&self) -> &[Diagnostic] {
        match self {
            Self::Read(_) => &[],
            Self::Parse(e) => &e.diagnostics,
        }
    }

    /// The error every other command reports for it (under `--json` one JSON object with the
    /// file, and for a parse error the line and the diagnostics).
    fn into_cli_error(self, file: &Path) -> CliError {
        match self {
            Self::Read(source) => CliError::File {
                path: file.to_owned(),
                source,
            },
            Self::Parse(source) => CliError::Dictionary {
                path: file.to_owned(),
                source,
            },
        }
    }
}

/// A diagnostic as `eds check --json` and `eds lint --json` give it.
fn diagnostic_json(file: &str, d: &Diagnostic) -> Json {
    json!({"file": file, "line": d.line, "severity": d.severity.to_string(), "message": d.message})
}

/// The diagnostics of `severity` as JSON objects.
pub(crate) fn diagnostics_json(file: &str, diagnostics: &[Diagnostic], severity: Severity) -> Json {
    Json::Array(
        diagnostics
            .iter()
            .filter(|d| d.severity == severity)
            .map(|d| diagnostic_json(file, d))
            .collect(),
    )
}

/// Reads and parses a file: the dictionary and its warnings, or why it failed.
fn load(file: &Path, report: Report) -> Result<(ObjectDictionary, Vec<Diagnostic>), Failed> {
    let bytes = std::fs::read(file).map_err(Failed::Read)?;
    canola::od::parse_with(&bytes, report.options())
        .map(|parsed| (parsed.od, parsed.diagnostics))
        .map_err(Failed::Parse)
}

/// Prints a diagnostic on stderr as `FILE:LINE: severity: message`, or under `--json` as one
/// JSON object (`warning` or `error`, `level`, `file`, `line`), as every command's warnings.
fn print_diagnostic(name: &str, d: &Diagnostic, global: Global) {
    if global.json {
        let mut fields = serde_json::Map::new();
        fields.insert("file".into(), name.into());
        fields.insert("line".into(), d.line.into());
        crate::bus::warn(&d.severity.to_string(), &d.message, fields);
    } else {
        eprintln!("{}", d.render(name));
    }
}

/// Loads `file` and runs `f` on its dictionary. Its warnings go to stderr; a file that does
/// not load is reported as text (`FILE:LINE: error: ...` lines), or under `--json` as one JSON
/// error object.
fn with_od(
    file: &Path,
    report: Report,
    global: Global,
    f: impl FnOnce(&ObjectDictionary) -> ExitCode,
) -> ExitCode {
    let name = file.display().to_string();
    match load(file, report) {
        Ok((od, diagnostics)) => {
            for d in &diagnostics {
                print_diagnostic(&name, d, global);
            }
            f(&od)
        }
        Err(failed) if global.json => failed.into_cli_error(file).report(),
        Err(failed) => {
            for l in failed.lines(&name) {
                eprintln!("{l}");
            }
            ExitCode::FAILURE
        }
    }
}

fn emit(output: Option<&Path>, text: &str) -> ExitCode {
    match output {
        None => {
            crate::out(text);
            ExitCode::SUCCESS
        }
        Some(path) => match crate::outfile::write_whole(path, text.as_bytes()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => crate::bus::fail(e),
        },
    }
}

/// How many diagnostics of `severity` a list stands for, counting those a `Suppressed`
/// summary stands for.
fn total(diagnostics: &[Diagnostic], severity: Severity) -> usize {
    diagnostics
        .iter()
        .filter(|d| d.severity == severity)
        .map(|d| d.suppressed_count().unwrap_or(1))
        .sum()
}

fn check(files: &[PathBuf], report_opts: Report, global: Global) -> ExitCode {
    let mut all_ok = true;
    let mut report = Vec::new();
    for file in files {
        let name = file.display().to_string();
        match load(file, report_opts) {
            Ok((od, diagnostics)) => {
                let warnings = total(&diagnostics, Severity::Warning);
                if global.json {
                    // Under --json, the diagnostics are in the report, not on stderr.
                    report.push(json!({
                        "file": name, "ok": true, "objects": od.objects.len(),
                        "error_count": 0, "warning_count": warnings,
                        "errors": [],
                        "warnings": diagnostics_json(&name, &diagnostics, Severity::Warning),
                    }));
                } else {
                    for d in &diagnostics {
                        eprintln!("{}", d.render(&name));
                    }
                    crate::outln(&format!(
                        "{name}: ok, {} objects, {warnings} warnings",
                        od.objects.len()
                    ));
                }
            }
            Err(failed) => {
                all_ok = false;
                let (lines, errors) = (failed.lines(&name), failed.errors());
                let diagnostics = failed.diagnostics();
                if global.json {
                    let mut error_list = diagnostics_json(&name, diagnostics, Severity::Error);
                    if diagnostics.is_empty() {
                        // Not read at all: the reason as the one error.
                        error_list = Json::Array(
                            lines
                                .iter()
                                .map(|l| json!({"file": name, "line": 0, "severity": "error", "message": l.strip_prefix(&format!("{name}: error: ")).unwrap_or(l)}))
                                .collect(),
                        );
                    }
                    report.push(json!({
                        "file": name, "ok": false,
                        "error_count": errors,
                        "warning_count": total(diagnostics, Severity::Warning),
                        "errors": error_list,
                        "warnings": diagnostics_json(&name, diagnostics, Severity::Warning),
                    }));
                } else {
                    for l in &lines {
                        eprintln!("{l}");
                    }
                    crate::outln(&format!(
                        "{name}: FAILED, {errors} error{}",
                        if errors == 1 { "" } else { "s" }
                    ));
                }
            }
        }
    }
    if global.json {
        crate::outln(&Json::Array(report).to_string());
    }
    if all_ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn lint(file: &Path, global: Global) -> ExitCode {
    let name = file.display().to_string();
    let bytes = match std::fs::read(file) {
        Ok(b) => b,
        Err(e) if global.json => return Failed::Read(e).into_cli_error(file).report(),
        Err(e) => {
            eprintln!("{name}: error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let findings = match canola::od::lint::lint_source(&bytes) {
        Ok(f) => f,
        Err(e) if global.json => return Failed::Parse(e).into_cli_error(file).report(),
        Err(e) => {
            for d in &e.diagnostics {
                eprintln!("{}", d.render(&name));
            }
            return ExitCode::FAILURE;
        }
    };
    if global.json {
        let list: Vec<Json> = findings.iter().map(|d| diagnostic_json(&name, d)).collect();
        crate::outln(&json!({"file": name, "findings": list}).to_string());
    } else {
        for d in &findings {
            eprintln!("{}", d.render(&name));
        }
        // A summary of findings not listed counts as what it stands for.
        let count = total(&findings, Severity::Warning) + total(&findings, Severity::Error);
        crate::outln(&format!("{name}: {count} findings"));
    }
    if findings.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn default_text(sub: &canola::od::SubObject) -> Option<String> {
    sub.default_value.as_ref().map(|d| d.text.trim().to_owned())
}

fn show(od: &ObjectDictionary, global: Global) -> ExitCode {
    if global.json {
        let objects: Vec<Json> = od
            .objects
            .values()
            .map(|obj| {
                let subs: Vec<Json> = obj
                    .subs
                    .values()
                    .map(|s| {
                        json!({
                            "subindex": s.sub_index,
                            "name": s.name.as_str(),
                            "data_type": s.data_type.code(),
                            "access": s.access.as_str(),
                            "pdo_mapping": s.pdo_mapping,
                            "default": default_text(s),
                        })
                    })
                    .collect();
                json!({
                    "index": obj.index,
                    "name": obj.name.as_str(),
                    "object_type": obj.object_code.code(),
                    "subs": subs,
                })
            })
            .collect();
        crate::outln(&json!({ "objects": objects }).to_string());
        return ExitCode::SUCCESS;
    }
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<6} {:<4} {:<40} {:<15} {:<6} {:<4} DEFAULT",
        "INDEX", "SUB", "NAME", "TYPE", "ACCESS", "PDO"
    );
    for obj in od.objects.values() {
        if !obj.is_simple() {
            let _ = writeln!(
                out,
                "{:04X}   {:<4} {:<40} [{}]",
                obj.index,
                "",
                truncate(&obj.name, 40),
                obj.object_code.name()
            );
        }
        for s in obj.subs.values() {
            let name = if obj.is_simple() { &obj.name } else { &s.name };
            let _ = writeln!(
                out,
                "{:<6} {:<4} {:<40} {:<15} {:<6} {:<4} {}",
                if obj.is_simple() {
                    format!("{:04X}", obj.index)
                } else {
                    String::new()
                },
                s.sub_index,
                truncate(name, 40),
                s.data_type.name().unwrap_or("?"),
                s.access.as_str(),
                if s.pdo_mapping { "yes" } else { "" },
                default_text(s).unwrap_or_default()
            );
        }
    }
    crate::out(&out);
    ExitCode::SUCCESS
}

fn truncate(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(max - 1).collect();
        t.push('…');
        t
    }
}
