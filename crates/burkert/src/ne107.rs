//! NAMUR NE 107 device status (object 0x2004 sub 1, bits 0..3), as the Bürkert manual's §1.5
//! defines it: six states, each with a priority and an LED colour. The device shows the state of
//! its highest-priority active event.

use core::fmt;

use crate::colour::PredefinedColour;

/// A NAMUR NE 107 status value. Unknown values (6..=15 in bits 0..3) are preserved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Ne107Status {
    /// 0 — diagnosis inactive (white), lowest priority.
    DiagnosisInactive,
    /// 1 — diagnosis active (green).
    DiagnosisActive,
    /// 2 — maintenance required (blue).
    MaintenanceRequired,
    /// 3 — out of specification (yellow).
    OutOfSpecification,
    /// 4 — function check (orange).
    FunctionCheck,
    /// 5 — failure, error or fault (red), highest priority.
    Failure,
    /// A value of bits 0..3 the manual does not define.
    Unknown(u8),
}

impl Ne107Status {
    /// Every defined state, highest priority first (the manual's table order).
    pub const BY_PRIORITY: [Ne107Status; 6] = [
        Self::Failure,
        Self::FunctionCheck,
        Self::OutOfSpecification,
        Self::MaintenanceRequired,
        Self::DiagnosisActive,
        Self::DiagnosisInactive,
    ];

    /// Decodes the raw object value; only bits 0..3 carry the status.
    pub const fn from_raw(raw: u8) -> Self {
        match raw & 0x0F {
            0 => Self::DiagnosisInactive,
            1 => Self::DiagnosisActive,
            2 => Self::MaintenanceRequired,
            3 => Self::OutOfSpecification,
            4 => Self::FunctionCheck,
            5 => Self::Failure,
            other => Self::Unknown(other),
        }
    }

    /// Same as [`from_raw`](Self::from_raw), named like the other one-byte decoders of this
    /// crate (`CanOperationStatus::from_u8`, `TransMemStatus::from_u8`).
    pub const fn from_u8(raw: u8) -> Self {
        Self::from_raw(raw)
    }

    /// The value in bits 0..3.
    pub const fn to_raw(self) -> u8 {
        match self {
            Self::DiagnosisInactive => 0,
            Self::DiagnosisActive => 1,
            Self::MaintenanceRequired => 2,
            Self::OutOfSpecification => 3,
            Self::FunctionCheck => 4,
            Self::Failure => 5,
            Self::Unknown(v) => v & 0x0F,
        }
    }

    /// The manual's priority rank: 1 is the highest (failure), 6 the lowest (diagnosis
    /// inactive). Unknown values rank below every defined state (7).
    pub const fn priority_rank(self) -> u8 {
        match self {
            Self::Failure => 1,
            Self::FunctionCheck => 2,
            Self::OutOfSpecification => 3,
            Self::MaintenanceRequired => 4,
            Self::DiagnosisActive => 5,
            Self::DiagnosisInactive => 6,
            Self::Unknown(_) => 7,
        }
    }

    /// Whether `self` takes precedence over `other` on the status LED.
    pub const fn outranks(self, other: Ne107Status) -> bool {
        self.priority_rank() < other.priority_rank()
    }

    /// The status the device shows for a set of active events: the one of highest priority;
    /// "diagnosis inactive" when no event is active.
    pub fn highest<I: IntoIterator<Item = Ne107Status>>(active: I) -> Ne107Status {
        active.into_iter().fold(Self::DiagnosisInactive, |best, s| {
            if s.outranks(best) { s } else { best }
        })
    }

    /// The LED colour of this state in NAMUR mode; `None` for unknown values.
    pub const fn colour(self) -> Option<PredefinedColour> {
        Some(match self {
            Self::Failure => PredefinedColour::Red,
            Self::FunctionCheck => PredefinedColour::Orange,
            Self::OutOfSpecification => PredefinedColour::Yellow,
            Self::MaintenanceRequired => PredefinedColour::Blue,
            Self::DiagnosisActive => PredefinedColour::Green,
            Self::DiagnosisInactive => PredefinedColour::White,
            Self::Unknown(_) => return None,
        })
    }

    /// English meaning.
    pub const fn meaning_en(self) -> &'static str {
        match self {
            Self::Failure => "failure, error or fault",
            Self::FunctionCheck => "function check",
            Self::OutOfSpecification => "out of specification",
            Self::MaintenanceRequired => "maintenance required",
            Self::DiagnosisActive => "diagnosis active",
            Self::DiagnosisInactive => "diagnosis inactive",
            Self::Unknown(_) => "unknown NE 107 status",
        }
    }

    /// German meaning, as the manual words it.
    pub const fn meaning_de(self) -> &'static str {
        match self {
            Self::Failure => "Ausfall, Fehler oder Störung",
            Self::FunctionCheck => "Funktionskontrolle",
            Self::OutOfSpecification => "Außerhalb der Spezifikation",
            Self::MaintenanceRequired => "Wartungsbedarf",
            Self::DiagnosisActive => "Diagnose aktiv",
            Self::DiagnosisInactive => "Diagnose inaktiv",
            Self::Unknown(_) => "unbekannter NE-107-Status",
        }
    }
}

impl fmt::Display for Ne107Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown(v) => write!(f, "unknown NE 107 status {v}"),
            s => f.write_str(s.meaning_en()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manual's §1.5 table: (priority rank, colour, value).
    #[test]
    fn manual_table() {
        let table = [
            (1, PredefinedColour::Red, 5),
            (2, PredefinedColour::Orange, 4),
            (3, PredefinedColour::Yellow, 3),
            (4, PredefinedColour::Blue, 2),
            (5, PredefinedColour::Green, 1),
            (6, PredefinedColour::White, 0),
        ];
        for (i, (rank, colour, value)) in table.into_iter().enumerate() {
            let s = Ne107Status::from_raw(value);
            assert_eq!(Ne107Status::BY_PRIORITY[i], s);
            assert_eq!(s.priority_rank(), rank);
            assert_eq!(s.colour(), Some(colour));
            assert_eq!(s.to_raw(), value);
        }
    }

    #[test]
    fn only_low_nibble_counts_and_unknown_is_kept() {
        assert_eq!(Ne107Status::from_raw(0xF5), Ne107Status::Failure);
        assert_eq!(Ne107Status::from_raw(9), Ne107Status::Unknown(9));
        assert_eq!(Ne107Status::Unknown(9).to_raw(), 9);
        assert_eq!(Ne107Status::Unknown(9).colour(), None);
    }

    #[test]
    fn highest_priority_wins() {
        use Ne107Status::*;
        assert_eq!(Ne107Status::highest([]), DiagnosisInactive);
        assert_eq!(
            Ne107Status::highest([MaintenanceRequired, DiagnosisActive]),
            MaintenanceRequired
        );
        // Maintenance shows blue only while nothing of higher priority is active.
        assert_eq!(
            Ne107Status::highest([MaintenanceRequired, OutOfSpecification]),
            OutOfSpecification
        );
        assert_eq!(
            Ne107Status::highest([FunctionCheck, Failure, MaintenanceRequired]),
            Failure
        );
        assert_eq!(
            Ne107Status::highest([Unknown(9), DiagnosisActive]),
            DiagnosisActive
        );
    }
}
