//! The later boot steps of one slave: the keep-alive node-state check, the application
//! software check and download (CiA 302-3), the configuration, and error control and start.

use canola::{Duration, ObjectAddress, Pending};

use super::failure::{Failure, Seen, to_u32, verify_stamp};
use super::report::{BootEvent, BootStep, SlaveStatus, SoftwareOutcome};
use super::slave::{Param, Phase, SlaveBoot};
use crate::codes::BootErrorCode;
use crate::config::ErrorControl;

impl SlaveBoot<'_> {
    /// The DCF's value of a parameter (0 when it has none).
    pub(super) fn dcf_u32(&self, index: u16) -> u32 {
        self.slave
            .dictionary
            .sub(index, 0)
            .and_then(|s| s.effective_value(self.slave.node_id.get()))
            .and_then(|v| v.as_i128())
            .map_or(0, |v| v as u32)
    }

    /// Keep-alive: wait for the node to tell its state — by heartbeat when its DCF gives a
    /// producer time (within the consumer time), else by node guarding (within the life time).
    pub(super) fn begin_node_state(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
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

    pub(super) fn no_state(&self, guarding: bool, what: &str) -> Failure {
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
    pub(super) fn node_state_known(
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
    pub(super) fn begin_software(
        &mut self,
        on_event: &mut impl FnMut(&BootEvent),
    ) -> Result<Phase, Failure> {
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
    pub(super) fn software_version(
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

    pub(super) fn begin_configuration(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
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

    pub(super) fn configuration_done(&mut self, on_event: &mut impl FnMut(&BootEvent)) -> Phase {
        self.step_done(
            BootStep::Configuration,
            Some(BootStep::ErrorControl),
            on_event,
        );
        self.error_control_phase()
    }

    pub(super) fn error_control_phase(&mut self) -> Phase {
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

    pub(super) fn start_error_control(
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

    pub(super) fn error_control_done(
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
