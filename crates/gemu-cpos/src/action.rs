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

use crate::params::RangeError;
use core::fmt;

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

/// A NoInit PWM value, 0..=1000.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Pwm(u16);

impl Pwm {
    /// A PWM value, or a range error above 1000.
    pub const fn new(v: u16) -> Result<Self, RangeError> {
        if v > 1000 {
            Err(RangeError::AboveRange {
                value: v as i64,
                max: 1000,
            })
        } else {
            Ok(Self(v))
        }
    }

    /// The value.
    pub const fn get(self) -> u16 {
        self.0
    }
}

/// NoInit functions (request) and statuses (answer): the function in v3, PWM in v1:v0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NoInitFunction {
    /// 0x00: stop the valve.
    Stop,
    /// 0x01: open slowly.
    OpenSlow,
    /// 0x02: open quickly.
    OpenFast,
    /// 0x03: close slowly.
    CloseSlow,
    /// 0x04: close quickly.
    CloseFast,
    /// 0x05: open with PWM.
    OpenPwm(Pwm),
    /// 0x06: close with PWM.
    ClosePwm(Pwm),
    /// 0x07: end the event (ends the action).
    EndEvent,
}

impl NoInitFunction {
    /// The 4-byte value `[function, 0x00, pwm_hi, pwm_lo]`.
    pub const fn to_value(self) -> u32 {
        let (f, pwm) = match self {
            Self::Stop => (0u32, 0u16),
            Self::OpenSlow => (1, 0),
            Self::OpenFast => (2, 0),
            Self::CloseSlow => (3, 0),
            Self::CloseFast => (4, 0),
            Self::OpenPwm(p) => (5, p.0),
            Self::ClosePwm(p) => (6, p.0),
            Self::EndEvent => (7, 0),
        };
        f << 24 | pwm as u32
    }

    /// From a 4-byte value; `None` if it is not one of the manual's values.
    pub const fn from_value(v: u32) -> Option<Self> {
        let f = (v >> 24) as u8;
        let mid = (v >> 16) as u8;
        let pwm = v as u16;
        if mid != 0 {
            return None;
        }
        let simple = match f {
            0 => Self::Stop,
            1 => Self::OpenSlow,
            2 => Self::OpenFast,
            3 => Self::CloseSlow,
            4 => Self::CloseFast,
            7 => Self::EndEvent,
            5 | 6 => {
                return match Pwm::new(pwm) {
                    Ok(p) if f == 5 => Some(Self::OpenPwm(p)),
                    Ok(p) => Some(Self::ClosePwm(p)),
                    Err(_) => None,
                };
            }
            _ => return None,
        };
        if pwm != 0 { None } else { Some(simple) }
    }
}

/// Functions of Init Valve, Adjust Time, Find Coefficient and Init Pilot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RunFunction {
    /// 0x00000001: start / activate.
    Start,
    /// 0x00000002: cancel.
    Cancel,
    /// 0x0000FF00: acknowledge the error.
    AcknowledgeError,
}

impl RunFunction {
    /// The 4-byte value.
    pub const fn to_value(self) -> u32 {
        match self {
            Self::Start => 1,
            Self::Cancel => 2,
            Self::AcknowledgeError => 0xFF00,
        }
    }

    /// From a 4-byte value.
    pub const fn from_value(v: u32) -> Option<Self> {
        match v {
            1 => Some(Self::Start),
            2 => Some(Self::Cancel),
            0xFF00 => Some(Self::AcknowledgeError),
            _ => None,
        }
    }
}

/// Functions of Find Function (no error acknowledgement is listed for it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FindFunctionFunction {
    /// 0x00000001: activate.
    Activate,
    /// 0x00000002: cancel.
    Cancel,
}

/// Functions of GoClose and GoOpen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GoFunction {
    /// 0x00000001: approach the position.
    Approach,
    /// 0x00000002: adopt the position as closed (open).
    Adopt,
    /// 0x00000003: cancel (ESC).
    Cancel,
}

impl GoFunction {
    /// From a 4-byte value.
    pub const fn from_value(v: u32) -> Option<Self> {
        match v {
            1 => Some(Self::Approach),
            2 => Some(Self::Adopt),
            3 => Some(Self::Cancel),
            _ => None,
        }
    }
}

/// A typed 'A' request: the action and its function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ActionRequest {
    /// 1 NoInit with a function.
    NoInit(NoInitFunction),
    /// 2 clear the error list (value 0).
    ClearErrorList,
    /// 3 set default (value 0).
    SetDefault,
    /// 4 init valve.
    InitValve(RunFunction),
    /// 5 GoClose.
    GoClose(GoFunction),
    /// 6 GoOpen.
    GoOpen(GoFunction),
    /// 7 find function.
    FindFunction(FindFunctionFunction),
    /// 8 adjust time.
    AdjustTime(RunFunction),
    /// 9 find coefficient.
    FindCoefficient(RunFunction),
    /// 10 init pilot.
    InitPilot(RunFunction),
    /// Any other action number or function value.
    Raw {
        /// The action.
        action: ActionId,
        /// The 4-byte value.
        value: u32,
    },
}

impl ActionRequest {
    /// The action number.
    pub const fn action(self) -> ActionId {
        self.to_parts().0
    }

