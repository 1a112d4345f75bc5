//! The power drive state machine of CiA 402-2 §6.4 seen from the master: the states decoded from
//! the statusword, the device-control commands of the controlword, the transitions 0..16, and a
//! [`Planner`] that gives the controlword sequence from the current state to a target state.
//!
//! ```text
//!  Start ─0→ Not ready to switch on ─1→ Switch on disabled ◄─────────15── Fault
//!                                       │ 2 ▲ 7        ▲ 9 ▲ 10 ▲ 12          ▲ 14
//!                                       ▼   │          │   │    │     Fault reaction active
//!                                  Ready to switch on ◄─8─┐│    │             ▲ 13 (any state)
//!                                       │ 3 ▲ 6           ││    │
//!                                       ▼   │             ││    │
//!                                     Switched on ────────┼┘    │
//!                                       │ 4 ▲ 5           │     │
//!                                       ▼   │             │     │
//!                                 Operation enabled ──11→ Quick stop active
//!                                                  ◄─16──
//! ```
//!
//! State masks and command codes: python-canopen, ros2_canopen, Toshiba citing CiA DS402-2
//! Table 27, Elmo, Synapticon, Beckhoff SSC. The Beckhoff SSC value of
//! switch on disabled (0x0020 under 0x006F) is the minority and is not used.
//!
//! This file holds the states, commands and transitions; the [`Planner`] and its [`Plan`] are in
//! `planner`.

use core::fmt;

use crate::words::{Controlword, Statusword};

mod planner;

pub use planner::{Plan, PlanError, Planner, Step, VoltageCheck};

/// A state of the power drive state machine.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum State {
    /// Not ready to switch on: the drive is initialising; it leaves by itself (transition 1).
    NotReadyToSwitchOn,
    /// Switch on disabled.
    SwitchOnDisabled,
    /// Ready to switch on.
    ReadyToSwitchOn,
    /// Switched on: power stage on, no torque.
    SwitchedOn,
    /// Operation enabled: the drive follows its mode's targets.
    OperationEnabled,
    /// Quick stop active.
    QuickStopActive,
    /// Fault reaction active: the drive reacts to a fault; it goes to fault by itself.
    FaultReactionActive,
    /// Fault.
    Fault,
}

impl State {
    /// Every state.
    pub const ALL: [State; 8] = [
        Self::NotReadyToSwitchOn,
        Self::SwitchOnDisabled,
        Self::ReadyToSwitchOn,
        Self::SwitchedOn,
        Self::OperationEnabled,
        Self::QuickStopActive,
        Self::FaultReactionActive,
        Self::Fault,
    ];

    /// The statusword bits that identify this state (bits 0..3, 5, 6 or bits 0..3, 6).
    pub const fn mask(self) -> u16 {
        match self {
            Self::NotReadyToSwitchOn
            | Self::SwitchOnDisabled
            | Self::FaultReactionActive
            | Self::Fault => 0x004F,
            _ => 0x006F,
        }
    }

    /// The value of the masked statusword bits in this state.
    pub const fn value(self) -> u16 {
        match self {
            Self::NotReadyToSwitchOn => 0x0000,
            Self::SwitchOnDisabled => 0x0040,
            Self::ReadyToSwitchOn => 0x0021,
            Self::SwitchedOn => 0x0023,
            Self::OperationEnabled => 0x0027,
            Self::QuickStopActive => 0x0007,
            Self::FaultReactionActive => 0x000F,
            Self::Fault => 0x0008,
        }
    }

    /// The state a statusword shows, with the [`StateMasks::Standard`] masks; `None` for the
    /// patterns no state has (for example 0x0001, or bit 6 set together with bit 0).
    pub const fn decode(sw: Statusword) -> Option<State> {
        Self::decode_with(sw, StateMasks::Standard)
    }

    /// The state a statusword shows with the given masks.
    pub const fn decode_with(sw: Statusword, masks: StateMasks) -> Option<State> {
        if let StateMasks::BeckhoffSsc = masks {
            // SSC: switch on disabled is 0x0020 under 0x006F; checked before not ready to
            // switch on, whose standard pattern it also matches.
            if sw.raw() & 0x006F == 0x0020 {
                return Some(Self::SwitchOnDisabled);
            }
        }
        Self::decode_standard(sw)
    }

