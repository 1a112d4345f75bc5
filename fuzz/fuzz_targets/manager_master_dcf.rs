//! Arbitrary bytes as a master DCF: reading its CiA 302 objects (0x1F80, 0x1F81, 0x1F84..0x1F88,
//! 0x1F22 concise DCFs, 0x1F53/0x1F54/0x1F58) never panics, nor does decoding each concise DCF
//! or taking the file as the `[master] dcf` of a description; the objects read write a master
//! dictionary that reads back the same.
#![no_main]

use std::path::Path;

use canopen_manager::NetworkConfig;
use canopen_manager::master_dcf::{MasterObjects, dictionary_from_concise};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(parsed) = canopen_od::parse(data) {
        let objects = MasterObjects::from_dictionary(&parsed.od);
        for s in objects.slaves.values() {
            if let Some(c) = &s.concise_dcf {
                let _ = dictionary_from_concise(c);
            }
        }
        let _ = objects.start_policy();
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
