//! A subscriber for received PDOs that takes them in batches: [`Network::subscribe_pdos`](crate::Network::subscribe_pdos).
//!
//! [`Network::subscribe`](crate::Network::subscribe) hands out one [`NetworkEvent`](crate::NetworkEvent) per frame through
//! a channel, each event owning its decoded values; at full bus load that allocation and the
//! channel's per-message work cost more than decoding the frame. A [`PdoSubscriber`] instead
//! takes everything received since its last call in one [`PdoBatch`], read as the same borrowed
//! [`PdoReceived`] views an [`on_pdo`](crate::Network::on_pdo) callback gets, but on the
//! application's own thread.
//!
//! Three buffers rotate between the network and the subscriber (the network's pending one, the
//! shared one, the subscriber's own), each keeping its capacity: once they have grown to a
//! batch's size, receiving allocates nothing. The network fills its pending buffer without a
//! lock and hands it over once per driving step (one lock). Under a background driver, it wakes
//! a waiting subscriber when a burst of frames has been handled (the transport holds no more),
//! when [`WAKE_AT`] PDOs wait, or when the driver stops: waking a sleeping thread costs more CPU
//! than decoding a few dozen frames, so in a burst the subscriber wakes once per hundreds of
//! PDOs, not once per step. Any other driving step (a stepping thread, a waiting call) wakes it
//! at its end, as nothing says another step follows.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{RecvError, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

use canola_frame::{Instant, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary, Value};

use crate::machine::events::{PdoData, PdoReceived};

/// How many PDOs may wait in the shared batch, while more frames are already waiting in the
/// transport, before a sleeping subscriber is woken anyway. Frames wait in the transport only
/// when the master is behind the bus (a step takes at most 32 of them); then waking the
/// subscriber for every step would cost a system call per step on both sides while neither
/// gains anything (the bench README has the counts). 1024 PDOs are 20 ms of data at 1 Mbit/s
/// full load, so a subscriber still hears of them promptly.
const WAKE_AT: usize = 1024;

/// One PDO of a batch; its values are `values[previous values_end..values_end]`.
#[derive(Debug, Clone)]
struct Record {
    node: NodeId,
    number: u8,
    data: PdoData,
    at: Instant,
    values_end: u32,
    /// The producer's dictionary (shared, not copied), for values by name.
    od: Option<Arc<ObjectDictionary>>,
}

/// The PDOs received since the subscriber's previous batch, in reception order.
///
/// ```
/// use canola::{MemoryBus, Network, NodeId, SimDevice};
/// use std::time::Duration;
///
/// let eds = include_bytes!("../../../eds/burkert-generic.eds");
/// let id = NodeId::new(5).unwrap();
/// let bus = MemoryBus::new();
/// let net = Network::new(bus.endpoint());
/// let node = net.add_node_with_dictionary(id, canola::od::parse(&eds[..]).unwrap().od);
/// bus.attach(SimDevice::from_eds(id, &eds[..]).unwrap());
/// let mut pdos = net.subscribe_pdos();
/// node.nmt().start().unwrap(); // the device sends its TPDOs when it starts
/// net.run_for(Duration::from_millis(10)).wait().unwrap();
/// for p in pdos.try_recv().unwrap() {
///     println!("node {} TPDO{}: {:?}", p.node, p.number, p.values);
/// }
/// ```
#[derive(Debug, Default)]
pub struct PdoBatch {
    records: Vec<Record>,
    values: Vec<(ObjectAddress, Value)>,
}

impl PdoBatch {
    /// How many PDOs the batch holds.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether the batch holds no PDO.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// The PDOs in reception order, as an [`on_pdo`](crate::Network::on_pdo) callback sees them.
    pub fn iter(&self) -> PdoBatchIter<'_> {
        PdoBatchIter {
            batch: self,
            next: 0,
            values_start: 0,
        }
    }

    fn push_record(
        &mut self,
        node: NodeId,
        number: u8,
        data: PdoData,
        at: Instant,
        od: Option<&Arc<ObjectDictionary>>,
    ) {
        self.records.push(Record {
            node,
            number,
            data,
            at,
            od: od.cloned(),
            // A batch holds what a few driving steps receive; u32 is far from full.
            values_end: u32::try_from(self.values.len()).unwrap_or(u32::MAX),
        });
    }

    fn clear(&mut self) {
        self.records.clear();
        self.values.clear();
    }

    /// Moves `other`'s PDOs behind this batch's, leaving `other` empty.
    fn append(&mut self, other: &mut PdoBatch) {
        let offset = u32::try_from(self.values.len()).unwrap_or(u32::MAX);
        self.values.append(&mut other.values);
        self.records.extend(other.records.drain(..).map(|r| Record {
            values_end: r.values_end.saturating_add(offset),
            ..r
        }));
    }
}

