//! What the master machine hands out: request ids, finished transfers and their progress,
//! the [`NetworkEvent`]s of the bus (NMT states, heartbeats, EMCY, SYNC, PDOs) and the types a
//! PDO reception is seen through. Shared by the machine and every layer above it, so they sit
//! at the bottom and import nothing of the crate but its error type.

use canola_frame::{Instant, NodeId};
use canola_nmt::{EmcyEvent, GuardingEvent, HeartbeatEvent};
use canola_od::{ObjectAddress, ObjectDictionary, Value};
use canola_sdo::AbortCode;

use crate::transport::BusEvent;

/// Identifies one SDO request for its whole life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct RequestId(pub(crate) u64);

/// How far a transfer is, for progress bars.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TransferProgress {
    /// The node.
    pub node: NodeId,
    /// The object.
    pub entry: ObjectAddress,
    /// Bytes done.
    pub done: u64,
    /// Total bytes, when known.
    pub total: Option<u64>,
}

/// A progress callback.
pub type ProgressFn = Box<dyn FnMut(TransferProgress) + Send>;

/// What a finished transfer produced: the uploaded bytes (empty for a download and for an
/// upload streamed into a writer) and the number of bytes transferred. Every kind of request
/// ends in the same shape, so each typed [`Pending`](crate::Pending) takes what it needs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Completion {
    pub(crate) data: Vec<u8>,
    pub(crate) transferred: u64,
    /// An expedited upload answered without the size indicated: `data` holds all four bytes,
    /// and a typed read takes its type's length from them.
    pub(crate) unsized_expedited: bool,
}

/// Something that happened on the network, for subscribers.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum NetworkEvent {
    /// A heartbeat consumer event: boot-up, state change, loss, recovery.
    Heartbeat(HeartbeatEvent),
    /// A node guarding event (CiA 301 §7.2.8.3.2.1): boot-up, state change, loss, recovery,
    /// toggle error.
    Guarding(GuardingEvent),
    /// An emergency message.
    Emcy(EmcyEvent),
    /// A transmit PDO from a node that the master does not decode: a node without a
    /// dictionary, a TPDO outside its mapping, or data of another length than the mapping's.
    /// A decoded TPDO comes as [`PdoValues`](Self::PdoValues) instead (one event per frame
    /// either way; [`pdo_data`](Self::pdo_data) reads the bytes of both).
    Pdo {
        /// The producer (from the predefined connection set, or the node configured with the
        /// COB-ID).
        node: NodeId,
        /// TPDO number 1..=512 as the node numbers it (1..=4 in the predefined set).
        number: u8,
        /// The PDO data.
        data: PdoData,
        /// Reception time.
        at: Instant,
    },
    /// A frame from an LSS slave (COB-ID 0x7E4).
    Lss {
        /// The eight data bytes.
        data: [u8; 8],
        /// Reception time.
        at: Instant,
    },
    /// A node's transmit PDO decoded through its dictionary's mapping (nodes added with a
    /// dictionary; see [`Network::add_node_with_dictionary`](crate::Network::add_node_with_dictionary)).
    PdoValues {
        /// The producer.
        node: NodeId,
        /// TPDO number 1..=4.
        number: u8,
        /// The PDO data the values were decoded from.
        data: PdoData,
        /// The mapped objects and their values as the node's dictionary types them
        /// (`Value::Unsigned16` for an UNSIGNED16), in mapping order.
        values: Vec<(ObjectAddress, Value)>,
        /// Reception time.
        at: Instant,
    },
    /// A bus event from the transport.
    Bus(BusEvent),
    /// The transport failed while the background driver drove it; the driver has stopped
    /// (see [`Network::stop_driver`](crate::Network::stop_driver)).
    TransportFailed {
        /// The bus, when the network was opened by name
        /// ([`Network::open`](crate::Network::open)).
        bus: Option<String>,
        /// How the transport failed (an operating-system error with its
        /// [`io::ErrorKind`](std::io::ErrorKind)).
        failure: crate::error::TransportFailure,
    },
}

impl NetworkEvent {
    /// The producer, TPDO number and data bytes of a received PDO, decoded or not.
    pub fn pdo_data(&self) -> Option<(NodeId, u8, &[u8])> {
        match self {
            Self::Pdo {
                node, number, data, ..
            }
            | Self::PdoValues {
                node, number, data, ..
            } => Some((*node, *number, data)),
            _ => None,
        }
    }
}

