//! The USDO server (CiA 1301) over the [`ObjectAccess`] trait of the SDO server: what a CANopen
//! FD device (or the device simulator) runs to serve its one USDO service to every client, with
//! up to [`MAX_SESSIONS`] transfers at once.
//!
//! # Call order (as [`Server`](crate::Server))
//!
//! 1. [`UsdoServer::new`] with the device's node-ID and a [`UsdoServerConfig`].
//! 2. For every CAN FD frame on 0x600 + any client node-ID call [`UsdoServer::handle_frame`]
//!    (or [`UsdoServer::handle_request`] with the client's node-ID and the data bytes).
//!    Frames whose destination byte is not this node are ignored.
//! 3. Send every frame [`UsdoServer::poll_transmit_frame`] yields (0x580 + this node; the
//!    destination byte inside says which client it is for).
//! 4. When the clock reaches [`UsdoServer::poll_timeout`], call [`UsdoServer::handle_timeout`].
//! 5. Optionally drain [`UsdoServer::poll_event`].
//!
//! # Behaviour
//!
//! - A session is keyed by the client's node-ID and the session-ID. Expedited transfers need
//!   none; a segmented transfer holds one until its end, an abort, or the timeout (the client
//!   silent for [`UsdoServerConfig::timeout`]: abort [`ABORT_TIMEOUT`] to the client). A
//!   segmented transfer while all sessions are taken is refused with [`ABORT_BUSY`].
//! - Every segment is confirmed with its counter (SOFA). A counter that names no segment already
//!   handled is abort 0x14 (as SOFA). One that does is a repeated request (SOFA would abort;
//!   this server tolerates the repeats a CAN FD bus with retransmitting gateways can produce):
//!   the last one is answered again without writing twice, older ones are ignored. A repeated initiate for a session that has not
//!   moved yet is answered again; once it has, it is ignored.
//! - A segment or end for no session is abort 0x21; a size that does not add up is 0x15; an
//!   unknown command specifier is 0x13. Object errors ([`ObjectAccess`] returns CiA 301 codes)
//!   go out as their 1-byte codes ([`UsdoAbortCode::from_cia301_or_general`]).
//! - The data type byte: the server announces [`ObjectAccess::data_type`] and refuses a
//!   download whose type differs from it with 0x36, unless either side says DOMAIN.

use canola_frame::{CanId, Duration, FdFrame, Instant, NodeId};

use crate::abort::AbortCode;
use crate::queue::Ring;
use crate::server::object::{Fail, ObjectAccess, read_exact, readable, writable};
use crate::usdo::abort::UsdoAbortCode;
use crate::usdo::assumed::{
    ABORT_BUSY, ABORT_TIMEOUT, DEFAULT_TIMEOUT_MS, REQUEST_BASE, RESPONSE_BASE, SEGMENT_DATA,
};
use crate::usdo::wire::{
    DataType, MAX_EXPEDITED, MAX_FRAME, UsdoBody, UsdoDecodeError, UsdoMessage, UsdoPacket,
};
use crate::wire::Multiplexer;

/// How many segmented transfers a server or client runs at once.
pub const MAX_SESSIONS: usize = 8;

/// The padded data bytes of one USDO frame.
pub type UsdoBytes = heapless::Vec<u8, MAX_FRAME>;

/// Server settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UsdoServerConfig {
    /// How long a client may take for its next request within a segmented transfer.
    /// Default [`DEFAULT_TIMEOUT_MS`].
    pub timeout: Duration,
}

impl Default for UsdoServerConfig {
    fn default() -> Self {
        Self {
            timeout: Duration::from_millis(DEFAULT_TIMEOUT_MS),
        }
    }
}

/// What happened on the server, for logs and the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UsdoServerEvent {
    /// A download completed and was committed.
    Downloaded {
        /// The client's node-ID.
        client: u8,
        /// The object.
        mux: Multiplexer,
        /// Bytes written.
        len: u32,
    },
    /// An upload completed (the last data went out).
    Uploaded {
        /// The client's node-ID.
        client: u8,
        /// The object.
        mux: Multiplexer,
        /// Bytes read.
        len: u32,
    },
    /// The server aborted a transfer (or refused one) with this code.
    Aborted {
        /// The client's node-ID.
        client: u8,
        /// The session-ID.
        session: u8,
        /// The object (0000:00 when the session was unknown).
        mux: Multiplexer,
        /// The code sent.
        code: UsdoAbortCode,
    },
    /// The client aborted a transfer.
    AbortedByClient {
        /// The client's node-ID.
        client: u8,
        /// The session-ID.
        session: u8,
        /// The object.
        mux: Multiplexer,
        /// The client's code.
        code: UsdoAbortCode,
    },
}

