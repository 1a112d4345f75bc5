//! [`MemoryBus`], the handle to an in-memory bus (configuration, attached stations, injected
//! bus events, statistics, the service thread of a real-time bus), and [`Endpoint`], one
//! attachment to it as a [`Transport`](crate::Transport): what an endpoint sends goes to every
//! other participant, what they send lands in its receive queue. One file: a bus opens its
//! endpoints and an endpoint names its bus.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, Duration, FdFrame, Instant};

use crate::transport::contract::{
    BusEvent, Received, RxCoalescing, Station, Transport, TransportError, TransportWaker,
};

use super::config::{BusConfig, BusStats, ClockMode, Faults, Rng};
use super::state::{Attached, Clock, Ep, Participant, Pending, Shared, State, WireFrame};

/// An in-memory CAN bus. Cloning gives another handle to the same bus.
#[derive(Clone)]
pub struct MemoryBus {
    pub(super) shared: Arc<Shared>,
}

impl core::fmt::Debug for MemoryBus {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("MemoryBus").finish_non_exhaustive()
    }
}

/// Handle of a station attached to a [`MemoryBus`].
#[derive(Debug)]
pub struct StationId<S> {
    pub(super) id: u64,
    pub(super) _type: core::marker::PhantomData<fn() -> S>,
}

impl<S> Clone for StationId<S> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<S> Copy for StationId<S> {}

impl Default for MemoryBus {
    fn default() -> Self {
        Self::new()
    }
}

impl MemoryBus {
    /// A bus with the default configuration: virtual clock, no timing model, no faults.
    pub fn new() -> Self {
        Self::with_config(BusConfig::default())
    }

    /// A bus with the given configuration.
    pub fn with_config(config: BusConfig) -> Self {
        let config_clock = config.clock;
        let real_clock = matches!(config.clock, ClockMode::RealTime).then(MonotonicClock::new);
        let clock = match real_clock {
            None => Clock::Virtual(Instant::ZERO),
            Some(c) => Clock::Real(c),
        };
        let faulty = config.faults.any();
        let state = State {
            clock,
            rng: Rng(config.faults.seed),
            config,
            endpoints: Vec::new(),
            stations: Vec::new(),
            next_station: 0,
            pending: Vec::new(),
            wire: None,
            wire_free_at: Instant::ZERO,
            down: false,
            seq: 0,
            faulty,
            timers_moved: false,
            floor: Instant::ZERO,
            stats: BusStats::default(),
            service_thread: false,
            sleepers: 0,
            batch_full: false,
            service_until: None,
        };
        Self {
            shared: Arc::new(Shared {
                real_time: matches!(config_clock, ClockMode::RealTime),
                real_clock,
                virtual_now: AtomicU64::new(0),
                state: Mutex::new(state),
                cond: Condvar::new(),
            }),
        }
    }

