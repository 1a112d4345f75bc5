//! The cPos client over DeviceNet against the simulated cPos behind a DeviceNet slave, on the
//! in-memory CAN bus with a virtual clock: the master drives an endpoint the way it would drive
//! SocketCAN, the slave is a station of the bus. Every action path, refusals with their
//! diagnostics, the size check, connection loss and a duplicate MAC ID.

use canola::mem::{BusConfig, Endpoint, MemoryBus, StationId};
use canola::transport::{Received, Station, Transport};
use canola_devicenet::{MacId, Slave};
use canola_frame::{CanFrame, Duration, Instant};
use canola_gemu::action::{
    ActionId, ActionRequest, ActionStatus, AdjustTimeStatus, DoneStatus, ErrorCode,
    FindCoefficientStatus, FindFunctionFunction, FindFunctionStatus, GoFunction, GoStatus,
    InitPilotStatus, InitValveStatus, NoInitFunction, RunFunction,
};
use canola_gemu::channel::{ActionBusy, ActionSource, DiagnosticCode, ErrorEntry};
use canola_gemu::client::{ActionOutcome, Event, Failure, Refusal, Reply, RequestId};
use canola_gemu::over_devicenet::{
    CposEvent, CposMaster, CposMasterConfig, CposSlave, ImageSizes, SIM_DIAGNOSTIC_PATH, SizeError,
    cpos_slave_config,
};
use canola_gemu::params::{Mode, ParamId};
use canola_gemu::sim::{SimConfig, SimulatedCpos};

struct SlaveStation(Slave<CposSlave>);

impl Station for SlaveStation {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.0.handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.0.handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.0.poll_transmit()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.0.poll_timeout()
    }
}

fn cpos_mac() -> MacId {
    MacId::new(63).unwrap()
}

fn slave(sizes: ImageSizes) -> SlaveStation {
    let mut s = Slave::new(
        cpos_slave_config(cpos_mac(), sizes, 0x1436_0001),
        CposSlave::new(SimulatedCpos::new(SimConfig::default())),
    );
    s.start(Instant::ZERO);
    SlaveStation(s)
}

struct Bench {
    bus: MemoryBus,
    ep: Endpoint,
    slave: Option<StationId<SlaveStation>>,
    m: CposMaster,
    events: Vec<(Instant, CposEvent)>,
    frames: usize,
}

impl Bench {
    fn new() -> Self {
        Self::with(ImageSizes::STANDARD, Some(ImageSizes::STANDARD))
    }

    fn with(sizes: ImageSizes, expected: Option<ImageSizes>) -> Self {
        // 500 kbit/s timing: frames take their real time on the wire.
        let bus = MemoryBus::with_config(BusConfig {
            bitrate: Some(500_000),
            ..BusConfig::default()
        });
        let ep = bus.endpoint();
        let slave = bus.attach(slave(sizes));
        let mut config = CposMasterConfig::new(cpos_mac());
        config.expected_sizes = expected;
        config.diagnostics = Some(SIM_DIAGNOSTIC_PATH);
        let mut m = CposMaster::new(config);
        m.start(bus.now());
        let mut b = Bench {
            bus,
            ep,
            slave: Some(slave),
            m,
            events: Vec::new(),
            frames: 0,
        };
        b.until(|b| {
            b.m.is_connected()
                || b.events
                    .iter()
                    .any(|(_, e)| matches!(e, CposEvent::SizeMismatch(_)))
        });
        b
    }

    fn now(&self) -> Instant {
        self.ep.now()
    }

    fn sim<R>(&self, f: impl FnOnce(&mut SimulatedCpos) -> R) -> R {
        self.bus
            .with_station(self.slave.unwrap(), |s| f(s.0.app_mut().sim_mut()))
            .unwrap()
    }

    /// One pass of the driver loop: send, wait for a frame or the next deadline, feed.
    fn step(&mut self, limit: Instant) {
        while let Some(f) = self.m.poll_transmit() {
            self.ep.send(&f).unwrap();
        }
        let deadline = self.m.poll_timeout().map_or(limit, |t| t.min(limit));
        match self.ep.recv_until(deadline).unwrap() {
            Some(Received::Frame { frame, at }) => {
                self.frames += 1;
                self.m.handle_frame(at, &frame);
            }
            Some(Received::Event(_)) => {}
            None => {
                let now = self.now();
                self.m.handle_timeout(now);
            }
        }
        let now = self.now();
        while let Some(e) = self.m.poll_event() {
            self.events.push((now, e));
        }
    }

