//! The gateway server: connections (TCP, Unix socket, stdio, any byte stream) in front of one
//! [`Network`].
//!
//! Threads and queues:
//! * Each connection has a reader (lines in, parse, answer or dispatch) and a writer (its
//!   outbox to the stream). Settings (`set node`, `set sdo_timeout`, ...) belong to the
//!   connection and apply to the requests read after them.
//! * SDO requests go to one queue per node, served by that node's worker thread: requests to
//!   one node run one after another (CANopen has one SDO channel per node), requests to
//!   different nodes run in parallel. NMT commands to a node go to its queue too, so that
//!   `write` then `start` happen in that order; NMT to all nodes (node 0) and the settings are
//!   answered at once. LSS requests share one queue (one LSS channel per bus). Each queue serves its connections round-robin, so a
//!   connection with many requests waiting delays another's by at most one request per node.
//! * Replies carry the request's sequence number; replies to different nodes may overtake one
//!   another.
//! * Bounds per connection: a line longer than [`Config::max_line`] is refused with
//!   `ERROR:600` (its beginning still gives the sequence number), at most
//!   [`Config::max_in_flight`] requests are waiting or unsent (the reader stops reading until
//!   the writer catches up), at most [`Config::max_events`] event lines wait in the outbox
//!   (later ones are dropped for that connection only), and an upload is at most
//!   [`Config::max_upload`] bytes. A connection whose peer stopped reading or vanished holds
//!   only its own requests: the node workers never wait for a connection.
//! * Access control, the audit log and the limits against hostile clients live in
//!   [`crate::access`], [`crate::audit_log`] and [`crate::conn_limits`]; this file calls them
//!   at a few marked hooks (the accept loops, the start of a line, the queue's reply).
//! * A background thread drives the network while no request runs (heartbeats, boot-up and
//!   EMCY are received) and turns its events into event lines for the connections that asked
//!   for them with `_events 1`.
//!
//! One cohesive unit (connections, per-node queues and workers share one state), so it stays
//! in one file.

use std::collections::{HashMap, VecDeque};
use std::io::{BufRead, BufReader, Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, mpsc};
use std::thread::JoinHandle;

use canola::{Network, NetworkEvent};
use canola_frame::{Duration, NodeId};
use canola_nmt::{GuardingEvent, HeartbeatEvent};

use crate::command::{
    Command, ErrorCode, Event, EventKind, HelpTopic, Level, Reply, Request, Response,
};
use crate::exec::{self, SdoSettings};
use crate::parse::{ParseError, parse_line};
use crate::value::DataType;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// What `info version` reports: `<vendor-ID> <product code> <revision major>.<minor> <serial>
/// <gateway class> <protocol major>.<minor> <implementation major>.<minor>` (the fields and
/// their order as Lely's gateway prints them: the identity of the gateway's own device, gateway
/// class 3 for a gateway that is the NMT master, the CiA 309-1 version, then the
/// implementation's version).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Version {
    /// Vendor-ID of the gateway (0: none assigned).
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number (major in the high 16 bits).
    pub revision: u32,
    /// Serial number.
    pub serial: u32,
    /// Gateway class (3: the gateway is the NMT master, as this one is; 1: not).
    pub class: u8,
    /// The version of CiA 309-1 implemented (major, minor).
    pub protocol: (u8, u8),
    /// Implementation version (major, minor).
    pub implementation: (u8, u8),
}

impl Default for Version {
    fn default() -> Self {
        let num = |s: &str| s.parse::<u8>().unwrap_or(0);
        let major = num(env!("CARGO_PKG_VERSION_MAJOR"));
        let minor = num(env!("CARGO_PKG_VERSION_MINOR"));
        Self {
            vendor_id: 0,
            product_code: 0,
            revision: (u32::from(major) << 16) | u32::from(minor),
            serial: 0,
            class: 3,
            protocol: (2, 0),
            implementation: (major, minor),
        }
    }
}