impl<'a> IntoIterator for &'a PdoBatch {
    type Item = PdoReceived<'a>;
    type IntoIter = PdoBatchIter<'a>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// The PDOs of a [`PdoBatch`], oldest first.
#[derive(Debug, Clone)]
pub struct PdoBatchIter<'a> {
    batch: &'a PdoBatch,
    next: usize,
    values_start: usize,
}

impl<'a> Iterator for PdoBatchIter<'a> {
    type Item = PdoReceived<'a>;

    fn next(&mut self) -> Option<PdoReceived<'a>> {
        let batch: &'a PdoBatch = self.batch;
        let r = batch.records.get(self.next)?;
        self.next += 1;
        let end = r.values_end as usize;
        let values = batch.values.get(self.values_start..end).unwrap_or_default();
        self.values_start = end;
        Some(PdoReceived {
            node: r.node,
            number: r.number,
            data: &r.data,
            values,
            at: r.at,
            dictionary: r.od.as_deref(),
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.batch.records.len() - self.next;
        (n, Some(n))
    }
}

impl ExactSizeIterator for PdoBatchIter<'_> {}

/// What the network and a subscriber share.
#[derive(Debug, Default)]
struct Shared {
    batch: PdoBatch,
    /// The network is gone: nothing more will come.
    closed: bool,
}

#[derive(Debug, Default)]
struct Queue {
    shared: Mutex<Shared>,
    ready: Condvar,
    /// Subscribers blocked in `ready` (the network wakes them only then).
    waiting: AtomicUsize,
    #[cfg(feature = "tokio")]
    notify: tokio::sync::Notify,
}

impl Queue {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        // The lock guards plain buffers: a panic while it was held leaves them usable.
        self.shared.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The network's end of one subscriber: the PDOs of the current step, not yet handed over.
#[derive(Debug)]
pub(crate) struct PdoPublisher {
    queue: Arc<Queue>,
    pending: PdoBatch,
}

impl PdoPublisher {
    /// A received PDO, its values copied.
    pub(crate) fn push(
        &mut self,
        node: NodeId,
        number: u8,
        data: PdoData,
        at: Instant,
        od: Option<&Arc<ObjectDictionary>>,
        values: &[(ObjectAddress, Value)],
    ) {
        self.pending.values.extend_from_slice(values);
        self.pending.push_record(node, number, data, at, od);
    }

    /// A received PDO, its values moved out of `values` (left empty, with its capacity).
    pub(crate) fn push_moving(
        &mut self,
        node: NodeId,
        number: u8,
        data: PdoData,
        at: Instant,
        od: Option<&Arc<ObjectDictionary>>,
        values: &mut Vec<(ObjectAddress, Value)>,
    ) {
        self.pending.values.append(values);
        self.pending.push_record(node, number, data, at, od);
    }

    /// Hands the pending PDOs to the subscriber; `false` when the subscriber is gone. `more`:
    /// the transport holds more frames already and a background driver steps again at once,
    /// so a waiting subscriber is woken only once [`WAKE_AT`] PDOs wait for it (the driver
    /// wakes it when it stops, see [`wake`](Self::wake)).
    pub(crate) fn flush(&mut self, more: bool) -> bool {
        if Arc::strong_count(&self.queue) == 1 {
            return false;
        }
        if self.pending.is_empty() {
            return true;
        }
        let waiting = {
            let mut shared = self.queue.lock();
            if shared.batch.is_empty() {
                // The subscriber took the last batch: hand this one over whole and keep the
                // (empty, already grown) buffer it leaves.
                core::mem::swap(&mut shared.batch, &mut self.pending);
                self.pending.clear();
            } else {
                shared.batch.append(&mut self.pending);
            }
            shared.batch.len()
        };
        if !more || waiting >= WAKE_AT {
            self.wake();
        }
        true
    }

