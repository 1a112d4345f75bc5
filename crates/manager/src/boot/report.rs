//! What a boot reports: the CiA 302-2 boot steps, each slave's status and error code, the
//! outcome of its configuration and software check, and the events a boot emits as it goes.

use canola::{Duration, NodeId, ObjectAddress};

use crate::codes::BootErrorCode;

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
