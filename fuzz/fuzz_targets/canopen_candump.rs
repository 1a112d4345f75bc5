//! The candump log reader: any bytes give entries or typed errors, never a panic, and every
//! line that parses formats back to text that parses to the same entry.
#![no_main]

use canola::candump::{Reader, format_line, parse_line};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for entry in Reader::new(data).flatten() {
        let text = format_line(&entry);
        assert_eq!(parse_line(&text).as_ref(), Ok(&entry), "{text}");
    }
});