    fn until(&mut self, mut f: impl FnMut(&Bench) -> bool) {
        let end = self.now() + Duration::from_secs(600);
        while !f(self) {
            assert!(self.now() < end, "condition not reached within 600 s");
            self.step(end);
        }
    }

    fn run_for(&mut self, d: Duration) {
        let end = self.now() + d;
        while self.now() < end {
            self.step(end);
        }
    }

    fn result_of(&self, id: RequestId) -> Option<Result<Reply, Failure>> {
        self.events.iter().find_map(|(_, e)| match e {
            CposEvent::Client(Event::Completed { id: i, result }) if *i == id => Some(*result),
            _ => None,
        })
    }

    fn wait(&mut self, id: RequestId) -> Result<Reply, Failure> {
        self.until(|b| b.result_of(id).is_some());
        self.result_of(id).unwrap()
    }

    fn act(&mut self, r: ActionRequest) -> Result<Reply, Failure> {
        let now = self.now();
        let id = self.m.client_mut().action(now, r).unwrap();
        self.wait(id)
    }

    fn progress(&self, action: ActionId) -> Vec<ActionStatus> {
        self.events
            .iter()
            .filter_map(|(_, e)| match e {
                CposEvent::Client(Event::ActionProgress { action: a, status }) if *a == action => {
                    Some(*status)
                }
                _ => None,
            })
            .collect()
    }

    fn ended(&self, action: ActionId) -> Option<ActionOutcome> {
        self.events.iter().find_map(|(_, e)| match e {
            CposEvent::Client(Event::ActionEnded { action: a, outcome }) if *a == action => {
                Some(*outcome)
            }
            _ => None,
        })
    }
}

fn refused(r: Refusal) -> Result<Reply, Failure> {
    Err(Failure::Refused(r))
}

#[test]
fn connects_with_identity_and_standard_sizes() {
    let b = Bench::new();
    let (identity, sizes) = b
        .events
        .iter()
        .find_map(|(_, e)| match e {
            CposEvent::Connected { identity, sizes } => Some((identity.clone(), *sizes)),
            _ => None,
        })
        .unwrap();
    assert_eq!(identity.vendor_id, 272);
    assert_eq!(identity.product_code, 1436);
    assert_eq!(identity.product_name.as_str(), "1436 cPos");
    assert_eq!(identity.serial_number, 0x1436_0001);
    assert_eq!(sizes, ImageSizes::STANDARD);
    assert!(b.m.has_channel());
    // Two Duplicate MAC ID checks of 1 s each come first.
    assert!(b.now() >= Instant::from_millis(2000));
}

#[test]
fn get_and_set_with_device_diagnostics() {
    let mut b = Bench::new();
    let n = b.now();
    let c = b.m.client_mut();
    let set = c.set(n, ParamId::MODE, Mode::Manual.to_raw()).unwrap();
    let get = c.get(n, ParamId::MODE).unwrap();
    let above = c.set_raw(n, ParamId::MODE.0, 7).unwrap();
    let unknown = c.get_raw(n, 0x7777).unwrap();
    let read_only = c.set_raw(n, ParamId::ADJ_TIME_OPEN.0, 5).unwrap();
    assert_eq!(
        b.wait(set),
        Ok(Reply::Value {
            param: ParamId::MODE,
            value: 2
        })
    );
    assert_eq!(
        b.wait(get),
        Ok(Reply::Value {
            param: ParamId::MODE,
            value: 2
        })
    );
    assert_eq!(
        b.wait(above),
        refused(Refusal::Diagnostic(DiagnosticCode::ABOVE_RANGE))
    );
    assert_eq!(
        b.wait(unknown),
        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_PARAMETER))
    );
    assert_eq!(
        b.wait(read_only),
        refused(Refusal::ValueNotApplied {
            requested: 5,
            actual: 0
        })
    );
    assert_eq!(b.sim(|s| s.value(ParamId::MODE)), Some(2));
}

