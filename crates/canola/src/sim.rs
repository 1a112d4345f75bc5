//! The device simulator: a CANopen slave built from any object dictionary (EDS/DCF or generated).
//!
//! A [`SimDevice`] composes the device-side machines of the protocol crates:
//! * NMT slave with boot-up and heartbeat producer (`canola-nmt`, CiA 301 §7.2.8, §7.3.2);
//! * SDO server for expedited, segmented and block transfers (`canola-sdo`, CiA 301 §7.2.4)
//!   over the dictionary's values;
//! * EMCY producer (`canola-nmt`, CiA 301 §7.2.7);
//! * TPDOs and RPDOs by the `canola-pdo` engine, configured from the device's PDO objects
//!   (0x1400.., 0x1600.., 0x1800.., 0x1A00..) when it enters Operational; SYNC, event timers,
//!   inhibit times and change-of-state ([`SimDevice::set_value`]) as the engine implements them;
//! * LSS slave (`canola-lss`, CiA 305) with the identity from 0x1018 as its LSS address. A
//!   device made with [`SimDevice::unconfigured`] has no node-ID: it only answers LSS until a
//!   master assigns one, then boots with it.
//!
//! It implements [`Station`], so it runs attached to an in-memory bus
//! ([`MemoryBus::attach`](crate::mem::MemoryBus::attach), deterministic on the virtual clock) or
//! on any transport with [`run_station`](crate::transport::run_station) (e.g. SocketCAN for
//! `canopen simulate`). Several devices share one bus.
//!
//! Device-specific behaviour plugs in through [`DeviceHook`]: hooks see every SDO write before it
//! is stored (and may refuse it with an abort code), may serve reads themselves (a generated
//! DOMAIN such as a logbook), get their own timers, and can request a reset or an emergency.
//!
//! Communication objects with side effects handled here: 0x1017 producer heartbeat time.

use std::collections::{HashMap, VecDeque};
use std::hash::{BuildHasherDefault, Hasher};

use canola_frame::cob::FunctionCode;
use canola_frame::{CanFrame, Instant, NodeId, is_due};
use canola_lss::{LssAddress, LssSlave, SlaveConfig as LssConfig, SlaveEvent as LssEvent};
use canola_nmt::{DeviceState, Emcy, EmcyProducer, NmtSlave, Service, SlaveConfig, SlaveEvent};
use canola_od::{AccessType, ObjectDictionary};
use canola_sdo::{
    AbortCode, Access, LengthRule, Multiplexer, ObjectAccess, ObjectInfo, SdoCobIds, Server,
    ServerConfig,
};

use crate::transport::Station;

/// Longest value a variable-size object (string, DOMAIN) accepts by download.
pub const MAX_VARIABLE_SIZE: u32 = 1 << 20;

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
    fn is_empty(&self) -> bool {
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

/// The device's current object values (little-endian bytes, CiA 301 §7.1).
#[derive(Clone, Default)]
pub struct Values {
    /// By [`key`], hashed: an SDO request looks a value up twice, and a tree of a few hundred
    /// entries costs several times a hash lookup.
    map: KeyMap<Vec<u8>>,
}

/// The key of `index:sub` (ordered as `(index, sub)`).
fn key(index: u16, sub: u8) -> u32 {
    (u32::from(index) << 8) | u32::from(sub)
}

/// A map by [`key`].
type KeyMap<V> = HashMap<u32, V, BuildHasherDefault<KeyHasher>>;

/// A multiplicative hash for the [`key`]s (the device's own entries, no untrusted input): the
/// default SipHash would cost more than the tree lookup it replaces.
#[derive(Default, Clone, Copy)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(self.0.rotate_left(8) ^ u64::from(*b));
        }
    }

    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }

    fn write_u64(&mut self, x: u64) {
        // The high bits mixed into the low ones, which pick the bucket.
        let h = x.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = h ^ (h >> 32);
    }
}