    const fn decode_standard(sw: Statusword) -> Option<State> {
        let raw = sw.raw();
        let mut i = 0;
        while i < Self::ALL.len() {
            let s = Self::ALL[i];
            if raw & s.mask() == s.value() {
                return Some(s);
            }
            i += 1;
        }
        None
    }

    /// Whether a master can make this state the target of a plan. Not ready to switch on,
    /// fault reaction active and fault are entered only by the drive.
    pub const fn is_commandable(self) -> bool {
        !matches!(
            self,
            Self::NotReadyToSwitchOn | Self::FaultReactionActive | Self::Fault
        )
    }

    /// The name CiA 402 gives the state.
    pub const fn name(self) -> &'static str {
        match self {
            Self::NotReadyToSwitchOn => "not ready to switch on",
            Self::SwitchOnDisabled => "switch on disabled",
            Self::ReadyToSwitchOn => "ready to switch on",
            Self::SwitchedOn => "switched on",
            Self::OperationEnabled => "operation enabled",
            Self::QuickStopActive => "quick stop active",
            Self::FaultReactionActive => "fault reaction active",
            Self::Fault => "fault",
        }
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which statusword masks identify the states. python-canopen,
/// ros2_canopen and Toshiba (citing CiA DS402-2 Table 30) give switch on disabled as 0x0040 under
/// 0x004F; Beckhoff's EtherCAT SSC (`cia402appl.h`) gives 0x0020 under 0x006F.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum StateMasks {
    /// The majority's masks (the table of [`State::mask`] and [`State::value`]).
    #[default]
    Standard,
    /// The standard masks, and also 0x0020 under 0x006F as switch on disabled (drives whose
    /// firmware follows Beckhoff SSC).
    BeckhoffSsc,
}

/// A device-control command: the controlword bits 0..3 and 7 (CiA 402-2 Table 27).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Command {
    /// Shutdown, 0x0006 (bits 0, 7 clear; 1, 2 set; 3 any): transitions 2, 6, 8.
    Shutdown,
    /// Switch on, 0x0007: transition 3. The same bits are "disable operation" (transition 5).
    SwitchOn,
    /// Disable voltage, 0x0000 (bit 1 clear): transitions 7, 9, 10, 12.
    DisableVoltage,
    /// Quick stop, 0x0002 (bit 1 set, bit 2 clear): transitions 7, 10, 11.
    QuickStop,
    /// Enable operation, 0x000F: transitions 4 and 16; in ready to switch on also "switch on +
    /// enable operation" (3 then 4) on most drives.
    EnableOperation,
    /// Fault reset, bit 7 rising edge: transition 15. The master sends 0x0080 after a
    /// controlword with bit 7 clear, and clears bit 7 again with the next command.
    FaultReset,
}

impl Command {
    /// Every command.
    pub const ALL: [Command; 6] = [
        Self::Shutdown,
        Self::SwitchOn,
        Self::DisableVoltage,
        Self::QuickStop,
        Self::EnableOperation,
        Self::FaultReset,
    ];

    /// "Disable operation" is the switch on code (0x0007), used for transition 5.
    pub const DISABLE_OPERATION: Command = Command::SwitchOn;

    /// The controlword a master sends for this command.
    pub const fn controlword(self) -> Controlword {
        Controlword::from_raw(match self {
            Self::Shutdown => 0x0006,
            Self::SwitchOn => 0x0007,
            Self::DisableVoltage => 0x0000,
            Self::QuickStop => 0x0002,
            Self::EnableOperation => 0x000F,
            Self::FaultReset => 0x0080,
        })
    }

    /// The decode mask of the command in Table 27 (the bits that must match).
    pub const fn mask(self) -> u16 {
        match self {
            Self::Shutdown => 0x0087,
            Self::SwitchOn | Self::EnableOperation => 0x008F,
            Self::DisableVoltage => 0x0082,
            Self::QuickStop => 0x0086,
            Self::FaultReset => 0x0080,
        }
    }