    pub(super) fn lock(&self) -> MutexGuard<'_, State> {
        // A panic in a station while the lock was held leaves consistent-enough state for tests.
        self.shared
            .state
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Attaches a sans-IO station (e.g. a simulated device) that the bus itself steps.
    pub fn attach<S: Station + 'static>(&self, station: S) -> StationId<S> {
        let mut st = self.lock();
        let id = st.next_station;
        st.next_station += 1;
        st.stations.push(Attached {
            id,
            station: Box::new(station),
            next: None,
        });
        // Let the station send what it has right away (e.g. a boot-up message).
        let now = st.now();
        let i = st.stations.len() - 1;
        st.stations[i].station.handle_timeout(now);
        st.drain_station(i, now);
        st.advance(now);
        let needs_thread = matches!(st.clock, Clock::Real(_)) && !st.service_thread;
        if needs_thread {
            st.service_thread = true;
        }
        self.shared.release(st);
        if needs_thread {
            self.spawn_service_thread();
        }
        StationId {
            id,
            _type: core::marker::PhantomData,
        }
    }

    /// Detaches a station and hands it back.
    pub fn detach<S: Station + 'static>(&self, id: StationId<S>) -> Option<S> {
        let mut st = self.lock();
        let pos = st.stations.iter().position(|a| a.id == id.id)?;
        let attached = st.stations.remove(pos);
        attached.station.into_any().downcast::<S>().ok().map(|b| *b)
    }

    /// Runs `f` on an attached station (e.g. to change a simulated device's state), then lets
    /// it send what it produced.
    pub fn with_station<S: Station + 'static, R>(
        &self,
        id: StationId<S>,
        f: impl FnOnce(&mut S) -> R,
    ) -> Option<R> {
        let mut st = self.lock();
        let pos = st.stations.iter().position(|a| a.id == id.id)?;
        let s = st.stations[pos].station.as_any_mut().downcast_mut::<S>()?;
        let r = f(s);
        let now = st.now();
        st.drain_station(pos, now);
        st.advance(now);
        self.shared.release(st);
        Some(r)
    }

    /// Delivers a bus event to every endpoint and station. [`BusEvent::InterfaceDown`] also makes
    /// sends fail until [`BusEvent::InterfaceUp`].
    pub fn inject_event(&self, event: BusEvent) {
        let mut st = self.lock();
        match event {
            BusEvent::InterfaceDown => st.down = true,
            BusEvent::InterfaceUp => st.down = false,
            _ => {}
        }
        let now = st.now();
        for ep in st.endpoints.iter_mut().filter(|e| e.open) {
            ep.queue.push_back(Received::Event(event.clone()));
        }
        for a in st.stations.iter_mut() {
            a.station.handle_bus_event(now, &event);
            a.next = a.station.poll_timeout();
        }
        st.timers_moved = true;
        self.shared.release(st);
    }

    /// Changes the fault injection (the generator keeps its state unless the seed changed).
    pub fn set_faults(&self, faults: Faults) {
        let mut st = self.lock();
        if faults.seed != st.config.faults.seed {
            st.rng = Rng(faults.seed);
        }
        st.config.faults = faults;
        st.faulty = faults.any();
    }

    /// The bus clock.
    pub fn now(&self) -> Instant {
        match &self.shared.real_clock {
            Some(c) => c.now(),
            None => Instant::from_micros(self.shared.virtual_now.load(Ordering::Acquire)),
        }
    }

    /// Lets time pass until `until`, stepping attached stations and the wire. With a virtual
    /// clock this jumps; with a real clock it sleeps.
    pub fn run_until(&self, until: Instant) {
        let mut st = self.lock();
        loop {
            let now = st.now();
            if now >= until {
                st.advance(now);
                break;
            }
            match st.clock {
                Clock::Virtual(_) => {
                    let next = st.next_event().filter(|t| *t < until).unwrap_or(until);
                    st.advance(next);
                    st.clock = Clock::Virtual(next.max(now));
                    self.shared.set_virtual_now(next.max(now));
                }
                Clock::Real(_) => {
                    st.advance(now);
                    let wait = until - now;
                    st.sleepers += 1;
                    let (mut g, _) = self
                        .shared
                        .cond
                        .wait_timeout(st, wait.into())
                        .unwrap_or_else(|p| p.into_inner());
                    g.sleepers -= 1;
                    st = g;
                }
            }
        }
        self.shared.release(st);
    }

    /// Lets `d` pass (see [`run_until`](Self::run_until)).
    pub fn run_for(&self, d: impl Into<Duration>) {
        let d: Duration = d.into();
        let until = self.now() + d;
        self.run_until(until);
    }

    /// Frames waiting for the wire (submitted by endpoints and stations, not yet sent).
    pub fn pending_frames(&self) -> usize {
        self.lock().pending.len()
    }

    /// Counters of what the bus did so far.
    pub fn stats(&self) -> BusStats {
        self.lock().stats
    }

    pub(super) fn spawn_service_thread(&self) {
        let weak: Weak<Shared> = Arc::downgrade(&self.shared);
        std::thread::Builder::new()
            .name("memory-bus".into())
            .spawn(move || {
                loop {
                    let Some(shared) = weak.upgrade() else { return };
                    let mut st = shared.state.lock().unwrap_or_else(|p| p.into_inner());
                    let now = st.now();
                    st.advance(now);
                    let next = st.next_event();
                    let wait = match next {
                        Some(t) if t > now => (t - now).min(Duration::from_millis(100)),
                        Some(_) => Duration::ZERO,
                        None => Duration::from_millis(100),
                    };
                    // What it advanced may be frames for a blocked endpoint, or fill a
                    // coalescing one's batch.
                    if st.sleepers > 0 || core::mem::take(&mut st.batch_full) {
                        shared.cond.notify_all();
                    }
                    st.service_until = Some(now + wait);
                    let (mut st, _) = shared
                        .cond
                        .wait_timeout(st, wait.into())
                        .unwrap_or_else(|p| p.into_inner());
                    st.service_until = None;
                    drop(st);
                }
            })
            .ok();
    }
}

