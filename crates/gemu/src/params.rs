//! The parameter table of the manual's chapter 6 ("Parametertabelle" / "Parameters table") as
//! static data, with typed enumerations and range checks.
//!
//! Each row carries both ID columns as transcribed (hex as [`ParamId`], decimal as
//! [`ParamDef::decimal`]); a test asserts they agree for every row. "Write" in the access column
//! means read and write; "Read" means read-only.
//!
//! OCR conflicts and how they are resolved (each is also noted at its row):
//! - In 2: the English hex column reads `0CE6` (the ID of In 1), the German copy `0CE7`; the
//!   decimal column reads 3303 in both. 3303 = 0x0CE7, so the ID is 0x0CE7.
//! - DeviceNet Adr: hex `1450` (= 5200) but decimal `5100` (= 0x13EC) in both copies. 0x1450 is
//!   taken: it sits beside Baudrate 0x1453 = 5203 in the same submenu, while 5101 (= 0x13ED) is
//!   already PwrOnT.Out. The decimal column is recorded as 5200.
//! - Unreadable enumerations (Warnings, Errors, Dlight, Helptext, ProcCtrlMode, K1 Switch,
//!   K2 Switch, X-Direction, W-Direction, Y-Direction, Pot Dir, Scaling) are plain integers
//!   ([`ValueKind::Integer`]) rather than guessed labels. Each of their cells shows two lines, so
//!   the range 0..=1 is assumed; the device's own 0x20/0x21 diagnostics remain the final word.
//! - CalPointQty reads "[1 .1 9]" / "[1 2 9]": taken as [1..9].
//! - "adjtTimeClose" is taken as adjTimeClose (the same spelling as adjTimeOpen); "sec [0.59]" as
//!   [0..59].
//! - K1 Fn 8 reads "5 e" in K1's cell; K2's identical list gives "X max", used for both.
//! - CpyParaSet entry 1 reads "P1<=W" in both copies; kept as read.
//! - HelpLanguage entry 2 reads "N" in both copies; kept as read.
//! - The table's scale "*0,1 %" is per mille; "*0,1" without unit is a gain in tenths.
//! - The manual gives no default values except the DeviceNet address 63 (used by the simulator).

use core::fmt;

/// A parameter ID (the channel's id for 'S' and 'G').
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParamId(pub u16);

/// Read-only or read-write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Access {
    /// "Read": the value can only be read.
    Read,
    /// "Write": the value can be read and written.
    Write,
}

/// Unit and scale of a numeric parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unit {
    /// No unit.
    None,
    /// "*0,1 %": per mille.
    PerMille,
    /// "*0,1": a dimensionless gain in tenths.
    Tenths,
    /// "*0,1 s".
    DeciSeconds,
    /// "*0,01 s".
    CentiSeconds,
    /// "ms".
    Milliseconds,
    /// "s".
    Seconds,
    /// "min".
    Minutes,
    /// "h".
    Hours,
}

impl Unit {
    /// (divisor, symbol) to show a raw value in engineering units.
    pub const fn scale(self) -> (u32, &'static str) {
        match self {
            Unit::None => (1, ""),
            Unit::PerMille => (10, "%"),
            Unit::Tenths => (10, ""),
            Unit::DeciSeconds => (10, "s"),
            Unit::CentiSeconds => (100, "s"),
            Unit::Milliseconds => (1, "ms"),
            Unit::Seconds => (1, "s"),
            Unit::Minutes => (1, "min"),
            Unit::Hours => (1, "h"),
        }
    }
}

/// What the value of a parameter means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ValueKind {
    /// A number with a unit.
    Number(Unit),
    /// An enumeration; the labels are indexed by value (all tables are contiguous from 0).
    Enum(&'static [&'static str]),
    /// An enumeration whose labels are unreadable in the manual: a plain integer.
    Integer,
}

/// A value outside a parameter's range.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RangeError {
    /// Below the minimum (the device would raise diagnostic 0x20).
    #[error("{value} is below the minimum {min}")]
    BelowRange {
        /// The value.
        value: i64,
        /// The minimum.
        min: i64,
    },
    /// Above the maximum (the device would raise diagnostic 0x21).
    #[error("{value} is above the maximum {max}")]
    AboveRange {
        /// The value.
        value: i64,
        /// The maximum.
        max: i64,
    },
}

