//! The EDS value text decoder for every data type: never panics; a decoded value re-encodes to
//! text that decodes to the same value, and its bytes decode back to it; its display form has
//! no control characters.
#![no_main]

use canola_od::{BASIC_DATA_TYPES, DataType, EdsValue, Value};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = core::str::from_utf8(rest) else {
        return;
    };
    let dt = BASIC_DATA_TYPES[usize::from(selector) % BASIC_DATA_TYPES.len()];
    let _ = EdsValue::parse(DataType::Other(u16::from(selector)), text);
    if let Ok((v, _)) = EdsValue::parse(dt, text) {
        let _ = v.resolve(selector);
        let canonical = v.to_eds_text();
        // Strings with line breaks cannot be written to an EDS line; everything else round-trips.
        if !canonical.contains(['\n', '\r']) {
            let (back, _) = EdsValue::parse(dt, &canonical).expect("canonical text parses");
            assert_eq!(back, v);
        }
        let shown = format!("{} {:#}", v.value, v.value);
        assert!(!shown.chars().any(char::is_control), "{shown:?}");
        let bytes = v.value.to_le_bytes();
        // A VISIBLE_STRING read from bytes ends at its first NUL (as devices terminate them), so
        // a text value with a NUL in it comes back cut there.
        let expected = match &v.value {
            Value::VisibleString(s) => {
                let end = s.iter().position(|&b| b == 0).unwrap_or(s.len());
                Value::VisibleString(s[..end].to_vec().into())
            }
            other => other.clone(),
        };
        assert_eq!(
            Value::from_le_bytes(dt, &bytes).expect("own bytes decode"),
            expected
        );
    }
    let _ = Value::from_le_bytes(dt, rest);
});
