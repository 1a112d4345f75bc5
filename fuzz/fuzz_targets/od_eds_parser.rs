//! Arbitrary bytes as an EDS/DCF file: the parser must never panic, its report stays bounded
//! (at most 25 diagnostics per severity and kind, plus one count of the rest, with no control
//! characters), and whatever parses must survive write -> parse with an equal model, and lint
//! without panicking.
//!
//! Run with `-max_len=2048` (fuzz/options/od_eds_parser.txt): a run parses its input twice
//! (with and without style warnings) and the written model once more, so its time grows with
//! the input, and two kilobytes already hold a dozen sections of every kind. The seeds are the
//! heads of the repository's EDS files, cut to that length.
#![no_main]

use libfuzzer_sys::fuzz_target;

/// Severities times diagnostic kinds times (25 listed + 1 summary).
const MAX_DIAGNOSTICS: usize = 2 * 13 * 26;

fuzz_target!(|data: &[u8]| {
    let parsed = canola_od::parse(data);
    let diagnostics = match &parsed {
        Ok(p) => &p.diagnostics,
        Err(e) => &e.diagnostics,
    };
    assert!(
        diagnostics.len() <= MAX_DIAGNOSTICS,
        "{} diagnostics",
        diagnostics.len()
    );
    for d in diagnostics {
        assert!(!d.message.chars().any(char::is_control), "{d}");
    }
    let quiet = canola_od::ParseOptions::new().style_warnings(false);
    if let Ok(p) = canola_od::parse_with(data, quiet) {
        assert!(
            p.diagnostics
                .iter()
                .all(|d| d.kind != canola_od::DiagnosticKind::Style)
        );
    }
    if let Ok(p) = parsed {
        let _ = canola_od::lint(&p.od);
        let text = canola_od::write_eds(&p.od);
        let again = canola_od::parse(text.as_bytes()).expect("written EDS parses");
        assert_eq!(again.od, p.od, "round trip changed the model");
        let _ = canola_od::write_dcf(&p.od, 1, Some(125));
    }
});
