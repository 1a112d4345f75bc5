//! The in-memory bus against its contract: delivery, the clock modes, the timing model, faults
//! and bus events.

use std::collections::VecDeque;
use std::sync::Arc;

use canola_frame::{CanFrame, CanId, Duration, Instant};

use crate::transport::contract::{BusEvent, Received, Station, Transport, TransportError};

use super::bus::Endpoint;
use super::bus::MemoryBus;
use super::config::{BusConfig, ClockMode, Faults, fd_frame_bits, fd_frame_time, frame_time};
use super::*;
use crate::transport::contract::run_station;

fn sid(raw: u16) -> CanId {
    CanId::standard(raw).unwrap()
}

fn frame(raw: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(sid(raw), data).unwrap()
}

fn recv_frame(ep: &mut Endpoint, until: Instant) -> Option<(CanFrame, Instant)> {
    match ep.recv_until(until).unwrap()? {
        Received::Frame { frame, at } => Some((frame, at)),
        Received::Event(e) => panic!("unexpected event {e}"),
    }
}

#[test]
fn frame_lengths_follow_iso_11898() {
    let f8 = frame(0x123, &[0; 8]);
    assert_eq!(frame_bits(&f8, false), 111);
    assert_eq!(frame_bits(&f8, true), 135);
    assert_eq!(frame_bits(&frame(0x123, &[]), false), 47);
    let ext = CanFrame::new(CanId::extended(0x1234).unwrap(), &[0; 8]).unwrap();
    assert_eq!(frame_bits(&ext, false), 131);
    assert_eq!(frame_bits(&ext, true), 160);
    assert_eq!(
        frame_time(&f8, 1_000_000, false),
        Duration::from_micros(111)
    );
    assert_eq!(frame_time(&f8, 125_000, true), Duration::from_micros(1080));
    assert_eq!(frame_time(&f8, 800_000, false), Duration::from_micros(139));
}

#[test]
fn frames_reach_everyone_but_the_sender() {
    let bus = MemoryBus::new();
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    let mut c = bus.endpoint();
    a.send(&frame(0x181, &[1, 2])).unwrap();
    let t = Instant::from_millis(1);
    assert_eq!(recv_frame(&mut b, t).unwrap().0, frame(0x181, &[1, 2]));
    assert_eq!(recv_frame(&mut c, t).unwrap().0, frame(0x181, &[1, 2]));
    assert_eq!(recv_frame(&mut a, t), None);
    // Waiting on the virtual clock jumped to the deadline.
    assert_eq!(bus.now(), t);
}

#[test]
fn timing_model_and_arbitration() {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(500_000),
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    let mut rx = bus.endpoint();
    // Both queue at t=0: a's 0x701 was first, but b's 0x081 wins arbitration.
    a.send(&frame(0x701, &[0x05])).unwrap();
    b.send(&frame(0x081, &[0; 8])).unwrap();
    let far = Instant::from_millis(10);
    // The first frame to start is the one submitted when the wire was idle: 0x701 entered
    // arbitration alone at t=0, so it goes first; 0x081 then waits for the wire.
    let (f1, t1) = recv_frame(&mut rx, far).unwrap();
    assert_eq!(f1.cob_id(), Some(0x701));
    assert_eq!(t1, Instant::from_micros(2 * 55));
    let (f2, t2) = recv_frame(&mut rx, far).unwrap();
    assert_eq!(f2.cob_id(), Some(0x081));
    assert_eq!(t2, t1 + Duration::from_micros(2 * 111));

    // While the wire is busy, three frames queue; they go out by identifier.
    a.send(&frame(0x600, &[0; 8])).unwrap();
    a.send(&frame(0x300, &[1])).unwrap();
    b.send(&frame(0x200, &[2])).unwrap();
    b.send(&frame(0x100, &[3])).unwrap();
    let order: Vec<u16> = (0..4)
        .map(|_| {
            recv_frame(&mut rx, far + Duration::from_millis(10))
                .unwrap()
                .0
                .cob_id()
                .unwrap()
        })
        .collect();
    assert_eq!(order, [0x600, 0x100, 0x200, 0x300]);
    assert!(bus.stats().busy > Duration::ZERO);
}

