//! [`Network`]: one transport, one clock, one core of protocol machines, and
//! the blocking API on top.
//!
//! Driving: whoever waits drives. A blocking call submits its request to the core, then loops:
//! if its result is there it returns; otherwise, if no other thread is driving, it takes the
//! transport and runs one step (send what the core produced, receive until the core's next
//! deadline or a short slice, feed the core, fire due timers); else it waits for the driving
//! thread to make progress. So one thread alone is deterministic on a virtual-clock bus, and
//! several threads share one transport safely. Requests to different nodes progress together
//! whichever of them is being waited on; requests to one node run in submission order.
//!
//! A step reads the transport's clock once, at its start, and stamps what it sends with that
//! reading ([`Transport::send_at`]); on a real clock a short step (one frame handled) passes
//! its last reading on to the next few (see `MAX_REUSED_READINGS`: a reading costs a good
//! part of an SDO round trip on the in-memory bus). A blocking request is submitted under the
//! core lock its first step takes (`Network::run`).
//!
//! The async API (`tokio` feature, `crate::asynch`) runs the same wait loop on tokio's
//! blocking pool on a real clock, steps it from the task on a virtual clock (whose time then
//! follows tokio's), and cancels the request when the future is dropped.
//!
//! Running by itself: [`Network::start_driver`] starts a background driver (a thread; under the
//! `tokio` feature [`Network::start_driver_on_runtime`] runs it on the caller's runtime's
//! blocking pool) that drives the network whenever nobody else does, so heartbeats, EMCY, PDO
//! events, SYNC and timeouts flow with no call from the application. It steps aside while a
//! thread waits for a request (that thread drives, so a request costs no hand-over between
//! threads), and stops when [`Network::stop_driver`] is called or the last handle to the
//! network is dropped. A transport that fails for good (closed, an operating-system error) ends
//! it: subscribers get
//! [`NetworkEvent::TransportFailed`] and [`Network::stop_driver`] returns the error.
//!
//! The explicit stepping mode stays for deterministic tests: without a driver nothing happens
//! between calls, and [`Network::run_for`] advances a virtual-clock bus by exactly the time
//! asked. A driver thread on a virtual-clock bus would run simulated time as fast as the CPU
//! allows; use it on SocketCAN or a [`ClockMode::RealTime`](crate::mem::ClockMode::RealTime)
//! bus. (Under the `tokio` feature, `start_driver_on_runtime` on a virtual-clock bus is a task
//! that keeps the bus at tokio's time instead.)

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak, mpsc};

use canola_frame::{CanFrame, Duration, Instant, NodeId};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget, SyncConfig};
use canola_od::ObjectDictionary;

use crate::error::{Error, SdoError, SdoErrorKind};
use crate::machine::{Completion, Core, NetworkEvent, Outcome, RequestId, SdoRequest, Taken};
use crate::transport::{Received, Transport, TransportError};
use canola_od::ObjectAddress;

/// Default SDO response timeout.
pub const DEFAULT_SDO_TIMEOUT: Duration = Duration::from_millis(1000);

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
/// of reading the clock again (real clocks only: a reading costs 30 ns alone here, and more
/// in the middle of a step, as it waits for the instructions before it; an SDO round trip on
/// the in-memory bus is about 400 ns). Only a short step passes its reading on (one
/// that handled at most one frame), so a step's idea of the time is at most this many short
/// steps old. A timer is not delayed by a wait: every wait ends at an absolute deadline no
/// later than the next timer, after which a step with a stale reading ends at once; a timer
/// fires at most this many short steps late.
const MAX_REUSED_READINGS: u8 = 7;

pub(crate) struct Inner {
    core: Mutex<Core>,
    cond: Condvar,
    /// Threads waiting on `cond`: a notification costs a system call, so it is only sent when
    /// one waits.
    waiting: AtomicUsize,
    pub(crate) io: Mutex<Io>,
    /// The async API's wake-ups and its tie between a virtual clock and tokio's.
    #[cfg(feature = "tokio")]
    pub(crate) reactor: crate::asynch::Reactor,
    /// Driving steps taken by threads inside [`Network::wait_for`] while a background driver
    /// runs: the driver steps aside while the count moves (a waiter drives) or a waiter is
    /// blocked (`waiting`). Written only by the holder of `io`, so a plain store counts: the
    /// fast path of a request pays no atomic read-modify-write and no clock reading for it.
    waiter_steps: AtomicU64,
    driver: Mutex<DriverSlot>,
    /// Whether a background driver was started (and not stopped).
    driven: AtomicBool,
}

