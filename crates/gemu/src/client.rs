//! A sans-IO client for the cPos parameter channel (manual 5.6).
//!
//! The client owns the master→device image: the application sets the cyclic values
//! ([`Client::set_set_value`], ...) and queues channel requests ([`Client::get`], [`Client::set`],
//! [`Client::action`], ...); the client puts one request at a time into the channel, matches the
//! device's answer by toggle byte, instruction and id, and reports the outcome as an [`Event`].
//!
//! Call order (one bus cycle):
//! 1. [`Client::handle_diagnostic`] for every external diagnostic the carrier reported this cycle
//!    (they belong to the request in flight, so feed them before the image);
//! 2. [`Client::handle_image`] with the device→master image;
//! 3. [`Client::handle_timeout`] when `now` has reached [`Client::poll_timeout`];
//! 4. drain [`Client::poll_event`], then send [`Client::image`] (or whatever
//!    [`Client::poll_transmit`] returned, which is the same image when it changed).
//!
//! Behaviour:
//! - Every new request gets a new toggle byte, so repeating an identical request is processed
//!   again by the device.
//! - After an 'E', 'D' or 'W' answer the client sends 'N' so the query is processed once.
//! - Only one action may be active. Starting a second one while the client knows of an active
//!   (or queued) action is refused locally with [`ClientError::ActionAlreadyActive`]; the device's
//!   own refusal (the 0xFF answer) is reported as [`Refusal::ActionAlreadyActive`].
//! - While an action is active the channel keeps its 'A' request so the device's status stays
//!   visible; every status change is an [`Event::ActionProgress`] and the end an
//!   [`Event::ActionEnded`]. Meanwhile only requests for the same action (cancel, acknowledge,
//!   adopt, other NoInit motions) and 'Q' are sent; other requests wait in the queue.
//! - A 'G' or 'S' in the channel that answers nothing in flight is an unsolicited parameter change
//!   notice ("if the parameter value changes, it is sent to the master immediately"):
//!   [`Event::ParameterChanged`].
//! - A request whose answer does not appear within [`ClientConfig::response_timeout`] fails with
//!   [`Failure::Timeout`]; an action whose status does not change within
//!   [`ClientConfig::action_timeout`] ends with [`ActionOutcome::TimedOut`].

use crate::action::{ActionId, ActionRequest, ActionStatus, Phase};
use crate::channel::{
    ActionBusy, Answer, Channel, DiagnosticCode, ErrorEntry, Instruction, Request,
};
use crate::image::{DeviceImage, DigitalInputs, DigitalOutputs, MasterImage, PerMille};
use crate::params::{ParamId, RangeError};
use canola_frame::{Duration, Instant};
use heapless::Deque;

/// Queue length of pending requests.
pub const QUEUE_LEN: usize = 16;
/// Capacity of the event queue; the oldest event is dropped when it is full.
pub const EVENT_LEN: usize = 32;

/// Client timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// How long to wait for the answer to a request.
    pub response_timeout: Duration,
    /// How long an active action may keep the same status before it is given up.
    pub action_timeout: Duration,
}

impl Default for ClientConfig {
    fn default() -> Self {
        Self {
            response_timeout: Duration::from_secs(1),
            action_timeout: Duration::from_secs(120),
        }
    }
}

/// Identifies a queued request in its [`Event::Completed`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestId(pub u32);

/// A request refused by the client before anything was sent.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ClientError {
    /// The parameter is not in the table (use [`Client::set_raw`]/[`Client::get_raw`] to send it
    /// anyway).
    #[error("parameter 0x{0:04X} is not in the parameter table")]
    UnknownParameter(u16),
    /// The parameter is read-only.
    #[error("parameter 0x{:04X} is read-only", .0.0)]
    ReadOnly(ParamId),
    /// The value is outside the parameter's range.
    #[error("parameter 0x{:04X}: {error}", param.0)]
    OutOfRange {
        /// The parameter.
        param: ParamId,
        /// Which bound.
        error: RangeError,
    },
    /// Another action is active or queued; only one action may be active at a time.
    #[error("{active} is already active or queued; end it (or send 'Q') first")]
    ActionAlreadyActive {
        /// The action that is active or queued.
        active: ActionId,
    },
    /// The request queue is full.
    #[error("request queue is full")]
    QueueFull,
}

debug_as_display!(ClientError);