/// One attachment to a [`MemoryBus`]; implements [`Transport`](crate::Transport).
pub struct Endpoint {
    pub(super) bus: MemoryBus,
    pub(super) index: usize,
    /// Something was queued for this endpoint when it last received or sent (for
    /// `has_pending`, which so takes no lock; frames queued since are found by the next
    /// receive). A send looks because stations answer while the frame is delivered.
    pub(super) more: bool,
    /// Frames taken over from the endpoint's queue on the bus while a send held the bus's
    /// lock (the stations' answers to what was sent), received from here without it. They
    /// still count against the queue's capacity until a later call locks the bus and learns
    /// how many were taken (`taken`): a frame received is freed at the endpoint's next call.
    pub(super) inbox: VecDeque<Received>,
    /// Frames received from `inbox` since the bus last learnt of it.
    pub(super) taken: usize,
    /// Receive wake-up coalescing (real clock only; see [`Transport::set_rx_coalescing`]).
    pub(super) coalescing: RxCoalescing,
}

impl core::fmt::Debug for Endpoint {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Endpoint")
            .field("index", &self.index)
            .finish()
    }
}

impl MemoryBus {
    /// Opens a new endpoint (a [`Transport`](crate::Transport)) on this bus.
    pub fn endpoint(&self) -> Endpoint {
        let mut st = self.lock();
        st.endpoints.push(Ep {
            open: true,
            queue: VecDeque::new(),
            lost: 0,
            sending: 0,
            held: 0,
            wake_at: None,
            woken: false,
        });
        Endpoint {
            bus: self.clone(),
            index: st.endpoints.len() - 1,
            more: false,
            inbox: VecDeque::new(),
            taken: 0,
            coalescing: RxCoalescing::OFF,
        }
    }
}

impl Endpoint {
    /// Locks the bus, telling it how many frames endpoint `index` received from its inbox
    /// meanwhile (`taken`). (Borrows the bus alone, so the endpoint's other fields stay free.)
    pub(super) fn lock_bus<'a>(
        bus: &'a MemoryBus,
        index: usize,
        taken: &mut usize,
    ) -> MutexGuard<'a, State> {
        let mut st = bus.lock();
        if *taken > 0 {
            if let Some(ep) = st.endpoints.get_mut(index) {
                ep.held -= *taken;
            }
            *taken = 0;
        }
        st
    }

    /// The bus this endpoint belongs to.
    pub fn bus(&self) -> &MemoryBus {
        &self.bus
    }

    /// Sends `frame`, on a real clock stamped `given` (a reading the caller just took) when
    /// there is one, never before what the bus has processed already.
    pub(super) fn send_stamped(
        &mut self,
        frame: WireFrame,
        given: Option<Instant>,
    ) -> Result<(), TransportError> {
        let mut st = Self::lock_bus(&self.bus, self.index, &mut self.taken);
        if st.down {
            return Err(TransportError::InterfaceDown);
        }
        if matches!(frame, WireFrame::Fd(_)) && !st.config.fd {
            return Err(classic_only());
        }
        let now = match (&st.clock, given) {
            (Clock::Real(_), Some(t)) => t.max(st.floor),
            _ => st.now(),
        };
        st.advance(now);
        let me = Participant::Endpoint(self.index);
        let waiting = st.endpoints.get(self.index).map_or(0, |e| e.sending);
        if waiting >= st.config.tx_queue_capacity {
            return Err(TransportError::TxQueueFull);
        }
        if st.faulty || !st.wire_is_instant() || !st.pending.is_empty() {
            st.submit(me, frame, now);
        } else {
            // Nothing else waits for the wire and nothing is due (advanced above): the frame
            // would go next and at once, so it goes now, past the queue.
            st.seq += 1;
            let p = Pending {
                seq: st.seq,
                from: me,
                frame,
                ready: now,
            };
            st.deliver(p, now);
        }
        st.advance(now);
        // What the stations answered is queued for this endpoint now: moved to the inbox,
        // it is received without locking the bus again. (Not with a loss to report: the
        // report comes first, from the bus's queue.)
        if let Some(ep) = st.endpoints.get_mut(self.index)
            && ep.lost == 0
            && !ep.queue.is_empty()
        {
            ep.held += ep.queue.len();
            crate::move_all(&mut ep.queue, &mut self.inbox);
        }
        self.more = !self.inbox.is_empty() || st.has_queued(self.index);
        self.bus.shared.release(st);
        Ok(())
    }
}