    /// Wakes the subscriber if it waits (blocked in `recv().wait()`, or awaiting `recv()`).
    pub(crate) fn wake(&self) {
        if self.queue.waiting.load(Ordering::SeqCst) > 0 {
            self.queue.ready.notify_all();
        }
        #[cfg(feature = "tokio")]
        self.queue.notify.notify_one();
    }
}

impl Drop for PdoPublisher {
    fn drop(&mut self) {
        self.flush(false);
        self.queue.lock().closed = true;
        self.queue.ready.notify_all();
        #[cfg(feature = "tokio")]
        self.queue.notify.notify_one();
    }
}

/// Receives the PDOs of a [`Network`](crate::Network) in batches (see
/// [`Network::subscribe_pdos`](crate::Network::subscribe_pdos)): every PDO received from a
/// node after the subscription, decoded through the node's dictionary where the master can
/// (values empty otherwise, as for [`on_pdo`](crate::Network::on_pdo)). Nothing is dropped:
/// PDOs wait for the subscriber however long it takes, so a subscriber that stops reading
/// should be dropped. The `recv` calls block the calling thread, so on a network driven by
/// the same thread (no driver) use [`try_recv`](Self::try_recv) between steps.
#[derive(Debug)]
pub struct PdoSubscriber {
    queue: Arc<Queue>,
    mine: PdoBatch,
}

/// The two ends of a new subscription.
pub(crate) fn pdo_subscription() -> (PdoPublisher, PdoSubscriber) {
    let queue = Arc::new(Queue::default());
    (
        PdoPublisher {
            queue: queue.clone(),
            pending: PdoBatch::default(),
        },
        PdoSubscriber {
            queue,
            mine: PdoBatch::default(),
        },
    )
}

/// Takes the shared batch into `mine` (whose PDOs the caller has read) if it holds PDOs.
fn take(shared: &mut Shared, mine: &mut PdoBatch) -> bool {
    if shared.batch.is_empty() {
        return false;
    }
    mine.clear();
    core::mem::swap(&mut shared.batch, mine);
    true
}

impl PdoSubscriber {
    /// The PDOs received since the last batch, without waiting: `Empty` when there are none
    /// yet, `Disconnected` when none will come (the network is gone).
    pub fn try_recv(&mut self) -> Result<&PdoBatch, TryRecvError> {
        let Self { queue, mine } = self;
        let mut shared = queue.lock();
        if take(&mut shared, mine) {
            return Ok(mine);
        }
        Err(if shared.closed {
            TryRecvError::Disconnected
        } else {
            TryRecvError::Empty
        })
    }

    /// Waits for PDOs: `.wait()` blocks the thread, `.await` (`tokio` feature) waits without
    /// blocking the runtime. An error only when none will come (the network is gone).
    pub fn recv(&mut self) -> Recv<'_> {
        Recv { subscriber: self }
    }

    /// Waits up to `timeout` for PDOs.
    pub fn recv_timeout(
        &mut self,
        timeout: impl Into<crate::Duration>,
    ) -> Result<&PdoBatch, RecvTimeoutError> {
        let timeout = std::time::Duration::from(timeout.into());
        let end = std::time::Instant::now() + timeout;
        let Self { queue, mine } = self;
        let mut shared = queue.lock();
        loop {
            if take(&mut shared, mine) {
                return Ok(mine);
            }
            if shared.closed {
                return Err(RecvTimeoutError::Disconnected);
            }
            let left = end.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return Err(RecvTimeoutError::Timeout);
            }
            queue.waiting.fetch_add(1, Ordering::SeqCst);
            shared = queue
                .ready
                .wait_timeout(shared, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
            queue.waiting.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// A wait for the next batch of a [`PdoSubscriber`] ([`PdoSubscriber::recv`]): finished by
/// [`wait`](Self::wait) or by `.await`.
#[must_use = "a receive does nothing until it is waited on or awaited"]
#[derive(Debug)]
pub struct Recv<'a> {
    subscriber: &'a mut PdoSubscriber,
}

impl<'a> Recv<'a> {
    /// Blocks the thread until PDOs come.
    pub fn wait(self) -> Result<&'a PdoBatch, RecvError> {
        let subscriber = self.subscriber;
        loop {
            match subscriber.recv_timeout(std::time::Duration::from_secs(3600)) {
                Ok(_) => break,
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Err(RecvError),
            }
        }
        Ok(&subscriber.mine)
    }
}

#[cfg(feature = "tokio")]
impl<'a> std::future::IntoFuture for Recv<'a> {
    type Output = Result<&'a PdoBatch, RecvError>;
    type IntoFuture = std::pin::Pin<Box<dyn Future<Output = Self::Output> + Send + 'a>>;

