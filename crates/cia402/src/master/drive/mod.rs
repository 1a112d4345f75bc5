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
//! in-memory bus) and end with [`DriveError::Timeout`], which holds what was awaited
//! ([`Awaited`]), what the drive showed ([`Reached`]) and the last statusword. A motion command
//! dropped or cancelled unfinished stops the drive ([`OnCancel`], in `stop`).
//!
//! This file holds [`Drive`], what its clones share, the controlword and the reads every command
//! uses; the errors are in `error`, the state walking in `states`, modes and motion in `motion`,
//! homing in `homing`, the actual values and their TPDO cache in `actuals`, the cyclic streams in
//! `cyclic`.

use std::prelude::rust_2024::*;
use std::sync::{Arc, Mutex};

use canola::{Duration, Node, Operation};

use crate::mode::ModeOfOperation;
use crate::objects::{self as obj, ErrorCode};
use crate::state::{PlanError, State};
use crate::words::{Controlword, Statusword};

mod actuals;
mod cyclic;
mod error;
mod homing;
mod motion;
mod states;
mod stop;

use actuals::Following;
pub use cyclic::CyclicStream;
pub(super) use error::pdo_kind;
pub use error::{Awaited, CyclicSetup, DriveError, Reached};
pub use homing::Homing;
pub use motion::Move;
pub use states::FaultReport;
pub use stop::OnCancel;
use stop::StopGuard;

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
    on_cancel: OnCancel,
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
    /// The stop a cancelled motion command started (see `stop`), running on its own.
    stopping: Mutex<Option<canola::Pending<()>>>,
}

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
        // The last clone is gone while a cancelled command's stop still runs: it is finished
        // on a thread of its own rather than cancelled with the drive.
        let stopping = self.stopping.get_mut().unwrap_or_else(|p| p.into_inner());
        if let Some(p) = stopping.take().filter(|p| !p.is_done()) {
            let _ = std::thread::Builder::new()
                .name("canola-cia402-stop".into())
                .spawn(move || p.wait());
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
                stopping: Mutex::new(None),
            }),
            node,
            axis: axis.min(obj::MAX_AXIS),
            timeouts: Timeouts::default(),
            transition_16: true,
            on_cancel: OnCancel::default(),
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

    /// The node's latest EMCY (since the network started).
    pub fn last_emcy(&self) -> Option<canola::nmt::Emcy> {
        self.node
            .network()
            .last_emcy(self.node.id())
            .map(|e| e.emcy)
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
}
