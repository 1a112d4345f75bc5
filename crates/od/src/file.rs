//! File conveniences (feature `std`): load an EDS/DCF by path with the path in every message,
//! and save EDS/DCF text.

use std::path::{Path, PathBuf};
use std::string::{String, ToString};
use std::vec::Vec;

use crate::diag::Diagnostic;
use crate::model::ObjectDictionary;
use crate::parse::{ParseError, parse};

/// A parsed file with its path.
#[derive(Debug, Clone)]
pub struct LoadedFile {
    /// The path as given.
    pub path: PathBuf,
    /// The object dictionary.
    pub od: ObjectDictionary,
    /// Warnings, sorted by line; render them with [`Diagnostic::render`] and the path.
    pub diagnostics: Vec<Diagnostic>,
}

impl LoadedFile {
    /// The warnings as `FILE:LINE: warning: message` lines.
    pub fn rendered_diagnostics(&self) -> Vec<String> {
        let file = self.path.display().to_string();
        self.diagnostics
            .iter()
            .map(|d| d.render(&file).to_string())
            .collect()
    }
}

/// Why a file could not be loaded.
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file could not be understood.
    #[error("{}", render_parse_error(path, error))]
    Parse {
        /// The path.
        path: PathBuf,
        /// Every error and warning with its line.
        error: ParseError,
    },
}

debug_as_display!(LoadError);

fn render_parse_error(path: &Path, error: &ParseError) -> String {
    let file = path.display().to_string();
    let lines: Vec<String> = error
        .errors()
        .map(|d| d.render(&file).to_string())
        .collect();
    lines.join("\n")
}

/// Reads and parses an EDS or DCF file.
pub fn load(path: impl AsRef<Path>) -> Result<LoadedFile, LoadError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.into(),
        source,
    })?;
    match parse(&bytes) {
        Ok(p) => Ok(LoadedFile {
            path: path.into(),
            od: p.od,
            diagnostics: p.diagnostics,
        }),
        Err(error) => Err(LoadError::Parse {
            path: path.into(),
            error,
        }),
    }
}

/// Writes `od` as an EDS file.
pub fn save_eds(od: &ObjectDictionary, path: impl AsRef<Path>) -> std::io::Result<()> {
    std::fs::write(path, crate::write::write_eds(od))
}

/// Writes `od` configured for `node_id` as a DCF file (see [`crate::write::write_dcf`]).
pub fn save_dcf(
    od: &ObjectDictionary,
    node_id: u8,
    baudrate_kbit: Option<u16>,
    path: impl AsRef<Path>,
) -> std::io::Result<()> {
    std::fs::write(path, crate::write::write_dcf(od, node_id, baudrate_kbit))
}
