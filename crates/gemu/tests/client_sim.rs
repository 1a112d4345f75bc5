//! The client against the simulated cPos on a virtual clock: every instruction and action path,
//! refusals and diagnostics.

use canola_frame::{Duration, Instant, is_due};
use canola_gemu::action::{
    ActionId, ActionRequest, ActionStatus, AdjustTimeStatus, DoneStatus, ErrorCode,
    FindCoefficientStatus, FindFunctionFunction, FindFunctionStatus, GoFunction, GoStatus,
    InitPilotStatus, InitValveStatus, NoInitFunction, Pwm, RunFunction,
};
use canola_gemu::channel::{
    ActionBusy, ActionSource, Channel, DiagnosticCode, ErrorEntry, Instruction,
};
use canola_gemu::client::{
    ActionOutcome, Client, ClientConfig, ClientError, Event, Failure, Refusal, Reply, RequestId,
};
use canola_gemu::image::PerMille;
use canola_gemu::params::{Mode, ParamId, RangeError};
use canola_gemu::sim::{SimConfig, SimulatedCpos};

const CYCLE: Duration = Duration::from_millis(10);

struct Bench {
    client: Client,
    sim: SimulatedCpos,
    now: Instant,
    events: Vec<Event>,
    sent: Vec<Channel>,
    answers: Vec<Channel>,
    connected: bool,
}

impl Bench {
    fn new() -> Self {
        Self::with(ClientConfig::default())
    }

    fn with(config: ClientConfig) -> Self {
        let mut b = Self {
            client: Client::new(config),
            sim: SimulatedCpos::new(SimConfig::default()),
            now: Instant::ZERO,
            events: Vec::new(),
            sent: Vec::new(),
            answers: Vec::new(),
            connected: true,
        };
        b.cycle();
        b
    }

    fn cycle(&mut self) {
        self.now += CYCLE;
        let now = self.now;
        if is_due(self.sim.poll_timeout(), now) {
            self.sim.handle_timeout(now);
        }
        let img = self.client.image();
        if self.sent.last() != Some(&img.channel) {
            self.sent.push(img.channel);
        }
        if self.connected {
            self.sim.handle_master_image(now, &img);
            while let Some(d) = self.sim.poll_diagnostic() {
                self.client.handle_diagnostic(now, d);
            }
            let dev = self.sim.device_image();
            if self.answers.last() != Some(&dev.channel) {
                self.answers.push(dev.channel);
            }
            // Through the byte codec, as a carrier would deliver it.
            self.client.handle_bytes(now, &dev.to_bytes()).unwrap();
        }
        if is_due(self.client.poll_timeout(), now) {
            self.client.handle_timeout(now);
        }
        while let Some(e) = self.client.poll_event() {
            self.events.push(e);
        }
    }

    fn result_of(&self, id: RequestId) -> Option<Result<Reply, Failure>> {
        self.events.iter().find_map(|e| match e {
            Event::Completed { id: i, result } if *i == id => Some(*result),
            _ => None,
        })
    }

    fn wait(&mut self, id: RequestId) -> Result<Reply, Failure> {
        for _ in 0..100_000 {
            if let Some(r) = self.result_of(id) {
                return r;
            }
            self.cycle();
        }
        panic!("request {id:?} never completed");
    }

    fn until_idle(&mut self) {
        for _ in 0..100_000 {
            if self.client.is_idle() && self.client.channel_instruction() != Instruction::Unknown(0)
            {
                // One more cycle so the last answer is seen.
                self.cycle();
                if self.client.is_idle() {
                    return;
                }
            }
            self.cycle();
        }
        panic!("client never idle");
    }

    fn run_for(&mut self, d: Duration) {
        let end = self.now + d;
        while self.now < end {
            self.cycle();
        }
    }

    fn progress(&self, action: ActionId) -> Vec<ActionStatus> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::ActionProgress { action: a, status } if *a == action => Some(*status),
                _ => None,
            })
            .collect()
    }

    fn ended(&self, action: ActionId) -> Option<ActionOutcome> {
        self.events.iter().find_map(|e| match e {
            Event::ActionEnded { action: a, outcome } if *a == action => Some(*outcome),
            _ => None,
        })
    }

    fn act(&mut self, r: ActionRequest) -> Result<Reply, Failure> {
        let now = self.now;
        let id = self.client.action(now, r).unwrap();
        self.wait(id)
    }
}

fn refused(r: Refusal) -> Result<Reply, Failure> {
    Err(Failure::Refused(r))
}

