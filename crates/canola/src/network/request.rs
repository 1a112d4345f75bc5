//! [`Sdo`], a node's SDO client as a builder (CiA 301 §7.2.4), the [`Pending`] request it
//! submits, typed by what it produces, and [`SdoValue`], what can be written.

use std::io::{Read, Write};

use canola_frame::{Duration, NodeId};
use canola_od::{DataType, Value};
use canola_sdo::{Method, SdoCobIds};

use super::handle::Network;
use super::operation::{self, Operation};
use crate::error::{Error, SdoError};
use crate::machine::{
    Completion, DownSource, Op, ProgressFn, Request, RequestId, SdoRequest, TransferProgress,
    UpSink,
};
use canola_od::ObjectAddress;

/// A request in flight, typed by what it produces: `Pending<Vec<u8>>` for an upload into
/// memory, `Pending<()>` for a download, `Pending<u64>` (bytes) for a streamed upload. Unlike an
/// [`Operation`], it runs from the moment it is made (several run at once, one per node and
/// channel). [`wait`](Self::wait) drives the network until it ends; `.await` (`tokio` feature)
/// waits without blocking. Dropping it cancels the request (a running transfer is aborted on the
/// bus with 0x08000000).
#[must_use = "dropping a pending request cancels it"]
pub struct Pending<T = Vec<u8>> {
    pub(crate) net: Network,
    pub(crate) id: Option<RequestId>,
    pub(crate) node: NodeId,
    pub(crate) entry: ObjectAddress,
    /// What this kind of request takes from its completion.
    pub(crate) output: fn(Completion) -> T,
}

impl<T> core::fmt::Debug for Pending<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Pending")
            .field("node", &self.node)
            .field("entry", &self.entry)
            .field("running", &self.id.is_some())
            .finish_non_exhaustive()
    }
}

impl<T> Pending<T> {
    /// Submits `req` (an SDO or USDO request) to `net`'s core: the request runs from now on,
    /// and this value waits for it and takes `output` from its completion.
    pub(crate) fn submit(net: Network, req: Request, output: fn(Completion) -> T) -> Self {
        let (node, entry) = (req.node(), req.entry());
        let id = net.shared().submit(req);
        Pending {
            net,
            id: Some(id),
            node,
            entry,
            output,
        }
    }

    /// Blocks until the request finishes.
    pub fn wait(mut self) -> Result<T, SdoError> {
        let output = self.output;
        match self.id.take() {
            Some(id) => self
                .net
                .shared()
                .wait(id, self.node, self.entry)
                .map(output),
            None => Err(self.cancelled()),
        }
    }

    /// The node the request is for.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// The object the request is for.
    pub fn entry(&self) -> ObjectAddress {
        self.entry
    }

    /// Whether the request has finished (its result is ready for [`wait`](Self::wait)).
    pub fn is_done(&self) -> bool {
        self.id.is_none_or(|id| self.net.core().is_done(id))
    }

    /// The request, taken out of this handle: its drop no longer cancels it (the operation
    /// that waits for it does). `None` when it no longer runs.
    pub(crate) fn into_req(mut self) -> Option<operation::Req> {
        let id = self.id.take()?;
        Some(operation::Req {
            id,
            node: self.node,
            entry: self.entry,
        })
    }

    /// Cancels the request (same as dropping it).
    pub fn cancel(mut self) {
        if let Some(id) = self.id.take() {
            self.net.shared().cancel(id);
        }
    }

    /// The error of a request that no longer runs.
    pub(crate) fn cancelled(&self) -> SdoError {
        operation::cancelled(self.node, self.entry)
    }
}

/// `.await` a pending request: the same request, waited for without blocking the runtime
/// (`tokio` feature; without it, awaiting blocks as [`Pending::wait`] does); dropping the
/// future cancels it.
impl<T: Send + 'static> std::future::IntoFuture for Pending<T> {
    type Output = Result<T, SdoError>;
    type IntoFuture =
        std::pin::Pin<Box<dyn std::future::Future<Output = Result<T, SdoError>> + Send>>;

    fn into_future(mut self) -> Self::IntoFuture {
        let id = self.id.take();
        let (net, node, entry, output) = (self.net.clone(), self.node, self.entry, self.output);
        Box::pin(async move {
            let Some(id) = id else {
                return Err(operation::cancelled(node, entry));
            };
            let req = operation::Req { id, node, entry };
            let mut r = operation::wait_requests(net.shared(), vec![req]).await;
            r.pop()
                .unwrap_or_else(|| Err(operation::cancelled(node, entry)))
                .map(output)
        })
    }
}

