//! Arbitrary text as a network description (`bus.toml`), with an in-memory set of files it may
//! name (two DCFs, a program image, a master DCF written from a known description): parsing
//! never panics, an error names a line within the text, and a description that parses writes
//! a master DCF that parses back to the same CiA 302 master objects.
#![no_main]

use std::path::{Path, PathBuf};

use canopen_manager::NetworkConfig;
use canopen_manager::master_dcf::MasterObjects;
use libfuzzer_sys::fuzz_target;

const VALVE: &[u8] = include_bytes!("../../crates/manager/tests/data/valve.dcf");
const VALVE_BOOT: &[u8] = include_bytes!("../../crates/manager/tests/data/valve-boot.dcf");
const PROGRAM: &[u8] = include_bytes!("../../crates/manager/tests/data/valve-v2.bin");

fn files(p: &Path) -> std::io::Result<Vec<u8>> {
    match p.file_name().and_then(|n| n.to_str()) {
        Some("valve.dcf") => Ok(VALVE.to_vec()),
        Some("valve-boot.dcf") => Ok(VALVE_BOOT.to_vec()),
        Some("valve-v2.bin") => Ok(PROGRAM.to_vec()),
        Some("master.dcf") => {
            let known = NetworkConfig::parse_with_files(
                "[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\nmandatory = true\n\
                 [[slave]]\nnode_id = 6\ndcf = \"valve-boot.dcf\"\nkeep_alive = true\n\
                 [slave.software]\ndate = 15400\ntime = 36000000\nupdate = true\nprogram = \"valve-v2.bin\"\n",
                Path::new("/fuzz/bus.toml"),
                &files,
            )
            .expect("the known description parses");
            Ok(MasterObjects::write_master_dcf(&known).into_bytes())
        }
        _ => Err(std::io::ErrorKind::NotFound.into()),
    }
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
            let dcf = MasterObjects::write_master_dcf(&config);
            let od = canopen_od::parse(dcf.as_bytes())
                .expect("the written master DCF parses")
                .od;
            assert_eq!(
                comparable(MasterObjects::from_dictionary(&od)),
                comparable(objects)
            );
        }
    }
});
