//! The async API (`tokio` feature): every blocking operation of the facade as a future, and
//! the network's events as a [`Stream`](futures_core::Stream).
//!
//! | blocking | async |
//! |---|---|
//! | [`Sdo::read`], [`Sdo::write`] | [`Sdo::read_async`], [`Sdo::write_async`] |
//! | [`Sdo::get`], [`Sdo::set`] (by name, typed) | [`Sdo::get_async`], [`Sdo::set_async`] |
//! | [`Sdo::read_value`], [`Sdo::read_as`] | [`Sdo::read_value_async`], [`Sdo::read_as_async`] |
//! | [`Sdo::read_entry`], [`Sdo::write_entry`] | [`Sdo::read_entry_async`], [`Sdo::write_entry_async`] |
//! | [`Sdo::upload_to`], [`Sdo::download_from`] | [`Sdo::upload_to_async`], [`Sdo::download_from_async`] |
//! | [`Pending::wait`] | [`Pending::wait_async`] |
//! | [`Nmt::start`], `stop`, `enter_preoperational`, `reset_node`, `reset_communication` | [`Nmt::start_async`], … |
//! | [`Nmt::wait_for_bootup`], [`Nmt::wait_for_state`] | [`Nmt::wait_for_bootup_async`], [`Nmt::wait_for_state_async`] |
//! | [`Network::nmt_all`], [`Network::send`] | [`Network::nmt_all_async`], [`Network::send_async`] |
//! | [`Network::run_for`] | [`Network::run_for_async`] |
//! | [`Network::scan`] | [`Network::scan_async`] |
//! | [`Lss::procedure`] (switch, configure, inquire, store), [`Lss::procedure_with`] | [`Lss::procedure_async`], [`Lss::procedure_with_async`] |
//! | [`Lss::fastscan`], [`Lss::discover_all`], [`Lss::assign_all`] | [`Lss::fastscan_async`], [`Lss::discover_all_async`], [`Lss::assign_all_async`] |
//! | [`Tpdos::read`](crate::Tpdos::read), [`Tpdos::save`](crate::Tpdos::save), [`Rpdos::read`](crate::Rpdos::read), [`Rpdos::save`](crate::Rpdos::save) | [`Tpdos::read_async`](crate::Tpdos::read_async), [`Tpdos::save_async`](crate::Tpdos::save_async), [`Rpdos::read_async`](crate::Rpdos::read_async), [`Rpdos::save_async`](crate::Rpdos::save_async) |
//! | [`Rpdos::start`](crate::Rpdos::start), [`RpdoSender::set`](crate::RpdoSender::set), `set_many`, `trigger` | [`Rpdos::start_async`](crate::Rpdos::start_async), [`RpdoSender::set_async`](crate::RpdoSender::set_async), `set_many_async`, `trigger_async` |
//! | [`Network::subscribe`] (mpsc) | [`Network::events`] ([`EventStream`]) |
//! | [`PdoSubscriber::recv`](crate::PdoSubscriber::recv) | [`PdoSubscriber::recv_async`](crate::PdoSubscriber::recv_async) |
//!
//! There is one core and no second protocol implementation: a future submits its request to
//! the core as the blocking call does, then waits for it.
//!
//! **Cancel by drop.** Dropping an SDO future (or a scan) cancels its requests: a queued one is
//! removed, a running transfer is aborted on the bus (0x08000000) and the node is free for the
//! next request at once; late responses to it are ignored. Dropping a wait ends the wait.
//! An NMT command or a frame is sent once the future is first polled. LSS has no abort: a
//! dropped LSS future's service runs to its end in the core (driven by whoever drives next)
//! and its result is discarded.
//!
//! **Clocks.** How a future waits depends on the transport's clock:
//! * A real clock (SocketCAN, UDP, a [`ClockMode::RealTime`](crate::transport::mem::ClockMode::RealTime)
//!   memory bus): the blocking wait loop runs on tokio's blocking pool, and bus time is real
//!   time, as tokio's timers are. A paused tokio clock (`start_paused`) does not move such a
//!   bus, and tokio does not auto-advance while the blocking wait runs: use a virtual bus for
//!   paused-clock tests.
//! * A virtual clock (the default [`MemoryBus`](crate::MemoryBus)): the future drives the bus
//!   on its task, and **virtual time follows tokio's clock**. On a normal runtime that is real
//!   time (a 1 s SDO timeout takes 1 s); under a paused clock tokio jumps to the earliest timer
//!   whenever every task is idle, so a test runs in microseconds and stays deterministic. Either
//!   way `tokio::time::timeout(50 ms, sdo.read_async(..))` fires after 50 ms of that clock,
//!   before a 10 s SDO timeout, and the dropped read sends its abort. The blocking and
//!   stepping calls ([`Network::run_for`], a blocking read) still jump virtual time as before;
//!   time never runs backwards, the async side follows tokio from where they left it. Nothing
//!   moves a virtual bus while no future waits: for events to flow meanwhile, start the driver
//!   with [`Network::start_driver_on_runtime`] (on a virtual bus, a task that keeps the bus at
//!   tokio's time and ends with the network) or run [`Network::run_for_async`] in a task.
//!
//! See [`events`] for the event stream.
//!
//! A test on the virtual bus under a paused tokio clock: runs in microseconds, and the timeout
//! fires after 50 ms of the one clock, long before the read's 1 s SDO timeout.
//!
//! ```
//! use canola::{Duration, MemoryBus, Network, NetworkEvent, NmtState, NodeId, SimDevice};
//!
//! #[tokio::main(flavor = "current_thread", start_paused = true)]
//! async fn main() -> Result<(), Box<dyn std::error::Error>> {
//!     let eds = include_bytes!("../../../../eds/burkert-generic.eds");
//!     let bus = MemoryBus::new(); // virtual clock: follows tokio's
//!     let net = Network::new(bus.endpoint());
//!     let mut events = net.events();
//!     let id = NodeId::new(5)?;
//!     bus.attach(SimDevice::from_eds(id, &eds[..])?);
//!     let nmt = net.node(id).nmt();
//!     nmt.start_async().await?;
//!     nmt.wait_for_state_async(NmtState::Operational, Duration::from_secs(1)).await?;
//!     let heartbeat = net.node(id).sdo().read_async((0x1017, 0)).await?;
//!     assert_eq!(heartbeat, 500u16.to_le_bytes());
//!
//!     let t0 = tokio::time::Instant::now();
//!     let absent = net.node(NodeId::new(9)?).sdo().read_async((0x1000, 0));
//!     let r = tokio::time::timeout(std::time::Duration::from_millis(50), absent).await;
//!     assert!(r.is_err()); // and node 9 was sent an SDO abort
//!     assert_eq!(t0.elapsed(), std::time::Duration::from_millis(50));
//!
//!     while let Some(Ok(event)) = events.try_next() {
//!         if let NetworkEvent::Heartbeat(e) = event {
//!             println!("{e:?}");
//!         }
//!     }
//!     Ok(())
//! }
//! ```

