//! The USDO frames on the wire (CiA 1301): a raw view ([`UsdoPacket`]) over the data bytes of a
//! CAN FD frame with the field offsets in one `field` module, and the typed [`UsdoMessage`]
//! with a total [`parse`](UsdoMessage::parse) and an [`emit`](UsdoMessage::emit).
//!
//! Every frame starts with the destination node-ID, the command specifier and the session-ID.
//! The layout below is SOFA-CANopenFD's (see the [assumptions table](crate::usdo::assumed) for what rests on it):
//!
//! | cs   | frame                              | bytes | after byte 2                                   |
//! |------|------------------------------------|-------|------------------------------------------------|
//! | 0x01 | expedited download request         | 8+N   | sub, index LE, data type, N, data (N ≤ 56)     |
//! | 0x21 | expedited download response        | 6     | sub, index LE                                  |
//! | 0x11 | upload request                     | 6     | sub, index LE                                  |
//! | 0x31 | expedited upload response          | 8+N   | sub, index LE, data type, N, data (N ≤ 56)     |
//! | 0x02 | segmented download initiate        | 12    | sub, index LE, data type, 0, size u32 LE       |
//! | 0x22 | segmented download initiate resp.  | 6     | sub, index LE                                  |
//! | 0x03 | download segment                   | 64    | counter, 60 data bytes                         |
//! | 0x23 | download segment response          | 4     | counter                                        |
//! | 0x04 | download end                       | 4+n   | n (1..=60), data                               |
//! | 0x24 | download end response              | 3     | —                                              |
//! | 0x32 | segmented upload initiate response | 12    | sub, index LE, data type, 0, size u32 LE       |
//! | 0x13 | upload segment request             | 4     | counter                                        |
//! | 0x33 | upload segment response            | 64    | counter, 60 data bytes                         |
//! | 0x34 | upload end response                | 4+n   | n (0..=60), data                               |
//! | 0x7F | abort (both directions)            | 7     | sub, index LE, 1-byte abort code               |
//!
//! Senders pad a frame to the next CAN FD length with zeros; `parse` accepts any bytes after
//! the protocol length (padding). `parse` is total: any byte slice gives a message or a
//! [`UsdoDecodeError`], never a panic. The reserved byte of the initiate frames is ignored on
//! parse and written as zero, so `parse(emit(m)) == m` for every message `m` whose fields are in
//! range ([`emit`](UsdoMessage::emit) refuses the others).

use crate::usdo::abort::UsdoAbortCode;
use crate::usdo::assumed::{self, SEGMENT_DATA};
use crate::wire::Multiplexer;

/// The most data bytes an expedited frame carries (CiA text: 56 of 64; SOFA agrees).
pub const MAX_EXPEDITED: usize = 56;

/// The longest USDO frame.
pub const MAX_FRAME: usize = 64;

/// Byte offsets of the USDO frames.
mod field {
    use core::ops::Range;

    use crate::usdo::assumed;

    pub(super) const DESTINATION: usize = 0;
    pub(super) const COMMAND: usize = 1;
    pub(super) const SESSION: usize = 2;
    /// Frames with the multiplexer.
    pub(super) const SUBINDEX: usize = assumed::SUBINDEX_AT;
    pub(super) const INDEX: Range<usize> = assumed::INDEX_AT..assumed::INDEX_AT + 2;
    /// Expedited and initiate frames.
    pub(super) const DATA_TYPE: usize = 6;
    /// Expedited frames: data length N.
    pub(super) const DATA_LEN: usize = 7;
    /// Expedited frames: data.
    pub(super) const EXPEDITED_DATA: usize = 8;
    /// Initiate frames: reserved byte, then the total size.
    pub(super) const RESERVED: usize = 7;
    pub(super) const SIZE: Range<usize> = 8..12;
    /// Segment frames: counter; end frames: data length n.
    pub(super) const COUNTER: usize = 3;
    pub(super) const END_LEN: usize = 3;
    pub(super) const SEGMENT: usize = 4;
    /// Abort frames.
    pub(super) const ABORT_CODE: usize = 6;

    /// Header length: destination, command, session.
    pub(super) const HEADER: usize = 3;
    /// With the multiplexer.
    pub(super) const MUX_HEADER: usize = 6;
    pub(super) const EXPEDITED_HEADER: usize = 8;
    pub(super) const INITIATE: usize = 12;
    pub(super) const ABORT: usize = 7;
}

/// Why bytes are not a USDO frame.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum UsdoDecodeError {
    /// Shorter than the command needs.
    #[error("USDO frame with command {command:#04x} needs {needed} bytes, has {len}")]
    TooShort {
        /// The command byte (0 when even it is missing).
        command: u8,
        /// Bytes the command needs.
        needed: usize,
        /// Bytes present.
        len: usize,
    },
    /// A command specifier outside the table.
    #[error("unknown USDO command specifier {0:#04x}")]
    UnknownCommand(u8),
    /// A remote (routed) service: its layout is not established.
    #[error("remote USDO service {0:#04x} is not supported")]
    Remote(u8),
    /// Session-ID 0.
    #[error("USDO session-ID 0 is not valid")]
    SessionZero,
    /// A data length field out of range for the command (expedited above 56, end above 60,
    /// download end 0).
    #[error("USDO command {command:#04x} with invalid data length {len}")]
    DataLength {
        /// The command byte.
        command: u8,
        /// The length field.
        len: u8,
    },
}

debug_as_display!(UsdoDecodeError);

