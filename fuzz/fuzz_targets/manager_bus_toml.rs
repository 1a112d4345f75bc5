//! Arbitrary text as a network description (`bus.toml`), with an in-memory set of files it may
//! name (two DCFs, a program image, a master DCF written from a known description): parsing
//! never panics, an error names a line within the text, and a description that parses writes
//! a master DCF that parses back to the same CiA 302 master objects.
//!
//! Run with `-max_len=512` (fuzz/options/manager_bus_toml.txt): room for a master section and a
//! handful of slaves with their values, identity and software checks, while bounding how many
//! DCFs one description makes the parser read (each slave names one).
//!
//! Kept cheap without checking less: the master DCF the description may name is written once,
//! and the write-and-parse-back of the master objects (a DCF of nine 127-entry arrays, a
//! function of the objects and the master's node-ID alone) is checked once for each distinct
//! pair.
#![no_main]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use canola_manager::NetworkConfig;
use canola_manager::master_dcf::MasterObjects;
use libfuzzer_sys::fuzz_target;

#[path = "common/first_time.rs"]
mod first_time;
use first_time::first_time;

const VALVE: &[u8] = include_bytes!("../../crates/manager/tests/data/valve.dcf");
const VALVE_BOOT: &[u8] = include_bytes!("../../crates/manager/tests/data/valve-boot.dcf");
const PROGRAM: &[u8] = include_bytes!("../../crates/manager/tests/data/valve-v2.bin");

fn files(p: &Path) -> std::io::Result<Vec<u8>> {
    match p.file_name().and_then(|n| n.to_str()) {
        Some("valve.dcf") => Ok(VALVE.to_vec()),
        Some("valve-boot.dcf") => Ok(VALVE_BOOT.to_vec()),
        Some("valve-v2.bin") => Ok(PROGRAM.to_vec()),
        Some("master.dcf") => Ok(master_dcf().to_vec()),
        _ => Err(std::io::ErrorKind::NotFound.into()),
    }
}

/// A master DCF written from a known description, made on first use.
fn master_dcf() -> &'static [u8] {
    static DCF: OnceLock<Vec<u8>> = OnceLock::new();
    DCF.get_or_init(|| {
        let known = NetworkConfig::parse_with_files(
            "[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\nmandatory = true\n\
             [[slave]]\nnode_id = 6\ndcf = \"valve-boot.dcf\"\nkeep_alive = true\n\
             [slave.software]\ndate = 15400\ntime = 36000000\nupdate = true\nprogram = \"valve-v2.bin\"\n",
            Path::new("/fuzz/bus.toml"),
            &files,
        )
        .expect("the known description parses");
        MasterObjects::write_master_dcf(&known).into_bytes()
    })
}

/// The master objects with program paths left out (a master DCF names no file).
fn comparable(mut o: MasterObjects) -> MasterObjects {
    for s in o.slaves.values_mut() {
        if let Some(p) = s.software.as_mut().and_then(|w| w.program.as_mut()) {
            p.path = PathBuf::new();
        }
    }
    o
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match NetworkConfig::parse_with_files(text, Path::new("/fuzz/bus.toml"), &files) {
        Err(e) => {
            if let Some(line) = e.line {
                assert!(line >= 1 && line <= text.lines().count().max(1) + 1, "{e}");
            }
            assert!(!e.message.is_empty());
        }
        Ok(config) => {
            let objects = MasterObjects::from_config(&config);
            if !first_time(format!("{} {objects:?}", config.master.node_id.get())) {
                return;
            }
            let dcf = MasterObjects::write_master_dcf(&config);
            let od = canola_od::parse(dcf.as_bytes())
                .expect("the written master DCF parses")
                .od;
            assert_eq!(
                comparable(MasterObjects::from_dictionary(&od)),
                comparable(objects)
            );
        }
    }
});
