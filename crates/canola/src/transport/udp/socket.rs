//! The multicast sockets: [`UdpMulticast`] joins the group, sends each frame as one datagram
//! and receives the others' frames as a [`Transport`](crate::Transport).

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, SocketAddrV4, SocketAddrV6, UdpSocket};
use std::os::fd::AsRawFd;
use std::os::unix::net::UnixDatagram;
use std::sync::Arc;

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, FdFrame, Instant};
use nix::sys::socket::{
    AddressFamily, SockFlag, SockProtocol, SockType, SockaddrIn, SockaddrIn6, bind, setsockopt,
    socket, sockopt,
};

use crate::transport::contract::{BusEvent, Received, Transport, TransportError, TransportWaker};

use super::codec::{Message, decode, encode, encode_fd};
use super::scope::{LocalSources, UdpScope};

/// python-can's default IPv4 multicast group of `udp_multicast`.
pub const DEFAULT_GROUP: Ipv4Addr = Ipv4Addr::new(239, 74, 163, 2);
/// python-can's default port of `udp_multicast`.
pub const DEFAULT_PORT: u16 = 43113;
/// Largest datagram read (python-can's receive buffer size).
pub const MAX_DATAGRAM: usize = 4096;

/// python-can's default group of `udp_multicast` (its `channel` when none is given), an IPv6
/// site-local group.
pub const DEFAULT_GROUP_V6: Ipv6Addr = Ipv6Addr::new(
    0xff15, 0x7079, 0x7468, 0x6f6e, 0x6465, 0x6d6f, 0x6d63, 0x6173,
);

/// Where a UDP multicast bus lives: `udp`, `udp:GROUP` or `udp:GROUP:PORT` with an IPv4 group,
/// `udp:GROUP6` or `udp:[GROUP6]:PORT` with an IPv6 one (python-can's defaults for the parts
/// left out: group 239.74.163.2, port 43113). `None` when `spec` does not start with `udp`.
pub fn parse_spec(spec: &str) -> Option<Result<SocketAddr, String>> {
    let rest = spec.strip_prefix("udp")?;
    let rest = match rest.strip_prefix(':') {
        Some(r) => r,
        None if rest.is_empty() => {
            return Some(Ok(SocketAddrV4::new(DEFAULT_GROUP, DEFAULT_PORT).into()));
        }
        None => return None,
    };
    let (group, port) = if let Some(inner) = rest.strip_prefix('[') {
        // `[GROUP6]` or `[GROUP6]:PORT`
        let Some((g, after)) = inner.split_once(']') else {
            return Some(Err(format!("`{spec}`: no `]` after the IPv6 group")));
        };
        match after {
            "" => (g, None),
            p => match p.strip_prefix(':') {
                Some(p) => (g, Some(p)),
                None => return Some(Err(format!("`{spec}`: expected `:PORT` after `]`"))),
            },
        }
    } else if rest.matches(':').count() > 1 {
        // An IPv6 group alone (its port needs the brackets).
        (rest, None)
    } else {
        match rest.split_once(':') {
            Some((g, p)) => (g, Some(p)),
            None => (rest, None),
        }
    };
    let group = match group.parse::<IpAddr>() {
        Ok(g) if g.is_multicast() => g,
        Ok(IpAddr::V4(g)) => {
            return Some(Err(format!("{g} is not a multicast address (224.0.0.0/4)")));
        }
        Ok(IpAddr::V6(g)) => {
            return Some(Err(format!("{g} is not a multicast address (ff00::/8)")));
        }
        Err(_) if group.contains(':') => {
            return Some(Err(format!(
                "`{group}` is not an IPv6 address (a port after one: udp:[GROUP]:PORT)"
            )));
        }
        Err(_) => {
            return Some(Err(format!(
                "`{group}` is not an IPv4 or IPv6 multicast address"
            )));
        }
    };
    let port = match port.map(str::parse::<u16>) {
        None => DEFAULT_PORT,
        Some(Ok(p)) if p != 0 => p,
        Some(_) => return Some(Err(format!("`{spec}`: the port is 1..=65535"))),
    };
    Some(Ok(SocketAddr::new(group, port)))
}

