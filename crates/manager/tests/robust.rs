//! Bad input never panics: any text as a network description, any bytes as a concise DCF.

use std::path::Path;

use canola_manager::NetworkConfig;
use canola_manager::master_dcf::dictionary_from_concise;
use proptest::prelude::*;

fn base() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bus.toml")
}

/// Lines that look like a description, in any order and with any values.
fn description_line() -> impl Strategy<Value = String> {
    let key = prop::sample::select(vec![
        "[master]",
        "[[slave]]",
        "[slave.identity]",
        "[slave.values]",
        "node_id = ",
        "dcf = ",
        "eds = ",
        "mandatory = ",
        "start = ",
        "vendor_id = ",
        "sdo_timeout_ms = ",
        "heartbeat_consumer_percent = ",
        "\"0x2000\" = ",
        "\"0x1018:01\" = ",
        "error_control = ",
    ]);
    let value = prop::sample::select(vec![
        "",
        "0",
        "5",
        "200",
        "-1",
        "0x39",
        "true",
        "\"valve.dcf\"",
        "\"valve-nostamp.dcf\"",
        "\"all\"",
        "\"x\"",
        "[1, 2]",
        "{ a = 1 }",
        "99999999999999999999",
        "\"0x10\"",
    ]);
    (key, value).prop_map(|(k, v)| {
        if k.starts_with('[') {
            k.to_owned()
        } else {
            format!("{k}{v}")
        }
    })
}

proptest! {
    #[test]
    fn any_text_is_an_error_or_a_description(text in "\\PC{0,200}") {
        let _ = NetworkConfig::parse(&text, &base());
    }

    #[test]
    fn description_like_text_never_panics(lines in prop::collection::vec(description_line(), 0..16)) {
        let text = lines.join("\n");
        if let Err(e) = NetworkConfig::parse(&text, &base()) {
            // Errors point into the text.
            if let Some(line) = e.line {
                prop_assert!(line >= 1 && line <= lines.len().max(1) + 1, "{e}");
            }
        }
    }

    #[test]
    fn any_bytes_as_a_concise_dcf(bytes in prop::collection::vec(any::<u8>(), 0..64)) {
        let _ = dictionary_from_concise(&bytes);
    }
}
