//! How the binary reads what a user types (negative values, indices, names, sub-index
//! defaults, repeated flags) and how it reports (number style, JSON errors, hints).

use std::os::unix::fs::FileTypeExt as _;
use std::process::Command;

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

/// A small device with a signed 64-bit object, for the negative-value tests.
const SIGNED_EDS: &str = "[FileInfo]\nFileName=signed.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=signed\nVendorNumber=0x39\nProductNumber=1\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x39\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=0\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2120\n\
[2120]\nParameterName=Offset\nObjectType=0x9\nSubNumber=2\n\
[2120sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[2120sub1]\nParameterName=Signed offset\nObjectType=0x7\nDataType=0x0015\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n";

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-cli-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn signed_eds() -> String {
    let p = tmp("signed.eds");
    std::fs::write(&p, SIGNED_EDS).unwrap();
    format!("4={}", p.display())
}

#[test]
fn negative_numbers_are_values() {
    let eds = signed_eds();
    // Each write succeeds only if the value parsed and the simulator took its 8 bytes.
    for args in [
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "1", "-42", "--type", "i64",
        ],
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "1", "--type", "i64", "--", "-42",
        ],
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "--", "1", "-0x10",
        ],
        // Options after the value, also after `--`, and `-t` for `--type`.
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "1", "--", "-42", "--type", "i64",
        ],
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "1", "-42", "-t", "i64",
        ],
        vec![
            "--eds", &eds, "sdo", "write", "4", "0x2120", "1", "--", "-0x10", "-t", "i64", "--json",
        ],
        vec![
            "--eds",
            &eds,
            "sdo",
            "write",
            "4",
            "Signed offset",
            "-9223372036854775808",
        ],
    ] {
        let o = canopen(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "write",
        "4",
        "0x2120",
        "1",
        "-9223372036854775809",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("out of range"), "{}", stderr(&o));
}

