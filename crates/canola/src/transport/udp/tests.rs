//! The datagram codec against python-can's format and arbitrary bytes, and the sockets.

use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, SocketAddrV4, SocketAddrV6};

use canola_frame::{CanFrame, CanId, FdFlags, FdFrame};

use crate::transport::contract::{BusEvent, Received, Transport};

use super::codec::{DecodeError, Message, decode, encode, encode_fd};
use super::socket::{DEFAULT_GROUP, DEFAULT_GROUP_V6, DEFAULT_PORT, UdpMulticast, parse_spec};

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
    assert_eq!(
        decode(fd),
        Ok(Message::Fd(FdFrame::new(sid(0x001), &[]).unwrap()))
    );
    // python-can sends an FD message's data as given: 10 bytes are padded to 12 as the wire
    // carries them; the flags come from bitrate_switch and error_state_indicator.
    let mut d = vec![0x84];
    d.extend_from_slice(b"\xAEarbitration_id\xCD\x06\x05\xA5is_fd\xC3");
    d.extend_from_slice(b"\xAEbitrate_switch\xC3\xA4data\xC4\x0A");
    d.extend_from_slice(&[7; 10]);
    let want = FdFrame::new_padded(sid(0x605), &[7; 10])
        .unwrap()
        .with_flags(FdFlags::BRS);
    assert_eq!(decode(&d), Ok(Message::Fd(want)));
    assert_eq!(want.data().len(), 12);
    // More than 64 bytes is no frame.
    let mut d = vec![0x83];
    d.extend_from_slice(b"\xAEarbitration_id\x01\xA5is_fd\xC3\xA4data\xC4\x41");
    d.extend_from_slice(&[0; 65]);
    assert_eq!(decode(&d), Err(DecodeError::BadFrame));
}

/// The datagram python-can 4's `pack_message` makes of
/// `Message(arbitration_id=0x5A5, is_fd=True, bitrate_switch=True, data=bytes(range(20)))`
/// (timestamp 0): `dlc` 20 is the length in bytes.
const PYTHON_CAN_FD: &str = "8ba974696d657374616d70cb0000000000000000ae6172626974726174696f6e5f6964cd05a5\
ae69735f657874656e6465645f6964c2af69735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65c2\
a76368616e6e656cc0a3646c6314a464617461c414000102030405060708090a0b0c0d0e0f10111213a569735f6664c3\
ae626974726174655f737769746368c3b56572726f725f73746174655f696e64696361746f72c2";

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn reads_and_writes_python_cans_fd_datagram() {
    let bytes = unhex(PYTHON_CAN_FD);
    let want = FdFrame::new(sid(0x5A5), &(0..20).collect::<Vec<u8>>())
        .unwrap()
        .with_flags(FdFlags::BRS);
    assert_eq!(decode(&bytes), Ok(Message::Fd(want)));
    // What this transport writes for it is python-can's datagram, byte for byte.
    assert_eq!(encode_fd(&want, 0.0), bytes);
}

#[test]
fn encodes_and_decodes_fd_frames() {
    for frame in [
        FdFrame::new(sid(0x605), &[0x11; 64]).unwrap(),
        FdFrame::new(sid(0x7FF), &[1, 2, 3])
            .unwrap()
            .with_flags(FdFlags::BRS),
        FdFrame::new(CanId::extended(0x1ABC_DEF0).unwrap(), &[0; 12])
            .unwrap()
            .with_flags(FdFlags::BRS | FdFlags::ESI),
    ] {
        assert_eq!(decode(&encode_fd(&frame, 2.5)), Ok(Message::Fd(frame)));
    }
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
        Some(Ok(SocketAddrV4::new(DEFAULT_GROUP, DEFAULT_PORT).into()))
    );
    assert_eq!(
        parse_spec("udp:239.0.0.1:5000"),
        Some(Ok(
            SocketAddrV4::new(Ipv4Addr::new(239, 0, 0, 1), 5000).into()
        ))
    );
    assert!(matches!(parse_spec("udp:10.0.0.1"), Some(Err(_))));
    assert!(matches!(parse_spec("udp:239.0.0.1:0"), Some(Err(_))));
    assert_eq!(parse_spec("vcan0"), None);
    assert_eq!(parse_spec("udpx"), None);
}

#[test]
fn parses_ipv6_groups() {
    let v6 = |g: Ipv6Addr, port| Some(Ok(SocketAddr::V6(SocketAddrV6::new(g, port, 0, 0))));
    // python-can's default channel, alone and with a port in brackets.
    assert_eq!(
        parse_spec("udp:ff15:7079:7468:6f6e:6465:6d6f:6d63:6173"),
        v6(DEFAULT_GROUP_V6, DEFAULT_PORT)
    );
    assert_eq!(
        parse_spec("udp:[ff15:7079:7468:6f6e:6465:6d6f:6d63:6173]:5000"),
        v6(DEFAULT_GROUP_V6, 5000)
    );
    let short: Ipv6Addr = "ff15::1".parse().unwrap();
    assert_eq!(parse_spec("udp:ff15::1"), v6(short, DEFAULT_PORT));
    assert_eq!(parse_spec("udp:[ff15::1]"), v6(short, DEFAULT_PORT));
    for (bad, says) in [
        ("udp:fd00::1", "not a multicast address (ff00::/8)"),
        ("udp:[ff15::1]5000", "expected `:PORT`"),
        ("udp:[ff15::1", "no `]`"),
        ("udp:[ff15::1]:0", "1..=65535"),
        ("udp:ff15::1::5", "udp:[GROUP]:PORT"),
        ("udp:ff15", "not an IPv4 or IPv6 multicast address"),
    ] {
        match parse_spec(bad) {
            Some(Err(e)) => assert!(e.contains(says), "{bad}: {e}"),
            other => panic!("{bad}: {other:?}"),
        }
    }
}

