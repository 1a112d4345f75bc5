//! Actions ('A' instruction, manual 5.6.8 .. 5.6.19) with their request functions and status
//! codes, and the error-list codes (5.6.7).
//!
//! Every action's answer is `[tg, 'A', id, status]`; the status depends on the action, so
//! [`ActionStatus::decode`] takes the action number. Values the manual does not list decode to
//! [`ActionStatus::Unknown`], which keeps the raw value (lossless).
//!
//! Ambiguities resolved here:
//! - NoInit's function sits in the high byte v3 (`0x01,0x00,0x00,0x00` = open slowly), unlike
//!   every other action (low byte). Its "stop valve" status is `0x00000000` and its "open slowly"
//!   status equals the "action cannot be started" value `0x01000000` of the other actions; the
//!   manual lists no "cannot be started" for NoInit, so `0x01000000` is always "open slowly" there.
//!   NoInit's refusal on an initialised valve is signalled by diagnostic 0x42 only.
//! - NoInit ends with function 7 "end event"; 0 "stop valve" only stops the motion.
//! - Clear error list / set default: status 2 "not cleared/not loaded (action remains active)"
//!   keeps the action active; it is ended with 'Q'.
//! - GoClose/GoOpen: function 1 starts the approach (status 1); the manual says the cPos "must be
//!   informed" once the position is reached, which is function 2 "adopt"; status 2 "position
//!   reached" is taken as the end of the action (after the adoption), status 3 as "cancelled".
//! - GoOpen "adopt the open position": the German copy gives `0x00,0x00,0x00,0x01`, the English copy
//!   and the symmetric GoClose give `0x00,0x00,0x00,0x02`; 0x02 is used (0x01 is "approach").
//! - Find function, adjust time, find coefficient and init pilot report "inactive" as status 1
//!   (not 0 as init valve does); "inactive" after a start means the action has ended.
//! - The German OCR places adjust time's status list under init pilot; the English copy (and
//!   the status names) assign them: adjust time 1 inactive, 2 start position, 3 measure "go close",
//!   4 measure "go open", error 22; init pilot 1 inactive, 2 active, errors 22 and 23.
//! - Find coefficient "approach the calibration point" is `0x00, 0x00, point, 0x02`: the point
//!   number is in v1.
//! - "Error xx active/acknowledged" is `0x0000xxFE`/`0x0000xxFF` with xx the error-list code
//!   (0x14 = 20 PotWrongDir, 0x16 = 22 Pneumatic, 0x17 = 23 Leakage). After acknowledgement the
//!   action has ended.
//!
//! Files: this one holds the action numbers and the error-list codes; `request` the functions a
//! request carries; `status` the statuses the answers carry.

use core::fmt;

mod request;
mod status;

pub use request::{
    ActionRequest, FindFunctionFunction, GoFunction, NoInitFunction, Pwm, RunFunction,
};
pub use status::{
    ActionStatus, AdjustTimeStatus, DoneStatus, FindCoefficientStatus, FindFunctionStatus,
    GoStatus, InitPilotStatus, InitValveStatus, Phase,
};

/// An action number (the id of an 'A' request). Open: unknown numbers are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ActionId {
    /// 1: move the valve by hand while it is not initialised.
    NoInit,
    /// 2: clear the error list.
    ClearErrorList,
    /// 3: load the default settings.
    SetDefault,
    /// 4: initialise the valve (end positions, control function, times, characteristics, pilots).
    InitValve,
    /// 5: drive to and adopt the closed position.
    GoClose,
    /// 6: drive to and adopt the open position.
    GoOpen,
    /// 7: determine the control function and the pilot valves' air flow.
    FindFunction,
    /// 8: measure opening and closing times.
    AdjustTime,
    /// 9: measure the valve at the calibration points.
    FindCoefficient,
    /// 0x0A: measure the internal pilot valves.
    InitPilot,
    /// Any other number (0 = "an action the fieldbus does not know" in the 0xFF answer).
    Unknown(u16),
}

impl ActionId {
    /// All actions the manual defines.
    pub const ALL: [ActionId; 10] = [
        Self::NoInit,
        Self::ClearErrorList,
        Self::SetDefault,
        Self::InitValve,
        Self::GoClose,
        Self::GoOpen,
        Self::FindFunction,
        Self::AdjustTime,
        Self::FindCoefficient,
        Self::InitPilot,
    ];

