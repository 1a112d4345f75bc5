//! A consumer that stops reading: frames keep arriving on vcan0 while nobody reads the
//! master's socket, its receive queue fills and the kernel drops the rest. Every drop must be
//! counted and reported (`SO_RXQ_OVFL`, read from the ancillary data of each received frame):
//! - at the transport: the frames read plus the `BusEvent::RxOverflow` counts equal the frames
//!   sent, the sequence gaps equal the drops, and `SocketCanStats::rx_dropped` agrees; a larger
//!   receive buffer (`SocketCan::set_receive_buffer`) holds proportionally more frames;
//! - through `canola::Network` (no driver, nobody driving): after it is driven again its
//!   subscriber gets `NetworkEvent::Bus(RxOverflow)` whose counts equal the PDO counter gaps.
//!
//! The kernel attaches the drop counter to the next frame it queues, so each test sends one
//! last frame after draining the queue: its counter covers every drop of the flood.
//!
//! The tests flood the shared bus, so `tests/vcan/run-all` runs this binary with
//! `--test-threads=1`.

use std::time::Duration as StdDuration;

use canola::socketcan::SocketCan;
use canola::{BusEvent, Network, NetworkEvent, NodeId, Received, Transport};
use canola_frame::{CanFrame, Duration};
use socketcan::{EmbeddedFrame, Socket};
use vcan_tests::{interface, open};

/// Sends `count` frames on `id` carrying the counters `first..first + count` (u32, little
/// endian), retrying while the transmit queue is full.
fn flood(peer: &socketcan::CanSocket, id: u16, first: u32, count: u32) {
    let sid = socketcan::StandardId::new(id).expect("11-bit id");
    for c in first..first + count {
        let f = socketcan::CanFrame::new(sid, &c.to_le_bytes()).expect("frame");
        loop {
            match peer.write_frame(&f) {
                Ok(()) => break,
                // ENOBUFS: the queue towards the interface is full for a moment.
                Err(e) if e.raw_os_error() == Some(105) => {
                    std::thread::sleep(StdDuration::from_micros(200));
                }
                Err(e) => panic!("the peer's send failed: {e}"),
            }
        }
    }
}