/// Why a message cannot be written.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum UsdoEncodeError {
    /// Data longer than the frame allows (56 expedited, 60 end), or an empty download end.
    #[error("{len} data bytes do not fit this USDO frame")]
    DataLength {
        /// The data length.
        len: usize,
    },
    /// Session-ID 0.
    #[error("USDO session-ID 0 is not valid")]
    SessionZero,
}

debug_as_display!(UsdoEncodeError);

/// A data type code (CiA 301 §7.4.7.1, the codes of objects 0x0001..=0x001B) in the USDO data
/// type byte. Open: every `u8` is kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DataType(pub u8);

impl DataType {
    /// BOOLEAN.
    pub const BOOLEAN: Self = Self(0x01);
    /// INTEGER8.
    pub const INTEGER8: Self = Self(0x02);
    /// INTEGER16.
    pub const INTEGER16: Self = Self(0x03);
    /// INTEGER32.
    pub const INTEGER32: Self = Self(0x04);
    /// UNSIGNED8.
    pub const UNSIGNED8: Self = Self(0x05);
    /// UNSIGNED16.
    pub const UNSIGNED16: Self = Self(0x06);
    /// UNSIGNED32.
    pub const UNSIGNED32: Self = Self(0x07);
    /// REAL32.
    pub const REAL32: Self = Self(0x08);
    /// VISIBLE_STRING.
    pub const VISIBLE_STRING: Self = Self(0x09);
    /// OCTET_STRING.
    pub const OCTET_STRING: Self = Self(0x0A);
    /// UNICODE_STRING.
    pub const UNICODE_STRING: Self = Self(0x0B);
    /// TIME_OF_DAY.
    pub const TIME_OF_DAY: Self = Self(0x0C);
    /// TIME_DIFFERENCE.
    pub const TIME_DIFFERENCE: Self = Self(0x0D);
    /// DOMAIN.
    pub const DOMAIN: Self = Self(0x0F);
    /// INTEGER24.
    pub const INTEGER24: Self = Self(0x10);
    /// REAL64.
    pub const REAL64: Self = Self(0x11);
    /// INTEGER64.
    pub const INTEGER64: Self = Self(0x15);
    /// UNSIGNED24.
    pub const UNSIGNED24: Self = Self(0x16);
    /// UNSIGNED64.
    pub const UNSIGNED64: Self = Self(0x1B);

    /// The size in bytes of a value of this type when it is fixed (`None` for strings,
    /// DOMAIN and unknown codes).
    pub const fn fixed_size(self) -> Option<u32> {
        Some(match self.0 {
            0x01 | 0x02 | 0x05 => 1,
            0x03 | 0x06 => 2,
            0x10 | 0x16 => 3,
            0x04 | 0x07 | 0x08 => 4,
            0x12 | 0x18 => 5,
            0x0C | 0x0D | 0x13 | 0x19 => 6,
            0x14 | 0x1A => 7,
            0x11 | 0x15 | 0x1B => 8,
            _ => return None,
        })
    }
}

impl Default for DataType {
    /// [`DataType::DOMAIN`], what SOFA always sends.
    fn default() -> Self {
        Self(assumed::DEFAULT_DATA_TYPE)
    }
}

