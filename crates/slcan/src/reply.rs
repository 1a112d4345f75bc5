//! Adapter-to-host lines: acknowledgements, received frames, query answers and the kernel
//! driver's bus state and error lines. [`Item::parse`] classifies one line by its first character.

use core::fmt;

use crate::error::LineError;
use crate::frame::{self, RxFrame};
use crate::hex;

/// Printable ASCII text of a reply line (at most [`MAX_LINE`](crate::MAX_LINE) characters), kept
/// without an allocator.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Text {
    len: u8,
    buf: [u8; crate::MAX_LINE],
}

impl Text {
    /// Copies `s` (printable ASCII, at most `MAX_LINE` bytes); `None` otherwise.
    pub fn new(s: &[u8]) -> Option<Self> {
        if s.len() > crate::MAX_LINE || s.iter().any(|b| !(0x20..0x7F).contains(b)) {
            return None;
        }
        let mut buf = [0; crate::MAX_LINE];
        buf[..s.len()].copy_from_slice(s);
        Some(Self {
            len: s.len() as u8,
            buf,
        })
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        // Only printable ASCII is ever stored.
        core::str::from_utf8(&self.buf[..usize::from(self.len)]).unwrap_or("")
    }
}

impl fmt::Debug for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl fmt::Display for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The flags of an `Fxx` status reply, read and cleared by the `F` command.
///
/// Bit meanings follow Lawicel CAN232 as Nakakiyo's firmware documents it. mac-can's SLCAN
/// library declares the bits in the reverse order, and EasySYNC adapters use another layout:
/// treat the bits as advisory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct StatusFlags(pub u8);

impl StatusFlags {
    /// Bit 0: receive FIFO full.
    pub const RX_FIFO_FULL: u8 = 1 << 0;
    /// Bit 1: transmit FIFO full.
    pub const TX_FIFO_FULL: u8 = 1 << 1;
    /// Bit 2: error warning (an error counter reached 96).
    pub const ERROR_WARNING: u8 = 1 << 2;
    /// Bit 3: data overrun (a frame was lost).
    pub const DATA_OVERRUN: u8 = 1 << 3;
    /// Bit 5: error passive (an error counter reached 128).
    pub const ERROR_PASSIVE: u8 = 1 << 5;
    /// Bit 6: arbitration lost.
    pub const ARBITRATION_LOST: u8 = 1 << 6;
    /// Bit 7: bus error.
    pub const BUS_ERROR: u8 = 1 << 7;

    /// Whether every bit of `mask` is set.
    pub const fn contains(self, mask: u8) -> bool {
        self.0 & mask == mask
    }
}

/// The controller state of a kernel-style `s` line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorState {
    /// `a`: error-active.
    Active,
    /// `w`: error warning.
    Warning,
    /// `p`: error-passive.
    Passive,
    /// `b`: bus-off.
    BusOff,
}

/// A bus state line, `s` + state + 3 decimal digits of receive and 3 of transmit error count
/// (`sa057033`). Only the Linux kernel driver documents it; it parses it as a host.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BusState {
    /// The controller state.
    pub state: ErrorState,
    /// Receive error counter.
    pub rx_errors: u16,
    /// Transmit error counter.
    pub tx_errors: u16,
}

/// The error kinds of a kernel-style `e` line (`e` + count + that many letters, e.g. `e2ac`), as
/// a set of bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct BusErrors(pub u8);

impl BusErrors {
    /// `a`: acknowledgement error.
    pub const ACK: u8 = 1 << 0;
    /// `b`: bit 0 error.
    pub const BIT0: u8 = 1 << 1;
    /// `B`: bit 1 error.
    pub const BIT1: u8 = 1 << 2;
    /// `c`: CRC error.
    pub const CRC: u8 = 1 << 3;
    /// `f`: form error.
    pub const FORM: u8 = 1 << 4;
    /// `o`: receive overrun.
    pub const RX_OVERRUN: u8 = 1 << 5;
    /// `O`: transmit overrun.
    pub const TX_OVERRUN: u8 = 1 << 6;
    /// `s`: stuff error.
    pub const STUFF: u8 = 1 << 7;

    const LETTERS: [(u8, u8); 8] = [
        (b'a', Self::ACK),
        (b'b', Self::BIT0),
        (b'B', Self::BIT1),
        (b'c', Self::CRC),
        (b'f', Self::FORM),
        (b'o', Self::RX_OVERRUN),
        (b'O', Self::TX_OVERRUN),
        (b's', Self::STUFF),
    ];
}

