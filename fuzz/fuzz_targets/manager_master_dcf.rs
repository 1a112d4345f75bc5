//! Arbitrary bytes as a master DCF: reading its CiA 302 objects (0x1F80, 0x1F81, 0x1F84..0x1F88,
//! 0x1F22 concise DCFs, 0x1F53/0x1F54/0x1F58) never panics, nor does decoding each concise DCF
//! or taking the file as the `[master] dcf` of a description; the objects read write a master
//! dictionary that reads back the same.
//!
//! Run with `-max_len=2048` (fuzz/options/manager_master_dcf.txt): a master DCF that names a
//! few slaves by their sub-objects fits (the seeds are such files), and the time of a run grows
//! with the text the parser reads twice.
//!
//! Two shortcuts keep a run cheap without checking less: a file that does not parse is not
//! offered as `[master] dcf` (the description would fail on the same parse, an outcome already
//! known), and the write-and-read-back of the master objects, a function of the objects alone
//! that builds a dictionary of 127 sub-objects in each of nine arrays, is checked once for each
//! distinct set of objects.
#![no_main]

use std::path::Path;

use canola_manager::NetworkConfig;
use canola_manager::master_dcf::{MasterObjects, dictionary_from_concise};
use libfuzzer_sys::fuzz_target;

#[path = "common/first_time.rs"]
mod first_time;
use first_time::first_time;

fuzz_target!(|data: &[u8]| {
    let Ok(parsed) = canola_od::parse(data) else {
        return;
    };
    let objects = MasterObjects::from_dictionary(&parsed.od);
    for s in objects.slaves.values() {
        if let Some(c) = &s.concise_dcf {
            let _ = dictionary_from_concise(c);
        }
    }
    let _ = objects.start_policy();
    if first_time(format!("{objects:?}")) {
        let again = MasterObjects::from_dictionary(&objects.to_dictionary());
        assert_eq!(again, objects);
    }
    let read = |p: &Path| -> std::io::Result<Vec<u8>> {
        if p.ends_with("master.dcf") {
            Ok(data.to_vec())
        } else {
            Err(std::io::ErrorKind::NotFound.into())
        }
    };
    let _ = NetworkConfig::parse_with_files(
        "[master]\ndcf = \"master.dcf\"\n",
        Path::new("/fuzz/bus.toml"),
        &read,
    );
});
