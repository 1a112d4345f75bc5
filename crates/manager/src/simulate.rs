//! Simulated slaves for a network description: each slave of a [`NetworkConfig`] as a
//! [`SimDevice`] on an in-memory bus, fresh from the factory — its dictionary's default values,
//! not the DCF's parameter values, so the boot has a configuration to write — with the identity
//! its file gives (a file whose 0x1018 differs from the expected identity fails its check as a
//! real device would). Slaves may be left off the bus to play absent devices.
//!
//! A dictionary with the CiA 302-3 program download objects — 0x1F50:01 program data, 0x1F51:01
//! program control, 0x1F52:01/02 application software date and time — gets a simulated boot
//! loader ([`BootLoader`]): the program control stops, clears and starts the program, the
//! program data takes an image while the program is stopped and cleared, and 0x1F52 reports the
//! version of the program that runs. The simulated images carry their version in their last
//! eight bytes (date, then time, each UNSIGNED32 little-endian): [`program_image`] makes one.

use canola::mem::StationId;
use canola::sdo::AbortCode;
use canola::{
    DeviceHook, HookActions, Instant, MemoryBus, NodeId, ObjectDictionary, SimDevice, Values,
};

use crate::config::NetworkConfig;

/// `od` as a device holds it before configuration: every `ParameterValue` removed.
pub fn factory_dictionary(od: &ObjectDictionary) -> ObjectDictionary {
    let mut od = od.clone();
    for object in od.objects.values_mut() {
        for sub in object.subs.values_mut() {
            if sub.parameter_value().is_some() {
                sub.extras_mut().parameter_value = None;
            }
        }
    }
    od
}

/// The devices of `config` except those in `absent`, as (node-ID, factory dictionary).
pub fn devices(config: &NetworkConfig, absent: &[NodeId]) -> Vec<(NodeId, ObjectDictionary)> {
    config
        .slaves
        .iter()
        .filter(|s| !absent.contains(&s.node_id))
        .map(|s| (s.node_id, factory_dictionary(&s.dictionary)))
        .collect()
}

/// The CiA 302-3 program control values (0x1F51).
const STOP: u8 = 0;
const START: u8 = 1;
const RESET: u8 = 2;
const CLEAR: u8 = 3;

/// A simulated boot loader behind 0x1F50/0x1F51/0x1F52 (CiA 302-3).
#[derive(Debug, Clone)]
pub struct BootLoader {
    /// The version (date, time) of the program in flash; `None` once cleared.
    flash: Option<(u32, u32)>,
    running: bool,
    /// Refuse program data with this abort code (a device whose flash fails).
    refuse: Option<AbortCode>,
}

impl BootLoader {
    /// A device running the program of version (`date`, `time`).
    pub fn new(date: u32, time: u32) -> Self {
        Self {
            flash: Some((date, time)),
            running: true,
            refuse: None,
        }
    }

    /// The boot loader for `od` when it has the program download objects: the version its
    /// 0x1F52 defaults give.
    pub fn for_dictionary(od: &ObjectDictionary, node: NodeId) -> Option<Self> {
        let has = |i, s| od.sub(i, s).is_some();
        if !(has(0x1F50, 1) && has(0x1F51, 1) && has(0x1F52, 1) && has(0x1F52, 2)) {
            return None;
        }
        let value = |sub| {
            od.sub(0x1F52, sub)
                .and_then(|s| s.effective_value(node.get()))
                .and_then(|v| v.as_i128())
                .map_or(0, |v| v as u32)
        };
        Some(Self::new(value(1), value(2)))
    }

    /// Makes every program data download fail with `code` (a flash that cannot be written).
    pub fn refusing(mut self, code: AbortCode) -> Self {
        self.refuse = Some(code);
        self
    }

    /// The version (date, time) a simulated image carries.
    pub fn image_version(image: &[u8]) -> Option<(u32, u32)> {
        let tail = image.len().checked_sub(8).map(|n| &image[n..])?;
        let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        Some((word(&tail[..4]), word(&tail[4..])))
    }

    fn version(&self) -> (u32, u32) {
        match (self.running, self.flash) {
            (true, Some(v)) => v,
            _ => (0, 0),
        }
    }
}

/// A simulated program image of version (`date`, `time`): `body`, then the version.
pub fn program_image(body: &[u8], date: u32, time: u32) -> Vec<u8> {
    let mut image = body.to_vec();
    image.extend_from_slice(&date.to_le_bytes());
    image.extend_from_slice(&time.to_le_bytes());
    image
}

impl DeviceHook for BootLoader {
    fn on_write(
        &mut self,
        _now: Instant,
        _values: &mut Values,
        index: u16,
        sub: u8,
        value: &[u8],
        _actions: &mut HookActions,
    ) -> Result<(), AbortCode> {
        match (index, sub) {
            (0x1F51, 1) => match value.first().copied() {
                Some(STOP) => self.running = false,
                Some(START) if self.flash.is_some() => self.running = true,
                Some(RESET) if self.flash.is_some() => self.running = true,
                Some(START | RESET) => return Err(AbortCode::CANNOT_STORE_DEVICE_STATE),
                Some(CLEAR) if !self.running => self.flash = None,
                Some(CLEAR) => return Err(AbortCode::CANNOT_STORE_DEVICE_STATE),
                _ => return Err(AbortCode::INVALID_VALUE),
            },
            (0x1F50, 1) => {
                if self.running || self.flash.is_some() {
                    // Program data only into a stopped, cleared flash.
                    return Err(AbortCode::CANNOT_STORE_DEVICE_STATE);
                }
                if let Some(code) = self.refuse {
                    return Err(code);
                }
                self.flash = Some(Self::image_version(value).ok_or(AbortCode::CANNOT_STORE)?);
            }
            _ => {}
        }
        Ok(())
    }

    fn on_read(
        &mut self,
        _now: Instant,
        _values: &Values,
        index: u16,
        sub: u8,
    ) -> Option<Result<Vec<u8>, AbortCode>> {
        match (index, sub) {
            (0x1F51, 1) => Some(Ok(vec![u8::from(self.running)])),
            (0x1F52, 1) => Some(Ok(self.version().0.to_le_bytes().to_vec())),
            (0x1F52, 2) => Some(Ok(self.version().1.to_le_bytes().to_vec())),
            _ => None,
        }
    }
}

/// A simulated device for `node` holding `od`, with a [`BootLoader`] when `od` has the program
/// download objects.
pub fn device(node: NodeId, od: ObjectDictionary) -> SimDevice {
    let boot_loader = BootLoader::for_dictionary(&od, node);
    let device = SimDevice::new(node, od);
    match boot_loader {
        Some(b) => device.with_hook(b),
        None => device,
    }
}

/// Attaches every slave of `config` except those in `absent` to `bus` as a simulated device.
/// Returns the node-IDs with their stations (for changing a device behind the master's back).
pub fn attach_slaves(
    bus: &MemoryBus,
    config: &NetworkConfig,
    absent: &[NodeId],
) -> Vec<(NodeId, StationId<SimDevice>)> {
    devices(config, absent)
        .into_iter()
        .map(|(node, od)| (node, bus.attach(device(node, od))))
        .collect()
}
