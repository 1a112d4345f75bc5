//! CANopen FD in the master: [`Usdo`], a node's universal SDO (CiA 1301) as `node.usdo()`,
//! the node's CAN FD mark, and the network's CAN FD frames ([`Network::send_fd`],
//! [`Network::open_fd`]).
//!
//! ```
//! use canola::{BusConfig, MemoryBus, Network, NodeId, SimDevice};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let eds = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds"));
//! // A bus that carries CAN FD, and a simulated CANopen FD device on it.
//! let bus = MemoryBus::with_config(BusConfig { fd: true, ..BusConfig::default() });
//! bus.attach(SimDevice::from_eds(NodeId::new(5)?, &eds[..])?.with_fd(true));
//! let net = Network::new(bus.endpoint());
//! let node = net.add_node_with_dictionary(NodeId::new(5)?, canola::od::parse(&eds[..])?.od);
//! node.set_fd(true); // its EDS has no `CANopenFD=1`: the application says so
//! assert_eq!(node.usdo().read_typed::<u16>((0x1017, 0)).wait()?, 500);
//! node.usdo().write((0x1017, 0), 750u16).wait()?;
//! assert_eq!(node.usdo().read_typed::<u16>((0x1017, 0)).wait()?, 750);
//! # Ok(())
//! # }
//! ```
//!
//! Requests run as SDO requests do: each call is an [`Operation`] (`.wait()` drives the network
//! until the transfer ends, `.await` waits on tokio); `submit_*` return a [`Pending`] that a
//! drop cancels (with a USDO abort to the server).
//! Errors are [`SdoError`](crate::SdoError)s: [`SdoErrorKind::Usdo`](crate::SdoErrorKind::Usdo)
//! for the transfer's failure (a server's 1-byte abort code maps to its CiA 301 code in
//! [`SdoError::server_abort`](crate::SdoError::server_abort)),
//! [`SdoErrorKind::FdNotSupported`](crate::SdoErrorKind::FdNotSupported) when the bus or the
//! node has no CAN FD (nothing is sent then).

use canola_frame::NodeId;
use canola_od::{DataType, ObjectAddress, Value};

use crate::error::Error;
use crate::machine::usdo::data_type_of;
use crate::machine::{Completion, DownSource, UpSink, UsdoOp, UsdoRequest};
use crate::network::{Network, Operation, Pending, SdoValue};

pub use crate::machine::usdo::{DEFAULT_USDO_NODE_ID, EDS_FD_KEY, eds_marks_fd};

/// A node's USDO client (CANopen FD) as a builder: one operation per value. Made with
/// [`Node::usdo`](crate::Node::usdo).
#[derive(Debug, Clone)]
pub struct Usdo {
    pub(crate) net: Network,
    pub(crate) node: NodeId,
}

impl Usdo {
    /// The node this client talks to.
    pub fn node_id(&self) -> NodeId {
        self.node
    }

    fn request(&self, entry: ObjectAddress, op: UsdoOp) -> UsdoRequest {
        UsdoRequest {
            node: self.node,
            entry,
            op,
        }
    }

    fn download(&self, entry: ObjectAddress, value: impl SdoValue) -> UsdoOp {
        let data_type = data_type_of(self.net.core().dictionary(self.node).as_deref(), entry);
        UsdoOp::Download(DownSource(value.to_sdo_bytes()), data_type)
    }

    fn submit<T>(
        self,
        entry: ObjectAddress,
        op: UsdoOp,
        output: fn(Completion) -> T,
    ) -> Pending<T> {
        let req = self.request(entry, op);
        Pending::submit(self.net, req.into(), output)
    }

    /// Starts a read (USDO upload) without waiting.
    pub fn submit_read(self, entry: impl Into<ObjectAddress>) -> Pending<Vec<u8>> {
        self.submit(entry.into(), UsdoOp::Upload(UpSink::Mem(Vec::new())), |c| {
            c.data
        })
    }

    /// Starts a write (USDO download) without waiting.
    pub fn submit_write(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Pending<()> {
        let entry = entry.into();
        let op = self.download(entry, value);
        self.submit(entry, op, |_| ())
    }

    /// The operation that runs `op` on `entry` to its end and takes `output` from its
    /// completion.
    fn transfer<T: Send + 'static>(
        self,
        entry: ObjectAddress,
        op: UsdoOp,
        output: fn(Completion) -> T,
    ) -> Operation<'static, T> {
        let req = self.request(entry, op);
        let net = self.net;
        Operation::request(net.shared, req.into(), output, Error::from)
    }

    /// Reads an object's bytes (USDO upload): expedited up to 56 bytes, segmented beyond,
    /// as the server answers.
    pub fn read(self, entry: impl Into<ObjectAddress>) -> Operation<'static, Vec<u8>> {
        let entry = entry.into();
        self.transfer(entry, UsdoOp::Upload(UpSink::Mem(Vec::new())), |c| c.data)
    }

    /// Writes an object (USDO download), announcing the data type from the node's dictionary
    /// (DOMAIN without one): expedited up to 56 bytes, segmented beyond.
    pub fn write(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Operation<'static, ()> {
        let entry = entry.into();
        let op = self.download(entry, value);
        self.transfer(entry, op, |_| ())
    }

    /// Reads an object and decodes it as `data_type`.
    pub fn read_as(
        self,
        entry: impl Into<ObjectAddress>,
        data_type: DataType,
    ) -> Operation<'static, Value> {
        let entry = entry.into();
        let node = self.node;
        let read = self.read(entry);
        Operation::new(async move {
            let data = read.await?;
            Value::from_le_bytes(data_type, &data).map_err(|e| Error::Value {
                node,
                entry,
                problem: crate::error::ValueProblem::Bytes(e),
            })
        })
    }

    /// The type the node's dictionary gives `entry`, if it describes it.
    fn dictionary_type(&self, entry: ObjectAddress) -> Option<DataType> {
        self.net
            .core()
            .dictionary(self.node)
            .and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type))
    }

    /// Reads an object and decodes it with the type from the node's dictionary.
    pub fn read_value(self, entry: impl Into<ObjectAddress>) -> Operation<'static, Value> {
        let entry = entry.into();
        match self.dictionary_type(entry) {
            Some(t) => self.read_as(entry, t),
            None => Operation::ready(Err(Error::Value {
                node: self.node,
                entry,
                problem: crate::error::ValueProblem::NotDescribed,
            })),
        }
    }

    /// Reads an object as a Rust value, typed as [`Sdo::read_typed`](crate::Sdo::read_typed)
    /// types it: the dictionary's type, else CiA 301's for a communication object, else `T`'s.
    pub fn read_typed<'t, T: canola_od::ValueType + 't>(
        self,
        entry: impl Into<ObjectAddress>,
    ) -> Operation<'t, T> {
        let entry = entry.into();
        let node = self.node;
        let data_type = self
            .dictionary_type(entry)
            .or_else(|| canola_od::profile::communication_type(entry.index, entry.sub_index))
            .unwrap_or(T::DATA_TYPE);
        let read = self.read_as(entry, data_type);
        Operation::new(async move {
            let value = read.await?;
            T::try_from(value).map_err(|e| Error::Value {
                node,
                entry,
                problem: crate::error::ValueProblem::Convert(e),
            })
        })
    }
}