impl<T> Drop for Pending<T> {
    fn drop(&mut self) {
        if let Some(id) = self.id.take() {
            self.net.shared().cancel(id);
        }
    }
}

/// A value that can be written by SDO (little-endian bytes, CiA 301 §7.1).
pub trait SdoValue {
    /// The bytes to download.
    fn to_sdo_bytes(&self) -> Vec<u8>;
}

macro_rules! le_value {
    ($($t:ty),*) => {$(
        impl SdoValue for $t {
            fn to_sdo_bytes(&self) -> Vec<u8> {
                self.to_le_bytes().to_vec()
            }
        }
    )*};
}
le_value!(u8, u16, u32, u64, i8, i16, i32, i64, f32, f64);

impl SdoValue for [u8] {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_vec()
    }
}
impl<const N: usize> SdoValue for [u8; N] {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_vec()
    }
}
impl SdoValue for Vec<u8> {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.clone()
    }
}
impl SdoValue for str {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.as_bytes().to_vec()
    }
}
impl SdoValue for Value {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        self.to_le_bytes()
    }
}
impl<T: SdoValue + ?Sized> SdoValue for &T {
    fn to_sdo_bytes(&self) -> Vec<u8> {
        (**self).to_sdo_bytes()
    }
}

/// Default SDO response timeout.
pub const DEFAULT_SDO_TIMEOUT: Duration = Duration::from_millis(1000);

/// A node of one network as the handles below [`Node`](crate::Node) hold it (the PDO
/// handles): its driver and node-ID, and the calls they need of it.
#[derive(Clone, Debug)]
pub(crate) struct NodeRef {
    pub(crate) net: Network,
    pub(crate) id: NodeId,
}

impl NodeRef {
    /// The node's SDO client with default settings.
    pub(crate) fn sdo(&self) -> Sdo {
        Sdo::new(self.net.clone(), self.id)
    }

    /// The node's dictionary, if it was added with one.
    pub(crate) fn dictionary(&self) -> Option<std::sync::Arc<canola_od::ObjectDictionary>> {
        self.net.core().dictionary(self.id)
    }

    /// Whether the node is marked CANopen FD.
    pub(crate) fn is_fd(&self) -> bool {
        self.net.core().node_fd(self.id)
    }
}

/// A node's SDO client (CiA 301 §7.2.4) as a builder: settings, then one operation.
pub struct Sdo {
    pub(crate) net: Network,
    pub(crate) node: NodeId,
    pub(crate) channel: SdoCobIds,
    pub(crate) method: Method,
    pub(crate) timeout: Duration,
    pub(crate) progress: Option<ProgressFn>,
}

impl core::fmt::Debug for Sdo {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Sdo")
            .field("node", &self.node)
            .field("channel", &self.channel)
            .field("method", &self.method)
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

/// An upload into memory, with room for an expedited value: the common read allocates once.
fn upload_to_memory() -> Op {
    Op::Upload(UpSink::Mem(Vec::with_capacity(4)))
}

/// A download of `value`'s bytes.
fn download(value: impl SdoValue) -> Op {
    Op::Download(DownSource(value.to_sdo_bytes()))
}

impl Sdo {
    /// The client of `node` on `net` with default settings (normal transfer, the node's
    /// default channel, [`DEFAULT_SDO_TIMEOUT`]).
    pub(crate) fn new(net: Network, node: NodeId) -> Self {
        Sdo {
            net,
            node,
            channel: SdoCobIds::default_for(node),
            method: Method::Normal,
            timeout: DEFAULT_SDO_TIMEOUT,
            progress: None,
        }
    }

