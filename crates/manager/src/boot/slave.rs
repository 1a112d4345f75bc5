//! One slave's boot as straight-line code ([`boot_slave`]): device present, identity, for a
//! keep-alive slave its node state, then the later steps of [`super::steps`], each awaiting
//! the facade's operations in turn; the first failed step ends the boot. The events go to the
//! boot's `emit` in the order the steps happen.

use canola::{Duration, Instant, Network, ObjectAddress};

use super::failure::{Failure, is_timeout, mismatch, to_u32};
use super::report::{
    BootEvent, BootStep, ConfigOutcome, SlaveReport, SlaveStatus, SoftwareOutcome,
};
use crate::codes::BootErrorCode;
use crate::config::{NetworkConfig, SlaveConfig};

/// Where the events of a slave's boot go (a channel the boot empties into the caller's
/// callback).
pub(super) type Emit<'a> = &'a (dyn Fn(BootEvent) + Sync);

/// One slave's boot: what it works with, and its report as it fills in.
pub(super) struct SlaveBoot<'a> {
    pub(super) net: &'a Network,
    pub(super) config: &'a NetworkConfig,
    pub(super) slave: &'a SlaveConfig,
    /// Whether the slave is started on its own once booted (start policy `individually`).
    pub(super) start: bool,
    /// When the network's boot began: the slave's elapsed time and its device-present
    /// deadline count from here.
    pub(super) t0: Instant,
    pub(super) emit: Emit<'a>,
    pub(super) report: SlaveReport,
}

/// Boots one slave through the CiA 302-2 "boot slave" steps and returns its report (the last
/// event emitted is [`BootEvent::SlaveDone`] with it).
pub(super) async fn boot_slave(
    net: &Network,
    config: &NetworkConfig,
    slave: &SlaveConfig,
    start: bool,
    t0: Instant,
    emit: Emit<'_>,
) -> SlaveReport {
    let mut boot = SlaveBoot {
        net,
        config,
        slave,
        start,
        t0,
        emit,
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
    };
    boot.event(BootEvent::StepStarted {
        node: slave.node_id,
        step: BootStep::DevicePresent,
    });
    let outcome = boot.run().await;
    boot.finish(outcome.err())
}