/// The device said no.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// An external diagnostic code (reported by the carrier, or implied by the answer: 0x34 for
    /// an 'E' answer of 0xFFFFFFFF).
    #[error("{0}")]
    Diagnostic(DiagnosticCode),
    /// The 0xFF answer: another action is active.
    #[error("another action is active: {} started via {}", .0.active, .0.source)]
    ActionAlreadyActive(ActionBusy),
    /// The status "action cannot be started".
    #[error("{0} cannot be started")]
    ActionCannotBeStarted(ActionId),
    /// The 'S' answer carries another value than requested and no diagnostic was reported.
    #[error("value {requested} not applied, the parameter is {actual}")]
    ValueNotApplied {
        /// What was sent.
        requested: i32,
        /// What the device answered.
        actual: i32,
    },
}

debug_as_display!(Refusal);

/// Why a request failed.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Failure {
    /// The device refused.
    #[error("refused: {0}")]
    Refused(Refusal),
    /// No answer within the response timeout.
    #[error("no answer within the response timeout")]
    Timeout,
}

debug_as_display!(Failure);

/// A successful answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// 'G' or 'S': the parameter's value (signed, two's complement).
    Value {
        /// The parameter.
        param: ParamId,
        /// Its value.
        value: i32,
    },
    /// 'E': the entry at `position` (code 0 = the list is empty).
    ErrorList {
        /// Position.
        position: u16,
        /// Entry.
        entry: ErrorEntry,
    },
    /// 'D': number of active errors and the selected one.
    ActiveErrors {
        /// Selected number.
        number: u16,
        /// Count of active errors.
        count: u16,
        /// Selected error's code.
        code: crate::action::ErrorCode,
    },
    /// 'W': number of active warnings and the selected one.
    ActiveWarnings {
        /// Selected number.
        number: u16,
        /// Count of active warnings.
        count: u16,
        /// Selected warning's code.
        code: crate::action::ErrorCode,
    },
    /// 'A': the device accepted the request; its first status.
    Action {
        /// The action.
        action: ActionId,
        /// Status.
        status: ActionStatus,
    },
    /// 'Q': all fieldbus actions quit.
    Quit,
}

/// How an action ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActionOutcome {
    /// The device reported an ending status (see [`ActionStatus::phase`]: ended, cancelled or
    /// ended after an acknowledged error).
    Ended(ActionStatus),
    /// Ended by 'Q'.
    Quit,
    /// The status did not change within the action timeout; the client stopped watching.
    TimedOut,
}

/// What the client reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// A request finished.
    Completed {
        /// The request.
        id: RequestId,
        /// Its result.
        result: Result<Reply, Failure>,
    },
    /// An action's status changed (including its first status).
    ActionProgress {
        /// The action.
        action: ActionId,
        /// The new status.
        status: ActionStatus,
    },
    /// An action the client watched has ended.
    ActionEnded {
        /// The action.
        action: ActionId,
        /// How.
        outcome: ActionOutcome,
    },
    /// An unsolicited change notice: the device reported a parameter's new value.
    ParameterChanged {
        /// The parameter.
        param: ParamId,
        /// Its new value.
        value: i32,
    },
    /// Valve position or outputs changed.
    ProcessData {
        /// Valve position.
        position: PerMille,
        /// Outputs K1, K2.
        outputs: DigitalOutputs,
    },
    /// A diagnostic that no request in flight can take.
    Diagnostic(DiagnosticCode),
    /// A channel change the client cannot attribute (e.g. a late answer after a timeout).
    UnmatchedAnswer(Channel),
}

#[derive(Debug, Clone, Copy)]
struct Queued {
    id: Option<RequestId>,
    request: Request,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    id: Option<RequestId>,
    request: Request,
    channel: Channel,
    deadline: Instant,
    diagnostic: Option<DiagnosticCode>,
}

#[derive(Debug, Clone, Copy)]
struct Active {
    action: ActionId,
    channel: Channel,
    status: Option<ActionStatus>,
    deadline: Instant,
}

/// The client. See the module docs for the call order.
#[derive(Debug)]
pub struct Client {
    config: ClientConfig,
    image: MasterImage,
    dirty: bool,
    toggle: u8,
    next_id: u32,
    queue: Deque<Queued, QUEUE_LEN>,
    pending: Option<Pending>,
    active: Option<Active>,
    last_channel: Option<Channel>,
    last_process: Option<(PerMille, DigitalOutputs)>,
    events: Deque<Event, EVENT_LEN>,
}

fn same_request(a: &Channel, b: &Channel) -> bool {
    a.toggle == b.toggle && a.instruction == b.instruction && a.id == b.id
}

