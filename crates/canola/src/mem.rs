//! The in-memory CAN bus for tests and simulation.
//!
//! Several [`Endpoint`]s (each a [`Transport`]) and any number of attached [`Station`]s share one
//! bus. A frame sent by one participant reaches every other participant (not the sender, like a
//! SocketCAN socket without `CAN_RAW_RECV_OWN_MSGS`).
//!
//! * **Clock.** [`ClockMode::Virtual`] (the default) is deterministic: time stands still while
//!   code runs and jumps to the next event (a frame leaving the wire, a station timer, the
//!   caller's deadline) when an endpoint waits in [`Transport::recv_until`]. Run one driving
//!   thread per virtual bus and attach simulated devices with [`MemoryBus::attach`], so they are
//!   stepped by the same loop. [`ClockMode::RealTime`] follows the host's monotonic clock; a
//!   service thread steps attached stations, and endpoints may be used from several threads.
//!   Under the async API (`tokio` feature) a virtual clock follows tokio's clock: real time on
//!   a normal runtime, jumps under a paused one, so tokio's timers and the bus's timeouts fire
//!   in their order (see `canola::asynch`).
//! * **Timing model** (optional, [`BusConfig::bitrate`]). Each frame occupies the wire for its
//!   length in bits (ISO 11898-1 classic frame: 47 + 8·n bits for an 11-bit identifier, 67 + 8·n
//!   for a 29-bit one, including the 3-bit interframe space), optionally with the worst-case
//!   number of stuff bits. When the wire goes idle, the pending frame with the lowest arbitration
//!   value (lowest identifier; an 11-bit identifier beats a 29-bit one with the same base; a data
//!   frame beats a remote frame) is sent next.
//! * **Fault injection** ([`Faults`]): drop, duplicate, delay or corrupt a chosen share of frames,
//!   from a seeded generator so every run is reproducible.
//! * **Bus state.** [`MemoryBus::inject_event`] delivers [`BusEvent`]s (error frames, bus-off,
//!   interface down/up); a full endpoint receive queue drops frames, counts them and reports a
//!   [`BusEvent::RxOverflow`] before the next frame.

use std::any::Any;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, CanId, Duration, Instant};

use crate::transport::{BusEvent, Received, Station, Transport, TransportError};

/// How the bus tells time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ClockMode {
    /// Deterministic simulated time starting at zero; advances only while an endpoint waits.
    #[default]
    Virtual,
    /// The host's monotonic clock.
    RealTime,
}

/// Fault injection settings. Shares are probabilities in `0.0..=1.0`, applied to every frame
/// independently, in this order: drop, corrupt, delay, duplicate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    /// Share of frames that vanish (no station receives them).
    pub drop: f64,
    /// Share of frames delivered twice.
    pub duplicate: f64,
    /// Share of frames whose data has one bit flipped (frames without data are not corrupted).
    /// Models a corruption the CRC did not catch.
    pub corrupt: f64,
    /// Share of frames held back by a random time up to [`max_delay`](Self::max_delay), which
    /// may reorder them.
    pub delay: f64,
    /// Upper bound of an injected delay.
    pub max_delay: Duration,
    /// Seed of the pseudo-random generator.
    pub seed: u64,
}

impl Default for Faults {
    fn default() -> Self {
        Self {
            drop: 0.0,
            duplicate: 0.0,
            corrupt: 0.0,
            delay: 0.0,
            max_delay: Duration::from_millis(10),
            seed: 0x5EED,
        }
    }
}

impl Faults {
    /// No faults.
    pub fn none() -> Self {
        Self::default()
    }

    /// Whether any fault can happen.
    fn any(&self) -> bool {
        self.drop > 0.0 || self.corrupt > 0.0 || self.delay > 0.0 || self.duplicate > 0.0
    }
}

/// Configuration of an in-memory bus.
#[derive(Debug, Clone, PartialEq)]
pub struct BusConfig {
    /// Clock mode.
    pub clock: ClockMode,
    /// Bit rate for the timing model in bit/s (e.g. 125_000..=1_000_000); `None` delivers frames
    /// instantly.
    pub bitrate: Option<u32>,
    /// Count the worst-case number of stuff bits in the timing model.
    pub worst_case_stuffing: bool,
    /// Receive queue length of each endpoint; beyond it frames are dropped and reported.
    pub queue_capacity: usize,
    /// Frames each endpoint may have waiting for the wire; beyond it [`Transport::send`] fails
    /// with [`TransportError::TxQueueFull`], as a SocketCAN socket does with `ENOBUFS`. A
    /// controller's transmit queue is bounded, so a sender that offers more than the bus
    /// carries meets back-pressure instead of an ever longer backlog.
    pub tx_queue_capacity: usize,
    /// Fault injection.
    pub faults: Faults,
}

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            clock: ClockMode::Virtual,
            bitrate: None,
            worst_case_stuffing: false,
            queue_capacity: 4096,
            tx_queue_capacity: 256,
            faults: Faults::none(),
        }
    }
}

