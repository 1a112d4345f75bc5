//! Walking the power drive state machine: [`Drive::set_state`] with the planner's controlwords
//! and a wait for each step (transition 16 retried through switch on disabled when the drive
//! ignores it), enable, disable, quick stop, halt and fault reset.

use std::prelude::rust_2024::*;

use canola::{Duration, Operation};

use crate::objects::{self as obj, ErrorCode, QuickStopOption};
use crate::state::{PlanError, Planner, State, Transition};
use crate::words::{Controlword, Statusword};

use super::{Awaited, Drive, DriveError, DriveOp, Reached};

/// What a fault reset found and did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaultReport {
    /// 0x603F before the reset.
    pub code: ErrorCode,
    /// The node's last EMCY before the reset, as text.
    pub emcy: Option<canola::nmt::Emcy>,
    /// The state before the reset.
    pub from: State,
    /// The state after it.
    pub state: State,
}

impl Drive {
    async fn quick_stop_option(&self) -> QuickStopOption {
        // 0x605A is optional: without it, the common default 2 (the drive ends in switch on
        // disabled); the waits accept either end of a quick stop anyway.
        self.read_at::<2>(self.at(obj::QUICK_STOP_OPTION_CODE))
            .await
            .map(|b| QuickStopOption(i16::from_le_bytes(b)))
            .unwrap_or(QuickStopOption::DEFAULT)
    }

    async fn planner(&self) -> Planner {
        Planner {
            quick_stop_option: self.quick_stop_option().await,
            transition_16: self.transition_16,
            ..Planner::default()
        }
    }

    /// Takes the drive to `target` with the planner's controlwords, waiting for each step's
    /// state. Returns the state reached (the target, or switch on disabled after a quick stop
    /// with 0x605A 0..4).
    pub fn set_state(&self, target: State) -> DriveOp<State> {
        let d = self.clone();
        Operation::new(async move {
            let planner = d.planner().await;
            d.walk(target, planner).await
        })
    }

    /// Walks the plan to `target`; once more through switch on disabled when the drive ignores
    /// transition 16.
    async fn walk(&self, target: State, mut planner: Planner) -> Result<State, DriveError> {
        loop {
            match self.walk_once(target, planner).await? {
                Walked::Reached(s) => return Ok(s),
                // The drive ignores transition 16 (python-canopen #169): through switch on
                // disabled instead (a walk without transition 16 does not end here).
                Walked::NoTransition16 => planner.transition_16 = false,
            }
        }
    }

    async fn walk_once(&self, target: State, planner: Planner) -> Result<Walked, DriveError> {
        let sw = self.statusword().await?;
        let from = State::decode(sw).ok_or(PlanError::UnknownState(sw))?;
        let plan = planner.plan_after(sw, self.last_controlword(), target)?;
        let steps = plan.steps();
        let mut i = 0;
        let mut last = sw;
        while i < steps.len() {
            let step = steps[i];
            if step.transition == Transition::T3 && !last.voltage_enabled() {
                // Safe torque off or no DC bus: switching on cannot work (ros2_canopen #421).
                return Err(PlanError::VoltageNotEnabled {
                    state: State::decode(last).unwrap_or(from),
                    statusword: last,
                }
                .into());
            }
            if let Some(cw) = step.controlword {
                self.put_controlword(cw).await?;
            }
            let accept: Vec<State> = steps[i..].iter().map(|s| s.expect).collect();
            match self.wait_state(&accept, self.timeouts.transition).await {
                Ok((state, sw)) => {
                    last = sw;
                    // Skip ahead when the drive went on by itself (quick stop → switch on
                    // disabled with 0x605A 0..4).
                    let j = steps[i..]
                        .iter()
                        .rposition(|s| s.expect == state)
                        .unwrap_or(0);
                    i += j + 1;
                }
                Err(DriveError::Timeout {
                    reached: Reached::State(Some(State::QuickStopActive)),
                    ..
                }) if step.transition == Transition::T16 && planner.transition_16 => {
                    return Ok(Walked::NoTransition16);
                }
                Err(e) => return Err(e),
            }
        }
        Ok(Walked::Reached(plan.end_state(from)))
    }