/// A CAN bus over UDP multicast (see the module documentation).
#[derive(Debug)]
pub struct UdpMulticast {
    rx: UdpSocket,
    pub(super) tx: UdpSocket,
    group: SocketAddr,
    own_port: u16,
    clock: MonotonicClock,
    skipped: u64,
    /// The waker's end of the wake-up pair ([`Transport::waker`]): a byte sent on the other
    /// end makes this one readable, which ends a wait.
    wake_rx: UnixDatagram,
    wake_tx: Arc<UnixDatagram>,
    /// Where the bus reaches ([`super::scope`]).
    scope: UdpScope,
    /// On the loopback scope: the sources taken.
    local: Option<LocalSources>,
}

impl UdpMulticast {
    /// Joins the bus at `group` (an IPv4 or IPv6 multicast address and port) on this machine
    /// only ([`UdpScope::Loopback`]).
    pub fn open(group: impl Into<SocketAddr>) -> Result<Self, TransportError> {
        Self::open_scoped(group, UdpScope::Loopback)
    }

    /// Joins the bus at `group` in `scope` ([`super::scope`]).
    pub fn open_scoped(
        group: impl Into<SocketAddr>,
        scope: UdpScope,
    ) -> Result<Self, TransportError> {
        let group = group.into();
        let (rx, tx) = match group {
            SocketAddr::V4(g) => Self::sockets_v4(g, &scope)?,
            SocketAddr::V6(g) => Self::sockets_v6(g, &scope)?,
        };
        let own_port = tx.local_addr()?.port();
        // Waits poll the socket (never block in a read), with the wake-up pair beside it.
        rx.set_nonblocking(true)?;
        let (wake_rx, wake_tx) = UnixDatagram::pair()?;
        wake_rx.set_nonblocking(true)?;
        wake_tx.set_nonblocking(true)?;
        Ok(Self {
            rx,
            tx,
            group,
            own_port,
            clock: MonotonicClock::new(),
            skipped: 0,
            wake_rx,
            wake_tx: Arc::new(wake_tx),
            local: (scope == UdpScope::Loopback).then(LocalSources::new),
            scope,
        })
    }

    /// The receiving socket bound to `group` (no unicast to the port), shared with the other
    /// processes on the port.
    fn bound(group: SocketAddr) -> Result<UdpSocket, TransportError> {
        let io = |e: nix::errno::Errno| TransportError::Io(e.into());
        let family = match group {
            SocketAddr::V4(_) => AddressFamily::Inet,
            SocketAddr::V6(_) => AddressFamily::Inet6,
        };
        let fd = socket(
            family,
            SockType::Datagram,
            SockFlag::SOCK_CLOEXEC,
            SockProtocol::Udp,
        )
        .map_err(io)?;
        setsockopt(&fd, sockopt::ReuseAddr, &true).map_err(io)?;
        setsockopt(&fd, sockopt::ReusePort, &true).map_err(io)?;
        match group {
            SocketAddr::V4(g) => bind(fd.as_raw_fd(), &SockaddrIn::from(g)),
            SocketAddr::V6(g) => {
                setsockopt(&fd, sockopt::Ipv6V6Only, &true).map_err(io)?;
                bind(fd.as_raw_fd(), &SockaddrIn6::from(g))
            }
        }
        .map_err(io)?;
        Ok(UdpSocket::from(fd))
    }

    /// IPv4: joined on the scope's interface only, sent from its address (so out of that
    /// interface only).
    fn sockets_v4(
        group: SocketAddrV4,
        scope: &UdpScope,
    ) -> Result<(UdpSocket, UdpSocket), TransportError> {
        let on = match scope.interface_addr() {
            IpAddr::V4(a) => a,
            IpAddr::V6(_) => Ipv4Addr::LOCALHOST,
        };
        let rx = Self::bound(group.into())?;
        rx.join_multicast_v4(group.ip(), &on)?;
        let tx = UdpSocket::bind(SocketAddrV4::new(on, 0))?;
        tx.set_multicast_ttl_v4(1)?;
        tx.set_multicast_loop_v4(true)?;
        Ok((rx, tx))
    }

