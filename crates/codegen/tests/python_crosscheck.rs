//! PDO structs against an independent reader of PDO mappings: python-canopen 2.4.1
//! (`tests/py/pdo_layout.py`, run with `$CANOPEN_PYTHON` or `<workspace>/.venv/bin/python`).
//! Without python the tests print that they skipped, unless `CANOPEN_REQUIRE_PYTHON=1`.
//!
//! For the PDO test device and every corpus file python-canopen reads, each generated struct's
//! mapping (index, sub-index, bit offset, bit length per entry, dummies included) and default
//! COB-ID for node 0x2A must be python-canopen's, and every mapping python-canopen reads that
//! has entries must have a struct or a note saying why not. The test device's TPDOs are then
//! decoded by both from the same data bytes.
//!
//! Deliberate differences:
//! 1. python-canopen reads no PDO whose communication parameter is missing from the file; the
//!    generator takes the predefined connection set's COB-ID for PDOs 1..=4. Such structs are
//!    not compared.
//! 2. python-canopen does not check mappings (mappable flag, access, sizes, dummy support);
//!    where it reads one the generator rejects, the generator's note must name that PDO.
//! 3. Values: python-canopen 2.4.1 unpacks a field that does not start on a byte from its own
//!    type's width starting at the field's first byte (`PdoVariable.get_data`), so a field that
//!    spills past that width loses its high bits (the test device's UNSIGNED8 at bit 35 decodes
//!    to its low five bits), and it reads a VISIBLE_STRING field by the length of the object's
//!    default. Values are compared for fields python-canopen reads whole: those that end within
//!    their type's width from their first byte, and no strings.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

#[allow(unreachable_pub)]
mod device {
    include!("golden/pdo-device.rs");
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn python() -> Option<PathBuf> {
    let p = std::env::var_os("CANOPEN_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(".venv/bin/python"));
    let ok = Command::new(&p)
        .args(["-c", "import canopen"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CANOPEN_REQUIRE_PYTHON").is_none(),
            "CANOPEN_REQUIRE_PYTHON=1 but {} cannot import canopen",
            p.display()
        );
        eprintln!("SKIPPED: no python with python-canopen at {}", p.display());
        return None;
    }
    Some(p)
}

/// python-canopen's output: the PDO lines by key (`t1`, `r1`) and the decoded lines.
struct PyView {
    pdos: BTreeMap<String, (u32, Vec<[u32; 4]>)>,
    decoded: BTreeMap<String, Vec<String>>,
}

fn run_python(py: &Path, eds: &Path, frames: &[String]) -> Result<PyView, String> {
    let out = Command::new(py)
        .arg(workspace().join("crates/codegen/tests/py/pdo_layout.py"))
        .arg(eds)
        .arg("0x2A")
        .args(frames)
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        return Err(stderr.lines().last().unwrap_or("").to_owned());
    }
    let mut view = PyView {
        pdos: BTreeMap::new(),
        decoded: BTreeMap::new(),
    };
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("").to_owned();
        if key == "decoded" {
            let frame = words.next().unwrap().to_owned();
            view.decoded
                .insert(frame, words.map(str::to_owned).collect());
            continue;
        }
        let cob: u32 = words.next().unwrap().parse().unwrap();
        let entries = words
            .map(|w| {
                let n: Vec<u32> = w.split(':').map(|x| x.parse().unwrap()).collect();
                [n[0], n[1], n[2], n[3]]
            })
            .collect();
        view.pdos.insert(key, (cob, entries));
    }
    Ok(view)
}

/// One generated struct, read back from the generated text: key, entries, default COB-ID.
struct Generated {
    key: String,
    entries: Vec<u32>,
    cob: Option<(u32, bool)>,
}

fn hex(s: &str) -> u32 {
    u32::from_str_radix(s.trim_start_matches("0x"), 16).unwrap()
}

fn generated_structs(code: &str) -> Vec<Generated> {
    let mut out: Vec<Generated> = Vec::new();
    for line in code.lines() {
        if let Some(rest) = line
            .strip_prefix("impl ")
            .filter(|l| l.contains("::TypedPdo for "))
        {
            let name = rest.rsplit(' ').nth(1).unwrap();
            let key = name.replace("Tpdo", "t").replace("Rpdo", "r");
            out.push(Generated {
                key,
                entries: Vec::new(),
                cob: None,
            });
        } else if let Some(g) = out.last_mut() {
            if let Some(e) = line.strip_prefix("        (0x") {
                g.entries.push(hex(e.split(',').next().unwrap()));
            } else if let Some(at) = line.find("DefaultCobId { raw: ") {
                let rest = &line[at + "DefaultCobId { raw: ".len()..];
                let raw = hex(rest.split(',').next().unwrap());
                g.cob = Some((raw, rest.contains("adds_node_id: true")));
            }
        }
    }
    out
}

