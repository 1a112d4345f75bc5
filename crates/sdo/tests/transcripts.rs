//! Transcript tests on a virtual clock: the client against the server (every transfer method,
//! byte for byte where the frames are short), and each machine against scripted frames for
//! every abort code, timeout and stray frame they handle.

mod common;

use canola_frame::{Duration, Instant};
use canola_sdo::{
    AbortCode, BlockSegment, Buffer, Client, ClientConfig, ClientRequest, ErrorKind, Event,
    Initiate, Method, Multiplexer, Segment, Server, ServerConfig, ServerEvent, ServerResponse,
    TransferError, Violation, crc16,
};
use common::{
    DOMAIN, From, LIAR, LIMITED, MemOd, Pair, RO, SMALL_STR, TestClient, U16_RW, U32_RW, WO,
};

const T0: Instant = Instant::ZERO;
const SEC: Duration = Duration::from_secs(1);

fn uploaded(ev: Event<Vec<u8>, Vec<u8>>) -> Vec<u8> {
    match ev {
        Event::Uploaded { sink, len, .. } => {
            assert_eq!(sink.len(), len as usize);
            sink
        }
        other => panic!("expected an upload, got {other:?}"),
    }
}

fn downloaded(ev: Event<Vec<u8>, Vec<u8>>) {
    match ev {
        Event::Downloaded { .. } => {}
        other => panic!("expected a download, got {other:?}"),
    }
}

fn failed<S: std::fmt::Debug, D: std::fmt::Debug>(ev: Option<Event<S, D>>) -> TransferError {
    match ev {
        Some(Event::Failed { error, .. }) => error,
        other => panic!("expected a failure, got {other:?}"),
    }
}

fn drain(c: &mut TestClient) -> Vec<[u8; 8]> {
    std::iter::from_fn(|| c.poll_transmit()).collect()
}

fn drain_server(s: &mut Server) -> Vec<[u8; 8]> {
    std::iter::from_fn(|| s.poll_transmit()).collect()
}

fn abort_bytes(mux: Multiplexer, code: AbortCode) -> [u8; 8] {
    ClientRequest::Abort { mux, code }.emit()
}

fn pattern(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 7 + 3) as u8).collect()
}

// ---------------------------------------------------------------------------------------------
// Client against server: the happy paths, byte for byte.

#[test]
fn expedited_upload_transcript() {
    let mut p = Pair::new();
    p.client
        .start_upload(T0, RO, Vec::new(), Method::Normal)
        .unwrap();
    let data = uploaded(p.run());
    assert_eq!(data, [0x91, 0x01, 0x02, 0x00]);
    assert_eq!(
        p.log,
        [
            (From::Client, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]),
            (
                From::Server,
                [0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x02, 0x00]
            ),
        ]
    );
    assert_eq!(
        p.server.poll_event(),
        Some(ServerEvent::Uploaded { mux: RO, len: 4 })
    );
}

#[test]
fn expedited_download_transcript() {
    let mut p = Pair::new();
    p.client
        .start_download(T0, U16_RW, vec![0x10, 0x27], Method::Normal)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(U16_RW), [0x10, 0x27]);
    assert_eq!(
        p.log,
        [
            (From::Client, [0x2B, 0x00, 0x20, 0x02, 0x10, 0x27, 0, 0]),
            (From::Server, [0x60, 0x00, 0x20, 0x02, 0, 0, 0, 0]),
        ]
    );
}

#[test]
fn segmented_upload_transcript() {
    let mut p = Pair::new();
    p.od.set(SMALL_STR, b"0123456789".to_vec());
    p.client
        .start_upload(T0, SMALL_STR, Vec::new(), Method::Normal)
        .unwrap();
    assert_eq!(uploaded(p.run()), b"0123456789");
    assert_eq!(
        p.log,
        [
            (From::Client, [0x40, 0x03, 0x20, 0x00, 0, 0, 0, 0]),
            (From::Server, [0x41, 0x03, 0x20, 0x00, 10, 0, 0, 0]),
            (From::Client, [0x60, 0, 0, 0, 0, 0, 0, 0]),
            (
                From::Server,
                [0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']
            ),
            (From::Client, [0x70, 0, 0, 0, 0, 0, 0, 0]),
            (From::Server, [0x19, b'7', b'8', b'9', 0, 0, 0, 0]),
        ]
    );
}

#[test]
fn segmented_download_transcript() {
    let mut p = Pair::new();
    p.client
        .start_download(T0, SMALL_STR, b"0123456789".to_vec(), Method::Normal)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(SMALL_STR), b"0123456789");
    assert_eq!(
        p.log,
        [
            (From::Client, [0x21, 0x03, 0x20, 0x00, 10, 0, 0, 0]),
            (From::Server, [0x60, 0x03, 0x20, 0x00, 0, 0, 0, 0]),
            (
                From::Client,
                [0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']
            ),
            (From::Server, [0x20, 0, 0, 0, 0, 0, 0, 0]),
            (From::Client, [0x19, b'7', b'8', b'9', 0, 0, 0, 0]),
            (From::Server, [0x30, 0, 0, 0, 0, 0, 0, 0]),
        ]
    );
}

#[test]
fn segmented_download_of_small_data_when_asked() {
    let mut p = Pair::new();
    p.client
        .start_download(T0, U16_RW, vec![1, 2], Method::Segmented)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(U16_RW), [1, 2]);
    assert_eq!(p.log[0].1[0], 0x21);
    assert_eq!(p.log[2].1, [0x0B, 1, 2, 0, 0, 0, 0, 0]);
}

#[test]
fn zero_length_objects() {
    // Upload of an empty DOMAIN: segmented, size 0, one empty last segment.
    let mut p = Pair::new();
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Normal)
        .unwrap();
    assert_eq!(uploaded(p.run()), b"");
    assert_eq!(p.log[1].1, [0x41, 0x00, 0x21, 0x00, 0, 0, 0, 0]);
    assert_eq!(p.log[3].1, [0x0F, 0, 0, 0, 0, 0, 0, 0]);

    // Download of nothing.
    let mut p = Pair::new();
    p.od.set(DOMAIN, vec![1, 2, 3]);
    p.client
        .start_download(T0, DOMAIN, Vec::new(), Method::Normal)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(DOMAIN), b"");
    assert_eq!(p.log[2].1, [0x0F, 0, 0, 0, 0, 0, 0, 0]);

    // Block download and upload of nothing: one segment, n = 7.
    let mut p = Pair::new();
    p.od.set(DOMAIN, vec![1, 2, 3]);
    p.client
        .start_download(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(DOMAIN), b"");
    let end = p.frames(From::Client)[2];
    assert_eq!(end[0], 0xC1 | 7 << 2);

    let mut p = Pair::new();
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    assert_eq!(uploaded(p.run()), b"");
}

#[test]
fn block_download_transcript() {
    let mut p = Pair::new();
    let data = pattern(20);
    p.client
        .start_download(T0, DOMAIN, data.clone(), Method::Block)
        .unwrap();
    downloaded(p.run());
    assert_eq!(p.od.value(DOMAIN), data);
    let crc = crc16(&data).to_le_bytes();
    let seg = |seqno: u8, last: bool, from: usize| {
        let mut d = [0u8; 7];
        let n = (data.len() - from).min(7);
        d[..n].copy_from_slice(&data[from..from + n]);
        BlockSegment {
            seqno,
            last,
            data: d,
        }
        .emit()
    };
    assert_eq!(
        p.log,
        [
            (From::Client, [0xC6, 0x00, 0x21, 0x00, 20, 0, 0, 0]),
            (From::Server, [0xA4, 0x00, 0x21, 0x00, 127, 0, 0, 0]),
            (From::Client, seg(1, false, 0)),
            (From::Client, seg(2, false, 7)),
            (From::Client, seg(3, true, 14)),
            (From::Server, [0xA2, 3, 127, 0, 0, 0, 0, 0]),
            // n = 1: the last segment carries 6 bytes.
            (From::Client, [0xC5, crc[0], crc[1], 0, 0, 0, 0, 0]),
            (From::Server, [0xA1, 0, 0, 0, 0, 0, 0, 0]),
        ]
    );
}

