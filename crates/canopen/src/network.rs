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
//! The async API (`tokio` feature, [`crate::asynch`]) runs the same wait loop on tokio's
//! blocking pool and cancels the request when the future is dropped.
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
//! asked. A driver on a virtual-clock bus would run simulated time as fast as the CPU allows;
//! use it on SocketCAN or a [`ClockMode::RealTime`](crate::mem::ClockMode::RealTime) bus.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak, mpsc};

use can_frame::{CanFrame, Duration, Instant, NodeId};
use canopen_nmt::{CommandSpecifier, NmtState, NmtTarget, SyncConfig};
use canopen_od::{DataType, ObjectDictionary, Value};
use canopen_sdo::{Method, SdoCobIds};

use crate::core::{
    Completion, Core, DownSource, NetworkEvent, Op, ProgressFn, RequestId, SdoRequest, Taken,
    TransferProgress, UpSink,
};
use crate::error::{Error, SdoError, SdoErrorKind};
use crate::transport::{Received, Transport, TransportError};
use canopen_od::ObjectAddress;

/// Default SDO response timeout.
pub const DEFAULT_SDO_TIMEOUT: Duration = Duration::from_millis(1000);

/// Longest a driving step waits on the transport when the core has no earlier deadline, so
/// requests submitted by other threads start promptly on a real clock.
const DRIVE_SLICE: Duration = Duration::from_millis(2);

