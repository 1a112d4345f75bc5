//! The in-memory bus's shared state, behind one mutex: the clock, the endpoints' receive
//! queues, the attached stations with their timers, the frames waiting for the wire and the
//! one on it. Every participant steps it forward to the time it asks for.

use std::any::Any;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, Duration, FdFrame, Instant};

use crate::transport::contract::{BusEvent, Received, Station};

use super::config::{BusConfig, BusStats, Rng, arbitration_key, fd_frame_time, frame_time};

/// A frame on its way over the bus: classic, or CAN FD (boxed: most traffic is classic, and an
/// FD frame is nine times a classic one's size).
#[derive(Debug, Clone)]
pub(super) enum WireFrame {
    Can(CanFrame),
    Fd(Box<FdFrame>),
}

impl WireFrame {
    fn arbitration_key(&self) -> u64 {
        match self {
            Self::Can(f) => arbitration_key(f.id(), f.is_remote()),
            Self::Fd(f) => arbitration_key(f.id(), false),
        }
    }

    fn time(&self, config: &BusConfig, bitrate: u32) -> Duration {
        match self {
            Self::Can(f) => frame_time(f, bitrate, config.worst_case_stuffing),
            Self::Fd(f) => {
                fd_frame_time(f, bitrate, config.data_bitrate, config.worst_case_stuffing)
            }
        }
    }

    /// The frame with bit `bit` of its data flipped.
    fn flipped(&self, bit: usize) -> Option<Self> {
        match self {
            Self::Can(f) => {
                let mut data = [0u8; 8];
                let len = f.data().len();
                data[..len].copy_from_slice(f.data());
                data[bit / 8] ^= 1 << (bit % 8);
                CanFrame::new(f.id(), &data[..len]).ok().map(Self::Can)
            }
            Self::Fd(f) => {
                let mut data = [0u8; 64];
                let len = f.data().len();
                data[..len].copy_from_slice(f.data());
                data[bit / 8] ^= 1 << (bit % 8);
                FdFrame::new(f.id(), &data[..len])
                    .ok()
                    .map(|c| Self::Fd(Box::new(c.with_flags(f.flags()))))
            }
        }
    }

    fn data_len(&self) -> usize {
        match self {
            Self::Can(f) => f.data().len(),
            Self::Fd(f) => f.data().len(),
        }
    }
}

/// A frame sent and not yet on the wire: it competes in arbitration once `ready`.
#[derive(Debug)]
pub(super) struct Pending {
    /// Send order, which breaks ties between equal identifiers.
    pub(super) seq: u64,
    /// Who sent it (it is not delivered back to its sender).
    pub(super) from: Participant,
    pub(super) frame: WireFrame,
    /// When it may start arbitrating (its send time, later when a fault delays it).
    pub(super) ready: Instant,
}

/// Who is on the bus: an endpoint (by index) or an attached station (by id).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Participant {
    /// An [`Endpoint`](super::Endpoint), by its index in `State::endpoints`.
    Endpoint(usize),
    /// An attached station, by its id.
    Station(u64),
}

/// An endpoint's side of the shared state: its receive queue and what it has in flight.
#[derive(Debug)]
pub(super) struct Ep {
    /// False once the endpoint was dropped (its index is not reused).
    pub(super) open: bool,
    /// Frames and bus events delivered and not yet moved to the endpoint's inbox.
    pub(super) queue: VecDeque<Received>,
    /// Frames dropped on a full queue since the last [`BusEvent::RxOverflow`] report.
    pub(super) lost: u64,
    /// Its frames in `State::pending` (for the transmit queue bound, without a scan per send).
    pub(super) sending: usize,
    /// Frames moved to the endpoint's own inbox and not yet known to be taken from it: they
    /// count against the receive queue's capacity (see `Endpoint::inbox`).
    pub(super) held: usize,
    /// While the endpoint waits to coalesce a burst (real clock, see
    /// [`RxCoalescing`](crate::RxCoalescing)): the queue length at which it wants to be woken
    /// before its window ends. Cleared when a delivery reaches it (one wake-up).
    pub(super) wake_at: Option<usize>,
    /// The endpoint's waker was called ([`Transport::waker`](crate::Transport::waker), real
    /// clock only): its current or next wait ends at once (and clears it).
    pub(super) woken: bool,
}