#[test]
fn block_upload_transcript() {
    let mut p = Pair::with(
        ClientConfig::default().with_block_size(2),
        ServerConfig::default(),
    );
    let data = pattern(15);
    p.od.set(DOMAIN, data.clone());
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    assert_eq!(uploaded(p.run()), data);
    let crc = crc16(&data).to_le_bytes();
    let c = p.frames(From::Client);
    let s = p.frames(From::Server);
    assert_eq!(c[0], [0xA4, 0x00, 0x21, 0x00, 2, 0, 0, 0]);
    assert_eq!(s[0], [0xC6, 0x00, 0x21, 0x00, 15, 0, 0, 0]);
    assert_eq!(c[1], [0xA3, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(s[1][0], 0x01);
    assert_eq!(s[2][0], 0x02);
    assert_eq!(c[2], [0xA2, 2, 2, 0, 0, 0, 0, 0]);
    assert_eq!(s[3][0], 0x81);
    assert_eq!(c[3], [0xA2, 1, 2, 0, 0, 0, 0, 0]);
    // 15 bytes: the third segment holds one byte, n = 6.
    assert_eq!(s[4], [0xC1 | 6 << 2, crc[0], crc[1], 0, 0, 0, 0, 0]);
    assert_eq!(c[4], [0xA1, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        p.server.poll_event(),
        Some(ServerEvent::Uploaded {
            mux: DOMAIN,
            len: 15
        })
    );
}

#[test]
fn block_transfers_without_crc() {
    for (client_crc, server_crc) in [(false, true), (true, false), (false, false)] {
        let mut p = Pair::with(
            ClientConfig::default().with_crc(client_crc),
            ServerConfig {
                crc: server_crc,
                ..ServerConfig::default()
            },
        );
        let data = pattern(100);
        p.client
            .start_download(T0, DOMAIN, data.clone(), Method::Block)
            .unwrap();
        downloaded(p.run());
        assert_eq!(p.od.value(DOMAIN), data);
        // No CRC agreed: the end message carries zero.
        let end = *p.frames(From::Client).last().unwrap();
        assert_eq!(&end[1..3], &[0, 0]);
        p.client
            .start_upload(p.now, DOMAIN, Vec::new(), Method::Block)
            .unwrap();
        assert_eq!(uploaded(p.run()), data);
    }
}

#[test]
fn block_upload_protocol_switch() {
    // Object of 10 bytes, threshold 21: the server answers with a segmented upload.
    let config = ClientConfig::default().with_protocol_switch_threshold(21);
    let mut p = Pair::with(config, ServerConfig::default());
    p.od.set(SMALL_STR, b"0123456789".to_vec());
    p.client
        .start_upload(T0, SMALL_STR, Vec::new(), Method::Block)
        .unwrap();
    assert_eq!(uploaded(p.run()), b"0123456789");
    assert_eq!(p.log[0].1, [0xA4, 0x03, 0x20, 0x00, 127, 21, 0, 0]);
    assert_eq!(p.log[1].1, [0x41, 0x03, 0x20, 0x00, 10, 0, 0, 0]);
    assert_eq!(p.log[2].1, [0x60, 0, 0, 0, 0, 0, 0, 0]);

    // Four bytes: an expedited answer.
    let mut p = Pair::with(config, ServerConfig::default());
    p.client
        .start_upload(T0, RO, Vec::new(), Method::Block)
        .unwrap();
    assert_eq!(uploaded(p.run()), [0x91, 0x01, 0x02, 0x00]);
    assert_eq!(p.log.len(), 2);

    // Above the threshold: a real block upload.
    let mut p = Pair::with(config, ServerConfig::default());
    p.od.set(DOMAIN, pattern(22));
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    assert_eq!(uploaded(p.run()), pattern(22));
    assert_eq!(p.log[1].1[0], 0xC6);
}

#[test]
fn large_domain_every_method_with_small_blocks() {
    let data = pattern(5000);
    let mut p = Pair::with(
        ClientConfig::default().with_block_size(10),
        ServerConfig {
            block_size: 9,
            ..ServerConfig::default()
        },
    );
    for method in [Method::Normal, Method::Block] {
        p.client
            .start_download(p.now, DOMAIN, data.clone(), method)
            .unwrap();
        downloaded(p.run());
        assert_eq!(p.od.value(DOMAIN), data);
        p.client
            .start_upload(p.now, DOMAIN, Vec::new(), method)
            .unwrap();
        assert_eq!(uploaded(p.run()), data);
    }
}

// ---------------------------------------------------------------------------------------------
// Retransmission in block transfers.

#[test]
fn block_download_retransmits_from_last_acknowledged_segment() {
    let mut p = Pair::with(
        ClientConfig::default(),
        ServerConfig {
            block_size: 5,
            ..ServerConfig::default()
        },
    );
    let data = pattern(60); // 9 segments
    p.client
        .start_download(T0, DOMAIN, data.clone(), Method::Block)
        .unwrap();
    let mut dropped = false;
    let mut client_frames = Vec::new();
    let mut server_frames = Vec::new();
    let mut now = T0;
    while p.client.poll_timeout().is_some() {
        while let Some(f) = p.client.poll_transmit() {
            client_frames.push(f);
            // Lose the third segment of the first sub-block once.
            if !dropped && f[0] == 3 && client_frames.len() == 4 {
                dropped = true;
                continue;
            }
            p.server.handle_request(now, &f, &mut p.od);
        }
        while let Some(f) = p.server.poll_transmit() {
            server_frames.push(f);
            p.client.handle_response(now, &f);
        }
        now += Duration::from_millis(1);
    }
    assert!(dropped);
    downloaded(p.client.poll_event().unwrap());
    assert_eq!(p.od.value(DOMAIN), data);
    // The first ack confirms only two segments ...
    assert_eq!(server_frames[1], [0xA2, 2, 5, 0, 0, 0, 0, 0]);
    // ... and the next sub-block starts again with the third segment's bytes as sequence 1.
    let resent = BlockSegment::parse(&client_frames[6]).unwrap();
    assert_eq!(resent.seqno, 1);
    assert_eq!(&resent.data[..], &data[14..21]);
}

#[test]
fn block_upload_retransmits_when_client_acks_fewer() {
    let mut p = Pair::with(
        ClientConfig::default().with_block_size(4),
        ServerConfig::default(),
    );
    let data = pattern(50);
    p.od.set(DOMAIN, data.clone());
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    let mut server_count = 0;
    let mut client_frames = Vec::new();
    let mut now = T0;
    while p.client.poll_timeout().is_some() {
        while let Some(f) = p.client.poll_transmit() {
            client_frames.push(f);
            p.server.handle_request(now, &f, &mut p.od);
        }
        while let Some(f) = p.server.poll_transmit() {
            server_count += 1;
            // Lose the second segment of the first sub-block.
            if server_count == 3 {
                continue;
            }
            p.client.handle_response(now, &f);
        }
        now += Duration::from_millis(1);
    }
    assert_eq!(uploaded(p.client.poll_event().unwrap()), data);
    assert_eq!(client_frames[2], [0xA2, 1, 4, 0, 0, 0, 0, 0]);
}

#[test]
fn client_follows_block_size_renegotiation() {
    let mut c: TestClient = Client::new(ClientConfig::default());
    let data = pattern(70); // 10 segments
    c.start_download(T0, DOMAIN, data.clone(), Method::Block)
        .unwrap();
    drain(&mut c);
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 3,
        }
        .emit(),
    );
    assert_eq!(drain(&mut c).len(), 3);
    // Ack all three, shrink to 2.
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadAck {
            ackseq: 3,
            blksize: 2,
        }
        .emit(),
    );
    let block = drain(&mut c);
    assert_eq!(block.len(), 2);
    assert_eq!(&block[0][1..], &data[21..28]);
    // Ack one of two, grow to 127: the rest (segments 5..=10) in one sub-block.
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadAck {
            ackseq: 1,
            blksize: 127,
        }
        .emit(),
    );
    let block = drain(&mut c);
    assert_eq!(block.len(), 6);
    assert_eq!(&block[0][1..], &data[28..35]);
    assert_eq!(block[5][0], 0x86);
    let progress = c.progress().unwrap();
    assert_eq!((progress.done, progress.total), (28, Some(70)));
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadAck {
            ackseq: 6,
            blksize: 127,
        }
        .emit(),
    );
    let end = drain(&mut c);
    assert_eq!(
        end,
        [ClientRequest::BlockDownloadEnd {
            unused: 0,
            crc: crc16(&data)
        }
        .emit()]
    );
    c.handle_response(T0, &ServerResponse::BlockDownloadEnd.emit());
    assert!(matches!(c.poll_event(), Some(Event::Downloaded { .. })));
}