#[test]
fn set_mode_manual_is_the_manual_example() {
    let mut b = Bench::new();
    let id = b
        .client
        .set(b.now, ParamId::MODE, Mode::Manual.to_raw())
        .unwrap();
    let tg = b.client.image().channel.toggle;
    assert_eq!(
        b.client.image().channel.to_bytes(),
        [tg, 0x53, 0x00, 0x64, 0x00, 0x00, 0x00, 0x02]
    );
    assert_eq!(
        b.wait(id),
        Ok(Reply::Value {
            param: ParamId::MODE,
            value: 2
        })
    );
    assert_eq!(b.sim.value(ParamId::MODE), Some(2));
    // The answer echoes the request.
    assert!(
        b.answers
            .contains(&Channel::from_bytes([tg, 0x53, 0x00, 0x64, 0, 0, 0, 2]))
    );
}

#[test]
fn repeated_identical_requests_are_processed_with_new_toggles() {
    let mut b = Bench::new();
    let a = b.client.get(b.now, ParamId::CTRL_FN).unwrap();
    let c = b.client.get(b.now, ParamId::CTRL_FN).unwrap();
    assert_eq!(
        b.wait(a),
        Ok(Reply::Value {
            param: ParamId::CTRL_FN,
            value: 0
        })
    );
    assert_eq!(
        b.wait(c),
        Ok(Reply::Value {
            param: ParamId::CTRL_FN,
            value: 0
        })
    );
    let gets: Vec<_> = b
        .sent
        .iter()
        .filter(|c| c.instruction == Instruction::Get)
        .collect();
    assert_eq!(gets.len(), 2);
    assert_ne!(gets[0].toggle, gets[1].toggle);
    assert_eq!((gets[0].id, gets[1].id), (0x0834, 0x0834));
}

#[test]
fn local_checks_refuse_before_sending() {
    let mut b = Bench::new();
    let n = b.now;
    assert_eq!(
        b.client.set(n, ParamId::OPEN_TIGHT, 799),
        Err(ClientError::OutOfRange {
            param: ParamId::OPEN_TIGHT,
            error: RangeError::BelowRange {
                value: 799,
                min: 800
            }
        })
    );
    assert_eq!(
        b.client.set(n, ParamId::MODE, 5),
        Err(ClientError::OutOfRange {
            param: ParamId::MODE,
            error: RangeError::AboveRange { value: 5, max: 4 }
        })
    );
    assert_eq!(
        b.client.set(n, ParamId::POT_MIN, 1),
        Err(ClientError::ReadOnly(ParamId::POT_MIN))
    );
    assert_eq!(
        b.client.set(n, ParamId(0x7777), 1),
        Err(ClientError::UnknownParameter(0x7777))
    );
    assert_eq!(
        b.client.get(n, ParamId(0x7777)),
        Err(ClientError::UnknownParameter(0x7777))
    );
    assert!(b.client.is_idle());
    assert_eq!(
        b.client.poll_transmit().map(|i| i.channel.instruction),
        Some(Instruction::Nop)
    );
}

#[test]
fn device_diagnostics_for_raw_requests() {
    let mut b = Bench::new();
    let n = b.now;
    let above = b.client.set_raw(n, ParamId::MODE.0, 7).unwrap();
    let below = b.client.set_raw(n, ParamId::OPEN_TIGHT.0, 10).unwrap();
    let unknown_set = b.client.set_raw(n, 0x7777, 5).unwrap();
    let unknown_get = b.client.get_raw(n, 0x7777).unwrap();
    let read_only = b.client.set_raw(n, ParamId::ADJ_TIME_OPEN.0, 5).unwrap();
    let negative = b
        .client
        .set_raw(n, ParamId::SCALE_4MA.0, (-999i32) as u32)
        .unwrap();
    assert_eq!(
        b.wait(above),
        refused(Refusal::Diagnostic(DiagnosticCode::ABOVE_RANGE))
    );
    assert_eq!(
        b.wait(below),
        refused(Refusal::Diagnostic(DiagnosticCode::BELOW_RANGE))
    );
    assert_eq!(
        b.wait(unknown_set),
        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_PARAMETER))
    );
    assert_eq!(
        b.wait(unknown_get),
        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_PARAMETER))
    );
    assert_eq!(
        b.wait(read_only),
        refused(Refusal::ValueNotApplied {
            requested: 5,
            actual: 0
        })
    );
    assert_eq!(
        b.wait(negative),
        Ok(Reply::Value {
            param: ParamId::SCALE_4MA,
            value: -999
        })
    );
    assert_eq!(b.sim.value(ParamId::MODE), Some(1), "unchanged after 0x21");
}

