//! A simulated Bürkert device: the generic CANopen device simulator ([`canola::SimDevice`],
//! built from `eds/burkert-generic.eds`) plus the behaviour the Bürkert manual describes
//! (SPEC-NOTES §1), as a [`Station`] for the in-memory bus or `run_station` on SocketCAN.
//!
//! What it adds to the generic simulator:
//! - boots Pre-Operational after its boot-up message, heartbeat 500 ms (0x1017 default);
//! - 0x2101 locating: a write of 1 makes the LED flash for [`LOCATE_DURATION`] (about 10 s);
//!   the object keeps reading 1 afterwards, and a new start needs it set back to 0 first (a
//!   1 written over a 1 is accepted but starts nothing);
//! - 0x210A maintenance: 1 adds "maintenance required" to the active NE 107 events; the status
//!   in 0x2004 sub 1 is the highest-priority active event ([`Ne107Status::highest`]), so a
//!   higher-priority fault keeps its colour;
//! - NE 107 events raised and cleared by the test or the operator ([`BurkertDevice::raise`]);
//! - 0x2001 sub 0x0A follows the NMT state (4 stopped, 5 operational, 127 pre-operational);
//! - 0x2001 sub 4 = 1 resets communication, 2 resets the device; the node-ID stored in 0x2001
//!   sub 2 takes effect there (and at NMT reset node / reset communication; a node-ID set by
//!   LSS, CiA 305, shows in sub 2 once active): the communication
//!   objects 0x1000..=0x1FFF return to their defaults for the new node-ID, the profile objects
//!   0x2000.. keep their stored values (a device reset also ends locating and maintenance and
//!   counts a boot in 0x2004 sub 0x0D);
//! - writes to 0x2001, 0x2120..=0x2122, 0x2101, 0x210A are checked with this crate's typed
//!   decoders (an undefined value is refused with abort 0x06090030);
//! - sensor values 0x2500.. (of the EDS's type: REAL32 in the generic EDS, integers rounded)
//!   change over virtual time and go out in TPDOs while
//!   Operational; RPDOs write control values 0x2540.. (the PDO machinery is the generic
//!   simulator's); a mapping is checked when its sub 0 is written (abort 0x06040041 /
//!   0x06040042);
//! - 0x2003 sub 4 serves a logbook XML document of a few KiB as a DOMAIN, with an entry for
//!   each event of the simulation;
//! - the status LED computed with [`LedState::indication`] ([`BurkertDevice::led`]).
//!
//! The device and its station are here; the SDO hook (the object checks) is in `hook`, the
//! logbook in `logbook`; both share the device's state through `Shared`.

use std::prelude::rust_2024::*;
use std::{format, vec};

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};

use canola::transport::Station;
use canola::{SimDevice, Values};
use canola_frame::{CanFrame, CanId, Duration, Instant, NodeId};
use canola_nmt::DeviceState;
use canola_od::{DataType, ObjectDictionary};

use crate::colour::{LedColour, PredefinedColour};
use crate::comm::{CanOperationStatus, ResetCommand};
use crate::led::{LedIndication, LedMode, LedState, ValveModeColours, ValvePosition};
use crate::ne107::Ne107Status;

mod hook;
mod logbook;

use hook::BurkertHook;
use logbook::{LogEntry, history};

/// How long the LED flashes after a locate.
pub const LOCATE_DURATION: Duration = Duration::from_secs(10);
/// How often the simulated sensors take a new reading.
pub const SENSOR_PERIOD: Duration = Duration::from_millis(100);
/// Entries of the logbook the device has from before the simulation started.
const HISTORIC_LOG_ENTRIES: usize = 36;

/// The device's CAN operation status code for an NMT state.
fn operation_status(state: DeviceState) -> CanOperationStatus {
    match state {
        DeviceState::Operational => CanOperationStatus::Operational,
        DeviceState::Stopped => CanOperationStatus::Stopped,
        DeviceState::PreOperational | DeviceState::Initialising => {
            CanOperationStatus::PreOperational
        }
    }
}

/// State shared by the device and its SDO hook.
#[derive(Debug)]
struct Shared {
    od: Arc<ObjectDictionary>,
    node: NodeId,
    now: Instant,
    booted_at: Instant,
    boots: u32,
    events: Vec<Ne107Status>,
    maintenance: bool,
    locate_latched: bool,
    locate_until: Option<Instant>,
    pending_reset: Option<ResetCommand>,
    state: DeviceState,
    valve: Option<ValvePosition>,
    log: Vec<LogEntry>,
}

