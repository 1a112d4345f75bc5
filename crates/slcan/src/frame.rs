//! Frame lines, the same in both directions: `t`/`T` classic data, `r`/`R` classic remote,
//! `d`/`D` CAN FD and `b`/`B` CAN FD with bit rate switch; lower case for 11-bit identifiers
//! (3 hex digits), upper case for 29-bit ones (8 hex digits); one length digit; the data as hex
//! pairs. Received frames may carry a timestamp (4 hex digits of ms or 8 of µs) and an ESI digit.

use canola_frame::fd::dlc_to_len;
use canola_frame::{CanFrame, CanId, FdFrame};

use crate::error::{EncodeError, LineError};
use crate::hex::{self, Writer};

/// A frame on an slcan line: classic or CAN FD.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Frame {
    /// A classic data or remote frame (`t`, `T`, `r`, `R`).
    Classic(CanFrame),
    /// A CAN FD frame (`d`, `D`, `b`, `B`; the bit rate switch is its BRS flag; its ESI flag is
    /// not written, an adapter reports it in [`RxFrame::esi`]).
    Fd(FdFrame),
}

impl From<CanFrame> for Frame {
    fn from(f: CanFrame) -> Self {
        Self::Classic(f)
    }
}

impl From<FdFrame> for Frame {
    fn from(f: FdFrame) -> Self {
        Self::Fd(f)
    }
}

/// The timestamp an adapter appends to a received frame after `Z1` or `Z2`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Timestamp {
    /// Four hex digits: milliseconds, 0..=59 999 (wraps at 60 000).
    Millis(u16),
    /// Eight hex digits: microseconds, wrapping after an hour (Nakakiyo `Z2`).
    Micros(u32),
}

/// A frame line from the adapter, with what the adapter may append to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RxFrame {
    /// The frame.
    pub frame: Frame,
    /// The adapter's timestamp, when timestamps are on.
    pub timestamp: Option<Timestamp>,
    /// The error state indicator digit after the timestamp (Nakakiyo firmware, enabled through its
    /// `z` command): `true` when the transmitter was error-passive.
    pub esi: Option<bool>,
}

impl RxFrame {
    /// A frame with nothing appended.
    pub const fn new(frame: Frame) -> Self {
        Self {
            frame,
            timestamp: None,
            esi: None,
        }
    }

    /// Writes the line an adapter sends for this frame, CR included; returns its length.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let extra = match self.timestamp {
            None => 0,
            Some(Timestamp::Millis(_)) => 4,
            Some(Timestamp::Micros(_)) => 8,
        } + usize::from(self.esi.is_some());
        let mut w = Writer::new(out, line_len(&self.frame) + extra + 1)?;
        write_frame(&mut w, &self.frame);
        match self.timestamp {
            None => {}
            Some(Timestamp::Millis(ms)) => w.hex(u32::from(ms), 4),
            Some(Timestamp::Micros(us)) => w.hex(us, 8),
        }
        if let Some(esi) = self.esi {
            w.byte(if esi { b'1' } else { b'0' });
        }
        w.byte(crate::CR);
        Ok(w.finish())
    }
}

/// Characters of a frame line without trailer and terminator.
pub(crate) fn line_len(frame: &Frame) -> usize {
    let (id, data) = match frame {
        Frame::Classic(f) => (f.id(), f.data().len()),
        Frame::Fd(f) => (f.id(), f.data().len()),
    };
    1 + if id.is_extended() { 8 } else { 3 } + 1 + 2 * data
}

/// Writes a frame line without trailer and terminator; `w` was sized with [`line_len`].
pub(crate) fn write_frame(w: &mut Writer<'_>, frame: &Frame) {
    let (id, kind, dlc, data) = match frame {
        Frame::Classic(f) => {
            let kind = match (f.is_remote(), f.id().is_extended()) {
                (false, false) => b't',
                (false, true) => b'T',
                (true, false) => b'r',
                (true, true) => b'R',
            };
            (f.id(), kind, f.dlc() as u8, f.data())
        }
        Frame::Fd(f) => {
            let kind = match (f.brs(), f.id().is_extended()) {
                (false, false) => b'd',
                (false, true) => b'D',
                (true, false) => b'b',
                (true, true) => b'B',
            };
            (f.id(), kind, f.dlc_code(), f.data())
        }
    };
    w.byte(kind);
    w.hex(id.as_raw(), if id.is_extended() { 8 } else { 3 });
    w.hex(u32::from(dlc), 1);
    w.hex_bytes(data);
}