/// Counters of what the bus did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusStats {
    /// Frames that went over the wire (duplicates counted twice).
    pub frames: u64,
    /// Frames removed by fault injection.
    pub dropped: u64,
    /// Frames duplicated by fault injection.
    pub duplicated: u64,
    /// Frames corrupted by fault injection.
    pub corrupted: u64,
    /// Frames delayed by fault injection.
    pub delayed: u64,
    /// Frames lost to full receive queues (summed over endpoints).
    pub overflowed: u64,
    /// Time the wire was busy (timing model only).
    pub busy: Duration,
}

/// Number of bits a classic data or remote frame occupies on the wire, interframe space included.
///
/// With `worst_case_stuffing`, adds the most stuff bits the frame can need: one per four bits of
/// the stuffed region (start of frame to the end of the CRC sequence) after the first.
pub fn frame_bits(frame: &CanFrame, worst_case_stuffing: bool) -> u32 {
    let n = if frame.is_remote() {
        0
    } else {
        frame.data().len() as u32 * 8
    };
    let (fixed, stuffed) = if frame.id().is_extended() {
        (67, 54)
    } else {
        (47, 34)
    };
    let stuff = if worst_case_stuffing {
        (stuffed + n - 1) / 4
    } else {
        0
    };
    fixed + n + stuff
}

/// On-wire time of `frame` at `bitrate` bit/s, rounded up to a whole microsecond.
pub fn frame_time(frame: &CanFrame, bitrate: u32, worst_case_stuffing: bool) -> Duration {
    let bits = u64::from(frame_bits(frame, worst_case_stuffing));
    let rate = u64::from(bitrate.max(1));
    Duration::from_micros((bits * 1_000_000).div_ceil(rate))
}

/// Arbitration value: lower wins (ISO 11898-1 identifier priority, data beats remote).
fn arbitration_key(frame: &CanFrame) -> u64 {
    let (base, ide, ext) = match frame.id() {
        CanId::Standard(s) => (u64::from(s.as_raw()), 0, 0),
        CanId::Extended(e) => {
            let raw = u64::from(e.as_raw());
            (raw >> 18, 1, raw & 0x3_FFFF)
        }
    };
    // base id, then (SRR/RTR, IDE) — an 11-bit frame's RTR bit sits where a 29-bit frame has a
    // recessive SRR — then the extension and the final RTR bit.
    let rtr = u64::from(frame.is_remote());
    let std_rtr = if ide == 1 { 1 } else { rtr };
    (base << 22) | (std_rtr << 21) | (ide << 20) | (ext << 1) | if ide == 1 { rtr } else { 0 }
}

/// SplitMix64: small, seedable, good enough for fault injection.
#[derive(Debug, Clone)]
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.unit() < p
    }
}

#[derive(Debug)]
struct Pending {
    seq: u64,
    from: Participant,
    frame: CanFrame,
    ready: Instant,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Participant {
    Endpoint(usize),
    Station(u64),
}

#[derive(Debug)]
struct Ep {
    open: bool,
    queue: VecDeque<Received>,
    lost: u64,
    /// Its frames in `State::pending` (for the transmit queue bound, without a scan per send).
    sending: usize,
    /// Frames moved to the endpoint's own inbox and not yet known to be taken from it: they
    /// count against the receive queue's capacity (see `Endpoint::inbox`).
    held: usize,
}

/// A station with its concrete type erased but recoverable.
trait AnyStation: Station {
    fn as_any_mut(&mut self) -> &mut dyn Any;
    fn into_any(self: Box<Self>) -> Box<dyn Any>;
}

impl<S: Station + Any> AnyStation for S {
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn into_any(self: Box<Self>) -> Box<dyn Any> {
        self
    }
}

struct Attached {
    id: u64,
    station: Box<dyn AnyStation>,
    /// The station's `poll_timeout` as of its last input (the bus asks for it at every event;
    /// a station's timers change only when it is given something).
    next: Option<Instant>,
}

enum Clock {
    Virtual(Instant),
    Real(MonotonicClock),
}

struct State {
    clock: Clock,
    config: BusConfig,
    rng: Rng,
    endpoints: Vec<Ep>,
    stations: Vec<Attached>,
    next_station: u64,
    pending: Vec<Pending>,
    wire: Option<(Pending, Instant)>,
    wire_free_at: Instant,
    down: bool,
    seq: u64,
    /// Whether the fault injection is on (`config.faults.any()`, kept: asked for every frame).
    faulty: bool,
    /// A station's timer changed since [`Shared::release`] last looked (so the service
    /// thread's wake-up time may be too late).
    timers_moved: bool,
    /// The latest time the bus has processed (advanced to): a frame stamped with a clock
    /// reading its sender took earlier is stamped this instead (see `Transport::send_at`).
    floor: Instant,
    stats: BusStats,
    service_thread: bool,
    /// Endpoint threads blocked on the condition variable (real clock only).
    sleepers: usize,
    /// When the service thread's current wait ends; `None` while it is not waiting (it then
    /// looks at the bus again before it waits).
    service_until: Option<Instant>,
}

struct Shared {
    state: Mutex<State>,
    cond: Condvar,
    /// Whether anyone can wait on `cond`: only real-time waits block, and a notification costs
    /// a system call even with nobody waiting.
    real_time: bool,
    /// The real-time clock (the same as the state's), read without the lock: the master asks
    /// for the time several times per request, and the lock is contended with the bus's
    /// service thread.
    real_clock: Option<MonotonicClock>,
    /// A virtual clock's time in microseconds (a copy of the state's, set under its lock), for
    /// the same reason.
    virtual_now: AtomicU64,
}

impl Shared {
    /// Publishes a virtual clock's new time (with the state locked).
    fn set_virtual_now(&self, t: Instant) {
        self.virtual_now.store(t.as_micros(), Ordering::Release);
    }

