//! The gateway's queues and the state the threads share: one fair queue per node (SDO and
//! NMT) and one for LSS, each served round-robin over the connections; the [`Shared`] state
//! they hang off; and the thread that turns network events into event lines. The threads that
//! serve the queues are in `dispatch`.

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, mpsc};
use std::thread::JoinHandle;

use canola::frame::NodeId;
use canola::nmt::{GuardingEvent, HeartbeatEvent};
use canola::{Network, NetworkEvent};

use crate::command::{Command, ErrorCode, Event, EventKind};
use crate::exec::SdoSettings;
use crate::value::DataType;

use super::client::{Client, lock};
use super::config::Config;

/// A job of a node or LSS queue.
pub(super) struct Job {
    pub(super) client: Arc<Client>,
    pub(super) seq: Option<u32>,
    pub(super) work: Work,
    /// The audit log line waiting for the reply (a request that changes the network).
    pub(super) audit: Option<crate::audit_log::Pending>,
}

pub(super) enum Work {
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
pub(super) struct FairQueue {
    pub(super) clients: VecDeque<(u64, VecDeque<Job>)>,
    pub(super) stop: bool,
}

impl FairQueue {
    pub(super) fn push(&mut self, job: Job) {
        let id = job.client.id;
        match self.clients.iter_mut().find(|(c, _)| *c == id) {
            Some((_, q)) => q.push_back(job),
            None => self.clients.push_back((id, VecDeque::from([job]))),
        }
    }

    pub(super) fn pop(&mut self) -> Option<Job> {
        let (id, mut q) = self.clients.pop_front()?;
        let job = q.pop_front();
        if !q.is_empty() {
            self.clients.push_back((id, q));
        }
        job
    }
}

/// The LSS queue and the signal of a job queued to it (or of the stop).
#[derive(Default)]
pub(super) struct Worker {
    pub(super) queue: Mutex<FairQueue>,
    pub(super) cond: Condvar,
}

/// The node queues (SDO and NMT jobs), served by the dispatcher.
#[derive(Default)]
pub(super) struct NodeQueues {
    pub(super) queues: BTreeMap<u8, FairQueue>,
    /// Jobs in `queues`.
    pub(super) queued: usize,
    /// Set by shutdown: no job is started any more.
    pub(super) stop: bool,
}

impl NodeQueues {
    /// The next job of `node`, if one waits.
    pub(super) fn pop(&mut self, node: u8) -> Option<Job> {
        let job = self.queues.get_mut(&node)?.pop()?;
        self.queued -= 1;
        Some(job)
    }
}

pub(super) struct Shared {
    pub(super) net: Network,
    pub(super) config: Config,
    /// The node queues and the dispatcher's signal: a job queued, or the stop.
    pub(super) nodes: Mutex<NodeQueues>,
    pub(super) nodes_cond: Condvar,
    /// The LSS queue; its thread starts with the first LSS request.
    pub(super) lss: Worker,
    pub(super) lss_started: AtomicBool,
    pub(super) clients: Mutex<Vec<std::sync::Weak<Client>>>,
    pub(super) next_client: AtomicU64,
    pub(super) stop: AtomicBool,
    pub(super) threads: Mutex<Vec<JoinHandle<()>>>,
    /// What access control refused.
    pub(super) access_counters: crate::access::Counters,
    /// The socket connections, for the connection limits.
    pub(super) conns: Arc<crate::conn_limits::ConnTable>,
}

impl Shared {
    /// Queues `job` behind the earlier jobs to `node` and wakes the dispatcher.
    pub(super) fn queue_node(&self, node: u8, job: Job) {
        let mut q = lock(&self.nodes);
        q.queues.entry(node).or_default().push(job);
        q.queued += 1;
        drop(q);
        self.nodes_cond.notify_one();
    }

    /// Queues an LSS job, starting the LSS thread with the first one.
    pub(super) fn queue_lss(self: &Arc<Self>, job: Job) {
        if !self.lss_started.swap(true, Ordering::SeqCst) {
            let shared = self.clone();
            let h = std::thread::Builder::new()
                .name("gateway-lss".into())
                .spawn(move || super::dispatch::serve_lss(&shared));
            if let Ok(h) = h {
                lock(&self.threads).push(h);
            }
        }
        lock(&self.lss.queue).push(job);
        self.lss.cond.notify_one();
    }

    pub(super) fn broadcast(&self, line: &str) {
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

pub(super) fn forward_events(shared: &Shared, events: &mpsc::Receiver<NetworkEvent>) {
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
