//! What real devices send: answers and requests shorter than eight bytes (the DLC covers the
//! bytes the command needs; CiA 301 §7.2.4.3 gives every other byte no meaning), and block
//! transfers whose sub-block segments arrive with gaps, twice or out of order (CiA 301
//! §7.2.4.3.9–16: the receiver acknowledges the last segment received in sequence and the
//! sender repeats the rest).

mod common;

use canola_frame::{Duration, Instant};
use canola_sdo::{
    ClientRequest, DecodeError, ErrorKind, Event, Method, Multiplexer, ServerResponse, Violation,
};
use common::{MemOd, TestClient, U16_RW};

const T0: Instant = Instant::ZERO;

fn drain(c: &mut TestClient) -> Vec<[u8; 8]> {
    std::iter::from_fn(|| c.poll_transmit()).collect()
}

fn upload(mux: Multiplexer) -> TestClient {
    let mut c = TestClient::new(canola_sdo::ClientConfig::default());
    c.start_upload(T0, mux, Vec::new(), Method::Normal).unwrap();
    drain(&mut c);
    c
}

// ---------------------------------------------------------------------------------------------
// Frames shorter than eight bytes.

/// A device answering an expedited upload of one byte with DLC 5 (`4F 00 14 02 FE`): the
/// command byte, the multiplexer and the one data byte it announces.
#[test]
fn client_takes_expedited_upload_answer_with_dlc_5() {
    let mux = Multiplexer::new(0x1400, 2);
    let mut c = upload(mux);
    c.handle_response(T0, &[0x4F, 0x00, 0x14, 0x02, 0xFE]);
    match c.poll_event() {
        Some(Event::Uploaded { sink, len, .. }) => {
            assert_eq!(sink, [0xFE]);
            assert_eq!(len, 1);
        }
        other => panic!("expected the upload, got {other:?}"),
    }
    assert!(drain(&mut c).is_empty(), "no abort goes out");
}

