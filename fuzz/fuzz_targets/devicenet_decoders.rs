//! Fuzzes the DeviceNet decoders: any frame decoded and printed, explicit frames, requests and
//! responses (lossless where they decode), Identity attributes, the Duplicate MAC ID check
//! message, and the reassembler fed arbitrary fragments.
#![no_main]

use std::fmt::Write as _;

use canola_devicenet::explicit::{ExplicitFrame, Request, Response};
use canola_devicenet::fragment::{FragmentByte, MessageBuf, Reassembler};
use canola_devicenet::{DuplicateMacCheck, Identity};
use canola_frame::{CanFrame, CanId};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&hi, rest)) = data.split_first() else {
        return;
    };
    let Some((&lo, body)) = rest.split_first() else {
        return;
    };
    let id = u16::from_be_bytes([hi, lo]) & 0x7FF;
    let frame_data = &body[..body.len().min(8)];
    let frame = CanFrame::new(CanId::standard(id).unwrap(), frame_data).unwrap();
    let mut s = String::new();
    let _ = write!(s, "{}", canola_devicenet::decode(&frame));
    assert!(!s.is_empty());

    if let Ok(f) = ExplicitFrame::parse(frame_data) {
        let out = f.emit().expect("a parsed frame re-encodes");
        assert_eq!(&out[..], &frame_data[..out.len()]);
    }
    if let Ok(r) = Request::parse(body) {
        let mut m = MessageBuf::new();
        if r.emit(&mut m).is_ok() {
            assert_eq!(Request::parse(&m), Ok(r));
        }
        let _ = write!(s, "{r}");
    }
    if let Ok(r) = Response::parse(body) {
        let mut m = MessageBuf::new();
        if r.emit(&mut m).is_ok() {
            assert_eq!(Response::parse(&m), Ok(r));
        }
        let _ = write!(s, "{r}");
    }
    if let Ok(c) = DuplicateMacCheck::parse(frame_data) {
        assert_eq!(&c.emit()[..], frame_data);
    }
    let mut identity = Identity::default();
    if identity.set_attribute(hi & 7, body).is_ok()
        && let Some(v) = identity.attribute(hi & 7)
    {
        assert_eq!(&v[..], body);
    }
    // The reassembler: each 8-byte chunk is a fragmentation byte and its data.
    let mut r = Reassembler::new();
    for chunk in body.chunks(8) {
        let (&fb, d) = chunk.split_first().unwrap();
        if let Ok(Some(m)) = r.push(FragmentByte::from_u8(fb), d) {
            assert!(m.len() <= canola_devicenet::fragment::MAX_MESSAGE);
        }
    }
});
