//! The MessagePack datagrams of python-can's `udp_multicast` interface: one CAN frame per
//! datagram as a map with python-can's keys. [`decode`] is a total reader (anything that is
//! not such a frame is a [`DecodeError`], never a panic); [`encode`] writes what python-can
//! reads.

use canola_frame::{CanFrame, CanId, FdFlags, FdFrame};

/// Why a datagram is not a frame in python-can's format.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// The datagram ends inside a MessagePack value.
    #[error("datagram ends inside a value")]
    Truncated,
    /// Bytes follow the map.
    #[error("bytes after the message map")]
    TrailingBytes,
    /// The datagram is not a MessagePack map.
    #[error("not a MessagePack map")]
    NotAMap,
    /// A field has the wrong type or is missing.
    #[error("field `{0}` is missing or has the wrong type")]
    BadField(&'static str),
    /// Values nest deeper than the reader follows.
    #[error("values nest too deep")]
    TooDeep,
    /// The identifier or data length is not a valid classic CAN frame.
    #[error("not a valid classic CAN frame")]
    BadFrame,
}

/// What a datagram carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Message {
    /// A classic data or remote frame.
    Frame(CanFrame),
    /// An error frame: class bits (python-can's `arbitration_id`) and up to 8 detail bytes.
    Error {
        /// Error class bits.
        class: u32,
        /// Detail bytes (missing ones zero).
        data: [u8; 8],
    },
    /// A CAN FD frame (`is_fd` true): its data padded with zeros to the next CAN FD length,
    /// `bitrate_switch` and `error_state_indicator` as its BRS and ESI flags.
    Fd(FdFrame),
}

/// A decoded MessagePack value (only what the message format needs is kept).
#[derive(Debug, Clone, PartialEq)]
enum Val<'a> {
    Nil,
    Bool(bool),
    Int(i128),
    Float(f64),
    Str(&'a [u8]),
    Bin(&'a [u8]),
    Array(Vec<Val<'a>>),
    /// A map, extension or anything else the format does not use.
    Other,
}

struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

const MAX_DEPTH: usize = 8;

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let end = self.pos.checked_add(n).ok_or(DecodeError::Truncated)?;
        let s = self.buf.get(self.pos..end).ok_or(DecodeError::Truncated)?;
        self.pos = end;
        Ok(s)
    }

    fn uint(&mut self, n: usize) -> Result<u64, DecodeError> {
        Ok(self
            .take(n)?
            .iter()
            .fold(0u64, |acc, b| (acc << 8) | u64::from(*b)))
    }

    fn len(&mut self, n: usize) -> Result<usize, DecodeError> {
        usize::try_from(self.uint(n)?).map_err(|_| DecodeError::Truncated)
    }

    fn value(&mut self, depth: usize) -> Result<Val<'a>, DecodeError> {
        if depth > MAX_DEPTH {
            return Err(DecodeError::TooDeep);
        }
        let b = self.take(1)?[0];
        Ok(match b {
            0x00..=0x7F => Val::Int(i128::from(b)),
            0x80..=0x8F => self.skip_map(usize::from(b & 0x0F), depth)?,
            0x90..=0x9F => self.array(usize::from(b & 0x0F), depth)?,
            0xA0..=0xBF => Val::Str(self.take(usize::from(b & 0x1F))?),
            0xC0 => Val::Nil,
            0xC2 => Val::Bool(false),
            0xC3 => Val::Bool(true),
            0xC4..=0xC6 => {
                let n = self.len(1 << (b - 0xC4))?;
                Val::Bin(self.take(n)?)
            }
            0xC7..=0xC9 => {
                let n = self.len(1 << (b - 0xC7))?;
                self.take(n + 1)?;
                Val::Other
            }
            0xCA => Val::Float(f64::from(f32::from_bits(self.uint(4)? as u32))),
            0xCB => Val::Float(f64::from_bits(self.uint(8)?)),
            0xCC..=0xCF => Val::Int(i128::from(self.uint(1 << (b - 0xCC))?)),
            0xD0..=0xD3 => {
                let n = 1usize << (b - 0xD0);
                let raw = self.uint(n)?;
                let shift = 64 - 8 * n as u32;
                Val::Int(i128::from(((raw << shift) as i64) >> shift))
            }
            0xD4..=0xD8 => {
                self.take((1usize << (b - 0xD4)) + 1)?;
                Val::Other
            }
            0xD9..=0xDB => {
                let n = self.len(1 << (b - 0xD9))?;
                Val::Str(self.take(n)?)
            }
            0xDC | 0xDD => {
                let n = self.len(if b == 0xDC { 2 } else { 4 })?;
                self.array(n, depth)?
            }
            0xDE | 0xDF => {
                let n = self.len(if b == 0xDE { 2 } else { 4 })?;
                self.skip_map(n, depth)?
            }
            0xE0..=0xFF => Val::Int(i128::from(b as i8)),
            // 0xC1 is never used.
            _ => Val::Other,
        })
    }

    fn array(&mut self, n: usize, depth: usize) -> Result<Val<'a>, DecodeError> {
        // Every element takes at least a byte: a count beyond the rest is a lie.
        if n > self.buf.len() - self.pos {
            return Err(DecodeError::Truncated);
        }
        (0..n)
            .map(|_| self.value(depth + 1))
            .collect::<Result<_, _>>()
            .map(Val::Array)
    }

    fn skip_map(&mut self, n: usize, depth: usize) -> Result<Val<'a>, DecodeError> {
        for _ in 0..n {
            self.value(depth + 1)?;
            self.value(depth + 1)?;
        }
        Ok(Val::Other)
    }

    fn map_len(&mut self) -> Result<usize, DecodeError> {
        let b = *self.buf.get(self.pos).ok_or(DecodeError::NotAMap)?;
        self.pos += 1;
        match b {
            0x80..=0x8F => Ok(usize::from(b & 0x0F)),
            0xDE => self.len(2),
            0xDF => self.len(4),
            _ => Err(DecodeError::NotAMap),
        }
    }
}

