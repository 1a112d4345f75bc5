//! The [`Network`] handle: what it shares between its clones (the core, the transport and its
//! clock, the background driver's slot, the async side's clock tie) and the calls that reach
//! the core directly (events, heartbeat monitoring, SYNC, raw frames).

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak, mpsc};

use canola_frame::{CanFrame, Duration, Instant, NodeId};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget, SyncConfig};

use super::operation::{self, Operation};
use crate::error::Error;
use crate::machine::{Core, NetworkEvent};
use crate::transport::Transport;

/// Default SDO response timeout.
pub const DEFAULT_SDO_TIMEOUT: Duration = Duration::from_millis(1000);

pub(crate) struct Inner {
    pub(super) core: Mutex<Core>,
    pub(super) cond: Condvar,
    /// Threads waiting on `cond`: a notification costs a system call, so it is only sent when
    /// one waits.
    pub(super) waiting: AtomicUsize,
    pub(crate) io: Mutex<Io>,
    /// The async API's wake-ups and its tie between a virtual clock and tokio's.
    #[cfg(feature = "tokio")]
    pub(crate) reactor: crate::reactor::Reactor,
    /// Driving steps taken by threads inside [`Network::wait_for`] while a background driver
    /// runs: the driver steps aside while the count moves (a waiter drives) or a waiter is
    /// blocked (`waiting`). Written only by the holder of `io`, so a plain store counts: the
    /// fast path of a request pays no atomic read-modify-write and no clock reading for it.
    pub(super) waiter_steps: AtomicU64,
    pub(super) driver: Mutex<DriverSlot>,
    /// Whether a background driver was started (and not stopped).
    pub(super) driven: AtomicBool,
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
    pub(super) error: Option<Arc<Mutex<Option<String>>>>,
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

pub(super) fn relock<T>(r: std::sync::LockResult<T>) -> T {
    r.unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Network {
    /// A network on `transport` (its clock is the network's clock).
    pub fn new(transport: impl Transport + 'static) -> Self {
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

    /// Opens a bus by the name `canopen --iface` takes (see [`BusSpec`](crate::BusSpec)):
    /// a SocketCAN interface (`"can0"`, `"vcan0"`), `"udp[:GROUP[:PORT]][@IFACE]"`, or an
    /// slcan adapter (`"slcan:/dev/ttyACM0@500k"`, `"slcan:COM3"`), and starts the background
    /// driver: the network runs by itself from the first line. A failure is
    /// [`Error::Open`]: it names the bus and carries a hint.
    ///
    /// ```no_run
    /// let net = canola::Network::open("can0")?;
    /// # Ok::<(), canola::Error>(())
    /// ```
    pub fn open(spec: &str) -> Result<Self, Error> {
        let net = Self::new(crate::transport::BusSpec::parse(spec)?.open()?);
        net.start_driver()?;
        Ok(net)
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

    /// The current time on the transport's clock.
    pub fn now(&self) -> Instant {
        relock(self.inner.io.lock()).now()
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

    /// The latest emergency message (CiA 301 §7.2.7) a node sent since the network started,
    /// subscribed or not: what a drive's fault reset reports with the fault.
    pub fn last_emcy(&self, id: NodeId) -> Option<canola_nmt::EmcyEvent> {
        self.core().last_emcy(id)
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

    /// Sends an NMT command to every node (queued, and sent as [`send`](Self::send) says).
    pub fn nmt_all(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        self.catch_up_on_runtime()?;
        self.core().nmt(cmd, NmtTarget::All);
        self.send_queued_now()
    }

    /// Sends a raw frame: at once when the transport is free, else in the step of whoever
    /// drives it now (a waiting call, the background driver), which is woken for it. Never
    /// waits, so it serves blocking and async callers alike. An error is the transport's
    /// refusal of a frame sent here at once.
    pub fn send(&self, frame: CanFrame) -> Result<(), Error> {
        self.catch_up_on_runtime()?;
        self.core().send_raw(frame);
        self.send_queued_now()
    }

    /// On a tokio runtime (`tokio` feature), brings a virtual-clock bus up to tokio's time (see
    /// the `asynch` module), so what is queued next is stamped with the time the application
    /// sees. Nothing to do otherwise.
    pub(crate) fn catch_up_on_runtime(&self) -> Result<(), Error> {
        #[cfg(feature = "tokio")]
        if tokio::runtime::Handle::try_current().is_ok() {
            return super::tokio_driving::catch_up(self);
        }
        Ok(())
    }

    /// Puts what the core has queued on the bus if the transport is free (see
    /// [`send`](Self::send)).
    pub(crate) fn send_queued_now(&self) -> Result<(), Error> {
        let mut io = match self.inner.io.try_lock() {
            Ok(io) => io,
            Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) => {
                self.wake();
                return Ok(());
            }
        };
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

    /// Drives the network for `d` (receives, dispatches events, runs timers). On a
    /// virtual-clock bus this advances simulated time (awaited: on tokio's clock, see the
    /// `asynch` module).
    pub fn run_for(&self, d: impl Into<Duration>) -> Operation<'static, ()> {
        let d: Duration = d.into();
        let net = self.clone();
        Operation::new(async move {
            operation::catch_up(&net)?;
            let until = net.now() + d;
            operation::run_until(&net, until).await
        })
    }

    /// Drives the network until `until` on its clock.
    pub fn run_until(&self, until: Instant) -> Operation<'static, ()> {
        let net = self.clone();
        Operation::new(async move { operation::run_until(&net, until).await })
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

    /// How many entries the master's tables hold now (nodes, SDO channels, requests, frames
    /// waiting for the transport, ...): a long run with steady traffic must see them stay put.
    pub fn occupancy(&self) -> crate::machine::Occupancy {
        self.core().occupancy()
    }

    /// Sends what the core has queued, without waiting for anything. Frames a full transmit
    /// queue refuses ([`TransportError::TxQueueFull`](crate::TransportError::TxQueueFull)) stay queued for the next driving step.
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

    pub(super) fn wake(&self) {
        self.notify();
    }

    /// Wakes the threads waiting for progress, if there are any.
    pub(crate) fn notify(&self) {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            self.inner.cond.notify_all();
        }
    }
}
