//! How an SDO client transfer ends unsuccessfully: the server's refusal ([`ErrorKind::ServerAbort`])
//! kept apart from local failures (timeout, cancel, a full buffer) and from protocol violations
//! by the server ([`Violation`], each with the abort code the client sends for it).

use crate::abort::AbortCode;
use crate::wire::Multiplexer;

/// A transfer was refused because another one runs or its completion was not yet polled. Holds
/// the buffer that was passed in.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("an SDO transfer is already in progress")]
pub struct Busy<T>(pub T);

debug_as_display!(Busy<T>);

/// Why a transfer failed, and for which object.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("SDO 0x{index:04X}:{subindex:02X}: {kind}")]
pub struct TransferError {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub subindex: u8,
    /// What went wrong.
    pub kind: ErrorKind,
}

debug_as_display!(TransferError);

impl TransferError {
    /// The object.
    pub const fn mux(&self) -> Multiplexer {
        Multiplexer::new(self.index, self.subindex)
    }

    /// The abort code that went over the bus, in either direction: the server's for
    /// [`ErrorKind::ServerAbort`], ours otherwise.
    pub const fn abort_code(&self) -> AbortCode {
        self.kind.abort_code()
    }

    /// Whether the server refused (aborted), rather than a local failure.
    pub const fn is_server_abort(&self) -> bool {
        matches!(self.kind, ErrorKind::ServerAbort(_))
    }
}

/// What ended a transfer. The server's refusal is kept apart from local failures.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The server aborted the transfer with this code.
    #[error("server aborted: {0}")]
    ServerAbort(AbortCode),
    /// The server did not answer within the timeout; abort 0x05040000 was sent.
    #[error("no response from the server (timeout); sent abort 0x05040000")]
    Timeout,
    /// The caller cancelled the transfer; this code was sent to the server.
    #[error("cancelled; sent abort {0}")]
    Cancelled(AbortCode),
    /// The server broke the protocol; the transfer was aborted with
    /// [`Violation::abort_code`].
    #[error("protocol violation by the server: {0}")]
    Protocol(Violation),
    /// The sink could not take the data; abort 0x05040005 (out of memory) was sent.
    #[error("the upload does not fit the buffer; sent abort 0x05040005")]
    BufferFull,
}

debug_as_display!(ErrorKind);

impl ErrorKind {
    /// The abort code that went over the bus for this failure.
    pub const fn abort_code(&self) -> AbortCode {
        match *self {
            Self::ServerAbort(code) | Self::Cancelled(code) => code,
            Self::Timeout => AbortCode::TIMEOUT,
            Self::Protocol(v) => v.abort_code(),
            Self::BufferFull => AbortCode::OUT_OF_MEMORY,
        }
    }
}

/// A protocol error detected by a machine, with the abort code it sends for it.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Violation {
    /// A message the protocol state does not allow (0x05040001).
    #[error("unexpected or unknown command (abort 0x05040001)")]
    UnexpectedCommand,
    /// The toggle bit did not alternate (0x05030000).
    #[error("toggle bit not alternated (abort 0x05030000)")]
    Toggle,
    /// A block size outside 1..=127 (0x05040002).
    #[error("invalid block size {0} (abort 0x05040002)")]
    BlockSize(u8),
    /// A sequence number that cannot occur (0x05040003).
    #[error("invalid sequence number {0} (abort 0x05040003)")]
    SequenceNumber(u8),
    /// The CRC of the data differs from the one sent (0x05040004).
    #[error("CRC mismatch: computed {computed:#06x}, received {received:#06x} (abort 0x05040004)")]
    Crc {
        /// CRC over the bytes received.
        computed: u16,
        /// CRC in the end message.
        received: u16,
    },
    /// A frame shorter than the bytes its command needs (0x05040001).
    #[error("frame too short for its command (abort 0x05040001)")]
    ShortFrame,
    /// More data than the announced size (0x06070012).
    #[error("more data than the announced {size} bytes (abort 0x06070012)")]
    TooLong {
        /// The announced size.
        size: u32,
    },
    /// Less data than the announced size (0x06070013).
    #[error("{received} bytes instead of the announced {size} (abort 0x06070013)")]
    TooShort {
        /// The announced size.
        size: u32,
        /// Bytes received.
        received: u32,
    },
}

debug_as_display!(Violation);

impl Violation {
    /// The abort code sent for this violation.
    pub const fn abort_code(&self) -> AbortCode {
        match self {
            Self::UnexpectedCommand | Self::ShortFrame => AbortCode::INVALID_COMMAND,
            Self::Toggle => AbortCode::TOGGLE_BIT_NOT_ALTERNATED,
            Self::BlockSize(_) => AbortCode::INVALID_BLOCK_SIZE,
            Self::SequenceNumber(_) => AbortCode::INVALID_SEQUENCE_NUMBER,
            Self::Crc { .. } => AbortCode::CRC_ERROR,
            Self::TooLong { .. } => AbortCode::LENGTH_TOO_HIGH,
            Self::TooShort { .. } => AbortCode::LENGTH_TOO_LOW,
        }
    }
}
