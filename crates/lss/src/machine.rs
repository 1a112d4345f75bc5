//! The sans-IO contract shared by every LSS master machine, and the request/response exchange
//! they are built on.
//!
//! # Call order
//! 1. Start the machine with its command (`start(now, ..)`).
//! 2. Drain [`LssMachine::poll_transmit`] and put every request on the bus (COB-ID 0x7E5), in
//!    order, right away: a response timeout runs from the instant passed to the call that queued
//!    the request.
//! 3. Feed every frame received on COB-ID 0x7E4 to [`LssMachine::handle_response`] (or
//!    [`LssMachine::handle_frame`], which ignores other frames), and call
//!    [`LssMachine::handle_timeout`] when [`LssMachine::poll_timeout`] has passed.
//! 4. After each call drain [`LssMachine::poll_event`]; the machine is finished once it returned
//!    [`MasterEvent::Done`].
//!
//! # Several slaves answering at once
//! Identify slave (0x4F) and identify non-configured slave (0x50) carry no data, so slaves that
//! answer the same request put identical frames on the bus. A receiver sees one frame when the
//! transmissions overlapped, or several identical frames when they did not. The machines count an
//! answer, never answerers, and ignore a response that arrives while a later request is still
//! queued (it belongs to an earlier request). With [`ResponsePolicy::WholeWindow`] (the default
//! for multi-slave requests) a machine also waits out the whole response window before it sends
//! the next request, so a slow slave's late duplicate cannot be taken for the answer to the next
//! request; [`ResponsePolicy::FirstAnswer`] moves on at the first answer and is about twice as
//! fast, which is safe when every slave answers within one frame time of the first (slave
//! frames on 0x7E4 win arbitration against the master's 0x7E5, so an answer already queued in a
//! slave's controller always precedes the next request).

use core::convert::Infallible;

use canola_frame::{CanFrame, Duration, Instant, NodeId};
use heapless::Deque;

use crate::address::{BitTiming, LssAddress};
use crate::error::{LssError, Service};
use crate::wire::{Request, Response};

/// When a machine that may get several identical answers moves on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ResponsePolicy {
    /// Wait for the whole response timeout even after an answer (robust against late duplicates).
    #[default]
    WholeWindow,
    /// Move on at the first answer.
    FirstAnswer,
}

/// What a master machine reports: `T` is what it produces when it finishes, `P` what it reports
/// as it goes (the assign-all workflow: each slave's outcome; nothing for the others).
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum MasterEvent<T, P = Infallible> {
    /// Activate bit timing was sent: the master's own CAN controller must switch to
    /// `bit_timing` at `at` (after the switch delay), as the slaves do.
    SwitchBitRate {
        /// The new bit timing.
        bit_timing: BitTiming,
        /// When to switch.
        at: Instant,
    },
    /// A scan found a slave.
    Found(LssAddress),
    /// A step of the procedure finished (assign-all: one slave assigned or failed).
    Progress(P),
    /// Assign-all: a node-ID of the pool was not handed out because it is in use on the bus
    /// (given in [`AssignConfig::in_use`](crate::AssignConfig::in_use) and reached by the
    /// pool, or reported during the run with
    /// [`AssignAll::node_id_heard`](crate::AssignAll::node_id_heard)). Each once.
    NodeIdInUse(NodeId),
    /// The machine finished.
    Done(Result<T, LssError>),
}

/// The sans-IO interface of every LSS master machine; see the module docs for the call order.
pub trait LssMachine {
    /// What the machine produces when it finishes successfully.
    type Output;

    /// What the machine reports as it goes ([`MasterEvent::Progress`]); `Infallible` for none.
    type Progress;

    /// A response received on COB-ID 0x7E4.
    fn handle_response(&mut self, now: Instant, response: &Response);

    /// Time passed; call when [`poll_timeout`](Self::poll_timeout) is due (early calls are
    /// harmless).
    fn handle_timeout(&mut self, now: Instant);

    /// The next request to transmit on COB-ID 0x7E5.
    #[must_use]
    fn poll_transmit(&mut self) -> Option<Request>;

    /// When [`handle_timeout`](Self::handle_timeout) must be called next, if at all.
    #[must_use]
    fn poll_timeout(&self) -> Option<Instant>;

