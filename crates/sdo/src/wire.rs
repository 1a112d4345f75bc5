//! The SDO messages on the wire (CiA 301 §7.2.4.3): every client request and server response,
//! as typed values with a total `parse` and an `emit`.
//!
//! An SDO message is eight data bytes. Byte 0 is the command byte: the command specifier
//! (`ccs` for client requests, `scs` for server responses) in bits 7..5 and per-command flags
//! below. The initiate messages and the abort carry the multiplexer (index little-endian in bytes
//! 1..=2, sub-index in byte 3).
//!
//! | ccs | client → server                         | scs | server → client                     |
//! |-----|-----------------------------------------|-----|-------------------------------------|
//! | 0   | download segment (t, n, c)               | 0   | upload segment (t, n, c)            |
//! | 1   | initiate download (n, e, s)              | 1   | download segment (t)                |
//! | 2   | initiate upload                          | 2   | initiate upload (n, e, s)           |
//! | 3   | upload segment (t)                       | 3   | initiate download                   |
//! | 4   | abort transfer                           | 4   | abort transfer                      |
//! | 5   | block upload: initiate / end / ack / start | 5 | block download: initiate / end / ack |
//! | 6   | block download: initiate / end           | 6   | block upload: initiate / end        |
//!
//! The segments of a block transfer's sub-block carry no command specifier (byte 0 is `c` and
//! the 7-bit sequence number), so they cannot be told apart from other messages by their bytes:
//! the receiving state machine parses them with [`BlockSegment::parse`] while it expects a
//! sub-block, and with [`ClientRequest::parse`] / [`ServerResponse::parse`] otherwise.
//!
//! # Frames shorter than eight bytes
//!
//! CiA 301 gives the bytes after those a command uses no meaning ("reserved"), and some devices
//! send only the bytes they use: an expedited upload response of one byte as `4F 00 14 02 FE`
//! with DLC 5. `parse` takes a frame of 1..=8 bytes when it holds every byte its command needs
//! (the multiplexer, the data bytes the message announces, the size, the abort code), and reads
//! the missing reserved bytes as zero. A frame too short for its command is
//! [`DecodeError::Short`]: no byte that carries meaning is ever made up. Block sub-block
//! segments keep their eight bytes, as the data length of the last one is told only by the end
//! message that follows it.
//!
//! All `parse` functions are total: any byte slice gives a value or a [`DecodeError`], never a
//! panic. Reserved bits are ignored on parse and written as zero by `emit`, so
//! `parse(emit(m)) == m` for every message `m` built from in-range fields.
//!
//! The bytes each command uses and the padding of short frames are in `length`, the `Display`
//! texts in `text`.

use crate::abort::AbortCode;

mod length;
mod text;

pub(crate) use length::{carries_mux, short_frame_mux};
use length::{client_needs, padded, server_needs};

/// Byte offsets and bit masks of the SDO messages.
mod field {
    use core::ops::Range;

    pub(super) const COMMAND: usize = 0;
    pub(super) const INDEX: Range<usize> = 1..3;
    pub(super) const SUBINDEX: usize = 3;
    /// Initiate data, size, or abort code.
    pub(super) const DATA: Range<usize> = 4..8;
    /// Segment data (normal and block segments).
    pub(super) const SEGMENT: Range<usize> = 1..8;
    /// Block upload initiate request: blksize and protocol switch threshold.
    pub(super) const INIT_BLKSIZE: usize = 4;
    pub(super) const PST: usize = 5;
    /// Block download initiate response: blksize.
    pub(super) const INIT_RESP_BLKSIZE: usize = 4;
    /// Block acknowledge: ackseq and blksize.
    pub(super) const ACKSEQ: usize = 1;
    pub(super) const ACK_BLKSIZE: usize = 2;
    /// Block end: CRC.
    pub(super) const CRC: Range<usize> = 1..3;

    pub(super) const CS_SHIFT: u8 = 5;
    /// Segments: toggle bit t.
    pub(super) const TOGGLE: u8 = 0x10;
    /// Segments: n (bytes without data), bits 3..1.
    pub(super) const SEG_N_MASK: u8 = 0x0E;
    pub(super) const SEG_N_SHIFT: u8 = 1;
    /// Segments: c (no more segments).
    pub(super) const LAST: u8 = 0x01;
    /// Initiate: n (bytes of d without data, expedited), bits 3..2; e; s.
    pub(super) const INIT_N_MASK: u8 = 0x0C;
    pub(super) const INIT_N_SHIFT: u8 = 2;
    pub(super) const EXPEDITED: u8 = 0x02;
    pub(super) const SIZE: u8 = 0x01;
    /// Block initiate: cc / sc (CRC support) and s (size indicated).
    pub(super) const BLOCK_CRC: u8 = 0x04;
    pub(super) const BLOCK_SIZE: u8 = 0x02;
    /// Block end: n, bits 4..2.
    pub(super) const END_N_MASK: u8 = 0x1C;
    pub(super) const END_N_SHIFT: u8 = 2;
    /// Block segment: c and seqno.
    pub(super) const SEQ_LAST: u8 = 0x80;
    pub(super) const SEQNO: u8 = 0x7F;
}

/// Largest block size CiA 301 allows (segments per sub-block).
pub const MAX_BLOCK_SIZE: u8 = 127;

/// Number of segments of `len` bytes in a block transfer (an empty object still takes one).
pub(crate) const fn segments_for(len: u32) -> u32 {
    let n = len / 7 + if len.is_multiple_of(7) { 0 } else { 1 };
    if n == 0 { 1 } else { n }
}

