//! `canopen cpos ...`: the GEMÜ 1436 cPos positioner (crate `canola-gemu`).
//!
//! With `--iface` the commands drive a cPos over DeviceNet (its DeviceNet variant speaks the
//! Predefined Master/Slave Connection Set on the same CAN interface as CANopen; `canopen cpos
//! simulate --iface ...` is a simulated one). Without it they talk to an in-process simulated
//! positioner on a virtual clock: every invocation starts a fresh, not yet initialised
//! simulator. Either way the requests, answers, toggle bytes and timeouts are the real client's.

use canola::frame::is_due;
use std::process::ExitCode;

use canola::{Duration, Instant};
use canola_gemu::action::{
    ActionId, ActionRequest, ErrorCode, FindFunctionFunction, GoFunction, NoInitFunction, Pwm,
    RunFunction,
};
use canola_gemu::channel::ErrorEntry;
use canola_gemu::client::{
    ActionOutcome, Client, ClientConfig, Event, Failure, Refusal, Reply, RequestId,
};
use canola_gemu::params::{self, PARAMETERS, ParamDef, ValueKind};
use canola_gemu::sim::{SimConfig, SimulatedCpos};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::{Value as Json, json};

use crate::Global;
use crate::error::CliError;

mod over_devicenet;

/// Options of the simulated positioner.
#[derive(Debug, Args)]
pub(crate) struct SimArgs {
    /// Start the simulator with an initialised valve.
    #[arg(long, global = true)]
    initialised: bool,
    /// Raise these error codes in the simulator first (e.g. 20 for PotWrongDir); repeatable.
    #[arg(long = "raise-error", value_name = "CODE", global = true)]
    raise_error: Vec<u16>,
    /// Cut the simulated compressed air (warning 030 Air missing).
    #[arg(long, global = true)]
    no_air: bool,
}

impl SimArgs {
    /// A fresh simulator set up as asked.
    fn simulator(&self) -> SimulatedCpos {
        let mut sim = SimulatedCpos::new(SimConfig::default());
        sim.set_initialised(self.initialised);
        for c in &self.raise_error {
            sim.raise_error(ErrorCode(*c));
        }
        if self.no_air {
            sim.set_air_supply(false);
        }
        sim
    }
}

/// GEMÜ 1436 cPos positioner commands. With --iface over DeviceNet (the cPos at --mac, through
/// the Predefined Master/Slave Connection Set); without it against an in-process SIMULATED
/// positioner on a virtual clock.
#[derive(Debug, Args)]
pub(crate) struct CposArgs {
    #[command(flatten)]
    sim: SimArgs,
    #[command(flatten)]
    dn: over_devicenet::DnOpts,
    #[command(subcommand)]
    command: CposCommand,
}