pub(crate) struct Inner {
    core: Mutex<Core>,
    cond: Condvar,
    /// Threads waiting on `cond`: a notification costs a system call, so it is only sent when
    /// one waits.
    waiting: AtomicUsize,
    io: Mutex<Box<dyn Transport>>,
    /// Threads inside [`Network::wait_for`]: the background driver steps aside while there are.
    driving_waiters: AtomicUsize,
    /// When the last waiter left [`Network::wait_for`], in nanoseconds since `epoch`.
    last_wait_end: AtomicU64,
    epoch: std::time::Instant,
    driver: Mutex<DriverSlot>,
    /// Whether a background driver was started (and not stopped).
    driven: AtomicBool,
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
        Self {
            inner: Arc::new(Inner {
                core: Mutex::new(core),
                cond: Condvar::new(),
                waiting: AtomicUsize::new(0),
                io: Mutex::new(Box::new(transport)),
                driving_waiters: AtomicUsize::new(0),
                last_wait_end: AtomicU64::new(0),
                epoch: std::time::Instant::now(),
                driver: Mutex::new(DriverSlot::default()),
                driven: AtomicBool::new(false),
            }),
        }
    }

    /// Opens a SocketCAN interface (e.g. `"can0"`, `"vcan0"`) and starts the background
    /// driver: the network runs by itself from the first line.
    ///
    /// ```no_run
    /// let net = canopen::Network::open("can0")?;
    /// # Ok::<(), canopen::Error>(())
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
    /// transport's receive blocks). Does nothing when one runs already. Panics outside a tokio
    /// runtime, as `tokio::task::spawn_blocking` does.
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
        drop(tokio::task::spawn_blocking(move || drive(&weak, &s, &e)));
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
    /// call arrive in order; a dropped receiver unsubscribes.
    pub fn subscribe(&self) -> mpsc::Receiver<NetworkEvent> {
        self.core().subscribe()
    }

    /// Watches a node's heartbeat: a `Lost` event when none arrives within `timeout`.
    pub fn monitor_heartbeat(&self, id: NodeId, timeout: Duration) -> bool {
        self.core().monitor_heartbeat(id, timeout)
    }

    /// Guards a node (CiA 301 node guarding): a remote request every `guard_time`, a `Lost`
    /// event when no answer comes within `guard_time × life_time_factor`. A zero guard time
    /// stops guarding.
    pub fn guard_node(&self, id: NodeId, guard_time: Duration, life_time_factor: u8) -> bool {
        let ok = self.core().guard_node(id, guard_time, life_time_factor);
        self.wake();
        ok
    }

    /// The last NMT state a node reported by heartbeat or boot-up.
    pub fn last_state(&self, id: NodeId) -> Option<NmtState> {
        self.core().last_state(id)
    }

    /// Starts producing SYNC (CiA 301 §7.2.3) with the given period, COB-ID 0x080.
    pub fn start_sync(&self, period: Duration) {
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
    pub fn set_transfer_gap(&self, gap: Duration) {
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
    pub fn run_for(&self, d: Duration) -> Result<(), Error> {
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

    /// Sends what the core has queued, without waiting for anything.
    pub fn flush(&self) -> Result<(), Error> {
        let mut io = relock(self.inner.io.lock());
        let now = io.now();
        let frames = {
            let mut c = self.core();
            c.handle_timeout(now);
            std::iter::from_fn(|| c.poll_transmit()).collect::<Vec<_>>()
        };
        for f in frames {
            io.send(&f)?;
        }
        drop(io);
        self.notify();
        Ok(())
    }

    fn wake(&self) {
        self.notify();
    }

    /// Wakes the threads waiting for progress, if there are any.
    fn notify(&self) {
        if self.inner.waiting.load(Ordering::SeqCst) > 0 {
            self.inner.cond.notify_all();
        }
    }

    /// One driving step: flush, receive until the next deadline (bounded by `limit` and the
    /// drive slice), feed the core.
    fn step(&self, io: &mut Box<dyn Transport>, limit: Option<Instant>) -> Result<(), Error> {
        let now = io.now();
        let (frames, next) = {
            let mut c = self.core();
            c.handle_timeout(now);
            let frames: Vec<_> = std::iter::from_fn(|| c.poll_transmit()).collect();
            (frames, c.poll_timeout())
        };
        for f in &frames {
            io.send(f)?;
        }
        let mut deadline = now + DRIVE_SLICE;
        if let Some(t) = next {
            deadline = deadline.min(t);
        }
        if let Some(l) = limit {
            deadline = deadline.min(l);
        }
        let got = io.recv_until(deadline.max(now));
        // A frame's reception time is the time now, give or take the decoding; only otherwise
        // ask the clock.
        let now = match &got {
            Ok(Some(Received::Frame { at, .. })) => *at,
            _ => io.now(),
        };
        let more = {
            let mut c = self.core();
            match got {
                Ok(Some(Received::Frame { frame, at })) => c.handle_frame(at, &frame),
                Ok(Some(Received::Event(ev))) => c.handle_bus_event(ev),
                Ok(None) => {}
                Err(e) => {
                    drop(c);
                    self.notify();
                    return Err(e.into());
                }
            }
            c.handle_timeout(now);
            std::iter::from_fn(|| c.poll_transmit()).collect::<Vec<_>>()
        };
        for f in &more {
            io.send(f)?;
        }
        self.notify();
        Ok(())
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
            let frames: Vec<_> = {
                let mut c = self.core();
                std::iter::from_fn(|| c.poll_transmit()).collect()
            };
            for f in &frames {
                let _ = io.send(f);
            }
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
        let r = self.wait_for(|c| match c.take_result(id) {
            Taken::Running => None,
            Taken::Done(r) => Some(r.map_err(|e| c.name_error(e))),
            Taken::Unknown => Some(Err(c.name_error(SdoError {
                node,
                entry,
                name: None,
                kind: SdoErrorKind::Cancelled,
            }))),
        });
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
                Err(core.name_error(SdoError {
                    node,
                    entry,
                    name: None,
                    kind: SdoErrorKind::Transport(text),
                }))
            }
        }
    }

    /// Drives the network until `done` returns a value (whoever waits drives; see the module
    /// docs).
    pub(crate) fn wait_for<T>(&self, done: impl FnMut(&mut Core) -> Option<T>) -> Result<T, Error> {
        self.inner.driving_waiters.fetch_add(1, Ordering::SeqCst);
        let r = self.wait_loop(done);
        // Only a background driver looks at the time (and reading the clock is not free).
        if self.inner.driven.load(Ordering::Relaxed) {
            let since = self.inner.epoch.elapsed().as_nanos();
            self.inner
                .last_wait_end
                .store(u64::try_from(since).unwrap_or(u64::MAX), Ordering::SeqCst);
        }
        self.inner.driving_waiters.fetch_sub(1, Ordering::SeqCst);
        r
    }

    fn wait_loop<T>(&self, mut done: impl FnMut(&mut Core) -> Option<T>) -> Result<T, Error> {
        loop {
            if let Some(r) = done(&mut self.core()) {
                return Ok(r);
            }
            match self.inner.io.try_lock() {
                Ok(mut io) => self.step(&mut io, None)?,
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
    while !stop.load(Ordering::SeqCst) {
        let Some(inner) = inner.upgrade() else {
            return;
        };
        let net = Network { inner };
        if net.waiter_drives() {
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
            let text = match e {
                Error::Transport(t) => t.to_string(),
                other => other.to_string(),
            };
            *relock(error.lock()) = Some(text.clone());
            stop.store(true, Ordering::SeqCst);
            net.core()
                .publish(NetworkEvent::TransportFailed { error: text });
            net.notify();
            return;
        }
    }
}

impl Network {
    /// Whether a thread waiting for a request drives now or did a moment ago.
    fn waiter_drives(&self) -> bool {
        if self.inner.driving_waiters.load(Ordering::SeqCst) > 0 {
            return true;
        }
        let last = self.inner.last_wait_end.load(Ordering::SeqCst);
        let now = u64::try_from(self.inner.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX);
        last != 0 && now.saturating_sub(last) < STEP_ASIDE.as_nanos() as u64
    }
}

/// A node on the network.
#[derive(Clone, Debug)]
pub struct Node {
    net: Network,
    id: NodeId,
}

impl Node {
    /// The node-ID.
    pub fn id(&self) -> NodeId {
        self.id
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// The node's SDO client with default settings (normal transfer, 1 s response timeout).
    pub fn sdo(&self) -> Sdo {
        Sdo {
            net: self.net.clone(),
            node: self.id,
            channel: SdoCobIds::default_for(self.id),
            method: Method::Normal,
            timeout: DEFAULT_SDO_TIMEOUT,
            progress: None,
        }
    }

    /// NMT commands to this node, and its state (see [`Nmt::state`]).
    pub fn nmt(&self) -> Nmt {
        Nmt::new(&self.net, NmtTarget::Node(self.id))
    }

    /// Remaps PDO `number` (1-based) of `direction` on the node by SDO, the CiA 301 way
    /// (disable, clear mapping, write entries, set count, set parameters, enable; the plan comes
    /// from `canopen_pdo::remap`). After a TPDO remap the master decodes that TPDO with the new
    /// mapping.
    pub fn remap_pdo(
        &self,
        direction: canopen_pdo::Direction,
        number: u16,
        comm: canopen_pdo::CommParams,
        mapping: canopen_pdo::Mapping,
    ) -> Result<(), Error> {
        let n = number.saturating_sub(1);
        let mut remote = canopen_pdo::RemoteObjects::dynamic(direction);
        // With a dictionary, write only the sub-indices the node has.
        if let Some(od) = self.dictionary() {
            let ci = direction.comm_index(n);
            let has = |sub| od.sub(ci, sub).is_some();
            remote.has_inhibit_time = has(3);
            remote.has_event_timer = has(5);
            remote.has_sync_start = has(6);
            // Dynamic mapping (CiA 301 §7.4.8.3): sub 0 of the mapping object is writable.
            remote.mapping_writable = od
                .sub(direction.mapping_index(n), 0)
                .is_none_or(|s| s.access.is_writable());
        }
        let steps = canopen_pdo::remap(direction, n, &comm, &mapping, &remote).map_err(|e| {
            Error::Value {
                node: self.id,
                entry: ObjectAddress::new(direction.comm_index(n), 0),
                message: e.to_string(),
            }
        })?;
        for step in &steps {
            self.sdo()
                .write((step.index, step.subindex), step.value())?;
        }
        if matches!(direction, canopen_pdo::Direction::Transmit) {
            let mapping = match self.dictionary() {
                Some(od) => crate::pdo_glue::typed_mapping(&od, self.id, direction, mapping),
                None => mapping,
            };
            self.net.core().mirror_tpdo(
                self.id,
                (n + 1) as u8,
                canopen_pdo::PdoConfig::new(comm, mapping),
            );
        }
        Ok(())
    }

    /// The node's dictionary, if it was added with one.
    pub fn dictionary(&self) -> Option<Arc<ObjectDictionary>> {
        self.net.core().dictionary(self.id)
    }
}

/// NMT module control (CiA 301 §7.2.8.3.1) for one node or all, and a node's NMT state as its
/// heartbeats, boot-up and guarding answers report it.
///
/// Boot-ups are counted, not sampled: [`wait_for_bootup`](Self::wait_for_bootup) returns for a
/// boot-up received since this handle was made or since its last command, even if a heartbeat
/// with the next state followed at once (or the background driver received both before the
/// wait began). So `nmt.reset_node()` then `nmt.wait_for_bootup(t)` cannot miss the boot-up.
#[derive(Debug)]
pub struct Nmt {
    net: Network,
    target: NmtTarget,
    /// The node's boot-up count when this handle was made or last sent a command.
    boots_seen: AtomicU64,
}

impl Clone for Nmt {
    fn clone(&self) -> Self {
        Self {
            net: self.net.clone(),
            target: self.target,
            boots_seen: AtomicU64::new(self.boots_seen.load(Ordering::SeqCst)),
        }
    }
}

impl Nmt {
    fn new(net: &Network, target: NmtTarget) -> Self {
        let boots = match target {
            NmtTarget::Node(id) => net.core().boot_count(id),
            _ => 0,
        };
        Self {
            net: net.clone(),
            target,
            boots_seen: AtomicU64::new(boots),
        }
    }

    /// NMT commands to all nodes (node-ID 0).
    pub fn all(net: &Network) -> Self {
        Self::new(net, NmtTarget::All)
    }

    fn send(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        let mut core = self.net.core();
        if let NmtTarget::Node(id) = self.target {
            self.boots_seen.store(core.boot_count(id), Ordering::SeqCst);
        }
        core.nmt(cmd, self.target);
        drop(core);
        self.net.flush()
    }

    fn node(&self) -> Result<NodeId, Error> {
        match self.target {
            NmtTarget::Node(id) => Ok(id),
            _ => Err(Error::InvalidRequest(
                "node states are per node: use node.nmt(), not Nmt::all".into(),
            )),
        }
    }

    /// The node's last reported NMT state (`None` before anything was heard from it; `BootUp`
    /// between its boot-up message and its first heartbeat). `None` for [`Nmt::all`].
    pub fn state(&self) -> Option<NmtState> {
        match self.target {
            NmtTarget::Node(id) => self.net.last_state(id),
            _ => None,
        }
    }

    /// Waits (driving the network) for a boot-up of the node received since this handle was
    /// made or sent its last command. Times out after `timeout` on the network's clock.
    pub fn wait_for_bootup(&self, timeout: Duration) -> Result<(), Error> {
        let node = self.node()?;
        let seen = self.boots_seen.load(Ordering::SeqCst);
        let deadline = self.net.now() + timeout;
        let r = self.net.wait_for(|c| {
            let boots = c.boot_count(node);
            if boots > seen {
                Some(Ok(boots))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "no boot-up from node {node} within {timeout}"
                ))))
            } else {
                None
            }
        })??;
        self.boots_seen.store(r, Ordering::SeqCst);
        Ok(())
    }

    /// Waits (driving the network) until the node reports `state`; returns at once if it is in
    /// it already. Times out after `timeout` on the network's clock.
    pub fn wait_for_state(&self, state: NmtState, timeout: Duration) -> Result<(), Error> {
        let node = self.node()?;
        let deadline = self.net.now() + timeout;
        self.net.wait_for(|c| {
            if c.last_state(node) == Some(state) {
                Some(Ok(()))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "node {node} not {state} within {timeout}"
                ))))
            } else {
                None
            }
        })?
    }

    /// Start remote node (to Operational).
    pub fn start(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::Start)
    }
    /// Stop remote node (to Stopped).
    pub fn stop(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::Stop)
    }
    /// Enter Pre-Operational.
    pub fn enter_preoperational(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::EnterPreOperational)
    }
    /// Reset node (application reset).
    pub fn reset_node(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::ResetNode)
    }
    /// Reset communication.
    pub fn reset_communication(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::ResetCommunication)
    }
}