/// n of the block end message: bytes of the last segment without data.
pub(crate) const fn unused_in_last(len: u32) -> u8 {
    let rest = len % 7;
    if len == 0 {
        7
    } else if rest == 0 {
        0
    } else {
        (7 - rest) as u8
    }
}

/// The object a transfer addresses: index and sub-index (the "multiplexer" of CiA 301).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Multiplexer {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub subindex: u8,
}

impl Multiplexer {
    /// `index:subindex`.
    pub const fn new(index: u16, subindex: u8) -> Self {
        Self { index, subindex }
    }

    fn read(b: &[u8; 8]) -> Self {
        Self {
            index: u16::from_le_bytes([b[field::INDEX.start], b[field::INDEX.start + 1]]),
            subindex: b[field::SUBINDEX],
        }
    }

    fn write(self, b: &mut [u8; 8]) {
        b[field::INDEX].copy_from_slice(&self.index.to_le_bytes());
        b[field::SUBINDEX] = self.subindex;
    }
}

impl core::fmt::Display for Multiplexer {
    /// `0x1018:02`, `0x1F50:0A`: the index in four upper-case hex digits, the sub-index in
    /// two, as every message of the stack writes an object address.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "0x{:04X}:{:02X}", self.index, self.subindex)
    }
}

/// Why bytes are not an SDO message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// No SDO message: an empty frame, or more than eight bytes.
    #[error("an SDO message has 1..=8 data bytes, this one has {0}")]
    Length(usize),
    /// The frame is shorter than the bytes its command needs.
    #[error("SDO command byte {command:#04x} needs {needs} data bytes, the frame has {len}")]
    Short {
        /// Byte 0 of the frame.
        command: u8,
        /// Bytes the command needs.
        needs: usize,
        /// Bytes in the frame.
        len: usize,
    },
    /// The command specifier (or the block sub-command) is not defined in this direction.
    #[error("unknown SDO command byte {0:#04x}")]
    UnknownCommand(u8),
}

fn bytes8(data: &[u8]) -> Result<&[u8; 8], DecodeError> {
    <&[u8; 8]>::try_from(data).map_err(|_| DecodeError::Length(data.len()))
}

fn data4(b: &[u8; 8]) -> [u8; 4] {
    [b[4], b[5], b[6], b[7]]
}

fn u32_at_data(b: &[u8; 8]) -> u32 {
    u32::from_le_bytes(data4(b))
}

fn seg7(b: &[u8; 8]) -> [u8; 7] {
    [b[1], b[2], b[3], b[4], b[5], b[6], b[7]]
}

/// The payload of an initiate download request or an initiate upload response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Initiate {
    /// e = 1: the data travels in this message.
    Expedited {
        /// Bytes 4..=7; only the first `size` (or all four when `size` is `None`) are data.
        data: [u8; 4],
        /// s = 1: 1..=4 data bytes (n = 4 − size). `None` (s = 0): unspecified, take all four.
        size: Option<u8>,
    },
    /// e = 0: a segmented transfer follows.
    Segmented {
        /// s = 1: the object size in bytes; `None` when not indicated.
        size: Option<u32>,
    },
}

impl Initiate {
    /// An expedited payload with size indicated; `None` unless `data` has 1..=4 bytes.
    pub fn expedited(data: &[u8]) -> Option<Self> {
        if data.is_empty() || data.len() > 4 {
            return None;
        }
        let mut buf = [0u8; 4];
        buf[..data.len()].copy_from_slice(data);
        Some(Self::Expedited {
            data: buf,
            size: Some(data.len() as u8),
        })
    }

    fn parse(b: &[u8; 8]) -> Self {
        let cmd = b[field::COMMAND];
        let sized = cmd & field::SIZE != 0;
        if cmd & field::EXPEDITED != 0 {
            let n = (cmd & field::INIT_N_MASK) >> field::INIT_N_SHIFT;
            Self::Expedited {
                data: data4(b),
                size: sized.then_some(4 - n),
            }
        } else {
            Self::Segmented {
                size: sized.then(|| u32_at_data(b)),
            }
        }
    }

    /// Flags for byte 0 and the four data bytes. An expedited size outside 1..=4 is clamped.
    fn emit(self) -> (u8, [u8; 4]) {
        match self {
            Self::Expedited { data, size: None } => (field::EXPEDITED, data),
            Self::Expedited {
                data,
                size: Some(size),
            } => {
                let n = 4 - size.clamp(1, 4);
                (
                    field::EXPEDITED | field::SIZE | (n << field::INIT_N_SHIFT),
                    data,
                )
            }
            Self::Segmented { size: None } => (0, [0; 4]),
            Self::Segmented { size: Some(size) } => (field::SIZE, size.to_le_bytes()),
        }
    }

    /// The expedited data bytes (empty for a segmented initiate).
    pub fn expedited_data(&self) -> &[u8] {
        match self {
            Self::Expedited { data, size } => {
                let len = usize::from(size.unwrap_or(4)).clamp(1, 4);
                &data[..len]
            }
            Self::Segmented { .. } => &[],
        }
    }
}

/// A download segment request or an upload segment response: up to seven data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Segment {
    /// Toggle bit t: 0 for the first segment, alternating after.
    pub toggle: bool,
    /// Bytes 1..=7; the first `len` are data.
    pub data: [u8; 7],
    /// Number of data bytes, 0..=7 (n = 7 − len).
    pub len: u8,
    /// c: no more segments follow.
    pub last: bool,
}

impl Segment {
    /// A segment carrying `data` (at most seven bytes; more are cut off).
    pub fn new(toggle: bool, data: &[u8], last: bool) -> Self {
        let len = data.len().min(7);
        let mut buf = [0u8; 7];
        buf[..len].copy_from_slice(&data[..len]);
        Self {
            toggle,
            data: buf,
            len: len as u8,
            last,
        }
    }