#[test]
fn pot_wrong_dir_example_and_nop_after_query() {
    let mut b = Bench::new();
    b.sim.raise_error(ErrorCode::POT_WRONG_DIR);
    let id = b.client.active_errors(b.now, 1).unwrap();
    let tg = b.client.image().channel.toggle;
    assert_eq!(
        b.client.image().channel.to_bytes(),
        [tg, 0x44, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00]
    );
    assert_eq!(
        b.wait(id),
        Ok(Reply::ActiveErrors {
            number: 1,
            count: 1,
            code: ErrorCode::POT_WRONG_DIR
        })
    );
    assert!(b.answers.contains(&Channel::from_bytes([
        tg, 0x44, 0x00, 0x01, 0x00, 0x01, 0x00, 0x14
    ])));
    b.until_idle();
    // 'N' follows the 'D' query.
    let last_two: Vec<_> = b.sent.iter().rev().take(2).map(|c| c.instruction).collect();
    assert_eq!(last_two, [Instruction::Nop, Instruction::ActiveErrors]);
    // K1 (default function "Error") reports the active error.
    assert!(b.sim.device_image().outputs.k1);
}

#[test]
fn air_missing_example() {
    let mut b = Bench::new();
    b.sim.set_air_supply(false);
    let id = b.client.active_warnings(b.now, 1).unwrap();
    let tg = b.client.image().channel.toggle;
    assert_eq!(
        b.client.image().channel.to_bytes(),
        [tg, 0x57, 0x00, 0x01, 0, 0, 0, 0]
    );
    assert_eq!(
        b.wait(id),
        Ok(Reply::ActiveWarnings {
            number: 1,
            count: 1,
            code: ErrorCode::AIR_MISSING
        })
    );
    assert!(b.answers.contains(&Channel::from_bytes([
        tg, 0x57, 0x00, 0x01, 0x00, 0x01, 0x00, 0x1E
    ])));
    b.until_idle();
    assert_eq!(b.sent.last().unwrap().instruction, Instruction::Nop);
    // A warning number above the count answers code 0.
    let id = b.client.active_warnings(b.now, 2).unwrap();
    assert_eq!(
        b.wait(id),
        Ok(Reply::ActiveWarnings {
            number: 2,
            count: 1,
            code: ErrorCode::NONE
        })
    );
    // Without air, motion actions cannot be started.
    assert_eq!(
        b.act(ActionRequest::InitValve(RunFunction::Start)),
        refused(Refusal::ActionCannotBeStarted(ActionId::InitValve))
    );
    assert_eq!(
        b.act(ActionRequest::GoClose(GoFunction::Approach)),
        refused(Refusal::ActionCannotBeStarted(ActionId::GoClose))
    );
    assert_eq!(
        b.act(ActionRequest::FindFunction(FindFunctionFunction::Activate)),
        refused(Refusal::ActionCannotBeStarted(ActionId::FindFunction))
    );
    b.sim.set_air_supply(true);
    let id = b.client.active_warnings(b.now, 1).unwrap();
    assert_eq!(
        b.wait(id),
        Ok(Reply::ActiveWarnings {
            number: 1,
            count: 0,
            code: ErrorCode::NONE
        })
    );
}

#[test]
fn error_list_newest_first_oldest_dropped() {
    let mut b = Bench::new();
    let id = b.client.read_error_list(b.now, 0).unwrap();
    assert_eq!(
        b.wait(id),
        Ok(Reply::ErrorList {
            position: 0,
            entry: ErrorEntry::Entry(ErrorCode::NONE)
        })
    );
    let id = b.client.read_error_list(b.now, 1).unwrap();
    assert_eq!(
        b.wait(id),
        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_ERROR_ENTRY))
    );
    assert!(
        b.answers
            .iter()
            .any(|c| c.instruction == Instruction::ErrorList && c.value == 0xFFFF_FFFF)
    );
    // 11 errors into a 10-entry list: the first (oldest) one is dropped.
    let codes = [
        ErrorCode::BUS_FAULT,
        ErrorCode::POT_WRONG_DIR,
        ErrorCode::WRONG_FUNC,
        ErrorCode::PNEUMATIC,
        ErrorCode::LEAKAGE,
        ErrorCode::AIR_MISSING,
        ErrorCode::TRAVEL_SENSOR,
        ErrorCode::POT_WRONG_DIR,
        ErrorCode::WRONG_FUNC,
        ErrorCode::PNEUMATIC,
        ErrorCode::LEAKAGE,
    ];
    for c in codes {
        b.sim.raise_error(c);
    }
    let mut read = Vec::new();
    for pos in 0..12u16 {
        let id = b.client.read_error_list(b.now, pos).unwrap();
        match b.wait(id) {
            Ok(Reply::ErrorList {
                entry: ErrorEntry::Entry(c),
                ..
            }) => read.push(c),
            Err(Failure::Refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_ERROR_ENTRY))) => {
                break;
            }
            other => panic!("{other:?}"),
        }
    }
    let expected: Vec<_> = codes.iter().rev().take(10).copied().collect();
    assert_eq!(read, expected);
    assert!(!read.contains(&ErrorCode::BUS_FAULT));
    // Every 'E' was followed by an 'N'.
    for w in b.sent.windows(2) {
        if w[0].instruction == Instruction::ErrorList {
            assert_eq!(w[1].instruction, Instruction::Nop);
        }
    }
    // Clear error list empties it.
    let r = b.act(ActionRequest::ClearErrorList);
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::ClearErrorList,
            status: ActionStatus::ClearErrorList(DoneStatus::Done)
        })
    );
    assert_eq!(b.sim.error_list().count(), 0);
    assert_eq!(
        b.ended(ActionId::ClearErrorList),
        Some(ActionOutcome::Ended(ActionStatus::ClearErrorList(
            DoneStatus::Done
        )))
    );
}

