//! The USDO client (CiA 1301): reads and writes objects of any CANopen FD node, up to
//! [`MAX_SESSIONS`] transfers at once, each under its own session-ID, as a sans-IO machine.
//!
//! # Call order (as [`Client`](crate::Client))
//!
//! 1. [`UsdoClient::new`] with this node's node-ID (the client's CAN-ID is 0x600 + it) and a
//!    [`UsdoClientConfig`].
//! 2. Start transfers: [`UsdoClient::start_upload`] into a [`Sink`],
//!    [`UsdoClient::start_download`] from a [`Source`]. Each returns the session-ID that names
//!    the transfer in its event. A start while [`MAX_SESSIONS`] transfers run or wait to be
//!    polled is refused with [`UsdoBusy`], handing the buffer back.
//! 3. Loop:
//!    - send every frame [`UsdoClient::poll_transmit_frame`] yields;
//!    - feed every CAN FD frame on 0x580 + any server to [`UsdoClient::handle_frame`] (or
//!      [`UsdoClient::handle_response`] with the server's node-ID and the data bytes);
//!    - when the clock reaches [`UsdoClient::poll_timeout`], call
//!      [`UsdoClient::handle_timeout`];
//!    - drain [`UsdoClient::poll_event`]: exactly one [`UsdoEvent`] ends each transfer and
//!      returns its buffer.
//! 4. [`UsdoClient::abort`] cancels a transfer; an abort frame goes to the server. A master
//!    calls it when the application drops its request.
//!
//! # Behaviour
//!
//! - Values of up to 56 bytes are written expedited, longer ones segmented (60 bytes per
//!   segment, each confirmed with its counter). The server chooses how to answer a read.
//! - Responses are matched by server node-ID and session-ID; frames for another destination,
//!   another session or an earlier step of this one (a repeated confirmation or segment) are
//!   ignored. A
//!   response that fits no step, a counter ahead of the one asked for, or sizes that do not add
//!   up end the transfer with an abort to the server ([`UsdoErrorKind::Protocol`]).
//! - The timeout is the time the server may take for each response. On expiry the client sends
//!   [`ABORT_TIMEOUT`] and reports [`UsdoErrorKind::Timeout`]; later responses are ignored.

use canola_frame::{CanId, Duration, FdFrame, Instant, NodeId};

use crate::buffer::{Sink, Source};
use crate::client::Buffer;
use crate::queue::Ring;
use crate::usdo::abort::UsdoAbortCode;
use crate::usdo::assumed::{
    ABORT_CANCELLED, ABORT_GENERAL, ABORT_TIMEOUT, DEFAULT_TIMEOUT_MS, REQUEST_BASE, RESPONSE_BASE,
    SEGMENT_DATA,
};
use crate::usdo::server::{MAX_SESSIONS, UsdoBytes, stale};
use crate::usdo::wire::{DataType, MAX_EXPEDITED, UsdoBody, UsdoMessage};
use crate::wire::Multiplexer;

/// Client settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UsdoClientConfig {
    /// How long the server may take for each response. Default [`DEFAULT_TIMEOUT_MS`].
    pub timeout: Duration,
}

impl Default for UsdoClientConfig {
    fn default() -> Self {
        Self {
            timeout: Duration::from_millis(DEFAULT_TIMEOUT_MS),
        }
    }
}

/// A transfer was refused: [`MAX_SESSIONS`] run or wait to be polled. Holds the buffer.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("all USDO sessions are in use")]
pub struct UsdoBusy<T>(pub T);

debug_as_display!(UsdoBusy<T>);

/// What ended a USDO transfer.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum UsdoErrorKind {
    /// The server aborted with this code.
    #[error("server aborted: {0}")]
    ServerAbort(UsdoAbortCode),
    /// The server did not answer in time; this code was sent.
    #[error("no response from the server (timeout); sent abort {0}")]
    Timeout(UsdoAbortCode),
    /// The caller cancelled; this code was sent.
    #[error("cancelled; sent abort {0}")]
    Cancelled(UsdoAbortCode),
    /// The server broke the protocol; this code was sent.
    #[error("protocol violation by the server; sent abort {0}")]
    Protocol(UsdoAbortCode),
    /// The sink could not take the data; this code was sent.
    #[error("the upload does not fit the buffer; sent abort {0}")]
    BufferFull(UsdoAbortCode),
}

debug_as_display!(UsdoErrorKind);

