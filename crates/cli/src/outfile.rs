//! Output files that appear whole or not at all.
//!
//! A command that writes `-o FILE` (`sdo upload`, `record`, ...) writes a temporary file beside
//! it (`.FILE.PID.tmp`, same directory, so same file system) and renames it over `FILE` only
//! when everything was written and flushed: a failed upload or recording leaves an existing
//! `FILE` as it was and no partial file behind, also when the process ends by a signal (Ctrl-C,
//! SIGTERM: the temporary file is registered with [`crate::bus::remove_on_signal`]). A `FILE`
//! that exists and is not a regular file
//! (`/dev/null`, `/dev/full`, a FIFO, `/dev/stdout`) is written directly: renaming over it
//! would replace the device, and a write error there is still reported.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::error::CliError;

/// An output file being written (see the module docs). Dropped without
/// [`commit`](Self::commit), it removes its temporary file.
#[derive(Debug)]
pub(crate) struct OutFile {
    path: PathBuf,
    /// The temporary file, `None` when writing `path` directly.
    temp: Option<PathBuf>,
    file: File,
    /// Removes the temporary file when the process ends by a signal.
    on_signal: Option<crate::bus::SignalGuard>,
}

impl OutFile {
    /// Opens the temporary file beside `path` (or `path` itself, when it is not a regular file).
    pub(crate) fn create(path: &Path) -> Result<Self, CliError> {
        let name = CliError::file(path);
        let direct = std::fs::metadata(path).is_ok_and(|m| !m.is_file());
        if direct {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(name)?;
            return Ok(Self {
                path: path.to_owned(),
                temp: None,
                file,
                on_signal: None,
            });
        }
        let temp = temp_beside(path);
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&temp)
            .map_err(CliError::file(path))?;
        let on_signal = Some(crate::bus::remove_on_signal(&temp));
        Ok(Self {
            path: path.to_owned(),
            temp: Some(temp),
            file,
            on_signal,
        })
    }

    /// A handle to write through (the same open file).
    pub(crate) fn writer(&self) -> Result<File, CliError> {
        self.file.try_clone().map_err(CliError::file(&self.path))
    }

    /// Puts the written file in place of `FILE`. Everything must have been flushed.
    pub(crate) fn commit(mut self) -> Result<(), CliError> {
        // Once renamed, the file at the temporary path's inode is `FILE`: it stays.
        let _registered = self.on_signal.take();
        match self.temp.take() {
            Some(temp) => std::fs::rename(&temp, &self.path).map_err(|e| {
                let _ = std::fs::remove_file(&temp);
                CliError::file(&self.path)(e)
            }),
            None => Ok(()),
        }
    }
}

impl Drop for OutFile {
    fn drop(&mut self) {
        if let Some(temp) = &self.temp {
            let _ = std::fs::remove_file(temp);
        }
    }
}

/// `FILE` with a temporary name beside it.
fn temp_beside(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    output.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `bytes` to `path` whole or not at all.
pub(crate) fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    use std::io::Write as _;
    let out = OutFile::create(path)?;
    let mut w = out.writer()?;
    w.write_all(bytes)
        .and_then(|()| w.flush())
        .map_err(CliError::file(path))?;
    out.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_appears_only_when_committed() {
        let dir = std::env::temp_dir().join(format!("canopen-outfile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.bin");
        std::fs::write(&path, b"old").unwrap();
        {
            let out = OutFile::create(&path).unwrap();
            std::io::Write::write_all(&mut out.writer().unwrap(), b"half").unwrap();
            // Dropped without commit: the old file stays, no temporary file is left.
        }
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        write_whole(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn devices_are_written_directly() {
        let out = OutFile::create(Path::new("/dev/null")).unwrap();
        assert!(out.temp.is_none());
        out.commit().unwrap();
    }
}
