//! Cross-check against an independent parser: python-canopen 2.4.1 (`canopen.import_od`).
//!
//! For every corpus file both parsers read, the set of (index, sub-index, data type, access type,
//! PDO mapping) must be equal after the deliberate differences below are accounted for. The
//! python side is `tests/py/dump_od.py`, run with `$CANOPEN_PYTHON` or `<workspace>/.venv/bin/python`.
//! Without python the test prints that it skipped, unless `CANOPEN_REQUIRE_PYTHON=1`.
//!
//! Deliberate differences (each handled where noted in the code):
//! 1. python-canopen fails on files this crate accepts with warnings: duplicate sections or
//!    duplicate keys (configparser's strict mode), `[Comments] Lines=` larger than the number of
//!    `LineN` keys present, missing `Dummy0001..0007` keys in `[DummyUsage]`, an empty numeric
//!    `[DeviceInfo]` value (e.g. `ProductNumber=`). Those files are listed in `PYTHON_REJECTS`
//!    with python's error and only checked to be rejected by python for that reason.
//! 2. `CompactSubObj` (CiA 306 §4.5.2.3): python-canopen creates only sub-index 1 plus the
//!    sub-indices named in `[xxxxName]`; this crate expands all sub-indices 1..=N. We require
//!    every python sub-object to match ours and ignore our additional ones. Sub-index 0 of such
//!    an array is `ro` here (CiA 306 says the count is read-only); python's default is `rw`, so
//!    sub-index 0 of compact arrays is not compared.
//! 3. `[DummyUsage]`: python-canopen adds objects 0x0001..0x0007 for `DummyNNNN=1`; this crate
//!    keeps them in `ObjectDictionary::dummy_usage`. The test adds the same rows on our side.
//! 4. DEFTYPE/DEFSTRUCT objects (object codes 5 and 6): python-canopen drops them; we keep them,
//!    so they are removed from our side.
//! 5. Access types are compared as lower-cased text (python keeps whatever the file says, e.g.
//!    `unknown`; this crate keeps invalid text in `access_raw`). `rwr`/`rww` are kept as such by
//!    both.
//! 6. Keys are case-insensitive here (`PdoMapping=1` counts) but case-sensitive in python-canopen
//!    (such a key is ignored there). No corpus file that python reads has such a key, so no
//!    adjustment is needed; the test would show it.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;

use canola_od::{ObjectCode, parse};

type Row = (u16, u8, u16, String, bool);

/// Files python-canopen 2.4.1 cannot read, and why (see difference 1).
const PYTHON_REJECTS: [(&str, &str); 11] = [
    (
        "cano-node__CANopen_Unit.eds",
        "NoOptionError: No option 'Line5'",
    ),
    (
        "cano-node__DS301_profile.eds",
        "ValueError: invalid literal for int() with base 0: ''",
    ),
    (
        "cano-socket__CANopenSocket.eds",
        "ValueError: invalid literal for int() with base 0: ''",
    ),
    (
        "corc__CANopenSocket.eds",
        "NoOptionError: No option 'Line5'",
    ),
    ("kaco__401.eds", "DuplicateSectionError"),
    ("kaco__Easy-ak_v1.30.eds", "DuplicateOptionError"),
    ("kaco__NEMA23_7_23_12.eds", "DuplicateSectionError"),
    (
        "zencan__example1.eds",
        "ValueError: invalid literal for int() with base 0: ''",
    ),
    (
        "edsdcfnet__full_features.dcf",
        "NoOptionError: No option 'Dummy0001'",
    ),
    (
        "lely__coapp-fiber-master.dcf",
        "NoOptionError: No option 'Dummy0001'",
    ),
    ("lely__coctl.dcf", "NoOptionError: No option 'Dummy0001'"),
];

