//! The SDO client (CiA 301 §7.2.4.3): upload (read) and download (write) of one object at a
//! time, expedited, segmented or by block, as a sans-IO state machine.
//!
//! # Call order
//!
//! 1. [`Client::new`] with a [`ClientConfig`] (response timeout, block size, CRC, protocol
//!    switch threshold).
//! 2. Start one transfer: [`Client::start_upload`] into a [`Sink`] or [`Client::start_download`]
//!    from a [`Source`]. The client owns the buffer until the transfer ends. A second start
//!    while a transfer runs (or while its completion event is not yet polled) is refused with
//!    [`Busy`], handing the buffer back; the caller (the master) queues.
//! 3. Loop:
//!    - send every frame [`Client::poll_transmit`] yields (request COB-ID, 0x600 + node by
//!      default; see [`SdoCobIds`]);
//!    - feed every frame from the server's response COB-ID to [`Client::handle_response`];
//!    - when the clock reaches [`Client::poll_timeout`], call [`Client::handle_timeout`];
//!    - after each of these, drain [`Client::poll_event`]: exactly one [`Event`] ends each
//!      transfer and returns the buffer.
//! 4. [`Client::abort`] cancels the running transfer (an abort message goes to the server).
//!
//! [`Client::progress`] reports bytes done and the total, if known, for progress bars.
//!
//! # Behaviour on unexpected input
//!
//! - An initiate response for another index/sub-index is ignored, whether it is an upload's or
//!   a download's (it is a late answer to an earlier request); it never completes or fails the
//!   running transfer.
//! - A server abort ends the transfer when its multiplexer is the transfer's (or 0000:00, as
//!   some servers send for unknown commands) and is reported as [`ErrorKind::ServerAbort`],
//!   apart from local failures.
//! - A response with the wrong command specifier, a toggle bit that did not alternate, an
//!   invalid block size or sequence number, a CRC mismatch or a wrong amount of data ends the
//!   transfer with an abort message to the server ([`ErrorKind::Protocol`]).
//! - Leftovers: after the client aborted a transfer (cancel, timeout, protocol error), or the
//!   server aborted one for 0000:00 or in the middle of a block download's sub-block, frames of the old transfer may still be on their way (the
//!   rest of a block upload's sub-block; the server's answers to the rest of a block download).
//!   Until the next transfer's first valid response, frames with a command that fits none of
//!   its steps, and 0000:00 aborts, are dropped instead of ending it.
//! - In a block upload's sub-block, a segment out of sequence is a gap: it and the rest of the
//!   sub-block are dropped and the acknowledgement names the last segment received in
//!   sequence, so the server repeats from there; a repeated segment changes nothing (see
//!   `subblock.rs`; the server does the same in a block download).
//! - A block transfer's receiving side aborts after [`crate::MAX_FRUITLESS_SUB_BLOCKS`]
//!   sub-blocks in a row without a segment in sequence (0x05040003).
//! - Frames shorter than eight bytes are taken when they hold the bytes their command needs
//!   (see [`crate::wire`]); one too short for its command ends the transfer with
//!   [`Violation::ShortFrame`] (abort 0x05040001). Empty frames and frames while idle are
//!   ignored.
//! - The timeout is the time the server may take for each response (it restarts on every
//!   step), so long domains do not need a long timeout; [`ClientConfig::transfer_timeout`]
//!   optionally bounds the whole transfer as well. On expiry the client sends abort
//!   0x05040000 and reports [`ErrorKind::Timeout`].

use canola_frame::{CanFrame, Duration, Instant};

use crate::abort::AbortCode;
use crate::buffer::{Sink, Source};
use crate::cob::SdoCobIds;
use crate::crc::Crc16;
pub use crate::error::{Busy, ErrorKind, TransferError, Violation};
use crate::queue::Ring;
use crate::subblock::Receiver;
pub use crate::wire::MAX_BLOCK_SIZE;
use crate::wire::{
    BlockSegment, ClientRequest, DecodeError, Initiate, Multiplexer, ServerResponse, carries_mux,
    is_abort, short_frame_mux,
};

mod download;
mod upload;

