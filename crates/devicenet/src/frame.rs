//! Decoding any CAN frame as DeviceNet, for monitors and logs: which predefined message the
//! identifier names, and what its data says. [`decode`] is total; [`Decoded`]'s `Display` is one
//! line per frame.
//!
//! I/O data is shown as bytes: whether a poll command or response is fragmented depends on the
//! connection's size, which a monitor does not know.

use core::fmt;

use canola_frame::CanFrame;

use crate::explicit::{ExplicitError, ExplicitFrame, Hex, Request, Response, is_response};
use crate::id::{DnId, Predefined};
use crate::identity::{DuplicateMacCheck, DuplicateMacError};

/// A decoded frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decoded<'a> {
    /// A Duplicate MAC ID check message.
    DuplicateMac {
        /// The identifier's meaning.
        message: Predefined,
        /// The data.
        check: Result<DuplicateMacCheck, DuplicateMacError>,
    },
    /// An explicit message (request, response, unconnected request).
    Explicit {
        /// The identifier's meaning.
        message: Predefined,
        /// The frame.
        frame: Result<ExplicitFrame<'a>, ExplicitError>,
    },
    /// An I/O message of the predefined set (poll, bit-strobe, COS/cyclic).
    Io {
        /// The identifier's meaning.
        message: Predefined,
        /// Data bytes.
        data: &'a [u8],
    },
    /// A DeviceNet identifier outside the predefined set.
    Other {
        /// The identifier.
        id: DnId,
        /// Data bytes.
        data: &'a [u8],
    },
    /// An extended-identifier or remote frame: not DeviceNet.
    NotDeviceNet,
}

/// Decodes a frame. Never panics.
pub fn decode(frame: &CanFrame) -> Decoded<'_> {
    let Some(id) = DnId::of(frame.id()) else {
        return Decoded::NotDeviceNet;
    };
    if frame.is_remote() {
        return Decoded::NotDeviceNet;
    }
    let data = frame.data();
    let Some(message) = Predefined::from_id(id) else {
        return Decoded::Other { id, data };
    };
    match message {
        Predefined::DuplicateMacCheck(_) => Decoded::DuplicateMac {
            message,
            check: DuplicateMacCheck::parse(data),
        },
        Predefined::SlaveExplicitResponse(_)
        | Predefined::MasterExplicitRequest(_)
        | Predefined::UnconnectedRequest(_) => Decoded::Explicit {
            message,
            frame: ExplicitFrame::parse(data),
        },
        _ => Decoded::Io { message, data },
    }
}

impl fmt::Display for Decoded<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decoded::DuplicateMac { message, check } => match check {
                Ok(c) => write!(f, "DeviceNet {message}: {c}"),
                Err(e) => write!(f, "DeviceNet {message}: malformed ({e})"),
            },
            Decoded::Explicit { message, frame } => {
                write!(f, "DeviceNet {message}: ")?;
                match frame {
                    Err(e) => write!(f, "malformed ({e})"),
                    Ok(ExplicitFrame::Ack {
                        header,
                        count,
                        status,
                    }) => write!(f, "[{}] ack of fragment #{count}: {status}", header.mac),
                    Ok(ExplicitFrame::Fragment {
                        header,
                        fragment,
                        data,
                    }) => write!(f, "[{}] {fragment}: {}", header.mac, Hex(data)),
                    Ok(ExplicitFrame::Whole { header, message }) => {
                        write!(
                            f,
                            "[{}{}] ",
                            header.mac,
                            if header.xid { " XID" } else { "" }
                        )?;
                        match message.first() {
                            Some(&s) if is_response(s) => match Response::parse(message) {
                                Ok(r) => write!(f, "{r}"),
                                Err(e) => write!(f, "malformed ({e})"),
                            },
                            _ => match Request::parse(message) {
                                Ok(r) => write!(f, "{r}"),
                                Err(e) => write!(f, "malformed ({e})"),
                            },
                        }
                    }
                }
            }
            Decoded::Io { message, data } => {
                if data.is_empty() {
                    write!(f, "DeviceNet {message}: no data (idle)")
                } else {
                    write!(f, "DeviceNet {message}: {}", Hex(data))
                }
            }
            Decoded::Other { id, data } => write!(f, "DeviceNet {id:?}: {}", Hex(data)),
            Decoded::NotDeviceNet => f.write_str("not a DeviceNet frame"),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use canola_frame::CanId;

    use super::*;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(CanId::standard(id).unwrap(), data).unwrap()
    }

    #[test]
    fn display_lines() {
        let f = frame(0x5FE, &[0x00, 0x4B, 0x03, 0x01, 0x03, 0x00]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet unconnected explicit request to MAC 63: [MAC 0] Allocate_Master/Slave_Connection_Set class 0x03 instance 1 choice 0x03 (explicit+polled) allocator MAC 0"
        );
        let f = frame(0x5FB, &[0x00, 0xCB, 0x00]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet explicit response from MAC 63: [MAC 0] Allocate_Master/Slave_Connection_Set response data 00"
        );
        let f = frame(0x5FF, &[0x00, 0x10, 0x01, 0x01, 0, 0, 0]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet duplicate MAC ID check of MAC 63: request port 0 vendor 272 serial 0x00000001"
        );
        let f = frame(0x5FD, &[]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet poll command to MAC 63: no data (idle)"
        );
        let f = frame(0x3FF, &[0x00, 1, 2]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet poll response from MAC 63: 00 01 02"
        );
        let f = frame(0x5FB, &[0x80, 0xC0, 0x00]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet explicit response from MAC 63: [MAC 0] ack of fragment #0: success"
        );
        let f = frame(0x5FB, &[0x00, 0x94, 0x16, 0xFF]);
        assert_eq!(
            decode(&f).to_string(),
            "DeviceNet explicit response from MAC 63: [MAC 0] Error Response: CIP status 0x16 (object does not exist), additional code 0xFF"
        );
    }

    proptest::proptest! {
        #[test]
        fn decode_any_frame(id in 0u16..0x800, data in proptest::collection::vec(proptest::num::u8::ANY, 0..=8)) {
            let f = frame(id, &data);
            let _ = decode(&f).to_string();
        }
    }
}
