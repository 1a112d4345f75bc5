//! The simulated drive on the bus: [`DriveHook`] puts a [`SimDrive`] behind the profile area of a
//! facade [`SimDevice`](canola::SimDevice), so a master's SDO and PDO traffic reach the drive
//! model.
//!
//! How the two meet (the device simulator's [`DeviceHook`] plug-in point, nothing else of the
//! simulator changes):
//! - SDO downloads to the drive's axis (0x6000 + axis × 0x800 .. + 0x7FF) go to
//!   [`SimDrive::write`] first; the drive's refusal is the SDO abort (0x06090030 for an
//!   unsupported mode, 0x08000022 for a mode change the drive's state forbids, ...).
//! - SDO uploads of the drive's objects are read from [`SimDrive::read`], fresh at the moment of
//!   the request (a statusword read after a controlword write shows the new state).
//! - After each RPDO (or SYNC applying synchronous RPDOs) the drive takes the values the RPDO
//!   wrote into the device (an object whose value differs from what the hook last published),
//!   so every controlword edge of a master's RPDOs counts, and publishes its objects back.
//! - Every [`DriveHook::TICK`] of bus time the drive steps and publishes its objects into the
//!   device's values, where TPDOs (SYNC or event-driven) read them.
//! - The drive's EMCYs (fault, reset) go out as the device's EMCYs.
//!
//! Objects outside the drive's table (the communication area, manufacturer objects) stay with
//! the simulator's own dictionary from the EDS.

use std::collections::HashMap;
use std::prelude::rust_2024::*;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration as StdDuration;

use canola::nmt::{Emcy, EmcyCode, ErrorRegister};
use canola::{AbortCode, DeviceHook, DeviceState, HookActions, Instant, NodeId, SimDevice, Values};

use crate::objects::{self as obj, ObjectInfo};
use crate::sim::SimDrive;

/// A [`SimDrive`] as the behaviour of a simulated device's profile objects. See the module
/// documentation.
#[derive(Debug)]
pub struct DriveHook {
    drive: Arc<Mutex<SimDrive>>,
    /// What the hook last published into the device's values (or the drive last accepted), by
    /// object: a value there that differs came from an RPDO.
    published: HashMap<(u16, u8), Vec<u8>>,
    last_step: Option<Instant>,
    next: Instant,
}

impl DriveHook {
    /// The period the drive model steps with, in bus time.
    pub const TICK: StdDuration = StdDuration::from_millis(1);

    /// The hook around `drive` (its [`SimConfig::axis`](crate::sim::SimConfig::axis) gives the
    /// objects it answers for).
    pub fn new(drive: SimDrive) -> Self {
        Self {
            drive: Arc::new(Mutex::new(drive)),
            published: HashMap::new(),
            last_step: None,
            next: Instant::ZERO,
        }
    }

    /// The drive model, shared: a test or a demo keeps a clone to inject faults, set the
    /// safe-torque-off input or move the shaft while the device runs on the bus.
    pub fn drive(&self) -> Arc<Mutex<SimDrive>> {
        Arc::clone(&self.drive)
    }

    fn d(&self) -> MutexGuard<'_, SimDrive> {
        self.drive.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn axis_index(&self, base: u16) -> u16 {
        base + u16::from(self.d().config().axis) * obj::AXIS_OFFSET
    }

    /// Whether `index` is one of this drive's objects.
    fn owns(&self, index: u16, sub: u8) -> bool {
        obj::axis_of(index).is_some_and(|(axis, base)| {
            axis == self.d().config().axis && Self::info(base, sub).is_some()
        })
    }

