//! [`Gateway`]: accepting connections (TCP, Unix socket, stdio, any byte stream), reading
//! each connection's lines, answering what needs no bus at once and dispatching the rest to
//! the queues; `help` and `info version` texts.

use std::io::{BufReader, Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use canola::Network;
use canola::frame::{Duration, NodeId};

use crate::command::{Command, ErrorCode, HelpTopic, Level, Reply, Request, Response};
use crate::exec::{self, SdoSettings};
use crate::parse::{ParseError, parse_line};

use super::client::{Client, OutboxState, error_text, leading_seq, lock, read_line, write_outbox};
use super::config::{Config, Version};
use super::queues::{Job, NodeQueues, Shared, Work, Worker, forward_events};

/// Per-connection settings.
pub(super) struct Session {
    pub(super) net: Option<u16>,
    pub(super) node: Option<u8>,
    pub(super) sdo: SdoSettings,
    /// Role and peer ([`crate::access`]).
    pub(super) access: crate::access::ConnAccess,
    pub(super) bad_lines: crate::conn_limits::BadLines,
}

/// The CiA 309-3 gateway in front of one [`Network`]. Cheap to clone.
///
/// ```
/// use canola::{MemoryBus, Network, SimDevice};
/// use canola_gateway::{Config, Gateway};
///
/// let bus = MemoryBus::new();
/// let net = Network::new(bus.endpoint());
/// let eds = include_bytes!("../../../../eds/burkert-generic.eds");
/// bus.attach(SimDevice::from_eds(canola::frame::NodeId::new(5).unwrap(), eds).unwrap());
/// let gateway = Gateway::new(net, Config::default());
/// let mut out = Vec::new();
/// gateway.serve_stream(&b"[1] 5 write 0x1017 0 u16 250\n[2] 5 read 0x1017 0 u16\n"[..], &mut out);
/// assert_eq!(String::from_utf8(out).unwrap(), "[1] OK\r\n[2] 250\r\n");
/// ```
#[derive(Clone)]
pub struct Gateway {
    pub(super) shared: Arc<Shared>,
}

impl core::fmt::Debug for Gateway {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Gateway")
            .field("net", &self.shared.config.net)
            .finish_non_exhaustive()
    }
}

impl Gateway {
    /// A gateway for `net`. Starts the dispatcher (which serves the node queues and drives the
    /// network, see [`Config::drive_period`]) and the event thread.
    pub fn new(net: Network, config: Config) -> Self {
        let events = net.subscribe();
        let shared = Arc::new(Shared {
            net,
            config,
            nodes: Mutex::new(NodeQueues::default()),
            nodes_cond: Condvar::new(),
            lss: Worker::default(),
            lss_started: AtomicBool::new(false),
            clients: Mutex::new(Vec::new()),
            next_client: AtomicU64::new(1),
            stop: AtomicBool::new(false),
            threads: Mutex::new(Vec::new()),
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
        let s = shared.clone();
        if let Ok(h) = std::thread::Builder::new()
            .name("gateway-dispatch".into())
            .spawn(move || super::dispatch::serve_nodes(&s))
        {
            lock(&shared.threads).push(h);
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

    pub(super) fn read_requests(
        &self,
        client: &Arc<Client>,
        reader: impl Read,
        peer: crate::access::Peer,
    ) {
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
    pub(super) fn handle_line(
        &self,
        client: &Arc<Client>,
        session: &mut Session,
        text: &str,
    ) -> bool {
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
            Err(e @ ParseError::OutOfRange { .. }) => {
                let reply = crate::command::Response {
                    seq: e.seq(),
                    reply: crate::command::Reply::Abort(e.abort_code().unwrap_or(0x0609_0030)),
                };
                client.reply(reply.to_text());
                return true;
            }
            Err(e) => {
                let code = match e {
                    ParseError::OutOfRange { .. } | ParseError::Syntax { .. } => ErrorCode::SYNTAX,
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
    pub(super) fn dispatch(
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
        let mut job = |work: Work| {
            lock(&client.out).pending += 1;
            Job {
                client: client.clone(),
                seq: req.seq,
                work,
                audit: audit.take(),
            }
        };
        let mut queue = |node: u8, work: Work| {
            shared.queue_node(node, job(work));
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
            lss => {
                shared.queue_lss(job(Work::Lss(lss.clone())));
                None
            }
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
    pub(super) fn spawn_socket<S: crate::conn_limits::Socket + Write>(
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

    /// Stops the background threads (event forwarding, the dispatcher, the LSS thread) once
    /// their running requests are done; queued requests are not started. Connections still
    /// being served end with their streams.
    pub fn shutdown(&self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        lock(&self.shared.nodes).stop = true;
        self.shared.nodes_cond.notify_all();
        lock(&self.shared.lss.queue).stop = true;
        self.shared.lss.cond.notify_all();
        let threads: Vec<_> = lock(&self.shared.threads).drain(..).collect();
        for t in threads {
            let _ = t.join();
        }
    }
}

pub(super) fn version_text(v: &Version) -> String {
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

pub(super) fn help(topic: Option<HelpTopic>) -> Vec<String> {
    let text = match topic {
        None => HELP,
        Some(HelpTopic::DataType) => HELP_DATATYPE,
        Some(HelpTopic::Lss) => HELP_LSS,
    };
    text.lines().map(str::to_owned).collect()
}

pub(super) const HELP: &str = "\
# Requests: [<seq>] [[<net>] <node>] <command>, one per line (CR LF or LF); '#' starts a comment.
# r[ead] <index> <sub> [<type>]          SDO upload
# w[rite] <index> <sub> <type> <value>   SDO download
# start | stop | preop[erational] | reset node | reset comm[unication]   NMT (node 0: all)
# [<net>] set network <n> | set node <n> | set sdo_timeout <ms> | set sdo_block 0|1
# help [datatype|lss] | info version | _events 0|1 (event lines on this connection)
# Replies: [<seq>] OK | <value> | ERROR:0x<SDO abort code> | ERROR:<gateway error code>";

pub(super) const HELP_DATATYPE: &str = "\
# b  boolean 0|1; i8 i16 i32 i64 u8 u16 u32 u64 integers (decimal or 0x hex)
# x8 x16 x32 x64  unsigned, shown in hex; r32 r64 reals
# t td  time of day, time difference: <days> <ms>
# vs  visible string, \"quoted\" (inner quotes doubled) or one word
# os us d  octet string, unicode string, domain: base64; hex  bytes in hex";

pub(super) const HELP_LSS: &str = "\
# lss_switch_glob 0|1 | lss_switch_sel <vendor> <product> <revision> <serial>
# lss_set_node <node> | lss_conf_bitrate <table> <index> | lss_activate_bitrate <delay_ms>
# lss_store | lss_inquire_addr [0..3] | lss_get_node | _lss_fastscan [<timeout_ms>]
# lss_allnodes [<timeout_ms> [<node_start> <store 0|1> [<scan type> <value>]x4]]
#   scan type 0: find by Fastscan, 1: ignore (not the vendor-ID), 2: match the value";
