//! [`MemoryBus`], the handle to an in-memory bus: configuration, endpoints, attached stations,
//! injected bus events, statistics, and the service thread of a real-time bus.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};

use canola_frame::time::MonotonicClock;
use canola_frame::{Duration, Instant};

use crate::transport::contract::{BusEvent, Received, Station};

use super::config::{BusConfig, BusStats, ClockMode, Faults, Rng};
use super::state::{Attached, Clock, Shared, State};

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
