//! Where a UDP multicast bus ([`super`]) reaches: this machine only (the default), or a
//! LAN segment on purpose.
//!
//! * [`UdpScope::Loopback`]: an IPv4 group is joined on the loopback interface only and frames
//!   are sent from `127.0.0.1`, so they go out on the loopback interface only and never onto a
//!   network. The loopback interface carries no IPv6 multicast: an IPv6 group is joined on the
//!   interface the host routes it to and frames are sent with a hop limit of 0, so they are
//!   looped back to this machine's sockets and never sent onto a network. A received datagram whose source is not an address of this machine is dropped
//!   (counted as skipped), so a host on the LAN cannot inject frames even where another
//!   program here joined the group on a LAN interface. Every process on this machine still
//!   shares the bus, python-can's `udp_multicast` with its defaults included: it joins on the
//!   default interface and receives what is sent here, and what it sends is looped back to
//!   this machine with its LAN address as the source (python-can's default group is the IPv6
//!   one, [`DEFAULT_GROUP_V6`](super::DEFAULT_GROUP_V6)).
//! * [`UdpScope::Interface`] (`udp:GROUP:PORT@IFACE`): the group is joined and sent on that
//!   interface, with a TTL of 1, as python-can does: **anyone on that segment can read every
//!   frame and inject frames** (start, stop, reset nodes, write their dictionaries).

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::time::{Duration, Instant};

/// Where the bus reaches.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UdpScope {
    /// This machine only.
    Loopback,
    /// The segment of this interface.
    Interface {
        /// The interface name (`eth0`).
        name: String,
        /// Its address of the group's family, which the group is joined and sent on (IPv4)
        /// or shown (IPv6).
        addr: IpAddr,
        /// Its index, which an IPv6 group is joined on.
        index: u32,
    },
}

impl UdpScope {
    /// The address of the interface an IPv4 group is joined and sent on (`127.0.0.1` on the
    /// loopback scope).
    pub fn interface_addr(&self) -> IpAddr {
        match self {
            Self::Loopback => Ipv4Addr::LOCALHOST.into(),
            Self::Interface { addr, .. } => *addr,
        }
    }

    /// The index of the interface an IPv6 group is joined on: 0 on the loopback scope (the
    /// interface the host routes the group to; frames then never leave the machine).
    pub fn interface_index(&self) -> u32 {
        match self {
            Self::Loopback => 0,
            Self::Interface { index, .. } => *index,
        }
    }

    /// The scope for interface `name` and an IPv4 group: its first IPv4 address. `lo` is
    /// [`Self::Loopback`].
    pub fn interface(name: &str) -> Result<Self, String> {
        Self::interface_for(name, false)
    }

    /// The scope for interface `name` and a group of IPv6 (`v6`) or IPv4: its first address of
    /// that family. `lo` is [`Self::Loopback`].
    pub fn interface_for(name: &str, v6: bool) -> Result<Self, String> {
        if name == "lo" {
            return Ok(Self::Loopback);
        }
        let family = if v6 { "IPv6" } else { "IPv4" };
        let addr = nix::ifaddrs::getifaddrs()
            .map_err(|e| format!("listing interfaces: {e}"))?
            .filter(|i| i.interface_name == name)
            .find_map(|i| {
                let a = i.address?;
                if v6 {
                    a.as_sockaddr_in6().map(|a| IpAddr::V6(a.ip()))
                } else {
                    a.as_sockaddr_in().map(|a| IpAddr::V4(a.ip()))
                }
            })
            .ok_or_else(|| {
                format!("interface `{name}` has no {family} address (or does not exist)")
            })?;
        let index =
            nix::net::if_::if_nametoindex(name).map_err(|e| format!("interface `{name}`: {e}"))?;
        Ok(Self::Interface {
            name: name.to_owned(),
            addr,
            index,
        })
    }

