//! The master's SocketCAN transport (`canola::socketcan::SocketCan`) on the real kernel CAN
//! stack: frames both ways between it and an independent `socketcan` socket, with ids, data and
//! RTR intact, and receive timestamps from the transport's clock; receive coalescing (bursts
//! held to the window or the deadline, frames stamped with the kernel's reception time).
//!
//! Ignored on the host; `tests/vcan/run-all` runs them in the QEMU guest with `--ignored`. Each
//! test uses ids of its own node-ID, so they may run in parallel on the shared bus.

use std::time::Duration as StdDuration;

use canola::socketcan::SocketCan;
use canola::{Received, RxCoalescing, Transport};
use canola_frame::{CanFrame, CanId, Duration};
use socketcan::{CanFilter, EmbeddedFrame, Id, Socket, StandardId};
use vcan_tests::{interface, open, open_filtered};

const WAIT: StdDuration = StdDuration::from_secs(10);

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(CanId::standard(id).expect("11-bit id"), data).expect("frame")
}

/// The next frame (not event) the transport receives within 10 s whose id is `id`.
fn next_frame_with_id(t: &mut SocketCan, id: u16) -> (CanFrame, canola_frame::Instant) {
    let deadline = t.now() + Duration::from_secs(10);
    loop {
        match t.recv_until(deadline).expect("recv") {
            Some(Received::Frame { frame, at }) if frame.id().as_standard() == Some(id) => {
                return (frame, at);
            }
            Some(_) => {}
            None => panic!("no frame 0x{id:03X} within 10 s"),
        }
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn transport_frames_reach_an_independent_socket() {
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    let peer = open_filtered(&[CanFilter::new(0x620, 0x7F0)]).expect("open the peer socket");

    let sent = [
        frame(0x621, &[0x2F, 0x00, 0x62, 0x01, 0x05, 0, 0, 0]),
        frame(0x622, &[]),
        CanFrame::remote(CanId::standard(0x623).expect("id"), 1).expect("remote"),
    ];
    for f in &sent {
        t.send(f).expect("send");
    }
    for want in &sent {
        let got = peer.read_frame_timeout(WAIT).expect("peer receives");
        let want_id =
            Id::Standard(StandardId::new(want.id().as_standard().expect("std")).expect("id"));
        assert_eq!(got.id(), want_id);
        assert_eq!(got.is_remote_frame(), want.is_remote());
        assert_eq!(got.dlc(), want.dlc());
        if !want.is_remote() {
            assert_eq!(got.data(), want.data());
        }
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn independent_frames_reach_the_transport_in_order() {
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    let peer = open().expect("open the peer socket");
    let mut last = None;
    for n in 0u8..20 {
        let f = socketcan::CanFrame::new(
            StandardId::new(0x5A6).expect("id"),
            &[0x43, 0x00, 0x10, 0x00, n, 0, 0, 0],
        )
        .expect("frame");
        peer.write_frame(&f).expect("peer sends");
        let (got, at) = next_frame_with_id(&mut t, 0x5A6);
        assert_eq!(got.data(), &[0x43, 0x00, 0x10, 0x00, n, 0, 0, 0]);
        if let Some(prev) = last {
            assert!(at >= prev, "receive timestamps go backwards");
        }
        assert!(at <= t.now());
        last = Some(at);
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn receive_deadline_passes_without_traffic() {
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    // Nothing on 0x7E7: a frame filter is not part of the transport, so wait for silence on our
    // own id by draining everything until the deadline.
    let start = t.now();
    let deadline = start + Duration::from_millis(200);
    while let Some(r) = t.recv_until(deadline).expect("recv") {
        if let Received::Frame { frame, .. } = r {
            assert_ne!(frame.id().as_standard(), Some(0x7E7));
        }
    }
    assert!(
        t.now() >= deadline,
        "recv_until returned None before its deadline"
    );
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn precise_waits_receive_in_order_and_end_at_the_deadline() {
    // The ppoll path of `recv_until` (`SocketCan::with_precise_waits`): frames that arrive
    // during a wait are returned in order, and an empty wait ends at its deadline, not before.
    let mut t = SocketCan::open(&interface())
        .expect("open the transport")
        .with_precise_waits(true);
    let peer = open().expect("open the peer socket");
    for n in 0u8..20 {
        let f = socketcan::CanFrame::new(StandardId::new(0x5A7).expect("id"), &[n]).expect("frame");
        peer.write_frame(&f).expect("peer sends");
        let (got, _) = next_frame_with_id(&mut t, 0x5A7);
        assert_eq!(got.data(), &[n]);
    }
    for wait_us in [300u64, 1_000, 2_500, 20_000] {
        let deadline = t.now() + Duration::from_micros(wait_us);
        while let Some(r) = t.recv_until(deadline).expect("recv") {
            if let Received::Frame { frame, .. } = r {
                assert_ne!(frame.id().as_standard(), Some(0x7E6));
            }
        }
        assert!(
            t.now() >= deadline,
            "recv_until returned None before its deadline ({wait_us} µs)"
        );
    }
}

/// Frames with id `id` and their stamps, received until `deadline`; with when the first
/// receive of the call returned.
fn frames_until(
    t: &mut SocketCan,
    id: u16,
    deadline: canola_frame::Instant,
) -> (
    Vec<(u8, canola_frame::Instant)>,
    Option<canola_frame::Instant>,
) {
    let (mut got, mut first_return) = (Vec::new(), None);
    while let Some(r) = t.recv_until(deadline).expect("recv") {
        // Only the test's own frames count: other tests of this binary run at the same time
        // on vcan0, and their frames, queued before a call, are handed over at once.
        if let Received::Frame { frame, at } = r
            && frame.id().as_standard() == Some(id)
        {
            first_return.get_or_insert_with(|| t.now());
            got.push((frame.data()[0], at));
        }
    }
    (got, first_return)
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn coalescing_stamps_frames_with_their_arrival() {
    // With receive coalescing on, frames are stamped with the kernel's reception time: five
    // frames sent 5 ms apart while nobody reads are read together, yet stamped 20 ms apart
    // (stamped when read, they would be within a fraction of a millisecond).
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    assert!(t.set_rx_coalescing(RxCoalescing::new(Duration::from_millis(5))));
    let peer = open().expect("open the peer socket");
    for n in 0u8..5 {
        let f = socketcan::CanFrame::new(StandardId::new(0x5A8).expect("id"), &[n]).expect("frame");
        peer.write_frame(&f).expect("peer sends");
        std::thread::sleep(StdDuration::from_millis(5));
    }
    let deadline = t.now() + Duration::from_millis(100);
    let (got, _) = frames_until(&mut t, 0x5A8, deadline);
    let data: Vec<u8> = got.iter().map(|(d, _)| *d).collect();
    assert_eq!(data, [0, 1, 2, 3, 4]);
    for w in got.windows(2) {
        assert!(w[1].1 >= w[0].1, "stamps go backwards: {got:?}");
    }
    let span = got[4].1.saturating_duration_since(got[0].1);
    assert!(
        span >= Duration::from_millis(15),
        "stamps {span:?} apart: {got:?}"
    );
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn coalescing_holds_a_burst_until_the_deadline_at_most() {
    // An endless window: a receive that saw a frame arrive while it waited hands it over at
    // its deadline, not before and (the test ends) not later; the frames come in order.
    let mut t = SocketCan::open(&interface()).expect("open the transport");
    assert!(t.set_rx_coalescing(RxCoalescing::new(Duration::MAX)));
    let peer = open().expect("open the peer socket");
    let deadline = t.now() + Duration::from_millis(300);
    let sender = std::thread::spawn(move || {
        std::thread::sleep(StdDuration::from_millis(50));
        for n in 0u8..3 {
            let f =
                socketcan::CanFrame::new(StandardId::new(0x5A9).expect("id"), &[n]).expect("frame");
            peer.write_frame(&f).expect("peer sends");
        }
    });
    let (got, first_return) = frames_until(&mut t, 0x5A9, deadline);
    sender.join().expect("sender");
    let data: Vec<u8> = got.iter().map(|(d, _)| *d).collect();
    assert_eq!(data, [0, 1, 2]);
    assert!(got.iter().all(|(_, at)| *at < deadline));
    assert!(
        first_return.is_some_and(|t| t >= deadline),
        "a burst was handed over before the deadline"
    );
}
