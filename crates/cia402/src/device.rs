//! The power drive state machine from the drive's side (CiA 402-2 §6.4): controlwords in, the
//! state and its statusword bits out. The simulated drive ([`crate::sim`] with `std`) runs its
//! state machine with it, and the planner's tests feed their plans to it.
//!
//! Device behaviour where drives differ:
//! - enable operation (0x000F) in ready to switch on: transition 3 then 4 (CiA DS402 V3.0
//!   Table 27, Synapticon, Toshiba: the default) or only 3 (Elmo), [`DeviceConfig::enable_from_ready`];
//! - transition 16 present or not (optional, python-canopen #169), [`DeviceConfig::transition_16`];
//! - quick stop's end state by 0x605A (5..8 stay in quick stop active).

use crate::objects::QuickStopOption;
use crate::state::{Command, State, Transition};
use crate::words::{Controlword, Statusword};

/// How the simulated or modelled drive behaves where drives differ.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct DeviceConfig {
    /// Quick stop option code 0x605A.
    pub quick_stop_option: QuickStopOption,
    /// Whether the drive implements transition 16 (with 0x605A 5..8).
    pub transition_16: bool,
    /// Whether enable operation in ready to switch on takes transitions 3 and 4 at once.
    pub enable_from_ready: bool,
}

impl Default for DeviceConfig {
    fn default() -> Self {
        Self {
            quick_stop_option: QuickStopOption::DEFAULT,
            transition_16: true,
            enable_from_ready: true,
        }
    }
}

/// The transitions one input caused (at most two: 3 and 4 for enable operation in ready to
/// switch on).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Taken {
    first: Option<Transition>,
    second: Option<Transition>,
}

impl Taken {
    fn push(&mut self, t: Transition) {
        if self.first.is_none() {
            self.first = Some(t);
        } else {
            self.second = Some(t);
        }
    }
    /// The transitions, in order.
    pub fn iter(&self) -> impl Iterator<Item = Transition> {
        self.first.into_iter().chain(self.second)
    }
    /// Whether no transition happened.
    pub fn is_empty(&self) -> bool {
        self.first.is_none()
    }
}

/// The drive-side state machine.
///
/// Call order: [`initialised`](Self::initialised) once the drive has started (transition 1),
/// [`on_controlword`](Self::on_controlword) for every controlword received (also unchanged
/// ones: fault reset needs the previous value to see an edge), [`fault`](Self::fault) on a fault,
/// [`fault_reaction_done`](Self::fault_reaction_done) and
/// [`quick_stop_done`](Self::quick_stop_done) when the motion has stopped, or
/// [`settle`](Self::settle) to finish every automatic transition at once.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct DeviceStateMachine {
    state: State,
    previous: Controlword,
    config: DeviceConfig,
    power: bool,
}

impl DeviceStateMachine {
    /// A drive after power-on: transition 0 taken, in not ready to switch on, power available.
    pub const fn new(config: DeviceConfig) -> Self {
        Self {
            state: State::NotReadyToSwitchOn,
            previous: Controlword::from_raw(0),
            config,
            power: true,
        }
    }

    /// A drive that starts in `state` (for tests and the planner's property tests).
    pub const fn in_state(config: DeviceConfig, state: State) -> Self {
        let mut m = Self::new(config);
        m.state = state;
        m
    }

    /// The state.
    pub const fn state(&self) -> State {
        self.state
    }

    /// The configuration.
    pub const fn config(&self) -> DeviceConfig {
        self.config
    }

    /// Changes the quick stop option code (a write of 0x605A).
    pub fn set_quick_stop_option(&mut self, code: QuickStopOption) {
        self.config.quick_stop_option = code;
    }

    /// The last controlword received.
    pub const fn controlword(&self) -> Controlword {
        self.previous
    }

    /// Whether the power stage can be supplied. `false` models safe torque off (or no DC bus):
    /// the drive refuses to switch on, and a drive that is switched on falls back to switch on
    /// disabled (the motor coasts). Statusword bit 4 follows it.
    pub fn set_power(&mut self, available: bool) {
        self.power = available;
        if !available
            && matches!(
                self.state,
                State::SwitchedOn | State::OperationEnabled | State::QuickStopActive
            )
        {
            self.state = State::SwitchOnDisabled;
        }
    }

    /// Whether the power stage can be supplied.
    pub const fn power(&self) -> bool {
        self.power
    }

