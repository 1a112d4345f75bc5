//! Every decoder of the Bürkert profile on arbitrary object values and text: no panic, and each
//! accepted value encodes back to what was decoded.
#![no_main]

use burkert_profile::{
    BitRate, BusMode, CanOperationStatus, EdsVersion, LedColour, LedMode, Ne107Status,
    ResetCommand, Termination, TransMemStatus,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut word = [0u8; 4];
    let n = data.len().min(4);
    word[..n].copy_from_slice(&data[..n]);
    let raw = u32::from_le_bytes(word);
    let byte = word[0];

    if let Ok(c) = LedColour::from_u32(raw) {
        assert_eq!(c.to_u32(), raw);
        let _ = c.quantise_blue();
    }
    if let Ok(m) = LedMode::from_u32(raw) {
        assert_eq!(m.to_u32(), raw);
    }
    let s = Ne107Status::from_raw(byte);
    assert_eq!(s.to_raw(), byte & 0x0F);
    let _ = (
        BitRate::from_code(byte),
        BusMode::from_u8(byte),
        ResetCommand::from_u8(byte),
    );
    let _ = Termination::from_u8(byte);
    assert_eq!(CanOperationStatus::from_u8(byte).to_u8(), byte);
    assert_eq!(TransMemStatus::from_u8(byte).to_u8(), byte);
    assert_eq!(EdsVersion::from_u8(byte).to_u8(), byte);

    if let Ok(text) = core::str::from_utf8(data) {
        let _ = LedColour::from_name(text);
        let _ = LedMode::from_name(text);
    }
});
