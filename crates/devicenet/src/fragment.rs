//! The fragmentation protocols of DeviceNet (volume 3, "Fragmentation Protocol"): the
//! acknowledged one of explicit messages and the unacknowledged one of I/O messages.
//!
//! Both put a fragmentation byte in front of each fragment's data:
//!
//! ```text
//! bit  7 6         5 4 3 2 1 0
//!      [type 2]    [count 6]        type: 0 first, 1 middle, 2 last, 3 acknowledge
//! ```
//!
//! The first fragment counts 0, every further one counts one more (modulo 64).
//!
//! - Explicit: a frame is `[header | 0x80, fragmentation byte, up to 6 bytes]`; the receiver
//!   acknowledges each fragment with `[header | 0x80, 0xC0 | count, ack status]` (0 success,
//!   1 too much data) and the sender waits for it before the next fragment.
//! - I/O: a frame is `[fragmentation byte, up to 7 bytes]`, without acknowledgement; a fragment
//!   out of sequence drops the message and the receiver waits for the next first fragment.
//!
//! Message buffers are bounded ([`MAX_MESSAGE`]); a longer message is refused, never truncated.

use core::fmt;

/// Largest message (explicit service + body, or I/O data) this crate reassembles.
pub const MAX_MESSAGE: usize = 128;

/// A bounded message buffer.
pub type MessageBuf = heapless::Vec<u8, MAX_MESSAGE>;

/// Data bytes of one explicit fragment (8 minus header and fragmentation byte).
pub const EXPLICIT_FRAGMENT_DATA: usize = 6;
/// Data bytes of one I/O fragment (8 minus the fragmentation byte).
pub const IO_FRAGMENT_DATA: usize = 7;

/// The fragment type, bits 6..7 of the fragmentation byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FragmentType {
    /// 0: the first fragment.
    First,
    /// 1: a middle fragment.
    Middle,
    /// 2: the last fragment.
    Last,
    /// 3: acknowledgement of an explicit fragment.
    Ack,
}

/// The fragmentation byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FragmentByte {
    /// Type.
    pub kind: FragmentType,
    /// Count, 0..=63.
    pub count: u8,
}

impl FragmentByte {
    /// Decodes the byte (total).
    pub const fn from_u8(b: u8) -> Self {
        let kind = match b >> 6 {
            0 => FragmentType::First,
            1 => FragmentType::Middle,
            2 => FragmentType::Last,
            _ => FragmentType::Ack,
        };
        Self {
            kind,
            count: b & 0x3F,
        }
    }

    /// The wire byte.
    pub const fn to_u8(self) -> u8 {
        let t = match self.kind {
            FragmentType::First => 0,
            FragmentType::Middle => 1,
            FragmentType::Last => 2,
            FragmentType::Ack => 3,
        };
        t << 6 | (self.count & 0x3F)
    }
}

impl fmt::Display for FragmentByte {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = match self.kind {
            FragmentType::First => "first",
            FragmentType::Middle => "middle",
            FragmentType::Last => "last",
            FragmentType::Ack => "ack",
        };
        write!(f, "{t} fragment #{}", self.count)
    }
}

/// Acknowledgement status of an explicit fragment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AckStatus {
    /// 0: received.
    Success,
    /// 1: the message is too large for the receiver.
    TooMuchData,
    /// Another code.
    Unknown(u8),
}

impl AckStatus {
    /// From the wire byte.
    pub const fn from_u8(b: u8) -> Self {
        match b {
            0 => AckStatus::Success,
            1 => AckStatus::TooMuchData,
            o => AckStatus::Unknown(o),
        }
    }
    /// The wire byte.
    pub const fn to_u8(self) -> u8 {
        match self {
            AckStatus::Success => 0,
            AckStatus::TooMuchData => 1,
            AckStatus::Unknown(o) => o,
        }
    }
}

impl fmt::Display for AckStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AckStatus::Success => f.write_str("success"),
            AckStatus::TooMuchData => f.write_str("too much data"),
            AckStatus::Unknown(c) => write!(f, "status 0x{c:02X}"),
        }
    }
}

