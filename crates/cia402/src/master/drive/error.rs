//! [`DriveError`]: why a drive command failed, with what a wait awaited ([`Awaited`]) and what the
//! drive showed instead ([`Reached`]).
//!
//! As every public error of the stack: fields a program inspects, `Display` in readable English
//! naming what failed, and `Debug` printing the same text, so a `main` that returns one with `?`
//! prints a sentence.

use core::fmt;
use std::prelude::rust_2024::*;

use canola::Duration;
use canola::nmt::Emcy;
use canola::pdo::Direction;

use super::super::dcf::DcfPdoError;
use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::ErrorCode;
use crate::state::{PlanError, State};
use crate::words::{Controlword, Statusword};

/// What a wait of a drive command awaited.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Awaited {
    /// One of these states (a step of a state walk; later steps of the plan count too).
    State(Vec<State>),
    /// 0x6061 showing this mode.
    Mode(ModeOfOperation),
    /// The set-point acknowledge of profile position (statusword bit 12).
    SetPointAcknowledge,
    /// Target reached (statusword bit 10).
    TargetReached,
    /// Homing attained and completed (statusword bits 12 and 10).
    HomingCompleted,
}

impl fmt::Display for Awaited {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::State(states) => {
                for (i, s) in states.iter().enumerate() {
                    if i > 0 {
                        f.write_str(" or ")?;
                    }
                    write!(f, "{s}")?;
                }
                Ok(())
            }
            Self::Mode(m) => write!(f, "mode {m} in 0x6061"),
            Self::SetPointAcknowledge => {
                f.write_str("the set-point acknowledge (statusword bit 12)")
            }
            Self::TargetReached => f.write_str("target reached (statusword bit 10)"),
            Self::HomingCompleted => f.write_str("homing completed (statusword bits 10 and 12)"),
        }
    }
}

/// What the drive showed last when a wait ran out of time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Reached {
    /// The state the statusword showed (`None`: a pattern no state has).
    State(Option<State>),
    /// The mode 0x6061 showed.
    Mode(ModeOfOperation),
    /// The homing status (statusword bits 13, 12, 10).
    Homing(HomingStatus),
    /// Still moving, at this actual position (counts).
    Position(i32),
}

impl fmt::Display for Reached {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::State(Some(s)) => write!(f, "the drive is in state \"{s}\""),
            Self::State(None) => f.write_str("the statusword shows no state"),
            Self::Mode(m) => write!(f, "0x6061 shows mode {m}"),
            Self::Homing(h) => write!(f, "homing status: {h}"),
            Self::Position(p) => write!(f, "the drive is at position {p}"),
        }
    }
}

/// Why a cyclic stream could not be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CyclicSetup {
    /// The node has no RPDO of this number (1-based).
    NoRpdo(u16),
    /// The DCF configures a PDO the node does not have.
    NoPdoForDcf {
        /// RPDO or TPDO (seen from the device).
        direction: Direction,
        /// Its number, 1-based.
        number: u16,
    },
    /// The period does not fit 0x60C2 (value × 10^index seconds).
    Period(Duration),
}

impl fmt::Display for CyclicSetup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoRpdo(n) => write!(f, "the node has no RPDO{n}"),
            Self::NoPdoForDcf { direction, number } => write!(
                f,
                "the DCF configures {}{number}, which the node does not have",
                pdo_kind(*direction)
            ),
            Self::Period(p) => write!(f, "a period of {p} does not fit 0x60C2"),
        }
    }
}

/// Why a drive command failed.
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum DriveError {
    /// An SDO transfer failed (the drive's abort code included: a mode it refuses is 0x06090030).
    #[error(transparent)]
    Sdo(#[from] canola::Error),
    /// A wait ran out of time.
    #[error(
        "timed out after {waited} waiting for {awaited}: {reached} (statusword {statusword}){}",
        hint(reached)
    )]
    Timeout {
        /// What was awaited.
        awaited: Awaited,
        /// What the drive showed last.
        reached: Reached,
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
        "the drive is in state \"{state}\" (statusword {statusword}); this command needs operation enabled{}",
        enable_hint(*state)
    )]
    NotEnabled {
        /// The drive's state.
        state: State,
        /// The statusword.
        statusword: Statusword,
    },
    /// The drive went to fault (or fault reaction active) during the command.
    #[error("the drive faulted: error code {code}{} (statusword {statusword})", .emcy.as_ref().map(|e| std::format!(", last EMCY {e}")).unwrap_or_default())]
    Fault {
        /// 0x603F.
        code: ErrorCode,
        /// The node's last EMCY.
        emcy: Option<Emcy>,
        /// The statusword.
        statusword: Statusword,
    },
    /// A cyclic stream needs csp, csv, cst (or, on an RPDO of its own, ip).
    #[error("mode {0} is not a cyclic mode (csp, csv, cst, ip)")]
    NotCyclic(ModeOfOperation),
    /// The DCF's PDOs cannot serve the mode (see [`Drive::start_cyclic_from_dcf`](super::Drive::start_cyclic_from_dcf)).
    #[error(transparent)]
    Dcf(#[from] DcfPdoError),
    /// The node has no such PDO, or the period does not fit 0x60C2.
    #[error("cannot set up the cyclic stream: {0}")]
    Cyclic(CyclicSetup),
    /// The drive refused a mode change while halt (controlword bit 8) is set, as some drives do.
    #[error(
        "the drive refused mode {mode} while halt is set (controlword {controlword}); clear halt first (it resumes what the drive was doing)"
    )]
    ModeRefusedWhileHalted {
        /// The mode asked for.
        mode: ModeOfOperation,
        /// The controlword read back, bit 8 set.
        controlword: Controlword,
    },
    /// Homing ended with an error (statusword bit 13).
    #[error("homing failed: {status} (statusword {statusword})")]
    Homing {
        /// The homing status.
        status: HomingStatus,
        /// The statusword.
        statusword: Statusword,
    },
}

/// `Debug` prints what `Display` prints (the stack's error convention).
impl fmt::Debug for DriveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// What to do about a drive that is not in operation enabled and cannot simply be enabled.
fn enable_hint(state: State) -> &'static str {
    match state {
        State::Fault | State::FaultReactionActive => "; reset the fault first",
        _ => "",
    }
}

fn hint(reached: &Reached) -> &'static str {
    match reached {
        Reached::Homing(HomingStatus::Interrupted) => {
            "; homing is interrupted: halt (controlword bit 8) may be set"
        }
        _ => "",
    }
}

/// `RPDO` or `TPDO`.
pub(in crate::master) fn pdo_kind(direction: Direction) -> &'static str {
    match direction {
        Direction::Receive => "RPDO",
        Direction::Transmit => "TPDO",
    }
}