impl Shared {
    fn ne107(&self) -> Ne107Status {
        let maintenance = self.maintenance.then_some(Ne107Status::MaintenanceRequired);
        Ne107Status::highest(self.events.iter().copied().chain(maintenance))
    }

    fn log(&mut self, source: &'static str, text: impl Into<String>) {
        let status = self.ne107();
        self.log.push(LogEntry {
            time_s: self.now.as_micros() as f64 / 1e6,
            status,
            source,
            text: text.into(),
        });
    }
}

fn lock(m: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A simulated Bürkert device. See the module docs.
pub struct BurkertDevice {
    sim: SimDevice,
    od: Arc<ObjectDictionary>,
    shared: Arc<Mutex<Shared>>,
    next_sensor: Instant,
    pinned: BTreeMap<u8, f32>,
    out: VecDeque<CanFrame>,
}

impl core::fmt::Debug for BurkertDevice {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("BurkertDevice")
            .field("node", &self.sim.node())
            .field("state", &self.sim.state())
            .finish_non_exhaustive()
    }
}

impl BurkertDevice {
    /// A device built from `eds/burkert-generic.eds` with node-ID `node`.
    pub fn new(node: NodeId) -> Self {
        Self::with_dictionary(node, crate::master::generic_od().as_ref().clone())
    }

    /// A device from an EDS text (a real Bürkert device's EDS, say).
    pub fn from_eds(node: NodeId, eds: &[u8]) -> Result<Self, canola_od::ParseError> {
        Ok(Self::with_dictionary(node, canola_od::parse(eds)?.od))
    }

    /// A device from a dictionary.
    pub fn with_dictionary(node: NodeId, od: ObjectDictionary) -> Self {
        let od = Arc::new(od);
        let mut log = history();
        log.push(LogEntry {
            time_s: 0.0,
            status: Ne107Status::DiagnosisInactive,
            source: "device",
            text: "device started".into(),
        });
        let shared = Arc::new(Mutex::new(Shared {
            od: od.clone(),
            node,
            now: Instant::ZERO,
            booted_at: Instant::ZERO,
            boots: 1,
            events: Vec::new(),
            maintenance: false,
            locate_latched: false,
            locate_until: None,
            pending_reset: None,
            state: DeviceState::Initialising,
            valve: None,
            log,
        }));
        let mut sim = SimDevice::new(node, (*od).clone()).with_hook(BurkertHook {
            shared: shared.clone(),
        });
        sim.values_mut()
            .set(0x2004, 0x0D, 1u32.to_le_bytes().to_vec());
        Self {
            sim,
            od,
            shared,
            next_sensor: Instant::ZERO,
            pinned: BTreeMap::new(),
            out: VecDeque::new(),
        }
    }

