//! Network boot-up the CiA 302-2 way: every slave at once (the facade runs different nodes' SDOs
//! in parallel), each through the "boot slave" steps — device present (0x1000), identity (0x1000
//! and 0x1018 against the expected values), for a keep-alive slave the node state by its
//! heartbeat or guarding (an operational slave is left running: no reset, no configuration,
//! code L; any other gets NMT reset communication), the application software version (0x1F52
//! against the expected date and time, with the CiA 302-3 program download through 0x1F51
//! program control and 0x1F50 program data when an update is needed and allowed), configuration
//! (the DCF's values, skipped when 0x1020 already holds the DCF's configuration date and time;
//! 0x1020 written last), error control start (heartbeat consumer from 0x1017, or node guarding)
//! — then NMT start, per slave or all together once every mandatory slave has booted.

use std::time::Instant as WallInstant;

use canola::nmt::GuardingEvent;
use canola::od::AccessType;
use canola::{
    CommandSpecifier, Duration, HeartbeatEvent, Instant, Network, NetworkEvent, NodeId,
    ObjectAddress, Pending, SdoError, SdoErrorKind, Value,
};

use crate::codes::BootErrorCode;
use crate::config::{ErrorControl, NetworkConfig, SlaveConfig, StartPolicy};

/// The steps of booting one slave (CiA 302-2 "boot slave").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BootStep {
    /// Reading the device type 0x1000: is the device there?
    DevicePresent,
    /// Comparing 0x1000 and 0x1018 against the expected identity.
    Identity,
    /// Keep-alive slaves: learning the node state from its heartbeat or guarding answer.
    NodeState,
    /// Comparing the application software 0x1F52 with the expected one, downloading the
    /// program when needed and allowed.
    Software,
    /// Writing the DCF's values (or finding them in place by 0x1020).
    Configuration,
    /// Starting the heartbeat consumer or node guarding.
    ErrorControl,
    /// NMT start.
    Start,
}

impl BootStep {
    /// The step's name in reports (`device-present`, `identity`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::DevicePresent => "device-present",
            Self::Identity => "identity",
            Self::NodeState => "node-state",
            Self::Software => "software",
            Self::Configuration => "configuration",
            Self::ErrorControl => "error-control",
            Self::Start => "start",
        }
    }
}

/// Where a slave ended up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlaveStatus {
    /// Booted and started.
    Operational,
    /// Booted, not started (start policy `none`, or a mandatory slave failed).
    PreOperational,
    /// Answered, but a boot step failed.
    Failed,
    /// Never answered.
    Absent,
}

impl SlaveStatus {
    /// The status word of reports (`operational`, `pre-operational`, `failed`, `absent`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Operational => "operational",
            Self::PreOperational => "pre-operational",
            Self::Failed => "failed",
            Self::Absent => "absent",
        }
    }
}

/// How a slave's configuration step went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConfigOutcome {
    /// Not reached.
    #[default]
    NotRun,
    /// This many values were written.
    Written(usize),
    /// Skipped: 0x1020 already held the DCF's configuration date and time.
    Verified,
}

/// How a slave's software check went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SoftwareOutcome {
    /// Not asked for, or not reached.
    #[default]
    NotChecked,
    /// 0x1F52 matched the expected date and time.
    Verified,
    /// The program was downloaded and 0x1F52 matches now.
    Updated,
}

/// The boot of one slave.
#[derive(Debug, Clone, PartialEq)]
pub struct SlaveReport {
    /// The slave.
    pub node_id: NodeId,
    /// Whether it is mandatory.
    pub mandatory: bool,
    /// Where it ended up.
    pub status: SlaveStatus,
    /// On failure, the CiA 302-2 boot error code.
    pub error_code: Option<BootErrorCode>,
    /// On failure, the step that failed.
    pub step: Option<BootStep>,
    /// On failure, the object the step was at.
    pub object: Option<ObjectAddress>,
    /// On failure, the SDO abort code (sent by the slave, or by the master on a timeout).
    pub abort_code: Option<u32>,
    /// On failure, what happened in words.
    pub detail: Option<String>,
    /// The software check.
    pub software: SoftwareOutcome,
    /// The configuration step.
    pub configuration: ConfigOutcome,
    /// The error control started (`heartbeat 150 ms`, `guarding 100 ms x 3`), if any.
    pub error_control: Option<String>,
    /// Network time the slave's boot took.
    pub elapsed: Duration,
}

/// The boot of the network.
#[derive(Debug, Clone, PartialEq)]
pub struct BootReport {
    /// Per slave, in description order.
    pub slaves: Vec<SlaveReport>,
    /// Whether every mandatory slave booted (so the network may run).
    pub mandatory_ok: bool,
    /// Network time of the whole boot, first request to the last start.
    pub elapsed: Duration,
    /// Wall-clock time of the whole boot.
    pub wall: std::time::Duration,
}