#[test]
fn fault_injection_is_seeded_and_counted() {
    let run = |seed| {
        let bus = MemoryBus::with_config(BusConfig {
            faults: Faults {
                drop: 0.1,
                duplicate: 0.1,
                corrupt: 0.1,
                delay: 0.1,
                seed,
                ..Faults::none()
            },
            ..BusConfig::default()
        });
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        for i in 0..1000u16 {
            a.send(&frame(0x200, &i.to_le_bytes())).unwrap();
        }
        let mut got = Vec::new();
        while let Some((f, _)) = recv_frame(&mut b, Instant::from_millis(100)) {
            got.push(u16::from_le_bytes([f.data()[0], f.data()[1]]));
        }
        (got, bus.stats())
    };
    let (got, stats) = run(1);
    assert_eq!(run(1).0, got, "same seed, same outcome");
    assert_ne!(run(2).0, got);
    assert!(stats.dropped > 50 && stats.dropped < 150, "{stats:?}");
    assert!(
        stats.duplicated > 50 && stats.corrupted > 50 && stats.delayed > 50,
        "{stats:?}"
    );
    assert_eq!(got.len() as u64, 1000 - stats.dropped + stats.duplicated);
}

#[test]
fn a_full_transmit_queue_refuses_frames_until_the_wire_takes_some() {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(125_000),
        tx_queue_capacity: 3,
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    // The first frame goes onto the idle wire at once, three wait, the fifth is refused.
    let results: Vec<_> = (0..5u8).map(|i| a.send(&frame(0x200, &[i]))).collect();
    assert!(results[..4].iter().all(Result::is_ok), "{results:?}");
    assert!(matches!(results[4], Err(TransportError::TxQueueFull)));
    assert_eq!(bus.pending_frames(), 3);
    // One frame time (55 bits at 125 kbit/s = 440 us) later there is room for one more.
    let (f, _) = recv_frame(&mut b, Instant::from_micros(450)).unwrap();
    assert_eq!(f.data(), [0]);
    a.send(&frame(0x200, &[5])).unwrap();
    assert!(matches!(
        a.send(&frame(0x200, &[6])),
        Err(TransportError::TxQueueFull)
    ));
    // Nothing refused was delivered, nothing accepted was lost, the order kept.
    let mut got = vec![0];
    while let Some((f, _)) = recv_frame(&mut b, Instant::from_millis(10)) {
        got.push(f.data()[0]);
    }
    assert_eq!(got, [0, 1, 2, 3, 5]);
}

