//! A simulated GEMÜ 1436 cPos behind the same cyclic image: parameters with their ranges and
//! diagnostic codes, the error list, active errors and warnings, actions running through their
//! phases over (virtual) time, and a simple valve model.
//!
//! Call order: [`SimulatedCpos::handle_master_image`] once per bus cycle (the simulator publishes
//! at most one new channel per cycle, so queued change notices are not lost), then
//! [`SimulatedCpos::device_image`] and [`SimulatedCpos::poll_diagnostic`];
//! [`SimulatedCpos::handle_timeout`] when [`SimulatedCpos::poll_timeout`] has passed.
//!
//! Behaviour where the manual is silent (the simulator's policy, documented so tests can rely on
//! it):
//! - The device processes a request when the master's channel changes. Answers echo toggle,
//!   instruction and id.
//! - 'S' on a read-only parameter answers the unchanged value without a diagnostic; out of range
//!   raises 0x20/0x21 and answers the unchanged value; an unknown ID raises 0x22 and answers 0.
//! - 'E' position 0 on an empty list answers 0 ("no error"); any other missing position answers
//!   0xFFFFFFFF and raises 0x34. 'D'/'W' for a number above the count answer code 0.
//! - The error list holds [`ERROR_LIST_LEN`] entries (the manual gives no size), newest at 0.
//! - Only one action runs at a time; a request for another action answers the 0xFF answer
//!   (source, number) and raises 0x40. A request for the running fieldbus action controls it
//!   (cancel, acknowledge, adopt, other NoInit motions). 'Q' ends fieldbus-started actions only.
//! - NoInit on an initialised valve raises 0x42 and answers "end event" (the manual does not give
//!   the answer). Init valve, find function, GoClose and GoOpen "cannot be started" while the air
//!   supply is missing; adjust time, find coefficient and init pilot also need an initialised
//!   valve. Control functions without a running action answer the action's "inactive" status
//!   (GoClose/GoOpen, which have none, answer "cannot be started").
//! - Each phase of a long action lasts [`SimConfig::phase`]; an injected fault
//!   ([`SimulatedCpos::inject_fault`]) turns a phase into "error xx active", adds the error to the
//!   error list and the active errors, and waits for "acknowledge error" (then "acknowledged",
//!   the action ends and the active error clears) or cancel.
//! - Parameters that change without an 'S' (adjTimeClose/adjTimeOpen measured by init valve and
//!   adjust time, [`SimulatedCpos::set_local`]) are published as `[toggle, 'G', id, value]`, the
//!   toggle being the last request's.
//! - Defaults are the simulator's own (the manual only gives DeviceNet address 63): the minimum of
//!   each range except those set in [`SimulatedCpos::new`].
//! - Set default reloads the parameter defaults and keeps the initialisation.

use crate::action::{
    ActionId, ActionRequest, ActionStatus, ErrorCode, FindCoefficientStatus, FindFunctionFunction,
    GoFunction, InitValveStatus, NoInitFunction, Phase, RunFunction,
};
use crate::channel::{
    ActionBusy, ActionSource, ActiveList, Answer, Channel, DiagnosticCode, ErrorEntry, Request,
};
use crate::image::{DeviceImage, DigitalOutputs, MasterImage, PerMille};
use crate::params::{Access, PARAMETERS, ParamId};
use canola_frame::{Duration, Instant};
use heapless::{Deque, Vec};

/// Entries the simulated error list keeps.
pub const ERROR_LIST_LEN: usize = 10;
const MAX_PARAMS: usize = 128;
const MOTION_TICK: Duration = Duration::from_millis(50);

/// Simulator timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimConfig {
    /// Duration of each phase of a long action.
    pub phase: Duration,
    /// Measured opening/closing time written to adjTimeClose/adjTimeOpen (0.1 s units).
    pub measured_time: i32,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            phase: Duration::from_secs(2),
            measured_time: 23,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Running {
    action: ActionId,
    source: ActionSource,
    status: ActionStatus,
    step: u8,
    next: Option<Instant>,
}

