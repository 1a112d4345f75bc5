//! How a network runs: the driving step (send what the core produced, receive until its
//! next deadline, feed it, fire its timers), the wait loop of every blocking call ("whoever
//! waits drives"), and the background driver that steps when nobody waits.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use canola_frame::{Duration, Instant, NodeId};

use crate::error::{Error, SdoError, SdoErrorKind, TransportFailure};
use crate::machine::{Completion, Core, NetworkEvent, Outcome, Request, RequestId, Taken};
use crate::transport::{Received, TransportError};
use canola_od::ObjectAddress;

use super::shared::{DriverSlot, Inner, Io, Shared, relock};

/// Longest a driving step waits on the transport when the core has no earlier deadline, so
/// requests submitted by other threads start promptly on a real clock.
const DRIVE_SLICE: Duration = Duration::from_millis(2);

/// How soon a step tries again when the transport's transmit queue was full (about two 8-byte
/// frames at 1 Mbit/s: room comes back as frames leave the wire).
const TX_RETRY: Duration = Duration::from_micros(250);

/// Most frames one driving step takes from the transport (those already waiting after the
/// first, see [`Transport::has_pending`]): enough to spread the step's fixed cost, few enough that the core's timers and the
/// transmit queue are served at least every batch.
const RECEIVE_BATCH: usize = 32;

/// Driving steps in a row that may start from the previous step's last clock reading instead
/// of reading the clock again (real clocks only: reading a real clock is a noticeable part of
/// a short step, see the bench README). Only a short step passes its reading on (one
/// that handled at most one frame), so a step's idea of the time is at most this many short
/// steps old. A timer is not delayed by a wait: every wait ends at an absolute deadline no
/// later than the next timer, after which a step with a stale reading ends at once; a timer
/// fires at most this many short steps late.
const MAX_REUSED_READINGS: u8 = 7;

/// How long the background driver keeps out of the way after a waiting thread stopped
/// driving, so that a caller issuing requests back to back keeps the transport.
const STEP_ASIDE: std::time::Duration = std::time::Duration::from_millis(2);

impl Shared {
    /// The body of [`Network::start_driver`](crate::Network::start_driver).
    pub(crate) fn start_driver(&self) -> Result<(), Error> {
        self.install_driver(|weak, stop, error| {
            std::thread::Builder::new()
                .name("canopen-driver".into())
                .spawn(move || drive(&weak, &stop, &error))
                .map(Some)
                .map_err(Error::from)
        })
    }

    /// Starts a background driver with `spawn` unless one runs already: `spawn` gets a weak
    /// handle to the network, the flag that asks the driver to stop and the slot for the error
    /// that ended it, and returns the driver's thread if it made one (a task returns `None`).
    pub(crate) fn install_driver<E>(
        &self,
        spawn: impl FnOnce(
            Weak<Inner>,
            Arc<AtomicBool>,
            Arc<Mutex<Option<TransportFailure>>>,
        ) -> Result<Option<std::thread::JoinHandle<()>>, E>,
    ) -> Result<(), E> {
        let mut slot = relock(self.inner.driver.lock());
        if slot
            .stop
            .as_ref()
            .is_some_and(|s| !s.load(Ordering::SeqCst))
        {
            return Ok(());
        }
        let (stop, error) = (Arc::new(AtomicBool::new(false)), Arc::new(Mutex::new(None)));
        let thread = spawn(Arc::downgrade(&self.inner), stop.clone(), error.clone())?;
        *slot = DriverSlot {
            stop: Some(stop),
            thread,
            error: Some(error),
        };
        self.inner.driven.store(true, Ordering::SeqCst);
        Ok(())
    }

    /// The body of [`Network::is_driven`](crate::Network::is_driven).
    pub(crate) fn is_driven(&self) -> bool {
        let slot = relock(self.inner.driver.lock());
        slot.stop
            .as_ref()
            .is_some_and(|s| !s.load(Ordering::SeqCst))
    }