    /// Unlocks the bus after a change, waking the blocked threads only when one needs it: an
    /// endpoint waits for frames, or the service thread sleeps past the bus's next event. (A
    /// notification costs a system call, and a needless wake-up of the service thread a
    /// context switch and a fight for the lock, on every frame sent.)
    fn release(&self, mut st: MutexGuard<'_, State>) {
        let wake = self.real_time && (st.sleepers > 0 || st.service_wakes_early());
        drop(st);
        if wake {
            self.cond.notify_all();
        }
    }
}

/// An in-memory CAN bus. Cloning gives another handle to the same bus.
#[derive(Clone)]
pub struct MemoryBus {
    shared: Arc<Shared>,
}

impl core::fmt::Debug for MemoryBus {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("MemoryBus").finish_non_exhaustive()
    }
}

/// Handle of a station attached to a [`MemoryBus`].
#[derive(Debug)]
pub struct StationId<S> {
    id: u64,
    _type: core::marker::PhantomData<fn() -> S>,
}

impl<S> Clone for StationId<S> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<S> Copy for StationId<S> {}

/// Upper bound of internal events processed in one step, so a misbehaving station whose timer
/// never moves forward cannot hang the bus.
const MAX_EVENTS_PER_STEP: usize = 100_000;

impl State {
    fn now(&self) -> Instant {
        match &self.clock {
            Clock::Virtual(t) => *t,
            Clock::Real(c) => c.now(),
        }
    }

    /// Puts a frame on the way to the wire, applying the fault injection.
    fn submit(&mut self, from: Participant, frame: CanFrame, now: Instant) {
        if !self.faulty {
            // Without faults the generator is not asked at all (`chance(0.0)` does not draw).
            self.push_pending(from, frame, now);
            return;
        }
        let f = self.config.faults;
        if self.rng.chance(f.drop) {
            self.stats.dropped += 1;
            return;
        }
        let mut frame = frame;
        if !frame.data().is_empty() && self.rng.chance(f.corrupt) {
            let mut data = [0u8; 8];
            let len = frame.data().len();
            data[..len].copy_from_slice(frame.data());
            let bit = (self.rng.next_u64() % (len as u64 * 8)) as usize;
            data[bit / 8] ^= 1 << (bit % 8);
            if let Ok(c) = CanFrame::new(frame.id(), &data[..len]) {
                frame = c;
                self.stats.corrupted += 1;
            }
        }
        let mut ready = now;
        if self.rng.chance(f.delay) {
            let max = f.max_delay.as_micros().max(1);
            ready = now + Duration::from_micros(self.rng.next_u64() % (max + 1));
            self.stats.delayed += 1;
        }
        let copies = if self.rng.chance(f.duplicate) {
            self.stats.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            self.push_pending(from, frame, ready);
        }
    }

    fn push_pending(&mut self, from: Participant, frame: CanFrame, ready: Instant) {
        self.seq += 1;
        self.pending.push(Pending {
            seq: self.seq,
            from,
            frame,
            ready,
        });
        if let Participant::Endpoint(i) = from
            && let Some(ep) = self.endpoints.get_mut(i)
        {
            ep.sending += 1;
        }
    }