debug_as_display!(RangeError);

/// One row of the parameter table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ParamDef {
    /// The manual's name (English copy).
    pub name: &'static str,
    /// The ID from the hex column.
    pub id: ParamId,
    /// The decimal column as transcribed (after resolving the conflicts above).
    pub decimal: u16,
    /// Configuration level: 0 for Mode (top of SETUP), 1 Service .. 5 Communication.
    pub level: u8,
    /// Access.
    pub access: Access,
    /// Smallest value.
    pub min: i32,
    /// Largest value.
    pub max: i32,
    /// Meaning of the value.
    pub kind: ValueKind,
    /// "*": only with the process controller activated.
    pub process_controller_only: bool,
}

impl ParamDef {
    /// Checks `value` against the range.
    pub const fn check(&self, value: i64) -> Result<(), RangeError> {
        if value < self.min as i64 {
            Err(RangeError::BelowRange {
                value,
                min: self.min as i64,
            })
        } else if value > self.max as i64 {
            Err(RangeError::AboveRange {
                value,
                max: self.max as i64,
            })
        } else {
            Ok(())
        }
    }

    /// Whether the parameter can be written.
    pub const fn writable(&self) -> bool {
        matches!(self.access, Access::Write)
    }

    /// The label of an enumeration value, if this is an enumeration and the value has one.
    pub fn label(&self, value: i32) -> Option<&'static str> {
        match self.kind {
            ValueKind::Enum(labels) => usize::try_from(value)
                .ok()
                .and_then(|i| labels.get(i).copied()),
            _ => None,
        }
    }

    /// Parses a value given as a number or (for enumerations) a label, ignoring case and
    /// spaces. Does not check the range.
    pub fn parse_value(&self, text: &str) -> Option<i32> {
        let t = text.trim();
        if let Ok(v) = t.parse::<i32>() {
            return Some(v);
        }
        if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
            return u32::from_str_radix(h, 16).ok().map(|v| v as i32);
        }
        match self.kind {
            ValueKind::Enum(labels) => labels
                .iter()
                .position(|l| names_match(l, t))
                .and_then(|i| i32::try_from(i).ok()),
            _ => None,
        }
    }

    /// Shows a value with its label or unit ("2 (Manual)", "50.0 %").
    pub const fn display(&self, value: i32) -> ValueDisplay {
        ValueDisplay { def: *self, value }
    }
}

/// A value shown with its label or unit; see [`ParamDef::display`].
#[derive(Debug, Clone, Copy)]
pub struct ValueDisplay {
    def: ParamDef,
    value: i32,
}

impl fmt::Display for ValueDisplay {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.def.kind {
            ValueKind::Enum(_) => match self.def.label(self.value) {
                Some(l) => write!(f, "{} ({l})", self.value),
                None => write!(f, "{} (no label)", self.value),
            },
            ValueKind::Integer => write!(f, "{}", self.value),
            ValueKind::Number(unit) => {
                let (div, sym) = unit.scale();
                let sep = if sym.is_empty() { "" } else { " " };
                if div == 1 {
                    write!(f, "{}{sep}{sym}", self.value)
                } else {
                    let v = self.value as i64;
                    let sign = if v < 0 { "-" } else { "" };
                    let a = v.unsigned_abs();
                    let digits = if div == 100 { 2 } else { 1 };
                    write!(
                        f,
                        "{sign}{}.{:0digits$}{sep}{sym}",
                        a / div as u64,
                        a % div as u64
                    )
                }
            }
        }
    }
}

/// Compares names ignoring ASCII case and the characters ' ', '.', '-', '_'.
pub fn names_match(a: &str, b: &str) -> bool {
    let skip = |c: &char| !matches!(c, ' ' | '.' | '-' | '_');
    let mut x = a.chars().filter(skip);
    let mut y = b.chars().filter(skip);
    loop {
        match (x.next(), y.next()) {
            (None, None) => return true,
            (Some(p), Some(q)) if p.eq_ignore_ascii_case(&q) => {}
            _ => return false,
        }
    }
}

