//! The threads that serve the queues: the dispatcher, one thread for every node's queue, and
//! the LSS thread.
//!
//! The dispatcher keeps at most one job per node in flight: it starts a node's next job (the
//! node's queue is fair over the connections) as a [`Pending`](canola::Pending) SDO request,
//! so requests to different nodes run on the bus together, drives the network itself with
//! [`Network::run_step`](canola::Network::run_step) while any runs, and answers each job as its
//! request ends. NMT jobs wait on nothing: they are answered as they are started. While no job
//! runs, it waits for one to be queued, driving the network meanwhile when
//! [`Config::drive_period`](super::Config::drive_period) asks for it (heartbeats, boot-up and
//! EMCY are then received while the gateway is idle; a virtual clock is kept near real time).
//!
//! LSS services are sequences of steps that the facade offers only as blocking
//! [`Operation`](canola::Operation)s, so they run on a thread of their own, one for the bus (one
//! LSS channel per bus), started with the first LSS request. While one runs, that thread and
//! the dispatcher share the driving of the network (whoever steps handles every frame), so SDO
//! requests to the nodes go on meanwhile.

use std::sync::atomic::Ordering;

use canola::frame::Duration;

use crate::command::{ErrorCode, Reply, Response};
use crate::exec::{self, Transfer};

use super::client::lock;
use super::queues::{Job, Shared, Work};

/// Longest a driving step lasts while requests run: a job queued meanwhile starts within it
/// (a received frame ends the step sooner).
const BUSY_STEP: Duration = Duration::from_millis(1);

/// How long the dispatcher waits after the transport failed before it drives again.
const AFTER_FAILURE: std::time::Duration = std::time::Duration::from_millis(1);

/// A job whose SDO request runs.
struct Running {
    job: Job,
    transfer: Transfer,
}

/// Where the idle driving started, on both clocks: a virtual clock is not driven ahead of
/// real time.
struct Pace {
    real: std::time::Instant,
    net: canola::frame::Instant,
}

/// The dispatcher's loop, until shutdown (after which the running jobs are finished, and
/// queued ones are left).
pub(super) fn serve_nodes(shared: &Shared) {
    // Indexed by node-ID (1..=127).
    let mut running: Vec<Option<Running>> = (0..128).map(|_| None).collect();
    let mut in_flight = 0usize;
    let mut pace: Option<Pace> = None;
    let mut starting = Vec::new();
    loop {
        // The next job of every node with none running.
        let stop = {
            let mut q = lock(&shared.nodes);
            if !q.stop && q.queued > 0 {
                let free: Vec<u8> = q
                    .queues
                    .iter()
                    .filter(|(n, fq)| !fq.clients.is_empty() && running[usize::from(**n)].is_none())
                    .map(|(n, _)| *n)
                    .collect();
                for n in free {
                    if let Some(job) = q.pop(n) {
                        starting.push((n, job));
                    }
                }
            }
            q.stop
        };
        if stop && in_flight == 0 {
            return;
        }
        let mut progressed = false;
        for (n, job) in starting.drain(..) {
            match start(shared, job) {
                Some(r) => {
                    running[usize::from(n)] = Some(r);
                    in_flight += 1;
                }
                // Answered at once: the node's next job may start.
                None => progressed = true,
            }
        }
        // Answer the jobs whose requests ended.
        if in_flight > 0 {
            for slot in &mut running {
                if slot.as_ref().is_some_and(|r| r.transfer.is_done())
                    && let Some(r) = slot.take()
                {
                    answer(&r.job, r.transfer.reply());
                    in_flight -= 1;
                    progressed = true;
                }
            }
        }
        if progressed {
            continue;
        }
        if in_flight > 0 {
            pace = None;
            if shared.net.run_step(BUSY_STEP).is_err() {
                // The transport failed: so does every running request (as the master's error
                // for it would be, a local failure), and the loop does not spin meanwhile.
                for r in running.iter_mut().filter_map(Option::take) {
                    drop(r.transfer);
                    answer(&r.job, Reply::Error(ErrorCode::INTERNAL_STATE));
                }
                in_flight = 0;
                std::thread::sleep(AFTER_FAILURE);
            }
            continue;
        }
        idle(shared, &mut pace);
    }
}

/// No job runs: waits for one to be queued (or the stop), driving the network meanwhile when
/// the configuration asks for it.
fn idle(shared: &Shared, pace: &mut Option<Pace>) {
    let net = &shared.net;
    let wait = match shared.config.drive_period {
        None => None,
        Some(period) => {
            let p = pace.get_or_insert_with(|| Pace {
                real: std::time::Instant::now(),
                net: net.now(),
            });
            let driven = std::time::Duration::from(net.now() - p.net);
            match driven.checked_sub(p.real.elapsed()) {
                // A virtual clock ahead of real time: wait for real time to catch up.
                // (A real clock's two readings differ by far less than a step.)
                Some(ahead) if ahead >= BUSY_STEP.into() => Some(ahead),
                _ => {
                    if net.run_step(Duration::from(period)).is_err() {
                        // A failed transport: try again a period later (or at a new job).
                        *pace = None;
                        Some(period)
                    } else {
                        return;
                    }
                }
            }
        }
    };
    let q = lock(&shared.nodes);
    if q.stop || q.queued > 0 {
        return;
    }
    match wait {
        Some(t) => drop(
            shared
                .nodes_cond
                .wait_timeout(q, t)
                .unwrap_or_else(std::sync::PoisonError::into_inner),
        ),
        None => drop(
            shared
                .nodes_cond
                .wait(q)
                .unwrap_or_else(std::sync::PoisonError::into_inner),
        ),
    }
}

/// Starts `job`: its running SDO request, or `None` when it was answered at once (an NMT
/// command, a connection that is gone).
fn start(shared: &Shared, job: Job) -> Option<Running> {
    if job.client.gone() {
        job.client.complete(String::new());
        return None;
    }
    let net = &shared.net;
    let transfer = match &job.work {
        Work::Read {
            node,
            index,
            sub,
            data_type,
            sdo,
        } => exec::submit_read(net, *node, *index, *sub, *data_type, *sdo),
        Work::Write {
            node,
            index,
            sub,
            value,
            sdo,
        } => exec::submit_write(net, *node, *index, *sub, value, *sdo),
        Work::Nmt { node, service } => {
            let reply = exec::nmt(net, *node, *service);
            answer(&job, reply);
            return None;
        }
        // Not queued to a node.
        Work::Lss(_) => {
            answer(&job, Reply::Error(ErrorCode::INTERNAL_STATE));
            return None;
        }
    };
    Some(Running { job, transfer })
}

/// Sends a job's reply to its connection (dropped there if the connection is gone) and to the
/// audit log.
fn answer(job: &Job, reply: Reply) {
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

/// The LSS thread's loop, until shutdown: one LSS job at a time, round-robin over the
/// connections.
pub(super) fn serve_lss(shared: &Shared) {
    let w = &shared.lss;
    loop {
        let job = {
            let mut q = lock(&w.queue);
            loop {
                if q.stop || shared.stop.load(Ordering::SeqCst) {
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
        let reply = match &job.work {
            Work::Lss(c) => exec::lss(&shared.net, c),
            // Only LSS jobs are queued here.
            _ => Reply::Error(ErrorCode::INTERNAL_STATE),
        };
        answer(&job, reply);
    }
}