    /// The action number and the 4-byte value.
    pub const fn to_parts(self) -> (ActionId, u32) {
        match self {
            Self::NoInit(f) => (ActionId::NoInit, f.to_value()),
            Self::ClearErrorList => (ActionId::ClearErrorList, 0),
            Self::SetDefault => (ActionId::SetDefault, 0),
            Self::InitValve(f) => (ActionId::InitValve, f.to_value()),
            Self::GoClose(f) => (ActionId::GoClose, f as u32 + 1),
            Self::GoOpen(f) => (ActionId::GoOpen, f as u32 + 1),
            Self::FindFunction(f) => (ActionId::FindFunction, f as u32 + 1),
            Self::AdjustTime(f) => (ActionId::AdjustTime, f.to_value()),
            Self::FindCoefficient(f) => (ActionId::FindCoefficient, f.to_value()),
            Self::InitPilot(f) => (ActionId::InitPilot, f.to_value()),
            Self::Raw { action, value } => (action, value),
        }
    }

    /// The typed request for an action number and value (total; [`ActionRequest::Raw`] for
    /// anything the manual does not list).
    pub const fn from_parts(action: ActionId, value: u32) -> Self {
        let typed = match action {
            ActionId::NoInit => match NoInitFunction::from_value(value) {
                Some(f) => Some(Self::NoInit(f)),
                None => None,
            },
            ActionId::ClearErrorList if value == 0 => Some(Self::ClearErrorList),
            ActionId::SetDefault if value == 0 => Some(Self::SetDefault),
            ActionId::InitValve
            | ActionId::AdjustTime
            | ActionId::FindCoefficient
            | ActionId::InitPilot => match RunFunction::from_value(value) {
                Some(f) => Some(match action {
                    ActionId::InitValve => Self::InitValve(f),
                    ActionId::AdjustTime => Self::AdjustTime(f),
                    ActionId::FindCoefficient => Self::FindCoefficient(f),
                    _ => Self::InitPilot(f),
                }),
                None => None,
            },
            ActionId::GoClose | ActionId::GoOpen => match GoFunction::from_value(value) {
                Some(f) if matches!(action, ActionId::GoClose) => Some(Self::GoClose(f)),
                Some(f) => Some(Self::GoOpen(f)),
                None => None,
            },
            ActionId::FindFunction => match value {
                1 => Some(Self::FindFunction(FindFunctionFunction::Activate)),
                2 => Some(Self::FindFunction(FindFunctionFunction::Cancel)),
                _ => None,
            },
            _ => None,
        };
        match typed {
            Some(t) => t,
            None => Self::Raw { action, value },
        }
    }

    /// Whether this request starts the action (as opposed to controlling a running one:
    /// cancel, acknowledge, adopt, or another NoInit motion).
    pub const fn is_start(self) -> bool {
        matches!(
            self,
            Self::NoInit(_)
                | Self::ClearErrorList
                | Self::SetDefault
                | Self::InitValve(RunFunction::Start)
                | Self::GoClose(GoFunction::Approach)
                | Self::GoOpen(GoFunction::Approach)
                | Self::FindFunction(FindFunctionFunction::Activate)
                | Self::AdjustTime(RunFunction::Start)
                | Self::FindCoefficient(RunFunction::Start)
                | Self::InitPilot(RunFunction::Start)
                | Self::Raw { .. }
        )
    }
}

/// Status shared by several actions: "error xx active / acknowledged" and "cannot be started".
const CANNOT_START: u32 = 0x0100_0000;

const fn error_status(v: u32) -> Option<(ErrorCode, bool)> {
    if v >> 16 != 0 {
        return None;
    }
    let code = ErrorCode(((v >> 8) & 0xFF) as u16);
    match v & 0xFF {
        0xFE => Some((code, false)),
        0xFF => Some((code, true)),
        _ => None,
    }
}

const fn error_value(code: ErrorCode, acknowledged: bool) -> u32 {
    ((code.0 as u32 & 0xFF) << 8) | if acknowledged { 0xFF } else { 0xFE }
}

/// Status of clear error list (5.6.11) and set default (5.6.12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DoneStatus {
    /// 1: cleared / loaded, the action has ended.
    Done,
    /// 2: not cleared / not loaded, the action remains active.
    NotDone,
}

/// Status of init valve (5.6.13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InitValveStatus {
    /// 0: initialisation inactive.
    Inactive,
    /// 1: the closed position is determined.
    ClosedPosition,
    /// 2: the open position is determined.
    OpenPosition,
    /// 3: the valve control function is determined.
    ControlFunction,
    /// 4: the opening and closing times are measured.
    Times,
    /// 5: the valve characteristics are measured.
    Characteristics,
    /// 6: the pilot valves are checked.
    PilotValves,
    /// 0x0000xxFE: init error xx active (20, 22, 23 listed).
    ErrorActive(ErrorCode),
    /// 0x0000xxFF: init error xx acknowledged.
    ErrorAcknowledged(ErrorCode),
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// Status of GoClose (5.6.14) and GoOpen (5.6.15).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GoStatus {
    /// 1: approaching the position.
    Approaching,
    /// 2: the position has been reached (and adopted).
    Reached,
    /// 3: the function was cancelled.
    Cancelled,
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// Status of find function (5.6.16).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FindFunctionStatus {
    /// 1: inactive.
    Inactive,
    /// 2: approaching the start position.
    StartPosition,
    /// 3: output of the test pattern.
    TestPattern,
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// Status of adjust time (5.6.17).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdjustTimeStatus {
    /// 1: inactive.
    Inactive,
    /// 2: approaching the start position.
    StartPosition,
    /// 3: measuring the "go close" time.
    MeasureClose,
    /// 4: measuring the "go open" time.
    MeasureOpen,
    /// 0x0000xxFE: error xx active (22 listed).
    ErrorActive(ErrorCode),
    /// 0x0000xxFF: error xx acknowledged.
    ErrorAcknowledged(ErrorCode),
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// Status of find coefficient (5.6.18).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FindCoefficientStatus {
    /// 1: inactive.
    Inactive,
    /// `0x0000pp02`: approaching calibration point pp.
    ApproachPoint(u8),
    /// 0x0000xxFE: error xx active (22 listed).
    ErrorActive(ErrorCode),
    /// 0x0000xxFF: error xx acknowledged.
    ErrorAcknowledged(ErrorCode),
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// Status of init pilot (5.6.19).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InitPilotStatus {
    /// 1: inactive.
    Inactive,
    /// 2: active.
    Active,
    /// 0x0000xxFE: error xx active (22, 23 listed).
    ErrorActive(ErrorCode),
    /// 0x0000xxFF: error xx acknowledged.
    ErrorAcknowledged(ErrorCode),
    /// 0x01000000: the action cannot be started.
    CannotBeStarted,
}

