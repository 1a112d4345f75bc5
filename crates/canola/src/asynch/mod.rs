//! The async side (`tokio` feature): every [`Operation`] of the facade awaited, a pending SDO
//! request ([`Pending`]) awaited, and the network's events as a
//! [`Stream`](futures_core::Stream).
//!
//! There is no second API: `node.sdo().read(entry)` returns one [`Operation`], finished with
//! `.wait()` in blocking code and with `.await` here; calls that never wait (NMT commands,
//! [`Network::send`](crate::Network::send), [`RpdoSender::set`](crate::RpdoSender::set)) are the same plain calls in
//! both. The network's events: [`Network::subscribe`](crate::Network::subscribe) (a blocking channel) or
//! [`Network::events`] (an [`EventStream`]); PDO batches: [`PdoSubscriber`](crate::PdoSubscriber).
//!
//! **Cancel by drop.** Dropping an SDO operation's future (or a scan's) cancels its requests: a
//! queued one is removed, a running transfer is aborted on the bus (0x08000000) and the node is
//! free for the next request at once; late responses to it are ignored. Dropping a wait ends
//! the wait. LSS has no abort: a dropped LSS operation's service runs to its end in the core
//! (driven by whoever drives next) and its result is discarded.
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
//!   way `tokio::time::timeout(50 ms, sdo.read(..))` fires after 50 ms of that clock,
//!   before a 10 s SDO timeout, and the dropped read sends its abort. The blocking and
//!   stepping calls ([`Network::run_for`](crate::Network::run_for), a blocking read) still jump virtual time as before;
//!   time never runs backwards, the async side follows tokio from where they left it. Nothing
//!   moves a virtual bus while no future waits: for events to flow meanwhile, start the driver
//!   with [`Network::start_driver_on_runtime`](crate::Network::start_driver_on_runtime) (on a virtual bus, a task that keeps the bus at
//!   tokio's time and ends with the network) or await [`Network::run_for`](crate::Network::run_for) in a task.
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
//!     nmt.start()?;
//!     nmt.wait_for_state(NmtState::Operational, Duration::from_secs(1)).await?;
//!     let heartbeat = net.node(id).sdo().read((0x1017, 0)).await?;
//!     assert_eq!(heartbeat, 500u16.to_le_bytes());
//!
//!     let t0 = tokio::time::Instant::now();
//!     let absent = net.node(NodeId::new(9)?).sdo().read((0x1000, 0));
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

pub mod events;

pub use events::{DEFAULT_EVENT_CAPACITY, EventStream, Lagged};

#[cfg(doc)]
use crate::network::{Network, Operation, Pending};
