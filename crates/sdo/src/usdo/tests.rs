//! The USDO client and server back to back through the real codec: every transfer kind,
//! several sessions at once, refusals, timeouts, cancel, and a channel that loses, repeats and
//! reorders frames.

extern crate std;

use std::collections::{BTreeMap, VecDeque};
use std::vec;
use std::vec::Vec;

use canola_frame::{Duration, Instant, NodeId};
use proptest::prelude::*;

use super::*;
use crate::abort::AbortCode;
use crate::client::Buffer;
use crate::server::{Access, ObjectAccess, ObjectInfo};
use crate::wire::Multiplexer;

const CLIENT: u8 = 0x01;
const SERVER: u8 = 0x05;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

#[derive(Debug, Clone)]
struct Obj {
    access: Access,
    value: Vec<u8>,
    max: u32,
    data_type: DataType,
    staged: Vec<u8>,
}

/// A small object dictionary: variable-length objects that stage downloads and log commits.
#[derive(Debug, Default)]
struct TestOd {
    objects: BTreeMap<(u16, u8), Obj>,
    commits: Vec<(Multiplexer, Vec<u8>)>,
    discards: usize,
}

impl TestOd {
    fn with(mut self, index: u16, access: Access, value: Vec<u8>, max: u32) -> Self {
        self.objects.insert(
            (index, 0),
            Obj {
                access,
                value,
                max,
                data_type: DataType::DOMAIN,
                staged: Vec::new(),
            },
        );
        self
    }
}

impl ObjectAccess for TestOd {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        if !self.objects.keys().any(|k| k.0 == mux.index) {
            return Err(AbortCode::OBJECT_DOES_NOT_EXIST);
        }
        let o = self
            .objects
            .get(&(mux.index, mux.subindex))
            .ok_or(AbortCode::SUBINDEX_DOES_NOT_EXIST)?;
        Ok(ObjectInfo::variable(o.access, o.value.len() as u32, o.max))
    }
    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let o = &self.objects[&(mux.index, mux.subindex)];
        let rest = &o.value[(offset as usize).min(o.value.len())..];
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }
    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let o = self.objects.get_mut(&(mux.index, mux.subindex)).unwrap();
        if offset == 0 {
            o.staged.clear();
        }
        assert_eq!(o.staged.len(), offset as usize, "writes arrive in order");
        o.staged.extend_from_slice(data);
        Ok(())
    }
    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        let o = self.objects.get_mut(&(mux.index, mux.subindex)).unwrap();
        assert_eq!(o.staged.len(), len as usize);
        o.value = core::mem::take(&mut o.staged);
        self.commits.push((mux, o.value.clone()));
        Ok(())
    }
    fn discard(&mut self, mux: Multiplexer) {
        if let Some(o) = self.objects.get_mut(&(mux.index, mux.subindex)) {
            o.staged.clear();
        }
        self.discards += 1;
    }
    fn data_type(&mut self, mux: Multiplexer) -> DataType {
        self.objects
            .get(&(mux.index, mux.subindex))
            .map_or(DataType::DOMAIN, |o| o.data_type)
    }
}

type Client = UsdoClient<Vec<u8>, Vec<u8>>;
type Ev = UsdoEvent<Vec<u8>, Vec<u8>>;

fn pattern(len: usize, seed: u8) -> Vec<u8> {
    (0..len)
        .map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed))
        .collect()
}

/// One client and one server on a channel that a fault script can disturb. Each script byte
/// decides the fate of the next frame on the wire: 0 lost, 1 repeated, 2 swapped with a later
/// one, anything else delivered. After the script, every frame is delivered in order.
struct Bus {
    now: Instant,
    client: Client,
    server: UsdoServer,
    od: TestOd,
    wire: VecDeque<(bool, Vec<u8>)>,
    script: VecDeque<u8>,
    events: Vec<Ev>,
    frames: usize,
}

impl Bus {
    fn new(od: TestOd) -> Self {
        Self {
            now: Instant::ZERO,
            client: UsdoClient::new(node(CLIENT), UsdoClientConfig::default()),
            server: UsdoServer::new(node(SERVER), UsdoServerConfig::default()),
            od,
            wire: VecDeque::new(),
            script: VecDeque::new(),
            events: Vec::new(),
            frames: 0,
        }
    }

