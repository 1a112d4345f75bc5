//! [`DriveError`]: why a drive command failed.

use std::format;
use std::prelude::rust_2024::*;

use canola::Duration;

use super::super::dcf::DcfPdoError;
use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::ErrorCode;
use crate::state::{PlanError, State};
use crate::words::Statusword;

/// Why a drive command failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriveError {
    /// An SDO transfer failed (the drive's abort code included: a mode it refuses is 0x06090030).
    #[error(transparent)]
    Sdo(#[from] canola::Error),
    /// A wait ran out of time.
    #[error(
        "timed out after {waited} waiting for {waiting_for}: expected {expected}, reached {reached} (statusword {statusword})"
    )]
    Timeout {
        /// What was awaited ("state", "mode", "set-point acknowledge", "target reached", "homing").
        waiting_for: &'static str,
        /// The state (or mode, or bit) expected.
        expected: String,
        /// What the drive showed last.
        reached: String,
        /// The last statusword read.
        statusword: Statusword,
        /// How long the wait took.
        waited: Duration,
    },
    /// No plan reaches the target: safe torque off (voltage not enabled), an unknown statusword,
    /// a state only the drive can enter.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The command needs operation enabled.
    #[error(
        "the drive is in {state} (statusword {statusword}); this command needs operation enabled"
    )]
    NotEnabled {
        /// The drive's state.
        state: State,
        /// The statusword.
        statusword: Statusword,
    },
    /// The drive went to fault (or fault reaction active) during the command.
    #[error("the drive faulted: error code {code}{} (statusword {statusword})", .emcy.as_ref().map(|e| format!(", {e}")).unwrap_or_default())]
    Fault {
        /// 0x603F.
        code: ErrorCode,
        /// The last EMCY of the node, as text.
        emcy: Option<String>,
        /// The statusword.
        statusword: Statusword,
    },
    /// A cyclic stream needs csp, csv or cst.
    #[error("{0:?} is not a cyclic synchronous mode (csp, csv, cst)")]
    NotCyclic(ModeOfOperation),
    /// The DCF's PDOs cannot serve the mode (see [`Drive::start_cyclic_from_dcf`]).
    #[error(transparent)]
    Dcf(#[from] DcfPdoError),
    /// The node has no such RPDO, or its period does not fit 0x60C2.
    #[error("cannot set up the cyclic stream: {0}")]
    Cyclic(String),
    /// Homing ended with an error (statusword bit 13).
    #[error("homing failed: {status:?} (statusword {statusword})")]
    Homing {
        /// The homing status.
        status: HomingStatus,
        /// The statusword.
        statusword: Statusword,
    },
}