    /// The next event; [`MasterEvent::Done`] comes last.
    #[must_use]
    fn poll_event(&mut self) -> Option<MasterEvent<Self::Output, Self::Progress>>;

    /// Whether the machine has finished (its `Done` event may still be waiting to be polled).
    fn is_finished(&self) -> bool;

    /// Feeds a received frame: LSS responses (data frames on 0x7E4) go to
    /// [`handle_response`](Self::handle_response); anything else is ignored. Returns whether the
    /// frame was an LSS response.
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> bool {
        match Response::from_frame(frame) {
            Ok(r) => {
                self.handle_response(now, &r);
                true
            }
            Err(_) => false,
        }
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on COB-ID 0x7E5.
    #[must_use]
    fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|r| r.to_frame())
    }
}

/// What every master machine has: its exchange, its events and whether it finished.
#[derive(Debug, Clone)]
pub(crate) struct Io<T, P = Infallible> {
    pub(crate) ex: Exchange,
    pub(crate) events: Events<T, P>,
    pub(crate) finished: bool,
}

impl<T, P> Io<T, P> {
    pub(crate) const fn new() -> Self {
        Self {
            ex: Exchange::new(),
            events: Events::new(),
            finished: false,
        }
    }
}

/// A master machine's own logic: how it reacts to the end of each exchange (and to a timer of
/// its own). The one driver, the [`LssMachine`] implementation for every `Driven`, does the
/// rest: routing responses and timeouts through the [`Exchange`], transmitting, events.
pub(crate) trait Driven {
    /// What the machine produces.
    type Output;

    /// What it reports as it goes.
    type Progress;

    fn io(&self) -> &Io<Self::Output, Self::Progress>;

    fn io_mut(&mut self) -> &mut Io<Self::Output, Self::Progress>;

    /// The awaited exchange ended.
    fn on_reply(&mut self, now: Instant, reply: Reply);

    /// A deadline of the machine's own besides the exchange's (a wait step).
    fn timer(&self) -> Option<Instant> {
        None
    }

    /// [`timer`](Self::timer) is due.
    fn on_timer(&mut self, _now: Instant) {}
}

/// The one driver: the [`LssMachine`] methods of every [`Driven`] machine.
pub(crate) fn handle_response<D: Driven>(d: &mut D, now: Instant, response: &Response) {
    if let Some(reply) = d.io_mut().ex.on_response(response) {
        d.on_reply(now, reply);
    }
}

pub(crate) fn handle_timeout<D: Driven>(d: &mut D, now: Instant) {
    if d.timer().is_some_and(|t| now >= t) {
        d.on_timer(now);
        return;
    }
    if let Some(reply) = d.io_mut().ex.on_timeout(now) {
        d.on_reply(now, reply);
    }
}

pub(crate) fn poll_timeout<D: Driven>(d: &D) -> Option<Instant> {
    d.timer().or(d.io().ex.poll_timeout())
}

/// Implements [`LssMachine`] for a [`Driven`] machine with output type `$out` through the one
/// driver above (a blanket implementation would expose the crate-private trait).
macro_rules! driven_machine {
    ($machine:ty, $out:ty) => {
        $crate::machine::driven_machine!($machine, $out, core::convert::Infallible);
    };
    ($machine:ty, $out:ty, $progress:ty) => {
        impl $crate::machine::LssMachine for $machine {
            type Output = $out;
            type Progress = $progress;

            fn handle_response(&mut self, now: Instant, response: &$crate::wire::Response) {
                $crate::machine::handle_response(self, now, response);
            }

            fn handle_timeout(&mut self, now: Instant) {
                $crate::machine::handle_timeout(self, now);
            }

            fn poll_transmit(&mut self) -> Option<$crate::wire::Request> {
                self.io.ex.poll_transmit()
            }

            fn poll_timeout(&self) -> Option<Instant> {
                $crate::machine::poll_timeout(self)
            }

            fn poll_event(&mut self) -> Option<$crate::machine::MasterEvent<$out, $progress>> {
                self.io.events.poll()
            }

            fn is_finished(&self) -> bool {
                self.io.finished
            }
        }
    };
}
pub(crate) use driven_machine;