impl core::fmt::Debug for Values {
    /// As the `(index, sub)` map it stands for, in that order.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut entries: Vec<_> = self.map.iter().collect();
        entries.sort_unstable_by_key(|(k, _)| **k);
        f.debug_map()
            .entries(
                entries
                    .into_iter()
                    .map(|(k, v)| (((k >> 8) as u16, *k as u8), v)),
            )
            .finish()
    }
}

impl Values {
    /// The value of `index:sub`.
    pub fn get(&self, index: u16, sub: u8) -> Option<&[u8]> {
        self.map.get(&key(index, sub)).map(Vec::as_slice)
    }

    /// Sets the value of `index:sub`.
    pub fn set(&mut self, index: u16, sub: u8, value: impl Into<Vec<u8>>) {
        self.map.insert(key(index, sub), value.into());
    }

    /// An unsigned value of up to 8 bytes.
    pub fn get_u64(&self, index: u16, sub: u8) -> Option<u64> {
        let b = self.get(index, sub)?;
        let mut buf = [0u8; 8];
        let n = b.len().min(8);
        buf[..n].copy_from_slice(&b[..n]);
        Some(u64::from_le_bytes(buf))
    }

    fn defaults(od: &ObjectDictionary, node: NodeId) -> Self {
        let mut map = KeyMap::default();
        for (index, sub) in od.entries() {
            let bytes = sub
                .effective_value(node.get())
                .map(|v| v.to_le_bytes())
                .unwrap_or_else(|| vec![0; sub.data_type.size().unwrap_or(0)]);
            map.insert(key(index, sub.sub_index), bytes);
        }
        Self { map }
    }
}

impl canola_pdo::ValueSource for Values {
    fn value(&self, index: u16, subindex: u8) -> Option<&[u8]> {
        self.get(index, subindex)
    }
}

/// What the SDO server asks the dictionary about a sub-object at every request.
#[derive(Debug, Clone, Copy)]
struct SubMeta {
    access: Access,
    /// The size of a fixed-size type.
    fixed: Option<u32>,
}

/// Every sub-object's [`SubMeta`], by [`key`] (the dictionary never changes).
fn sub_meta(od: &ObjectDictionary) -> KeyMap<SubMeta> {
    od.entries()
        .map(|(index, s)| {
            let fixed = match s.data_type.size() {
                Some(n) if !s.data_type.is_variable_size() => Some(n as u32),
                _ => None,
            };
            let meta = SubMeta {
                access: access(s.access),
                fixed,
            };
            (key(index, s.sub_index), meta)
        })
        .collect()
}

/// The objects as the SDO server sees them: dictionary metadata plus current values.
struct Objects<'a> {
    od: &'a ObjectDictionary,
    meta: &'a KeyMap<SubMeta>,
    values: &'a mut Values,
    staging: &'a mut Vec<u8>,
    hooks: &'a mut Vec<Box<dyn DeviceHook>>,
    actions: &'a mut HookActions,
    written: &'a mut Vec<(u16, u8)>,
    now: Instant,
}

fn access(a: AccessType) -> Access {
    match a {
        AccessType::Ro => Access::ReadOnly,
        AccessType::Wo => Access::WriteOnly,
        AccessType::Const => Access::Const,
        _ => Access::ReadWrite,
    }
}

