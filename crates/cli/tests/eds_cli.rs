//! `canopen eds ...` run as a process, the way users and scripts call it.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::canopen;

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
        .display()
        .to_string()
}

fn corpus() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/eds-corpus");
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CANOPEN_REQUIRE_CORPUS").is_none(),
        "CANOPEN_REQUIRE_CORPUS=1 but the corpus is missing"
    );
    eprintln!("SKIPPED: ../shared/eds-corpus not found beside the checkout");
    None
}

#[test]
fn check_accepts_the_burkert_eds_without_warnings() {
    let out = canopen(&["eds", "check", &repo("eds/burkert-generic.eds")]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("ok, 49 objects, 0 warnings"));
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn check_reports_errors_with_file_and_line_and_exits_1() {
    let Some(dir) = corpus() else { return };
    let broken = dir.join("kaco__401.eds").display().to_string();
    let good = dir.join("zencan__example1.eds").display().to_string();
    let out = canopen(&["eds", "check", &good, &broken]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let first = stderr
        .lines()
        .find(|l| l.contains(": error: "))
        .expect("an error line");
    let mut parts = first.splitn(3, ':');
    assert_eq!(parts.next(), Some(broken.as_str()));
    assert!(
        parts.next().unwrap().parse::<u32>().is_ok(),
        "FILE:LINE: error: ... but got {first}"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(&format!("{good}: ok")), "{stdout}");
}

#[test]
fn check_passes_every_corpus_file_but_the_broken_one() {
    let Some(dir) = corpus() else { return };
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension().is_some_and(|e| e == "eds" || e == "dcf") && !p.ends_with("kaco__401.eds")
        })
        .map(|p| p.display().to_string())
        .collect();
    files.sort();
    let mut args = vec!["eds", "check"];
    args.extend(files.iter().map(String::as_str));
    let out = canopen(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_eq!(
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.contains(": ok,"))
            .count(),
        files.len()
    );
}

