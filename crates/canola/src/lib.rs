//! CANopen master facade: the layer that turns the sans-IO protocol crates into a library an
//! application uses, plus the transports and the device simulator.
//!
//! Layers, bottom up (each imports only from the layers below it):
//! * [`transport`]: one small [`Transport`] trait (blocking send and receive-until-deadline, the
//!   transport's clock, bus-state [`BusEvent`]s); implementations are the in-memory bus
//!   ([`mem`]), SocketCAN and UDP (`socketcan` feature, Linux); [`candump`] is the can-utils
//!   log format for recording and replaying traffic.
//! * `machine` (internal): the sans-IO master machine. It routes received frames by COB-ID to
//!   the per-node machines of the protocol crates (SDO clients, heartbeat and guarding, EMCY
//!   consumer, SYNC producer, the LSS job, the PDO mirrors), keeps the request table and
//!   reports [`NetworkEvent`]s; it knows no thread, transport or clock.
//! * [`network`]: [`Network`] owns one transport, its clock and one machine, and steps them
//!   (whoever waits drives, or the background driver); [`Node`], [`Nmt`], [`Sdo`] and
//!   [`Pending`] are the API on it. Every call that waits on the bus returns an [`Operation`],
//!   written once as async code over a few waiting primitives and finished by
//!   [`Operation::wait`] (blocking) or `.await`; [`join_all`] runs several together on one
//!   thread.
//! * Services over the network: [`lss`] (CiA 305), [`scan`], [`typed`] values, PDOs
//!   ([`Node::tpdo`] / [`Node::rpdo`] read and save a node's PDO parameters, [`Rpdos::start`]
//!   transmits RPDOs through the `canola-pdo` engine; TPDOs arrive decoded as
//!   [`NetworkEvent::PdoValues`], in batches from [`Network::subscribe_pdos`](crate::Network::subscribe_pdos) or to an
//!   [`Network::on_pdo`](crate::Network::on_pdo) callback), [`mod@describe`] (traffic in words).
//! * `asynch` (`tokio` feature): what awaiting an operation means on each clock (a tie between
//!   the network's clock and tokio's lets a virtual-clock bus follow tokio's time), and the
//!   event stream.
//! * [`sim`]: the device simulator, a [`Station`] built from any object dictionary.
//!
//! ```
//! use canola::{MemoryBus, Network, NodeId, SimDevice};
//!
//! let eds = include_bytes!("../../../eds/burkert-generic.eds");
//! let node = NodeId::new(5).unwrap();
//! let bus = MemoryBus::new(); // virtual clock: deterministic
//! let net = Network::new(bus.endpoint());
//! bus.attach(SimDevice::from_eds(node, eds).unwrap());
//! net.node(node).sdo().write((0x1017, 0), 100u16).wait().unwrap();
//! assert_eq!(net.node(node).sdo().read((0x1017, 0)).wait().unwrap(), 100u16.to_le_bytes());
//! net.node(node).nmt().start().unwrap();
//! ```
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(feature = "tokio")]
pub mod asynch;
pub mod describe;
pub mod error;
pub mod lss;
mod machine;
pub mod network;
mod pdo_access;
mod pdo_subscriber;
pub mod prelude;
#[cfg(feature = "tokio")]
mod reactor;
pub mod restricted;
pub mod scan;
pub mod sim;
pub mod transport;
pub mod typed;
pub mod usdo;

// The public names, in one block: the protocol crates (for what the facade does not wrap:
// applications and the CLI need no other dependency than this crate), then the names common
// work needs.
pub use crate::machine::{
    CANCEL_ABORT, NetworkEvent, Occupancy, PdoCallbackId, PdoData, PdoReceived, ProgressFn,
    TransferProgress,
};
#[cfg(feature = "tokio")]
pub use asynch::{EventStream, Lagged};
pub use canola_frame as frame;
pub use canola_frame::{CanFrame, CanId, Duration, Instant, NodeId};
pub use canola_nmt as nmt;
pub use canola_nmt::{CommandSpecifier, DeviceState, HeartbeatEvent, NmtState};
pub use canola_od as od;
pub use canola_od::{DataType, ObjectAddress, ObjectDictionary, Value};
pub use canola_pdo as pdo;
pub use canola_sdo as sdo;
pub use canola_sdo::{AbortCode, Method, SdoCobIds};
pub use describe::{
    BusDictionary, DecodedPdo, Description, FdDescription, Monitor, PdoValue, describe, describe_fd,
};
pub use error::{Error, SdoError, SdoErrorKind, TransportFailure};
pub use lss::{Lss, LssOutcome};
pub use mem::{BusConfig, ClockMode, Endpoint, Faults, MemoryBus};
pub use network::{
    Network, Nmt, Node, Operation, ParameterGroup, Pending, Sdo, SdoValue, join_all, wait_all_with,
};
pub use pdo_access::{
    DamSender, MappedVariable, Mpdos, PdoParameters, PdoSet, RpdoSender, Rpdos, Tpdos, Transmission,
};
pub use pdo_subscriber::{PdoBatch, PdoBatchIter, PdoSubscriber, Recv};
pub use restricted::restricted_cob_id;
pub use scan::{Identity, ScannedNode};
pub use sim::{DeviceHook, HookActions, SimDevice, Values};
#[cfg(feature = "slcan")]
pub use transport::slcan;
pub use transport::{
    BusEvent, BusSpec, OpenError, OpenErrorKind, Received, RxCoalescing, Station, Transport,
    TransportError, TransportWaker, run_station,
};
pub use transport::{candump, mem};
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub use transport::{socketcan, udp};
pub use typed::{ObjectKey, WriteValue};
pub use usdo::Usdo;

/// Moves every element of `from` to the back of `to`, in order. Mostly `to` is empty (the
/// queues between the core, the network and the in-memory bus are drained at every step):
/// then the two trade buffers, and no element is copied.
#[inline]
pub(crate) fn move_all<T>(
    from: &mut std::collections::VecDeque<T>,
    to: &mut std::collections::VecDeque<T>,
) {
    if to.is_empty() {
        std::mem::swap(from, to);
    } else {
        to.extend(from.drain(..));
    }
}

/// The README's code, compiled and run as doctests (its "Use as a library" program).
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
mod readme {}

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}