pub(crate) mod drive;
pub mod events;

pub use events::{DEFAULT_EVENT_CAPACITY, EventStream, Lagged};

use canola_frame::{CanFrame, Duration, Instant, NodeId};
use canola_lss::{
    AssignAll, AssignConfig, AssignReport, DiscoverAll, Fastscan, FastscanConfig, LssAddress,
    LssError, LssMachine, LssMaster, MasterConfig, Procedure, ServiceReport,
};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget};
use canola_od::{DataType, ObjectAddress, Value};

use crate::error::{Error, SdoError, SdoErrorKind, TransportFailure};
use crate::lss::Lss;
use crate::machine::lss::LssOutput;
use crate::machine::{Completion, DownSource, Op, RequestId, Taken, UpSink};
use crate::network::{Network, Nmt, Pending, Sdo, SdoValue};
use crate::scan::{Identity, ScannedNode};
use crate::typed::{ObjectKey, WriteValue};

/// Cancels requests when dropped unless disarmed.
struct CancelGuard {
    net: Network,
    ids: Vec<RequestId>,
}

impl Drop for CancelGuard {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            self.net.cancel(id);
        }
    }
}

/// What one request is, for naming its errors.
#[derive(Clone, Copy)]
struct Req {
    id: RequestId,
    node: NodeId,
    entry: ObjectAddress,
}

/// Takes the requests out of `pending` (their drop no longer cancels them; the guard in
/// [`wait_requests`] does).
/// What a kind of request takes from its completion.
type Output<T> = fn(Completion) -> T;