    /// When the wire does something next: a frame finishes, or the next arbitration starts.
    fn next_wire_event(&self) -> Option<Instant> {
        if let Some((_, done)) = &self.wire {
            return Some(*done);
        }
        let earliest = self.pending.iter().map(|p| p.ready).min()?;
        Some(earliest.max(self.wire_free_at))
    }

    fn next_station_event(&self) -> Option<Instant> {
        self.stations.iter().filter_map(|s| s.next).min()
    }

    fn next_event(&self) -> Option<Instant> {
        match (self.next_wire_event(), self.next_station_event()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Whether the service thread's current wait ends after the bus's next event: a frame
    /// waiting for the wire, or a station timer (looked at only when one moved: the stations'
    /// timers mostly stay as they were, e.g. through an SDO round trip).
    fn service_wakes_early(&mut self) -> bool {
        let Some(until) = self.service_until else {
            return false;
        };
        let frames = !self.pending.is_empty() || self.wire.is_some();
        let timers = core::mem::take(&mut self.timers_moved);
        (frames && self.next_wire_event().is_some_and(|t| t < until))
            || (timers && self.next_station_event().is_some_and(|t| t < until))
    }

    /// Processes everything that happens up to and including `now`, in time order.
    #[inline]
    fn advance(&mut self, now: Instant) {
        self.floor = self.floor.max(now);
        // Mostly nothing is due (asked before and after every send and receive): an idle wire,
        // no frame waiting and no station timer passed are found out cheaper than by a pass of
        // the event loop.
        if self.wire.is_none()
            && self.pending.is_empty()
            && self.next_station_event().is_none_or(|t| t > now)
        {
            return;
        }
        self.run_events(now);
    }

    fn run_events(&mut self, now: Instant) {
        for _ in 0..MAX_EVENTS_PER_STEP {
            // Without a timing model, one frame waiting and due, no station timer before it:
            // delivered at once (what a request and its answer are), without the searches of
            // the general case below, which does the same for it.
            if self.wire_is_instant() && self.pending.len() == 1 {
                let ready = self.pending[0].ready;
                if ready <= now && self.next_station_event().is_none_or(|s| s >= ready) {
                    if let Some(p) = self.pending.pop() {
                        self.leaves_queue(&p);
                        self.deliver(p, ready);
                    }
                    continue;
                }
            }
            let wire = self.next_wire_event().filter(|t| *t <= now);
            let station = self.next_station_event().filter(|t| *t <= now);
            match (wire, station) {
                (Some(w), Some(s)) if s < w => self.station_timers(s),
                (Some(w), _) => self.wire_step(w),
                (None, Some(s)) => self.station_timers(s),
                (None, None) => return,
            }
        }
    }

    fn wire_step(&mut self, t: Instant) {
        if let Some((_, done)) = &self.wire {
            if *done <= t
                && let Some((p, done)) = self.wire.take()
            {
                self.wire_free_at = done;
                self.deliver(p, done);
            }
            return;
        }
        // Arbitration among the frames ready at `t`.
        let Some(pos) = self
            .pending
            .iter()
            .enumerate()
            .filter(|(_, p)| p.ready <= t)
            .min_by_key(|(_, p)| (arbitration_key(&p.frame), p.seq))
            .map(|(i, _)| i)
        else {
            return;
        };
        let p = self.pending.swap_remove(pos);
        self.leaves_queue(&p);
        match self.config.bitrate {
            Some(rate) => {
                let d = frame_time(&p.frame, rate, self.config.worst_case_stuffing);
                self.stats.busy = self.stats.busy + d;
                self.wire = Some((p, t + d));
            }
            None => self.deliver(p, t),
        }
    }

    /// Whether a frame takes no time on the wire: no timing model (and so nothing on it).
    fn wire_is_instant(&self) -> bool {
        self.wire.is_none() && self.config.bitrate.is_none()
    }

    /// Counts a frame out of its sender's transmit queue.
    fn leaves_queue(&mut self, p: &Pending) {
        if let Participant::Endpoint(i) = p.from
            && let Some(ep) = self.endpoints.get_mut(i)
        {
            ep.sending -= 1;
        }
    }

    fn station_timers(&mut self, t: Instant) {
        for i in 0..self.stations.len() {
            let due = self.stations[i].next.is_some_and(|d| d <= t);
            if due {
                self.stations[i].station.handle_timeout(t);
                self.drain_station(i, t);
            }
        }
    }

    fn drain_station(&mut self, i: usize, t: Instant) {
        let id = self.stations[i].id;
        while let Some(frame) = self.stations[i].station.poll_transmit() {
            if !self.down {
                self.submit(Participant::Station(id), frame, t);
            }
        }
        let next = self.stations[i].station.poll_timeout();
        self.timers_moved |= next != self.stations[i].next;
        self.stations[i].next = next;
    }

    fn deliver(&mut self, p: Pending, at: Instant) {
        self.stats.frames += 1;
        let cap = self.config.queue_capacity;
        for (i, ep) in self.endpoints.iter_mut().enumerate() {
            if !ep.open || p.from == Participant::Endpoint(i) {
                continue;
            }
            if ep.queue.len() + ep.held >= cap {
                ep.lost += 1;
                self.stats.overflowed += 1;
            } else {
                ep.queue.push_back(Received::Frame { frame: p.frame, at });
            }
        }
        for i in 0..self.stations.len() {
            if p.from == Participant::Station(self.stations[i].id) {
                continue;
            }
            self.stations[i].station.handle_frame(at, &p.frame);
            self.drain_station(i, at);
        }
    }

    /// Whether endpoint `ep` has a frame or an overflow report waiting.
    fn has_queued(&self, ep: usize) -> bool {
        self.endpoints
            .get(ep)
            .is_some_and(|e| e.lost > 0 || !e.queue.is_empty())
    }

    fn pop(&mut self, ep: usize) -> Option<Received> {
        let e = self.endpoints.get_mut(ep)?;
        if e.lost > 0 {
            let dropped = core::mem::take(&mut e.lost);
            return Some(Received::Event(BusEvent::RxOverflow { dropped }));
        }
        e.queue.pop_front()
    }
}

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

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic in a station while the lock was held leaves consistent-enough state for tests.
        self.shared
            .state
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Opens a new endpoint (a [`Transport`]) on this bus.
    pub fn endpoint(&self) -> Endpoint {
        let mut st = self.lock();
        st.endpoints.push(Ep {
            open: true,
            queue: VecDeque::new(),
            lost: 0,
            sending: 0,
            held: 0,
        });
        Endpoint {
            bus: self.clone(),
            index: st.endpoints.len() - 1,
            more: false,
            inbox: VecDeque::new(),
            taken: 0,
        }
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

    fn spawn_service_thread(&self) {
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
                    // What it advanced may be frames for a blocked endpoint.
                    if st.sleepers > 0 {
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

/// One attachment to a [`MemoryBus`]; implements [`Transport`].
pub struct Endpoint {
    bus: MemoryBus,
    index: usize,
    /// Something was queued for this endpoint when it last received or sent (for
    /// `has_pending`, which so takes no lock; frames queued since are found by the next
    /// receive). A send looks because stations answer while the frame is delivered.
    more: bool,
    /// Frames taken over from the endpoint's queue on the bus while a send held the bus's
    /// lock (the stations' answers to what was sent), received from here without it. They
    /// still count against the queue's capacity until a later call locks the bus and learns
    /// how many were taken (`taken`): a frame received is freed at the endpoint's next call.
    inbox: VecDeque<Received>,
    /// Frames received from `inbox` since the bus last learnt of it.
    taken: usize,
}

impl core::fmt::Debug for Endpoint {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Endpoint")
            .field("index", &self.index)
            .finish()
    }
}

impl Endpoint {
    /// Locks the bus, telling it how many frames endpoint `index` received from its inbox
    /// meanwhile (`taken`). (Borrows the bus alone, so the endpoint's other fields stay free.)
    fn lock_bus<'a>(bus: &'a MemoryBus, index: usize, taken: &mut usize) -> MutexGuard<'a, State> {
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
    fn send_stamped(
        &mut self,
        frame: &CanFrame,
        given: Option<Instant>,
    ) -> Result<(), TransportError> {
        let mut st = Self::lock_bus(&self.bus, self.index, &mut self.taken);
        if st.down {
            return Err(TransportError::InterfaceDown);
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
            st.submit(me, *frame, now);
        } else {
            // Nothing else waits for the wire and nothing is due (advanced above): the frame
            // would go next and at once, so it goes now, past the queue.
            st.seq += 1;
            let p = Pending {
                seq: st.seq,
                from: me,
                frame: *frame,
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

impl Drop for Endpoint {
    fn drop(&mut self) {
        let mut st = Self::lock_bus(&self.bus, self.index, &mut self.taken);
        if let Some(ep) = st.endpoints.get_mut(self.index) {
            ep.open = false;
            ep.queue.clear();
        }
    }
}

impl Transport for Endpoint {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.send_stamped(frame, None)
    }

    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        self.send_stamped(frame, Some(now))
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
        loop {
            let now = if queued {
                queued = false;
                None
            } else {
                let now = st.now();
                st.advance(now);
                Some(now)
            };
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
                Clock::Real(_) => {
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
                }
            }
        }
    }

    fn now(&self) -> Instant {
        self.bus.now()
    }

    fn is_virtual(&self) -> bool {
        !self.bus.shared.real_time
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::run_station;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    fn frame(raw: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(sid(raw), data).unwrap()
    }

    fn recv_frame(ep: &mut Endpoint, until: Instant) -> Option<(CanFrame, Instant)> {
        match ep.recv_until(until).unwrap()? {
            Received::Frame { frame, at } => Some((frame, at)),
            Received::Event(e) => panic!("unexpected event {e}"),
        }
    }

    #[test]
    fn frame_lengths_follow_iso_11898() {
        let f8 = frame(0x123, &[0; 8]);
        assert_eq!(frame_bits(&f8, false), 111);
        assert_eq!(frame_bits(&f8, true), 135);
        assert_eq!(frame_bits(&frame(0x123, &[]), false), 47);
        let ext = CanFrame::new(CanId::extended(0x1234).unwrap(), &[0; 8]).unwrap();
        assert_eq!(frame_bits(&ext, false), 131);
        assert_eq!(frame_bits(&ext, true), 160);
        assert_eq!(
            frame_time(&f8, 1_000_000, false),
            Duration::from_micros(111)
        );
        assert_eq!(frame_time(&f8, 125_000, true), Duration::from_micros(1080));
        assert_eq!(frame_time(&f8, 800_000, false), Duration::from_micros(139));
    }

    #[test]
    fn frames_reach_everyone_but_the_sender() {
        let bus = MemoryBus::new();
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        let mut c = bus.endpoint();
        a.send(&frame(0x181, &[1, 2])).unwrap();
        let t = Instant::from_millis(1);
        assert_eq!(recv_frame(&mut b, t).unwrap().0, frame(0x181, &[1, 2]));
        assert_eq!(recv_frame(&mut c, t).unwrap().0, frame(0x181, &[1, 2]));
        assert_eq!(recv_frame(&mut a, t), None);
        // Waiting on the virtual clock jumped to the deadline.
        assert_eq!(bus.now(), t);
    }

    #[test]
    fn timing_model_and_arbitration() {
        let bus = MemoryBus::with_config(BusConfig {
            bitrate: Some(500_000),
            ..BusConfig::default()
        });
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        let mut rx = bus.endpoint();
        // Both queue at t=0: a's 0x701 was first, but b's 0x081 wins arbitration.
        a.send(&frame(0x701, &[0x05])).unwrap();
        b.send(&frame(0x081, &[0; 8])).unwrap();
        let far = Instant::from_millis(10);
        // The first frame to start is the one submitted when the wire was idle: 0x701 entered
        // arbitration alone at t=0, so it goes first; 0x081 then waits for the wire.
        let (f1, t1) = recv_frame(&mut rx, far).unwrap();
        assert_eq!(f1.cob_id(), Some(0x701));
        assert_eq!(t1, Instant::from_micros(2 * 55));
        let (f2, t2) = recv_frame(&mut rx, far).unwrap();
        assert_eq!(f2.cob_id(), Some(0x081));
        assert_eq!(t2, t1 + Duration::from_micros(2 * 111));

        // While the wire is busy, three frames queue; they go out by identifier.
        a.send(&frame(0x600, &[0; 8])).unwrap();
        a.send(&frame(0x300, &[1])).unwrap();
        b.send(&frame(0x200, &[2])).unwrap();
        b.send(&frame(0x100, &[3])).unwrap();
        let order: Vec<u16> = (0..4)
            .map(|_| {
                recv_frame(&mut rx, far + Duration::from_millis(10))
                    .unwrap()
                    .0
                    .cob_id()
                    .unwrap()
            })
            .collect();
        assert_eq!(order, [0x600, 0x100, 0x200, 0x300]);
        assert!(bus.stats().busy > Duration::ZERO);
    }

    #[test]
    fn fault_injection_is_seeded_and_counted() {
        let run = |seed| {
            let bus = MemoryBus::with_config(BusConfig {
                faults: Faults {
                    drop: 0.1,
                    duplicate: 0.1,
                    corrupt: 0.1,
                    delay: 0.1,
                    seed,
                    ..Faults::none()
                },
                ..BusConfig::default()
            });
            let mut a = bus.endpoint();
            let mut b = bus.endpoint();
            for i in 0..1000u16 {
                a.send(&frame(0x200, &i.to_le_bytes())).unwrap();
            }
            let mut got = Vec::new();
            while let Some((f, _)) = recv_frame(&mut b, Instant::from_millis(100)) {
                got.push(u16::from_le_bytes([f.data()[0], f.data()[1]]));
            }
            (got, bus.stats())
        };
        let (got, stats) = run(1);
        assert_eq!(run(1).0, got, "same seed, same outcome");
        assert_ne!(run(2).0, got);
        assert!(stats.dropped > 50 && stats.dropped < 150, "{stats:?}");
        assert!(
            stats.duplicated > 50 && stats.corrupted > 50 && stats.delayed > 50,
            "{stats:?}"
        );
        assert_eq!(got.len() as u64, 1000 - stats.dropped + stats.duplicated);
    }

    #[test]
    fn a_full_transmit_queue_refuses_frames_until_the_wire_takes_some() {
        let bus = MemoryBus::with_config(BusConfig {
            bitrate: Some(125_000),
            tx_queue_capacity: 3,
            ..BusConfig::default()
        });
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        // The first frame goes onto the idle wire at once, three wait, the fifth is refused.
        let results: Vec<_> = (0..5u8).map(|i| a.send(&frame(0x200, &[i]))).collect();
        assert!(results[..4].iter().all(Result::is_ok), "{results:?}");
        assert!(matches!(results[4], Err(TransportError::TxQueueFull)));
        assert_eq!(bus.pending_frames(), 3);
        // One frame time (55 bits at 125 kbit/s = 440 us) later there is room for one more.
        let (f, _) = recv_frame(&mut b, Instant::from_micros(450)).unwrap();
        assert_eq!(f.data(), [0]);
        a.send(&frame(0x200, &[5])).unwrap();
        assert!(matches!(
            a.send(&frame(0x200, &[6])),
            Err(TransportError::TxQueueFull)
        ));
        // Nothing refused was delivered, nothing accepted was lost, the order kept.
        let mut got = vec![0];
        while let Some((f, _)) = recv_frame(&mut b, Instant::from_millis(10)) {
            got.push(f.data()[0]);
        }
        assert_eq!(got, [0, 1, 2, 3, 5]);
    }

    #[test]
    fn overflow_is_reported_not_silent() {
        let bus = MemoryBus::with_config(BusConfig {
            queue_capacity: 2,
            ..BusConfig::default()
        });
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        for i in 0..5u8 {
            a.send(&frame(0x200, &[i])).unwrap();
        }
        assert_eq!(
            b.try_recv().unwrap(),
            Some(Received::Event(BusEvent::RxOverflow { dropped: 3 }))
        );
        assert!(matches!(
            b.try_recv().unwrap(),
            Some(Received::Frame { .. })
        ));
        assert!(matches!(
            b.try_recv().unwrap(),
            Some(Received::Frame { .. })
        ));
        assert_eq!(b.try_recv().unwrap(), None);
        assert_eq!(bus.stats().overflowed, 3);
    }

    #[test]
    fn frames_taken_over_by_a_send_keep_their_order_and_count_against_the_queue() {
        let bus = MemoryBus::with_config(BusConfig {
            queue_capacity: 2,
            ..BusConfig::default()
        });
        let mut a = bus.endpoint();
        let mut b = bus.endpoint();
        let data = |r: Option<Received>| match r {
            Some(Received::Frame { frame, .. }) => frame.data()[0],
            other => panic!("expected a frame, got {other:?}"),
        };
        a.send(&frame(0x200, &[1])).unwrap();
        // b's send takes frame 1 over into b's inbox; it still fills a place in b's queue.
        b.send(&frame(0x300, &[0])).unwrap();
        assert!(b.has_pending());
        a.send(&frame(0x200, &[2])).unwrap();
        a.send(&frame(0x200, &[3])).unwrap();
        assert_eq!(bus.stats().overflowed, 1, "capacity 2: frame 3 is lost");
        assert_eq!(data(b.try_recv().unwrap()), 1);
        // Received from the inbox without the bus's lock; the bus learns of it at b's next
        // call, which reports the loss first (as a receive queue always does), then frame 2.
        assert_eq!(
            b.try_recv().unwrap(),
            Some(Received::Event(BusEvent::RxOverflow { dropped: 1 }))
        );
        assert_eq!(data(b.try_recv().unwrap()), 2);
        a.send(&frame(0x200, &[4])).unwrap();
        a.send(&frame(0x200, &[5])).unwrap();
        assert_eq!(bus.stats().overflowed, 1, "both places are free again");
        assert_eq!(data(b.try_recv().unwrap()), 4);
        assert_eq!(data(b.try_recv().unwrap()), 5);
        assert_eq!(b.try_recv().unwrap(), None);
    }

    #[test]
    fn interface_down_fails_sends_and_is_reported() {
        let bus = MemoryBus::new();
        let mut a = bus.endpoint();
        bus.inject_event(BusEvent::BusOff);
        bus.inject_event(BusEvent::InterfaceDown);
        assert!(matches!(
            a.send(&frame(1, &[])),
            Err(TransportError::InterfaceDown)
        ));
        assert_eq!(
            a.try_recv().unwrap(),
            Some(Received::Event(BusEvent::BusOff))
        );
        assert_eq!(
            a.try_recv().unwrap(),
            Some(Received::Event(BusEvent::InterfaceDown))
        );
        bus.inject_event(BusEvent::InterfaceUp);
        a.send(&frame(1, &[])).unwrap();
    }

    /// Answers every frame on 0x600 with 0x580 and sends a "heartbeat" every 100 ms.
    #[derive(Default)]
    struct Echo {
        out: VecDeque<CanFrame>,
        next_beat: Option<Instant>,
        seen: usize,
    }

    impl Station for Echo {
        fn handle_frame(&mut self, _now: Instant, f: &CanFrame) {
            self.seen += 1;
            if f.cob_id() == Some(0x600) {
                self.out
                    .push_back(CanFrame::new(sid(0x580), f.data()).unwrap());
            }
        }
        fn handle_timeout(&mut self, now: Instant) {
            let due = self.next_beat.is_none_or(|t| t <= now);
            if due {
                self.out.push_back(frame(0x700, &[0x05]));
                self.next_beat = Some(now + Duration::from_millis(100));
            }
        }
        fn poll_transmit(&mut self) -> Option<CanFrame> {
            self.out.pop_front()
        }
        fn poll_timeout(&self) -> Option<Instant> {
            Some(self.next_beat.unwrap_or(Instant::ZERO))
        }
    }

    #[test]
    fn attached_stations_run_on_virtual_time() {
        let bus = MemoryBus::new();
        let mut master = bus.endpoint();
        let id = bus.attach(Echo::default());
        master.send(&frame(0x600, &[0x40])).unwrap();
        let mut beats = Vec::new();
        let mut echoed = false;
        while let Some((f, at)) = recv_frame(&mut master, Instant::from_millis(350)) {
            match f.cob_id() {
                Some(0x700) => beats.push(at.as_micros() / 1000),
                Some(0x580) => echoed = true,
                other => panic!("{other:?}"),
            }
        }
        assert!(echoed);
        assert_eq!(beats, [0, 100, 200, 300]);
        assert_eq!(bus.with_station(id, |e| e.seen), Some(1));
        let echo = bus.detach(id).unwrap();
        assert_eq!(echo.seen, 1);
        bus.run_for(Duration::from_secs(1));
        assert_eq!(
            master.try_recv().unwrap(),
            None,
            "detached station is silent"
        );
    }

    #[test]
    fn real_time_mode_with_a_station_on_its_own_endpoint() {
        let bus = MemoryBus::with_config(BusConfig {
            clock: ClockMode::RealTime,
            ..BusConfig::default()
        });
        let mut master = bus.endpoint();
        let mut dev_ep = bus.endpoint();
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let stop2 = stop.clone();
        let h = std::thread::spawn(move || {
            let mut echo = Echo::default();
            run_station(&mut dev_ep, &mut echo, || {
                stop2.load(std::sync::atomic::Ordering::Relaxed)
            })
            .unwrap();
        });
        master.send(&frame(0x600, &[0x40, 1])).unwrap();
        let deadline = master.now() + Duration::from_secs(5);
        let mut echoed = false;
        while let Some(r) = master.recv_until(deadline).unwrap() {
            if let Received::Frame { frame, .. } = r
                && frame.cob_id() == Some(0x580)
            {
                echoed = true;
                break;
            }
        }
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        h.join().unwrap();
        assert!(echoed);
    }

    #[test]
    fn send_at_stamps_with_the_callers_reading_but_never_before_the_bus() {
        let bus = MemoryBus::with_config(BusConfig {
            clock: ClockMode::RealTime,
            ..BusConfig::default()
        });
        let (mut a, mut b, mut c) = (bus.endpoint(), bus.endpoint(), bus.endpoint());
        let stamp = |c: &mut Endpoint| recv_frame(c, c.now() + Duration::from_secs(1)).unwrap().1;
        // A fresh reading is the stamp: the bus does not read its clock again.
        let t1 = a.now();
        a.send_at(&frame(0x181, &[1]), t1).unwrap();
        assert_eq!(stamp(&mut c), t1);
        // A reading older than what the bus has processed since is not.
        std::thread::sleep(std::time::Duration::from_millis(2));
        b.send(&frame(0x182, &[2])).unwrap();
        let t2 = stamp(&mut c);
        assert!(t2 > t1 + Duration::from_millis(1), "{t2:?} after {t1:?}");
        a.send_at(&frame(0x183, &[3]), t1).unwrap();
        assert_eq!(stamp(&mut c), t2);
    }
}
