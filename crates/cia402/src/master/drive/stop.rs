//! Stopping the motion a command started when the command ends unfinished: a motion operation
//! ([`Drive::move_to`], [`Drive::home`], [`Drive::wait_target_reached`]) dropped or cancelled
//! before it finished, and a [`CyclicStream`](super::CyclicStream) dropped without
//! [`stop`](super::CyclicStream::stop), leave the drive stopping ([`OnCancel`]), not moving.
//!
//! A drop cannot wait, so the stop is a controlword download started at once and left to run
//! (it goes out as soon as the network is driven: at once with a background driver, else with
//! the next wait on the network); a cyclic stream's RPDO that maps the controlword carries it too.
//! A panic that unwinds through a motion operation drops it, so the same stop goes out while the
//! network is still driven; a process that aborts (`panic = "abort"`) or exits before that, or a
//! network that is gone, sends nothing: the drive then relies on its own monitoring (heartbeat
//! or node guarding consumer, 0x6007 abort connection option code).

use crate::state::Command;
use crate::words::Controlword;

use super::{Drive, lock};
use crate::objects as obj;

/// How the drive is stopped when a motion command is dropped or cancelled unfinished (see
/// [`Drive::on_cancel`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum OnCancel {
    /// Quick stop (controlword 0x0002): the drive brakes on its quick stop ramp (0x6085) and
    /// ends as its quick stop option code 0x605A says: in quick stop active (5..8) or in
    /// switch on disabled (0..4; 0 lets the motor coast). The default.
    #[default]
    QuickStop,
    /// Halt (controlword bit 8): the drive brakes as its halt option code 0x605D says and stays
    /// in operation enabled; clear it with [`Drive::halt`]`(false)`.
    Halt,
    /// Nothing is sent: the drive goes on with what it was commanded.
    Nothing,
}

impl OnCancel {
    /// The controlword that stops the drive, after `last` (the last controlword sent).
    pub(super) fn controlword(self, last: Option<Controlword>) -> Option<Controlword> {
        match self {
            Self::QuickStop => Some(Command::QuickStop.controlword()),
            Self::Halt => Some(
                last.filter(|c| c.raw() & 0x008F == 0x000F)
                    .unwrap_or(Controlword::from_raw(0x000F))
                    .with(0x0100, true),
            ),
            Self::Nothing => None,
        }
    }
}

/// Held by a motion command while it runs: dropped armed (the command did not finish), it
/// stops the drive as [`Drive::on_cancel`] says.
pub(super) struct StopGuard {
    drive: Option<Drive>,
}

impl StopGuard {
    pub(super) fn new(drive: &Drive) -> Self {
        Self {
            drive: Some(drive.clone()),
        }
    }

    /// The command finished (or failed on its own): nothing to stop.
    pub(super) fn disarm(mut self) {
        self.drive = None;
    }
}

impl Drop for StopGuard {
    fn drop(&mut self) {
        if let Some(d) = self.drive.take() {
            d.stop_unwaited(d.on_cancel);
        }
    }
}

impl Drive {
    /// Starts a controlword download that stops the drive as `how` says, without waiting for
    /// it (it runs while the network is driven and until every clone of this drive is gone),
    /// and puts the controlword into a cyclic stream's RPDO that maps it.
    pub(super) fn stop_unwaited(&self, how: OnCancel) {
        let Some(cw) = how.controlword(self.last_controlword()) else {
            return;
        };
        if let Some((sender, at)) = lock(&self.shared.stream_controlword).as_ref() {
            let _ = sender.set(*at, cw.raw());
        }
        *lock(&self.shared.last_cw) = None;
        let pending = self
            .node
            .sdo()
            .submit_write(self.at(obj::CONTROLWORD), cw.raw());
        // Kept (not dropped, which would cancel it) until the next stop or the last clone.
        *lock(&self.shared.stopping) = Some(pending);
    }

    /// How a motion command dropped or cancelled unfinished stops the drive
    /// ([`OnCancel::QuickStop`] unless set otherwise).
    pub fn on_cancel(&self) -> OnCancel {
        self.on_cancel
    }

    /// With another way of stopping a motion command dropped or cancelled unfinished.
    pub fn with_on_cancel(mut self, how: OnCancel) -> Self {
        self.on_cancel = how;
        self
    }
}