    /// The body of [`Network::stop_driver`](crate::Network::stop_driver).
    pub(crate) fn stop_driver(&self) -> Result<(), Error> {
        let slot = std::mem::take(&mut *relock(self.inner.driver.lock()));
        self.inner.driven.store(false, Ordering::SeqCst);
        if let Some(stop) = &slot.stop {
            stop.store(true, Ordering::SeqCst);
        }
        self.inner.cond.notify_all();
        // The driver may be waiting on the transport: end that wait, so it sees `stop` now.
        self.wake();
        if let Some(t) = slot.thread {
            let _ = t.join();
        }
        match slot.error.and_then(|e| relock(e.lock()).take()) {
            Some(failure) => Err(Error::Driver {
                bus: self.inner.bus.clone(),
                failure,
            }),
            None => Ok(()),
        }
    }

    /// One driving step: flush, receive until the next deadline (bounded by `limit` and the
    /// drive slice), feed the core. Returns whether a frame or bus event was received.
    pub(crate) fn step(&self, io: &mut Io, limit: Option<Instant>) -> Result<bool, Error> {
        let (received, _) = self.step_checking(io, limit, None, &mut |_| None::<()>)?;
        Ok(received)
    }

    /// The body of [`Network::run_step`](crate::Network::run_step).
    pub(crate) fn run_step(&self, limit: impl Into<Duration>) -> Result<bool, Error> {
        let limit: Duration = limit.into();
        match self.inner.io.try_lock() {
            Ok(mut io) => {
                self.count_waiter_step();
                // The step's own reading, when it may reuse one: no extra clock read for the bound.
                let now = match io.reading {
                    Some(t) => t,
                    None => io.now(),
                };
                self.step(&mut io, Some(now + limit))
            }
            Err(_) => {
                let c = self.core();
                // Counted while the core is locked, as in `wait_for_by`: the driving thread
                // notifies at the end of its step.
                self.inner.waiting.fetch_add(1, Ordering::SeqCst);
                let wait =
                    std::time::Duration::from(limit).min(std::time::Duration::from_millis(5));
                let _ = relock(self.inner.cond.wait_timeout(c, wait));
                self.inner.waiting.fetch_sub(1, Ordering::SeqCst);
                Ok(false)
            }
        }
    }

    /// [`step`](Self::step) for a waiter: `check` looks at the core under the step's own locks
    /// (before anything is done, and after the frames are handled), so waiting costs no lock
    /// of its own. A value from the first look ends the step at once. With `held` (the core,
    /// locked by the caller) the step starts under that lock, without the first look.
    pub(super) fn step_checking<T>(
        &self,
        io: &mut Io,
        limit: Option<Instant>,
        held: Option<MutexGuard<'_, Core>>,
        check: &mut impl FnMut(&mut Core) -> Option<T>,
    ) -> Result<(bool, Option<T>), Error> {
        let now = match io.reading.take() {
            Some(t) => {
                io.reused += 1;
                t
            }
            None => {
                io.reused = 0;
                io.now()
            }
        };
        let start = now;
        let mut c = match held {
            Some(c) => c,
            None => {
                let mut c = self.core();
                if let Some(r) = check(&mut c) {
                    return Ok((false, Some(r)));
                }
                c
            }
        };
        let next = c.handle_timeout_and_poll(now);
        c.take_transmit(&mut io.out);
        // Sent under the core's lock: a transport's send does not block (a full queue is
        // back-pressure), and the answer may be there at once.
        let backlog = self.send_queued(io, now, Some(&mut c))?;
        let mut deadline = now + if backlog { TX_RETRY } else { DRIVE_SLICE };
        if let Some(t) = next {
            deadline = deadline.min(t);
        }
        if let Some(l) = limit {
            deadline = deadline.min(l);
        }
        // A transport that holds a frame already (the in-memory bus hands a request to its
        // stations as it is sent, and their answers are queued) is read under the same lock;
        // otherwise the lock is let go for the wait, so other threads can submit meanwhile.
        let mut got = if io.has_pending() {
            io.recv_until(now)
        } else {
            drop(c);
            let got = io.recv_until(deadline.max(now));
            c = self.core();
            got
        };
        let received = matches!(got, Ok(Some(_)));
        // The first frame, then whatever else is waiting already (up to a batch), under one
        // lock and with one timer pass and one wake-up for all of them.
        let mut at_last = None;
        let mut frames = 0;
        c.hold_events();
        for taken in 1..=RECEIVE_BATCH {
            match got {
                Ok(Some(Received::Frame { frame, at })) => {
                    c.handle_frame(at, &frame);
                    at_last = Some(at);
                    frames += 1;
                }
                Ok(Some(Received::Event(ev))) => c.handle_bus_event(ev),
                Ok(None) => break,
                Err(e) => {
                    c.release_events(false);
                    drop(c);
                    self.notify();
                    return Err(e.into());
                }
            }
            if taken == RECEIVE_BATCH || !io.has_pending() {
                break;
            }
            // A deadline not after the last reception: take only what has arrived.
            got = io.recv_until(at_last.unwrap_or(start));
        }
        // A background driver steps again at once for frames already waiting: the batch
        // subscribers are woken once the burst is over (any other caller may not step again).
        let more = frames == RECEIVE_BATCH
            && self.inner.driven.load(Ordering::Relaxed)
            && io.has_pending();
        c.release_events(more);
        // Nothing received: the wait ended at a deadline, so fire what is due now. After
        // frames, the timers wait for the next step's start: the wait ended before any core
        // deadline (it was one of the wait's bounds), and a timer is not worth a second pass
        // over the core per frame. `latest` stamps what the step sends last.
        let latest = match at_last {
            Some(at) => at,
            None => {
                let t = io.now();
                c.handle_timeout(t);
                t
            }
        };
        c.take_transmit(&mut io.out);
        // A frame stamped before the step began (queued earlier, or a burst a coalescing
        // transport held back) is no reading of the clock now: the next step reads it afresh.
        if frames <= 1 && latest >= start && !io.virtual_clock && io.reused < MAX_REUSED_READINGS {
            io.reading = Some(latest);
        }
        let done = check(&mut c);
        let sent = self.send_queued(io, latest, Some(&mut c));
        drop(c);
        self.notify();
        sent?;
        Ok((received, done))
    }