impl core::fmt::Display for UsdoServerEvent {
    /// `USDO download of 0x2000:01 from node 1 done, 4 bytes`, `USDO aborted 0x2000:01 for
    /// node 1 (session 3): 0x32 (...)`, `USDO node 1 aborted 0x2000:01 (session 3): ...`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Downloaded { client, mux, len } => {
                write!(
                    f,
                    "USDO download of {mux} from node {client} done, {len} bytes"
                )
            }
            Self::Uploaded { client, mux, len } => {
                write!(f, "USDO upload of {mux} to node {client} done, {len} bytes")
            }
            Self::Aborted {
                client,
                session,
                mux,
                code,
            } => write!(
                f,
                "USDO aborted {mux} for node {client} (session {session}): {code}"
            ),
            Self::AbortedByClient {
                client,
                session,
                mux,
                code,
            } => write!(
                f,
                "USDO node {client} aborted {mux} (session {session}): {code}"
            ),
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Phase {
    /// Segmented download: bytes received, the announced size, the next counter.
    Download {
        received: u32,
        size: u32,
        counter: u8,
    },
    /// Segmented upload: bytes sent, the value's length, the next counter.
    Upload { offset: u32, len: u32, counter: u8 },
}

#[derive(Debug, Clone, Copy)]
struct Session {
    client: u8,
    session: u8,
    mux: Multiplexer,
    deadline: Instant,
    phase: Phase,
}

impl Session {
    /// Whether no segment moved yet.
    fn fresh(&self) -> bool {
        matches!(
            self.phase,
            Phase::Download { counter: 0, .. } | Phase::Upload { counter: 0, .. }
        )
    }
}

/// The USDO server of one node. See the [module docs](self) for the call order.
#[derive(Debug)]
pub struct UsdoServer {
    node: NodeId,
    config: UsdoServerConfig,
    sessions: heapless::Vec<Session, MAX_SESSIONS>,
    tx: Ring<UsdoBytes, 16>,
    events: Ring<UsdoServerEvent, 16>,
}

impl UsdoServer {
    /// A server for node `node` with no session.
    pub fn new(node: NodeId, config: UsdoServerConfig) -> Self {
        Self {
            node,
            config,
            sessions: heapless::Vec::new(),
            tx: Ring::new(),
            events: Ring::new(),
        }
    }

    /// The node served.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// Segmented transfers in progress.
    pub fn sessions(&self) -> usize {
        self.sessions.len()
    }

