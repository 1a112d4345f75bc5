//! One decoder for every command: what `demo`, `replay` and `analyze --frames` make of frames
//! and logs that real recordings contain (a log cut mid-file, a log that starts inside an SDO
//! block transfer, a PDO remote request, error frames).

mod common;

use common::{canopen, stderr, stdout};

fn log_file(name: &str, text: &str) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!("canopen-decode-{}-{name}", std::process::id()));
    std::fs::write(&path, text).unwrap();
    path
}

/// Issue 40 point 13: the demo's abort section read the abort as a block segment (the logbook
/// transfer before it was shown only in part, and the monitor did not see its end).
#[test]
fn the_demos_abort_section_decodes_the_abort_as_an_abort() {
    let out = canopen(&["demo"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let line = text
        .lines()
        .find(|l| l.contains("585#8000600100000206"))
        .unwrap_or_else(|| panic!("no abort frame in\n{text}"));
    assert!(
        line.contains("node 5: SDO abort transfer 0x6000:01: 0x06020000"),
        "{line}"
    );
    assert!(!text.contains("block segment 0"), "{text}");
}

/// Issue 40 point 9: a log cut after a whole byte replayed the shorter frame, exit 0.
#[test]
fn replay_refuses_a_log_cut_at_a_byte_boundary() {
    let cut = log_file(
        "cut.log",
        "(1.000000) mem0 705#05\n(1.100000) mem0 185#2E93",
    );
    let out = canopen(&["replay", cut.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("line 2") && err.contains("cut"), "{err}");
    assert!(err.contains("nothing was sent"), "{err}");
    // The same log with its line end replays.
    let whole = log_file(
        "whole.log",
        "(1.000000) mem0 705#05\n(1.100000) mem0 185#2E93\n",
    );
    let out = canopen(&["replay", whole.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("2 frames replayed"),
        "{}",
        stderr(&out)
    );
}

/// Issue 42: `replay` in text mode dropped the count of skipped error frames its help promises.
#[test]
fn replay_says_how_many_error_frames_it_skipped() {
    let log = log_file(
        "errors.log",
        "(1.000000) mem0 705#05\n(1.000100) mem0 20000004#0004000000000000\n(1.000200) mem0 705#05\n",
    );
    let out = canopen(&["replay", log.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("2 frames replayed (1 error frames skipped)"),
        "{err}"
    );
}

/// Issue 42: a log that starts inside a block download, and a PDO remote request, decode right
/// in `analyze --frames` (the monitor's decoder), text and JSON.
#[test]
fn analyze_frames_decodes_a_log_without_replaying_it() {
    let log = log_file(
        "block.log",
        "(1.000000) can0 584#A27F7F0000000000\n\
         (1.000100) can0 604#0111223344556677\n\
         (1.000200) can0 604#82AABBCCDDEEFF00\n\
         (1.000300) can0 584#A2027F0000000000\n\
         (1.000400) can0 604#C900000000000000\n\
         (1.000500) can0 584#A100000000000000\n\
         (2.000000) can0 181#R\n\
         (2.500000) can0 20000040#0000000000000000\n",
    );
    let out = canopen(&["analyze", "--frames", log.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let lines: Vec<_> = text.lines().collect();
    assert_eq!(lines.len(), 8, "{text}");
    assert!(lines[0].starts_with("1.000000  584"), "{}", lines[0]);
    assert!(
        lines[1].contains("node 4: SDO block segment 1"),
        "{}",
        lines[1]
    );
    assert!(
        lines[2].contains("node 4: SDO block segment 2") && lines[2].ends_with("last"),
        "{}",
        lines[2]
    );
    assert!(
        lines[4].contains("SDO end block download request"),
        "{}",
        lines[4]
    );
    assert!(
        lines[6].contains("TPDO1 node 1: remote transmission request"),
        "{}",
        lines[6]
    );
    assert!(lines[7].contains("CAN error frame"), "{}", lines[7]);
    // --json: one object per frame, as `monitor --json` writes them.
    let out = canopen(&["analyze", "--frames", "--json", log.to_str().unwrap()]);
    let objects: Vec<serde_json::Value> = stdout(&out)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(objects.len(), 8);
    assert_eq!(objects[1]["frame"], "604#0111223344556677");
    assert!(
        objects[1]["decoded"]
            .as_str()
            .unwrap()
            .contains("block segment 1")
    );
    assert_eq!(objects[6]["time"], 2.0);
    // From standard input too, and a bad line is reported with its number (exit 1).
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["analyze", "--frames", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Write as _;
        let mut stdin = child.stdin.take().unwrap();
        stdin
            .write_all(b"(1.000000) can0 705#05\nnonsense\n(1.1) can0 705#05\n")
            .unwrap();
    }
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout(&out).lines().count(), 2);
    assert!(stderr(&out).contains("line 2"), "{}", stderr(&out));
}