// ---------------------------------------------------------------------------------------------
// Abort codes the server produces, seen by a real client.

fn server_refuses(mux: Multiplexer, upload: bool, data: Vec<u8>, method: Method) -> AbortCode {
    let mut p = Pair::new();
    if upload {
        p.client.start_upload(T0, mux, Vec::new(), method).unwrap();
    } else {
        p.client.start_download(T0, mux, data, method).unwrap();
    }
    let error = failed(Some(p.run()));
    assert_eq!((error.index, error.subindex), (mux.index, mux.subindex));
    assert!(error.is_server_abort(), "{error}");
    let code = error.abort_code();
    assert_eq!(
        p.server.poll_event(),
        Some(ServerEvent::Aborted { mux, code })
    );
    assert!(p.server.is_idle());
    code
}

#[test]
fn server_abort_codes_for_objects() {
    for method in [Method::Normal, Method::Segmented, Method::Block] {
        let missing = Multiplexer::new(0x5000, 0);
        assert_eq!(
            server_refuses(missing, true, vec![], method),
            AbortCode::OBJECT_DOES_NOT_EXIST
        );
        assert_eq!(
            server_refuses(Multiplexer::new(0x2000, 9), false, vec![1, 2], method),
            AbortCode::SUBINDEX_DOES_NOT_EXIST
        );
        assert_eq!(
            server_refuses(WO, true, vec![], method),
            AbortCode::WRITE_ONLY
        );
        assert_eq!(
            server_refuses(RO, false, vec![1, 2, 3, 4], method),
            AbortCode::READ_ONLY
        );
        assert_eq!(
            server_refuses(U32_RW, false, vec![1, 2], method),
            AbortCode::LENGTH_TOO_LOW
        );
        assert_eq!(
            server_refuses(U16_RW, false, vec![1, 2, 3], method),
            AbortCode::LENGTH_TOO_HIGH
        );
        assert_eq!(
            server_refuses(SMALL_STR, false, pattern(11), method),
            AbortCode::LENGTH_TOO_HIGH
        );
        // The object delivers less than it announced.
        assert_eq!(
            server_refuses(LIAR, true, vec![], method),
            AbortCode::NO_DATA_AVAILABLE
        );
        // The object refuses the value when it is committed.
        assert_eq!(
            server_refuses(LIMITED, false, vec![200], method),
            AbortCode::VALUE_TOO_HIGH
        );
    }
}

/// A server and scripted client frames.
struct Scripted {
    server: Server,
    od: MemOd,
    now: Instant,
}

impl Scripted {
    fn new() -> Self {
        Self::with(ServerConfig::default())
    }

    fn with(config: ServerConfig) -> Self {
        Self {
            server: Server::new(config),
            od: MemOd::new(),
            now: T0,
        }
    }

    fn send(&mut self, req: ClientRequest) -> Vec<[u8; 8]> {
        self.raw(req.emit())
    }

    fn raw(&mut self, bytes: [u8; 8]) -> Vec<[u8; 8]> {
        self.server.handle_request(self.now, &bytes, &mut self.od);
        drain_server(&mut self.server)
    }

    fn aborted(&mut self, mux: Multiplexer, code: AbortCode, reply: Vec<[u8; 8]>) {
        assert_eq!(reply, [ServerResponse::Abort { mux, code }.emit()]);
        let mut events: Vec<_> = std::iter::from_fn(|| self.server.poll_event()).collect();
        assert_eq!(events.pop(), Some(ServerEvent::Aborted { mux, code }));
        assert!(self.server.is_idle());
        assert_eq!(self.server.poll_timeout(), None);
    }
}

fn seg_download(mux: Multiplexer, size: Option<u32>) -> ClientRequest {
    ClientRequest::InitiateDownload {
        mux,
        data: Initiate::Segmented { size },
    }
}

#[test]
fn server_protocol_abort_codes() {
    // Toggle bit not alternated (segmented download).
    let mut s = Scripted::new();
    s.send(seg_download(DOMAIN, Some(14)));
    s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 7], false,
    )));
    let r = s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 7], true,
    )));
    s.aborted(DOMAIN, AbortCode::TOGGLE_BIT_NOT_ALTERNATED, r);
    assert_eq!(s.od.discards, 1);

    // Toggle in segmented upload.
    let mut s = Scripted::new();
    s.od.set(DOMAIN, pattern(30));
    s.send(ClientRequest::InitiateUpload { mux: DOMAIN });
    let r = s.send(ClientRequest::UploadSegment { toggle: true });
    s.aborted(DOMAIN, AbortCode::TOGGLE_BIT_NOT_ALTERNATED, r);

    // Unknown command specifier (ccs = 7), idle and during a transfer.
    let mut s = Scripted::new();
    let r = s.raw([0xE0, 0, 0, 0, 0, 0, 0, 0]);
    s.aborted(Multiplexer::default(), AbortCode::INVALID_COMMAND, r);
    s.send(seg_download(DOMAIN, None));
    let r = s.raw([0xE0, 0, 0, 0, 0, 0, 0, 0]);
    s.aborted(DOMAIN, AbortCode::INVALID_COMMAND, r);

    // A valid command that does not fit the state.
    let mut s = Scripted::new();
    let r = s.send(ClientRequest::UploadSegment { toggle: false });
    s.aborted(Multiplexer::default(), AbortCode::INVALID_COMMAND, r);
    s.send(seg_download(DOMAIN, None));
    let r = s.send(ClientRequest::UploadSegment { toggle: false });
    s.aborted(DOMAIN, AbortCode::INVALID_COMMAND, r);

    // Length: more than the announced size (0x06070010), fewer (0x06070010).
    let mut s = Scripted::new();
    s.send(seg_download(DOMAIN, Some(3)));
    let r = s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 4], true,
    )));
    s.aborted(DOMAIN, AbortCode::LENGTH_MISMATCH, r);
    let mut s = Scripted::new();
    s.send(seg_download(DOMAIN, Some(5)));
    let r = s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 4], true,
    )));
    s.aborted(DOMAIN, AbortCode::LENGTH_MISMATCH, r);
    // Size not indicated: the object's limits still apply.
    let mut s = Scripted::new();
    s.send(seg_download(SMALL_STR, None));
    s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 7], false,
    )));
    let r = s.send(ClientRequest::DownloadSegment(Segment::new(
        true, &[1; 7], true,
    )));
    s.aborted(SMALL_STR, AbortCode::LENGTH_TOO_HIGH, r);
    let mut s = Scripted::new();
    s.send(seg_download(U32_RW, None));
    let r = s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 3], true,
    )));
    s.aborted(U32_RW, AbortCode::LENGTH_TOO_LOW, r);
}

#[test]
fn server_expedited_without_size_takes_object_length() {
    let mut s = Scripted::new();
    let r = s.send(ClientRequest::InitiateDownload {
        mux: U16_RW,
        data: Initiate::Expedited {
            data: [7, 8, 9, 10],
            size: None,
        },
    });
    assert_eq!(r, [ServerResponse::InitiateDownload { mux: U16_RW }.emit()]);
    assert_eq!(s.od.value(U16_RW), [7, 8]);
}