    fn collect(&mut self) {
        while let Some(f) = self.client.poll_transmit_frame() {
            assert_eq!(f.cob_id(), Some(0x600 + u16::from(CLIENT)));
            self.wire.push_back((true, f.data().to_vec()));
        }
        while let Some(f) = self.server.poll_transmit_frame() {
            assert_eq!(f.cob_id(), Some(0x580 + u16::from(SERVER)));
            self.wire.push_back((false, f.data().to_vec()));
        }
        while let Some(e) = self.client.poll_event() {
            self.events.push(e);
        }
    }

    fn deliver(&mut self, to_server: bool, data: &[u8]) {
        self.frames += 1;
        self.now += Duration::from_micros(200);
        if to_server {
            self.server
                .handle_request(self.now, CLIENT, data, &mut self.od);
        } else {
            self.client.handle_response(self.now, SERVER, data);
        }
    }

    /// Runs until nothing is on the wire and no timer is set.
    fn run(&mut self) {
        for _ in 0..200_000 {
            self.collect();
            let Some((to_server, data)) = self.wire.pop_front() else {
                let next = [self.client.poll_timeout(), self.server.poll_timeout()]
                    .into_iter()
                    .flatten()
                    .min();
                let Some(at) = next else { return };
                self.now = self.now.max(at);
                self.client.handle_timeout(self.now);
                self.server.handle_timeout(self.now, &mut self.od);
                continue;
            };
            match self.script.pop_front().map(|d| d % 8) {
                Some(0) => {}
                Some(1) => {
                    self.deliver(to_server, &data);
                    self.wire.push_back((to_server, data));
                }
                Some(2) if !self.wire.is_empty() => {
                    self.wire.insert(1.min(self.wire.len()), (to_server, data));
                }
                _ => self.deliver(to_server, &data),
            }
        }
        panic!("the pair did not settle");
    }

    fn take(&mut self, session: u8) -> Ev {
        let i = self
            .events
            .iter()
            .position(|e| match e {
                UsdoEvent::Uploaded { session: s, .. }
                | UsdoEvent::Downloaded { session: s, .. } => *s == session,
                UsdoEvent::Failed { error, .. } => error.session == session,
            })
            .expect("an event for the session");
        self.events.remove(i)
    }

    fn upload(&mut self, index: u16) -> Result<Vec<u8>, UsdoErrorKind> {
        let s = self
            .client
            .start_upload(
                self.now,
                node(SERVER),
                Multiplexer::new(index, 0),
                Vec::new(),
            )
            .unwrap();
        self.run();
        match self.take(s) {
            UsdoEvent::Uploaded { sink, len, .. } => {
                assert_eq!(sink.len(), len as usize);
                Ok(sink)
            }
            UsdoEvent::Failed { error, .. } => Err(error.kind),
            e => panic!("{e:?}"),
        }
    }

    fn download(&mut self, index: u16, data: Vec<u8>) -> Result<(), UsdoErrorKind> {
        let s = self
            .client
            .start_download(
                self.now,
                node(SERVER),
                Multiplexer::new(index, 0),
                DataType::DOMAIN,
                data,
            )
            .unwrap();
        self.run();
        match self.take(s) {
            UsdoEvent::Downloaded { .. } => Ok(()),
            UsdoEvent::Failed { error, .. } => Err(error.kind),
            e => panic!("{e:?}"),
        }
    }
}

const SIZES: [usize; 12] = [0, 1, 56, 57, 60, 61, 119, 120, 121, 1000, 4096, 20_000];

#[test]
fn uploads_of_every_size() {
    for (i, len) in SIZES.into_iter().enumerate() {
        let value = pattern(len, i as u8);
        let mut bus = Bus::new(TestOd::default().with(0x2000, Access::ReadOnly, value.clone(), 0));
        assert_eq!(bus.upload(0x2000), Ok(value), "{len} bytes");
        // Expedited up to 56 bytes: one request, one response; then 2 per segment.
        let expected = if len <= MAX_EXPEDITED {
            2
        } else {
            2 + 2 * len.div_ceil(60)
        };
        assert_eq!(bus.frames, expected, "{len} bytes");
        assert!(bus.client.is_idle() && bus.server.sessions() == 0);
    }
}