macro_rules! param_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $var:ident = $val:literal $label:literal,)+ }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name {
            $($(#[$vm])* $var = $val,)+
        }

        impl $name {
            /// The manual's labels, indexed by value.
            pub const LABELS: &'static [&'static str] = &[$($label,)+];

            /// The raw parameter value.
            pub const fn to_raw(self) -> i32 {
                self as i32
            }

            /// From a raw parameter value, if it is one of the listed values.
            pub const fn from_raw(v: i32) -> Option<Self> {
                match v {
                    $($val => Some(Self::$var),)+
                    _ => None,
                }
            }
        }

        impl From<$name> for i32 {
            fn from(v: $name) -> i32 {
                v.to_raw()
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(Self::LABELS[*self as usize])
            }
        }
    };
}

param_enum!(
    /// Mode (0x0064).
    Mode {
        /// 0 OFF.
        Off = 0 "OFF",
        /// 1 Auto.
        Auto = 1 "Auto",
        /// 2 Manual.
        Manual = 2 "Manual",
        /// 3 Manual-Flex.
        ManualFlex = 3 "Manual-Flex",
        /// 4 Test.
        Test = 4 "Test",
    }
);

param_enum!(
    /// ActiveParaSet (0x03E8).
    ParaSet {
        /// 0 P1.
        P1 = 0 "P1",
        /// 1 P2.
        P2 = 1 "P2",
        /// 2 P3.
        P3 = 2 "P3",
        /// 3 P4.
        P4 = 3 "P4",
    }
);

param_enum!(
    /// SensTest (0x0451).
    SensTest {
        /// 0 Disable.
        Disable = 0 "Disable",
        /// 1 Enabled.
        Enabled = 1 "Enabled",
    }
);

param_enum!(
    /// HelpLanguage (0x07D4). Entry 2 is kept as the manual prints it ("N").
    HelpLanguage {
        /// 0 D (German).
        D = 0 "D",
        /// 1 GB (English).
        Gb = 1 "GB",
        /// 2 "N" as printed.
        N = 2 "N",
    }
);

param_enum!(
    /// PwrOnMode (0x07D6).
    PwrOnMode {
        /// 0 Fast.
        Fast = 0 "Fast",
        /// 1 Safe.
        Safe = 1 "Safe",
    }
);

param_enum!(
    /// CtrlFn, the valve's control function (0x0834).
    CtrlFn {
        /// 0 NC (normally closed).
        Nc = 0 "NC",
        /// 1 NO (normally open).
        No = 1 "NO",
        /// 2 DA (double acting).
        Da = 2 "DA",
        /// 3 Boost NC.
        BoostNc = 3 "Boost NC",
        /// 4 Boost NO.
        BoostNo = 4 "Boost NO",
        /// 5 Auto.
        Auto = 5 "Auto",
        /// 6 Auto NC.
        AutoNc = 6 "Auto NC",
        /// 7 Auto NO.
        AutoNo = 7 "Auto NO",
        /// 8 Auto DA.
        AutoDa = 8 "Auto DA",
        /// 9 Auto NC B.
        AutoNcB = 9 "Auto NC B",
        /// 10 Auto NO B.
        AutoNoB = 10 "Auto NO B",
    }
);

param_enum!(
    /// CpyParaSet (0x0BBA): copy parameter sets.
    CpyParaSet {
        /// 0 OFF.
        Off = 0 "OFF",
        /// 1 "P1<=W" as printed.
        P1FromW = 1 "P1<=W",
        /// 2 P1=>P2.
        P1ToP2 = 2 "P1=>P2",
        /// 3 P1<=P2.
        P1FromP2 = 3 "P1<=P2",
        /// 4 P1=>P3.
        P1ToP3 = 4 "P1=>P3",
        /// 5 P1<=P3.
        P1FromP3 = 5 "P1<=P3",
        /// 6 P1=>P4.
        P1ToP4 = 6 "P1=>P4",
        /// 7 P1<=P4.
        P1FromP4 = 7 "P1<=P4",
    }
);

param_enum!(
    /// IxType (0x0C20).
    IxType {
        /// 0 OFF.
        Off = 0 "OFF",
        /// 1 RC.
        Rc = 1 "RC",
        /// 2 avr.
        Avr = 2 "avr",
    }
);