#[test]
fn init_valve_runs_through_its_phases() {
    let mut b = Bench::new();
    assert!(!b.sim.is_initialised());
    let id = b
        .client
        .action(b.now, ActionRequest::InitValve(RunFunction::Start))
        .unwrap();
    let tg = b.client.image().channel.toggle;
    assert_eq!(
        b.client.image().channel.to_bytes(),
        [tg, 0x41, 0x00, 0x04, 0, 0, 0, 1]
    );
    assert_eq!(
        b.wait(id),
        Ok(Reply::Action {
            action: ActionId::InitValve,
            status: ActionStatus::InitValve(InitValveStatus::ClosedPosition)
        })
    );
    b.until_idle();
    use InitValveStatus::*;
    let phases: Vec<_> = [
        ClosedPosition,
        OpenPosition,
        ControlFunction,
        Times,
        Characteristics,
        PilotValves,
        Inactive,
    ]
    .into_iter()
    .map(ActionStatus::InitValve)
    .collect();
    assert_eq!(b.progress(ActionId::InitValve), phases);
    assert_eq!(
        b.ended(ActionId::InitValve),
        Some(ActionOutcome::Ended(ActionStatus::InitValve(Inactive)))
    );
    assert!(b.sim.is_initialised());
    b.run_for(Duration::from_millis(100));
    // The measured times arrive as unsolicited change notices.
    let changes: Vec<_> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::ParameterChanged { param, value } => Some((*param, *value)),
            _ => None,
        })
        .collect();
    assert_eq!(
        changes,
        [(ParamId::ADJ_TIME_CLOSE, 23), (ParamId::ADJ_TIME_OPEN, 25)]
    );
    // Six phases of the simulator's 2 s each: the whole run is at least 12 s of virtual time.
    assert!(b.now >= Instant::from_millis(12_000));
    // NoInit is refused once initialised (0x42).
    assert_eq!(
        b.act(ActionRequest::NoInit(NoInitFunction::OpenSlow)),
        refused(Refusal::Diagnostic(
            DiagnosticCode::NOINIT_ON_INITIALISED_VALVE
        ))
    );
}

#[test]
fn init_valve_error_acknowledge_and_cancel() {
    let mut b = Bench::new();
    b.sim
        .inject_fault(ActionId::InitValve, 3, ErrorCode::PNEUMATIC);
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    b.run_for(Duration::from_secs(6));
    let p = b.progress(ActionId::InitValve);
    assert_eq!(
        p.last(),
        Some(&ActionStatus::InitValve(InitValveStatus::ErrorActive(
            ErrorCode::PNEUMATIC
        )))
    );
    assert_eq!(b.client.active_action(), Some(ActionId::InitValve));
    assert_eq!(b.sim.error_list().next(), Some(ErrorCode::PNEUMATIC));
    let r = b.act(ActionRequest::InitValve(RunFunction::AcknowledgeError));
    let acked = ActionStatus::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::PNEUMATIC));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::InitValve,
            status: acked
        })
    );
    assert_eq!(
        b.ended(ActionId::InitValve),
        Some(ActionOutcome::Ended(acked))
    );
    assert!(!b.sim.is_initialised());
    let tg = b
        .sent
        .iter()
        .rev()
        .find(|c| c.instruction == Instruction::Action)
        .unwrap()
        .toggle;
    assert!(
        b.sent
            .contains(&Channel::from_bytes([tg, 0x41, 0, 4, 0, 0, 0xFF, 0]))
    );
    assert!(
        b.answers
            .contains(&Channel::from_bytes([tg, 0x41, 0, 4, 0, 0, 0x16, 0xFF]))
    );

    // Cancel a second run.
    let mut b = Bench::new();
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    b.run_for(Duration::from_secs(3));
    let r = b.act(ActionRequest::InitValve(RunFunction::Cancel));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::InitValve,
            status: ActionStatus::InitValve(InitValveStatus::Inactive)
        })
    );
    assert!(b.client.active_action().is_none());
    assert!(b.sim.running_action().is_none());
}