/// A raw view over the data bytes of a USDO frame: getters by field, each `None` when the
/// buffer is too short for it. Never panics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UsdoPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> UsdoPacket<T> {
    /// A view over `buffer` without checks.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// A view over `buffer` that holds at least the three header bytes.
    pub fn new_checked(buffer: T) -> Result<Self, UsdoDecodeError> {
        let len = buffer.as_ref().len();
        if len < field::HEADER {
            return Err(UsdoDecodeError::TooShort {
                command: buffer.as_ref().get(field::COMMAND).copied().unwrap_or(0),
                needed: field::HEADER,
                len,
            });
        }
        Ok(Self { buffer })
    }

    /// The underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    fn byte(&self, at: usize) -> Option<u8> {
        self.buffer.as_ref().get(at).copied()
    }

    /// Byte 0: the destination node-ID.
    pub fn destination(&self) -> Option<u8> {
        self.byte(field::DESTINATION)
    }

    /// Byte 1: the command specifier.
    pub fn command(&self) -> Option<u8> {
        self.byte(field::COMMAND)
    }

    /// Byte 2: the session-ID.
    pub fn session(&self) -> Option<u8> {
        self.byte(field::SESSION)
    }

    /// The multiplexer (frames that carry one).
    pub fn mux(&self) -> Option<Multiplexer> {
        let b = self.buffer.as_ref();
        let index = b.get(field::INDEX)?;
        Some(Multiplexer::new(
            u16::from_le_bytes([index[0], index[1]]),
            *b.get(field::SUBINDEX)?,
        ))
    }

    /// The data type byte (expedited and initiate frames).
    pub fn data_type(&self) -> Option<DataType> {
        self.byte(field::DATA_TYPE).map(DataType)
    }

    /// The data length byte of an expedited frame.
    pub fn expedited_len(&self) -> Option<u8> {
        self.byte(field::DATA_LEN)
    }

    /// The total size of an initiate frame.
    pub fn size(&self) -> Option<u32> {
        let s = self.buffer.as_ref().get(field::SIZE)?;
        Some(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    /// The segment counter of segment frames (the data length of end frames: same byte).
    pub fn counter(&self) -> Option<u8> {
        self.byte(field::COUNTER)
    }

    /// The abort code of an abort frame.
    pub fn abort_code(&self) -> Option<UsdoAbortCode> {
        self.byte(field::ABORT_CODE).map(UsdoAbortCode)
    }
}

/// What a USDO frame says after its destination and session-ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UsdoBody<'a> {
    /// 0x01: write `data` (up to 56 bytes) to `mux`.
    DownloadExpedited {
        /// The object.
        mux: Multiplexer,
        /// The data type of `data`.
        data_type: DataType,
        /// The value.
        data: &'a [u8],
    },
    /// 0x21: the expedited write is done.
    DownloadExpeditedResponse {
        /// The object.
        mux: Multiplexer,
    },
    /// 0x11: read `mux`.
    Upload {
        /// The object.
        mux: Multiplexer,
    },
    /// 0x31: the value of `mux` (up to 56 bytes).
    UploadExpeditedResponse {
        /// The object.
        mux: Multiplexer,
        /// The data type of `data`.
        data_type: DataType,
        /// The value.
        data: &'a [u8],
    },
    /// 0x02: a segmented write of `size` bytes to `mux` begins.
    DownloadInitiate {
        /// The object.
        mux: Multiplexer,
        /// The data type of the value.
        data_type: DataType,
        /// Total bytes.
        size: u32,
    },
    /// 0x22: the server accepts the segmented write.
    DownloadInitiateResponse {
        /// The object.
        mux: Multiplexer,
    },
    /// 0x03: a full segment of a write.
    DownloadSegment {
        /// Segment number (0 first).
        counter: u8,
        /// 60 bytes.
        data: &'a [u8; SEGMENT_DATA],
    },
    /// 0x23: the server took segment `counter`.
    DownloadSegmentResponse {
        /// The counter echoed.
        counter: u8,
    },
    /// 0x04: the last 1..=60 bytes of a write.
    DownloadEnd {
        /// The data.
        data: &'a [u8],
    },
    /// 0x24: the segmented write is done.
    DownloadEndResponse,
    /// 0x32: the value of `mux` follows in segments, `size` bytes in total.
    UploadInitiateResponse {
        /// The object.
        mux: Multiplexer,
        /// The data type of the value.
        data_type: DataType,
        /// Total bytes.
        size: u32,
    },
    /// 0x13: send segment `counter`.
    UploadSegment {
        /// Segment number (0 first).
        counter: u8,
    },
    /// 0x33: a full segment of a read.
    UploadSegmentResponse {
        /// The counter of the request.
        counter: u8,
        /// 60 bytes.
        data: &'a [u8; SEGMENT_DATA],
    },
    /// 0x34: the last 0..=60 bytes of a read.
    UploadEnd {
        /// The data.
        data: &'a [u8],
    },
    /// 0x7F: the sender aborts the transfer.
    Abort {
        /// The object (as the sender knows it).
        mux: Multiplexer,
        /// Why.
        code: UsdoAbortCode,
    },
}

impl UsdoBody<'_> {
    /// The command specifier.
    pub const fn command(&self) -> u8 {
        use assumed::*;
        match self {
            Self::DownloadExpedited { .. } => CS_DOWNLOAD_EXPEDITED,
            Self::DownloadExpeditedResponse { .. } => CS_DOWNLOAD_EXPEDITED_RESPONSE,
            Self::Upload { .. } => CS_UPLOAD,
            Self::UploadExpeditedResponse { .. } => CS_UPLOAD_EXPEDITED_RESPONSE,
            Self::DownloadInitiate { .. } => CS_DOWNLOAD_INITIATE,
            Self::DownloadInitiateResponse { .. } => CS_DOWNLOAD_INITIATE_RESPONSE,
            Self::DownloadSegment { .. } => CS_DOWNLOAD_SEGMENT,
            Self::DownloadSegmentResponse { .. } => CS_DOWNLOAD_SEGMENT_RESPONSE,
            Self::DownloadEnd { .. } => CS_DOWNLOAD_END,
            Self::DownloadEndResponse => CS_DOWNLOAD_END_RESPONSE,
            Self::UploadInitiateResponse { .. } => CS_UPLOAD_INITIATE_RESPONSE,
            Self::UploadSegment { .. } => CS_UPLOAD_SEGMENT,
            Self::UploadSegmentResponse { .. } => CS_UPLOAD_SEGMENT_RESPONSE,
            Self::UploadEnd { .. } => CS_UPLOAD_END,
            Self::Abort { .. } => CS_ABORT,
        }
    }

    /// Whether a server sends this (responses; an abort goes either way and counts as both).
    pub const fn is_response(&self) -> bool {
        matches!(self, Self::Abort { .. }) || self.command() & 0x20 != 0
    }

    /// Whether a client sends this.
    pub const fn is_request(&self) -> bool {
        matches!(self, Self::Abort { .. }) || self.command() & 0x20 == 0
    }
}

/// One USDO frame: destination node-ID, session-ID and body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UsdoMessage<'a> {
    /// The receiver's node-ID (1..=127 unicast; other values are not established).
    pub destination: u8,
    /// The session-ID (1..=255), chosen by the client.
    pub session: u8,
    /// The rest.
    pub body: UsdoBody<'a>,
}