/// Progress of a boot: a slave started or finished a step.
#[derive(Debug, Clone, PartialEq)]
pub enum BootEvent {
    /// A step began.
    StepStarted {
        /// The slave.
        node: NodeId,
        /// The step.
        step: BootStep,
    },
    /// A step succeeded.
    StepDone {
        /// The slave.
        node: NodeId,
        /// The step.
        step: BootStep,
    },
    /// A step failed; the slave's boot ends here.
    StepFailed {
        /// The slave.
        node: NodeId,
        /// The step.
        step: BootStep,
        /// The CiA 302-2 code.
        code: BootErrorCode,
        /// What happened.
        detail: String,
    },
    /// A slave's boot is over.
    SlaveDone(SlaveReport),
}

/// A failed step, as the slave's boot thread ends with it.
struct Failure {
    step: BootStep,
    code: BootErrorCode,
    object: Option<ObjectAddress>,
    abort: Option<u32>,
    detail: String,
    absent: bool,
}

impl Failure {
    fn sdo(step: BootStep, code: BootErrorCode, e: &SdoError) -> Self {
        Self {
            step,
            code,
            object: Some(e.entry),
            abort: e.abort_code().map(|c| c.get()),
            detail: e.to_string(),
            absent: false,
        }
    }
}

/// What the network reported since the last poll, by node.
#[derive(Default)]
struct Seen {
    /// A state change or recovery by heartbeat or guarding: the node is alive.
    life: Vec<NodeId>,
    /// A boot-up message.
    boot_ups: Vec<NodeId>,
}

impl SlaveReport {
    /// Whether the slave booted: no error code, or L (operational already, left running).
    pub fn booted(&self) -> bool {
        match self.error_code {
            None => matches!(
                self.status,
                SlaveStatus::PreOperational | SlaveStatus::Operational
            ),
            Some(code) => code == BootErrorCode::L,
        }
    }
}

/// Boots the network `net` as `config` describes; blocks until done.
pub fn boot(net: &Network, config: &NetworkConfig) -> BootReport {
    boot_with(net, config, |_| {})
}

/// How finely the boot loop drives the network between looking at its slaves' requests: a
/// finished SDO is followed up at most this late.
const TICK: Duration = Duration::from_micros(20);

/// [`boot`], calling `on_event` for every step of every slave.
///
/// One thread drives every slave's boot: each slave is a small machine with at most one SDO
/// request in flight, and the facade runs requests to different nodes together on the bus. (One
/// thread rather than one per slave keeps a virtual-clock bus deterministic.)
pub fn boot_with(
    net: &Network,
    config: &NetworkConfig,
    mut on_event: impl FnMut(&BootEvent),
) -> BootReport {
    let wall = WallInstant::now();
    let t0 = net.now();
    for s in &config.slaves {
        net.add_node_with_dictionary(s.node_id, s.dictionary.clone());
    }
    let individually = config.master.start == StartPolicy::Individually;
    if individually && let Some(p) = config.master.sync_period {
        net.start_sync(p);
    }
    let events = net.subscribe();
    let mut seen = Seen::default();
    let mut slaves: Vec<SlaveBoot<'_>> = config
        .slaves
        .iter()
        .map(|s| SlaveBoot::new(net, config, s, individually))
        .collect();
    loop {
        for ev in events.try_iter() {
            match ev {
                NetworkEvent::Heartbeat(
                    HeartbeatEvent::StateChanged { node, .. }
                    | HeartbeatEvent::Recovered { node, .. },
                )
                | NetworkEvent::Guarding(
                    GuardingEvent::StateChanged { node, .. }
                    | GuardingEvent::Recovered { node, .. },
                ) => seen.life.push(node),
                NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node })
                | NetworkEvent::Guarding(GuardingEvent::BootUp { node }) => {
                    seen.boot_ups.push(node)
                }
                _ => {}
            }
        }
        let mut running = false;
        for s in &mut slaves {
            s.poll(&mut seen, &mut on_event);
            running |= !s.finished;
        }
        seen.life.clear();
        seen.boot_ups.clear();
        if !running {
            break;
        }
        if net.run_for(TICK).is_err() {
            // A failed transport fails every request, which the next poll reports.
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
    let mut reports: Vec<SlaveReport> = slaves.into_iter().map(|s| s.report).collect();

    let mandatory_ok = reports.iter().all(|r| !r.mandatory || r.booted());
    if config.master.start == StartPolicy::All && mandatory_ok {
        if let Some(p) = config.master.sync_period {
            net.start_sync(p);
        }
        let all_booted = reports.iter().all(SlaveReport::booted);
        // A broadcast when every slave booted; otherwise only the booted ones, so a slave that
        // failed its checks is not started unconfigured.
        let started = if all_booted {
            net.nmt_all(CommandSpecifier::Start).is_ok()
        } else {
            reports
                .iter()
                .filter(|r| r.status == SlaveStatus::PreOperational)
                .all(|r| net.node(r.node_id).nmt().start().is_ok())
        };
        if started {
            for r in &mut reports {
                if r.status == SlaveStatus::PreOperational {
                    r.status = SlaveStatus::Operational;
                    on_event(&BootEvent::StepDone {
                        node: r.node_id,
                        step: BootStep::Start,
                    });
                }
            }
        }
    }
    let mandatory_ok = reports.iter().all(|r| !r.mandatory || r.booted());
    BootReport {
        slaves: reports,
        mandatory_ok,
        elapsed: net.now().saturating_duration_since(t0),
        wall: wall.elapsed(),
    }
}