    /// Polls until the drive shows one of `states`; a fault (not expected) ends the wait.
    async fn wait_state(
        &self,
        states: &[State],
        timeout: Duration,
    ) -> Result<(State, Statusword), DriveError> {
        let start = self.node.network().now();
        loop {
            let sw = self.statusword().await?;
            let state = State::decode(sw);
            if let Some(s) = state
                && states.contains(&s)
            {
                return Ok((s, sw));
            }
            let faulted = matches!(state, Some(State::Fault | State::FaultReactionActive));
            if faulted && !states.contains(&State::Fault) {
                return Err(self.fault_error(sw).await);
            }
            let waited = self.node.network().now() - start;
            if waited >= timeout {
                return Err(DriveError::Timeout {
                    awaited: Awaited::State(states.to_vec()),
                    reached: Reached::State(state),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    /// Operation enabled, from any state (a fault is reset on the way, quick stop active is
    /// left by transition 16 when 0x605A allows it). With safe torque off the drive cannot
    /// switch on: [`PlanError::VoltageNotEnabled`].
    pub fn enable(&self) -> DriveOp<State> {
        self.set_state(State::OperationEnabled)
    }

    /// Switch on disabled (power stage off), from any state but fault.
    pub fn disable(&self) -> DriveOp<State> {
        let d = self.clone();
        Operation::new(async move {
            let planner = Planner {
                fault_reset: false,
                ..d.planner().await
            };
            d.walk(State::SwitchOnDisabled, planner).await
        })
    }

    /// Quick stop. From operation enabled the drive stops and, by 0x605A, stays in quick stop
    /// active (5..8) or goes on to switch on disabled (0..4, python-canopen #167); from ready to
    /// switch on or switched on it goes to switch on disabled (transitions 7, 10). Returns the
    /// state reached.
    pub fn quick_stop(&self) -> DriveOp<State> {
        let d = self.clone();
        Operation::new(async move {
            let sw = d.statusword().await?;
            match State::decode(sw) {
                Some(State::OperationEnabled) => {
                    let planner = d.planner().await;
                    d.walk(State::QuickStopActive, planner).await
                }
                Some(State::ReadyToSwitchOn | State::SwitchedOn) => {
                    d.put_controlword(crate::state::Command::QuickStop.controlword())
                        .await?;
                    let timeout = d.timeouts.transition;
                    Ok(d.wait_state(&[State::SwitchOnDisabled], timeout).await?.0)
                }
                Some(s) => Ok(s),
                None => Err(PlanError::UnknownState(sw).into()),
            }
        })
    }

    /// Sets or clears halt (controlword bit 8) in operation enabled, keeping the mode bits of
    /// the last controlword. In any other state: [`DriveError::NotEnabled`] (a controlword
    /// written there could switch the drive on).
    pub fn halt(&self, on: bool) -> DriveOp<()> {
        let d = self.clone();
        Operation::new(async move {
            d.require_enabled().await?;
            let cw = d
                .last_controlword()
                .filter(|c| c.raw() & 0x008F == 0x000F)
                .unwrap_or(Controlword::from_raw(0x000F));
            d.put_controlword(cw.with(0x0100, on)).await
        })
    }

    /// Fault reset (transition 15, on a rising edge of bit 7): reads 0x603F and the last EMCY
    /// first, then waits for switch on disabled. A drive not in fault is left as it is.
    pub fn fault_reset(&self) -> DriveOp<FaultReport> {
        let d = self.clone();
        Operation::new(async move {
            let sw = d.statusword().await?;
            let from = State::decode(sw).ok_or(PlanError::UnknownState(sw))?;
            let code = d.error_code().await?;
            let emcy = d.last_emcy();
            let state = match from {
                State::Fault | State::FaultReactionActive => {
                    let planner = d.planner().await;
                    d.walk(State::SwitchOnDisabled, planner).await?
                }
                s => s,
            };
            Ok(FaultReport {
                code,
                emcy,
                from,
                state,
            })
        })
    }
}

/// How one walk of a plan ended.
enum Walked {
    /// The state reached.
    Reached(State),
    /// The drive stayed in quick stop active after transition 16.
    NoTransition16,
}
