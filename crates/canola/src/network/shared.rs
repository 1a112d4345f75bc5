//! What every handle of one network shares, at the bottom of the network layer: the core, the
//! transport and its clock, the background driver's slot and the async side's clock tie
//! ([`Inner`]), held through [`Shared`]. The driving loop (`driving`, `tokio_driving`) and the
//! operations (`operation`) work on it; the public calls are [`Network`](crate::Network)'s, one floor up.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};

use canola_frame::Instant;

use crate::error::{Error, TransportFailure};
use crate::machine::Core;
use crate::transport::Transport;

pub(crate) struct Inner {
    pub(super) core: Mutex<Core>,
    pub(super) cond: Condvar,
    /// Threads waiting on `cond`: a notification costs a system call, so it is only sent when
    /// one waits.
    pub(super) waiting: AtomicUsize,
    pub(crate) io: Mutex<Io>,
    /// Ends the transport's wait in another thread ([`Transport::waker`]), when it has one.
    pub(super) transport_waker: Option<crate::transport::TransportWaker>,
    /// The async API's wake-ups and its tie between a virtual clock and tokio's.
    #[cfg(feature = "tokio")]
    pub(crate) reactor: crate::reactor::Reactor,
    /// Driving steps taken by threads inside `Shared::wait_for` (in `driving`) while a background driver
    /// runs: the driver steps aside while the count moves (a waiter drives) or a waiter is
    /// blocked (`waiting`). Written only by the holder of `io`, so a plain store counts: the
    /// fast path of a request pays no atomic read-modify-write and no clock reading for it.
    pub(super) waiter_steps: AtomicU64,
    pub(super) driver: Mutex<DriverSlot>,
    /// Whether a background driver was started (and not stopped).
    pub(super) driven: AtomicBool,
    /// The bus's name, when the network was opened by name.
    pub(super) bus: Option<String>,
}

/// The transport, and what the driving thread needs along with it.
pub(crate) struct Io {
    pub(super) transport: Box<dyn Transport>,
    /// The frames taken from the core for sending: kept between steps so that a step
    /// allocates nothing for them.
    pub(super) out: std::collections::VecDeque<crate::machine::Outgoing>,
    /// A clock reading the next driving step may start from (see `MAX_REUSED_READINGS` of the driving step).
    pub(super) reading: Option<Instant>,
    /// Steps in a row that started from such a reading.
    pub(super) reused: u8,
    /// Whether the transport's clock is virtual (a reading is then free, and exact).
    pub(super) virtual_clock: bool,
}

impl core::ops::Deref for Io {
    type Target = dyn Transport;
    fn deref(&self) -> &Self::Target {
        &*self.transport
    }
}

impl core::ops::DerefMut for Io {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut *self.transport
    }
}

/// The background driver of a network, if one was started.
#[derive(Default)]
pub(super) struct DriverSlot {
    pub(super) stop: Option<Arc<AtomicBool>>,
    pub(super) thread: Option<std::thread::JoinHandle<()>>,
    /// Why the driver ended, if the transport failed.
    pub(super) error: Option<Arc<Mutex<Option<TransportFailure>>>>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        let slot = std::mem::take(relock(self.driver.get_mut()));
        if let Some(stop) = &slot.stop {
            stop.store(true, Ordering::SeqCst);
        }
        // The driver holds only a weak handle, so it ends within one step; joining it from its
        // own thread (when its step dropped the last handle) would deadlock.
        if let Some(t) = slot.thread
            && t.thread().id() != std::thread::current().id()
        {
            let _ = t.join();
        }
    }
}