/// The simulated positioner.
#[derive(Debug)]
pub struct SimulatedCpos {
    config: SimConfig,
    values: [i32; MAX_PARAMS],
    initialised: bool,
    air: bool,
    position: i32,
    target: i32,
    speed: i32,
    set_value: PerMille,
    last_master: Option<Channel>,
    request: Channel,
    answer: Channel,
    shown: Channel,
    answer_published: bool,
    notices: Deque<Channel, 8>,
    diagnostics: Deque<DiagnosticCode, 8>,
    error_list: Deque<ErrorCode, ERROR_LIST_LEN>,
    errors: Vec<ErrorCode, 8>,
    warnings: Vec<ErrorCode, 8>,
    running: Option<Running>,
    fault: Option<(ActionId, u8, ErrorCode)>,
    refuse_done: bool,
    last_motion: Instant,
}

fn index_of(id: u16) -> Option<usize> {
    PARAMETERS.iter().position(|p| p.id.0 == id)
}

impl Default for SimulatedCpos {
    fn default() -> Self {
        Self::new(SimConfig::default())
    }
}

impl SimulatedCpos {
    /// A new, not yet initialised positioner with default parameters.
    pub fn new(config: SimConfig) -> Self {
        let mut s = Self {
            config,
            values: [0; MAX_PARAMS],
            initialised: false,
            air: true,
            position: 0,
            target: 0,
            speed: 0,
            set_value: PerMille::ZERO,
            last_master: None,
            request: Channel::default(),
            answer: Channel::default(),
            shown: Channel::default(),
            answer_published: true,
            notices: Deque::new(),
            diagnostics: Deque::new(),
            error_list: Deque::new(),
            errors: Vec::new(),
            warnings: Vec::new(),
            running: None,
            fault: None,
            refuse_done: false,
            last_motion: Instant::ZERO,
        };
        s.load_defaults();
        s
    }

    fn load_defaults(&mut self) {
        for (i, p) in PARAMETERS.iter().enumerate().take(MAX_PARAMS) {
            if let Some(v) = self.values.get_mut(i) {
                *v = p.min;
            }
        }
        let defaults: [(ParamId, i32); 19] = [
            (ParamId::MODE, 1),
            (ParamId::POT_MAX, 1000),
            (ParamId::MAX_POS, 1000),
            (ParamId::OUT_MAX_POS, 1000),
            (ParamId::OPEN_TIGHT, 1000),
            (ParamId::ALARM_MAX_K1, 998),
            (ParamId::ALARM_MAX_K2, 998),
            (ParamId::K1_FN, 11),
            (ParamId::K2_FN, 12),
            (ParamId::CAL_POINT_QTY, 3),
            (ParamId::DEVICENET_ADR, 63),
            (ParamId::W_10, 100),
            (ParamId::W_20, 200),
            (ParamId::W_30, 300),
            (ParamId::W_40, 400),
            (ParamId::W_50, 500),
            (ParamId::W_60, 600),
            (ParamId::W_70, 700),
            (ParamId::W_80, 800),
        ];
        for (id, v) in defaults
            .into_iter()
            .chain([(ParamId::W_90, 900), (ParamId::W_100, 1000)])
        {
            self.store(id.0, v);
        }
    }

    fn store(&mut self, id: u16, v: i32) {
        if let Some(slot) = index_of(id).and_then(|i| self.values.get_mut(i)) {
            *slot = v;
        }
    }

    /// A parameter's current value (live values for Pos X, PosW and Pot Abs).
    pub fn value(&self, id: ParamId) -> Option<i32> {
        match id {
            ParamId::POS_X | ParamId::POT_ABS => return Some(self.position),
            ParamId::POS_W => return Some(self.set_value.get() as i32),
            _ => {}
        }
        index_of(id.0).and_then(|i| self.values.get(i).copied())
    }