    /// The data bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.data[..usize::from(self.len.min(7))]
    }

    fn parse(b: &[u8; 8]) -> Self {
        let cmd = b[field::COMMAND];
        let n = (cmd & field::SEG_N_MASK) >> field::SEG_N_SHIFT;
        Self {
            toggle: toggle_of(cmd),
            data: seg7(b),
            len: 7 - n,
            last: cmd & field::LAST != 0,
        }
    }

    fn emit(&self, cs: u8) -> [u8; 8] {
        let n = 7 - self.len.min(7);
        let mut b = [0u8; 8];
        b[field::COMMAND] = (cs << field::CS_SHIFT)
            | toggle_flag(self.toggle)
            | (n << field::SEG_N_SHIFT)
            | if self.last { field::LAST } else { 0 };
        b[field::SEGMENT].copy_from_slice(&self.data);
        b
    }
}

/// A message from the SDO client to the server (except block download sub-block segments, see
/// [`BlockSegment`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ClientRequest {
    /// ccs = 1: initiate download (write), expedited or segmented.
    InitiateDownload {
        /// The object.
        mux: Multiplexer,
        /// Expedited data or the announced size.
        data: Initiate,
    },
    /// ccs = 0: download segment.
    DownloadSegment(Segment),
    /// ccs = 2: initiate upload (read).
    InitiateUpload {
        /// The object.
        mux: Multiplexer,
    },
    /// ccs = 3: upload segment request.
    UploadSegment {
        /// Toggle bit t.
        toggle: bool,
    },
    /// ccs = 4: abort transfer.
    Abort {
        /// The object of the aborted transfer.
        mux: Multiplexer,
        /// Why.
        code: AbortCode,
    },
    /// ccs = 6, cs = 0: initiate block download.
    BlockDownloadInitiate {
        /// The object.
        mux: Multiplexer,
        /// cc: the client supports CRC generation.
        crc: bool,
        /// s = 1: the object size.
        size: Option<u32>,
    },
    /// ccs = 6, cs = 1: end block download.
    BlockDownloadEnd {
        /// n: bytes of the last segment that carry no data (0..=7).
        unused: u8,
        /// CRC of the whole data (meaningful when both sides agreed on CRC).
        crc: u16,
    },
    /// ccs = 5, cs = 0: initiate block upload.
    BlockUploadInitiate {
        /// The object.
        mux: Multiplexer,
        /// cc: the client supports CRC checking.
        crc: bool,
        /// Segments per sub-block the client accepts, 1..=127.
        blksize: u8,
        /// Protocol switch threshold: the server may answer with a normal (expedited or
        /// segmented) upload when the object has at most `pst` bytes; 0 forbids switching.
        pst: u8,
    },
    /// ccs = 5, cs = 3: start sending the sub-blocks.
    BlockUploadStart,
    /// ccs = 5, cs = 2: sub-block acknowledged.
    BlockUploadAck {
        /// Sequence number of the last segment received in order (0: none).
        ackseq: u8,
        /// Segments per sub-block for the next sub-block, 1..=127.
        blksize: u8,
    },
    /// ccs = 5, cs = 1: end block upload (answer to the server's end message).
    BlockUploadEnd,
}

impl ClientRequest {
    /// Decodes a client request of 1..=8 bytes that holds the bytes its command needs (see
    /// the [module docs](self)). Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        let b = &padded(data, client_needs)?;
        let cmd = b[field::COMMAND];
        Ok(match cmd >> field::CS_SHIFT {
            0 => Self::DownloadSegment(Segment::parse(b)),
            1 => Self::InitiateDownload {
                mux: Multiplexer::read(b),
                data: Initiate::parse(b),
            },
            2 => Self::InitiateUpload {
                mux: Multiplexer::read(b),
            },
            3 => Self::UploadSegment {
                toggle: toggle_of(cmd),
            },
            4 => {
                let (mux, code) = parse_abort(b);
                Self::Abort { mux, code }
            }
            5 => match cmd & 0x03 {
                0 => Self::BlockUploadInitiate {
                    mux: Multiplexer::read(b),
                    crc: crc_of(cmd),
                    blksize: b[field::INIT_BLKSIZE],
                    pst: b[field::PST],
                },
                1 => Self::BlockUploadEnd,
                2 => {
                    let (ackseq, blksize) = parse_ack(b);
                    Self::BlockUploadAck { ackseq, blksize }
                }
                _ => Self::BlockUploadStart,
            },
            6 if cmd & 0x01 == 0 => {
                let (mux, crc, size) = parse_sized_block_initiate(b);
                Self::BlockDownloadInitiate { mux, crc, size }
            }
            6 => {
                let (unused, crc) = parse_block_end(b);
                Self::BlockDownloadEnd { unused, crc }
            }
            _ => return Err(DecodeError::UnknownCommand(cmd)),
        })
    }

    /// Encodes the request into its eight bytes. Out-of-range fields are clamped.
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            Self::DownloadSegment(seg) => seg.emit(0),
            Self::InitiateDownload { mux, data } => emit_initiate(1, mux, data),
            Self::InitiateUpload { mux } => emit_command(2, 0, Some(mux)),
            Self::UploadSegment { toggle } => emit_command(3, toggle_flag(toggle), None),
            Self::Abort { mux, code } => emit_abort(mux, code),
            Self::BlockUploadInitiate {
                mux,
                crc,
                blksize,
                pst,
            } => {
                let mut b = emit_command(5, crc_flag(crc), Some(mux));
                b[field::INIT_BLKSIZE] = blksize;
                b[field::PST] = pst;
                b
            }
            Self::BlockUploadEnd => emit_command(5, 1, None),
            Self::BlockUploadAck { ackseq, blksize } => emit_ack(5, ackseq, blksize),
            Self::BlockUploadStart => emit_command(5, 3, None),
            Self::BlockDownloadInitiate { mux, crc, size } => {
                emit_sized_block_initiate(6, mux, crc, size)
            }
            Self::BlockDownloadEnd { unused, crc } => emit_block_end(6, unused, crc),
        }
    }
}