impl UsdoErrorKind {
    /// The 1-byte code that went over the bus, in either direction.
    pub const fn abort_code(&self) -> UsdoAbortCode {
        match *self {
            Self::ServerAbort(c)
            | Self::Timeout(c)
            | Self::Cancelled(c)
            | Self::Protocol(c)
            | Self::BufferFull(c) => c,
        }
    }
}

/// Why a transfer failed, with which server, session and object.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("USDO {mux} on node {server}, session {session}: {kind}")]
pub struct UsdoTransferError {
    /// The server's node-ID.
    pub server: u8,
    /// The session-ID.
    pub session: u8,
    /// The object.
    pub mux: Multiplexer,
    /// What went wrong.
    pub kind: UsdoErrorKind,
}

debug_as_display!(UsdoTransferError);

/// How a transfer ended. Exactly one event ends every started transfer.
#[derive(Debug)]
pub enum UsdoEvent<S, D> {
    /// The upload finished; `sink` holds the data.
    Uploaded {
        /// The server's node-ID.
        server: u8,
        /// The session-ID the start returned.
        session: u8,
        /// The object.
        mux: Multiplexer,
        /// The data type the server announced.
        data_type: DataType,
        /// The caller's sink.
        sink: S,
        /// Bytes received.
        len: u32,
    },
    /// The download finished and the server confirmed it.
    Downloaded {
        /// The server's node-ID.
        server: u8,
        /// The session-ID the start returned.
        session: u8,
        /// The object.
        mux: Multiplexer,
        /// The caller's source.
        source: D,
    },
    /// The transfer failed.
    Failed {
        /// What went wrong.
        error: UsdoTransferError,
        /// The caller's buffer.
        buffer: Buffer<S, D>,
    },
}

#[derive(Debug, Clone, Copy)]
enum Step {
    /// Upload request sent.
    UploadInitiate,
    /// Upload segment `counter` requested; `size` announced, `received` so far.
    UploadSegment {
        counter: u8,
        size: u32,
        received: u32,
    },
    /// Expedited download sent.
    DownloadExpedited,
    /// Download initiate sent.
    DownloadInitiate,
    /// Segment `counter` sent; `sent` bytes so far including it.
    DownloadSegment { counter: u8, sent: u32 },
    /// Download end sent.
    DownloadEnd,
}

#[derive(Debug)]
enum Buf<S, D> {
    Up(S, DataType),
    Down(D, u32),
}

#[derive(Debug)]
struct Transfer<S, D> {
    server: u8,
    session: u8,
    mux: Multiplexer,
    deadline: Instant,
    step: Step,
    buf: Buf<S, D>,
}

/// The USDO client of one node. See the [module docs](self) for the call order.
#[derive(Debug)]
pub struct UsdoClient<S, D> {
    node: NodeId,
    config: UsdoClientConfig,
    transfers: heapless::Vec<Transfer<S, D>, MAX_SESSIONS>,
    /// The session-ID the next transfer tries first.
    next_session: u8,
    tx: Ring<UsdoBytes, 16>,
    events: Ring<UsdoEvent<S, D>, MAX_SESSIONS>,
    pending_events: usize,
}

/// A request a response step makes the client send.
enum Request {
    UploadSegment(u8),
    Segment(u8, [u8; SEGMENT_DATA]),
    End([u8; SEGMENT_DATA], usize),
}

/// The next piece of a segmented download after `sent` bytes: a full segment while more than
/// one segment's worth is left, the end otherwise.
fn next_segment<D: Source>(source: &mut D, len: u32, sent: u32, counter: u8) -> (Step, Request) {
    let mut buf = [0u8; SEGMENT_DATA];
    let rest = len.saturating_sub(sent);
    if rest as usize > SEGMENT_DATA {
        source.read(sent, &mut buf);
        (
            Step::DownloadSegment {
                counter,
                sent: sent + SEGMENT_DATA as u32,
            },
            Request::Segment(counter, buf),
        )
    } else {
        let n = source.read(sent, &mut buf[..rest as usize]);
        (Step::DownloadEnd, Request::End(buf, n))
    }
}

enum Outcome {
    /// Keep going (or ignore the frame).
    Continue,
    /// Done.
    Done,
    /// Ends with this error.
    Fail(UsdoErrorKind),
}

impl<S: Sink, D: Source> UsdoClient<S, D> {
    /// A client for node `node` with no transfer.
    pub fn new(node: NodeId, config: UsdoClientConfig) -> Self {
        Self {
            node,
            config,
            transfers: heapless::Vec::new(),
            next_session: 1,
            tx: Ring::new(),
            events: Ring::new(),
            pending_events: 0,
        }
    }

    /// This node.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// Transfers running.
    pub fn active(&self) -> usize {
        self.transfers.len()
    }

