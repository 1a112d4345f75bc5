//! Every canola-lss decoder on arbitrary bytes: no panic, whatever decodes re-encodes to a
//! value that decodes to the same thing (unknown command specifiers keep every byte), and its
//! CiA 305 text (`Display`) is written without a panic.
#![no_main]

use canola_frame::{CanFrame, CanId};
use canola_lss::{Request, Response};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = Request::parse(data) {
        assert_eq!(data.len(), 8);
        assert_eq!(Request::parse(&r.emit()), Ok(r));
        assert_eq!(Request::from_frame(&r.to_frame()), Ok(r));
        if let Request::Unknown { .. } = r {
            assert_eq!(&r.emit()[..], data);
        }
        assert!(r.to_string().starts_with("LSS "));
    }
    if let Ok(r) = Response::parse(data) {
        assert_eq!(Response::parse(&r.emit()), Ok(r));
        assert_eq!(Response::from_frame(&r.to_frame()), Ok(r));
        if let Response::Unknown { .. } = r {
            assert_eq!(&r.emit()[..], data);
        }
        assert!(r.to_string().starts_with("LSS "));
        let _ = match r {
            Response::ConfigureNodeId(s)
            | Response::ConfigureBitTiming(s)
            | Response::StoreConfiguration(s) => s.result().map(|()| 0),
            _ => Ok(1),
        };
    }
    // The same bytes as a frame on either LSS COB-ID (or a neighbour), data or remote.
    if let Some((&sel, rest)) = data.split_first() {
        let cob = 0x7E3 + u16::from(sel & 3);
        if let (Ok(id), Some(body)) = (CanId::standard(cob), rest.get(..rest.len().min(8))) {
            let frame = if sel & 4 != 0 {
                CanFrame::remote(id, body.len())
            } else {
                CanFrame::new(id, body)
            };
            if let Ok(f) = frame {
                let _ = Request::from_frame(&f);
                let _ = Response::from_frame(&f);
            }
        }
    }
});
