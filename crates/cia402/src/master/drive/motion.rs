//! Modes and motion: selecting a mode (confirmed by 0x6061), profile-position moves with the
//! set-point handshake and the wait for target reached, profile velocity and profile torque.

use std::prelude::rust_2024::*;

use canola::{Duration, Operation};

use crate::mode::ModeOfOperation;
use crate::objects::{self as obj};
use crate::state::{PlanError, State};
use crate::words::{Controlword, Statusword};

use super::{Awaited, Drive, DriveError, DriveOp, Reached, StopGuard};

/// A profile-position move.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Move {
    /// The target (0x607A), counts.
    pub target: i32,
    /// Relative to the present target (controlword bit 6) instead of absolute.
    pub relative: bool,
    /// Profile velocity 0x6081 to write first; `None` keeps the drive's.
    pub velocity: Option<u32>,
    /// Change set immediately (controlword bit 5).
    pub immediate: bool,
}

impl Drive {
    /// Selects a mode: writes 0x6060 and waits until 0x6061 shows it. Succeeds at once when
    /// 0x6061 already shows it (ros2_canopen #445); does not read 0x6502 (ros2_canopen #299: a
    /// mode the drive refuses is its SDO abort); does not change the power state (python-canopen
    /// #244). Returns the mode before.
    ///
    /// Some drives refuse a mode change while halt (controlword bit 8) is set (ros2_canopen
    /// #234): the refusal (an SDO abort, or 0x6061 not following) is then
    /// [`DriveError::ModeRefusedWhileHalted`]. Halt is not cleared here: clearing it resumes
    /// what the drive was doing; clear it with [`halt`](Self::halt)`(false)` when that is wanted.
    pub fn set_mode(&self, mode: ModeOfOperation) -> DriveOp<ModeOfOperation> {
        let d = self.clone();
        Operation::new(async move { d.select_mode(mode).await })
    }

