//! [`Operation`]: what every facade call that waits on the bus returns, finished either by
//! [`wait`](Operation::wait) (blocking) or by `.await` (`tokio` feature); and [`join_all`],
//! which runs several operations together.
//!
//! Each operation is written once, as straight-line async code over a few primitives of this
//! module: [`until`] (drive the network until a condition on the core holds), [`run_request`]
//! (one SDO request to its end), [`wait_requests`] (several at once), [`run_until`] (let bus
//! time pass) and [`flush`]. How a primitive waits depends on who finishes the operation, a
//! thread-local mode:
//!
//! * [`Operation::wait`] polls the body on the calling thread with the primitives in blocking
//!   mode: each one drives the network itself until it is done (whoever waits drives, see
//!   [`crate::network`]), so every await is ready at once and the thread never parks. Several
//!   operations awaited in one body therefore run one after another.
//! * A waited [`join_all`] polls its operations in joined mode: a primitive that is not done
//!   checks its condition once, leaves its network and deadline in a thread-local and returns
//!   `Pending` (a request is submitted first, then waited for the same way). When every
//!   operation has been polled, the join drives each network waited on one step, no further
//!   than the earliest deadline left (and the network's own next timer, as any step), and
//!   polls them again. One thread, no timer tick: on a virtual-clock bus the run is
//!   deterministic, and the operations overlap on the bus as they would from several threads.
//!   A step that fails gives its error to the next wait on that network.
//! * `.await` runs the same body on a tokio task: the primitives wait as `crate::asynch`
//!   describes (a virtual-clock bus follows tokio's clock; a real clock waits on tokio's
//!   blocking pool), and a join is a future that polls its operations.
//!
//! Dropping an operation (or its future, or a join holding it) before it ends cancels its SDO
//! requests: a queued one is removed, a running transfer is aborted on the bus (0x08000000).

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use canola_frame::{Instant, NodeId};
use canola_od::ObjectAddress;

use super::shared::Shared;
use crate::error::{Error, SdoError, SdoErrorKind, TransportFailure};
use crate::machine::{Completion, Core, Request, RequestId, Taken};

/// A facade call that waits on the bus (an SDO transfer, a scan, an LSS service, a wait for a
/// node's state), typed by what it produces. Nothing happens until it is finished:
///
/// * blocking: `node.sdo().read((0x1017, 0)).wait()?`
/// * async (`tokio` feature): `node.sdo().read((0x1017, 0)).await?`
///
/// Dropping it unfinished, or dropping its future, cancels it (a running SDO transfer is
/// aborted on the bus). The lifetime is that of what the operation borrows (a [`PdoSet`]
/// being saved); most operations borrow nothing and are `'static`, so their futures can be
/// spawned. `E` is the error: this crate's [`Error`], or a profile's own (a CiA 402 drive's).
///
/// Other crates write their multi-step operations the same way, once, with
/// [`Operation::new`]: an async block that awaits this crate's operations. Without the `tokio`
/// feature every operation waits by blocking, awaited or not.
///
/// [`PdoSet`]: crate::PdoSet
#[must_use = "an operation does nothing until it is waited on or awaited"]
pub struct Operation<'a, T, E = Error> {
    /// Straight-line async code over the primitives: every operation, a single SDO request
    /// too, waits by one path.
    body: BoxedBody<'a, T, E>,
}

/// An operation as a future.
type BoxedBody<'a, T, E> = Pin<Box<dyn Future<Output = Result<T, E>> + Send + 'a>>;

impl<T, E> core::fmt::Debug for Operation<'_, T, E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Operation").finish_non_exhaustive()
    }
}

impl<'a, T, E> Operation<'a, T, E> {
    /// The operation whose body is `body`: an async block that awaits operations of this
    /// crate (and [`Pending`](crate::Pending) requests), in order, as straight-line code. It
    /// must await nothing tied to one runtime (a tokio timer): [`wait`](Self::wait) runs it
    /// on the calling thread. Wait on the bus with [`Network::run_for`](crate::Network::run_for).
    ///
    /// ```
    /// use canola::{Error, MemoryBus, Network, NodeId, Operation, SimDevice};
    ///
    /// /// The heartbeat time, doubled, written back: one operation of two transfers.
    /// fn double_heartbeat(node: canola::Node) -> Operation<'static, u16> {
    ///     Operation::new(async move {
    ///         let ms: u16 = node.read_typed((0x1017, 0)).await?;
    ///         node.sdo().write((0x1017, 0), ms * 2).await?;
    ///         Ok::<_, Error>(ms * 2)
    ///     })
    /// }
    ///
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// let bus = MemoryBus::new();
    /// let net = Network::new(bus.endpoint());
    /// let id = NodeId::new(5)?;
    /// bus.attach(SimDevice::from_eds(id, &include_bytes!("../../../../eds/burkert-generic.eds")[..])?);
    /// assert_eq!(double_heartbeat(net.node(id)).wait()?, 1000);
    /// # Ok(())
    /// # }
    /// ```
    pub fn new(body: impl Future<Output = Result<T, E>> + Send + 'a) -> Self {
        Self {
            body: Box::pin(body),
        }
    }

