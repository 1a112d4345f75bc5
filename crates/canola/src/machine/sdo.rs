//! The SDO client side of the master (CiA 301 §7.2.4): one SDO request and where its bytes
//! come from or go to, the state a request passes through in the request table (queued,
//! running on a channel, done), the table itself, and one client channel to a node's server
//! with its queue.

use std::collections::VecDeque;
use std::io::Write;

use canola_frame::{CanFrame, Duration, FdFrame, Instant, NodeId};
use canola_od::ObjectAddress;
use canola_sdo::{Client, ClientConfig, Method, SdoCobIds};

use super::events::{Completion, ProgressFn, RequestId};
use crate::error::SdoError;

/// Where an upload's bytes go: memory, or a writer (streamed as they arrive).
pub(crate) enum UpSink {
    Mem(Vec<u8>),
    Stream {
        w: Box<dyn Write + Send>,
        written: u64,
        error: Option<std::io::Error>,
    },
}

impl canola_sdo::Sink for UpSink {
    fn write(&mut self, data: &[u8]) -> Result<(), canola_sdo::Full> {
        match self {
            Self::Mem(v) => {
                v.extend_from_slice(data);
                Ok(())
            }
            Self::Stream { w, written, error } => match w.write_all(data) {
                Ok(()) => {
                    *written += data.len() as u64;
                    Ok(())
                }
                Err(e) => {
                    *error = Some(e);
                    Err(canola_sdo::Full)
                }
            },
        }
    }
}

/// A download's bytes.
pub(crate) struct DownSource(pub(crate) Vec<u8>);

impl canola_sdo::Source for DownSource {
    fn len(&self) -> u32 {
        u32::try_from(self.0.len()).unwrap_or(u32::MAX)
    }
    fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
        let start = (offset as usize).min(self.0.len());
        let n = out.len().min(self.0.len() - start);
        out[..n].copy_from_slice(&self.0[start..start + n]);
        n
    }
}

/// What an SDO request does, with the buffer it needs: an upload (read from the server) and
/// where its bytes go, or a download (write to the server) and the bytes it sends.
pub(crate) enum Op {
    /// Read the entry into the sink.
    Upload(UpSink),
    /// Write the source's bytes to the entry.
    Download(DownSource),
}

/// What a USDO request (CANopen FD) does, with the buffer it needs.
pub(crate) enum UsdoOp {
    /// Read the entry into the sink.
    Upload(UpSink),
    /// Write the source's bytes to the entry, announcing this data type code.
    Download(DownSource, u8),
}

/// A request the core runs to its end: an SDO transfer on one of a node's server channels, or
/// a USDO transfer on the master's USDO client. Each kind carries only what it uses.
pub(crate) enum Request {
    Sdo(SdoRequest),
    Usdo(UsdoRequest),
}

impl Request {
    /// The node the request is for.
    pub(crate) fn node(&self) -> NodeId {
        match self {
            Self::Sdo(r) => r.node,
            Self::Usdo(r) => r.node,
        }
    }

    /// The object the request is for.
    pub(crate) fn entry(&self) -> ObjectAddress {
        match self {
            Self::Sdo(r) => r.entry,
            Self::Usdo(r) => r.entry,
        }
    }
}

impl From<SdoRequest> for Request {
    fn from(r: SdoRequest) -> Self {
        Self::Sdo(r)
    }
}

impl From<UsdoRequest> for Request {
    fn from(r: UsdoRequest) -> Self {
        Self::Usdo(r)
    }
}

/// One USDO request: the server, the object and what to do (the timeout and the session are
/// the USDO client's).
pub(crate) struct UsdoRequest {
    pub(crate) node: NodeId,
    pub(crate) entry: ObjectAddress,
    pub(crate) op: UsdoOp,
}