/// Why a fragment was not taken.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FragmentError {
    /// A middle or last fragment without a first one.
    #[error("{0} without a first fragment")]
    NotInProgress(FragmentByte),
    /// The count is not the expected one.
    #[error("fragment count {got}, expected {expected}")]
    OutOfSequence {
        /// Expected count.
        expected: u8,
        /// Count received.
        got: u8,
    },
    /// The message would exceed [`MAX_MESSAGE`].
    #[error("message longer than {MAX_MESSAGE} bytes")]
    TooMuchData,
    /// An acknowledgement where a data fragment is expected (or the reverse).
    #[error("unexpected acknowledgement")]
    UnexpectedAck,
}

debug_as_display!(FragmentError);

/// Reassembles fragments (both protocols; the caller sends the explicit acknowledgements).
#[derive(Debug, Clone, Default)]
pub struct Reassembler {
    buf: MessageBuf,
    next: Option<u8>,
}

impl Reassembler {
    /// An idle reassembler.
    pub const fn new() -> Self {
        Self {
            buf: heapless::Vec::new(),
            next: None,
        }
    }

    /// Whether a message is partly received.
    pub fn in_progress(&self) -> bool {
        self.next.is_some()
    }

    /// Drops a partly received message.
    pub fn reset(&mut self) {
        self.buf.clear();
        self.next = None;
    }

    /// Takes one fragment. Returns the complete message after the last fragment. A first
    /// fragment always starts over; an error drops the partial message.
    pub fn push(
        &mut self,
        fragment: FragmentByte,
        data: &[u8],
    ) -> Result<Option<&[u8]>, FragmentError> {
        match fragment.kind {
            FragmentType::Ack => return Err(FragmentError::UnexpectedAck),
            FragmentType::First => {
                self.buf.clear();
                self.next = Some(0);
                if fragment.count != 0 {
                    self.reset();
                    return Err(FragmentError::OutOfSequence {
                        expected: 0,
                        got: fragment.count,
                    });
                }
            }
            FragmentType::Middle | FragmentType::Last => match self.next {
                None => return Err(FragmentError::NotInProgress(fragment)),
                Some(n) if n != fragment.count => {
                    self.reset();
                    return Err(FragmentError::OutOfSequence {
                        expected: n,
                        got: fragment.count,
                    });
                }
                Some(_) => {}
            },
        }
        if self.buf.extend_from_slice(data).is_err() {
            self.reset();
            return Err(FragmentError::TooMuchData);
        }
        self.next = self.next.map(|n| (n + 1) & 0x3F);
        if fragment.kind == FragmentType::Last {
            self.next = None;
            Ok(Some(&self.buf))
        } else {
            Ok(None)
        }
    }
}

/// Splits a message into fragments of `chunk` bytes: yields (fragmentation byte, data).
/// A message of at most `chunk` bytes is still one "first" fragment followed by nothing: callers
/// only fragment messages that do not fit one frame, so at least two fragments come out of them.
pub fn split(message: &[u8], chunk: usize) -> impl Iterator<Item = (FragmentByte, &[u8])> {
    let chunk = chunk.max(1);
    let n = message.len().div_ceil(chunk).max(1);
    (0..n).map(move |i| {
        let start = i * chunk;
        let end = (start + chunk).min(message.len());
        let kind = if i == 0 {
            FragmentType::First
        } else if i + 1 == n {
            FragmentType::Last
        } else {
            FragmentType::Middle
        };
        (
            FragmentByte {
                kind,
                count: (i & 0x3F) as u8,
            },
            &message[start..end],
        )
    })
}