/// An action's status, typed per action. [`ActionStatus::Unknown`] keeps values the manual does
/// not list for that action.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ActionStatus {
    /// NoInit: the currently selected function.
    NoInit(NoInitFunction),
    /// Clear error list.
    ClearErrorList(DoneStatus),
    /// Set default.
    SetDefault(DoneStatus),
    /// Init valve.
    InitValve(InitValveStatus),
    /// GoClose.
    GoClose(GoStatus),
    /// GoOpen.
    GoOpen(GoStatus),
    /// Find function.
    FindFunction(FindFunctionStatus),
    /// Adjust time.
    AdjustTime(AdjustTimeStatus),
    /// Find coefficient.
    FindCoefficient(FindCoefficientStatus),
    /// Init pilot.
    InitPilot(InitPilotStatus),
    /// A value the manual does not list for this action (or an unknown action).
    Unknown(u32),
}

/// Where an action stands, derived from its status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Still active (including "not cleared / not loaded, action remains active").
    Running,
    /// An error is active; the action waits for "acknowledge error" (or cancel / 'Q').
    WaitingForAcknowledge(ErrorCode),
    /// The action has ended normally (or was cancelled).
    Ended,
    /// The action ended after an error was acknowledged.
    EndedWithError(ErrorCode),
    /// The device answered "action cannot be started".
    CannotBeStarted,
    /// A status the manual does not list.
    Unknown,
}

impl ActionStatus {
    /// Decodes a status value for `action` (total).
    pub const fn decode(action: ActionId, v: u32) -> Self {
        let err = error_status(v);
        let typed = match action {
            ActionId::NoInit => match NoInitFunction::from_value(v) {
                Some(f) => Some(Self::NoInit(f)),
                None => None,
            },
            ActionId::ClearErrorList | ActionId::SetDefault => {
                let s = match v {
                    1 => Some(DoneStatus::Done),
                    2 => Some(DoneStatus::NotDone),
                    _ => None,
                };
                match (s, action) {
                    (Some(s), ActionId::ClearErrorList) => Some(Self::ClearErrorList(s)),
                    (Some(s), _) => Some(Self::SetDefault(s)),
                    (None, _) => None,
                }
            }
            ActionId::InitValve => {
                let s = match (v, err) {
                    (0, _) => Some(InitValveStatus::Inactive),
                    (1, _) => Some(InitValveStatus::ClosedPosition),
                    (2, _) => Some(InitValveStatus::OpenPosition),
                    (3, _) => Some(InitValveStatus::ControlFunction),
                    (4, _) => Some(InitValveStatus::Times),
                    (5, _) => Some(InitValveStatus::Characteristics),
                    (6, _) => Some(InitValveStatus::PilotValves),
                    (CANNOT_START, _) => Some(InitValveStatus::CannotBeStarted),
                    (_, Some((c, false))) => Some(InitValveStatus::ErrorActive(c)),
                    (_, Some((c, true))) => Some(InitValveStatus::ErrorAcknowledged(c)),
                    _ => None,
                };
                match s {
                    Some(s) => Some(Self::InitValve(s)),
                    None => None,
                }
            }
            ActionId::GoClose | ActionId::GoOpen => {
                let s = match v {
                    1 => Some(GoStatus::Approaching),
                    2 => Some(GoStatus::Reached),
                    3 => Some(GoStatus::Cancelled),
                    CANNOT_START => Some(GoStatus::CannotBeStarted),
                    _ => None,
                };
                match (s, action) {
                    (Some(s), ActionId::GoClose) => Some(Self::GoClose(s)),
                    (Some(s), _) => Some(Self::GoOpen(s)),
                    (None, _) => None,
                }
            }
            ActionId::FindFunction => match v {
                1 => Some(Self::FindFunction(FindFunctionStatus::Inactive)),
                2 => Some(Self::FindFunction(FindFunctionStatus::StartPosition)),
                3 => Some(Self::FindFunction(FindFunctionStatus::TestPattern)),
                CANNOT_START => Some(Self::FindFunction(FindFunctionStatus::CannotBeStarted)),
                _ => None,
            },
            ActionId::AdjustTime => {
                let s = match (v, err) {
                    (1, _) => Some(AdjustTimeStatus::Inactive),
                    (2, _) => Some(AdjustTimeStatus::StartPosition),
                    (3, _) => Some(AdjustTimeStatus::MeasureClose),
                    (4, _) => Some(AdjustTimeStatus::MeasureOpen),
                    (CANNOT_START, _) => Some(AdjustTimeStatus::CannotBeStarted),
                    (_, Some((c, false))) => Some(AdjustTimeStatus::ErrorActive(c)),
                    (_, Some((c, true))) => Some(AdjustTimeStatus::ErrorAcknowledged(c)),
                    _ => None,
                };
                match s {
                    Some(s) => Some(Self::AdjustTime(s)),
                    None => None,
                }
            }
            ActionId::FindCoefficient => {
                let s = match (v, err) {
                    (1, _) => Some(FindCoefficientStatus::Inactive),
                    (CANNOT_START, _) => Some(FindCoefficientStatus::CannotBeStarted),
                    (_, Some((c, false))) => Some(FindCoefficientStatus::ErrorActive(c)),
                    (_, Some((c, true))) => Some(FindCoefficientStatus::ErrorAcknowledged(c)),
                    (v, None) if v >> 16 == 0 && v & 0xFF == 0x02 => {
                        Some(FindCoefficientStatus::ApproachPoint((v >> 8) as u8))
                    }
                    _ => None,
                };
                match s {
                    Some(s) => Some(Self::FindCoefficient(s)),
                    None => None,
                }
            }
            ActionId::InitPilot => {
                let s = match (v, err) {
                    (1, _) => Some(InitPilotStatus::Inactive),
                    (2, _) => Some(InitPilotStatus::Active),
                    (CANNOT_START, _) => Some(InitPilotStatus::CannotBeStarted),
                    (_, Some((c, false))) => Some(InitPilotStatus::ErrorActive(c)),
                    (_, Some((c, true))) => Some(InitPilotStatus::ErrorAcknowledged(c)),
                    _ => None,
                };
                match s {
                    Some(s) => Some(Self::InitPilot(s)),
                    None => None,
                }
            }
            ActionId::Unknown(_) => None,
        };
        match typed {
            Some(t) => t,
            None => Self::Unknown(v),
        }
    }

