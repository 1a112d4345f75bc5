//! The device status LED: LED mode (0x2120), valve-mode colours (0x2121), the external colour
//! (0x2122), and the pure function that tells which colour the LED shows.

use core::fmt;

use crate::colour::{LedColour, PredefinedColour};
use crate::ne107::Ne107Status;

/// Object 0x2120, LED mode (UNSIGNED32, default 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LedMode {
    /// 0 — colour from the NAMUR NE 107 device status.
    #[default]
    Namur,
    /// 2 — valve mode: colours of 0x2121 by valve position (valves only).
    Valve,
    /// 3 — valve mode with warnings: valve colours, NE 107 warnings and failures take over.
    ValveWithWarnings,
    /// 4 — a fixed colour, 0x2122.
    FixedColour,
    /// 6 — LED always off.
    Off,
}

/// An LED mode value the manual does not define (1, 5, 7 and above).
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "{0} is not a Bürkert LED mode (0 NAMUR, 2 valve, 3 valve + warnings, 4 fixed colour, 6 off)"
)]
pub struct LedModeError(pub u32);

debug_as_display!(LedModeError);

impl LedMode {
    /// All modes in value order.
    pub const ALL: [LedMode; 5] = [
        Self::Namur,
        Self::Valve,
        Self::ValveWithWarnings,
        Self::FixedColour,
        Self::Off,
    ];

    /// Decodes 0x2120; undefined values are an error.
    pub const fn from_u32(raw: u32) -> Result<Self, LedModeError> {
        match raw {
            0 => Ok(Self::Namur),
            2 => Ok(Self::Valve),
            3 => Ok(Self::ValveWithWarnings),
            4 => Ok(Self::FixedColour),
            6 => Ok(Self::Off),
            other => Err(LedModeError(other)),
        }
    }

    /// The object value.
    pub const fn to_u32(self) -> u32 {
        match self {
            Self::Namur => 0,
            Self::Valve => 2,
            Self::ValveWithWarnings => 3,
            Self::FixedColour => 4,
            Self::Off => 6,
        }
    }

    /// Short name as the CLI accepts it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Namur => "namur",
            Self::Valve => "valve",
            Self::ValveWithWarnings => "valve-warnings",
            Self::FixedColour => "fixed",
            Self::Off => "off",
        }
    }

    /// Parses [`LedMode::name`] or the numeric value.
    pub fn from_name(s: &str) -> Result<Self, LedModeError> {
        let s = s.trim();
        Self::ALL
            .into_iter()
            .find(|m| s.eq_ignore_ascii_case(m.name()))
            .map_or_else(
                || {
                    s.parse::<u32>()
                        .map_err(|_| LedModeError(u32::MAX))
                        .and_then(Self::from_u32)
                },
                Ok,
            )
    }
}

impl fmt::Display for LedMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a three-position valve stands (valve mode colours).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ValvePosition {
    /// Closed: 0x2121 sub 1.
    Closed,
    /// Between closed and open: 0x2121 sub 2.
    Between,
    /// Open: 0x2121 sub 3.
    Open,
}

/// Object 0x2121, valve mode configuration: one colour per valve position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ValveModeColours {
    /// Sub 1, default green 0x10000002.
    pub closed: LedColour,
    /// Sub 2, default off 0x10000000.
    pub between: LedColour,
    /// Sub 3, default yellow 0x10000004.
    pub open: LedColour,
}

impl Default for ValveModeColours {
    /// The manual's defaults.
    fn default() -> Self {
        Self {
            closed: PredefinedColour::Green.into(),
            between: PredefinedColour::Off.into(),
            open: PredefinedColour::Yellow.into(),
        }
    }
}

impl ValveModeColours {
    /// The colour for a valve position.
    pub const fn for_position(&self, p: ValvePosition) -> LedColour {
        match p {
            ValvePosition::Closed => self.closed,
            ValvePosition::Between => self.between,
            ValvePosition::Open => self.open,
        }
    }
}

/// Everything the status LED depends on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LedState {
    /// 0x2120.
    pub mode: LedMode,
    /// The device status (0x2004 sub 1): already the highest-priority active event; see
    /// [`Ne107Status::highest`].
    pub status: Ne107Status,
    /// The valve position, for valves; `None` for devices without one.
    pub valve: Option<ValvePosition>,
    /// 0x2121.
    pub valve_colours: ValveModeColours,
    /// 0x2122, default white.
    pub external: LedColour,
    /// 0x2101 locating active: the LED flashes.
    pub locating: bool,
}

impl Default for LedState {
    fn default() -> Self {
        Self {
            mode: LedMode::Namur,
            status: Ne107Status::DiagnosisInactive,
            valve: None,
            valve_colours: ValveModeColours::default(),
            external: PredefinedColour::White.into(),
            locating: false,
        }
    }
}

/// What the LED shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LedIndication {
    /// The colour (off included).
    pub colour: LedColour,
    /// Flashing (the locating function).
    pub flashing: bool,
}