/// A request in flight, typed by what it produces: `Pending<Vec<u8>>` for an upload into
/// memory, `Pending<()>` for a download, `Pending<u64>` (bytes) for a streamed upload. Waiting
/// drives the network; dropping it cancels the request (a running transfer is aborted on the bus
/// with 0x08000000).
#[must_use = "dropping a pending request cancels it"]
pub struct Pending<T = Vec<u8>> {
    pub(crate) net: Network,
    pub(crate) id: Option<RequestId>,
    pub(crate) node: NodeId,
    pub(crate) entry: ObjectAddress,
    /// What this kind of request takes from its completion.
    pub(crate) output: fn(Completion) -> T,
}

impl<T> core::fmt::Debug for Pending<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Pending")
            .field("node", &self.node)
            .field("entry", &self.entry)
            .field("running", &self.id.is_some())
            .finish_non_exhaustive()
    }
}

impl<T> Pending<T> {
    /// Blocks until the request finishes.
    pub fn wait(mut self) -> Result<T, SdoError> {
        let output = self.output;
        match self.id.take() {
            Some(id) => self.net.wait(id, self.node, self.entry).map(output),
            None => Err(self.cancelled()),
        }
    }

    /// The node the request is for.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// The object the request is for.
    pub fn entry(&self) -> ObjectAddress {
        self.entry
    }