/// A message from the SDO server to the client (except block upload sub-block segments, see
/// [`BlockSegment`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ServerResponse {
    /// scs = 2: initiate upload response, expedited data or the announced size.
    InitiateUpload {
        /// The object.
        mux: Multiplexer,
        /// Expedited data or the size of the segmented transfer.
        data: Initiate,
    },
    /// scs = 0: upload segment.
    UploadSegment(Segment),
    /// scs = 3: initiate download response.
    InitiateDownload {
        /// The object.
        mux: Multiplexer,
    },
    /// scs = 1: download segment response.
    DownloadSegment {
        /// Toggle bit t of the acknowledged segment.
        toggle: bool,
    },
    /// scs = 4: abort transfer.
    Abort {
        /// The object of the aborted transfer.
        mux: Multiplexer,
        /// Why.
        code: AbortCode,
    },
    /// scs = 5, ss = 0: initiate block download response.
    BlockDownloadInitiate {
        /// The object.
        mux: Multiplexer,
        /// sc: the server supports CRC checking.
        crc: bool,
        /// Segments per sub-block the server accepts, 1..=127.
        blksize: u8,
    },
    /// scs = 5, ss = 2: sub-block acknowledged.
    BlockDownloadAck {
        /// Sequence number of the last segment received in order (0: none).
        ackseq: u8,
        /// Segments per sub-block for the next sub-block, 1..=127.
        blksize: u8,
    },
    /// scs = 5, ss = 1: end block download response.
    BlockDownloadEnd,
    /// scs = 6, ss = 0: initiate block upload response.
    BlockUploadInitiate {
        /// The object.
        mux: Multiplexer,
        /// sc: the server supports CRC generation.
        crc: bool,
        /// s = 1: the object size.
        size: Option<u32>,
    },
    /// scs = 6, ss = 1: end block upload.
    BlockUploadEnd {
        /// n: bytes of the last segment that carry no data (0..=7).
        unused: u8,
        /// CRC of the whole data.
        crc: u16,
    },
}

impl ServerResponse {
    /// Decodes a server response of 1..=8 bytes that holds the bytes its command needs (see
    /// the [module docs](self)). Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        let b = &padded(data, server_needs)?;
        let cmd = b[field::COMMAND];
        Ok(match cmd >> field::CS_SHIFT {
            0 => Self::UploadSegment(Segment::parse(b)),
            1 => Self::DownloadSegment {
                toggle: toggle_of(cmd),
            },
            2 => Self::InitiateUpload {
                mux: Multiplexer::read(b),
                data: Initiate::parse(b),
            },
            3 => Self::InitiateDownload {
                mux: Multiplexer::read(b),
            },
            4 => {
                let (mux, code) = parse_abort(b);
                Self::Abort { mux, code }
            }
            5 => match cmd & 0x03 {
                0 => Self::BlockDownloadInitiate {
                    mux: Multiplexer::read(b),
                    crc: crc_of(cmd),
                    blksize: b[field::INIT_RESP_BLKSIZE],
                },
                1 => Self::BlockDownloadEnd,
                2 => {
                    let (ackseq, blksize) = parse_ack(b);
                    Self::BlockDownloadAck { ackseq, blksize }
                }
                _ => return Err(DecodeError::UnknownCommand(cmd)),
            },
            6 if cmd & 0x01 == 0 => {
                let (mux, crc, size) = parse_sized_block_initiate(b);
                Self::BlockUploadInitiate { mux, crc, size }
            }
            6 => {
                let (unused, crc) = parse_block_end(b);
                Self::BlockUploadEnd { unused, crc }
            }
            _ => return Err(DecodeError::UnknownCommand(cmd)),
        })
    }

    /// Encodes the response into its eight bytes. Out-of-range fields are clamped.
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            Self::UploadSegment(seg) => seg.emit(0),
            Self::DownloadSegment { toggle } => emit_command(1, toggle_flag(toggle), None),
            Self::InitiateUpload { mux, data } => emit_initiate(2, mux, data),
            Self::InitiateDownload { mux } => emit_command(3, 0, Some(mux)),
            Self::Abort { mux, code } => emit_abort(mux, code),
            Self::BlockDownloadInitiate { mux, crc, blksize } => {
                let mut b = emit_command(5, crc_flag(crc), Some(mux));
                b[field::INIT_RESP_BLKSIZE] = blksize;
                b
            }
            Self::BlockDownloadAck { ackseq, blksize } => emit_ack(5, ackseq, blksize),
            Self::BlockDownloadEnd => emit_command(5, 1, None),
            Self::BlockUploadInitiate { mux, crc, size } => {
                emit_sized_block_initiate(6, mux, crc, size)
            }
            Self::BlockUploadEnd { unused, crc } => emit_block_end(6, unused, crc),
        }
    }
}

// The fields client and server messages share: CiA 301 lays out the two directions' abort,
// initiate, block initiate, acknowledge and block end messages alike.

fn toggle_of(cmd: u8) -> bool {
    cmd & field::TOGGLE != 0
}

fn toggle_flag(toggle: bool) -> u8 {
    if toggle { field::TOGGLE } else { 0 }
}

fn crc_of(cmd: u8) -> bool {
    cmd & field::BLOCK_CRC != 0
}