fn take_request<T>(mut pending: Pending<T>) -> Result<(Req, Output<T>), SdoError> {
    match pending.id.take() {
        Some(id) => Ok((
            Req {
                id,
                node: pending.node,
                entry: pending.entry,
            },
            pending.output,
        )),
        None => Err(pending.cancelled()),
    }
}

/// Waits for every request in `reqs`; dropping the future cancels those still running.
async fn wait_requests(net: &Network, reqs: Vec<Req>) -> Vec<Result<Completion, SdoError>> {
    let mut guard = CancelGuard {
        net: net.clone(),
        ids: reqs.iter().map(|r| r.id).collect(),
    };
    let n = reqs.len();
    let mut results: Vec<Option<Result<Completion, SdoError>>> = vec![None; n];
    let mut left = n;
    let list = reqs.clone();
    let r = drive::wait_until(net, None, move |c| {
        for (slot, req) in results.iter_mut().zip(&list) {
            if slot.is_some() {
                continue;
            }
            let r = match c.take_result(req.id) {
                Taken::Running => continue,
                Taken::Done(r) => r.map_err(|e| c.name_error(*e)),
                Taken::Unknown => Err(c.name_error(SdoError {
                    node: req.node,
                    entry: req.entry,
                    name: None,
                    kind: SdoErrorKind::Cancelled,
                })),
            };
            *slot = Some(r);
            left -= 1;
        }
        (left == 0).then(|| std::mem::take(&mut results).into_iter().flatten().collect())
    })
    .await;
    guard.ids.clear();
    match r {
        Ok(v) => v,
        Err(e) => {
            // A transport failure ends the requests: say which node and object each was for.
            let failure = TransportFailure::from(&e);
            let mut core = net.core();
            reqs.iter()
                .map(|req| {
                    core.cancel(req.id);
                    Err(core.name_error(SdoError {
                        node: req.node,
                        entry: req.entry,
                        name: None,
                        kind: SdoErrorKind::Transport(failure.clone()),
                    }))
                })
                .collect()
        }
    }
}

async fn wait_pending<T>(pending: Pending<T>) -> Result<T, SdoError> {
    let net = pending.net.clone();
    let (req, output) = take_request(pending)?;
    let mut r = wait_requests(&net, vec![req]).await;
    match r.pop() {
        Some(r) => r.map(output),
        None => Err(SdoError {
            node: req.node,
            entry: req.entry,
            name: None,
            kind: SdoErrorKind::Cancelled,
        }),
    }
}

impl<T> Pending<T> {
    /// Waits for the request without blocking the async runtime. Dropping the future cancels
    /// it.
    pub async fn wait_async(self) -> Result<T, SdoError> {
        wait_pending(self).await
    }
}

impl Sdo {
    /// Reads an object's bytes (async [`read`](Self::read)). Dropping the future cancels the
    /// transfer.
    pub async fn read_async(self, entry: impl Into<ObjectAddress>) -> Result<Vec<u8>, Error> {
        drive::catch_up(&self.net)?;
        Ok(wait_pending(self.submit_read(entry)).await?)
    }

    /// Writes an object (async [`write`](Self::write)). Dropping the future cancels the
    /// transfer.
    pub async fn write_async(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Result<(), Error> {
        drive::catch_up(&self.net)?;
        Ok(wait_pending(self.submit_write(entry, value)).await?)
    }

    /// Uploads an object into `writer`, streaming as segments arrive, and flushes it at the end
    /// (async [`upload_to`](Self::upload_to)). Returns the byte count; a failing write or flush
    /// is an error. The writer is called from whatever drives the network (this task on a
    /// virtual clock, tokio's blocking pool on a real one).
    pub async fn upload_to_async(
        self,
        entry: impl Into<ObjectAddress>,
        writer: impl std::io::Write + Send + 'static,
    ) -> Result<u64, Error> {
        drive::catch_up(&self.net)?;
        let sink = UpSink::Stream {
            w: Box::new(writer),
            written: 0,
            error: None,
        };
        let pending = self.request(entry.into(), Op::Upload(sink), |c| c.transferred);
        Ok(wait_pending(pending).await?)
    }

    /// Downloads `data` into an object (async [`download_from`](Self::download_from), with the
    /// bytes read already: reading a file is the caller's, with tokio's file API or
    /// `spawn_blocking`). Returns the byte count.
    pub async fn download_from_async(
        self,
        entry: impl Into<ObjectAddress>,
        data: Vec<u8>,
    ) -> Result<u64, Error> {
        drive::catch_up(&self.net)?;
        let pending = self.request(entry.into(), Op::Download(DownSource(data)), |c| {
            c.transferred
        });
        Ok(wait_pending(pending).await?)
    }

    /// Reads an object by name or address, decoded with its dictionary type (async
    /// [`get`](Self::get)).
    pub async fn get_async<'k>(self, key: impl Into<ObjectKey<'k>>) -> Result<Value, Error> {
        let at = self.resolve(key)?;
        self.read_value_async(at).await
    }