    /// Hands queued frames to the transport in order. A full transmit queue is back-pressure,
    /// not a failure: the frames it did not take go back to the front of the core's queue for
    /// the next step (where a failed SDO transfer's frames can still be withdrawn). Returns
    /// whether frames stayed behind. `now` is a reading of the transport's clock taken a moment
    /// before (see [`Transport::send_at`]); `core` is the core when the caller holds its lock.
    #[inline]
    pub(super) fn send_queued(
        &self,
        io: &mut Io,
        now: Instant,
        core: Option<&mut Core>,
    ) -> Result<bool, Error> {
        // Mostly nothing to send (a step asks twice).
        if io.out.is_empty() {
            return Ok(false);
        }
        self.send_all(io, now, core)
    }

    pub(super) fn send_all(
        &self,
        io: &mut Io,
        now: Instant,
        core: Option<&mut Core>,
    ) -> Result<bool, Error> {
        let Io { transport, out, .. } = io;
        for i in 0..out.len() {
            match out[i].frame.send_at(transport.as_mut(), now) {
                Ok(()) => {}
                Err(TransportError::TxQueueFull) => {
                    match core {
                        Some(c) => c.unsend(out.drain(i..)),
                        None => self.core().unsend(out.drain(i..)),
                    }
                    out.clear();
                    return Ok(true);
                }
                Err(e) => {
                    out.clear();
                    return Err(e.into());
                }
            }
        }
        out.clear();
        Ok(false)
    }

    pub(crate) fn submit(&self, req: Request) -> RequestId {
        let id = self.core().submit(req);
        self.wake();
        id
    }

    pub(crate) fn cancel(&self, id: RequestId) {
        self.core().cancel(id);
        self.wake();
        // Put the abort on the bus now if nobody is driving.
        if let Ok(mut io) = self.inner.io.try_lock() {
            self.core().take_transmit(&mut io.out);
            let now = io.now();
            let _ = self.send_queued(&mut io, now, None);
        }
    }

    /// Blocks until request `id` (for `entry` of `node`) finishes, driving the network
    /// meanwhile.
    pub(crate) fn wait(
        &self,
        id: RequestId,
        node: NodeId,
        entry: ObjectAddress,
    ) -> Result<Completion, SdoError> {
        let r = self.wait_for(|c| Self::finished(c, id, node, entry));
        self.waited(r, id, node, entry).map_err(|e| *e)
    }