fn crc_flag(crc: bool) -> u8 {
    if crc { field::BLOCK_CRC } else { 0 }
}

/// Byte 0 from the command specifier `cs` and `flags`, and the multiplexer if the message
/// carries one; the other bytes zero.
fn emit_command(cs: u8, flags: u8, mux: Option<Multiplexer>) -> [u8; 8] {
    let mut b = [0u8; 8];
    b[field::COMMAND] = (cs << field::CS_SHIFT) | flags;
    if let Some(mux) = mux {
        mux.write(&mut b);
    }
    b
}

fn emit_initiate(cs: u8, mux: Multiplexer, data: Initiate) -> [u8; 8] {
    let (flags, d) = data.emit();
    let mut b = emit_command(cs, flags, Some(mux));
    b[field::DATA].copy_from_slice(&d);
    b
}

fn parse_abort(b: &[u8; 8]) -> (Multiplexer, AbortCode) {
    (Multiplexer::read(b), AbortCode(u32_at_data(b)))
}

fn emit_abort(mux: Multiplexer, code: AbortCode) -> [u8; 8] {
    let mut b = emit_command(4, 0, Some(mux));
    b[field::DATA].copy_from_slice(&code.0.to_le_bytes());
    b
}

/// Initiate block download (client) and initiate block upload response (server): multiplexer,
/// CRC support and the size if indicated.
fn parse_sized_block_initiate(b: &[u8; 8]) -> (Multiplexer, bool, Option<u32>) {
    let cmd = b[field::COMMAND];
    (
        Multiplexer::read(b),
        crc_of(cmd),
        (cmd & field::BLOCK_SIZE != 0).then(|| u32_at_data(b)),
    )
}

fn emit_sized_block_initiate(cs: u8, mux: Multiplexer, crc: bool, size: Option<u32>) -> [u8; 8] {
    let size_flag = if size.is_some() { field::BLOCK_SIZE } else { 0 };
    let mut b = emit_command(cs, crc_flag(crc) | size_flag, Some(mux));
    b[field::DATA].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
    b
}

/// A sub-block acknowledgement: ackseq and the next blksize.
fn parse_ack(b: &[u8; 8]) -> (u8, u8) {
    (b[field::ACKSEQ], b[field::ACK_BLKSIZE])
}

fn emit_ack(cs: u8, ackseq: u8, blksize: u8) -> [u8; 8] {
    let mut b = emit_command(cs, 2, None);
    b[field::ACKSEQ] = ackseq;
    b[field::ACK_BLKSIZE] = blksize;
    b
}

/// End block download (client) and end block upload (server): unused bytes and CRC.
fn parse_block_end(b: &[u8; 8]) -> (u8, u16) {
    (
        (b[field::COMMAND] & field::END_N_MASK) >> field::END_N_SHIFT,
        u16::from_le_bytes([b[field::CRC.start], b[field::CRC.start + 1]]),
    )
}

fn emit_block_end(cs: u8, unused: u8, crc: u16) -> [u8; 8] {
    let mut b = emit_command(cs, ((unused.min(7)) << field::END_N_SHIFT) | 1, None);
    b[field::CRC].copy_from_slice(&crc.to_le_bytes());
    b
}

/// One segment of a block transfer's sub-block: `c`, a sequence number and seven bytes.
///
/// Sent by the client during block download and by the server during block upload. Valid
/// sequence numbers are 1..=127; `parse` keeps 0 as it is so the machine can answer it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BlockSegment {
    /// Sequence number within the sub-block, 1..=blksize (7 bits on the wire).
    pub seqno: u8,
    /// c: the last segment of the whole transfer.
    pub last: bool,
    /// Seven bytes; padding in the last segment is told by the end message's `n`.
    pub data: [u8; 7],
}

impl BlockSegment {
    /// Decodes a sub-block segment. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        let b = bytes8(data)?;
        Ok(Self {
            seqno: b[field::COMMAND] & field::SEQNO,
            last: b[field::COMMAND] & field::SEQ_LAST != 0,
            data: seg7(b),
        })
    }

    /// Encodes the segment; a sequence number above 127 loses its top bit.
    pub fn emit(&self) -> [u8; 8] {
        let mut b = [0u8; 8];
        b[field::COMMAND] =
            (self.seqno & field::SEQNO) | if self.last { field::SEQ_LAST } else { 0 };
        b[field::SEGMENT].copy_from_slice(&self.data);
        b
    }
}

/// Whether bytes received while a sub-block is expected are an abort transfer message rather
/// than a segment: byte 0 `0x80` would be a segment with the invalid sequence number 0.
pub(crate) fn is_abort(data: &[u8]) -> bool {
    data.len() == 8 && data.first() == Some(&0x80)
}

#[cfg(test)]
mod tests {
    use super::*;

    const M1000: Multiplexer = Multiplexer::new(0x1000, 0);
    const M1017: Multiplexer = Multiplexer::new(0x1017, 0);
    const M1008: Multiplexer = Multiplexer::new(0x1008, 0);

    fn client(bytes: [u8; 8], msg: ClientRequest) {
        assert_eq!(ClientRequest::parse(&bytes), Ok(msg), "parse {bytes:02x?}");
        assert_eq!(msg.emit(), bytes, "emit {msg:?}");
    }

    fn server(bytes: [u8; 8], msg: ServerResponse) {
        assert_eq!(ServerResponse::parse(&bytes), Ok(msg), "parse {bytes:02x?}");
        assert_eq!(msg.emit(), bytes, "emit {msg:?}");
    }

