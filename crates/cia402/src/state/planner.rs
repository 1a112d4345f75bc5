//! The [`Planner`]: the controlword sequence ([`Plan`]) from the state a statusword shows to a
//! target state, with quick stop's end by 0x605A, transition 16 only where the drive has it, the
//! rising edge of bit 7 for a fault reset, or the reason ([`PlanError`]) no plan reaches it.

use crate::objects::QuickStopOption;
use crate::words::{Controlword, Statusword};

use super::{Command, State, StateMasks, Transition};
/// One step of a [`Plan`].
///
/// A fault reset can take two steps of transition 15: first 0x0000 (bit 7 clear, the drive
/// stays in fault), then 0x0080 (the rising edge). Send them in separate cycles: two writes
/// less than about a millisecond apart may not be seen as an edge (yarp-devices #215).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Step {
    /// The transition this step is part of.
    pub transition: Transition,
    /// The controlword to send (its bits 0..3, 7; the master keeps its mode bits), or `None`
    /// when the drive takes the transition by itself and the master only waits.
    pub controlword: Option<Controlword>,
    /// The state the drive shows when the step is done.
    pub expect: State,
}

/// Why no plan reaches the target.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The statusword shows no state.
    #[error("statusword {0} shows no CiA 402 state")]
    UnknownState(Statusword),
    /// Not ready to switch on, fault reaction active and fault are entered only by the drive.
    #[error("{0} cannot be commanded; only the drive enters it")]
    NotCommandable(State),
    /// The drive is in fault (or reacting to one) and the planner was told not to reset it.
    #[error("the drive is in {0} and fault reset is not allowed")]
    FaultResetNotAllowed(State),
    /// The power stage has no voltage (statusword bit 4 clear; safe torque off or no DC bus):
    /// the drive cannot switch on.
    #[error(
        "voltage not enabled in {state} (statusword {statusword}): safe torque off or no power; the drive cannot switch on"
    )]
    VoltageNotEnabled {
        /// Where the drive stays.
        state: State,
        /// The statusword.
        statusword: Statusword,
    },
}

/// `Debug` prints what `Display` prints (the stack's error convention).
impl core::fmt::Debug for PlanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// When the planner reads statusword bit 4 (voltage enabled) as a gate for switching on.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum VoltageCheck {
    /// Never.
    Off,
    /// In ready to switch on, switched on, operation enabled and quick stop active, where a
    /// drive with its power stage supplied sets bit 4. The default.
    #[default]
    BeforeSwitchOn,
    /// Also in switch on disabled, for drives that report their supply there too.
    Always,
}

/// The controlword sequence from a state to a target state.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Plan {
    steps: [Step; Plan::MAX_STEPS],
    len: u8,
}

impl Plan {
    /// The longest plan: fault reaction active → wait → fault reset (2 words) → shutdown →
    /// switch on → enable → quick stop → wait.
    pub const MAX_STEPS: usize = 8;

    const fn empty() -> Self {
        let filler = Step {
            transition: Transition::T0,
            controlword: None,
            expect: State::NotReadyToSwitchOn,
        };
        Self {
            steps: [filler; Self::MAX_STEPS],
            len: 0,
        }
    }

    fn push(&mut self, step: Step) {
        // The planner's walks are at most MAX_STEPS long (checked by the tests); a longer one
        // would be a planner bug, and dropping the step keeps `push` panic-free.
        if usize::from(self.len) < Self::MAX_STEPS {
            self.steps[usize::from(self.len)] = step;
            self.len += 1;
        }
    }

    /// The steps, in order.
    pub fn steps(&self) -> &[Step] {
        &self.steps[..usize::from(self.len)]
    }

    /// The controlwords to send, in order (waits left out).
    pub fn controlwords(&self) -> impl Iterator<Item = Controlword> + '_ {
        self.steps().iter().filter_map(|s| s.controlword)
    }

    /// Whether the drive is already there.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The state the drive is in when the plan is done: the target, except for quick stop
    /// active with 0x605A 0..4, where the drive goes on to switch on disabled.
    pub fn end_state(&self, from: State) -> State {
        self.steps().last().map_or(from, |s| s.expect)
    }
}

/// Plans controlword sequences; its fields describe the drive.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Planner {
    /// The drive's quick stop option code 0x605A: 5..8 keep quick stop active (and allow
    /// transition 16), 0..4 end in switch on disabled.
    pub quick_stop_option: QuickStopOption,
    /// Whether the drive implements transition 16 (optional in CiA 402-2; python-canopen
    /// #169). Without it, quick stop active → operation enabled goes through switch on disabled.
    pub transition_16: bool,
    /// Whether plans may include a fault reset (transition 15).
    pub fault_reset: bool,
    /// When statusword bit 4 gates switching on.
    pub voltage_check: VoltageCheck,
    /// The statusword masks of the drive's states.
    pub state_masks: StateMasks,
}

