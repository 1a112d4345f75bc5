//! The network's events as a [`Stream`]: every subscriber gets every event published after it
//! subscribed, in order, from a bounded queue of its own. A subscriber that falls behind loses
//! the oldest events and is told how many, as an item in their place ([`Lagged`]): nothing is
//! dropped silently, and a slow subscriber never holds up the network or the others.

use std::collections::VecDeque;
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};

use futures_core::Stream;

use crate::machine::NetworkEvent;
use crate::machine::events::EventSink;
use crate::network::Network;

/// Queue length of [`Network::events`].
pub const DEFAULT_EVENT_CAPACITY: usize = 1024;

/// `n` events were lost between the item before this one and the item after it: the subscriber
/// fell behind by more than its queue holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{0} event(s) lost: the subscriber fell behind")]
pub struct Lagged(pub u64);

struct Queue {
    events: VecDeque<NetworkEvent>,
    capacity: usize,
    /// Events dropped since the subscriber last took an item.
    lost: u64,
    waker: Option<Waker>,
    /// The network is gone: the stream ends once the queue is empty.
    closed: bool,
    /// The stream is gone: the network forgets this subscriber.
    dropped: bool,
}

type Shared = Arc<Mutex<Queue>>;

fn lock(q: &Shared) -> MutexGuard<'_, Queue> {
    q.lock().unwrap_or_else(|p| p.into_inner())
}

/// The network's end of one subscription.
struct Sink(Shared);

impl EventSink for Sink {
    fn deliver(&self, event: &NetworkEvent) -> bool {
        let mut q = lock(&self.0);
        if q.dropped {
            return false;
        }
        if q.events.len() >= q.capacity {
            q.events.pop_front();
            q.lost += 1;
        }
        q.events.push_back(event.clone());
        if let Some(w) = q.waker.take() {
            w.wake();
        }
        true
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        let mut q = lock(&self.0);
        q.closed = true;
        if let Some(w) = q.waker.take() {
            w.wake();
        }
    }
}

/// A subscription to the network's events (see [`Network::events`]): a [`Stream`] of
/// `Result<NetworkEvent, Lagged>`. It ends when the network is gone; dropping it
/// unsubscribes.
///
/// Events are produced while the network is driven (a background driver, a waiting call, or an
/// async operation on a virtual-clock bus, see [`crate::asynch`]); the stream itself drives
/// nothing.
pub struct EventStream {
    queue: Shared,
}

impl core::fmt::Debug for EventStream {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let q = lock(&self.queue);
        f.debug_struct("EventStream")
            .field("queued", &q.events.len())
            .field("capacity", &q.capacity)
            .field("lost", &q.lost)
            .finish()
    }
}

impl Drop for EventStream {
    fn drop(&mut self) {
        lock(&self.queue).dropped = true;
    }
}

impl EventStream {
    /// The next item, waiting for it: `None` once the network is gone and the queue is empty.
    pub async fn next(&mut self) -> Option<Result<NetworkEvent, Lagged>> {
        std::future::poll_fn(|cx| Pin::new(&mut *self).poll_next(cx)).await
    }

    /// The next item if one is queued, without waiting.
    pub fn try_next(&mut self) -> Option<Result<NetworkEvent, Lagged>> {
        take(&mut lock(&self.queue))
    }
}

fn take(q: &mut Queue) -> Option<Result<NetworkEvent, Lagged>> {
    if q.lost > 0 {
        return Some(Err(Lagged(core::mem::take(&mut q.lost))));
    }
    q.events.pop_front().map(Ok)
}

impl Stream for EventStream {
    type Item = Result<NetworkEvent, Lagged>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let mut q = lock(&self.queue);
        if let Some(item) = take(&mut q) {
            return Poll::Ready(Some(item));
        }
        if q.closed {
            return Poll::Ready(None);
        }
        q.waker = Some(cx.waker().clone());
        Poll::Pending
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let q = lock(&self.queue);
        let n = q.events.len() + usize::from(q.lost > 0);
        (n, if q.closed { Some(n) } else { None })
    }
}

/// The network's events as a stream.
impl Network {
    /// Subscribes to the network's events as a [`Stream`](futures_core::Stream), with a queue
    /// of [`DEFAULT_EVENT_CAPACITY`] events (see
    /// [`events_with_capacity`](Self::events_with_capacity)).
    pub fn events(&self) -> EventStream {
        self.events_with_capacity(DEFAULT_EVENT_CAPACITY)
    }

    /// Subscribes to the network's events as a [`Stream`](futures_core::Stream) whose queue
    /// holds `capacity` events (at least one). Each subscriber has its own queue; when it is
    /// full the oldest event goes and the stream yields `Err(Lagged(n))` in place of the `n`
    /// lost ones.
    pub fn events_with_capacity(&self, capacity: usize) -> EventStream {
        EventStream::new(self, capacity)
    }
}

impl EventStream {
    /// A stream of `net`'s events whose queue holds `capacity` events (at least one): see
    /// [`Network::events_with_capacity`].
    fn new(net: &Network, capacity: usize) -> Self {
        let queue = Arc::new(Mutex::new(Queue {
            events: VecDeque::new(),
            capacity: capacity.max(1),
            lost: 0,
            waker: None,
            closed: false,
            dropped: false,
        }));
        net.core().add_sink(Box::new(Sink(queue.clone())));
        EventStream { queue }
    }
}
