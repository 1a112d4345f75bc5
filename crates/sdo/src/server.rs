//! The SDO server (CiA 301 §7.2.4.3) over an object-access trait: what a device (or the
//! device simulator) runs to serve one SDO channel.
//!
//! # Call order
//!
//! 1. [`Server::new`] with a [`ServerConfig`].
//! 2. For every frame on the request COB-ID (0x600 + node by default) call
//!    [`Server::handle_request`] with the device's [`ObjectAccess`] implementation.
//! 3. Send every frame [`Server::poll_transmit`] yields on the response COB-ID (0x580 + node).
//! 4. When the clock reaches [`Server::poll_timeout`], call [`Server::handle_timeout`] (a client
//!    that stops half-way is aborted with 0x05040000).
//! 5. Optionally drain [`Server::poll_event`] for completed and aborted transfers.
//!
//! # Objects
//!
//! The server asks [`ObjectAccess::info`] for existence, access and length, and answers the
//! CiA 301 abort codes itself: read of a write-only object 0x06010001, write of a read-only
//! object 0x06010002, wrong lengths 0x06070010 / 0x06070012 / 0x06070013. Whatever
//! `info`, `read`, `write` or `commit` return as `Err(code)` is sent as the abort code
//! (0x06020000 object does not exist, 0x06090011 sub-index does not exist, 0x06090030 value
//! range, ...). Data moves in pieces of at most 889 bytes (one sub-block), so a multi-KiB
//! DOMAIN never has to sit in one buffer.
//!
//! A new initiate request while a transfer runs ends the old transfer (reported as
//! [`ServerEvent::Superseded`]) and starts the new one: the client has given up on the old one.

use canola_frame::{CanFrame, Duration, Instant};

use crate::abort::AbortCode;
use crate::cob::SdoCobIds;
use crate::crc::Crc16;
use crate::queue::Ring;
use crate::subblock::Receiver;
pub(crate) mod object;

pub use object::{Access, LengthRule, ObjectAccess, ObjectInfo};
use object::{Fail, check_end, check_progress, read_exact, readable, writable};

use crate::wire::{
    BlockSegment, ClientRequest, DecodeError, Initiate, MAX_BLOCK_SIZE, Multiplexer, Segment,
    ServerResponse, is_abort, segments_for, unused_in_last,
};

/// Bytes of one full sub-block.
const BLOCK_BYTES: usize = MAX_BLOCK_SIZE as usize * 7;

/// Server settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// How long the client may take for its next request within a transfer. Default 1 s.
    pub timeout: Duration,
    /// Segments per sub-block the server accepts in block download, 1..=127. Default 127.
    pub block_size: u8,
    /// Whether the server supports CRC in block transfers. Default on.
    pub crc: bool,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            timeout: Duration::from_secs(1),
            block_size: MAX_BLOCK_SIZE,
            crc: true,
        }
    }
}

/// What happened on the server, for logs and the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServerEvent {
    /// A download completed and was committed.
    Downloaded {
        /// The object.
        mux: Multiplexer,
        /// Bytes written.
        len: u32,
    },
    /// An upload completed.
    Uploaded {
        /// The object.
        mux: Multiplexer,
        /// Bytes read.
        len: u32,
    },
    /// The server aborted a transfer (or refused to start one) with this code.
    Aborted {
        /// The object.
        mux: Multiplexer,
        /// The code sent.
        code: AbortCode,
    },
    /// The client aborted the transfer.
    AbortedByClient {
        /// The object.
        mux: Multiplexer,
        /// The client's code.
        code: AbortCode,
    },
    /// A new initiate request replaced an unfinished transfer.
    Superseded {
        /// The object of the abandoned transfer.
        mux: Multiplexer,
    },
}

