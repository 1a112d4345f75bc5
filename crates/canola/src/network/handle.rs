//! [`Network`], the one public handle of a network, and its calls on the shared state: opening
//! a bus, the clock, subscriptions and callbacks, heartbeat monitoring and node guarding, SYNC,
//! raw frames, and running (for a while, or by the background driver). The handles above it
//! (`Node`, `Sdo`, `Lss`, the PDO and USDO handles, ...) each hold a clone of it; the calls that
//! make them are `impl Network` blocks in their own modules (`node`, `crate::lss`,
//! `crate::scan`, `crate::asynch`), so this file names none of them.

use std::sync::{MutexGuard, mpsc};

use canola_frame::{CanFrame, Duration, FdFrame, Instant, NodeId};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget, SyncConfig};

use super::operation::{self, Operation};
use super::shared::Shared;
use crate::error::Error;
use crate::machine::{Core, NetworkEvent};

/// A CANopen network: the master side of one CAN bus. The transport, its clock and the core of
/// protocol machines, stepped by whoever waits or by the background driver (see the `network`
/// module docs). Cheap to clone (a shared handle); every handle made from it holds a clone
/// ([`Node::network`](crate::Node::network)).
#[derive(Clone)]
pub struct Network {
    pub(crate) shared: Shared,
}

impl core::fmt::Debug for Network {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Network").finish_non_exhaustive()
    }
}

impl Network {
    /// A network on `transport` (its clock is the network's clock).
    pub fn new(transport: impl crate::transport::Transport + 'static) -> Self {
        Self {
            shared: Shared::new(transport, None),
        }
    }

    /// A network on the bus `spec` names, with its background driver running.
    fn open_spec(
        spec: &str,
        transport: impl crate::transport::Transport + 'static,
    ) -> Result<Self, Error> {
        let net = Self {
            shared: Shared::new(transport, Some(spec.to_string())),
        };
        net.start_driver()?;
        Ok(net)
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
        Self::open_spec(spec, crate::transport::BusSpec::parse(spec)?.open()?)
    }

    /// [`Network::open`] for CAN FD: the bus must carry FD frames (a SocketCAN interface with
    /// MTU 72, the UDP bus, an slcan adapter with a data bit rate); a classic-only one is an
    /// [`Error::Open`] saying `FD not supported on ...`.
    pub fn open_fd(spec: &str) -> Result<Self, Error> {
        Self::open_spec(spec, crate::transport::BusSpec::parse(spec)?.open_fd()?)
    }

    /// The core, locked (for the handles).
    pub(crate) fn core(&self) -> MutexGuard<'_, Core> {
        self.shared.core()
    }

    /// What the operations waiting on this network hold.
    pub(crate) fn shared(&self) -> &Shared {
        &self.shared
    }

    /// Whether the network's transport runs on a virtual clock, which the async API ties to
    /// tokio's (see the `asynch` module docs).
    #[cfg(feature = "tokio")]
    pub fn is_virtual_clock(&self) -> bool {
        self.shared.reactor().virtual_clock
    }

    /// The current time on the transport's clock.
    pub fn now(&self) -> Instant {
        self.shared.now()
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
        self.shared.wake();
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
        self.shared.wake();
    }

    /// Starts producing SYNC with a full configuration (COB-ID, period, counter overflow).
    pub fn start_sync_with(&self, config: SyncConfig) {
        self.core().start_sync(config);
        self.shared.wake();
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
        self.shared.catch_up_on_runtime()?;
        self.core().nmt(cmd, NmtTarget::All);
        self.shared.send_queued_now()
    }

    /// Sends a raw frame: at once when the transport is free, else in the step of whoever
    /// drives it now (a waiting call, the background driver), which is woken for it. Never
    /// waits, so it serves blocking and async callers alike. An error is the transport's
    /// refusal of a frame sent here at once.
    pub fn send(&self, frame: CanFrame) -> Result<(), Error> {
        self.shared.catch_up_on_runtime()?;
        self.core().send_raw(frame);
        self.shared.send_queued_now()
    }

    /// Drives the network for `d` (receives, dispatches events, runs timers). On a
    /// virtual-clock bus this advances simulated time (awaited: on tokio's clock, see the
    /// `asynch` module).
    pub fn run_for(&self, d: impl Into<Duration>) -> Operation<'static, ()> {
        let d: Duration = d.into();
        let net = self.shared.clone();
        Operation::new(async move {
            operation::catch_up(&net)?;
            let until = net.now() + d;
            operation::run_until(&net, until).await
        })
    }

    /// Drives the network until `until` on its clock.
    pub fn run_until(&self, until: Instant) -> Operation<'static, ()> {
        let net = self.shared.clone();
        Operation::new(async move { operation::run_until(&net, until).await })
    }

    /// How many entries the master's tables hold now (nodes, SDO channels, requests, frames
    /// waiting for the transport, ...): a long run with steady traffic must see them stay put.
    pub fn occupancy(&self) -> crate::machine::Occupancy {
        self.core().occupancy()
    }

    /// Sends what the core has queued, without waiting for anything. Frames a full transmit
    /// queue refuses ([`TransportError::TxQueueFull`](crate::TransportError::TxQueueFull)) stay queued for the next driving step.
    pub fn flush(&self) -> Result<(), Error> {
        self.shared.flush()
    }
}

