//! The interface goes down under the master and comes back (`ip link set vcan0 down/up`):
//! - at the transport: sending fails with `TransportError::InterfaceDown`, the receive side
//!   reports `BusEvent::InterfaceDown`, and after `up` traffic flows again and
//!   `BusEvent::InterfaceUp` is reported;
//! - frames queued before the link went down are read while it is down, after the
//!   `InterfaceDown` event, and are no `InterfaceUp`;
//! - during an SDO block upload from the simulator: the transfer ends with a clear error, the
//!   network reports the bus event, and after `up` the next transfers succeed.
//!
//! These tests change the state of the shared interface, so `tests/vcan/run-all` runs this
//! binary on its own with `--test-threads=1`. Needs root in the guest (`ip`).

mod common;

use std::process::Command;
use std::time::Duration as StdDuration;

use canola::socketcan::SocketCan;
use canola::{BusEvent, Network, NetworkEvent, Received, Transport, TransportError};
use canola_frame::{CanFrame, CanId, Duration};
use common::{RunningSim, device, node};
use socketcan::{CanFilter, EmbeddedFrame, Socket};
use vcan_tests::{interface, open_filtered};

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
    let peer = open_filtered(&[CanFilter::new(0x630, 0x7F0)]).expect("open the peer socket");

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

#[test]
#[ignore = "needs vcan0 and root: run by tests/vcan/run-all"]
fn frames_queued_before_the_link_went_down_are_read_without_a_false_interface_up() {
    let _guard = LinkGuard;
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    let peer = vcan_tests::open().expect("open the peer socket");
    let id = socketcan::StandardId::new(0x642).expect("id");
    for i in 0..5u8 {
        let f = socketcan::CanFrame::new(id, &[i]).expect("frame");
        peer.write_frame(&f).expect("peer sends");
    }
    // Not read yet: the five frames wait in the transport's receive queue.
    set_link(false);
    let mut seen = Vec::new();
    let deadline = t.now() + Duration::from_secs(5);
    while seen.len() < 6 {
        match t.recv_until(deadline).expect("recv") {
            Some(Received::Event(e)) => seen.push(format!("{e}")),
            Some(Received::Frame { frame, .. }) if frame.id().as_standard() == Some(0x642) => {
                seen.push(format!("frame {}", frame.data()[0]));
            }
            Some(_) => {}
            None => break,
        }
    }
    // The kernel reports ENETDOWN first, then hands out what it had queued; none of those
    // frames means the link is back.
    assert_eq!(
        seen,
        [
            "interface is down",
            "frame 0",
            "frame 1",
            "frame 2",
            "frame 3",
            "frame 4"
        ]
    );
    assert!(
        t.try_recv().expect("recv").is_none(),
        "nothing else while down"
    );
    set_link(true);
    t.send(&frame(0x643, &[9]))
        .expect("send after the link returned");
    expect_event(&mut t, &BusEvent::InterfaceUp);
}

#[test]
#[ignore = "needs vcan0 and root: run by tests/vcan/run-all"]
fn link_down_during_a_block_upload_ends_it_clearly_and_the_network_recovers() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    let _guard = LinkGuard;
    const ID: u8 = 0x44;
    let data: Vec<u8> = (0..65536u32).map(|i| (i * 7 % 251) as u8).collect();
    let mut dev = device(ID);
    dev.values_mut().set(0x2001, 0, data.clone());
    let _sim = RunningSim::start(dev);
    let net = Network::new(SocketCan::open(&interface()).expect("open the master's socket"));
    let events = net.subscribe();
    let n = net.node(node(ID));

    // Take the link down once 8 KiB of the 64 KiB have arrived.
    let pulled = Arc::new(AtomicBool::new(false));
    let flag = pulled.clone();
    let result = n
        .sdo()
        .block(true)
        .timeout(Duration::from_secs(2))
        .on_progress(move |p| {
            if p.done >= 8192 && !flag.swap(true, Ordering::SeqCst) {
                set_link(false);
            }
        })
        .read((0x2001, 0))
        .wait();
    assert!(
        pulled.load(Ordering::SeqCst),
        "the transfer ended before 8 KiB: {result:?}"
    );
    let err = result.expect_err("a block upload interrupted by a downed link must fail");
    let text = err.to_string();
    eprintln!("the interrupted transfer ended with: {text}");
    // Whether the master was sending (a block acknowledgement) or waiting when the link went,
    // the transfer ends when its next send fails: the error says why, not just "timeout".
    assert!(
        text.ends_with("transport failed: the CAN interface is down"),
        "unclear error for a downed link: {text}"
    );
    let bus_events: Vec<NetworkEvent> = events.try_iter().collect();
    assert!(
        bus_events.contains(&NetworkEvent::Bus(BusEvent::InterfaceDown)),
        "no InterfaceDown bus event: {bus_events:?}"
    );

    // The link returns: the network recovers without being rebuilt.
    set_link(true);
    let sdo = || n.sdo().timeout(Duration::from_secs(2));
    let mut first = sdo().read((0x1018, 1)).wait();
    for _ in 0..5 {
        // The simulator may still be finishing the interrupted transfer (its own timeout).
        if first.is_ok() {
            break;
        }
        eprintln!("first read after the link returned: {first:?}");
        first = sdo().read((0x1018, 1)).wait();
    }
    assert_eq!(
        first.expect("expedited read after recovery"),
        0x0ABCu32.to_le_bytes()
    );
    assert_eq!(
        sdo()
            .block(true)
            .read((0x2001, 0))
            .wait()
            .expect("block upload after recovery"),
        data
    );
}