/// Client settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// How long the server may take for each response. Default 1 s.
    pub timeout: Duration,
    /// Segments per sub-block the client accepts in block upload, 1..=127. Default 127.
    pub block_size: u8,
    /// Offer CRC in block transfers (used when the server supports it too). Default on.
    pub crc: bool,
    /// Protocol switch threshold sent in block upload: the server may answer with a normal
    /// upload when the object has at most this many bytes. 0 (default) forbids switching.
    pub protocol_switch_threshold: u8,
    /// Upper bound for a whole transfer, however steadily the server answers. `None`
    /// (default): only the per-response `timeout` applies.
    pub transfer_timeout: Option<Duration>,
}

impl Default for ClientConfig {
    fn default() -> Self {
        Self {
            timeout: Duration::from_secs(1),
            block_size: MAX_BLOCK_SIZE,
            crc: true,
            protocol_switch_threshold: 0,
            transfer_timeout: None,
        }
    }
}

impl ClientConfig {
    /// Sets the response timeout.
    pub const fn with_timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }

    /// Sets the block size offered in block upload (clamped to 1..=127).
    pub const fn with_block_size(mut self, blksize: u8) -> Self {
        self.block_size = clamp_blksize(blksize);
        self
    }

    /// Whether to offer CRC in block transfers.
    pub const fn with_crc(mut self, crc: bool) -> Self {
        self.crc = crc;
        self
    }

    /// Bounds the duration of a whole transfer.
    pub const fn with_transfer_timeout(mut self, limit: Duration) -> Self {
        self.transfer_timeout = Some(limit);
        self
    }

    /// Sets the protocol switch threshold of block upload.
    pub const fn with_protocol_switch_threshold(mut self, pst: u8) -> Self {
        self.protocol_switch_threshold = pst;
        self
    }
}

const fn clamp_blksize(blksize: u8) -> u8 {
    if blksize == 0 {
        1
    } else if blksize > MAX_BLOCK_SIZE {
        MAX_BLOCK_SIZE
    } else {
        blksize
    }
}

/// How to transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Method {
    /// Download: expedited for 1..=4 bytes, segmented otherwise. Upload: the server chooses
    /// expedited or segmented.
    #[default]
    Normal,
    /// Download segmented even when the data would fit an expedited message. For upload the
    /// same as `Normal`.
    Segmented,
    /// Block transfer (CiA 301 §7.2.4.3.9–16), with CRC when both sides support it. A server
    /// without block transfer typically aborts with 0x05040001; retry with `Normal` then.
    Block,
}

impl core::fmt::Display for Method {
    /// `normal`, `segmented`, `block`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Normal => "normal",
            Self::Segmented => "segmented",
            Self::Block => "block",
        })
    }
}

/// Upload or download.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Server to client (read).
    Upload,
    /// Client to server (write).
    Download,
}

impl core::fmt::Display for Direction {
    /// `upload`, `download`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Upload => "upload",
            Self::Download => "download",
        })
    }
}

/// How far the running transfer is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// The object.
    pub mux: Multiplexer,
    /// Upload or download.
    pub direction: Direction,
    /// Bytes confirmed so far (received, or acknowledged by the server).
    pub done: u32,
    /// The object size, when known.
    pub total: Option<u32>,
}

/// The buffer of a transfer, handed back when it fails.
#[derive(Debug)]
pub enum Buffer<S, D> {
    /// An upload's sink, holding whatever arrived before the failure.
    Sink(S),
    /// A download's source.
    Source(D),
}

/// How a transfer ended. Exactly one event ends every started transfer.
#[derive(Debug)]
pub enum Event<S, D> {
    /// The upload finished; `sink` holds the data.
    Uploaded {
        /// The object.
        mux: Multiplexer,
        /// The caller's sink.
        sink: S,
        /// Number of bytes received.
        len: u32,
        /// The server answered expedited without indicating the size (e = 1, s = 0): the
        /// sink holds all four data bytes, of which CiA 301 leaves those past the object
        /// unspecified, so the object's length is its data type's (decode with
        /// `canola_od::Value::from_le_bytes_unsized`). `false` for every other answer, whose
        /// length is the object's.
        unsized_expedited: bool,
    },
    /// The download finished and the server confirmed it.
    Downloaded {
        /// The object.
        mux: Multiplexer,
        /// The caller's source.
        source: D,
    },
    /// The transfer failed.
    Failed {
        /// What went wrong, for which object.
        error: TransferError,
        /// The caller's buffer.
        buffer: Buffer<S, D>,
    },
}