impl<'a> UsdoMessage<'a> {
    /// Decodes the data bytes of a frame; bytes after the protocol length are padding.
    pub fn parse(data: &'a [u8]) -> Result<Self, UsdoDecodeError> {
        use assumed::*;
        let p = UsdoPacket::new_checked(data)?;
        let (Some(destination), Some(command), Some(session)) =
            (p.destination(), p.command(), p.session())
        else {
            // new_checked guarantees the header; kept total anyway.
            return Err(UsdoDecodeError::TooShort {
                command: 0,
                needed: field::HEADER,
                len: data.len(),
            });
        };
        if command & REMOTE_FLAG != 0 {
            return Err(UsdoDecodeError::Remote(command));
        }
        let needed = match command {
            CS_DOWNLOAD_EXPEDITED | CS_UPLOAD_EXPEDITED_RESPONSE => field::EXPEDITED_HEADER,
            CS_DOWNLOAD_EXPEDITED_RESPONSE | CS_UPLOAD | CS_DOWNLOAD_INITIATE_RESPONSE => {
                field::MUX_HEADER
            }
            CS_DOWNLOAD_INITIATE | CS_UPLOAD_INITIATE_RESPONSE => field::INITIATE,
            CS_DOWNLOAD_SEGMENT | CS_UPLOAD_SEGMENT_RESPONSE => field::SEGMENT + SEGMENT_DATA,
            CS_DOWNLOAD_SEGMENT_RESPONSE | CS_UPLOAD_SEGMENT | CS_DOWNLOAD_END | CS_UPLOAD_END => {
                field::SEGMENT
            }
            CS_DOWNLOAD_END_RESPONSE => field::HEADER,
            CS_ABORT => field::ABORT,
            _ => return Err(UsdoDecodeError::UnknownCommand(command)),
        };
        let short = |needed| UsdoDecodeError::TooShort {
            command,
            needed,
            len: data.len(),
        };
        if data.len() < needed {
            return Err(short(needed));
        }
        if !SESSION_ZERO_VALID && session == 0 {
            return Err(UsdoDecodeError::SessionZero);
        }
        let bad_len = |len| UsdoDecodeError::DataLength { command, len };
        // Every getter below is within `needed`; the `ok_or` paths cannot be taken.
        let mux = || p.mux().ok_or(short(field::MUX_HEADER));
        let counter = || p.counter().ok_or(short(field::SEGMENT));
        let slice = |at: usize, len: usize| data.get(at..at + len);
        let tail = |at: usize, n: u8| slice(at, usize::from(n)).ok_or(short(at + usize::from(n)));
        let segment = || {
            slice(field::SEGMENT, SEGMENT_DATA)
                .and_then(|s| <&[u8; SEGMENT_DATA]>::try_from(s).ok())
                .ok_or(short(field::SEGMENT + SEGMENT_DATA))
        };
        let body = match command {
            CS_DOWNLOAD_EXPEDITED | CS_UPLOAD_EXPEDITED_RESPONSE => {
                let n = p.expedited_len().unwrap_or(0);
                if usize::from(n) > MAX_EXPEDITED {
                    return Err(bad_len(n));
                }
                let mux = mux()?;
                let data_type = p.data_type().unwrap_or_default();
                let data = tail(field::EXPEDITED_DATA, n)?;
                if command == CS_DOWNLOAD_EXPEDITED {
                    UsdoBody::DownloadExpedited {
                        mux,
                        data_type,
                        data,
                    }
                } else {
                    UsdoBody::UploadExpeditedResponse {
                        mux,
                        data_type,
                        data,
                    }
                }
            }
            CS_DOWNLOAD_EXPEDITED_RESPONSE => UsdoBody::DownloadExpeditedResponse { mux: mux()? },
            CS_UPLOAD => UsdoBody::Upload { mux: mux()? },
            CS_DOWNLOAD_INITIATE_RESPONSE => UsdoBody::DownloadInitiateResponse { mux: mux()? },
            CS_DOWNLOAD_INITIATE | CS_UPLOAD_INITIATE_RESPONSE => {
                let mux = mux()?;
                let data_type = p.data_type().unwrap_or_default();
                let size = p.size().ok_or(short(field::INITIATE))?;
                if command == CS_DOWNLOAD_INITIATE {
                    UsdoBody::DownloadInitiate {
                        mux,
                        data_type,
                        size,
                    }
                } else {
                    UsdoBody::UploadInitiateResponse {
                        mux,
                        data_type,
                        size,
                    }
                }
            }
            CS_DOWNLOAD_SEGMENT => UsdoBody::DownloadSegment {
                counter: counter()?,
                data: segment()?,
            },
            CS_UPLOAD_SEGMENT_RESPONSE => UsdoBody::UploadSegmentResponse {
                counter: counter()?,
                data: segment()?,
            },
            CS_DOWNLOAD_SEGMENT_RESPONSE => UsdoBody::DownloadSegmentResponse {
                counter: counter()?,
            },
            CS_UPLOAD_SEGMENT => UsdoBody::UploadSegment {
                counter: counter()?,
            },
            CS_DOWNLOAD_END | CS_UPLOAD_END => {
                let n = counter()?;
                if usize::from(n) > SEGMENT_DATA || (command == CS_DOWNLOAD_END && n == 0) {
                    return Err(bad_len(n));
                }
                let data = tail(field::SEGMENT, n)?;
                if command == CS_DOWNLOAD_END {
                    UsdoBody::DownloadEnd { data }
                } else {
                    UsdoBody::UploadEnd { data }
                }
            }
            CS_DOWNLOAD_END_RESPONSE => UsdoBody::DownloadEndResponse,
            _ => UsdoBody::Abort {
                mux: mux()?,
                code: p.abort_code().ok_or(short(field::ABORT))?,
            },
        };
        Ok(Self {
            destination,
            session,
            body,
        })
    }

