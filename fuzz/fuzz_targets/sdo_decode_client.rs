//! The decoders an SDO client runs on bus bytes (server responses and block upload segments):
//! no panic (in decoding or in the `Display` text), and whatever decodes re-encodes to bytes that decode to the same value.
#![no_main]

use canola_sdo::{BlockSegment, ServerResponse};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(msg) = ServerResponse::parse(data) {
        assert_eq!(ServerResponse::parse(&msg.emit()), Ok(msg));
        // A short frame reads as its eight-byte form with zero reserved bytes.
        let mut padded = [0u8; 8];
        padded[..data.len()].copy_from_slice(data);
        assert_eq!(ServerResponse::parse(&padded), Ok(msg));
        let _ = msg.to_string();
    }
    if let Ok(seg) = BlockSegment::parse(data) {
        assert_eq!(&seg.emit()[..], data);
        let _ = seg.to_string();
    }
});
