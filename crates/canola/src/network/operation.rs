//! [`Operation`]: what every facade call that waits on the bus returns, finished either by
//! [`wait`](Operation::wait) (blocking) or by `.await` (`tokio` feature).
//!
//! Each operation is written once, as straight-line async code over three primitives of this
//! module: [`until`] (drive the network until a condition on the core holds), [`run_request`]
//! (one SDO request to its end) and [`wait_requests`] (several at once). How a primitive
//! waits depends on who finishes the operation:
//!
//! * [`Operation::wait`] polls the body on the calling thread with the primitives in blocking
//!   mode: each one drives the network itself until it is done (whoever waits drives, see
//!   [`crate::network`]), so every await is ready at once and the thread never parks.
//! * `.await` runs the same body on a tokio task: the primitives wait as `crate::asynch`
//!   describes (a virtual-clock bus follows tokio's clock; a real clock waits on tokio's
//!   blocking pool).
//!
//! Dropping an operation (or its future) before it ends cancels its SDO requests: a queued one
//! is removed, a running transfer is aborted on the bus (0x08000000).

use std::cell::Cell;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use canola_frame::{Instant, NodeId};
use canola_od::ObjectAddress;

use super::handle::Network;
use crate::error::{Error, SdoError, SdoErrorKind, TransportFailure};
use crate::machine::{Completion, Core, RequestId, SdoRequest, Taken};

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
    body: Body<'a, T, E>,
}

/// What an operation runs.
enum Body<'a, T, E> {
    /// Straight-line async code over the primitives.
    Code(Pin<Box<dyn Future<Output = Result<T, E>> + Send + 'a>>),
    /// One SDO (or USDO) request, the commonest operation, held as it is: a blocking wait runs
    /// it with no future or waker made for it (`Network::run`, as the code form's blocking
    /// path does). `tests/operation.rs` checks that both forms give the same results.
    Request(OneRequest<T, E>),
}

/// One request, what its completion gives and how its error reads.
pub(crate) struct OneRequest<T, E> {
    net: Network,
    req: SdoRequest,
    output: fn(Completion) -> T,
    error: fn(SdoError) -> E,
}

impl<T, E> OneRequest<T, E> {
    /// The request as code (for `.await`).
    async fn run(self) -> Result<T, E> {
        run_request(&self.net, self.req)
            .await
            .map(self.output)
            .map_err(self.error)
    }
}

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
            body: Body::Code(Box::pin(body)),
        }
    }

    /// The operation that runs `req` to its end and takes `output` from its completion.
    pub(crate) fn request(
        net: Network,
        req: SdoRequest,
        output: fn(Completion) -> T,
        error: fn(SdoError) -> E,
    ) -> Self {
        Self {
            body: Body::Request(OneRequest {
                net,
                req,
                output,
                error,
            }),
        }
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
        let mut body = match self.body {
            Body::Request(r) => {
                let OneRequest {
                    net,
                    req,
                    output,
                    error,
                } = r;
                return net.run(req).map(output).map_err(error);
            }
            Body::Code(body) => body,
        };
        let _mode = BlockingMode::enter();
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
    type IntoFuture = Pin<Box<dyn Future<Output = Result<T, E>> + Send + 'a>>;

    fn into_future(self) -> Self::IntoFuture {
        match self.body {
            Body::Code(body) => body,
            Body::Request(r) => Box::pin(r.run()),
        }
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

thread_local! {
    /// Whether the primitives polled on this thread wait by blocking (inside
    /// [`Operation::wait`]).
    static BLOCKING: Cell<bool> = const { Cell::new(false) };
    /// This thread's waker, made once.
    static THREAD_WAKER: Waker = Waker::from(Arc::new(ThreadWaker(std::thread::current())));
}

/// Blocking mode for this thread while it lives (restores the mode it found: a blocking wait
/// inside an async task ends in async mode again).
struct BlockingMode(bool);

impl BlockingMode {
    fn enter() -> Self {
        Self(BLOCKING.with(|b| b.replace(true)))
    }
}

impl Drop for BlockingMode {
    fn drop(&mut self) {
        BLOCKING.with(|b| b.set(self.0));
    }
}

/// Whether a primitive polled now waits by blocking. Without the `tokio` feature there is no
/// other way.
fn blocking() -> bool {
    !cfg!(feature = "tokio") || BLOCKING.with(Cell::get)
}

/// Brings a virtual clock up to tokio's time before an operation stamps "now" (a request's
/// timeout, an LSS machine's timers, a wait's deadline). Nothing to do when blocking or on a
/// real clock.
pub(crate) fn catch_up(net: &Network) -> Result<(), Error> {
    #[cfg(feature = "tokio")]
    if !blocking() {
        return super::tokio_driving::catch_up(net);
    }
    let _ = net;
    Ok(())
}

/// Drives the network until `done` returns a value. `deadline`: an instant on the network's
/// clock at which `done` may change by time alone (a wait's timeout), so an async wait on a
/// virtual clock wakes for it.
pub(crate) async fn until<T: Send + 'static>(
    net: &Network,
    deadline: Option<Instant>,
    done: impl FnMut(&mut Core) -> Option<T> + Send + 'static,
) -> Result<T, Error> {
    #[cfg(feature = "tokio")]
    if !blocking() {
        return super::tokio_driving::wait_until(net, deadline, done).await;
    }
    net.wait_for_by(deadline, done)
}

/// Sends what the core has queued, waiting for the transport if another thread holds it (a
/// service that ends on a frame without an answer returns once the frame is on the bus).
pub(crate) async fn flush(net: &Network) -> Result<(), Error> {
    #[cfg(feature = "tokio")]
    if !blocking() {
        return super::tokio_driving::flush(net).await;
    }
    net.flush()
}

/// Drives the network until `until` on its clock.
pub(crate) async fn run_until(net: &Network, until: Instant) -> Result<(), Error> {
    if blocking() {
        return net.step_until(until);
    }
    self::until(net, Some(until), move |c| (c.now() >= until).then_some(())).await
}

/// Runs one SDO request to its end. Blocking, the first driving step starts under the lock the
/// submission took (see `Network::run`).
pub(crate) async fn run_request(net: &Network, req: SdoRequest) -> Result<Completion, SdoError> {
    if blocking() {
        return net.run(req);
    }
    let (node, entry) = (req.node, req.entry);
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
    net: &'n Network,
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
    net: &Network,
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
fn transport_error(net: &Network, node: NodeId, entry: ObjectAddress, e: &Error) -> SdoError {
    net.core().name_error(SdoError {
        node,
        entry,
        name: None,
        kind: SdoErrorKind::Transport(TransportFailure::from(e)),
    })
}
