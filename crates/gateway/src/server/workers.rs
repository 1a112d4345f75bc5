//! The gateway's queues and the threads that serve them: one queue per node and one for LSS,
//! each served round-robin over the connections by its worker; the shared state they hang off;
//! the thread that drives the network while no request runs and the one that turns network
//! events into event lines.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, mpsc};
use std::thread::JoinHandle;

use canola::frame::{Duration, NodeId};
use canola::nmt::{GuardingEvent, HeartbeatEvent};
use canola::{Network, NetworkEvent};

use crate::command::{Command, ErrorCode, Event, EventKind, Response};
use crate::exec::{self, SdoSettings};
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

pub(super) struct Worker {
    pub(super) queue: Mutex<FairQueue>,
    pub(super) cond: Condvar,
}

pub(super) struct Shared {
    pub(super) net: Network,
    pub(super) config: Config,
    /// One worker per node (SDO), created on first use, and one for LSS (key 0).
    pub(super) workers: Mutex<HashMap<u8, Arc<Worker>>>,
    pub(super) clients: Mutex<Vec<std::sync::Weak<Client>>>,
    pub(super) next_client: AtomicU64,
    pub(super) stop: AtomicBool,
    pub(super) threads: Mutex<Vec<JoinHandle<()>>>,
    /// Requests being carried out: while there are any, their threads drive the network.
    pub(super) active: std::sync::atomic::AtomicUsize,
    /// What access control refused.
    pub(super) access_counters: crate::access::Counters,
    /// The socket connections, for the connection limits.
    pub(super) conns: Arc<crate::conn_limits::ConnTable>,
}

impl Shared {
    pub(super) fn worker(self: &Arc<Self>, key: u8) -> Arc<Worker> {
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

    pub(super) fn serve_queue(&self, w: &Worker) {
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

/// Drives the network for `period` at a time while no request runs (a running request's
/// thread drives it then, without waiting for this one's receive slices), so events arrive
/// when the gateway is idle. On a virtual-clock bus this also keeps simulated time close to
/// real time.
pub(super) fn drive(shared: &Shared, period: std::time::Duration) {
    let step = Duration::from_micros(period.as_micros().try_into().unwrap_or(u64::MAX));
    while !shared.stop.load(Ordering::SeqCst) {
        let start = std::time::Instant::now();
        if shared.active.load(Ordering::SeqCst) == 0 {
            let _ = shared.net.run_for(step).wait();
        }
        if let Some(rest) = period.checked_sub(start.elapsed()) {
            std::thread::sleep(rest);
        }
    }
}