impl Default for Planner {
    /// 0x605A = 2, transition 16 used when 0x605A allows it, fault reset allowed, voltage
    /// checked before switching on.
    fn default() -> Self {
        Self {
            quick_stop_option: QuickStopOption::DEFAULT,
            transition_16: true,
            fault_reset: true,
            voltage_check: VoltageCheck::BeforeSwitchOn,
            state_masks: StateMasks::Standard,
        }
    }
}

impl Planner {
    /// The plan from the state `sw` shows to `target`, when the controlword last sent is not
    /// known (a fault reset then starts with a controlword that clears bit 7). Besides the
    /// state, the statusword's bit 4 is checked as [`voltage_check`](Self::voltage_check) says.
    pub fn plan(&self, sw: Statusword, target: State) -> Result<Plan, PlanError> {
        self.plan_after(sw, None, target)
    }

    /// The plan from the state `sw` shows to `target`, after the master sent `last` (`None`:
    /// unknown). A fault reset needs a rising edge of bit 7: when `last` had bit 7 clear the
    /// plan sends 0x0080 at once, otherwise it first sends 0x0000.
    ///
    /// A master replans from each fresh statusword: the first step is what to do now.
    pub fn plan_after(
        &self,
        sw: Statusword,
        last: Option<Controlword>,
        target: State,
    ) -> Result<Plan, PlanError> {
        let from = State::decode_with(sw, self.state_masks).ok_or(PlanError::UnknownState(sw))?;
        let plan = self.walk(from, last, target)?;
        let checked = match self.voltage_check {
            VoltageCheck::Off => false,
            VoltageCheck::BeforeSwitchOn => from != State::SwitchOnDisabled,
            VoltageCheck::Always => true,
        };
        let switches_on = plan.steps().iter().any(|s| s.transition == Transition::T3);
        if checked && switches_on && !sw.voltage_enabled() {
            return Err(PlanError::VoltageNotEnabled {
                state: from,
                statusword: sw,
            });
        }
        Ok(plan)
    }

    /// The first step of [`plan_after`](Self::plan_after), or `None` when the drive is there.
    pub fn next_step(
        &self,
        sw: Statusword,
        last: Option<Controlword>,
        target: State,
    ) -> Result<Option<Step>, PlanError> {
        Ok(self.plan_after(sw, last, target)?.steps().first().copied())
    }

    /// The plan from the state `from` to `target`, without the statusword checks and with the
    /// last controlword unknown.
    pub fn plan_from(&self, from: State, target: State) -> Result<Plan, PlanError> {
        self.walk(from, None, target)
    }

    fn walk(
        &self,
        from: State,
        last: Option<Controlword>,
        target: State,
    ) -> Result<Plan, PlanError> {
        if !target.is_commandable() && target != from {
            return Err(PlanError::NotCommandable(target));
        }
        let mut plan = Plan::empty();
        let mut at = from;
        // Bit 7 is known clear after the last word sent, or after any word of this plan.
        let mut bit7_clear = last.is_some_and(|cw| !cw.fault_reset());
        while at != target {
            let t = self.hop(at, target)?;
            if t == Transition::T15 && !bit7_clear {
                // Fault reset acts on the rising edge of bit 7: make sure bit 7 was clear before.
                plan.push(Step {
                    transition: t,
                    controlword: Some(Command::DisableVoltage.controlword()),
                    expect: State::Fault,
                });
            }
            let controlword = t
                .command()
                .map(Command::controlword)
                .filter(|_| !t.is_automatic());
            if let Some(cw) = controlword {
                bit7_clear = !cw.fault_reset();
            }
            plan.push(Step {
                transition: t,
                controlword,
                expect: t.to(),
            });
            at = t.to();
            if t == Transition::T11 && !self.quick_stop_option.stays_in_quick_stop() {
                // 0x605A 0..4: the drive ends the quick stop in switch on disabled by itself.
                plan.push(Step {
                    transition: Transition::T12,
                    controlword: None,
                    expect: State::SwitchOnDisabled,
                });
                break;
            }
        }
        Ok(plan)
    }

    /// The next transition on the way from `at` to `target` (different states).
    fn hop(&self, at: State, target: State) -> Result<Transition, PlanError> {
        use State::*;
        Ok(match at {
            NotReadyToSwitchOn => Transition::T1,
            FaultReactionActive | Fault if !self.fault_reset => {
                return Err(PlanError::FaultResetNotAllowed(at));
            }
            FaultReactionActive => Transition::T14,
            Fault => Transition::T15,
            SwitchOnDisabled => Transition::T2,
            ReadyToSwitchOn => match target {
                SwitchOnDisabled => Transition::T7,
                _ => Transition::T3,
            },
            SwitchedOn => match target {
                SwitchOnDisabled => Transition::T10,
                ReadyToSwitchOn => Transition::T6,
                _ => Transition::T4,
            },
            OperationEnabled => match target {
                SwitchOnDisabled => Transition::T9,
                ReadyToSwitchOn => Transition::T8,
                SwitchedOn => Transition::T5,
                _ => Transition::T11,
            },
            QuickStopActive => match target {
                OperationEnabled
                    if self.transition_16 && self.quick_stop_option.allows_transition_16() =>
                {
                    Transition::T16
                }
                _ => Transition::T12,
            },
        })
    }
}