#[test]
fn server_block_abort_codes() {
    // CRC mismatch.
    let mut s = Scripted::new();
    let r = s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: true,
        size: Some(10),
    });
    assert_eq!(
        r,
        [ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 127
        }
        .emit()]
    );
    s.raw(
        BlockSegment {
            seqno: 1,
            last: false,
            data: [1; 7],
        }
        .emit(),
    );
    let r = s.raw(
        BlockSegment {
            seqno: 2,
            last: true,
            data: [2; 7],
        }
        .emit(),
    );
    assert_eq!(
        r,
        [ServerResponse::BlockDownloadAck {
            ackseq: 2,
            blksize: 127
        }
        .emit()]
    );
    let good = crc16(&[1, 1, 1, 1, 1, 1, 1, 2, 2, 2]);
    let r = s.send(ClientRequest::BlockDownloadEnd {
        unused: 4,
        crc: good ^ 1,
    });
    s.aborted(DOMAIN, AbortCode::CRC_ERROR, r);
    assert_eq!(s.od.commits, 0);
    assert_eq!(s.od.discards, 1);

    // Without CRC agreed the same bytes pass.
    let mut s = Scripted::new();
    s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: false,
        size: Some(10),
    });
    s.raw(
        BlockSegment {
            seqno: 1,
            last: false,
            data: [1; 7],
        }
        .emit(),
    );
    s.raw(
        BlockSegment {
            seqno: 2,
            last: true,
            data: [2; 7],
        }
        .emit(),
    );
    let r = s.send(ClientRequest::BlockDownloadEnd {
        unused: 4,
        crc: 0xDEAD,
    });
    assert_eq!(r, [ServerResponse::BlockDownloadEnd.emit()]);
    assert_eq!(s.od.value(DOMAIN), [1, 1, 1, 1, 1, 1, 1, 2, 2, 2]);

    // Invalid sequence number: above the block size.
    let mut s = Scripted::with(ServerConfig {
        block_size: 4,
        ..ServerConfig::default()
    });
    s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: true,
        size: None,
    });
    let r = s.raw(
        BlockSegment {
            seqno: 5,
            last: false,
            data: [1; 7],
        }
        .emit(),
    );
    s.aborted(DOMAIN, AbortCode::INVALID_SEQUENCE_NUMBER, r);

    // Out-of-order segments are ignored; the ack names the last good one.
    let mut s = Scripted::with(ServerConfig {
        block_size: 4,
        ..ServerConfig::default()
    });
    s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: true,
        size: None,
    });
    assert!(
        s.raw(
            BlockSegment {
                seqno: 1,
                last: false,
                data: [1; 7]
            }
            .emit()
        )
        .is_empty()
    );
    assert!(
        s.raw(
            BlockSegment {
                seqno: 3,
                last: false,
                data: [3; 7]
            }
            .emit()
        )
        .is_empty()
    );
    let r = s.raw(
        BlockSegment {
            seqno: 4,
            last: false,
            data: [4; 7],
        }
        .emit(),
    );
    assert_eq!(
        r,
        [ServerResponse::BlockDownloadAck {
            ackseq: 1,
            blksize: 4
        }
        .emit()]
    );

    // Invalid block size in block upload initiate and in an ack.
    let mut s = Scripted::new();
    s.od.set(DOMAIN, pattern(100));
    let r = s.send(ClientRequest::BlockUploadInitiate {
        mux: DOMAIN,
        crc: true,
        blksize: 0,
        pst: 0,
    });
    s.aborted(DOMAIN, AbortCode::INVALID_BLOCK_SIZE, r);
    let r = s.send(ClientRequest::BlockUploadInitiate {
        mux: DOMAIN,
        crc: true,
        blksize: 128,
        pst: 0,
    });
    s.aborted(DOMAIN, AbortCode::INVALID_BLOCK_SIZE, r);
    s.send(ClientRequest::BlockUploadInitiate {
        mux: DOMAIN,
        crc: true,
        blksize: 4,
        pst: 0,
    });
    s.send(ClientRequest::BlockUploadStart);
    let r = s.send(ClientRequest::BlockUploadAck {
        ackseq: 4,
        blksize: 200,
    });
    s.aborted(DOMAIN, AbortCode::INVALID_BLOCK_SIZE, r);

    // An ack for more segments than were sent.
    s.send(ClientRequest::BlockUploadInitiate {
        mux: DOMAIN,
        crc: true,
        blksize: 4,
        pst: 0,
    });
    let segs = s.send(ClientRequest::BlockUploadStart);
    assert_eq!(segs.len(), 4);
    let r = s.send(ClientRequest::BlockUploadAck {
        ackseq: 5,
        blksize: 4,
    });
    s.aborted(DOMAIN, AbortCode::INVALID_SEQUENCE_NUMBER, r);
}

#[test]
fn server_timeouts() {
    let timeout = ServerConfig::default().timeout;
    let cases: Vec<(Multiplexer, Vec<ClientRequest>)> = vec![
        (DOMAIN, vec![seg_download(DOMAIN, Some(20))]),
        (DOMAIN, vec![ClientRequest::InitiateUpload { mux: DOMAIN }]),
        (
            DOMAIN,
            vec![ClientRequest::BlockDownloadInitiate {
                mux: DOMAIN,
                crc: true,
                size: Some(20),
            }],
        ),
        (
            DOMAIN,
            vec![ClientRequest::BlockUploadInitiate {
                mux: DOMAIN,
                crc: true,
                blksize: 4,
                pst: 0,
            }],
        ),
        (
            DOMAIN,
            vec![
                ClientRequest::BlockUploadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    blksize: 4,
                    pst: 0,
                },
                ClientRequest::BlockUploadStart,
            ],
        ),
        (
            DOMAIN,
            vec![
                ClientRequest::BlockUploadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    blksize: 127,
                    pst: 0,
                },
                ClientRequest::BlockUploadStart,
                ClientRequest::BlockUploadAck {
                    ackseq: 15,
                    blksize: 127,
                },
            ],
        ),
    ];
    for (mux, script) in cases {
        let mut s = Scripted::new();
        s.od.set(DOMAIN, pattern(100));
        for req in script {
            s.send(req);
        }
        let deadline = s.server.poll_timeout().expect("a deadline while busy");
        assert_eq!(deadline, T0 + timeout);
        s.server
            .handle_timeout(deadline - Duration::from_micros(1), &mut s.od);
        assert!(!s.server.is_idle());
        s.server.handle_timeout(deadline, &mut s.od);
        let r = drain_server(&mut s.server);
        s.aborted(mux, AbortCode::TIMEOUT, r);
    }
}

#[test]
fn server_new_initiate_during_transfer_and_client_abort() {
    let mut s = Scripted::new();
    s.send(seg_download(DOMAIN, Some(20)));
    s.send(ClientRequest::DownloadSegment(Segment::new(
        false, &[1; 7], false,
    )));
    // The client gave up and reads another object.
    let r = s.send(ClientRequest::InitiateUpload { mux: RO });
    assert_eq!(
        r,
        [ServerResponse::InitiateUpload {
            mux: RO,
            data: Initiate::expedited(&[0x91, 0x01, 0x02, 0x00]).unwrap()
        }
        .emit()]
    );
    assert_eq!(
        s.server.poll_event(),
        Some(ServerEvent::Superseded { mux: DOMAIN })
    );
    assert_eq!(
        s.server.poll_event(),
        Some(ServerEvent::Uploaded { mux: RO, len: 4 })
    );
    assert_eq!(s.od.discards, 1);
    assert_eq!(s.od.value(DOMAIN), b"");

    // An abort for another object is ignored; the right one ends the transfer silently.
    s.send(seg_download(DOMAIN, Some(20)));
    assert!(
        s.send(ClientRequest::Abort {
            mux: RO,
            code: AbortCode::GENERAL_ERROR
        })
        .is_empty()
    );
    assert!(!s.server.is_idle());
    let r = s.send(ClientRequest::Abort {
        mux: DOMAIN,
        code: AbortCode::GENERAL_ERROR,
    });
    assert!(r.is_empty());
    assert!(s.server.is_idle());
    assert_eq!(
        s.server.poll_event(),
        Some(ServerEvent::AbortedByClient {
            mux: DOMAIN,
            code: AbortCode::GENERAL_ERROR
        })
    );
    // An abort in a block download sub-block (byte 0 = 0x80) is an abort, not a segment.
    s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: true,
        size: None,
    });
    let r = s.raw(abort_bytes(DOMAIN, AbortCode::TIMEOUT));
    assert!(r.is_empty());
    assert!(s.server.is_idle());
    // Idle: an abort or a frame of the wrong length changes nothing.
    assert!(s.raw(abort_bytes(DOMAIN, AbortCode::TIMEOUT)).is_empty());
    s.server.handle_request(T0, &[0x40, 0, 0x10], &mut s.od);
    assert!(drain_server(&mut s.server).is_empty());
}

// ---------------------------------------------------------------------------------------------
// The client against scripted server frames.

fn started_upload(method: Method) -> TestClient {
    let mut c: TestClient = Client::new(ClientConfig::default());
    c.start_upload(T0, DOMAIN, Vec::new(), method).unwrap();
    drain(&mut c);
    c
}