/// A station with its concrete type erased but recoverable.
pub(super) trait AnyStation: Station {
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

/// A station the bus steps itself, with its id and its next timer.
pub(super) struct Attached {
    pub(super) id: u64,
    pub(super) station: Box<dyn AnyStation>,
    /// The station's `poll_timeout` as of its last input (the bus asks for it at every event;
    /// a station's timers change only when it is given something).
    pub(super) next: Option<Instant>,
}

/// The bus's time: a virtual instant that moves only when a participant waits, or the host's
/// monotonic clock.
pub(super) enum Clock {
    /// Virtual time, now at this instant.
    Virtual(Instant),
    /// Real time.
    Real(MonotonicClock),
}

/// Everything the participants of one bus share, behind the bus's one mutex: the clock, each
/// endpoint's receive queue, the attached stations, the frames waiting for arbitration and the
/// one on the wire. Whoever holds the lock advances it to the time it asks for
/// (`advance`): frames leave the wire in arbitration order and reach every other
/// participant, stations get their frames and timers, faults are applied as frames are sent.
pub(super) struct State {
    pub(super) clock: Clock,
    pub(super) config: BusConfig,
    /// The seeded generator of the fault injection.
    pub(super) rng: Rng,
    pub(super) endpoints: Vec<Ep>,
    pub(super) stations: Vec<Attached>,
    pub(super) next_station: u64,
    /// Frames sent and not yet on the wire.
    pub(super) pending: Vec<Pending>,
    /// The frame on the wire and when its transmission ends.
    pub(super) wire: Option<(Pending, Instant)>,
    /// When the wire is free for the next frame.
    pub(super) wire_free_at: Instant,
    /// The interface is down (an injected `InterfaceDown`): sends fail.
    pub(super) down: bool,
    /// Numbers the frames sent ([`Pending::seq`]).
    pub(super) seq: u64,
    /// Whether the fault injection is on (`config.faults.any()`, kept: asked for every frame).
    pub(super) faulty: bool,
    /// A station's timer changed since [`Shared::release`] last looked (so the service
    /// thread's wake-up time may be too late).
    pub(super) timers_moved: bool,
    /// The latest time the bus has processed (advanced to): a frame stamped with a clock
    /// reading its sender took earlier is stamped this instead (see `Transport::send_at`).
    pub(super) floor: Instant,
    pub(super) stats: BusStats,
    pub(super) service_thread: bool,
    /// Endpoint threads blocked on the condition variable (real clock only) that a frame for
    /// them ends (an endpoint coalescing a burst is not counted: see `Ep::wake_at`).
    pub(super) sleepers: usize,
    /// A delivery filled a coalescing endpoint's queue to its `Ep::wake_at`: the next release
    /// of the lock wakes the waiting threads.
    pub(super) batch_full: bool,
    /// When the service thread's current wait ends; `None` while it is not waiting (it then
    /// looks at the bus again before it waits).
    pub(super) service_until: Option<Instant>,
}

pub(super) struct Shared {
    pub(super) state: Mutex<State>,
    pub(super) cond: Condvar,
    /// Whether anyone can wait on `cond`: only real-time waits block, and a notification costs
    /// a system call even with nobody waiting.
    pub(super) real_time: bool,
    /// The real-time clock (the same as the state's), read without the lock: the master asks
    /// for the time several times per request, and the lock is contended with the bus's
    /// service thread.
    pub(super) real_clock: Option<MonotonicClock>,
    /// A virtual clock's time in microseconds (a copy of the state's, set under its lock), for
    /// the same reason.
    pub(super) virtual_now: AtomicU64,
}

impl Shared {
    /// Publishes a virtual clock's new time (with the state locked).
    pub(super) fn set_virtual_now(&self, t: Instant) {
        self.virtual_now.store(t.as_micros(), Ordering::Release);
    }

    /// Unlocks the bus after a change, waking the blocked threads only when one needs it: an
    /// endpoint waits for frames, or the service thread sleeps past the bus's next event. (A
    /// notification costs a system call, and a needless wake-up of the service thread a
    /// context switch and a fight for the lock, on every frame sent.)
    pub(super) fn release(&self, mut st: MutexGuard<'_, State>) {
        let wake = self.real_time
            && (st.sleepers > 0 || core::mem::take(&mut st.batch_full) || st.service_wakes_early());
        drop(st);
        if wake {
            self.cond.notify_all();
        }
    }
}

/// Upper bound of internal events processed in one step, so a misbehaving station whose timer
/// never moves forward cannot hang the bus.
pub(super) const MAX_EVENTS_PER_STEP: usize = 100_000;

impl State {
    pub(super) fn now(&self) -> Instant {
        match &self.clock {
            Clock::Virtual(t) => *t,
            Clock::Real(c) => c.now(),
        }
    }