    /// The 4-byte status value.
    pub const fn to_value(self) -> u32 {
        match self {
            Self::NoInit(f) => f.to_value(),
            Self::ClearErrorList(s) | Self::SetDefault(s) => match s {
                DoneStatus::Done => 1,
                DoneStatus::NotDone => 2,
            },
            Self::InitValve(s) => match s {
                InitValveStatus::Inactive => 0,
                InitValveStatus::ClosedPosition => 1,
                InitValveStatus::OpenPosition => 2,
                InitValveStatus::ControlFunction => 3,
                InitValveStatus::Times => 4,
                InitValveStatus::Characteristics => 5,
                InitValveStatus::PilotValves => 6,
                InitValveStatus::ErrorActive(c) => error_value(c, false),
                InitValveStatus::ErrorAcknowledged(c) => error_value(c, true),
                InitValveStatus::CannotBeStarted => CANNOT_START,
            },
            Self::GoClose(s) | Self::GoOpen(s) => match s {
                GoStatus::Approaching => 1,
                GoStatus::Reached => 2,
                GoStatus::Cancelled => 3,
                GoStatus::CannotBeStarted => CANNOT_START,
            },
            Self::FindFunction(s) => match s {
                FindFunctionStatus::Inactive => 1,
                FindFunctionStatus::StartPosition => 2,
                FindFunctionStatus::TestPattern => 3,
                FindFunctionStatus::CannotBeStarted => CANNOT_START,
            },
            Self::AdjustTime(s) => match s {
                AdjustTimeStatus::Inactive => 1,
                AdjustTimeStatus::StartPosition => 2,
                AdjustTimeStatus::MeasureClose => 3,
                AdjustTimeStatus::MeasureOpen => 4,
                AdjustTimeStatus::ErrorActive(c) => error_value(c, false),
                AdjustTimeStatus::ErrorAcknowledged(c) => error_value(c, true),
                AdjustTimeStatus::CannotBeStarted => CANNOT_START,
            },
            Self::FindCoefficient(s) => match s {
                FindCoefficientStatus::Inactive => 1,
                FindCoefficientStatus::ApproachPoint(p) => (p as u32) << 8 | 0x02,
                FindCoefficientStatus::ErrorActive(c) => error_value(c, false),
                FindCoefficientStatus::ErrorAcknowledged(c) => error_value(c, true),
                FindCoefficientStatus::CannotBeStarted => CANNOT_START,
            },
            Self::InitPilot(s) => match s {
                InitPilotStatus::Inactive => 1,
                InitPilotStatus::Active => 2,
                InitPilotStatus::ErrorActive(c) => error_value(c, false),
                InitPilotStatus::ErrorAcknowledged(c) => error_value(c, true),
                InitPilotStatus::CannotBeStarted => CANNOT_START,
            },
            Self::Unknown(v) => v,
        }
    }