/// An error control parameter (0x1017, 0x100C, 0x100D): from the DCF, or being read.
enum Param {
    Known(u32),
    Reading(Pending<Vec<u8>>),
}

/// Where one slave's boot is.
enum Phase {
    /// Reading 0x1000, retried until `deadline`.
    Present(Pending<Vec<u8>>, Instant),
    /// Reading 0x1018 sub `checks[i]`.
    Identity(usize, Pending<Vec<u8>>),
    /// Looking for the next identity check.
    NextIdentity(usize),
    /// Keep-alive: waiting for a heartbeat (or guarding answer) after `since` that tells the
    /// node state, until `deadline`.
    NodeState {
        since: Instant,
        deadline: Instant,
        guarding: bool,
    },
    /// NMT reset communication sent: waiting for the boot-up until `deadline`.
    AwaitBootUp { deadline: Instant, guarding: bool },
    /// Reading 0x1F52:01 and :02 (`true`: after a program download).
    SoftwareVersion(Pending<Vec<u8>>, Pending<Vec<u8>>, bool),
    /// Program download step `i` (stop, clear, program data, start).
    Download(usize, Pending<()>),
    /// Starting program download step `i`.
    NextDownload(usize),
    /// Reading 0x1020:01 and :02 to see whether the configuration is in place.
    Verify(Pending<Vec<u8>>, Pending<Vec<u8>>),
    /// Writing `writes[i]`.
    Write(usize, Pending<()>),
    /// Starting the next write.
    NextWrite(usize),
    /// Collecting 0x1017, 0x100C, 0x100D.
    ErrorControl([Param; 3]),
    /// Waiting for the first heartbeat (or guarding answer) after the first instant, until the
    /// second.
    AwaitLife(Instant, Instant, String),
    /// Boot over (report filled in).
    Over,
}

struct SlaveBoot<'a> {
    net: &'a Network,
    config: &'a NetworkConfig,
    slave: &'a SlaveConfig,
    start: bool,
    /// The checks of 0x1018: (sub-index, expected, code).
    checks: Vec<(u8, u32, BootErrorCode)>,
    /// The configuration, 0x1020 last.
    writes: Vec<(ObjectAddress, Value)>,
    phase: Phase,
    t0: Instant,
    report: SlaveReport,
    finished: bool,
    started_event: bool,
    /// Keep-alive found the slave operational: it is left running (code L).
    initially_operational: bool,
}

fn to_u32(bytes: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    let n = bytes.len().min(4);
    b[..n].copy_from_slice(&bytes[..n]);
    u32::from_le_bytes(b)
}

impl<'a> SlaveBoot<'a> {
    fn new(
        net: &'a Network,
        config: &'a NetworkConfig,
        slave: &'a SlaveConfig,
        start: bool,
    ) -> Self {
        let id = &slave.identity;
        let checks = [
            (1u8, id.vendor_id, BootErrorCode::D),
            (2, id.product_code, BootErrorCode::M),
            (3, id.revision, BootErrorCode::N),
            (4, id.serial, BootErrorCode::O),
        ]
        .into_iter()
        .filter_map(|(sub, e, c)| e.map(|e| (sub, e, c)))
        .collect();
        let mut writes = configured_values(slave);
        if let Some((date, time)) = verify_stamp(slave) {
            writes.push((ObjectAddress::new(0x1020, 1), Value::Unsigned32(date)));
            writes.push((ObjectAddress::new(0x1020, 2), Value::Unsigned32(time)));
        }
        let mut this = Self {
            net,
            config,
            slave,
            start,
            checks,
            writes,
            phase: Phase::Over,
            t0: net.now(),
            report: SlaveReport {
                node_id: slave.node_id,
                mandatory: slave.mandatory,
                status: SlaveStatus::PreOperational,
                error_code: None,
                step: None,
                object: None,
                abort_code: None,
                detail: None,
                software: SoftwareOutcome::NotChecked,
                configuration: ConfigOutcome::NotRun,
                error_control: None,
                elapsed: Duration::ZERO,
            },
            finished: false,
            started_event: false,
            initially_operational: false,
        };
        let deadline = net.now() + config.master.boot_timeout;
        this.phase = Phase::Present(this.read(ObjectAddress::new(0x1000, 0)), deadline);
        this
    }