/// The transport, and what the driving thread needs along with it.
pub(crate) struct Io {
    transport: Box<dyn Transport>,
    /// The frames taken from the core for sending: kept between steps so that a step
    /// allocates nothing for them.
    out: std::collections::VecDeque<crate::machine::Outgoing>,
    /// A clock reading the next driving step may start from (see [`MAX_REUSED_READINGS`]).
    reading: Option<Instant>,
    /// Steps in a row that started from such a reading.
    reused: u8,
    /// Whether the transport's clock is virtual (a reading is then free, and exact).
    virtual_clock: bool,
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
struct DriverSlot {
    stop: Option<Arc<AtomicBool>>,
    thread: Option<std::thread::JoinHandle<()>>,
    /// Why the driver ended, if the transport failed.
    error: Option<Arc<Mutex<Option<String>>>>,
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

/// How long the background driver keeps out of the way after a waiting thread stopped
/// driving, so that a caller issuing requests back to back keeps the transport.
const STEP_ASIDE: std::time::Duration = std::time::Duration::from_millis(2);

/// A CANopen network: the master side of one CAN bus. Cheap to clone (a shared handle).
#[derive(Clone)]
pub struct Network {
    pub(crate) inner: Arc<Inner>,
}

impl core::fmt::Debug for Network {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Network").finish_non_exhaustive()
    }
}

fn relock<T>(r: std::sync::LockResult<T>) -> T {
    r.unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Network {
    /// A network on `transport` (its clock is the network's clock).
    pub fn new(transport: impl Transport + 'static) -> Self {
        let mut core = Core::new();
        core.set_now(transport.now());
        #[cfg(feature = "tokio")]
        let reactor = crate::asynch::Reactor::new(transport.is_virtual());
        Self {
            inner: Arc::new(Inner {
                core: Mutex::new(core),
                cond: Condvar::new(),
                waiting: AtomicUsize::new(0),
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
            }),
        }
    }

    /// Opens a SocketCAN interface (e.g. `"can0"`, `"vcan0"`) and starts the background
    /// driver: the network runs by itself from the first line.
    ///
    /// ```no_run
    /// let net = canola::Network::open("can0")?;
    /// # Ok::<(), canola::Error>(())
    /// ```
    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    pub fn open(interface: &str) -> Result<Self, Error> {
        let net = Self::new(crate::socketcan::SocketCan::open(interface)?);
        net.start_driver()?;
        Ok(net)
    }

    /// Starts the background driver on a thread of its own (see the module docs). Does nothing
    /// when one runs already. Use it with a real clock (SocketCAN, a real-time memory bus).
    pub fn start_driver(&self) -> Result<(), Error> {
        let mut slot = relock(self.inner.driver.lock());
        if slot
            .stop
            .as_ref()
            .is_some_and(|s| !s.load(Ordering::SeqCst))
        {
            return Ok(());
        }
        let (stop, error) = (Arc::new(AtomicBool::new(false)), Arc::new(Mutex::new(None)));
        let (weak, s, e) = (Arc::downgrade(&self.inner), stop.clone(), error.clone());
        let thread = std::thread::Builder::new()
            .name("canopen-driver".into())
            .spawn(move || drive(&weak, &s, &e))?;
        *slot = DriverSlot {
            stop: Some(stop),
            thread: Some(thread),
            error: Some(error),
        };
        self.inner.driven.store(true, Ordering::SeqCst);
        Ok(())
    }

    /// Starts the background driver on the current tokio runtime (its blocking pool: the
    /// transport's receive blocks; on a virtual-clock bus, a task that keeps the bus at
    /// tokio's time instead, see `canola::asynch`). Does nothing when one runs already.
    /// Panics outside a tokio runtime, as `tokio::task::spawn_blocking` does.
    #[cfg(feature = "tokio")]
    pub fn start_driver_on_runtime(&self) {
        let mut slot = relock(self.inner.driver.lock());
        if slot
            .stop
            .as_ref()
            .is_some_and(|s| !s.load(Ordering::SeqCst))
        {
            return;
        }
        let (stop, error) = (Arc::new(AtomicBool::new(false)), Arc::new(Mutex::new(None)));
        let (weak, s, e) = (Arc::downgrade(&self.inner), stop.clone(), error.clone());
        // The task ends by itself once `stop` is set or the network is gone.
        if self.is_virtual_clock() {
            crate::asynch::spawn_virtual_driver(weak, s, e);
        } else {
            drop(tokio::task::spawn_blocking(move || drive(&weak, &s, &e)));
        }
        *slot = DriverSlot {
            stop: Some(stop),
            thread: None,
            error: Some(error),
        };
        self.inner.driven.store(true, Ordering::SeqCst);
    }

    /// Whether a background driver runs (started and not ended by a transport failure).
    pub fn is_driven(&self) -> bool {
        let slot = relock(self.inner.driver.lock());
        slot.stop
            .as_ref()
            .is_some_and(|s| !s.load(Ordering::SeqCst))
    }

    /// Stops the background driver and waits for its thread to end. Returns the transport
    /// error that ended it, if one did. Stepping by [`run_for`](Self::run_for) and by waiting
    /// calls goes on as before.
    pub fn stop_driver(&self) -> Result<(), Error> {
        let slot = std::mem::take(&mut *relock(self.inner.driver.lock()));
        self.inner.driven.store(false, Ordering::SeqCst);
        if let Some(stop) = &slot.stop {
            stop.store(true, Ordering::SeqCst);
        }
        self.inner.cond.notify_all();
        if let Some(t) = slot.thread {
            let _ = t.join();
        }
        match slot.error.and_then(|e| relock(e.lock()).take()) {
            Some(text) => Err(Error::Driver(text)),
            None => Ok(()),
        }
    }

    pub(crate) fn core(&self) -> MutexGuard<'_, Core> {
        relock(self.inner.core.lock())
    }

    /// The current time on the transport's clock.
    pub fn now(&self) -> Instant {
        relock(self.inner.io.lock()).now()
    }

    /// Adds a node without a dictionary (values are raw bytes).
    pub fn add_node(&self, id: NodeId) -> Node {
        self.core().add_node(id, None);
        self.node(id)
    }

    /// Adds a node with its object dictionary (from an EDS/DCF or generated code): errors then
    /// name objects, and typed reads decode values.
    pub fn add_node_with_dictionary(&self, id: NodeId, od: ObjectDictionary) -> Node {
        self.core().add_node(id, Some(Arc::new(od)));
        self.node(id)
    }

    /// A handle to a node (added on first use if needed).
    pub fn node(&self, id: NodeId) -> Node {
        Node {
            net: self.clone(),
            id,
        }
    }

    /// Subscribes to heartbeat, EMCY, PDO, LSS and bus events. Events published after this
    /// call arrive in order; a dropped receiver unsubscribes. Every received PDO is an event
    /// of its own here, owning its values; at high PDO rates [`subscribe_pdos`](Self::subscribe_pdos)
    /// (batches) or [`on_pdo`](Self::on_pdo) (a callback) take a fraction of the CPU
    /// (`canola-bench`'s `pdo_rx` compares them).
    pub fn subscribe(&self) -> mpsc::Receiver<NetworkEvent> {
        self.core().subscribe()
    }

    /// Subscribes to the PDOs received from nodes, taken in batches: each
    /// [`PdoSubscriber::try_recv`](crate::PdoSubscriber::try_recv) or `recv` returns every PDO
    /// received since the previous one, read as the [`PdoReceived`](crate::PdoReceived) views
    /// an [`on_pdo`](Self::on_pdo) callback gets — but on the subscriber's thread, and without
    /// the allocation and channel message per frame of [`subscribe`](Self::subscribe)'s
    /// events. The way to follow TPDOs at full bus load; a dropped subscriber unsubscribes.
    pub fn subscribe_pdos(&self) -> crate::PdoSubscriber {
        self.core().subscribe_pdos()
    }

    /// Calls `f` for every PDO received from a node, decoded or not — python-canopen's PDO
    /// callback, without its copies: `f` borrows the data and the typed values, and a
    /// reception that only callbacks see allocates nothing. The events of
    /// [`subscribe`](Self::subscribe) carry the same PDOs.
    ///
    /// `f` runs on the thread that drives the network (the driver, or the caller of a
    /// blocking call), with the network locked: it must not call this network (that would
    /// wait for itself) and should be short. Hand longer work to another thread, e.g. through
    /// a channel.
    pub fn on_pdo(
        &self,
        f: impl FnMut(&crate::PdoReceived<'_>) + Send + 'static,
    ) -> crate::PdoCallbackId {
        self.core().add_pdo_callback(Box::new(f))
    }

    /// Removes a callback added by [`on_pdo`](Self::on_pdo); `false` when it was not there.
    pub fn remove_pdo_callback(&self, id: crate::PdoCallbackId) -> bool {
        self.core().remove_pdo_callback(id)
    }

    /// Watches a node's heartbeat: a `Lost` event when none arrives within `timeout`.
    pub fn monitor_heartbeat(&self, id: NodeId, timeout: impl Into<Duration>) -> bool {
        let timeout: Duration = timeout.into();
        self.core().monitor_heartbeat(id, timeout)
    }

    /// Guards a node (CiA 301 node guarding): a remote request every `guard_time`, a `Lost`
    /// event when no answer comes within `guard_time × life_time_factor`. A zero guard time
    /// stops guarding.
    pub fn guard_node(
        &self,
        id: NodeId,
        guard_time: impl Into<Duration>,
        life_time_factor: u8,
    ) -> bool {
        let guard_time: Duration = guard_time.into();
        let ok = self.core().guard_node(id, guard_time, life_time_factor);
        self.wake();
        ok
    }

    /// The last NMT state a node reported by heartbeat or boot-up.
    pub fn last_state(&self, id: NodeId) -> Option<NmtState> {
        self.core().last_state(id)
    }

    /// When the latest heartbeat (or boot-up) of a node arrived, monitored or not: a sign of
    /// life that, unlike [`last_state`](Self::last_state), also shows a node repeating its state.
    pub fn last_heartbeat(&self, id: NodeId) -> Option<Instant> {
        self.core().last_heartbeat(id)
    }

    /// Starts producing SYNC (CiA 301 §7.2.3) with the given period, COB-ID 0x080.
    pub fn start_sync(&self, period: impl Into<Duration>) {
        let period: Duration = period.into();
        if let Ok(cfg) = SyncConfig::new(period, 0) {
            self.core().start_sync(cfg);
        }
        self.wake();
    }

    /// Starts producing SYNC with a full configuration (COB-ID, period, counter overflow).
    pub fn start_sync_with(&self, config: SyncConfig) {
        self.core().start_sync(config);
        self.wake();
    }

    /// Sets the quiet time between two SDO transfers to the same node (default 1 ms).
    ///
    /// The pause lets a late or duplicated response to a finished transfer reach an idle SDO
    /// client, which ignores it, instead of the next transfer to that node. On a clean bus
    /// `Duration::ZERO` gives the full expedited rate (the pause otherwise caps a node at about
    /// 800 expedited transfers per second at 1 Mbit/s); on a bus that duplicates frames keep it.
    /// Transfers to different nodes never wait for each other.
    pub fn set_transfer_gap(&self, gap: impl Into<Duration>) {
        let gap: Duration = gap.into();
        self.core().settle = gap;
    }

    /// Stops the SYNC producer.
    pub fn stop_sync(&self) {
        self.core().stop_sync();
    }

    /// Sends an NMT command to every node.
    pub fn nmt_all(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        self.core().nmt(cmd, NmtTarget::All);
        self.flush()
    }

    /// Sends a raw frame.
    pub fn send(&self, frame: CanFrame) -> Result<(), Error> {
        self.core().send_raw(frame);
        self.flush()
    }

    /// Drives the network for `d` (receives, dispatches events, runs timers). On a virtual-clock
    /// bus this advances simulated time.
    pub fn run_for(&self, d: impl Into<Duration>) -> Result<(), Error> {
        let d: Duration = d.into();
        let until = self.now() + d;
        self.run_until(until)
    }

    /// Drives the network until `until` on its clock.
    pub fn run_until(&self, until: Instant) -> Result<(), Error> {
        loop {
            let mut io = relock(self.inner.io.lock());
            if io.now() >= until {
                self.step(&mut io, Some(until))?;
                return Ok(());
            }
            self.step(&mut io, Some(until))?;
        }
    }

    /// How many entries the master's tables hold now (nodes, SDO channels, requests, frames
    /// waiting for the transport, ...): a long run with steady traffic must see them stay put.
    pub fn occupancy(&self) -> crate::machine::Occupancy {
        self.core().occupancy()
    }

    /// Sends what the core has queued, without waiting for anything. Frames a full transmit
    /// queue refuses ([`TransportError::TxQueueFull`]) stay queued for the next driving step.
    pub fn flush(&self) -> Result<(), Error> {
        let mut io = relock(self.inner.io.lock());
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

    fn wake(&self) {
        self.notify();
    }

    /// Wakes the threads waiting for progress, if there are any.
    pub(crate) fn notify(&self) {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            self.inner.cond.notify_all();
        }
    }

    /// One driving step: flush, receive until the next deadline (bounded by `limit` and the
    /// drive slice), feed the core. Returns whether a frame or bus event was received.
    pub(crate) fn step(&self, io: &mut Io, limit: Option<Instant>) -> Result<bool, Error> {
        let (received, _) = self.step_checking(io, limit, None, &mut |_| None::<()>)?;
        Ok(received)
    }

    /// [`step`](Self::step) for a waiter: `check` looks at the core under the step's own locks
    /// (before anything is done, and after the frames are handled), so waiting costs no lock
    /// of its own. A value from the first look ends the step at once. With `held` (the core,
    /// locked by the caller) the step starts under that lock, without the first look.
    fn step_checking<T>(
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
        if frames <= 1 && !io.virtual_clock && io.reused < MAX_REUSED_READINGS {
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
    fn send_queued(
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

    fn send_all(&self, io: &mut Io, now: Instant, core: Option<&mut Core>) -> Result<bool, Error> {
        let Io { transport, out, .. } = io;
        for i in 0..out.len() {
            match transport.send_at(&out[i].frame, now) {
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

    pub(crate) fn submit(&self, req: SdoRequest) -> RequestId {
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
    pub(crate) fn run(&self, req: SdoRequest) -> Result<Completion, SdoError> {
        let (node, entry) = (req.node, req.entry);
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
    fn count_waiter_step(&self) {
        // Only a background driver looks at the count.
        if self.inner.driven.load(Ordering::Relaxed) {
            let n = self.inner.waiter_steps.load(Ordering::Relaxed);
            self.inner
                .waiter_steps
                .store(n.wrapping_add(1), Ordering::Release);
        }
    }

    /// The result of request `id` if it has finished (see [`wait`](Self::wait)).
    fn finished(
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
    fn waited(
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
                // The transport's own words ("the CAN interface is down"), without the
                // "transport: " that `Error` puts in front: SdoErrorKind::Transport says it.
                let text = match e {
                    Error::Transport(t) => t.to_string(),
                    other => other.to_string(),
                };
                Err(Box::new(core.name_error(SdoError {
                    node,
                    entry,
                    name: None,
                    kind: SdoErrorKind::Transport(text),
                })))
            }
        }
    }

    /// Drives the network until `done` returns a value (whoever waits drives; see the module
    /// docs).
    pub(crate) fn wait_for<T>(
        &self,
        mut done: impl FnMut(&mut Core) -> Option<T>,
    ) -> Result<T, Error> {
        loop {
            match self.inner.io.try_lock() {
                Ok(mut io) => {
                    self.count_waiter_step();
                    if let (_, Some(r)) = self.step_checking(&mut io, None, None, &mut done)? {
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

/// The background driver's loop: one step whenever no waiting thread drives, until `stop` is
/// set, the network is gone or the transport fails.
fn drive(inner: &Weak<Inner>, stop: &AtomicBool, error: &Mutex<Option<String>>) {
    let mut steps_seen = 0;
    while !stop.load(Ordering::SeqCst) {
        let Some(inner) = inner.upgrade() else {
            return;
        };
        let net = Network { inner };
        if net.waiter_drives(&mut steps_seen) {
            // Out of the way until the waiters are done. Not counted in `waiting`: waking this
            // thread at every step of a waiter would cost each request a context switch; the
            // timeout is soon enough, and `stop_driver` notifies.
            let c = net.core();
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
    if let Some(inner) = inner.upgrade() {
        Network { inner }.core().wake_pdo_subscribers();
    }
}

impl Network {
    /// A background driver's end on a transport failure: the error kept for `stop_driver`, the
    /// driver told to stop, and [`NetworkEvent::TransportFailed`] published (thread and task
    /// drivers alike).
    pub(crate) fn driver_failed(
        &self,
        e: &Error,
        error: &Mutex<Option<String>>,
        stop: &AtomicBool,
    ) {
        let text = match e {
            Error::Transport(t) => t.to_string(),
            other => other.to_string(),
        };
        *relock(error.lock()) = Some(text.clone());
        stop.store(true, Ordering::SeqCst);
        self.core()
            .publish(NetworkEvent::TransportFailed { error: text });
        self.notify();
    }

    /// Whether a waiting thread wants to drive (it is blocked for want of the transport) or
    /// drove since the driver last looked (`seen`: the count of waiters' steps it saw then).
    /// The driver looks every [`STEP_ASIDE`] while it steps aside, so a caller idle that long
    /// gets the driver back; one whose step outlasts that (a slow answer) meets the driver at
    /// its next step, finds the transport taken, blocks, and so has the driver step aside.
    fn waiter_drives(&self, seen: &mut u64) -> bool {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            return true;
        }
        let steps = self.inner.waiter_steps.load(Ordering::Acquire);
        steps != core::mem::replace(seen, steps)
    }
}

pub use crate::node::{Nmt, Node};
pub use crate::request::{Pending, Sdo, SdoValue};