    /// Whether the request has finished (its result is ready for [`wait`](Self::wait)).
    pub fn is_done(&self) -> bool {
        self.id.is_none_or(|id| self.net.core().is_done(id))
    }

    /// Cancels the request (same as dropping it).
    pub fn cancel(mut self) {
        if let Some(id) = self.id.take() {
            self.net.cancel(id);
        }
    }

    /// The error of a request that no longer runs.
    pub(crate) fn cancelled(&self) -> SdoError {
        SdoError {
            node: self.node,
            entry: self.entry,
            name: None,
            kind: SdoErrorKind::Cancelled,
        }
    }
}

impl<T> Drop for Pending<T> {
    fn drop(&mut self) {
        if let Some(id) = self.id.take() {
            self.net.cancel(id);
        }
    }
}

/// A value that can be written by SDO (little-endian bytes, CiA 301 §7.1).
pub trait SdoValue {
    /// The bytes to download.
    fn to_sdo_bytes(&self) -> Vec<u8>;
}

macro_rules! le_value {
    ($($t:ty),*) => {$(
        impl SdoValue for $t {
            fn to_sdo_bytes(&self) -> Vec<u8> {
                self.to_le_bytes().to_vec()
            }
        }
    )*};
}
le_value!(u8, u16, u32, u64, i8, i16, i32, i64, f32, f64);