#[test]
fn only_one_action_at_a_time() {
    let mut b = Bench::new();
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    // Refused locally.
    assert_eq!(
        b.client
            .action(b.now, ActionRequest::GoClose(GoFunction::Approach)),
        Err(ClientError::ActionAlreadyActive {
            active: ActionId::InitValve
        })
    );
    // A get waits until the action has ended.
    let g = b.client.get(b.now, ParamId::MODE).unwrap();
    b.run_for(Duration::from_secs(5));
    assert!(b.result_of(g).is_none());
    assert_eq!(
        b.wait(g),
        Ok(Reply::Value {
            param: ParamId::MODE,
            value: 1
        })
    );
    assert!(b.ended(ActionId::InitValve).is_some());
}

#[test]
fn device_refuses_while_a_keypad_action_runs() {
    let mut b = Bench::new();
    b.sim.start_local_action(
        b.now,
        ActionRequest::InitValve(RunFunction::Start),
        ActionSource::Keypad,
    );
    let id = b
        .client
        .action(b.now, ActionRequest::GoOpen(GoFunction::Approach))
        .unwrap();
    let tg = b.client.image().channel.toggle;
    let busy = ActionBusy {
        source: ActionSource::Keypad,
        active: ActionId::InitValve,
    };
    // The answer is [tg, 'A', 0x0006, 0xFF, source, number] (the carrier also reports 0x40;
    // the 0xFF answer says more, so it is the refusal reported).
    assert_eq!(b.wait(id), refused(Refusal::ActionAlreadyActive(busy)));
    assert!(b.answers.contains(&Channel::from_bytes([
        tg, 0x41, 0x00, 0x06, 0xFF, 0x01, 0x00, 0x04
    ])));
    // 'Q' does not end a keypad action.
    let q = b.client.quit(b.now).unwrap();
    assert_eq!(b.wait(q), Ok(Reply::Quit));
    assert!(b.sim.running_action().is_some());
    b.sim.end_local_action();
    assert!(b.act(ActionRequest::GoOpen(GoFunction::Approach)).is_ok());
}

#[test]
fn busy_answer_without_carrier_diagnostics() {
    // A carrier that does not forward diagnostics: the 0xFF answer alone is the refusal.
    let mut client = Client::new(ClientConfig::default());
    let mut sim = SimulatedCpos::default();
    sim.set_initialised(true);
    let mut now = Instant::ZERO;
    sim.start_local_action(
        now,
        ActionRequest::AdjustTime(RunFunction::Start),
        ActionSource::WebInterface,
    );
    let id = client
        .action(now, ActionRequest::GoClose(GoFunction::Approach))
        .unwrap();
    let mut result = None;
    for _ in 0..10 {
        now += CYCLE;
        sim.handle_master_image(now, &client.image());
        let _ = sim.poll_diagnostic();
        client.handle_image(now, &sim.device_image());
        while let Some(e) = client.poll_event() {
            if let Event::Completed { id: i, result: r } = e {
                assert_eq!(i, id);
                result = Some(r);
            }
        }
    }
    assert_eq!(
        result,
        Some(refused(Refusal::ActionAlreadyActive(ActionBusy {
            source: ActionSource::WebInterface,
            active: ActionId::AdjustTime
        })))
    );
    assert!(client.active_action().is_none());
}

#[test]
fn quit_ends_a_fieldbus_action() {
    let mut b = Bench::new();
    b.act(ActionRequest::GoClose(GoFunction::Approach)).unwrap();
    b.run_for(Duration::from_millis(500));
    let q = b.client.quit(b.now).unwrap();
    let tg = b.client.image().channel.toggle;
    assert_eq!(
        b.client.image().channel.to_bytes(),
        [tg, 0x51, 0, 0, 0, 0, 0, 0]
    );
    assert_eq!(b.wait(q), Ok(Reply::Quit));
    assert!(
        b.answers
            .contains(&Channel::from_bytes([tg, 0x51, 0, 0, 0, 0, 0, 0]))
    );
    assert_eq!(b.ended(ActionId::GoClose), Some(ActionOutcome::Quit));
    assert!(b.sim.running_action().is_none());
}