    /// Where the action stands.
    pub const fn phase(self) -> Phase {
        use Phase::*;
        match self {
            Self::NoInit(NoInitFunction::EndEvent) => Ended,
            Self::NoInit(_) => Running,
            Self::ClearErrorList(DoneStatus::Done) | Self::SetDefault(DoneStatus::Done) => Ended,
            Self::ClearErrorList(DoneStatus::NotDone) | Self::SetDefault(DoneStatus::NotDone) => {
                Running
            }
            Self::InitValve(s) => match s {
                InitValveStatus::Inactive => Ended,
                InitValveStatus::ErrorActive(c) => WaitingForAcknowledge(c),
                InitValveStatus::ErrorAcknowledged(c) => EndedWithError(c),
                InitValveStatus::CannotBeStarted => CannotBeStarted,
                _ => Running,
            },
            Self::GoClose(s) | Self::GoOpen(s) => match s {
                GoStatus::Approaching => Running,
                GoStatus::Reached | GoStatus::Cancelled => Ended,
                GoStatus::CannotBeStarted => CannotBeStarted,
            },
            Self::FindFunction(s) => match s {
                FindFunctionStatus::Inactive => Ended,
                FindFunctionStatus::CannotBeStarted => CannotBeStarted,
                _ => Running,
            },
            Self::AdjustTime(s) => match s {
                AdjustTimeStatus::Inactive => Ended,
                AdjustTimeStatus::ErrorActive(c) => WaitingForAcknowledge(c),
                AdjustTimeStatus::ErrorAcknowledged(c) => EndedWithError(c),
                AdjustTimeStatus::CannotBeStarted => CannotBeStarted,
                _ => Running,
            },
            Self::FindCoefficient(s) => match s {
                FindCoefficientStatus::Inactive => Ended,
                FindCoefficientStatus::ApproachPoint(_) => Running,
                FindCoefficientStatus::ErrorActive(c) => WaitingForAcknowledge(c),
                FindCoefficientStatus::ErrorAcknowledged(c) => EndedWithError(c),
                FindCoefficientStatus::CannotBeStarted => CannotBeStarted,
            },
            Self::InitPilot(s) => match s {
                InitPilotStatus::Inactive => Ended,
                InitPilotStatus::Active => Running,
                InitPilotStatus::ErrorActive(c) => WaitingForAcknowledge(c),
                InitPilotStatus::ErrorAcknowledged(c) => EndedWithError(c),
                InitPilotStatus::CannotBeStarted => CannotBeStarted,
            },
            Self::Unknown(_) => Unknown,
        }
    }
}