impl SdoValue for [u8] {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_vec()
    }
}
impl<const N: usize> SdoValue for [u8; N] {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_vec()
    }
}
impl SdoValue for Vec<u8> {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.clone()
    }
}
impl SdoValue for str {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.as_bytes().to_vec()
    }
}
impl SdoValue for Value {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_le_bytes()
    }
}
impl<T: SdoValue + ?Sized> SdoValue for &T {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        (**self).to_sdo_bytes()
    }
}

/// A node's SDO client (CiA 301 §7.2.4) as a builder: settings, then one operation.
pub struct Sdo {
    net: Network,
    node: NodeId,
    channel: SdoCobIds,
    method: Method,
    timeout: Duration,
    progress: Option<ProgressFn>,
}

impl core::fmt::Debug for Sdo {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Sdo")
            .field("node", &self.node)
            .field("channel", &self.channel)
            .field("method", &self.method)
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

impl Sdo {
    /// The node this client talks to.
    pub fn node_id(&self) -> NodeId {
        self.node
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// Talks to the node's SDO server on another channel than its default one (0x600/0x580 +
    /// node-ID): a further server channel (0x1201..=0x127F) or a changed 0x1200. Requests on
    /// one channel run one at a time; different channels run in parallel.
    pub fn channel(mut self, ids: SdoCobIds) -> Self {
        self.channel = ids;
        self
    }

    /// Uses block transfer (CiA 301 §7.2.4.3.9) when `on`.
    pub fn block(mut self, on: bool) -> Self {
        self.method = if on { Method::Block } else { Method::Normal };
        self
    }

    /// Chooses the transfer method.
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Sets the response timeout (per server response).
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }

    /// Calls `f` as the transfer progresses.
    pub fn on_progress(mut self, f: impl FnMut(TransferProgress) + Send + 'static) -> Self {
        self.progress = Some(Box::new(f));
        self
    }

    fn request<T>(self, entry: ObjectAddress, op: Op, output: fn(Completion) -> T) -> Pending<T> {
        let node = self.node;
        let req = SdoRequest {
            node,
            channel: self.channel,
            entry,
            op,
            method: self.method,
            timeout: self.timeout,
            progress: self.progress,
        };
        let id = self.net.submit(req);
        Pending {
            net: self.net,
            id: Some(id),
            node,
            entry,
            output,
        }
    }

