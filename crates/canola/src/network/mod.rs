//! [`Network`]: one transport, one clock, one core of protocol machines, and
//! the blocking API on top.
//!
//! Driving: whoever waits drives. A blocking call submits its request to the core, then loops:
//! if its result is there it returns; otherwise, if no other thread is driving, it takes the
//! transport and runs one step (send what the core produced, receive until the core's next
//! deadline or a short slice, feed the core, fire due timers); else it waits for the driving
//! thread to make progress. So one thread alone is deterministic on a virtual-clock bus, and
//! several threads share one transport safely. A request submitted while another thread waits
//! on the transport ends that wait through the transport's waker
//! ([`Transport::waker`](crate::Transport::waker), where it has one), so it leaves at once. Requests to different nodes progress together
//! whichever of them is being waited on; requests to one node run in submission order.
//!
//! A step reads the transport's clock once, at its start, and stamps what it sends with that
//! reading ([`Transport::send_at`](crate::Transport::send_at)); on a real clock a short step (one frame handled) passes
//! its last reading on to the next few (see `MAX_REUSED_READINGS`: a reading costs a good
//! part of an SDO round trip on the in-memory bus). A blocking request is submitted under the
//! core lock its first step takes (`Shared::run` in `driving`).
//!
//! The async API (`tokio` feature, `crate::asynch`) runs the same wait loop on tokio's
//! blocking pool on a real clock, steps it from the task on a virtual clock (whose time then
//! follows tokio's), and cancels the request when the future is dropped.
//!
//! Running by itself: [`Network::start_driver`](crate::Network::start_driver) starts a background driver (a thread; under the
//! `tokio` feature `Network::start_driver_on_runtime` runs it on the caller's runtime's
//! blocking pool) that drives the network whenever nobody else does, so heartbeats, EMCY, PDO
//! events, SYNC and timeouts flow with no call from the application. It steps aside while a
//! thread waits for a request (that thread drives, so a request costs no hand-over between
//! threads), and stops when [`Network::stop_driver`](crate::Network::stop_driver) is called or the last handle to the
//! network is dropped. A transport that fails for good (closed, an operating-system error) ends
//! it: subscribers get
//! [`NetworkEvent::TransportFailed`](crate::NetworkEvent::TransportFailed) and [`Network::stop_driver`](crate::Network::stop_driver) returns the error.
//!
//! The explicit stepping mode stays for deterministic tests: without a driver nothing happens
//! between calls, and [`Network::run_for`](crate::Network::run_for) advances a virtual-clock bus by exactly the time
//! asked. A driver thread on a virtual-clock bus would run simulated time as fast as the CPU
//! allows; use it on SocketCAN or a [`ClockMode::RealTime`](crate::transport::mem::ClockMode::RealTime)
//! bus. (Under the `tokio` feature, `start_driver_on_runtime` on a virtual-clock bus is a task
//! that keeps the bus at tokio's time instead.)
//!
//! One name per part: the *core* (`crate::machine::Core`, the sans-IO protocol machines), the
//! *shared state* (`Shared`: the core, the transport and its clock, the background driver's
//! slot, behind one `Arc`), the *driver* (the background thread or tokio task that steps the
//! network when nobody waits), and [`Network`], the one public handle over the shared state.
//!
//! Files by job, from the bottom up (no file imports one after it): `shared` (the shared
//! state), `driving` (the step, the blocking wait loop, the background driver thread),
//! `tokio_driving` (the async waits and the tokio driver task, over `driving`'s step),
//! `operation` ([`Operation`], [`join_all`] and the waiting primitives), `handle` ([`Network`]
//! and its calls on the shared state: opening a bus, clock, subscriptions, SYNC, raw frames,
//! running), `request` ([`Sdo`], [`Pending`], [`SdoValue`]), `node` ([`Node`], [`Nmt`]; every
//! handle a node makes, and `impl Network` for making nodes). Each service module above adds
//! its own `impl Network` block for the handle it makes (`crate::lss`, `crate::scan`, the event
//! stream), so `handle` names none of them.

pub(crate) mod driving;
pub(crate) mod handle;
pub(crate) mod node;
pub(crate) mod operation;
pub(crate) mod request;
pub(crate) mod shared;
#[cfg(feature = "tokio")]
pub(crate) mod tokio_driving;

pub use handle::Network;
pub use node::{Nmt, Node, ParameterGroup};
pub use operation::{Operation, join_all, wait_all_with};
pub use request::DEFAULT_SDO_TIMEOUT;
pub use request::{Pending, Sdo, SdoValue};