#[test]
fn go_close_adopt_and_go_open_cancel() {
    let mut b = Bench::new();
    b.sim.set_initialised(true);
    b.client.set_set_value(PerMille::new(600).unwrap());
    b.run_for(Duration::from_secs(3));
    assert_eq!(b.sim.device_image().position.get(), 600);
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::ProcessData { position, .. } if position.get() == 600))
    );
    let r = b.act(ActionRequest::GoClose(GoFunction::Approach));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::GoClose,
            status: ActionStatus::GoClose(GoStatus::Approaching)
        })
    );
    b.run_for(Duration::from_secs(3));
    assert_eq!(b.sim.device_image().position.get(), 0);
    let r = b.act(ActionRequest::GoClose(GoFunction::Adopt));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::GoClose,
            status: ActionStatus::GoClose(GoStatus::Reached)
        })
    );
    assert_eq!(
        b.ended(ActionId::GoClose),
        Some(ActionOutcome::Ended(ActionStatus::GoClose(
            GoStatus::Reached
        )))
    );

    b.act(ActionRequest::GoOpen(GoFunction::Approach)).unwrap();
    let r = b.act(ActionRequest::GoOpen(GoFunction::Cancel));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::GoOpen,
            status: ActionStatus::GoOpen(GoStatus::Cancelled)
        })
    );
    // Adopt without a running GoOpen: "cannot be started".
    assert_eq!(
        b.act(ActionRequest::GoOpen(GoFunction::Adopt)),
        refused(Refusal::ActionCannotBeStarted(ActionId::GoOpen))
    );
}

#[test]
fn noinit_moves_the_valve_by_hand() {
    let mut b = Bench::new();
    let r = b.act(ActionRequest::NoInit(NoInitFunction::OpenFast));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::NoInit,
            status: ActionStatus::NoInit(NoInitFunction::OpenFast)
        })
    );
    let tg = b
        .sent
        .iter()
        .rev()
        .find(|c| c.instruction == Instruction::Action)
        .unwrap()
        .toggle;
    assert!(
        b.sent
            .contains(&Channel::from_bytes([tg, 0x41, 0, 1, 0x02, 0, 0, 0]))
    );
    b.run_for(Duration::from_secs(1));
    let p = b.sim.device_image().position.get();
    assert!(p > 400, "{p}");
    let pwm = NoInitFunction::ClosePwm(Pwm::new(500).unwrap());
    b.act(ActionRequest::NoInit(pwm)).unwrap();
    assert!(
        b.sent
            .iter()
            .any(|c| c.to_bytes()[1..] == [0x41, 0, 1, 0x06, 0, 0x01, 0xF4])
    );
    b.run_for(Duration::from_secs(1));
    assert!(b.sim.device_image().position.get() < p);
    b.act(ActionRequest::NoInit(NoInitFunction::Stop)).unwrap();
    let stopped = b.sim.device_image().position;
    b.run_for(Duration::from_millis(500));
    assert_eq!(b.sim.device_image().position, stopped);
    for f in [
        NoInitFunction::OpenSlow,
        NoInitFunction::CloseSlow,
        NoInitFunction::CloseFast,
        NoInitFunction::OpenPwm(Pwm::new(10).unwrap()),
    ] {
        b.act(ActionRequest::NoInit(f)).unwrap();
    }
    assert_eq!(b.client.active_action(), Some(ActionId::NoInit));
    let r = b.act(ActionRequest::NoInit(NoInitFunction::EndEvent));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::NoInit,
            status: ActionStatus::NoInit(NoInitFunction::EndEvent)
        })
    );
    assert_eq!(b.client.active_action(), None);
    assert!(b.sim.running_action().is_none());
    assert_eq!(b.progress(ActionId::NoInit).len(), 8);
}