param_enum!(
    /// Function of a digital input: In W, In X, In 1, In 2 (0x0CE4..0x0CE7).
    InputFn {
        /// 0 OFF.
        Off = 0 "OFF",
        /// 1 OFF/ON.
        OffOn = 1 "OFF/ON",
        /// 2 Save/ON.
        SaveOn = 2 "Save/ON",
        /// 3 ParamSetB0.
        ParamSetB0 = 3 "ParamSetB0",
        /// 4 ParamSetB1.
        ParamSetB1 = 4 "ParamSetB1",
        /// 5 Poti/Ix.
        PotiIx = 5 "Poti/Ix",
    }
);

param_enum!(
    /// Function of a digital output: K1 Fn, K2 Fn (0x0D49, 0x0D4D).
    OutputFn {
        /// 0 No.
        No = 0 "No",
        /// 1 P min.
        PMin = 1 "P min",
        /// 2 P max.
        PMax = 2 "P max",
        /// 3 P min/max.
        PMinMax = 3 "P min/max",
        /// 4 W min.
        WMin = 4 "W min",
        /// 5 W max.
        WMax = 5 "W max",
        /// 6 W min/max.
        WMinMax = 6 "W min/max",
        /// 7 X min.
        XMin = 7 "X min",
        /// 8 X max.
        XMax = 8 "X max",
        /// 9 X min/max.
        XMinMax = 9 "X min/max",
        /// 10 Active.
        Active = 10 "Active",
        /// 11 Error.
        Error = 11 "Error",
        /// 12 Warning.
        Warning = 12 "Warning",
        /// 13 SSE min.
        SseMin = 13 "SSE min",
        /// 14 SSE max.
        SseMax = 14 "SSE max",
        /// 15 SSE min/max.
        SseMinMax = 15 "SSE min/max",
    }
);

param_enum!(
    /// ErrorAction (0x0D51).
    ErrorAction {
        /// 0 Close.
        Close = 0 "Close",
        /// 1 Open.
        Open = 1 "Open",
        /// 2 Hold.
        Hold = 2 "Hold",
    }
);

param_enum!(
    /// W-Function, the set-value characteristic (0x0FA2).
    WFunction {
        /// 0 lin.
        Linear = 0 "lin.",
        /// 1 1:25.
        OneTo25 = 1 "1:25",
        /// 2 1:50.
        OneTo50 = 2 "1:50",
        /// 3 free.
        Free = 3 "free",
    }
);

param_enum!(
    /// Baudrate (0x1453).
    Baudrate {
        /// 0 125 kBaud.
        K125 = 0 "125 KBaud",
        /// 1 250 kBaud.
        K250 = 1 "250 KBaud",
        /// 2 500 kBaud.
        K500 = 2 "500 KBaud",
    }
);