    /// The operation that runs `req` to its end and takes `output` from its completion.
    pub(crate) fn request(
        net: Shared,
        req: Request,
        output: fn(Completion) -> T,
        error: fn(SdoError) -> E,
    ) -> Self
    where
        T: Send + 'a,
        E: Send + 'a,
    {
        Self::new(async move { run_request(&net, req).await.map(output).map_err(error) })
    }

    /// An operation that ends at once with `r` (an argument already found wrong).
    pub fn ready(r: Result<T, E>) -> Self
    where
        T: Send + 'a,
        E: Send + 'a,
    {
        Self::new(async move { r })
    }

    /// Finishes the operation on this thread, driving the network until it ends.
    pub fn wait(self) -> Result<T, E> {
        let mut body = self.body;
        let _mode = ModeGuard::enter(Mode::Blocking);
        let waker = THREAD_WAKER.with(Waker::clone);
        let mut cx = Context::from_waker(&waker);
        loop {
            match body.as_mut().poll(&mut cx) {
                Poll::Ready(r) => return r,
                // Every primitive completes within its poll in blocking mode; a body that
                // awaits anything else is woken through this thread's waker.
                Poll::Pending => std::thread::park_timeout(std::time::Duration::from_millis(1)),
            }
        }
    }
}

/// `.await` an operation: with the `tokio` feature it waits on tokio without blocking (see the
/// `asynch` module); without it, it blocks as [`Operation::wait`] does.
impl<'a, T: 'a, E: 'a> std::future::IntoFuture for Operation<'a, T, E> {
    type Output = Result<T, E>;
    type IntoFuture = BoxedBody<'a, T, E>;

    fn into_future(self) -> Self::IntoFuture {
        self.body
    }
}

/// Wakes a thread finishing an operation.
struct ThreadWaker(std::thread::Thread);

impl Wake for ThreadWaker {
    fn wake(self: Arc<Self>) {
        self.0.unpark();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.unpark();
    }
}

/// How the primitives polled on this thread wait.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// On tokio (`.await` with the `tokio` feature): see the `asynch` module.
    Async,
    /// Inside [`Operation::wait`]: each primitive drives the network itself until it is done.
    Blocking,
    /// Inside the blocking loop of a [`join_all`]: a primitive that is not done says what it
    /// waits for (its network, its deadline) in [`JOINED`] and returns `Pending`; the loop
    /// drives the network one step and polls again.
    Joined,
}

thread_local! {
    /// How the primitives polled on this thread wait (outside any wait: `Async`).
    static MODE: Cell<Mode> = const { Cell::new(Mode::Async) };
    /// This thread's waker, made once.
    static THREAD_WAKER: Waker = Waker::from(Arc::new(ThreadWaker(std::thread::current())));
    /// What the bodies of a blocking join wait for (see [`Mode::Joined`]).
    static JOINED: RefCell<Waits> = const { RefCell::new(Waits::new()) };
}

/// What the pending primitives of a blocking join wait for.
struct Waits {
    /// Each network waited on (once), with the earliest deadline a wait on it gave.
    nets: Vec<(Shared, Option<Instant>)>,
    /// The driving steps of the join that failed, by network: each error goes to the next
    /// wait on its network (whoever drives gets the error, as in a blocking wait).
    failed: Vec<(Shared, Error)>,
}

impl Waits {
    const fn new() -> Self {
        Self {
            nets: Vec::new(),
            failed: Vec::new(),
        }
    }

    /// A wait on `net` that may end by time alone at `deadline`.
    fn wait_on(&mut self, net: &Shared, deadline: Option<Instant>) {
        match self.nets.iter_mut().find(|(n, _)| n.same(net)) {
            Some((_, d)) => {
                *d = match (*d, deadline) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                }
            }
            None => self.nets.push((net.clone(), deadline)),
        }
    }

    /// The error of a failed step on `net`, for one wait.
    fn take_failure(&mut self, net: &Shared) -> Option<Error> {
        let i = self.failed.iter().position(|(n, _)| n.same(net))?;
        Some(self.failed.swap_remove(i).1)
    }
}