    /// Writes an object by name or address, converted to its dictionary type first (async
    /// [`set`](Self::set)): a value that does not fit is an error before anything is sent.
    pub async fn set_async<'k>(
        self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(), Error> {
        let (at, typed) = self.typed_write(key, value)?;
        self.write_async(at, typed).await
    }

    /// Reads an object and decodes it with the type from the node's dictionary (async
    /// [`read_value`](Self::read_value)).
    pub async fn read_value_async(self, entry: impl Into<ObjectAddress>) -> Result<Value, Error> {
        let entry = entry.into();
        let node = self.node;
        let data_type = self
            .net
            .core()
            .dictionary(node)
            .and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type));
        match data_type {
            Some(t) => self.read_as_async(entry, t).await,
            None => Err(Error::Value {
                node,
                entry,
                message: "the node's dictionary does not describe this object".into(),
            }),
        }
    }

    /// Reads an object and decodes it as `data_type` (async [`read_as`](Self::read_as)).
    pub async fn read_as_async(
        self,
        entry: impl Into<ObjectAddress>,
        data_type: DataType,
    ) -> Result<Value, Error> {
        let entry = entry.into();
        let node = self.node;
        drive::catch_up(&self.net)?;
        let upload = wait_pending(self.submit_read_upload(entry)).await?;
        upload.decode(node, entry, data_type)
    }

    /// Reads a typed entry from generated code (async [`read_entry`](Self::read_entry)).
    pub async fn read_entry_async<T: canola_od::EntryValue>(
        self,
        entry: &canola_od::Entry<T>,
    ) -> Result<T, Error> {
        let at = ObjectAddress::new(entry.index(), entry.sub_index());
        let node = self.node;
        drive::catch_up(&self.net)?;
        let upload = wait_pending(self.submit_read_upload(at)).await?;
        crate::network::request::decode_entry(node, entry, &upload)
    }

    /// Writes a typed entry from generated code (async [`write_entry`](Self::write_entry)).
    pub async fn write_entry_async<T: canola_od::EntryValue>(
        self,
        entry: &canola_od::Entry<T>,
        value: &T,
    ) -> Result<(), Error> {
        let (at, bytes) = crate::network::request::encode_entry(self.node, entry, value)?;
        self.write_async(at, bytes).await
    }
}

impl Nmt {
    async fn send_async(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        drive::catch_up(&self.net)?;
        {
            self.net.core().nmt(cmd, self.target);
        }
        drive::flush(&self.net).await
    }

    fn node_id(&self) -> Result<NodeId, Error> {
        match self.target {
            NmtTarget::Node(id) => Ok(id),
            _ => Err(Error::InvalidRequest(
                "node states are per node: use node.nmt(), not Nmt::all".into(),
            )),
        }
    }

    /// Start remote node (async [`start`](Self::start)).
    pub async fn start_async(&self) -> Result<(), Error> {
        self.send_async(CommandSpecifier::Start).await
    }
    /// Stop remote node (async [`stop`](Self::stop)).
    pub async fn stop_async(&self) -> Result<(), Error> {
        self.send_async(CommandSpecifier::Stop).await
    }
    /// Enter Pre-Operational (async [`enter_preoperational`](Self::enter_preoperational)).
    pub async fn enter_preoperational_async(&self) -> Result<(), Error> {
        self.send_async(CommandSpecifier::EnterPreOperational).await
    }
    /// Reset node (async [`reset_node`](Self::reset_node)).
    pub async fn reset_node_async(&self) -> Result<(), Error> {
        self.send_async(CommandSpecifier::ResetNode).await
    }
    /// Reset communication (async [`reset_communication`](Self::reset_communication)).
    pub async fn reset_communication_async(&self) -> Result<(), Error> {
        self.send_async(CommandSpecifier::ResetCommunication).await
    }