impl ObjectAccess for Objects<'_> {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        let (index, sub) = (mux.index, mux.subindex);
        let Some(&meta) = self.meta.get(&key(index, sub)) else {
            return Err(if self.od.get(index).is_none() {
                AbortCode::OBJECT_DOES_NOT_EXIST
            } else {
                AbortCode::SUBINDEX_DOES_NOT_EXIST
            });
        };
        // A hook may serve the value: its length counts.
        for h in self.hooks.iter_mut() {
            if let Some(r) = h.on_read(self.now, self.values, index, sub) {
                let v = r?;
                self.values.set(index, sub, v);
                break;
            }
        }
        let len = self.values.get(index, sub).map_or(0, |v| v.len()) as u32;
        let acc = meta.access;
        Ok(match meta.fixed {
            Some(n) => ObjectInfo {
                access: acc,
                len,
                accepts: LengthRule::Exact(n),
            },
            None => ObjectInfo::variable(acc, len, MAX_VARIABLE_SIZE),
        })
    }

    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let v = self
            .values
            .get(mux.index, mux.subindex)
            .ok_or(AbortCode::NO_DATA_AVAILABLE)?;
        let start = (offset as usize).min(v.len());
        let n = buf.len().min(v.len() - start);
        buf[..n].copy_from_slice(&v[start..start + n]);
        Ok(n)
    }

    fn write(&mut self, _mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let offset = offset as usize;
        if offset == 0 {
            self.staging.clear();
        }
        let end = offset + data.len();
        if end > MAX_VARIABLE_SIZE as usize {
            return Err(AbortCode::OUT_OF_MEMORY);
        }
        if self.staging.len() < end {
            self.staging.resize(end, 0);
        }
        self.staging[offset..end].copy_from_slice(data);
        Ok(())
    }

    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        let value: Vec<u8> = self.staging.iter().take(len as usize).copied().collect();
        self.staging.clear();
        let (index, sub) = (mux.index, mux.subindex);
        // Range check against the dictionary's limits for integers.
        if let Some(s) = self.od.sub(index, sub) {
            let v = canola_od::Value::from_le_bytes(s.data_type, &value)
                .map_err(|_| AbortCode::LENGTH_MISMATCH)?;
            if let Some(x) = v.as_i128() {
                let limit = |f: Option<&canola_od::FieldValue>| {
                    f.and_then(|f| f.resolve(0)).and_then(|v| v.as_i128())
                };
                if limit(s.low_limit()).is_some_and(|lo| x < lo) {
                    return Err(AbortCode::VALUE_TOO_LOW);
                }
                if limit(s.high_limit()).is_some_and(|hi| x > hi) {
                    return Err(AbortCode::VALUE_TOO_HIGH);
                }
            }
        }
        for h in self.hooks.iter_mut() {
            h.on_write(self.now, self.values, index, sub, &value, self.actions)?;
        }
        self.values.set(index, sub, value);
        self.written.push((index, sub));
        Ok(())
    }

    fn discard(&mut self, _mux: Multiplexer) {
        self.staging.clear();
    }
}

/// One SDO server channel (CiA 301 §7.2.4.2): its COB-IDs and its server machine.
struct SdoChannel {
    ids: SdoCobIds,
    server: Server,
}

/// The device's SDO server channels: the default channel (0x1200: 0x600/0x580 + node-ID, which
/// CiA 301 fixes to the node-ID, so it follows a node-ID change) and every further server
/// parameter record 0x1201..=0x127F whose two COB-IDs are valid in the current values.
fn sdo_channels(od: &ObjectDictionary, values: &Values, node: NodeId) -> Vec<SdoChannel> {
    let ids_of = |index: u16| {
        od.get(index)?;
        let cob = |sub| values.get_u64(index, sub).map(|v| v as u32);
        SdoCobIds::from_parameters(cob(1)?, cob(2)?)
    };
    core::iter::once(SdoCobIds::default_for(node))
        .chain((0x1201..=0x127F).filter_map(ids_of))
        .map(|ids| SdoChannel {
            ids,
            server: Server::new(ServerConfig::default()),
        })
        .collect()
}