impl Endpoint {
    /// When the first thing queued for endpoint `index` arrived: a frame's reception time; for
    /// a bus event (which carries none) the clock now.
    fn first_arrival(st: &State, index: usize) -> Instant {
        let first = st
            .endpoints
            .get(index)
            .and_then(|e| e.queue.front())
            .and_then(|r| match r {
                Received::Frame { at, .. } => Some(*at),
                Received::Event(BusEvent::FdFrame { at, .. }) => Some(*at),
                Received::Event(_) => None,
            });
        first.unwrap_or_else(|| st.now())
    }

    /// The coalescing wait of a real-clock receive (see [`RxCoalescing`]): waits until
    /// `until`, or until the queue of endpoint `index` holds `max_frames` (or lost one). The
    /// endpoint is not counted among the sleepers meanwhile, so frames arriving do not wake
    /// it; a delivery that fills the batch does (`Ep::wake_at`). Without a service thread (no
    /// station attached) it is woken as a plain receive is, and at the bus's own events, to
    /// step the wire (frames are then delivered by this thread, or at once by their senders
    /// on a bus without a timing model).
    fn coalesce<'a>(
        bus: &'a MemoryBus,
        index: usize,
        coalescing: RxCoalescing,
        mut st: MutexGuard<'a, State>,
        until: Instant,
    ) -> MutexGuard<'a, State> {
        let limit = coalescing.max_frames().min(st.config.queue_capacity).max(1);
        loop {
            let now = st.now();
            st.advance(now);
            let Some(ep) = st.endpoints.get_mut(index) else {
                return st;
            };
            if now >= until || ep.queue.len() >= limit || ep.lost > 0 {
                ep.wake_at = None;
                return st;
            }
            ep.wake_at = Some(limit);
            // Without a service thread this endpoint steps the wire: woken as a plain receive
            // is (a frame sent, and so a new wire event), and at the wire's next event.
            let stepping = !st.service_thread;
            let end = match st.next_event() {
                Some(t) if stepping => t.min(until),
                _ => until,
            };
            let wait = end.saturating_duration_since(now);
            st.sleepers += usize::from(stepping);
            let (mut g, _) = bus
                .shared
                .cond
                .wait_timeout(st, wait.into())
                .unwrap_or_else(|p| p.into_inner());
            g.sleepers -= usize::from(stepping);
            st = g;
        }
    }

    /// Hands over a coalesced burst: the first frame or event, with the rest of the queue
    /// moved to the endpoint's inbox (received from there without the bus's lock). A loss to
    /// report stays on the bus: it comes before the frames behind it.
    /// (Takes the endpoint's fields apart: the lock borrows its bus.)
    fn take_burst(
        mut st: MutexGuard<'_, State>,
        index: usize,
        inbox: &mut VecDeque<Received>,
        more: &mut bool,
    ) -> Option<Received> {
        let first = st.pop(index);
        if let Some(ep) = st.endpoints.get_mut(index)
            && ep.lost == 0
            && !ep.queue.is_empty()
        {
            ep.held += ep.queue.len();
            crate::move_all(&mut ep.queue, inbox);
        }
        *more = !inbox.is_empty() || st.has_queued(index);
        first
    }
}

impl Drop for Endpoint {
    fn drop(&mut self) {
        let mut st = Self::lock_bus(&self.bus, self.index, &mut self.taken);
        if let Some(ep) = st.endpoints.get_mut(self.index) {
            ep.open = false;
            ep.queue.clear();
        }
    }
}

/// The error of an FD frame on a classic in-memory bus.
fn classic_only() -> TransportError {
    TransportError::fd_not_supported(
        "the in-memory bus (configured for classic CAN: BusConfig::fd)",
    )
}

