//! Python callbacks of received messages (`pdo_map.add_callback`, `node.emcy.add_callback`).
//!
//! The facade calls its own callbacks on the thread that drives the network, with the network
//! locked: no place to run Python code, which may call the network itself. So a facade
//! callback only queues a job here, and the job runs with the GIL held in one of two places:
//!
//! * a blocking call of this package that waits (`wait`) runs the jobs queued while it drives
//!   the network, between driving steps and before it returns. On a virtual-clock bus that
//!   makes callbacks deterministic: those of the messages a wait received have run when it
//!   returns.
//! * the dispatcher thread (started by the first `add_callback`, or by a subscription that
//!   must be drained) runs them when no such wait is running: on a network driven in the
//!   background, callbacks come without any call.
//!
//! Subscriptions of the facade that need draining (the EMCY consumers' events) are polled at
//! the same places (`poll`).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, Once};

use pyo3::prelude::*;

use crate::network::lock;

/// A queued callback run: calls the Python callbacks of one received message.
pub(crate) type Job = Box<dyn FnOnce(Python<'_>) + Send>;

static QUEUE: Mutex<VecDeque<Job>> = Mutex::new(VecDeque::new());
static READY: Condvar = Condvar::new();
/// Whether jobs are queued (checked without the lock on every driving step).
static PENDING: AtomicBool = AtomicBool::new(false);
/// Blocking calls of this package waiting now (they run the jobs themselves).
static WAITERS: AtomicUsize = AtomicUsize::new(0);
static DISPATCHER: Once = Once::new();

/// Something to look at regularly without the GIL (a subscription to drain); `false` once
/// it is gone.
pub(crate) type Poller = Box<dyn FnMut() -> bool + Send>;

static POLLERS: Mutex<Vec<Poller>> = Mutex::new(Vec::new());

/// Adds a poller, run by `poll` from now on until it returns `false`.
pub(crate) fn add_poller(p: Poller) {
    lock(&POLLERS).push(p);
}

/// Runs every poller once (the GIL not needed; they may queue jobs).
pub(crate) fn poll() {
    lock(&POLLERS).retain_mut(|p| p());
}

/// Queues `job` (callable without the GIL, from a facade callback).
pub(crate) fn push(job: Job) {
    lock(&QUEUE).push_back(job);
    PENDING.store(true, Ordering::SeqCst);
    READY.notify_all();
}

/// Whether jobs are queued.
pub(crate) fn pending() -> bool {
    PENDING.load(Ordering::SeqCst)
}

/// Runs the queued jobs, in order (the GIL held).
pub(crate) fn run_pending(py: Python<'_>) {
    loop {
        let job = {
            let mut q = lock(&QUEUE);
            let job = q.pop_front();
            if q.is_empty() {
                PENDING.store(false, Ordering::SeqCst);
            }
            job
        };
        match job {
            Some(job) => job(py),
            None => return,
        }
    }
}

/// Calls `callback(arg)`; an exception it raises is reported as unraisable (as python-can's
/// notifier thread logs it), not raised into whoever happened to run it.
pub(crate) fn call(py: Python<'_>, callback: &Py<PyAny>, arg: &Bound<'_, PyAny>) {
    if let Err(e) = callback.call1(py, (arg,)) {
        e.write_unraisable(py, Some(callback.bind(py)));
    }
}

/// Marks a blocking wait of this package as running until the guard is dropped.
pub(crate) struct Waiting;

impl Waiting {
    pub(crate) fn enter() -> Self {
        WAITERS.fetch_add(1, Ordering::SeqCst);
        Waiting
    }
}

impl Drop for Waiting {
    fn drop(&mut self) {
        WAITERS.fetch_sub(1, Ordering::SeqCst);
        READY.notify_all();
    }
}

/// Starts the dispatcher thread once.
pub(crate) fn start_dispatcher() {
    DISPATCHER.call_once(|| {
        std::thread::Builder::new()
            .name("canola-callbacks".into())
            .spawn(|| {
                loop {
                    loop {
                        if WAITERS.load(Ordering::SeqCst) == 0 {
                            poll();
                        }
                        let q = lock(&QUEUE);
                        if !q.is_empty() && WAITERS.load(Ordering::SeqCst) == 0 {
                            break;
                        }
                        drop(
                            READY
                                .wait_timeout(q, std::time::Duration::from_millis(50))
                                .unwrap_or_else(std::sync::PoisonError::into_inner),
                        );
                    }
                    // None while the interpreter shuts down: nothing to call then.
                    if Python::try_attach(run_pending).is_none() {
                        return;
                    }
                }
            })
            .expect("starting the callback thread");
    });
}