#[test]
fn show_json_has_the_documented_shape() {
    let out = canopen(&["eds", "show", "--json", &repo("eds/burkert-generic.eds")]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    let objects = v["objects"].as_array().unwrap();
    let hb = objects.iter().find(|o| o["index"] == 0x1017).unwrap();
    assert_eq!(hb["object_type"], 7);
    assert_eq!(hb["name"], "Producer Heartbeat Time");
    let subs = hb["subs"].as_array().unwrap();
    assert_eq!(subs.len(), 1, "a VAR has one sub");
    assert_eq!(
        subs[0],
        serde_json::json!({"subindex": 0, "name": "Producer Heartbeat Time", "data_type": 6,
                           "access": "rw", "pdo_mapping": false, "default": "500"})
    );
    let logbook = objects.iter().find(|o| o["index"] == 0x2003).unwrap();
    assert_eq!(logbook["object_type"], 9);
    let domain = logbook["subs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["subindex"] == 4)
        .unwrap();
    assert_eq!(domain["data_type"], 0x0F);
    assert_eq!(
        domain["default"],
        serde_json::Value::Null,
        "no DefaultValue is null"
    );
    let emcy = objects.iter().find(|o| o["index"] == 0x1014).unwrap();
    assert_eq!(
        emcy["subs"][0]["default"], "$NODEID+0x80",
        "the text as written"
    );
}

#[test]
fn show_table_lists_objects() {
    let out = canopen(&["eds", "show", &repo("eds/burkert-generic.eds")]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.lines()
            .any(|l| l.starts_with("1017") && l.contains("UNSIGNED16") && l.ends_with("500"))
    );
}

#[test]
fn to_dcf_resolves_node_id() {
    let dir = std::env::temp_dir().join(format!("canopen-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dcf = dir.join("node5.dcf");
    let out = canopen(&[
        "eds",
        "to-dcf",
        &repo("eds/burkert-generic.eds"),
        "--node-id",
        "5",
        "-o",
        &dcf.display().to_string(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&dcf).unwrap();
    assert!(text.contains("NodeID=5"));
    // The written DCF parses again, and 0x1014 = $NODEID+0x80 is 0x85 for node 5.
    let parsed = canola::od::parse(text.as_bytes()).expect("the DCF parses");
    let emcy = parsed.od.sub(0x1014, 0).unwrap();
    assert_eq!(
        emcy.parameter_value().and_then(|p| p.resolve(5)),
        Some(canola::od::Value::Unsigned32(0x85))
    );
    let bad = canopen(&[
        "eds",
        "to-dcf",
        &repo("eds/burkert-generic.eds"),
        "--node-id",
        "0",
    ]);
    assert!(!bad.status.success(), "node-ID 0 is refused");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn codegen_writes_typed_entries() {
    let out = canopen(&["eds", "codegen", &repo("eds/burkert-generic.eds")]);
    assert!(out.status.success());
    let code = String::from_utf8_lossy(&out.stdout);
    assert!(code.starts_with("// @generated by canola-codegen"));
    assert!(code.contains("pub const PRODUCER_HEARTBEAT_TIME: ::canola_od::Entry<u16>"));
}

#[test]
fn codegen_for_canopen_adds_pdo_structs_and_the_client_and_warns_of_what_it_leaves_out() {
    let eds = repo("crates/codegen/tests/data/pdo-device.eds");
    let out = canopen(&["eds", "codegen", "--for-canola", &eds]);
    assert!(out.status.success());
    let code = String::from_utf8_lossy(&out.stdout);
    assert!(code.contains("pub struct Tpdo1 {"));
    assert!(code.contains("impl ::canola::pdo::TypedPdo for Tpdo1 {"));
    assert!(code.contains("pub fn producer_heartbeat_time(&self) -> ReadWrite<u16>"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("pdo-device.eds: warning: codegen: no struct Tpdo4"),
        "{stderr}"
    );
    // PDO structs alone refer to canola-pdo and have no client.
    let out = canopen(&["eds", "codegen", "--pdo-structs", &eds]);
    let code = String::from_utf8_lossy(&out.stdout);
    assert!(code.contains("impl ::canola_pdo::TypedPdo for Tpdo1 {"));
    assert!(!code.contains("pub mod client"));
}

#[test]
fn lint_is_clean_for_the_burkert_eds_and_finds_faults_elsewhere() {
    let out = canopen(&["eds", "lint", &repo("eds/burkert-generic.eds")]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains(": 0 findings"));
    // A file whose SubNumber disagrees with its sub-objects.
    let dir = std::env::temp_dir().join(format!("canopen-lint-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.eds");
    std::fs::write(
        &bad,
        "[MandatoryObjects]\nSupportedObjects=1\n1=0x1018\n\n[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=3\n\n[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\n[1018sub1]\nParameterName=Vendor\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n",
    )
    .unwrap();
    let out = canopen(&["eds", "lint", &bad.display().to_string()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with(&format!("{}:", bad.display())) && l.contains("warning")),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A scratch directory of its own for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-eds-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn check_fails_an_empty_file_and_one_without_sections() {
    let dir = scratch("empty");
    for (name, text) in [
        ("empty.eds", ""),
        ("blank.eds", "\n  \n"),
        ("keys.eds", "ParameterName=x\n"),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let out = canopen(&["eds", "check", &path.display().to_string()]);
        assert_eq!(out.status.code(), Some(1), "{name}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(":1: error: "), "{name}: {stderr}");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("FAILED"),
            "{name}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn check_of_junk_prints_a_bounded_report_without_raw_control_bytes() {
    let dir = scratch("junk");
    // 2 MB of pseudo-random bytes (xorshift), with a newline now and then and one very long
    // section header.
    let mut junk = Vec::with_capacity(2_000_000);
    junk.extend_from_slice(b"[");
    junk.extend(std::iter::repeat_n(b'S', 10_000));
    junk.extend_from_slice(b"]\n");
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    while junk.len() < 2_000_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        junk.push(if x.is_multiple_of(23) {
            b'\n'
        } else {
            (x >> 24) as u8
        });
    }
    let path = dir.join("junk.eds");
    std::fs::write(&path, &junk).unwrap();
    let out = canopen(&["eds", "check", &path.display().to_string()]);
    assert_eq!(out.status.code(), Some(1));
    let lines: Vec<&[u8]> = out.stderr.split(|&b| b == b'\n').collect();
    assert!(lines.len() < 200, "{} lines of diagnostics", lines.len());
    for l in &lines {
        assert!(l.len() < 400, "{}", String::from_utf8_lossy(l));
        assert!(
            !l.iter().any(|&b| b < 0x20 || b == 0x7F),
            "raw control byte in {}",
            String::from_utf8_lossy(l)
        );
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("more errors of kind syntax not listed"),
        "{stderr}"
    );
    assert!(
        !stderr.contains(&"S".repeat(100)),
        "the long header is echoed whole"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("FAILED, "), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn no_style_hides_only_style_warnings() {
    let dir = scratch("style");
    let path = dir.join("style.eds");
    std::fs::write(
        &path,
        "[fileinfo]\nEDSVersion=4.0 \n[1000]\nparametername=Device type\nDataType=0x0007\n\
         AccessType=ro\nDefaultValue=0x1234LL\n",
    )
    .unwrap();
    let file = path.display().to_string();
    let all = canopen(&["eds", "check", &file]);
    let quiet = canopen(&["eds", "check", "--no-style", &file]);
    assert!(all.status.success() && quiet.status.success());
    let all = String::from_utf8_lossy(&all.stderr).into_owned();
    let quiet = String::from_utf8_lossy(&quiet.stderr).into_owned();
    for style in ["[fileinfo]", "trailing whitespace", "`parametername`"] {
        assert!(all.contains(style), "{style}: {all}");
        assert!(!quiet.contains(style), "{style}: {quiet}");
    }
    // A spelling that changes how a value is read stays.
    assert!(quiet.contains("C integer suffix"), "{quiet}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Peak memory of `eds check` on 20 MB of text junk (short lines, some `=` and `[`, nearly every
/// line an error): a small multiple of the file, not of its error count. Measured with
/// `/usr/bin/time`; skipped where it is missing.
#[test]
fn check_of_junk_stays_within_a_small_multiple_of_the_file_in_memory() {
    let time = Path::new("/usr/bin/time");
    if !time.exists() {
        eprintln!("SKIPPED: /usr/bin/time not found");
        return;
    }
    let dir = scratch("memory");
    let alphabet = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 =[];#$.,";
    let mut junk = Vec::with_capacity(20_000_100);
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    while junk.len() < 20_000_000 {
        let len = 1 + next() % 50;
        for _ in 0..len {
            junk.push(alphabet[(next() % alphabet.len() as u64) as usize]);
        }
        junk.push(b'\n');
    }
    let path = dir.join("junk.eds");
    std::fs::write(&path, &junk).unwrap();
    let out = Command::new(time)
        .args(["-f", "%M"])
        .arg(env!("CARGO_BIN_EXE_canopen"))
        .args(["eds", "check"])
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let peak_kib: u64 = stderr
        .lines()
        .last()
        .and_then(|l| l.trim().parse().ok())
        .expect("/usr/bin/time prints the peak RSS in KiB last");
    let file_kib = junk.len() as u64 / 1024;
    assert!(
        peak_kib < 4 * file_kib,
        "peak RSS {peak_kib} KiB for a {file_kib} KiB file"
    );
    assert!(
        stderr.lines().count() < 200,
        "{} lines",
        stderr.lines().count()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A file with one warning (a manufacturer object's value kept as text) and one with an
/// error (a communication object's value that does not parse).
const WARNING_EDS: &str = "[FileInfo]\nFileName=x.eds\n[DeviceInfo]\nVendorName=t\n\
[MandatoryObjects]\nSupportedObjects=1\n1=0x1000\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n\
[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x1Z\nPDOMapping=0\n";

#[test]
fn check_json_is_only_json_with_diagnostics_as_objects() {
    let dir = std::env::temp_dir().join(format!("canopen-eds-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let warn = dir.join("warn.eds");
    std::fs::write(&warn, WARNING_EDS).unwrap();
    let bad = dir.join("bad.eds");
    std::fs::write(
        &bad,
        WARNING_EDS.replace("DefaultValue=0\n", "DefaultValue=0x1Z\n"),
    )
    .unwrap();
    let (warn, bad) = (warn.to_str().unwrap(), bad.to_str().unwrap());
    let out = canopen(&["--json", "eds", "check", warn, bad]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("only JSON");
    let w = &v[0];
    assert_eq!(w["file"], warn);
    assert_eq!(w["ok"], true);
    assert_eq!(w["errors"], serde_json::json!([]));
    let warning = &w["warnings"][0];
    assert_eq!(warning["file"], warn);
    assert_eq!(warning["line"], 23);
    assert_eq!(warning["severity"], "warning");
    assert!(
        warning["message"]
            .as_str()
            .unwrap()
            .contains("kept as text")
    );
    let b = &v[1];
    assert_eq!(b["ok"], false);
    assert_eq!(b["errors"][0]["severity"], "error");
    assert_eq!(b["errors"][0]["line"], 13);
    assert!(b["errors"][0]["message"].as_str().unwrap().contains("0x1Z"));

    // `eds lint` includes what `check` finds.
    let out = canopen(&["--json", "eds", "lint", warn]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let findings = v["findings"].as_array().unwrap();
    assert!(
        findings
            .iter()
            .any(|f| f["line"] == 23 && f["message"].as_str().unwrap().contains("kept as text")),
        "{v}"
    );
}

/// Every line of stderr as a JSON object (panics on one that is not).
fn stderr_json(out: &std::process::Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: not JSON: {l}")))
        .collect()
}

#[test]
fn show_json_reports_every_error_as_json() {
    let dir = std::env::temp_dir().join(format!("canopen-eds-show-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    // A file that is not there: one JSON error naming it, exit 1, nothing on stdout.
    let missing = dir.join("missing.eds");
    let missing = missing.to_str().unwrap();
    let out = canopen(&["eds", "show", "--json", missing]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let errs = stderr_json(&out);
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert_eq!(errs[0]["file"], missing);
    assert!(
        errs[0]["error"].as_str().unwrap().starts_with(missing),
        "{errs:?}"
    );

    // A file that does not parse: the file, the line of its first error and the errors as
    // `eds check --json` gives them.
    let bad = dir.join("bad.eds");
    std::fs::write(
        &bad,
        WARNING_EDS.replace("DefaultValue=0\n", "DefaultValue=0x1Z\n"),
    )
    .unwrap();
    let bad = bad.to_str().unwrap();
    let out = canopen(&["eds", "show", "--json", bad]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let errs = stderr_json(&out);
    assert_eq!(errs.len(), 1, "{errs:?}");
    let e = &errs[0];
    assert_eq!(e["file"], bad);
    assert_eq!(e["line"], 13);
    assert_eq!(e["error_count"], 1);
    assert_eq!(e["errors"][0]["file"], bad);
    assert_eq!(e["errors"][0]["line"], 13);
    assert_eq!(e["errors"][0]["severity"], "error");
    assert!(e["error"].as_str().unwrap().contains("0x1Z"), "{e}");
    assert!(e.get("usage").is_none(), "{e}");

    // Bad arguments: clap's errors as JSON, exit 2.
    let out = canopen(&["eds", "show", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let errs = stderr_json(&out);
    assert_eq!(errs[0]["kind"], "missing-required-argument", "{errs:?}");
    assert_eq!(errs[0]["usage"], true);
    let out = canopen(&["eds", "show", "--json", "--bogus", bad]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr_json(&out)[0]["kind"], "unknown-argument");

    // Warnings of a file that loads: JSON too, with the file and line; the objects on stdout.
    let warn = dir.join("warn.eds");
    std::fs::write(&warn, WARNING_EDS).unwrap();
    let warn = warn.to_str().unwrap();
    let out = canopen(&["eds", "show", "--json", warn]);
    assert!(out.status.success());
    let warnings = stderr_json(&out);
    assert!(
        warnings
            .iter()
            .any(|w| w["file"] == warn && w["line"] == 23 && w["level"] == "warning"),
        "{warnings:?}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["objects"].as_array().unwrap().len(), 2);

    // Without --json, the same failures stay text in the FILE:LINE form.
    let out = canopen(&["eds", "show", bad]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).starts_with(&format!("{bad}:13: error: ")),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