    fn shared(&self) -> MutexGuard<'_, Shared> {
        lock(&self.shared)
    }

    /// The node-ID the device currently answers on.
    pub fn node(&self) -> NodeId {
        self.sim.node()
    }

    /// The NMT state.
    pub fn state(&self) -> DeviceState {
        self.sim.state()
    }

    /// The object values.
    pub fn values(&self) -> &Values {
        self.sim.values()
    }

    /// The object values, to change them directly (no PDO is triggered).
    pub fn values_mut(&mut self) -> &mut Values {
        self.sim.values_mut()
    }

    /// The generic simulator underneath (PDOs, SDO server, NMT slave, heartbeat).
    pub fn sim(&self) -> &SimDevice {
        &self.sim
    }

    /// Raises a NAMUR NE 107 event (a fault, a function check, ...). The status (0x2004 sub 1)
    /// becomes the highest-priority active event.
    pub fn raise(&mut self, event: Ne107Status) {
        let mut s = self.shared();
        if !s.events.contains(&event) {
            s.events.push(event);
            s.log("device", format!("event raised: {}", event.meaning_en()));
        }
        drop(s);
        self.sync_values();
    }

    /// Clears a NAMUR NE 107 event.
    pub fn clear(&mut self, event: Ne107Status) {
        let mut s = self.shared();
        if let Some(i) = s.events.iter().position(|e| *e == event) {
            s.events.remove(i);
            s.log("device", format!("event cleared: {}", event.meaning_en()));
        }
        drop(s);
        self.sync_values();
    }

    /// The events raised and not cleared (maintenance not included).
    pub fn active_events(&self) -> Vec<Ne107Status> {
        self.shared().events.clone()
    }

    /// The NE 107 status the device reports: the highest-priority active event.
    pub fn ne107(&self) -> Ne107Status {
        self.shared().ne107()
    }

    /// Whether the device is in the maintenance state (0x210A sub 1 = 1).
    pub fn maintenance(&self) -> bool {
        self.shared().maintenance
    }

    /// Whether the LED is flashing for a locate right now.
    pub fn locating(&self) -> bool {
        self.shared().locate_until.is_some()
    }

    /// Sets the valve position (for the valve LED modes); `None` for a device without one.
    pub fn set_valve_position(&mut self, position: Option<ValvePosition>) {
        self.shared().valve = position;
    }

    /// What the status LED shows now: [`LedState::indication`] of the configured mode and
    /// colours (0x2120..=0x2122), the NE 107 status, the valve position and the locating state.
    pub fn led(&self) -> LedIndication {
        let v = self.sim.values();
        let colour = |index: u16, sub: u8, default: LedColour| {
            v.get_u64(index, sub)
                .and_then(|raw| LedColour::from_u32(raw as u32).ok())
                .unwrap_or(default)
        };
        let d = ValveModeColours::default();
        let s = self.shared();
        LedState {
            mode: v
                .get_u64(0x2120, 0)
                .and_then(|raw| LedMode::from_u32(raw as u32).ok())
                .unwrap_or_default(),
            status: s.ne107(),
            valve: s.valve,
            valve_colours: ValveModeColours {
                closed: colour(0x2121, 1, d.closed),
                between: colour(0x2121, 2, d.between),
                open: colour(0x2121, 3, d.open),
            },
            external: colour(0x2122, 0, PredefinedColour::White.into()),
            locating: s.locate_until.is_some(),
        }
        .indication()
    }

    /// The logbook document 0x2003 sub 4 serves right now.
    pub fn logbook_xml(&self) -> Vec<u8> {
        self.shared().logbook_xml(self.sim.values())
    }

    /// Holds sensor `sensor` (0x2500 + sensor) at `value` instead of letting it drift. The
    /// value is stored at once (a TPDO mapping it sends it at the next sensor reading, every
    /// [`SENSOR_PERIOD`]).
    pub fn pin_sensor(&mut self, sensor: u8, value: f32) {
        self.pinned.insert(sensor, value);
        let now = self.shared().now;
        self.update_sensors(now);
    }

    /// Lets a pinned sensor drift again.
    pub fn unpin_sensor(&mut self, sensor: u8) {
        self.pinned.remove(&sensor);
    }

    /// Control value `control` (0x2540 + control, sub 1), typed by the dictionary.
    pub fn control_value_typed(&self, control: u8) -> Option<canola_od::Value> {
        let index = 0x2540 + u16::from(control);
        let dt = self.od.sub(index, 1)?.data_type;
        canola_od::Value::from_le_bytes(dt, self.sim.values().get(index, 1)?).ok()
    }

    /// Control value `control` (0x2540 + control, sub 1) as REAL32, if it is one.
    pub fn control_value(&self, control: u8) -> Option<f32> {
        let index = 0x2540 + u16::from(control);
        if self.od.sub(index, 1)?.data_type != DataType::Real32 {
            return None;
        }
        let b: [u8; 4] = self.sim.values().get(index, 1)?.try_into().ok()?;
        Some(f32::from_le_bytes(b))
    }

    /// A simulated sensor reading: a slow sine around a per-sensor level.
    fn sensor_reading(sensor: u8, now: Instant) -> f32 {
        let t = now.as_micros() as f64 / 1e6;
        let phase = std::f64::consts::TAU * t / 20.0 + f64::from(sensor);
        (20.0 + 10.0 * f64::from(sensor) + 5.0 * phase.sin()) as f32
    }

    fn update_sensors(&mut self, now: Instant) {
        for sensor in 0..crate::master::VALUES_PER_KIND {
            let index = crate::master::SENSOR_VALUE_BASE + u16::from(sensor);
            let Some(sub) = self.od.sub(index, 1) else {
                continue;
            };
            let v = self
                .pinned
                .get(&sensor)
                .copied()
                .unwrap_or_else(|| Self::sensor_reading(sensor, now));
            // The value type is the device's (its EDS): REAL32/64 as is, integers rounded;
            // other types are left alone.
            let value = match sub.data_type {
                DataType::Real32 => Some(canola_od::Value::Real32(v)),
                DataType::Real64 => Some(canola_od::Value::Real64(f64::from(v))),
                dt if dt.integer_bits().is_some() => {
                    canola_od::Value::from_i128_wrapping(dt, v.round() as i128)
                }
                _ => None,
            };
            let Some(value) = value else { continue };
            let bytes = value.to_le_bytes();
            if self.sim.values().get(index, 1) != Some(&bytes[..]) {
                // Through the simulator, so TPDOs mapping the sensor send the change.
                self.sim.set_value(now, index, 1, bytes);
            }
        }
    }

    /// Values that follow the device's state; the NE 107 status goes through the simulator so
    /// a TPDO mapping it sends the change.
    fn sync_values(&mut self) {
        let s = lock(&self.shared);
        let status = s.ne107().to_raw();
        let op = operation_status(s.state).to_u8();
        let now = s.now;
        drop(s);
        if self.sim.values().get(0x2004, 1) != Some(&[status][..]) {
            self.sim.set_value(now, 0x2004, 1, vec![status]);
        }
        self.sim.values_mut().set(0x2001, 0x0A, vec![op]);
    }

    /// After any input: apply a reset the hook asked for, follow the device's state.
    fn after_input(&mut self, now: Instant) {
        let reset = {
            let mut s = self.shared();
            s.now = now;
            s.pending_reset.take()
        };
        if let Some(r) = reset {
            self.reset(now, r == ResetCommand::Device);
            return;
        }
        // LSS may have given the simulator another node-ID: 0x2001 sub 2 shows it.
        let node = self.sim.node();
        if self.shared().node != node {
            self.shared().node = node;
            self.sim.values_mut().set(0x2001, 2, vec![node.get()]);
        }
        self.sync_values();
    }

    /// Communication reset (`device == false`) or device reset: restart under the node-ID of
    /// 0x2001 sub 2. Frames already produced (the SDO confirmation of the reset write) go out
    /// first.
    fn reset(&mut self, now: Instant, device: bool) {
        while let Some(f) = self.sim.poll_transmit() {
            self.out.push_back(f);
        }
        let old = self.sim.values().clone();
        let node = old
            .get_u64(0x2001, 2)
            .and_then(|v| u8::try_from(v).ok())
            .and_then(|v| NodeId::new(v).ok())
            .unwrap_or_else(|| self.sim.node());
        let sim = SimDevice::new(node, (*self.od).clone()).with_hook(BurkertHook {
            shared: self.shared.clone(),
        });
        self.sim = sim;
        self.shared().state = DeviceState::Initialising;
        let what = if device {
            "device reset"
        } else {
            "communication reset"
        };
        self.after_reset(now, &old, device, what);
    }

    /// What every reset leaves behind, however it came (0x2001 sub 4 or NMT): the profile
    /// objects (0x2000 and up) are stored settings and keep their values, the communication
    /// objects have their defaults for the (new) node-ID, 0x2001 sub 4 reads 0 again; a device
    /// reset also counts a boot and ends locating and maintenance.
    fn after_reset(&mut self, now: Instant, old: &Values, device: bool, what: &str) {
        let node = self.sim.node();
        let v = self.sim.values_mut();
        for (index, sub) in self.od.entries() {
            if index >= 0x2000
                && let Some(x) = old.get(index, sub.sub_index)
            {
                v.set(index, sub.sub_index, x.to_vec());
            }
        }
        v.set(0x2001, 2, vec![node.get()]);
        v.set(0x2001, 4, vec![0]);
        let mut s = self.shared();
        s.node = node;
        s.log("device", format!("{what}, node-ID {}", node.get()));
        if device {
            s.boots += 1;
            s.booted_at = now;
            s.maintenance = false;
            s.locate_latched = false;
            s.locate_until = None;
            let boots = s.boots;
            drop(s);
            let v = self.sim.values_mut();
            v.set(0x2101, 1, vec![0]);
            v.set(0x210A, 1, vec![0]);
            v.set(0x2004, 0x0D, boots.to_le_bytes().to_vec());
        } else {
            drop(s);
        }
        self.sync_values();
    }

    /// An NMT reset addressed to this device. A node-ID stored in 0x2001 sub 2 takes effect
    /// (the device restarts under it); otherwise the simulator resets (and activates a node-ID
    /// configured by LSS, CiA 305), and the profile settings and 0x2001 sub 2 follow.
    fn nmt_reset_received(&mut self, now: Instant, frame: &CanFrame, device: bool) {
        let stored = self
            .sim
            .values()
            .get_u64(0x2001, 2)
            .and_then(|v| u8::try_from(v).ok())
            .and_then(|v| NodeId::new(v).ok());
        if stored.is_some_and(|n| n != self.sim.node()) {
            self.reset(now, device);
            return;
        }
        let old = self.sim.values().clone();
        self.sim.handle_frame(now, frame);
        let what = if device {
            "NMT reset node"
        } else {
            "NMT reset communication"
        };
        self.after_reset(now, &old, device, what);
    }

    /// NMT reset node (`Some(true)`) / reset communication (`Some(false)`) addressed to this
    /// device, if `frame` is one.
    fn nmt_reset(&self, frame: &CanFrame) -> Option<bool> {
        match frame.id() {
            CanId::Standard(id) if id.as_raw() == 0 && !frame.is_remote() => {}
            _ => return None,
        }
        let [cmd, target] = frame.data() else {
            return None;
        };
        if *target != 0 && *target != self.sim.node().get() {
            return None;
        }
        match cmd {
            0x81 => Some(true),
            0x82 => Some(false),
            _ => None,
        }
    }
}