/// A mode for this thread while it lives (restores the mode it found: a blocking wait inside
/// an async task ends in async mode again, one inside a join's body in joined mode).
struct ModeGuard(Mode);

impl ModeGuard {
    fn enter(mode: Mode) -> Self {
        Self(MODE.with(|m| m.replace(mode)))
    }
}

impl Drop for ModeGuard {
    fn drop(&mut self) {
        MODE.with(|m| m.set(self.0));
    }
}

/// How a primitive polled now waits. Without the `tokio` feature there is no async mode: an
/// operation awaited outside a wait blocks.
fn mode() -> Mode {
    match MODE.with(Cell::get) {
        Mode::Async if !cfg!(feature = "tokio") => Mode::Blocking,
        m => m,
    }
}

impl Shared {
    /// On a tokio runtime (`tokio` feature), brings a virtual-clock bus up to tokio's time (see
    /// the `asynch` module), so what is queued next is stamped with the time the application
    /// sees. Nothing to do otherwise. (Here, above the driving floor, so that the shared state
    /// at the bottom names no driving file.)
    pub(crate) fn catch_up_on_runtime(&self) -> Result<(), Error> {
        #[cfg(feature = "tokio")]
        if tokio::runtime::Handle::try_current().is_ok() {
            return super::tokio_driving::catch_up(self);
        }
        Ok(())
    }
}

/// Brings a virtual clock up to tokio's time before an operation stamps "now" (a request's
/// timeout, an LSS machine's timers, a wait's deadline). Nothing to do when blocking or on a
/// real clock.
pub(crate) fn catch_up(net: &Shared) -> Result<(), Error> {
    #[cfg(feature = "tokio")]
    if mode() == Mode::Async {
        return super::tokio_driving::catch_up(net);
    }
    let _ = net;
    Ok(())
}

/// Drives the network until `done` returns a value. `deadline`: an instant on the network's
/// clock at which `done` may change by time alone (a wait's timeout), so an async wait on a
/// virtual clock wakes for it.
pub(crate) async fn until<T: Send + 'static>(
    net: &Shared,
    deadline: Option<Instant>,
    done: impl FnMut(&mut Core) -> Option<T> + Send + 'static,
) -> Result<T, Error> {
    match mode() {
        #[cfg(feature = "tokio")]
        Mode::Async => super::tokio_driving::wait_until(net, deadline, done).await,
        Mode::Joined => joined_until(net, deadline, done).await,
        _ => net.wait_for_by(deadline, done),
    }
}

/// [`until`] in a join's blocking loop: checks `done` once per poll; if it is not done, says
/// what it waits for (see [`Mode::Joined`]) and returns `Pending`.
async fn joined_until<T>(
    net: &Shared,
    deadline: Option<Instant>,
    mut done: impl FnMut(&mut Core) -> Option<T>,
) -> Result<T, Error> {
    std::future::poll_fn(|_| {
        if let Some(e) = JOINED.with(|w| w.borrow_mut().take_failure(net)) {
            return Poll::Ready(Err(e));
        }
        if let Some(v) = done(&mut net.core()) {
            return Poll::Ready(Ok(v));
        }
        JOINED.with(|w| w.borrow_mut().wait_on(net, deadline));
        Poll::Pending
    })
    .await
}

/// Runs several operations together and gives their results in their order, each as it ended
/// (one failing does not end the others). The join itself does not fail: its error type is the
/// operations' own so that it reads like them (`join_all(ops).wait()?`).
///
/// * [`wait`](Operation::wait)ed (or awaited without the `tokio` feature), it runs them all on
///   the calling thread: it polls every unfinished operation; each one that waits on the bus
///   says for which network and until when, and the join drives each such network one step
///   (up to the earliest of those deadlines and the network's own next timer), then polls
///   again. No thread is started and nothing polls on a timer, so on a virtual-clock bus the
///   run is deterministic, and operations on different nodes overlap on the bus as they would
///   from several threads: two nodes' reads take about the bus time of one.
/// * Awaited on tokio, it is a future that polls every operation (each waits as async
///   operations do).
///
/// Dropping the join unfinished drops the operations (their SDO transfers are cancelled).
/// Operations may nest: one of them can await several operations, or a join of its own.
///
/// ```
/// use canola::{MemoryBus, Network, NodeId, SimDevice, join_all};
///
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let bus = MemoryBus::new();
/// let net = Network::new(bus.endpoint());
/// let eds = &include_bytes!("../../../../eds/burkert-generic.eds")[..];
/// for id in [5, 6] {
///     bus.attach(SimDevice::from_eds(NodeId::new(id)?, eds)?);
/// }
/// let reads = [5, 6].map(|id| net.node(NodeId::new(id).unwrap()).sdo().read((0x1018, 1)));
/// let vendors = join_all(reads).wait()?;
/// assert_eq!(vendors.len(), 2);
/// assert!(vendors.iter().all(Result::is_ok));
/// # Ok(())
/// # }
/// ```
pub fn join_all<'a, T: Send + 'a, E: Send + 'a>(
    ops: impl IntoIterator<Item = Operation<'a, T, E>>,
) -> Operation<'a, Vec<Result<T, E>>, E> {
    let bodies: Vec<_> = ops
        .into_iter()
        .map(|op| Some(std::future::IntoFuture::into_future(op)))
        .collect();
    let results = bodies.iter().map(|_| None).collect();
    Operation::new(Join { bodies, results })
}