/// Compares one file's generated structs with python-canopen's reading; returns how many
/// structs were compared.
fn compare_layouts(eds: &Path, py: &PyView) -> usize {
    let name = eds.file_name().unwrap().to_string_lossy().into_owned();
    let parsed = canola_od::parse(&std::fs::read(eds).unwrap()).unwrap();
    let (code, notes) = canola_codegen::Config::new()
        .pdo_structs(true)
        .generate_with_notes(&parsed.od, &name);
    let structs = generated_structs(&code);
    let mut compared = 0;
    for g in &structs {
        let Some((cob, entries)) = py.pdos.get(&g.key) else {
            // Difference 1: python-canopen skips PDOs without a communication parameter.
            let n: u16 = g.key[1..].parse().unwrap();
            let comm = if g.key.starts_with('t') {
                0x1800
            } else {
                0x1400
            } + n
                - 1;
            assert!(
                parsed.od.get(comm).is_none(),
                "{name}: python-canopen does not read {}",
                g.key
            );
            continue;
        };
        let mut offset = 0;
        let ours: Vec<[u32; 4]> = g
            .entries
            .iter()
            .map(|&raw| {
                let row = [raw >> 16, raw >> 8 & 0xFF, offset, raw & 0xFF];
                offset += raw & 0xFF;
                row
            })
            .collect();
        assert_eq!(&ours, entries, "{name}: {} mapping", g.key);
        let (raw, adds) = g
            .cob
            .unwrap_or_else(|| panic!("{name}: {} has no COB-ID", g.key));
        let resolved = if adds { raw.wrapping_add(0x2A) } else { raw };
        assert_eq!(resolved & 0x1FFF_FFFF, *cob, "{name}: {} COB-ID", g.key);
        compared += 1;
    }
    // Every mapping python-canopen reads with entries has a struct or a note (difference 2).
    for (key, (_, entries)) in &py.pdos {
        if entries.is_empty() || structs.iter().any(|g| &g.key == key) {
            continue;
        }
        let struct_name = key.replace('t', "Tpdo").replace('r', "Rpdo");
        assert!(
            notes
                .iter()
                .any(|n| n.starts_with(&format!("no struct {struct_name}:"))),
            "{name}: python-canopen reads {key} with {} entries; no struct and no note: {notes:?}",
            entries.len()
        );
    }
    compared
}

#[test]
fn pdo_device_layouts_and_values_match_python_canopen() {
    let Some(py) = python() else { return };
    let eds = workspace().join("crates/codegen/tests/data/pdo-device.eds");
    // Pseudo-random data bytes for TPDO1 and TPDO2, six bytes each.
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut frames = Vec::new();
    for i in 0..32 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let bytes = &x.to_le_bytes()[..6];
        let text: String = bytes.iter().map(|b| format!("{b:02X}")).collect();
        frames.push(format!("t{}:{text}", 1 + i % 2));
    }
    let view = run_python(&py, &eds, &frames).unwrap();
    assert_eq!(compare_layouts(&eds, &view), 4);
    for frame in &frames {
        let (which, text) = frame.split_once(':').unwrap();
        let data: Vec<u8> = (0..6)
            .map(|i| u8::from_str_radix(&text[2 * i..2 * i + 2], 16).unwrap())
            .collect();
        let theirs = &view.decoded[frame];
        if which == "t1" {
            let t = device::Tpdo1::from_data(&data).unwrap();
            // Positions 0 and 2 (the BOOLEANs); 3 and 5 spill past their type's width from
            // their first byte (difference 3).
            assert_eq!(theirs[0], u8::from(t.valve_open).to_string(), "{frame}");
            assert_eq!(theirs[2], u8::from(t.alarm).to_string(), "{frame}");
        } else {
            let t = device::Tpdo2::from_data(&data).unwrap();
            let ours: f64 = t.temperature.into();
            let theirs: f64 = theirs[0].parse().unwrap_or(f64::NAN);
            assert!(
                ours.to_bits() == theirs.to_bits() || (ours.is_nan() && theirs.is_nan()),
                "{frame}: {ours} vs {theirs}"
            );
        }
    }
}

#[test]
fn corpus_pdo_layouts_match_python_canopen() {
    let Some(py) = python() else { return };
    let dir = workspace().join("../shared/eds-corpus");
    if !dir.is_dir() {
        assert!(
            std::env::var_os("CANOPEN_REQUIRE_CORPUS").is_none(),
            "CANOPEN_REQUIRE_CORPUS=1 but ../shared/eds-corpus is missing"
        );
        eprintln!("SKIPPED: ../shared/eds-corpus not found beside the checkout");
        return;
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("eds") || e.eq_ignore_ascii_case("dcf"))
        })
        .collect();
    files.sort();
    let (mut compared, mut files_compared, mut python_rejects) = (0, 0, 0);
    for file in &files {
        if canola_od::parse(&std::fs::read(file).unwrap()).is_err() {
            continue;
        }
        match run_python(&py, file, &[]) {
            Ok(view) => {
                let n = compare_layouts(file, &view);
                compared += n;
                files_compared += usize::from(n > 0);
            }
            // Files python-canopen cannot read (see the od crate's cross-check).
            Err(_) => python_rejects += 1,
        }
    }
    eprintln!(
        "{compared} PDO structs of {files_compared} corpus files match python-canopen; {python_rejects} files python-canopen cannot read"
    );
    assert!(compared > 100, "{compared} structs compared");
}