impl Station for BurkertDevice {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        if self.sim.state() != DeviceState::Initialising
            && let Some(device) = self.nmt_reset(frame)
        {
            self.shared().now = now;
            self.nmt_reset_received(now, frame, device);
            return;
        }
        self.sim.handle_frame(now, frame);
        self.after_input(now);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.sim.handle_timeout(now);
        self.shared().now = now;
        if now >= self.next_sensor {
            self.update_sensors(now);
            self.next_sensor = now + SENSOR_PERIOD;
        }
        self.after_input(now);
    }

    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front().or_else(|| self.sim.poll_transmit())
    }

    fn handle_fd_frame(&mut self, now: Instant, frame: &canola::frame::FdFrame) {
        self.sim.handle_fd_frame(now, frame);
        self.after_input(now);
    }

    fn poll_transmit_fd(&mut self) -> Option<canola::frame::FdFrame> {
        self.sim.poll_transmit_fd()
    }

    fn poll_timeout(&self) -> Option<Instant> {
        [self.sim.poll_timeout(), Some(self.next_sensor)]
            .into_iter()
            .flatten()
            .min()
    }
}

/// A simulated device for any dictionary: a [`BurkertDevice`] when the dictionary carries the
/// Bürkert profile (device description, communication, status and locating objects), the
/// generic [`SimDevice`] otherwise. What `canopen simulate` and the CLI's in-memory bus run.
pub enum SimulatedDevice {
    /// Any EDS.
    Generic(Box<SimDevice>),
    /// An EDS with the Bürkert profile objects.
    Burkert(Box<BurkertDevice>),
}