/// One line (or lone BEL) from the adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Item {
    /// A bare CR: the previous command succeeded.
    Ok,
    /// A BEL: the previous command failed (unknown, wrong state, bad argument).
    Error,
    /// `z` or `Z` alone: a `t`/`r` (`extended == false`) or `T`/`R` frame was queued (Lawicel).
    TxAck {
        /// Whether it acknowledges an extended-identifier frame (`Z`).
        extended: bool,
    },
    /// A frame received from the bus.
    Frame(RxFrame),
    /// `V…`: the version reply; Lawicel sends `Vhhss` (see [`Item::lawicel_version`]). The text
    /// after the `V`.
    Version(Text),
    /// `N…`: the serial number reply; the text after the `N`.
    Serial(Text),
    /// `Fxx`: the status flags.
    Status(StatusFlags),
    /// A kernel-style bus state line.
    BusState(BusState),
    /// A kernel-style bus error line.
    BusErrors(BusErrors),
    /// Any other printable line: CANable's free-text version reply, `v` details, Tx event
    /// reports, and text with a space or punctuation that starts with a frame letter. Not an
    /// error; the caller decides what it means.
    Other(Text),
}

impl Item {
    /// Classifies one line (without its CR). An empty line is [`Item::Ok`]. Never panics.
    pub fn parse(line: &[u8]) -> Result<Self, LineError> {
        if let Some(&b) = line.iter().find(|&&b| !(0x20..0x7F).contains(&b)) {
            return Err(LineError::BadByte(b));
        }
        if line.len() > crate::MAX_LINE {
            return Err(LineError::TooLong);
        }
        let Some((&letter, rest)) = line.split_first() else {
            return Ok(Self::Ok);
        };
        let text = |s: &[u8]| Text::new(s).ok_or(LineError::TooLong);
        match letter {
            // A frame line is letters and digits only; free text that happens to start with a
            // frame letter (CANable's version reply starts with a git hash) is not a bad frame.
            c if frame::is_frame_letter(c) && line.iter().all(u8::is_ascii_alphanumeric) => {
                let (frame, trailer) = frame::parse_frame(line)?;
                let (timestamp, esi) = frame::parse_trailer(trailer)?;
                Ok(Self::Frame(RxFrame {
                    frame,
                    timestamp,
                    esi,
                }))
            }
            b'z' | b'Z' if rest.is_empty() => Ok(Self::TxAck {
                extended: letter == b'Z',
            }),
            b'V' => Ok(Self::Version(text(rest)?)),
            b'N' => Ok(Self::Serial(text(rest)?)),
            b'F' => match rest {
                [_, _] => hex::number(rest)
                    .map(|v| Self::Status(StatusFlags(v as u8)))
                    .map_err(|_| LineError::Malformed(b'F')),
                _ => Err(LineError::Malformed(b'F')),
            },
            b's' => parse_state(rest).map(Self::BusState),
            b'e' => parse_errors(rest).map(Self::BusErrors),
            _ => Ok(Self::Other(text(line)?)),
        }
    }

    /// The hardware and software versions of a Lawicel `Vhhss` reply, each two decimal digits
    /// (python-can reads them the same way). `None` for other items and free-text versions.
    pub fn lawicel_version(&self) -> Option<(u8, u8)> {
        let Self::Version(t) = self else { return None };
        let b = t.as_str().as_bytes();
        if b.len() != 4 || !b.iter().all(u8::is_ascii_digit) {
            return None;
        }
        Some((
            (b[0] - b'0') * 10 + b[1] - b'0',
            (b[2] - b'0') * 10 + b[3] - b'0',
        ))
    }
}

fn parse_state(rest: &[u8]) -> Result<BusState, LineError> {
    let bad = LineError::Malformed(b's');
    let [s, counters @ ..] = rest else {
        return Err(bad);
    };
    let state = match s {
        b'a' => ErrorState::Active,
        b'w' => ErrorState::Warning,
        b'p' => ErrorState::Passive,
        b'b' => ErrorState::BusOff,
        _ => return Err(bad),
    };
    if counters.len() != 6 || !counters.iter().all(u8::is_ascii_digit) {
        return Err(bad);
    }
    let dec = |d: &[u8]| d.iter().fold(0u16, |acc, c| acc * 10 + u16::from(c - b'0'));
    Ok(BusState {
        state,
        rx_errors: dec(&counters[..3]),
        tx_errors: dec(&counters[3..]),
    })
}

fn parse_errors(rest: &[u8]) -> Result<BusErrors, LineError> {
    let bad = LineError::Malformed(b'e');
    let [n @ b'1'..=b'8', codes @ ..] = rest else {
        return Err(bad);
    };
    if codes.len() != usize::from(n - b'0') {
        return Err(bad);
    }
    codes.iter().try_fold(BusErrors(0), |acc, c| {
        BusErrors::LETTERS
            .iter()
            .find(|(l, _)| l == c)
            .map(|&(_, bit)| BusErrors(acc.0 | bit))
            .ok_or(bad)
    })
}
