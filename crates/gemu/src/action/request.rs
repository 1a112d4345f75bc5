//! The functions an 'A' request carries, per action (manual 5.6.10 .. 5.6.19), and the typed
//! request.

use super::ActionId;
use crate::params::RangeError;

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