#[derive(Debug)]
enum UpPhase {
    /// Sent initiate upload; waiting for its response.
    Initiate,
    /// Sent upload segment request with this toggle.
    Segment { toggle: bool },
    /// Sent initiate block upload; waiting for the block or a normal initiate response.
    BlockInitiate,
    /// Receiving sub-blocks (see [`crate::subblock`]).
    SubBlock { crc: bool, receiver: Receiver },
    /// Acknowledged the last segment of the transfer, `held` (its length is known only from
    /// the end message); waiting for the end message.
    BlockEnd { crc: bool, held: BlockSegment },
}

#[derive(Debug)]
enum DownPhase {
    /// Sent initiate download; waiting for its response.
    Initiate { expedited: bool },
    /// Sent a segment ending at byte `end`; waiting for its response.
    Segment { toggle: bool, end: u32, last: bool },
    /// Sent initiate block download.
    BlockInitiate,
    /// Sending a sub-block of `count` segments (`sent` so far), then waiting for the ack.
    SubBlock {
        crc: bool,
        count: u8,
        sent: u8,
        /// Segments of the whole transfer acknowledged so far.
        acked: u32,
        total: u32,
    },
    /// Sent end block download.
    BlockEnd,
}

#[derive(Debug)]
enum Kind<S, D> {
    Up {
        sink: S,
        phase: UpPhase,
        total: Option<u32>,
        /// Answered expedited without size (see [`Event::Uploaded`]).
        unsized_expedited: bool,
    },
    Down {
        source: D,
        phase: DownPhase,
        len: u32,
        /// Bytes fed to the CRC so far (segments are first sent in order).
        crc_upto: u32,
    },
}

#[derive(Debug)]
struct Active<S, D> {
    mux: Multiplexer,
    kind: Kind<S, D>,
    done: u32,
    crc: Crc16,
    deadline: Instant,
    /// End of the whole transfer when [`ClientConfig::transfer_timeout`] is set.
    limit: Instant,
}

impl<S, D> Active<S, D> {
    /// Restarts the response timer, never past the transfer's limit.
    fn rearm(&mut self, now: Instant, timeout: Duration) {
        self.deadline = (now + timeout).min(self.limit);
    }
}

/// The SDO client machine for one server. See the [module docs](self) for the call order.
///
/// `S` is the upload sink type and `D` the download source type (both caller-owned; see
/// [`crate::buffer`]).
#[derive(Debug)]
pub struct Client<S, D> {
    config: ClientConfig,
    active: Option<Active<S, D>>,
    tx: Ring<[u8; 8], 4>,
    event: Option<Event<S, D>>,
    /// The last transfer ended while frames of it may still be on their way: this client
    /// aborted it while the server may still have been sending (a sub-block of a block upload
    /// goes out without waiting for the client), or the server aborted it for "0000:00", as it
    /// answers frames it cannot place. Until the next transfer's first valid response, frames
    /// that fit no command of it, and 0000:00 aborts, are leftovers, and are dropped.
    after_abort: bool,
}

enum Step<S, D> {
    Continue(Active<S, D>),
    Finish(Active<S, D>, Result<(), ErrorKind>),
}

impl<S: Sink, D: Source> Client<S, D> {
    /// An idle client.
    pub fn new(config: ClientConfig) -> Self {
        let config = ClientConfig {
            block_size: clamp_blksize(config.block_size),
            ..config
        };
        Self {
            config,
            active: None,
            tx: Ring::new(),
            event: None,
            after_abort: false,
        }
    }

    /// The settings.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// Changes the settings; they apply to the next transfer.
    pub fn set_config(&mut self, config: ClientConfig) {
        self.config = ClientConfig {
            block_size: clamp_blksize(config.block_size),
            ..config
        };
    }

    /// Whether a new transfer can start (none runs and no completion waits to be polled).
    pub fn is_idle(&self) -> bool {
        self.active.is_none() && self.event.is_none()
    }