#[test]
fn find_function_adjust_time_find_coefficient_init_pilot() {
    let mut b = Bench::new();
    // These three need an initialised valve.
    for r in [
        ActionRequest::AdjustTime(RunFunction::Start),
        ActionRequest::FindCoefficient(RunFunction::Start),
        ActionRequest::InitPilot(RunFunction::Start),
    ] {
        assert_eq!(
            b.act(r),
            refused(Refusal::ActionCannotBeStarted(r.action()))
        );
    }
    b.act(ActionRequest::FindFunction(FindFunctionFunction::Activate))
        .unwrap();
    b.until_idle();
    assert_eq!(
        b.progress(ActionId::FindFunction),
        [
            FindFunctionStatus::StartPosition,
            FindFunctionStatus::TestPattern,
            FindFunctionStatus::Inactive
        ]
        .map(ActionStatus::FindFunction)
    );
    b.sim.set_initialised(true);
    b.act(ActionRequest::AdjustTime(RunFunction::Start))
        .unwrap();
    b.until_idle();
    assert_eq!(
        b.progress(ActionId::AdjustTime),
        [
            AdjustTimeStatus::StartPosition,
            AdjustTimeStatus::MeasureClose,
            AdjustTimeStatus::MeasureOpen,
            AdjustTimeStatus::Inactive
        ]
        .map(ActionStatus::AdjustTime)
    );
    b.run_for(Duration::from_millis(100));
    assert!(b.events.contains(&Event::ParameterChanged {
        param: ParamId::ADJ_TIME_CLOSE,
        value: 24
    }));
    assert!(b.events.contains(&Event::ParameterChanged {
        param: ParamId::ADJ_TIME_OPEN,
        value: 26
    }));

    b.act(ActionRequest::FindCoefficient(RunFunction::Start))
        .unwrap();
    b.until_idle();
    use FindCoefficientStatus::*;
    assert_eq!(
        b.progress(ActionId::FindCoefficient),
        [
            ApproachPoint(1),
            ApproachPoint(2),
            ApproachPoint(3),
            Inactive
        ]
        .map(ActionStatus::FindCoefficient)
    );

    b.act(ActionRequest::InitPilot(RunFunction::Start)).unwrap();
    b.until_idle();
    assert_eq!(
        b.progress(ActionId::InitPilot),
        [InitPilotStatus::Active, InitPilotStatus::Inactive].map(ActionStatus::InitPilot)
    );

    // Faults and their acknowledgement.
    b.sim
        .inject_fault(ActionId::InitPilot, 1, ErrorCode::LEAKAGE);
    let r = b.act(ActionRequest::InitPilot(RunFunction::Start));
    let active = ActionStatus::InitPilot(InitPilotStatus::ErrorActive(ErrorCode::LEAKAGE));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::InitPilot,
            status: active
        })
    );
    let r = b.act(ActionRequest::InitPilot(RunFunction::AcknowledgeError));
    let acked = ActionStatus::InitPilot(InitPilotStatus::ErrorAcknowledged(ErrorCode::LEAKAGE));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::InitPilot,
            status: acked
        })
    );

    b.sim
        .inject_fault(ActionId::AdjustTime, 2, ErrorCode::PNEUMATIC);
    b.act(ActionRequest::AdjustTime(RunFunction::Start))
        .unwrap();
    b.run_for(Duration::from_secs(3));
    assert_eq!(b.client.active_action(), Some(ActionId::AdjustTime));
    let r = b.act(ActionRequest::AdjustTime(RunFunction::AcknowledgeError));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::AdjustTime,
            status: ActionStatus::AdjustTime(AdjustTimeStatus::ErrorAcknowledged(
                ErrorCode::PNEUMATIC
            ))
        })
    );

    b.sim
        .inject_fault(ActionId::FindCoefficient, 2, ErrorCode::PNEUMATIC);
    b.act(ActionRequest::FindCoefficient(RunFunction::Start))
        .unwrap();
    b.run_for(Duration::from_secs(3));
    let r = b.act(ActionRequest::FindCoefficient(
        RunFunction::AcknowledgeError,
    ));
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::FindCoefficient,
            status: ActionStatus::FindCoefficient(ErrorAcknowledged(ErrorCode::PNEUMATIC))
        })
    );

    // Cancels.
    for (start, cancel) in [
        (
            ActionRequest::FindFunction(FindFunctionFunction::Activate),
            ActionRequest::FindFunction(FindFunctionFunction::Cancel),
        ),
        (
            ActionRequest::AdjustTime(RunFunction::Start),
            ActionRequest::AdjustTime(RunFunction::Cancel),
        ),
        (
            ActionRequest::FindCoefficient(RunFunction::Start),
            ActionRequest::FindCoefficient(RunFunction::Cancel),
        ),
        (
            ActionRequest::InitPilot(RunFunction::Start),
            ActionRequest::InitPilot(RunFunction::Cancel),
        ),
    ] {
        b.act(start).unwrap();
        let r = b.act(cancel).unwrap();
        let Reply::Action { status, .. } = r else {
            panic!("{r:?}")
        };
        assert_eq!(
            status.to_value(),
            1,
            "{status:?} is the action's 'inactive'"
        );
        assert!(b.client.active_action().is_none());
    }
}