impl Transport for Endpoint {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.send_stamped(WireFrame::Can(*frame), None)
    }

    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        self.send_stamped(WireFrame::Can(*frame), Some(now))
    }

    fn fd_support(&self) -> Result<(), TransportError> {
        if self.bus.lock().config.fd {
            Ok(())
        } else {
            Err(classic_only())
        }
    }

    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        self.send_stamped(WireFrame::Fd(Box::new(*frame)), None)
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        // Frames in the inbox were queued before anything now on the bus.
        if let Some(r) = self.inbox.pop_front() {
            self.taken += 1;
            self.more = !self.inbox.is_empty();
            return Ok(Some(r));
        }
        let mut st = Self::lock_bus(&self.bus, self.index, &mut self.taken);
        // A frame delivered already comes before anything that fell due since (that would be
        // delivered after it), so it is handed over without reading the clock: on a real-time
        // bus a clock reading costs a good part of an SDO round trip through the network.
        let mut queued = true;
        // Whether this call waited for the clock (a frame found after that arrived during the
        // call, and may start a coalesced burst).
        let mut waited = false;
        loop {
            let now = if queued {
                queued = false;
                None
            } else {
                let now = st.now();
                st.advance(now);
                Some(now)
            };
            if waited && self.coalescing.is_on() && st.has_queued(self.index) {
                // The first of a burst arrived while this call waited: wait on for the rest.
                let until =
                    (Self::first_arrival(&st, self.index) + self.coalescing.window()).min(deadline);
                st = Self::coalesce(&self.bus, self.index, self.coalescing, st, until);
                return Ok(Self::take_burst(
                    st,
                    self.index,
                    &mut self.inbox,
                    &mut self.more,
                ));
            }
            if let Some(r) = st.pop(self.index) {
                self.more = st.has_queued(self.index);
                return Ok(Some(r));
            }
            self.more = false;
            let Some(now) = now else {
                continue;
            };
            if now >= deadline {
                return Ok(None);
            }
            let next = st
                .next_event()
                .filter(|t| *t < deadline)
                .unwrap_or(deadline);
            match st.clock {
                Clock::Virtual(_) => {
                    st.advance(next);
                    st.clock = Clock::Virtual(next.max(now));
                    self.bus.shared.set_virtual_now(next.max(now));
                }
                Clock::Real(_)
                    if self.coalescing.is_on() && now + self.coalescing.window() >= deadline =>
                {
                    // Whatever arrives from now on would be coalesced up to the deadline (or
                    // a full batch): wait for that alone, without a wake-up at the first frame.
                    st = Self::coalesce(&self.bus, self.index, self.coalescing, st, deadline);
                    if st.has_queued(self.index) {
                        return Ok(Self::take_burst(
                            st,
                            self.index,
                            &mut self.inbox,
                            &mut self.more,
                        ));
                    }
                }
                Clock::Real(_) => {
                    if let Some(ep) = st.endpoints.get_mut(self.index)
                        && core::mem::take(&mut ep.woken)
                    {
                        return Ok(None);
                    }
                    let wait = next.saturating_duration_since(now);
                    st.sleepers += 1;
                    let (mut g, _) = self
                        .bus
                        .shared
                        .cond
                        .wait_timeout(st, wait.into())
                        .unwrap_or_else(|p| p.into_inner());
                    g.sleepers -= 1;
                    st = g;
                    waited = true;
                }
            }
        }
    }

    fn set_rx_coalescing(&mut self, coalescing: RxCoalescing) -> bool {
        self.coalescing = coalescing;
        // A virtual clock never blocks: nothing to coalesce, and determinism stays as it is.
        self.bus.shared.real_time && coalescing.is_on()
    }

    fn now(&self) -> Instant {
        self.bus.now()
    }

    fn is_virtual(&self) -> bool {
        !self.bus.shared.real_time
    }

    /// On a real clock: sets the endpoint's wake flag and wakes the bus's waiting threads (a
    /// virtual clock's waits never block).
    fn waker(&self) -> Option<TransportWaker> {
        if !self.bus.shared.real_time {
            return None;
        }
        let (bus, index) = (Arc::downgrade(&self.bus.shared), self.index);
        Some(TransportWaker::new(move || {
            let Some(shared) = bus.upgrade() else { return };
            let mut st = shared.state.lock().unwrap_or_else(|p| p.into_inner());
            if let Some(ep) = st.endpoints.get_mut(index) {
                ep.woken = true;
            }
            drop(st);
            shared.cond.notify_all();
        }))
    }

    fn has_pending(&self) -> bool {
        self.more
    }

    fn next_event(&self) -> Option<Instant> {
        let st = self.bus.lock();
        if !matches!(st.clock, Clock::Virtual(_)) {
            return None;
        }
        if !self.inbox.is_empty() || st.has_queued(self.index) {
            return Some(st.now());
        }
        st.next_event()
    }
}
