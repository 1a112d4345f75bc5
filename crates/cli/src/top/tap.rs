//! The bus side of `canopen top`: a [`Transport`] that hands everything it receives and sends
//! to the network unchanged and puts a copy of each frame and bus event into a bounded queue
//! for the view. Putting a copy in costs one queue push; the view takes them at its own pace
//! (10 times a second), so drawing never holds up the bus. A full queue drops the copy (never
//! the frame the network gets) and counts it in [`TapStats::lost`].
//!
//! Since the view looks at the bus ten times a second, [`tap`] asks the transport to coalesce
//! receive wake-ups ([`RX_COALESCING`], see [`canola::RxCoalescing`]): the master's driver is
//! woken once per burst of frames instead of once per frame, which on a busy bus is most of
//! what receiving it costs. Frames keep their reception times (on SocketCAN the kernel's, unless
//! it refuses `SO_TIMESTAMPNS`: then the time they were read, up to a window late), and the
//! network's timers are not delayed, so heartbeat ages and rates come out as before.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};

use canola::candump::LogFrame;
use canola::transport::{BusEvent, Received, Transport, TransportError};
use canola::{CanFrame, Duration, Instant, RxCoalescing};

/// What the bus side saw, for the view's model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Seen {
    /// A frame on the bus (received, or sent by this master), FD and error frames included.
    Frame {
        /// When (the transport's clock).
        at: Instant,
        /// The frame.
        frame: LogFrame,
        /// Sent by this master.
        sent: bool,
    },
    /// The transport's receive queue overflowed: `dropped` frames never reached the master.
    Overflow {
        /// When.
        at: Instant,
        /// How many.
        dropped: u64,
    },
}

/// Counters the bus side keeps for the view, and the transport's clock as the view reads it.
#[derive(Debug, Default)]
pub(crate) struct TapStats {
    /// Copies the view's queue had no room for.
    pub(crate) lost: AtomicU64,
    /// Copies put into the queue.
    pub(crate) queued: AtomicU64,
    /// A reading of a real transport clock and the host's monotonic clock taken together
    /// (`None` for a virtual clock), see [`now`](Self::now).
    clock: Option<(Instant, std::time::Instant)>,
}

impl TapStats {
    /// The transport's clock now, read without the transport: its reading when the tap was
    /// made plus the host's monotonic time since. A real transport clock counts the host's
    /// monotonic time from an epoch of its own, so this is its time (to a microsecond or so).
    /// The network's own `now` waits for the transport, which its driver holds while it waits
    /// for frames; a view that draws at a fixed rate must not wait for that. `None` on a
    /// virtual clock (it follows no host time): ask the network then.
    pub(crate) fn now(&self) -> Option<Instant> {
        let (at, host) = self.clock?;
        let d = host.elapsed();
        Some(at + Duration::from_micros(d.as_micros().try_into().unwrap_or(u64::MAX)))
    }
}

/// Room in the view's queue: at 1 Mbit/s a bus carries at most about 22 000 frames a second,
/// so the queue holds several seconds of a full bus between two draws.
pub(crate) const QUEUE: usize = 1 << 17;

/// The receive coalescing [`tap`] sets on its transport: a frame reaches the network (and the
/// view's queue) at most this long after it arrived, well inside one draw (100 ms at 10 draws a
/// second). The network's driving step bounds each wait too (a few ms), so a longer window
/// would gain little.
pub(crate) const RX_COALESCING: Duration = Duration::from_millis(5);

/// The transport wrapper (see the module docs).
pub(crate) struct Tap<T> {
    inner: T,
    tx: SyncSender<Seen>,
    stats: Arc<TapStats>,
}

/// A tap around `inner`, the queue the view reads, and the shared counters. Sets receive
/// coalescing of [`RX_COALESCING`] on `inner` (a transport that cannot coalesce works as
/// before).
pub(crate) fn tap<T: Transport>(mut inner: T) -> (Tap<T>, Receiver<Seen>, Arc<TapStats>) {
    inner.set_rx_coalescing(RxCoalescing::new(RX_COALESCING));
    tap_with(inner, QUEUE)
}

/// [`tap`] with a queue of `capacity` copies.
pub(crate) fn tap_with<T: Transport>(
    inner: T,
    capacity: usize,
) -> (Tap<T>, Receiver<Seen>, Arc<TapStats>) {
    let (tx, rx) = sync_channel(capacity);
    let clock = (!inner.is_virtual()).then(|| (inner.now(), std::time::Instant::now()));
    let stats = Arc::new(TapStats {
        clock,
        ..TapStats::default()
    });
    (
        Tap {
            inner,
            tx,
            stats: stats.clone(),
        },
        rx,
        stats,
    )
}

impl<T: Transport> Tap<T> {
    fn copy(&self, seen: Seen) {
        match self.tx.try_send(seen) {
            Ok(()) => {
                self.stats.queued.fetch_add(1, Ordering::Relaxed);
            }
            Err(TrySendError::Full(_)) => {
                self.stats.lost.fetch_add(1, Ordering::Relaxed);
            }
            // The view has ended: nothing to count for.
            Err(TrySendError::Disconnected(_)) => {}
        }
    }

    fn received(&self, r: &Received) {
        let seen = match r {
            Received::Frame { frame, at } => Seen::Frame {
                at: *at,
                frame: LogFrame::Can(*frame),
                sent: false,
            },
            Received::Event(BusEvent::FdFrame { frame, at }) => Seen::Frame {
                at: *at,
                frame: LogFrame::Fd(**frame),
                sent: false,
            },
            Received::Event(BusEvent::ErrorFrame { class, data }) => Seen::Frame {
                at: self.now_of_event(),
                frame: LogFrame::Error {
                    class: *class,
                    data: *data,
                },
                sent: false,
            },
            Received::Event(BusEvent::RxOverflow { dropped }) => Seen::Overflow {
                at: self.now_of_event(),
                dropped: *dropped,
            },
            Received::Event(_) => return,
        };
        self.copy(seen);
    }

    /// Bus events carry no time of their own: the transport's clock when it was taken.
    fn now_of_event(&self) -> Instant {
        self.inner.now()
    }
}

impl<T: Transport> Transport for Tap<T> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let now = self.inner.now();
        self.send_at(frame, now)
    }

    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        self.inner.send_at(frame, now)?;
        self.copy(Seen::Frame {
            at: now,
            frame: LogFrame::Can(*frame),
            sent: true,
        });
        Ok(())
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        let r = self.inner.recv_until(deadline)?;
        if let Some(r) = &r {
            self.received(r);
        }
        Ok(r)
    }

    fn now(&self) -> Instant {
        self.inner.now()
    }

    fn try_recv(&mut self) -> Result<Option<Received>, TransportError> {
        let r = self.inner.try_recv()?;
        if let Some(r) = &r {
            self.received(r);
        }
        Ok(r)
    }

    fn has_pending(&self) -> bool {
        self.inner.has_pending()
    }

    fn is_virtual(&self) -> bool {
        self.inner.is_virtual()
    }

    fn set_rx_coalescing(&mut self, coalescing: RxCoalescing) -> bool {
        self.inner.set_rx_coalescing(coalescing)
    }

    fn next_event(&self) -> Option<Instant> {
        self.inner.next_event()
    }

    fn waker(&self) -> Option<canola::TransportWaker> {
        self.inner.waker()
    }
}
