//! Properties: codec round trips, every transfer method moves random objects of 0..=4096 bytes
//! intact, and a lossy link (frames dropped or duplicated) ends either with the right data or
//! in a clean abort or timeout — never with wrong data.

mod common;

use canola_frame::{Duration, Instant};
use canola_sdo::{
    AbortCode, BlockSegment, ClientConfig, ClientRequest, Event, Initiate, Method, Multiplexer,
    Segment, ServerConfig, ServerResponse,
};
use common::{DOMAIN, Pair};
use proptest::prelude::*;

fn mux() -> impl Strategy<Value = Multiplexer> {
    (any::<u16>(), any::<u8>()).prop_map(|(i, s)| Multiplexer::new(i, s))
}

fn initiate() -> impl Strategy<Value = Initiate> {
    prop_oneof![
        (any::<[u8; 4]>(), proptest::option::of(1u8..=4))
            .prop_map(|(data, size)| Initiate::Expedited { data, size }),
        proptest::option::of(any::<u32>()).prop_map(|size| Initiate::Segmented { size }),
    ]
}

fn segment() -> impl Strategy<Value = Segment> {
    (any::<bool>(), any::<[u8; 7]>(), 0u8..=7, any::<bool>()).prop_map(
        |(toggle, data, len, last)| Segment {
            toggle,
            data,
            len,
            last,
        },
    )
}

fn client_request() -> impl Strategy<Value = ClientRequest> {
    prop_oneof![
        (mux(), initiate()).prop_map(|(mux, data)| ClientRequest::InitiateDownload { mux, data }),
        segment().prop_map(ClientRequest::DownloadSegment),
        mux().prop_map(|mux| ClientRequest::InitiateUpload { mux }),
        any::<bool>().prop_map(|toggle| ClientRequest::UploadSegment { toggle }),
        (mux(), any::<u32>()).prop_map(|(mux, c)| ClientRequest::Abort {
            mux,
            code: AbortCode(c)
        }),
        (mux(), any::<bool>(), proptest::option::of(any::<u32>()))
            .prop_map(|(mux, crc, size)| ClientRequest::BlockDownloadInitiate { mux, crc, size }),
        (0u8..=7, any::<u16>())
            .prop_map(|(unused, crc)| ClientRequest::BlockDownloadEnd { unused, crc }),
        (mux(), any::<bool>(), any::<u8>(), any::<u8>()).prop_map(|(mux, crc, blksize, pst)| {
            ClientRequest::BlockUploadInitiate {
                mux,
                crc,
                blksize,
                pst,
            }
        }),
        Just(ClientRequest::BlockUploadStart),
        (any::<u8>(), any::<u8>())
            .prop_map(|(ackseq, blksize)| ClientRequest::BlockUploadAck { ackseq, blksize }),
        Just(ClientRequest::BlockUploadEnd),
    ]
}

fn server_response() -> impl Strategy<Value = ServerResponse> {
    prop_oneof![
        (mux(), initiate()).prop_map(|(mux, data)| ServerResponse::InitiateUpload { mux, data }),
        segment().prop_map(ServerResponse::UploadSegment),
        mux().prop_map(|mux| ServerResponse::InitiateDownload { mux }),
        any::<bool>().prop_map(|toggle| ServerResponse::DownloadSegment { toggle }),
        (mux(), any::<u32>()).prop_map(|(mux, c)| ServerResponse::Abort {
            mux,
            code: AbortCode(c)
        }),
        (mux(), any::<bool>(), any::<u8>()).prop_map(|(mux, crc, blksize)| {
            ServerResponse::BlockDownloadInitiate { mux, crc, blksize }
        }),
        (any::<u8>(), any::<u8>())
            .prop_map(|(ackseq, blksize)| ServerResponse::BlockDownloadAck { ackseq, blksize }),
        Just(ServerResponse::BlockDownloadEnd),
        (mux(), any::<bool>(), proptest::option::of(any::<u32>()))
            .prop_map(|(mux, crc, size)| ServerResponse::BlockUploadInitiate { mux, crc, size }),
        (0u8..=7, any::<u16>())
            .prop_map(|(unused, crc)| ServerResponse::BlockUploadEnd { unused, crc }),
    ]
}

fn method() -> impl Strategy<Value = Method> {
    prop_oneof![
        Just(Method::Normal),
        Just(Method::Segmented),
        Just(Method::Block)
    ]
}