/// A received PDO as a callback sees it (see [`Network::on_pdo`](crate::Network::on_pdo)):
/// borrowed for the duration of the call, nothing copied or allocated for it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct PdoReceived<'a> {
    /// The producer.
    pub node: NodeId,
    /// TPDO number as the node numbers it.
    pub number: u8,
    /// The PDO data.
    pub data: &'a [u8],
    /// The mapped objects and their values as the node's dictionary types them, in mapping
    /// order; empty when the master does not decode this PDO (see [`NetworkEvent::Pdo`]).
    pub values: &'a [(ObjectAddress, Value)],
    /// Reception time.
    pub at: Instant,
    /// The producer's dictionary, when the node was added with one: how [`get`](Self::get)
    /// finds a value by name.
    pub dictionary: Option<&'a ObjectDictionary>,
}

impl<'a> PdoReceived<'a> {
    /// The value of a mapped object by its name in the producer's dictionary, as
    /// python-canopen names them: `p.get("Sensor Value 1.Value")` (`"object.sub-object"` for
    /// an entry of an ARRAY or RECORD, the object's name for a VAR; any letter case). `None`
    /// when the node has no dictionary, the name is not in it, or this PDO does not map it.
    pub fn get(&self, name: &str) -> Option<&'a Value> {
        let at = self.dictionary?.find(name)?;
        self.value(at)
    }

    /// The value of a mapped object by its address; `None` when this PDO does not map it.
    pub fn value(&self, at: impl Into<ObjectAddress>) -> Option<&'a Value> {
        let at = at.into();
        self.values.iter().find(|(a, _)| *a == at).map(|(_, v)| v)
    }
}

/// Identifies a PDO callback for [`Network::remove_pdo_callback`](crate::Network::remove_pdo_callback).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoCallbackId(pub(super) u64);

pub(super) type PdoCallback = Box<dyn FnMut(&PdoReceived<'_>) + Send>;

/// The data bytes of a received PDO: up to 64 (a CAN FD PDO; eight on a classic bus), kept
/// in place (no allocation per frame). Reads as a byte slice.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoData {
    pub(super) buf: [u8; 64],
    pub(super) len: u8,
}

impl PdoData {
    /// The data of a classic or CAN FD frame (at most 64 bytes; more are cut off).
    pub fn new(data: &[u8]) -> Self {
        let len = data.len().min(64);
        let mut buf = [0; 64];
        // Full classic frames (the usual PDO) as one 8-byte copy, not a copy of a run-time
        // length.
        match <[u8; 8]>::try_from(data) {
            Ok(full) => buf[..8].copy_from_slice(&full),
            Err(_) => buf[..len].copy_from_slice(&data[..len]),
        }
        Self {
            buf,
            len: len as u8,
        }
    }
}

impl core::ops::Deref for PdoData {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.buf[..usize::from(self.len)]
    }
}

impl AsRef<[u8]> for PdoData {
    fn as_ref(&self) -> &[u8] {
        self
    }
}

impl core::fmt::Debug for PdoData {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Debug::fmt(&**self, f)
    }
}

impl PartialEq<[u8]> for PdoData {
    fn eq(&self, other: &[u8]) -> bool {
        **self == *other
    }
}

impl<const N: usize> PartialEq<[u8; N]> for PdoData {
    fn eq(&self, other: &[u8; N]) -> bool {
        **self == other[..]
    }
}

impl PartialEq<Vec<u8>> for PdoData {
    fn eq(&self, other: &Vec<u8>) -> bool {
        **self == other[..]
    }
}

/// A subscriber other than an mpsc channel (the async API's event streams): it takes each
/// event as it is published and says whether it still wants more.
pub(crate) trait EventSink: Send {
    /// Takes one event; `false` when the subscriber is gone (it is then forgotten).
    fn deliver(&self, event: &NetworkEvent) -> bool;
}

/// How many entries the master's tables hold at one moment, for soak tests (none may grow
/// while the traffic stays the same) and diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub struct Occupancy {
    /// Nodes the master knows.
    pub nodes: usize,
    /// SDO client channels over all nodes.
    pub sdo_channels: usize,
    /// Entries of the request table: queued, running, or finished and not yet taken.
    pub requests: usize,
    /// Requests waiting in the channels' queues.
    pub queued_requests: usize,
    /// Frames not yet handed to the transport.
    pub unsent_frames: usize,
    /// Nodes with a boot-up count.
    pub boot_counts: usize,
    /// Event subscribers.
    pub subscribers: usize,
}

/// The abort code sent when a caller cancels a running transfer: "general error" (CiA 301
/// has no dedicated code for a client giving up).
pub const CANCEL_ABORT: AbortCode = AbortCode(0x0800_0000);
