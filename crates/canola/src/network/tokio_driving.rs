//! How an async operation waits: the one wait primitive every future of the async API uses.
//!
//! * **Real clock** (SocketCAN, UDP, a [`ClockMode::RealTime`](crate::transport::mem::ClockMode) memory
//!   bus): the blocking wait loop of the driver runs on tokio's blocking pool (whoever waits
//!   drives, or the background driver does). A dropped future sets a flag the loop checks at
//!   every step, so the blocking task ends within one step.
//! * **Virtual clock** (the default memory bus): the future drives the network itself, on the
//!   task, with no blocking: it steps the bus up to the instant that tokio's clock says it is
//!   now, then sleeps on a tokio timer until the next thing due (a core deadline, a frame
//!   leaving the wire, a station timer, the operation's own deadline) or until another future
//!   made progress. So virtual time follows tokio's time: real time on a normal runtime, and
//!   jumps under a paused clock (`start_paused`), where tokio advances to the earliest timer
//!   when every task is idle — a `tokio::time::timeout` and the bus's own timeouts run on one
//!   clock and fire in their order.
//!
//! The tie between the two clocks is one anchor per network, a pair (tokio instant, network
//! instant) that correspond. Blocking calls on the same virtual bus ([`Network::run_for`](crate::Network::run_for), a
//! blocking SDO) still jump virtual time ahead; the anchor then moves so that time never runs
//! backwards, and the async side follows tokio from there.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, Weak};

use canola_frame::Instant;

use super::driving::drive;
use super::shared::{Inner, Shared};
use crate::error::Error;
use crate::machine::Core;
use crate::transport::TransportError;

/// Steps taken in one go before the future yields to the runtime.
const STEPS_PER_TURN: usize = 1024;

/// On a virtual clock: steps the network up to the instant tokio's clock is at, and returns
/// when something is due next. `None` when another task is stepping right now. Wakes the
/// other futures if anything happened.
fn catch_up_once(net: &Shared, deadline: Option<Instant>) -> Result<Option<Next>, Error> {
    let Some(mut io) = net.try_io() else {
        return Ok(None);
    };
    let r = &net.reactor();
    let due = net.core().poll_timeout();
    let target = r.target(io.now());
    let mut received = false;
    let mut steps = 0;
    let busy = loop {
        received |= net.step(&mut io, Some(target))?;
        steps += 1;
        let now = io.now();
        if now >= target && io.next_event().is_none_or(|t| t > now) {
            break false;
        }
        if steps >= STEPS_PER_TURN {
            break true;
        }
    };
    let mut next = io.next_event();
    drop(io);
    let core = net.core();
    // What can end another future's wait: a frame or bus event, or a core timer (an SDO or
    // LSS timeout). Time passing alone is not: waits with a deadline sleep until it, and
    // waking the others for it would have two futures on a real-time runtime wake each
    // other for ever.
    let progressed = received || due.is_some_and(|t| t <= target);
    for t in [core.poll_timeout(), deadline].into_iter().flatten() {
        next = Some(next.map_or(t, |n| n.min(t)));
    }
    drop(core);
    if progressed {
        r.progress.notify_waiters();
    }
    Ok(Some(if busy {
        Next::Now
    } else {
        match next {
            Some(t) => Next::At(r.tokio_at(t)),
            None => Next::Never,
        }
    }))
}

/// What a virtual-clock future waits for after a catch-up.
enum Next {
    /// More work is waiting: yield, then go on.
    Now,
    /// Sleep until this tokio instant (or until another future makes progress).
    At(tokio::time::Instant),
    /// Nothing is due: wait for another future's progress.
    Never,
}

/// Brings a virtual clock up to tokio's time before an operation stamps "now" (a request's
/// timeout, an LSS machine's timers). Nothing to do on a real clock.
pub(crate) fn catch_up(net: &Shared) -> Result<(), Error> {
    if net.reactor().virtual_clock {
        // Another task stepping holds the transport: it is catching up the same clock.
        catch_up_once(net, None)?;
    }
    Ok(())
}

/// Waits until `done` returns a value, driving the network meanwhile (see the module docs).
/// `deadline`: an instant on the network's clock at which `done` may change by time alone (a
/// wait's timeout), so a virtual-clock future wakes for it.
pub(crate) async fn wait_until<T: Send + 'static>(
    net: &Shared,
    deadline: Option<Instant>,
    done: impl FnMut(&mut Core) -> Option<T> + Send + 'static,
) -> Result<T, Error> {
    if net.reactor().virtual_clock {
        drive_virtual(net, deadline, done).await
    } else {
        wait_blocking(net, done).await
    }
}