    /// Feeds a frame if it is on a USDO request identifier (0x600 + client); returns whether
    /// it was.
    pub fn handle_frame<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        frame: &FdFrame,
        od: &mut O,
    ) -> bool {
        let Some(cob) = frame.cob_id() else {
            return false;
        };
        let client = (cob & 0x7F) as u8;
        if cob & 0x780 != REQUEST_BASE || client == 0 {
            return false;
        }
        self.handle_request(now, client, frame.data(), od);
        true
    }

    /// [`poll_transmit`](Self::poll_transmit) as a CAN FD frame on 0x580 + this node, with the
    /// bit-rate switch set (its data phase runs at the bus's data bit rate).
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<FdFrame> {
        let data = self.poll_transmit()?;
        let id = CanId::standard(RESPONSE_BASE + u16::from(self.node.get())).ok()?;
        FdFrame::new(id, &data).ok().map(|f| f.with_brs(true))
    }

    /// The next frame's data bytes for a client, padded to a CAN FD length.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<UsdoBytes> {
        self.tx.pop()
    }

    /// The next event, if any.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<UsdoServerEvent> {
        self.events.pop()
    }

    /// When [`handle_timeout`](Self::handle_timeout) must be called next, if a session runs.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.sessions.iter().map(|s| s.deadline).min()
    }

    /// Ends every session whose client was silent past its deadline, with abort
    /// [`ABORT_TIMEOUT`] to the client.
    pub fn handle_timeout<O: ObjectAccess + ?Sized>(&mut self, now: Instant, od: &mut O) {
        while let Some(i) = self.sessions.iter().position(|s| now >= s.deadline) {
            let s = self.sessions.swap_remove(i);
            if matches!(s.phase, Phase::Download { .. }) {
                od.discard(s.mux);
            }
            self.send_abort(s.client, s.session, s.mux, ABORT_TIMEOUT);
        }
    }

    /// Feeds the data bytes of one request frame from client `client` (the low 7 bits of its
    /// CAN-ID).
    pub fn handle_request<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        client: u8,
        data: &[u8],
        od: &mut O,
    ) {
        let msg = match UsdoMessage::parse(data) {
            Ok(msg) => msg,
            Err(UsdoDecodeError::UnknownCommand(_) | UsdoDecodeError::Remote(_)) => {
                // Answer a command we cannot serve when the frame is for us.
                let p = UsdoPacket::new_unchecked(data);
                if let (Some(dst), Some(session)) = (p.destination(), p.session())
                    && dst == self.node.get()
                    && session != 0
                {
                    self.send_abort(
                        client,
                        session,
                        Multiplexer::default(),
                        UsdoAbortCode::INVALID_COMMAND,
                    );
                }
                return;
            }
            Err(_) => return,
        };
        if msg.destination != self.node.get() || !msg.body.is_request() {
            return;
        }
        let session = msg.session;
        let found = self
            .sessions
            .iter()
            .position(|s| s.client == client && s.session == session);
        match msg.body {
            UsdoBody::Abort { code, .. } => {
                if let Some(i) = found {
                    let s = self.sessions.swap_remove(i);
                    if matches!(s.phase, Phase::Download { .. }) {
                        od.discard(s.mux);
                    }
                    self.events.push(UsdoServerEvent::AbortedByClient {
                        client,
                        session,
                        mux: s.mux,
                        code,
                    });
                }
            }
            UsdoBody::DownloadExpedited {
                mux,
                data_type,
                data,
            } => {
                self.drop_session(found, od);
                let len = data.len() as u32;
                let result = check_download(od, mux, data_type, len)
                    .and_then(|_| od.write(mux, 0, data).map_err(|c| Fail(mux, c)))
                    .and_then(|_| od.commit(mux, len).map_err(|c| Fail(mux, c)));
                match result {
                    Ok(()) => {
                        self.send(client, session, UsdoBody::DownloadExpeditedResponse { mux });
                        self.events
                            .push(UsdoServerEvent::Downloaded { client, mux, len });
                    }
                    Err(Fail(mux, code)) => {
                        od.discard(mux);
                        self.send_abort_301(client, session, mux, code);
                    }
                }
            }
            UsdoBody::DownloadInitiate {
                mux,
                data_type,
                size,
            } => {
                if let Some(i) = found {
                    let s = self.sessions[i];
                    if s.mux == mux
                        && matches!(s.phase, Phase::Download { size: n, .. } if n == size)
                    {
                        if s.fresh() {
                            self.sessions[i].deadline = now + self.config.timeout;
                            self.send(client, session, UsdoBody::DownloadInitiateResponse { mux });
                        }
                        return;
                    }
                }
                self.drop_session(found, od);
                if let Err(Fail(mux, code)) = check_download(od, mux, data_type, size) {
                    self.send_abort_301(client, session, mux, code);
                    return;
                }
                let phase = Phase::Download {
                    received: 0,
                    size,
                    counter: 0,
                };
                if self.open(now, client, session, mux, phase) {
                    self.send(client, session, UsdoBody::DownloadInitiateResponse { mux });
                }
            }
            UsdoBody::Upload { mux } => {
                if let Some(i) = found {
                    let s = self.sessions[i];
                    if s.mux == mux && matches!(s.phase, Phase::Upload { .. }) {
                        if s.fresh() {
                            self.sessions[i].deadline = now + self.config.timeout;
                            let Phase::Upload { len, .. } = s.phase else {
                                return;
                            };
                            let data_type = od.data_type(mux);
                            self.send(
                                client,
                                session,
                                UsdoBody::UploadInitiateResponse {
                                    mux,
                                    data_type,
                                    size: len,
                                },
                            );
                        }
                        return;
                    }
                }
                self.drop_session(found, od);
                self.on_upload(now, client, session, mux, od);
            }
            UsdoBody::DownloadSegment { counter, data } => {
                self.on_download_data(now, client, session, found, Some(counter), data, od)
            }
            UsdoBody::DownloadEnd { data } => {
                self.on_download_data(now, client, session, found, None, data, od)
            }
            UsdoBody::UploadSegment { counter } => {
                self.on_upload_segment(now, client, session, found, counter, od)
            }
            // Responses were filtered out above.
            _ => {}
        }
    }

    fn on_upload<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        client: u8,
        session: u8,
        mux: Multiplexer,
        od: &mut O,
    ) {
        let info = match readable(od, mux) {
            Ok(info) => info,
            Err(Fail(mux, code)) => return self.send_abort_301(client, session, mux, code),
        };
        let data_type = od.data_type(mux);
        if info.len as usize <= MAX_EXPEDITED {
            let mut buf = [0u8; MAX_EXPEDITED];
            let n = info.len as usize;
            match read_exact(od, mux, 0, &mut buf[..n]) {
                Ok(_) => {
                    self.send(
                        client,
                        session,
                        UsdoBody::UploadExpeditedResponse {
                            mux,
                            data_type,
                            data: &buf[..n],
                        },
                    );
                    self.events.push(UsdoServerEvent::Uploaded {
                        client,
                        mux,
                        len: info.len,
                    });
                }
                Err(Fail(mux, code)) => self.send_abort_301(client, session, mux, code),
            }
            return;
        }
        let phase = Phase::Upload {
            offset: 0,
            len: info.len,
            counter: 0,
        };
        if self.open(now, client, session, mux, phase) {
            self.send(
                client,
                session,
                UsdoBody::UploadInitiateResponse {
                    mux,
                    data_type,
                    size: info.len,
                },
            );
        }
    }

    /// A download segment (`counter` set) or the download end.
    #[allow(clippy::too_many_arguments)]
    fn on_download_data<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        client: u8,
        session: u8,
        found: Option<usize>,
        counter: Option<u8>,
        data: &[u8],
        od: &mut O,
    ) {
        let Some(i) = found else {
            return self.send_abort(
                client,
                session,
                Multiplexer::default(),
                UsdoAbortCode::UNKNOWN_SESSION,
            );
        };
        let s = self.sessions[i];
        let Phase::Download {
            received,
            size,
            counter: expected,
        } = s.phase
        else {
            return self.fail(i, UsdoAbortCode::INVALID_COMMAND, od);
        };
        if let Some(c) = counter
            && c != expected
        {
            match stale(expected, c, received / SEGMENT_DATA as u32) {
                // The client repeated the segment just confirmed: confirm it again.
                Some(1) => {
                    self.sessions[i].deadline = now + self.config.timeout;
                    self.send(
                        client,
                        session,
                        UsdoBody::DownloadSegmentResponse { counter: c },
                    );
                }
                // An older repeat, answered already.
                Some(_) => {}
                None => self.fail(i, UsdoAbortCode::INVALID_COUNTER, od),
            }
            return;
        }
        let end = received + data.len() as u32;
        // A full segment must leave at least one byte for the end frame.
        let fits = match counter {
            Some(_) => end < size,
            None => end == size,
        };
        if received.checked_add(data.len() as u32).is_none() || !fits {
            return self.fail(i, UsdoAbortCode::WRONG_SIZE, od);
        }
        if let Err(code) = od.write(s.mux, received, data) {
            return self.fail(i, UsdoAbortCode::from_cia301_or_general(code), od);
        }
        match counter {
            Some(c) => {
                self.sessions[i].phase = Phase::Download {
                    received: end,
                    size,
                    counter: c.wrapping_add(1),
                };
                self.sessions[i].deadline = now + self.config.timeout;
                self.send(
                    client,
                    session,
                    UsdoBody::DownloadSegmentResponse { counter: c },
                );
            }
            None => {
                if let Err(code) = od.commit(s.mux, size) {
                    return self.fail(i, UsdoAbortCode::from_cia301_or_general(code), od);
                }
                self.sessions.swap_remove(i);
                self.send(client, session, UsdoBody::DownloadEndResponse);
                self.events.push(UsdoServerEvent::Downloaded {
                    client,
                    mux: s.mux,
                    len: size,
                });
            }
        }
    }

    fn on_upload_segment<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        client: u8,
        session: u8,
        found: Option<usize>,
        counter: u8,
        od: &mut O,
    ) {
        let Some(i) = found else {
            return self.send_abort(
                client,
                session,
                Multiplexer::default(),
                UsdoAbortCode::UNKNOWN_SESSION,
            );
        };
        let s = self.sessions[i];
        let Phase::Upload {
            offset,
            len,
            counter: expected,
        } = s.phase
        else {
            return self.fail(i, UsdoAbortCode::INVALID_COMMAND, od);
        };
        // The segment just sent, asked again: send it again; older repeats were answered.
        let (offset, repeat) = if counter == expected {
            (offset, false)
        } else {
            match stale(expected, counter, offset / SEGMENT_DATA as u32) {
                Some(1) => (offset - SEGMENT_DATA as u32, true),
                Some(_) => return,
                None => return self.fail(i, UsdoAbortCode::INVALID_COUNTER, od),
            }
        };
        let rest = len - offset;
        let mut buf = [0u8; SEGMENT_DATA];
        if rest as usize > SEGMENT_DATA {
            if let Err(Fail(_, code)) = read_exact(od, s.mux, offset, &mut buf) {
                return self.fail(i, UsdoAbortCode::from_cia301_or_general(code), od);
            }
            if !repeat {
                self.sessions[i].phase = Phase::Upload {
                    offset: offset + SEGMENT_DATA as u32,
                    len,
                    counter: counter.wrapping_add(1),
                };
            }
            self.sessions[i].deadline = now + self.config.timeout;
            self.send(
                client,
                session,
                UsdoBody::UploadSegmentResponse {
                    counter,
                    data: &buf,
                },
            );
        } else {
            let n = rest as usize;
            if let Err(Fail(_, code)) = read_exact(od, s.mux, offset, &mut buf[..n]) {
                return self.fail(i, UsdoAbortCode::from_cia301_or_general(code), od);
            }
            self.sessions.swap_remove(i);
            self.send(client, session, UsdoBody::UploadEnd { data: &buf[..n] });
            self.events.push(UsdoServerEvent::Uploaded {
                client,
                mux: s.mux,
                len,
            });
        }
    }

    /// Starts a session; refuses with [`ABORT_BUSY`] when all are taken.
    fn open(
        &mut self,
        now: Instant,
        client: u8,
        session: u8,
        mux: Multiplexer,
        phase: Phase,
    ) -> bool {
        let s = Session {
            client,
            session,
            mux,
            deadline: now + self.config.timeout,
            phase,
        };
        if self.sessions.push(s).is_err() {
            self.send_abort(client, session, mux, ABORT_BUSY);
            return false;
        }
        true
    }

    /// Ends session `found` silently (a new initiate replaced it).
    fn drop_session<O: ObjectAccess + ?Sized>(&mut self, found: Option<usize>, od: &mut O) {
        if let Some(i) = found {
            let s = self.sessions.swap_remove(i);
            if matches!(s.phase, Phase::Download { .. }) {
                od.discard(s.mux);
            }
        }
    }

    /// Ends session `i` with `code`.
    fn fail<O: ObjectAccess + ?Sized>(&mut self, i: usize, code: UsdoAbortCode, od: &mut O) {
        let s = self.sessions.swap_remove(i);
        if matches!(s.phase, Phase::Download { .. }) {
            od.discard(s.mux);
        }
        self.send_abort(s.client, s.session, s.mux, code);
    }

    fn send_abort_301(&mut self, client: u8, session: u8, mux: Multiplexer, code: AbortCode) {
        self.send_abort(
            client,
            session,
            mux,
            UsdoAbortCode::from_cia301_or_general(code),
        );
    }

    fn send_abort(&mut self, client: u8, session: u8, mux: Multiplexer, code: UsdoAbortCode) {
        self.send(client, session, UsdoBody::Abort { mux, code });
        self.events.push(UsdoServerEvent::Aborted {
            client,
            session,
            mux,
            code,
        });
    }

    fn send(&mut self, client: u8, session: u8, body: UsdoBody<'_>) {
        let msg = UsdoMessage {
            destination: client,
            session,
            body,
        };
        // Our own messages always encode (data lengths are bounded above).
        if let Ok(bytes) = msg.to_bytes() {
            self.tx.push(bytes);
        }
    }
}

/// How far counter `c` lies behind `expected` when it names one of the `done` segments already
/// handled (a repeated request; at most 128 back, so the modulo-256 counter stays
/// unambiguous); `None` for a counter that cannot be a repeat.
pub(crate) fn stale(expected: u8, c: u8, done: u32) -> Option<u8> {
    let behind = expected.wrapping_sub(c);
    (behind >= 1 && u32::from(behind) <= done.min(128)).then_some(behind)
}

/// The object takes a download of `len` bytes of type `data_type`.
fn check_download<O: ObjectAccess + ?Sized>(
    od: &mut O,
    mux: Multiplexer,
    data_type: DataType,
    len: u32,
) -> Result<(), Fail> {
    let info = writable(od, mux)?;
    let own = od.data_type(mux);
    if own != DataType::DOMAIN && data_type != DataType::DOMAIN && own != data_type {
        return Err(Fail(mux, AbortCode::LENGTH_MISMATCH));
    }
    info.accepts.check(len).map_err(|c| Fail(mux, c))
}