/// CAN FD and the USDO client's settings (see the `usdo` module).
impl Network {
    /// Sends a raw CAN FD frame. On a bus that carries classic frames only this is
    /// [`TransportError::FdNotSupported`](crate::TransportError::FdNotSupported) and nothing
    /// is queued.
    pub fn send_fd(&self, frame: FdFrame) -> Result<(), Error> {
        self.shared.catch_up_on_runtime()?;
        {
            let mut c = self.core();
            if let Some(bus) = c.classic_bus() {
                return Err(crate::TransportError::fd_not_supported(bus).into());
            }
            c.send_raw_fd(frame);
        }
        self.shared.send_queued_now()
    }

    /// Whether the bus carries CAN FD frames.
    pub fn is_fd(&self) -> bool {
        self.core().classic_bus().is_none()
    }

    /// Sets the master's own node-ID as a USDO client: its requests go out on 0x600 + it and
    /// servers address their responses to it (default [`DEFAULT_USDO_NODE_ID`](crate::usdo::DEFAULT_USDO_NODE_ID)). Only while
    /// no USDO transfer runs or waits; returns whether it was set.
    pub fn set_usdo_node_id(&self, node: NodeId) -> bool {
        self.core().set_usdo_node_id(node)
    }

    /// The master's own node-ID as a USDO client.
    pub fn usdo_node_id(&self) -> NodeId {
        self.core().usdo_node_id()
    }

    /// Sets how long a USDO server may take for each response (default 1 s), for transfers
    /// started once none runs.
    pub fn set_usdo_timeout(&self, timeout: impl Into<Duration>) {
        self.core().set_usdo_timeout(timeout.into());
    }
}

/// Running the network: the background driver and single steps (see the `network` module).
impl Network {
    /// Starts the background driver on a thread of its own (see the module docs). Does nothing
    /// when one runs already. Use it with a real clock (SocketCAN, a real-time memory bus).
    pub fn start_driver(&self) -> Result<(), Error> {
        self.shared.start_driver()
    }

    /// Whether a background driver runs (started and not ended by a transport failure).
    pub fn is_driven(&self) -> bool {
        self.shared.is_driven()
    }

    /// Stops the background driver and waits for its thread to end. Returns the transport
    /// error that ended it, if one did. Stepping by [`run_for`](Self::run_for) and by waiting
    /// calls goes on as before.
    pub fn stop_driver(&self) -> Result<(), Error> {
        self.shared.stop_driver()
    }

    /// One driving step, for a thread that drives the network itself between looks at its own
    /// work (several [`Pending`](crate::Pending) requests at once, new work handed over by other
    /// threads): sends what the core has queued, receives until a frame arrives, the core's next
    /// deadline passes, `limit` passes or a short slice (2 ms) does, handles what arrived and
    /// fires the timers that are due. Returns whether a frame or bus event was received. (On a
    /// transport that coalesces receive wake-ups, see
    /// [`RxCoalescing`](crate::transport::RxCoalescing), "a frame arrives" means its burst's
    /// window ended.)
    ///
    /// Unlike [`run_for`](Self::run_for), which always runs for the whole time asked, it returns
    /// as soon as something arrived, so a loop around it sees a finished request at once on a
    /// real clock (on a virtual clock, time advances by at most `limit`). When another thread is
    /// driving, it waits for that thread's next step instead (at most `limit`) and returns
    /// `false`. Blocking: async code awaits the requests instead.
    pub fn run_step(&self, limit: impl Into<Duration>) -> Result<bool, Error> {
        self.shared.run_step(limit)
    }

    /// Starts the background driver on the current tokio runtime (its blocking pool: the
    /// transport's receive blocks; on a virtual-clock bus, a task that keeps the bus at
    /// tokio's time instead, see [`crate::asynch`]). Does nothing when one runs already.
    /// Panics outside a tokio runtime, as `tokio::task::spawn_blocking` does.
    #[cfg(feature = "tokio")]
    pub fn start_driver_on_runtime(&self) {
        self.shared.start_driver_on_runtime()
    }
}