    /// The statusword bits of the state machine: the state's pattern (bits 0..3, 5, 6), bit 4
    /// voltage enabled (power available), bit 9 remote. Mode bits are the caller's.
    pub const fn statusword(&self) -> Statusword {
        let mut raw = self.state.value();
        // Bit 5 (quick stop, active-low) is set except in quick stop active; in the states
        // whose mask leaves it free it is clear, as most drives report it.
        if matches!(
            self.state,
            State::ReadyToSwitchOn | State::SwitchedOn | State::OperationEnabled
        ) {
            raw |= Statusword::QUICK_STOP;
        }
        if self.power {
            raw |= Statusword::VOLTAGE_ENABLED;
        }
        raw |= Statusword::REMOTE;
        Statusword::from_raw(raw)
    }

    /// Transition 1: initialisation is done.
    pub fn initialised(&mut self) -> Option<Transition> {
        self.go(State::NotReadyToSwitchOn, Transition::T1)
    }

    /// Transition 13: a fault occurred (in any state but fault and fault reaction active).
    pub fn fault(&mut self) -> Option<Transition> {
        if matches!(self.state, State::Fault | State::FaultReactionActive) {
            return None;
        }
        self.state = State::FaultReactionActive;
        Some(Transition::T13)
    }

    /// Transition 14: the fault reaction has ended.
    pub fn fault_reaction_done(&mut self) -> Option<Transition> {
        self.go(State::FaultReactionActive, Transition::T14)
    }

    /// Transition 12 by itself: the quick stop has stopped the motor and 0x605A is not 5..8.
    pub fn quick_stop_done(&mut self) -> Option<Transition> {
        if self.config.quick_stop_option.stays_in_quick_stop() {
            return None;
        }
        self.go(State::QuickStopActive, Transition::T12)
    }

    /// Every automatic transition that waits only for time (1, 14, and 12 by 0x605A), as if
    /// the drive's motion stopped at once.
    pub fn settle(&mut self) -> Taken {
        let mut taken = Taken::default();
        for _ in 0..3 {
            let t = match self.state {
                State::NotReadyToSwitchOn => self.initialised(),
                State::FaultReactionActive => self.fault_reaction_done(),
                State::QuickStopActive => self.quick_stop_done(),
                _ => None,
            };
            match t {
                Some(t) => taken.push(t),
                None => break,
            }
        }
        taken
    }

    /// A controlword arrived: the transitions it causes. Commands that are not valid in the
    /// state change nothing (Elmo answers them with an SDO abort and the warning bit; this
    /// model ignores them).
    pub fn on_controlword(&mut self, cw: Controlword) -> Taken {
        let command = Command::decode(cw, self.previous);
        self.previous = cw;
        let mut taken = Taken::default();
        let Some(command) = command else {
            return taken;
        };
        use Command as C;
        use State::*;
        let t = match (self.state, command) {
            (SwitchOnDisabled, C::Shutdown) => Transition::T2,
            (ReadyToSwitchOn, C::SwitchOn) if self.power => Transition::T3,
            (ReadyToSwitchOn, C::EnableOperation)
                if self.power && self.config.enable_from_ready =>
            {
                self.state = SwitchedOn;
                taken.push(Transition::T3);
                Transition::T4
            }
            (ReadyToSwitchOn, C::EnableOperation) if self.power => Transition::T3,
            (ReadyToSwitchOn, C::DisableVoltage | C::QuickStop) => Transition::T7,
            (SwitchedOn, C::EnableOperation) => Transition::T4,
            (SwitchedOn, C::Shutdown) => Transition::T6,
            (SwitchedOn, C::DisableVoltage | C::QuickStop) => Transition::T10,
            (OperationEnabled, C::SwitchOn) => Transition::T5,
            (OperationEnabled, C::Shutdown) => Transition::T8,
            (OperationEnabled, C::DisableVoltage) => Transition::T9,
            (OperationEnabled, C::QuickStop) => Transition::T11,
            (QuickStopActive, C::DisableVoltage) => Transition::T12,
            (QuickStopActive, C::EnableOperation)
                if self.config.transition_16
                    && self.config.quick_stop_option.allows_transition_16() =>
            {
                Transition::T16
            }
            (Fault, C::FaultReset) => Transition::T15,
            _ => return taken,
        };
        self.state = t.to();
        taken.push(t);
        taken
    }