impl Client {
    /// A client with an all-zero image ('N' in the channel).
    pub fn new(config: ClientConfig) -> Self {
        Self {
            config,
            image: MasterImage::default(),
            dirty: true,
            toggle: 0,
            next_id: 0,
            queue: Deque::new(),
            pending: None,
            active: None,
            last_channel: None,
            last_process: None,
            events: Deque::new(),
        }
    }

    /// Sets the set value sent cyclically.
    pub fn set_set_value(&mut self, v: PerMille) {
        self.image.set_value = v;
        self.dirty = true;
    }

    /// Sets the actual value (process controller) sent cyclically.
    pub fn set_actual_value(&mut self, v: PerMille) {
        self.image.actual_value = v;
        self.dirty = true;
    }

    /// Sets the digital inputs sent cyclically.
    pub fn set_inputs(&mut self, v: DigitalInputs) {
        self.image.inputs = v;
        self.dirty = true;
    }

    /// The current master→device image (send it every cycle).
    pub fn image(&self) -> MasterImage {
        self.image
    }

    /// The image, if it changed since the last call.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<MasterImage> {
        core::mem::take(&mut self.dirty).then_some(self.image)
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// The next deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        let p = self.pending.map(|p| p.deadline);
        let a = self.active.map(|a| a.deadline);
        match (p, a) {
            (Some(p), Some(a)) => Some(p.min(a)),
            (p, a) => p.or(a),
        }
    }

    /// The action the client is watching, if any.
    pub fn active_action(&self) -> Option<ActionId> {
        self.active.map(|a| a.action)
    }

    /// Whether nothing is queued, in flight or active.
    pub fn is_idle(&self) -> bool {
        self.queue.is_empty() && self.pending.is_none() && self.active.is_none()
    }

    /// Queues 'G' for a parameter of the table.
    pub fn get(&mut self, now: Instant, param: ParamId) -> Result<RequestId, ClientError> {
        param.def().ok_or(ClientError::UnknownParameter(param.0))?;
        self.enqueue(now, Request::Get { id: param.0 })
    }

    /// Queues 'G' for any ID, without looking at the table.
    pub fn get_raw(&mut self, now: Instant, id: u16) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::Get { id })
    }

    /// Queues 'S' after checking the table: the parameter exists, is writable and `value` is in
    /// range. Nothing is sent otherwise.
    pub fn set(
        &mut self,
        now: Instant,
        param: ParamId,
        value: i32,
    ) -> Result<RequestId, ClientError> {
        let def = param.def().ok_or(ClientError::UnknownParameter(param.0))?;
        if !def.writable() {
            return Err(ClientError::ReadOnly(param));
        }
        def.check(value as i64)
            .map_err(|error| ClientError::OutOfRange { param, error })?;
        self.enqueue(
            now,
            Request::Set {
                id: param.0,
                value: value as u32,
            },
        )
    }

    /// Queues 'S' for any ID and value, without checks (the device reports 0x20/0x21/0x22).
    pub fn set_raw(&mut self, now: Instant, id: u16, value: u32) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::Set { id, value })
    }

    /// Queues 'E' for the error-list entry at `position` (0 = the current error).
    pub fn read_error_list(
        &mut self,
        now: Instant,
        position: u16,
    ) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::ErrorList { position })
    }

    /// Queues 'D' for active error `number` (the first is 1).
    pub fn active_errors(&mut self, now: Instant, number: u16) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::ActiveErrors { number })
    }

    /// Queues 'W' for active warning `number` (the first is 1).
    pub fn active_warnings(&mut self, now: Instant, number: u16) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::ActiveWarnings { number })
    }

    /// Queues an 'A' request. A request for another action than the active (or queued) one is
    /// refused locally.
    pub fn action(
        &mut self,
        now: Instant,
        request: ActionRequest,
    ) -> Result<RequestId, ClientError> {
        let action = request.action();
        if let Some(active) = self.busy_action()
            && active != action
        {
            return Err(ClientError::ActionAlreadyActive { active });
        }
        let (a, value) = request.to_parts();
        self.enqueue(now, Request::Action { action: a, value })
    }

    /// Queues 'Q': quit all actions started over the fieldbus.
    pub fn quit(&mut self, now: Instant) -> Result<RequestId, ClientError> {
        self.enqueue(now, Request::Quit)
    }

    /// The action that is active, in flight or queued, if any.
    fn busy_action(&self) -> Option<ActionId> {
        if let Some(a) = self.active {
            return Some(a.action);
        }
        let of = |r: &Request| match r {
            Request::Action { action, .. } => Some(*action),
            _ => None,
        };
        self.pending
            .as_ref()
            .and_then(|p| of(&p.request))
            .or_else(|| self.queue.iter().find_map(|q| of(&q.request)))
    }

    fn enqueue(&mut self, now: Instant, request: Request) -> Result<RequestId, ClientError> {
        let id = RequestId(self.next_id);
        // Requests for the active action and 'Q' go first: they are what ends the action.
        let urgent = match (request, self.active) {
            (Request::Quit, Some(_)) => true,
            (Request::Action { action, .. }, Some(a)) => action == a.action,
            _ => false,
        };
        let q = Queued {
            id: Some(id),
            request,
        };
        let r = if urgent {
            self.queue.push_front(q)
        } else {
            self.queue.push_back(q)
        };
        r.map_err(|_| ClientError::QueueFull)?;
        self.next_id = self.next_id.wrapping_add(1);
        self.dispatch(now);
        Ok(id)
    }

    fn push_event(&mut self, e: Event) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    /// Sends the next eligible request if nothing is in flight.
    fn dispatch(&mut self, now: Instant) {
        if self.pending.is_some() {
            return;
        }
        let eligible = |q: &Queued, active: &Option<Active>| match (active, q.request) {
            (None, _) => true,
            (Some(_), Request::Quit) => true,
            (Some(a), Request::Action { action, .. }) => action == a.action,
            (Some(_), _) => false,
        };
        let Some(pos) = self.queue.iter().position(|q| eligible(q, &self.active)) else {
            return;
        };
        // Rotate the chosen request to the front, keeping the others' order.
        let mut chosen = None;
        let n = self.queue.len();
        for i in 0..n {
            if let Some(q) = self.queue.pop_front() {
                if i == pos {
                    chosen = Some(q);
                } else {
                    let _ = self.queue.push_back(q);
                }
            }
        }
        let Some(q) = chosen else { return };
        self.toggle = self.toggle.wrapping_add(1);
        let channel = q.request.to_channel(self.toggle);
        self.image.channel = channel;
        self.dirty = true;
        self.pending = Some(Pending {
            id: q.id,
            request: q.request,
            channel,
            deadline: now + self.config.response_timeout,
            diagnostic: None,
        });
    }

    /// Feeds an external diagnostic code reported by the carrier.
    pub fn handle_diagnostic(&mut self, _now: Instant, code: DiagnosticCode) {
        match &mut self.pending {
            Some(p) if p.id.is_some() && p.diagnostic.is_none() => p.diagnostic = Some(code),
            _ => self.push_event(Event::Diagnostic(code)),
        }
    }

    /// Feeds the device→master image.
    pub fn handle_image(&mut self, now: Instant, image: &DeviceImage) {
        let process = (image.position, image.outputs);
        if self.last_process != Some(process) {
            self.last_process = Some(process);
            self.push_event(Event::ProcessData {
                position: image.position,
                outputs: image.outputs,
            });
        }
        if self.last_channel == Some(image.channel) {
            return;
        }
        self.last_channel = Some(image.channel);
        self.handle_channel(now, image.channel);
        self.dispatch(now);
    }

    /// Decodes and feeds raw device→master bytes.
    pub fn handle_bytes(
        &mut self,
        now: Instant,
        bytes: &[u8],
    ) -> Result<(), crate::image::ImageError> {
        let image = DeviceImage::parse(bytes)?;
        self.handle_image(now, &image);
        Ok(())
    }

    fn handle_channel(&mut self, now: Instant, ch: Channel) {
        if let Some(p) = self.pending
            && same_request(&p.channel, &ch)
        {
            self.pending = None;
            self.complete(now, p, ch);
            return;
        }
        if let Some(a) = self.active
            && same_request(&a.channel, &ch)
            && let Answer::Action { status, .. } = Answer::from_channel(&ch)
        {
            self.action_status(now, status);
            return;
        }
        match Answer::from_channel(&ch) {
            Answer::Get { id, value } | Answer::Set { id, value } => {
                self.push_event(Event::ParameterChanged {
                    param: ParamId(id),
                    value: value as i32,
                })
            }
            _ => self.push_event(Event::UnmatchedAnswer(ch)),
        }
    }

    fn finish(&mut self, id: Option<RequestId>, result: Result<Reply, Failure>) {
        if let Some(id) = id {
            self.push_event(Event::Completed { id, result });
        }
    }

    fn complete(&mut self, now: Instant, p: Pending, ch: Channel) {
        let refused = |r| Err(Failure::Refused(r));
        let diag = p.diagnostic.map(Refusal::Diagnostic);
        let answer = Answer::from_channel(&ch);
        let result = match (p.request, answer) {
            (Request::Nop, _) => return,
            (Request::Set { id, value }, Answer::Set { value: actual, .. }) => match diag {
                Some(d) => refused(d),
                None if actual == value => Ok(Reply::Value {
                    param: ParamId(id),
                    value: actual as i32,
                }),
                None => refused(Refusal::ValueNotApplied {
                    requested: value as i32,
                    actual: actual as i32,
                }),
            },
            (Request::Get { id }, Answer::Get { value, .. }) => match diag {
                Some(d) => refused(d),
                None => Ok(Reply::Value {
                    param: ParamId(id),
                    value: value as i32,
                }),
            },
            (Request::ErrorList { .. }, Answer::ErrorList { position, entry }) => {
                match (diag, entry) {
                    (Some(d), _) => refused(d),
                    (None, ErrorEntry::NoEntry) => {
                        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_ERROR_ENTRY))
                    }
                    (None, entry) => Ok(Reply::ErrorList { position, entry }),
                }
            }
            (Request::ActiveErrors { .. }, Answer::ActiveErrors { number, list }) => {
                Ok(Reply::ActiveErrors {
                    number,
                    count: list.count,
                    code: list.code,
                })
            }
            (Request::ActiveWarnings { .. }, Answer::ActiveWarnings { number, list }) => {
                Ok(Reply::ActiveWarnings {
                    number,
                    count: list.count,
                    code: list.code,
                })
            }
            (Request::Action { .. }, Answer::ActionBusy { busy, .. }) => {
                refused(Refusal::ActionAlreadyActive(busy))
            }
            (Request::Action { action, .. }, Answer::Action { status, .. }) => {
                if let Some(d) = diag {
                    refused(d)
                } else if status.phase() == Phase::CannotBeStarted {
                    refused(Refusal::ActionCannotBeStarted(action))
                } else {
                    self.finish(p.id, Ok(Reply::Action { action, status }));
                    let watching = matches!(self.active, Some(a) if a.action == action);
                    if !watching {
                        self.active = Some(Active {
                            action,
                            channel: ch,
                            status: None,
                            deadline: now + self.config.action_timeout,
                        });
                    } else if let Some(a) = &mut self.active {
                        a.channel = ch;
                    }
                    self.action_status(now, status);
                    return;
                }
            }
            (Request::Quit, Answer::Quit) => {
                if let Some(a) = self.active.take() {
                    self.push_event(Event::ActionEnded {
                        action: a.action,
                        outcome: ActionOutcome::Quit,
                    });
                }
                Ok(Reply::Quit)
            }
            // Same toggle, instruction and id but a shape that does not fit (e.g. an 'N'/'Q' with
            // data): report it and fail the request rather than guess.
            _ => {
                self.push_event(Event::UnmatchedAnswer(ch));
                Err(Failure::Timeout)
            }
        };
        self.finish(p.id, result);
        if p.request.instruction().needs_nop_after() {
            let _ = self.queue.push_front(Queued {
                id: None,
                request: Request::Nop,
            });
        }
    }

    fn action_status(&mut self, now: Instant, status: ActionStatus) {
        let Some(a) = &mut self.active else { return };
        if a.status == Some(status) {
            return;
        }
        a.status = Some(status);
        a.deadline = now + self.config.action_timeout;
        let action = a.action;
        self.push_event(Event::ActionProgress { action, status });
        match status.phase() {
            Phase::Ended | Phase::EndedWithError(_) | Phase::CannotBeStarted => {
                self.active = None;
                self.push_event(Event::ActionEnded {
                    action,
                    outcome: ActionOutcome::Ended(status),
                });
            }
            Phase::Running | Phase::WaitingForAcknowledge(_) | Phase::Unknown => {}
        }
    }

    /// Handles expired deadlines.
    pub fn handle_timeout(&mut self, now: Instant) {
        if let Some(p) = self.pending
            && now >= p.deadline
        {
            self.pending = None;
            self.finish(p.id, Err(Failure::Timeout));
        }
        if let Some(a) = self.active
            && now >= a.deadline
        {
            self.active = None;
            self.push_event(Event::ActionEnded {
                action: a.action,
                outcome: ActionOutcome::TimedOut,
            });
        }
        self.dispatch(now);
    }

    /// The instruction currently in the channel (for diagnostics and tests).
    pub fn channel_instruction(&self) -> Instruction {
        self.image.channel.instruction
    }
}