/// One SDO request.
pub(crate) struct SdoRequest {
    pub(crate) node: NodeId,
    /// The server channel: the node's default one (0x600/0x580 + node-ID) or another.
    pub(crate) channel: SdoCobIds,
    pub(crate) entry: ObjectAddress,
    pub(crate) op: Op,
    pub(crate) method: Method,
    pub(crate) timeout: Duration,
    pub(crate) progress: Option<ProgressFn>,
}

/// Where a request is in its life, as the request table keeps it under its [`RequestId`]:
/// waiting in its channel's queue, running on the channel's client machine, or finished with
/// its result until the caller takes it. A cancelled request leaves the table at once (a
/// running one with an abort on the bus), so a late response finds no entry to complete.
pub(super) enum ReqState {
    /// In the channel's queue; the request itself is kept here until it starts.
    Queued(SdoRequest),
    /// In the USDO client's queue, waiting for a free session.
    QueuedUsdo(UsdoRequest),
    /// Running on `channel` of `node` (its buffer now belongs to the client machine); what a
    /// finished transfer needs to report is kept here.
    Active {
        /// Called as segments or blocks arrive.
        progress: Option<ProgressFn>,
        /// The entry, for the error should it fail.
        entry: ObjectAddress,
        /// The node it runs on.
        node: NodeId,
        /// The index of its channel among the node's channels.
        channel: usize,
    },
    /// A USDO transfer running on the master's USDO client under `session`.
    UsdoActive {
        /// The server.
        node: NodeId,
        /// The object, for the error should it fail.
        entry: ObjectAddress,
        /// Its session-ID.
        session: u8,
    },
    /// Finished: the result, until [`Core::take_result`](super::Core::take_result) hands it over.
    Done(Outcome),
}

/// A finished request's result as the core keeps and hands it over: the error boxed, so that
/// the result moves through the waiting loop as a few words (an error is the rare case).
pub(crate) type Outcome = Result<Completion, Box<SdoError>>;

/// A frame the core sends: classic, or CAN FD (USDO, raw FD frames; boxed, as it is rare and
/// nine times the size).
pub(crate) enum OutFrame {
    Can(CanFrame),
    Fd(Box<FdFrame>),
}

impl OutFrame {
    /// The identifier.
    pub(crate) fn id(&self) -> canola_frame::CanId {
        match self {
            Self::Can(f) => f.id(),
            Self::Fd(f) => f.id(),
        }
    }

    /// The data bytes.
    pub(crate) fn data(&self) -> &[u8] {
        match self {
            Self::Can(f) => f.data(),
            Self::Fd(f) => f.data(),
        }
    }

    /// Hands the frame to `transport` (see [`Transport::send_at`](crate::Transport::send_at)).
    pub(crate) fn send_at(
        &self,
        transport: &mut dyn crate::Transport,
        now: Instant,
    ) -> Result<(), crate::TransportError> {
        match self {
            Self::Can(f) => transport.send_at(f, now),
            Self::Fd(f) => transport.send_fd(f),
        }
    }
}

impl From<CanFrame> for OutFrame {
    fn from(f: CanFrame) -> Self {
        Self::Can(f)
    }
}

/// A frame waiting to be handed to the transport.
pub(crate) struct Outgoing {
    pub(crate) frame: OutFrame,
    /// The SDO transfer the frame belongs to: node, channel index and the channel's transfer
    /// number (see [`Core::withdraw`]).
    pub(super) transfer: Option<(NodeId, usize, u64)>,
}

/// One SDO client channel to a node's server (CiA 301 §7.2.4.2): its COB-IDs, its client
/// machine and its request queue. Requests on one channel run one at a time.
pub(super) struct SdoChannel {
    pub(super) ids: SdoCobIds,
    pub(super) client: Client<UpSink, DownSource>,
    pub(super) queue: VecDeque<RequestId>,
    pub(super) active: Option<RequestId>,
    /// The next queued transfer may start at this time (see [`Core::settle`]).
    pub(super) ready_at: Instant,
    /// Number of the running (or last) transfer, counting from 1.
    pub(super) transfer: u64,
    /// Frames that transfer has queued so far.
    pub(super) queued: usize,
    /// The server has answered the running transfer at least once.
    pub(super) answered: bool,
    /// The running transfer's request has a progress callback (else the request table is not
    /// searched for one at every turn).
    pub(super) reports_progress: bool,
    /// The node sent a boot-up while the transfer ran, before the server answered it: if the
    /// response timeout ends the transfer, the error is [`SdoErrorKind::NodeRebooted`].
    pub(super) boot_seen: bool,
    /// The node sent a boot-up after its server had answered the transfer: it ends at once
    /// with [`SdoErrorKind::NodeRebooted`].
    pub(super) rebooted: bool,
}