    /// The protocol length of this frame (before padding to a CAN FD length).
    pub fn buffer_len(&self) -> usize {
        match self.body {
            UsdoBody::DownloadExpedited { data, .. }
            | UsdoBody::UploadExpeditedResponse { data, .. } => {
                field::EXPEDITED_HEADER + data.len()
            }
            UsdoBody::DownloadExpeditedResponse { .. }
            | UsdoBody::Upload { .. }
            | UsdoBody::DownloadInitiateResponse { .. } => field::MUX_HEADER,
            UsdoBody::DownloadInitiate { .. } | UsdoBody::UploadInitiateResponse { .. } => {
                field::INITIATE
            }
            UsdoBody::DownloadSegment { .. } | UsdoBody::UploadSegmentResponse { .. } => {
                field::SEGMENT + SEGMENT_DATA
            }
            UsdoBody::DownloadSegmentResponse { .. } | UsdoBody::UploadSegment { .. } => {
                field::SEGMENT
            }
            UsdoBody::DownloadEnd { data } | UsdoBody::UploadEnd { data } => {
                field::SEGMENT + data.len()
            }
            UsdoBody::DownloadEndResponse => field::HEADER,
            UsdoBody::Abort { .. } => field::ABORT,
        }
    }

    /// Writes the frame into `out` and returns its protocol length; the bytes after it are
    /// zeroed, so `out[..padded_len(n)]` is the padded frame. Fails for data that does not fit
    /// the frame and for session-ID 0.
    pub fn emit(&self, out: &mut [u8; MAX_FRAME]) -> Result<usize, UsdoEncodeError> {
        if !assumed::SESSION_ZERO_VALID && self.session == 0 {
            return Err(UsdoEncodeError::SessionZero);
        }
        let too_long = |len| UsdoEncodeError::DataLength { len };
        match self.body {
            UsdoBody::DownloadExpedited { data, .. }
            | UsdoBody::UploadExpeditedResponse { data, .. }
                if data.len() > MAX_EXPEDITED =>
            {
                return Err(too_long(data.len()));
            }
            UsdoBody::DownloadEnd { data } if data.is_empty() || data.len() > SEGMENT_DATA => {
                return Err(too_long(data.len()));
            }
            UsdoBody::UploadEnd { data } if data.len() > SEGMENT_DATA => {
                return Err(too_long(data.len()));
            }
            _ => {}
        }
        *out = [0; MAX_FRAME];
        out[field::DESTINATION] = self.destination;
        out[field::COMMAND] = self.body.command();
        out[field::SESSION] = self.session;
        let put_mux = |out: &mut [u8; MAX_FRAME], mux: Multiplexer| {
            out[field::SUBINDEX] = mux.subindex;
            out[field::INDEX].copy_from_slice(&mux.index.to_le_bytes());
        };
        match self.body {
            UsdoBody::DownloadExpedited {
                mux,
                data_type,
                data,
            }
            | UsdoBody::UploadExpeditedResponse {
                mux,
                data_type,
                data,
            } => {
                put_mux(out, mux);
                out[field::DATA_TYPE] = data_type.0;
                out[field::DATA_LEN] = data.len() as u8;
                out[field::EXPEDITED_DATA..field::EXPEDITED_DATA + data.len()]
                    .copy_from_slice(data);
            }
            UsdoBody::DownloadExpeditedResponse { mux }
            | UsdoBody::Upload { mux }
            | UsdoBody::DownloadInitiateResponse { mux } => put_mux(out, mux),
            UsdoBody::DownloadInitiate {
                mux,
                data_type,
                size,
            }
            | UsdoBody::UploadInitiateResponse {
                mux,
                data_type,
                size,
            } => {
                put_mux(out, mux);
                out[field::DATA_TYPE] = data_type.0;
                out[field::RESERVED] = 0;
                out[field::SIZE].copy_from_slice(&size.to_le_bytes());
            }
            UsdoBody::DownloadSegment { counter, data }
            | UsdoBody::UploadSegmentResponse { counter, data } => {
                out[field::COUNTER] = counter;
                out[field::SEGMENT..field::SEGMENT + SEGMENT_DATA].copy_from_slice(data);
            }
            UsdoBody::DownloadSegmentResponse { counter } | UsdoBody::UploadSegment { counter } => {
                out[field::COUNTER] = counter;
            }
            UsdoBody::DownloadEnd { data } | UsdoBody::UploadEnd { data } => {
                out[field::END_LEN] = data.len() as u8;
                out[field::SEGMENT..field::SEGMENT + data.len()].copy_from_slice(data);
            }
            UsdoBody::DownloadEndResponse => {}
            UsdoBody::Abort { mux, code } => {
                put_mux(out, mux);
                out[field::ABORT_CODE] = code.0;
            }
        }
        Ok(self.buffer_len())
    }

    /// The frame's bytes padded with zeros to the next CAN FD length.
    pub fn to_bytes(&self) -> Result<heapless::Vec<u8, MAX_FRAME>, UsdoEncodeError> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.emit(&mut buf)?;
        let padded = canola_frame::fd::padded_len(n).unwrap_or(MAX_FRAME);
        let mut v = heapless::Vec::new();
        // Cannot fail: `padded` is at most 64.
        let _ = v.extend_from_slice(&buf[..padded]);
        Ok(v)
    }
}

impl core::fmt::Display for DataType {
    /// `0x07`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:#04x}", self.0)
    }
}

