//! Every canola-nmt decoder on arbitrary bytes: no panic (in decoding or in the `Display`
//! texts), and whatever decodes re-encodes to a
//! value that decodes to the same thing.
#![no_main]

use canola_frame::{CanFrame, CanId};
use canola_nmt::{
    Emcy, ErrorControlFrame, ErrorControlMessage, GuardResponse, Heartbeat, NmtCommand,
    SyncMessage, TimeOfDay,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(c) = NmtCommand::parse(data) {
        assert_eq!(c.emit(), data);
        assert_eq!(NmtCommand::from_frame(&c.to_frame()), Ok(c));
        let _ = c.to_string();
    }
    if let Ok(h) = Heartbeat::parse(data) {
        assert_eq!([h.emit()], data);
        let _ = h.to_string();
    }
    if let Ok(g) = GuardResponse::parse(data) {
        assert_eq!(GuardResponse::from_byte(g.emit()), g);
        let _ = g.to_string();
    }
    if let Ok(s) = SyncMessage::parse(data) {
        assert_eq!(s.to_frame(0x80).data(), data);
        let _ = s.to_string();
    }
    if let Ok(t) = TimeOfDay::parse(data) {
        assert_eq!(TimeOfDay::parse(&t.emit()), Ok(t));
        let _ = TimeOfDay::from_unix_millis(t.to_unix_millis());
        let _ = t.to_string();
    }
    if let Ok(e) = Emcy::parse(data) {
        assert_eq!(&e.emit()[..], data);
        let _ = e.code.description();
        let _ = e.to_string();
    }
    // Whole frames: first two bytes pick the identifier and the RTR flag, the rest is data.
    if let [a, b, rest @ ..] = data {
        let raw = u16::from_le_bytes([*a, *b]);
        if let Ok(id) = CanId::standard(raw & 0x7FF) {
            let frame = if raw & 0x8000 != 0 {
                CanFrame::remote(id, rest.len().min(8))
            } else {
                CanFrame::new(id, &rest[..rest.len().min(8)])
            };
            if let Ok(f) = frame {
                let _ = ErrorControlFrame::from_frame(&f);
                if let Ok(m) = ErrorControlMessage::from_frame(&f) {
                    if !f.is_remote() {
                        assert_eq!(m.to_frame(), f);
                    }
                    let _ = m.to_string();
                }
                if let Some(cob) = canola_frame::CobId::classify(raw & 0x7FF) {
                    let _ = cob.to_string();
                }
                let _ = NmtCommand::from_frame(&f);
                let _ = SyncMessage::from_frame(&f, 0x80);
                let _ = TimeOfDay::from_frame(&f, 0x100);
            }
        }
    }
});
