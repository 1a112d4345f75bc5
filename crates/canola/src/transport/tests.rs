//! Stations run on the in-memory bus against the contract of [`run_station`].

use std::collections::VecDeque;

use canola_frame::CanId;

use canola_frame::{CanFrame, Duration, Instant};

use super::contract::{Received, Station, Transport, run_station};
use super::mem::MemoryBus;

fn frame(raw: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(CanId::standard(raw).unwrap(), data).unwrap()
}

/// A timer every 100 ms from 100 ms on; answers 0x600 with 0x580. Records its calls.
struct Recorder {
    next: Instant,
    timeouts: Vec<u64>,
    frames: Vec<u64>,
    out: VecDeque<CanFrame>,
}

impl Station for Recorder {
    fn handle_frame(&mut self, now: Instant, f: &CanFrame) {
        self.frames.push(now.as_micros() / 1000);
        if f.cob_id() == Some(0x600) {
            self.out.push_back(frame(0x580, f.data()));
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.timeouts.push(now.as_micros() / 1000);
        if now >= self.next {
            self.next += Duration::from_millis(100);
        }
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        Some(self.next)
    }
}

#[test]
fn run_station_fires_timers_when_due_and_answers_frames() {
    let bus = MemoryBus::new();
    let mut master = bus.endpoint();
    let mut dev = bus.endpoint();
    for n in 0..3 {
        master.send(&frame(0x600, &[n])).unwrap();
    }
    let mut station = Recorder {
        next: Instant::from_millis(100),
        timeouts: Vec::new(),
        frames: Vec::new(),
        out: VecDeque::new(),
    };
    let clock = bus.clone();
    run_station(&mut dev, &mut station, || {
        clock.now() >= Instant::from_millis(450)
    })
    .unwrap();
    // Timers only when due (not once per received frame or per 50 ms wait), on time.
    assert_eq!(station.timeouts, [100, 200, 300, 400]);
    assert_eq!(station.frames, [0, 0, 0]);
    let mut answers = Vec::new();
    while let Some(Received::Frame { frame, .. }) = master.try_recv().unwrap() {
        assert_eq!(frame.cob_id(), Some(0x580));
        answers.push(frame.data()[0]);
    }
    assert_eq!(answers, [0, 1, 2]);
}