impl LedState {
    /// The colour the status LED shows.
    ///
    /// - NAMUR mode: the NE 107 colour of the status (an unknown status value shows off).
    /// - Valve mode: the 0x2121 colour of the valve position; a device without a valve position
    ///   falls back to the NE 107 colour (the manual restricts valve mode to valves).
    /// - Valve mode + warnings: as valve mode, except that a status from "maintenance required"
    ///   upwards (a warning or a failure) shows its NE 107 colour. The manual names the mode
    ///   without spelling the rule out; this is our reading of it.
    /// - Fixed colour: 0x2122. Off: off, even while locating.
    pub fn indication(&self) -> LedIndication {
        let namur = || {
            self.status
                .colour()
                .map_or(LedColour::OFF, LedColour::Predefined)
        };
        let colour = match self.mode {
            LedMode::Namur => namur(),
            LedMode::Valve => self
                .valve
                .map_or_else(namur, |p| self.valve_colours.for_position(p)),
            LedMode::ValveWithWarnings => {
                if self.status.priority_rank() <= Ne107Status::MaintenanceRequired.priority_rank() {
                    namur()
                } else {
                    self.valve
                        .map_or_else(namur, |p| self.valve_colours.for_position(p))
                }
            }
            LedMode::FixedColour => self.external,
            LedMode::Off => LedColour::OFF,
        };
        LedIndication {
            colour,
            flashing: self.locating && self.mode != LedMode::Off,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Ne107Status::*;
    use PredefinedColour as P;

    #[test]
    fn mode_values() {
        for (raw, mode) in [
            (0, LedMode::Namur),
            (2, LedMode::Valve),
            (3, LedMode::ValveWithWarnings),
            (4, LedMode::FixedColour),
            (6, LedMode::Off),
        ] {
            assert_eq!(LedMode::from_u32(raw), Ok(mode));
            assert_eq!(mode.to_u32(), raw);
            assert_eq!(LedMode::from_name(mode.name()), Ok(mode));
        }
        for bad in [1, 5, 7, 0xFFFF_FFFF] {
            assert_eq!(LedMode::from_u32(bad), Err(LedModeError(bad)));
        }
        assert_eq!(LedMode::default(), LedMode::Namur);
        assert_eq!(LedMode::from_name("4"), Ok(LedMode::FixedColour));
        assert!(LedMode::from_name("blink").is_err());
    }

    #[test]
    fn valve_defaults() {
        let d = ValveModeColours::default();
        assert_eq!(d.closed.to_u32(), 0x1000_0002);
        assert_eq!(d.between.to_u32(), 0x1000_0000);
        assert_eq!(d.open.to_u32(), 0x1000_0004);
    }

    /// (mode, status, valve, expected colour)
    #[test]
    fn indication_table() {
        let custom = LedColour::rgb(0, 255, 255);
        let rows: [(LedMode, Ne107Status, Option<ValvePosition>, LedColour); 16] = [
            (LedMode::Namur, DiagnosisInactive, None, P::White.into()),
            (LedMode::Namur, DiagnosisActive, None, P::Green.into()),
            (LedMode::Namur, MaintenanceRequired, None, P::Blue.into()),
            (LedMode::Namur, OutOfSpecification, None, P::Yellow.into()),
            (LedMode::Namur, FunctionCheck, None, P::Orange.into()),
            (LedMode::Namur, Failure, None, P::Red.into()),
            (LedMode::Namur, Unknown(9), None, LedColour::OFF),
            (
                LedMode::Valve,
                Failure,
                Some(ValvePosition::Closed),
                P::Green.into(),
            ),
            (
                LedMode::Valve,
                DiagnosisInactive,
                Some(ValvePosition::Between),
                P::Off.into(),
            ),
            (
                LedMode::Valve,
                DiagnosisInactive,
                Some(ValvePosition::Open),
                P::Yellow.into(),
            ),
            (LedMode::Valve, MaintenanceRequired, None, P::Blue.into()),
            (
                LedMode::ValveWithWarnings,
                DiagnosisActive,
                Some(ValvePosition::Open),
                P::Yellow.into(),
            ),
            (
                LedMode::ValveWithWarnings,
                MaintenanceRequired,
                Some(ValvePosition::Open),
                P::Blue.into(),
            ),
            (
                LedMode::ValveWithWarnings,
                Failure,
                Some(ValvePosition::Closed),
                P::Red.into(),
            ),
            (
                LedMode::FixedColour,
                Failure,
                Some(ValvePosition::Open),
                custom,
            ),
            (
                LedMode::Off,
                Failure,
                Some(ValvePosition::Open),
                LedColour::OFF,
            ),
        ];
        for (mode, status, valve, want) in rows {
            let s = LedState {
                mode,
                status,
                valve,
                external: custom,
                ..LedState::default()
            };
            assert_eq!(s.indication().colour, want, "{mode:?} {status:?} {valve:?}");
        }
    }

    #[test]
    fn maintenance_blue_unless_higher_priority() {
        let status = Ne107Status::highest([MaintenanceRequired, DiagnosisActive]);
        assert_eq!(
            LedState {
                status,
                ..LedState::default()
            }
            .indication()
            .colour,
            P::Blue.into()
        );
        let status = Ne107Status::highest([MaintenanceRequired, FunctionCheck]);
        assert_eq!(
            LedState {
                status,
                ..LedState::default()
            }
            .indication()
            .colour,
            P::Orange.into()
        );
    }

    #[test]
    fn locating_flashes_unless_off() {
        let s = LedState {
            locating: true,
            ..LedState::default()
        };
        assert!(s.indication().flashing);
        let s = LedState {
            locating: true,
            mode: LedMode::Off,
            ..LedState::default()
        };
        assert!(!s.indication().flashing);
    }
}