    /// Waits for a boot-up of the node not accounted for yet, and accounts for it (async
    /// [`wait_for_bootup`](Self::wait_for_bootup): boot-ups are counted per node, so one that
    /// arrived before this handle was made, or followed at once by a heartbeat, is not
    /// missed). Times out after `timeout` on the network's clock.
    pub async fn wait_for_bootup_async(&self, timeout: impl Into<Duration>) -> Result<(), Error> {
        let timeout: Duration = timeout.into();
        let node = self.node_id()?;
        drive::catch_up(&self.net)?;
        let deadline = self.net.now() + timeout;
        drive::wait_until(&self.net, Some(deadline), move |c| {
            let boots = c.boot_count(node);
            if boots > c.boots_taken(node) {
                c.take_boots(node, boots);
                Some(Ok(()))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "no boot-up from node {node} within {timeout}"
                ))))
            } else {
                None
            }
        })
        .await?
    }

    /// Waits until the node reports `state`; returns at once if it is in it already (async
    /// [`wait_for_state`](Self::wait_for_state)). Times out after `timeout` on the network's
    /// clock.
    pub async fn wait_for_state_async(
        &self,
        state: NmtState,
        timeout: impl Into<Duration>,
    ) -> Result<(), Error> {
        let timeout: Duration = timeout.into();
        let node = self.node_id()?;
        drive::catch_up(&self.net)?;
        let deadline = self.net.now() + timeout;
        drive::wait_until(&self.net, Some(deadline), move |c| {
            if c.last_state(node) == Some(state) {
                Some(Ok(()))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "node {node} not {state} within {timeout}"
                ))))
            } else {
                None
            }
        })
        .await?
    }
}