    /// Whether the valve has been initialised.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// Marks the valve initialised (or not) without running init valve.
    pub fn set_initialised(&mut self, yes: bool) {
        self.initialised = yes;
    }

    /// The running action and who started it.
    pub fn running_action(&self) -> Option<(ActionId, ActionSource, ActionStatus)> {
        self.running.map(|r| (r.action, r.source, r.status))
    }

    /// The error list, newest first.
    pub fn error_list(&self) -> impl Iterator<Item = ErrorCode> + '_ {
        self.error_list.iter().copied()
    }

    /// Changes a parameter on the device itself (keypad, web): the change is published to the
    /// master as an unsolicited 'G'.
    pub fn set_local(&mut self, id: ParamId, value: i32) {
        self.store(id.0, value);
        self.notify(id.0, value);
    }

    fn notify(&mut self, id: u16, value: i32) {
        let n = Answer::Get {
            id,
            value: value as u32,
        }
        .to_channel(self.request.toggle);
        if self.notices.is_full() {
            self.notices.pop_front();
        }
        let _ = self.notices.push_back(n);
    }

    /// Records an error: newest first in the error list (the oldest is dropped when full) and
    /// active until cleared.
    pub fn raise_error(&mut self, code: ErrorCode) {
        if self.error_list.is_full() {
            self.error_list.pop_back();
        }
        let _ = self.error_list.push_front(code);
        if !self.errors.contains(&code) {
            let _ = self.errors.push(code);
        }
    }

    /// Clears an active error (the error list keeps it).
    pub fn clear_error(&mut self, code: ErrorCode) {
        self.errors.retain(|c| *c != code);
    }

    /// Raises a warning.
    pub fn raise_warning(&mut self, code: ErrorCode) {
        if !self.warnings.contains(&code) {
            let _ = self.warnings.push(code);
        }
    }

    /// Clears a warning.
    pub fn clear_warning(&mut self, code: ErrorCode) {
        self.warnings.retain(|c| *c != code);
    }

    /// Cuts or restores the compressed air: cutting it raises the "030 Air missing" warning and
    /// error-list entry; motion actions cannot be started without air.
    pub fn set_air_supply(&mut self, present: bool) {
        if self.air && !present {
            self.raise_warning(ErrorCode::AIR_MISSING);
            if self.error_list.is_full() {
                self.error_list.pop_back();
            }
            let _ = self.error_list.push_front(ErrorCode::AIR_MISSING);
        } else if present {
            self.clear_warning(ErrorCode::AIR_MISSING);
        }
        self.air = present;
    }

    /// Makes the next run of `action` fail with `code` when it enters its phase number `step`
    /// (counted from 1: init valve 1..=6 as its status codes; find function 1..=2; adjust time
    /// 1..=3; find coefficient: the calibration point; init pilot 1).
    pub fn inject_fault(&mut self, action: ActionId, step: u8, code: ErrorCode) {
        self.fault = Some((action, step, code));
    }

    /// Makes clear error list / set default answer "not cleared / not loaded (action remains
    /// active)".
    pub fn refuse_clear_and_default(&mut self, refuse: bool) {
        self.refuse_done = refuse;
    }

    /// Starts an action as if from the keypad or web interface (it cannot be quit with 'Q').
    pub fn start_local_action(
        &mut self,
        now: Instant,
        request: ActionRequest,
        source: ActionSource,
    ) {
        if self.running.is_none() {
            let st = self.start(now, request);
            if let Some(r) = &mut self.running {
                r.source = source;
            }
            let _ = st;
        }
    }

    /// Ends whatever action runs (the operator acknowledged it on the device).
    pub fn end_local_action(&mut self) {
        self.running = None;
        self.target = self.position;
    }

    /// The device→master image.
    pub fn device_image(&self) -> DeviceImage {
        DeviceImage {
            position: PerMille::new(self.position.clamp(0, 1000) as u16).unwrap_or(PerMille::ZERO),
            outputs: self.outputs(),
            channel: self.shown,
        }
    }

    /// The next external diagnostic the device raised.
    #[must_use]
    pub fn poll_diagnostic(&mut self) -> Option<DiagnosticCode> {
        self.diagnostics.pop_front()
    }

    /// When [`SimulatedCpos::handle_timeout`] wants to run next.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        let phase = self.running.and_then(|r| r.next);
        let motion = (self.position != self.target).then(|| self.last_motion + MOTION_TICK);
        match (phase, motion) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn outputs(&self) -> DigitalOutputs {
        let f = |fn_id: ParamId, min_id: ParamId, max_id: ParamId| {
            let min = self.value(min_id).unwrap_or(0);
            let max = self.value(max_id).unwrap_or(1000);
            let x = self.position;
            let w = self.set_value.get() as i32;
            match self.value(fn_id).unwrap_or(0) {
                4 => w < min,
                5 => w > max,
                6 => w < min || w > max,
                7 => x < min,
                8 => x > max,
                9 => x < min || x > max,
                10 => self.running.is_some(),
                11 => !self.errors.is_empty(),
                12 => !self.warnings.is_empty(),
                _ => false,
            }
        };
        DigitalOutputs {
            k1: f(ParamId::K1_FN, ParamId::ALARM_MIN_K1, ParamId::ALARM_MAX_K1),
            k2: f(ParamId::K2_FN, ParamId::ALARM_MIN_K2, ParamId::ALARM_MAX_K2),
        }
    }

    /// One bus cycle: takes the master's image, processes a changed request and publishes at most
    /// one new channel.
    pub fn handle_master_image(&mut self, now: Instant, image: &MasterImage) {
        self.advance(now);
        self.set_value = image.set_value;
        if self.running.is_none() && self.initialised && self.value(ParamId::MODE) == Some(1) {
            self.move_to(now, image.set_value.get() as i32, 500);
        }
        if self.last_master != Some(image.channel) {
            self.last_master = Some(image.channel);
            self.process(now, image.channel);
        }
        if !self.answer_published {
            self.shown = self.answer;
            self.answer_published = true;
        } else if let Some(n) = self.notices.pop_front() {
            self.shown = n;
        }
    }

    fn set_answer(&mut self, a: Answer) {
        self.answer = a.to_channel(self.request.toggle);
        self.answer_published = false;
    }

    fn diag(&mut self, d: DiagnosticCode) {
        if self.diagnostics.is_full() {
            self.diagnostics.pop_front();
        }
        let _ = self.diagnostics.push_back(d);
    }

    fn process(&mut self, now: Instant, ch: Channel) {
        let Some(req) = Request::from_channel(&ch) else {
            return;
        };
        self.request = ch;
        match req {
            Request::Nop => self.set_answer(Answer::Nop),
            Request::Set { id, value } => {
                let Some(def) = PARAMETERS.iter().find(|p| p.id.0 == id) else {
                    self.diag(DiagnosticCode::NO_SUCH_PARAMETER);
                    return self.set_answer(Answer::Set { id, value: 0 });
                };
                let v = value as i32;
                let current = self.value(def.id).unwrap_or(0);
                let stored = if def.access == Access::Read {
                    current
                } else if v < def.min {
                    self.diag(DiagnosticCode::BELOW_RANGE);
                    current
                } else if v > def.max {
                    self.diag(DiagnosticCode::ABOVE_RANGE);
                    current
                } else {
                    self.store(id, v);
                    v
                };
                self.set_answer(Answer::Set {
                    id,
                    value: stored as u32,
                });
            }
            Request::Get { id } => match self.value(ParamId(id)) {
                Some(v) => self.set_answer(Answer::Get {
                    id,
                    value: v as u32,
                }),
                None => {
                    self.diag(DiagnosticCode::NO_SUCH_PARAMETER);
                    self.set_answer(Answer::Get { id, value: 0 });
                }
            },
            Request::ErrorList { position } => {
                let entry = match self.error_list.iter().nth(position as usize) {
                    Some(c) => ErrorEntry::Entry(*c),
                    None if position == 0 => ErrorEntry::Entry(ErrorCode::NONE),
                    None => {
                        self.diag(DiagnosticCode::NO_SUCH_ERROR_ENTRY);
                        ErrorEntry::NoEntry
                    }
                };
                self.set_answer(Answer::ErrorList { position, entry });
            }
            Request::ActiveErrors { number } => {
                let list = Self::active(&self.errors, number);
                self.set_answer(Answer::ActiveErrors { number, list });
            }
            Request::ActiveWarnings { number } => {
                let list = Self::active(&self.warnings, number);
                self.set_answer(Answer::ActiveWarnings { number, list });
            }
            Request::Action { action, value } => {
                let request = ActionRequest::from_parts(action, value);
                let status = match self.running {
                    Some(r) if r.action == action && r.source == ActionSource::Fieldbus => {
                        self.control(now, request)
                    }
                    Some(r) => {
                        self.diag(DiagnosticCode::ACTION_ALREADY_ACTIVE);
                        let busy = ActionBusy {
                            source: r.source,
                            active: r.action,
                        };
                        return self.set_answer(Answer::ActionBusy { action, busy });
                    }
                    None => self.start(now, request),
                };
                self.set_answer(Answer::Action { action, status });
            }
            Request::Quit => {
                if matches!(self.running, Some(r) if r.source == ActionSource::Fieldbus) {
                    self.end_local_action();
                }
                self.set_answer(Answer::Quit);
            }
        }
    }

    fn active(list: &[ErrorCode], number: u16) -> ActiveList {
        let code = (number as usize)
            .checked_sub(1)
            .and_then(|i| list.get(i).copied())
            .unwrap_or(ErrorCode::NONE);
        ActiveList {
            count: list.len() as u16,
            code,
        }
    }

    fn move_to(&mut self, now: Instant, target: i32, speed: i32) {
        if self.position == self.target {
            self.last_motion = now;
        }
        self.target = target.clamp(0, 1000);
        self.speed = speed;
    }

    fn run(
        &mut self,
        now: Instant,
        action: ActionId,
        status: ActionStatus,
        phased: bool,
    ) -> ActionStatus {
        self.running = Some(Running {
            action,
            source: ActionSource::Fieldbus,
            status,
            step: 1,
            next: phased.then(|| now + self.config.phase),
        });
        self.enter(now);
        self.running.map(|r| r.status).unwrap_or(status)
    }

    /// Starts an action from idle; returns the first status.
    fn start(&mut self, now: Instant, request: ActionRequest) -> ActionStatus {
        use ActionRequest as R;
        let cannot = |a: ActionId| ActionStatus::decode(a, 0x0100_0000);
        let needs_init = |a: ActionId| {
            matches!(
                a,
                ActionId::AdjustTime | ActionId::FindCoefficient | ActionId::InitPilot
            )
        };
        let action = request.action();
        match request {
            R::NoInit(f) => {
                if self.initialised {
                    self.diag(DiagnosticCode::NOINIT_ON_INITIALISED_VALVE);
                    return ActionStatus::NoInit(NoInitFunction::EndEvent);
                }
                if f == NoInitFunction::EndEvent {
                    return ActionStatus::NoInit(f);
                }
                let st = self.run(now, action, ActionStatus::NoInit(f), false);
                self.noinit_motion(now, f);
                st
            }
            R::ClearErrorList | R::SetDefault => {
                if self.refuse_done {
                    let st = ActionStatus::decode(action, 2);
                    return self.run(now, action, st, false);
                }
                if request == R::ClearErrorList {
                    self.error_list.clear();
                } else {
                    self.load_defaults();
                }
                ActionStatus::decode(action, 1)
            }
            R::InitValve(RunFunction::Start)
            | R::GoClose(GoFunction::Approach)
            | R::GoOpen(GoFunction::Approach)
            | R::FindFunction(FindFunctionFunction::Activate)
            | R::AdjustTime(RunFunction::Start)
            | R::FindCoefficient(RunFunction::Start)
            | R::InitPilot(RunFunction::Start) => {
                if !self.air || (needs_init(action) && !self.initialised) {
                    return cannot(action);
                }
                let first = match action {
                    ActionId::InitValve => 1,
                    ActionId::GoClose | ActionId::GoOpen => 1,
                    _ => 2,
                };
                let phased = !matches!(action, ActionId::GoClose | ActionId::GoOpen);
                self.run(now, action, ActionStatus::decode(action, first), phased)
            }
            R::GoClose(_) | R::GoOpen(_) => cannot(action),
            R::InitValve(_) => ActionStatus::InitValve(InitValveStatus::Inactive),
            R::FindFunction(_) | R::AdjustTime(_) | R::FindCoefficient(_) | R::InitPilot(_) => {
                ActionStatus::decode(action, 1)
            }
            R::Raw { action, .. } => cannot(action),
        }
    }

    fn noinit_motion(&mut self, now: Instant, f: NoInitFunction) {
        match f {
            NoInitFunction::OpenSlow => self.move_to(now, 1000, 100),
            NoInitFunction::OpenFast => self.move_to(now, 1000, 500),
            NoInitFunction::CloseSlow => self.move_to(now, 0, 100),
            NoInitFunction::CloseFast => self.move_to(now, 0, 500),
            NoInitFunction::OpenPwm(p) => self.move_to(now, 1000, (p.get() as i32 / 2).max(1)),
            NoInitFunction::ClosePwm(p) => self.move_to(now, 0, (p.get() as i32 / 2).max(1)),
            NoInitFunction::Stop | NoInitFunction::EndEvent => self.target = self.position,
        }
    }

    /// A request for the running fieldbus action.
    fn control(&mut self, now: Instant, request: ActionRequest) -> ActionStatus {
        use ActionRequest as R;
        let Some(r) = self.running else {
            return self.start(now, request);
        };
        let action = r.action;
        let waiting = matches!(r.status.phase(), Phase::WaitingForAcknowledge(_));
        let end = |s: &mut Self, st: ActionStatus| {
            s.running = None;
            s.target = s.position;
            st
        };
        match request {
            R::NoInit(NoInitFunction::EndEvent) => {
                end(self, ActionStatus::NoInit(NoInitFunction::EndEvent))
            }
            R::NoInit(f) => {
                self.noinit_motion(now, f);
                self.set_status(ActionStatus::NoInit(f));
                ActionStatus::NoInit(f)
            }
            R::ClearErrorList | R::SetDefault => r.status,
            R::GoClose(GoFunction::Adopt) | R::GoOpen(GoFunction::Adopt) => {
                end(self, ActionStatus::decode(action, 2))
            }
            R::GoClose(GoFunction::Cancel) | R::GoOpen(GoFunction::Cancel) => {
                end(self, ActionStatus::decode(action, 3))
            }
            R::InitValve(RunFunction::Cancel) => {
                end(self, ActionStatus::InitValve(InitValveStatus::Inactive))
            }
            R::FindFunction(FindFunctionFunction::Cancel)
            | R::AdjustTime(RunFunction::Cancel)
            | R::FindCoefficient(RunFunction::Cancel)
            | R::InitPilot(RunFunction::Cancel) => end(self, ActionStatus::decode(action, 1)),
            R::InitValve(RunFunction::AcknowledgeError)
            | R::AdjustTime(RunFunction::AcknowledgeError)
            | R::FindCoefficient(RunFunction::AcknowledgeError)
            | R::InitPilot(RunFunction::AcknowledgeError)
                if waiting =>
            {
                let code = match r.status.phase() {
                    Phase::WaitingForAcknowledge(c) => c,
                    _ => ErrorCode::NONE,
                };
                self.clear_error(code);
                end(
                    self,
                    ActionStatus::decode(action, (code.0 as u32 & 0xFF) << 8 | 0xFF),
                )
            }
            _ => r.status,
        }
    }

    fn set_status(&mut self, status: ActionStatus) {
        let Some(r) = &mut self.running else { return };
        r.status = status;
        let action = r.action;
        if self.request.instruction == crate::channel::Instruction::Action
            && self.request.id == action.to_u16()
            && r.source == ActionSource::Fieldbus
        {
            self.set_answer(Answer::Action { action, status });
        }
    }

    /// Applies the current step of the running action (status, motion, faults).
    fn enter(&mut self, now: Instant) {
        let Some(r) = self.running else { return };
        if let Some((a, step, code)) = self.fault
            && a == r.action
            && step == r.step
        {
            self.fault = None;
            self.raise_error(code);
            if let Some(r) = &mut self.running {
                r.next = None;
            }
            let v = (code.0 as u32 & 0xFF) << 8 | 0xFE;
            self.set_status(ActionStatus::decode(r.action, v));
            return;
        }
        let status = match r.action {
            ActionId::InitValve => {
                match r.step {
                    1 => self.move_to(now, 0, 500),
                    2 => self.move_to(now, 1000, 500),
                    4 => self.move_to(now, 0, 500),
                    _ => {}
                }
                ActionStatus::decode(r.action, r.step as u32)
            }
            ActionId::GoClose => {
                self.move_to(now, 0, 300);
                r.status
            }
            ActionId::GoOpen => {
                self.move_to(now, 1000, 300);
                r.status
            }
            ActionId::FindFunction | ActionId::AdjustTime | ActionId::InitPilot => {
                if r.step == 2 && r.action == ActionId::AdjustTime {
                    self.move_to(now, 1000, 500);
                }
                ActionStatus::decode(r.action, r.step as u32 + 1)
            }
            ActionId::FindCoefficient => {
                ActionStatus::FindCoefficient(FindCoefficientStatus::ApproachPoint(r.step))
            }
            _ => r.status,
        };
        self.set_status(status);
    }

    /// Moves the valve and the running action on to `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.advance(now);
    }

    fn advance(&mut self, now: Instant) {
        // Valve motion.
        if self.position != self.target && now > self.last_motion {
            let dt = now.saturating_duration_since(self.last_motion).as_millis() as i64;
            let step = (self.speed as i64 * dt / 1000).max(1) as i32;
            let d = self.target - self.position;
            self.position += d.signum() * step.min(d.abs());
            self.last_motion = now;
        } else if self.position == self.target {
            self.last_motion = now;
        }
        // Action phases (a loop, because a long gap may cover several phases).
        for _ in 0..16 {
            let Some(r) = self.running else { return };
            let Some(next) = r.next else { return };
            if now < next {
                return;
            }
            let last = match r.action {
                ActionId::InitValve => 6,
                ActionId::FindFunction => 2,
                ActionId::AdjustTime => 3,
                ActionId::FindCoefficient => {
                    self.value(ParamId::CAL_POINT_QTY).unwrap_or(1).clamp(1, 9) as u8
                }
                ActionId::InitPilot => 1,
                _ => 0,
            };
            if r.step >= last {
                self.finish(next);
            } else if let Some(run) = &mut self.running {
                run.step += 1;
                run.next = Some(next + self.config.phase);
                self.enter(next);
            }
        }
    }

    fn finish(&mut self, _now: Instant) {
        let Some(r) = self.running else { return };
        let t = self.config.measured_time;
        match r.action {
            ActionId::InitValve => {
                self.initialised = true;
                self.set_local(ParamId::ADJ_TIME_CLOSE, t);
                self.set_local(ParamId::ADJ_TIME_OPEN, t + 2);
            }
            ActionId::AdjustTime => {
                self.set_local(ParamId::ADJ_TIME_CLOSE, t + 1);
                self.set_local(ParamId::ADJ_TIME_OPEN, t + 3);
            }
            _ => {}
        }
        let inactive = if r.action == ActionId::InitValve {
            0
        } else {
            1
        };
        self.set_status(ActionStatus::decode(r.action, inactive));
        self.running = None;
        self.target = self.position;
    }
}