/// The value that arrives is the one typed: written from one process to a simulator in
/// another, read back.
#[test]
fn negative_values_after_dashes_arrive_as_typed() {
    let iface = common::udp_bus(2);
    let eds_file = tmp("signed-sim.eds");
    std::fs::write(&eds_file, SIGNED_EDS).unwrap();
    let mut sim = common::simulator(&iface, eds_file.to_str().unwrap(), "4", "30");
    let eds = format!("4={}", eds_file.display());
    let read = || {
        let o = canopen(&[
            "--iface", &iface, "--eds", &eds, "sdo", "read", "4", "0x2120", "1",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    for (args, expected) in [
        (vec!["1", "--", "-42", "--type", "i64"], "-42\n"),
        (vec!["1", "--", "-0x10", "-t", "i64", "--json"], "-16\n"),
        (vec!["1", "-7", "-t", "i64"], "-7\n"),
        (vec!["--", "1", "-0x20", "--type=i64"], "-32\n"),
    ] {
        let mut line = vec![
            "--iface", &iface, "--eds", &eds, "sdo", "write", "4", "0x2120",
        ];
        line.extend(&args);
        let o = canopen(&line);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert_eq!(read(), expected, "{args:?}");
    }
    // cpos takes negative values too (the simulated positioner checks the range).
    let o = canopen(&["cpos", "set", "4 mA S", "--", "-5", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["value"], -5);
    let _ = sim.kill();
    let _ = sim.wait();
}

#[test]
fn indices_sub_defaults_and_names() {
    let eds = format!("5={EDS}");
    let read = |args: &[&str]| {
        let mut all = vec!["--eds", eds.as_str(), "sdo", "read", "5"];
        all.extend_from_slice(args);
        canopen(&all)
    };
    // Sub-index defaults to 0.
    assert_eq!(stdout(&read(&["0x1017"])), "500\n");
    // Names, case-insensitively, from the node's dictionary; OBJECT/SUB names a sub-object.
    assert_eq!(stdout(&read(&["producer heartbeat time"])), "500\n");
    assert_eq!(stdout(&read(&["PRODUCER HEARTBEAT TIME", "0"])), "500\n");
    assert_eq!(stdout(&read(&["identity object/vendor id"])), "57\n");
    // The library's syntax too: a dot, and the printed form `Object / Sub-object`.
    assert_eq!(stdout(&read(&["Identity object.Vendor ID"])), "57\n");
    assert_eq!(stdout(&read(&["Identity object / Vendor ID"])), "57\n");
    let o = read(&["No such object"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no object named"), "{}", stderr(&o));
    // Without a dictionary a name is refused with the way out.
    let o = canopen(&["sdo", "read", "5", "Producer heartbeat time"]);
    assert!(stderr(&o).contains("--eds NODE=FILE"), "{}", stderr(&o));
    // A decimal index that looks like a hex one: read as decimal, and the note says so.
    let o = read(&["1017", "0"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("index `1017` is decimal, object 0x03F9"), "{e}");
    assert!(e.contains("`0x1017`"), "{e}");
    // A decimal index in range is taken without a note.
    let o = read(&["4119"]);
    assert_eq!(stdout(&o), "500\n");
    assert!(!stderr(&o).contains("note"), "{}", stderr(&o));
    // Under --json the note is a JSON warning object, like the error after it.
    let o = canopen(&[
        "--json",
        "--eds",
        &format!("5={EDS}"),
        "sdo",
        "read",
        "5",
        "1017",
        "0",
    ]);
    let lines: Vec<serde_json::Value> = stderr(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect();
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(lines[0]["warning"].as_str().unwrap().contains("is decimal"));
    assert_eq!(lines[0]["level"], "note");
    assert_eq!(lines[0]["given"], "1017");
    assert_eq!(lines[0]["index"], 1017);
    assert!(lines[1]["error"].is_string());
}

#[test]
fn a_node_has_one_dictionary() {
    let a = format!("5={EDS}");
    let o = canopen(&["--eds", &a, "--eds", &a, "scan"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("node 5 already has a dictionary"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn one_number_style_with_a_hex_switch() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--eds", &eds, "sdo", "read", "5", "0x1018", "1"]);
    assert_eq!(stdout(&o), "57\n");
    let scan = stdout(&canopen(&["--eds", &eds, "scan"]));
    assert!(
        scan.lines()
            .any(|l| l.split_whitespace().take(2).eq(["5", "57"])),
        "{scan}"
    );
    let o = canopen(&["--eds", &eds, "--hex", "sdo", "read", "5", "0x1018", "1"]);
    assert_eq!(stdout(&o), "0x00000039\n");
    let scan = stdout(&canopen(&["--eds", &eds, "--hex", "scan"]));
    assert!(
        scan.lines()
            .any(|l| l.split_whitespace().take(2).eq(["5", "0x00000039"])),
        "{scan}"
    );
    // Signed values and strings are the same either way.
    let o = canopen(&["--eds", &eds, "--hex", "sdo", "read", "5", "0x1008"]);
    assert_eq!(stdout(&o), "Buerkert generic device\n");
    // LSS identities: the same style, the same switch.
    let lss = |args: &[&str]| {
        let o = canopen(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        stdout(&o)
    };
    assert_eq!(
        lss(&["lss", "--unconfigured", "1", "fastscan"]),
        "found vendor-id 57, product 16777217, revision 1, serial 1001\n"
    );
    assert_eq!(
        lss(&["--hex", "lss", "--unconfigured", "1", "fastscan"]),
        "found vendor-id 0x00000039, product 0x01000001, revision 0x00000001, serial 0x000003E9\n"
    );
    assert_eq!(
        lss(&[
            "--hex",
            "lss",
            "--unconfigured",
            "2",
            "assign-all",
            "--first",
            "5"
        ]),
        "vendor-id 0x00000039, product 0x01000001, revision 0x00000001, serial 0x000003E9: node-ID 5\n\
         vendor-id 0x00000039, product 0x01000001, revision 0x00000001, serial 0x000003EA: node-ID 6\n"
    );
    assert_eq!(
        lss(&["lss", "--unconfigured", "2", "discover-all"]),
        "found vendor-id 57, product 16777217, revision 1, serial 1001\n\
         found vendor-id 57, product 16777217, revision 1, serial 1002\n"
    );
    assert_eq!(
        lss(&["lss", "--unconfigured", "1", "identify-non-configured"]),
        "an unconfigured slave answered\n"
    );
    // JSON keeps numbers as numbers.
    let v: serde_json::Value = serde_json::from_str(&lss(&[
        "--hex",
        "--json",
        "lss",
        "--unconfigured",
        "1",
        "fastscan",
    ]))
    .unwrap();
    assert_eq!(v["found"]["serial"], 1001);
    // Bürkert status: serial number and software version.
    let status = lss(&["--eds", &eds, "burkert", "status", "5"]);
    assert!(status.contains("software         65536\n"), "{status}");
    let status = lss(&["--hex", "--eds", &eds, "burkert", "status", "5"]);
    assert!(status.contains("software         0x00010000\n"), "{status}");
    assert!(status.contains("serial number    0x00000000\n"), "{status}");
}

/// `audit` prints the values that differ in the same style: a device changed behind the
/// master's back (on a UDP bus, the simulator in another process).
#[test]
fn audit_values_follow_the_hex_switch() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../manager/tests/data");
    let toml = tmp("one-valve.toml");
    std::fs::write(
        &toml,
        format!(
            "[master]\nnode_id = 1\nsdo_timeout_ms = 300\n\n[[slave]]\nnode_id = 6\n\
             dcf = \"{data}/valve.dcf\"\nmandatory = true\n"
        ),
    )
    .unwrap();
    let iface = common::udp_bus(3);
    let mut sim = common::simulator(&iface, &format!("{data}/valve.dcf"), "6", "30");
    let o = canopen(&[
        "--iface", &iface, "sdo", "write", "6", "0x2001", "77", "-t", "u32",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let audit = |hex: bool| {
        let mut args = vec!["--iface", &iface, "audit", toml.to_str().unwrap()];
        if hex {
            args.insert(0, "--hex");
        }
        let o = canopen(&args);
        assert!(!o.status.success(), "a difference fails the audit");
        stdout(&o)
    };
    let text = audit(false);
    assert!(
        text.contains("\"Close Delay\" UNSIGNED32: expected 4102, actual 77"),
        "{text}"
    );
    let text = audit(true);
    assert!(
        text.contains("\"Close Delay\" UNSIGNED32: expected 0x00001006, actual 0x0000004D"),
        "{text}"
    );
    let _ = sim.kill();
    let _ = sim.wait();
}

#[test]
fn json_errors_are_json_with_fields() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--eds", &eds, "--json", "sdo", "read", "5", "0x1234", "0"]);
    assert!(!o.status.success());
    assert!(stdout(&o).is_empty());
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert_eq!(v["node"], 5);
    assert_eq!(v["index"], 0x1234);
    assert_eq!(v["sub"], 0);
    assert_eq!(v["abort_code"], "0x06020000");
    assert_eq!(
        v["meaning"],
        "Object does not exist in the object dictionary"
    );
    // Usage errors too (with clap's exit code 2 where the usage is wrong).
    let o = canopen(&[
        "--json",
        "lss",
        "--unconfigured",
        "1",
        "assign-all",
        "--first",
        "10",
        "--last",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert!(v["error"].as_str().unwrap().contains("empty node-ID pool"));
    let o = canopen(&["--json", "--eds", &eds, "--eds", &eds, "scan"]);
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .contains("already has a dictionary")
    );
}

#[test]
fn hints_for_a_missing_interface_and_a_silent_bus() {
    let o = canopen(&["--iface", "nosuchcan7", "scan"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.starts_with("error: nosuchcan7:"), "{e}");
    assert!(
        e.contains("hint: there is no interface `nosuchcan7`"),
        "{e}"
    );
    assert!(e.contains("ip link"), "{e}");
    assert!(e.contains("type vcan"), "{e}");
    // Nothing on the in-memory bus answers node 9.
    let o = canopen(&["sdo", "read", "9", "0x1000"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("SDO timeout"), "{e}");
    assert!(e.contains("hint: nothing answered"), "{e}");
    let o = canopen(&["--json", "sdo", "read", "9", "0x1000"]);
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert_eq!(v["abort_code"], "0x05040000");
    assert!(v["hint"].as_str().unwrap().contains("nothing answered"));
}

#[test]
fn replay_checks_the_whole_log_and_skips_fd_frames() {
    let log = tmp("fd.log");
    std::fs::write(
        &log,
        "(1.000000) can0 000#0105\n(1.000100) can0 123##1000102030405060708090A0B\n\
         (1.000200) can0 705#7F\n",
    )
    .unwrap();
    let o = canopen(&["--json", "replay", log.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["sent"], 2);
    assert_eq!(v["skipped_fd"], 1);
    assert!(
        stderr(&o).contains("skipping 1 CAN FD frame"),
        "{}",
        stderr(&o)
    );
    // A bad line anywhere: refused before the first frame goes out.
    let bad = tmp("bad.log");
    std::fs::write(&bad, "(1.000000) can0 000#0105\n(1.000100) can0 123#zz\n").unwrap();
    let o = canopen(&["replay", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("line 2") && e.contains("nothing was sent"),
        "{e}"
    );
    assert!(!e.contains("replayed"), "{e}");
}

#[test]
fn a_failed_record_leaves_the_file_alone() {
    let out = tmp("keep.log");
    std::fs::write(&out, "precious\n").unwrap();
    // The in-memory bus needs --duration: this run fails after opening the bus.
    let o = canopen(&["record", "-o", out.to_str().unwrap()]);
    assert!(!o.status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious\n");
    let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // A run that succeeds replaces it.
    let eds = format!("5={EDS}");
    let o = canopen(&[
        "--eds",
        &eds,
        "record",
        "-o",
        out.to_str().unwrap(),
        "--duration",
        "0.5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains(" mem0 705#00"), "{text}");
}

#[test]
fn monitor_filters_like_candump() {
    let (e5, e6) = (format!("5={EDS}"), format!("6={EDS}"));
    let frames = |filters: &[&str]| {
        let mut args = vec![
            "--eds",
            &e5,
            "--eds",
            &e6,
            "--json",
            "monitor",
            "--duration",
            "1.2",
        ];
        args.extend_from_slice(filters);
        let o = canopen(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let mut ids: Vec<String> = stdout(&o)
            .lines()
            .map(|l| {
                let v: serde_json::Value = serde_json::from_str(l).unwrap();
                v["frame"].as_str().unwrap()[..3].to_string()
            })
            .collect();
        ids.dedup();
        ids.sort();
        ids.dedup();
        ids
    };
    assert_eq!(frames(&[]), ["705", "706"]);
    assert_eq!(frames(&["705:7FF"]), ["705"]);
    assert_eq!(frames(&["705~7FF"]), ["706"]);
    assert_eq!(frames(&["705:7FF,706:7FF"]), ["705", "706"]);
    assert_eq!(frames(&["700:780"]), ["705", "706"]);
    assert!(frames(&["00000705:1FFFFFFF"]).is_empty());
    let o = canopen(&["monitor", "--duration", "0", "705"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("ID:MASK"), "{}", stderr(&o));
}

#[test]
fn every_bus_command_fails_with_one_prefix() {
    let missing = tmp("missing.log");
    let missing = missing.to_str().unwrap();
    for args in [
        vec!["sdo", "read", "9", "0x1000"],
        vec!["nmt", "start", "nine"],
        vec!["--iface", "nosuchcan7", "scan"],
        vec!["monitor"],
        vec!["replay", missing],
        vec!["lss", "assign-all", "--first", "10", "--last", "2"],
        vec!["gateway", "--listen", "nonsense-scheme:x"],
        vec!["--eds", "5=/nonexistent.eds", "scan"],
    ] {
        let o = canopen(&args);
        assert!(!o.status.success(), "{args:?}");
        let e = stderr(&o);
        assert!(e.starts_with("error: "), "{args:?}: {e}");
    }
}

#[test]
fn progress_bar_only_on_a_terminal_and_ending_at_100_percent() {
    let out = tmp("up.bin");
    let eds = format!("5={EDS}");
    let args = [
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1008",
        "-o",
        out.to_str().unwrap(),
    ];
    // Not a terminal: no bar.
    let o = canopen(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains('\r') && !stderr(&o).contains('%'),
        "{}",
        stderr(&o)
    );
    // A terminal (util-linux `script` gives the command a pseudo-terminal): the bar ends full.
    let line = std::iter::once(env!("CARGO_BIN_EXE_canopen").to_string())
        .chain(args.iter().map(|a| format!("'{a}'")))
        .collect::<Vec<_>>()
        .join(" ");
    let o = Command::new("script")
        .args(["-qec", &line, "/dev/null"])
        .output()
        .expect("util-linux `script` runs");
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let last_bar = text
        .split(['\r', '\n'])
        .rfind(|l| l.contains(" bytes ") && l.contains('%'))
        .unwrap_or_else(|| panic!("no bar in {text:?}"));
    assert!(last_bar.ends_with("23/23 bytes 100 %"), "{last_bar:?}");
}

/// `.tmp` files left in `dir`.
fn leftovers(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[test]
fn an_upload_file_appears_whole_or_not_at_all() {
    let eds = format!("5={EDS}");
    let dir = tmp("upload");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("name.bin");
    std::fs::write(&file, "precious\n").unwrap();
    // The device aborts (no such object): the old file stays, no partial file is left.
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1234",
        "-o",
        file.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("0x06020000"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "precious\n");
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    let fresh = dir.join("fresh.bin");
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1234",
        "-o",
        fresh.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(!fresh.exists());
    // A good upload replaces the file.
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1008",
        "-o",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&file).unwrap(),
        "Buerkert generic device"
    );
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    // A device file is written directly (never renamed over), and its write error reported.
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1008",
        "-o",
        "/dev/full",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("No space left on device"),
        "{}",
        stderr(&o)
    );
    let o = canopen(&[
        "--eds",
        &eds,
        "--json",
        "sdo",
        "upload",
        "5",
        "0x1008",
        "-o",
        "/dev/full",
    ]);
    assert!(!o.status.success());
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert!(
        v["error"].as_str().unwrap().contains("No space left"),
        "{v}"
    );
    assert_eq!(v["index"], 0x1008);
    let o = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x1008",
        "-o",
        "/dev/null",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // `record` likewise.
    let o = canopen(&[
        "--eds",
        &eds,
        "record",
        "-o",
        "/dev/full",
        "--duration",
        "0.5",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("No space left"), "{}", stderr(&o));
    assert!(
        std::fs::metadata("/dev/full")
            .unwrap()
            .file_type()
            .is_char_device()
    );
}

/// What a wrong value or object says: the object and its type, and that a usage mistake is
/// one (exit 2).
#[test]
fn parse_messages_name_the_object_and_the_type() {
    let eds = format!("5={EDS}");
    let run = |args: &[&str]| {
        let mut all = vec!["--eds", &eds];
        all.extend_from_slice(args);
        canopen(&all)
    };
    let o = run(&["sdo", "write", "5", "0x1017", "abc"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "error: node 5, object 0x1017:00: `abc` is not an UNSIGNED16 value\n"
    );
    let o = run(&["sdo", "write", "5", "0x1017", "70000"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("0x1017:00: `70000` is out of range for UNSIGNED16 (0..=65535)"),
        "{}",
        stderr(&o)
    );
    let o = run(&["sdo", "write", "5", "0x1017", "1.5x", "--type", "f32"]);
    assert!(
        stderr(&o).contains("`1.5x` is not a REAL32 value"),
        "{}",
        stderr(&o)
    );
    for index in ["0x10000", "70000"] {
        let o = run(&["sdo", "read", "5", index]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!(
                "`{index}` is not an object index (0x0000..0xFFFF)"
            )),
            "{}",
            stderr(&o)
        );
    }
    let o = run(&["sdo", "write", "5", "0x1017"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("the value to write is missing"),
        "{}",
        stderr(&o)
    );
}

/// Under `--json` a hint is a field of its own, given once: not repeated inside `error`.
#[test]
fn json_errors_carry_the_hint_once() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--json", "--eds", &eds, "sdo", "read", "9", "0x1000"]);
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    let hint = v["hint"].as_str().expect("a hint");
    assert!(hint.starts_with("nothing answered"), "{hint}");
    assert!(
        !v["error"].as_str().unwrap().contains("nothing answered"),
        "{v}"
    );
    assert_eq!(stderr(&o).matches("nothing answered").count(), 1);
    let o = canopen(&["--json", "--iface", "nosuchcan0", "scan"]);
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert!(v["hint"].as_str().is_some(), "{v}");
    assert!(!v["error"].as_str().unwrap().contains("hint"), "{v}");
}