    /// Puts a frame on the way to the wire, applying the fault injection.
    pub(super) fn submit(&mut self, from: Participant, frame: WireFrame, now: Instant) {
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
        let len = frame.data_len();
        if len > 0 && self.rng.chance(f.corrupt) {
            let bit = (self.rng.next_u64() % (len as u64 * 8)) as usize;
            if let Some(c) = frame.flipped(bit) {
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
        for _ in 1..copies {
            self.push_pending(from, frame.clone(), ready);
        }
        self.push_pending(from, frame, ready);
    }

    pub(super) fn push_pending(&mut self, from: Participant, frame: WireFrame, ready: Instant) {
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
    pub(super) fn next_wire_event(&self) -> Option<Instant> {
        if let Some((_, done)) = &self.wire {
            return Some(*done);
        }
        let earliest = self.pending.iter().map(|p| p.ready).min()?;
        Some(earliest.max(self.wire_free_at))
    }

    pub(super) fn next_station_event(&self) -> Option<Instant> {
        self.stations.iter().filter_map(|s| s.next).min()
    }

    pub(super) fn next_event(&self) -> Option<Instant> {
        match (self.next_wire_event(), self.next_station_event()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Whether the service thread's current wait ends after the bus's next event: a frame
    /// waiting for the wire, or a station timer (looked at only when one moved: the stations'
    /// timers mostly stay as they were, e.g. through an SDO round trip).
    pub(super) fn service_wakes_early(&mut self) -> bool {
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
    pub(super) fn advance(&mut self, now: Instant) {
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

    pub(super) fn run_events(&mut self, now: Instant) {
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

    pub(super) fn wire_step(&mut self, t: Instant) {
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
            .min_by_key(|(_, p)| (p.frame.arbitration_key(), p.seq))
            .map(|(i, _)| i)
        else {
            return;
        };
        let p = self.pending.swap_remove(pos);
        self.leaves_queue(&p);
        match self.config.bitrate {
            Some(rate) => {
                let d = p.frame.time(&self.config, rate);
                self.stats.busy = self.stats.busy + d;
                self.wire = Some((p, t + d));
            }
            None => self.deliver(p, t),
        }
    }

    /// Whether a frame takes no time on the wire: no timing model (and so nothing on it).
    pub(super) fn wire_is_instant(&self) -> bool {
        self.wire.is_none() && self.config.bitrate.is_none()
    }

    /// Counts a frame out of its sender's transmit queue.
    pub(super) fn leaves_queue(&mut self, p: &Pending) {
        if let Participant::Endpoint(i) = p.from
            && let Some(ep) = self.endpoints.get_mut(i)
        {
            ep.sending -= 1;
        }
    }

    pub(super) fn station_timers(&mut self, t: Instant) {
        for i in 0..self.stations.len() {
            let due = self.stations[i].next.is_some_and(|d| d <= t);
            if due {
                self.stations[i].station.handle_timeout(t);
                self.drain_station(i, t);
            }
        }
    }

    pub(super) fn drain_station(&mut self, i: usize, t: Instant) {
        let id = self.stations[i].id;
        while let Some(frame) = self.stations[i].station.poll_transmit() {
            if !self.down {
                self.submit(Participant::Station(id), WireFrame::Can(frame), t);
            }
        }
        while let Some(frame) = self.stations[i].station.poll_transmit_fd() {
            // A classic bus carries no FD frame (a classic controller would flag an error).
            if !self.down && self.config.fd {
                self.submit(Participant::Station(id), WireFrame::Fd(Box::new(frame)), t);
            }
        }
        let next = self.stations[i].station.poll_timeout();
        self.timers_moved |= next != self.stations[i].next;
        self.stations[i].next = next;
    }

    pub(super) fn deliver(&mut self, p: Pending, at: Instant) {
        self.stats.frames += 1;
        let cap = self.config.queue_capacity;
        let mut batch_full = false;
        for (i, ep) in self.endpoints.iter_mut().enumerate() {
            if !ep.open || p.from == Participant::Endpoint(i) {
                continue;
            }
            if ep.queue.len() + ep.held >= cap {
                ep.lost += 1;
                self.stats.overflowed += 1;
            } else {
                ep.queue.push_back(match &p.frame {
                    WireFrame::Can(frame) => Received::Frame { frame: *frame, at },
                    WireFrame::Fd(frame) => Received::Event(BusEvent::FdFrame {
                        frame: frame.clone(),
                        at,
                    }),
                });
            }
            if ep
                .wake_at
                .is_some_and(|n| ep.queue.len() >= n || ep.lost > 0)
            {
                ep.wake_at = None;
                batch_full = true;
            }
        }
        self.batch_full |= batch_full;
        for i in 0..self.stations.len() {
            if p.from == Participant::Station(self.stations[i].id) {
                continue;
            }
            match &p.frame {
                WireFrame::Can(frame) => self.stations[i].station.handle_frame(at, frame),
                WireFrame::Fd(frame) => self.stations[i].station.handle_fd_frame(at, frame),
            }
            self.drain_station(i, at);
        }
    }

    /// Whether endpoint `ep` has a frame or an overflow report waiting.
    pub(super) fn has_queued(&self, ep: usize) -> bool {
        self.endpoints
            .get(ep)
            .is_some_and(|e| e.lost > 0 || !e.queue.is_empty())
    }

    pub(super) fn pop(&mut self, ep: usize) -> Option<Received> {
        let e = self.endpoints.get_mut(ep)?;
        if e.lost > 0 {
            let dropped = core::mem::take(&mut e.lost);
            return Some(Received::Event(BusEvent::RxOverflow { dropped }));
        }
        e.queue.pop_front()
    }
}