/// A simulated CANopen device. See the module docs.
pub struct SimDevice {
    node: NodeId,
    od: ObjectDictionary,
    /// What the SDO server asks `od` at each request, found by one hash lookup.
    meta: KeyMap<SubMeta>,
    values: Values,
    staging: Vec<u8>,
    nmt: NmtSlave,
    /// SDO server channels: 0x1200 first, then the valid ones of 0x1201..=0x127F.
    sdo: Vec<SdoChannel>,
    emcy: EmcyProducer,
    hooks: Vec<Box<dyn DeviceHook>>,
    out: VecDeque<CanFrame>,
    booted: bool,
    configured: bool,
    lss: LssSlave,
    pdo: Box<crate::pdo_glue::PdoEngine>,
    last_state: DeviceState,
    /// The earliest deadline of the protocol machines (hooks are asked each time), kept
    /// current by every input: the bus asks for it after every frame, and a scan over all
    /// machines costs more than the SDO request that changed one of them.
    timers: Option<Instant>,
    /// SDO requests served, for tests and statistics.
    pub sdo_requests: u64,
}

impl core::fmt::Debug for SimDevice {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SimDevice")
            .field("node", &self.node)
            .field("state", &self.nmt.state())
            .finish_non_exhaustive()
    }
}

impl SimDevice {
    /// A device with node-ID `node` and the dictionary `od` (values from ParameterValue or
    /// DefaultValue, `$NODEID` resolved). It boots (sends its boot-up message) at the first
    /// timer step.
    pub fn new(node: NodeId, od: ObjectDictionary) -> Self {
        let values = Values::defaults(&od, node);
        let heartbeat_ms = values.get_u64(0x1017, 0).unwrap_or(0) as u16;
        let nmt = NmtSlave::new(
            node,
            SlaveConfig {
                heartbeat_ms,
                guard_time_ms: values.get_u64(0x100C, 0).unwrap_or(0) as u16,
                life_time_factor: values.get_u64(0x100D, 0).unwrap_or(0) as u8,
            },
        );
        let emcy_cob = FunctionCode::Emcy.cob_id(node);
        let id = |sub| values.get_u64(0x1018, sub).unwrap_or(0) as u32;
        let mut lss_config = LssConfig::unconfigured(LssAddress::new(id(1), id(2), id(3), id(4)));
        lss_config.node_id = node.get();
        let sdo = sdo_channels(&od, &values, node);
        Self {
            node,
            meta: sub_meta(&od),
            od,
            values,
            staging: Vec::new(),
            nmt,
            sdo,
            emcy: EmcyProducer::new(emcy_cob, 0),
            hooks: Vec::new(),
            out: VecDeque::new(),
            booted: false,
            configured: true,
            lss: LssSlave::new(lss_config),
            pdo: Box::new(crate::pdo_glue::PdoEngine::new()),
            last_state: DeviceState::Initialising,
            timers: None,
            sdo_requests: 0,
        }
    }

    /// The earliest deadline of the protocol machines, looked up.
    fn machine_timers(&self) -> Option<Instant> {
        [
            self.nmt.poll_timeout(),
            self.emcy.poll_timeout(),
            self.lss.poll_timeout(),
            self.pdo.poll_timeout(),
        ]
        .into_iter()
        .chain(self.sdo.iter().map(|c| c.server.poll_timeout()))
        .flatten()
        .min()
    }

    fn refresh_timers(&mut self) {
        self.timers = self.machine_timers();
    }

    /// A device without a node-ID (CiA 305 "unconfigured", 0xFF) whose LSS address is `address`
    /// (also put into 0x1018). It stays silent except for LSS until a master configures a
    /// node-ID; then it boots with that node-ID.
    pub fn unconfigured(od: ObjectDictionary, address: LssAddress) -> Self {
        Self::unconfigured_with(od, LssConfig::unconfigured(address))
    }

    /// [`unconfigured`](Self::unconfigured) with an LSS slave of this behaviour, e.g.
    /// [`LssConfig::unconfigured_real`] (answers Fastscan in configuration state too, as real
    /// slaves do) or one that does not support store configuration. Its node-ID is taken as
    /// unconfigured whatever `lss.node_id` says.
    pub fn unconfigured_with(od: ObjectDictionary, mut lss: LssConfig) -> Self {
        let mut dev = Self::new(NodeId::MAX, od);
        dev.configured = false;
        lss.node_id = canola_lss::wire::UNCONFIGURED_NODE_ID;
        dev.lss = LssSlave::new(lss);
        dev.set_identity(lss.address);
        dev
    }

