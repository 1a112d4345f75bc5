//! Where a UDP multicast bus ([`super`]) reaches: this machine only (the default), or a
//! LAN segment on purpose.
//!
//! * [`UdpScope::Loopback`]: the group is joined on the loopback interface only and frames are
//!   sent from `127.0.0.1`, so they go out on the loopback interface only and never onto a
//!   network. A received datagram whose source is not an address of this machine is dropped
//!   (counted as skipped), so a host on the LAN cannot inject frames even where another
//!   program here joined the group on a LAN interface. Every process on this machine still
//!   shares the bus, python-can's `udp_multicast` with its defaults included: it joins on the
//!   default interface and receives what is sent here, and what it sends is looped back to
//!   this machine with its LAN address as the source.
//! * [`UdpScope::Interface`] (`udp:GROUP:PORT@IFACE`): the group is joined and sent on that
//!   interface, with a TTL of 1, as python-can does: **anyone on that segment can read every
//!   frame and inject frames** (start, stop, reset nodes, write their dictionaries).

use std::net::{IpAddr, Ipv4Addr, SocketAddrV4};
use std::time::{Duration, Instant};

/// Where the bus reaches.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UdpScope {
    /// This machine only.
    Loopback,
    /// The segment of this interface (its name and IPv4 address).
    Interface {
        /// The interface name (`eth0`).
        name: String,
        /// Its IPv4 address, which the group is joined and sent on.
        addr: Ipv4Addr,
    },
}

impl UdpScope {
    /// The address of the interface the group is joined and sent on.
    pub fn interface_addr(&self) -> Ipv4Addr {
        match self {
            Self::Loopback => Ipv4Addr::LOCALHOST,
            Self::Interface { addr, .. } => *addr,
        }
    }

    /// The scope for interface `name`: its first IPv4 address. `lo` is [`Self::Loopback`].
    pub fn interface(name: &str) -> Result<Self, String> {
        if name == "lo" {
            return Ok(Self::Loopback);
        }
        let addr = nix::ifaddrs::getifaddrs()
            .map_err(|e| format!("listing interfaces: {e}"))?
            .filter(|i| i.interface_name == name)
            .find_map(|i| i.address?.as_sockaddr_in().map(|a| a.ip()))
            .ok_or_else(|| format!("interface `{name}` has no IPv4 address (or does not exist)"))?;
        Ok(Self::Interface {
            name: name.to_owned(),
            addr,
        })
    }

    /// The warning to show for a bus in this scope, if any.
    pub fn warning(&self, group: SocketAddrV4) -> Option<String> {
        match self {
            Self::Loopback => None,
            Self::Interface { name, addr } => Some(format!(
                "the CAN bus udp:{group} is on interface {name} ({addr}): anyone on that network \
                 segment can read every frame and inject frames (start, stop and reset nodes, \
                 write their dictionaries)"
            )),
        }
    }
}

/// Splits `udp[:GROUP[:PORT]][@IFACE]` into the bus part and the scope (no `@`: loopback).
/// `None` when `spec` is not a UDP bus.
pub fn parse_scoped_spec(spec: &str) -> Option<Result<(SocketAddrV4, UdpScope), String>> {
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
        Some(i) => UdpScope::interface(i),
    };
    Some(scope.map(|s| (group, s)))
}

/// The source addresses a loopback-scoped bus takes datagrams from: the loopback range and the
/// addresses of this machine's interfaces (read again, at most once a second, when a datagram
/// comes from an address not known).
#[derive(Debug)]
pub(crate) struct LocalSources {
    addrs: Vec<Ipv4Addr>,
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
                .filter_map(|i| i.address?.as_sockaddr_in().map(|a| a.ip()))
                .collect();
        }
    }

    /// Whether a datagram from `from` comes from this machine.
    pub(crate) fn admits(&mut self, from: IpAddr) -> bool {
        let IpAddr::V4(ip) = from else { return false };
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
        let g = SocketAddrV4::new(
            crate::transport::udp::DEFAULT_GROUP,
            crate::transport::udp::DEFAULT_PORT,
        );
        assert_eq!(parse_scoped_spec("udp"), Some(Ok((g, UdpScope::Loopback))));
        assert_eq!(
            parse_scoped_spec("udp@lo"),
            Some(Ok((g, UdpScope::Loopback)))
        );
        let g2 = SocketAddrV4::new(Ipv4Addr::new(239, 0, 0, 9), 5000);
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
        assert!(!s.admits("::1".parse().unwrap()));
    }
}