fn started_download(data: Vec<u8>, method: Method) -> TestClient {
    let mut c: TestClient = Client::new(ClientConfig::default());
    c.start_download(T0, DOMAIN, data, method).unwrap();
    drain(&mut c);
    c
}

/// Feeds `frame`; the client must abort with `violation` and send the abort.
fn violates(c: &mut TestClient, frame: [u8; 8], violation: Violation) {
    c.handle_response(T0, &frame);
    assert_eq!(drain(c), [abort_bytes(DOMAIN, violation.abort_code())]);
    let error = failed(c.poll_event());
    assert_eq!(error.kind, ErrorKind::Protocol(violation));
    assert_eq!(error.mux(), DOMAIN);
    assert!(!error.is_server_abort());
    assert!(c.is_idle());
}

fn up_init(size: Option<u32>) -> [u8; 8] {
    ServerResponse::InitiateUpload {
        mux: DOMAIN,
        data: Initiate::Segmented { size },
    }
    .emit()
}

fn up_seg(toggle: bool, data: &[u8], last: bool) -> [u8; 8] {
    ServerResponse::UploadSegment(Segment::new(toggle, data, last)).emit()
}

#[test]
fn client_toggle_error() {
    let mut c = started_upload(Method::Normal);
    c.handle_response(T0, &up_init(Some(14)));
    assert_eq!(drain(&mut c), [[0x60, 0, 0, 0, 0, 0, 0, 0]]);
    violates(&mut c, up_seg(true, &[1; 7], false), Violation::Toggle);

    let mut c = started_download(pattern(20), Method::Normal);
    c.handle_response(T0, &ServerResponse::InitiateDownload { mux: DOMAIN }.emit());
    drain(&mut c);
    violates(
        &mut c,
        ServerResponse::DownloadSegment { toggle: true }.emit(),
        Violation::Toggle,
    );
}

#[test]
fn client_wrong_size() {
    // More than announced.
    let mut c = started_upload(Method::Normal);
    c.handle_response(T0, &up_init(Some(5)));
    drain(&mut c);
    violates(
        &mut c,
        up_seg(false, &[1; 6], true),
        Violation::TooLong { size: 5 },
    );
    // Fewer than announced.
    let mut c = started_upload(Method::Normal);
    c.handle_response(T0, &up_init(Some(10)));
    drain(&mut c);
    violates(
        &mut c,
        up_seg(false, &[1; 6], true),
        Violation::TooShort {
            size: 10,
            received: 6,
        },
    );
    // Size not indicated: whatever arrives is taken, n honoured.
    let mut c = started_upload(Method::Normal);
    c.handle_response(T0, &up_init(None));
    drain(&mut c);
    c.handle_response(T0, &up_seg(false, &[1; 7], false));
    assert_eq!(c.progress().unwrap().total, None);
    assert_eq!(c.progress().unwrap().done, 7);
    drain(&mut c);
    c.handle_response(T0, &up_seg(true, &[2; 2], true));
    match c.poll_event() {
        Some(Event::Uploaded { sink, len: 9, .. }) => assert_eq!(sink, [1, 1, 1, 1, 1, 1, 1, 2, 2]),
        other => panic!("{other:?}"),
    }
    // Expedited without size: four bytes.
    let mut c = started_upload(Method::Normal);
    c.handle_response(
        T0,
        &ServerResponse::InitiateUpload {
            mux: DOMAIN,
            data: Initiate::Expedited {
                data: [1, 2, 3, 4],
                size: None,
            },
        }
        .emit(),
    );
    assert!(matches!(
        c.poll_event(),
        Some(Event::Uploaded { len: 4, .. })
    ));
}

#[test]
fn client_block_upload_violations() {
    let start = |c: &mut TestClient| {
        c.handle_response(
            T0,
            &ServerResponse::BlockUploadInitiate {
                mux: DOMAIN,
                crc: true,
                size: Some(10),
            }
            .emit(),
        );
        assert_eq!(drain(c), [ClientRequest::BlockUploadStart.emit()]);
    };
    // CRC mismatch.
    let mut c = started_upload(Method::Block);
    start(&mut c);
    c.handle_response(
        T0,
        &BlockSegment {
            seqno: 1,
            last: false,
            data: [1; 7],
        }
        .emit(),
    );
    assert!(drain(&mut c).is_empty());
    c.handle_response(
        T0,
        &BlockSegment {
            seqno: 2,
            last: true,
            data: [2; 7],
        }
        .emit(),
    );
    assert_eq!(
        drain(&mut c),
        [ClientRequest::BlockUploadAck {
            ackseq: 2,
            blksize: 127
        }
        .emit()]
    );
    let crc = crc16(&[1, 1, 1, 1, 1, 1, 1, 2, 2, 2]);
    violates(
        &mut c,
        ServerResponse::BlockUploadEnd {
            unused: 4,
            crc: crc ^ 0x100,
        }
        .emit(),
        Violation::Crc {
            computed: crc,
            received: crc ^ 0x100,
        },
    );
    // Sequence number 0 (not an abort: c clear) and above blksize.
    let mut c = started_upload(Method::Block);
    start(&mut c);
    violates(
        &mut c,
        BlockSegment {
            seqno: 0,
            last: false,
            data: [1; 7],
        }
        .emit(),
        Violation::SequenceNumber(0),
    );
    let mut c: TestClient = Client::new(ClientConfig::default().with_block_size(3));
    c.start_upload(T0, DOMAIN, Vec::new(), Method::Block)
        .unwrap();
    drain(&mut c);
    start(&mut c);
    violates(
        &mut c,
        BlockSegment {
            seqno: 4,
            last: false,
            data: [1; 7],
        }
        .emit(),
        Violation::SequenceNumber(4),
    );
    // Wrong end length.
    let mut c = started_upload(Method::Block);
    start(&mut c);
    c.handle_response(
        T0,
        &BlockSegment {
            seqno: 1,
            last: true,
            data: [1; 7],
        }
        .emit(),
    );
    drain(&mut c);
    violates(
        &mut c,
        ServerResponse::BlockUploadEnd { unused: 0, crc: 0 }.emit(),
        Violation::TooShort {
            size: 10,
            received: 7,
        },
    );
    // A server abort arriving in the middle of a sub-block.
    let mut c = started_upload(Method::Block);
    start(&mut c);
    c.handle_response(
        T0,
        &ServerResponse::Abort {
            mux: DOMAIN,
            code: AbortCode::HARDWARE_ERROR,
        }
        .emit(),
    );
    assert!(drain(&mut c).is_empty());
    let error = failed(c.poll_event());
    assert_eq!(
        error.kind,
        ErrorKind::ServerAbort(AbortCode::HARDWARE_ERROR)
    );
}

#[test]
fn client_block_download_violations() {
    let mut c = started_download(pattern(20), Method::Block);
    violates(
        &mut c,
        ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 0,
        }
        .emit(),
        Violation::BlockSize(0),
    );
    let mut c = started_download(pattern(20), Method::Block);
    violates(
        &mut c,
        ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 200,
        }
        .emit(),
        Violation::BlockSize(200),
    );
    let mut c = started_download(pattern(20), Method::Block);
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 2,
        }
        .emit(),
    );
    assert_eq!(drain(&mut c).len(), 2);
    violates(
        &mut c,
        ServerResponse::BlockDownloadAck {
            ackseq: 3,
            blksize: 2,
        }
        .emit(),
        Violation::SequenceNumber(3),
    );
    let mut c = started_download(pattern(20), Method::Block);
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 2,
        }
        .emit(),
    );
    drain(&mut c);
    violates(
        &mut c,
        ServerResponse::BlockDownloadAck {
            ackseq: 2,
            blksize: 128,
        }
        .emit(),
        Violation::BlockSize(128),
    );
}

#[test]
fn client_unexpected_and_unknown_commands() {
    // A download segment response while waiting for an initiate upload response.
    let mut c = started_upload(Method::Normal);
    violates(
        &mut c,
        ServerResponse::DownloadSegment { toggle: false }.emit(),
        Violation::UnexpectedCommand,
    );
    // scs = 7.
    let mut c = started_upload(Method::Normal);
    violates(
        &mut c,
        [0xE0, 0, 0, 0, 0, 0, 0, 0],
        Violation::UnexpectedCommand,
    );
    // A block download response to a normal download.
    let mut c = started_download(pattern(20), Method::Normal);
    violates(
        &mut c,
        ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: true,
            blksize: 5,
        }
        .emit(),
        Violation::UnexpectedCommand,
    );
}