/// Whether `c` starts a frame line.
pub(crate) const fn is_frame_letter(c: u8) -> bool {
    matches!(c, b't' | b'T' | b'r' | b'R' | b'd' | b'D' | b'b' | b'B')
}

/// Parses a frame line (first character one of [`is_frame_letter`]); returns the frame and the
/// characters after its data.
pub(crate) fn parse_frame(line: &[u8]) -> Result<(Frame, &[u8]), LineError> {
    let kind = *line.first().ok_or(LineError::Truncated)?;
    let extended = kind.is_ascii_uppercase();
    let id_digits = if extended { 8 } else { 3 };
    let id_field = line.get(1..1 + id_digits).ok_or(LineError::Truncated)?;
    let raw = hex::number(id_field)?;
    let id = if extended {
        CanId::extended(raw)
    } else {
        CanId::standard(raw as u16)
    }
    .map_err(|_| LineError::IdOutOfRange(raw))?;
    let dlc_char = *line.get(1 + id_digits).ok_or(LineError::Truncated)?;
    let rest = &line[2 + id_digits..];
    let fd = matches!(kind, b'd' | b'D' | b'b' | b'B');
    let len = if fd {
        let code = hex::digit(dlc_char).map_err(|_| LineError::BadDlc(dlc_char))?;
        dlc_to_len(code).ok_or(LineError::BadDlc(dlc_char))?
    } else {
        match dlc_char {
            b'0'..=b'8' => usize::from(dlc_char - b'0'),
            _ => return Err(LineError::BadDlc(dlc_char)),
        }
    };
    // Remote frames carry a length but never data (the kernel: "RTR frames may have a dlc > 0
    // but they never have any data bytes").
    if matches!(kind, b'r' | b'R') {
        let frame = CanFrame::remote(id, len).map_err(|_| LineError::BadDlc(dlc_char))?;
        return Ok((Frame::Classic(frame), rest));
    }
    let digits = rest.get(..2 * len).ok_or(LineError::Truncated)?;
    let mut data = [0u8; 64];
    hex::bytes(digits, &mut data[..len])?;
    let frame = if fd {
        let f = FdFrame::new(id, &data[..len]).map_err(|_| LineError::BadDlc(dlc_char))?;
        Frame::Fd(f.with_brs(matches!(kind, b'b' | b'B')))
    } else {
        Frame::Classic(CanFrame::new(id, &data[..len]).map_err(|_| LineError::BadDlc(dlc_char))?)
    };
    Ok((frame, &rest[2 * len..]))
}

/// Parses what an adapter may append to a received frame: nothing, a 4-digit millisecond or an
/// 8-digit microsecond timestamp, each optionally followed by an ESI digit.
pub(crate) fn parse_trailer(
    trailer: &[u8],
) -> Result<(Option<Timestamp>, Option<bool>), LineError> {
    let (stamp, esi) = match trailer.len() {
        0 | 4 | 8 => (trailer, None),
        1 | 5 | 9 => (
            &trailer[..trailer.len() - 1],
            Some(trailer[trailer.len() - 1]),
        ),
        n => return Err(LineError::BadTrailer(n)),
    };
    let timestamp = match stamp.len() {
        0 => None,
        4 => Some(Timestamp::Millis(hex::number(stamp)? as u16)),
        _ => Some(Timestamp::Micros(hex::number(stamp)?)),
    };
    let esi = match esi {
        None => None,
        Some(b'0') => Some(false),
        Some(b'1') => Some(true),
        Some(_) => return Err(LineError::BadTrailer(trailer.len())),
    };
    Ok((timestamp, esi))
}