/// Settings of a [`Gateway`].
#[derive(Debug, Clone)]
pub struct Config {
    /// The network number of the one network (CiA 309-3 `net`), also every connection's
    /// default net.
    pub net: u16,
    /// SDO timeout a connection starts with (`set sdo_timeout` changes it).
    pub sdo_timeout: Duration,
    /// Longest request line in bytes, line end included.
    pub max_line: usize,
    /// Requests a connection may have waiting or unsent.
    pub max_in_flight: usize,
    /// Event lines a connection may have unsent.
    pub max_events: usize,
    /// Connections at once; one more is answered `ERROR:600` and closed.
    pub max_connections: usize,
    /// Longest upload in bytes (a longer one is aborted: `ERROR:0x05040005`).
    pub max_upload: usize,
    /// Period of the background driver; `None` leaves driving to the requests (and to the
    /// application).
    pub drive_period: Option<std::time::Duration>,
    /// What `info version` reports.
    pub version: Version,
    /// Who may do what ([`crate::access`]); the default admits everyone to everything.
    pub access: crate::access::Access,
    /// Where the requests that change the network are logged ([`crate::audit_log`]).
    pub audit: Option<Arc<crate::audit_log::AuditLog>>,
    /// Limits against hostile clients on sockets ([`crate::conn_limits`]).
    pub limits: crate::conn_limits::ConnLimits,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            net: 1,
            sdo_timeout: Duration::from_millis(500),
            max_line: 4096,
            max_in_flight: 64,
            max_events: 256,
            max_connections: 256,
            max_upload: 64 * 1024,
            drive_period: Some(std::time::Duration::from_millis(10)),
            version: Version::default(),
            access: crate::access::Access::default(),
            audit: None,
            limits: crate::conn_limits::ConnLimits::default(),
        }
    }
}

/// One item of a connection's outbox.
enum Out {
    Reply(String),
    Event(String),
}

#[derive(Default)]
struct OutboxState {
    queue: VecDeque<Out>,
    /// Requests dispatched to a queue whose reply is not yet in `queue`.
    pending: usize,
    /// Replies in `queue`.
    replies: usize,
    events: usize,
    /// Event lines dropped because the outbox was full.
    dropped_events: u64,
    /// The reader is done (end of stream): the writer ends when everything is sent.
    reading_done: bool,
    /// Writing failed: the peer is gone; nothing more is queued.
    gone: bool,
}

/// A connection as the workers see it.
struct Client {
    id: u64,
    out: Mutex<OutboxState>,
    /// Signalled when the outbox gains an item or loses one.
    cond: Condvar,
    events: AtomicBool,
}

impl Client {
    fn gone(&self) -> bool {
        lock(&self.out).gone
    }

    /// Queues the reply of a dispatched request.
    fn complete(&self, text: String) {
        let mut o = lock(&self.out);
        o.pending = o.pending.saturating_sub(1);
        if !o.gone {
            o.queue.push_back(Out::Reply(text));
            o.replies += 1;
        }
        drop(o);
        self.cond.notify_all();
    }

    /// Queues an immediate reply (the reader waited for room before reading the line).
    fn reply(&self, text: String) {
        let mut o = lock(&self.out);
        if !o.gone {
            o.queue.push_back(Out::Reply(text));
            o.replies += 1;
        }
        drop(o);
        self.cond.notify_all();
    }

    fn event(&self, text: &str, max: usize) {
        let mut o = lock(&self.out);
        if o.gone {
            return;
        }
        if o.events >= max {
            o.dropped_events += 1;
            return;
        }
        o.queue.push_back(Out::Event(text.to_owned()));
        o.events += 1;
        drop(o);
        self.cond.notify_all();
    }
}

/// A job of a node or LSS queue.
struct Job {
    client: Arc<Client>,
    seq: Option<u32>,
    work: Work,
    /// The audit log line waiting for the reply (a request that changes the network).
    audit: Option<crate::audit_log::Pending>,
}

enum Work {
    Read {
        node: NodeId,
        index: u16,
        sub: u8,
        data_type: Option<DataType>,
        sdo: SdoSettings,
    },
    Write {
        node: NodeId,
        index: u16,
        sub: u8,
        value: crate::value::Value,
        sdo: SdoSettings,
    },
    Nmt {
        node: u8,
        service: crate::command::NmtService,
    },
    Lss(Command),
}

/// A queue that serves its clients round-robin: each client's jobs in order, one job per
/// client per turn.
#[derive(Default)]
struct FairQueue {
    clients: VecDeque<(u64, VecDeque<Job>)>,
    stop: bool,
}

impl FairQueue {
    fn push(&mut self, job: Job) {
        let id = job.client.id;
        match self.clients.iter_mut().find(|(c, _)| *c == id) {
            Some((_, q)) => q.push_back(job),
            None => self.clients.push_back((id, VecDeque::from([job]))),
        }
    }