impl SlaveBoot<'_> {
    /// The steps in order.
    async fn run(&mut self) -> Result<(), Failure> {
        self.device_present().await?;
        self.identity().await?;
        // Keep-alive: a slave found operational is left running, straight to error control.
        let left_running = self.slave.keep_alive && self.node_state().await?;
        if !left_running {
            self.software().await?;
            self.configuration().await?;
        }
        self.error_control().await?;
        self.start_or_leave(left_running)
    }

    pub(super) fn event(&self, e: BootEvent) {
        (self.emit)(e);
    }

    /// `step` done, and `next` begun.
    pub(super) fn step_done(&self, step: BootStep, next: Option<BootStep>) {
        let node = self.slave.node_id;
        self.event(BootEvent::StepDone { node, step });
        if let Some(step) = next {
            self.event(BootEvent::StepStarted { node, step });
        }
    }

    pub(super) fn sdo(&self) -> canola::Sdo {
        self.net
            .node(self.slave.node_id)
            .sdo()
            .timeout(self.config.master.sdo_timeout)
    }

    /// Reads an object's value as an unsigned number.
    pub(super) async fn read_u32(&self, at: ObjectAddress) -> Result<u32, canola::Error> {
        Ok(to_u32(&self.sdo().read(at).await?))
    }

    /// Device present: 0x1000 read, again after each response timeout until the boot timeout,
    /// and compared with the expected device type.
    async fn device_present(&self) -> Result<(), Failure> {
        let at = ObjectAddress::new(0x1000, 0);
        let deadline = self.t0 + self.config.master.boot_timeout;
        let device_type = loop {
            match self.read_u32(at).await {
                Ok(v) => break v,
                Err(e) if is_timeout(&e) && self.net.now() < deadline => {}
                Err(e) => {
                    let mut f = Failure::sdo(BootStep::DevicePresent, BootErrorCode::B, at, &e);
                    f.absent = is_timeout(&e);
                    return Err(f);
                }
            }
        };
        self.step_done(BootStep::DevicePresent, Some(BootStep::Identity));
        match self.slave.identity.device_type {
            Some(expected) if expected != device_type => {
                Err(mismatch(BootErrorCode::C, at, expected, device_type))
            }
            _ => Ok(()),
        }
    }

    /// Identity: the expected values of 0x1018 (vendor, product code, revision, serial), each
    /// with its error code.
    async fn identity(&self) -> Result<(), Failure> {
        let id = &self.slave.identity;
        let checks = [
            (1u8, id.vendor_id, BootErrorCode::D),
            (2, id.product_code, BootErrorCode::M),
            (3, id.revision, BootErrorCode::N),
            (4, id.serial, BootErrorCode::O),
        ];
        for (sub, expected, code) in checks {
            let Some(expected) = expected else {
                continue;
            };
            let at = ObjectAddress::new(0x1018, sub);
            let actual = self
                .read_u32(at)
                .await
                .map_err(|e| Failure::sdo(BootStep::Identity, code, at, &e))?;
            if actual != expected {
                return Err(mismatch(code, at, expected, actual));
            }
        }
        self.step_done(BootStep::Identity, None);
        Ok(())
    }

    /// Keep-alive: waits for the node to tell its state — by heartbeat when its DCF gives a
    /// producer time (within the consumer time), else by node guarding (within the life
    /// time). Returns whether it is operational (left running); any other state gets NMT reset
    /// communication and its boot-up is awaited.
    async fn node_state(&self) -> Result<bool, Failure> {
        let node = self.slave.node_id;
        self.event(BootEvent::StepStarted {
            node,
            step: BootStep::NodeState,
        });
        let hb = self.dcf_u32(0x1017) & 0xFFFF;
        let (gt, lf) = (self.dcf_u32(0x100C) & 0xFFFF, self.dcf_u32(0x100D) & 0xFF);
        let guarding = hb == 0 && gt > 0 && lf > 0;
        let since = self.net.now();
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
        let by = if guarding {
            "node guarding"
        } else {
            "heartbeat"
        };
        let no_state = |what: &str| {
            Failure::keep_alive(
                BootStep::NodeState,
                guarding,
                format!("keep-alive check by {by}: {what}"),
            )
        };
        let alive = self
            .net
            .node(node)
            .nmt()
            .wait_for_life((!guarding).then_some(since), since + window)
            .await
            .map_err(|e| no_state(&format!("no answer with the node state: {e}")))?;
        if !alive {
            return Err(no_state("no answer with the node state in time"));
        }
        if self.net.last_state(node) == Some(canola::NmtState::Operational) {
            self.step_done(BootStep::NodeState, Some(BootStep::ErrorControl));
            return Ok(true);
        }
        let nmt = self.net.node(node).nmt();
        // Not sent: no object to blame, the keep-alive check's code.
        nmt.reset_communication().map_err(|e| Failure {
            object: None,
            ..Failure::keep_alive(
                BootStep::NodeState,
                guarding,
                format!("NMT reset communication could not be sent: {e}"),
            )
        })?;
        let no_boot_up = "no boot-up after NMT reset communication";
        match nmt.wait_for_bootup(self.config.master.boot_timeout).await {
            Ok(()) => {}
            Err(canola::Error::Timeout { .. }) => return Err(no_state(no_boot_up)),
            Err(e) => return Err(no_state(&format!("{no_boot_up}: {e}"))),
        }
        self.step_done(BootStep::NodeState, None);
        Ok(false)
    }

    /// The DCF's value of a parameter (0 when it has none).
    pub(super) fn dcf_u32(&self, index: u16) -> u32 {
        self.slave
            .dictionary
            .sub(index, 0)
            .and_then(|s| s.effective_value(self.slave.node_id.get()))
            .and_then(|v| v.as_i128())
            .map_or(0, |v| v as u32)
    }

    /// The boot's end: the failure, if any, in the report and as an event, then the report
    /// as the last event.
    fn finish(mut self, failure: Option<Failure>) -> SlaveReport {
        if let Some(f) = failure {
            self.event(BootEvent::StepFailed {
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
        self.event(BootEvent::SlaveDone(self.report.clone()));
        self.report
    }
}
