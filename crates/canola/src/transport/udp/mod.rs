//! A CAN bus over UDP multicast in the wire format of python-can's `udp_multicast` interface,
//! for several processes on one machine (or, on purpose, one LAN segment: see [`scope`])
//! without CAN hardware or vcan.
//!
//! Every attached process joins one multicast group (IPv4, or IPv6 as python-can's default)
//! and port; each frame is one datagram
//! holding a MessagePack map with the keys python-can writes: `timestamp` (float seconds),
//! `arbitration_id`, `is_extended_id`, `is_remote_frame`, `is_error_frame`, `channel`, `dlc`,
//! `data` (binary), `is_fd`, `bitrate_switch`, `error_state_indicator`. python-can's default
//! IPv4 group is `239.74.163.2`, its default port 43113; its default group is the IPv6 one
//! `ff15:7079:7468:6f6e:6465:6d6f:6d63:6173` ([`DEFAULT_GROUP_V6`]), which this transport joins
//! as `udp:ff15:7079:7468:6f6e:6465:6d6f:6d63:6173` (`udp` alone is the IPv4 group).
//!
//! Like python-can, the socket binds the group's port with `SO_REUSEADDR`/`SO_REUSEPORT` and
//! sends with multicast loopback on, so processes on the same machine hear each other (with a
//! TTL of 1 on IPv4 and on an interface's segment, a hop limit of 0 for an IPv6 group on this
//! machine only). Unlike python-can, it binds the group's address (no unicast datagrams to the port) and
//! by default joins and sends on the loopback interface only: nothing leaves the machine and
//! only this machine's datagrams are taken ([`UdpScope`]). Frames are sent from
//! a second socket on an ephemeral port; a datagram whose source port is that port is this
//! transport's own and is not received again (a CAN controller does not receive its own frames
//! either).
//!
//! Received datagrams are decoded by a total MessagePack reader ([`decode`]): a datagram that is
//! not a frame in this format is skipped and counted ([`UdpMulticast::skipped`]), never fatal:
//! on a LAN scope anyone on the segment can send to the group.
//!
//! CAN FD: python-can marks an FD message with `is_fd` (its `udp_multicast` bus is opened with
//! `fd=True` by default) and carries the BRS and ESI flags as `bitrate_switch` and
//! `error_state_indicator`; `dlc` is the data length in bytes. This bus carries FD frames both
//! ways: received ones come as [`BusEvent::FdFrame`](crate::BusEvent::FdFrame) (data padded with
//! zeros to the next CAN FD length), [`Transport::send_fd`](crate::Transport::send_fd) sends
//! them ([`encode_fd`]).
//!
//! Waiting: a receive polls the socket (`poll`, on the kernel's high-resolution timers: a
//! receive timeout, `SO_RCVTIMEO`, would be rounded up to the scheduler's tick) beside one end
//! of a Unix socket pair; [`Transport::waker`](crate::Transport::waker) writes a byte to the
//! other end, which ends the wait at once (or the next one, when nobody waits).
//!
//! Files by job: `codec` (the MessagePack datagrams), `socket` (the multicast sockets), [`scope`]
//! (where the bus reaches, and the `udp:GROUP:PORT@IFACE` spec).

mod codec;
pub mod scope;
mod socket;
#[cfg(test)]
mod tests;

pub use codec::{DecodeError, Message, decode, encode, encode_fd};
pub use scope::{UdpScope, parse_scoped_spec};
pub use socket::{
    DEFAULT_GROUP, DEFAULT_GROUP_V6, DEFAULT_PORT, MAX_DATAGRAM, UdpMulticast, parse_spec,
};