/// A site-local IPv6 group of this test run's own, and whether this host carries IPv6
/// multicast (a transport joins it); else the test says it skipped.
fn ipv6_group(salt: u16) -> Option<SocketAddrV6> {
    let port = 40000 + ((std::process::id() + 13 + u32::from(salt)) % 20000) as u16;
    let group = SocketAddrV6::new(
        Ipv6Addr::new(0xff15, 0x7079, 0x7468, 0x6f6e, 0, 0, 0, salt),
        port,
        0,
        0,
    );
    match UdpMulticast::open(group) {
        Ok(_) => Some(group),
        Err(e) => {
            eprintln!("SKIPPED: this host carries no IPv6 multicast: {e}");
            None
        }
    }
}

#[test]
fn ipv6_transports_hear_each_other_on_this_machine_only() {
    let Some(group) = ipv6_group(1) else { return };
    let (mut a, mut b) = (
        UdpMulticast::open(group).unwrap(),
        UdpMulticast::open(group).unwrap(),
    );
    assert_eq!(a.group(), SocketAddr::V6(group));
    let f = CanFrame::new(sid(0x185), &[1, 2, 3, 4]).unwrap();
    a.send(&f).unwrap();
    let got = b
        .recv_timeout(canola_frame::Duration::from_millis(2000))
        .unwrap();
    assert!(
        matches!(got, Some(Received::Frame { frame, .. }) if frame == f),
        "{got:?}"
    );
    // Not received by its sender.
    assert_eq!(
        a.recv_timeout(canola_frame::Duration::from_millis(50))
            .unwrap(),
        None
    );
    // Sent with a hop limit of 0: looped back to this machine, never onto a network.
    let hops =
        nix::sys::socket::getsockopt(&a.tx, nix::sys::socket::sockopt::Ipv6MulticastHops).unwrap();
    assert_eq!(hops, 0);
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

#[test]
fn fd_frames_cross_the_bus() {
    let port = 40000 + ((std::process::id() + 7) % 20000) as u16;
    let group = SocketAddrV4::new(Ipv4Addr::new(239, 74, 163, 4), port);
    let (Ok(mut a), Ok(mut b)) = (UdpMulticast::open(group), UdpMulticast::open(group)) else {
        panic!("cannot open UDP multicast sockets");
    };
    assert!(a.fd_support().is_ok());
    let f = FdFrame::new(sid(0x123), &[9; 48])
        .unwrap()
        .with_flags(FdFlags::BRS);
    a.send_fd(&f).unwrap();
    let got = b
        .recv_timeout(canola_frame::Duration::from_millis(2000))
        .unwrap();
    assert!(
        matches!(&got, Some(Received::Event(BusEvent::FdFrame { frame, .. })) if **frame == f),
        "{got:?}"
    );
}

/// A transport of its own on the loopback scope, on a port of this test run (`salt` apart).
fn own_bus(last: u8, salt: u32) -> UdpMulticast {
    let port = 40000 + ((std::process::id() + salt) % 20000) as u16;
    let group = SocketAddrV4::new(Ipv4Addr::new(239, 74, 163, last), port);
    UdpMulticast::open(group).expect("cannot open UDP multicast sockets")
}

#[test]
fn the_waker_ends_a_wait_blocked_in_another_thread() {
    let mut t = own_bus(5, 13);
    let waker = t.waker().expect("the UDP bus has a waker");
    let deadline = t.now() + canola_frame::Duration::from_secs(10);
    let (entered, wait_entered) = std::sync::mpsc::channel::<()>();
    let waking = std::thread::spawn(move || {
        // Woken once the test is about to wait (or already waits: either way the wait ends).
        wait_entered.recv().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        waker.wake();
    });
    entered.send(()).unwrap();
    assert_eq!(t.recv_until(deadline).unwrap(), None);
    // Ended by the wake, not by the deadline (ten seconds away on the transport's clock).
    assert!(t.now() < deadline);
    waking.join().unwrap();
}

#[test]
fn a_wake_before_the_wait_ends_the_next_wait_once() {
    let mut t = own_bus(6, 17);
    let waker = t.waker().unwrap();
    // Two wakes while nobody waits: the next wait returns at once, the one after waits.
    waker.wake();
    waker.clone().wake();
    let far = t.now() + canola_frame::Duration::from_secs(10);
    assert_eq!(t.recv_until(far).unwrap(), None);
    assert!(t.now() < far);
    let near = t.now() + canola_frame::Duration::from_millis(5);
    assert_eq!(t.recv_until(near).unwrap(), None);
    assert!(t.now() >= near);
}

#[test]
fn a_frame_waiting_is_read_after_a_wake() {
    let (mut a, mut b) = (own_bus(7, 19), own_bus(7, 19));
    let f = CanFrame::new(sid(0x181), &[7]).unwrap();
    a.send(&f).unwrap();
    b.waker().unwrap().wake();
    let deadline = b.now() + canola_frame::Duration::from_secs(2);
    // The wake may end one wait; the frame is still there for the next.
    let got = match b.recv_until(deadline).unwrap() {
        None => b.recv_until(deadline).unwrap(),
        got => got,
    };
    assert!(
        matches!(got, Some(Received::Frame { frame, .. }) if frame == f),
        "{got:?}"
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