macro_rules! table {
    ($($(#[$m:meta])* $konst:ident = $hex:literal, $dec:literal, $name:literal, $level:literal, $acc:ident, [$min:literal ..= $max:literal], $kind:expr, $pc:literal;)+) => {
        impl ParamId {
            $($(#[$m])* #[doc = concat!("`", $name, "`")] pub const $konst: ParamId = ParamId($hex);)+
        }

        /// The parameter table of chapter 6, in the manual's order.
        pub static PARAMETERS: &[ParamDef] = &[
            $(ParamDef {
                name: $name,
                id: ParamId($hex),
                decimal: $dec,
                level: $level,
                access: Access::$acc,
                min: $min,
                max: $max,
                kind: $kind,
                process_controller_only: $pc,
            },)+
        ];
    };
}

use Unit as U;
use ValueKind::{Enum, Integer, Number};

table! {
    MODE = 0x0064, 100, "Mode", 0, Write, [0..=4], Enum(Mode::LABELS), false;
    // 1 Service: inputs and outputs
    ACTIVE_PARA_SET = 0x03E8, 1000, "ActiveParaSet", 1, Read, [0..=3], Enum(ParaSet::LABELS), false;
    POT_MIN = 0x03E9, 1001, "Pot Min", 1, Read, [0..=1000], Number(U::PerMille), false;
    POT_MAX = 0x03EA, 1002, "Pot Max", 1, Read, [0..=1000], Number(U::PerMille), false;
    PROC_W = 0x03EB, 1003, "ProcW", 1, Read, [0..=1000], Number(U::PerMille), true;
    PROC_X = 0x03EC, 1004, "ProcX", 1, Read, [0..=1000], Number(U::PerMille), true;
    POS_W = 0x03ED, 1005, "PosW", 1, Read, [0..=1000], Number(U::PerMille), false;
    POS_X = 0x03EE, 1006, "Pos X", 1, Read, [0..=1000], Number(U::PerMille), false;
    POT_ABS = 0x03EF, 1007, "Pot Abs", 1, Read, [0..=1000], Number(U::PerMille), false;
    PROC_CTRL_OUT = 0x03F0, 1008, "Proc Ctrl Out", 1, Read, [0..=1000], Number(U::PerMille), false;
    POS_CTRL_OUT = 0x03F1, 1009, "Pos Ctrl Out", 1, Read, [-1000..=1000], Number(U::PerMille), false;
    // 1 Service: diagnostic messages
    HRS = 0x044C, 1100, "hrs", 1, Read, [0..=99999], Number(U::Hours), false;
    MIN = 0x044D, 1101, "min", 1, Read, [0..=59], Number(U::Minutes), false;
    /// The OCR reads "[0.59]"; taken as [0..59].
    SEC = 0x044E, 1102, "sec", 1, Read, [0..=59], Number(U::Seconds), false;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    WARNINGS = 0x044F, 1103, "Warnings", 1, Write, [0..=1], Integer, false;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    ERRORS = 0x0450, 1104, "Errors", 1, Write, [0..=1], Integer, false;
    SENS_TEST = 0x0451, 1105, "SensTest", 1, Write, [0..=1], Enum(SensTest::LABELS), false;
    // 2 SetBasics
    /// The OCR reads "[1 .1 9]" / "[1 2 9]"; taken as [1..9].
    CAL_POINT_QTY = 0x07D0, 2000, "CalPointQty", 2, Write, [1..=9], Number(U::None), false;
    D_REFRESH = 0x07D1, 2001, "D.Refresh", 2, Write, [1..=10], Number(U::DeciSeconds), false;
    /// Enumeration unreadable ("0: ON / 1 ON Key" at best): a plain integer, 0..=1.
    DLIGHT = 0x07D2, 2002, "Dlight", 2, Write, [0..=1], Integer, false;
    AUTO_RETURN = 0x07D3, 2003, "AutoReturn", 2, Write, [1..=60], Number(U::Minutes), false;
    HELP_LANGUAGE = 0x07D4, 2004, "HelpLanguage", 2, Write, [0..=2], Enum(HelpLanguage::LABELS), false;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    HELPTEXT = 0x07D5, 2005, "Helptext", 2, Write, [0..=1], Integer, false;
    PWR_ON_MODE = 0x07D6, 2006, "PwrOnMode", 2, Write, [0..=1], Enum(PwrOnMode::LABELS), false;
    // 2 SetBasics: initialisation
    CTRL_FN = 0x0834, 2100, "CtrlFn", 2, Write, [0..=10], Enum(CtrlFn::LABELS), false;
    /// The OCR reads "adjtTimeClose".
    ADJ_TIME_CLOSE = 0x0835, 2101, "adjTimeClose", 2, Read, [0..=999], Number(U::DeciSeconds), false;
    ADJ_TIME_OPEN = 0x0836, 2102, "adjTimeOpen", 2, Read, [0..=999], Number(U::DeciSeconds), false;
    // 3 SetFunction
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    PROC_CTRL_MODE = 0x0BB8, 3000, "ProcCtrlMode", 3, Write, [0..=1], Integer, true;
    DEAD_BAND = 0x0BB9, 3001, "DeadBand", 3, Write, [1..=250], Number(U::PerMille), false;
    CPY_PARA_SET = 0x0BBA, 3002, "CpyParaSet", 3, Write, [0..=7], Enum(CpyParaSet::LABELS), false;
    // 3 SetFunction: process controller
    PROC_P = 0x0C1C, 3100, "Proc-P", 3, Write, [0..=1000], Number(U::Tenths), true;
    PROC_I = 0x0C1D, 3101, "Proc-I", 3, Write, [0..=9999], Number(U::DeciSeconds), true;
    PROC_D = 0x0C1E, 3102, "Proc-D", 3, Write, [0..=1000], Number(U::Tenths), true;
    PROC_T = 0x0C1F, 3103, "Proc-T", 3, Write, [1..=10000], Number(U::Milliseconds), true;
    IX_TYPE = 0x0C20, 3104, "IxType", 3, Write, [0..=2], Enum(IxType::LABELS), false;
    IX_FILTER = 0x0C21, 3105, "IxFilter", 3, Write, [10..=2000], Number(U::CentiSeconds), false;
    // 3 SetFunction: positioner
    POS_P = 0x0C80, 3200, "Pos P", 3, Write, [0..=1000], Number(U::Tenths), false;
    POS_D = 0x0C81, 3201, "Pos D", 3, Write, [0..=1000], Number(U::Tenths), false;
    POS_T = 0x0C82, 3202, "Pos T", 3, Write, [1..=5000], Number(U::Milliseconds), false;
    MIN_POS = 0x0C83, 3203, "MinPos", 3, Write, [0..=1000], Number(U::PerMille), false;
    MAX_POS = 0x0C84, 3204, "MaxPos", 3, Write, [0..=1000], Number(U::PerMille), false;
    CLOSE_TIGHT = 0x0C85, 3205, "closeTight", 3, Write, [0..=200], Number(U::PerMille), false;
    OPEN_TIGHT = 0x0C86, 3206, "openTight", 3, Write, [800..=1000], Number(U::PerMille), false;
    // 3 SetFunction: digital inputs
    IN_W = 0x0CE4, 3300, "In W", 3, Write, [0..=5], Enum(InputFn::LABELS), false;
    IN_X = 0x0CE5, 3301, "In X", 3, Write, [0..=5], Enum(InputFn::LABELS), false;
    IN_1 = 0x0CE6, 3302, "In 1", 3, Write, [0..=5], Enum(InputFn::LABELS), false;
    /// OCR conflict: the English hex column reads 0CE6 (In 1's ID); decimal 3303 = 0x0CE7 and
    /// the German copy's 0CE7 agree, so 0x0CE7.
    IN_2 = 0x0CE7, 3303, "In 2", 3, Write, [0..=5], Enum(InputFn::LABELS), false;
    // 3 SetFunction: digital outputs
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    K1_SWITCH = 0x0D48, 3400, "K1 Switch", 3, Write, [0..=1], Integer, false;
    K1_FN = 0x0D49, 3401, "K1 Fn", 3, Write, [0..=15], Enum(OutputFn::LABELS), false;
    ALARM_MIN_K1 = 0x0D4A, 3402, "AlarmMinK1", 3, Write, [2..=998], Number(U::PerMille), false;
    ALARM_MAX_K1 = 0x0D4B, 3403, "AlarmMaxK1", 3, Write, [2..=998], Number(U::PerMille), false;
    SSE1_TIME = 0x0D52, 3410, "SSE1Time", 3, Write, [1..=1000], Number(U::DeciSeconds), false;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    K2_SWITCH = 0x0D4C, 3404, "K2 Switch", 3, Write, [0..=1], Integer, false;
    K2_FN = 0x0D4D, 3405, "K2 Fn", 3, Write, [0..=15], Enum(OutputFn::LABELS), false;
    ALARM_MIN_K2 = 0x0D4E, 3406, "AlarmMinK2", 3, Write, [2..=998], Number(U::PerMille), false;
    ALARM_MAX_K2 = 0x0D4F, 3407, "AlarmMaxK2", 3, Write, [2..=998], Number(U::PerMille), false;
    SSE2_TIME = 0x0D53, 3411, "SSE2Time", 3, Write, [1..=1000], Number(U::DeciSeconds), false;
    ERROR_TIME = 0x0D50, 3408, "ErrorTime", 3, Write, [2..=1000], Number(U::DeciSeconds), false;
    ERROR_ACTION = 0x0D51, 3409, "ErrorAction", 3, Write, [0..=2], Enum(ErrorAction::LABELS), false;
    // 4 SetCalibration
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    X_DIRECTION = 0x0FA0, 4000, "X-Direction", 4, Write, [0..=1], Integer, true;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    W_DIRECTION = 0x0FA1, 4001, "W-Direction", 4, Write, [0..=1], Integer, false;
    W_FUNCTION = 0x0FA2, 4002, "W-Function", 4, Write, [0..=3], Enum(WFunction::LABELS), false;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    Y_DIRECTION = 0x0FA3, 4003, "Y-Direction", 4, Write, [0..=1], Integer, true;
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    POT_DIR = 0x0FA4, 4004, "Pot Dir", 4, Write, [0..=1], Integer, false;
    OUT_MIN_POS = 0x0FA5, 4005, "OutMinPos", 4, Write, [0..=1000], Number(U::PerMille), false;
    OUT_MAX_POS = 0x0FA6, 4006, "OutMaxPos", 4, Write, [0..=1000], Number(U::PerMille), false;
    // 4 SetCalibration: set-value calibration points
    W_0 = 0x1004, 4100, "W 0%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_10 = 0x1005, 4101, "W 10%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_20 = 0x1006, 4102, "W 20%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_30 = 0x1007, 4103, "W 30%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_40 = 0x1008, 4104, "W 40%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_50 = 0x1009, 4105, "W 50%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_60 = 0x100A, 4106, "W 60%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_70 = 0x100B, 4107, "W 70%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_80 = 0x100C, 4108, "W 80%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_90 = 0x100D, 4109, "W 90%", 4, Write, [0..=1000], Number(U::PerMille), false;
    W_100 = 0x100E, 4110, "W 100%", 4, Write, [0..=1000], Number(U::PerMille), false;
    // 4 SetCalibration: display scaling
    /// Enumeration unreadable in the manual: a plain integer, 0..=1 assumed.
    SCALING = 0x1068, 4200, "Scaling", 4, Write, [0..=1], Integer, false;
    DECIMALPOINT = 0x1069, 4201, "Decimalpoint", 4, Write, [0..=2], Number(U::None), false;
    SCALE_4MA = 0x106A, 4202, "4 mA S", 4, Write, [-999..=9999], Number(U::None), false;
    SCALE_20MA = 0x106B, 4203, "20 mA S", 4, Write, [-999..=9999], Number(U::None), false;
    // 5 Communication
    /// OCR conflict: hex 1450 (= 5200) against decimal 5100 (= 0x13EC). 0x1450 is taken: it
    /// sits beside Baudrate 0x1453 = 5203; the decimal column is recorded as 5200.
    DEVICENET_ADR = 0x1450, 5200, "DeviceNet Adr", 5, Write, [1..=63], Number(U::None), false;
    BAUDRATE = 0x1453, 5203, "Baudrate", 5, Write, [0..=2], Enum(Baudrate::LABELS), false;
    PWR_ON_T_OUT = 0x13ED, 5101, "PwrOnT.Out", 5, Write, [0..=300], Number(U::Seconds), false;
}

impl ParamId {
    /// The table row of this ID.
    pub fn def(self) -> Option<&'static ParamDef> {
        PARAMETERS.iter().find(|p| p.id == self)
    }
}

/// Looks a parameter up by its manual name, ignoring case and ' ', '.', '-', '_'
/// ("pos ctrl out", "PosCtrlOut", "d-refresh").
pub fn by_name(name: &str) -> Option<&'static ParamDef> {
    PARAMETERS.iter().find(|p| names_match(p.name, name))
}

/// Looks a parameter up by ID.
pub fn by_id(id: u16) -> Option<&'static ParamDef> {
    ParamId(id).def()
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::format;

    /// Hex and decimal columns agree for every transcribed row (hex = decimal in base 16).
    #[test]
    fn hex_and_decimal_columns_agree() {
        for p in PARAMETERS {
            assert_eq!(
                p.id.0, p.decimal,
                "{}: 0x{:04X} vs {}",
                p.name, p.id.0, p.decimal
            );
        }
        assert_eq!(PARAMETERS.len(), 84);
    }

    #[test]
    fn ids_and_names_are_unique() {
        for (i, a) in PARAMETERS.iter().enumerate() {
            for b in &PARAMETERS[i + 1..] {
                assert_ne!(a.id, b.id, "{} / {}", a.name, b.name);
                assert!(!names_match(a.name, b.name), "{} / {}", a.name, b.name);
            }
        }
    }

    #[test]
    fn spec_notes_examples() {
        assert_eq!(ParamId::MODE, ParamId(0x0064));
        assert_eq!(ParamId::ACTIVE_PARA_SET.0, 1000);
        assert_eq!(ParamId::CTRL_FN.0, 2100);
        assert_eq!(ParamId::W_0.0, 4100);
        assert_eq!(ParamId::W_100.0, 4110);
        assert_eq!(ParamId::IN_2.0, 0x0CE7);
        assert_eq!(ParamId::DEVICENET_ADR.0, 0x1450);
        assert_eq!(ParamId::BAUDRATE.0, 5203);
        let pco = by_name("pos ctrl out").unwrap();
        assert_eq!((pco.min, pco.max, pco.access), (-1000, 1000, Access::Read));
        assert_eq!(by_name("W 100%").unwrap().id, ParamId::W_100);
        assert_eq!(by_name("in2").unwrap().id, ParamId::IN_2);
        assert!(by_name("nope").is_none());
        assert_eq!(by_id(0x0834).unwrap().name, "CtrlFn");
    }

    #[test]
    fn enumerations() {
        assert_eq!(
            Mode::LABELS,
            &["OFF", "Auto", "Manual", "Manual-Flex", "Test"]
        );
        assert_eq!(Mode::from_raw(2), Some(Mode::Manual));
        assert_eq!(Mode::from_raw(5), None);
        assert_eq!(i32::from(Mode::Test), 4);
        assert_eq!(format!("{}", Mode::ManualFlex), "Manual-Flex");
        assert_eq!(CtrlFn::LABELS.len(), 11);
        assert_eq!(CtrlFn::AutoNoB.to_raw(), 10);
        assert_eq!(OutputFn::LABELS.len(), 16);
        assert_eq!(OutputFn::SseMinMax.to_raw(), 15);
        assert_eq!(ErrorAction::Hold.to_raw(), 2);
        assert_eq!(InputFn::PotiIx.to_raw(), 5);
        assert_eq!(WFunction::Free.to_raw(), 3);
        // Every enumeration's range matches its label count.
        for p in PARAMETERS {
            if let ValueKind::Enum(l) = p.kind {
                assert_eq!((p.min, p.max), (0, l.len() as i32 - 1), "{}", p.name);
            }
        }
        let mode = ParamId::MODE.def().unwrap();
        assert_eq!(mode.parse_value("manual"), Some(2));
        assert_eq!(mode.parse_value("Manual-Flex"), Some(3));
        assert_eq!(mode.parse_value("4"), Some(4));
        assert_eq!(mode.parse_value("0x03"), Some(3));
        assert_eq!(mode.parse_value("bogus"), None);
    }

    #[test]
    fn range_checks_and_display() {
        let ot = ParamId::OPEN_TIGHT.def().unwrap();
        assert_eq!(
            ot.check(799),
            Err(RangeError::BelowRange {
                value: 799,
                min: 800
            })
        );
        assert_eq!(
            ot.check(1001),
            Err(RangeError::AboveRange {
                value: 1001,
                max: 1000
            })
        );
        assert_eq!(ot.check(900), Ok(()));
        assert_eq!(format!("{}", ot.display(905)), "90.5 %");
        let pco = ParamId::POS_CTRL_OUT.def().unwrap();
        assert_eq!(format!("{}", pco.display(-5)), "-0.5 %");
        let ix = ParamId::IX_FILTER.def().unwrap();
        assert_eq!(format!("{}", ix.display(105)), "1.05 s");
        let mode = ParamId::MODE.def().unwrap();
        assert_eq!(format!("{}", mode.display(2)), "2 (Manual)");
        assert_eq!(format!("{}", mode.display(9)), "9 (no label)");
        assert_eq!(
            format!("{}", ParamId::HRS.def().unwrap().display(12)),
            "12 h"
        );
        assert!(!ParamId::POT_MIN.def().unwrap().writable());
        assert!(ParamId::PROC_P.def().unwrap().process_controller_only);
    }
}