fn counter(frame: &CanFrame) -> u32 {
    let b = frame.data();
    u32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

/// What draining a transport gave: frames on `id` with their counters, and the drops reported.
#[derive(Debug, Default)]
struct Drained {
    received: u64,
    gaps: u64,
    backwards: u64,
    dropped: u64,
    overflow_events: u64,
    last: u32,
}

impl Drained {
    fn frame(&mut self, c: u32) {
        if c <= self.last {
            self.backwards += 1;
        } else {
            self.gaps += u64::from(c - self.last - 1);
        }
        self.last = c;
    }
}

/// Floods `count` frames at a transport that does not read, then drains it, then sends a last
/// frame (counter `count + 1`) and reads up to it.
fn overflow_at_the_transport(t: &mut SocketCan, id: u16, count: u32) -> Drained {
    let peer = open().expect("open the peer socket");
    flood(&peer, id, 1, count);
    let mut d = Drained::default();
    let take = |r: Received, d: &mut Drained| -> bool {
        match r {
            Received::Frame { frame, .. } if frame.id().as_standard() == Some(id) => {
                let c = counter(&frame);
                d.frame(c);
                if c == count + 1 {
                    return true;
                }
                d.received += 1;
            }
            Received::Event(BusEvent::RxOverflow { dropped }) => {
                d.overflow_events += 1;
                d.dropped += dropped;
            }
            _ => {}
        }
        false
    };
    while let Some(r) = t.try_recv().expect("receive") {
        take(r, &mut d);
    }
    flood(&peer, id, count + 1, 1);
    let deadline = t.now() + Duration::from_secs(10);
    loop {
        match t.recv_until(deadline).expect("receive") {
            Some(r) => {
                if take(r, &mut d) {
                    break;
                }
            }
            None => panic!("the last frame did not arrive: {d:?}"),
        }
    }
    d
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn a_full_receive_queue_counts_every_drop_and_a_larger_buffer_holds_more() {
    const COUNT: u32 = 20_000;
    let mut t = SocketCan::open_default_buffer(&interface()).expect("open the transport");
    let stats = t.stats();
    let small = t.receive_buffer().expect("SO_RCVBUF");
    let d = overflow_at_the_transport(&mut t, 0x3A1, COUNT);
    eprintln!(
        "kernel default buffer ({small} bytes): {} of {COUNT} frames queued ({:.0} bytes each), \
         {} dropped in {} RxOverflow event(s)",
        d.received,
        small as f64 / d.received.max(1) as f64,
        d.dropped,
        d.overflow_events
    );
    assert!(
        d.dropped > 0,
        "{COUNT} frames did not overflow {small} bytes: {d:?}"
    );
    assert_eq!(
        d.received + d.dropped,
        u64::from(COUNT),
        "a silent loss: {d:?}"
    );
    assert_eq!(
        d.gaps, d.dropped,
        "the gaps are not the drops reported: {d:?}"
    );
    assert_eq!(d.backwards, 0, "frames out of order: {d:?}");
    assert_eq!(stats.rx_dropped(), d.dropped);
    assert!(stats.frames_received() > d.received);

    // The transport's default buffer: granted in full to root (SO_RCVBUFFORCE), holds more.
    let mut big_t = SocketCan::open(&interface()).expect("open the transport");
    let big = big_t.receive_buffer().expect("SO_RCVBUF");
    let b = overflow_at_the_transport(&mut big_t, 0x3A2, COUNT);
    eprintln!(
        "default of the transport ({} asked, {big} bytes reported): {} of {COUNT} frames \
         queued ({:.0} bytes each), {} dropped",
        canola::socketcan::DEFAULT_RECEIVE_BUFFER,
        b.received,
        big as f64 / b.received.max(1) as f64,
        b.dropped
    );
    assert_eq!(
        big,
        2 * canola::socketcan::DEFAULT_RECEIVE_BUFFER,
        "not granted in full"
    );
    assert_eq!(
        b.received + b.dropped,
        u64::from(COUNT),
        "a silent loss: {b:?}"
    );
    assert_eq!(b.gaps, b.dropped);
    // The queue's room is bytes; the frames it holds grow with it (the kernel charges each
    // frame the same true size).
    let ratio = b.received as f64 / d.received as f64;
    let expected = big as f64 / small as f64;
    assert!(
        (ratio - expected).abs() < 0.1 * expected,
        "{} frames in {big} bytes against {} in {small}",
        b.received,
        d.received
    );
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn a_network_nobody_drives_reports_the_overflow_and_it_equals_the_pdo_gaps() {
    const COUNT: u32 = 5_000;
    const NODE: u8 = 0x31;
    let t = SocketCan::open_default_buffer(&interface()).expect("open the transport");
    let stats = t.stats();
    let net = Network::new(t);
    net.add_node(NodeId::new(NODE).expect("node-ID"));
    let events = net.subscribe();
    let peer = open().expect("open the peer socket");
    let tpdo1 = 0x180 + u16::from(NODE);
    // Nobody drives the network (no driver, no waiting call): its socket is not read.
    flood(&peer, tpdo1, 1, COUNT);

    let mut d = Drained::default();
    let mut done = false;
    let take = |e: NetworkEvent, d: &mut Drained, done: &mut bool| match e {
        NetworkEvent::Pdo { node, data, .. } if node.get() == NODE => {
            let c = u32::from_le_bytes([data[0], data[1], data[2], data[3]]);
            d.frame(c);
            if c == COUNT + 1 {
                *done = true;
            } else {
                d.received += 1;
            }
        }
        NetworkEvent::Bus(BusEvent::RxOverflow { dropped }) => {
            d.overflow_events += 1;
            d.dropped += dropped;
        }
        _ => {}
    };
    // Driven again: it reads what the queue kept ...
    net.run_for(Duration::from_millis(500))
        .wait()
        .expect("drive");
    for e in events.try_iter() {
        take(e, &mut d, &mut done);
    }
    // ... and the next frame brings the drop count.
    flood(&peer, tpdo1, COUNT + 1, 1);
    for _ in 0..100 {
        if done {
            break;
        }
        net.run_for(Duration::from_millis(100))
            .wait()
            .expect("drive");
        for e in events.try_iter() {
            take(e, &mut d, &mut done);
        }
    }
    assert!(done, "the last PDO did not arrive: {d:?}");
    eprintln!(
        "network not driven while {COUNT} PDOs arrived: {} received, {} dropped in {} \
         RxOverflow event(s), counter gaps {}",
        d.received, d.dropped, d.overflow_events, d.gaps
    );
    assert!(d.dropped > 0, "no overflow: {d:?}");
    assert_eq!(
        d.received + d.dropped,
        u64::from(COUNT),
        "a silent loss: {d:?}"
    );
    assert_eq!(
        d.gaps, d.dropped,
        "the gaps are not the drops reported: {d:?}"
    );
    assert_eq!(d.backwards, 0);
    assert_eq!(stats.rx_dropped(), d.dropped);
}