    fn pop(&mut self) -> Option<Job> {
        let (id, mut q) = self.clients.pop_front()?;
        let job = q.pop_front();
        if !q.is_empty() {
            self.clients.push_back((id, q));
        }
        job
    }
}

struct Worker {
    queue: Mutex<FairQueue>,
    cond: Condvar,
}

struct Shared {
    net: Network,
    config: Config,
    /// One worker per node (SDO), created on first use, and one for LSS (key 0).
    workers: Mutex<HashMap<u8, Arc<Worker>>>,
    clients: Mutex<Vec<std::sync::Weak<Client>>>,
    next_client: AtomicU64,
    stop: AtomicBool,
    threads: Mutex<Vec<JoinHandle<()>>>,
    /// Requests being carried out: while there are any, their threads drive the network.
    active: std::sync::atomic::AtomicUsize,
    /// What access control refused.
    access_counters: crate::access::Counters,
    /// The socket connections, for the connection limits.
    conns: Arc<crate::conn_limits::ConnTable>,
}

impl Shared {
    fn worker(self: &Arc<Self>, key: u8) -> Arc<Worker> {
        let mut w = lock(&self.workers);
        if let Some(w) = w.get(&key) {
            return w.clone();
        }
        let worker = Arc::new(Worker {
            queue: Mutex::new(FairQueue::default()),
            cond: Condvar::new(),
        });
        w.insert(key, worker.clone());
        let (shared, me) = (self.clone(), worker.clone());
        let h = std::thread::Builder::new()
            .name(format!("gateway-queue-{key}"))
            .spawn(move || shared.serve_queue(&me));
        if let Ok(h) = h {
            lock(&self.threads).push(h);
        }
        worker
    }

    fn serve_queue(&self, w: &Worker) {
        loop {
            let job = {
                let mut q = lock(&w.queue);
                loop {
                    if q.stop {
                        return;
                    }
                    if let Some(j) = q.pop() {
                        break j;
                    }
                    q = w
                        .cond
                        .wait(q)
                        .unwrap_or_else(std::sync::PoisonError::into_inner);
                }
            };
            if job.client.gone() {
                job.client.complete(String::new());
                continue;
            }
            self.active.fetch_add(1, Ordering::SeqCst);
            let reply = match &job.work {
                Work::Read {
                    node,
                    index,
                    sub,
                    data_type,
                    sdo,
                } => exec::read(&self.net, *node, *index, *sub, *data_type, *sdo),
                Work::Write {
                    node,
                    index,
                    sub,
                    value,
                    sdo,
                } => exec::write(&self.net, *node, *index, *sub, value, *sdo),
                Work::Nmt { node, service } => exec::nmt(&self.net, *node, *service),
                Work::Lss(c) => exec::lss(&self.net, c),
            };
            self.active.fetch_sub(1, Ordering::SeqCst);
            let text = Response {
                seq: job.seq,
                reply,
            }
            .to_text();
            if let Some(a) = &job.audit {
                a.record(&text);
            }
            job.client.complete(text);
        }
    }

    fn broadcast(&self, line: &str) {
        let clients: Vec<_> = {
            let mut c = lock(&self.clients);
            c.retain(|w| w.strong_count() > 0);
            c.iter().filter_map(std::sync::Weak::upgrade).collect()
        };
        for c in clients {
            if c.events.load(Ordering::Relaxed) {
                c.event(line, self.config.max_events);
            }
        }
    }
}

/// Per-connection settings.
struct Session {
    net: Option<u16>,
    node: Option<u8>,
    sdo: SdoSettings,
    /// Role and peer ([`crate::access`]).
    access: crate::access::ConnAccess,
    bad_lines: crate::conn_limits::BadLines,
}

/// The CiA 309-3 gateway in front of one [`Network`]. Cheap to clone.
///
/// ```
/// use canola::{MemoryBus, Network, SimDevice};
/// use canola_gateway::{Config, Gateway};
///
/// let bus = MemoryBus::new();
/// let net = Network::new(bus.endpoint());
/// let eds = include_bytes!("../../../eds/burkert-generic.eds");
/// bus.attach(SimDevice::from_eds(canola_frame::NodeId::new(5).unwrap(), eds).unwrap());
/// let gateway = Gateway::new(net, Config::default());
/// let mut out = Vec::new();
/// gateway.serve_stream(&b"[1] 5 write 0x1017 0 u16 250\n[2] 5 read 0x1017 0 u16\n"[..], &mut out);
/// assert_eq!(String::from_utf8(out).unwrap(), "[1] OK\r\n[2] 250\r\n");
/// ```
#[derive(Clone)]
pub struct Gateway {
    shared: Arc<Shared>,
}

