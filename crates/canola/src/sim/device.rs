//! The simulated device itself: [`SimDevice`], the composition of the protocol crates'
//! device-side machines over one dictionary and its values, as a [`Station`] on a bus.

use std::collections::VecDeque;

use canola_frame::cob::FunctionCode;
use canola_frame::{CanFrame, FdFrame, Instant, NodeId, is_due};
use canola_lss::{LssAddress, LssSlave, SlaveConfig as LssConfig, SlaveEvent as LssEvent};
use canola_nmt::{DeviceState, Emcy, EmcyProducer, NmtSlave, Service, SlaveConfig, SlaveEvent};
use canola_od::ObjectDictionary;
use canola_sdo::Server;
use canola_sdo::usdo::{UsdoServer, UsdoServerConfig};

use crate::transport::Station;

use super::hook::{DeviceHook, HookActions};
use super::objects::{Objects, SdoChannel, SubMeta, sdo_channels, sub_meta};
use super::pdo::{DeviceMpdos, FdPdos, Store, device_engine};
use super::values::{KeyMap, Values};
use crate::machine::pdo::PdoEngine;

/// A simulated CANopen device. See the module docs.
pub struct SimDevice {
    pub(super) node: NodeId,
    pub(super) od: ObjectDictionary,
    /// What the SDO server asks `od` at each request, found by one hash lookup.
    pub(super) meta: KeyMap<SubMeta>,
    pub(super) values: Values,
    pub(super) staging: Vec<u8>,
    pub(super) nmt: NmtSlave,
    /// SDO server channels: 0x1200 first, then the valid ones of 0x1201..=0x127F.
    pub(super) sdo: Vec<SdoChannel>,
    pub(super) emcy: EmcyProducer,
    pub(super) hooks: Vec<Box<dyn DeviceHook>>,
    pub(super) out: VecDeque<CanFrame>,
    pub(super) booted: bool,
    pub(super) configured: bool,
    pub(super) lss: LssSlave,
    pub(super) pdo: Box<PdoEngine>,
    /// PDOs of more than 8 bytes, as CAN FD frames (a device marked CANopen FD only).
    pub(super) fd_pdo: FdPdos,
    /// SAM-MPDO producers and DAM-MPDO consumers.
    pub(super) mpdo: DeviceMpdos,
    pub(super) last_state: DeviceState,
    /// The earliest deadline of the protocol machines (hooks are asked each time), kept
    /// current by every input: the bus asks for it after every frame, and a scan over all
    /// machines costs more than the SDO request that changed one of them.
    pub(super) timers: Option<Instant>,
    /// Habits of real devices this one copies.
    pub(super) quirks: super::Quirks,
    /// SDO requests served, for tests and statistics.
    pub sdo_requests: u64,
    /// The values in non-volatile memory (0x1010 stores into it, 0x1011 puts defaults back
    /// into it), which an NMT reset node loads; `None` while nothing was stored or restored
    /// (the defaults).
    pub(super) stored: Option<Values>,
    /// The parser's warnings of the EDS the device was built from.
    pub(super) warnings: Vec<canola_od::Diagnostic>,
    /// The USDO server of a device marked CANopen FD (CiA 1301), on 0x600 + any client.
    pub(super) usdo: Option<Box<UsdoServer>>,
    /// CAN FD frames waiting to be sent (USDO responses).
    pub(super) out_fd: VecDeque<FdFrame>,
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
        let fd = crate::usdo::eds_marks_fd(&od);
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
            pdo: Box::new(PdoEngine::new()),
            fd_pdo: FdPdos::default(),
            mpdo: DeviceMpdos::none(node),
            last_state: DeviceState::Initialising,
            timers: None,
            quirks: super::Quirks::default(),
            sdo_requests: 0,
            stored: None,
            warnings: Vec::new(),
            usdo: fd.then(|| Box::new(UsdoServer::new(node, UsdoServerConfig::default()))),
            out_fd: VecDeque::new(),
        }
    }

    /// The earliest deadline of the protocol machines, looked up.
    pub(super) fn machine_timers(&self) -> Option<Instant> {
        [
            self.nmt.poll_timeout(),
            self.emcy.poll_timeout(),
            self.lss.poll_timeout(),
            self.pdo.poll_timeout(),
        ]
        .into_iter()
        .chain(self.sdo.iter().map(|c| c.server.poll_timeout()))
        .chain(self.usdo.as_ref().map(|u| u.poll_timeout()))
        .chain([self.fd_pdo.poll_timeout()])
        .flatten()
        .min()
    }

    pub(super) fn refresh_timers(&mut self) {
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

    pub(super) fn set_identity(&mut self, a: LssAddress) {
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
    pub(super) fn adopt_node_id(&mut self, now: Instant, node: NodeId) {
        let address = self.lss.address();
        self.node = node;
        self.configured = true;
        self.values = Values::defaults(&self.od, node);
        self.set_identity(address);
        self.emcy = EmcyProducer::new(FunctionCode::Emcy.cob_id(node), 0);
        self.reset(now, false);
    }

    /// Parses an EDS/DCF text and builds a device from it. A file with errors is refused,
    /// among them a value of a communication object (0x1000..=0x1FFF) that does not parse:
    /// kept as text it would leave a COB-ID at 0 and the device sending on 0x000, the NMT
    /// identifier. The parser's warnings stay with the device: [`warnings`](Self::warnings).
    pub fn from_eds(node: NodeId, text: &[u8]) -> Result<Self, canola_od::ParseError> {
        let parsed = canola_od::parse(text)?;
        let mut device = Self::new(node, parsed.od);
        device.warnings = parsed.diagnostics;
        Ok(device)
    }

    /// The warnings of the EDS the device was built from ([`from_eds`](Self::from_eds)), as
    /// `canola_od::parse` gives them; empty for a device built from a dictionary.
    pub fn warnings(&self) -> &[canola_od::Diagnostic] {
        &self.warnings
    }

    /// [`from_eds`](Self::from_eds) with parser options (e.g.
    /// [`ParseOptions::strict`](canola_od::ParseOptions::strict), which refuses a file with any
    /// finding in a communication object), handing back the parser's warnings with the device.
    pub fn from_eds_with(
        node: NodeId,
        text: &[u8],
        options: canola_od::ParseOptions,
    ) -> Result<(Self, Vec<canola_od::Diagnostic>), canola_od::ParseError> {
        let parsed = canola_od::parse_with(text, options)?;
        let mut device = Self::new(node, parsed.od);
        device.warnings = parsed.diagnostics.clone();
        Ok((device, parsed.diagnostics))
    }

    /// Makes the device a CANopen FD device serving USDO (CiA 1301) on CAN FD frames
    /// (`true`), or not (`false`). A device whose EDS has `CANopenFD=1` in `[DeviceInfo]`
    /// ([`crate::usdo::EDS_FD_KEY`]) is one from the start. Its classic SDO server stays.
    pub fn with_fd(mut self, fd: bool) -> Self {
        self.set_fd(fd);
        self
    }

    /// [`with_fd`](Self::with_fd) on a device already built (a transfer in progress ends).
    pub fn set_fd(&mut self, fd: bool) {
        self.usdo = fd.then(|| Box::new(UsdoServer::new(self.node, UsdoServerConfig::default())));
        self.refresh_timers();
    }

    /// Whether the device serves USDO (CANopen FD).
    pub fn is_fd(&self) -> bool {
        self.usdo.is_some()
    }

    /// Copies habits of real devices (see [`Quirks`](super::Quirks)).
    pub fn with_quirks(mut self, quirks: super::Quirks) -> Self {
        self.quirks = quirks;
        self
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
        self.fd_pdo.set_now(now);
        if self.nmt.state() == DeviceState::Operational {
            self.pdo.update(now, &mut Store(&mut self.values));
            self.collect();
            self.refresh_timers();
        }
    }

    /// (Re)builds the PDO engine from the current PDO objects; enabled in Operational.
    pub(super) fn rebuild_pdos(&mut self, now: Instant) {
        let view = canola_pdo::OdView::with_values(&self.od, &self.values);
        self.pdo = device_engine(&view, now);
        self.fd_pdo = if self.usdo.is_some() {
            FdPdos::from_view(&view)
        } else {
            FdPdos::default()
        };
        self.fd_pdo.set_now(now);
        self.mpdo = DeviceMpdos::from_view(&view, self.node);
        let operational = self.nmt.state() == DeviceState::Operational;
        self.pdo.set_enabled(now, operational);
        if operational {
            // Event-driven TPDOs send their first value when the device starts.
            self.pdo.update(now, &mut Store(&mut self.values));
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

    pub(super) fn collect(&mut self) {
        while let Some(f) = self.nmt.poll_transmit_frame() {
            self.out.push_back(f);
        }
        for ch in &mut self.sdo {
            while let Some(data) = ch.server.poll_transmit() {
                let data = self.quirks.sdo_response(data);
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
        if !self.fd_pdo.is_empty() && self.nmt.state() == DeviceState::Operational {
            self.fd_pdo.changed(&self.values, &mut self.out_fd);
        }
        if !self.mpdo.is_empty() && self.nmt.state() == DeviceState::Operational {
            self.mpdo.changed(&mut self.values, &mut self.out);
        }
    }

    pub(super) fn after_lss(&mut self, now: Instant) {
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

    pub(super) fn reset(&mut self, now: Instant, application: bool) {
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
            self.values = match &self.stored {
                Some(stored) => stored.clone(),
                None => Values::defaults(&self.od, self.node),
            };
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
        if self.usdo.is_some() {
            self.usdo = Some(Box::new(UsdoServer::new(
                self.node,
                UsdoServerConfig::default(),
            )));
        }
        self.nmt.boot(now);
        self.after_nmt(now);
    }

    pub(super) fn after_nmt(&mut self, now: Instant) {
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
    pub(super) fn serve_sdo(
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
                let data = self.quirks.sdo_response(data);
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

    /// Runs one step of the USDO server over the device's objects (as
    /// [`serve_sdo`](Self::serve_sdo) for an SDO channel), then queues its CAN FD frames.
    pub(super) fn serve_usdo(
        &mut self,
        now: Instant,
        step: impl FnOnce(&mut UsdoServer, Instant, &mut Objects<'_>),
    ) {
        let Some(server) = self.usdo.as_deref_mut() else {
            return;
        };
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
        step(server, now, &mut objs);
        while let Some(f) = server.poll_transmit_frame() {
            self.out_fd.push_back(f);
        }
        while server.poll_event().is_some() {}
        self.apply(now, actions, &written);
        self.refresh_timers();
    }

    /// Takes new SDO server parameters (0x1200..=0x127F written): channels whose COB-IDs are
    /// unchanged keep their server (and a transfer in progress).
    pub(super) fn reconfigure_sdo(&mut self) {
        let mut old = core::mem::take(&mut self.sdo);
        self.sdo = sdo_channels(&self.od, &self.values, self.node)
            .into_iter()
            .map(|fresh| match old.iter().position(|c| c.ids == fresh.ids) {
                Some(i) => old.swap_remove(i),
                None => fresh,
            })
            .collect();
    }

    /// Stores `group`'s current values in the non-volatile memory (`save`), or its defaults
    /// (`load`, restore default parameters: they take effect at the next reset node).
    fn store(&mut self, group: crate::ParameterGroup, save: bool) {
        let defaults = Values::defaults(&self.od, self.node);
        let source = if save { &self.values } else { &defaults };
        let stored = self.stored.get_or_insert_with(|| defaults.clone());
        let in_group = |k: &u32| group.holds((k >> 8) as u16);
        stored.map.retain(|k, _| !in_group(k));
        stored.map.extend(
            source
                .map
                .iter()
                .filter(|(k, _)| in_group(k))
                .map(|(k, v)| (*k, v.clone())),
        );
    }

    pub(super) fn apply(&mut self, now: Instant, actions: HookActions, written: &[(u16, u8)]) {
        let mut remapped = false;
        let mut sdo_parameters = false;
        for &(index, sub) in written {
            match index {
                0x1010 => self.store(crate::ParameterGroup::from_sub_index(sub), true),
                0x1011 => self.store(crate::ParameterGroup::from_sub_index(sub), false),
                _ => {}
            }
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
        self.fd_pdo.set_now(now);
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
        if !self.fd_pdo.is_empty()
            && self.nmt.state() == DeviceState::Operational
            && cob == canola_frame::cob::SYNC
        {
            self.fd_pdo.sync(&self.values, &mut self.out_fd);
        }
        if !self.mpdo.is_empty()
            && self.nmt.state() == DeviceState::Operational
            && self.mpdo.receive(frame, &mut self.values)
        {
            let mut actions = HookActions::default();
            for h in self.hooks.iter_mut() {
                h.on_pdo_input(now, &mut self.values, &mut actions);
            }
            self.pdo.update(now, &mut Store(&mut self.values));
            self.collect();
            self.apply(now, actions, &[]);
            self.refresh_timers();
            return;
        }
        if self.nmt.handle_frame(now, frame).unwrap_or(false) {
            self.after_nmt(now);
        } else if self
            .pdo
            .handle_frame(now, frame, &mut Store(&mut self.values))
        {
            // An RPDO (or a SYNC applying one) may have written values: the hooks see them
            // at once, one frame at a time (a controlword edge is not lost between two timers).
            let mut actions = HookActions::default();
            for h in self.hooks.iter_mut() {
                h.on_pdo_input(now, &mut self.values, &mut actions);
            }
            if !self.hooks.is_empty() {
                self.pdo.update(now, &mut Store(&mut self.values));
            }
            self.apply(now, actions, &[]);
        }
        self.refresh_timers();
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.fd_pdo.set_now(now);
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
        if is_due(self.usdo.as_ref().and_then(|u| u.poll_timeout()), now) {
            self.serve_usdo(now, |server, now, objs| server.handle_timeout(now, objs));
        }
        if is_due(self.emcy.poll_timeout(), now) {
            self.emcy.handle_timeout(now);
        }
        if is_due(self.fd_pdo.poll_timeout(), now) {
            // Event timers of CAN FD TPDOs (set only while Operational).
            self.fd_pdo
                .handle_timeout(now, &self.values, &mut self.out_fd);
        }
        if is_due(self.pdo.poll_timeout(), now) {
            self.pdo.handle_timeout(now, &mut Store(&mut self.values));
            self.collect();
        }
        let mut actions = HookActions::default();
        let mut hooked = false;
        for h in self.hooks.iter_mut() {
            if is_due(h.poll_timeout(), now) {
                h.on_timeout(now, &mut self.values, &mut actions);
                hooked = true;
            }
        }
        if hooked && self.nmt.state() == DeviceState::Operational {
            // A hook's timer may change mapped values (a drive model stepping): event-driven
            // TPDOs send what changed, as for `set_value`.
            self.pdo.update(now, &mut Store(&mut self.values));
        }
        self.apply(now, actions, &[]);
        self.refresh_timers();
    }

    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }

    /// USDO requests (CAN FD on 0x600 + a client's node-ID) for a device marked CANopen FD,
    /// served while NMT allows SDO (pre-operational and operational).
    fn handle_fd_frame(&mut self, now: Instant, frame: &FdFrame) {
        self.fd_pdo.set_now(now);
        if !self.booted || !self.configured || self.usdo.is_none() {
            return;
        }
        if self.nmt.state() == DeviceState::Operational
            && self.fd_pdo.receive(frame, &mut self.values)
        {
            let mut actions = HookActions::default();
            for h in self.hooks.iter_mut() {
                h.on_pdo_input(now, &mut self.values, &mut actions);
            }
            self.pdo.update(now, &mut Store(&mut self.values));
            self.collect();
            self.apply(now, actions, &[]);
            self.refresh_timers();
            return;
        }
        if !self.nmt.allows(Service::Sdo) {
            return;
        }
        self.sdo_requests += 1;
        self.serve_usdo(now, |server, now, objs| {
            server.handle_frame(now, frame, objs);
        });
    }

    fn poll_transmit_fd(&mut self) -> Option<FdFrame> {
        self.out_fd.pop_front()
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