impl core::fmt::Display for ServerEvent {
    /// `SDO download of 0x2000:01 done, 4 bytes`, `SDO aborted 0x2000:01: 0x06010002 (...)`,
    /// `SDO client aborted ...`, `SDO transfer of 0x2000:01 superseded by a new request`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Downloaded { mux, len } => write!(f, "SDO download of {mux} done, {len} bytes"),
            Self::Uploaded { mux, len } => write!(f, "SDO upload of {mux} done, {len} bytes"),
            Self::Aborted { mux, code } => write!(f, "SDO server aborted {mux}: {code}"),
            Self::AbortedByClient { mux, code } => write!(f, "SDO client aborted {mux}: {code}"),
            Self::Superseded { mux } => {
                write!(f, "SDO transfer of {mux} superseded by a new request")
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum State {
    Idle,
    /// Segmented download: next toggle expected, bytes received.
    Download {
        mux: Multiplexer,
        toggle: bool,
        received: u32,
        size: Option<u32>,
        accepts: LengthRule,
    },
    /// Segmented upload: next toggle expected, bytes sent.
    Upload {
        mux: Multiplexer,
        toggle: bool,
        offset: u32,
        len: u32,
    },
    /// Block download, receiving sub-blocks (see [`crate::subblock`]), or, with `held` set
    /// to the transfer's last segment, waiting for the end.
    BlockDownload {
        mux: Multiplexer,
        crc: bool,
        receiver: Receiver,
        received: u32,
        size: Option<u32>,
        accepts: LengthRule,
        held: Option<BlockSegment>,
    },
    /// Block upload initiated; waiting for the start command.
    BlockUploadStart {
        mux: Multiplexer,
        crc: bool,
        blksize: u8,
        len: u32,
    },
    /// Block upload: sending a sub-block of `count` segments from the block buffer.
    BlockUpload {
        mux: Multiplexer,
        crc: bool,
        len: u32,
        acked: u32,
        total: u32,
        count: u8,
        sent: u8,
    },
    /// Block upload end sent; waiting for the client's end response.
    BlockUploadEnd {
        mux: Multiplexer,
        len: u32,
    },
}

impl State {
    fn mux(&self) -> Option<Multiplexer> {
        match *self {
            Self::Idle => None,
            Self::Download { mux, .. }
            | Self::Upload { mux, .. }
            | Self::BlockDownload { mux, .. }
            | Self::BlockUploadStart { mux, .. }
            | Self::BlockUpload { mux, .. }
            | Self::BlockUploadEnd { mux, .. } => Some(mux),
        }
    }

    fn is_download(&self) -> bool {
        matches!(self, Self::Download { .. } | Self::BlockDownload { .. })
    }
}

/// The SDO server machine for one channel. See the [module docs](self) for the call order.
#[derive(Debug)]
pub struct Server {
    config: ServerConfig,
    state: State,
    crc: Crc16,
    deadline: Option<Instant>,
    tx: Ring<[u8; 8], 4>,
    events: Ring<ServerEvent, 4>,
    /// The current sub-block of a block upload.
    block: [u8; BLOCK_BYTES],
}

impl Server {
    /// An idle server.
    pub fn new(config: ServerConfig) -> Self {
        let block_size = config.block_size.clamp(1, MAX_BLOCK_SIZE);
        Self {
            config: ServerConfig {
                block_size,
                ..config
            },
            state: State::Idle,
            crc: Crc16::new(),
            deadline: None,
            tx: Ring::new(),
            events: Ring::new(),
            block: [0; BLOCK_BYTES],
        }
    }

    /// The settings.
    pub fn config(&self) -> &ServerConfig {
        &self.config
    }

    /// Whether no transfer is in progress.
    pub fn is_idle(&self) -> bool {
        matches!(self.state, State::Idle)
    }

    /// The object of the transfer in progress.
    pub fn current(&self) -> Option<Multiplexer> {
        self.state.mux()
    }

    /// Feeds one frame's data from the client (the request COB-ID).
    pub fn handle_request<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        data: &[u8],
        od: &mut O,
    ) {
        let state = core::mem::replace(&mut self.state, State::Idle);
        let result = match state {
            State::BlockDownload { held: None, .. } if !is_abort(data) => {
                match BlockSegment::parse(data) {
                    Ok(seg) => self.on_block_segment(state, seg, od),
                    Err(_) => Ok(state),
                }
            }
            // A repeat of the transfer's last segment (its bytes may read as any request, an
            // abort among them).
            State::BlockDownload {
                held: Some(held), ..
            } if data == held.emit() => Ok(state),
            _ => match ClientRequest::parse(data) {
                Ok(req) => self.on_request(state, req, od),
                // A request too short for its command, while idle, is answered for the object
                // it names when it holds the
                // multiplexer; one that does not, while idle, cannot be placed and is dropped.
                Err(DecodeError::Short { .. }) if state.mux().is_none() => {
                    match crate::wire::short_frame_mux(data) {
                        Some(mux) => Err(Fail(mux, AbortCode::INVALID_COMMAND)),
                        None => Ok(state),
                    }
                }
                Err(DecodeError::UnknownCommand(_) | DecodeError::Short { .. }) => Err(Fail(
                    state.mux().unwrap_or_default(),
                    AbortCode::INVALID_COMMAND,
                )),
                Err(_) => Ok(state),
            },
        };
        match result {
            Ok(next) => {
                self.state = next;
                self.deadline = match next {
                    State::Idle => None,
                    _ => Some(now + self.config.timeout),
                };
            }
            Err(Fail(mux, code)) => {
                if state.is_download()
                    && let Some(m) = state.mux()
                {
                    od.discard(m);
                }
                self.abort(mux, code);
            }
        }
    }

    /// Feeds `frame` if it is a data frame on the channel's request identifier; returns
    /// whether it was. The frame adapter over [`handle_request`](Self::handle_request).
    pub fn handle_frame<O: ObjectAccess + ?Sized>(
        &mut self,
        now: Instant,
        ids: &SdoCobIds,
        frame: &CanFrame,
        od: &mut O,
    ) -> bool {
        let ours = ids.is_request(frame);
        if ours {
            self.handle_request(now, frame.data(), od);
        }
        ours
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on the channel's response identifier.
    #[must_use]
    pub fn poll_transmit_frame(&mut self, ids: &SdoCobIds) -> Option<CanFrame> {
        self.poll_transmit().map(|data| ids.response_frame(data))
    }

    /// Checks the timeout: a client silent for longer than the timeout within a transfer is
    /// sent abort 0x05040000 and the transfer is dropped.
    pub fn handle_timeout<O: ObjectAccess + ?Sized>(&mut self, now: Instant, od: &mut O) {
        if let (Some(deadline), Some(mux)) = (self.deadline, self.state.mux())
            && now >= deadline
        {
            if self.state.is_download() {
                od.discard(mux);
            }
            self.abort(mux, AbortCode::TIMEOUT);
        }
    }

    /// The next frame to send to the client (eight data bytes for the response COB-ID).
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<[u8; 8]> {
        if let Some(frame) = self.tx.pop() {
            return Some(frame);
        }
        let State::BlockUpload {
            acked,
            total,
            count,
            sent,
            ..
        } = &mut self.state
        else {
            return None;
        };
        if *sent >= *count {
            return None;
        }
        let start = usize::from(*sent) * 7;
        let mut data = [0u8; 7];
        data.copy_from_slice(&self.block[start..start + 7]);
        *sent += 1;
        Some(
            BlockSegment {
                seqno: *sent,
                last: *acked + u32::from(*sent) >= *total,
                data,
            }
            .emit(),
        )
    }

    /// The next event, if any (the last four are kept).
    #[must_use]
    pub fn poll_event(&mut self) -> Option<ServerEvent> {
        self.events.pop()
    }

    /// When [`handle_timeout`](Self::handle_timeout) must be called next, if a transfer runs.
    #[must_use]
    #[inline]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.deadline
    }

    fn abort(&mut self, mux: Multiplexer, code: AbortCode) {
        self.state = State::Idle;
        self.deadline = None;
        self.tx.clear();
        self.tx.push(ServerResponse::Abort { mux, code }.emit());
        self.events.push(ServerEvent::Aborted { mux, code });
    }

    fn send(&mut self, response: ServerResponse) {
        self.tx.push(response.emit());
    }

    fn on_request<O: ObjectAccess + ?Sized>(
        &mut self,
        state: State,
        req: ClientRequest,
        od: &mut O,
    ) -> Result<State, Fail> {
        let busy = state.mux();
        match req {
            ClientRequest::Abort { mux, code } => {
                return match busy {
                    Some(current) if mux == current || mux == Multiplexer::default() => {
                        if state.is_download() {
                            od.discard(current);
                        }
                        self.events
                            .push(ServerEvent::AbortedByClient { mux: current, code });
                        self.tx.clear();
                        Ok(State::Idle)
                    }
                    _ => Ok(state),
                };
            }
            ClientRequest::InitiateDownload { .. }
            | ClientRequest::InitiateUpload { .. }
            | ClientRequest::BlockDownloadInitiate { .. }
            | ClientRequest::BlockUploadInitiate { .. } => {
                if let Some(old) = busy {
                    if state.is_download() {
                        od.discard(old);
                    }
                    self.tx.clear();
                    self.events.push(ServerEvent::Superseded { mux: old });
                }
                return self.on_initiate(req, od);
            }
            _ => {}
        }
        let unexpected = Fail(busy.unwrap_or_default(), AbortCode::INVALID_COMMAND);
        match (state, req) {
            (
                State::Download {
                    mux,
                    toggle,
                    received,
                    size,
                    accepts,
                },
                ClientRequest::DownloadSegment(seg),
            ) => {
                if seg.toggle != toggle {
                    return Err(Fail(mux, AbortCode::TOGGLE_BIT_NOT_ALTERNATED));
                }
                let bytes = seg.bytes();
                let end = received.saturating_add(bytes.len() as u32);
                check_progress(end, size, accepts).map_err(|c| Fail(mux, c))?;
                od.write(mux, received, bytes).map_err(|c| Fail(mux, c))?;
                if seg.last {
                    check_end(end, size, accepts).map_err(|c| Fail(mux, c))?;
                    od.commit(mux, end).map_err(|c| Fail(mux, c))?;
                    self.send(ServerResponse::DownloadSegment { toggle });
                    self.events.push(ServerEvent::Downloaded { mux, len: end });
                    return Ok(State::Idle);
                }
                self.send(ServerResponse::DownloadSegment { toggle });
                Ok(State::Download {
                    mux,
                    toggle: !toggle,
                    received: end,
                    size,
                    accepts,
                })
            }
            (
                State::Upload {
                    mux,
                    toggle,
                    offset,
                    len,
                },
                ClientRequest::UploadSegment { toggle: t },
            ) => {
                if t != toggle {
                    return Err(Fail(mux, AbortCode::TOGGLE_BIT_NOT_ALTERNATED));
                }
                let want = len.saturating_sub(offset).min(7) as usize;
                let mut data = [0u8; 7];
                let n = read_exact(od, mux, offset, &mut data[..want])?;
                let end = offset + n as u32;
                let last = end >= len;
                self.send(ServerResponse::UploadSegment(Segment::new(
                    toggle,
                    &data[..n],
                    last,
                )));
                if last {
                    self.events.push(ServerEvent::Uploaded { mux, len });
                    return Ok(State::Idle);
                }
                Ok(State::Upload {
                    mux,
                    toggle: !toggle,
                    offset: end,
                    len,
                })
            }
            (
                State::BlockDownload {
                    mux,
                    crc,
                    received,
                    size,
                    accepts,
                    held: Some(held),
                    ..
                },
                ClientRequest::BlockDownloadEnd {
                    unused,
                    crc: their_crc,
                },
            ) => {
                let bytes = &held.data[..usize::from(7 - unused.min(7))];
                let end = received.saturating_add(bytes.len() as u32);
                check_progress(end, size, accepts).map_err(|c| Fail(mux, c))?;
                check_end(end, size, accepts).map_err(|c| Fail(mux, c))?;
                self.crc.update(bytes);
                if crc && self.crc.get() != their_crc {
                    return Err(Fail(mux, AbortCode::CRC_ERROR));
                }
                od.write(mux, received, bytes).map_err(|c| Fail(mux, c))?;
                od.commit(mux, end).map_err(|c| Fail(mux, c))?;
                self.send(ServerResponse::BlockDownloadEnd);
                self.events.push(ServerEvent::Downloaded { mux, len: end });
                Ok(State::Idle)
            }
            (
                State::BlockUploadStart {
                    mux,
                    crc,
                    blksize,
                    len,
                },
                ClientRequest::BlockUploadStart,
            ) => {
                let total = segments_for(len);
                let count = self.fill_block(od, mux, len, 0, total, blksize)?;
                Ok(State::BlockUpload {
                    mux,
                    crc,
                    len,
                    acked: 0,
                    total,
                    count,
                    sent: 0,
                })
            }
            (
                State::BlockUpload {
                    mux,
                    crc,
                    len,
                    acked,
                    total,
                    sent,
                    ..
                },
                ClientRequest::BlockUploadAck { ackseq, blksize },
            ) => {
                if ackseq > sent {
                    return Err(Fail(mux, AbortCode::INVALID_SEQUENCE_NUMBER));
                }
                if blksize == 0 || blksize > MAX_BLOCK_SIZE {
                    return Err(Fail(mux, AbortCode::INVALID_BLOCK_SIZE));
                }
                let start = acked.saturating_mul(7);
                let acked_bytes = (u32::from(ackseq) * 7).min(len.saturating_sub(start));
                self.crc.update(&self.block[..acked_bytes as usize]);
                let acked = acked + u32::from(ackseq);
                if acked >= total {
                    let crc = if crc { self.crc.get() } else { 0 };
                    self.send(ServerResponse::BlockUploadEnd {
                        unused: unused_in_last(len),
                        crc,
                    });
                    return Ok(State::BlockUploadEnd { mux, len });
                }
                let count = self.fill_block(od, mux, len, acked, total, blksize)?;
                Ok(State::BlockUpload {
                    mux,
                    crc,
                    len,
                    acked,
                    total,
                    count,
                    sent: 0,
                })
            }
            (State::BlockUploadEnd { mux, len }, ClientRequest::BlockUploadEnd) => {
                self.events.push(ServerEvent::Uploaded { mux, len });
                Ok(State::Idle)
            }
            _ => Err(unexpected),
        }
    }

    fn on_initiate<O: ObjectAccess + ?Sized>(
        &mut self,
        req: ClientRequest,
        od: &mut O,
    ) -> Result<State, Fail> {
        self.crc = Crc16::new();
        match req {
            ClientRequest::InitiateDownload { mux, data } => {
                let info = writable(od, mux)?;
                match data {
                    Initiate::Expedited { data: bytes, size } => {
                        let len = match (size, info.accepts) {
                            (Some(n), _) => n.clamp(1, 4),
                            // Size not indicated: a fixed-length object takes its own length.
                            (None, LengthRule::Exact(n)) if n <= 4 => n as u8,
                            (None, rule) => rule.max().min(4) as u8,
                        };
                        let bytes = &bytes[..usize::from(len)];
                        info.accepts
                            .check(u32::from(len))
                            .map_err(|c| Fail(mux, c))?;
                        if let Err(code) = od
                            .write(mux, 0, bytes)
                            .and_then(|()| od.commit(mux, u32::from(len)))
                        {
                            od.discard(mux);
                            return Err(Fail(mux, code));
                        }
                        self.send(ServerResponse::InitiateDownload { mux });
                        self.events.push(ServerEvent::Downloaded {
                            mux,
                            len: u32::from(len),
                        });
                        Ok(State::Idle)
                    }
                    Initiate::Segmented { size } => {
                        if let Some(size) = size {
                            info.accepts.check(size).map_err(|c| Fail(mux, c))?;
                        }
                        self.send(ServerResponse::InitiateDownload { mux });
                        Ok(State::Download {
                            mux,
                            toggle: false,
                            received: 0,
                            size,
                            accepts: info.accepts,
                        })
                    }
                }
            }
            ClientRequest::InitiateUpload { mux } => {
                let info = readable(od, mux)?;
                self.initiate_normal_upload(od, mux, info.len)
            }
            ClientRequest::BlockDownloadInitiate { mux, crc, size } => {
                let info = writable(od, mux)?;
                if let Some(size) = size {
                    info.accepts.check(size).map_err(|c| Fail(mux, c))?;
                }
                self.send(ServerResponse::BlockDownloadInitiate {
                    mux,
                    crc: self.config.crc,
                    blksize: self.config.block_size,
                });
                Ok(State::BlockDownload {
                    mux,
                    crc: crc && self.config.crc,
                    receiver: Receiver::new(),
                    received: 0,
                    size,
                    accepts: info.accepts,
                    held: None,
                })
            }
            ClientRequest::BlockUploadInitiate {
                mux,
                crc,
                blksize,
                pst,
            } => {
                let info = readable(od, mux)?;
                if blksize == 0 || blksize > MAX_BLOCK_SIZE {
                    return Err(Fail(mux, AbortCode::INVALID_BLOCK_SIZE));
                }
                if pst != 0 && info.len <= u32::from(pst) {
                    // Protocol switch: answer with a normal upload.
                    return self.initiate_normal_upload(od, mux, info.len);
                }
                self.send(ServerResponse::BlockUploadInitiate {
                    mux,
                    crc: self.config.crc,
                    size: Some(info.len),
                });
                Ok(State::BlockUploadStart {
                    mux,
                    crc: crc && self.config.crc,
                    blksize,
                    len: info.len,
                })
            }
            _ => Err(Fail(Multiplexer::default(), AbortCode::INVALID_COMMAND)),
        }
    }

    fn initiate_normal_upload<O: ObjectAccess + ?Sized>(
        &mut self,
        od: &mut O,
        mux: Multiplexer,
        len: u32,
    ) -> Result<State, Fail> {
        if (1..=4).contains(&len) {
            let mut data = [0u8; 4];
            read_exact(od, mux, 0, &mut data[..len as usize])?;
            self.send(ServerResponse::InitiateUpload {
                mux,
                data: Initiate::Expedited {
                    data,
                    size: Some(len as u8),
                },
            });
            self.events.push(ServerEvent::Uploaded { mux, len });
            return Ok(State::Idle);
        }
        self.send(ServerResponse::InitiateUpload {
            mux,
            data: Initiate::Segmented { size: Some(len) },
        });
        Ok(State::Upload {
            mux,
            toggle: false,
            offset: 0,
            len,
        })
    }

    /// Reads the next sub-block (segments `acked..`) into the block buffer; returns its
    /// segment count.
    fn fill_block<O: ObjectAccess + ?Sized>(
        &mut self,
        od: &mut O,
        mux: Multiplexer,
        len: u32,
        acked: u32,
        total: u32,
        blksize: u8,
    ) -> Result<u8, Fail> {
        let count = (total - acked).min(u32::from(blksize)) as u8;
        let offset = acked.saturating_mul(7);
        let want = (usize::from(count) * 7).min(len.saturating_sub(offset) as usize);
        self.block = [0; BLOCK_BYTES];
        read_exact(od, mux, offset, &mut self.block[..want])?;
        Ok(count)
    }

    fn on_block_segment<O: ObjectAccess + ?Sized>(
        &mut self,
        state: State,
        seg: BlockSegment,
        od: &mut O,
    ) -> Result<State, Fail> {
        let State::BlockDownload {
            mux,
            crc,
            mut receiver,
            mut received,
            size,
            accepts,
            held: None,
        } = state
        else {
            return Ok(state);
        };
        let blksize = self.config.block_size;
        let verdict = receiver
            .on_segment(&seg, blksize)
            .map_err(|_| Fail(mux, AbortCode::INVALID_SEQUENCE_NUMBER))?;
        let mut held = None;
        if verdict.take {
            if seg.last {
                held = Some(seg);
            } else {
                let end = received.saturating_add(7);
                check_progress(end, size, accepts).map_err(|c| Fail(mux, c))?;
                od.write(mux, received, &seg.data)
                    .map_err(|c| Fail(mux, c))?;
                self.crc.update(&seg.data);
                received = end;
            }
        }
        if let Some(ackseq) = verdict.ack {
            self.send(ServerResponse::BlockDownloadAck { ackseq, blksize });
        }
        Ok(State::BlockDownload {
            mux,
            crc,
            receiver,
            received,
            size,
            accepts,
            held,
        })
    }
}
