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

// ---------------------------------------------------------------------------------------------
// Block transfers with sub-block segments lost, repeated or out of order, through the real
// client and server. The sender's frames pass a faulty link; every transfer must end with the
// right data in the object or the sink, never with other data.

use canola_sdo::{Client, ClientConfig, Server, ServerConfig};
use common::DOMAIN;

/// What the link does to the sender's n-th frame (counted over the whole transfer).
#[derive(Debug, Clone, Copy)]
enum Fault {
    /// Lost.
    Drop(usize),
    /// Delivered twice in a row (a CAN frame repeated by its transmitter after an error in
    /// the last bit of the end of frame, already taken by the receiver).
    Dup(usize),
    /// Delivered after the frame that follows it.
    Swap(usize),
}

/// Which side sends the sub-blocks.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Dir {
    Upload,
    Download,
}

struct Link {
    client: TestClient,
    server: Server,
    od: MemOd,
    now: Instant,
    faults: Vec<Fault>,
    /// Frames the sub-block sender has emitted so far.
    sent: usize,
    /// Acknowledgements from the receiver, (ackseq, blksize).
    acks: Vec<u8>,
}

impl Link {
    fn new(crc: bool, blksize: u8, faults: &[Fault]) -> Self {
        Self {
            client: Client::new(
                ClientConfig::default()
                    .with_crc(crc)
                    .with_block_size(blksize),
            ),
            server: Server::new(ServerConfig {
                crc,
                block_size: blksize,
                ..ServerConfig::default()
            }),
            od: MemOd::new(),
            now: T0,
            faults: faults.to_vec(),
            sent: 0,
            acks: Vec::new(),
        }
    }

    /// Passes a batch of the sender's frames through the faults.
    fn mangle(&mut self, batch: Vec<[u8; 8]>) -> Vec<[u8; 8]> {
        let mut out: Vec<[u8; 8]> = Vec::new();
        let mut swapped: Option<[u8; 8]> = None;
        for f in batch {
            let n = self.sent;
            self.sent += 1;
            let mut copies = 1;
            for fault in &self.faults {
                match *fault {
                    Fault::Drop(i) if i == n => copies = 0,
                    Fault::Dup(i) if i == n => copies = 2,
                    Fault::Swap(i) if i == n => {
                        swapped = Some(f);
                        copies = 0;
                    }
                    _ => {}
                }
            }
            out.extend(std::iter::repeat_n(f, copies));
            if copies > 0
                && let Some(held) = swapped.take()
            {
                out.push(held);
            }
        }
        out.extend(swapped);
        out
    }

    fn run(&mut self, dir: Dir) -> Event<Vec<u8>, Vec<u8>> {
        for _ in 0..10_000 {
            loop {
                let from_client: Vec<_> =
                    std::iter::from_fn(|| self.client.poll_transmit()).collect();
                let from_client = if dir == Dir::Download {
                    self.mangle(from_client)
                } else {
                    from_client
                };
                for f in &from_client {
                    if dir == Dir::Upload && f[0] == 0xA2 {
                        self.acks.push(f[1]);
                    }
                    self.server.handle_request(self.now, f, &mut self.od);
                }
                let from_server: Vec<_> =
                    std::iter::from_fn(|| self.server.poll_transmit()).collect();
                let from_server = if dir == Dir::Upload {
                    self.mangle(from_server)
                } else {
                    from_server
                };
                for f in &from_server {
                    if dir == Dir::Download && f[0] == 0xA2 {
                        self.acks.push(f[1]);
                    }
                    self.client.handle_response(self.now, f);
                }
                if from_client.is_empty() && from_server.is_empty() {
                    break;
                }
                self.now += Duration::from_micros(100);
            }
            if let Some(ev) = self.client.poll_event() {
                for f in std::iter::from_fn(|| self.client.poll_transmit()).collect::<Vec<_>>() {
                    self.server.handle_request(self.now, &f, &mut self.od);
                }
                return ev;
            }
            let next = [self.client.poll_timeout(), self.server.poll_timeout()]
                .into_iter()
                .flatten()
                .min()
                .expect("something must be pending");
            self.now = self.now.max(next);
            self.client.handle_timeout(self.now);
            self.server.handle_timeout(self.now, &mut self.od);
        }
        panic!("transfer did not end");
    }
}

fn pattern(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 7 + 3) as u8).collect()
}

/// 100 bytes: 15 segments, in sub-blocks of 8 (the second one 7, its last segment carries 2
/// bytes). Frame 0 of the upload stream is the initiate response; the segments of the first
/// sub-block are frames 1..=8, the next sub-block follows the acknowledgement.
const LEN: usize = 100;
const BLKSIZE: u8 = 8;