#[test]
fn error_list_active_errors_and_warnings() {
    let mut b = Bench::new();
    b.sim(|s| {
        s.raise_error(ErrorCode::POT_WRONG_DIR);
        s.raise_error(ErrorCode::PNEUMATIC);
        s.set_air_supply(false);
    });
    let n = b.now();
    let c = b.m.client_mut();
    let e0 = c.read_error_list(n, 0).unwrap();
    let e1 = c.read_error_list(n, 1).unwrap();
    let e9 = c.read_error_list(n, 9).unwrap();
    let e2 = c.read_error_list(n, 2).unwrap();
    let d = c.active_errors(n, 1).unwrap();
    let w = c.active_warnings(n, 1).unwrap();
    assert_eq!(
        b.wait(e0),
        Ok(Reply::ErrorList {
            position: 0,
            entry: ErrorEntry::Entry(ErrorCode::AIR_MISSING)
        })
    );
    assert_eq!(
        b.wait(e1),
        Ok(Reply::ErrorList {
            position: 1,
            entry: ErrorEntry::Entry(ErrorCode::PNEUMATIC)
        })
    );
    assert_eq!(
        b.wait(e2),
        Ok(Reply::ErrorList {
            position: 2,
            entry: ErrorEntry::Entry(ErrorCode::POT_WRONG_DIR)
        })
    );
    assert_eq!(
        b.wait(e9),
        refused(Refusal::Diagnostic(DiagnosticCode::NO_SUCH_ERROR_ENTRY))
    );
    assert!(matches!(
        b.wait(d),
        Ok(Reply::ActiveErrors { count: 2, .. })
    ));
    assert!(matches!(
        b.wait(w),
        Ok(Reply::ActiveWarnings {
            count: 1,
            code: ErrorCode::AIR_MISSING,
            ..
        })
    ));
}

#[test]
fn init_valve_runs_through_its_phases() {
    let mut b = Bench::new();
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    b.until(|b| b.ended(ActionId::InitValve).is_some());
    let p = b.progress(ActionId::InitValve);
    assert!(p.len() >= 6, "{p:?}");
    assert_eq!(
        b.ended(ActionId::InitValve),
        Some(ActionOutcome::Ended(ActionStatus::InitValve(
            InitValveStatus::Inactive
        )))
    );
    assert!(b.sim(|s| s.is_initialised()));
    // The measured times are published as change notices.
    b.run_for(Duration::from_millis(200));
    assert!(b.events.iter().any(|(_, e)| matches!(
        e,
        CposEvent::Client(Event::ParameterChanged { value: 23, .. })
    )));
}

#[test]
fn init_valve_fault_is_acknowledged() {
    let mut b = Bench::new();
    b.sim(|s| s.inject_fault(ActionId::InitValve, 3, ErrorCode::PNEUMATIC));
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    b.until(|b| {
        b.progress(ActionId::InitValve).last()
            == Some(&ActionStatus::InitValve(InitValveStatus::ErrorActive(
                ErrorCode::PNEUMATIC,
            )))
    });
    let acked = ActionStatus::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::PNEUMATIC));
    assert_eq!(
        b.act(ActionRequest::InitValve(RunFunction::AcknowledgeError)),
        Ok(Reply::Action {
            action: ActionId::InitValve,
            status: acked
        })
    );
    assert_eq!(
        b.ended(ActionId::InitValve),
        Some(ActionOutcome::Ended(acked))
    );
}

#[test]
fn refusals_cannot_start_noinit_on_initialised_and_busy() {
    let mut b = Bench::new();
    b.sim(|s| s.set_air_supply(false));
    assert_eq!(
        b.act(ActionRequest::InitValve(RunFunction::Start)),
        refused(Refusal::ActionCannotBeStarted(ActionId::InitValve))
    );
    b.sim(|s| {
        s.set_air_supply(true);
        s.set_initialised(true);
    });
    assert_eq!(
        b.act(ActionRequest::NoInit(NoInitFunction::OpenFast)),
        refused(Refusal::Diagnostic(DiagnosticCode(0x42)))
    );
    // A keypad action runs: the fieldbus request gets the 0xFF answer (the 0x40 diagnostic
    // comes along; the answer says more and is the refusal reported).
    let now = b.now();
    b.sim(|s| {
        s.set_initialised(false);
        s.start_local_action(
            now,
            ActionRequest::InitValve(RunFunction::Start),
            ActionSource::Keypad,
        );
    });
    assert_eq!(
        b.act(ActionRequest::GoOpen(GoFunction::Approach)),
        refused(Refusal::ActionAlreadyActive(ActionBusy {
            source: ActionSource::Keypad,
            active: ActionId::InitValve
        }))
    );
}