impl fmt::Display for ActionStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match *self {
            Self::NoInit(n) => match n {
                NoInitFunction::Stop => "valve stopped",
                NoInitFunction::OpenSlow => "opening slowly",
                NoInitFunction::OpenFast => "opening quickly",
                NoInitFunction::CloseSlow => "closing slowly",
                NoInitFunction::CloseFast => "closing quickly",
                NoInitFunction::OpenPwm(p) => return write!(f, "opening with PWM {}", p.0),
                NoInitFunction::ClosePwm(p) => return write!(f, "closing with PWM {}", p.0),
                NoInitFunction::EndEvent => "event ended",
            },
            Self::ClearErrorList(DoneStatus::Done) => "error list cleared (action ended)",
            Self::ClearErrorList(DoneStatus::NotDone) => {
                "error list not cleared (action remains active)"
            }
            Self::SetDefault(DoneStatus::Done) => "default setting loaded (action ended)",
            Self::SetDefault(DoneStatus::NotDone) => {
                "default setting not loaded (action remains active)"
            }
            Self::InitValve(s) => match s {
                InitValveStatus::Inactive => "initialisation inactive",
                InitValveStatus::ClosedPosition => "determining the closed position",
                InitValveStatus::OpenPosition => "determining the open position",
                InitValveStatus::ControlFunction => "determining the valve control function",
                InitValveStatus::Times => "measuring the opening and closing times",
                InitValveStatus::Characteristics => "measuring the valve characteristics",
                InitValveStatus::PilotValves => "checking the pilot valves",
                InitValveStatus::ErrorActive(c) => return write!(f, "init error {c} active"),
                InitValveStatus::ErrorAcknowledged(c) => {
                    return write!(f, "init error {c} acknowledged");
                }
                InitValveStatus::CannotBeStarted => "action cannot be started",
            },
            Self::GoClose(s) | Self::GoOpen(s) => match s {
                GoStatus::Approaching => "approaching the position",
                GoStatus::Reached => "position reached",
                GoStatus::Cancelled => "cancelled",
                GoStatus::CannotBeStarted => "action cannot be started",
            },
            Self::FindFunction(s) => match s {
                FindFunctionStatus::Inactive => "find function inactive",
                FindFunctionStatus::StartPosition => "approaching the start position",
                FindFunctionStatus::TestPattern => "output of the test pattern",
                FindFunctionStatus::CannotBeStarted => "action cannot be started",
            },
            Self::AdjustTime(s) => match s {
                AdjustTimeStatus::Inactive => "adjust time inactive",
                AdjustTimeStatus::StartPosition => "approaching the start position",
                AdjustTimeStatus::MeasureClose => "measuring the \"go close\" time",
                AdjustTimeStatus::MeasureOpen => "measuring the \"go open\" time",
                AdjustTimeStatus::ErrorActive(c) => return write!(f, "error {c} active"),
                AdjustTimeStatus::ErrorAcknowledged(c) => {
                    return write!(f, "error {c} acknowledged");
                }
                AdjustTimeStatus::CannotBeStarted => "action cannot be started",
            },
            Self::FindCoefficient(s) => match s {
                FindCoefficientStatus::Inactive => "find coefficient inactive",
                FindCoefficientStatus::ApproachPoint(p) => {
                    return write!(f, "approaching calibration point {p}");
                }
                FindCoefficientStatus::ErrorActive(c) => return write!(f, "error {c} active"),
                FindCoefficientStatus::ErrorAcknowledged(c) => {
                    return write!(f, "error {c} acknowledged");
                }
                FindCoefficientStatus::CannotBeStarted => "action cannot be started",
            },
            Self::InitPilot(s) => match s {
                InitPilotStatus::Inactive => "init pilot inactive",
                InitPilotStatus::Active => "init pilot active",
                InitPilotStatus::ErrorActive(c) => return write!(f, "error {c} active"),
                InitPilotStatus::ErrorAcknowledged(c) => {
                    return write!(f, "error {c} acknowledged");
                }
                InitPilotStatus::CannotBeStarted => "action cannot be started",
            },
            Self::Unknown(v) => return write!(f, "status 0x{v:08X}"),
        };
        f.write_str(text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(b: [u8; 4]) -> u32 {
        u32::from_be_bytes(b)
    }

    #[test]
    fn action_numbers() {
        for (i, a) in ActionId::ALL.iter().enumerate() {
            assert_eq!(a.to_u16(), i as u16 + 1);
            assert_eq!(ActionId::from_u16(i as u16 + 1), *a);
        }
        assert_eq!(ActionId::InitPilot.to_u16(), 0x0A);
        assert_eq!(ActionId::from_u16(0), ActionId::Unknown(0));
        assert_eq!(ActionId::from_name("init-valve"), Some(ActionId::InitValve));
        assert_eq!(ActionId::from_name("goclose"), Some(ActionId::GoClose));
    }

    /// 5.6.10 NoInit functions, byte-exact.
    #[test]
    fn manual_noinit_functions() {
        let pwm = Pwm::new(0x0123).unwrap();
        let cases = [
            (NoInitFunction::Stop, [0x00, 0x00, 0x00, 0x00]),
            (NoInitFunction::OpenSlow, [0x01, 0x00, 0x00, 0x00]),
            (NoInitFunction::OpenFast, [0x02, 0x00, 0x00, 0x00]),
            (NoInitFunction::CloseSlow, [0x03, 0x00, 0x00, 0x00]),
            (NoInitFunction::CloseFast, [0x04, 0x00, 0x00, 0x00]),
            (NoInitFunction::OpenPwm(pwm), [0x05, 0x00, 0x01, 0x23]),
            (NoInitFunction::ClosePwm(pwm), [0x06, 0x00, 0x01, 0x23]),
            (NoInitFunction::EndEvent, [0x07, 0x00, 0x00, 0x00]),
        ];
        for (f, b) in cases {
            assert_eq!(f.to_value(), v(b));
            assert_eq!(NoInitFunction::from_value(v(b)), Some(f));
            assert_eq!(
                ActionRequest::from_parts(ActionId::NoInit, v(b)),
                ActionRequest::NoInit(f)
            );
            // The status is the current function (same coding).
            assert_eq!(
                ActionStatus::decode(ActionId::NoInit, v(b)),
                ActionStatus::NoInit(f)
            );
        }
        assert!(Pwm::new(1001).is_err());
        assert_eq!(
            NoInitFunction::from_value(v([0x05, 0x00, 0x03, 0xE9])),
            None
        );
        assert_eq!(
            NoInitFunction::from_value(v([0x01, 0x00, 0x00, 0x01])),
            None
        );
        assert_eq!(
            NoInitFunction::from_value(v([0x08, 0x00, 0x00, 0x00])),
            None
        );
        // 0x01000000 is "open slowly" for NoInit, never "cannot be started".
        assert_eq!(
            ActionStatus::decode(ActionId::NoInit, 0x0100_0000),
            ActionStatus::NoInit(NoInitFunction::OpenSlow)
        );
    }

    /// Request values of every action (5.6.11 .. 5.6.19), byte-exact.
    #[test]
    fn manual_action_requests() {
        use ActionRequest as R;
        let cases = [
            (R::ClearErrorList, 2, [0, 0, 0, 0]),
            (R::SetDefault, 3, [0, 0, 0, 0]),
            (R::InitValve(RunFunction::Start), 4, [0, 0, 0, 1]),
            (R::InitValve(RunFunction::Cancel), 4, [0, 0, 0, 2]),
            (
                R::InitValve(RunFunction::AcknowledgeError),
                4,
                [0, 0, 0xFF, 0],
            ),
            (R::GoClose(GoFunction::Approach), 5, [0, 0, 0, 1]),
            (R::GoClose(GoFunction::Adopt), 5, [0, 0, 0, 2]),
            (R::GoClose(GoFunction::Cancel), 5, [0, 0, 0, 3]),
            (R::GoOpen(GoFunction::Approach), 6, [0, 0, 0, 1]),
            (R::GoOpen(GoFunction::Adopt), 6, [0, 0, 0, 2]),
            (R::GoOpen(GoFunction::Cancel), 6, [0, 0, 0, 3]),
            (
                R::FindFunction(FindFunctionFunction::Activate),
                7,
                [0, 0, 0, 1],
            ),
            (
                R::FindFunction(FindFunctionFunction::Cancel),
                7,
                [0, 0, 0, 2],
            ),
            (R::AdjustTime(RunFunction::Start), 8, [0, 0, 0, 1]),
            (R::AdjustTime(RunFunction::Cancel), 8, [0, 0, 0, 2]),
            (
                R::AdjustTime(RunFunction::AcknowledgeError),
                8,
                [0, 0, 0xFF, 0],
            ),
            (R::FindCoefficient(RunFunction::Start), 9, [0, 0, 0, 1]),
            (R::FindCoefficient(RunFunction::Cancel), 9, [0, 0, 0, 2]),
            (
                R::FindCoefficient(RunFunction::AcknowledgeError),
                9,
                [0, 0, 0xFF, 0],
            ),
            (R::InitPilot(RunFunction::Start), 0x0A, [0, 0, 0, 1]),
            (R::InitPilot(RunFunction::Cancel), 0x0A, [0, 0, 0, 2]),
            (
                R::InitPilot(RunFunction::AcknowledgeError),
                0x0A,
                [0, 0, 0xFF, 0],
            ),
        ];
        for (r, id, b) in cases {
            assert_eq!(r.to_parts(), (ActionId::from_u16(id), v(b)), "{r:?}");
            assert_eq!(ActionRequest::from_parts(ActionId::from_u16(id), v(b)), r);
            // Full channel: [YY, 0x41, 0x00, id, b0..b3].
            let ch = crate::channel::Request::Action {
                action: r.action(),
                value: v(b),
            }
            .to_channel(0x33);
            assert_eq!(
                ch.to_bytes(),
                [0x33, 0x41, 0x00, id as u8, b[0], b[1], b[2], b[3]]
            );
        }
        assert_eq!(
            ActionRequest::from_parts(ActionId::GoOpen, 4),
            ActionRequest::Raw {
                action: ActionId::GoOpen,
                value: 4
            }
        );
    }

    /// Status values of every action, byte-exact.
    #[test]
    fn manual_action_statuses() {
        use ActionStatus as S;
        let e22 = ErrorCode::PNEUMATIC;
        let cases: &[(ActionId, [u8; 4], ActionStatus, Phase)] = &[
            (
                ActionId::ClearErrorList,
                [0, 0, 0, 1],
                S::ClearErrorList(DoneStatus::Done),
                Phase::Ended,
            ),
            (
                ActionId::ClearErrorList,
                [0, 0, 0, 2],
                S::ClearErrorList(DoneStatus::NotDone),
                Phase::Running,
            ),
            (
                ActionId::SetDefault,
                [0, 0, 0, 1],
                S::SetDefault(DoneStatus::Done),
                Phase::Ended,
            ),
            (
                ActionId::SetDefault,
                [0, 0, 0, 2],
                S::SetDefault(DoneStatus::NotDone),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 0],
                S::InitValve(InitValveStatus::Inactive),
                Phase::Ended,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 1],
                S::InitValve(InitValveStatus::ClosedPosition),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 2],
                S::InitValve(InitValveStatus::OpenPosition),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 3],
                S::InitValve(InitValveStatus::ControlFunction),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 4],
                S::InitValve(InitValveStatus::Times),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 5],
                S::InitValve(InitValveStatus::Characteristics),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0, 6],
                S::InitValve(InitValveStatus::PilotValves),
                Phase::Running,
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x16, 0xFE],
                S::InitValve(InitValveStatus::ErrorActive(e22)),
                Phase::WaitingForAcknowledge(e22),
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x16, 0xFF],
                S::InitValve(InitValveStatus::ErrorAcknowledged(e22)),
                Phase::EndedWithError(e22),
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x14, 0xFE],
                S::InitValve(InitValveStatus::ErrorActive(ErrorCode::POT_WRONG_DIR)),
                Phase::WaitingForAcknowledge(ErrorCode::POT_WRONG_DIR),
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x14, 0xFF],
                S::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::POT_WRONG_DIR)),
                Phase::EndedWithError(ErrorCode::POT_WRONG_DIR),
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x17, 0xFE],
                S::InitValve(InitValveStatus::ErrorActive(ErrorCode::LEAKAGE)),
                Phase::WaitingForAcknowledge(ErrorCode::LEAKAGE),
            ),
            (
                ActionId::InitValve,
                [0, 0, 0x17, 0xFF],
                S::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::LEAKAGE)),
                Phase::EndedWithError(ErrorCode::LEAKAGE),
            ),
            (
                ActionId::InitValve,
                [1, 0, 0, 0],
                S::InitValve(InitValveStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::GoClose,
                [0, 0, 0, 1],
                S::GoClose(GoStatus::Approaching),
                Phase::Running,
            ),
            (
                ActionId::GoClose,
                [0, 0, 0, 2],
                S::GoClose(GoStatus::Reached),
                Phase::Ended,
            ),
            (
                ActionId::GoClose,
                [0, 0, 0, 3],
                S::GoClose(GoStatus::Cancelled),
                Phase::Ended,
            ),
            (
                ActionId::GoClose,
                [1, 0, 0, 0],
                S::GoClose(GoStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::GoOpen,
                [0, 0, 0, 1],
                S::GoOpen(GoStatus::Approaching),
                Phase::Running,
            ),
            (
                ActionId::GoOpen,
                [0, 0, 0, 2],
                S::GoOpen(GoStatus::Reached),
                Phase::Ended,
            ),
            (
                ActionId::GoOpen,
                [0, 0, 0, 3],
                S::GoOpen(GoStatus::Cancelled),
                Phase::Ended,
            ),
            (
                ActionId::GoOpen,
                [1, 0, 0, 0],
                S::GoOpen(GoStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::FindFunction,
                [0, 0, 0, 1],
                S::FindFunction(FindFunctionStatus::Inactive),
                Phase::Ended,
            ),
            (
                ActionId::FindFunction,
                [0, 0, 0, 2],
                S::FindFunction(FindFunctionStatus::StartPosition),
                Phase::Running,
            ),
            (
                ActionId::FindFunction,
                [0, 0, 0, 3],
                S::FindFunction(FindFunctionStatus::TestPattern),
                Phase::Running,
            ),
            (
                ActionId::FindFunction,
                [1, 0, 0, 0],
                S::FindFunction(FindFunctionStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0, 1],
                S::AdjustTime(AdjustTimeStatus::Inactive),
                Phase::Ended,
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0, 2],
                S::AdjustTime(AdjustTimeStatus::StartPosition),
                Phase::Running,
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0, 3],
                S::AdjustTime(AdjustTimeStatus::MeasureClose),
                Phase::Running,
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0, 4],
                S::AdjustTime(AdjustTimeStatus::MeasureOpen),
                Phase::Running,
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0x16, 0xFE],
                S::AdjustTime(AdjustTimeStatus::ErrorActive(e22)),
                Phase::WaitingForAcknowledge(e22),
            ),
            (
                ActionId::AdjustTime,
                [0, 0, 0x16, 0xFF],
                S::AdjustTime(AdjustTimeStatus::ErrorAcknowledged(e22)),
                Phase::EndedWithError(e22),
            ),
            (
                ActionId::AdjustTime,
                [1, 0, 0, 0],
                S::AdjustTime(AdjustTimeStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::FindCoefficient,
                [0, 0, 0, 1],
                S::FindCoefficient(FindCoefficientStatus::Inactive),
                Phase::Ended,
            ),
            (
                ActionId::FindCoefficient,
                [0, 0, 7, 2],
                S::FindCoefficient(FindCoefficientStatus::ApproachPoint(7)),
                Phase::Running,
            ),
            (
                ActionId::FindCoefficient,
                [0, 0, 0x16, 0xFE],
                S::FindCoefficient(FindCoefficientStatus::ErrorActive(e22)),
                Phase::WaitingForAcknowledge(e22),
            ),
            (
                ActionId::FindCoefficient,
                [0, 0, 0x16, 0xFF],
                S::FindCoefficient(FindCoefficientStatus::ErrorAcknowledged(e22)),
                Phase::EndedWithError(e22),
            ),
            (
                ActionId::FindCoefficient,
                [1, 0, 0, 0],
                S::FindCoefficient(FindCoefficientStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0, 1],
                S::InitPilot(InitPilotStatus::Inactive),
                Phase::Ended,
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0, 2],
                S::InitPilot(InitPilotStatus::Active),
                Phase::Running,
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0x16, 0xFE],
                S::InitPilot(InitPilotStatus::ErrorActive(e22)),
                Phase::WaitingForAcknowledge(e22),
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0x16, 0xFF],
                S::InitPilot(InitPilotStatus::ErrorAcknowledged(e22)),
                Phase::EndedWithError(e22),
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0x17, 0xFE],
                S::InitPilot(InitPilotStatus::ErrorActive(ErrorCode::LEAKAGE)),
                Phase::WaitingForAcknowledge(ErrorCode::LEAKAGE),
            ),
            (
                ActionId::InitPilot,
                [0, 0, 0x17, 0xFF],
                S::InitPilot(InitPilotStatus::ErrorAcknowledged(ErrorCode::LEAKAGE)),
                Phase::EndedWithError(ErrorCode::LEAKAGE),
            ),
            (
                ActionId::InitPilot,
                [1, 0, 0, 0],
                S::InitPilot(InitPilotStatus::CannotBeStarted),
                Phase::CannotBeStarted,
            ),
        ];
        for (a, b, s, p) in cases {
            assert_eq!(ActionStatus::decode(*a, v(*b)), *s, "{a:?} {b:?}");
            assert_eq!(s.to_value(), v(*b));
            assert_eq!(s.phase(), *p, "{s:?}");
        }
        assert_eq!(
            ActionStatus::decode(ActionId::GoOpen, 9),
            ActionStatus::Unknown(9)
        );
        assert_eq!(
            ActionStatus::decode(ActionId::Unknown(0x55), 1),
            ActionStatus::Unknown(1)
        );
        assert_eq!(ActionStatus::Unknown(9).phase(), Phase::Unknown);
    }

    #[test]
    fn error_codes() {
        let expected = [
            (0, "NO ERROR"),
            (20, "PotWrongDir"),
            (21, "Wrong Func."),
            (22, "Pneumatic"),
            (23, "Leakage"),
            (30, "Air missing"),
            (40, "Bus Fault"),
            (60, "TrvlSensErr"),
        ];
        for (i, (c, n, m)) in ErrorCode::ALL.iter().enumerate() {
            assert_eq!((c.0, *n), expected[i]);
            assert!(!m.is_empty());
        }
        assert_eq!(ErrorCode(0x14), ErrorCode::POT_WRONG_DIR);
        assert_eq!(ErrorCode(0x1E), ErrorCode::AIR_MISSING);
        assert_eq!(ErrorCode(0x28), ErrorCode::BUS_FAULT);
        assert_eq!(ErrorCode(0x3C), ErrorCode::TRAVEL_SENSOR);
        assert_eq!(ErrorCode(99).name(), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn status_decode_is_lossless(id in 0u16..12, v in any::<u32>()) {
            let a = ActionId::from_u16(id);
            prop_assert_eq!(ActionStatus::decode(a, v).to_value(), v);
        }

        #[test]
        fn request_parts_lossless(id in 0u16..12, v in any::<u32>()) {
            let a = ActionId::from_u16(id);
            prop_assert_eq!(ActionRequest::from_parts(a, v).to_parts(), (a, v));
        }
    }
}