impl core::fmt::Debug for Gateway {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Gateway")
            .field("net", &self.shared.config.net)
            .finish_non_exhaustive()
    }
}

impl Gateway {
    /// A gateway for `net`. Starts the event thread (and the background driver, see
    /// [`Config::drive_period`]).
    pub fn new(net: Network, config: Config) -> Self {
        let events = net.subscribe();
        let shared = Arc::new(Shared {
            net,
            config,
            workers: Mutex::new(HashMap::new()),
            clients: Mutex::new(Vec::new()),
            next_client: AtomicU64::new(1),
            stop: AtomicBool::new(false),
            threads: Mutex::new(Vec::new()),
            active: std::sync::atomic::AtomicUsize::new(0),
            access_counters: crate::access::Counters::default(),
            conns: Arc::default(),
        });
        let s = shared.clone();
        if let Ok(h) = std::thread::Builder::new()
            .name("gateway-events".into())
            .spawn(move || forward_events(&s, &events))
        {
            lock(&shared.threads).push(h);
        }
        if let Some(period) = shared.config.drive_period {
            let s = shared.clone();
            if let Ok(h) = std::thread::Builder::new()
                .name("gateway-driver".into())
                .spawn(move || drive(&s, period))
            {
                lock(&shared.threads).push(h);
            }
        }
        Self { shared }
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.shared.net
    }

    /// Serves one connection on a byte stream until the reader ends and every reply is
    /// written (or writing fails). Blocks; run it on a thread of its own per connection.
    pub fn serve_stream(&self, reader: impl Read, writer: impl Write + Send) {
        self.serve_peer(reader, writer, crate::access::Peer::Local);
    }

    /// What access control refused so far.
    pub fn access_counters(&self) -> crate::access::AccessCounters {
        self.shared.access_counters.snapshot()
    }

    /// What the connection limits did so far.
    pub fn limit_counters(&self) -> crate::conn_limits::LimitCounters {
        self.shared.conns.counters()
    }

    fn serve_peer(&self, reader: impl Read, writer: impl Write + Send, peer: crate::access::Peer) {
        let shared = &self.shared;
        let client = Arc::new(Client {
            id: shared.next_client.fetch_add(1, Ordering::Relaxed),
            out: Mutex::new(OutboxState::default()),
            cond: Condvar::new(),
            events: AtomicBool::new(false),
        });
        lock(&shared.clients).push(Arc::downgrade(&client));
        std::thread::scope(|scope| {
            let c = client.clone();
            scope.spawn(move || write_outbox(&c, writer));
            self.read_requests(&client, reader, peer);
            let mut o = lock(&client.out);
            o.reading_done = true;
            drop(o);
            client.cond.notify_all();
        });
    }

    fn read_requests(&self, client: &Arc<Client>, reader: impl Read, peer: crate::access::Peer) {
        let cfg = &self.shared.config;
        let mut session = Session {
            net: Some(cfg.net),
            node: None,
            sdo: SdoSettings {
                timeout: cfg.sdo_timeout,
                block: false,
                max_upload: cfg.max_upload,
            },
            access: crate::access::ConnAccess::new(&cfg.access, peer),
            bad_lines: crate::conn_limits::BadLines::default(),
        };
        let mut reader = BufReader::with_capacity(cfg.max_line.clamp(64, 64 * 1024), reader);
        let mut line = Vec::with_capacity(256);
        loop {
            // Room for one more reply before reading the next line.
            {
                let mut o = lock(&client.out);
                while !o.gone && o.pending + o.replies >= cfg.max_in_flight {
                    o = client
                        .cond
                        .wait(o)
                        .unwrap_or_else(std::sync::PoisonError::into_inner);
                }
                if o.gone {
                    return;
                }
            }
            line.clear();
            let (too_long, eof) = match read_line(&mut reader, &mut line, cfg.max_line) {
                Ok(r) => r,
                Err(_) => return,
            };
            if eof && line.is_empty() {
                return;
            }
            let bad = if too_long {
                let seq = std::str::from_utf8(&line)
                    .ok()
                    .and_then(|t| parse_line(t).err().and_then(|e| e.seq()))
                    .or_else(|| leading_seq(&line));
                client.reply(error_text(seq, ErrorCode::OUT_OF_MEMORY));
                true
            } else {
                match std::str::from_utf8(&line) {
                    Ok(text) => self.handle_line(client, &mut session, text),
                    Err(_) => {
                        client.reply(error_text(leading_seq(&line), ErrorCode::SYNTAX));
                        true
                    }
                }
            };
            // Access and junk limits: a failed `auth`, or too many bad lines in a row, ends it.
            if session.access.closed() || session.bad_lines.note(bad, &cfg.limits) {
                return;
            }
            if eof {
                return;
            }
        }
    }