#[test]
fn go_close_adopt_and_quit() {
    let mut b = Bench::new();
    b.sim(|s| s.set_initialised(true));
    b.act(ActionRequest::GoClose(GoFunction::Approach)).unwrap();
    b.run_for(Duration::from_secs(3));
    b.act(ActionRequest::GoClose(GoFunction::Adopt)).unwrap();
    b.until(|b| b.ended(ActionId::GoClose).is_some());
    assert_eq!(
        b.ended(ActionId::GoClose),
        Some(ActionOutcome::Ended(ActionStatus::GoClose(
            GoStatus::Reached
        )))
    );
    // NoInit motion on an uninitialised valve, then 'Q'.
    b.sim(|s| s.set_initialised(false));
    b.act(ActionRequest::NoInit(NoInitFunction::OpenSlow))
        .unwrap();
    b.run_for(Duration::from_secs(1));
    let now = b.now();
    let q = b.m.client_mut().quit(now).unwrap();
    assert_eq!(b.wait(q), Ok(Reply::Quit));
    assert_eq!(b.ended(ActionId::NoInit), Some(ActionOutcome::Quit));
    assert!(b.sim(|s| s.running_action().is_none()));
}

#[test]
fn set_value_moves_the_simulated_valve_through_the_poll_connection() {
    let mut b = Bench::new();
    b.sim(|s| s.set_initialised(true));
    let n = b.now();
    let c = b.m.client_mut();
    let s = c.set(n, ParamId::MODE, Mode::Auto.to_raw()).unwrap();
    b.wait(s).unwrap();
    b.m.client_mut()
        .set_set_value(canola_gemu::image::PerMille::new(500).unwrap());
    b.run_for(Duration::from_secs(10));
    let last = b
        .events
        .iter()
        .rev()
        .find_map(|(_, e)| match e {
            CposEvent::Client(Event::ProcessData { position, .. }) => Some(position.get()),
            _ => None,
        })
        .unwrap();
    assert!((450..=550).contains(&last), "position {last}");
}

#[test]
fn size_check_at_connect() {
    // The device is set to send 5 / receive 3: refused when the standard sizes are expected.
    let b = Bench::with(
        ImageSizes {
            send: 5,
            receive: 3,
        },
        Some(ImageSizes::STANDARD),
    );
    assert!(
        b.events
            .iter()
            .any(|(_, e)| matches!(e, CposEvent::SizeMismatch(SizeError::Unexpected { .. })))
    );
    assert!(!b.m.is_connected());
    // Sizes the cPos does not offer are refused even when any size is accepted.
    let b = Bench::with(
        ImageSizes {
            send: 6,
            receive: 3,
        },
        None,
    );
    assert!(
        b.events
            .iter()
            .any(|(_, e)| matches!(e, CposEvent::SizeMismatch(SizeError::NotOffered(_))))
    );
    // Accepted when any offered size is fine: the position comes, the channel does not.
    let mut b = Bench::with(
        ImageSizes {
            send: 5,
            receive: 3,
        },
        None,
    );
    assert!(b.m.is_connected());
    assert!(!b.m.has_channel());
    b.run_for(Duration::from_millis(100));
    assert!(
        b.events
            .iter()
            .any(|(_, e)| matches!(e, CposEvent::Client(Event::ProcessData { .. })))
    );
    let now = b.now();
    let g = b.m.client_mut().get(now, ParamId::MODE).unwrap();
    assert_eq!(b.wait(g), Err(Failure::Timeout));
}

#[test]
fn connection_loss_and_reconnect() {
    let mut b = Bench::new();
    let slave = b.bus.detach(b.slave.take().unwrap()).unwrap();
    let now = b.now();
    let g = b.m.client_mut().get(now, ParamId::MODE).unwrap();
    b.until(|b| {
        b.events
            .iter()
            .any(|(_, e)| matches!(e, CposEvent::ConnectionLost))
    });
    assert!(!b.m.is_connected());
    assert_eq!(b.wait(g), Err(Failure::Timeout));
    // The cPos is back (its poll connection timed out meanwhile); the master connects again
    // once the cPos has let go of the old allocation.
    b.slave = Some(b.bus.attach(slave));
    b.until(|b| b.m.is_connected());
    let now = b.now();
    let g = b.m.client_mut().get(now, ParamId::MODE).unwrap();
    assert!(b.wait(g).is_ok());
}

