//! How often a network on a real clock reads it: a short driving step (one frame handled)
//! passes its reading on to the next few steps, and the timers still fire within a few steps of
//! falling due. The transport here is a scripted SDO server on a clock only the test moves, so
//! every reading and every frame is counted.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use canola::transport::{Received, Transport, TransportError};
use canola::{CanFrame, CanId, Duration, Instant, Network, NodeId};

/// What the test sees of the transport.
#[derive(Default)]
struct Shared {
    /// The clock, in microseconds: moved by the test only.
    now: AtomicU64,
    /// Clock readings taken by the network.
    readings: AtomicU64,
    /// Frames the network sent, in order.
    sent: Mutex<Vec<CanFrame>>,
}

/// A real-clock transport (not virtual: a reading is not free) whose node 5 answers every
/// expedited upload request at once with four bytes, stamped with the time the request was
/// sent at (as the in-memory bus stamps it).
struct Scripted {
    shared: Arc<Shared>,
    queue: VecDeque<(CanFrame, Instant)>,
}

impl Transport for Scripted {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let now = self.now();
        self.send_at(frame, now)
    }

    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        self.shared.sent.lock().unwrap().push(*frame);
        if frame.cob_id() == Some(0x605) && frame.data().first() == Some(&0x40) {
            let d = frame.data();
            let answer = [0x43, d[1], d[2], d[3], 0x39, 0, 0, 0];
            let id = CanId::standard(0x585).unwrap();
            self.queue
                .push_back((CanFrame::new(id, &answer).unwrap(), now));
        }
        Ok(())
    }

    fn recv_until(&mut self, _deadline: Instant) -> Result<Option<Received>, TransportError> {
        Ok(self
            .queue
            .pop_front()
            .map(|(frame, at)| Received::Frame { frame, at }))
    }

    fn now(&self) -> Instant {
        self.shared.readings.fetch_add(1, Ordering::SeqCst);
        Instant::from_micros(self.shared.now.load(Ordering::SeqCst))
    }
}

fn network() -> (Network, Arc<Shared>) {
    let shared = Arc::new(Shared::default());
    let net = Network::new(Scripted {
        shared: shared.clone(),
        queue: VecDeque::new(),
    });
    net.set_transfer_gap(Duration::ZERO);
    (net, shared)
}

fn syncs(shared: &Shared) -> usize {
    let sent = shared.sent.lock().unwrap();
    sent.iter().filter(|f| f.cob_id() == Some(0x080)).count()
}

#[test]
fn short_steps_pass_their_clock_reading_on() {
    let (net, shared) = network();
    let node = net.node(NodeId::new(5).unwrap());
    let before = shared.readings.load(Ordering::SeqCst);
    for _ in 0..40 {
        assert_eq!(
            node.sdo().read((0x1018, 1)).wait().unwrap(),
            [0x39, 0, 0, 0]
        );
    }
    let readings = shared.readings.load(Ordering::SeqCst) - before;
    // One step per read; a fresh reading every eighth step (seven reused in a row).
    assert!(readings <= 7, "{readings} clock readings for 40 reads");
    assert!(readings >= 4, "{readings} clock readings for 40 reads");
}

#[test]
fn a_timer_falling_due_between_short_steps_fires_within_a_few_of_them() {
    let (net, shared) = network();
    let node = net.node(NodeId::new(5).unwrap());
    net.start_sync(Duration::from_millis(1));
    // Steps at 0 ms: whatever SYNC is due at the start goes out.
    for _ in 0..8 {
        node.sdo().read((0x1018, 1)).wait().unwrap();
    }
    let at_start = syncs(&shared);
    // The next SYNC falls due; the reads go on, each a short step.
    shared.now.store(1_500, Ordering::SeqCst);
    let mut steps = 0;
    while syncs(&shared) == at_start {
        node.sdo().read((0x1018, 1)).wait().unwrap();
        steps += 1;
        assert!(
            steps <= 8,
            "the SYNC due at 1 ms not sent after {steps} steps"
        );
    }
    assert_eq!(syncs(&shared), at_start + 1);
}