    /// Serves one line; whether it was an erroneous line.
    fn handle_line(&self, client: &Arc<Client>, session: &mut Session, text: &str) -> bool {
        // Access hook: `auth` first where a token is needed.
        let (cfg, counters) = (&self.shared.config, &self.shared.access_counters);
        if let crate::access::Gate::Answer(a) =
            crate::access::gate(&cfg.access, &mut session.access, counters, text)
        {
            client.reply(a);
            return false;
        }
        let req = match parse_line(text) {
            Ok(Some(r)) => r,
            Ok(None) => return false,
            Err(e) => {
                let code = match e {
                    ParseError::Syntax { .. } => ErrorCode::SYNTAX,
                    ParseError::NotSupported { .. } => ErrorCode::REQUEST_NOT_SUPPORTED,
                    ParseError::UnsupportedNode { .. } => ErrorCode::UNSUPPORTED_NODE,
                };
                client.reply(error_text(e.seq(), code));
                return true;
            }
        };
        // Access hook: the role, and the audit line of a request that changes the network.
        let mut audit = match (&cfg.audit, crate::access::Class::of(&req.command)) {
            (Some(log), crate::access::Class::Change) => Some(crate::audit_log::Pending::new(
                log,
                session.access.peer.to_string(),
                text,
            )),
            _ => None,
        };
        let reply = match crate::access::permit(&session.access, counters, &req.command) {
            Ok(()) => self.dispatch(client, session, &req, &mut audit),
            Err(code) => Some(Reply::Error(code)),
        };
        if let Some(reply) = reply {
            let text = Response {
                seq: req.seq,
                reply,
            }
            .to_text();
            if let Some(a) = audit {
                a.record(&text);
            }
            client.reply(text);
        }
        false
    }

    /// Answers `req` now, or queues it and returns `None`.
    fn dispatch(
        &self,
        client: &Arc<Client>,
        s: &mut Session,
        req: &Request,
        audit: &mut Option<crate::audit_log::Pending>,
    ) -> Option<Reply> {
        let shared = &self.shared;
        let err = |c| Some(Reply::Error(c));
        // The net: given, else the default; only the gateway's own exists.
        let net = req.net.or(s.net);
        if req.command.level() != Level::Gateway {
            match net {
                None => return err(ErrorCode::NO_DEFAULT_NET),
                Some(n) if n != shared.config.net => return err(ErrorCode::UNSUPPORTED_NET),
                Some(_) => {}
            }
        }
        let node = req.node.or(s.node);
        let sdo_node = || match node {
            None => Err(ErrorCode::NO_DEFAULT_NODE),
            Some(n) => NodeId::new(n).map_err(|_| ErrorCode::UNSUPPORTED_NODE),
        };
        let mut queue = |key: u8, work: Work| {
            let w = shared.worker(key);
            lock(&client.out).pending += 1;
            lock(&w.queue).push(Job {
                client: client.clone(),
                seq: req.seq,
                work,
                audit: audit.take(),
            });
            w.cond.notify_one();
            None
        };
        match &req.command {
            Command::Read {
                index,
                sub,
                data_type,
            } => match sdo_node() {
                Ok(node) => queue(
                    node.get(),
                    Work::Read {
                        node,
                        index: *index,
                        sub: *sub,
                        data_type: *data_type,
                        sdo: s.sdo,
                    },
                ),
                Err(c) => err(c),
            },
            Command::Write { index, sub, value } => match sdo_node() {
                Ok(node) => queue(
                    node.get(),
                    Work::Write {
                        node,
                        index: *index,
                        sub: *sub,
                        value: value.clone(),
                        sdo: s.sdo,
                    },
                ),
                Err(c) => err(c),
            },
            Command::Nmt(service) => match node {
                None => err(ErrorCode::NO_DEFAULT_NODE),
                Some(n) if n > 127 => err(ErrorCode::UNSUPPORTED_NODE),
                // To all nodes: at once.
                Some(0) => Some(exec::nmt(&shared.net, 0, *service)),
                // Behind this connection's earlier requests to the node.
                Some(n) => queue(
                    n,
                    Work::Nmt {
                        node: n,
                        service: *service,
                    },
                ),
            },
            Command::SetNetwork(n) => {
                if *n != shared.config.net {
                    return err(ErrorCode::UNSUPPORTED_NET);
                }
                s.net = Some(*n);
                Some(Reply::Ok)
            }
            Command::SetNode(n) => {
                if *n > 127 {
                    return err(ErrorCode::UNSUPPORTED_NODE);
                }
                s.node = Some(*n);
                Some(Reply::Ok)
            }
            Command::SetSdoTimeout(ms) => {
                s.sdo.timeout = Duration::from_millis((*ms).into());
                Some(Reply::Ok)
            }
            Command::SetSdoBlock(b) => {
                s.sdo.block = *b;
                Some(Reply::Ok)
            }
            Command::Help(topic) => Some(Reply::Lines(help(*topic))),
            Command::InfoVersion => Some(Reply::Text(version_text(&shared.config.version))),
            Command::Events(on) => {
                client.events.store(*on, Ordering::Relaxed);
                Some(Reply::Ok)
            }
            lss => queue(0, Work::Lss(lss.clone())),
        }
    }

