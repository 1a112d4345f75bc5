//! A CAN bus over UDP multicast in the wire format of python-can's `udp_multicast` interface,
//! for several processes on one machine (or, on purpose, one LAN segment: see
//! [`crate::udp_scope`]) without CAN hardware or vcan.
//!
//! Every attached process joins one IPv4 multicast group and port; each frame is one datagram
//! holding a MessagePack map with the keys python-can writes: `timestamp` (float seconds),
//! `arbitration_id`, `is_extended_id`, `is_remote_frame`, `is_error_frame`, `channel`, `dlc`,
//! `data` (binary), `is_fd`, `bitrate_switch`, `error_state_indicator`. python-can's default
//! IPv4 group is `239.74.163.2`, its default port 43113 (its default group is an IPv6 one:
//! give python-can `channel="239.74.163.2"` to meet this transport).
//!
//! Like python-can, the socket binds the group's port with `SO_REUSEADDR`/`SO_REUSEPORT` and
//! sends with a TTL of 1 and multicast loopback on, so processes on the same machine hear each
//! other. Unlike python-can, it binds the group's address (no unicast datagrams to the port) and
//! by default joins and sends on the loopback interface only: nothing leaves the machine and
//! only this machine's datagrams are taken ([`crate::udp_scope::UdpScope`]). Frames are sent from
//! a second socket on an ephemeral port; a datagram whose source port is that port is this
//! transport's own and is not received again (a CAN controller does not receive its own frames
//! either).
//!
//! Received datagrams are decoded by a total MessagePack reader ([`decode`]): a datagram that is
//! not a frame in this format, and CAN FD frames (the stack carries classic frames), are skipped
//! and counted ([`UdpMulticast::skipped`]), never fatal: on a LAN scope anyone on the segment
//! can send to the group.

use std::net::{Ipv4Addr, SocketAddrV4, UdpSocket};
use std::os::fd::AsRawFd;

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, CanId, Instant};
use nix::sys::socket::{
    AddressFamily, SockFlag, SockProtocol, SockType, SockaddrIn, bind, setsockopt, socket, sockopt,
};

use crate::transport::{BusEvent, Received, Transport, TransportError};

