//! [`Drive`]: one axis of a CiA 402 drive commanded over the master facade.
//!
//! Every command that talks to the bus or waits returns a [`canola::Operation`], finished by
//! `.wait()` (blocking) or `.await` (canola's `tokio` feature), as the facade's own calls are;
//! each is written once, as an async body awaiting the facade's operations. Dropping one
//! unfinished cancels it (a running SDO transfer is aborted on the bus); the drive stays usable
//! and the next command starts from the statusword it reads.
//!
//! Every value is read and written by SDO on the node's default channel; the statusword is read
//! fresh each time it is needed, never from a cached TPDO (python-canopen #168, #554). Nothing
//! changes the NMT state, and nothing changes the power state except the calls that say so
//! (python-canopen #178, #244; ros2_canopen #421): selecting a mode, homing and motion commands
//! never enable the drive; they fail with [`DriveError::NotEnabled`] when they need operation
//! enabled.
//!
//! Waits poll the statusword every [`Timeouts::poll`] of the network's clock (bus time on the
//! in-memory bus) and end with [`DriveError::Timeout`], which names what was awaited, the state
//! expected, the state reached and the last statusword.

use std::collections::HashMap;
use std::format;
use std::prelude::rust_2024::*;
use std::sync::{Arc, Mutex};

use canola::{Duration, Node, Operation};

use super::dcf::{DcfPdo, DcfPdoError, DcfPdos};
use crate::mode::{HomingStatus, ModeOfOperation};
use crate::objects::{self as obj, ErrorCode, QuickStopOption};
use crate::state::{PlanError, Planner, State, Transition};
use crate::words::{Controlword, Statusword};

/// How long each kind of wait may take, and how often it polls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// One state transition (each step of a plan).
    pub transition: Duration,
    /// 0x6061 showing a new mode.
    pub mode: Duration,
    /// The set-point acknowledge (statusword bit 12) after a new set-point.
    pub set_point: Duration,
    /// A move's target reached (bit 10).
    pub motion: Duration,
    /// Homing attained (bits 10 and 12); homing can take long (ros2_canopen #196).
    pub homing: Duration,
    /// The interval between two statusword reads while waiting.
    pub poll: Duration,
}

impl Default for Timeouts {
    /// 1 s per transition, 1 s for a mode, 500 ms for a set-point acknowledge, 60 s for a move
    /// and for homing, polling every 5 ms.
    fn default() -> Self {
        Self {
            transition: Duration::from_millis(1000),
            mode: Duration::from_millis(1000),
            set_point: Duration::from_millis(500),
            motion: Duration::from_secs(60),
            homing: Duration::from_secs(60),
            poll: Duration::from_millis(5),
        }
    }
}

/// Why a drive command failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriveError {
    /// An SDO transfer failed (the drive's abort code included: a mode it refuses is 0x06090030).
    #[error(transparent)]
    Sdo(#[from] canola::Error),
    /// A wait ran out of time.
    #[error(
        "timed out after {waited} waiting for {waiting_for}: expected {expected}, reached {reached} (statusword {statusword})"
    )]
    Timeout {
        /// What was awaited ("state", "mode", "set-point acknowledge", "target reached", "homing").
        waiting_for: &'static str,
        /// The state (or mode, or bit) expected.
        expected: String,
        /// What the drive showed last.
        reached: String,
        /// The last statusword read.
        statusword: Statusword,
        /// How long the wait took.
        waited: Duration,
    },
    /// No plan reaches the target: safe torque off (voltage not enabled), an unknown statusword,
    /// a state only the drive can enter.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The command needs operation enabled.
    #[error(
        "the drive is in {state} (statusword {statusword}); this command needs operation enabled"
    )]
    NotEnabled {
        /// The drive's state.
        state: State,
        /// The statusword.
        statusword: Statusword,
    },
    /// The drive went to fault (or fault reaction active) during the command.
    #[error("the drive faulted: error code {code}{} (statusword {statusword})", .emcy.as_ref().map(|e| format!(", {e}")).unwrap_or_default())]
    Fault {
        /// 0x603F.
        code: ErrorCode,
        /// The last EMCY of the node, as text.
        emcy: Option<String>,
        /// The statusword.
        statusword: Statusword,
    },
    /// A cyclic stream needs csp, csv or cst.
    #[error("{0:?} is not a cyclic synchronous mode (csp, csv, cst)")]
    NotCyclic(ModeOfOperation),
    /// The DCF's PDOs cannot serve the mode (see [`Drive::start_cyclic_from_dcf`]).
    #[error(transparent)]
    Dcf(#[from] DcfPdoError),
    /// The node has no such RPDO, or its period does not fit 0x60C2.
    #[error("cannot set up the cyclic stream: {0}")]
    Cyclic(String),
    /// Homing ended with an error (statusword bit 13).
    #[error("homing failed: {status:?} (statusword {statusword})")]
    Homing {
        /// The homing status.
        status: HomingStatus,
        /// The statusword.
        statusword: Statusword,
    },
}