    /// The warning to show for a bus in this scope, if any.
    pub fn warning(&self, group: impl Into<SocketAddr>) -> Option<String> {
        let group = group.into();
        match self {
            Self::Loopback => None,
            Self::Interface { name, addr, .. } => Some(format!(
                "the CAN bus udp:{group} is on interface {name} ({addr}): anyone on that network \
                 segment can read every frame and inject frames (start, stop and reset nodes, \
                 write their dictionaries)"
            )),
        }
    }
}

/// Splits `udp[:GROUP[:PORT]][@IFACE]` into the bus part and the scope (no `@`: loopback).
/// `None` when `spec` is not a UDP bus.
pub fn parse_scoped_spec(spec: &str) -> Option<Result<(SocketAddr, UdpScope), String>> {
    let (bus, iface) = match spec.split_once('@') {
        Some((b, i)) => (b, Some(i)),
        None => (spec, None),
    };
    let group = match super::parse_spec(bus)? {
        Ok(g) => g,
        Err(e) => return Some(Err(e)),
    };
    let scope = match iface {
        None => Ok(UdpScope::Loopback),
        Some("") => Err(format!("`{spec}`: no interface after @")),
        Some(i) => UdpScope::interface_for(i, group.is_ipv6()),
    };
    Some(scope.map(|s| (group, s)))
}

/// The source addresses a loopback-scoped bus takes datagrams from: the loopback range and the
/// addresses of this machine's interfaces (read again, at most once a second, when a datagram
/// comes from an address not known).
#[derive(Debug)]
pub(crate) struct LocalSources {
    addrs: Vec<IpAddr>,
    read_at: Option<Instant>,
}

impl LocalSources {
    pub(crate) fn new() -> Self {
        let mut s = Self {
            addrs: Vec::new(),
            read_at: None,
        };
        s.refresh();
        s
    }

    fn refresh(&mut self) {
        self.read_at = Some(Instant::now());
        if let Ok(ifs) = nix::ifaddrs::getifaddrs() {
            self.addrs = ifs
                .filter_map(|i| {
                    let a = i.address?;
                    a.as_sockaddr_in()
                        .map(|a| IpAddr::V4(a.ip()))
                        .or_else(|| a.as_sockaddr_in6().map(|a| IpAddr::V6(a.ip())))
                })
                .collect();
        }
    }

    /// Whether a datagram from `from` comes from this machine.
    pub(crate) fn admits(&mut self, from: IpAddr) -> bool {
        let ip = from.to_canonical();
        if ip.is_loopback() || self.addrs.contains(&ip) {
            return true;
        }
        if self
            .read_at
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(1))
        {
            self.refresh();
            return self.addrs.contains(&ip);
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_with_an_interface() {
        let g = SocketAddr::from((
            crate::transport::udp::DEFAULT_GROUP,
            crate::transport::udp::DEFAULT_PORT,
        ));
        assert_eq!(parse_scoped_spec("udp"), Some(Ok((g, UdpScope::Loopback))));
        assert_eq!(
            parse_scoped_spec("udp@lo"),
            Some(Ok((g, UdpScope::Loopback)))
        );
        let g2 = SocketAddr::from((Ipv4Addr::new(239, 0, 0, 9), 5000));
        assert_eq!(
            parse_scoped_spec("udp:239.0.0.9:5000@lo"),
            Some(Ok((g2, UdpScope::Loopback)))
        );
        assert!(matches!(parse_scoped_spec("udp@"), Some(Err(_))));
        assert!(matches!(
            parse_scoped_spec("udp@no-such-interface-x"),
            Some(Err(_))
        ));
        assert_eq!(parse_scoped_spec("vcan0"), None);
    }

    #[test]
    fn loopback_sources_are_local() {
        let mut s = LocalSources::new();
        assert!(s.admits("127.0.0.1".parse().unwrap()));
        assert!(s.admits("127.1.2.3".parse().unwrap()));
        // TEST-NET-3 is no address of this machine.
        assert!(!s.admits("203.0.113.9".parse().unwrap()));
        assert!(s.admits("::1".parse().unwrap()));
        // IPv6 documentation prefix: no address of this machine.
        assert!(!s.admits("2001:db8::9".parse().unwrap()));
    }
}