/// Short answers of every normal step: initiate download response (4 bytes), download
/// segment response (1 byte), segmented initiate without size (4 bytes), an upload segment
/// carrying 3 bytes (4 bytes).
#[test]
fn client_takes_short_answers_of_every_step() {
    // Segmented upload, size not indicated, then one last segment of 3 bytes.
    let mux = Multiplexer::new(0x1008, 0);
    let mut c = upload(mux);
    c.handle_response(T0, &[0x40, 0x08, 0x10, 0x00]);
    assert_eq!(drain(&mut c), [[0x60, 0, 0, 0, 0, 0, 0, 0]]);
    c.handle_response(T0, &[0x09, b'a', b'b', b'c']);
    match c.poll_event() {
        Some(Event::Uploaded { sink, .. }) => assert_eq!(sink, b"abc"),
        other => panic!("expected the upload, got {other:?}"),
    }
    // Segmented download of 10 bytes: every answer 4 or 1 bytes long.
    c.start_download(T0, mux, (0..10).collect(), Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(T0, &[0x60, 0x08, 0x10, 0x00]);
    assert_eq!(drain(&mut c).len(), 1);
    c.handle_response(T0, &[0x20]);
    assert_eq!(drain(&mut c).len(), 1);
    c.handle_response(T0, &[0x30]);
    assert!(matches!(c.poll_event(), Some(Event::Downloaded { .. })));
}

/// An answer too short for what its command says (an expedited answer announcing 2 bytes with
/// only one of them in the frame; a segment announcing 7 bytes in 4; an abort without its
/// code) is a typed decode error, and the client ends the transfer with an abort rather
/// than invent the missing bytes or wait for its timeout.
#[test]
fn client_refuses_answers_too_short_for_their_command() {
    assert_eq!(
        ServerResponse::parse(&[0x4B, 0x00, 0x14, 0x02, 0xFE]),
        Err(DecodeError::Short {
            command: 0x4B,
            needs: 6,
            len: 5
        })
    );
    for frame in [
        &[0x4B, 0x00, 0x14, 0x02, 0xFE][..],
        &[0x43, 0x00, 0x14, 0x02, 1, 2, 3],
        &[0x42, 0x00, 0x14, 0x02, 1, 2, 3],
        &[0x41, 0x00, 0x14, 0x02, 1],
        &[0x80, 0x00, 0x14, 0x02, 0, 0, 2],
    ] {
        let mux = Multiplexer::new(0x1400, 2);
        let mut c = upload(mux);
        c.handle_response(T0, frame);
        let code = Violation::ShortFrame.abort_code();
        assert_eq!(
            drain(&mut c),
            [ClientRequest::Abort { mux, code }.emit()],
            "{frame:02x?}"
        );
        match c.poll_event() {
            Some(Event::Failed { error, .. }) => {
                assert_eq!(error.kind, ErrorKind::Protocol(Violation::ShortFrame))
            }
            other => panic!("expected a failure for {frame:02x?}, got {other:?}"),
        }
    }
    // A short answer naming another object is a late answer to another transfer, ignored
    // as its long form would be; so is one too short to name its object.
    let mux = Multiplexer::new(0x1400, 2);
    let mut c = upload(mux);
    c.handle_response(T0, &[0x4B, 0x00, 0x15, 0x02, 0xFE]);
    c.handle_response(T0, &[0x4B, 0x00, 0x14]);
    assert!(c.poll_event().is_none());
    assert!(drain(&mut c).is_empty());
    c.handle_response(T0, &[0x4B, 0x00, 0x14, 0x02, 0xFE, 0x01]);
    assert!(matches!(
        c.poll_event(),
        Some(Event::Uploaded { len: 2, .. })
    ));
    // An empty frame and one longer than eight bytes are no SDO message.
    assert_eq!(ServerResponse::parse(&[]), Err(DecodeError::Length(0)));
    assert_eq!(ServerResponse::parse(&[0; 9]), Err(DecodeError::Length(9)));
}

/// The server side: a master that sends short requests. Each holds every byte its command
/// needs, so the server serves it as it would the eight-byte request; a request too short for
/// its command is answered with abort 0x05040001 and changes nothing.
#[test]
fn server_takes_short_requests_that_hold_their_bytes() {
    let mut od = MemOd::new();
    let mut s = canola_sdo::Server::new(canola_sdo::ServerConfig::default());
    // Initiate upload of 0x2000:02 in four bytes.
    s.handle_request(T0, &[0x40, 0x00, 0x20, 0x02], &mut od);
    assert_eq!(
        s.poll_transmit(),
        Some([0x4B, 0x00, 0x20, 0x02, 0xE8, 0x03, 0, 0])
    );
    // Expedited download of two bytes in six.
    s.handle_request(T0, &[0x2B, 0x00, 0x20, 0x02, 0x10, 0x27], &mut od);
    assert_eq!(
        s.poll_transmit(),
        Some([0x60, 0x00, 0x20, 0x02, 0, 0, 0, 0])
    );
    assert_eq!(od.value(U16_RW), [0x10, 0x27]);
    // Announces two bytes, carries one: refused, the object keeps its value.
    s.handle_request(
        T0 + Duration::from_millis(1),
        &[0x2B, 0x00, 0x20, 0x02, 0x55],
        &mut od,
    );
    assert_eq!(
        s.poll_transmit(),
        Some([0x80, 0x00, 0x20, 0x02, 0x01, 0x00, 0x04, 0x05])
    );
    assert_eq!(od.value(U16_RW), [0x10, 0x27]);
}

// ---------------------------------------------------------------------------------------------
// Expedited upload without the size indicated.

/// `42 ...`: e = 1, s = 0. The four bytes reach the sink and the event says the size was not
/// indicated, so the master decodes the object with its type's length (CiA 301 leaves the
/// bytes past the object unspecified); an answer with the size indicated says so too.
#[test]
fn client_reports_an_expedited_upload_without_size() {
    let mux = Multiplexer::new(0x2000, 1);
    let mut c = upload(mux);
    c.handle_response(T0, &[0x42, 0x00, 0x20, 0x01, 0x05, 0xA5, 0xA5, 0xA5]);
    match c.poll_event() {
        Some(Event::Uploaded {
            sink,
            len,
            unsized_expedited,
            ..
        }) => {
            assert_eq!(sink, [0x05, 0xA5, 0xA5, 0xA5]);
            assert_eq!(len, 4);
            assert!(unsized_expedited);
        }
        other => panic!("expected the upload, got {other:?}"),
    }
    for (answer, expect) in [
        (&[0x4F, 0x00, 0x20, 0x01, 0x05, 0, 0, 0], false),
        (&[0x43, 0x00, 0x20, 0x01, 0x05, 0, 0, 0], false),
    ] {
        c.start_upload(T0, mux, Vec::new(), Method::Normal).unwrap();
        drain(&mut c);
        c.handle_response(T0, answer);
        match c.poll_event() {
            Some(Event::Uploaded {
                unsized_expedited, ..
            }) => assert_eq!(unsized_expedited, expect, "{answer:02x?}"),
            other => panic!("expected the upload, got {other:?}"),
        }
    }
}