/// Decodes one datagram. Total: any bytes give a message or a [`DecodeError`].
pub fn decode(datagram: &[u8]) -> Result<Message, DecodeError> {
    let mut r = Reader {
        buf: datagram,
        pos: 0,
    };
    let n = r.map_len()?;
    let mut id = None;
    let mut extended = false;
    let mut remote = false;
    let mut error = false;
    let mut fd = false;
    let mut brs = false;
    let mut esi = false;
    let mut dlc = None;
    let mut data: Vec<u8> = Vec::new();
    for _ in 0..n {
        let key = r.value(1)?;
        let value = r.value(1)?;
        let Val::Str(key) = key else { continue };
        let flag = |name| match value {
            Val::Bool(b) => Ok(b),
            Val::Nil => Ok(false),
            _ => Err(DecodeError::BadField(name)),
        };
        match key {
            b"arbitration_id" => match value {
                Val::Int(i) => {
                    id = Some(
                        u32::try_from(i).map_err(|_| DecodeError::BadField("arbitration_id"))?,
                    )
                }
                _ => return Err(DecodeError::BadField("arbitration_id")),
            },
            b"is_extended_id" => extended = flag("is_extended_id")?,
            b"is_remote_frame" => remote = flag("is_remote_frame")?,
            b"is_error_frame" => error = flag("is_error_frame")?,
            b"is_fd" => fd = flag("is_fd")?,
            b"bitrate_switch" => brs = flag("bitrate_switch")?,
            b"error_state_indicator" => esi = flag("error_state_indicator")?,
            b"dlc" => match value {
                Val::Int(i) => dlc = usize::try_from(i).ok(),
                Val::Nil => {}
                _ => return Err(DecodeError::BadField("dlc")),
            },
            b"data" => {
                data = match value {
                    Val::Bin(b) | Val::Str(b) => b.to_vec(),
                    Val::Nil => Vec::new(),
                    Val::Array(items) => items
                        .iter()
                        .map(|v| match v {
                            Val::Int(i) => u8::try_from(*i).ok(),
                            _ => None,
                        })
                        .collect::<Option<_>>()
                        .ok_or(DecodeError::BadField("data"))?,
                    _ => return Err(DecodeError::BadField("data")),
                }
            }
            // timestamp, channel, anything newer.
            _ => {}
        }
    }
    if r.pos != datagram.len() {
        return Err(DecodeError::TrailingBytes);
    }
    let id = id.ok_or(DecodeError::BadField("arbitration_id"))?;
    if fd && !error {
        let can_id = can_id(id, extended)?;
        let mut flags = FdFlags::EMPTY;
        if brs {
            flags = flags | FdFlags::BRS;
        }
        if esi {
            flags = flags | FdFlags::ESI;
        }
        return FdFrame::new_padded(can_id, &data)
            .map(|f| Message::Fd(f.with_flags(flags)))
            .map_err(|_| DecodeError::BadFrame);
    }
    if error {
        let mut detail = [0u8; 8];
        let n = data.len().min(8);
        detail[..n].copy_from_slice(&data[..n]);
        return Ok(Message::Error {
            class: id & 0x1FFF_FFFF,
            data: detail,
        });
    }
    let can_id = can_id(id, extended)?;
    let frame = if remote {
        CanFrame::remote(can_id, dlc.unwrap_or(0))
    } else {
        CanFrame::new(can_id, &data)
    }
    .map_err(|_| DecodeError::BadFrame)?;
    Ok(Message::Frame(frame))
}