    /// From the wire number (total).
    pub const fn from_u16(v: u16) -> Self {
        match v {
            1 => Self::NoInit,
            2 => Self::ClearErrorList,
            3 => Self::SetDefault,
            4 => Self::InitValve,
            5 => Self::GoClose,
            6 => Self::GoOpen,
            7 => Self::FindFunction,
            8 => Self::AdjustTime,
            9 => Self::FindCoefficient,
            10 => Self::InitPilot,
            other => Self::Unknown(other),
        }
    }

    /// The wire number.
    pub const fn to_u16(self) -> u16 {
        match self {
            Self::NoInit => 1,
            Self::ClearErrorList => 2,
            Self::SetDefault => 3,
            Self::InitValve => 4,
            Self::GoClose => 5,
            Self::GoOpen => 6,
            Self::FindFunction => 7,
            Self::AdjustTime => 8,
            Self::FindCoefficient => 9,
            Self::InitPilot => 10,
            Self::Unknown(v) => v,
        }
    }

    /// The manual's name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::NoInit => "NoInit",
            Self::ClearErrorList => "Clear Error List",
            Self::SetDefault => "Set Default",
            Self::InitValve => "Init Valve",
            Self::GoClose => "GoClose",
            Self::GoOpen => "GoOpen",
            Self::FindFunction => "Find Function",
            Self::AdjustTime => "Adjust Time",
            Self::FindCoefficient => "Find Coefficient",
            Self::InitPilot => "Init Pilot",
            Self::Unknown(_) => "unknown action",
        }
    }

    /// Looks an action up by name, ignoring case, spaces, '-' and '_' ("init-valve", "InitValve").
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|a| crate::params::names_match(a.name(), name))
    }
}

impl fmt::Display for ActionId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown(v) => write!(f, "action {v}"),
            other => f.write_str(other.name()),
        }
    }
}

/// An error-list / warning code (5.6.7). A newtype so unknown codes survive and still print.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct ErrorCode(pub u16);

impl ErrorCode {
    /// 0: no error.
    pub const NONE: Self = Self(0);
    /// 20 (0x14) PotWrongDir.
    pub const POT_WRONG_DIR: Self = Self(20);
    /// 21 (0x15) Wrong Func.
    pub const WRONG_FUNC: Self = Self(21);
    /// 22 (0x16) Pneumatic.
    pub const PNEUMATIC: Self = Self(22);
    /// 23 (0x17) Leakage.
    pub const LEAKAGE: Self = Self(23);
    /// 30 (0x1E) Air missing.
    pub const AIR_MISSING: Self = Self(30);
    /// 40 (0x28) Bus fault.
    pub const BUS_FAULT: Self = Self(40);
    /// 60 (0x3C) TrvlSensErr.
    pub const TRAVEL_SENSOR: Self = Self(60);

    /// Every code of the manual's error table: code, name, meaning.
    pub const ALL: [(Self, &'static str, &'static str); 8] = [
        (Self::NONE, "NO ERROR", "there are no errors"),
        (
            Self::POT_WRONG_DIR,
            "PotWrongDir",
            "the potentiometer recognised the wrong control function during initialisation",
        ),
        (
            Self::WRONG_FUNC,
            "Wrong Func.",
            "an incorrect control function was recognised during automatic initialisation",
        ),
        (
            Self::PNEUMATIC,
            "Pneumatic",
            "a pneumatic error was detected during automatic initialisation",
        ),
        (
            Self::LEAKAGE,
            "Leakage",
            "leakage was detected during automatic initialisation",
        ),
        (
            Self::AIR_MISSING,
            "Air missing",
            "a failure of the compressed air was discovered",
        ),
        (Self::BUS_FAULT, "Bus Fault", "a bus fault was recognised"),
        (
            Self::TRAVEL_SENSOR,
            "TrvlSensErr",
            "a cable break or short circuit in the travel sensor connection was detected",
        ),
    ];

    /// The manual's name, if known.
    pub fn name(self) -> Option<&'static str> {
        Self::ALL
            .iter()
            .find(|(c, ..)| *c == self)
            .map(|(_, n, _)| *n)
    }

    /// The manual's meaning, if known.
    pub fn meaning(self) -> Option<&'static str> {
        Self::ALL
            .iter()
            .find(|(c, ..)| *c == self)
            .map(|(.., m)| *m)
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(n) => write!(f, "{:03}: {n}", self.0),
            None => write!(f, "{:03}: unknown error", self.0),
        }
    }
}

#[cfg(test)]
mod tests;