#[test]
fn downloads_of_every_size() {
    for (i, len) in SIZES.into_iter().enumerate() {
        let value = pattern(len, i as u8);
        let mut bus =
            Bus::new(TestOd::default().with(0x2001, Access::ReadWrite, Vec::new(), 30_000));
        assert_eq!(bus.download(0x2001, value.clone()), Ok(()), "{len} bytes");
        assert_eq!(bus.od.commits, vec![(Multiplexer::new(0x2001, 0), value)]);
        assert!(bus.server.poll_event().is_some());
    }
}

#[test]
fn refusals_carry_one_byte_codes() {
    let od = TestOd::default()
        .with(0x2000, Access::ReadOnly, vec![1, 2, 3], 0)
        .with(0x2001, Access::WriteOnly, vec![0; 4], 4)
        .with(0x2002, Access::ReadWrite, vec![], 100);
    let mut bus = Bus::new(od);
    fn abort<T>(c: UsdoAbortCode) -> Result<T, UsdoErrorKind> {
        Err(UsdoErrorKind::ServerAbort(c))
    }
    assert_eq!(
        bus.upload(0x3000),
        abort(UsdoAbortCode::OBJECT_DOES_NOT_EXIST)
    );
    assert_eq!(
        bus.download(0x2000, vec![1]),
        abort(UsdoAbortCode::READ_ONLY)
    );
    assert_eq!(bus.upload(0x2001), abort(UsdoAbortCode::WRITE_ONLY));
    assert_eq!(
        bus.download(0x2002, vec![0; 101]),
        abort(UsdoAbortCode::LENGTH_TOO_HIGH)
    );
    // A typed object refuses another type, but takes DOMAIN.
    bus.od.objects.get_mut(&(0x2002, 0)).unwrap().data_type = DataType::UNSIGNED32;
    let s = bus
        .client
        .start_download(
            bus.now,
            node(SERVER),
            Multiplexer::new(0x2002, 0),
            DataType::UNSIGNED16,
            vec![1, 2],
        )
        .unwrap();
    bus.run();
    assert!(matches!(
        bus.take(s),
        UsdoEvent::Failed {
            error: UsdoTransferError {
                kind: UsdoErrorKind::ServerAbort(UsdoAbortCode::LENGTH_MISMATCH),
                ..
            },
            buffer: Buffer::Source(_)
        }
    ));
    assert_eq!(bus.download(0x2002, vec![1, 2, 3, 4]), Ok(()));
    // The upload announces the object's type.
    let s = bus
        .client
        .start_upload(
            bus.now,
            node(SERVER),
            Multiplexer::new(0x2002, 0),
            Vec::new(),
        )
        .unwrap();
    bus.run();
    assert!(matches!(
        bus.take(s),
        UsdoEvent::Uploaded {
            data_type: DataType::UNSIGNED32,
            ..
        }
    ));
}

#[test]
fn sessions_run_in_parallel() {
    let mut od = TestOd::default();
    for i in 0..4u16 {
        od = od
            .with(
                0x2100 + i,
                Access::ReadOnly,
                pattern(500 + 100 * i as usize, i as u8),
                0,
            )
            .with(0x2200 + i, Access::ReadWrite, Vec::new(), 2000);
    }
    let mut bus = Bus::new(od);
    let mut started = Vec::new();
    for i in 0..4u16 {
        let up = bus
            .client
            .start_upload(
                bus.now,
                node(SERVER),
                Multiplexer::new(0x2100 + i, 0),
                Vec::new(),
            )
            .unwrap();
        let down = bus
            .client
            .start_download(
                bus.now,
                node(SERVER),
                Multiplexer::new(0x2200 + i, 0),
                DataType::DOMAIN,
                pattern(700 + i as usize, 9),
            )
            .unwrap();
        started.push((i, up, down));
    }
    // The ninth is refused and its buffer handed back.
    let busy = bus
        .client
        .start_upload(bus.now, node(SERVER), Multiplexer::new(0x2100, 0), vec![7]);
    assert_eq!(busy, Err(UsdoBusy(vec![7])));
    bus.collect();
    assert_eq!(bus.server.sessions(), 0);
    // Let the server see every initiate before any segment: all eight sessions open at once.
    let initiates: Vec<_> = bus.wire.drain(..).collect();
    for (_, data) in &initiates {
        bus.deliver(true, data);
    }
    assert_eq!(bus.server.sessions(), 8);
    bus.run();
    for (i, up, down) in started {
        match bus.take(up) {
            UsdoEvent::Uploaded { sink, .. } => {
                assert_eq!(sink, pattern(500 + 100 * i as usize, i as u8))
            }
            e => panic!("{e:?}"),
        }
        assert!(matches!(bus.take(down), UsdoEvent::Downloaded { .. }));
        assert_eq!(
            bus.od.objects[&(0x2200 + i, 0)].value,
            pattern(700 + i as usize, 9)
        );
    }
}