/// python-can's `arbitration_id` and `is_extended_id` as an identifier.
fn can_id(id: u32, extended: bool) -> Result<CanId, DecodeError> {
    if extended {
        CanId::extended(id).ok()
    } else {
        u16::try_from(id).ok().and_then(|i| CanId::standard(i).ok())
    }
    .ok_or(DecodeError::BadFrame)
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    // Only the fixed keys are written: all are shorter than 32 bytes (fixstr).
    debug_assert!(s.len() < 32);
    out.push(0xA0 | s.len() as u8);
    out.extend_from_slice(s.as_bytes());
}

fn put_uint(out: &mut Vec<u8>, v: u32) {
    match v {
        0..=0x7F => out.push(v as u8),
        0x80..=0xFF => out.extend_from_slice(&[0xCC, v as u8]),
        0x100..=0xFFFF => {
            out.push(0xCD);
            out.extend_from_slice(&(v as u16).to_be_bytes());
        }
        _ => {
            out.push(0xCE);
            out.extend_from_slice(&v.to_be_bytes());
        }
    }
}

fn put_bool(out: &mut Vec<u8>, key: &str, v: bool) {
    put_str(out, key);
    out.push(if v { 0xC3 } else { 0xC2 });
}

/// The map python-can's `udp_multicast` writes for a message; `timestamp` in seconds.
struct Fields<'a> {
    id: CanId,
    remote: bool,
    /// python-can's `dlc`: the data length in bytes.
    dlc: usize,
    data: &'a [u8],
    fd: bool,
    brs: bool,
    esi: bool,
}

fn put_message(m: &Fields<'_>, timestamp: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(200);
    out.push(0x80 | 11);
    put_str(&mut out, "timestamp");
    out.push(0xCB);
    out.extend_from_slice(&timestamp.to_bits().to_be_bytes());
    put_str(&mut out, "arbitration_id");
    put_uint(&mut out, m.id.as_raw());
    put_bool(
        &mut out,
        "is_extended_id",
        matches!(m.id, CanId::Extended(_)),
    );
    put_bool(&mut out, "is_remote_frame", m.remote);
    put_bool(&mut out, "is_error_frame", false);
    put_str(&mut out, "channel");
    out.push(0xC0);
    put_str(&mut out, "dlc");
    put_uint(&mut out, m.dlc as u32);
    put_str(&mut out, "data");
    out.extend_from_slice(&[0xC4, m.data.len() as u8]);
    out.extend_from_slice(m.data);
    put_bool(&mut out, "is_fd", m.fd);
    put_bool(&mut out, "bitrate_switch", m.brs);
    put_bool(&mut out, "error_state_indicator", m.esi);
    out
}

/// Encodes `frame` as python-can's `udp_multicast` writes a message; `timestamp` in seconds.
pub fn encode(frame: &CanFrame, timestamp: f64) -> Vec<u8> {
    let data: &[u8] = if frame.is_remote() { &[] } else { frame.data() };
    put_message(
        &Fields {
            id: frame.id(),
            remote: frame.is_remote(),
            dlc: frame.dlc(),
            data,
            fd: false,
            brs: false,
            esi: false,
        },
        timestamp,
    )
}

/// Encodes a CAN FD frame as python-can writes one: `is_fd` true, `bitrate_switch` and
/// `error_state_indicator` from its flags, `dlc` the data length in bytes (python-can's
/// meaning of the field).
pub fn encode_fd(frame: &FdFrame, timestamp: f64) -> Vec<u8> {
    put_message(
        &Fields {
            id: frame.id(),
            remote: false,
            dlc: frame.dlc(),
            data: frame.data(),
            fd: true,
            brs: frame.brs(),
            esi: frame.esi(),
        },
        timestamp,
    )
}
