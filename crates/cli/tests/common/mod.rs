//! What the CLI tests share: running the `canopen` binary and reading its output.
#![allow(dead_code)] // each test file uses the part it needs

use std::process::{Command, Output};

/// Runs `canopen ARGS...` to completion.
pub(crate) fn canopen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Its standard output as text.
pub(crate) fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Its standard error as text.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