#[test]
fn a_full_server_refuses_with_busy() {
    let mut od = TestOd::default();
    for i in 0..9u16 {
        od = od.with(0x2100 + i, Access::ReadOnly, pattern(100, 1), 0);
    }
    let mut server = UsdoServer::new(node(SERVER), UsdoServerConfig::default());
    let mut clients: Vec<Client> = (1..=2)
        .map(|n| UsdoClient::new(node(n), UsdoClientConfig::default()))
        .collect();
    let now = Instant::ZERO;
    for i in 0..9u16 {
        let c = &mut clients[usize::from(i % 2)];
        c.start_upload(
            now,
            node(SERVER),
            Multiplexer::new(0x2100 + i, 0),
            Vec::new(),
        )
        .unwrap();
        let f = c.poll_transmit_frame().unwrap();
        assert!(server.handle_frame(now, &f, &mut od));
    }
    assert_eq!(server.sessions(), MAX_SESSIONS);
    let mut aborts = 0;
    while let Some(f) = server.poll_transmit_frame() {
        for c in &mut clients {
            assert!(c.handle_frame(now, &f));
        }
        if UsdoMessage::parse(f.data()).unwrap().body
            == (UsdoBody::Abort {
                mux: Multiplexer::new(0x2108, 0),
                code: assumed::ABORT_BUSY,
            })
        {
            aborts += 1;
        }
    }
    assert_eq!(aborts, 1);
    // Only client 1 (the ninth upload's) got the refusal: destination bytes route responses.
    assert!(
        matches!(clients[0].poll_event(), Some(UsdoEvent::Failed { error, .. }) if error.kind == UsdoErrorKind::ServerAbort(assumed::ABORT_BUSY))
    );
    assert!(clients[1].poll_event().is_none());
}

#[test]
fn timeouts_and_cancel_send_aborts() {
    let od = TestOd::default().with(0x2000, Access::ReadWrite, pattern(300, 3), 1000);
    let mut bus = Bus::new(od);
    // The server never answers: the client gives up after its timeout and tells the server.
    let s = bus
        .client
        .start_upload(
            bus.now,
            node(SERVER),
            Multiplexer::new(0x2000, 0),
            Vec::new(),
        )
        .unwrap();
    bus.collect();
    bus.wire.clear();
    assert_eq!(
        bus.client.poll_timeout(),
        Some(Instant::ZERO + Duration::from_millis(assumed::DEFAULT_TIMEOUT_MS))
    );
    bus.client
        .handle_timeout(Instant::ZERO + Duration::from_millis(999));
    assert!(bus.client.poll_event().is_none());
    bus.client
        .handle_timeout(Instant::ZERO + Duration::from_secs(1));
    let abort = bus.client.poll_transmit().unwrap();
    assert_eq!(
        UsdoMessage::parse(&abort).unwrap(),
        UsdoMessage {
            destination: SERVER,
            session: s,
            body: UsdoBody::Abort {
                mux: Multiplexer::new(0x2000, 0),
                code: assumed::ABORT_TIMEOUT
            },
        }
    );
    assert!(
        matches!(bus.client.poll_event(), Some(UsdoEvent::Failed { error, .. }) if error.kind == UsdoErrorKind::Timeout(assumed::ABORT_TIMEOUT))
    );

    // The client stops half-way through a download: the server times the session out.
    let mut bus = Bus::new(TestOd::default().with(0x2000, Access::ReadWrite, vec![], 1000));
    bus.now = Instant::ZERO + Duration::from_secs(10);
    let s = bus
        .client
        .start_download(
            bus.now,
            node(SERVER),
            Multiplexer::new(0x2000, 0),
            DataType::DOMAIN,
            pattern(300, 1),
        )
        .unwrap();
    bus.collect();
    let (_, init) = bus.wire.pop_front().unwrap();
    bus.deliver(true, &init);
    assert_eq!(bus.server.sessions(), 1);
    let deadline = bus.server.poll_timeout().unwrap();
    bus.server.handle_timeout(deadline, &mut bus.od);
    assert_eq!(bus.server.sessions(), 0);
    assert_eq!(bus.od.discards, 1);
    let _ = bus.server.poll_transmit(); // The initiate response.
    let abort = bus.server.poll_transmit().unwrap();
    assert!(
        matches!(UsdoMessage::parse(&abort).unwrap().body, UsdoBody::Abort { code, .. } if code == assumed::ABORT_TIMEOUT)
    );

    // Cancel: the abort reaches the server, which drops the session and the staged data.
    let mut bus = Bus::new(TestOd::default().with(0x2000, Access::ReadWrite, vec![], 1000));
    let s2 = bus
        .client
        .start_download(
            bus.now,
            node(SERVER),
            Multiplexer::new(0x2000, 0),
            DataType::DOMAIN,
            pattern(300, 1),
        )
        .unwrap();
    bus.collect();
    let (_, init) = bus.wire.pop_front().unwrap();
    bus.deliver(true, &init);
    assert!(bus.client.abort(node(SERVER), s2));
    assert!(!bus.client.abort(node(SERVER), s2));
    bus.run();
    assert!(
        matches!(bus.take(s2), UsdoEvent::Failed { error, buffer: Buffer::Source(_) } if error.kind == UsdoErrorKind::Cancelled(assumed::ABORT_CANCELLED))
    );
    assert_eq!(bus.server.sessions(), 0);
    assert!(bus.od.commits.is_empty());
    let _ = s;
}

