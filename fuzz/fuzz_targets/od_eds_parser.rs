//! Arbitrary bytes as an EDS/DCF file: the parser must never panic, and whatever parses must
//! survive write -> parse with an equal model, and lint without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(p) = canopen_od::parse(data) {
        let _ = canopen_od::lint(&p.od);
        let text = canopen_od::write_eds(&p.od);
        let again = canopen_od::parse(text.as_bytes()).expect("written EDS parses");
        assert_eq!(again.od, p.od, "round trip changed the model");
        let _ = canopen_od::write_dcf(&p.od, 1, Some(125));
    }
});