    fn set_identity(&mut self, a: LssAddress) {
        for (sub, v) in [
            (1, a.vendor_id),
            (2, a.product_code),
            (3, a.revision_number),
            (4, a.serial_number),
        ] {
            self.values.set(0x1018, sub, v.to_le_bytes().to_vec());
        }
    }

    /// Whether the device has a node-ID.
    pub fn is_configured(&self) -> bool {
        self.configured
    }

    /// The LSS address (identity).
    pub fn lss_address(&self) -> LssAddress {
        self.lss.address()
    }

    /// Takes a new node-ID (after LSS): values back to defaults for that node-ID, machines
    /// rebuilt, boot-up.
    fn adopt_node_id(&mut self, now: Instant, node: NodeId) {
        let address = self.lss.address();
        self.node = node;
        self.configured = true;
        self.values = Values::defaults(&self.od, node);
        self.set_identity(address);
        self.emcy = EmcyProducer::new(FunctionCode::Emcy.cob_id(node), 0);
        self.reset(now, false);
    }

    /// Parses an EDS/DCF text and builds a device from it.
    pub fn from_eds(node: NodeId, text: &[u8]) -> Result<Self, canola_od::ParseError> {
        Ok(Self::new(node, canola_od::parse(text)?.od))
    }

    /// Adds device-specific behaviour.
    pub fn with_hook(mut self, hook: impl DeviceHook + 'static) -> Self {
        self.hooks.push(Box::new(hook));
        self
    }

    /// The node-ID.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// The NMT state.
    pub fn state(&self) -> DeviceState {
        self.nmt.state()
    }

    /// The current values.
    pub fn values(&self) -> &Values {
        &self.values
    }

    /// The current values, to change them (e.g. a sensor reading).
    pub fn values_mut(&mut self) -> &mut Values {
        &mut self.values
    }

    /// The dictionary.
    pub fn dictionary(&self) -> &ObjectDictionary {
        &self.od
    }

    /// Sets a value the way the application would (e.g. a new sensor reading): event-driven
    /// TPDOs that map it go out when it changed (change-of-state, within their inhibit time).
    pub fn set_value(&mut self, now: Instant, index: u16, sub: u8, value: impl Into<Vec<u8>>) {
        self.values.set(index, sub, value);
        if self.nmt.state() == DeviceState::Operational {
            self.pdo
                .update(now, &mut crate::pdo_glue::Store(&mut self.values));
            self.collect();
            self.refresh_timers();
        }
    }

    /// (Re)builds the PDO engine from the current PDO objects; enabled in Operational.
    fn rebuild_pdos(&mut self, now: Instant) {
        let view = canola_pdo::OdView::with_values(&self.od, &self.values);
        self.pdo = crate::pdo_glue::device_engine(&view, now);
        let operational = self.nmt.state() == DeviceState::Operational;
        self.pdo.set_enabled(now, operational);
        if operational {
            // Event-driven TPDOs send their first value when the device starts.
            self.pdo
                .update(now, &mut crate::pdo_glue::Store(&mut self.values));
        }
    }

    /// Sends an emergency (when the NMT state allows EMCY).
    pub fn signal_emcy(&mut self, now: Instant, emcy: Emcy) {
        if self.nmt.allows(Service::Emcy) {
            let _ = self.emcy.signal(now, emcy);
            self.collect();
            self.refresh_timers();
        }
    }

    fn collect(&mut self) {
        while let Some(f) = self.nmt.poll_transmit_frame() {
            self.out.push_back(f);
        }
        for ch in &mut self.sdo {
            while let Some(data) = ch.server.poll_transmit() {
                self.out.push_back(ch.ids.response_frame(data));
            }
        }
        while let Some(f) = self.emcy.poll_transmit_frame() {
            self.out.push_back(f);
        }
        while let Some(f) = self.lss.poll_transmit_frame() {
            self.out.push_back(f);
        }
        while let Some(f) = self.pdo.poll_transmit() {
            self.out.push_back(f);
        }
        while self.pdo.poll_event().is_some() {}
    }

