//! The CiA 309-3 request line parser: never panics on any text; whatever parses formats to a
//! line that parses to the same request, and a value's bytes decode back to the same value.
#![no_main]

use canola_gateway::{Command, Value, parse_line};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for line in text.split_inclusive('\n') {
        let Ok(Some(req)) = parse_line(line) else {
            continue;
        };
        let again = req.to_string();
        let back = parse_line(&again).expect("a formatted request parses");
        // NaN reals are the one value unequal to itself: compare the text instead.
        assert_eq!(back.map(|r| r.to_string()), Some(again));
        if let Command::Write { value, .. } = &req.command {
            let bytes = value.to_le_bytes();
            let decoded =
                Value::from_le_bytes(value.data_type(), &bytes).expect("own bytes decode");
            assert_eq!(decoded.to_string(), value.to_string());
        }
    }
});