    fn info(base: u16, sub: u8) -> Option<&'static ObjectInfo> {
        obj::ALL
            .iter()
            .find(|o| o.index == base && o.sub_index == sub)
    }

    fn read_bytes(&self, index: u16, sub: u8) -> Option<Vec<u8>> {
        let mut buf = [0u8; 8];
        let n = self.d().read(index, sub, &mut buf).ok()?;
        Some(buf[..n].to_vec())
    }

    /// Takes what RPDOs wrote since the last tick into the drive.
    fn take_rpdo_writes(&mut self, values: &Values) {
        // The controlword last: a set-point edge in the same PDO as its target takes that
        // target (objects are otherwise in index order, 0x6040 before 0x607A).
        let controlword = |o: &&ObjectInfo| o.index == obj::CONTROLWORD.index();
        let others = obj::ALL.iter().filter(|o| !controlword(o));
        for o in others.chain(obj::ALL.iter().filter(controlword)) {
            let index = self.axis_index(o.index);
            let Some(now) = values.get(index, o.sub_index) else {
                continue;
            };
            let changed = self
                .published
                .get(&(index, o.sub_index))
                .is_none_or(|p| p.as_slice() != now);
            if changed {
                // A refused value (read-only, out of range) is left to be overwritten below.
                let _ = self.d().write(index, o.sub_index, now);
            }
        }
    }

    /// Publishes the drive's objects into the device's values.
    fn publish(&mut self, values: &mut Values) {
        for o in obj::ALL {
            let index = self.axis_index(o.index);
            if let Some(bytes) = self.read_bytes(index, o.sub_index) {
                if values.get(index, o.sub_index) != Some(bytes.as_slice()) {
                    values.set(index, o.sub_index, bytes.clone());
                }
                self.published.insert((index, o.sub_index), bytes);
            }
        }
    }

    fn send_emcys(&mut self, actions: &mut HookActions) {
        while let Some(e) = self.d().poll_emcy() {
            actions.emcy.push(Emcy::new(
                EmcyCode(e.code.0),
                ErrorRegister(e.error_register),
            ));
        }
    }
}

impl DeviceHook for DriveHook {
    fn on_write(
        &mut self,
        _now: Instant,
        _values: &mut Values,
        index: u16,
        sub: u8,
        value: &[u8],
        actions: &mut HookActions,
    ) -> Result<(), AbortCode> {
        if !self.owns(index, sub) {
            return Ok(());
        }
        self.d()
            .write(index, sub, value)
            .map_err(|e| AbortCode(e.abort_code()))?;
        // The device stores `value`: the next tick must not take it for an RPDO write.
        self.published.insert((index, sub), value.to_vec());
        self.send_emcys(actions);
        Ok(())
    }

    fn on_read(
        &mut self,
        _now: Instant,
        _values: &Values,
        index: u16,
        sub: u8,
    ) -> Option<Result<Vec<u8>, AbortCode>> {
        if !self.owns(index, sub) {
            return None;
        }
        let mut buf = [0u8; 8];
        Some(
            self.d()
                .read(index, sub, &mut buf)
                .map(|n| buf[..n].to_vec())
                .map_err(|e| AbortCode(e.abort_code())),
        )
    }

    fn on_pdo_input(&mut self, _now: Instant, values: &mut Values, actions: &mut HookActions) {
        self.take_rpdo_writes(values);
        self.publish(values);
        self.send_emcys(actions);
    }

    fn on_timeout(&mut self, now: Instant, values: &mut Values, actions: &mut HookActions) {
        self.take_rpdo_writes(values);
        let dt = self
            .last_step
            .map_or(StdDuration::ZERO, |last| (now - last).into());
        self.d().step(dt);
        self.last_step = Some(now);
        self.publish(values);
        self.send_emcys(actions);
        self.next = now + Self::TICK.into();
    }

    fn poll_timeout(&self) -> Option<Instant> {
        Some(self.next)
    }

    fn on_state(&mut self, _now: Instant, state: DeviceState, values: &mut Values) {
        // A reset reloads the EDS defaults: the drive's values replace them again.
        if state != DeviceState::Initialising {
            self.publish(values);
        }
    }
}

/// A simulated device with `drive` behind its profile objects: the dictionary from `eds` (e.g.
/// the crate's `eds/cia402-servo.eds`), node `node`; with the shared drive model (see
/// [`DriveHook::drive`]).
pub fn simulated_drive(
    node: NodeId,
    eds: &[u8],
    drive: SimDrive,
) -> Result<(SimDevice, Arc<Mutex<SimDrive>>), canola::od::ParseError> {
    let hook = DriveHook::new(drive);
    let shared = hook.drive();
    Ok((SimDevice::from_eds(node, eds)?.with_hook(hook), shared))
}
