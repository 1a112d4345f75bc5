//! Shared helpers of the integration tests: where the real-world EDS corpus is.
#![allow(dead_code)]

use std::path::PathBuf;

/// The workspace root (two levels above this crate), symlinks resolved.
pub(crate) fn workspace_root() -> PathBuf {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let manifest = std::fs::canonicalize(&manifest).unwrap_or(manifest);
    manifest.join("../..")
}

/// The corpus folder: `CANOPEN_EDS_CORPUS` when set (a git worktree lives elsewhere than the
/// main checkout), else `../shared/eds-corpus` next to the workspace; `None` (after printing
/// why) when it does not exist. With `CANOPEN_REQUIRE_CORPUS=1` a missing corpus panics.
pub(crate) fn corpus_dir(test: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("CANOPEN_EDS_CORPUS") {
        Some(dir) => PathBuf::from(dir),
        None => workspace_root().join("../shared/eds-corpus"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("CANOPEN_REQUIRE_CORPUS").as_deref() == Ok("1") {
        panic!(
            "{test}: CANOPEN_REQUIRE_CORPUS=1 but the EDS corpus is missing at {}",
            dir.display()
        );
    }
    eprintln!(
        "SKIPPED {test}: EDS corpus not found at {} (set CANOPEN_REQUIRE_CORPUS=1 to make this fatal)",
        dir.display()
    );
    None
}

/// Every `.eds` / `.dcf` file of the corpus, sorted by name.
pub(crate) fn corpus_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("read corpus dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension()
                    .and_then(|e| e.to_str())
                    .map(str::to_ascii_lowercase)
                    .as_deref(),
                Some("eds" | "dcf")
            )
        })
        .collect();
    files.sort();
    files
}

/// The file that must fail to parse.
pub(crate) const BROKEN: &str = "kaco__401.eds";