    fn limit(&self, now: Instant) -> Instant {
        match self.config.transfer_timeout {
            Some(limit) => now + limit,
            None => Instant::MAX,
        }
    }

    fn first_deadline(&self, now: Instant) -> Instant {
        (now + self.config.timeout).min(self.limit(now))
    }

    /// Reads the object `mux` from the server into `sink` (appending).
    pub fn start_upload(
        &mut self,
        now: Instant,
        mux: Multiplexer,
        sink: S,
        method: Method,
    ) -> Result<(), Busy<S>> {
        if !self.is_idle() {
            return Err(Busy(sink));
        }
        let (request, phase) = match method {
            Method::Block => (
                ClientRequest::BlockUploadInitiate {
                    mux,
                    crc: self.config.crc,
                    blksize: self.config.block_size,
                    pst: self.config.protocol_switch_threshold,
                },
                UpPhase::BlockInitiate,
            ),
            Method::Normal | Method::Segmented => {
                (ClientRequest::InitiateUpload { mux }, UpPhase::Initiate)
            }
        };
        self.tx.push(request.emit());
        self.active = Some(Active {
            mux,
            kind: Kind::Up {
                sink,
                phase,
                total: None,
                unsized_expedited: false,
            },
            done: 0,
            crc: Crc16::new(),
            deadline: self.first_deadline(now),
            limit: self.limit(now),
        });
        Ok(())
    }

    /// Writes the whole of `source` to the object `mux` on the server.
    pub fn start_download(
        &mut self,
        now: Instant,
        mux: Multiplexer,
        mut source: D,
        method: Method,
    ) -> Result<(), Busy<D>> {
        if !self.is_idle() {
            return Err(Busy(source));
        }
        let len = source.len();
        let (request, phase) = match method {
            Method::Normal if (1..=4).contains(&len) => {
                let mut data = [0u8; 4];
                let n = source.read(0, &mut data[..len as usize]);
                let init = Initiate::Expedited {
                    data,
                    size: Some(n.clamp(1, 4) as u8),
                };
                (
                    ClientRequest::InitiateDownload { mux, data: init },
                    DownPhase::Initiate { expedited: true },
                )
            }
            Method::Normal | Method::Segmented => (
                ClientRequest::InitiateDownload {
                    mux,
                    data: Initiate::Segmented { size: Some(len) },
                },
                DownPhase::Initiate { expedited: false },
            ),
            Method::Block => (
                ClientRequest::BlockDownloadInitiate {
                    mux,
                    crc: self.config.crc,
                    size: Some(len),
                },
                DownPhase::BlockInitiate,
            ),
        };
        self.tx.push(request.emit());
        self.active = Some(Active {
            mux,
            kind: Kind::Down {
                source,
                phase,
                len,
                crc_upto: 0,
            },
            done: 0,
            crc: Crc16::new(),
            deadline: self.first_deadline(now),
            limit: self.limit(now),
        });
        Ok(())
    }

    /// Cancels the running transfer: sends an abort with `code` to the server and ends the
    /// transfer with [`ErrorKind::Cancelled`]. Returns whether a transfer was running.
    pub fn abort(&mut self, now: Instant, code: AbortCode) -> bool {
        let _ = now;
        match self.active.take() {
            Some(active) => {
                self.tx.push(abort_frame(active.mux, code));
                self.after_abort = true;
                self.finish(active, Err(ErrorKind::Cancelled(code)));
                true
            }
            None => false,
        }
    }

    /// Feeds one frame's data from the server (its response COB-ID).
    pub fn handle_response(&mut self, now: Instant, data: &[u8]) {
        let Some(active) = self.active.take() else {
            return;
        };
        let step = self.step(now, active, data);
        match step {
            Step::Continue(active) => self.active = Some(active),
            Step::Finish(active, Err(kind)) => {
                let code = match kind {
                    ErrorKind::ServerAbort(_) => None,
                    other => Some(other.abort_code()),
                };
                if let Some(code) = code {
                    self.tx.push(abort_frame(active.mux, code));
                    self.after_abort = true;
                }
                self.finish(active, Err(kind));
            }
            Step::Finish(active, Ok(())) => self.finish(active, Ok(())),
        }
    }