#[test]
fn overflow_is_reported_not_silent() {
    let bus = MemoryBus::with_config(BusConfig {
        queue_capacity: 2,
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    for i in 0..5u8 {
        a.send(&frame(0x200, &[i])).unwrap();
    }
    assert_eq!(
        b.try_recv().unwrap(),
        Some(Received::Event(BusEvent::RxOverflow { dropped: 3 }))
    );
    assert!(matches!(
        b.try_recv().unwrap(),
        Some(Received::Frame { .. })
    ));
    assert!(matches!(
        b.try_recv().unwrap(),
        Some(Received::Frame { .. })
    ));
    assert_eq!(b.try_recv().unwrap(), None);
    assert_eq!(bus.stats().overflowed, 3);
}

#[test]
fn frames_taken_over_by_a_send_keep_their_order_and_count_against_the_queue() {
    let bus = MemoryBus::with_config(BusConfig {
        queue_capacity: 2,
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    let data = |r: Option<Received>| match r {
        Some(Received::Frame { frame, .. }) => frame.data()[0],
        other => panic!("expected a frame, got {other:?}"),
    };
    a.send(&frame(0x200, &[1])).unwrap();
    // b's send takes frame 1 over into b's inbox; it still fills a place in b's queue.
    b.send(&frame(0x300, &[0])).unwrap();
    assert!(b.has_pending());
    a.send(&frame(0x200, &[2])).unwrap();
    a.send(&frame(0x200, &[3])).unwrap();
    assert_eq!(bus.stats().overflowed, 1, "capacity 2: frame 3 is lost");
    assert_eq!(data(b.try_recv().unwrap()), 1);
    // Received from the inbox without the bus's lock; the bus learns of it at b's next
    // call, which reports the loss first (as a receive queue always does), then frame 2.
    assert_eq!(
        b.try_recv().unwrap(),
        Some(Received::Event(BusEvent::RxOverflow { dropped: 1 }))
    );
    assert_eq!(data(b.try_recv().unwrap()), 2);
    a.send(&frame(0x200, &[4])).unwrap();
    a.send(&frame(0x200, &[5])).unwrap();
    assert_eq!(bus.stats().overflowed, 1, "both places are free again");
    assert_eq!(data(b.try_recv().unwrap()), 4);
    assert_eq!(data(b.try_recv().unwrap()), 5);
    assert_eq!(b.try_recv().unwrap(), None);
}

#[test]
fn interface_down_fails_sends_and_is_reported() {
    let bus = MemoryBus::new();
    let mut a = bus.endpoint();
    bus.inject_event(BusEvent::BusOff);
    bus.inject_event(BusEvent::InterfaceDown);
    assert!(matches!(
        a.send(&frame(1, &[])),
        Err(TransportError::InterfaceDown)
    ));
    assert_eq!(
        a.try_recv().unwrap(),
        Some(Received::Event(BusEvent::BusOff))
    );
    assert_eq!(
        a.try_recv().unwrap(),
        Some(Received::Event(BusEvent::InterfaceDown))
    );
    bus.inject_event(BusEvent::InterfaceUp);
    a.send(&frame(1, &[])).unwrap();
}

/// Answers every frame on 0x600 with 0x580 and sends a "heartbeat" every 100 ms.
#[derive(Default)]
struct Echo {
    out: VecDeque<CanFrame>,
    next_beat: Option<Instant>,
    seen: usize,
}

impl Station for Echo {
    fn handle_frame(&mut self, _now: Instant, f: &CanFrame) {
        self.seen += 1;
        if f.cob_id() == Some(0x600) {
            self.out
                .push_back(CanFrame::new(sid(0x580), f.data()).unwrap());
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        let due = self.next_beat.is_none_or(|t| t <= now);
        if due {
            self.out.push_back(frame(0x700, &[0x05]));
            self.next_beat = Some(now + Duration::from_millis(100));
        }
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        Some(self.next_beat.unwrap_or(Instant::ZERO))
    }
}

#[test]
fn attached_stations_run_on_virtual_time() {
    let bus = MemoryBus::new();
    let mut master = bus.endpoint();
    let id = bus.attach(Echo::default());
    master.send(&frame(0x600, &[0x40])).unwrap();
    let mut beats = Vec::new();
    let mut echoed = false;
    while let Some((f, at)) = recv_frame(&mut master, Instant::from_millis(350)) {
        match f.cob_id() {
            Some(0x700) => beats.push(at.as_micros() / 1000),
            Some(0x580) => echoed = true,
            other => panic!("{other:?}"),
        }
    }
    assert!(echoed);
    assert_eq!(beats, [0, 100, 200, 300]);
    assert_eq!(bus.with_station(id, |e| e.seen), Some(1));
    let echo = bus.detach(id).unwrap();
    assert_eq!(echo.seen, 1);
    bus.run_for(Duration::from_secs(1));
    assert_eq!(
        master.try_recv().unwrap(),
        None,
        "detached station is silent"
    );
}

#[test]
fn real_time_mode_with_a_station_on_its_own_endpoint() {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let mut master = bus.endpoint();
    let mut dev_ep = bus.endpoint();
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop2 = stop.clone();
    let h = std::thread::spawn(move || {
        let mut echo = Echo::default();
        run_station(&mut dev_ep, &mut echo, || {
            stop2.load(std::sync::atomic::Ordering::Relaxed)
        })
        .unwrap();
    });
    master.send(&frame(0x600, &[0x40, 1])).unwrap();
    let deadline = master.now() + Duration::from_secs(5);
    let mut echoed = false;
    while let Some(r) = master.recv_until(deadline).unwrap() {
        if let Received::Frame { frame, .. } = r
            && frame.cob_id() == Some(0x580)
        {
            echoed = true;
            break;
        }
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    h.join().unwrap();
    assert!(echoed);
}

#[test]
fn send_at_stamps_with_the_callers_reading_but_never_before_the_bus() {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let (mut a, mut b, mut c) = (bus.endpoint(), bus.endpoint(), bus.endpoint());
    let stamp = |c: &mut Endpoint| recv_frame(c, c.now() + Duration::from_secs(1)).unwrap().1;
    // A fresh reading is the stamp: the bus does not read its clock again.
    let t1 = a.now();
    a.send_at(&frame(0x181, &[1]), t1).unwrap();
    assert_eq!(stamp(&mut c), t1);
    // A reading older than what the bus has processed since is not.
    std::thread::sleep(std::time::Duration::from_millis(2));
    b.send(&frame(0x182, &[2])).unwrap();
    let t2 = stamp(&mut c);
    assert!(t2 > t1 + Duration::from_millis(1), "{t2:?} after {t1:?}");
    a.send_at(&frame(0x183, &[3]), t1).unwrap();
    assert_eq!(stamp(&mut c), t2);
}

fn fd(raw: u16, data: &[u8]) -> canola_frame::FdFrame {
    canola_frame::FdFrame::new(sid(raw), data).unwrap()
}

#[test]
fn fd_frame_lengths_follow_iso_11898_by_phase() {
    // 11-bit identifier, 64 bytes: 17 + 13 nominal bits; ESI, DLC, 512 data bits, stuff count
    // and CRC-21 with its 7 fixed stuff bits in the data phase.
    assert_eq!(fd_frame_bits(&fd(0x123, &[0; 64]), false), (30, 549));
    assert_eq!(fd_frame_bits(&fd(0x123, &[0; 64]), true), (34, 678));
    // Up to 16 bytes: CRC-17 with 6 fixed stuff bits.
    assert_eq!(fd_frame_bits(&fd(0x123, &[0; 8]), false), (30, 96));
    assert_eq!(fd_frame_bits(&fd(0x123, &[0; 16]), false), (30, 160));
    assert_eq!(fd_frame_bits(&fd(0x123, &[0; 20]), false), (30, 197));
    let ext = canola_frame::FdFrame::new(CanId::extended(0x1234).unwrap(), &[]).unwrap();
    assert_eq!(fd_frame_bits(&ext, false), (49, 32));
    // 1 Mbit/s arbitration, 5 Mbit/s data with BRS: 30 µs + 109.8 µs.
    let f = fd(0x123, &[0; 64]).with_brs(true);
    assert_eq!(
        fd_frame_time(&f, 1_000_000, Some(5_000_000), false),
        Duration::from_micros(140)
    );
    assert_eq!(
        fd_frame_time(&f, 1_000_000, Some(2_000_000), false),
        Duration::from_micros(305)
    );
    // Without BRS the data phase runs at the arbitration rate.
    assert_eq!(
        fd_frame_time(&f.with_brs(false), 1_000_000, Some(5_000_000), false),
        Duration::from_micros(579)
    );
    assert_eq!(
        fd_frame_time(&f, 1_000_000, None, false),
        Duration::from_micros(579)
    );
}

/// A station that answers every FD frame with an FD frame on the next identifier.
struct FdEcho(VecDeque<canola_frame::FdFrame>);

impl Station for FdEcho {
    fn handle_frame(&mut self, _now: Instant, _frame: &CanFrame) {}
    fn handle_timeout(&mut self, _now: Instant) {}
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        None
    }
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
    fn handle_fd_frame(&mut self, _now: Instant, frame: &canola_frame::FdFrame) {
        let id = frame.cob_id().unwrap() + 1;
        self.0.push_back(fd(id, frame.data()).with_brs(true));
    }
    fn poll_transmit_fd(&mut self) -> Option<canola_frame::FdFrame> {
        self.0.pop_front()
    }
}

#[test]
fn fd_frames_cross_the_bus_in_their_time_and_arbitrate() {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        data_bitrate: Some(5_000_000),
        fd: true,
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    assert!(a.fd_support().is_ok());
    bus.attach(FdEcho(VecDeque::new()));
    let f = fd(0x200, &[7; 64]).with_brs(true);
    a.send_fd(&f).unwrap();
    let until = Instant::from_millis(1);
    // b hears it after its 140 µs on the wire, then the echo (another 140 µs).
    match b.recv_until(until).unwrap() {
        Some(Received::Event(BusEvent::FdFrame { frame, at })) => {
            assert_eq!(*frame, f);
            assert_eq!(at, Instant::from_micros(140));
        }
        other => panic!("{other:?}"),
    }
    match b.recv_until(until).unwrap() {
        Some(Received::Event(BusEvent::FdFrame { frame, at })) => {
            assert_eq!(frame.id(), sid(0x201));
            assert_eq!(at, Instant::from_micros(280));
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        a.recv_until(until).unwrap(),
        Some(Received::Event(BusEvent::FdFrame { .. }))
    ));
}

#[test]
fn fd_frames_arbitrate_as_data_frames_with_their_identifier() {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        data_bitrate: Some(2_000_000),
        fd: true,
        ..BusConfig::default()
    });
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    // While a frame is on the wire, a classic frame on 0x300 and then an FD frame on 0x100
    // wait: the FD frame (lower identifier) wins the next arbitration.
    a.send(&frame(0x400, &[0; 8])).unwrap();
    a.send(&frame(0x300, &[1])).unwrap();
    a.send_fd(&fd(0x100, &[2; 8])).unwrap();
    let until = Instant::from_millis(1);
    let mut order = Vec::new();
    while let Some(r) = b.recv_until(until).unwrap() {
        order.push(match r {
            Received::Frame { frame, at } => (frame.cob_id().unwrap(), at),
            Received::Event(BusEvent::FdFrame { frame, at }) => (frame.cob_id().unwrap(), at),
            Received::Event(e) => panic!("{e}"),
        });
    }
    // 0x400: 111 µs; the FD frame without BRS, 30 + 96 bits at 1 Mbit/s: 126 µs; then 0x300.
    assert_eq!(
        order,
        [
            (0x400, Instant::from_micros(111)),
            (0x100, Instant::from_micros(237)),
            (0x300, Instant::from_micros(292)),
        ]
    );
}

#[test]
fn a_classic_bus_refuses_fd_frames_by_name() {
    let bus = MemoryBus::new();
    let mut a = bus.endpoint();
    let mut b = bus.endpoint();
    bus.attach(FdEcho(VecDeque::new()));
    let e = a.send_fd(&fd(0x200, &[1; 12])).unwrap_err();
    assert!(matches!(e, TransportError::FdNotSupported { .. }));
    assert_eq!(
        e.to_string(),
        "FD not supported on the in-memory bus (configured for classic CAN: BusConfig::fd)"
    );
    assert!(a.fd_support().is_err());
    assert_eq!(b.recv_until(Instant::from_millis(1)).unwrap(), None);
    assert_eq!(bus.stats().frames, 0);
}

#[test]
fn the_waker_ends_a_real_time_wait_and_a_virtual_bus_has_none() {
    assert!(MemoryBus::new().endpoint().waker().is_none());
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let mut ep = bus.endpoint();
    let waker = ep.waker().expect("a real-time bus has a waker");
    // A wake while nobody waits ends the next wait at once, once.
    waker.wake();
    let far = ep.now() + Duration::from_secs(10);
    assert_eq!(ep.recv_until(far).unwrap(), None);
    assert!(ep.now() < far);
    let near = ep.now() + Duration::from_millis(2);
    assert_eq!(ep.recv_until(near).unwrap(), None);
    assert!(ep.now() >= near);
    // A wait blocked in this thread, woken from another.
    let waking = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(20));
        waker.wake();
    });
    let far = ep.now() + Duration::from_secs(10);
    assert_eq!(ep.recv_until(far).unwrap(), None);
    assert!(ep.now() < far);
    waking.join().unwrap();
}