    /// Whether no transfer runs and no event waits.
    pub fn is_idle(&self) -> bool {
        self.transfers.is_empty() && self.pending_events == 0
    }

    fn free_session(&mut self, server: u8) -> Option<u8> {
        if self.transfers.len() + self.pending_events >= MAX_SESSIONS {
            return None;
        }
        for _ in 0..255 {
            let s = self.next_session;
            self.next_session = if s == 255 { 1 } else { s + 1 };
            if !self
                .transfers
                .iter()
                .any(|t| t.server == server && t.session == s)
            {
                return Some(s);
            }
        }
        None
    }

    /// Reads `mux` from node `server` into `sink`; returns the session-ID.
    pub fn start_upload(
        &mut self,
        now: Instant,
        server: NodeId,
        mux: Multiplexer,
        sink: S,
    ) -> Result<u8, UsdoBusy<S>> {
        let Some(session) = self.free_session(server.get()) else {
            return Err(UsdoBusy(sink));
        };
        self.push(Transfer {
            server: server.get(),
            session,
            mux,
            deadline: now + self.config.timeout,
            step: Step::UploadInitiate,
            buf: Buf::Up(sink, DataType::DOMAIN),
        });
        self.send(server.get(), session, UsdoBody::Upload { mux });
        Ok(session)
    }

    /// Writes all of `source` to `mux` on node `server`, announcing `data_type`; returns the
    /// session-ID.
    pub fn start_download(
        &mut self,
        now: Instant,
        server: NodeId,
        mux: Multiplexer,
        data_type: DataType,
        mut source: D,
    ) -> Result<u8, UsdoBusy<D>> {
        let Some(session) = self.free_session(server.get()) else {
            return Err(UsdoBusy(source));
        };
        let len = source.len();
        let step = if len as usize <= MAX_EXPEDITED {
            let mut buf = [0u8; MAX_EXPEDITED];
            let n = source.read(0, &mut buf[..len as usize]);
            self.send(
                server.get(),
                session,
                UsdoBody::DownloadExpedited {
                    mux,
                    data_type,
                    data: &buf[..n],
                },
            );
            Step::DownloadExpedited
        } else {
            self.send(
                server.get(),
                session,
                UsdoBody::DownloadInitiate {
                    mux,
                    data_type,
                    size: len,
                },
            );
            Step::DownloadInitiate
        };
        self.push(Transfer {
            server: server.get(),
            session,
            mux,
            deadline: now + self.config.timeout,
            step,
            buf: Buf::Down(source, len),
        });
        Ok(session)
    }

    fn push(&mut self, t: Transfer<S, D>) {
        // free_session checked the room.
        let _ = self.transfers.push(t);
    }

    /// Cancels the transfer with `session` on `server`: abort [`ABORT_CANCELLED`] goes out
    /// and its event reports [`UsdoErrorKind::Cancelled`]. Returns whether it ran.
    pub fn abort(&mut self, server: NodeId, session: u8) -> bool {
        let Some(i) = self
            .transfers
            .iter()
            .position(|t| t.server == server.get() && t.session == session)
        else {
            return false;
        };
        self.finish(i, Err(UsdoErrorKind::Cancelled(ABORT_CANCELLED)));
        true
    }

    /// Feeds a frame if it is on a USDO response identifier (0x580 + server); returns whether
    /// it was.
    pub fn handle_frame(&mut self, now: Instant, frame: &FdFrame) -> bool {
        let Some(cob) = frame.cob_id() else {
            return false;
        };
        let server = (cob & 0x7F) as u8;
        if cob & 0x780 != RESPONSE_BASE || server == 0 {
            return false;
        }
        self.handle_response(now, server, frame.data());
        true
    }

    /// [`poll_transmit`](Self::poll_transmit) as a CAN FD frame on 0x600 + this node, with the
    /// bit-rate switch set (its data phase runs at the bus's data bit rate).
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<FdFrame> {
        let data = self.poll_transmit()?;
        let id = CanId::standard(REQUEST_BASE + u16::from(self.node.get())).ok()?;
        FdFrame::new(id, &data).ok().map(|f| f.with_brs(true))
    }