    /// The command a drive sees in `cw`, given the controlword before it (`previous`): a
    /// rising edge of bit 7 is a fault reset; bit 7 held high is no command; otherwise the
    /// bits 0..3 select one of the five other commands (every pattern has one).
    pub const fn decode(cw: Controlword, previous: Controlword) -> Option<Command> {
        let raw = cw.raw();
        if raw & 0x80 != 0 {
            return if previous.raw() & 0x80 == 0 {
                Some(Self::FaultReset)
            } else {
                None
            };
        }
        Some(if raw & 0x02 == 0 {
            Self::DisableVoltage
        } else if raw & 0x04 == 0 {
            Self::QuickStop
        } else if raw & 0x01 == 0 {
            Self::Shutdown
        } else if raw & 0x08 == 0 {
            Self::SwitchOn
        } else {
            Self::EnableOperation
        })
    }

    /// The CiA 402 name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Shutdown => "shutdown",
            Self::SwitchOn => "switch on",
            Self::DisableVoltage => "disable voltage",
            Self::QuickStop => "quick stop",
            Self::EnableOperation => "enable operation",
            Self::FaultReset => "fault reset",
        }
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A transition of the state machine, numbered as in CiA 402-2 Figure 6.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Transition(u8);

impl Transition {
    /// 0: start → not ready to switch on (automatic at power-on or NMT reset).
    pub const T0: Self = Self(0);
    /// 1: not ready to switch on → switch on disabled (automatic once initialised).
    pub const T1: Self = Self(1);
    /// 2: switch on disabled → ready to switch on (shutdown).
    pub const T2: Self = Self(2);
    /// 3: ready to switch on → switched on (switch on).
    pub const T3: Self = Self(3);
    /// 4: switched on → operation enabled (enable operation).
    pub const T4: Self = Self(4);
    /// 5: operation enabled → switched on (disable operation; reaction by 0x605C).
    pub const T5: Self = Self(5);
    /// 6: switched on → ready to switch on (shutdown).
    pub const T6: Self = Self(6);
    /// 7: ready to switch on → switch on disabled (disable voltage or quick stop).
    pub const T7: Self = Self(7);
    /// 8: operation enabled → ready to switch on (shutdown; reaction by 0x605B).
    pub const T8: Self = Self(8);
    /// 9: operation enabled → switch on disabled (disable voltage).
    pub const T9: Self = Self(9);
    /// 10: switched on → switch on disabled (disable voltage or quick stop).
    pub const T10: Self = Self(10);
    /// 11: operation enabled → quick stop active (quick stop; reaction by 0x605A).
    pub const T11: Self = Self(11);
    /// 12: quick stop active → switch on disabled (disable voltage, or automatic when the
    /// quick stop ends and 0x605A is 0..4).
    pub const T12: Self = Self(12);
    /// 13: any state → fault reaction active (automatic on a fault).
    pub const T13: Self = Self(13);
    /// 14: fault reaction active → fault (automatic when the reaction ends).
    pub const T14: Self = Self(14);
    /// 15: fault → switch on disabled (fault reset, rising edge of bit 7).
    pub const T15: Self = Self(15);
    /// 16: quick stop active → operation enabled (enable operation; only with 0x605A 5..8 and
    /// only on drives that implement it).
    pub const T16: Self = Self(16);

    /// Every transition, 0..=16.
    pub const ALL: [Transition; 17] = {
        let mut all = [Self(0); 17];
        let mut i = 0;
        while i < 17 {
            all[i] = Self(i as u8);
            i += 1;
        }
        all
    };

    /// The transition with this number; `None` above 16.
    pub const fn from_number(n: u8) -> Option<Self> {
        if n <= 16 { Some(Self(n)) } else { None }
    }

    /// The number, 0..=16.
    pub const fn number(self) -> u8 {
        self.0
    }

    /// The state it leaves; `None` for 0 (start) and 13 (any state).
    pub const fn from(self) -> Option<State> {
        use State::*;
        Some(match self.0 {
            1 => NotReadyToSwitchOn,
            2 => SwitchOnDisabled,
            3 | 7 => ReadyToSwitchOn,
            4 | 6 | 10 => SwitchedOn,
            5 | 8 | 9 | 11 => OperationEnabled,
            12 | 16 => QuickStopActive,
            14 => FaultReactionActive,
            15 => Fault,
            _ => return None,
        })
    }