    /// Accepts TCP connections on `listener` on a thread, each served on a thread of its own.
    pub fn serve_tcp(&self, listener: std::net::TcpListener) -> JoinHandle<()> {
        let gw = self.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(stream) = stream else { continue };
                let _ = stream.set_nodelay(true);
                // Access hook: the allow-list.
                let Ok(peer) = stream.peer_addr() else {
                    continue;
                };
                if !gw.shared.config.access.admits(peer.ip()) {
                    gw.shared.access_counters.count_not_allowed();
                    let _ =
                        (&stream).write_all(error_text(None, ErrorCode::INTERNAL_STATE).as_bytes());
                    continue;
                }
                gw.spawn_socket(stream, crate::access::Peer::Tcp(peer));
            }
        })
    }

    /// Accepts connections on a Unix socket on a thread, each served on a thread of its own.
    #[cfg(unix)]
    pub fn serve_unix(&self, listener: std::os::unix::net::UnixListener) -> JoinHandle<()> {
        let gw = self.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(stream) = stream else { continue };
                gw.spawn_socket(stream, crate::access::Peer::Unix);
            }
        })
    }

    /// Serves standard input and output as one connection until standard input ends.
    pub fn serve_stdio(&self) {
        self.serve_stream(std::io::stdin().lock(), std::io::stdout());
    }

    /// Serves a socket connection on a thread of its own, under the connection limits.
    fn spawn_socket<S: crate::conn_limits::Socket + Write>(
        &self,
        stream: S,
        peer: crate::access::Peer,
    ) {
        let Ok(mut writer) = stream.handle() else {
            return;
        };
        let cfg = &self.shared.config;
        let live = {
            let mut c = lock(&self.shared.clients);
            c.retain(|w| w.strong_count() > 0);
            c.len()
        };
        if live >= cfg.max_connections
            && !self.shared.conns.evict_idlest(cfg.limits.evict_idle_after)
        {
            let _ = writer.write_all(error_text(None, ErrorCode::OUT_OF_MEMORY).as_bytes());
            return;
        }
        let Ok(reg) = self.shared.conns.register(&stream) else {
            return;
        };
        let first_line_due = cfg.access.needs_token();
        let reader = crate::conn_limits::Guarded::new(stream, reg, &cfg.limits, first_line_due);
        let gw = self.clone();
        let _ = std::thread::Builder::new()
            .name("gateway-connection".into())
            .spawn(move || gw.serve_peer(reader, writer, peer));
    }

    /// Stops the background threads (event forwarding, driver, queue workers) once their
    /// current request is done. Connections still being served end with their streams.
    pub fn shutdown(&self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        for w in lock(&self.shared.workers).values() {
            lock(&w.queue).stop = true;
            w.cond.notify_all();
        }
        let threads: Vec<_> = lock(&self.shared.threads).drain(..).collect();
        for t in threads {
            let _ = t.join();
        }
    }
}

