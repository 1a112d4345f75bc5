//! Homing (mode hm): how to home ([`Homing`]: the method set, a method number, the present
//! position, or not at all), the start edge and the wait for homing attained.

use std::prelude::rust_2024::*;

use canola::Operation;

use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::{self as obj};
use crate::state::{PlanError, State};
use crate::words::Controlword;

use super::{Awaited, Drive, DriveError, DriveOp, Reached, StopGuard};

/// How [`Drive::home_with`] homes (ros2_canopen #245, #328: homing skippable or custom).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Homing {
    /// The method 0x6098 holds already.
    #[default]
    Configured,
    /// This method, written to 0x6098 first (CiA 402-2 §10: 1..=35 and 37; negative codes are
    /// manufacturer-specific).
    Method(i8),
    /// Homing on the present position (method 37): no motion, the home offset 0x607C becomes
    /// the actual position.
    CurrentPosition,
    /// The drive is homed already (an absolute encoder, homed by an earlier run or by its own
    /// program): nothing is written, the mode is left as it is, and the actual position is
    /// returned. For code that always homes before it moves.
    AlreadyHomed,
}

impl Homing {
    /// CiA 402-2's method code for homing on the present position (35 in drafts before 2016).
    pub const CURRENT_POSITION_METHOD: i8 = 37;
}

impl Drive {
    /// Homes as `how` says (see [`Homing`]); [`home`](Self::home) for the rest.
    pub fn home_with(&self, how: Homing) -> DriveOp<i32> {
        match how {
            Homing::Configured => self.home(None),
            Homing::Method(m) => self.home(Some(m)),
            Homing::CurrentPosition => self.home(Some(Homing::CURRENT_POSITION_METHOD)),
            Homing::AlreadyHomed => self.position(),
        }
    }

    /// Homing: selects mode hm (in any state) and the method 0x6098 if given, then, in operation
    /// enabled only, starts it (bit 4 rising) and waits until it is attained (bits 12 and 10)
    /// or fails (bit 13). From any other state: [`DriveError::NotEnabled`] after the mode
    /// selection, the power state untouched (python-canopen #244, ros2_canopen #421). Returns
    /// the position where homing ended. Dropped or cancelled after homing started, it stops the
    /// drive as [`on_cancel`](Self::on_cancel) says.
    pub fn home(&self, method: Option<i8>) -> DriveOp<i32> {
        let d = self.clone();
        Operation::new(async move {
            d.select_mode(ModeOfOperation::Homing).await?;
            if let Some(m) = method {
                d.node.sdo().write(d.at(obj::HOMING_METHOD), m).await?;
            }
            d.require_enabled().await?;
            let base = Controlword::from_raw(0x000F);
            let guard = StopGuard::new(&d);
            let result = async {
                d.put_controlword(base).await?;
                d.put_controlword(base.with(0x0010, true)).await?;
                d.until_homed().await
            }
            .await;
            guard.disarm();
            // Bit 4 back to 0 (the homing start is an edge), whatever the result.
            if matches!(
                d.statusword().await.map(State::decode),
                Ok(Some(State::OperationEnabled))
            ) {
                let _ = d.put_controlword(base).await;
            }
            result
        })
    }

    async fn until_homed(&self) -> Result<i32, DriveError> {
        let start = self.node.network().now();
        loop {
            let sw = self.statusword().await?;
            let status = HomingStatus::decode(sw);
            match State::decode(sw) {
                Some(State::OperationEnabled) => {}
                Some(State::Fault | State::FaultReactionActive) => {
                    return Err(self.fault_error(sw).await);
                }
                Some(state) => {
                    return Err(DriveError::NotEnabled {
                        state,
                        statusword: sw,
                    });
                }
                None => return Err(PlanError::UnknownState(sw).into()),
            }
            if status == HomingStatus::Completed {
                return self.position().await;
            }
            if status.is_error() {
                return Err(DriveError::Homing {
                    status,
                    statusword: sw,
                });
            }
            let waited = self.node.network().now() - start;
            if waited >= self.timeouts.homing {
                return Err(DriveError::Timeout {
                    awaited: Awaited::HomingCompleted,
                    reached: Reached::Homing(status),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }
}
