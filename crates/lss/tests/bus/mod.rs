//! A virtual-clock CAN bus for LSS tests: one master machine, any number of slave machines and
//! scripted responders.
//!
//! Frames travel as `CanFrame`s. A request reaches every node at the instant it is sent; each
//! answer leaves its node `latency` (+ a per-answer spread) later. Slaves answering the same
//! request put identical frames on the bus: with [`Delivery::Merged`] frames that are identical
//! and due at the same instant reach the master once (the transmissions overlapped bit for bit,
//! as on a real bus); with [`Delivery::Separate`] every answer arrives as its own frame, each
//! with its own random extra delay up to `spread`.
#![allow(dead_code)]

use std::vec::Vec;

use canola_frame::{CanFrame, Duration, Instant};
use canola_lss::{
    LssAddress, LssError, LssMachine, LssSlave, MasterEvent, Request, Response, SlaveConfig,
};

/// A small deterministic random generator (xorshift64*).
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    pub(crate) fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub(crate) fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }
    pub(crate) fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// `n` distinct random addresses.
pub(crate) fn random_addresses(rng: &mut Rng, n: usize) -> Vec<LssAddress> {
    let mut v: Vec<LssAddress> = Vec::new();
    while v.len() < n {
        let a = LssAddress::new(
            rng.next_u32(),
            rng.next_u32(),
            rng.next_u32(),
            rng.next_u32(),
        );
        if !v.contains(&a) {
            v.push(a);
        }
    }
    v
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Delivery {
    Merged,
    Separate { spread: Duration },
}

/// A node that answers requests by a script (for error codes real slaves do not produce).
/// What [`Bus::run`] returns: the result and the events before it.
pub(crate) type RunResult<T, P = core::convert::Infallible> =
    (Result<T, LssError>, Vec<MasterEvent<T, P>>);

pub(crate) type Script = Box<dyn FnMut(&Request) -> Option<Response>>;

pub(crate) struct Bus {
    pub(crate) now: Instant,
    pub(crate) slaves: Vec<LssSlave>,
    pub(crate) scripts: Vec<Script>,
    pub(crate) delivery: Delivery,
    pub(crate) latency: Duration,
    pub(crate) rng: Rng,
    pending: Vec<(Instant, CanFrame)>,
    /// Every request the master sent, with its time.
    pub(crate) sent: Vec<(Instant, Request)>,
    /// How many response frames reached the master.
    pub(crate) delivered: usize,
}

impl Bus {
    pub(crate) fn new(delivery: Delivery) -> Self {
        Self {
            now: Instant::ZERO,
            slaves: Vec::new(),
            scripts: Vec::new(),
            delivery,
            latency: Duration::from_micros(500),
            rng: Rng::new(7),
            pending: Vec::new(),
            sent: Vec::new(),
            delivered: 0,
        }
    }

    pub(crate) fn with_unconfigured(delivery: Delivery, addresses: &[LssAddress]) -> Self {
        let mut bus = Self::new(delivery);
        for a in addresses {
            bus.slaves
                .push(LssSlave::new(SlaveConfig::unconfigured(*a)));
        }
        bus
    }

    /// Unconfigured slaves that, as real slaves do, answer Fastscan in configuration state too.
    pub(crate) fn with_real(delivery: Delivery, addresses: &[LssAddress]) -> Self {
        let mut bus = Self::new(delivery);
        for a in addresses {
            bus.add(SlaveConfig::unconfigured_real(*a));
        }
        bus
    }

    /// [`with_real`](Self::with_real) when `real`, else [`with_unconfigured`](Self::with_unconfigured).
    pub(crate) fn with_slaves(delivery: Delivery, addresses: &[LssAddress], real: bool) -> Self {
        if real {
            Self::with_real(delivery, addresses)
        } else {
            Self::with_unconfigured(delivery, addresses)
        }
    }

    /// How many Fastscan requests the master sent (each costs one response window under
    /// `ResponsePolicy::WholeWindow`).
    pub(crate) fn fastscans(&self) -> u64 {
        self.sent
            .iter()
            .filter(|(_, r)| matches!(r, Request::Fastscan { .. }))
            .count() as u64
    }

    pub(crate) fn add(&mut self, config: SlaveConfig) {
        self.slaves.push(LssSlave::new(config));
    }

    pub(crate) fn slave(&self, a: LssAddress) -> &LssSlave {
        self.slaves
            .iter()
            .find(|s| s.address() == a)
            .expect("no such slave")
    }

    fn transmit(&mut self, frame: CanFrame) {
        let req = Request::from_frame(&frame).expect("master sent a non-LSS frame");
        assert_eq!(frame.dlc(), 8, "LSS frames are 8 bytes");
        self.sent.push((self.now, req));
        let mut answers = Vec::new();
        for s in &mut self.slaves {
            s.handle_frame(self.now, &frame);
            while let Some(f) = s.poll_transmit_frame() {
                answers.push(f);
            }
            while s.poll_event().is_some() {}
        }
        for script in &mut self.scripts {
            if let Some(r) = script(&req) {
                answers.push(r.to_frame());
            }
        }
        for f in answers {
            let extra = match self.delivery {
                Delivery::Merged => Duration::ZERO,
                Delivery::Separate { spread } => {
                    Duration::from_micros(self.rng.below(spread.as_micros() + 1))
                }
            };
            self.pending.push((self.now + self.latency + extra, f));
        }
    }

    fn deliver_due<M: LssMachine>(&mut self, m: &mut M) {
        let now = self.now;
        let mut due: Vec<(Instant, CanFrame)> = Vec::new();
        self.pending.retain(|p| {
            if p.0 <= now {
                due.push(*p);
                false
            } else {
                true
            }
        });
        due.sort_by_key(|p| p.0);
        if self.delivery == Delivery::Merged {
            due.dedup();
        }
        for (_, f) in due {
            self.delivered += 1;
            assert!(m.handle_frame(now, &f));
        }
    }

    /// Runs `m` until it reports `Done`; returns the result and the events before it.
    pub(crate) fn run<M: LssMachine>(&mut self, m: &mut M) -> RunResult<M::Output, M::Progress> {
        self.run_with(m, |_, _| {})
    }

    /// [`run`](Self::run), handing every event to `seen` with the machine first (a test
    /// reports what the caller hears on the bus meanwhile: boot-ups, heartbeats).
    pub(crate) fn run_with<M: LssMachine>(
        &mut self,
        m: &mut M,
        mut seen: impl FnMut(&mut M, &MasterEvent<M::Output, M::Progress>),
    ) -> RunResult<M::Output, M::Progress> {
        let mut events = Vec::new();
        for _ in 0..1_000_000 {
            while let Some(f) = m.poll_transmit_frame() {
                self.transmit(f);
            }
            while let Some(e) = m.poll_event() {
                if let MasterEvent::Done(r) = e {
                    // Requests queued together with the end (switch mode global) still go out.
                    while let Some(f) = m.poll_transmit_frame() {
                        self.transmit(f);
                    }
                    assert!(m.is_finished());
                    return (r, events);
                }
                seen(m, &e);
                events.push(e);
            }
            let t_frames = self.pending.iter().map(|p| p.0).min();
            let t_slaves = self.slaves.iter().filter_map(|s| s.poll_timeout()).min();
            let t_master = m.poll_timeout();
            let next = [t_frames, t_slaves, t_master]
                .into_iter()
                .flatten()
                .min()
                .expect("master stalled: nothing to wait for and not done");
            if next > self.now {
                self.now = next;
            }
            for s in &mut self.slaves {
                s.handle_timeout(self.now);
                while s.poll_event().is_some() {}
            }
            self.deliver_due(m);
            if t_master.is_some_and(|t| t <= self.now) {
                m.handle_timeout(self.now);
            }
        }
        panic!("master did not finish");
    }

    /// Lets slave timers (bit timing activation) run out.
    pub(crate) fn settle(&mut self, until: Instant) {
        if until > self.now {
            self.now = until;
        }
        for s in &mut self.slaves {
            s.handle_timeout(self.now);
        }
    }
}