    fn sdo(&self) -> canola::Sdo {
        self.net
            .node(self.slave.node_id)
            .sdo()
            .timeout(self.config.master.sdo_timeout)
    }

    fn read(&self, addr: ObjectAddress) -> Pending<Vec<u8>> {
        self.sdo().submit_read(addr)
    }

    /// The DCF's value of an error control parameter, else a read of it.
    fn param(&self, index: u16) -> Param {
        let dcf = self
            .slave
            .dictionary
            .sub(index, 0)
            .and_then(|s| s.parameter_value())
            .and_then(|f| f.resolve(self.slave.node_id.get()))
            .and_then(|v| v.as_i128());
        match dcf {
            Some(v) => Param::Known(v as u32),
            None => Param::Reading(self.read(ObjectAddress::new(index, 0))),
        }
    }

    fn poll(&mut self, seen: &mut Seen, on_event: &mut impl FnMut(&BootEvent)) {
        if self.finished {
            return;
        }
        let node = self.slave.node_id;
        if !self.started_event {
            self.started_event = true;
            on_event(&BootEvent::StepStarted {
                node,
                step: BootStep::DevicePresent,
            });
        }
        // Several steps may finish in one poll (a skipped check, a value known from the DCF).
        loop {
            let phase = std::mem::replace(&mut self.phase, Phase::Over);
            match self.advance(phase, seen, on_event) {
                Ok(Some(next)) => {
                    let waiting = self.is_waiting(&next);
                    self.phase = next;
                    if waiting {
                        return;
                    }
                }
                Ok(None) => {
                    self.finish(None, on_event);
                    return;
                }
                Err(f) => {
                    self.finish(Some(f), on_event);
                    return;
                }
            }
        }
    }

    /// Whether the phase waits on the bus (its request is not done yet).
    fn is_waiting(&self, phase: &Phase) -> bool {
        match phase {
            Phase::Present(p, _) | Phase::Identity(_, p) => !p.is_done(),
            Phase::Verify(a, b) => !(a.is_done() && b.is_done()),
            Phase::Write(_, p) => !p.is_done(),
            Phase::ErrorControl(ps) => ps
                .iter()
                .any(|p| matches!(p, Param::Reading(r) if !r.is_done())),
            Phase::SoftwareVersion(a, b, _) => !(a.is_done() && b.is_done()),
            Phase::Download(_, p) => !p.is_done(),
            Phase::AwaitLife(..) | Phase::NodeState { .. } | Phase::AwaitBootUp { .. } => true,
            Phase::NextIdentity(_) | Phase::NextWrite(_) | Phase::NextDownload(_) | Phase::Over => {
                false
            }
        }
    }

    fn finish(&mut self, failure: Option<Failure>, on_event: &mut impl FnMut(&BootEvent)) {
        self.finished = true;
        if let Some(f) = failure {
            on_event(&BootEvent::StepFailed {
                node: self.slave.node_id,
                step: f.step,
                code: f.code,
                detail: f.detail.clone(),
            });
            self.report.status = if f.absent {
                SlaveStatus::Absent
            } else {
                SlaveStatus::Failed
            };
            self.report.error_code = Some(f.code);
            self.report.step = Some(f.step);
            self.report.object = f.object;
            self.report.abort_code = f.abort;
            self.report.detail = Some(f.detail);
        }
        self.report.elapsed = self.net.now().saturating_duration_since(self.t0);
        on_event(&BootEvent::SlaveDone(self.report.clone()));
    }

    fn step_done(
        &self,
        step: BootStep,
        next: Option<BootStep>,
        on_event: &mut impl FnMut(&BootEvent),
    ) {
        let node = self.slave.node_id;
        on_event(&BootEvent::StepDone { node, step });
        if let Some(step) = next {
            on_event(&BootEvent::StepStarted { node, step });
        }
    }