#[test]
fn set_default_and_actions_that_remain_active() {
    let mut b = Bench::new();
    let id = b.client.set(b.now, ParamId::MODE, 3).unwrap();
    b.wait(id).unwrap();
    let r = b.act(ActionRequest::SetDefault);
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::SetDefault,
            status: ActionStatus::SetDefault(DoneStatus::Done)
        })
    );
    assert_eq!(b.sim.value(ParamId::MODE), Some(1));
    b.sim.refuse_clear_and_default(true);
    let r = b.act(ActionRequest::ClearErrorList);
    assert_eq!(
        r,
        Ok(Reply::Action {
            action: ActionId::ClearErrorList,
            status: ActionStatus::ClearErrorList(DoneStatus::NotDone)
        })
    );
    assert_eq!(b.client.active_action(), Some(ActionId::ClearErrorList));
    let q = b.client.quit(b.now).unwrap();
    assert_eq!(b.wait(q), Ok(Reply::Quit));
    assert_eq!(b.client.active_action(), None);
    assert!(b.sim.running_action().is_none());
}

#[test]
fn timeouts_when_the_answer_does_not_change() {
    let mut b = Bench::new();
    b.connected = false;
    let start = b.now;
    let id = b.client.get(b.now, ParamId::MODE).unwrap();
    assert_eq!(
        b.client.poll_timeout(),
        Some(start + Duration::from_secs(1))
    );
    assert_eq!(b.wait(id), Err(Failure::Timeout));
    assert!(b.now >= start + Duration::from_secs(1));
    assert!(b.now < start + Duration::from_millis(1100));
    // The next request goes out after the timeout.
    b.connected = true;
    let id = b.client.get(b.now, ParamId::MODE).unwrap();
    assert!(b.wait(id).is_ok());

    // An action whose status does not change ends with TimedOut.
    let mut b = Bench::with(ClientConfig {
        action_timeout: Duration::from_secs(5),
        ..ClientConfig::default()
    });
    b.act(ActionRequest::GoClose(GoFunction::Approach)).unwrap();
    b.run_for(Duration::from_secs(6));
    assert_eq!(b.ended(ActionId::GoClose), Some(ActionOutcome::TimedOut));
    assert!(b.client.poll_timeout().is_none());
}

#[test]
fn unsolicited_change_notices() {
    let mut b = Bench::new();
    b.sim.set_local(ParamId::MODE, Mode::ManualFlex.to_raw());
    b.run_for(Duration::from_millis(50));
    assert!(b.events.contains(&Event::ParameterChanged {
        param: ParamId::MODE,
        value: 3
    }));
    // A notice does not disturb a request in flight.
    let id = b.client.get(b.now, ParamId::CTRL_FN).unwrap();
    b.sim.set_local(ParamId::DEAD_BAND, 5);
    assert_eq!(
        b.wait(id),
        Ok(Reply::Value {
            param: ParamId::CTRL_FN,
            value: 0
        })
    );
    b.run_for(Duration::from_millis(50));
    assert!(b.events.contains(&Event::ParameterChanged {
        param: ParamId::DEAD_BAND,
        value: 5
    }));
}

#[test]
fn diagnostics_and_late_answers_without_a_request_in_flight() {
    let mut client = Client::new(ClientConfig::default());
    let mut sim = SimulatedCpos::default();
    let t0 = Instant::ZERO;
    // A diagnostic with nothing in flight is reported on its own.
    client.handle_diagnostic(t0, DiagnosticCode(0x99));
    assert_eq!(
        client.poll_event(),
        Some(Event::Diagnostic(DiagnosticCode(0x99)))
    );
    assert_eq!(
        format!("{}", DiagnosticCode::ABOVE_RANGE),
        "diagnostic 0x21: value above the valid range"
    );
    // A request times out, then its answer arrives late: reported as unmatched.
    let id = client.get(t0, ParamId::MODE).unwrap();
    let sent = client.image();
    let deadline = client.poll_timeout().unwrap();
    client.handle_timeout(deadline);
    assert_eq!(
        client.poll_event(),
        Some(Event::Completed {
            id,
            result: Err(Failure::Timeout)
        })
    );
    sim.handle_master_image(deadline, &sent);
    let late = sim.device_image();
    client.handle_image(deadline, &late);
    let events: Vec<_> = std::iter::from_fn(|| client.poll_event()).collect();
    // A late 'G' looks like a change notice; the client cannot tell it apart and says so.
    assert!(
        events.contains(&Event::ParameterChanged {
            param: ParamId::MODE,
            value: 1
        }),
        "{events:?}"
    );
    // An answer of another instruction that matches nothing is unmatched.
    let mut img = late;
    img.channel = Channel::from_bytes([0x77, 0x44, 0, 1, 0, 0, 0, 0]);
    client.handle_image(deadline, &img);
    assert_eq!(
        client.poll_event(),
        Some(Event::UnmatchedAnswer(img.channel))
    );
}