async fn drive_virtual<T>(
    net: &Shared,
    deadline: Option<Instant>,
    mut done: impl FnMut(&mut Core) -> Option<T>,
) -> Result<T, Error> {
    let r = &net.reactor();
    loop {
        // Registered before the check, so progress made after it wakes this future.
        let progress = r.progress.notified();
        let mut progress = std::pin::pin!(progress);
        progress.as_mut().enable();
        if let Some(v) = done(&mut net.core()) {
            return Ok(v);
        }
        let next = catch_up_once(net, deadline)?;
        if let Some(v) = done(&mut net.core()) {
            return Ok(v);
        }
        match next {
            Some(Next::Now) => tokio::task::yield_now().await,
            Some(Next::At(t)) => {
                tokio::select! {
                    () = progress => {}
                    () = tokio::time::sleep_until(t) => {}
                }
            }
            Some(Next::Never) => progress.await,
            // Another task is stepping; it wakes us if it gets anywhere, and a short sleep
            // covers a step that got nowhere.
            None => {
                let soon = tokio::time::Instant::now() + std::time::Duration::from_millis(1);
                tokio::select! {
                    () = progress => {}
                    () = tokio::time::sleep_until(soon) => {}
                }
            }
        }
    }
}

/// Ends the blocking wait when the future is dropped.
struct StopOnDrop {
    flag: Arc<AtomicBool>,
    net: Shared,
}

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.flag.store(true, Ordering::SeqCst);
        self.net.notify();
    }
}

async fn wait_blocking<T: Send + 'static>(
    net: &Shared,
    mut done: impl FnMut(&mut Core) -> Option<T> + Send + 'static,
) -> Result<T, Error> {
    let flag = Arc::new(AtomicBool::new(false));
    let _stop = StopOnDrop {
        flag: flag.clone(),
        net: net.clone(),
    };
    let n = net.clone();
    let r = tokio::task::spawn_blocking(move || {
        n.wait_for(move |c| {
            if flag.load(Ordering::SeqCst) {
                Some(None)
            } else {
                done(c).map(Some)
            }
        })
    })
    .await;
    match r {
        Ok(Ok(Some(v))) => Ok(v),
        // Only a dropped future stops the wait, and then nobody reads this.
        Ok(Ok(None)) => Err(Error::TaskEnded),
        Ok(Err(e)) => Err(e),
        Err(_) => Err(Error::TaskEnded),
    }
}

/// Sends what the core has queued. On a real clock the transport may be held by a thread in a
/// receive (up to one driving step), so the flush runs on the blocking pool.
pub(crate) async fn flush(net: &Shared) -> Result<(), Error> {
    if net.reactor().virtual_clock {
        return net.flush();
    }
    let n = net.clone();
    tokio::task::spawn_blocking(move || n.flush())
        .await
        .map_err(|_| Error::TaskEnded)?
}

/// Longest the virtual-clock driver sleeps without looking whether it should stop, on tokio's
/// clock (it also wakes for every event due and every other future's progress).
const DRIVER_SLICE: std::time::Duration = std::time::Duration::from_millis(50);

/// The background driver of a virtual-clock network: a task that keeps the bus at tokio's
/// time, so heartbeats, EMCY and PDO events flow while the application awaits something else.
/// Ends when `stop` is set, the network is gone or the transport fails for good.
fn spawn_virtual_driver(
    inner: Weak<Inner>,
    stop: Arc<AtomicBool>,
    error: Arc<Mutex<Option<crate::error::TransportFailure>>>,
) {
    drop(tokio::spawn(async move {
        while !stop.load(Ordering::SeqCst) {
            let Some(net) = Shared::upgrade(&inner) else {
                return;
            };
            let progress = net.reactor().progress.notified();
            let mut progress = std::pin::pin!(progress);
            progress.as_mut().enable();
            let slice_end = tokio::time::Instant::now() + DRIVER_SLICE;
            let wake = match catch_up_once(&net, None) {
                Ok(Some(Next::Now)) => None,
                Ok(Some(Next::At(t))) => Some(t.min(slice_end)),
                Ok(Some(Next::Never) | None) => Some(slice_end),
                Err(Error::Transport(
                    TransportError::InterfaceDown
                    | TransportError::BusOff
                    | TransportError::TxQueueFull,
                )) => Some(slice_end),
                Err(e) => {
                    net.driver_failed(&e, &error, &stop);
                    return;
                }
            };
            match wake {
                None => tokio::task::yield_now().await,
                Some(t) => {
                    tokio::select! {
                        () = progress => {}
                        () = tokio::time::sleep_until(t) => {}
                    }
                }
            }
            // The last handle is this one: the application let the network go.
            if net.is_last_handle() {
                return;
            }
        }
        if let Some(net) = Shared::upgrade(&inner) {
            net.core().wake_pdo_subscribers();
        }
    }));
}

impl Shared {
    /// The body of [`Network::start_driver_on_runtime`](crate::Network::start_driver_on_runtime).
    pub(crate) fn start_driver_on_runtime(&self) {
        let virtual_clock = self.reactor().virtual_clock;
        let started = self.install_driver(|weak, stop, error| {
            // The task ends by itself once `stop` is set or the network is gone.
            if virtual_clock {
                spawn_virtual_driver(weak, stop, error);
            } else {
                drop(tokio::task::spawn_blocking(move || {
                    drive(&weak, &stop, &error);
                }));
            }
            Ok::<_, core::convert::Infallible>(None)
        });
        match started {
            Ok(()) => {}
            Err(never) => match never {},
        }
    }
}
