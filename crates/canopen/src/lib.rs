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
mod core;
pub mod error;
pub mod lss;
pub mod mem;
pub mod network;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;
pub mod transport;

pub use crate::core::{CANCEL_ABORT, Completion, Entry, NetworkEvent, RequestId, TransferProgress};
pub use error::{Error, SdoError, SdoErrorKind, describe_abort};
pub use mem::{BusConfig, ClockMode, Endpoint, Faults, MemoryBus};
pub use network::{Network, Nmt, Node, Pending, Sdo, SdoValue};
pub use transport::{BusEvent, Received, Station, Transport, TransportError, run_station};
#[cfg(feature = "tokio")]
pub mod asynch;
pub mod sim;
pub use crate::core::ProgressFn;
pub use lss::{Lss, LssOutcome};
pub use sim::{DeviceHook, HookActions, SimDevice, Values};