fn u32_of(bytes: &[u8]) -> Option<u32> {
    bytes
        .get(..4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

impl Network {
    /// Sends an NMT command to every node (async [`nmt_all`](Self::nmt_all)).
    pub async fn nmt_all_async(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        drive::catch_up(self)?;
        self.core().nmt(cmd, NmtTarget::All);
        drive::flush(self).await
    }

    /// Sends a raw frame (async [`send`](Self::send)).
    pub async fn send_async(&self, frame: CanFrame) -> Result<(), Error> {
        drive::catch_up(self)?;
        self.core().send_raw(frame);
        drive::flush(self).await
    }

    /// Drives the network for `d` on its clock (async [`run_for`](Self::run_for)): heartbeats,
    /// EMCY, PDO events and timers flow meanwhile. On a virtual-clock bus `d` passes on tokio's
    /// clock (see the module docs); run it in a task to keep such a bus going while other
    /// futures wait on events.
    pub async fn run_for_async(&self, d: impl Into<Duration>) -> Result<(), Error> {
        let d: Duration = d.into();
        drive::catch_up(self)?;
        let until = self.now() + d;
        self.run_until_async(until).await
    }

    /// Drives the network until `until` on its clock (async [`run_until`](Self::run_until)).
    pub async fn run_until_async(&self, until: Instant) -> Result<(), Error> {
        drive::wait_until(self, Some(until), move |c| (c.now() >= until).then_some(())).await
    }

    /// The nodes that answer an SDO read of 0x1018:01 within `timeout`, with their identity
    /// (async [`scan`](Self::scan)). All reads run at once; dropping the future cancels them.
    pub async fn scan_async(
        &self,
        timeout: impl Into<Duration>,
    ) -> Result<Vec<ScannedNode>, Error> {
        let timeout: Duration = timeout.into();
        drive::catch_up(self)?;
        let first: Vec<Req> = NodeId::all()
            .filter_map(|n| {
                take_request(self.node(n).sdo().timeout(timeout).submit_read((0x1018, 1)))
                    .ok()
                    .map(|(r, _)| r)
            })
            .collect();
        let found: Vec<(NodeId, u32)> = wait_requests(self, first.clone())
            .await
            .into_iter()
            .zip(&first)
            .filter_map(|(r, req)| Some((req.node, u32_of(&r.ok()?.data)?)))
            .collect();
        let rest: Vec<Req> = found
            .iter()
            .flat_map(|&(node, _)| {
                (2..=4u8).filter_map(move |s| {
                    take_request(
                        self.node(node)
                            .sdo()
                            .timeout(timeout)
                            .submit_read((0x1018, s)),
                    )
                    .ok()
                    .map(|(r, _)| r)
                })
            })
            .collect();
        let mut values = wait_requests(self, rest)
            .await
            .into_iter()
            .map(|r| r.ok().as_ref().and_then(|c| u32_of(&c.data)));
        let mut next = || values.next().flatten();
        Ok(found
            .into_iter()
            .map(|(node, vendor_id)| ScannedNode {
                node,
                identity: Identity {
                    vendor_id,
                    product_code: next(),
                    revision: next(),
                    serial: next(),
                },
            })
            .collect())
    }

    /// Whether the network's transport runs on a virtual clock, which the async API ties to
    /// tokio's (see the module docs).
    pub fn is_virtual_clock(&self) -> bool {
        drive::is_virtual(self)
    }
}

impl Lss {
    /// The async driver of every LSS service: starts `machine`, waits for its result, flushes
    /// its last frames.
    async fn run_async<M>(
        &self,
        mut machine: M,
        start: impl FnOnce(&mut M, Instant) -> Result<(), LssError>,
    ) -> Result<<M::Output as LssOutput>::Value, Error>
    where
        M: LssMachine + crate::machine::lss::HearsNodeIds + Send + 'static,
        M::Output: LssOutput,
    {
        drive::catch_up(&self.net)?;
        let now = self.net.now();
        start(&mut machine, now).map_err(Error::Lss)?;
        self.net.core().start_lss(Box::new(machine));
        let result = drive::wait_until(&self.net, None, |c| c.take_lss_result()).await?;
        drive::flush(&self.net).await?;
        let outcome = result.map_err(Error::Lss)?;
        M::Output::from_outcome(outcome).ok_or(Error::Lss(LssError::Busy))
    }

    /// Runs a procedure of LSS services: switch, configure node-ID or bit timing, store,
    /// inquire (async [`procedure`](Self::procedure)).
    pub async fn procedure_async(&self, procedure: Procedure) -> Result<ServiceReport, Error> {
        self.procedure_with_async(MasterConfig::default(), procedure)
            .await
    }

    /// [`procedure_async`](Self::procedure_async) with other response timeouts.
    pub async fn procedure_with_async(
        &self,
        config: MasterConfig,
        procedure: Procedure,
    ) -> Result<ServiceReport, Error> {
        self.run_async(LssMaster::new(config), |m, now| m.start(now, procedure))
            .await
    }

    /// Fastscan: finds one unconfigured slave and leaves it in configuration state (async
    /// [`fastscan`](Self::fastscan)).
    pub async fn fastscan_async(
        &self,
        config: FastscanConfig,
    ) -> Result<Option<LssAddress>, Error> {
        self.run_async(Fastscan::new(config), |m, now| m.start(now))
            .await
    }

    /// Finds every unconfigured slave (async [`discover_all`](Self::discover_all)).
    pub async fn discover_all_async(
        &self,
        config: FastscanConfig,
    ) -> Result<Vec<LssAddress>, Error> {
        self.run_async(DiscoverAll::new(config), |m, now| m.start(now))
            .await
    }

    /// The commissioning workflow: every unconfigured slave found and given a node-ID, none
    /// in use on the bus (async [`assign_all`](Self::assign_all)).
    pub async fn assign_all_async(&self, mut config: AssignConfig) -> Result<AssignReport, Error> {
        let candidates = Self::candidates(&config);
        let found = self
            .nodes_in_use_async(candidates, config.services.response_timeout)
            .await?;
        for id in found.iter() {
            config.in_use.insert(id);
        }
        let in_use = config.in_use;
        let mut report = self
            .run_async(AssignAll::new(config), |m, now| m.start(now))
            .await?;
        crate::lss::list_conflicts(&mut report, candidates, in_use);
        Ok(report)
    }

    /// The node-IDs of `candidates` in use on the bus (async
    /// [`nodes_in_use`](Self::nodes_in_use)).
    pub async fn nodes_in_use_async(
        &self,
        candidates: canola_lss::NodeIdPool,
        timeout: impl Into<Duration>,
    ) -> Result<canola_lss::NodeIdPool, Error> {
        drive::catch_up(&self.net)?;
        let (mut in_use, pending) = self.probe(candidates, timeout.into());
        for (id, p) in pending {
            if crate::lss::answered(p.wait_async().await)? || self.heard(id) {
                in_use.insert(id);
            }
        }
        Ok(in_use)
    }
}
