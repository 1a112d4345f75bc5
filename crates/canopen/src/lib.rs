//! CANopen master facade: the layer that turns the sans-IO protocol crates into a library an
//! application uses, plus the transports and the device simulator.
//!
//! Layers, bottom up:
//! * [`transport`]: one small [`Transport`] trait (blocking send and receive-until-deadline, the
//!   transport's clock, bus-state [`BusEvent`]s); implementations are the in-memory bus
//!   ([`mem`]) and SocketCAN (`socketcan` feature, Linux).
//! * [`candump`]: the can-utils log format for recording and replaying traffic.
#![cfg_attr(docsrs, feature(doc_auto_cfg))]

pub mod candump;
pub mod mem;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;
pub mod transport;

pub use mem::{BusConfig, ClockMode, Endpoint, Faults, MemoryBus};
pub use transport::{BusEvent, Received, Station, Transport, TransportError, run_station};