impl core::fmt::Display for UsdoMessage<'_> {
    /// One line for logs and monitors: `to 5, session 7: download 0x2000:01 type 0x07, 4
    /// bytes: 78 56 34 12`, `to 1, session 9: download segment 0 confirmed`, `to 1, session 11:
    /// abort 0x6000:00: 0x33 (Object does not exist in the object dictionary)`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use canola_frame::HexBytes;
        write!(f, "to {}, session {}: ", self.destination, self.session)?;
        match self.body {
            UsdoBody::DownloadExpedited {
                mux,
                data_type,
                data,
            } => write!(
                f,
                "download {mux} type {data_type}, {} bytes: {}",
                data.len(),
                HexBytes(data)
            ),
            UsdoBody::DownloadExpeditedResponse { mux } => write!(f, "download {mux} done"),
            UsdoBody::Upload { mux } => write!(f, "upload {mux}"),
            UsdoBody::UploadExpeditedResponse {
                mux,
                data_type,
                data,
            } => write!(
                f,
                "upload {mux} type {data_type}, {} bytes: {}",
                data.len(),
                HexBytes(data)
            ),
            UsdoBody::DownloadInitiate {
                mux,
                data_type,
                size,
            } => write!(f, "segmented download {mux} type {data_type}, {size} bytes"),
            UsdoBody::DownloadInitiateResponse { mux } => {
                write!(f, "segmented download {mux} accepted")
            }
            UsdoBody::DownloadSegment { counter, data } => {
                write!(f, "download segment {counter}: {}", HexBytes(data))
            }
            UsdoBody::DownloadSegmentResponse { counter } => {
                write!(f, "download segment {counter} confirmed")
            }
            UsdoBody::DownloadEnd { data } => {
                write!(f, "download end, {} bytes: {}", data.len(), HexBytes(data))
            }
            UsdoBody::DownloadEndResponse => f.write_str("download end confirmed"),
            UsdoBody::UploadInitiateResponse {
                mux,
                data_type,
                size,
            } => write!(f, "segmented upload {mux} type {data_type}, {size} bytes"),
            UsdoBody::UploadSegment { counter } => write!(f, "upload segment {counter} requested"),
            UsdoBody::UploadSegmentResponse { counter, data } => {
                write!(f, "upload segment {counter}: {}", HexBytes(data))
            }
            UsdoBody::UploadEnd { data } => {
                write!(f, "upload end, {} bytes: {}", data.len(), HexBytes(data))
            }
            UsdoBody::Abort { mux, code } => write!(f, "abort {mux}: {code}"),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use proptest::prelude::*;

    use super::*;

    fn mux(index: u16, subindex: u8) -> Multiplexer {
        Multiplexer::new(index, subindex)
    }

    fn emit(m: &UsdoMessage<'_>) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME];
        let n = m.emit(&mut buf).unwrap();
        buf[..n].to_vec()
    }

    /// Each frame kind as bytes, laid out as SOFA-CANopenFD's `fbsec_co_fd_usdo.c` builds them
    /// (tables in ../shared/spec/usdo.md §5–7): client node 0x01, server node 0x05.
    #[test]
    fn byte_vectors() {
        let seg: [u8; 60] = core::array::from_fn(|i| i as u8);
        let cases: Vec<(Vec<u8>, UsdoMessage<'_>)> = std::vec![
            // Expedited write of UNSIGNED32 0x12345678 to 0x2000:01, session 7.
            (
                std::vec![
                    0x05, 0x01, 0x07, 0x01, 0x00, 0x20, 0x07, 0x04, 0x78, 0x56, 0x34, 0x12
                ],
                UsdoMessage {
                    destination: 5,
                    session: 7,
                    body: UsdoBody::DownloadExpedited {
                        mux: mux(0x2000, 1),
                        data_type: DataType::UNSIGNED32,
                        data: &[0x78, 0x56, 0x34, 0x12],
                    },
                },
            ),
            (
                std::vec![0x01, 0x21, 0x07, 0x01, 0x00, 0x20],
                UsdoMessage {
                    destination: 1,
                    session: 7,
                    body: UsdoBody::DownloadExpeditedResponse {
                        mux: mux(0x2000, 1)
                    },
                },
            ),
            // Read 0x1018:01.
            (
                std::vec![0x05, 0x11, 0x08, 0x01, 0x18, 0x10],
                UsdoMessage {
                    destination: 5,
                    session: 8,
                    body: UsdoBody::Upload {
                        mux: mux(0x1018, 1)
                    },
                },
            ),
            (
                std::vec![0x01, 0x31, 0x08, 0x01, 0x18, 0x10, 0x0F, 0x02, 0xAA, 0xBB],
                UsdoMessage {
                    destination: 1,
                    session: 8,
                    body: UsdoBody::UploadExpeditedResponse {
                        mux: mux(0x1018, 1),
                        data_type: DataType::DOMAIN,
                        data: &[0xAA, 0xBB],
                    },
                },
            ),
            // Segmented write of 100 bytes to 0x2100:00.
            (
                std::vec![0x05, 0x02, 0x09, 0x00, 0x00, 0x21, 0x0F, 0x00, 100, 0, 0, 0],
                UsdoMessage {
                    destination: 5,
                    session: 9,
                    body: UsdoBody::DownloadInitiate {
                        mux: mux(0x2100, 0),
                        data_type: DataType::DOMAIN,
                        size: 100,
                    },
                },
            ),
            (
                std::vec![0x01, 0x22, 0x09, 0x00, 0x00, 0x21],
                UsdoMessage {
                    destination: 1,
                    session: 9,
                    body: UsdoBody::DownloadInitiateResponse {
                        mux: mux(0x2100, 0)
                    },
                },
            ),
            (
                [&[0x05, 0x03, 0x09, 0x00][..], &seg[..]].concat(),
                UsdoMessage {
                    destination: 5,
                    session: 9,
                    body: UsdoBody::DownloadSegment {
                        counter: 0,
                        data: &seg
                    },
                },
            ),
            (
                std::vec![0x01, 0x23, 0x09, 0x00],
                UsdoMessage {
                    destination: 1,
                    session: 9,
                    body: UsdoBody::DownloadSegmentResponse { counter: 0 },
                },
            ),
            (
                [&[0x05, 0x04, 0x09, 40][..], &seg[..40]].concat(),
                UsdoMessage {
                    destination: 5,
                    session: 9,
                    body: UsdoBody::DownloadEnd { data: &seg[..40] },
                },
            ),
            (
                std::vec![0x01, 0x24, 0x09],
                UsdoMessage {
                    destination: 1,
                    session: 9,
                    body: UsdoBody::DownloadEndResponse,
                },
            ),
            // Segmented read of 0x1008:00, 70 bytes.
            (
                std::vec![0x01, 0x32, 0x0A, 0x00, 0x08, 0x10, 0x09, 0x00, 70, 0, 0, 0],
                UsdoMessage {
                    destination: 1,
                    session: 10,
                    body: UsdoBody::UploadInitiateResponse {
                        mux: mux(0x1008, 0),
                        data_type: DataType::VISIBLE_STRING,
                        size: 70,
                    },
                },
            ),
            (
                std::vec![0x05, 0x13, 0x0A, 0x00],
                UsdoMessage {
                    destination: 5,
                    session: 10,
                    body: UsdoBody::UploadSegment { counter: 0 },
                },
            ),
            (
                [&[0x01, 0x33, 0x0A, 0x00][..], &seg[..]].concat(),
                UsdoMessage {
                    destination: 1,
                    session: 10,
                    body: UsdoBody::UploadSegmentResponse {
                        counter: 0,
                        data: &seg
                    },
                },
            ),
            (
                [&[0x01, 0x34, 0x0A, 10][..], &seg[..10]].concat(),
                UsdoMessage {
                    destination: 1,
                    session: 10,
                    body: UsdoBody::UploadEnd { data: &seg[..10] },
                },
            ),
            // Abort: object 0x6000:00 does not exist (0x33).
            (
                std::vec![0x01, 0x7F, 0x0B, 0x00, 0x00, 0x60, 0x33],
                UsdoMessage {
                    destination: 1,
                    session: 11,
                    body: UsdoBody::Abort {
                        mux: mux(0x6000, 0),
                        code: UsdoAbortCode::OBJECT_DOES_NOT_EXIST,
                    },
                },
            ),
        ];
        assert_eq!(
            std::format!("{}", cases[0].1),
            "to 5, session 7: download 0x2000:01 type 0x07, 4 bytes: 78 56 34 12"
        );
        assert_eq!(
            std::format!("{}", cases[14].1),
            "to 1, session 11: abort 0x6000:00: 0x33 (Object does not exist in the object dictionary)"
        );
        for (bytes, msg) in &cases {
            assert!(!std::format!("{msg}").is_empty());
            assert_eq!(&emit(msg), bytes, "{msg:?}");
            assert_eq!(UsdoMessage::parse(bytes).as_ref(), Ok(msg));
            // Zero padding to the next FD length is accepted.
            let padded = msg.to_bytes().unwrap();
            assert_eq!(
                canola_frame::fd::padded_len(bytes.len()),
                Some(padded.len())
            );
            assert_eq!(UsdoMessage::parse(&padded).as_ref(), Ok(msg));
        }
    }

    #[test]
    fn errors() {
        use UsdoDecodeError as E;
        assert_eq!(
            UsdoMessage::parse(&[5, 0x11]),
            Err(E::TooShort {
                command: 0x11,
                needed: 3,
                len: 2
            })
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0x11, 1, 0, 0]),
            Err(E::TooShort {
                command: 0x11,
                needed: 6,
                len: 5
            })
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0x45, 1]),
            Err(E::UnknownCommand(0x45))
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0xFF, 1, 0, 0, 0x60, 0x33]),
            Err(E::Remote(0xFF))
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0x11, 0, 0, 0, 0x10]),
            Err(E::SessionZero)
        );
        // Expedited N above 56, N beyond the frame, end n of 0 and above 60.
        let mut long = [0u8; 64];
        long[..8].copy_from_slice(&[5, 0x01, 1, 0, 0, 0x20, 0x0F, 57]);
        assert_eq!(
            UsdoMessage::parse(&long),
            Err(E::DataLength {
                command: 1,
                len: 57
            })
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0x01, 1, 0, 0, 0x20, 0x0F, 4, 1, 2]),
            Err(E::TooShort {
                command: 1,
                needed: 12,
                len: 10
            })
        );
        assert_eq!(
            UsdoMessage::parse(&[5, 0x04, 1, 0]),
            Err(E::DataLength { command: 4, len: 0 })
        );
        assert_eq!(UsdoMessage::parse(&[0; 64]), Err(E::UnknownCommand(0)));
        let mut end = [0u8; 64];
        end[..4].copy_from_slice(&[1, 0x34, 1, 61]);
        assert_eq!(
            UsdoMessage::parse(&end),
            Err(E::DataLength {
                command: 0x34,
                len: 61
            })
        );
        // Emit refuses what it cannot write.
        let mut buf = [0u8; MAX_FRAME];
        let big = [0u8; 57];
        let m = UsdoMessage {
            destination: 5,
            session: 1,
            body: UsdoBody::DownloadExpedited {
                mux: mux(0x2000, 0),
                data_type: DataType::DOMAIN,
                data: &big,
            },
        };
        assert_eq!(
            m.emit(&mut buf),
            Err(UsdoEncodeError::DataLength { len: 57 })
        );
        let m = UsdoMessage {
            destination: 5,
            session: 0,
            body: UsdoBody::DownloadEndResponse,
        };
        assert_eq!(m.emit(&mut buf), Err(UsdoEncodeError::SessionZero));
        let m = UsdoMessage {
            destination: 5,
            session: 1,
            body: UsdoBody::DownloadEnd { data: &[] },
        };
        assert_eq!(
            m.emit(&mut buf),
            Err(UsdoEncodeError::DataLength { len: 0 })
        );
    }

    #[test]
    fn raw_view() {
        let bytes = [
            0x05, 0x02, 0x09, 0x03, 0x00, 0x21, 0x07, 0x00, 0x10, 0x27, 0, 0,
        ];
        let p = UsdoPacket::new_checked(&bytes[..]).unwrap();
        assert_eq!(p.destination(), Some(5));
        assert_eq!(p.command(), Some(2));
        assert_eq!(p.session(), Some(9));
        assert_eq!(p.mux(), Some(mux(0x2100, 3)));
        assert_eq!(p.data_type(), Some(DataType::UNSIGNED32));
        assert_eq!(p.size(), Some(10_000));
        let short = UsdoPacket::new_checked(&bytes[..4]).unwrap();
        assert_eq!(
            (short.mux(), short.size(), short.abort_code()),
            (None, None, None)
        );
        assert!(UsdoPacket::new_checked(&bytes[..2]).is_err());
    }

    #[test]
    fn direction_and_types() {
        assert!(UsdoBody::Upload { mux: mux(1, 0) }.is_request());
        assert!(!UsdoBody::Upload { mux: mux(1, 0) }.is_response());
        assert!(UsdoBody::DownloadEndResponse.is_response());
        let abort = UsdoBody::Abort {
            mux: mux(1, 0),
            code: UsdoAbortCode(0x60),
        };
        assert!(abort.is_request() && abort.is_response());
        assert_eq!(DataType::UNSIGNED32.fixed_size(), Some(4));
        assert_eq!(DataType::DOMAIN.fixed_size(), None);
        assert_eq!(DataType::default(), DataType::DOMAIN);
    }

    proptest! {
        #[test]
        fn any_bytes_decode_or_fail(bytes in proptest::collection::vec(any::<u8>(), 0..=64)) {
            if let Ok(m) = UsdoMessage::parse(&bytes) {
                // What decodes, encodes to the same protocol bytes.
                let out = emit(&m);
                prop_assert_eq!(&out[..], &bytes[..out.len()].iter().enumerate()
                    .map(|(i, b)| if i == 7 && matches!(m.body, UsdoBody::DownloadInitiate { .. } | UsdoBody::UploadInitiateResponse { .. }) { 0 } else { *b })
                    .collect::<Vec<_>>()[..]);
            }
        }

        #[test]
        fn round_trip(
            kind in 0u8..15,
            destination in any::<u8>(),
            session in 1u8..,
            index in any::<u16>(),
            subindex in any::<u8>(),
            dt in any::<u8>(),
            size in any::<u32>(),
            counter in any::<u8>(),
            code in any::<u8>(),
            data in proptest::collection::vec(any::<u8>(), 1..=60),
            seg in proptest::array::uniform32(any::<u8>()),
        ) {
            let m = mux(index, subindex);
            let data_type = DataType(dt);
            let segment: [u8; 60] = core::array::from_fn(|i| seg[i % 32] ^ i as u8);
            let short = &data[..data.len().min(MAX_EXPEDITED)];
            let body = match kind {
                0 => UsdoBody::DownloadExpedited { mux: m, data_type, data: short },
                1 => UsdoBody::DownloadExpeditedResponse { mux: m },
                2 => UsdoBody::Upload { mux: m },
                3 => UsdoBody::UploadExpeditedResponse { mux: m, data_type, data: short },
                4 => UsdoBody::DownloadInitiate { mux: m, data_type, size },
                5 => UsdoBody::DownloadInitiateResponse { mux: m },
                6 => UsdoBody::DownloadSegment { counter, data: &segment },
                7 => UsdoBody::DownloadSegmentResponse { counter },
                8 => UsdoBody::DownloadEnd { data: &data },
                9 => UsdoBody::DownloadEndResponse,
                10 => UsdoBody::UploadInitiateResponse { mux: m, data_type, size },
                11 => UsdoBody::UploadSegment { counter },
                12 => UsdoBody::UploadSegmentResponse { counter, data: &segment },
                13 => UsdoBody::UploadEnd { data: &data },
                _ => UsdoBody::Abort { mux: m, code: UsdoAbortCode(code) },
            };
            let msg = UsdoMessage { destination, session, body };
            let bytes = msg.to_bytes().unwrap();
            prop_assert!(canola_frame::fd::is_valid_len(bytes.len()));
            prop_assert_eq!(UsdoMessage::parse(&bytes), Ok(msg));
        }
    }
}