    /// The state it enters.
    pub const fn to(self) -> State {
        use State::*;
        match self.0 {
            0 => NotReadyToSwitchOn,
            1 | 7 | 9 | 10 | 12 | 15 => SwitchOnDisabled,
            2 | 6 | 8 => ReadyToSwitchOn,
            3 | 5 => SwitchedOn,
            4 | 16 => OperationEnabled,
            11 => QuickStopActive,
            13 => FaultReactionActive,
            _ => Fault,
        }
    }

    /// The command a master sends for it; `None` for the automatic ones (0, 1, 13, 14).
    /// Transitions 7, 10 also take quick stop and 12 also happens by itself (see
    /// [`accepts`](Self::accepts)).
    pub const fn command(self) -> Option<Command> {
        Some(match self.0 {
            2 | 6 | 8 => Command::Shutdown,
            3 | 5 => Command::SwitchOn,
            4 | 16 => Command::EnableOperation,
            7 | 9 | 10 | 12 => Command::DisableVoltage,
            11 => Command::QuickStop,
            15 => Command::FaultReset,
            _ => return None,
        })
    }

    /// Whether `command` triggers this transition (from its source state).
    pub const fn accepts(self, command: Command) -> bool {
        match (self.0, command) {
            (7 | 10, Command::QuickStop) => true,
            _ => match self.command() {
                Some(c) => c as u8 == command as u8,
                None => false,
            },
        }
    }

    /// Whether the drive takes it by itself (0, 1, 13, 14; 12 can be both).
    pub const fn is_automatic(self) -> bool {
        matches!(self.0, 0 | 1 | 13 | 14)
    }
}

