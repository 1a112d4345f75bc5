//! The interface goes down under the master's SocketCAN transport and comes back: sending fails
//! with `TransportError::InterfaceDown`, the receive side reports `BusEvent::InterfaceDown`, and
//! after `ip link set vcan0 up` traffic flows again and `BusEvent::InterfaceUp` is reported.
//!
//! This binary changes the state of the shared interface, so it holds a single test and
//! `tests/vcan/run-all` runs it on its own (`--test-threads=1`). Needs root in the guest (`ip`).

use std::process::Command;
use std::time::Duration as StdDuration;

use can_frame::{CanFrame, CanId, Duration};
use canopen::socketcan::SocketCan;
use canopen::{BusEvent, Received, Transport, TransportError};
use socketcan::{CanFilter, EmbeddedFrame, Socket, SocketOptions};
use vcan_tests::{interface, open};

fn set_link(up: bool) {
    let iface = interface();
    let status = Command::new("ip")
        .args(["link", "set", "dev", &iface, if up { "up" } else { "down" }])
        .status()
        .expect("run ip");
    assert!(status.success(), "ip link set {iface} failed: {status}");
}

/// Brings the interface back up even when an assertion fails, so later tests keep their bus.
struct LinkGuard;

impl Drop for LinkGuard {
    fn drop(&mut self) {
        set_link(true);
    }
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(CanId::standard(id).expect("11-bit id"), data).expect("frame")
}

/// Waits up to 10 s for `event`, skipping frames and other events.
fn expect_event(t: &mut SocketCan, event: &BusEvent) {
    let deadline = t.now() + Duration::from_secs(10);
    loop {
        match t.recv_until(deadline) {
            Ok(Some(Received::Event(e))) if &e == event => return,
            Ok(Some(_)) => {}
            Ok(None) => panic!("no {event} within 10 s"),
            Err(e) => panic!("recv failed while waiting for {event}: {e}"),
        }
    }
}

#[test]
#[ignore = "needs vcan0 and root: run by tests/vcan/run-all"]
fn interface_down_is_reported_and_traffic_recovers() {
    let _guard = LinkGuard;
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    let peer = open().expect("open the peer socket");
    peer.set_filters(&[CanFilter::new(0x630, 0x7F0)])
        .expect("filter");

    t.send(&frame(0x631, &[1])).expect("send while up");
    let got = peer
        .read_frame_timeout(StdDuration::from_secs(10))
        .expect("peer receives");
    assert_eq!(got.data(), &[1]);

    set_link(false);
    match t.send(&frame(0x631, &[2])) {
        Err(TransportError::InterfaceDown) => {}
        other => panic!("send on a down interface: expected InterfaceDown, got {other:?}"),
    }
    assert_eq!(
        TransportError::InterfaceDown.to_string(),
        "the CAN interface is down"
    );
    expect_event(&mut t, &BusEvent::InterfaceDown);

    set_link(true);
    t.send(&frame(0x631, &[3]))
        .expect("send after the link returned");
    expect_event(&mut t, &BusEvent::InterfaceUp);
    // The peer's socket saw the link go down too: its next read may report ENETDOWN once.
    let deadline = std::time::Instant::now() + StdDuration::from_secs(10);
    let got = loop {
        match peer.read_frame_timeout(StdDuration::from_secs(10)) {
            Ok(f) => break f,
            Err(e) if e.raw_os_error() == Some(100) && std::time::Instant::now() < deadline => {}
            Err(e) => panic!("peer read after the link returned: {e}"),
        }
    };
    assert_eq!(
        got.data(),
        &[3],
        "the frame sent while down must not be delivered late"
    );

    // And the other direction.
    let f = socketcan::CanFrame::new(socketcan::StandardId::new(0x5B1).expect("id"), &[4])
        .expect("frame");
    peer.write_frame(&f).expect("peer sends");
    let deadline = t.now() + Duration::from_secs(10);
    loop {
        match t.recv_until(deadline).expect("recv") {
            Some(Received::Frame { frame, .. }) if frame.id().as_standard() == Some(0x5B1) => {
                assert_eq!(frame.data(), &[4]);
                break;
            }
            Some(_) => {}
            None => panic!("no frame from the peer after the link returned"),
        }
    }
}
