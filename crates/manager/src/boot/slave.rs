//! One slave's boot as a machine: its phases (device present, identity, node state, software,
//! configuration, error control, start), each with at most one SDO request in flight, advanced
//! by the boot loop of [`super::boot_with`].

use canola::{Duration, Instant, Network, ObjectAddress, Pending, Value};

use super::failure::{Failure, Seen, is_timeout, mismatch, to_u32, verify_stamp};
use super::report::{
    BootEvent, BootStep, ConfigOutcome, SlaveReport, SlaveStatus, SoftwareOutcome,
};
use crate::codes::BootErrorCode;
use crate::config::{NetworkConfig, SlaveConfig, configured_values};

/// An error control parameter (0x1017, 0x100C, 0x100D): from the DCF, or being read.
pub(super) enum Param {
    Known(u32),
    Reading(Pending<Vec<u8>>),
}

/// Where one slave's boot is.
pub(super) enum Phase {
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

pub(super) struct SlaveBoot<'a> {
    pub(super) net: &'a Network,
    pub(super) config: &'a NetworkConfig,
    pub(super) slave: &'a SlaveConfig,
    pub(super) start: bool,
    /// The checks of 0x1018: (sub-index, expected, code).
    pub(super) checks: Vec<(u8, u32, BootErrorCode)>,
    /// The configuration, 0x1020 last.
    pub(super) writes: Vec<(ObjectAddress, Value)>,
    pub(super) phase: Phase,
    pub(super) t0: Instant,
    pub(super) report: SlaveReport,
    pub(super) finished: bool,
    pub(super) started_event: bool,
    /// Keep-alive found the slave operational: it is left running (code L).
    pub(super) initially_operational: bool,
}

impl<'a> SlaveBoot<'a> {
    pub(super) fn new(
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

    pub(super) fn sdo(&self) -> canola::Sdo {
        self.net
            .node(self.slave.node_id)
            .sdo()
            .timeout(self.config.master.sdo_timeout)
    }

    pub(super) fn read(&self, addr: ObjectAddress) -> Pending<Vec<u8>> {
        self.sdo().submit_read(addr)
    }

    /// The DCF's value of an error control parameter, else a read of it.
    pub(super) fn param(&self, index: u16) -> Param {
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

    pub(super) fn poll(&mut self, seen: &mut Seen, on_event: &mut impl FnMut(&BootEvent)) {
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
    pub(super) fn is_waiting(&self, phase: &Phase) -> bool {
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

    pub(super) fn finish(
        &mut self,
        failure: Option<Failure>,
        on_event: &mut impl FnMut(&BootEvent),
    ) {
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

    pub(super) fn step_done(
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
    pub(super) fn advance(
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
            // Before the first write: a configuration that would put a COB-ID on a CAN
            // identifier CiA 301 restricts is refused whole, nothing written.
            Phase::NextWrite(0)
                if let Some(e) =
                    crate::config::restricted_write(self.slave.node_id, &self.writes) =>
            {
                let object = match &e {
                    canola::Error::RestrictedCobId { entry, .. } => Some(*entry),
                    _ => None,
                };
                return Err(Failure {
                    step: BootStep::Configuration,
                    code: BootErrorCode::J,
                    object,
                    abort: None,
                    detail: e.to_string(),
                    absent: false,
                });
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
}
