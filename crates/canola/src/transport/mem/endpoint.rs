//! [`Endpoint`], one attachment to an in-memory bus as a [`Transport`](crate::Transport): what it sends goes to
//! every other participant, what they send lands in its receive queue.

use std::collections::VecDeque;
use std::sync::MutexGuard;

use canola_frame::{CanFrame, FdFrame, Instant};

use crate::transport::contract::{Received, Transport, TransportError};

use super::bus::MemoryBus;
use super::state::{Clock, Ep, Participant, Pending, State, WireFrame};

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
        });
        Endpoint {
            bus: self.clone(),
            index: st.endpoints.len() - 1,
            more: false,
            inbox: VecDeque::new(),
            taken: 0,
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