/// Small deterministic generator for the link's faults.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 32) as u32
    }

    /// True with probability `per_mille` / 1000.
    fn chance(&mut self, per_mille: u32) -> bool {
        self.next() % 1000 < per_mille
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(std::env::var("SDO_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)))]

    #[test]
    fn client_requests_round_trip(msg in client_request()) {
        prop_assert_eq!(ClientRequest::parse(&msg.emit()), Ok(msg));
    }

    #[test]
    fn server_responses_round_trip(msg in server_response()) {
        prop_assert_eq!(ServerResponse::parse(&msg.emit()), Ok(msg));
    }

    #[test]
    fn any_bytes_decode_or_error(bytes in proptest::collection::vec(any::<u8>(), 0..12)) {
        if let Ok(msg) = ClientRequest::parse(&bytes) {
            prop_assert_eq!(ClientRequest::parse(&msg.emit()), Ok(msg));
        }
        if let Ok(msg) = ServerResponse::parse(&bytes) {
            prop_assert_eq!(ServerResponse::parse(&msg.emit()), Ok(msg));
        }
        if let Ok(seg) = BlockSegment::parse(&bytes) {
            prop_assert_eq!(&seg.emit()[..], &bytes[..]);
        }
    }

    /// Every method moves every size intact, with random block sizes and CRC settings.
    #[test]
    fn transfers_are_intact(
        data in proptest::collection::vec(any::<u8>(), 0..=4096),
        method in method(),
        client_blksize in 1u8..=127,
        server_blksize in 1u8..=127,
        client_crc in any::<bool>(),
        server_crc in any::<bool>(),
        pst in prop_oneof![Just(0u8), any::<u8>()],
    ) {
        let mut p = Pair::with(
            ClientConfig::default()
                .with_block_size(client_blksize)
                .with_crc(client_crc)
                .with_protocol_switch_threshold(pst),
            ServerConfig { block_size: server_blksize, crc: server_crc, ..ServerConfig::default() },
        );
        p.client.start_download(Instant::ZERO, DOMAIN, data.clone(), method).unwrap();
        let ev = p.run();
        prop_assert!(matches!(ev, Event::Downloaded { .. }), "{:?}", ev);
        prop_assert_eq!(p.od.value(DOMAIN), &data[..]);
        // Expedited where it fits.
        if method == Method::Normal && (1..=4).contains(&data.len()) {
            prop_assert_eq!(p.log.len(), 2);
        }
        p.client.start_upload(p.now, DOMAIN, Vec::new(), method).unwrap();
        match p.run() {
            Event::Uploaded { sink, .. } => prop_assert_eq!(sink, data),
            other => prop_assert!(false, "{:?}", other),
        }
        prop_assert!(p.server.is_idle());
    }

    /// Frames dropped or duplicated at random: the transfer completes with the right data or
    /// fails cleanly (abort or timeout); the object holds either its old or its new value;
    /// both machines end idle.
    #[test]
    fn lossy_link_never_gives_wrong_data(
        data in proptest::collection::vec(any::<u8>(), 0..=600),
        old in proptest::collection::vec(any::<u8>(), 0..=40),
        method in method(),
        upload in any::<bool>(),
        blksize in 1u8..=20,
        seed in any::<u64>(),
        drop_per_mille in 0u32..60,
        dup_per_mille in 0u32..60,
    ) {
        let mut p = Pair::with(
            ClientConfig::default().with_block_size(blksize),
            ServerConfig { block_size: blksize, ..ServerConfig::default() },
        );
        let mut rng = XorShift(seed | 1);
        p.od.set(DOMAIN, if upload { data.clone() } else { old.clone() });
        if upload {
            p.client.start_upload(Instant::ZERO, DOMAIN, Vec::new(), method).unwrap();
        } else {
            p.client.start_download(Instant::ZERO, DOMAIN, data.clone(), method).unwrap();
        }
        let mut event = None;
        for _ in 0..200_000 {
            let mut moved = false;
            while let Some(f) = p.client.poll_transmit() {
                moved = true;
                if rng.chance(drop_per_mille) { continue; }
                let copies = if rng.chance(dup_per_mille) { 2 } else { 1 };
                for _ in 0..copies { p.server.handle_request(p.now, &f, &mut p.od); }
            }
            while let Some(f) = p.server.poll_transmit() {
                moved = true;
                if rng.chance(drop_per_mille) { continue; }
                let copies = if rng.chance(dup_per_mille) { 2 } else { 1 };
                for _ in 0..copies { p.client.handle_response(p.now, &f); }
            }
            if let Some(ev) = p.client.poll_event() {
                prop_assert!(event.is_none());
                event = Some(ev);
            }
            if event.is_some() && p.server.is_idle() && !moved {
                break;
            }
            if moved {
                p.now += Duration::from_micros(200);
            } else {
                let next = [p.client.poll_timeout(), p.server.poll_timeout()]
                    .into_iter().flatten().min();
                match next {
                    Some(next) => p.now = p.now.max(next),
                    None => prop_assert!(false, "stuck without a deadline"),
                }
                p.client.handle_timeout(p.now);
                p.server.handle_timeout(p.now, &mut p.od);
            }
        }
        let event = event.expect("the transfer ended");
        prop_assert!(p.server.is_idle());
        match event {
            Event::Uploaded { sink, .. } => prop_assert_eq!(&sink[..], &data[..]),
            Event::Downloaded { .. } => prop_assert_eq!(p.od.value(DOMAIN), &data[..]),
            Event::Failed { .. } => {
                let value = p.od.value(DOMAIN);
                prop_assert!(value == &data[..] || value == &old[..] || upload);
            }
        }
        if upload {
            prop_assert_eq!(p.od.value(DOMAIN), &data[..]);
        }
    }
}