    fn go(&mut self, from: State, t: Transition) -> Option<Transition> {
        if self.state != from {
            return None;
        }
        self.state = t.to();
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn send(m: &mut DeviceStateMachine, raw: u16) -> State {
        m.on_controlword(Controlword::from_raw(raw));
        m.state()
    }

    #[test]
    fn walk_and_fault_reset_edge() {
        let mut m = DeviceStateMachine::new(DeviceConfig::default());
        assert_eq!(m.state(), State::NotReadyToSwitchOn);
        assert_eq!(send(&mut m, 0x06), State::NotReadyToSwitchOn);
        assert_eq!(m.initialised(), Some(Transition::T1));
        assert_eq!(send(&mut m, 0x06), State::ReadyToSwitchOn);
        assert_eq!(send(&mut m, 0x07), State::SwitchedOn);
        assert_eq!(send(&mut m, 0x0F), State::OperationEnabled);
        assert_eq!(m.statusword().raw(), 0x0237);
        assert_eq!(m.fault(), Some(Transition::T13));
        assert_eq!(m.fault_reaction_done(), Some(Transition::T14));
        assert_eq!(m.statusword().raw() & 0x4F, 0x08);
        // 0x0F then 0x8F: an edge; but first hold 0x80 high without an edge.
        let mut held = m;
        held.previous = Controlword::from_raw(0x80);
        assert_eq!(send(&mut held, 0x80), State::Fault);
        assert_eq!(send(&mut m, 0x80), State::SwitchOnDisabled);
        // Bit 7 still high: shutdown with bit 7 set is not a command; clearing it is.
        assert_eq!(send(&mut m, 0x86), State::SwitchOnDisabled);
        assert_eq!(send(&mut m, 0x06), State::ReadyToSwitchOn);
    }

    #[test]
    fn quick_stop_end_state_by_605a() {
        for (code, end) in [(2, State::SwitchOnDisabled), (6, State::QuickStopActive)] {
            let cfg = DeviceConfig {
                quick_stop_option: QuickStopOption(code),
                ..Default::default()
            };
            let mut m = DeviceStateMachine::in_state(cfg, State::OperationEnabled);
            assert_eq!(send(&mut m, 0x02), State::QuickStopActive);
            m.settle();
            assert_eq!(m.state(), end, "605A={code}");
        }
        // Transition 16 only with 5..8 and only when implemented.
        let cfg = DeviceConfig {
            quick_stop_option: QuickStopOption(6),
            ..Default::default()
        };
        let mut m = DeviceStateMachine::in_state(cfg, State::QuickStopActive);
        assert_eq!(send(&mut m, 0x0F), State::OperationEnabled);
        let mut m = DeviceStateMachine::in_state(
            DeviceConfig {
                transition_16: false,
                ..cfg
            },
            State::QuickStopActive,
        );
        assert_eq!(send(&mut m, 0x0F), State::QuickStopActive);
        assert_eq!(send(&mut m, 0x00), State::SwitchOnDisabled);
    }

    #[test]
    fn enable_from_ready_is_selectable() {
        let mut m = DeviceStateMachine::in_state(DeviceConfig::default(), State::ReadyToSwitchOn);
        let taken: std::vec::Vec<u8> = m
            .on_controlword(Controlword::from_raw(0x0F))
            .iter()
            .map(|t| t.number())
            .collect();
        assert_eq!(taken, [3, 4]);
        let elmo = DeviceConfig {
            enable_from_ready: false,
            ..Default::default()
        };
        let mut m = DeviceStateMachine::in_state(elmo, State::ReadyToSwitchOn);
        assert_eq!(send(&mut m, 0x0F), State::SwitchedOn);
    }

    #[test]
    fn no_power_no_switch_on() {
        let mut m = DeviceStateMachine::in_state(DeviceConfig::default(), State::SwitchOnDisabled);
        m.set_power(false);
        assert_eq!(send(&mut m, 0x06), State::ReadyToSwitchOn);
        assert_eq!(send(&mut m, 0x07), State::ReadyToSwitchOn);
        assert!(!m.statusword().voltage_enabled());
        m.set_power(true);
        assert_eq!(send(&mut m, 0x0F), State::OperationEnabled);
        m.set_power(false);
        assert_eq!(m.state(), State::SwitchOnDisabled);
    }
}