/// What a fault reset found and did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaultReport {
    /// 0x603F before the reset.
    pub code: ErrorCode,
    /// The node's last EMCY before the reset, as text.
    pub emcy: Option<String>,
    /// The state before the reset.
    pub from: State,
    /// The state after it.
    pub state: State,
}

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

/// The drive's values at one moment (each read by SDO).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveStatus {
    /// 0x6041.
    pub statusword: Statusword,
    /// The state it shows (`None`: a pattern no state has).
    pub state: Option<State>,
    /// 0x6061.
    pub mode: ModeOfOperation,
    /// 0x6064, counts.
    pub position: i32,
    /// 0x606C, counts/s.
    pub velocity: i32,
    /// 0x6077, ‰ of rated torque.
    pub torque: i16,
    /// 0x603F.
    pub error_code: ErrorCode,
}

/// One axis of a CiA 402 drive on a node. See the module documentation.
///
/// Cheap to clone: clones command the same axis and share what the master knows of it (the
/// last controlword, the TPDO values followed, a cyclic stream's controlword), so a clone can
/// move into a task or an operation's body.
#[derive(Clone, Debug)]
pub struct Drive {
    node: Node,
    axis: u8,
    timeouts: Timeouts,
    transition_16: bool,
    shared: Arc<Shared>,
}

/// What the clones of a [`Drive`] share.
#[derive(Debug)]
struct Shared {
    node: Node,
    /// The last controlword sent (bit 7 matters for the fault reset's rising edge); `None`
    /// while unknown (before the first, or while a write is on its way).
    last_cw: Mutex<Option<Controlword>>,
    /// Actual values from TPDOs, when followed.
    tpdo: Mutex<Option<Following>>,
    /// The RPDO of a cyclic stream that carries the controlword too (a DCF's mapping), and
    /// where: every controlword written goes into it as well, so its next frame does not undo
    /// the write.
    stream_controlword: Mutex<Option<(canola::RpdoSender, (u16, u8))>>,
}

/// The TPDO values a [`Drive`] follows (see [`Drive::follow_tpdos`]).
#[derive(Debug)]
struct Following {
    callback: canola::PdoCallbackId,
    cache: Arc<Mutex<ActualsCache>>,
    max_age: Duration,
}

/// The latest value of each followed object, with its reception time.
type ActualsCache = HashMap<(u16, u8), (i64, canola::Instant)>;

/// What the drive's commands return: an operation finished by `.wait()` or `.await`.
type DriveOp<T> = Operation<'static, T, DriveError>;