    /// The next frame's data bytes, padded to a CAN FD length.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<UsdoBytes> {
        self.tx.pop()
    }

    /// The next completion, if any.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<UsdoEvent<S, D>> {
        let e = self.events.pop()?;
        self.pending_events -= 1;
        Some(e)
    }

    /// When [`handle_timeout`](Self::handle_timeout) must be called next.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.transfers.iter().map(|t| t.deadline).min()
    }

    /// Ends every transfer whose server was silent past its deadline.
    pub fn handle_timeout(&mut self, now: Instant) {
        while let Some(i) = self.transfers.iter().position(|t| now >= t.deadline) {
            self.finish(i, Err(UsdoErrorKind::Timeout(ABORT_TIMEOUT)));
        }
    }

    /// Feeds the data bytes of one response frame from node `server` (the low 7 bits of its
    /// CAN-ID).
    pub fn handle_response(&mut self, now: Instant, server: u8, data: &[u8]) {
        let Ok(msg) = UsdoMessage::parse(data) else {
            return;
        };
        if msg.destination != self.node.get() || !msg.body.is_response() {
            return;
        }
        let Some(i) = self
            .transfers
            .iter()
            .position(|t| t.server == server && t.session == msg.session)
        else {
            return;
        };
        let outcome = self.step(i, msg.body);
        match outcome {
            Outcome::Continue => {}
            Outcome::Done => self.finish(i, Ok(())),
            Outcome::Fail(kind) => self.finish(i, Err(kind)),
        }
        // Any step that went on rearms the response timer.
        if let Some(t) = self.transfers.get_mut(i)
            && t.server == server
            && t.session == msg.session
        {
            t.deadline = now + self.config.timeout;
        }
    }

    fn step(&mut self, i: usize, body: UsdoBody<'_>) -> Outcome {
        let protocol = |code| Outcome::Fail(UsdoErrorKind::Protocol(code));
        let unexpected = protocol(UsdoAbortCode::INVALID_COMMAND);
        let t = &mut self.transfers[i];
        let (server, session, mux) = (t.server, t.session, t.mux);
        if let UsdoBody::Abort { code, .. } = body {
            return Outcome::Fail(UsdoErrorKind::ServerAbort(code));
        }
        let mut request = None;
        let outcome = match (&mut t.buf, t.step, body) {
            (
                Buf::Up(sink, dt),
                Step::UploadInitiate,
                UsdoBody::UploadExpeditedResponse {
                    mux: m,
                    data_type,
                    data,
                },
            ) if m == mux => {
                *dt = data_type;
                match sink
                    .expect_size(data.len() as u32)
                    .and_then(|_| sink.write(data))
                {
                    Ok(()) => {
                        t.step = Step::UploadSegment {
                            counter: 0,
                            size: data.len() as u32,
                            received: data.len() as u32,
                        };
                        Outcome::Done
                    }
                    Err(_) => Outcome::Fail(UsdoErrorKind::BufferFull(ABORT_GENERAL)),
                }
            }
            (
                Buf::Up(sink, dt),
                Step::UploadInitiate,
                UsdoBody::UploadInitiateResponse {
                    mux: m,
                    data_type,
                    size,
                },
            ) if m == mux => {
                *dt = data_type;
                if sink.expect_size(size).is_err() {
                    Outcome::Fail(UsdoErrorKind::BufferFull(ABORT_GENERAL))
                } else {
                    t.step = Step::UploadSegment {
                        counter: 0,
                        size,
                        received: 0,
                    };
                    request = Some(Request::UploadSegment(0));
                    Outcome::Continue
                }
            }
            // Late answers to a request of the same step or an earlier one.
            (Buf::Up(..), Step::UploadInitiate, _) => unexpected,
            (
                Buf::Up(..),
                Step::UploadSegment { .. },
                UsdoBody::UploadExpeditedResponse { .. } | UsdoBody::UploadInitiateResponse { .. },
            ) => Outcome::Continue,
            (
                Buf::Up(sink, _),
                Step::UploadSegment {
                    counter,
                    size,
                    received,
                },
                UsdoBody::UploadSegmentResponse { counter: c, data },
            ) => {
                if c != counter && stale(counter, c, received / SEGMENT_DATA as u32).is_some() {
                    Outcome::Continue
                } else if c != counter {
                    protocol(UsdoAbortCode::INVALID_COUNTER)
                } else if u64::from(received) + SEGMENT_DATA as u64 >= u64::from(size) {
                    protocol(UsdoAbortCode::WRONG_SIZE)
                } else if sink.write(data).is_err() {
                    Outcome::Fail(UsdoErrorKind::BufferFull(ABORT_GENERAL))
                } else {
                    let next = counter.wrapping_add(1);
                    t.step = Step::UploadSegment {
                        counter: next,
                        size,
                        received: received + SEGMENT_DATA as u32,
                    };
                    request = Some(Request::UploadSegment(next));
                    Outcome::Continue
                }
            }
            (
                Buf::Up(sink, _),
                Step::UploadSegment {
                    size,
                    received,
                    counter,
                },
                UsdoBody::UploadEnd { data },
            ) => {
                if u64::from(received) + data.len() as u64 != u64::from(size) {
                    protocol(UsdoAbortCode::WRONG_SIZE)
                } else if sink.write(data).is_err() {
                    Outcome::Fail(UsdoErrorKind::BufferFull(ABORT_GENERAL))
                } else {
                    t.step = Step::UploadSegment {
                        counter,
                        size,
                        received: size,
                    };
                    Outcome::Done
                }
            }
            (Buf::Up(..), _, _) => unexpected,
            (
                Buf::Down(..),
                Step::DownloadExpedited,
                UsdoBody::DownloadExpeditedResponse { mux: m },
            ) => {
                if m == mux {
                    Outcome::Done
                } else {
                    unexpected
                }
            }
            (
                Buf::Down(source, len),
                Step::DownloadInitiate,
                UsdoBody::DownloadInitiateResponse { mux: m },
            ) if m == mux => {
                let (step, body_bytes) = next_segment(source, *len, 0, 0);
                t.step = step;
                request = Some(body_bytes);
                Outcome::Continue
            }
            (
                Buf::Down(source, len),
                Step::DownloadSegment { counter, sent },
                UsdoBody::DownloadSegmentResponse { counter: c },
            ) => {
                if c == counter {
                    let (step, body_bytes) =
                        next_segment(source, *len, sent, counter.wrapping_add(1));
                    t.step = step;
                    request = Some(body_bytes);
                    Outcome::Continue
                } else if stale(counter, c, sent / SEGMENT_DATA as u32 - 1).is_some() {
                    Outcome::Continue
                } else {
                    protocol(UsdoAbortCode::INVALID_COUNTER)
                }
            }
            (
                Buf::Down(..),
                Step::DownloadSegment { .. } | Step::DownloadEnd,
                UsdoBody::DownloadInitiateResponse { .. }
                | UsdoBody::DownloadSegmentResponse { .. },
            ) => Outcome::Continue,
            (Buf::Down(..), Step::DownloadEnd, UsdoBody::DownloadEndResponse) => Outcome::Done,
            (Buf::Down(..), _, _) => unexpected,
        };
        if let Some(req) = request {
            self.send_request(server, session, req);
        }
        outcome
    }

    fn send_request(&mut self, server: u8, session: u8, request: Request) {
        match request {
            Request::UploadSegment(counter) => {
                self.send(server, session, UsdoBody::UploadSegment { counter })
            }
            Request::Segment(counter, data) => self.send(
                server,
                session,
                UsdoBody::DownloadSegment {
                    counter,
                    data: &data,
                },
            ),
            Request::End(data, n) => {
                self.send(server, session, UsdoBody::DownloadEnd { data: &data[..n] })
            }
        }
    }

    /// Ends transfer `i`, queuing its event and, for a local failure, an abort to the server.
    fn finish(&mut self, i: usize, result: Result<(), UsdoErrorKind>) {
        let t = self.transfers.swap_remove(i);
        let event = match (result, t.buf) {
            (Ok(()), Buf::Up(sink, data_type)) => UsdoEvent::Uploaded {
                server: t.server,
                session: t.session,
                mux: t.mux,
                data_type,
                sink,
                len: match t.step {
                    Step::UploadSegment { received, .. } => received,
                    _ => 0,
                },
            },
            (Ok(()), Buf::Down(source, _)) => UsdoEvent::Downloaded {
                server: t.server,
                session: t.session,
                mux: t.mux,
                source,
            },
            (Err(kind), buf) => {
                if !matches!(kind, UsdoErrorKind::ServerAbort(_)) {
                    self.send(
                        t.server,
                        t.session,
                        UsdoBody::Abort {
                            mux: t.mux,
                            code: kind.abort_code(),
                        },
                    );
                }
                UsdoEvent::Failed {
                    error: UsdoTransferError {
                        server: t.server,
                        session: t.session,
                        mux: t.mux,
                        kind,
                    },
                    buffer: match buf {
                        Buf::Up(s, _) => Buffer::Sink(s),
                        Buf::Down(d, _) => Buffer::Source(d),
                    },
                }
            }
        };
        self.events.push(event);
        self.pending_events += 1;
    }

    fn send(&mut self, server: u8, session: u8, body: UsdoBody<'_>) {
        let msg = UsdoMessage {
            destination: server,
            session,
            body,
        };
        if let Ok(bytes) = msg.to_bytes() {
            self.tx.push(bytes);
        }
    }
}