    fn after_lss(&mut self, now: Instant) {
        let mut adopt = None;
        while let Some(ev) = self.lss.poll_event() {
            if let LssEvent::ResetCommunication { node_id } = ev {
                adopt = Some(node_id);
            }
        }
        self.collect();
        if let Some(n) = adopt {
            self.adopt_node_id(now, n);
        }
    }

    fn reset(&mut self, now: Instant, application: bool) {
        // NMT reset makes a node-ID configured by LSS active (CiA 305).
        self.lss.reset_communication();
        if let Ok(n) = NodeId::new(self.lss.active_node_id())
            && n != self.node
        {
            self.node = n;
            self.emcy = EmcyProducer::new(FunctionCode::Emcy.cob_id(n), 0);
        }
        if application {
            let address = self.lss.address();
            self.values = Values::defaults(&self.od, self.node);
            self.set_identity(address);
        }
        let hb = self.values.get_u64(0x1017, 0).unwrap_or(0) as u16;
        self.nmt = NmtSlave::new(
            self.node,
            SlaveConfig {
                heartbeat_ms: hb,
                guard_time_ms: self.values.get_u64(0x100C, 0).unwrap_or(0) as u16,
                life_time_factor: self.values.get_u64(0x100D, 0).unwrap_or(0) as u8,
            },
        );
        self.sdo = sdo_channels(&self.od, &self.values, self.node);
        self.nmt.boot(now);
        self.after_nmt(now);
    }

    fn after_nmt(&mut self, now: Instant) {
        let mut resets = Vec::new();
        while let Some(ev) = self.nmt.poll_event() {
            match ev {
                SlaveEvent::ResetNode => resets.push(true),
                SlaveEvent::ResetCommunication => resets.push(false),
                _ => {}
            }
        }
        let state = self.nmt.state();
        if state != self.last_state {
            self.last_state = state;
            self.rebuild_pdos(now);
            for h in self.hooks.iter_mut() {
                h.on_state(now, state, &mut self.values);
            }
        }
        self.collect();
        if let Some(app) = resets.first() {
            self.reset(now, *app);
        }
    }