/// Progress events (oldest dropped when nobody polls) and the final result.
#[derive(Debug, Clone)]
pub(crate) struct Events<T, P = Infallible> {
    queue: Deque<MasterEvent<T, P>, 4>,
    done: Option<Result<T, LssError>>,
}

impl<T, P> Events<T, P> {
    pub(crate) const fn new() -> Self {
        Self {
            queue: Deque::new(),
            done: None,
        }
    }

    pub(crate) fn clear(&mut self) {
        self.queue.clear();
        self.done = None;
    }

    /// A progress event; drops the oldest one when the queue is full.
    pub(crate) fn push(&mut self, event: MasterEvent<T, P>) {
        if self.queue.is_full() {
            let _ = self.queue.pop_front();
        }
        let _ = self.queue.push_back(event);
    }

    pub(crate) fn finish(&mut self, result: Result<T, LssError>) {
        self.done = Some(result);
    }

    pub(crate) fn poll(&mut self) -> Option<MasterEvent<T, P>> {
        self.queue
            .pop_front()
            .or_else(|| self.done.take().map(MasterEvent::Done))
    }
}

/// How an awaited exchange ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Reply {
    /// At least one matching response.
    Answer(Response),
    /// Two answers in a window that asked for one answerer ([`Exchange::ask_one`]): the first
    /// and the second (equal or not), so several slaves answered.
    Several(Response, Response),
    /// The response window closed without a matching response.
    Silence,
}

#[derive(Debug, Clone, Copy)]
struct Wait {
    cs: u8,
    deadline: Instant,
    collect: bool,
    /// Report a second answer ([`Reply::Several`]) instead of ignoring it.
    one: bool,
    got: Option<Response>,
    second: Option<Response>,
}

/// At most this many requests are queued at once (switch selective is 4, an identify probe 6).
const QUEUE: usize = 16;

/// Queued requests plus at most one awaited response.
#[derive(Debug, Clone)]
pub(crate) struct Exchange {
    queue: Deque<Request, QUEUE>,
    wait: Option<Wait>,
}

impl Exchange {
    pub(crate) const fn new() -> Self {
        Self {
            queue: Deque::new(),
            wait: None,
        }
    }

    /// Queues a request that has no answer.
    pub(crate) fn send(&mut self, req: Request) {
        // The machines never queue more than a handful of requests between two polls; a full
        // queue would be a bug in this crate, not something bus input can cause.
        let pushed = self.queue.push_back(req);
        debug_assert!(pushed.is_ok(), "LSS request queue overflow");
    }

    /// Queues `req` and awaits a response with command specifier `cs` until `now + timeout`.
    /// `collect`: keep the window open after the first answer.
    pub(crate) fn ask(
        &mut self,
        now: Instant,
        req: Request,
        cs: u8,
        timeout: Duration,
        collect: bool,
    ) {
        self.send(req);
        self.wait = Some(Wait {
            cs,
            deadline: now + timeout,
            collect,
            one: false,
            got: None,
            second: None,
        });
    }

    /// Queues `req` and awaits exactly one answerer: the whole window is waited out, and a
    /// second answer makes the reply [`Reply::Several`].
    pub(crate) fn ask_one(&mut self, now: Instant, req: Request, cs: u8, timeout: Duration) {
        self.ask(now, req, cs, timeout, true);
        if let Some(w) = self.wait.as_mut() {
            w.one = true;
        }
    }

    pub(crate) fn poll_transmit(&mut self) -> Option<Request> {
        self.queue.pop_front()
    }

    pub(crate) fn poll_timeout(&self) -> Option<Instant> {
        self.wait.as_ref().map(|w| w.deadline)
    }

    #[cfg(test)]
    pub(crate) fn is_waiting(&self) -> bool {
        self.wait.is_some()
    }

    pub(crate) fn clear(&mut self) {
        self.queue.clear();
        self.wait = None;
    }

