//! The USDO decoder (CiA 1301) on any bytes, as a client or server meets them on the bus: no
//! panic, the raw view's getters total, and whatever decodes re-encodes to bytes that decode to
//! the same value and match the input over the protocol length (reserved byte aside).
#![no_main]

use canola_frame::fd::padded_len;
use canola_sdo::usdo::{MAX_FRAME, UsdoBody, UsdoMessage, UsdoPacket};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(p) = UsdoPacket::new_checked(data) {
        let _ = (
            p.destination(),
            p.command(),
            p.session(),
            p.mux(),
            p.data_type(),
        );
        let _ = (p.expedited_len(), p.size(), p.counter(), p.abort_code());
    }
    let Ok(msg) = UsdoMessage::parse(data) else {
        return;
    };
    let mut out = [0u8; MAX_FRAME];
    let n = msg.emit(&mut out).expect("a decoded message encodes");
    assert!(n <= data.len());
    let initiate = matches!(
        msg.body,
        UsdoBody::DownloadInitiate { .. } | UsdoBody::UploadInitiateResponse { .. }
    );
    for i in 0..n {
        if !(initiate && i == 7) {
            assert_eq!(out[i], data[i], "byte {i}");
        }
    }
    let bytes = msg.to_bytes().expect("encodes");
    assert_eq!(Some(bytes.len()), padded_len(n));
    assert_eq!(UsdoMessage::parse(&bytes), Ok(msg));
    let _ = format!("{msg} {msg:?} {}", msg.body.is_request());
});