    /// Runs one step of SDO channel `ch`'s server over the device's objects, then applies what
    /// the hooks asked for and what the writes changed. Keeps [`timers`](Self::timers)
    /// current.
    fn serve_sdo(
        &mut self,
        now: Instant,
        ch: usize,
        step: impl FnOnce(&mut Server, Instant, &mut Objects<'_>),
    ) {
        let mut actions = HookActions::default();
        let mut written = Vec::new();
        let mut objs = Objects {
            od: &self.od,
            meta: &self.meta,
            values: &mut self.values,
            staging: &mut self.staging,
            hooks: &mut self.hooks,
            actions: &mut actions,
            written: &mut written,
            now,
        };
        let before = self.sdo[ch].server.poll_timeout();
        step(&mut self.sdo[ch].server, now, &mut objs);
        if written.is_empty() && actions.is_empty() {
            // Only this server had input (every machine's output is collected after each of
            // its inputs): only it can have frames, and only its timer can have moved.
            let c = &mut self.sdo[ch];
            while let Some(data) = c.server.poll_transmit() {
                self.out.push_back(c.ids.response_frame(data));
            }
            if c.server.poll_timeout() != before {
                self.refresh_timers();
            }
        } else {
            self.apply(now, actions, &written);
            self.refresh_timers();
        }
    }

    /// Takes new SDO server parameters (0x1200..=0x127F written): channels whose COB-IDs are
    /// unchanged keep their server (and a transfer in progress).
    fn reconfigure_sdo(&mut self) {
        let mut old = core::mem::take(&mut self.sdo);
        self.sdo = sdo_channels(&self.od, &self.values, self.node)
            .into_iter()
            .map(|fresh| match old.iter().position(|c| c.ids == fresh.ids) {
                Some(i) => old.swap_remove(i),
                None => fresh,
            })
            .collect();
    }

    fn apply(&mut self, now: Instant, actions: HookActions, written: &[(u16, u8)]) {
        let mut remapped = false;
        let mut sdo_parameters = false;
        for &(index, sub) in written {
            remapped |= (0x1400..=0x1BFF).contains(&index);
            sdo_parameters |= (0x1200..=0x127F).contains(&index);
            if (index, sub) == (0x1017, 0) {
                let ms = self.values.get_u64(0x1017, 0).unwrap_or(0) as u16;
                self.nmt.set_heartbeat_time(now, ms);
            }
        }
        if remapped {
            self.rebuild_pdos(now);
        }
        if sdo_parameters {
            self.reconfigure_sdo();
        }
        for e in actions.emcy {
            let _ = self.emcy.signal(now, e);
        }
        self.collect();
        if actions.reset_node || actions.reset_communication {
            self.reset(now, actions.reset_node);
        }
    }
}

impl Station for SimDevice {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        if !self.booted {
            return;
        }
        let Some(cob) = frame.cob_id() else { return };
        if cob == canola_frame::cob::LSS_MASTER_TO_SLAVE {
            self.lss.handle_frame(now, frame);
            self.after_lss(now);
            self.refresh_timers();
            return;
        }
        if !self.configured {
            return;
        }
        if let Some(ch) = self.sdo.iter().position(|c| c.ids.is_request(frame)) {
            if !self.nmt.allows(Service::Sdo) {
                return;
            }
            self.sdo_requests += 1;
            self.serve_sdo(now, ch, |server, now, objs| {
                server.handle_request(now, frame.data(), objs)
            });
            return;
        }
        if self.nmt.handle_frame(now, frame).unwrap_or(false) {
            self.after_nmt(now);
        } else if self
            .pdo
            .handle_frame(now, frame, &mut crate::pdo_glue::Store(&mut self.values))
        {
            self.collect();
        }
        self.refresh_timers();
    }

    fn handle_timeout(&mut self, now: Instant) {
        if !self.booted {
            self.booted = true;
            if self.configured {
                self.nmt.boot(now);
                self.after_nmt(now);
            }
        }
        if is_due(self.lss.poll_timeout(), now) {
            self.lss.handle_timeout(now);
            self.after_lss(now);
        }
        if is_due(self.nmt.poll_timeout(), now) {
            self.nmt.handle_timeout(now);
            self.after_nmt(now);
        }
        for ch in 0..self.sdo.len() {
            if is_due(self.sdo[ch].server.poll_timeout(), now) {
                self.serve_sdo(now, ch, |server, now, objs| {
                    server.handle_timeout(now, objs)
                });
            }
        }
        if is_due(self.emcy.poll_timeout(), now) {
            self.emcy.handle_timeout(now);
        }
        if is_due(self.pdo.poll_timeout(), now) {
            self.pdo
                .handle_timeout(now, &mut crate::pdo_glue::Store(&mut self.values));
            self.collect();
        }
        let mut actions = HookActions::default();
        for h in self.hooks.iter_mut() {
            if is_due(h.poll_timeout(), now) {
                h.on_timeout(now, &mut self.values, &mut actions);
            }
        }
        self.apply(now, actions, &[]);
        self.refresh_timers();
    }

    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }

    fn poll_timeout(&self) -> Option<Instant> {
        if !self.booted {
            return Some(Instant::ZERO);
        }
        debug_assert_eq!(self.timers, self.machine_timers(), "stale device timers");
        self.hooks
            .iter()
            .filter_map(|h| h.poll_timeout())
            .chain(self.timers)
            .min()
    }
}
