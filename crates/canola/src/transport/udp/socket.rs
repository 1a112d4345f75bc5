//! The multicast sockets: [`UdpMulticast`] joins the group, sends each frame as one datagram
//! and receives the others' frames as a [`Transport`](crate::Transport).

use std::net::{Ipv4Addr, SocketAddrV4, UdpSocket};
use std::os::fd::AsRawFd;

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, FdFrame, Instant};
use nix::sys::socket::{
    AddressFamily, SockFlag, SockProtocol, SockType, SockaddrIn, bind, setsockopt, socket, sockopt,
};

use crate::transport::contract::{BusEvent, Received, Transport, TransportError};

use super::codec::{Message, decode, encode, encode_fd};
use super::scope::{LocalSources, UdpScope};

/// python-can's default IPv4 multicast group of `udp_multicast`.
pub const DEFAULT_GROUP: Ipv4Addr = Ipv4Addr::new(239, 74, 163, 2);
/// python-can's default port of `udp_multicast`.
pub const DEFAULT_PORT: u16 = 43113;
/// Largest datagram read (python-can's receive buffer size).
pub const MAX_DATAGRAM: usize = 4096;

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
    /// Where the bus reaches ([`super::scope`]).
    scope: UdpScope,
    /// On the loopback scope: the sources taken.
    local: Option<LocalSources>,
}

impl UdpMulticast {
    /// Joins the bus at `group` (an IPv4 multicast address and port) on this machine only
    /// ([`UdpScope::Loopback`]).
    pub fn open(group: SocketAddrV4) -> Result<Self, TransportError> {
        Self::open_scoped(group, UdpScope::Loopback)
    }

    /// Joins the bus at `group` in `scope` ([`super::scope`]).
    pub fn open_scoped(group: SocketAddrV4, scope: UdpScope) -> Result<Self, TransportError> {
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
        // Bound to the group (no unicast to the port), joined on the scope's interface only,
        // sent from its address (so out of that interface only).
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
            local: (scope == UdpScope::Loopback).then(LocalSources::new),
            scope,
        })
    }

    /// Where the bus reaches.
    pub fn scope(&self) -> &UdpScope {
        &self.scope
    }

    /// The group and port of the bus.
    pub fn group(&self) -> SocketAddrV4 {
        self.group
    }

    /// Datagrams received and skipped: not a frame in the format.
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

    /// python-can's `udp_multicast` format carries CAN FD frames (`is_fd`).
    fn fd_support(&self) -> Result<(), TransportError> {
        Ok(())
    }

    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        self.tx.send_to(&encode_fd(frame, stamp), self.group)?;
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
            // On the loopback scope, only this machine's datagrams.
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
                Some(Ok(Message::Fd(frame))) => {
                    return Ok(Some(Received::Event(BusEvent::FdFrame {
                        frame: Box::new(frame),
                        at,
                    })));
                }
                _ => self.skipped += 1,
            }
        }
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }
}
