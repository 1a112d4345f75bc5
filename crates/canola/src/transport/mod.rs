//! The transport boundary: one small trait every bus implementation fulfils.
//!
//! A transport moves classic CAN frames (ISO 11898-1) and reports the state of the bus as
//! [`BusEvent`]s in the same receive stream, so nothing that happens on the wire is silent:
//! error frames, bus-off, the interface going down or up, and frames the receive queue had to
//! drop. The transport also owns the clock the [`Network`](crate::Network) and the simulator run
//! on: a real monotonic clock for SocketCAN, a virtual one for the deterministic in-memory bus.
//!
//! The shape is blocking with an absolute deadline ([`Transport::recv_until`]). That is what both
//! the blocking API and the async API need: on a real clock the async API drives the same loop
//! from a blocking worker thread (tokio's `spawn_blocking`); on a virtual clock
//! ([`Transport::is_virtual`]) a `recv_until` never blocks, so an async task steps the same
//! loop up to tokio's time and sleeps on a tokio timer until [`Transport::next_event`].

//!
//! Files by job: `contract` (the trait and its types), [`mem`] (the in-memory bus),
//! [`candump`] (can-utils log files), `socketcan` and `udp` (`socketcan` feature, Linux),
//! `slcan` (`slcan` feature: serial-line adapters on every system), [`spec`] (the bus names
//! users type, parsed and opened with hints on failure).

pub mod candump;
pub(crate) mod contract;
pub mod mem;
#[cfg(feature = "slcan")]
pub mod slcan;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;
pub mod spec;
#[cfg(test)]
mod tests;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod udp;

pub use contract::{
    BusEvent, Received, RxCoalescing, Station, Transport, TransportError, TransportWaker,
    run_station,
};
pub use spec::{BusSpec, OpenError, OpenErrorKind};