#[test]
fn repeated_requests_are_answered_again_not_applied_twice() {
    let mut bus = Bus::new(TestOd::default().with(0x2000, Access::ReadWrite, vec![], 1000));
    // Every frame repeated once.
    bus.script = core::iter::repeat_n(1, 1000).collect();
    assert_eq!(bus.download(0x2000, pattern(250, 4)), Ok(()));
    assert_eq!(bus.upload(0x2000), Ok(pattern(250, 4)));
    assert!(bus.od.commits.iter().all(|(_, v)| *v == pattern(250, 4)));
}

#[test]
fn the_server_answers_only_its_own_frames() {
    let mut od = TestOd::default().with(0x2000, Access::ReadOnly, vec![1, 2, 3], 0);
    let mut server = UsdoServer::new(node(SERVER), UsdoServerConfig::default());
    let now = Instant::ZERO;
    let read = |dst: u8| {
        UsdoMessage {
            destination: dst,
            session: 1,
            body: UsdoBody::Upload {
                mux: Multiplexer::new(0x2000, 0),
            },
        }
        .to_bytes()
        .unwrap()
    };
    // Another destination, a response kind, a frame on a response identifier: all ignored.
    server.handle_request(now, CLIENT, &read(6), &mut od);
    let response = UsdoMessage {
        destination: SERVER,
        session: 1,
        body: UsdoBody::DownloadEndResponse,
    };
    server.handle_request(now, CLIENT, &response.to_bytes().unwrap(), &mut od);
    let id = canola_frame::CanId::standard(0x581).unwrap();
    let on_response_id = canola_frame::FdFrame::new_padded(id, &read(SERVER)).unwrap();
    assert!(!server.handle_frame(now, &on_response_id, &mut od));
    assert!(server.poll_transmit().is_none());
    // An unknown command for us: abort 0x13; a segment for no session: abort 0x21.
    server.handle_request(now, CLIENT, &[SERVER, 0x45, 9, 0, 0, 0, 0, 0], &mut od);
    let seg = UsdoMessage {
        destination: SERVER,
        session: 4,
        body: UsdoBody::UploadSegment { counter: 0 },
    };
    server.handle_request(now, CLIENT, &seg.to_bytes().unwrap(), &mut od);
    let codes: Vec<_> = core::iter::from_fn(|| server.poll_transmit())
        .map(|b| match UsdoMessage::parse(&b).unwrap() {
            UsdoMessage {
                destination: CLIENT,
                session,
                body: UsdoBody::Abort { code, .. },
            } => (session, code),
            m => panic!("{m:?}"),
        })
        .collect();
    assert_eq!(
        codes,
        [
            (9, UsdoAbortCode::INVALID_COMMAND),
            (4, UsdoAbortCode::UNKNOWN_SESSION)
        ]
    );
    let text = std::format!("{}", server.poll_event().unwrap());
    assert_eq!(
        text,
        "USDO aborted 0x0000:00 for node 1 (session 9): 0x13 (Unknown, unexpected or unsupported command specifier)"
    );
    // The client ignores responses meant for another node.
    let mut client: Client = UsdoClient::new(node(CLIENT), UsdoClientConfig::default());
    let s = client
        .start_upload(now, node(SERVER), Multiplexer::new(0x2000, 0), Vec::new())
        .unwrap();
    let other = UsdoMessage {
        destination: 2,
        session: s,
        body: UsdoBody::UploadExpeditedResponse {
            mux: Multiplexer::new(0x2000, 0),
            data_type: DataType::DOMAIN,
            data: &[9],
        },
    };
    client.handle_response(now, SERVER, &other.to_bytes().unwrap());
    assert!(client.poll_event().is_none());
    assert_eq!(client.active(), 1);
}