impl SdoChannel {
    pub(super) fn new(ids: SdoCobIds) -> Self {
        Self {
            ids,
            client: Client::new(ClientConfig::default()),
            queue: VecDeque::new(),
            active: None,
            ready_at: Instant::ZERO,
            transfer: 0,
            queued: 0,
            answered: false,
            reports_progress: false,
            boot_seen: false,
            rebooted: false,
        }
    }

    /// Whether a queued request waits for the channel to become free.
    pub(super) fn has_waiting(&self) -> bool {
        self.active.is_none() && !self.queue.is_empty()
    }
}

/// The request table: entries in id order (ids only grow, so a new one goes at the back), and
/// most leave from the front, as requests run in submission order per channel. A few entries
/// live in it at a time, so a binary search over a ring buffer beats a tree, which allocates a
/// node whenever the table goes from empty to one entry — once per blocking request.
pub(super) struct RequestTable {
    pub(super) entries: VecDeque<(RequestId, ReqState)>,
}

impl RequestTable {
    pub(super) fn new() -> Self {
        Self {
            entries: VecDeque::new(),
        }
    }

    pub(super) fn position(&self, id: RequestId) -> Option<usize> {
        // Mostly the oldest, else one of the next: look at those before searching.
        if self.entries.front().is_some_and(|(i, _)| *i == id) {
            return Some(0);
        }
        if let Some(i) = self.entries.iter().take(4).position(|(i, _)| *i == id) {
            return Some(i);
        }
        self.entries.binary_search_by_key(&id, |(i, _)| *i).ok()
    }

    pub(super) fn get(&self, id: &RequestId) -> Option<&ReqState> {
        let i = self.position(*id)?;
        self.entries.get(i).map(|(_, s)| s)
    }

    pub(super) fn get_mut(&mut self, id: &RequestId) -> Option<&mut ReqState> {
        let i = self.position(*id)?;
        self.entries.get_mut(i).map(|(_, s)| s)
    }

    /// Adds a request with an id above every id in the table.
    pub(super) fn push(&mut self, id: RequestId, state: ReqState) {
        debug_assert!(self.entries.back().is_none_or(|(last, _)| *last < id));
        self.entries.push_back((id, state));
    }

    pub(super) fn remove(&mut self, id: &RequestId) -> Option<ReqState> {
        let i = self.position(*id)?;
        self.entries.remove(i).map(|(_, s)| s)
    }

    /// Removes a finished request's entry and hands its result over.
    pub(super) fn take_result(&mut self, id: RequestId) -> Taken {
        let Some(i) = self.position(id) else {
            return Taken::Unknown;
        };
        if !matches!(self.entries.get(i), Some((_, ReqState::Done(_)))) {
            return Taken::Running;
        }
        // Mostly the oldest entry: a pop is cheaper than a general removal.
        let entry = if i == 0 {
            self.entries.pop_front()
        } else {
            self.entries.remove(i)
        };
        match entry {
            Some((_, ReqState::Done(r))) => Taken::Done(r),
            _ => Taken::Unknown,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.entries.len()
    }
}

/// What [`Core::take_result`] found for a request.
pub(crate) enum Taken {
    /// Still queued or running.
    Running,
    /// Finished; the result is handed over (and forgotten by the core).
    Done(Outcome),
    /// Not in the table: cancelled, or its result was taken already.
    Unknown,
}