/// Reads one line (up to and including LF, or to the end of the stream) into `line`, keeping
/// at most `max` bytes of it. Returns (too long, end of stream).
fn read_line(
    r: &mut impl BufRead,
    line: &mut Vec<u8>,
    max: usize,
) -> std::io::Result<(bool, bool)> {
    let mut too_long = false;
    loop {
        let buf = match r.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            return Ok((too_long, true));
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(p) => (p + 1, true),
            None => (buf.len(), false),
        };
        let room = max.saturating_sub(line.len());
        if take > room {
            too_long = true;
        }
        line.extend_from_slice(&buf[..take.min(room)]);
        r.consume(take);
        if done {
            return Ok((too_long, false));
        }
    }
}

/// The sequence number at the start of raw line bytes, if readable.
fn leading_seq(line: &[u8]) -> Option<u32> {
    let t = line.strip_prefix(b"[")?;
    let end = t.iter().position(|&b| b == b']')?;
    std::str::from_utf8(&t[..end]).ok()?.trim().parse().ok()
}

fn error_text(seq: Option<u32>, code: ErrorCode) -> String {
    Response {
        seq,
        reply: Reply::Error(code),
    }
    .to_text()
}

fn write_outbox(client: &Client, mut writer: impl Write) {
    loop {
        let item = {
            let mut o = lock(&client.out);
            loop {
                if let Some(item) = o.queue.pop_front() {
                    break Some(item);
                }
                if o.reading_done && o.pending == 0 {
                    break None;
                }
                o = client
                    .cond
                    .wait(o)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        };
        let Some(item) = item else {
            let _ = writer.flush();
            return;
        };
        let text = match &item {
            Out::Reply(t) | Out::Event(t) => t,
        };
        let ok = writer.write_all(text.as_bytes()).is_ok() && writer.flush().is_ok();
        let mut o = lock(&client.out);
        match item {
            Out::Reply(_) => o.replies -= 1,
            Out::Event(_) => o.events -= 1,
        }
        if !ok {
            o.gone = true;
            o.queue.clear();
            o.replies = 0;
            o.events = 0;
        }
        drop(o);
        client.cond.notify_all();
        if !ok {
            return;
        }
    }
}

fn forward_events(shared: &Shared, events: &mpsc::Receiver<NetworkEvent>) {
    let net = shared.config.net;
    while !shared.stop.load(Ordering::SeqCst) {
        let Ok(ev) = events.recv_timeout(std::time::Duration::from_millis(100)) else {
            continue;
        };
        let line = |node: NodeId, kind| Event {
            net,
            node: node.get(),
            kind,
        };
        let event = match ev {
            NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node })
            | NetworkEvent::Guarding(GuardingEvent::BootUp { node }) => {
                line(node, EventKind::BootUp)
            }
            NetworkEvent::Heartbeat(HeartbeatEvent::Lost { node, .. }) => {
                line(node, EventKind::Error(ErrorCode::HEARTBEAT_LOST))
            }
            NetworkEvent::Heartbeat(HeartbeatEvent::Recovered { node, .. }) => {
                line(node, EventKind::Error(ErrorCode::HEARTBEAT_STARTED))
            }
            NetworkEvent::Guarding(GuardingEvent::Lost { node, .. }) => {
                line(node, EventKind::Error(ErrorCode::LOST_GUARDING))
            }
            NetworkEvent::Emcy(e) => line(
                e.node,
                EventKind::Emcy {
                    code: e.emcy.code.0,
                    register: e.emcy.register.bits(),
                    manufacturer: e.emcy.manufacturer,
                },
            ),
            _ => continue,
        };
        shared.broadcast(&format!("{event}\r\n"));
    }
}

/// Drives the network for `period` at a time while no request runs (a running request's
/// thread drives it then, without waiting for this one's receive slices), so events arrive
/// when the gateway is idle. On a virtual-clock bus this also keeps simulated time close to
/// real time.
fn drive(shared: &Shared, period: std::time::Duration) {
    let step = Duration::from_micros(period.as_micros().try_into().unwrap_or(u64::MAX));
    while !shared.stop.load(Ordering::SeqCst) {
        let start = std::time::Instant::now();
        if shared.active.load(Ordering::SeqCst) == 0 {
            let _ = shared.net.run_for(step);
        }
        if let Some(rest) = period.checked_sub(start.elapsed()) {
            std::thread::sleep(rest);
        }
    }
}