impl core::fmt::Debug for SimulatedDevice {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Generic(d) => f.debug_tuple("Generic").field(d).finish(),
            Self::Burkert(_) => f.write_str("Burkert"),
        }
    }
}

impl SimulatedDevice {
    /// Whether `od` has the Bürkert profile's objects 0x2000:01, 0x2001:04, 0x2004:01 and
    /// 0x2101:01.
    pub fn has_burkert_profile(od: &ObjectDictionary) -> bool {
        [(0x2000, 1), (0x2001, 4), (0x2004, 1), (0x2101, 1)]
            .iter()
            .all(|&(i, s)| od.sub(i, s).is_some())
    }

    /// The device for `od` as node `node`.
    pub fn for_dictionary(node: NodeId, od: ObjectDictionary) -> Self {
        if Self::has_burkert_profile(&od) {
            Self::Burkert(Box::new(BurkertDevice::with_dictionary(node, od)))
        } else {
            Self::Generic(Box::new(SimDevice::new(node, od)))
        }
    }

    fn station(&mut self) -> &mut dyn Station {
        match self {
            Self::Generic(d) => d.as_mut(),
            Self::Burkert(d) => d.as_mut(),
        }
    }

    /// Makes the device serve USDO on CAN FD (CANopen FD, CiA 1301), or not (see
    /// [`SimDevice::set_fd`]).
    pub fn set_fd(&mut self, fd: bool) {
        match self {
            Self::Generic(d) => d.set_fd(fd),
            Self::Burkert(d) => d.sim.set_fd(fd),
        }
    }
}

impl Station for SimulatedDevice {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.station().handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.station().handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.station().poll_transmit()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        match self {
            Self::Generic(d) => d.poll_timeout(),
            Self::Burkert(d) => d.poll_timeout(),
        }
    }
    fn handle_bus_event(&mut self, now: Instant, event: &canola::BusEvent) {
        self.station().handle_bus_event(now, event);
    }
    fn handle_fd_frame(&mut self, now: Instant, frame: &canola::frame::FdFrame) {
        self.station().handle_fd_frame(now, frame);
    }
    fn poll_transmit_fd(&mut self) -> Option<canola::frame::FdFrame> {
        self.station().poll_transmit_fd()
    }
}