#[derive(Debug, Subcommand)]
pub(crate) enum CposCommand {
    /// List the parameter table (chapter 6): name, ID, access, range, unit or labels.
    Params,
    /// Read a parameter by name ("Mode", "Pos Ctrl Out", "W 50%") or ID (0x0064).
    Get {
        /// Parameter name or ID.
        name: String,
    },
    /// Write a parameter: the value is a number or an enumeration label ("manual"). Range and
    /// access are checked before anything is sent.
    Set {
        /// Parameter name or ID.
        name: String,
        /// Value or label (negative numbers as `-5`).
        #[arg(allow_negative_numbers = true)]
        value: String,
    },
    /// Run an action and follow its status until it ends.
    Action {
        /// The action.
        action: ActionArg,
        /// Its function (default: start/approach/activate; NoInit: open-slow).
        function: Option<FunctionArg>,
        /// PWM 0..=1000 for NoInit open-pwm / close-pwm.
        #[arg(long, default_value_t = 500)]
        pwm: u16,
        /// Make the simulated run fail with this error code (20, 22, 23) in phase `--fault-step`,
        /// then acknowledge it.
        #[arg(long, value_name = "CODE")]
        fault: Option<u16>,
        /// Phase in which `--fault` occurs.
        #[arg(long, default_value_t = 2)]
        fault_step: u8,
    },
    /// Read the error list (newest first), the active errors and the active warnings.
    Errors,
    /// Demo: initialise the simulated valve and show every phase of the run.
    Demo,
    /// Run a simulated cPos as a DeviceNet slave at --mac: with --iface on that interface until
    /// stopped (or --duration), without it on the in-memory bus for --duration.
    Simulate {
        /// Stop after this many seconds (required on the in-memory bus).
        #[arg(long)]
        duration: Option<f64>,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum ActionArg {
    NoInit,
    ClearErrorList,
    SetDefault,
    InitValve,
    GoClose,
    GoOpen,
    FindFunction,
    AdjustTime,
    FindCoefficient,
    InitPilot,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum FunctionArg {
    Start,
    Cancel,
    Acknowledge,
    Approach,
    Adopt,
    Stop,
    OpenSlow,
    OpenFast,
    CloseSlow,
    CloseFast,
    OpenPwm,
    ClosePwm,
    End,
}

const CYCLE: Duration = Duration::from_millis(10);

/// What carries the image: the in-process simulator, or a DeviceNet poll connection.
enum Carrier {
    /// Client and simulator exchanging images every 10 ms of virtual time.
    Local {
        client: Box<Client>,
        sim: Box<SimulatedCpos>,
    },
    /// The client through a DeviceNet master on a CAN interface.
    DeviceNet(Box<over_devicenet::Link>),
}

/// A client and what carries its image, with the events seen so far.
struct Bench {
    carrier: Carrier,
    now: Instant,
    /// When the bench was ready (event times are printed relative to it).
    start: Instant,
    events: Vec<(Instant, Event)>,
}

impl Bench {
    fn new(
        sim: &SimArgs,
        dn: &over_devicenet::DnOpts,
        iface: Option<&str>,
    ) -> Result<Self, CliError> {
        if let Some(iface) = iface {
            if sim.initialised || !sim.raise_error.is_empty() || sim.no_air {
                return Err(CliError::Argument(
                    "--initialised, --raise-error and --no-air set up the in-process simulator; \
                     with --iface give them to `canopen cpos simulate`"
                        .into(),
                ));
            }
            let link = over_devicenet::Link::connect(dn, iface)?;
            let now = link.now();
            return Ok(Self {
                carrier: Carrier::DeviceNet(Box::new(link)),
                now,
                start: now,
                events: Vec::new(),
            });
        }
        if dn.over_devicenet {
            let link = over_devicenet::Link::connect_simulated(dn, sim)?;
            let now = link.now();
            return Ok(Self {
                carrier: Carrier::DeviceNet(Box::new(link)),
                now,
                start: now,
                events: Vec::new(),
            });
        }
        let mut b = Self {
            carrier: Carrier::Local {
                client: Box::new(Client::new(ClientConfig::default())),
                sim: Box::new(sim.simulator()),
            },
            now: Instant::ZERO,
            start: Instant::ZERO,
            events: Vec::new(),
        };
        b.cycle();
        Ok(b)
    }

    fn client(&mut self) -> &mut Client {
        match &mut self.carrier {
            Carrier::Local { client, .. } => client,
            Carrier::DeviceNet(link) => link.client(),
        }
    }

    /// The in-process simulator, if that is what carries the image.
    fn sim(&mut self) -> Option<&mut SimulatedCpos> {
        match &mut self.carrier {
            Carrier::Local { sim, .. } => Some(&mut **sim),
            Carrier::DeviceNet(_) => None,
        }
    }

    fn elapsed(&self) -> Duration {
        self.now.saturating_duration_since(self.start)
    }

    fn cycle(&mut self) {
        match &mut self.carrier {
            Carrier::Local { client, sim } => {
                self.now += CYCLE;
                let now = self.now;
                if is_due(sim.poll_timeout(), now) {
                    sim.handle_timeout(now);
                }
                sim.handle_master_image(now, &client.image());
                while let Some(d) = sim.poll_diagnostic() {
                    client.handle_diagnostic(now, d);
                }
                client.handle_image(now, &sim.device_image());
                if is_due(client.poll_timeout(), now) {
                    client.handle_timeout(now);
                }
                while let Some(e) = client.poll_event() {
                    self.events.push((now, e));
                }
            }
            Carrier::DeviceNet(link) => {
                let until = self.now + CYCLE;
                link.pump(until, &mut self.events);
                self.now = link.now();
            }
        }
    }

    /// Runs until the request completed; returns its result.
    fn wait(&mut self, id: RequestId) -> Result<Reply, Failure> {
        loop {
            if let Some(r) = self.events.iter().find_map(|(_, e)| match e {
                Event::Completed { id: i, result } if *i == id => Some(*result),
                _ => None,
            }) {
                return r;
            }
            self.cycle();
        }
    }

    /// Runs until the client is idle (an action it watches has ended).
    fn settle(&mut self) {
        while !self.client().is_idle() {
            self.cycle();
        }
        for _ in 0..10 {
            self.cycle();
        }
    }
}

fn find_param(name: &str) -> Option<&'static ParamDef> {
    let t = name.trim();
    let as_id = t
        .strip_prefix("0x")
        .or_else(|| t.strip_prefix("0X"))
        .and_then(|h| u16::from_str_radix(h, 16).ok())
        .and_then(params::by_id);
    as_id.or_else(|| params::by_name(t))
}

/// Reports a failure as every command does: text or (`--json`) one JSON object on stderr, exit 2
/// for a usage error and 1 for another.
fn fail(e: CliError) -> ExitCode {
    e.report()
}

fn param_json(p: &ParamDef) -> Json {
    let kind = match p.kind {
        ValueKind::Number(u) => json!({ "unit": format!("{u:?}") }),
        ValueKind::Enum(labels) => json!({ "labels": labels }),
        ValueKind::Integer => json!({ "integer": "enumeration unreadable in the manual" }),
    };
    json!({
        "name": p.name, "id": p.id.0, "access": format!("{:?}", p.access),
        "min": p.min, "max": p.max, "kind": kind,
        "process_controller_only": p.process_controller_only,
    })
}

pub(crate) fn run(args: CposArgs, iface: Option<&str>, global: Global) -> ExitCode {
    let CposArgs { sim, dn, command } = args;
    let bench = || Bench::new(&sim, &dn, iface);
    match command {
        CposCommand::Params => {
            if global.json {
                let all: Vec<Json> = PARAMETERS.iter().map(param_json).collect();
                crate::outln(&Json::Array(all).to_string());
            } else {
                for p in PARAMETERS {
                    let what = match p.kind {
                        ValueKind::Enum(l) => l.join(", "),
                        ValueKind::Integer => "integer (labels unreadable)".to_owned(),
                        ValueKind::Number(u) => {
                            let (_, sym) = u.scale();
                            format!("{} .. {} {sym}", p.display(p.min), p.display(p.max))
                        }
                    };
                    crate::outln(&format!(
                        "{:<14} 0x{:04X} {:>5} {:<5} [{}..{}] {what}",
                        p.name,
                        p.id.0,
                        p.id.0,
                        format!("{:?}", p.access),
                        p.min,
                        p.max
                    ));
                }
            }
            ExitCode::SUCCESS
        }
        CposCommand::Get { name } => {
            let Some(p) = find_param(&name) else {
                return fail(CliError::Argument(format!("no parameter {name:?}")));
            };
            let mut b = match bench() {
                Ok(b) => b,
                Err(e) => return fail(e),
            };
            let now = b.now;
            let id = match b.client().get(now, p.id) {
                Ok(id) => id,
                Err(e) => return fail(CliError::Device(e.to_string())),
            };
            report_value(global, p, b.wait(id))
        }
        CposCommand::Set { name, value } => {
            let Some(p) = find_param(&name) else {
                return fail(CliError::Argument(format!("no parameter {name:?}")));
            };
            let Some(v) = p.parse_value(&value) else {
                return fail(CliError::Argument(format!(
                    "{value:?} is not a value of {}",
                    p.name
                )));
            };
            let mut b = match bench() {
                Ok(b) => b,
                Err(e) => return fail(e),
            };
            let now = b.now;
            let id = match b.client().set(now, p.id, v) {
                Ok(id) => id,
                Err(e) => return fail(CliError::Device(format!("{}: {e}", p.name))),
            };
            report_value(global, p, b.wait(id))
        }
        CposCommand::Action {
            action,
            function,
            pwm,
            fault,
            fault_step,
        } => {
            let request = match build_action(action, function, pwm) {
                Ok(r) => r,
                Err(e) => return fail(e),
            };
            if fault.is_some() && (iface.is_some() || dn.over_devicenet) {
                return fail(CliError::Argument(
                    "--fault needs the in-process simulator (without --iface and --over-devicenet)"
                        .into(),
                ));
            }
            let mut b = match bench() {
                Ok(b) => b,
                Err(e) => return fail(e),
            };
            if let (Some(code), Some(sim)) = (fault, b.sim()) {
                sim.inject_fault(request.action(), fault_step, ErrorCode(code));
            }
            run_action(&mut b, global, request)
        }
        CposCommand::Errors => match bench() {
            Ok(mut b) => errors(&mut b, global),
            Err(e) => fail(e),
        },
        CposCommand::Demo => match bench() {
            Ok(b) => demo(b, global),
            Err(e) => fail(e),
        },
        CposCommand::Simulate { duration } => {
            over_devicenet::simulate(&sim, &dn, iface, duration, global)
        }
    }
}

fn report_value(global: Global, p: &ParamDef, r: Result<Reply, Failure>) -> ExitCode {
    match r {
        Ok(Reply::Value { value, .. }) => {
            if global.json {
                let label = p.label(value);
                crate::outln(&json!({ "ok": true, "name": p.name, "id": p.id.0, "value": value, "label": label }).to_string());
            } else {
                crate::outln(&format!(
                    "{} (0x{:04X}) = {}",
                    p.name,
                    p.id.0,
                    p.display(value)
                ));
            }
            ExitCode::SUCCESS
        }
        Ok(other) => fail(CliError::Device(format!("unexpected reply {other:?}"))),
        Err(e) => fail(CliError::Device(format!("{}: {e}", p.name))),
    }
}

fn build_action(a: ActionArg, f: Option<FunctionArg>, pwm: u16) -> Result<ActionRequest, CliError> {
    use FunctionArg as F;
    let run = |f: Option<F>| match f {
        None | Some(F::Start) => Ok(RunFunction::Start),
        Some(F::Cancel) => Ok(RunFunction::Cancel),
        Some(F::Acknowledge) => Ok(RunFunction::AcknowledgeError),
        Some(other) => Err(CliError::Argument(format!(
            "{other:?} is not a function of this action (start, cancel, acknowledge)"
        ))),
    };
    let go = |f: Option<F>| match f {
        None | Some(F::Approach) | Some(F::Start) => Ok(GoFunction::Approach),
        Some(F::Adopt) => Ok(GoFunction::Adopt),
        Some(F::Cancel) => Ok(GoFunction::Cancel),
        Some(other) => Err(CliError::Argument(format!(
            "{other:?} is not a function of GoClose/GoOpen (approach, adopt, cancel)"
        ))),
    };
    Ok(match a {
        ActionArg::NoInit => {
            let p = Pwm::new(pwm).map_err(|e| CliError::Rejected {
                what: "--pwm".into(),
                source: Box::new(e),
            })?;
            ActionRequest::NoInit(match f {
                None | Some(F::OpenSlow) => NoInitFunction::OpenSlow,
                Some(F::Stop) => NoInitFunction::Stop,
                Some(F::OpenFast) => NoInitFunction::OpenFast,
                Some(F::CloseSlow) => NoInitFunction::CloseSlow,
                Some(F::CloseFast) => NoInitFunction::CloseFast,
                Some(F::OpenPwm) => NoInitFunction::OpenPwm(p),
                Some(F::ClosePwm) => NoInitFunction::ClosePwm(p),
                Some(F::End) => NoInitFunction::EndEvent,
                Some(other) => {
                    return Err(CliError::Argument(format!(
                        "{other:?} is not a NoInit function"
                    )));
                }
            })
        }
        ActionArg::ClearErrorList => ActionRequest::ClearErrorList,
        ActionArg::SetDefault => ActionRequest::SetDefault,
        ActionArg::InitValve => ActionRequest::InitValve(run(f)?),
        ActionArg::GoClose => ActionRequest::GoClose(go(f)?),
        ActionArg::GoOpen => ActionRequest::GoOpen(go(f)?),
        ActionArg::FindFunction => ActionRequest::FindFunction(match f {
            None | Some(F::Start) => FindFunctionFunction::Activate,
            Some(F::Cancel) => FindFunctionFunction::Cancel,
            Some(other) => {
                return Err(CliError::Argument(format!(
                    "{other:?} is not a function of find function (start, cancel)"
                )));
            }
        }),
        ActionArg::AdjustTime => ActionRequest::AdjustTime(run(f)?),
        ActionArg::FindCoefficient => ActionRequest::FindCoefficient(run(f)?),
        ActionArg::InitPilot => ActionRequest::InitPilot(run(f)?),
    })
}

/// Seconds since the bench was ready.
fn secs(b: &Bench, t: Instant) -> f64 {
    t.saturating_duration_since(b.start).as_micros() as f64 / 1e6
}

/// Starts `request`, follows its progress; a NoInit motion or a GoClose/GoOpen approach runs for
/// 2 s and is then ended (end event / adopt); an error is acknowledged.
fn run_action(b: &mut Bench, global: Global, request: ActionRequest) -> ExitCode {
    let action = request.action();
    let now = b.now;
    let id = match b.client().action(now, request) {
        Ok(id) => id,
        Err(e) => return fail(CliError::Device(e.to_string())),
    };
    let first = b.wait(id);
    if let Err(e) = first {
        let msg = match e {
            Failure::Refused(Refusal::Diagnostic(d)) => format!("{action}: refused, {d}"),
            other => format!("{action}: {other}"),
        };
        return fail(CliError::Device(msg));
    }
    let mut acknowledged = false;
    let mut followups = 0;
    while b.client().active_action() == Some(action) && followups < 4 {
        let before = b.events.len();
        b.cycle();
        let waiting = b.events[before..].iter().find_map(|(_, e)| match e {
            Event::ActionProgress { status, .. } => match status.phase() {
                canola_gemu::action::Phase::WaitingForAcknowledge(c) => Some(c),
                _ => None,
            },
            _ => None,
        });
        let open_ended = matches!(
            request,
            ActionRequest::NoInit(_)
                | ActionRequest::GoClose(GoFunction::Approach)
                | ActionRequest::GoOpen(GoFunction::Approach)
        );
        let next = if waiting.is_some() && !acknowledged {
            acknowledged = true;
            Some(match action {
                ActionId::InitValve => ActionRequest::InitValve(RunFunction::AcknowledgeError),
                ActionId::AdjustTime => ActionRequest::AdjustTime(RunFunction::AcknowledgeError),
                ActionId::FindCoefficient => {
                    ActionRequest::FindCoefficient(RunFunction::AcknowledgeError)
                }
                _ => ActionRequest::InitPilot(RunFunction::AcknowledgeError),
            })
        } else if open_ended && b.elapsed() >= Duration::from_millis(2_000) {
            Some(match action {
                ActionId::NoInit => ActionRequest::NoInit(NoInitFunction::EndEvent),
                ActionId::GoClose => ActionRequest::GoClose(GoFunction::Adopt),
                ActionId::GoOpen => ActionRequest::GoOpen(GoFunction::Adopt),
                _ => break,
            })
        } else if !open_ended
            && b.client().active_action().is_some()
            && b.elapsed() >= Duration::from_millis(120_000)
        {
            let now = b.now;
            let _ = b.client().quit(now);
            None
        } else {
            None
        };
        if let Some(r) = next {
            followups += 1;
            let now = b.now;
            if let Ok(id) = b.client().action(now, r) {
                let _ = b.wait(id);
            }
        }
    }
    b.settle();
    print_events(b, global, action)
}

fn print_events(b: &Bench, global: Global, action: ActionId) -> ExitCode {
    let mut ok = true;
    let mut lines = Vec::new();
    for (t, e) in &b.events {
        match e {
            Event::ActionProgress { action: a, status } if *a == action => {
                lines.push(json!({ "t": secs(b, *t), "event": "progress", "status": status.to_string(), "value": status.to_value() }));
            }
            Event::ActionEnded { action: a, outcome } if *a == action => {
                let text = match outcome {
                    ActionOutcome::Ended(s) => {
                        ok &= matches!(s.phase(), canola_gemu::action::Phase::Ended);
                        format!("ended: {s}")
                    }
                    ActionOutcome::Quit => "quit".to_owned(),
                    ActionOutcome::TimedOut => {
                        ok = false;
                        "timed out".to_owned()
                    }
                };
                lines.push(json!({ "t": secs(b, *t), "event": "ended", "outcome": text }));
            }
            Event::ParameterChanged { param, value } => {
                let name = param.def().map_or("?", |p| p.name);
                lines.push(json!({ "t": secs(b, *t), "event": "parameter", "name": name, "id": param.0, "value": value }));
            }
            _ => {}
        }
    }
    if global.json {
        crate::outln(
            &json!({ "ok": ok, "action": action.to_string(), "events": lines }).to_string(),
        );
    } else {
        for l in &lines {
            let t = l["t"].as_f64().unwrap_or(0.0);
            let text = match l["event"].as_str() {
                Some("progress") => format!(
                    "{action}: {} (0x{:08X})",
                    l["status"].as_str().unwrap_or(""),
                    l["value"].as_u64().unwrap_or(0)
                ),
                Some("ended") => format!("{action}: {}", l["outcome"].as_str().unwrap_or("")),
                _ => format!(
                    "parameter {} (0x{:04X}) changed to {}",
                    l["name"].as_str().unwrap_or(""),
                    l["id"].as_u64().unwrap_or(0),
                    l["value"]
                ),
            };
            crate::outln(&format!("[{t:>7.2} s] {text}"));
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn errors(b: &mut Bench, global: Global) -> ExitCode {
    let mut list = Vec::new();
    for pos in 0..=u16::MAX {
        let now = b.now;
        let Ok(id) = b.client().read_error_list(now, pos) else {
            break;
        };
        match b.wait(id) {
            Ok(Reply::ErrorList {
                entry: ErrorEntry::Entry(c),
                ..
            }) if c != ErrorCode::NONE => list.push(c),
            _ => break,
        }
    }
    let mut active = |warnings: bool| {
        let mut out = Vec::new();
        let mut n = 1u16;
        loop {
            let now = b.now;
            let id = if warnings {
                b.client().active_warnings(now, n)
            } else {
                b.client().active_errors(now, n)
            };
            let Ok(id) = id else { break };
            match b.wait(id) {
                Ok(
                    Reply::ActiveErrors { count, code, .. }
                    | Reply::ActiveWarnings { count, code, .. },
                ) => {
                    if n > count {
                        break;
                    }
                    out.push(code);
                }
                _ => break,
            }
            n += 1;
        }
        out
    };
    let errors = active(false);
    let warnings = active(true);
    let j = |v: &[ErrorCode]| -> Vec<Json> {
        v.iter()
            .map(|c| json!({ "code": c.0, "name": c.name(), "meaning": c.meaning() }))
            .collect()
    };
    if global.json {
        crate::outln(&json!({ "error_list": j(&list), "active_errors": j(&errors), "active_warnings": j(&warnings) }).to_string());
    } else {
        crate::outln("error list (newest first):");
        if list.is_empty() {
            crate::outln("  000: NO ERROR");
        }
        for (i, c) in list.iter().enumerate() {
            crate::outln(&format!(
                "  {i}: {c} - {}",
                c.meaning().unwrap_or("unknown")
            ));
        }
        crate::outln(&format!(
            "active errors: {}",
            errors
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
        crate::outln(&format!(
            "active warnings: {}",
            warnings
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    ExitCode::SUCCESS
}

fn demo(mut b: Bench, global: Global) -> ExitCode {
    if !global.json {
        let what = match b.carrier {
            Carrier::Local { .. } => "simulated positioner, virtual time",
            Carrier::DeviceNet(_) => "over DeviceNet",
        };
        crate::outln(&format!("GEMÜ 1436 cPos demo ({what}): init valve"));
    }
    let code = run_action(&mut b, global, ActionRequest::InitValve(RunFunction::Start));
    if !global.json
        && code == ExitCode::SUCCESS
        && let Some(sim) = b.sim()
    {
        crate::outln(&format!("valve initialised: {}", sim.is_initialised()));
    }
    code
}
