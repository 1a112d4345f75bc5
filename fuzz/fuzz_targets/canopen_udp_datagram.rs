//! The UDP multicast bus's datagram decoder (python-can's MessagePack format): any bytes give a
//! message or a typed error, never a panic, and every frame decoded encodes to a datagram that
//! decodes to the same frame.
#![no_main]

use canola::udp::{Message, decode, encode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(Message::Frame(frame)) = decode(data) {
        assert_eq!(decode(&encode(&frame, 0.0)), Ok(Message::Frame(frame)));
    }
});