#[test]
fn client_out_of_memory() {
    let mut c: Client<heapless::Vec<u8, 8>, &[u8]> = Client::new(ClientConfig::default());
    c.start_upload(T0, DOMAIN, heapless::Vec::new(), Method::Normal)
        .unwrap();
    let _ = std::iter::from_fn(|| c.poll_transmit()).count();
    c.handle_response(T0, &up_init(Some(20)));
    assert_eq!(
        c.poll_transmit(),
        Some(abort_bytes(DOMAIN, AbortCode::OUT_OF_MEMORY))
    );
    let error = failed(c.poll_event());
    assert_eq!(error.kind, ErrorKind::BufferFull);
    assert_eq!(error.abort_code(), AbortCode::OUT_OF_MEMORY);
    // Without a size, the overflow is found by the segment that does not fit.
    c.start_upload(T0, DOMAIN, heapless::Vec::new(), Method::Normal)
        .unwrap();
    let _ = std::iter::from_fn(|| c.poll_transmit()).count();
    c.handle_response(T0, &up_init(None));
    let _ = c.poll_transmit();
    c.handle_response(T0, &up_seg(false, &[1; 7], false));
    let _ = c.poll_transmit();
    c.handle_response(T0, &up_seg(true, &[1; 7], false));
    assert_eq!(
        c.poll_transmit(),
        Some(abort_bytes(DOMAIN, AbortCode::OUT_OF_MEMORY))
    );
    match c.poll_event() {
        Some(Event::Failed {
            buffer: Buffer::Sink(sink),
            ..
        }) => assert_eq!(sink.len(), 7),
        other => panic!("{other:?}"),
    }
}

#[test]
fn client_timeouts_in_every_phase() {
    let timeout = Duration::from_millis(300);
    let config = ClientConfig::default().with_timeout(timeout);
    type Setup = fn(&mut TestClient);
    let setups: Vec<(&str, Method, bool, Setup)> = vec![
        ("initiate upload", Method::Normal, true, |_| {}),
        ("upload segment", Method::Normal, true, |c| {
            c.handle_response(T0, &up_init(Some(20)));
        }),
        ("block upload initiate", Method::Block, true, |_| {}),
        ("block upload sub-block", Method::Block, true, |c| {
            c.handle_response(
                T0,
                &ServerResponse::BlockUploadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    size: None,
                }
                .emit(),
            );
        }),
        ("block upload end", Method::Block, true, |c| {
            c.handle_response(
                T0,
                &ServerResponse::BlockUploadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    size: None,
                }
                .emit(),
            );
            c.handle_response(
                T0,
                &BlockSegment {
                    seqno: 1,
                    last: true,
                    data: [0; 7],
                }
                .emit(),
            );
        }),
        ("initiate download", Method::Normal, false, |_| {}),
        ("download segment", Method::Normal, false, |c| {
            c.handle_response(T0, &ServerResponse::InitiateDownload { mux: DOMAIN }.emit());
        }),
        ("block download initiate", Method::Block, false, |_| {}),
        ("block download ack", Method::Block, false, |c| {
            c.handle_response(
                T0,
                &ServerResponse::BlockDownloadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    blksize: 127,
                }
                .emit(),
            );
        }),
        ("block download end", Method::Block, false, |c| {
            c.handle_response(
                T0,
                &ServerResponse::BlockDownloadInitiate {
                    mux: DOMAIN,
                    crc: true,
                    blksize: 127,
                }
                .emit(),
            );
            let _ = std::iter::from_fn(|| c.poll_transmit()).count();
            c.handle_response(
                T0,
                &ServerResponse::BlockDownloadAck {
                    ackseq: 3,
                    blksize: 127,
                }
                .emit(),
            );
        }),
    ];
    for (name, method, upload, setup) in setups {
        let mut c: TestClient = Client::new(config);
        if upload {
            c.start_upload(T0, DOMAIN, Vec::new(), method).unwrap();
        } else {
            c.start_download(T0, DOMAIN, pattern(20), method).unwrap();
        }
        setup(&mut c);
        drain(&mut c);
        assert_eq!(c.poll_timeout(), Some(T0 + timeout), "{name}");
        c.handle_timeout(T0 + timeout - Duration::from_micros(1));
        assert!(c.poll_event().is_none(), "{name}");
        c.handle_timeout(T0 + timeout);
        assert_eq!(
            drain(&mut c),
            [abort_bytes(DOMAIN, AbortCode::TIMEOUT)],
            "{name}"
        );
        let error = failed(c.poll_event());
        assert_eq!(error.kind, ErrorKind::Timeout, "{name}");
        assert_eq!(error.abort_code(), AbortCode::TIMEOUT);
        assert_eq!(c.poll_timeout(), None);
    }
}

#[test]
fn client_timeout_restarts_on_each_response() {
    let mut c = started_upload(Method::Normal);
    let later = T0 + Duration::from_millis(900);
    c.handle_response(later, &up_init(Some(20)));
    assert_eq!(c.poll_timeout(), Some(later + SEC));
    c.handle_timeout(T0 + SEC);
    assert!(c.poll_event().is_none());
}

#[test]
fn client_cancel_sends_abort() {
    let mut c = started_download(pattern(100), Method::Block);
    assert!(c.abort(T0, AbortCode::CANNOT_STORE_LOCAL_CONTROL));
    assert_eq!(
        drain(&mut c),
        [abort_bytes(DOMAIN, AbortCode::CANNOT_STORE_LOCAL_CONTROL)]
    );
    match c.poll_event() {
        Some(Event::Failed {
            error,
            buffer: Buffer::Source(source),
        }) => {
            assert_eq!(
                error.kind,
                ErrorKind::Cancelled(AbortCode::CANNOT_STORE_LOCAL_CONTROL)
            );
            assert_eq!(source, pattern(100));
        }
        other => panic!("{other:?}"),
    }
    assert!(!c.abort(T0, AbortCode::GENERAL_ERROR));
    assert!(drain(&mut c).is_empty());
}

#[test]
fn stray_and_late_frames_never_complete_the_wrong_transfer() {
    let mut c = started_upload(Method::Normal);
    // An expedited answer for another object (late answer to an earlier request): ignored.
    let other = Multiplexer::new(0x1017, 0);
    c.handle_response(
        T0,
        &ServerResponse::InitiateUpload {
            mux: other,
            data: Initiate::expedited(&[1, 2]).unwrap(),
        }
        .emit(),
    );
    assert!(c.poll_event().is_none());
    assert!(drain(&mut c).is_empty());
    // Same index, other sub-index: ignored.
    c.handle_response(
        T0,
        &ServerResponse::InitiateUpload {
            mux: Multiplexer::new(DOMAIN.index, 1),
            data: Initiate::expedited(&[1, 2]).unwrap(),
        }
        .emit(),
    );
    assert!(c.poll_event().is_none());
    // An abort for another object: ignored.
    c.handle_response(
        T0,
        &ServerResponse::Abort {
            mux: other,
            code: AbortCode::GENERAL_ERROR,
        }
        .emit(),
    );
    assert!(c.poll_event().is_none());
    // Short frames: ignored.
    c.handle_response(T0, &[0x43, 0x00, 0x21]);
    assert!(c.poll_event().is_none());
    // The right answer completes it.
    c.handle_response(
        T0,
        &ServerResponse::InitiateUpload {
            mux: DOMAIN,
            data: Initiate::expedited(&[9]).unwrap(),
        }
        .emit(),
    );
    match c.poll_event() {
        Some(Event::Uploaded { sink, mux, .. }) => {
            assert_eq!(sink, [9]);
            assert_eq!(mux, DOMAIN);
        }
        other => panic!("{other:?}"),
    }
    // Idle: anything is ignored.
    c.handle_response(T0, &up_seg(false, &[1; 7], true));
    assert!(c.poll_event().is_none());
    assert!(drain(&mut c).is_empty());

    // Download side: an initiate download response for another object is ignored.
    let mut c = started_download(vec![1, 2], Method::Normal);
    c.handle_response(T0, &ServerResponse::InitiateDownload { mux: other }.emit());
    assert!(c.poll_event().is_none());
    // A server abort with multiplexer 0000:00 (unknown command) ends it.
    c.handle_response(
        T0,
        &ServerResponse::Abort {
            mux: Multiplexer::default(),
            code: AbortCode::INVALID_COMMAND,
        }
        .emit(),
    );
    let error = failed(c.poll_event());
    assert_eq!(
        error.kind,
        ErrorKind::ServerAbort(AbortCode::INVALID_COMMAND)
    );
    assert_eq!(
        error.to_string(),
        "SDO 0x2100:00: server aborted: 0x05040001 (Client/server command specifier not valid or unknown)"
    );
    assert!(
        drain(&mut c).is_empty(),
        "no abort is sent back for a server abort"
    );
}

