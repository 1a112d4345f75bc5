//! The names most applications need, in one import: `use canola::prelude::*;`.
//!
//! Everything here is also reachable at the crate root or in the re-exported protocol crates;
//! the prelude only saves the list of `use` lines. Time arguments of the facade take
//! `impl Into<Duration>`, so `std::time::Duration` works wherever a [`Duration`] is asked for.
//!
//! ```
//! use canola::prelude::*;
//! use std::time::Duration as StdDuration;
//!
//! let eds = include_bytes!("../../../eds/burkert-generic.eds");
//! let bus = MemoryBus::new();
//! let net = Network::new(bus.endpoint());
//! let id = NodeId::new(5).unwrap();
//! let node = net.add_node_with_dictionary(id, canola::od::parse(&eds[..]).unwrap().od);
//! bus.attach(SimDevice::from_eds(id, &eds[..]).unwrap());
//! node.nmt().wait_for_bootup(StdDuration::from_secs(1)).wait().unwrap();
//! node.sdo().set("Producer heartbeat time", 250).wait().unwrap();
//! assert_eq!(node.sdo().get("Producer heartbeat time").wait().unwrap(), Value::Unsigned16(250));
//! node.nmt().start().unwrap();
//! node.nmt().wait_for_state(NmtState::Operational, StdDuration::from_secs(1)).wait().unwrap();
//! ```

pub use crate::{
    AbortCode, BusEvent, CanFrame, CanId, DataType, DeviceState, Duration, Error, Identity,
    Instant, MappedVariable, MemoryBus, Network, NetworkEvent, NmtState, Node, NodeId,
    ObjectAddress, ObjectDictionary, PdoParameters, PdoSet, RpdoSender, SdoError, SdoErrorKind,
    SimDevice, Transmission, Transport, TransportError, Value,
};
#[cfg(feature = "tokio")]
pub use crate::{EventStream, Lagged};