pub(super) fn relock<T>(r: std::sync::LockResult<T>) -> T {
    r.unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// What every handle of one network shares, below the operations that wait on it: the core,
/// the transport and its clock, the background driver's slot. The public handle is
/// [`Network`](crate::Network); this is what `Operation`s and the driving loop hold.
#[derive(Clone)]
pub(crate) struct Shared {
    pub(crate) inner: Arc<Inner>,
}

impl Shared {
    /// The shared state of a network on `transport` (its clock is the network's clock).
    pub(crate) fn new(transport: impl Transport + 'static, bus: Option<String>) -> Self {
        let mut core = Core::new();
        core.set_now(transport.now());
        core.set_classic_bus(crate::machine::usdo::classic_bus(&transport));
        #[cfg(feature = "tokio")]
        let reactor = crate::reactor::Reactor::new(transport.is_virtual());
        Self {
            inner: Arc::new(Inner {
                core: Mutex::new(core),
                cond: Condvar::new(),
                waiting: AtomicUsize::new(0),
                transport_waker: transport.waker(),
                io: Mutex::new(Io {
                    virtual_clock: transport.is_virtual(),
                    transport: Box::new(transport),
                    out: std::collections::VecDeque::new(),
                    reading: None,
                    reused: 0,
                }),
                #[cfg(feature = "tokio")]
                reactor,
                waiter_steps: AtomicU64::new(0),
                driver: Mutex::new(DriverSlot::default()),
                driven: AtomicBool::new(false),
                bus,
            }),
        }
    }

    /// The transport, unless another thread holds it (it is then driving).
    #[cfg(feature = "tokio")]
    pub(crate) fn try_io(&self) -> Option<MutexGuard<'_, Io>> {
        self.inner.io.try_lock().ok()
    }

    /// The tie between this network's clock and tokio's.
    #[cfg(feature = "tokio")]
    pub(crate) fn reactor(&self) -> &crate::reactor::Reactor {
        &self.inner.reactor
    }

    /// The network behind a weak handle (a background driver's), while any handle lives.
    pub(crate) fn upgrade(inner: &Weak<Inner>) -> Option<Self> {
        inner.upgrade().map(|inner| Self { inner })
    }

    /// Whether this is the last handle: the application let the network go.
    #[cfg(feature = "tokio")]
    pub(crate) fn is_last_handle(&self) -> bool {
        Arc::strong_count(&self.inner) == 1
    }

    pub(crate) fn core(&self) -> MutexGuard<'_, Core> {
        relock(self.inner.core.lock())
    }

    /// Puts what the core has queued on the bus if the transport is free (see
    /// [`send`](Self::send)).
    pub(crate) fn send_queued_now(&self) -> Result<(), Error> {
        let io = match self.inner.io.try_lock() {
            Ok(io) => io,
            Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) => {
                self.wake();
                return Ok(());
            }
        };
        self.send_with(io)
    }

    /// The blocking form of [`run_until`](Self::run_until): steps up to `until` exactly, and
    /// once more at `until` for what is due then.
    pub(crate) fn step_until(&self, until: Instant) -> Result<(), Error> {
        loop {
            let mut io = relock(self.inner.io.lock());
            if io.now() >= until {
                self.step(&mut io, Some(until))?;
                return Ok(());
            }
            self.step(&mut io, Some(until))?;
        }
    }

    /// Tells the thread that drives (and the threads waiting for it) that the core changed: a
    /// request was submitted, a timer set. The driving thread may be waiting on the transport
    /// (it holds it): its wait is ended through the transport's waker, so what the core queued
    /// leaves now rather than when that wait ends (up to the drive slice, rounded up to the
    /// scheduler's tick by a receive timeout). A wake that comes before the wait starts ends
    /// it at once (the waker keeps it), so none is lost.
    pub(crate) fn wake(&self) {
        self.notify();
        if let Some(w) = &self.inner.transport_waker
            && self.inner.io.try_lock().is_err()
        {
            w.wake();
        }
    }

    /// Wakes the threads waiting for progress, if there are any.
    pub(crate) fn notify(&self) {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            self.inner.cond.notify_all();
        }
    }

    /// The current time on the transport's clock.
    pub(crate) fn now(&self) -> Instant {
        relock(self.inner.io.lock()).now()
    }

    /// The body of `Network::flush`: sends what the core has queued, without waiting.
    pub(crate) fn flush(&self) -> Result<(), Error> {
        self.send_with(relock(self.inner.io.lock()))
    }

    /// Fires what is due, then hands what the core has queued to the transport held in `io`,
    /// and wakes the waiters.
    fn send_with(&self, mut io: MutexGuard<'_, Io>) -> Result<(), Error> {
        let now = io.now();
        {
            let mut c = self.core();
            c.handle_timeout(now);
            c.take_transmit(&mut io.out);
        }
        self.send_queued(&mut io, now, None)?;
        drop(io);
        self.notify();
        Ok(())
    }
}