    /// The node this client talks to.
    pub fn node_id(&self) -> NodeId {
        self.node
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// Talks to the node's SDO server on another channel than its default one (0x600/0x580 +
    /// node-ID): a further server channel (0x1201..=0x127F) or a changed 0x1200. Requests on
    /// one channel run one at a time; different channels run in parallel.
    pub fn channel(mut self, ids: SdoCobIds) -> Self {
        self.channel = ids;
        self
    }

    /// Uses block transfer (CiA 301 §7.2.4.3.9) when `on`.
    pub fn block(mut self, on: bool) -> Self {
        self.method = if on { Method::Block } else { Method::Normal };
        self
    }

    /// Chooses the transfer method.
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Sets the response timeout (per server response).
    pub fn timeout(mut self, timeout: impl Into<Duration>) -> Self {
        let timeout: Duration = timeout.into();
        self.timeout = timeout;
        self
    }

    /// Calls `f` as the transfer progresses.
    pub fn on_progress(mut self, f: impl FnMut(TransferProgress) + Send + 'static) -> Self {
        self.progress = Some(Box::new(f));
        self
    }

    pub(crate) fn request<T>(
        self,
        entry: ObjectAddress,
        op: Op,
        output: fn(Completion) -> T,
    ) -> Pending<T> {
        let (net, req) = self.into_request(entry, op);
        Pending::submit(net, req.into(), output)
    }

    /// The request for `op` on `entry` with this builder's settings, and the network.
    fn into_request(self, entry: ObjectAddress, op: Op) -> (Network, SdoRequest) {
        let req = SdoRequest {
            node: self.node,
            channel: self.channel,
            entry,
            op,
            method: self.method,
            timeout: self.timeout,
            progress: self.progress,
        };
        (self.net, req)
    }

    /// The operation that runs `op` on `entry` to its end and takes `output` from its
    /// completion.
    fn transfer<T: Send + 'static>(
        self,
        entry: ObjectAddress,
        op: Op,
        output: fn(Completion) -> T,
    ) -> Operation<'static, T> {
        let (net, req) = self.into_request(entry, op);
        Operation::request(net.shared, req.into(), output, Error::from)
    }

    /// Starts an upload into memory without waiting.
    pub fn submit_read(self, entry: impl Into<ObjectAddress>) -> Pending<Vec<u8>> {
        self.request(entry.into(), upload_to_memory(), |c| c.data)
    }

    /// Starts a download without waiting.
    pub fn submit_write(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Pending<()> {
        self.request(entry.into(), download(value), |_| ())
    }

    /// Starts an upload into `writer` without waiting: [`upload_to`](Self::upload_to) as a
    /// [`Pending`] request, whose result is the byte count. The writer is called from whatever
    /// drives the network; a write or the final flush failing ends the request with
    /// [`SdoErrorKind::Io`](crate::SdoErrorKind::Io) (the transfer is aborted on the bus).
    pub fn submit_upload_to(
        self,
        entry: impl Into<ObjectAddress>,
        writer: impl Write + Send + 'static,
    ) -> Pending<u64> {
        let sink = UpSink::Stream {
            w: Box::new(writer),
            written: 0,
            error: None,
        };
        self.request(entry.into(), Op::Upload(sink), |c| c.transferred)
    }

    /// Reads an object's bytes (SDO upload).
    pub fn read(self, entry: impl Into<ObjectAddress>) -> Operation<'static, Vec<u8>> {
        self.transfer(entry.into(), upload_to_memory(), |c| c.data)
    }

