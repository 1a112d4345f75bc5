//! The simulator's plug-in point for device-specific behaviour: a [`DeviceHook`] sees SDO
//! writes before they are stored, may serve reads, sees the values RPDOs wrote, gets timers,
//! and asks for resets or emergencies through [`HookActions`].

use canola_frame::Instant;
use canola_nmt::{DeviceState, Emcy};
use canola_sdo::AbortCode;

use super::values::Values;

/// What a hook may do to the device besides answering.
#[derive(Debug, Default)]
pub struct HookActions {
    /// Emergencies to send.
    pub emcy: Vec<Emcy>,
    /// Reset the application (as NMT reset node).
    pub reset_node: bool,
    /// Reset communication.
    pub reset_communication: bool,
}

impl HookActions {
    /// Nothing asked for.
    pub(super) fn is_empty(&self) -> bool {
        self.emcy.is_empty() && !self.reset_node && !self.reset_communication
    }
}

/// Device-specific behaviour. Every method has a default that does nothing.
pub trait DeviceHook: Send {
    /// An SDO download of `value` to `entry` completed; return `Err(code)` to refuse it (the
    /// value is then not stored and the client gets the abort code).
    fn on_write(
        &mut self,
        now: Instant,
        values: &mut Values,
        index: u16,
        sub: u8,
        value: &[u8],
        actions: &mut HookActions,
    ) -> Result<(), AbortCode> {
        let _ = (now, values, index, sub, value, actions);
        Ok(())
    }

    /// An SDO upload of `entry` starts; return `Some` to serve the value (or an abort) instead of
    /// the stored one.
    fn on_read(
        &mut self,
        now: Instant,
        values: &Values,
        index: u16,
        sub: u8,
    ) -> Option<Result<Vec<u8>, AbortCode>> {
        let _ = (now, values, index, sub);
        None
    }

    /// The PDO engine took a received frame (an RPDO, or a SYNC that applies synchronous
    /// RPDOs): the values it wrote are in `values`. A hook with behaviour behind mapped objects
    /// (a drive model reacting to a controlword) takes them here.
    fn on_pdo_input(&mut self, now: Instant, values: &mut Values, actions: &mut HookActions) {
        let _ = (now, values, actions);
    }

    /// The hook's timer passed.
    fn on_timeout(&mut self, now: Instant, values: &mut Values, actions: &mut HookActions) {
        let _ = (now, values, actions);
    }

    /// When [`on_timeout`](Self::on_timeout) wants to be called.
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }

    /// The device's NMT state changed (or it was reset: `Initialising`).
    fn on_state(&mut self, now: Instant, state: DeviceState, values: &mut Values) {
        let _ = (now, state, values);
    }
}