#[test]
fn a_lost_frame_ends_in_a_timeout_on_both_sides() {
    let od = TestOd::default().with(0x2000, Access::ReadWrite, vec![], 1000);
    let mut bus = Bus::new(od);
    // Initiate, its response, segment 0 delivered; the confirmation of segment 0 is lost.
    bus.script = [3, 3, 3, 0].into();
    assert_eq!(
        bus.download(0x2000, pattern(200, 1)),
        Err(UsdoErrorKind::Timeout(assumed::ABORT_TIMEOUT))
    );
    assert!(bus.od.commits.is_empty());
    assert_eq!(bus.od.discards, 1);
    // The client's abort reached the server before its own timeout.
    assert!(
        core::iter::from_fn(|| bus.server.poll_event()).any(|e| matches!(
            e,
            UsdoServerEvent::AbortedByClient { code, .. } if code == assumed::ABORT_TIMEOUT
        ))
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Under any pattern of loss, repetition and reordering every transfer ends with exactly
    /// one event, a success delivers exactly the data, and both sides end without sessions.
    #[test]
    fn lossy_channel(
        script in proptest::collection::vec(any::<u8>(), 0..200),
        lens in proptest::collection::vec(0usize..400, 1..=4),
    ) {
        let mut od = TestOd::default();
        for (i, len) in lens.iter().enumerate() {
            od = od
                .with(0x2100 + i as u16, Access::ReadOnly, pattern(*len, i as u8), 0)
                .with(0x2200 + i as u16, Access::ReadWrite, Vec::new(), 1000);
        }
        let mut bus = Bus::new(od);
        let faults = script.iter().any(|d| d % 8 < 3);
        bus.script = script.into();
        let mut started = Vec::new();
        for (i, len) in lens.iter().enumerate() {
            let up = bus.client.start_upload(bus.now, node(SERVER), Multiplexer::new(0x2100 + i as u16, 0), Vec::new()).unwrap();
            let down = bus.client.start_download(bus.now, node(SERVER), Multiplexer::new(0x2200 + i as u16, 0), DataType::DOMAIN, pattern(*len, 100 + i as u8)).unwrap();
            started.push((i, *len, up, down));
        }
        bus.run();
        for (i, len, up, down) in started {
            match bus.take(up) {
                UsdoEvent::Uploaded { sink, .. } => prop_assert_eq!(sink, pattern(len, i as u8)),
                UsdoEvent::Failed { error, .. } => prop_assert!(faults, "{error}"),
                e => panic!("{e:?}"),
            }
            match bus.take(down) {
                UsdoEvent::Downloaded { mux, source, .. } => {
                    prop_assert!(bus.od.commits.contains(&(mux, source)));
                }
                UsdoEvent::Failed { error, .. } => prop_assert!(faults, "{error}"),
                e => panic!("{e:?}"),
            }
        }
        prop_assert!(bus.events.is_empty());
        prop_assert!(bus.client.is_idle());
        prop_assert_eq!(bus.server.sessions(), 0);
        // Whatever the server committed is a value some download sent.
        for (mux, value) in &bus.od.commits {
            let i = usize::from(mux.index - 0x2200);
            prop_assert_eq!(value, &pattern(lens[i], 100 + i as u8));
        }
    }
}