#[test]
fn duplicate_mac_of_the_cpos_keeps_it_off_line() {
    // A second device with MAC 63 is already on line: it answers the cPos's check, the cPos
    // faults, and the master never connects to it (the other device does not speak DeviceNet
    // beyond its check answer here).
    let bus = MemoryBus::new();
    let mut ep = bus.endpoint();
    let slave = bus.attach(slave(ImageSizes::STANDARD));
    // The answer of the other device with MAC 63: a check response.
    let other = canola_devicenet::DuplicateMacCheck {
        response: true,
        port: 0,
        vendor_id: 1,
        serial_number: 2,
    };
    let id = canola_devicenet::Predefined::DuplicateMacCheck(cpos_mac()).can_id();
    ep.send(&CanFrame::new(id, &other.emit()).unwrap()).unwrap();
    bus.run_for(Duration::from_secs(3));
    let state = bus.with_station(slave, |s| s.0.network_state()).unwrap();
    assert_eq!(state, canola_devicenet::slave::NetworkState::Faulted);
}

#[test]
fn the_other_actions_over_devicenet() {
    let mut b = Bench::new();
    // Clear error list and set default end at once.
    b.sim(|s| s.raise_error(ErrorCode::POT_WRONG_DIR));
    assert_eq!(
        b.act(ActionRequest::ClearErrorList),
        Ok(Reply::Action {
            action: ActionId::ClearErrorList,
            status: ActionStatus::ClearErrorList(DoneStatus::Done)
        })
    );
    assert_eq!(b.sim(|s| s.error_list().count()), 0);
    assert_eq!(
        b.act(ActionRequest::SetDefault),
        Ok(Reply::Action {
            action: ActionId::SetDefault,
            status: ActionStatus::SetDefault(DoneStatus::Done)
        })
    );
    // Find function, then (initialised) adjust time, find coefficient and init pilot, each to
    // its end through every phase.
    b.act(ActionRequest::FindFunction(FindFunctionFunction::Activate))
        .unwrap();
    b.until(|b| b.ended(ActionId::FindFunction).is_some());
    assert_eq!(
        b.progress(ActionId::FindFunction),
        [
            FindFunctionStatus::StartPosition,
            FindFunctionStatus::TestPattern,
            FindFunctionStatus::Inactive
        ]
        .map(ActionStatus::FindFunction)
    );
    b.sim(|s| s.set_initialised(true));
    b.act(ActionRequest::AdjustTime(RunFunction::Start))
        .unwrap();
    b.until(|b| b.ended(ActionId::AdjustTime).is_some());
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
    b.act(ActionRequest::FindCoefficient(RunFunction::Start))
        .unwrap();
    b.until(|b| b.ended(ActionId::FindCoefficient).is_some());
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
    b.until(|b| b.ended(ActionId::InitPilot).is_some());
    assert_eq!(
        b.progress(ActionId::InitPilot),
        [InitPilotStatus::Active, InitPilotStatus::Inactive].map(ActionStatus::InitPilot)
    );
    // GoOpen approach, then cancel; init valve started and cancelled.
    b.act(ActionRequest::GoOpen(GoFunction::Approach)).unwrap();
    b.run_for(Duration::from_millis(500));
    b.act(ActionRequest::GoOpen(GoFunction::Cancel)).unwrap();
    b.until(|b| b.ended(ActionId::GoOpen).is_some());
    assert_eq!(
        b.ended(ActionId::GoOpen),
        Some(ActionOutcome::Ended(ActionStatus::GoOpen(
            GoStatus::Cancelled
        )))
    );
    b.act(ActionRequest::InitValve(RunFunction::Start)).unwrap();
    b.run_for(Duration::from_secs(3));
    assert_eq!(
        b.act(ActionRequest::InitValve(RunFunction::Cancel)),
        Ok(Reply::Action {
            action: ActionId::InitValve,
            status: ActionStatus::InitValve(InitValveStatus::Inactive)
        })
    );
    assert!(b.sim(|s| s.running_action().is_none()));
    assert!(b.frames > 1000, "{} frames received", b.frames);
}