fn version_text(v: &Version) -> String {
    format!(
        "{} {} {}.{} {} {} {}.{} {}.{}",
        v.vendor_id,
        v.product_code,
        v.revision >> 16,
        v.revision & 0xFFFF,
        v.serial,
        v.class,
        v.protocol.0,
        v.protocol.1,
        v.implementation.0,
        v.implementation.1
    )
}

fn help(topic: Option<HelpTopic>) -> Vec<String> {
    let text = match topic {
        None => HELP,
        Some(HelpTopic::DataType) => HELP_DATATYPE,
        Some(HelpTopic::Lss) => HELP_LSS,
    };
    text.lines().map(str::to_owned).collect()
}

const HELP: &str = "\
# Requests: [<seq>] [[<net>] <node>] <command>, one per line (CR LF or LF); '#' starts a comment.
# r[ead] <index> <sub> [<type>]          SDO upload
# w[rite] <index> <sub> <type> <value>   SDO download
# start | stop | preop[erational] | reset node | reset comm[unication]   NMT (node 0: all)
# [<net>] set network <n> | set node <n> | set sdo_timeout <ms> | set sdo_block 0|1
# help [datatype|lss] | info version | _events 0|1 (event lines on this connection)
# Replies: [<seq>] OK | <value> | ERROR:0x<SDO abort code> | ERROR:<gateway error code>";

const HELP_DATATYPE: &str = "\
# b  boolean 0|1; i8 i16 i32 i64 u8 u16 u32 u64 integers (decimal or 0x hex)
# x8 x16 x32 x64  unsigned, shown in hex; r32 r64 reals
# t td  time of day, time difference: <days> <ms>
# vs  visible string, \"quoted\" (inner quotes doubled) or one word
# os us d  octet string, unicode string, domain: base64; hex  bytes in hex";

const HELP_LSS: &str = "\
# lss_switch_glob 0|1 | lss_switch_sel <vendor> <product> <revision> <serial>
# lss_set_node <node> | lss_conf_bitrate <table> <index> | lss_activate_bitrate <delay_ms>
# lss_store | lss_inquire_addr [0..3] | lss_get_node | _lss_fastscan [<timeout_ms>]
# lss_allnodes [<timeout_ms> [<node_start> <store 0|1> [<scan type> <value>]x4]]
#   scan type 0: find by Fastscan, 1: ignore (not the vendor-ID), 2: match the value";

#[cfg(test)]
mod tests {
    use super::*;

    fn client(id: u64) -> Arc<Client> {
        Arc::new(Client {
            id,
            out: Mutex::new(OutboxState::default()),
            cond: Condvar::new(),
            events: AtomicBool::new(false),
        })
    }

    fn job(c: &Arc<Client>, seq: u32) -> Job {
        Job {
            client: c.clone(),
            seq: Some(seq),
            work: Work::Lss(Command::LssStore),
            audit: None,
        }
    }

    #[test]
    fn the_queue_serves_connections_round_robin() {
        let (a, b, c) = (client(1), client(2), client(3));
        let mut q = FairQueue::default();
        for seq in 0..5 {
            q.push(job(&a, seq));
        }
        q.push(job(&b, 100));
        q.push(job(&b, 101));
        q.push(job(&c, 200));
        let order: Vec<_> = std::iter::from_fn(|| q.pop())
            .map(|j| (j.client.id, j.seq.unwrap()))
            .collect();
        assert_eq!(
            order,
            [
                (1, 0),
                (2, 100),
                (3, 200),
                (1, 1),
                (2, 101),
                (1, 2),
                (1, 3),
                (1, 4)
            ]
        );
    }

    #[test]
    fn lines_are_cut_at_the_limit_and_the_rest_skipped() {
        let mut r = BufReader::with_capacity(8, &b"[1] abcdefghijkl\n[2] ok\nlast"[..]);
        let mut line = Vec::new();
        assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (true, false));
        assert_eq!(line, b"[1] abcdef");
        assert_eq!(leading_seq(&line), Some(1));
        line.clear();
        assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (false, false));
        assert_eq!(line, b"[2] ok\n");
        line.clear();
        assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (false, true));
        assert_eq!(line, b"last");
    }
}