    /// One step of the machine: the next phase, `None` when the boot is over.
    fn advance(
        &mut self,
        phase: Phase,
        seen: &mut Seen,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Option<Phase>, Failure> {
        let node = self.slave.node_id;
        if self.is_waiting(&phase) {
            let now = self.net.now();
            let heard_since =
                |since: Instant| self.net.last_heartbeat(node).is_some_and(|t| t > since);
            match &phase {
                Phase::NodeState {
                    since,
                    deadline,
                    guarding,
                } => {
                    let alive = if *guarding {
                        seen.life.contains(&node)
                    } else {
                        heard_since(*since)
                    };
                    if alive {
                        return self.node_state_known(*guarding, on_event).map(Some);
                    }
                    if now >= *deadline {
                        return Err(
                            self.no_state(*guarding, "no answer with the node state in time")
                        );
                    }
                }
                Phase::AwaitBootUp { deadline, guarding } => {
                    if seen.boot_ups.contains(&node) {
                        self.step_done(BootStep::NodeState, None, on_event);
                        return self.begin_software(on_event).map(Some);
                    }
                    if now >= *deadline {
                        return Err(
                            self.no_state(*guarding, "no boot-up after NMT reset communication")
                        );
                    }
                }
                _ => {}
            }
            if let Phase::AwaitLife(since, deadline, what) = &phase {
                let heartbeat = what.starts_with("heartbeat");
                if seen.life.contains(&node) || (heartbeat && heard_since(*since)) {
                    self.report.error_control = Some(what.clone());
                    return self.error_control_done(on_event);
                }
                if self.net.now() >= *deadline {
                    let guarding = what.starts_with("guarding");
                    return Err(Failure {
                        step: BootStep::ErrorControl,
                        code: if guarding {
                            BootErrorCode::F
                        } else {
                            BootErrorCode::K
                        },
                        object: Some(ObjectAddress::new(
                            if guarding { 0x100C } else { 0x1017 },
                            0,
                        )),
                        abort: None,
                        detail: format!("{what}: no sign of life in time"),
                        absent: false,
                    });
                }
            }
            return Ok(Some(phase));
        }
        Ok(Some(match phase {
            Phase::Present(p, deadline) => match p.wait() {
                Ok(bytes) => {
                    let device_type = to_u32(&bytes);
                    self.step_done(BootStep::DevicePresent, Some(BootStep::Identity), on_event);
                    if let Some(expected) = self.slave.identity.device_type
                        && expected != device_type
                    {
                        return Err(mismatch(
                            BootErrorCode::C,
                            ObjectAddress::new(0x1000, 0),
                            expected,
                            device_type,
                        ));
                    }
                    Phase::NextIdentity(0)
                }
                Err(e) if is_timeout(&e) && self.net.now() < deadline => {
                    Phase::Present(self.read(ObjectAddress::new(0x1000, 0)), deadline)
                }
                Err(e) => {
                    let mut f = Failure::sdo(BootStep::DevicePresent, BootErrorCode::B, &e);
                    f.absent = is_timeout(&e);
                    return Err(f);
                }
            },
            Phase::NextIdentity(i) => match self.checks.get(i) {
                Some(&(sub, _, _)) => {
                    Phase::Identity(i, self.read(ObjectAddress::new(0x1018, sub)))
                }
                None => {
                    self.step_done(BootStep::Identity, None, on_event);
                    if self.slave.keep_alive {
                        self.begin_node_state(on_event)
                    } else {
                        self.begin_software(on_event)?
                    }
                }
            },
            Phase::SoftwareVersion(date, time, downloaded) => {
                return self.software_version(date, time, downloaded, on_event);
            }
            Phase::NextDownload(i) => {
                let program = self
                    .slave
                    .software
                    .as_ref()
                    .and_then(|w| w.program.as_ref());
                let control = ObjectAddress::new(0x1F51, 1);
                match (i, program) {
                    (0, _) => Phase::Download(0, self.sdo().submit_write(control, 0u8)),
                    (1, _) => Phase::Download(1, self.sdo().submit_write(control, 3u8)),
                    (2, Some(p)) => Phase::Download(
                        2,
                        self.sdo()
                            .submit_write(ObjectAddress::new(0x1F50, 1), p.data.as_slice()),
                    ),
                    (3, _) => Phase::Download(3, self.sdo().submit_write(control, 1u8)),
                    _ => Phase::SoftwareVersion(
                        self.read(ObjectAddress::new(0x1F52, 1)),
                        self.read(ObjectAddress::new(0x1F52, 2)),
                        true,
                    ),
                }
            }
            Phase::Download(i, p) => match p.wait() {
                Ok(()) => Phase::NextDownload(i + 1),
                // Stopping the program may restart the device into its boot loader before it
                // confirms: a timeout there is no failure.
                Err(e) if i == 0 && is_timeout(&e) => Phase::NextDownload(1),
                Err(e) => {
                    let mut f = Failure::sdo(BootStep::Software, BootErrorCode::I, &e);
                    f.detail = format!(
                        "program download, {}: {}",
                        [
                            "stop program",
                            "clear program",
                            "program data",
                            "start program"
                        ]
                        .get(i)
                        .copied()
                        .unwrap_or("step"),
                        f.detail
                    );
                    return Err(f);
                }
            },
            Phase::Identity(i, p) => {
                let (sub, expected, code) = self.checks[i];
                let actual = to_u32(
                    &p.wait()
                        .map_err(|e| Failure::sdo(BootStep::Identity, code, &e))?,
                );
                if actual != expected {
                    return Err(mismatch(
                        code,
                        ObjectAddress::new(0x1018, sub),
                        expected,
                        actual,
                    ));
                }
                Phase::NextIdentity(i + 1)
            }
            Phase::Verify(date, time) => {
                let stamp = verify_stamp(self.slave);
                let got = (
                    date.wait().ok().map(|b| to_u32(&b)),
                    time.wait().ok().map(|b| to_u32(&b)),
                );
                if stamp.is_some_and(|(d, t)| got == (Some(d), Some(t))) {
                    self.report.configuration = ConfigOutcome::Verified;
                    self.configuration_done(on_event)
                } else {
                    Phase::NextWrite(0)
                }
            }
            Phase::NextWrite(i) => match self.writes.get(i) {
                Some((addr, value)) => Phase::Write(i, self.sdo().submit_write(*addr, value)),
                None => {
                    let n = self.writes.len()
                        - if verify_stamp(self.slave).is_some() {
                            2
                        } else {
                            0
                        };
                    self.report.configuration = ConfigOutcome::Written(n);
                    self.configuration_done(on_event)
                }
            },
            Phase::Write(i, p) => {
                p.wait()
                    .map_err(|e| Failure::sdo(BootStep::Configuration, BootErrorCode::J, &e))?;
                Phase::NextWrite(i + 1)
            }
            Phase::ErrorControl(params) => {
                let [hb, gt, lf] = params.map(|p| match p {
                    Param::Known(v) => v,
                    // An object the slave lacks counts as 0: that kind of error control is off.
                    Param::Reading(r) => r.wait().map(|b| to_u32(&b)).unwrap_or(0),
                });
                return self.start_error_control(hb, gt, lf, seen, on_event);
            }
            Phase::AwaitLife(..)
            | Phase::NodeState { .. }
            | Phase::AwaitBootUp { .. }
            | Phase::Over => return Ok(None),
        }))
    }

    /// The DCF's value of a parameter (0 when it has none).
    fn dcf_u32(&self, index: u16) -> u32 {
        self.slave
            .dictionary
            .sub(index, 0)
            .and_then(|s| s.effective_value(self.slave.node_id.get()))
            .and_then(|v| v.as_i128())
            .map_or(0, |v| v as u32)
    }

    /// Keep-alive: wait for the node to tell its state — by heartbeat when its DCF gives a
    /// producer time (within the consumer time), else by node guarding (within the life time).
    fn begin_node_state(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
        let node = self.slave.node_id;
        on_event(&BootEvent::StepStarted {
            node,
            step: BootStep::NodeState,
        });
        let now = self.net.now();
        let hb = self.dcf_u32(0x1017) & 0xFFFF;
        let (gt, lf) = (self.dcf_u32(0x100C) & 0xFFFF, self.dcf_u32(0x100D) & 0xFF);
        let guarding = hb == 0 && gt > 0 && lf > 0;
        let window = if guarding {
            self.net
                .guard_node(node, Duration::from_millis(u64::from(gt)), lf as u8);
            Duration::from_millis(u64::from(gt * lf))
        } else if hb > 0 {
            Duration::from_millis(
                u64::from(hb) * u64::from(self.config.master.heartbeat_consumer_percent) / 100,
            )
        } else {
            self.config.master.boot_timeout
        };
        Phase::NodeState {
            since: now,
            deadline: now + window,
            guarding,
        }
    }

    fn no_state(&self, guarding: bool, what: &str) -> Failure {
        Failure {
            step: BootStep::NodeState,
            code: if guarding {
                BootErrorCode::F
            } else {
                BootErrorCode::E
            },
            object: Some(ObjectAddress::new(
                if guarding { 0x100C } else { 0x1017 },
                0,
            )),
            abort: None,
            detail: format!(
                "keep-alive check by {}: {what}",
                if guarding {
                    "node guarding"
                } else {
                    "heartbeat"
                }
            ),
            absent: false,
        }
    }

    /// The node told its state: an operational slave is left running and goes straight to
    /// error control (no reset, no software or configuration check); any other is reset and
    /// booted as usual once its boot-up arrives.
    fn node_state_known(
        &mut self,
        guarding: bool,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Phase, Failure> {
        let node = self.slave.node_id;
        if self.net.last_state(node) == Some(canola::NmtState::Operational) {
            self.initially_operational = true;
            self.step_done(BootStep::NodeState, Some(BootStep::ErrorControl), on_event);
            return Ok(self.error_control_phase());
        }
        self.net
            .node(node)
            .nmt()
            .reset_communication()
            .map_err(|e| Failure {
                step: BootStep::NodeState,
                code: if guarding {
                    BootErrorCode::F
                } else {
                    BootErrorCode::E
                },
                object: None,
                abort: None,
                detail: format!("NMT reset communication could not be sent: {e}"),
                absent: false,
            })?;
        Ok(Phase::AwaitBootUp {
            deadline: self.net.now() + self.config.master.boot_timeout,
            guarding,
        })
    }

    /// The software check (0x1F81 bit 5), or straight on to the configuration.
    fn begin_software(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Result<Phase, Failure> {
        let Some(w) = &self.slave.software else {
            return Ok(self.begin_configuration(on_event));
        };
        let node = self.slave.node_id;
        on_event(&BootEvent::StepStarted {
            node,
            step: BootStep::Software,
        });
        if w.expected().is_none() {
            return Err(Failure {
                step: BootStep::Software,
                code: BootErrorCode::G,
                object: Some(ObjectAddress::new(
                    if w.date.unwrap_or(0) == 0 { 0x1F53 } else { 0x1F54 },
                    node.get(),
                )),
                abort: None,
                detail: "the software check needs the expected application software date (0x1F53) and time (0x1F54)".into(),
                absent: false,
            });
        }
        Ok(Phase::SoftwareVersion(
            self.read(ObjectAddress::new(0x1F52, 1)),
            self.read(ObjectAddress::new(0x1F52, 2)),
            false,
        ))
    }

    /// 0x1F52 read: matches (on to the configuration), or an update is needed.
    fn software_version(
        &mut self,
        date: Pending<Vec<u8>>,
        time: Pending<Vec<u8>>,
        downloaded: bool,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Option<Phase>, Failure> {
        let node = self.slave.node_id;
        let code = if downloaded {
            BootErrorCode::I
        } else {
            BootErrorCode::G
        };
        let read = |p: Pending<Vec<u8>>| {
            p.wait().map(|b| to_u32(&b)).map_err(|e| {
                let mut f = Failure::sdo(BootStep::Software, code, &e);
                f.detail = format!("application software version 0x1F52: {}", f.detail);
                f
            })
        };
        let actual = (read(date)?, read(time)?);
        let Some(w) = self.slave.software.as_ref() else {
            return Ok(Some(self.begin_configuration(on_event)));
        };
        let expected = w.expected().unwrap_or_default();
        if actual == expected {
            self.report.software = if downloaded {
                SoftwareOutcome::Updated
            } else {
                SoftwareOutcome::Verified
            };
            self.step_done(BootStep::Software, None, on_event);
            return Ok(Some(self.begin_configuration(on_event)));
        }
        let differs = format!(
            "0x1F52 is date {} time {}, expected date {} time {}",
            actual.0, actual.1, expected.0, expected.1
        );
        let fail = |code, object: ObjectAddress, detail: String| Failure {
            step: BootStep::Software,
            code,
            object: Some(object),
            abort: None,
            detail,
            absent: false,
        };
        let version = ObjectAddress::new(0x1F52, 1);
        if downloaded {
            return Err(fail(
                BootErrorCode::I,
                version,
                format!("after the program download {differs}"),
            ));
        }
        if !w.update || self.slave.keep_alive {
            let why = if w.update {
                "no update on a keep-alive slave"
            } else {
                "update not allowed (0x1F81 bit 6)"
            };
            return Err(fail(BootErrorCode::H, version, format!("{differs}; {why}")));
        }
        if w.program.is_none() {
            return Err(fail(
                BootErrorCode::G,
                ObjectAddress::new(0x1F58, node.get()),
                format!("{differs}; update allowed but no program (0x1F58) configured"),
            ));
        }
        Ok(Some(Phase::NextDownload(0)))
    }

    fn begin_configuration(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
        on_event(&BootEvent::StepStarted {
            node: self.slave.node_id,
            step: BootStep::Configuration,
        });
        match verify_stamp(self.slave) {
            Some(_) => Phase::Verify(
                self.read(ObjectAddress::new(0x1020, 1)),
                self.read(ObjectAddress::new(0x1020, 2)),
            ),
            None => Phase::NextWrite(0),
        }
    }

    fn configuration_done(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
        self.step_done(
            BootStep::Configuration,
            Some(BootStep::ErrorControl),
            on_event,
        );
        self.error_control_phase()
    }

    fn error_control_phase(&mut self) -> Phase {
        let want = self.slave.error_control;
        let hb = if matches!(want, ErrorControl::Heartbeat | ErrorControl::Auto) {
            self.param(0x1017)
        } else {
            Param::Known(0)
        };
        let guarding = matches!(want, ErrorControl::Guarding | ErrorControl::Auto);
        let (gt, lf) = if guarding {
            (self.param(0x100C), self.param(0x100D))
        } else {
            (Param::Known(0), Param::Known(0))
        };
        Phase::ErrorControl([hb, gt, lf])
    }

    fn start_error_control(
        &mut self,
        hb_ms: u32,
        guard_ms: u32,
        factor: u32,
        seen: &mut Seen,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Option<Phase>, Failure> {
        let node = self.slave.node_id;
        let hb_ms = hb_ms & 0xFFFF;
        let guard_ms = guard_ms & 0xFFFF;
        let factor = (factor & 0xFF) as u8;
        seen.life.retain(|&n| n != node);
        if self.slave.error_control == ErrorControl::None {
            return self.error_control_done(on_event);
        }
        if hb_ms > 0 {
            let consumer_ms =
                u64::from(hb_ms) * u64::from(self.config.master.heartbeat_consumer_percent) / 100;
            let consumer = Duration::from_millis(consumer_ms);
            self.net.monitor_heartbeat(node, consumer);
            return Ok(Some(Phase::AwaitLife(
                self.net.now(),
                self.net.now() + consumer,
                format!("heartbeat {consumer_ms} ms"),
            )));
        }
        if guard_ms > 0 && factor > 0 && self.slave.error_control != ErrorControl::Heartbeat {
            self.net
                .guard_node(node, Duration::from_millis(u64::from(guard_ms)), factor);
            let life = Duration::from_millis(u64::from(guard_ms) * u64::from(factor));
            return Ok(Some(Phase::AwaitLife(
                self.net.now(),
                self.net.now() + life,
                format!("guarding {guard_ms} ms x {factor}"),
            )));
        }
        if self.slave.error_control != ErrorControl::Auto {
            // Asked for, but the slave's parameters leave it off.
            return Err(Failure {
                step: BootStep::ErrorControl,
                code: if self.slave.error_control == ErrorControl::Guarding {
                    BootErrorCode::F
                } else {
                    BootErrorCode::K
                },
                object: Some(ObjectAddress::new(
                    if self.slave.error_control == ErrorControl::Guarding {
                        0x100C
                    } else {
                        0x1017
                    },
                    0,
                )),
                abort: None,
                detail: "the slave's error control parameter is 0".into(),
                absent: false,
            });
        }
        self.error_control_done(on_event)
    }

    fn error_control_done(
        &mut self,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Option<Phase>, Failure> {
        let node = self.slave.node_id;
        if self.initially_operational {
            // Left running as found: no NMT start, and the CiA 302-2 code L says why.
            self.step_done(BootStep::ErrorControl, None, on_event);
            self.report.status = SlaveStatus::Operational;
            self.report.error_code = Some(BootErrorCode::L);
            self.report.step = Some(BootStep::NodeState);
            self.report.detail = Some(
                "operational when its boot began (keep-alive): not reset, software and configuration not checked".into(),
            );
            return Ok(None);
        }
        self.step_done(
            BootStep::ErrorControl,
            self.start.then_some(BootStep::Start),
            on_event,
        );
        if self.start {
            self.net.node(node).nmt().start().map_err(|e| Failure {
                step: BootStep::Start,
                code: BootErrorCode::J,
                object: None,
                abort: None,
                detail: format!("NMT start could not be sent: {e}"),
                absent: false,
            })?;
            self.report.status = SlaveStatus::Operational;
            on_event(&BootEvent::StepDone {
                node,
                step: BootStep::Start,
            });
        }
        Ok(None)
    }
}
fn is_timeout(e: &SdoError) -> bool {
    matches!(
        e.kind,
        SdoErrorKind::Transfer(canola::sdo::ErrorKind::Timeout)
    )
}

fn mismatch(code: BootErrorCode, at: ObjectAddress, expected: u32, actual: u32) -> Failure {
    Failure {
        step: BootStep::Identity,
        code,
        object: Some(at),
        abort: None,
        detail: format!("{at} is {actual:#010x}, expected {expected:#010x}"),
        absent: false,
    }
}

/// The values the DCF configures: every writable entry with a `ParameterValue`, in index
/// order, without 0x1020 (written last, as the mark of a finished configuration).
pub fn configured_values(slave: &SlaveConfig) -> Vec<(ObjectAddress, Value)> {
    let node = slave.node_id.get();
    slave
        .dictionary
        .entries()
        .filter(|(index, s)| {
            *index != 0x1020
                && !matches!(s.access, AccessType::Ro | AccessType::Const)
                && s.parameter_value().is_some()
        })
        .filter_map(|(index, s)| {
            let v = s.parameter_value()?.resolve(node)?;
            Some((ObjectAddress::new(index, s.sub_index), v))
        })
        .collect()
}

/// The configuration date and time 0x1020:01/02 the DCF records, when it records one.
fn verify_stamp(slave: &SlaveConfig) -> Option<(u32, u32)> {
    let get = |sub| {
        let s = slave.dictionary.sub(0x1020, sub)?;
        let v = s.parameter_value()?.resolve(slave.node_id.get())?;
        // A UNSIGNED32 from a DCF, or four bytes from a concise DCF.
        <[u8; 4]>::try_from(v.to_le_bytes().as_slice())
            .ok()
            .map(u32::from_le_bytes)
    };
    let stamp = (get(1)?, get(2)?);
    (stamp != (0, 0)).then_some(stamp)
}