/// The body of [`join_all`]'s operation.
struct Join<'a, T, E> {
    /// The operations not finished yet (`None` once finished).
    bodies: Vec<Option<BoxedBody<'a, T, E>>>,
    /// Their results, as they come.
    results: Vec<Option<Result<T, E>>>,
}

impl<T, E> Join<'_, T, E> {
    /// Polls every unfinished operation once; whether all are finished.
    fn poll_all(&mut self, cx: &mut Context<'_>) -> bool {
        let mut all = true;
        for (body, result) in self.bodies.iter_mut().zip(&mut self.results) {
            if let Some(f) = body {
                match f.as_mut().poll(cx) {
                    Poll::Ready(r) => {
                        *result = Some(r);
                        *body = None;
                    }
                    Poll::Pending => all = false,
                }
            }
        }
        all
    }

    fn results(&mut self) -> Vec<Result<T, E>> {
        std::mem::take(&mut self.results)
            .into_iter()
            .flatten()
            .collect()
    }
}

// Nothing in a join is pinned in place: the operations are boxed, the results only moved.
impl<T, E> Unpin for Join<'_, T, E> {}

impl<T, E> Future for Join<'_, T, E> {
    type Output = Result<Vec<Result<T, E>>, E>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        let this = self.get_mut();
        if mode() != Mode::Blocking {
            // Awaited on tokio, or inside another join (whose loop drives).
            return match this.poll_all(cx) {
                true => Poll::Ready(Ok(this.results())),
                false => Poll::Pending,
            };
        }
        this.drive(cx, &mut || {}).map(Ok)
    }
}

impl<T, E> Join<'_, T, E> {
    /// The blocking loop of a waited join: polls the operations, drives the networks they wait
    /// on one step each, calls `between`, and again, until all are finished (or those left
    /// wait on something else than the bus: `Pending`, with `cx` woken for it).
    fn drive(
        &mut self,
        cx: &mut Context<'_>,
        between: &mut dyn FnMut(),
    ) -> Poll<Vec<Result<T, E>>> {
        let _joined = ModeGuard::enter(Mode::Joined);
        // What an enclosing join's round gathered so far (a body of it that waits on this
        // join by blocking), given back when this loop ends.
        let _outer = OuterWaits(JOINED.with(|w| w.replace(Waits::new())));
        loop {
            let all = self.poll_all(cx);
            // A failure nobody took (its waits ended meanwhile) is dropped with the round.
            let waits = JOINED.with(|w| w.replace(Waits::new()));
            if all {
                return Poll::Ready(self.results());
            }
            if waits.nets.is_empty() {
                // The pending operations wait on something else than the bus, which wakes
                // this thread (see `Operation::wait`).
                return Poll::Pending;
            }
            for (net, deadline) in waits.nets {
                if let Err(e) = net.step_once(deadline) {
                    JOINED.with(|w| w.borrow_mut().failed.push((net, e)));
                }
            }
            between();
        }
    }
}

/// [`join_all`] waited on, calling `between` on this thread after every driving step: where
/// the operations hand out what they produce as they go to something that cannot go into an
/// operation (an operation is `Send`; a caller's event callback need not be). The operations
/// can, say, send events into a channel that `between` empties into the callback: they then
/// reach it in order, at most one step late. Gives the results in the operations' order.
pub fn wait_all_with<'a, T: Send + 'a, E: Send + 'a>(
    ops: impl IntoIterator<Item = Operation<'a, T, E>>,
    mut between: impl FnMut(),
) -> Vec<Result<T, E>> {
    let bodies: Vec<_> = ops
        .into_iter()
        .map(|op| Some(std::future::IntoFuture::into_future(op)))
        .collect();
    let results = bodies.iter().map(|_| None).collect();
    let mut join = Join { bodies, results };
    let _mode = ModeGuard::enter(Mode::Blocking);
    let waker = THREAD_WAKER.with(Waker::clone);
    let mut cx = Context::from_waker(&waker);
    loop {
        match join.drive(&mut cx, &mut between) {
            Poll::Ready(r) => return r,
            Poll::Pending => std::thread::park_timeout(std::time::Duration::from_millis(1)),
        }
    }
}