    pub(super) async fn select_mode(
        &self,
        mode: ModeOfOperation,
    ) -> Result<ModeOfOperation, DriveError> {
        let before = self.mode().await?;
        if before == mode {
            return Ok(before);
        }
        if let Err(e) = self
            .node
            .sdo()
            .write(self.at(obj::MODES_OF_OPERATION), mode.code())
            .await
        {
            return Err(self.halt_refusal(mode).await.unwrap_or(e.into()));
        }
        let start = self.node.network().now();
        loop {
            let now_mode = self.mode().await?;
            if now_mode == mode {
                return Ok(before);
            }
            let waited = self.node.network().now() - start;
            if waited >= self.timeouts.mode {
                if let Some(e) = self.halt_refusal(mode).await {
                    return Err(e);
                }
                return Err(DriveError::Timeout {
                    awaited: Awaited::Mode(mode),
                    reached: Reached::Mode(now_mode),
                    statusword: self.statusword().await?,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    /// A refused change to `mode` explained by halt: the controlword (read back by SDO) has
    /// bit 8 set.
    async fn halt_refusal(&self, mode: ModeOfOperation) -> Option<DriveError> {
        let cw = Controlword::from_le_bytes(self.read_at(self.at(obj::CONTROLWORD)).await.ok()?);
        cw.halt().then_some(DriveError::ModeRefusedWhileHalted {
            mode,
            controlword: cw,
        })
    }

    /// Starts a profile-position move: mode pp, profile velocity, target 0x607A, then the new
    /// set-point handshake (bit 4 rising, wait for the acknowledge bit 12, bit 4 cleared).
    /// Needs operation enabled.
    pub fn start_move(&self, m: Move) -> DriveOp<()> {
        let d = self.clone();
        Operation::new(async move { d.begin_move(m).await })
    }

    async fn begin_move(&self, m: Move) -> Result<(), DriveError> {
        self.require_enabled().await?;
        self.select_mode(ModeOfOperation::ProfilePosition).await?;
        if let Some(v) = m.velocity {
            self.node
                .sdo()
                .write(self.at(obj::PROFILE_VELOCITY), v)
                .await?;
        }
        self.node
            .sdo()
            .write(self.at(obj::TARGET_POSITION), m.target)
            .await?;
        let base = Controlword::from_raw(0x000F)
            .with(0x0040, m.relative)
            .with(0x0020, m.immediate);
        // Bit 4 clear first, so that the set-point is a rising edge.
        if self.last_controlword() != Some(base) {
            self.put_controlword(base).await?;
        }
        self.put_controlword(base.with(0x0010, true)).await?;
        self.wait_bit(
            12,
            true,
            Awaited::SetPointAcknowledge,
            self.timeouts.set_point,
        )
        .await?;
        self.put_controlword(base).await
    }

    /// Waits for target reached, statusword bit 10 (not bit 4: OpenCAN #51), calling `each`
    /// with the actual position at every poll. Returns the final position. Dropped or
    /// cancelled before it ends, it stops the drive as [`on_cancel`](Self::on_cancel) says.
    pub fn wait_target_reached<'a>(
        &self,
        mut each: impl FnMut(i32) + Send + 'a,
    ) -> Operation<'a, i32, DriveError> {
        let d = self.clone();
        Operation::new(async move {
            let guard = StopGuard::new(&d);
            let r = d.until_target_reached(&mut each).await;
            guard.disarm();
            r
        })
    }

    async fn until_target_reached(
        &self,
        each: &mut (dyn FnMut(i32) + Send + '_),
    ) -> Result<i32, DriveError> {
        let start = self.node.network().now();
        loop {
            let sw = self.statusword().await?;
            let state = State::decode(sw);
            if state != Some(State::OperationEnabled) {
                if matches!(state, Some(State::Fault | State::FaultReactionActive)) {
                    return Err(self.fault_error(sw).await);
                }
                return Err(DriveError::NotEnabled {
                    state: state.ok_or(PlanError::UnknownState(sw))?,
                    statusword: sw,
                });
            }
            let position = self.position().await?;
            each(position);
            if sw.target_reached() && !sw.bit(12) {
                return Ok(position);
            }
            let waited = self.node.network().now() - start;
            if waited >= self.timeouts.motion {
                return Err(DriveError::Timeout {
                    awaited: Awaited::TargetReached,
                    reached: Reached::Position(position),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    /// A profile-position move to the end: [`start_move`](Self::start_move), then
    /// [`wait_target_reached`](Self::wait_target_reached). Returns the final position.
    ///
    /// Dropped or cancelled before it ends, it stops the drive as [`on_cancel`](Self::on_cancel)
    /// says (a quick stop unless set otherwise; see [`OnCancel`](super::OnCancel) for what a panic leaves).
    pub fn move_to(&self, m: Move) -> DriveOp<i32> {
        let d = self.clone();
        Operation::new(async move {
            let guard = StopGuard::new(&d);
            let r = async {
                d.begin_move(m).await?;
                d.until_target_reached(&mut |_| {}).await
            }
            .await;
            guard.disarm();
            r
        })
    }

    async fn wait_bit(
        &self,
        bit: u32,
        on: bool,
        what: Awaited,
        timeout: Duration,
    ) -> Result<Statusword, DriveError> {
        let start = self.node.network().now();
        loop {
            let sw = self.statusword().await?;
            if sw.bit(bit) == on {
                return Ok(sw);
            }
            let state = State::decode(sw);
            if matches!(state, Some(State::Fault | State::FaultReactionActive)) {
                return Err(self.fault_error(sw).await);
            }
            let waited = self.node.network().now() - start;
            if waited >= timeout {
                return Err(DriveError::Timeout {
                    awaited: what,
                    reached: Reached::State(state),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    /// Profile velocity: mode pv, target velocity 0x60FF (counts/s), halt cleared when the
    /// drive is enabled. Does not enable the drive (a target set before enabling is taken when
    /// it is enabled).
    pub fn set_velocity(&self, velocity: i32) -> DriveOp<()> {
        let d = self.clone();
        Operation::new(async move {
            d.select_mode(ModeOfOperation::ProfileVelocity).await?;
            d.node
                .sdo()
                .write(d.at(obj::TARGET_VELOCITY), velocity)
                .await?;
            d.release_halt().await
        })
    }

    /// Profile torque: mode tq, target torque 0x6071 (‰ of rated torque), halt cleared when the
    /// drive is enabled. Does not enable the drive.
    pub fn set_torque(&self, torque: i16) -> DriveOp<()> {
        let d = self.clone();
        Operation::new(async move {
            d.select_mode(ModeOfOperation::ProfileTorque).await?;
            d.node.sdo().write(d.at(obj::TARGET_TORQUE), torque).await?;
            d.release_halt().await
        })
    }

    async fn release_halt(&self) -> Result<(), DriveError> {
        if State::decode(self.statusword().await?) == Some(State::OperationEnabled)
            && self.last_controlword() != Some(Controlword::from_raw(0x000F))
        {
            self.put_controlword(Controlword::from_raw(0x000F)).await?;
        }
        Ok(())
    }
}