impl fmt::Display for Transition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "transition {}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::objects::QuickStopOption;

    #[test]
    fn state_table_of_the_spec() {
        for (sw, state) in [
            (0x0000, State::NotReadyToSwitchOn),
            (0x0040, State::SwitchOnDisabled),
            (0x0021, State::ReadyToSwitchOn),
            (0x0023, State::SwitchedOn),
            (0x0027, State::OperationEnabled),
            (0x0007, State::QuickStopActive),
            (0x000F, State::FaultReactionActive),
            (0x0008, State::Fault),
            // Observed words: python-canopen #167 candump 0x0217 (QSA), 0x0640 (SOD).
            (0x0217, State::QuickStopActive),
            (0x0640, State::SwitchOnDisabled),
            (0x0660, State::SwitchOnDisabled),
            (0x0237, State::OperationEnabled),
            (0xFFB0, State::NotReadyToSwitchOn),
        ] {
            assert_eq!(
                State::decode(Statusword::from_raw(sw)),
                Some(state),
                "{sw:#06x}"
            );
            assert_eq!(
                State::decode(Statusword::from_raw(state.value())),
                Some(state)
            );
        }
        for unknown in [0x0001, 0x0003, 0x0041, 0x0061, 0x0067, 0x0048] {
            assert_eq!(
                State::decode(Statusword::from_raw(unknown)),
                None,
                "{unknown:#06x}"
            );
        }
    }

    #[test]
    fn beckhoff_ssc_switch_on_disabled_is_selectable() {
        let ssc = Statusword::from_raw(0x0220);
        assert_eq!(State::decode(ssc), Some(State::NotReadyToSwitchOn));
        assert_eq!(
            State::decode_with(ssc, StateMasks::BeckhoffSsc),
            Some(State::SwitchOnDisabled)
        );
        for raw in [0x0040, 0x0021, 0x0027, 0x0008, 0x0000] {
            let sw = Statusword::from_raw(raw);
            assert_eq!(
                State::decode_with(sw, StateMasks::BeckhoffSsc),
                State::decode(sw)
            );
        }
    }

    #[test]
    fn states_are_disjoint() {
        for raw in 0..=u16::MAX {
            let matching = State::ALL
                .iter()
                .filter(|s| raw & s.mask() == s.value())
                .count();
            assert!(matching <= 1, "{raw:#06x} matches {matching} states");
        }
    }

    #[test]
    fn command_table_of_the_spec() {
        let zero = Controlword::from_raw(0);
        for c in Command::ALL {
            let cw = c.controlword();
            assert_eq!(cw.raw() & c.mask(), cw.raw(), "{c}");
            let decoded = Command::decode(cw, zero);
            let same_bits = matches!((c, decoded), (Command::SwitchOn, Some(Command::SwitchOn)));
            assert!(decoded == Some(c) || same_bits, "{c} -> {decoded:?}");
        }
        // Table 27 patterns with the don't-care bits set.
        let d = |raw| Command::decode(Controlword::from_raw(raw), zero);
        assert_eq!(d(0x000E), Some(Command::Shutdown));
        assert_eq!(d(0x000D), Some(Command::DisableVoltage));
        assert_eq!(d(0x000B), Some(Command::QuickStop));
        assert_eq!(d(0x0003), Some(Command::QuickStop));
        assert_eq!(d(0x007F), Some(Command::EnableOperation));
        assert_eq!(d(0x0087), Some(Command::FaultReset));
        // Bit 7 held high is no edge, so no command.
        assert_eq!(
            Command::decode(Controlword::from_raw(0x80), Controlword::from_raw(0x80)),
            None
        );
    }

    #[test]
    fn transition_table_of_the_spec() {
        use State::*;
        let table: [(u8, Option<State>, State, Option<Command>); 17] = [
            (0, None, NotReadyToSwitchOn, None),
            (1, Some(NotReadyToSwitchOn), SwitchOnDisabled, None),
            (
                2,
                Some(SwitchOnDisabled),
                ReadyToSwitchOn,
                Some(Command::Shutdown),
            ),
            (
                3,
                Some(ReadyToSwitchOn),
                SwitchedOn,
                Some(Command::SwitchOn),
            ),
            (
                4,
                Some(SwitchedOn),
                OperationEnabled,
                Some(Command::EnableOperation),
            ),
            (
                5,
                Some(OperationEnabled),
                SwitchedOn,
                Some(Command::DISABLE_OPERATION),
            ),
            (
                6,
                Some(SwitchedOn),
                ReadyToSwitchOn,
                Some(Command::Shutdown),
            ),
            (
                7,
                Some(ReadyToSwitchOn),
                SwitchOnDisabled,
                Some(Command::DisableVoltage),
            ),
            (
                8,
                Some(OperationEnabled),
                ReadyToSwitchOn,
                Some(Command::Shutdown),
            ),
            (
                9,
                Some(OperationEnabled),
                SwitchOnDisabled,
                Some(Command::DisableVoltage),
            ),
            (
                10,
                Some(SwitchedOn),
                SwitchOnDisabled,
                Some(Command::DisableVoltage),
            ),
            (
                11,
                Some(OperationEnabled),
                QuickStopActive,
                Some(Command::QuickStop),
            ),
            (
                12,
                Some(QuickStopActive),
                SwitchOnDisabled,
                Some(Command::DisableVoltage),
            ),
            (13, None, FaultReactionActive, None),
            (14, Some(FaultReactionActive), Fault, None),
            (15, Some(Fault), SwitchOnDisabled, Some(Command::FaultReset)),
            (
                16,
                Some(QuickStopActive),
                OperationEnabled,
                Some(Command::EnableOperation),
            ),
        ];
        for (n, from, to, cmd) in table {
            let t = Transition::from_number(n).unwrap();
            assert_eq!((t.from(), t.to(), t.command()), (from, to, cmd), "{t}");
        }
        assert!(
            Transition::T7.accepts(Command::QuickStop)
                && Transition::T10.accepts(Command::QuickStop)
        );
        assert!(!Transition::T9.accepts(Command::QuickStop));
        assert_eq!(Transition::from_number(17), None);
    }

    fn words(plan: &Plan) -> std::vec::Vec<u16> {
        plan.controlwords().map(|c| c.raw()).collect()
    }

    #[test]
    fn plans() {
        use State::*;
        let p = Planner::default();
        assert_eq!(
            words(&p.plan_from(SwitchOnDisabled, OperationEnabled).unwrap()),
            [0x06, 0x07, 0x0F]
        );
        assert_eq!(
            words(&p.plan_from(Fault, OperationEnabled).unwrap()),
            [0x00, 0x80, 0x06, 0x07, 0x0F]
        );
        // After a word with bit 7 clear the edge is there already; after 0x0080 it is not.
        let fault = Statusword::from_raw(0x0218);
        let after = |last| {
            words(
                &p.plan_after(fault, Some(Controlword::from_raw(last)), SwitchOnDisabled)
                    .unwrap(),
            )
        };
        assert_eq!(after(0x000F), [0x80]);
        assert_eq!(after(0x0080), [0x00, 0x80]);
        assert_eq!(
            words(&p.plan_from(OperationEnabled, SwitchedOn).unwrap()),
            [0x07]
        );
        assert_eq!(
            words(&p.plan_from(OperationEnabled, SwitchOnDisabled).unwrap()),
            [0x00]
        );
        // 0x605A = 2: quick stop ends in switch on disabled (python-canopen #167).
        let qs = p.plan_from(OperationEnabled, QuickStopActive).unwrap();
        assert_eq!(words(&qs), [0x02]);
        assert_eq!(qs.end_state(OperationEnabled), SwitchOnDisabled);
        // 0x605A = 6: it stays, and transition 16 leads back.
        let p6 = Planner {
            quick_stop_option: QuickStopOption(6),
            ..p
        };
        assert_eq!(
            p6.plan_from(OperationEnabled, QuickStopActive)
                .unwrap()
                .end_state(OperationEnabled),
            QuickStopActive
        );
        assert_eq!(
            words(&p6.plan_from(QuickStopActive, OperationEnabled).unwrap()),
            [0x0F]
        );
        // Without transition 16 (python-canopen #169): through switch on disabled.
        let no16 = Planner {
            transition_16: false,
            ..p6
        };
        assert_eq!(
            words(&no16.plan_from(QuickStopActive, OperationEnabled).unwrap()),
            [0x00, 0x06, 0x07, 0x0F]
        );
        // Automatic states are waited for.
        let w = p.plan_from(FaultReactionActive, SwitchOnDisabled).unwrap();
        assert_eq!(
            w.steps()[0],
            Step {
                transition: Transition::T14,
                controlword: None,
                expect: Fault
            }
        );
        assert_eq!(
            p.plan_from(OperationEnabled, Fault),
            Err(PlanError::NotCommandable(Fault))
        );
        assert!(p.plan_from(Fault, Fault).unwrap().is_empty());
        let no_reset = Planner {
            fault_reset: false,
            ..p
        };
        assert_eq!(
            no_reset.plan_from(Fault, SwitchOnDisabled),
            Err(PlanError::FaultResetNotAllowed(Fault))
        );
        // Every plan fits.
        for from in State::ALL {
            for to in State::ALL.into_iter().filter(|s| s.is_commandable()) {
                for qs in [2, 6] {
                    let pl = Planner {
                        quick_stop_option: QuickStopOption(qs),
                        ..p
                    };
                    let plan = pl.plan_from(from, to).unwrap();
                    assert!(plan.steps().len() <= Plan::MAX_STEPS, "{from} -> {to}");
                }
            }
        }
    }

    #[test]
    fn voltage_not_enabled_is_reported() {
        let p = Planner::default();
        // Ready to switch on without bit 4 (safe torque off): switching on is refused.
        let sw = Statusword::from_raw(0x0221);
        assert_eq!(
            p.plan(sw, State::OperationEnabled),
            Err(PlanError::VoltageNotEnabled {
                state: State::ReadyToSwitchOn,
                statusword: sw
            })
        );
        // Going down is still possible.
        assert_eq!(words(&p.plan(sw, State::SwitchOnDisabled).unwrap()), [0x00]);
        // In switch on disabled the default check waits (many drives clear bit 4 there).
        assert!(
            p.plan(Statusword::from_raw(0x0240), State::OperationEnabled)
                .is_ok()
        );
        let strict = Planner {
            voltage_check: VoltageCheck::Always,
            ..p
        };
        assert!(
            strict
                .plan(Statusword::from_raw(0x0240), State::OperationEnabled)
                .is_err()
        );
        assert!(
            p.plan(Statusword::from_raw(0x0231), State::OperationEnabled)
                .is_ok()
        );
        assert_eq!(
            p.plan(Statusword::from_raw(0x0001), State::SwitchedOn),
            Err(PlanError::UnknownState(Statusword::from_raw(1)))
        );
    }
}