    #[test]
    fn initiate_upload_expedited() {
        // Read the device type 0x1000:00 = 0x00020191 (CiA 301 expedited upload).
        client(
            [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0],
            ClientRequest::InitiateUpload { mux: M1000 },
        );
        server(
            [0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x02, 0x00],
            ServerResponse::InitiateUpload {
                mux: M1000,
                data: Initiate::Expedited {
                    data: [0x91, 0x01, 0x02, 0x00],
                    size: Some(4),
                },
            },
        );
        // 1, 2 and 3 data bytes: n = 3, 2, 1.
        for (cmd, size) in [(0x4F, 1), (0x4B, 2), (0x47, 3)] {
            server(
                [cmd, 0x00, 0x10, 0x00, 0x05, 0, 0, 0],
                ServerResponse::InitiateUpload {
                    mux: M1000,
                    data: Initiate::Expedited {
                        data: [0x05, 0, 0, 0],
                        size: Some(size),
                    },
                },
            );
        }
        // e = 1, s = 0: four bytes of unspecified meaning.
        let msg = ServerResponse::parse(&[0x42, 0x00, 0x10, 0x00, 1, 2, 3, 4]).unwrap();
        assert_eq!(
            msg,
            ServerResponse::InitiateUpload {
                mux: M1000,
                data: Initiate::Expedited {
                    data: [1, 2, 3, 4],
                    size: None
                }
            }
        );
    }

    #[test]
    fn initiate_download_expedited() {
        // Write the producer heartbeat time 0x1017:00 = 1000 ms (UNSIGNED16).
        client(
            [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00],
            ClientRequest::InitiateDownload {
                mux: M1017,
                data: Initiate::expedited(&[0xE8, 0x03]).unwrap(),
            },
        );
        server(
            [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0],
            ServerResponse::InitiateDownload { mux: M1017 },
        );
        client(
            [0x2F, 0x17, 0x10, 0x00, 0x01, 0, 0, 0],
            ClientRequest::InitiateDownload {
                mux: M1017,
                data: Initiate::expedited(&[0x01]).unwrap(),
            },
        );
        client(
            [0x23, 0x17, 0x10, 0x00, 1, 2, 3, 4],
            ClientRequest::InitiateDownload {
                mux: M1017,
                data: Initiate::expedited(&[1, 2, 3, 4]).unwrap(),
            },
        );
        client(
            [0x22, 0x17, 0x10, 0x00, 1, 2, 3, 4],
            ClientRequest::InitiateDownload {
                mux: M1017,
                data: Initiate::Expedited {
                    data: [1, 2, 3, 4],
                    size: None,
                },
            },
        );
        assert_eq!(Initiate::expedited(&[]), None);
        assert_eq!(Initiate::expedited(&[0; 5]), None);
    }

    #[test]
    fn segmented_upload() {
        // Read the 26-byte device name 0x1008:00.
        server(
            [0x41, 0x08, 0x10, 0x00, 0x1A, 0x00, 0x00, 0x00],
            ServerResponse::InitiateUpload {
                mux: M1008,
                data: Initiate::Segmented { size: Some(26) },
            },
        );
        server(
            [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0],
            ServerResponse::InitiateUpload {
                mux: M1008,
                data: Initiate::Segmented { size: None },
            },
        );
        client(
            [0x60, 0, 0, 0, 0, 0, 0, 0],
            ClientRequest::UploadSegment { toggle: false },
        );
        client(
            [0x70, 0, 0, 0, 0, 0, 0, 0],
            ClientRequest::UploadSegment { toggle: true },
        );
        server(
            [0x00, b'B', b'u', b'r', b'k', b'e', b'r', b't'],
            ServerResponse::UploadSegment(Segment::new(false, b"Burkert", false)),
        );
        // Last segment, toggle 1, 3 data bytes: n = 4 -> 0x10 | 4 << 1 | 1.
        server(
            [0x19, b'x', b'y', b'z', 0, 0, 0, 0],
            ServerResponse::UploadSegment(Segment::new(true, b"xyz", true)),
        );
        // Empty last segment (zero-length object): n = 7.
        server(
            [0x0F, 0, 0, 0, 0, 0, 0, 0],
            ServerResponse::UploadSegment(Segment::new(false, b"", true)),
        );
    }

    #[test]
    fn segmented_download() {
        client(
            [0x21, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00],
            ClientRequest::InitiateDownload {
                mux: M1008,
                data: Initiate::Segmented { size: Some(20) },
            },
        );
        client(
            [0x00, 1, 2, 3, 4, 5, 6, 7],
            ClientRequest::DownloadSegment(Segment::new(false, &[1, 2, 3, 4, 5, 6, 7], false)),
        );
        // Toggle 1, last, 6 data bytes: 0x10 | 1 << 1 | 1.
        client(
            [0x13, 1, 2, 3, 4, 5, 6, 0],
            ClientRequest::DownloadSegment(Segment::new(true, &[1, 2, 3, 4, 5, 6], true)),
        );
        server(
            [0x20, 0, 0, 0, 0, 0, 0, 0],
            ServerResponse::DownloadSegment { toggle: false },
        );
        server(
            [0x30, 0, 0, 0, 0, 0, 0, 0],
            ServerResponse::DownloadSegment { toggle: true },
        );
    }

    #[test]
    fn abort() {
        // Object 0x6000:01 does not exist.
        let bytes = [0x80, 0x00, 0x60, 0x01, 0x00, 0x00, 0x02, 0x06];
        let mux = Multiplexer::new(0x6000, 1);
        client(
            bytes,
            ClientRequest::Abort {
                mux,
                code: AbortCode::OBJECT_DOES_NOT_EXIST,
            },
        );
        server(
            bytes,
            ServerResponse::Abort {
                mux,
                code: AbortCode::OBJECT_DOES_NOT_EXIST,
            },
        );
        assert!(is_abort(&bytes));
    }