    /// A response arrived. Returns the reply when the exchange is over.
    pub(crate) fn on_response(&mut self, resp: &Response) -> Option<Reply> {
        if !self.queue.is_empty() {
            // Our request is not on the bus yet: this answers an earlier one.
            return None;
        }
        let wait = self.wait.as_mut()?;
        if resp.cs() != wait.cs {
            return None;
        }
        if wait.collect {
            if wait.got.is_none() {
                wait.got = Some(*resp);
            } else if wait.second.is_none() {
                wait.second = Some(*resp);
            }
            None
        } else {
            self.wait = None;
            Some(Reply::Answer(*resp))
        }
    }

    /// Time passed. Returns the reply when the window closed.
    pub(crate) fn on_timeout(&mut self, now: Instant) -> Option<Reply> {
        let wait = self.wait?;
        if now < wait.deadline {
            return None;
        }
        self.wait = None;
        Some(match (wait.got, wait.second) {
            (Some(a), Some(b)) if wait.one => Reply::Several(a, b),
            (Some(r), _) => Reply::Answer(r),
            (None, _) => Reply::Silence,
        })
    }
}

/// The error for a closed window without an answer.
pub(crate) fn timeout(service: Service, timeout: Duration) -> LssError {
    LssError::Timeout { service, timeout }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::{Mode, cs};

    #[test]
    fn stale_answers_are_ignored_until_the_request_left() {
        let mut ex = Exchange::new();
        let t0 = Instant::from_millis(10);
        ex.ask(
            t0,
            Request::StoreConfiguration,
            cs::STORE_CONFIGURATION,
            Duration::from_millis(5),
            false,
        );
        let ok = Response::StoreConfiguration(crate::wire::ConfigStatus::OK);
        assert_eq!(ex.on_response(&ok), None, "request still queued");
        assert_eq!(ex.poll_transmit(), Some(Request::StoreConfiguration));
        assert_eq!(ex.on_response(&Response::IdentifySlave), None, "other cs");
        assert_eq!(ex.on_response(&ok), Some(Reply::Answer(ok)));
        assert!(!ex.is_waiting());
        assert_eq!(ex.on_response(&ok), None, "duplicate after the end");
    }

    #[test]
    fn a_window_for_one_answerer_reports_a_second_answer() {
        let t0 = Instant::from_millis(0);
        let req = Request::InquireIdentity(crate::address::AddressPart::Serial);
        let a = Response::InquireIdentity(crate::address::AddressPart::Serial, 1);
        let b = Response::InquireIdentity(crate::address::AddressPart::Serial, 2);
        for (answers, want) in [
            (&[][..], Reply::Silence),
            (&[a][..], Reply::Answer(a)),
            (&[a, b][..], Reply::Several(a, b)),
            (&[a, a, b][..], Reply::Several(a, a)),
        ] {
            let mut ex = Exchange::new();
            ex.ask_one(t0, req, cs::INQUIRE_VENDOR + 3, Duration::from_millis(5));
            while ex.poll_transmit().is_some() {}
            for r in answers {
                assert_eq!(ex.on_response(r), None, "the window stays open");
            }
            assert_eq!(ex.on_timeout(Instant::from_millis(5)), Some(want));
        }
    }

    #[test]
    fn collecting_windows_close_on_time() {
        let mut ex = Exchange::new();
        let t0 = Instant::from_millis(0);
        ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        ex.ask(
            t0,
            Request::IdentifyNonConfigured,
            cs::IDENTIFY_NON_CONFIGURED_SLAVE,
            Duration::from_millis(5),
            true,
        );
        assert_eq!(ex.poll_timeout(), Some(Instant::from_millis(5)));
        while ex.poll_transmit().is_some() {}
        let r = Response::IdentifyNonConfiguredSlave;
        assert_eq!(ex.on_response(&r), None);
        assert_eq!(ex.on_response(&r), None);
        assert_eq!(ex.on_timeout(Instant::from_millis(4)), None);
        assert_eq!(
            ex.on_timeout(Instant::from_millis(5)),
            Some(Reply::Answer(r))
        );
        ex.ask(
            t0,
            Request::IdentifyNonConfigured,
            cs::IDENTIFY_NON_CONFIGURED_SLAVE,
            Duration::from_millis(5),
            true,
        );
        assert_eq!(ex.on_timeout(Instant::from_millis(6)), Some(Reply::Silence));
    }
}