/// The I/O frames (data bytes with their length) of one produced I/O message on a connection
/// whose size is `connection_size`: unfragmented when it fits 8 bytes, else the I/O
/// fragmentation protocol.
pub fn io_frames(data: &[u8], connection_size: usize) -> heapless::Vec<heapless::Vec<u8, 8>, 19> {
    let mut out = heapless::Vec::new();
    if connection_size <= 8 || data.is_empty() {
        let mut f = heapless::Vec::new();
        let _ = f.extend_from_slice(&data[..data.len().min(8)]);
        let _ = out.push(f);
        return out;
    }
    for (fb, chunk) in split(data, IO_FRAGMENT_DATA) {
        let mut f = heapless::Vec::new();
        let _ = f.push(fb.to_u8());
        let _ = f.extend_from_slice(chunk);
        if out.push(f).is_err() {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fragment_bytes() {
        assert_eq!(FragmentByte::from_u8(0x00).kind, FragmentType::First);
        assert_eq!(
            FragmentByte::from_u8(0x41),
            FragmentByte {
                kind: FragmentType::Middle,
                count: 1
            }
        );
        assert_eq!(
            FragmentByte::from_u8(0x82),
            FragmentByte {
                kind: FragmentType::Last,
                count: 2
            }
        );
        assert_eq!(
            FragmentByte::from_u8(0xC1),
            FragmentByte {
                kind: FragmentType::Ack,
                count: 1
            }
        );
        for b in 0..=255u8 {
            assert_eq!(FragmentByte::from_u8(b).to_u8(), b);
        }
    }

    #[test]
    fn thirteen_byte_poll_command_is_two_io_fragments() {
        let data: [u8; 13] = core::array::from_fn(|i| i as u8 + 1);
        let frames = io_frames(&data, 13);
        assert_eq!(frames.len(), 2);
        assert_eq!(&frames[0][..], &[0x00, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(&frames[1][..], &[0x81, 8, 9, 10, 11, 12, 13]);
        let frames = io_frames(&data[..11], 11);
        assert_eq!(&frames[1][..], &[0x81, 8, 9, 10, 11]);
        // 5 bytes fit one frame and are not fragmented.
        assert_eq!(&io_frames(&data[..5], 5)[0][..], &data[..5]);
    }

    #[test]
    fn reassembly_and_errors() {
        let mut r = Reassembler::new();
        assert_eq!(
            r.push(FragmentByte::from_u8(0x81), &[1]),
            Err(FragmentError::NotInProgress(FragmentByte::from_u8(0x81)))
        );
        assert_eq!(r.push(FragmentByte::from_u8(0x00), &[1, 2]), Ok(None));
        assert_eq!(r.push(FragmentByte::from_u8(0x41), &[3]), Ok(None));
        assert_eq!(
            r.push(FragmentByte::from_u8(0x82), &[4]),
            Ok(Some(&[1, 2, 3, 4][..]))
        );
        assert!(!r.in_progress());
        r.push(FragmentByte::from_u8(0x00), &[1]).unwrap();
        assert_eq!(
            r.push(FragmentByte::from_u8(0x82), &[1]),
            Err(FragmentError::OutOfSequence {
                expected: 1,
                got: 2
            })
        );
        assert!(!r.in_progress());
        r.push(FragmentByte::from_u8(0x00), &[0; 7]).unwrap();
        let mut err = None;
        for i in 1..40u8 {
            if let Err(e) = r.push(
                FragmentByte {
                    kind: FragmentType::Middle,
                    count: i,
                },
                &[0; 7],
            ) {
                err = Some(e);
                break;
            }
        }
        assert_eq!(err, Some(FragmentError::TooMuchData));
    }

    proptest::proptest! {
        #[test]
        fn split_then_reassemble(msg in proptest::collection::vec(proptest::num::u8::ANY, 2..=MAX_MESSAGE), chunk in 1usize..8) {
            let mut r = Reassembler::new();
            let mut out = None;
            let n = msg.len().div_ceil(chunk);
            for (fb, d) in split(&msg, chunk) {
                if n == 1 {
                    // One chunk: callers never fragment it; nothing to reassemble.
                    proptest::prop_assert_eq!(fb.kind, FragmentType::First);
                    return Ok(());
                }
                if let Some(m) = r.push(fb, d).unwrap() {
                    out = Some(m.to_vec());
                }
            }
            proptest::prop_assert_eq!(out, Some(msg));
        }
    }
}