/// python-can's default IPv4 multicast group of `udp_multicast`.
pub const DEFAULT_GROUP: Ipv4Addr = Ipv4Addr::new(239, 74, 163, 2);
/// python-can's default port of `udp_multicast`.
pub const DEFAULT_PORT: u16 = 43113;
/// Largest datagram read (python-can's receive buffer size).
pub const MAX_DATAGRAM: usize = 4096;

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
    /// A CAN FD frame, which this stack does not carry.
    Fd,
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
            // timestamp, channel, bitrate_switch, error_state_indicator, anything newer.
            _ => {}
        }
    }
    if r.pos != datagram.len() {
        return Err(DecodeError::TrailingBytes);
    }
    let id = id.ok_or(DecodeError::BadField("arbitration_id"))?;
    if fd {
        return Ok(Message::Fd);
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
    let can_id = if extended {
        CanId::extended(id).ok()
    } else {
        u16::try_from(id).ok().and_then(|i| CanId::standard(i).ok())
    }
    .ok_or(DecodeError::BadFrame)?;
    let frame = if remote {
        CanFrame::remote(can_id, dlc.unwrap_or(0))
    } else {
        CanFrame::new(can_id, &data)
    }
    .map_err(|_| DecodeError::BadFrame)?;
    Ok(Message::Frame(frame))
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

/// Encodes `frame` as python-can's `udp_multicast` writes a message; `timestamp` in seconds.
pub fn encode(frame: &CanFrame, timestamp: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(200);
    out.push(0x80 | 11);
    put_str(&mut out, "timestamp");
    out.push(0xCB);
    out.extend_from_slice(&timestamp.to_bits().to_be_bytes());
    put_str(&mut out, "arbitration_id");
    put_uint(&mut out, frame.id().as_raw());
    put_bool(
        &mut out,
        "is_extended_id",
        matches!(frame.id(), CanId::Extended(_)),
    );
    put_bool(&mut out, "is_remote_frame", frame.is_remote());
    put_bool(&mut out, "is_error_frame", false);
    put_str(&mut out, "channel");
    out.push(0xC0);
    put_str(&mut out, "dlc");
    put_uint(&mut out, frame.dlc() as u32);
    put_str(&mut out, "data");
    let data: &[u8] = if frame.is_remote() { &[] } else { frame.data() };
    out.extend_from_slice(&[0xC4, data.len() as u8]);
    out.extend_from_slice(data);
    put_bool(&mut out, "is_fd", false);
    put_bool(&mut out, "bitrate_switch", false);
    put_bool(&mut out, "error_state_indicator", false);
    out
}

/// Where a UDP multicast bus lives: `udp`, `udp:GROUP` or `udp:GROUP:PORT` (python-can's
/// defaults for the parts left out). `None` when `spec` does not start with `udp`.
pub fn parse_spec(spec: &str) -> Option<Result<SocketAddrV4, String>> {
    let rest = spec.strip_prefix("udp")?;
    let rest = match rest.strip_prefix(':') {
        Some(r) => r,
        None if rest.is_empty() => return Some(Ok(SocketAddrV4::new(DEFAULT_GROUP, DEFAULT_PORT))),
        None => return None,
    };
    let (group, port) = match rest.split_once(':') {
        Some((g, p)) => (g, Some(p)),
        None => (rest, None),
    };
    let group = match group.parse::<Ipv4Addr>() {
        Ok(g) if g.is_multicast() => g,
        Ok(g) => return Some(Err(format!("{g} is not a multicast address (224.0.0.0/4)"))),
        Err(e) => return Some(Err(format!("`{group}`: {e}"))),
    };
    let port = match port.map(str::parse::<u16>) {
        None => DEFAULT_PORT,
        Some(Ok(p)) if p != 0 => p,
        Some(_) => return Some(Err(format!("`{spec}`: the port is 1..=65535"))),
    };
    Some(Ok(SocketAddrV4::new(group, port)))
}

/// A CAN bus over UDP multicast (see the module documentation).
#[derive(Debug)]
pub struct UdpMulticast {
    rx: UdpSocket,
    tx: UdpSocket,
    group: SocketAddrV4,
    own_port: u16,
    clock: MonotonicClock,
    skipped: u64,
    nonblocking: bool,
    read_timeout: Option<std::time::Duration>,
    /// Where the bus reaches ([`crate::udp_scope`]).
    scope: crate::udp_scope::UdpScope,
    /// On the loopback scope: the sources taken.
    local: Option<crate::udp_scope::LocalSources>,
}

impl UdpMulticast {
    /// Joins the bus at `group` (an IPv4 multicast address and port) on this machine only
    /// ([`crate::udp_scope::UdpScope::Loopback`]).
    pub fn open(group: SocketAddrV4) -> Result<Self, TransportError> {
        Self::open_scoped(group, crate::udp_scope::UdpScope::Loopback)
    }

    /// Joins the bus at `group` in `scope` ([`crate::udp_scope`]).
    pub fn open_scoped(
        group: SocketAddrV4,
        scope: crate::udp_scope::UdpScope,
    ) -> Result<Self, TransportError> {
        let io = |e: nix::errno::Errno| TransportError::Io(e.into());
        let fd = socket(
            AddressFamily::Inet,
            SockType::Datagram,
            SockFlag::SOCK_CLOEXEC,
            SockProtocol::Udp,
        )
        .map_err(io)?;
        setsockopt(&fd, sockopt::ReuseAddr, &true).map_err(io)?;
        setsockopt(&fd, sockopt::ReusePort, &true).map_err(io)?;
        // Scope hook: bound to the group (no unicast to the port), joined on the scope's
        // interface only, sent from its address (so out of that interface only).
        bind(fd.as_raw_fd(), &SockaddrIn::from(group)).map_err(io)?;
        let rx = UdpSocket::from(fd);
        rx.join_multicast_v4(group.ip(), &scope.interface_addr())?;
        let tx = UdpSocket::bind(SocketAddrV4::new(scope.interface_addr(), 0))?;
        tx.set_multicast_ttl_v4(1)?;
        tx.set_multicast_loop_v4(true)?;
        let own_port = tx.local_addr()?.port();
        Ok(Self {
            rx,
            tx,
            group,
            own_port,
            clock: MonotonicClock::new(),
            skipped: 0,
            nonblocking: false,
            read_timeout: None,
            local: (scope == crate::udp_scope::UdpScope::Loopback)
                .then(crate::udp_scope::LocalSources::new),
            scope,
        })
    }

    /// Where the bus reaches.
    pub fn scope(&self) -> &crate::udp_scope::UdpScope {
        &self.scope
    }

    /// The group and port of the bus.
    pub fn group(&self) -> SocketAddrV4 {
        self.group
    }

    /// Datagrams received and skipped: not a classic frame in the format (CAN FD frames
    /// included).
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    fn set_nonblocking(&mut self, on: bool) -> Result<(), TransportError> {
        if self.nonblocking != on {
            self.rx.set_nonblocking(on)?;
            self.nonblocking = on;
        }
        Ok(())
    }
}

impl Transport for UdpMulticast {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        self.tx.send_to(&encode(frame, stamp), self.group)?;
        Ok(())
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        let mut buf = [0u8; MAX_DATAGRAM];
        loop {
            let now = self.clock.now();
            let wait = deadline.saturating_duration_since(now);
            if wait.is_zero() {
                self.set_nonblocking(true)?;
            } else {
                self.set_nonblocking(false)?;
                let want = std::time::Duration::from_micros(wait.as_micros());
                if self.read_timeout != Some(want) {
                    self.rx.set_read_timeout(Some(want))?;
                    self.read_timeout = Some(want);
                }
            }
            let (n, from) = match self.rx.recv_from(&mut buf) {
                Ok(r) => r,
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    if self.clock.now() >= deadline {
                        return Ok(None);
                    }
                    continue;
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            if from.port() == self.own_port {
                continue;
            }
            // Scope hook: on the loopback scope, only this machine's datagrams.
            if let Some(local) = &mut self.local
                && !local.admits(from.ip())
            {
                self.skipped += 1;
                continue;
            }
            let at = self.clock.now();
            match buf.get(..n).map(decode) {
                Some(Ok(Message::Frame(frame))) => return Ok(Some(Received::Frame { frame, at })),
                Some(Ok(Message::Error { class, data })) => {
                    return Ok(Some(Received::Event(BusEvent::ErrorFrame { class, data })));
                }
                _ => self.skipped += 1,
            }
        }
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    #[test]
    fn encodes_and_decodes_frames() {
        for frame in [
            CanFrame::new(sid(0x605), &[0x40, 0x17, 0x10, 0, 0, 0, 0, 0]).unwrap(),
            CanFrame::new(sid(0x000), &[]).unwrap(),
            CanFrame::remote(sid(0x705), 1).unwrap(),
            CanFrame::new(CanId::extended(0x1ABC_DEF0).unwrap(), &[1, 2]).unwrap(),
        ] {
            assert_eq!(decode(&encode(&frame, 1.5)), Ok(Message::Frame(frame)));
        }
    }

    #[test]
    fn reads_other_encodings_of_the_fields() {
        // map16, int fields as uint16, data as an array of ints, an extra key.
        let mut d = vec![0xDE, 0x00, 0x04];
        d.extend_from_slice(b"\xAEarbitration_id\xCD\x06\x05");
        d.extend_from_slice(b"\xA4data\x92\x01\xCC\xFF");
        d.extend_from_slice(b"\xA5is_fd\xC0");
        d.extend_from_slice(b"\xA3new\x81\xA1k\x90");
        assert_eq!(
            decode(&d),
            Ok(Message::Frame(
                CanFrame::new(sid(0x605), &[1, 0xFF]).unwrap()
            ))
        );
        let fd = b"\x82\xAEarbitration_id\x01\xA5is_fd\xC3";
        assert_eq!(decode(fd), Ok(Message::Fd));
    }

    #[test]
    fn rejects_what_is_not_a_frame() {
        assert_eq!(decode(b""), Err(DecodeError::NotAMap));
        assert_eq!(decode(b"\x91\x01"), Err(DecodeError::NotAMap));
        assert_eq!(decode(b"\x81\xA4data"), Err(DecodeError::Truncated));
        assert_eq!(decode(b"\x80\x00"), Err(DecodeError::TrailingBytes));
        assert_eq!(
            decode(b"\x80"),
            Err(DecodeError::BadField("arbitration_id"))
        );
        assert_eq!(
            decode(b"\x81\xAEarbitration_id\xCD\x08\x00"),
            Err(DecodeError::BadFrame)
        );
        assert_eq!(
            decode(b"\x81\xAEarbitration_id\xFF"),
            Err(DecodeError::BadField("arbitration_id"))
        );
        let deep = [vec![0x91; 40], vec![0x01]].concat();
        let mut d = b"\x81\xA1x".to_vec();
        d.extend_from_slice(&deep);
        assert_eq!(decode(&d), Err(DecodeError::TooDeep));
        assert_eq!(
            decode(b"\x81\xA1x\xDD\xFF\xFF\xFF\xFF"),
            Err(DecodeError::Truncated)
        );
    }

    #[test]
    fn parses_bus_specs() {
        assert_eq!(
            parse_spec("udp"),
            Some(Ok(SocketAddrV4::new(DEFAULT_GROUP, DEFAULT_PORT)))
        );
        assert_eq!(
            parse_spec("udp:239.0.0.1:5000"),
            Some(Ok(SocketAddrV4::new(Ipv4Addr::new(239, 0, 0, 1), 5000)))
        );
        assert!(matches!(parse_spec("udp:10.0.0.1"), Some(Err(_))));
        assert!(matches!(parse_spec("udp:239.0.0.1:0"), Some(Err(_))));
        assert_eq!(parse_spec("vcan0"), None);
        assert_eq!(parse_spec("udpx"), None);
    }

    #[test]
    fn two_transports_hear_each_other_not_themselves() {
        // A port of its own per test run, so parallel runs do not cross.
        let port = 40000 + (std::process::id() % 20000) as u16;
        let group = SocketAddrV4::new(Ipv4Addr::new(239, 74, 163, 3), port);
        let (Ok(mut a), Ok(mut b)) = (UdpMulticast::open(group), UdpMulticast::open(group)) else {
            panic!("cannot open UDP multicast sockets");
        };
        let f = CanFrame::new(sid(0x123), &[1, 2, 3]).unwrap();
        a.send(&f).unwrap();
        let got = b
            .recv_timeout(canola_frame::Duration::from_millis(2000))
            .unwrap();
        assert!(
            matches!(got, Some(Received::Frame { frame, .. }) if frame == f),
            "{got:?}"
        );
        assert_eq!(
            a.recv_timeout(canola_frame::Duration::from_millis(50))
                .unwrap(),
            None
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = decode(&bytes);
        }

        #[test]
        fn decode_never_panics_on_maps(tail in proptest::collection::vec(any::<u8>(), 0..200)) {
            let mut d = vec![0x8B];
            d.extend_from_slice(&tail);
            let _ = decode(&d);
        }
    }
}