    fn into_future(self) -> Self::IntoFuture {
        let PdoSubscriber { queue, mine } = self.subscriber;
        Box::pin(async move {
            loop {
                {
                    let mut shared = queue.lock();
                    if take(&mut shared, mine) {
                        break;
                    }
                    if shared.closed {
                        return Err(RecvError);
                    }
                }
                // A hand-over between the look above and this wait leaves a permit: no
                // wake-up is lost.
                queue.notify.notified().await;
            }
            Ok(&*mine)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn push(p: &mut PdoPublisher, k: u32) {
        let node = NodeId::new(5).expect("node-ID");
        let data = PdoData::new(&k.to_le_bytes());
        let values = [(ObjectAddress::new(0x2000, 1), Value::Unsigned32(k))];
        p.push(node, 1, data, Instant::ZERO, None, &values);
    }

    fn counters(batch: &PdoBatch) -> Vec<u32> {
        batch
            .iter()
            .map(|p| match p.values {
                [(_, Value::Unsigned32(k))] => *k,
                other => panic!("unexpected values {other:?}"),
            })
            .collect()
    }

    /// A step that leaves frames in the transport still hands its PDOs over (a polling
    /// subscriber sees them at once); only the wake-up waits.
    #[test]
    fn a_flush_in_a_burst_hands_the_pdos_over() {
        let (mut p, mut s) = pdo_subscription();
        push(&mut p, 1);
        assert!(p.flush(true));
        push(&mut p, 2);
        assert!(p.flush(true));
        assert_eq!(counters(s.try_recv().expect("a batch")), [1, 2]);
        assert_eq!(s.try_recv().unwrap_err(), TryRecvError::Empty);
    }

    /// A subscriber blocked in `recv_timeout` wakes at the end of a burst, and within a burst
    /// once `WAKE_AT` PDOs wait; every PDO arrives, in order.
    #[test]
    fn a_blocked_subscriber_wakes_at_the_end_of_a_burst_or_a_full_batch() {
        for (count, end_of_burst) in [(10, true), (WAKE_AT as u32, false)] {
            let (mut p, mut s) = pdo_subscription();
            let queue = p.queue.clone();
            // `recv` waits an hour per try: a missed wake-up shows as the reader not done.
            let (done, result) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let mut got = Vec::new();
                while got.len() < count as usize {
                    got.extend(counters(s.recv().wait().expect("not disconnected")));
                }
                done.send(got)
            });
            while queue.waiting.load(Ordering::SeqCst) == 0 {
                std::thread::sleep(Duration::from_millis(1));
            }
            for k in 0..count {
                push(&mut p, k);
                assert!(p.flush(k + 1 < count || !end_of_burst));
            }
            let got = result
                .recv_timeout(Duration::from_secs(20))
                .expect("the reader was woken");
            assert_eq!(got, (0..count).collect::<Vec<_>>());
        }
    }

    /// The publisher's end going away wakes a blocked subscriber with what was pending, then
    /// `Disconnected`.
    #[test]
    fn a_dropped_publisher_flushes_and_disconnects() {
        let (mut p, mut s) = pdo_subscription();
        push(&mut p, 7);
        assert!(p.flush(true));
        drop(p);
        assert_eq!(counters(s.recv().wait().expect("the pending batch")), [7]);
        assert_eq!(s.recv().wait().unwrap_err(), RecvError);
    }
}
