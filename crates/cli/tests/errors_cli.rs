//! How `canopen` fails, through the binary: one exit-code rule (2 for a command line that is
//! wrong, 1 for what it names failing), `--json` for every error including clap's own, and
//! the small wordings of issue 40 (the bus-name typo, `FAILED, 1 error`, `simulate` refused
//! before it says it runs, the `usdo` help).

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn code(o: &std::process::Output) -> Option<i32> {
    o.status.code()
}

#[test]
fn a_wrong_command_line_exits_2_everywhere() {
    let eds5 = format!("5={EDS}");
    for args in [
        // Each of these exited 1 before.
        vec!["--eds", "0=F", "sdo", "read", "5", "0x1017"],
        vec!["--eds", "5", "sdo", "read", "5", "0x1017"],
        vec!["lss", "configure-node-id", "128"],
        vec!["gateway", "--listen", "foo:1"],
        vec!["gateway"],
        vec!["--eds", &eds5, "--eds", &eds5, "sdo", "read", "5", "0x1017"],
        vec!["--eds", &eds5, "sdo", "read", "5", "No such object"],
        vec!["nmt", "start"],
        vec!["--eds", &eds5, "simulate", EDS, "--node-id", "5"],
        // Already 2: clap's own errors and the value checks.
        vec!["sdo", "read", "128", "0x1017"],
        vec!["sdo", "read", "0", "0x1017"],
        vec!["--eds", &eds5, "sdo", "write", "5", "0x1017", "0", "abc"],
        vec!["no-such-command"],
    ] {
        let o = canopen(&args);
        assert_eq!(code(&o), Some(2), "{args:?}: {}", stderr(&o));
        assert!(
            stderr(&o).starts_with("error: "),
            "{args:?}: {}",
            stderr(&o)
        );
    }
    // What the command line names failing is 1: a file that is not there, a node that does not
    // answer.
    for args in [
        vec![
            "--eds",
            "5=/nonexistent/x.eds",
            "sdo",
            "read",
            "5",
            "0x1017",
        ],
        vec!["sdo", "read", "5", "0x1017"],
    ] {
        let o = canopen(&args);
        assert_eq!(code(&o), Some(1), "{args:?}: {}", stderr(&o));
    }
}

/// The one JSON object `o` printed on stderr.
fn json_error(o: &std::process::Output) -> serde_json::Value {
    let text = stderr(o);
    assert_eq!(text.lines().count(), 1, "one line of JSON: {text}");
    serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[test]
fn json_covers_argument_parsing_errors() {
    // The node-ID is checked while clap parses.
    let o = canopen(&["--json", "sdo", "read", "128", "0x1017"]);
    assert_eq!(code(&o), Some(2));
    let v = json_error(&o);
    assert!(v["error"].as_str().unwrap().contains("node-ID 128"), "{v}");
    assert_eq!(v["kind"], "value-validation", "{v}");
    assert_eq!(v["argument"], "<NODE>", "{v}");
    assert_eq!(v["value"], "128", "{v}");
    assert_eq!(v["usage"], true, "{v}");
    // `--json` after the subcommand, and errors of other kinds.
    let o = canopen(&["sdo", "read", "5", "--json"]);
    assert_eq!(code(&o), Some(2));
    assert_eq!(json_error(&o)["kind"], "missing-required-argument");
    let o = canopen(&["--json", "sdo", "raed", "5", "0x1017"]);
    assert_eq!(code(&o), Some(2));
    let v = json_error(&o);
    assert_eq!(v["kind"], "invalid-subcommand", "{v}");
    assert!(v["hint"].as_str().unwrap().contains("read"), "{v}");
    let o = canopen(&["--json", "sdo", "read", "5", "0x1017", "--bogus"]);
    assert_eq!(json_error(&o)["kind"], "unknown-argument");
    // The usage errors of the commands themselves say so too.
    let o = canopen(&["--json", "--eds", "0=F", "sdo", "read", "5", "0x1017"]);
    assert_eq!(code(&o), Some(2));
    let v = json_error(&o);
    assert_eq!(v["usage"], true, "{v}");
    assert!(v["error"].as_str().unwrap().contains("node-ID 0"), "{v}");
    let o = canopen(&["--json", "gateway"]);
    assert!(
        json_error(&o)["error"]
            .as_str()
            .unwrap()
            .contains("nothing to serve")
    );
    // Help is still text, on stdout, exit 0; and `--json` after `--` is a value, not the flag.
    let o = canopen(&["--json", "sdo", "--help"]);
    assert_eq!(code(&o), Some(0));
    assert!(stdout(&o).contains("Usage: canopen sdo"), "{}", stdout(&o));
    let o = canopen(&["sdo", "write", "128", "0x2000", "--", "--json"]);
    assert_eq!(code(&o), Some(2));
    assert!(stderr(&o).starts_with("error: "), "{}", stderr(&o));
}

#[test]
fn a_misspelt_bus_name_suggests_the_bus_meant() {
    let o = canopen(&["--iface", "udpp", "scan"]);
    assert_eq!(code(&o), Some(1));
    let err = stderr(&o);
    assert!(err.contains("did you mean `udp`?"), "{err}");
    assert!(!err.contains("type vcan"), "{err}");
}

#[test]
fn one_error_is_one_error() {
    let dir = std::env::temp_dir().join(format!("canopen-errors-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The Bürkert EDS with one broken object: 0x1017 of a type that does not exist.
    let text = std::fs::read_to_string(EDS).unwrap();
    let at = text.find("[1017]").unwrap();
    let dt = at + text[at..].find("DataType=").unwrap();
    let end = dt + text[dt..].find('\n').unwrap();
    let broken = format!("{}DataType=0x0099{}", &text[..dt], &text[end..]);
    let path = dir.join("one.eds");
    std::fs::write(&path, broken).unwrap();
    let o = canopen(&["eds", "check", path.to_str().unwrap()]);
    assert_eq!(code(&o), Some(1));
    assert!(
        stdout(&o).ends_with(": FAILED, 1 error\n"),
        "{}",
        stdout(&o)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_without_duration_is_refused_before_it_says_it_runs() {
    let o = canopen(&["simulate", EDS, "--node-id", "5"]);
    assert_eq!(code(&o), Some(2));
    let err = stderr(&o);
    assert!(!err.contains("simulating"), "{err}");
    assert!(
        err.starts_with("error: on the in-memory bus give --duration"),
        "{err}"
    );
}

#[test]
fn usdo_help_says_where_fd_is_needed() {
    let o = canopen(&["usdo", "--help"]);
    let help = stdout(&o);
    assert!(help.contains("the UDP bus carries CAN FD"), "{help}");
    assert!(help.contains("upload"), "{help}");
}
