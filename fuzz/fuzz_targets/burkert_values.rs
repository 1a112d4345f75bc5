//! Every decoder of the Bürkert profile on arbitrary object values and text: no panic, and each
//! accepted value encodes back to what was decoded.
#![no_main]

use canola_burkert::objects::{
    self, buerkert_device_description_object as desc, device_status_object as st,
    error_management_object,
};
use canola_burkert::{
    BitRate, BusMode, CanOperationStatus, EdsVersion, Kelvin, LedColour, LedMode, LedState,
    Ne107Status, ResetCommand, Termination, TransMemStatus, ValveModeColours, ValvePosition,
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

    // The generated entries the master decodes SDO upload bytes with (BurkertNode): total on
    // any length; a decoded string (trailing NULs dropped) survives an encode-decode round trip.
    if let Ok(name) = desc::DEVICE_NAME.decode(data) {
        let mut out = vec![0u8; data.len()];
        let n = desc::DEVICE_NAME.encode(&name, &mut out).unwrap();
        assert_eq!(desc::DEVICE_NAME.decode(&out[..n]).unwrap(), name);
    }
    let _ = error_management_object::LOGBOOK_DOWNLOAD.decode(data);
    if let Ok(t) = st::DEVICE_TEMPERATURE.decode(data) {
        let _ = Kelvin(t).celsius();
    }
    let _ = st::OPERATION_TIME_S.decode(data);
    let _ = st::MAXIMUM_DEVICE_TEMPERATURE.decode(data);
    if let Ok(v) = st::DEVICE_STATUS_NAMUR_NE107.decode(data) {
        let _ = Ne107Status::from_raw(v).colour();
    }
    if let Ok(mode) = objects::LED_MODE.decode(data) {
        // The device's LED for whatever the bytes configure.
        let status = Ne107Status::from_raw(byte);
        let colour = LedColour::from_u32(raw).unwrap_or(LedColour::OFF);
        let state = LedState {
            mode: LedMode::from_u32(mode).unwrap_or_default(),
            status,
            valve: [
                None,
                Some(ValvePosition::Closed),
                Some(ValvePosition::Between),
                Some(ValvePosition::Open),
            ][usize::from(byte >> 6)],
            valve_colours: ValveModeColours::default(),
            external: colour,
            locating: byte & 0x10 != 0,
        };
        let _ = state.indication();
    }
});