    /// Checks the timeout: when `now` has reached [`poll_timeout`](Self::poll_timeout), sends
    /// abort 0x05040000 and ends the transfer with [`ErrorKind::Timeout`].
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(active) = self.active.take() {
            if now >= active.deadline {
                self.tx.push(abort_frame(active.mux, AbortCode::TIMEOUT));
                self.after_abort = true;
                self.finish(active, Err(ErrorKind::Timeout));
            } else {
                self.active = Some(active);
            }
        }
    }

    /// The next frame to send to the server (eight data bytes for the request COB-ID).
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<[u8; 8]> {
        if let Some(frame) = self.tx.pop() {
            return Some(frame);
        }
        let active = self.active.as_mut()?;
        let Kind::Down {
            source,
            phase:
                DownPhase::SubBlock {
                    count,
                    sent,
                    acked,
                    total,
                    ..
                },
            len,
            crc_upto,
        } = &mut active.kind
        else {
            return None;
        };
        if *sent >= *count {
            return None;
        }
        *sent += 1;
        let index = *acked + u32::from(*sent) - 1;
        let offset = index.saturating_mul(7);
        let mut data = [0u8; 7];
        let want = (*len).saturating_sub(offset).min(7) as usize;
        let n = source.read(offset, &mut data[..want]);
        let end = offset.saturating_add(n as u32);
        if end > *crc_upto {
            let from = crc_upto.saturating_sub(offset) as usize;
            active.crc.update(&data[from.min(n)..n]);
            *crc_upto = end;
        }
        Some(
            BlockSegment {
                seqno: *sent,
                last: index + 1 >= *total,
                data,
            }
            .emit(),
        )
    }

    /// Feeds `frame` if it is a data frame on the channel's response identifier; returns
    /// whether it was. The frame adapter over [`handle_response`](Self::handle_response).
    pub fn handle_frame(&mut self, now: Instant, ids: &SdoCobIds, frame: &CanFrame) -> bool {
        let ours = ids.is_response(frame);
        if ours {
            self.handle_response(now, frame.data());
        }
        ours
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on the channel's request identifier.
    #[must_use]
    pub fn poll_transmit_frame(&mut self, ids: &SdoCobIds) -> Option<CanFrame> {
        self.poll_transmit().map(|data| ids.request_frame(data))
    }

    /// The event that ended a transfer, once.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<Event<S, D>> {
        self.event.take()
    }

    /// When [`handle_timeout`](Self::handle_timeout) must be called next, if a transfer runs.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.active.as_ref().map(|a| a.deadline)
    }

    /// How far the running transfer is.
    pub fn progress(&self) -> Option<Progress> {
        let active = self.active.as_ref()?;
        let (direction, total) = match &active.kind {
            Kind::Up { total, .. } => (Direction::Upload, *total),
            Kind::Down { len, .. } => (Direction::Download, Some(*len)),
        };
        Some(Progress {
            mux: active.mux,
            direction,
            done: active.done,
            total,
        })
    }

    fn finish(&mut self, active: Active<S, D>, result: Result<(), ErrorKind>) {
        let mux = active.mux;
        self.event = Some(match (active.kind, result) {
            (
                Kind::Up {
                    sink,
                    unsized_expedited,
                    ..
                },
                Ok(()),
            ) => Event::Uploaded {
                mux,
                sink,
                len: active.done,
                unsized_expedited,
            },
            (Kind::Down { source, .. }, Ok(())) => Event::Downloaded { mux, source },
            (kind, Err(kind_err)) => Event::Failed {
                error: TransferError {
                    index: mux.index,
                    subindex: mux.subindex,
                    kind: kind_err,
                },
                buffer: match kind {
                    Kind::Up { sink, .. } => Buffer::Sink(sink),
                    Kind::Down { source, .. } => Buffer::Source(source),
                },
            },
        });
    }

    fn step(&mut self, now: Instant, mut active: Active<S, D>, data: &[u8]) -> Step<S, D> {
        // In an upload sub-block every frame is a segment, except an abort.
        if let Kind::Up { phase, .. } = &active.kind {
            match phase {
                UpPhase::SubBlock { .. } if !is_abort(data) => {
                    return match BlockSegment::parse(data) {
                        Ok(seg) => self.on_block_segment(now, active, seg),
                        Err(_) => Step::Continue(active),
                    };
                }
                // A repeat of the transfer's last segment (its bytes may read as anything,
                // an abort of 0000:00 among them).
                UpPhase::BlockEnd { held, .. } if data == held.emit() => {
                    return Step::Continue(active);
                }
                _ => {}
            }
        }
        // Right after this client aborted a transfer, the server's frames still on their way
        // (up to a sub-block of segments, each byte pattern a possible command) are dropped
        // until this transfer is answered, rather than failing it: a segment parses as any
        // command, and one with a zero index as an abort of "0000:00".
        let leftovers = self.after_abort;
        let msg = match ServerResponse::parse(data) {
            Ok(msg) => msg,
            Err(DecodeError::UnknownCommand(_)) if leftovers => return Step::Continue(active),
            Err(DecodeError::UnknownCommand(_)) => {
                return Step::Finish(active, Err(protocol(Violation::UnexpectedCommand)));
            }
            // A short frame fails the transfer only when it is surely this transfer's: a
            // command without multiplexer (segments, acknowledgements) or one naming this
            // transfer's object. One naming another object, or too short to name one, is a
            // stray frame, as its long form would be.
            Err(DecodeError::Short { command, .. })
                if !leftovers
                    && match short_frame_mux(data) {
                        Some(mux) => mux == active.mux,
                        None => !carries_mux(command),
                    } =>
            {
                return Step::Finish(active, Err(protocol(Violation::ShortFrame)));
            }
            Err(_) => return Step::Continue(active),
        };
        if let ServerResponse::Abort { mux, code } = msg {
            // Some servers abort with index 0 when they cannot tell which object a request was
            // for; taken as this transfer's, except among leftovers.
            if mux == active.mux {
                // Aborted while this client was sending a sub-block: the server answers the
                // segments still on their way as requests it cannot place.
                self.after_abort |= matches!(
                    active.kind,
                    Kind::Down {
                        phase: DownPhase::SubBlock { .. },
                        ..
                    }
                );
                return Step::Finish(active, Err(ErrorKind::ServerAbort(code)));
            }
            if mux == Multiplexer::default() && !leftovers {
                // A server that cannot tell which object a frame was for may be answering
                // frames of another transfer (e.g. the rest of a block download reaching a
                // server that rebooted): more such answers may follow, and are leftovers for
                // the next transfer.
                self.after_abort = true;
                return Step::Finish(active, Err(ErrorKind::ServerAbort(code)));
            }
            return Step::Continue(active);
        }
        // An initiate response naming another object answers an earlier request, whatever
        // its kind: e.g. a read that timed out while its request still waited in a full
        // transmit queue, answered once the next transfer (a write) had started. It is not
        // this transfer's, so it neither completes nor fails it. (The one check of the
        // multiplexer: the upload and download steps see only this transfer's.)
        if let ServerResponse::InitiateUpload { mux, .. }
        | ServerResponse::InitiateDownload { mux }
        | ServerResponse::BlockDownloadInitiate { mux, .. }
        | ServerResponse::BlockUploadInitiate { mux, .. } = &msg
            && *mux != active.mux
        {
            return Step::Continue(active);
        }
        let result = if matches!(active.kind, Kind::Up { .. }) {
            self.on_upload(&mut active, msg)
        } else {
            self.on_download(&mut active, msg)
        };
        match result {
            Ok(Flow::Continue) => {
                self.after_abort = false;
                active.rearm(now, self.config.timeout);
                Step::Continue(active)
            }
            Ok(Flow::Done) => {
                self.after_abort = false;
                Step::Finish(active, Ok(()))
            }
            Err(ErrorKind::Protocol(Violation::UnexpectedCommand)) if leftovers => {
                Step::Continue(active)
            }
            Err(kind) => Step::Finish(active, Err(kind)),
        }
    }
}

enum Flow {
    /// Progress: restart the response timer.
    Continue,
    /// The transfer completed.
    Done,
}

fn protocol(v: Violation) -> ErrorKind {
    ErrorKind::Protocol(v)
}

fn abort_frame(mux: Multiplexer, code: AbortCode) -> [u8; 8] {
    ClientRequest::Abort { mux, code }.emit()
}