    #[test]
    fn block_download() {
        let mux = Multiplexer::new(0x1F50, 1);
        // Initiate with CRC and size 1000.
        client(
            [0xC6, 0x50, 0x1F, 0x01, 0xE8, 0x03, 0x00, 0x00],
            ClientRequest::BlockDownloadInitiate {
                mux,
                crc: true,
                size: Some(1000),
            },
        );
        client(
            [0xC0, 0x50, 0x1F, 0x01, 0, 0, 0, 0],
            ClientRequest::BlockDownloadInitiate {
                mux,
                crc: false,
                size: None,
            },
        );
        server(
            [0xA4, 0x50, 0x1F, 0x01, 0x7F, 0, 0, 0],
            ServerResponse::BlockDownloadInitiate {
                mux,
                crc: true,
                blksize: 127,
            },
        );
        assert_eq!(
            BlockSegment::parse(&[0x05, 1, 2, 3, 4, 5, 6, 7]),
            Ok(BlockSegment {
                seqno: 5,
                last: false,
                data: [1, 2, 3, 4, 5, 6, 7]
            })
        );
        let last = BlockSegment {
            seqno: 0x7F,
            last: true,
            data: [9; 7],
        };
        assert_eq!(last.emit(), [0xFF, 9, 9, 9, 9, 9, 9, 9]);
        server(
            [0xA2, 0x7F, 0x40, 0, 0, 0, 0, 0],
            ServerResponse::BlockDownloadAck {
                ackseq: 127,
                blksize: 64,
            },
        );
        // End: 5 unused bytes, CRC 0x1234: 0xC1 | 5 << 2.
        client(
            [0xD5, 0x34, 0x12, 0, 0, 0, 0, 0],
            ClientRequest::BlockDownloadEnd {
                unused: 5,
                crc: 0x1234,
            },
        );
        server(
            [0xA1, 0, 0, 0, 0, 0, 0, 0],
            ServerResponse::BlockDownloadEnd,
        );
    }

    #[test]
    fn block_upload() {
        let mux = Multiplexer::new(0x2010, 0);
        client(
            [0xA4, 0x10, 0x20, 0x00, 0x7F, 0x15, 0, 0],
            ClientRequest::BlockUploadInitiate {
                mux,
                crc: true,
                blksize: 127,
                pst: 21,
            },
        );
        server(
            [0xC6, 0x10, 0x20, 0x00, 0x00, 0x10, 0x00, 0x00],
            ServerResponse::BlockUploadInitiate {
                mux,
                crc: true,
                size: Some(4096),
            },
        );
        client([0xA3, 0, 0, 0, 0, 0, 0, 0], ClientRequest::BlockUploadStart);
        client(
            [0xA2, 0x10, 0x7F, 0, 0, 0, 0, 0],
            ClientRequest::BlockUploadAck {
                ackseq: 16,
                blksize: 127,
            },
        );
        server(
            [0xC9, 0xC3, 0x31, 0, 0, 0, 0, 0],
            ServerResponse::BlockUploadEnd {
                unused: 2,
                crc: 0x31C3,
            },
        );
        client([0xA1, 0, 0, 0, 0, 0, 0, 0], ClientRequest::BlockUploadEnd);
    }

    #[test]
    fn errors() {
        assert_eq!(ClientRequest::parse(&[]), Err(DecodeError::Length(0)));
        assert_eq!(ClientRequest::parse(&[0; 9]), Err(DecodeError::Length(9)));
        // Short frames: enough for an initiate download response, not for an abort.
        assert_eq!(
            ServerResponse::parse(&[0x60, 0x17, 0x10, 0x00]),
            Ok(ServerResponse::InitiateDownload { mux: M1017 })
        );
        assert_eq!(
            ServerResponse::parse(&[0x60, 0x17, 0x10]),
            Err(DecodeError::Short {
                command: 0x60,
                needs: 4,
                len: 3
            })
        );
        assert_eq!(
            ClientRequest::parse(&[0x80, 0x17, 0x10, 0x00, 0, 0, 0]),
            Err(DecodeError::Short {
                command: 0x80,
                needs: 8,
                len: 7
            })
        );
        assert_eq!(BlockSegment::parse(&[0; 9]), Err(DecodeError::Length(9)));
        assert_eq!(
            ClientRequest::parse(&[0xE0, 0, 0, 0, 0, 0, 0, 0]),
            Err(DecodeError::UnknownCommand(0xE0))
        );
        assert_eq!(
            ServerResponse::parse(&[0xE0, 0, 0, 0, 0, 0, 0, 0]),
            Err(DecodeError::UnknownCommand(0xE0))
        );
        // scs = 5 with ss = 3 is not defined.
        assert_eq!(
            ServerResponse::parse(&[0xA3, 0, 0, 0, 0, 0, 0, 0]),
            Err(DecodeError::UnknownCommand(0xA3))
        );
    }