    /// IPv6: the loopback interface carries no IPv6 multicast, so on this machine only the
    /// group is joined on the interface the host routes it to and sent with a hop limit of 0:
    /// looped back to this machine's sockets, never onto a network. On an interface's segment,
    /// joined and sent on that interface with a hop limit of 1.
    fn sockets_v6(
        group: SocketAddrV6,
        scope: &UdpScope,
    ) -> Result<(UdpSocket, UdpSocket), TransportError> {
        let io = |e: nix::errno::Errno| TransportError::Io(e.into());
        let no_multicast = |e: std::io::Error| {
            TransportError::Io(std::io::Error::new(
                e.kind(),
                format!(
                    "joining the IPv6 group {}: {e} (does this host carry IPv6 multicast? \
                     `ip -6 route` should show a route for ff00::/8; else give an IPv4 group)",
                    group.ip()
                ),
            ))
        };
        let rx = Self::bound(group.into())?;
        rx.join_multicast_v6(group.ip(), scope.interface_index())
            .map_err(no_multicast)?;
        let tx = UdpSocket::bind(SocketAddrV6::new(Ipv6Addr::UNSPECIFIED, 0, 0, 0))?;
        let hops = match scope {
            UdpScope::Loopback => 0,
            UdpScope::Interface { name, .. } => {
                setsockopt(&tx, sockopt::BindToDevice, &std::ffi::OsString::from(name))
                    .map_err(io)?;
                1
            }
        };
        setsockopt(&tx, sockopt::Ipv6MulticastHops, &hops).map_err(io)?;
        tx.set_multicast_loop_v6(true)?;
        Ok((rx, tx))
    }

    /// Where the bus reaches.
    pub fn scope(&self) -> &UdpScope {
        &self.scope
    }

    /// The group and port of the bus.
    pub fn group(&self) -> SocketAddr {
        self.group
    }

    /// Datagrams received and skipped: not a frame in the format.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    /// Waits until the socket is readable, the waker was called or `wait` has passed, with
    /// `poll` on the kernel's high-resolution timers (a receive timeout, `SO_RCVTIMEO`, is
    /// rounded up to the scheduler's tick: milliseconds). Returns whether the waker was called
    /// (its bytes are then taken).
    fn poll_wait(&mut self, wait: std::time::Duration) -> Result<bool, TransportError> {
        use nix::poll::{PollFd, PollFlags, ppoll};
        use std::os::fd::AsFd;
        let mut fds = [
            PollFd::new(self.rx.as_fd(), PollFlags::POLLIN),
            PollFd::new(self.wake_rx.as_fd(), PollFlags::POLLIN),
        ];
        match ppoll(&mut fds, Some(nix::sys::time::TimeSpec::from(wait)), None) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => return Ok(false),
            Ok(_) => {}
            Err(e) => return Err(std::io::Error::from(e).into()),
        }
        let woken = fds[1].any().unwrap_or(false);
        if woken {
            let mut byte = [0u8; 1];
            while self.wake_rx.recv(&mut byte).is_ok() {}
        }
        Ok(woken)
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
        // Whether the socket may hold another datagram (one was just read and skipped): read
        // again at once instead of polling first.
        let mut ready = false;
        loop {
            if !ready {
                let wait = deadline.saturating_duration_since(self.clock.now());
                if !wait.is_zero() {
                    let wait = std::time::Duration::from_micros(wait.as_micros().max(1));
                    if self.poll_wait(wait)? {
                        return Ok(None);
                    }
                }
            }
            let (n, from) = match self.rx.recv_from(&mut buf) {
                Ok(r) => r,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if self.clock.now() >= deadline {
                        return Ok(None);
                    }
                    ready = false;
                    continue;
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            ready = true;
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

    fn waker(&self) -> Option<TransportWaker> {
        let tx = self.wake_tx.clone();
        // A full pair (wakes nobody took) is readable already: nothing lost.
        Some(TransportWaker::new(move || {
            let _ = tx.send(&[1]);
        }))
    }
}