fn block_upload(crc: bool, faults: &[Fault]) -> (Event<Vec<u8>, Vec<u8>>, Link) {
    let mut l = Link::new(crc, BLKSIZE, faults);
    l.od.set(DOMAIN, pattern(LEN));
    l.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    let ev = l.run(Dir::Upload);
    (ev, l)
}

fn block_download(crc: bool, faults: &[Fault]) -> (Event<Vec<u8>, Vec<u8>>, Link) {
    let mut l = Link::new(crc, BLKSIZE, faults);
    l.client
        .start_download(T0, DOMAIN, pattern(LEN), Method::Block)
        .unwrap();
    let ev = l.run(Dir::Download);
    (ev, l)
}

fn assert_uploaded(ev: Event<Vec<u8>, Vec<u8>>, what: &str) {
    match ev {
        Event::Uploaded { sink, .. } => assert_eq!(sink, pattern(LEN), "{what}"),
        other => panic!("{what}: expected the upload, got {other:?}"),
    }
}

fn assert_downloaded(ev: Event<Vec<u8>, Vec<u8>>, l: &Link, what: &str) {
    match ev {
        Event::Downloaded { .. } => assert_eq!(l.od.value(DOMAIN), pattern(LEN), "{what}"),
        other => panic!("{what}: expected the download, got {other:?}"),
    }
}

/// The faults of every test: a gap, a repeated segment, two segments swapped, at the start,
/// the middle and the end of a sub-block. Stream positions: the upload's frame 0 is the
/// initiate response, so its segment k of the first sub-block is frame k; the download's
/// frame 0 is the initiate request as well.
fn faults() -> Vec<(&'static str, Vec<Fault>)> {
    vec![
        ("gap at segment 3", vec![Fault::Drop(3)]),
        ("gap at segment 1", vec![Fault::Drop(1)]),
        ("two gaps", vec![Fault::Drop(2), Fault::Drop(5)]),
        ("segment 3 twice", vec![Fault::Dup(3)]),
        ("segment 1 twice", vec![Fault::Dup(1)]),
        ("last of the sub-block twice", vec![Fault::Dup(8)]),
        ("segments 3 and 4 swapped", vec![Fault::Swap(3)]),
        ("segments 1 and 2 swapped", vec![Fault::Swap(1)]),
        ("segments 7 and 8 swapped", vec![Fault::Swap(7)]),
        (
            "gap, then a repeat of the segment after it",
            vec![Fault::Drop(3), Fault::Dup(4)],
        ),
        ("a gap in the second sub-block", vec![Fault::Drop(12)]),
        ("last segment of the transfer twice", vec![Fault::Dup(15)]),
        (
            "last segment of the transfer before the one ahead of it",
            vec![Fault::Swap(14)],
        ),
    ]
}

#[test]
fn block_upload_with_segments_lost_repeated_or_reordered() {
    for crc in [true, false] {
        for (what, faults) in faults() {
            let (ev, l) = block_upload(crc, &faults);
            let what = format!("{what}, crc {crc}, acks {:?}", l.acks);
            assert_uploaded(ev, &what);
        }
    }
}

#[test]
fn block_download_with_segments_lost_repeated_or_reordered() {
    for crc in [true, false] {
        for (what, faults) in faults() {
            let (ev, l) = block_download(crc, &faults);
            let what = format!("{what}, crc {crc}, acks {:?}", l.acks);
            assert_downloaded(ev, &l, &what);
        }
    }
}

/// Each sub-block is acknowledged once, with the last segment received in sequence: a gap at
/// segment 3 gives ackseq 2, and the repeat of the rest gives a full sub-block again.
#[test]
fn block_acknowledges_the_last_segment_in_sequence() {
    for crc in [true, false] {
        let (ev, l) = block_upload(crc, &[Fault::Drop(3)]);
        assert_uploaded(ev, "gap");
        assert_eq!(l.acks, [2, 8, 5], "crc {crc}");
        // A repeated last segment of the sub-block is not acknowledged a second time.
        let (ev, l) = block_upload(crc, &[Fault::Dup(8)]);
        assert_uploaded(ev, "repeat");
        assert_eq!(l.acks, [8, 7], "crc {crc}");
        // Segment 4 before segment 3: the rest of the sub-block after the gap is dropped,
        // segment 3 included, and sent again.
        let (ev, l) = block_upload(crc, &[Fault::Swap(3)]);
        assert_uploaded(ev, "swap");
        assert_eq!(l.acks, [2, 8, 5], "crc {crc}");
        let (ev, l) = block_download(crc, &[Fault::Swap(3)]);
        assert_downloaded(ev, &l, "swap");
        assert_eq!(l.acks, [2, 8, 5], "crc {crc}");
    }
}

