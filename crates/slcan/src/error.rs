//! The codec's errors: a line that does not parse, and a buffer too small to encode into.

/// Why a line (a command or an adapter's reply, without its terminator) did not parse.
///
/// The decoder counts these and skips the line; nothing here is fatal to the stream.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LineError {
    /// A byte that is not printable ASCII inside a line (the decoder drops the rest of the line).
    #[error("byte {0:#04x} is not printable ASCII")]
    BadByte(u8),
    /// The line is longer than [`MAX_LINE`](crate::MAX_LINE) (the decoder drops it up to the next
    /// CR or BEL).
    #[error("line longer than {} characters", crate::MAX_LINE)]
    TooLong,
    /// A command line with nothing in it.
    #[error("empty command line")]
    Empty,
    /// A command letter this codec does not know.
    #[error("unknown command '{}'", char::from(*.0))]
    UnknownCommand(u8),
    /// A character that should have been a hexadecimal digit.
    #[error("'{}' is not a hexadecimal digit", char::from(*.0))]
    BadHex(u8),
    /// The line ends before its last field.
    #[error("line ends early")]
    Truncated,
    /// The identifier does not fit its format (standard above 0x7FF, extended above 0x1FFFFFFF).
    #[error("identifier {0:#x} out of range")]
    IdOutOfRange(u32),
    /// A length digit outside '0'..='8' (classic) or '0'..='F' (CAN FD).
    #[error("bad length digit '{}'", char::from(*.0))]
    BadDlc(u8),
    /// Characters after a frame that are neither a 4- or 8-digit timestamp nor an ESI digit.
    #[error("{0} unexpected characters after the frame data")]
    BadTrailer(usize),
    /// Characters after a complete command.
    #[error("unexpected characters after the command")]
    TrailingCharacters,
    /// A digit argument outside its range (`S`, `Y`, `Z`).
    #[error("argument '{}' out of range", char::from(*.0))]
    BadArgument(u8),
    /// A status (`F`), bus state (`s`) or bus error (`e`) line of the wrong shape.
    #[error("malformed '{}' line", char::from(*.0))]
    Malformed(u8),
}

debug_as_display!(LineError);

/// Why a command or line could not be encoded.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is shorter than the line; `needed` bytes are required.
    #[error("output buffer too small: {needed} bytes needed")]
    BufferTooSmall {
        /// The encoded length, terminator included.
        needed: usize,
    },
}

debug_as_display!(EncodeError);