    /// Starts an upload into memory without waiting.
    pub fn submit_read(self, entry: impl Into<ObjectAddress>) -> Pending<Vec<u8>> {
        self.request(entry.into(), Op::Upload(UpSink::Mem(Vec::new())), |c| {
            c.data
        })
    }

    /// Starts a download without waiting.
    pub fn submit_write(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Pending<()> {
        let data = value.to_sdo_bytes();
        self.request(entry.into(), Op::Download(DownSource(data)), |_| ())
    }

    /// Reads an object's bytes (SDO upload).
    pub fn read(self, entry: impl Into<ObjectAddress>) -> Result<Vec<u8>, Error> {
        Ok(self.submit_read(entry).wait()?)
    }

    /// Reads an object and decodes it with the type from the node's dictionary.
    pub fn read_value(self, entry: impl Into<ObjectAddress>) -> Result<Value, Error> {
        let entry = entry.into();
        let node = self.node;
        let data_type = self
            .net
            .core()
            .dictionary(node)
            .and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type));
        match data_type {
            Some(t) => self.read_as(entry, t),
            None => Err(Error::Value {
                node,
                entry,
                message: "the node's dictionary does not describe this object".into(),
            }),
        }
    }

    /// Reads an object and decodes it as `data_type` (whatever the dictionary says).
    pub fn read_as(
        self,
        entry: impl Into<ObjectAddress>,
        data_type: DataType,
    ) -> Result<Value, Error> {
        let entry = entry.into();
        let node = self.node;
        let bytes = self.read(entry)?;
        Value::from_le_bytes(data_type, &bytes).map_err(|e| Error::Value {
            node,
            entry,
            message: e.to_string(),
        })
    }

    /// Reads a typed entry (from generated code: `canopen_od::Entry<T>`) and decodes it.
    pub fn read_entry<T: canopen_od::EntryValue>(
        self,
        entry: &canopen_od::Entry<T>,
    ) -> Result<T, Error> {
        let (node, at) = (
            self.node,
            ObjectAddress::new(entry.index(), entry.sub_index()),
        );
        let bytes = self.read(at)?;
        entry.decode(&bytes).map_err(|e| Error::Value {
            node,
            entry: at,
            message: e.to_string(),
        })
    }

    /// Writes a typed entry (from generated code: `canopen_od::Entry<T>`).
    pub fn write_entry<T: canopen_od::EntryValue>(
        self,
        entry: &canopen_od::Entry<T>,
        value: &T,
    ) -> Result<(), Error> {
        let at = ObjectAddress::new(entry.index(), entry.sub_index());
        // Large enough for every fixed-size type; strings and domains are written as bytes.
        let mut buf = vec![0u8; 4096];
        let n = entry.encode(value, &mut buf).map_err(|e| Error::Value {
            node: self.node,
            entry: at,
            message: e.to_string(),
        })?;
        buf.truncate(n);
        self.write(at, buf)
    }

    /// Writes an object (SDO download).
    pub fn write(self, entry: impl Into<ObjectAddress>, value: impl SdoValue) -> Result<(), Error> {
        self.submit_write(entry, value).wait()?;
        Ok(())
    }

    /// Uploads an object into `writer`, streaming as segments arrive, and flushes it at the
    /// end. Returns the byte count; a write or the final flush failing is an error
    /// ([`SdoErrorKind::Io`]), so no data is lost silently.
    pub fn upload_to(
        self,
        entry: impl Into<ObjectAddress>,
        writer: impl Write + Send + 'static,
    ) -> Result<u64, Error> {
        let sink = UpSink::Stream {
            w: Box::new(writer),
            written: 0,
            error: None,
        };
        Ok(self
            .request(entry.into(), Op::Upload(sink), |c| c.transferred)
            .wait()?)
    }

    /// Downloads the whole content of `reader` into an object. Returns the byte count.
    pub fn download_from(
        self,
        entry: impl Into<ObjectAddress>,
        mut reader: impl Read,
    ) -> Result<u64, Error> {
        let mut data = Vec::new();
        reader.read_to_end(&mut data)?;
        Ok(self
            .request(entry.into(), Op::Download(DownSource(data)), |c| {
                c.transferred
            })
            .wait()?)
    }
}