impl Drop for Shared {
    fn drop(&mut self) {
        if let Some(f) = self
            .tpdo
            .get_mut()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            self.node.network().remove_pdo_callback(f.callback);
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Drive {
    /// Axis 0 of `node`.
    pub fn new(node: Node) -> Self {
        Self::on_axis(node, 0)
    }

    /// Axis `axis` of a multi-axis `node` (objects at index + axis × 0x800; axes 0..=7).
    pub fn on_axis(node: Node, axis: u8) -> Self {
        Self {
            shared: Arc::new(Shared {
                node: node.clone(),
                last_cw: Mutex::new(None),
                tpdo: Mutex::new(None),
                stream_controlword: Mutex::new(None),
            }),
            node,
            axis: axis.min(obj::MAX_AXIS),
            timeouts: Timeouts::default(),
            transition_16: true,
        }
    }

    /// With other timeouts.
    pub fn with_timeouts(mut self, timeouts: Timeouts) -> Self {
        self.timeouts = timeouts;
        self
    }

    /// Whether to use transition 16 (quick stop active → operation enabled) when 0x605A is
    /// 5..8. On by default; without it (or when the drive ignores it: python-canopen #169) the
    /// drive is enabled through switch on disabled.
    pub fn with_transition_16(mut self, on: bool) -> Self {
        self.transition_16 = on;
        self
    }

    /// The node.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// The axis.
    pub fn axis(&self) -> u8 {
        self.axis
    }

    /// The timeouts.
    pub fn timeouts(&self) -> Timeouts {
        self.timeouts
    }

    fn at<T>(&self, e: canola::od::Entry<T>) -> (u16, u8) {
        (
            e.index() + u16::from(self.axis) * obj::AXIS_OFFSET,
            e.sub_index(),
        )
    }

    /// The first `N` bytes of the object at `at` (zero-padded), by SDO.
    async fn read_at<const N: usize>(&self, at: (u16, u8)) -> Result<[u8; N], DriveError> {
        let data = self.node.sdo().read(at).await?;
        let mut out = [0u8; N];
        let n = data.len().min(N);
        out[..n].copy_from_slice(&data[..n]);
        Ok(out)
    }

    /// Reads the statusword 0x6041 (by SDO: always fresh).
    pub fn statusword(&self) -> DriveOp<Statusword> {
        let d = self.clone();
        Operation::new(async move {
            let at = d.at(obj::STATUSWORD);
            Ok(Statusword::from_le_bytes(d.read_at(at).await?))
        })
    }

    /// The state the statusword shows; a pattern no state has is [`PlanError::UnknownState`].
    pub fn state(&self) -> DriveOp<State> {
        let d = self.clone();
        Operation::new(async move {
            let sw = d.statusword().await?;
            State::decode(sw).ok_or(DriveError::Plan(PlanError::UnknownState(sw)))
        })
    }

    /// The mode running, 0x6061. 0 (no mode), manufacturer-specific and reserved codes are
    /// values too (python-canopen #183).
    pub fn mode(&self) -> DriveOp<ModeOfOperation> {
        let d = self.clone();
        Operation::new(async move {
            let [b] = d.read_at(d.at(obj::MODES_OF_OPERATION_DISPLAY)).await?;
            Ok(ModeOfOperation::from_code(b as i8))
        })
    }

    /// The error code 0x603F.
    pub fn error_code(&self) -> DriveOp<ErrorCode> {
        let d = self.clone();
        Operation::new(async move {
            let b = d.read_at(d.at(obj::ERROR_CODE)).await?;
            Ok(ErrorCode(u16::from_le_bytes(b)))
        })
    }

    /// Takes the actual values (position 0x6064, velocity 0x606C, torque 0x6077) from the
    /// node's TPDOs as they arrive, each while it is at most `max_age` old; an older
    /// or never received value is read by SDO. TPDOs are decoded through the node's dictionary
    /// (a node added with [`Network::add_node_with_dictionary`](canola::Network::add_node_with_dictionary)),
    /// with the mapping the master knows. The statusword and the mode are always read by SDO:
    /// the state machine and mode changes wait on fresh ones (python-canopen #554).
    pub fn follow_tpdos(&self, max_age: Duration) {
        let cache: Arc<Mutex<ActualsCache>> = Arc::default();
        let sink = Arc::clone(&cache);
        let me = self.node.id();
        let watched = [
            self.at(obj::POSITION_ACTUAL_VALUE),
            self.at(obj::VELOCITY_ACTUAL_VALUE),
            self.at(obj::TORQUE_ACTUAL_VALUE),
        ];
        let callback = self.node.network().on_pdo(move |p| {
            if p.node != me {
                return;
            }
            let mut c = lock(&sink);
            for (addr, value) in p.values {
                let key = (addr.index, addr.sub_index);
                if let (true, Some(v)) = (watched.contains(&key), value.as_i128()) {
                    c.insert(key, (v as i64, p.at));
                }
            }
        });
        let old = lock(&self.shared.tpdo).replace(Following {
            callback,
            cache,
            max_age,
        });
        if let Some(f) = old {
            self.node.network().remove_pdo_callback(f.callback);
        }
    }

    /// A followed TPDO value of `e`, if fresh enough.
    fn tpdo_value<T>(&self, e: canola::od::Entry<T>) -> Option<i64> {
        let guard = lock(&self.shared.tpdo);
        let f = guard.as_ref()?;
        let (v, at) = *lock(&f.cache).get(&self.at(e))?;
        (self.node.network().now() - at <= f.max_age).then_some(v)
    }

    /// An actual value: the followed TPDO's while fresh, else `N` bytes by SDO.
    fn actual<const N: usize, E, T: Send + 'static>(
        &self,
        e: canola::od::Entry<E>,
        from_tpdo: fn(i64) -> T,
        from_bytes: fn([u8; N]) -> T,
    ) -> DriveOp<T> {
        let cached = self.tpdo_value(e).map(from_tpdo);
        let d = self.clone();
        let at = self.at(e);
        Operation::new(async move {
            match cached {
                Some(v) => Ok(v),
                None => Ok(from_bytes(d.read_at(at).await?)),
            }
        })
    }

    /// The actual position 0x6064, counts (from a TPDO when followed and fresh).
    pub fn position(&self) -> DriveOp<i32> {
        self.actual(obj::POSITION_ACTUAL_VALUE, |v| v as i32, i32::from_le_bytes)
    }

    /// The actual velocity 0x606C, counts/s (from a TPDO when followed and fresh).
    pub fn velocity(&self) -> DriveOp<i32> {
        self.actual(obj::VELOCITY_ACTUAL_VALUE, |v| v as i32, i32::from_le_bytes)
    }

    /// The actual torque 0x6077, ‰ of rated torque (from a TPDO when followed and fresh).
    pub fn torque(&self) -> DriveOp<i16> {
        self.actual(obj::TORQUE_ACTUAL_VALUE, |v| v as i16, i16::from_le_bytes)
    }

    /// Statusword, state, mode, actual values and error code.
    pub fn status(&self) -> DriveOp<DriveStatus> {
        let d = self.clone();
        Operation::new(async move {
            let statusword = d.statusword().await?;
            Ok(DriveStatus {
                statusword,
                state: State::decode(statusword),
                mode: d.mode().await?,
                position: d.position().await?,
                velocity: d.velocity().await?,
                torque: d.torque().await?,
                error_code: d.error_code().await?,
            })
        })
    }

    /// The node's latest EMCY (since the network started), as text.
    pub fn last_emcy(&self) -> Option<String> {
        self.node
            .network()
            .last_emcy(self.node.id())
            .map(|e| e.emcy.to_string())
    }

    /// Writes the controlword 0x6040 (by SDO; also into a cyclic stream's RPDO that maps it).
    pub fn write_controlword(&self, cw: Controlword) -> DriveOp<()> {
        let d = self.clone();
        Operation::new(async move { d.put_controlword(cw).await })
    }

    async fn put_controlword(&self, cw: Controlword) -> Result<(), DriveError> {
        if let Some((sender, at)) = lock(&self.shared.stream_controlword).as_ref() {
            sender.set(*at, cw.raw())?;
        }
        // Unknown until the drive has it: a write cancelled half-way (its operation dropped)
        // leaves the master not knowing which controlword the drive took.
        *lock(&self.shared.last_cw) = None;
        self.node
            .sdo()
            .write(self.at(obj::CONTROLWORD), cw.raw())
            .await?;
        *lock(&self.shared.last_cw) = Some(cw);
        Ok(())
    }

    fn last_controlword(&self) -> Option<Controlword> {
        *lock(&self.shared.last_cw)
    }

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

    /// One poll interval of the network's clock.
    async fn sleep(&self) -> Result<(), DriveError> {
        self.node.network().run_for(self.timeouts.poll).await?;
        Ok(())
    }

    async fn fault_error(&self, sw: Statusword) -> DriveError {
        DriveError::Fault {
            code: self.error_code().await.unwrap_or_default(),
            emcy: self.last_emcy(),
            statusword: sw,
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
                Err(DriveError::Timeout { reached, .. })
                    if step.transition == Transition::T16
                        && reached == State::QuickStopActive.name()
                        && planner.transition_16 =>
                {
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
                    waiting_for: "state",
                    expected: states
                        .iter()
                        .map(|s| s.name())
                        .collect::<Vec<_>>()
                        .join(" or "),
                    reached: state.map_or_else(|| "no state".to_string(), |s| s.name().to_string()),
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

    /// Selects a mode: writes 0x6060 and waits until 0x6061 shows it. Succeeds at once when
    /// 0x6061 already shows it (ros2_canopen #445); does not read 0x6502 (ros2_canopen #299: a
    /// mode the drive refuses is its SDO abort); does not change the power state (python-canopen
    /// #244). Returns the mode before.
    pub fn set_mode(&self, mode: ModeOfOperation) -> DriveOp<ModeOfOperation> {
        let d = self.clone();
        Operation::new(async move { d.select_mode(mode).await })
    }

    async fn select_mode(&self, mode: ModeOfOperation) -> Result<ModeOfOperation, DriveError> {
        let before = self.mode().await?;
        if before == mode {
            return Ok(before);
        }
        self.node
            .sdo()
            .write(self.at(obj::MODES_OF_OPERATION), mode.code())
            .await?;
        let start = self.node.network().now();
        loop {
            let now_mode = self.mode().await?;
            if now_mode == mode {
                return Ok(before);
            }
            let waited = self.node.network().now() - start;
            if waited >= self.timeouts.mode {
                return Err(DriveError::Timeout {
                    waiting_for: "mode (0x6061)",
                    expected: mode_name(mode),
                    reached: mode_name(now_mode),
                    statusword: self.statusword().await?,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    async fn require_enabled(&self) -> Result<Statusword, DriveError> {
        let sw = self.statusword().await?;
        match State::decode(sw) {
            Some(State::OperationEnabled) => Ok(sw),
            Some(state) => Err(DriveError::NotEnabled {
                state,
                statusword: sw,
            }),
            None => Err(PlanError::UnknownState(sw).into()),
        }
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
            "set-point acknowledge (statusword bit 12)",
            self.timeouts.set_point,
        )
        .await?;
        self.put_controlword(base).await
    }

    /// Waits for target reached, statusword bit 10 (not bit 4: OpenCAN #51), calling `each`
    /// with the actual position at every poll. Returns the final position.
    pub fn wait_target_reached<'a>(
        &self,
        mut each: impl FnMut(i32) + Send + 'a,
    ) -> Operation<'a, i32, DriveError> {
        let d = self.clone();
        Operation::new(async move { d.until_target_reached(&mut each).await })
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
                    waiting_for: "target reached (statusword bit 10)",
                    expected: "target reached".into(),
                    reached: format!("{} at position {position}", State::OperationEnabled),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }

    /// A profile-position move to the end: [`start_move`](Self::start_move), then
    /// [`wait_target_reached`](Self::wait_target_reached). Returns the final position.
    pub fn move_to(&self, m: Move) -> DriveOp<i32> {
        let d = self.clone();
        Operation::new(async move {
            d.begin_move(m).await?;
            d.until_target_reached(&mut |_| {}).await
        })
    }

    async fn wait_bit(
        &self,
        bit: u32,
        on: bool,
        what: &'static str,
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
                    waiting_for: what,
                    expected: format!("bit {bit} {}", if on { "set" } else { "clear" }),
                    reached: state.map_or_else(|| "no state".into(), |s| s.name().to_string()),
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

    /// Homing: selects mode hm (in any state) and the method 0x6098 if given, then, in operation
    /// enabled only, starts it (bit 4 rising) and waits until it is attained (bits 12 and 10)
    /// or fails (bit 13). From any other state: [`DriveError::NotEnabled`] after the mode
    /// selection, the power state untouched (python-canopen #244, ros2_canopen #421). Returns
    /// the position where homing ended.
    pub fn home(&self, method: Option<i8>) -> DriveOp<i32> {
        let d = self.clone();
        Operation::new(async move {
            d.select_mode(ModeOfOperation::Homing).await?;
            if let Some(m) = method {
                d.node.sdo().write(d.at(obj::HOMING_METHOD), m).await?;
            }
            d.require_enabled().await?;
            let base = Controlword::from_raw(0x000F);
            d.put_controlword(base).await?;
            d.put_controlword(base.with(0x0010, true)).await?;
            let result = d.until_homed().await;
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
                    waiting_for: "homing attained (statusword bits 10, 12)",
                    expected: "homing completed".into(),
                    reached: format!("{status:?}"),
                    statusword: sw,
                    waited,
                });
            }
            self.sleep().await?;
        }
    }
}

/// How one walk of a plan ended.
enum Walked {
    /// The state reached.
    Reached(State),
    /// The drive stayed in quick stop active after transition 16.
    NoTransition16,
}

/// A cyclic synchronous stream (csp, csv, cst) of one drive: its target goes in an RPDO the
/// master's PDO engine sends after every SYNC the master produces (see
/// [`Drive::start_cyclic`]). Set the next target once per cycle; nothing here waits.
#[derive(Debug)]
pub struct CyclicStream {
    drive: Drive,
    sender: canola::RpdoSender,
    target: (u16, u8),
}

impl CyclicStream {
    /// The target the next SYNC's RPDO carries (position in counts for csp, velocity in
    /// counts/s for csv, torque in ‰ for cst; range-checked against the object's type).
    pub fn set_target(&self, value: i32) -> Result<(), DriveError> {
        self.sender.set(self.target, value)?;
        Ok(())
    }

    /// The drive.
    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The RPDO number the stream sends.
    pub fn rpdo(&self) -> u16 {
        self.sender.number()
    }

    /// Stops sending the RPDO (the drive keeps its last target). Does not wait.
    pub fn stop(self) -> Result<(), DriveError> {
        let mut slot = lock(&self.drive.shared.stream_controlword);
        if slot
            .as_ref()
            .is_some_and(|(s, _)| s.number() == self.sender.number())
        {
            *slot = None;
        }
        drop(slot);
        self.sender.stop()?;
        Ok(())
    }
}

impl Drive {
    /// Starts a cyclic synchronous stream in `mode` (csp, csv or cst) through the node's RPDO
    /// number `rpdo`, which is remapped to carry only the mode's target (0x607A, 0x60FF or
    /// 0x6071) on every SYNC (type 1). 0x60C2 is set to `period`, the SYNC period the master
    /// produces (start it with [`Network::start_sync`](canola::Network::start_sync)); the node
    /// must be operational for its RPDOs to count.
    ///
    /// The first target is the present actual value for csp (the drive does not jump:
    /// ethercat_driver_ros2 #125) and 0 for csv and cst; it is in the RPDO before the mode is
    /// switched, so the drive never takes a stale target. The power state is not changed.
    pub fn start_cyclic(
        &self,
        mode: ModeOfOperation,
        rpdo: u16,
        period: Duration,
    ) -> DriveOp<CyclicStream> {
        let d = self.clone();
        Operation::new(async move {
            let (target, bits, first) = match mode {
                ModeOfOperation::CyclicSyncPosition => (
                    d.at(obj::TARGET_POSITION),
                    32,
                    i64::from(d.position().await?),
                ),
                ModeOfOperation::CyclicSyncVelocity => (d.at(obj::TARGET_VELOCITY), 32, 0),
                ModeOfOperation::CyclicSyncTorque => (d.at(obj::TARGET_TORQUE), 16, 0),
                m => return Err(DriveError::NotCyclic(m)),
            };
            d.write_interpolation_period(period).await?;
            let rpdos = d.node.rpdo();
            let mut set = rpdos.read().await?;
            let p = set
                .get_mut(rpdo)
                .ok_or_else(|| DriveError::Cyclic(format!("the node has no RPDO{rpdo}")))?;
            p.clear();
            p.map_entry(canola::ObjectAddress::new(target.0, target.1), bits);
            p.set_transmission_type(canola::pdo::TransmissionType::SyncCyclic(1));
            p.set_enabled(true);
            rpdos.save(&mut set).await?;
            let p = set
                .get(rpdo)
                .ok_or_else(|| DriveError::Cyclic(format!("the node has no RPDO{rpdo}")))?;
            let sender = rpdos.start(p, canola::Transmission::on_sync())?;
            sender.set(target, first)?;
            // Also by SDO, so the target is in place before the mode switch whatever the SYNC
            // does.
            match bits {
                16 => d.node.sdo().write(target, first as i16).await?,
                _ => d.node.sdo().write(target, first as i32).await?,
            }
            d.select_mode(mode).await?;
            Ok(CyclicStream {
                drive: d,
                sender,
                target,
            })
        })
    }

    /// 0x60C2 (interpolation time period) set to `period`.
    async fn write_interpolation_period(&self, period: Duration) -> Result<(), DriveError> {
        let ip = obj::InterpolationPeriod::from_micros(period.as_micros()).ok_or_else(|| {
            DriveError::Cyclic(format!("a period of {period} does not fit 0x60C2"))
        })?;
        let sdo = || self.node.sdo();
        sdo()
            .write(self.at(obj::INTERPOLATION_TIME_PERIOD_VALUE), ip.value)
            .await?;
        sdo()
            .write(self.at(obj::INTERPOLATION_TIME_INDEX), ip.index)
            .await?;
        Ok(())
    }

    /// Starts a cyclic synchronous stream in `mode` (csp, csv or cst) on the PDOs a DCF
    /// configures for it ([`DcfPdos::for_mode`]) instead of a mapping of its own: the valid
    /// synchronous RPDO that carries the mode's target, as the DCF maps it (with whatever else
    /// it maps, e.g. the controlword), and the valid TPDOs carrying the actual value. Both are
    /// written to the device as the DCF has them (COB-ID, transmission type, timers, mapping;
    /// what the device holds already is not written again), so the master decodes the TPDOs
    /// with that mapping (see [`follow_tpdos`](Self::follow_tpdos)) and sends the RPDO on
    /// every SYNC it produces.
    ///
    /// A DCF without such PDOs fails with [`DriveError::Dcf`] before anything is written. The
    /// other objects the RPDO maps start at their present values (read by SDO): the
    /// controlword at the last one written, which every later controlword write also updates
    /// (so the RPDO never undoes a state change), the mode of operation (0x6060) at `mode`.
    /// The first target is the actual position for csp and 0 for csv and cst, as in
    /// [`start_cyclic`](Self::start_cyclic); 0x60C2 is set to `period`; the power state is not
    /// changed.
    pub fn start_cyclic_from_dcf(
        &self,
        mode: ModeOfOperation,
        pdos: &DcfPdos,
        period: Duration,
    ) -> DriveOp<CyclicStream> {
        let m = pdos.for_mode(mode, self.axis);
        let d = self.clone();
        Operation::new(async move {
            let m = m?;
            let first = match mode {
                ModeOfOperation::CyclicSyncPosition => i64::from(d.position().await?),
                _ => 0,
            };
            d.write_interpolation_period(period).await?;
            let tpdos = d.node.tpdo();
            let mut set = tpdos.read().await?;
            for t in &m.tpdos {
                apply_dcf_pdo(&mut set, t)?;
            }
            tpdos.save(&mut set).await?;
            let rpdos = d.node.rpdo();
            let mut set = rpdos.read().await?;
            apply_dcf_pdo(&mut set, &m.rpdo)?;
            rpdos.save(&mut set).await?;
            let p = set.get(m.rpdo.number).ok_or_else(|| {
                DriveError::Cyclic(format!("the node has no RPDO{}", m.rpdo.number))
            })?;
            let sender = rpdos.start(p, canola::Transmission::on_sync())?;
            let cw_at = d.at(obj::CONTROLWORD);
            let mode_at = d.at(obj::MODES_OF_OPERATION);
            let mut cw_mapped = false;
            for (index, sub, bits) in m.rpdo.objects() {
                let at = (index, sub);
                if at == m.target {
                    sender.set(at, first)?;
                } else if at == cw_at {
                    let cw = match d.last_controlword() {
                        Some(cw) => cw.raw(),
                        None => u16::from_le_bytes(d.read_at(cw_at).await?),
                    };
                    sender.set(at, cw)?;
                    cw_mapped = true;
                } else if at == mode_at {
                    sender.set(at, mode.code())?;
                } else if index >= 0x1000 && bits % 8 == 0 {
                    // Anything else keeps the value the device has.
                    let mut data = d.node.sdo().read(at).await?;
                    data.resize(usize::from(bits / 8), 0);
                    sender.set(at, data)?;
                }
            }
            if cw_mapped {
                *lock(&d.shared.stream_controlword) = Some((sender.clone(), cw_at));
            }
            // Also by SDO, so the target is in place before the mode switch whatever the SYNC
            // does.
            match m.target_bits {
                16 => d.node.sdo().write(m.target, first as i16).await?,
                _ => d.node.sdo().write(m.target, first as i32).await?,
            }
            d.select_mode(mode).await?;
            Ok(CyclicStream {
                drive: d,
                sender,
                target: m.target,
            })
        })
    }
}

/// Sets PDO `d.number` of `set` to the DCF's parameters and mapping.
fn apply_dcf_pdo(set: &mut canola::PdoSet, d: &DcfPdo) -> Result<(), DriveError> {
    let kind = match set.direction() {
        canola::pdo::Direction::Receive => "RPDO",
        canola::pdo::Direction::Transmit => "TPDO",
    };
    let p = set.get_mut(d.number).ok_or_else(|| {
        DriveError::Cyclic(format!(
            "the DCF configures {kind}{}, which the node does not have",
            d.number
        ))
    })?;
    p.clear();
    for (index, sub, bits) in d.objects() {
        p.map_entry(canola::ObjectAddress::new(index, sub), bits);
    }
    p.comm = d.comm;
    Ok(())
}

fn mode_name(m: ModeOfOperation) -> String {
    format!("{} ({})", m.short_name().unwrap_or("?"), m.code())
}