#[test]
fn client_refuses_second_transfer_while_busy() {
    let mut c = started_upload(Method::Normal);
    match c.start_download(T0, RO, vec![1], Method::Normal) {
        Err(busy) => assert_eq!(busy.0, vec![1]),
        Ok(()) => panic!("started twice"),
    }
    c.handle_response(
        T0,
        &ServerResponse::Abort {
            mux: DOMAIN,
            code: AbortCode::GENERAL_ERROR,
        }
        .emit(),
    );
    // The completion must be polled first.
    assert!(c.start_upload(T0, RO, Vec::new(), Method::Normal).is_err());
    assert!(c.poll_event().is_some());
    assert!(c.start_upload(T0, RO, Vec::new(), Method::Normal).is_ok());
}

#[test]
fn progress_reports_bytes_and_total() {
    let mut p = Pair::new();
    p.od.set(DOMAIN, pattern(30));
    p.client
        .start_upload(T0, DOMAIN, Vec::new(), Method::Normal)
        .unwrap();
    let mut seen = Vec::new();
    while p.client.poll_event().is_none() {
        if let Some(progress) = p.client.progress() {
            seen.push((progress.done, progress.total));
        }
        if let Some(f) = p.client.poll_transmit() {
            p.server.handle_request(p.now, &f, &mut p.od);
        }
        if let Some(f) = p.server.poll_transmit() {
            p.client.handle_response(p.now, &f);
        }
    }
    seen.dedup();
    assert_eq!(
        seen,
        [
            (0, None),
            (0, Some(30)),
            (7, Some(30)),
            (14, Some(30)),
            (21, Some(30)),
            (28, Some(30))
        ]
    );
}

#[test]
fn transfer_timeout_bounds_the_whole_transfer() {
    let config = ClientConfig::default().with_transfer_timeout(Duration::from_millis(1500));
    let mut c: TestClient = Client::new(config);
    c.start_upload(T0, DOMAIN, Vec::new(), Method::Normal)
        .unwrap();
    drain(&mut c);
    assert_eq!(c.poll_timeout(), Some(T0 + SEC));
    // The server answers steadily every 800 ms ...
    let t1 = T0 + Duration::from_millis(800);
    c.handle_response(t1, &up_init(None));
    drain(&mut c);
    // ... but the transfer may not last longer than 1.5 s.
    assert_eq!(c.poll_timeout(), Some(T0 + Duration::from_millis(1500)));
    c.handle_timeout(T0 + Duration::from_millis(1500));
    assert_eq!(drain(&mut c), [abort_bytes(DOMAIN, AbortCode::TIMEOUT)]);
    assert_eq!(failed(c.poll_event()).kind, ErrorKind::Timeout);
}

/// A device's second SDO server channel (0x1201: requests on 0x641, responses on 0x5C1) beside
/// the default one of node 1: the frame adapters route by the pair they are given, so a
/// transfer on the second channel runs there, and frames of the default channel are not its.
#[test]
fn second_server_channel_over_frame_adapters() {
    use canola_frame::{CanFrame, NodeId};
    use canola_sdo::SdoCobIds;

    let default = SdoCobIds::default_for(NodeId::new(1).unwrap());
    let second = SdoCobIds::from_parameters(0x641, 0x5C1).unwrap();
    let mut od = MemOd::new();
    od.set(DOMAIN, (0..1000u32).map(|i| (i * 7) as u8).collect());
    let mut client = TestClient::new(ClientConfig::default());
    let mut server_default = Server::new(ServerConfig::default());
    let mut server_second = Server::new(ServerConfig::default());
    for method in [Method::Normal, Method::Block] {
        client.start_upload(T0, DOMAIN, Vec::new(), method).unwrap();
        let mut bus: Vec<CanFrame> = Vec::new();
        let mut seen = Vec::new();
        while let Some(f) = client.poll_transmit_frame(&second) {
            bus.push(f);
        }
        while let Some(frame) = bus.pop() {
            seen.push(frame.id().as_raw());
            assert!(!server_default.handle_frame(T0, &default, &frame, &mut od));
            assert!(!client.handle_frame(T0, &default, &frame));
            if server_second.handle_frame(T0, &second, &frame, &mut od) {
                while let Some(f) = server_second.poll_transmit_frame(&second) {
                    bus.insert(0, f);
                }
            }
            if client.handle_frame(T0, &second, &frame) {
                while let Some(f) = client.poll_transmit_frame(&second) {
                    bus.insert(0, f);
                }
            }
        }
        assert_eq!(uploaded(client.poll_event().unwrap()), od.value(DOMAIN));
        assert!(
            seen.iter().all(|id| *id == 0x641 || *id == 0x5C1),
            "{seen:x?}"
        );
        assert!(server_default.is_idle() && server_default.poll_transmit().is_none());
    }
}

/// A client in a block upload of DOMAIN (no CRC, size not given), the start sent.
fn in_first_upload_sub_block() -> TestClient {
    let mut c = started_upload(Method::Block);
    c.handle_response(
        T0,
        &ServerResponse::BlockUploadInitiate {
            mux: DOMAIN,
            crc: false,
            size: None,
        }
        .emit(),
    );
    assert_eq!(drain(&mut c), [ClientRequest::BlockUploadStart.emit()]);
    c
}

/// Two block machines out of step: a block upload client fed a server's block download
/// acknowledgements (`A2 00 7F`: to the client a last segment with sequence number 34), and a
/// block download server fed the client's block upload acknowledgements (the same bytes). Each
/// answered every such "sub-block" with an acknowledgement of nothing, which rearmed its
/// timeout; found by the `canopen_network_sequence` fuzz target, where the two acknowledged
/// each other forever after a device rebooted in the middle of a block download. Now the same
/// eight bytes again are a repeat of the segment that ended the sub-block, acknowledged only
/// once, so the timeout ends the transfer; and acknowledgements that differ (another
/// blksize each time) end it after `MAX_FRUITLESS_SUB_BLOCKS` rounds in a row (abort
/// 0x05040003), while a lost segment, which costs one round, still recovers.
#[test]
fn crossed_block_machines_give_up() {
    use canola_sdo::MAX_FRUITLESS_SUB_BLOCKS;
    let crossed = |blksize: u8| ServerResponse::BlockDownloadAck { ackseq: 0, blksize }.emit();
    assert_eq!(
        crossed(127),
        ClientRequest::BlockUploadAck {
            ackseq: 0,
            blksize: 127
        }
        .emit()
    );
    let nothing = ClientRequest::BlockUploadAck {
        ackseq: 0,
        blksize: 127,
    }
    .emit();

    // Client: the same frame over and over is acknowledged once; the timeout ends it.
    let mut c = in_first_upload_sub_block();
    c.handle_response(T0, &crossed(127));
    assert_eq!(drain(&mut c), [nothing]);
    for _ in 0..2 * MAX_FRUITLESS_SUB_BLOCKS {
        c.handle_response(T0, &crossed(127));
        assert!(drain(&mut c).is_empty());
        assert!(c.poll_event().is_none());
    }
    c.handle_timeout(T0 + SEC);
    assert_eq!(failed(c.poll_event()).kind, ErrorKind::Timeout);

    // Client: fruitless rounds up to the bound, then progress resets the count.
    let mut c = in_first_upload_sub_block();
    for i in 0..MAX_FRUITLESS_SUB_BLOCKS {
        c.handle_response(T0, &crossed(127 - i));
        assert_eq!(drain(&mut c), [nothing]);
        assert!(c.poll_event().is_none());
    }
    let segment = |seqno| {
        BlockSegment {
            seqno,
            last: false,
            data: [seqno; 7],
        }
        .emit()
    };
    c.handle_response(T0, &segment(1));
    c.handle_response(T0, &segment(2));
    c.handle_response(T0, &segment(3));
    c.handle_response(T0, &segment(127)); // out of sequence, ends the sub-block
    assert_eq!(
        drain(&mut c),
        [ClientRequest::BlockUploadAck {
            ackseq: 3,
            blksize: 127
        }
        .emit()]
    );
    for i in 0..MAX_FRUITLESS_SUB_BLOCKS {
        c.handle_response(T0, &crossed(127 - i));
        assert_eq!(drain(&mut c), [nothing]);
    }
    violates(&mut c, crossed(100), Violation::SequenceNumber(0x22));

    // Server: the same on a block download.
    let mut s = Scripted::new();
    s.send(ClientRequest::BlockDownloadInitiate {
        mux: DOMAIN,
        crc: false,
        size: None,
    });
    let ack0 = [ServerResponse::BlockDownloadAck {
        ackseq: 0,
        blksize: 127,
    }
    .emit()];
    assert_eq!(s.raw(crossed(127)), ack0);
    assert!(s.raw(crossed(127)).is_empty(), "a repeat");
    for i in 1..MAX_FRUITLESS_SUB_BLOCKS {
        assert_eq!(s.raw(crossed(127 - i)), ack0);
    }
    let r = s.raw(crossed(100));
    s.aborted(DOMAIN, AbortCode::INVALID_SEQUENCE_NUMBER, r);
}

