//! The statuses an action's answer carries, per action (manual 5.6.10 .. 5.6.19), and where an
//! action stands ([`Phase`]).

use core::fmt;

use super::request::NoInitFunction;
use super::{ActionId, ErrorCode};

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
                NoInitFunction::OpenPwm(p) => return write!(f, "opening with PWM {}", p.get()),
                NoInitFunction::ClosePwm(p) => return write!(f, "closing with PWM {}", p.get()),
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