    /// Submits `req` and blocks until it finishes (the blocking calls' path): what
    /// [`submit`](Self::submit) then [`wait`](Self::wait) do, but when the transport is free the
    /// first driving step starts under the lock the submission took (one lock of the core
    /// fewer, and no look for a result that cannot be there yet).
    pub(crate) fn run(&self, req: Request) -> Result<Completion, SdoError> {
        let (node, entry) = (req.node(), req.entry());
        let mut c = self.core();
        let id = c.submit(req);
        // The core is locked and a driving step takes the transport first: only a free
        // transport is taken here (waiting for it could deadlock with that step).
        let first = match self.inner.io.try_lock() {
            Ok(mut io) => {
                self.count_waiter_step();
                self.step_checking(&mut io, None, Some(c), &mut |c| {
                    Self::finished(c, id, node, entry)
                })
            }
            Err(_) => {
                drop(c);
                self.wake();
                Ok((false, None))
            }
        };
        let r = match first {
            Ok((_, Some(r))) => Ok(r),
            Ok((_, None)) => self.wait_for(|c| Self::finished(c, id, node, entry)),
            Err(e) => Err(e),
        };
        self.waited(r, id, node, entry).map_err(|e| *e)
    }

    /// Counts a waiter's driving step for the background driver (see `Inner::waiter_steps`);
    /// called with the transport locked.
    pub(super) fn count_waiter_step(&self) {
        // Only a background driver looks at the count.
        if self.inner.driven.load(Ordering::Relaxed) {
            let n = self.inner.waiter_steps.load(Ordering::Relaxed);
            self.inner
                .waiter_steps
                .store(n.wrapping_add(1), Ordering::Release);
        }
    }

    /// The result of request `id` if it has finished (see [`wait`](Self::wait)).
    pub(super) fn finished(
        c: &mut Core,
        id: RequestId,
        node: NodeId,
        entry: ObjectAddress,
    ) -> Option<Outcome> {
        match c.take_result(id) {
            Taken::Running => None,
            Taken::Done(r) => Some(r.map_err(|e| Box::new(c.name_error(*e)))),
            Taken::Unknown => Some(Err(Box::new(c.name_error(SdoError {
                node,
                entry,
                name: None,
                kind: SdoErrorKind::Cancelled,
            })))),
        }
    }

    /// A wait's end: its result, or the transport error that ended it, as the request's error.
    pub(super) fn waited(
        &self,
        r: Result<Outcome, Error>,
        id: RequestId,
        node: NodeId,
        entry: ObjectAddress,
    ) -> Outcome {
        match r {
            Ok(r) => r,
            Err(e) => {
                // A transport failure ends the request: say which node and object it was for.
                let mut core = self.core();
                core.cancel(id);
                Err(Box::new(core.name_error(SdoError {
                    node,
                    entry,
                    name: None,
                    kind: SdoErrorKind::Transport(TransportFailure::from(&e)),
                })))
            }
        }
    }

    /// Drives the network until `done` returns a value (whoever waits drives; see the module
    /// docs).
    pub(crate) fn wait_for<T>(&self, done: impl FnMut(&mut Core) -> Option<T>) -> Result<T, Error> {
        self.wait_for_by(None, done)
    }

    /// [`wait_for`](Self::wait_for) where `done` may change by time alone at `deadline` (a
    /// wait's timeout): no driving step waits past it, so a virtual clock stops there.
    pub(crate) fn wait_for_by<T>(
        &self,
        deadline: Option<Instant>,
        mut done: impl FnMut(&mut Core) -> Option<T>,
    ) -> Result<T, Error> {
        loop {
            match self.inner.io.try_lock() {
                Ok(mut io) => {
                    self.count_waiter_step();
                    if let (_, Some(r)) = self.step_checking(&mut io, deadline, None, &mut done)? {
                        return Ok(r);
                    }
                }
                Err(_) => {
                    let mut c = self.core();
                    if let Some(r) = done(&mut c) {
                        return Ok(r);
                    }
                    // Counted while the core is locked, and the wait releases that lock: a
                    // thread that changes the core after the check above sees the count and
                    // notifies. (The driving thread's release of the transport is not a core
                    // change; the timeout bounds that wait.)
                    self.inner.waiting.fetch_add(1, Ordering::SeqCst);
                    let _ = relock(
                        self.inner
                            .cond
                            .wait_timeout(c, std::time::Duration::from_millis(5)),
                    );
                    self.inner.waiting.fetch_sub(1, Ordering::SeqCst);
                }
            }
        }
    }
}