/// Gives an enclosing join's waits back when dropped.
struct OuterWaits(Waits);

impl Drop for OuterWaits {
    fn drop(&mut self) {
        let outer = std::mem::replace(&mut self.0, Waits::new());
        JOINED.with(|w| *w.borrow_mut() = outer);
    }
}

/// Sends what the core has queued, waiting for the transport if another thread holds it (a
/// service that ends on a frame without an answer returns once the frame is on the bus).
pub(crate) async fn flush(net: &Shared) -> Result<(), Error> {
    #[cfg(feature = "tokio")]
    if mode() == Mode::Async {
        return super::tokio_driving::flush(net).await;
    }
    net.flush()
}

/// Drives the network until `until` on its clock.
pub(crate) async fn run_until(net: &Shared, until: Instant) -> Result<(), Error> {
    if mode() == Mode::Blocking {
        return net.step_until(until);
    }
    self::until(net, Some(until), move |c| (c.now() >= until).then_some(())).await
}

/// Runs one SDO request to its end. Blocking, the first driving step starts under the lock the
/// submission took (see `Shared::run`).
pub(crate) async fn run_request(net: &Shared, req: Request) -> Result<Completion, SdoError> {
    if mode() == Mode::Blocking {
        return net.run(req);
    }
    let (node, entry) = (req.node(), req.entry());
    if let Err(e) = catch_up(net) {
        return Err(transport_error(net, node, entry, &e));
    }
    let id = net.submit(req);
    let mut r = wait_requests(net, vec![Req { id, node, entry }]).await;
    r.pop().unwrap_or_else(|| Err(cancelled(node, entry)))
}

/// One submitted SDO request, for naming its errors.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Req {
    pub(crate) id: RequestId,
    pub(crate) node: NodeId,
    pub(crate) entry: ObjectAddress,
}

/// Cancels requests when dropped unless disarmed (an operation dropped while it waits).
struct CancelGuard<'n> {
    net: &'n Shared,
    ids: Vec<RequestId>,
}

impl Drop for CancelGuard<'_> {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            self.net.cancel(id);
        }
    }
}

/// Waits for every request in `reqs`, in order; dropping the future cancels those still
/// running.
pub(crate) async fn wait_requests(
    net: &Shared,
    reqs: Vec<Req>,
) -> Vec<Result<Completion, SdoError>> {
    let mut guard = CancelGuard {
        net,
        ids: reqs.iter().map(|r| r.id).collect(),
    };
    let n = reqs.len();
    let mut results: Vec<Option<Result<Completion, SdoError>>> = vec![None; n];
    let mut left = n;
    let list = reqs.clone();
    let r = until(net, None, move |c| {
        for (slot, req) in results.iter_mut().zip(&list) {
            if slot.is_some() {
                continue;
            }
            let r = match c.take_result(req.id) {
                Taken::Running => continue,
                Taken::Done(r) => r.map_err(|e| c.name_error(*e)),
                Taken::Unknown => Err(c.name_error(cancelled(req.node, req.entry))),
            };
            *slot = Some(r);
            left -= 1;
        }
        (left == 0).then(|| std::mem::take(&mut results).into_iter().flatten().collect())
    })
    .await;
    guard.ids.clear();
    match r {
        Ok(v) => v,
        Err(e) => reqs
            .iter()
            .map(|req| {
                net.core().cancel(req.id);
                Err(transport_error(net, req.node, req.entry, &e))
            })
            .collect(),
    }
}

/// The error of a request that no longer runs.
pub(crate) fn cancelled(node: NodeId, entry: ObjectAddress) -> SdoError {
    SdoError {
        node,
        entry,
        name: None,
        kind: SdoErrorKind::Cancelled,
    }
}

/// A transport failure that ended a request, as the request's error (which node and object it
/// was for).
fn transport_error(net: &Shared, node: NodeId, entry: ObjectAddress, e: &Error) -> SdoError {
    net.core().name_error(SdoError {
        node,
        entry,
        name: None,
        kind: SdoErrorKind::Transport(TransportFailure::from(e)),
    })
}