    /// An upload for a typed read: the bytes, and whether the server answered expedited
    /// without the size indicated (see [`Upload`]).
    fn read_upload(self, entry: ObjectAddress) -> Operation<'static, Upload> {
        self.transfer(entry, upload_to_memory(), Upload::from)
    }

    /// The type the node's dictionary gives `entry`, if it has one that describes it.
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

    /// Reads an object as a Rust value (`read_typed::<u16>((0x1017, 0))`): decoded with the
    /// object's type from the node's dictionary, else the type CiA 301 gives a communication
    /// profile object, else `T`'s own CANopen type (`u16` is UNSIGNED16), then converted to
    /// `T` ([`TryFrom<Value>`](canola_od::ValueType)). A value that `T` cannot hold (500 read
    /// as `u8`) is an [`Error::Value`] naming the object, never a truncated number.
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

    /// Reads an object and decodes it as `data_type` (whatever the dictionary says).
    pub fn read_as(
        self,
        entry: impl Into<ObjectAddress>,
        data_type: DataType,
    ) -> Operation<'static, Value> {
        let entry = entry.into();
        let node = self.node;
        let upload = self.read_upload(entry);
        Operation::new(async move { upload.await?.decode(node, entry, data_type) })
    }

    /// Reads a typed entry (from generated code: `canola_od::Entry<T>`) and decodes it.
    pub fn read_entry<'t, T: canola_od::EntryValue + 't>(
        self,
        entry: &canola_od::Entry<T>,
    ) -> Operation<'t, T> {
        let at = ObjectAddress::new(entry.index(), entry.sub_index());
        let node = self.node;
        let entry = *entry;
        let upload = self.read_upload(at);
        Operation::new(async move { decode_entry(node, &entry, &upload.await?) })
    }

    /// Writes a typed entry (from generated code: `canola_od::Entry<T>`).
    pub fn write_entry<T: canola_od::EntryValue>(
        self,
        entry: &canola_od::Entry<T>,
        value: &T,
    ) -> Operation<'static, ()> {
        match encode_entry(self.node, entry, value) {
            Ok((at, bytes)) => self.write(at, bytes),
            Err(e) => Operation::ready(Err(e)),
        }
    }

    /// Writes an object (SDO download).
    pub fn write(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Operation<'static, ()> {
        self.transfer(entry.into(), download(value), |_| ())
    }

    /// Uploads an object into `writer`, streaming as segments arrive, and flushes it at the
    /// end. Returns the byte count; a write or the final flush failing is an error
    /// ([`SdoErrorKind::Io`](crate::SdoErrorKind::Io)), so no data is lost silently. The writer is called from whatever
    /// drives the network (the waiting thread, the background driver, or tokio's blocking
    /// pool when awaited on a real clock).
    pub fn upload_to(
        self,
        entry: impl Into<ObjectAddress>,
        writer: impl Write + Send + 'static,
    ) -> Operation<'static, u64> {
        let sink = UpSink::Stream {
            w: Box::new(writer),
            written: 0,
            error: None,
        };
        self.transfer(entry.into(), Op::Upload(sink), |c| c.transferred)
    }

    /// Downloads the whole content of `reader` into an object. Returns the byte count. The
    /// reader is read to its end at once, before the operation starts (from async code, pass
    /// the bytes: `&data[..]` is a reader).
    pub fn download_from(
        self,
        entry: impl Into<ObjectAddress>,
        mut reader: impl Read,
    ) -> Operation<'static, u64> {
        let mut data = Vec::new();
        if let Err(e) = reader.read_to_end(&mut data) {
            return Operation::ready(Err(e.into()));
        }
        self.transfer(entry.into(), Op::Download(DownSource(data)), |c| {
            c.transferred
        })
    }
}

/// An upload's bytes for a typed read.
pub(crate) struct Upload {
    pub(crate) data: Vec<u8>,
    /// The server answered expedited without the size indicated (e = 1, s = 0): `data` holds
    /// all four bytes, of which CiA 301 leaves those past the object unspecified, so the
    /// type's length is taken from the front (real devices that always send four bytes
    /// answer a 1- or 2-byte object this way).
    pub(crate) unsized_expedited: bool,
}

impl From<Completion> for Upload {
    fn from(c: Completion) -> Self {
        Self {
            data: c.data,
            unsized_expedited: c.unsized_expedited,
        }
    }
}

impl Upload {
    /// The bytes decoded as `data_type`, the error naming node and object (blocking and async
    /// reads).
    pub(crate) fn decode(
        &self,
        node: NodeId,
        entry: ObjectAddress,
        data_type: DataType,
    ) -> Result<Value, Error> {
        let decoded = if self.unsized_expedited {
            Value::from_le_bytes_unsized(data_type, &self.data)
        } else {
            Value::from_le_bytes(data_type, &self.data)
        };
        decoded.map_err(|e| Error::Value {
            node,
            entry,
            problem: crate::error::ValueProblem::Bytes(e),
        })
    }
}

/// A typed entry's bytes decoded, the error naming node and object (blocking and async reads).
pub(crate) fn decode_entry<T: canola_od::EntryValue>(
    node: NodeId,
    entry: &canola_od::Entry<T>,
    upload: &Upload,
) -> Result<T, Error> {
    let decoded = if upload.unsized_expedited {
        entry.decode_unsized(&upload.data)
    } else {
        entry.decode(&upload.data)
    };
    decoded.map_err(|e| Error::Value {
        node,
        entry: ObjectAddress::new(entry.index(), entry.sub_index()),
        problem: crate::error::ValueProblem::Entry(e),
    })
}

/// A typed entry's address and encoded value (blocking and async writes).
pub(crate) fn encode_entry<T: canola_od::EntryValue>(
    node: NodeId,
    entry: &canola_od::Entry<T>,
    value: &T,
) -> Result<(ObjectAddress, Vec<u8>), Error> {
    let at = ObjectAddress::new(entry.index(), entry.sub_index());
    // Large enough for every fixed-size type; strings and domains are written as bytes.
    let mut buf = vec![0u8; 4096];
    let n = entry.encode(value, &mut buf).map_err(|e| Error::Value {
        node,
        entry: at,
        problem: crate::error::ValueProblem::Entry(e),
    })?;
    buf.truncate(n);
    Ok((at, buf))
}