impl Shared {
    /// One driving step for a waiter that checks its condition itself, between steps (the
    /// loop of a blocking [`join_all`](crate::join_all)): no step waits past `deadline`. When
    /// another thread drives, waits for it to make progress instead (a short while at most).
    pub(crate) fn step_once(&self, deadline: Option<Instant>) -> Result<(), Error> {
        match self.inner.io.try_lock() {
            Ok(mut io) => {
                self.count_waiter_step();
                self.step(&mut io, deadline).map(|_| ())
            }
            Err(_) => {
                let c = self.core();
                self.inner.waiting.fetch_add(1, Ordering::SeqCst);
                let _ = relock(
                    self.inner
                        .cond
                        .wait_timeout(c, std::time::Duration::from_millis(5)),
                );
                self.inner.waiting.fetch_sub(1, Ordering::SeqCst);
                Ok(())
            }
        }
    }

    /// Whether `other` is a handle to this same network.
    pub(crate) fn same(&self, other: &Shared) -> bool {
        Arc::ptr_eq(&self.inner, &other.inner)
    }
}

/// The background driver's loop: one step whenever no waiting thread drives, until `stop` is
/// set, the network is gone or the transport fails.
pub(crate) fn drive(
    inner: &Weak<Inner>,
    stop: &AtomicBool,
    error: &Mutex<Option<TransportFailure>>,
) {
    let mut steps_seen = 0;
    while !stop.load(Ordering::SeqCst) {
        let Some(net) = Shared::upgrade(inner) else {
            return;
        };
        if net.waiter_drives(&mut steps_seen) {
            // Out of the way until the waiters are done. Not counted in `waiting`: waking this
            // thread at every step of a waiter would cost each request a context switch; the
            // timeout is soon enough, and `stop_driver` notifies.
            let c = net.core();
            // A waiter that blocked for want of the transport while this driver held it may
            // have missed the end of its step (the step notifies before it lets the transport
            // go): wake it, the transport is free now. Under the core's lock, a waiter counted
            // in `waiting` is in its wait already.
            if net.inner.waiting.load(Ordering::SeqCst) > 0 {
                net.inner.cond.notify_all();
            }
            let _ = relock(net.inner.cond.wait_timeout(c, STEP_ASIDE));
            continue;
        }
        let r = {
            let mut io = relock(net.inner.io.lock());
            net.step(&mut io, None)
        };
        if let Err(e) = r {
            if matches!(
                e,
                Error::Transport(
                    TransportError::InterfaceDown
                        | TransportError::BusOff
                        | TransportError::TxQueueFull
                )
            ) {
                // The bus may come back (the transport reports that as a bus event): keep
                // driving, without spinning on a failing send.
                std::thread::sleep(STEP_ASIDE);
                continue;
            }
            net.driver_failed(&e, error, stop);
            return;
        }
    }
    if let Some(net) = Shared::upgrade(inner) {
        net.core().wake_pdo_subscribers();
    }
}

impl Shared {
    /// A background driver's end on a transport failure: the error kept for `stop_driver`, the
    /// driver told to stop, and [`NetworkEvent::TransportFailed`] published (thread and task
    /// drivers alike).
    pub(crate) fn driver_failed(
        &self,
        e: &Error,
        error: &Mutex<Option<TransportFailure>>,
        stop: &AtomicBool,
    ) {
        let failure = TransportFailure::from(e);
        *relock(error.lock()) = Some(failure.clone());
        stop.store(true, Ordering::SeqCst);
        self.core().publish(NetworkEvent::TransportFailed {
            bus: self.inner.bus.clone(),
            failure,
        });
        self.notify();
    }

    /// Whether a waiting thread wants to drive (it is blocked for want of the transport) or
    /// drove since the driver last looked (`seen`: the count of waiters' steps it saw then).
    /// The driver looks every [`STEP_ASIDE`] while it steps aside, so a caller idle that long
    /// gets the driver back; one whose step outlasts that (a slow answer) meets the driver at
    /// its next step, finds the transport taken, blocks, and so has the driver step aside.
    pub(super) fn waiter_drives(&self, seen: &mut u64) -> bool {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            return true;
        }
        let steps = self.inner.waiter_steps.load(Ordering::Acquire);
        steps != core::mem::replace(seen, steps)
    }
}
