//! The later boot steps of one slave, as straight-line code: the application software check
//! and download (CiA 302-3), the configuration, error control, and the start (or, for a
//! keep-alive slave found operational, leaving it running with code L).

use canola::{Duration, ObjectAddress, Value};

use super::failure::{Failure, is_timeout, verify_stamp};
use super::report::{BootEvent, BootStep, ConfigOutcome, SlaveStatus, SoftwareOutcome};
use super::slave::SlaveBoot;
use crate::codes::BootErrorCode;
use crate::config::{ErrorControl, configured_values};

/// The program download's steps: what is written where, and how a failure names the step.
const DOWNLOAD: [&str; 4] = [
    "stop program",
    "clear program",
    "program data",
    "start program",
];

impl SlaveBoot<'_> {
    /// The software check (0x1F81 bit 5): 0x1F52 against the expected date and time, with a
    /// program download when it differs and an update is allowed. Nothing when not asked for.
    pub(super) async fn software(&mut self) -> Result<(), Failure> {
        let slave = self.slave;
        let Some(w) = &slave.software else {
            return Ok(());
        };
        let node = self.slave.node_id;
        self.event(BootEvent::StepStarted {
            node,
            step: BootStep::Software,
        });
        let Some(expected) = w.expected() else {
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
        };
        let version = ObjectAddress::new(0x1F52, 1);
        let fail = |code, object: ObjectAddress, detail: String| Failure {
            step: BootStep::Software,
            code,
            object: Some(object),
            abort: None,
            detail,
            absent: false,
        };
        let actual = self.software_version(BootErrorCode::G).await?;
        if actual == expected {
            self.report.software = SoftwareOutcome::Verified;
            self.step_done(BootStep::Software, None);
            return Ok(());
        }
        let differs = |actual: (u32, u32)| {
            format!(
                "0x1F52 is date {} time {}, expected date {} time {}",
                actual.0, actual.1, expected.0, expected.1
            )
        };
        if !w.update || slave.keep_alive {
            let why = if w.update {
                "no update on a keep-alive slave"
            } else {
                "update not allowed (0x1F81 bit 6)"
            };
            let detail = format!("{}; {why}", differs(actual));
            return Err(fail(BootErrorCode::H, version, detail));
        }
        let Some(program) = &w.program else {
            return Err(fail(
                BootErrorCode::G,
                ObjectAddress::new(0x1F58, node.get()),
                format!(
                    "{}; update allowed but no program (0x1F58) configured",
                    differs(actual)
                ),
            ));
        };
        let control = ObjectAddress::new(0x1F51, 1);
        for (i, name) in DOWNLOAD.iter().enumerate() {
            let (at, write) = match i {
                0 => (control, self.sdo().write(control, 0u8)),
                1 => (control, self.sdo().write(control, 3u8)),
                2 => {
                    let data = ObjectAddress::new(0x1F50, 1);
                    (data, self.sdo().write(data, program.data.as_slice()))
                }
                _ => (control, self.sdo().write(control, 1u8)),
            };
            match write.await {
                Ok(()) => {}
                // Stopping the program may restart the device into its boot loader before it
                // confirms: a timeout there is no failure.
                Err(e) if i == 0 && is_timeout(&e) => {}
                Err(e) => {
                    let mut f = Failure::sdo(BootStep::Software, BootErrorCode::I, at, &e);
                    f.detail = format!("program download, {name}: {}", f.detail);
                    return Err(f);
                }
            }
        }
        let actual = self.software_version(BootErrorCode::I).await?;
        if actual != expected {
            let detail = format!("after the program download {}", differs(actual));
            return Err(fail(BootErrorCode::I, version, detail));
        }
        self.report.software = SoftwareOutcome::Updated;
        self.step_done(BootStep::Software, None);
        Ok(())
    }

    /// 0x1F52:01 and :02, the application software date and time; a failed read is `code`.
    async fn software_version(&self, code: BootErrorCode) -> Result<(u32, u32), Failure> {
        let mut version = [0; 2];
        for (sub, v) in (1u8..).zip(&mut version) {
            let at = ObjectAddress::new(0x1F52, sub);
            *v = self.read_u32(at).await.map_err(|e| {
                let mut f = Failure::sdo(BootStep::Software, code, at, &e);
                f.detail = format!("application software version 0x1F52: {}", f.detail);
                f
            })?;
        }
        Ok((version[0], version[1]))
    }

    /// The configuration: skipped when 0x1020 holds the DCF's configuration date and time
    /// already, else the DCF's values written in order, 0x1020 last. A configuration that
    /// would put a COB-ID on a CAN identifier CiA 301 restricts is refused whole, nothing
    /// written.
    pub(super) async fn configuration(&mut self) -> Result<(), Failure> {
        self.event(BootEvent::StepStarted {
            node: self.slave.node_id,
            step: BootStep::Configuration,
        });
        let stamp = verify_stamp(self.slave);
        if let Some(stamp) = stamp {
            // A slave without 0x1020 (a read error) is configured.
            let date = self.read_u32(ObjectAddress::new(0x1020, 1)).await.ok();
            let time = self.read_u32(ObjectAddress::new(0x1020, 2)).await.ok();
            if (date, time) == (Some(stamp.0), Some(stamp.1)) {
                self.report.configuration = ConfigOutcome::Verified;
                self.step_done(BootStep::Configuration, Some(BootStep::ErrorControl));
                return Ok(());
            }
        }
        let mut writes = configured_values(self.slave);
        let values = writes.len();
        if let Some((date, time)) = stamp {
            writes.push((ObjectAddress::new(0x1020, 1), Value::Unsigned32(date)));
            writes.push((ObjectAddress::new(0x1020, 2), Value::Unsigned32(time)));
        }
        if let Some(e) = crate::config::restricted_write(self.slave.node_id, &writes) {
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
        for (at, value) in &writes {
            self.sdo()
                .write(*at, value)
                .await
                .map_err(|e| Failure::sdo(BootStep::Configuration, BootErrorCode::J, *at, &e))?;
        }
        self.report.configuration = ConfigOutcome::Written(values);
        self.step_done(BootStep::Configuration, Some(BootStep::ErrorControl));
        Ok(())
    }

    /// An error control parameter (0x1017, 0x100C, 0x100D): the DCF's value, else read from
    /// the slave (an object the slave lacks counts as 0: that kind of error control is off).
    async fn param(&self, index: u16) -> u32 {
        let dcf = self
            .slave
            .dictionary
            .sub(index, 0)
            .and_then(|s| s.parameter_value())
            .and_then(|f| f.resolve(self.slave.node_id.get()))
            .and_then(|v| v.as_i128());
        match dcf {
            Some(v) => v as u32,
            None => self
                .read_u32(ObjectAddress::new(index, 0))
                .await
                .unwrap_or(0),
        }
    }

    /// Error control start: the heartbeat consumer from 0x1017, or node guarding from 0x100C
    /// and 0x100D, then the first sign of life within the consumer (or life) time.
    pub(super) async fn error_control(&mut self) -> Result<(), Failure> {
        let node = self.slave.node_id;
        let want = self.slave.error_control;
        let hb_ms = if matches!(want, ErrorControl::Heartbeat | ErrorControl::Auto) {
            self.param(0x1017).await
        } else {
            0
        } & 0xFFFF;
        let (guard_ms, factor) = if matches!(want, ErrorControl::Guarding | ErrorControl::Auto) {
            (self.param(0x100C).await, self.param(0x100D).await)
        } else {
            (0, 0)
        };
        let (guard_ms, factor) = (guard_ms & 0xFFFF, (factor & 0xFF) as u8);
        if want == ErrorControl::None {
            return Ok(());
        }
        let since = self.net.now();
        let (window, what, guarding) = if hb_ms > 0 {
            let consumer_ms =
                u64::from(hb_ms) * u64::from(self.config.master.heartbeat_consumer_percent) / 100;
            let consumer = Duration::from_millis(consumer_ms);
            self.net.monitor_heartbeat(node, consumer);
            (consumer, format!("heartbeat {consumer_ms} ms"), false)
        } else if guard_ms > 0 && factor > 0 && want != ErrorControl::Heartbeat {
            self.net
                .guard_node(node, Duration::from_millis(u64::from(guard_ms)), factor);
            let life = Duration::from_millis(u64::from(guard_ms) * u64::from(factor));
            (life, format!("guarding {guard_ms} ms x {factor}"), true)
        } else if want == ErrorControl::Auto {
            return Ok(());
        } else {
            // Asked for, but the slave's parameters leave it off.
            return Err(Failure::keep_alive(
                BootStep::ErrorControl,
                want == ErrorControl::Guarding,
                "the slave's error control parameter is 0".into(),
            ));
        };
        let no_life = |why: String| {
            Failure::keep_alive(BootStep::ErrorControl, guarding, format!("{what}: {why}"))
        };
        let alive = self
            .net
            .node(node)
            .nmt()
            .wait_for_life((!guarding).then_some(since), since + window)
            .await
            .map_err(|e| no_life(format!("no sign of life: {e}")))?;
        if !alive {
            return Err(no_life("no sign of life in time".into()));
        }
        self.report.error_control = Some(what);
        Ok(())
    }

    /// The boot's last step: NMT start when the slave is started on its own; a keep-alive
    /// slave found operational is left running as found (code L, no failure).
    pub(super) fn start_or_leave(&mut self, left_running: bool) -> Result<(), Failure> {
        let node = self.slave.node_id;
        if left_running {
            self.step_done(BootStep::ErrorControl, None);
            self.report.status = SlaveStatus::Operational;
            self.report.error_code = Some(BootErrorCode::L);
            self.report.step = Some(BootStep::NodeState);
            self.report.detail = Some(
                "operational when its boot began (keep-alive): not reset, software and configuration not checked".into(),
            );
            return Ok(());
        }
        self.step_done(
            BootStep::ErrorControl,
            self.start.then_some(BootStep::Start),
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
            self.event(BootEvent::StepDone {
                node,
                step: BootStep::Start,
            });
        }
        Ok(())
    }
}