/// After the client aborts a block upload in the middle of a sub-block, the server's segments
/// still on their way reach the next transfer. Each parses as some command: `05 ..` as an upload
/// segment response, `FF ..` as an unknown command, `81 00 00 00 ..` (a zero-padded last
/// segment) as an abort of 0000:00. The next transfer drops them until its answer comes, then
/// completes; a transfer not preceded by an abort still fails at once on the same frame.
#[test]
fn leftovers_of_an_aborted_block_upload_do_not_fail_the_next_transfer() {
    let leftovers = [
        [0x05, 1, 2, 3, 4, 5, 6, 7],
        [0xFF, 1, 2, 3, 4, 5, 6, 7],
        [0x81, 0, 0, 0, 0, 0, 0, 0],
    ];
    let mut c = in_first_upload_sub_block();
    c.handle_response(
        T0,
        &BlockSegment {
            seqno: 1,
            last: false,
            data: [1; 7],
        }
        .emit(),
    );
    assert!(c.abort(T0, AbortCode::GENERAL_ERROR));
    assert!(matches!(c.poll_event(), Some(Event::Failed { .. })));
    drain(&mut c);
    c.start_download(T0, U16_RW, vec![0x10, 0x27], Method::Normal)
        .unwrap();
    drain(&mut c);
    for frame in leftovers {
        c.handle_response(T0, &frame);
        assert!(c.poll_event().is_none(), "{frame:02X?} taken as the answer");
        assert!(drain(&mut c).is_empty());
    }
    c.handle_response(T0, &ServerResponse::InitiateDownload { mux: U16_RW }.emit());
    downloaded(c.poll_event().expect("the download completes"));

    // Answered once, the client is strict again: the same frame ends a transfer at once.
    c.start_download(T0, U16_RW, vec![0x10, 0x27], Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(T0, &leftovers[1]);
    assert_eq!(
        failed(c.poll_event()).kind,
        ErrorKind::Protocol(Violation::UnexpectedCommand)
    );
}

/// A server abort of 0000:00 (a server answering a frame it cannot place, e.g. the rest of a
/// block download reaching it after a reboot) ends the transfer, and the same answers to the
/// other leftover frames do not end the next one before it is answered.
#[test]
fn aborts_of_0000_00_after_one_are_leftovers_for_the_next_transfer() {
    let unplaced = ServerResponse::Abort {
        mux: Multiplexer::default(),
        code: AbortCode(0x0504_0001),
    }
    .emit();
    let mut c: TestClient = Client::new(ClientConfig::default());
    c.start_download(T0, U16_RW, vec![1, 2], Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(T0, &unplaced);
    assert_eq!(
        failed(c.poll_event()).kind,
        ErrorKind::ServerAbort(AbortCode(0x0504_0001))
    );
    assert!(drain(&mut c).is_empty(), "no abort for a server abort");
    c.start_download(T0, U16_RW, vec![3, 4], Method::Normal)
        .unwrap();
    drain(&mut c);
    for _ in 0..5 {
        c.handle_response(T0, &unplaced);
        assert!(c.poll_event().is_none());
    }
    c.handle_response(T0, &ServerResponse::InitiateDownload { mux: U16_RW }.emit());
    downloaded(c.poll_event().expect("the download completes"));
}

/// A server that aborts a block download in the middle of a sub-block gets the segments still
/// on their way as requests it cannot place, and answers them with aborts of 0000:00: those do
/// not end the next transfer.
#[test]
fn a_block_download_aborted_mid_sub_block_leaves_leftovers() {
    let mut c = started_download(pattern(100), Method::Block);
    c.handle_response(
        T0,
        &ServerResponse::BlockDownloadInitiate {
            mux: DOMAIN,
            crc: false,
            blksize: 127,
        }
        .emit(),
    );
    assert!(drain(&mut c).len() > 2, "the sub-block goes out");
    c.handle_response(
        T0,
        &ServerResponse::Abort {
            mux: DOMAIN,
            code: AbortCode(0x0607_0010),
        }
        .emit(),
    );
    assert!(failed(c.poll_event()).is_server_abort());
    c.start_download(T0, U16_RW, vec![3, 4], Method::Normal)
        .unwrap();
    drain(&mut c);
    let unplaced = ServerResponse::Abort {
        mux: Multiplexer::default(),
        code: AbortCode(0x0504_0001),
    }
    .emit();
    c.handle_response(T0, &unplaced);
    assert!(c.poll_event().is_none());
    c.handle_response(T0, &ServerResponse::InitiateDownload { mux: U16_RW }.emit());
    downloaded(c.poll_event().expect("the download completes"));
}

/// What a master saw on a saturated bus (64 slaves booting at 1 Mbit/s): a read whose request
/// waited in the transmit queue longer than the SDO timeout timed out and was repeated; the
/// first request's answer completed the repeat, and the repeat's answer (an upload response
/// for 0x1000) came while the next transfer, a write of 0x1017, waited for its confirmation.
/// That late answer must not fail the write.
#[test]
fn a_late_answer_of_another_kind_and_object_does_not_fail_the_next_transfer() {
    let device_type = Multiplexer::new(0x1000, 0);
    let heartbeat = Multiplexer::new(0x1017, 0);
    let answer = ServerResponse::InitiateUpload {
        mux: device_type,
        data: Initiate::expedited(&[0x91, 0x01, 0, 0]).unwrap(),
    }
    .emit();
    let mut c: TestClient = Client::new(ClientConfig::default());
    c.start_upload(T0, device_type, Vec::new(), Method::Normal)
        .unwrap();
    drain(&mut c);
    let late = T0 + Duration::from_secs(1);
    c.handle_timeout(late);
    assert_eq!(
        drain(&mut c),
        [abort_bytes(device_type, AbortCode::TIMEOUT)]
    );
    assert!(matches!(c.poll_event(), Some(Event::Failed { .. })));
    // The repeat, completed by the first request's answer.
    c.start_upload(late, device_type, Vec::new(), Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(late, &answer);
    assert!(matches!(c.poll_event(), Some(Event::Uploaded { .. })));
    // The write; the repeat's own answer arrives first.
    c.start_download(late, heartbeat, vec![0, 0], Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(late, &answer);
    assert!(drain(&mut c).is_empty(), "no abort for a late answer");
    assert!(c.poll_event().is_none());
    c.handle_response(
        late,
        &ServerResponse::InitiateDownload { mux: heartbeat }.emit(),
    );
    assert!(matches!(c.poll_event(), Some(Event::Downloaded { .. })));
    // The other way round: a download's confirmation for another object during a read.
    c.start_upload(late, device_type, Vec::new(), Method::Normal)
        .unwrap();
    drain(&mut c);
    c.handle_response(
        late,
        &ServerResponse::InitiateDownload { mux: heartbeat }.emit(),
    );
    assert!(drain(&mut c).is_empty());
    assert!(c.poll_event().is_none());
    c.handle_response(late, &answer);
    assert!(matches!(c.poll_event(), Some(Event::Uploaded { .. })));
}