    #[test]
    fn texts() {
        extern crate std;
        use std::string::ToString;
        let c = |b: [u8; 8]| ClientRequest::parse(&b).unwrap().to_string();
        let s = |b: [u8; 8]| ServerResponse::parse(&b).unwrap().to_string();
        assert_eq!(
            c([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            "SDO initiate upload request 0x1018:01"
        );
        assert_eq!(
            s([0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x02, 0x00]),
            "SDO initiate upload response 0x1000:00, expedited, 4 bytes 91 01 02 00"
        );
        assert_eq!(
            c([0x2F, 0x17, 0x10, 0x00, 0x01, 0, 0, 0]),
            "SDO initiate download request 0x1017:00, expedited, 1 byte 01"
        );
        assert_eq!(
            c([0x22, 0x17, 0x10, 0x00, 1, 2, 3, 4]),
            "SDO initiate download request 0x1017:00, expedited, size not indicated, 01 02 03 04"
        );
        assert_eq!(
            s([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]),
            "SDO initiate download response 0x1017:00"
        );
        assert_eq!(
            s([0x41, 0x08, 0x10, 0x00, 0x1A, 0, 0, 0]),
            "SDO initiate upload response 0x1008:00, segmented, 26 bytes"
        );
        assert_eq!(
            c([0x21, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            "SDO initiate download request 0x1008:00, segmented, 0 bytes"
        );
        assert_eq!(
            s([0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            "SDO initiate upload response 0x1008:00, segmented, size not indicated"
        );
        assert_eq!(
            c([0x70, 0, 0, 0, 0, 0, 0, 0]),
            "SDO upload segment request toggle 1"
        );
        assert_eq!(
            s([0x19, b'x', b'y', b'z', 0, 0, 0, 0]),
            "SDO upload segment response toggle 1, 3 bytes 78 79 7a, last"
        );
        assert_eq!(
            s([0x0F, 0, 0, 0, 0, 0, 0, 0]),
            "SDO upload segment response toggle 0, 0 bytes, last"
        );
        assert_eq!(
            c([0x00, 1, 2, 3, 4, 5, 6, 7]),
            "SDO download segment request toggle 0, 7 bytes 01 02 03 04 05 06 07"
        );
        assert_eq!(
            s([0x30, 0, 0, 0, 0, 0, 0, 0]),
            "SDO download segment response toggle 1"
        );
        let abort = [0x80, 0x00, 0x60, 0x01, 0x00, 0x00, 0x02, 0x06];
        let text = "SDO abort transfer 0x6000:01: 0x06020000 (Object does not exist in the object dictionary)";
        assert_eq!(c(abort), text);
        assert_eq!(s(abort), text);
        assert_eq!(
            c([0xC6, 0x50, 0x1F, 0x01, 0xE8, 0x03, 0, 0]),
            "SDO initiate block download request 0x1F50:01, CRC, 1000 bytes"
        );
        assert_eq!(
            c([0xC0, 0x50, 0x1F, 0x01, 0, 0, 0, 0]),
            "SDO initiate block download request 0x1F50:01, no CRC, size not indicated"
        );
        assert_eq!(
            s([0xA4, 0x50, 0x1F, 0x01, 0x7F, 0, 0, 0]),
            "SDO initiate block download response 0x1F50:01, CRC, blksize 127"
        );
        assert_eq!(
            s([0xA2, 0x7F, 0x40, 0, 0, 0, 0, 0]),
            "SDO block download response ackseq 127, blksize 64"
        );
        assert_eq!(
            c([0xD5, 0x34, 0x12, 0, 0, 0, 0, 0]),
            "SDO end block download request, 5 bytes of the last segment unused, CRC 0x1234"
        );
        assert_eq!(
            s([0xA1, 0, 0, 0, 0, 0, 0, 0]),
            "SDO end block download response"
        );
        assert_eq!(
            c([0xA4, 0x10, 0x20, 0x00, 0x7F, 0x15, 0, 0]),
            "SDO initiate block upload request 0x2010:00, CRC, blksize 127, pst 21"
        );
        assert_eq!(
            s([0xC6, 0x10, 0x20, 0x00, 0x00, 0x10, 0x00, 0x00]),
            "SDO initiate block upload response 0x2010:00, CRC, 4096 bytes"
        );
        assert_eq!(
            c([0xA3, 0, 0, 0, 0, 0, 0, 0]),
            "SDO start block upload request"
        );
        assert_eq!(
            c([0xA2, 0x10, 0x7F, 0, 0, 0, 0, 0]),
            "SDO block upload response ackseq 16, blksize 127"
        );
        assert_eq!(
            s([0xC9, 0xC3, 0x31, 0, 0, 0, 0, 0]),
            "SDO end block upload request, 2 bytes of the last segment unused, CRC 0x31c3"
        );
        assert_eq!(
            c([0xA1, 0, 0, 0, 0, 0, 0, 0]),
            "SDO end block upload response"
        );
        assert_eq!(
            BlockSegment::parse(&[0x85, 1, 2, 3, 4, 5, 6, 7])
                .unwrap()
                .to_string(),
            "SDO block segment 5, 01 02 03 04 05 06 07, last"
        );
        use crate::server::ServerEvent;
        let mux = Multiplexer::new(0x2000, 1);
        assert_eq!(
            ServerEvent::Downloaded { mux, len: 4 }.to_string(),
            "SDO download of 0x2000:01 done, 4 bytes"
        );
        assert_eq!(
            ServerEvent::Aborted {
                mux,
                code: AbortCode::READ_ONLY
            }
            .to_string(),
            "SDO server aborted 0x2000:01: 0x06010002 (Attempt to write a read only object)"
        );
        assert_eq!(crate::Method::Block.to_string(), "block");
        assert_eq!(crate::Direction::Upload.to_string(), "upload");
    }

    #[test]
    fn every_byte_pattern_parses_or_errors_and_reemits_canonically() {
        for cmd in 0..=255u8 {
            let bytes = [cmd, 0x34, 0x12, 0x05, 0xAA, 0xBB, 0xCC, 0xDD];
            if let Ok(msg) = ClientRequest::parse(&bytes) {
                assert_eq!(ClientRequest::parse(&msg.emit()), Ok(msg));
            }
            if let Ok(msg) = ServerResponse::parse(&bytes) {
                assert_eq!(ServerResponse::parse(&msg.emit()), Ok(msg));
            }
            let seg = BlockSegment::parse(&bytes).unwrap();
            assert_eq!(seg.emit(), bytes);
        }
    }
}