fn python() -> Option<PathBuf> {
    let p = std::env::var_os("CANOPEN_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| common::workspace_root().join(".venv/bin/python"));
    let ok = Command::new(&p)
        .args(["-c", "import canopen"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if ok {
        return Some(p);
    }
    if std::env::var("CANOPEN_REQUIRE_PYTHON").as_deref() == Ok("1") {
        panic!(
            "CANOPEN_REQUIRE_PYTHON=1 but {} cannot import canopen",
            p.display()
        );
    }
    eprintln!(
        "SKIPPED python_crosscheck: {} cannot import canopen (set CANOPEN_PYTHON, or CANOPEN_REQUIRE_PYTHON=1 to make this fatal)",
        p.display()
    );
    None
}

/// Indices of object sections with a non-zero `CompactSubObj` key, read from the raw text.
fn compact_objects(text: &str) -> BTreeSet<u16> {
    let mut out = BTreeSet::new();
    let mut current: Option<u16> = None;
    for line in text.lines() {
        let l = line.trim();
        if let Some(name) = l.strip_prefix('[').and_then(|r| r.split(']').next()) {
            current = if name.len() == 4 {
                u16::from_str_radix(name, 16).ok()
            } else {
                None
            };
        } else if let (Some(i), Some((k, v))) = (current, l.split_once('='))
            && k.trim().eq_ignore_ascii_case("CompactSubObj")
            && v.trim() != "0"
            && !v.trim().is_empty()
        {
            out.insert(i);
        }
    }
    out
}

fn ours(bytes: &[u8]) -> (BTreeSet<Row>, BTreeSet<u16>) {
    let od = parse(bytes).expect("parses").od;
    let mut rows = BTreeSet::new();
    for obj in od.objects.values() {
        // Difference 4.
        if matches!(obj.object_code, ObjectCode::DefType | ObjectCode::DefStruct) {
            continue;
        }
        for sub in obj.subs.values() {
            let access = match sub.access_raw() {
                Some(raw) => raw.to_lowercase(),
                None => sub.access.as_str().to_string(),
            };
            rows.insert((
                obj.index,
                sub.sub_index,
                sub.data_type.code(),
                access,
                sub.pdo_mapping,
            ));
        }
    }
    // Difference 3.
    for (&dt, &used) in &od.dummy_usage {
        if used && (1..=7).contains(&dt) {
            rows.insert((dt, 0, dt, "const".into(), false));
        }
    }
    let compact = compact_objects(&String::from_utf8_lossy(bytes));
    (rows, compact)
}

#[test]
fn same_entries_as_python_canopen() {
    let Some(dir) = common::corpus_dir("same_entries_as_python_canopen") else {
        return;
    };
    let Some(py) = python() else { return };
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/dump_od.py");
    let files = common::corpus_files(&dir);
    let out = Command::new(&py)
        .arg(&script)
        .args(&files)
        .output()
        .expect("run python");
    assert!(
        out.status.success(),
        "dump_od.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut theirs: BTreeMap<String, Result<BTreeSet<Row>, String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.split('\t').collect();
        let name = PathBuf::from(f[0])
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        match f[1] {
            "ERROR" => {
                theirs.insert(name, Err(f[2].to_string()));
            }
            "NOTE" => {}
            _ => {
                let row: Row = (
                    f[1].parse().unwrap(),
                    f[2].parse().unwrap(),
                    f[3].parse().unwrap(),
                    f[4].to_string(),
                    f[5] == "1",
                );
                if let Ok(set) = theirs.entry(name).or_insert_with(|| Ok(BTreeSet::new())) {
                    set.insert(row);
                }
            }
        }
    }
    let mut problems = Vec::new();
    let (mut compared, mut rows_compared) = (0, 0);
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let rejected = PYTHON_REJECTS.iter().find(|(f, _)| *f == name);
        let Some(result) = theirs.get(&name) else {
            // python printed nothing: an empty dictionary.
            problems.push(format!("{name}: python-canopen printed no rows"));
            continue;
        };
        match (result, rejected) {
            (Err(msg), Some((_, why))) => {
                assert!(
                    msg.contains(why),
                    "{name}: python failed differently: {msg}"
                );
                continue;
            }
            (Err(msg), None) => {
                problems.push(format!("{name}: python-canopen failed unexpectedly: {msg}"));
                continue;
            }
            (Ok(_), Some(_)) => {
                problems.push(format!(
                    "{name}: listed in PYTHON_REJECTS but python read it"
                ));
                continue;
            }
            (Ok(py_rows), None) => {
                let (mut mine, compact) = ours(&std::fs::read(path).unwrap());
                let mut py_rows = py_rows.clone();
                // Difference 2.
                py_rows.retain(|r| !(compact.contains(&r.0) && r.1 == 0));
                mine.retain(|r| {
                    !compact.contains(&r.0)
                        || (r.1 != 0 && py_rows.iter().any(|p| p.0 == r.0 && p.1 == r.1))
                });
                let only_mine: Vec<_> = mine.difference(&py_rows).collect();
                let only_theirs: Vec<_> = py_rows.difference(&mine).collect();
                if !only_mine.is_empty() || !only_theirs.is_empty() {
                    problems.push(format!(
                        "{name}: only here {:?}\n    only in python-canopen {:?}",
                        &only_mine[..only_mine.len().min(8)],
                        &only_theirs[..only_theirs.len().min(8)]
                    ));
                }
                compared += 1;
                rows_compared += py_rows.len();
            }
        }
    }
    println!("python cross-check: {compared} files compared, {rows_compared} entries");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