/// The last segment of a sub-block (or of the transfer) lost: the receiver never learns the
/// sub-block ended, and CiA 301 gives it no way to ask; the transfer ends in the timeout
/// abort (0x05040000) on both sides, and nothing of it is stored.
#[test]
fn block_transfer_whose_last_segment_is_lost_times_out_cleanly() {
    for crc in [true, false] {
        for lost in [8, 16] {
            let (ev, l) = block_upload(crc, &[Fault::Drop(lost)]);
            match ev {
                Event::Failed { error, .. } => assert_eq!(error.kind, ErrorKind::Timeout),
                other => panic!("expected the timeout, got {other:?}"),
            }
            assert!(l.server.is_idle());
            let (ev, l) = block_download(crc, &[Fault::Drop(lost)]);
            match ev {
                Event::Failed { error, .. } => assert_eq!(error.kind, ErrorKind::Timeout),
                other => panic!("expected the timeout, got {other:?}"),
            }
            assert!(l.server.is_idle());
            assert!(l.od.value(DOMAIN).is_empty(), "nothing stored");
        }
    }
}

/// The last segment of the transfer repeated, when its bytes read as an abort of "0000:00"
/// (`0x87 00 00 00 ...`: an object ending in zeros): a repeat, not an abort.
#[test]
fn block_repeat_of_a_last_segment_of_zeros() {
    for crc in [true, false] {
        let mut l = Link::new(crc, BLKSIZE, &[Fault::Dup(15)]);
        l.od.set(DOMAIN, vec![0; LEN]);
        l.client
            .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
            .unwrap();
        match l.run(Dir::Upload) {
            Event::Uploaded { sink, .. } => assert_eq!(sink, [0; LEN]),
            other => panic!("crc {crc}: expected the upload, got {other:?}"),
        }
        let mut l = Link::new(crc, BLKSIZE, &[Fault::Dup(15)]);
        l.client
            .start_download(T0, DOMAIN, vec![0; LEN], Method::Block)
            .unwrap();
        match l.run(Dir::Download) {
            Event::Downloaded { .. } => assert_eq!(l.od.value(DOMAIN), [0; LEN]),
            other => panic!("crc {crc}: expected the download, got {other:?}"),
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

    /// Any mix of lost, repeated and swapped frames of the sender (segments, initiate and end
    /// messages alike), with or without CRC: the transfer ends with the right data or fails;
    /// it never hands over or stores other data.
    #[test]
    fn block_transfers_on_a_faulty_link_never_give_wrong_data(
        crc in proptest::bool::ANY,
        upload in proptest::bool::ANY,
        len in 0usize..300,
        faults in proptest::collection::vec((0u8..3, 0usize..60), 0..6),
    ) {
        let faults: Vec<Fault> = faults
            .into_iter()
            .map(|(kind, at)| match kind {
                0 => Fault::Drop(at),
                1 => Fault::Dup(at),
                _ => Fault::Swap(at),
            })
            .collect();
        let data = pattern(len);
        let mut l = Link::new(crc, BLKSIZE, &faults);
        if upload {
            l.od.set(DOMAIN, data.clone());
            l.client.start_upload(T0, DOMAIN, Vec::new(), Method::Block).unwrap();
            if let Event::Uploaded { sink, .. } = l.run(Dir::Upload) {
                proptest::prop_assert_eq!(sink, data);
            }
        } else {
            l.client.start_download(T0, DOMAIN, data.clone(), Method::Block).unwrap();
            let ev = l.run(Dir::Download);
            let stored = l.od.value(DOMAIN);
            // Stored only when complete and right.
            proptest::prop_assert!(stored.is_empty() || stored == &data[..]);
            if let Event::Downloaded { .. } = ev {
                proptest::prop_assert_eq!(stored, &data[..]);
            }
        }
    }
}

/// One way to write an object address in every message: `0x1F50:01` (index in four upper-case
/// hex digits, sub-index in two), as canola-od's `ObjectAddress` writes it.
#[test]
fn object_addresses_read_one_way() {
    let mux = Multiplexer::new(0x1F50, 0x0A);
    assert_eq!(mux.to_string(), "0x1F50:0A");
    let error = canola_sdo::TransferError {
        index: 0x1F50,
        subindex: 0x0A,
        kind: ErrorKind::Timeout,
    };
    assert!(error.to_string().starts_with("SDO 0x1F50:0A: "), "{error}");
    assert!(
        ServerResponse::parse(&[0x80, 0x50, 0x1F, 0x0A, 0, 0, 2, 6])
            .unwrap()
            .to_string()
            .contains("0x1F50:0A"),
    );
}
