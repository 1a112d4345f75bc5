//! PDOs from the master (CiA 301 §7.2.2, parameter objects §7.4.8): a node's TPDO and RPDO
//! parameters read by SDO into a typed [`PdoSet`], changed and saved back the CiA 301 way; and
//! the node's RPDOs transmitted by the master through the `canola-pdo` engine.
//!
//! * [`Node::tpdo`] / [`Node::rpdo`] → [`Tpdos`] / [`Rpdos`]. `read()` reads every PDO the node
//!   has (communication object 0x1800.. / 0x1400..: COB-ID, transmission type, inhibit time,
//!   event timer, SYNC start value; mapping object 0x1A00.. / 0x1600..) into one
//!   [`PdoParameters`] per PDO. `save()` writes the PDOs changed since they were read, each with
//!   the sequence [`Node::remap_pdo`] uses (invalidate the COB-ID, mapping count 0, entries,
//!   count, parameters, COB-ID as wanted).
//! * After a TPDO `read()` or `save()` the master decodes that TPDO from the COB-ID and with the
//!   mapping the node has (`NetworkEvent::PdoValues`), not only from the predefined ones.
//! * [`Rpdos::start`] transmits one of the node's RPDOs: the node's COB-ID and mapping, the
//!   master's [`Transmission`] (on change with an inhibit time, cyclic by event timer, or on the
//!   master's SYNC). The application sets mapped values through the [`RpdoSender`]; the
//!   network's own driving (background driver, waiting calls, `run_for`) sends the frames.

use std::sync::Arc;

use canola_frame::{CanId, Duration, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::{
    Catalog, CommParams, Direction, Mapping, MappingEntry, OdView, PdoCobId, PdoConfig,
    RemoteObjects, TransmissionType,
};
use canola_sdo::AbortCode;

use crate::error::Error;
use crate::network::Node;
use crate::typed::{ObjectKey, WriteValue};

/// One mapped object of a PDO: its address and mapped length, with its name when the node has
/// a dictionary that describes it (`"Sensor Value 1.Value"`, as [`ObjectDictionary::find`]
/// resolves names).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MappedVariable {
    /// The mapped object (a data type index 0x0001..=0x0007 for a dummy entry).
    pub addr: ObjectAddress,
    /// The mapped length in bits.
    pub bits: u8,
    /// The object's name in the node's dictionary.
    pub name: Option<String>,
}

impl MappedVariable {
    /// The raw mapping entry, `index << 16 | subindex << 8 | bits`.
    pub fn entry(&self) -> u32 {
        MappingEntry::new(self.addr.index, self.addr.sub_index, self.bits).0
    }
}

/// Which optional sub-indices of the communication object the node has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Present {
    inhibit_time: bool,
    event_timer: bool,
    sync_start: bool,
    mapping_writable: bool,
}

/// The communication and mapping parameters of one PDO of a node, as read by
/// [`Tpdos::read`] / [`Rpdos::read`]. Change the public fields (or use the setters) and save
/// the set with `save()`.
#[derive(Debug, Clone)]
pub struct PdoParameters {
    direction: Direction,
    number: u16,
    /// Communication parameters. `inhibit_time` is in units of 100 µs and `event_timer` in ms,
    /// as on the bus; sub-indices the node does not have read as 0 and are not written.
    pub comm: CommParams,
    /// The mapped objects in PDO order.
    pub mapped: Vec<MappedVariable>,
    present: Present,
    /// Sub 0 of the mapping object when it selects an MPDO (0xFE, 0xFF).
    mpdo: Option<u8>,
    /// What the node holds (as read or last saved): `save` writes only what differs.
    saved: (CommParams, Vec<u32>),
    node: NodeId,
    od: Option<Arc<ObjectDictionary>>,
}

impl PartialEq for PdoParameters {
    fn eq(&self, other: &Self) -> bool {
        (self.direction, self.number, self.comm, &self.mapped)
            == (other.direction, other.number, other.comm, &other.mapped)
    }
}

impl PdoParameters {
    /// TPDO or RPDO (seen from the node).
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// The PDO number, 1-based (TPDO1 is object 0x1800 / 0x1A00).
    pub fn number(&self) -> u16 {
        self.number
    }

    /// Whether the PDO exists (COB-ID bit 31 clear).
    pub fn is_enabled(&self) -> bool {
        self.comm.cob_id.is_valid()
    }

    /// Sets COB-ID bit 31: `false` makes the PDO not exist.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.comm.cob_id = self.comm.cob_id.with_valid(enabled);
    }

    /// The CAN identifier of the COB-ID (an error when its bits do not form one).
    pub fn can_id(&self) -> Result<CanId, Error> {
        self.comm
            .cob_id
            .can_id()
            .map_err(|e| self.error(e.to_string()))
    }

    /// Puts the PDO on another identifier, keeping the valid and RTR bits (bit 29 follows the
    /// identifier's format).
    pub fn set_can_id(&mut self, id: CanId) {
        let flags = self.comm.cob_id.0 & 0xC000_0000;
        self.comm.cob_id = match id {
            CanId::Standard(s) => PdoCobId(flags | u32::from(s.as_raw())),
            CanId::Extended(e) => PdoCobId(flags | canola_pdo::comm::COB_ID_EXTENDED | e.as_raw()),
        };
    }

    /// Whether remote requests are allowed (COB-ID bit 30 clear).
    pub fn rtr_allowed(&self) -> bool {
        self.comm.cob_id.rtr_allowed()
    }

    /// The transmission type.
    pub fn transmission_type(&self) -> TransmissionType {
        self.comm.transmission_type
    }

    /// Sets the transmission type.
    pub fn set_transmission_type(&mut self, t: TransmissionType) {
        self.comm.transmission_type = t;
    }

    /// The inhibit time (sub 3).
    pub fn inhibit_time(&self) -> Duration {
        self.comm.inhibit()
    }

    /// Sets the inhibit time: a multiple of 100 µs up to 6.5535 s, on a node that has sub 3.
    pub fn set_inhibit_time(&mut self, d: impl Into<Duration>) -> Result<(), Error> {
        if !self.present.inhibit_time {
            return Err(self.error("the node has no inhibit time (sub 3) for this PDO".into()));
        }
        self.comm.inhibit_time = inhibit_units(d.into()).map_err(|m| self.error(m))?;
        Ok(())
    }

    /// The event timer (sub 5; zero = off).
    pub fn event_timer(&self) -> Duration {
        self.comm.event_time()
    }

    /// Sets the event timer: whole milliseconds up to 65.535 s, on a node that has sub 5.
    pub fn set_event_timer(&mut self, d: impl Into<Duration>) -> Result<(), Error> {
        if !self.present.event_timer {
            return Err(self.error("the node has no event timer (sub 5) for this PDO".into()));
        }
        self.comm.event_timer = event_millis(d.into()).map_err(|m| self.error(m))?;
        Ok(())
    }

    /// Whether the node has an inhibit time (sub 3) for this PDO.
    pub fn has_inhibit_time(&self) -> bool {
        self.present.inhibit_time
    }

    /// Whether the node has an event timer (sub 5) for this PDO.
    pub fn has_event_timer(&self) -> bool {
        self.present.event_timer
    }

    /// Whether the node has a SYNC start value (sub 6) for this PDO.
    pub fn has_sync_start(&self) -> bool {
        self.present.sync_start
    }

    /// Whether the mapping is an MPDO (mapping sub 0 = 0xFE or 0xFF); `mapped` is empty then.
    pub fn mpdo(&self) -> Option<u8> {
        self.mpdo
    }

    /// Removes every mapped object.
    pub fn clear(&mut self) {
        self.mapped.clear();
        self.mpdo = None;
    }

    /// Maps one more object, by name (`"Sensor Value 1.Value"`) or address, with its size from
    /// the node's dictionary. Without a dictionary use [`map_entry`](Self::map_entry).
    pub fn map<'k>(&mut self, key: impl Into<ObjectKey<'k>>) -> Result<(), Error> {
        let Some(od) = self.od.clone() else {
            return Err(Error::UnknownObject {
                node: self.node,
                name: String::new(),
                reason: "the node has no dictionary: give the length (map_entry)".into(),
            });
        };
        let key = key.into();
        let addr = match key {
            ObjectKey::Address(a) => a,
            ObjectKey::Name(name) => od.find(name).ok_or_else(|| Error::UnknownObject {
                node: self.node,
                name: name.into(),
                reason: "no such object in the node's dictionary".into(),
            })?,
        };
        let info = OdView::new(&od, self.node.get())
            .object_info(addr)
            .ok_or_else(|| Error::Value {
                node: self.node,
                entry: addr,
                message: "the node's dictionary does not describe this object".into(),
            })?;
        let bits = u8::try_from(info.bits).map_err(|_| Error::Value {
            node: self.node,
            entry: addr,
            message: format!("{} bits do not fit a PDO", info.bits),
        })?;
        self.map_entry(addr, bits);
        Ok(())
    }

    /// Maps one more object with `bits` as its length (a dummy entry: a data type index
    /// 0x0001..=0x0007 as `addr.index`). The mapping is checked when it is saved.
    pub fn map_entry(&mut self, addr: ObjectAddress, bits: u8) {
        let name = self.od.as_deref().and_then(|od| name_of(od, addr));
        self.mapped.push(MappedVariable { addr, bits, name });
        self.mpdo = None;
    }

    /// Whether the parameters differ from what the node holds (as read or last saved).
    pub fn is_changed(&self) -> bool {
        let (comm, entries) = &self.saved;
        *comm != self.comm || !entries.iter().copied().eq(self.raw_entries())
    }

    fn raw_entries(&self) -> impl Iterator<Item = u32> + '_ {
        self.mapped.iter().map(MappedVariable::entry)
    }

    /// The mapping as the PDO engine takes it, checked against the node's dictionary when it
    /// has one (objects exist, are mappable with the access the direction needs, sizes match).
    pub fn mapping(&self) -> Result<Mapping, Error> {
        let raw: Vec<u32> = self.raw_entries().collect();
        let mapping = match self.od.as_deref() {
            Some(od) => {
                Mapping::from_raw_checked(self.direction, &raw, &OdView::new(od, self.node.get()))
            }
            None => Mapping::from_raw(&raw),
        };
        mapping.map_err(|e| self.error(e.to_string()))
    }

    /// The mapping for decoding and encoding: checked when possible, else with every object
    /// read as unsigned (a node may report a mapping its dictionary does not allow).
    fn mapping_lenient(&self) -> Option<Mapping> {
        self.mapping().ok().or_else(|| {
            let raw: Vec<u32> = self.raw_entries().collect();
            Mapping::from_raw(&raw).ok()
        })
    }

    fn comm_index(&self) -> u16 {
        self.direction.comm_index(self.number - 1)
    }

    fn error(&self, message: String) -> Error {
        Error::Value {
            node: self.node,
            entry: ObjectAddress::new(self.comm_index(), 0),
            message: format!("{}{}: {message}", kind_name(self.direction), self.number),
        }
    }
}

fn kind_name(direction: Direction) -> &'static str {
    match direction {
        Direction::Transmit => "TPDO",
        Direction::Receive => "RPDO",
    }
}

/// The inhibit time in units of 100 µs.
fn inhibit_units(d: Duration) -> Result<u16, String> {
    let us = d.as_micros();
    if !us.is_multiple_of(100) {
        return Err(format!("inhibit time {d} is not a multiple of 100 µs"));
    }
    u16::try_from(us / 100).map_err(|_| format!("inhibit time {d} exceeds 6.5535 s"))
}

/// The event timer in ms.
fn event_millis(d: Duration) -> Result<u16, String> {
    let us = d.as_micros();
    if !us.is_multiple_of(1000) {
        return Err(format!("event timer {d} is not whole milliseconds"));
    }
    u16::try_from(us / 1000).map_err(|_| format!("event timer {d} exceeds 65.535 s"))
}

fn name_of(od: &ObjectDictionary, addr: ObjectAddress) -> Option<String> {
    od.sub(addr.index, addr.sub_index)
        .map(|_| crate::typed::object_name(od, addr))
}

/// Every PDO of one direction a node has, as read by SDO. Indexed by PDO number.
#[derive(Debug, Clone, PartialEq)]
pub struct PdoSet {
    direction: Direction,
    pdos: Vec<PdoParameters>,
}

impl PdoSet {
    /// TPDOs or RPDOs (seen from the node).
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// PDO `number` (1-based), if the node has it.
    pub fn get(&self, number: u16) -> Option<&PdoParameters> {
        self.pdos.iter().find(|p| p.number == number)
    }

    /// PDO `number` (1-based), to change it.
    pub fn get_mut(&mut self, number: u16) -> Option<&mut PdoParameters> {
        self.pdos.iter_mut().find(|p| p.number == number)
    }

    /// The PDOs in number order.
    pub fn iter(&self) -> impl Iterator<Item = &PdoParameters> {
        self.pdos.iter()
    }

    /// How many PDOs the node has in this direction.
    pub fn len(&self) -> usize {
        self.pdos.len()
    }

    /// Whether the node has none.
    pub fn is_empty(&self) -> bool {
        self.pdos.is_empty()
    }
}

impl Node {
    /// The node's transmit PDOs: read and save their parameters (python-canopen's
    /// `node.tpdo.read()` / `save()`); after either, the master decodes them as the node sends
    /// them.
    pub fn tpdo(&self) -> Tpdos {
        Tpdos { node: self.clone() }
    }

    /// The node's receive PDOs: read and save their parameters, and transmit them from the
    /// master ([`Rpdos::start`]).
    pub fn rpdo(&self) -> Rpdos {
        Rpdos { node: self.clone() }
    }
}

/// A node's transmit PDOs ([`Node::tpdo`]).
#[derive(Debug, Clone)]
pub struct Tpdos {
    node: Node,
}

impl Tpdos {
    /// Reads every TPDO's parameters by SDO (the PDOs the node's dictionary lists; without a
    /// dictionary TPDO1..4, those that exist). The master decodes each valid TPDO from its
    /// COB-ID and with its mapping from now on.
    pub fn read(&self) -> Result<PdoSet, Error> {
        let port = Port::Blocking(&self.node);
        port.run(read_set(port, Direction::Transmit))
    }

    /// Writes the TPDOs changed since they were read (see the module docs for the sequence);
    /// the master's decoding follows. Stops at the first failure (the PDOs saved before it
    /// stay saved, the failed one is left invalid on the node as the sequence leaves it).
    pub fn save(&self, set: &mut PdoSet) -> Result<(), Error> {
        let port = Port::Blocking(&self.node);
        port.run(save_set(port, Direction::Transmit, set))
    }
}

/// A node's receive PDOs ([`Node::rpdo`]).
#[derive(Debug, Clone)]
pub struct Rpdos {
    node: Node,
}

impl Rpdos {
    /// Reads every RPDO's parameters by SDO (the PDOs the node's dictionary lists; without a
    /// dictionary RPDO1..4, those that exist). RPDOs the master transmits follow the COB-ID
    /// and mapping read.
    pub fn read(&self) -> Result<PdoSet, Error> {
        let port = Port::Blocking(&self.node);
        port.run(read_set(port, Direction::Receive))
    }

    /// Writes the RPDOs changed since they were read (as [`Tpdos::save`]); RPDOs the master
    /// transmits follow the new COB-ID and mapping.
    pub fn save(&self, set: &mut PdoSet) -> Result<(), Error> {
        let port = Port::Blocking(&self.node);
        port.run(save_set(port, Direction::Receive, set))
    }

    /// Transmits the node's RPDO `pdo` (its COB-ID and mapping, from [`read`](Self::read))
    /// from the master as `how` says, until [`RpdoSender::stop`]. Mapped values start at zero;
    /// set them through the returned sender. Starting an RPDO that is being transmitted
    /// replaces its transmission parameters. The master's engine holds four transmitted RPDOs
    /// per node.
    pub fn start(&self, pdo: &PdoParameters, how: Transmission) -> Result<RpdoSender, Error> {
        let sender = self.engage(pdo, how)?;
        self.node.net.flush()?;
        Ok(sender)
    }

    /// [`start`](Self::start) without sending: the RPDO is in the master's engine, its first
    /// frame queued.
    fn engage(&self, pdo: &PdoParameters, how: Transmission) -> Result<RpdoSender, Error> {
        if pdo.direction != Direction::Receive {
            return Err(pdo.error("the master transmits a node's RPDOs, not its TPDOs".into()));
        }
        if !pdo.is_enabled() {
            return Err(pdo.error("the PDO is not valid on the node (COB-ID bit 31)".into()));
        }
        let mapping = pdo
            .mapping_lenient()
            .ok_or_else(|| pdo.error("the mapping does not fit a PDO".into()))?;
        if mapping.is_empty() {
            return Err(pdo.error("nothing is mapped".into()));
        }
        let comm = CommParams {
            cob_id: pdo.comm.cob_id,
            transmission_type: how.transmission_type,
            inhibit_time: inhibit_units(how.inhibit_time).map_err(|m| pdo.error(m))?,
            event_timer: event_millis(how.event_timer).map_err(|m| pdo.error(m))?,
            sync_start: 0,
        };
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        core.start_rpdo(self.node.id, pdo.number, PdoConfig::new(comm, mapping))
            .map_err(|e| pdo.error(e.to_string()))?;
        Ok(RpdoSender {
            node: self.node.clone(),
            number: pdo.number,
        })
    }
}

/// How the master transmits a node's RPDO: the transmission type, inhibit time and event timer
/// of the master's own transmit PDO (CiA 301 §7.2.2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transmission {
    /// 254/255: on change (and on the event timer); 0: on the SYNC after a change; 1..=240:
    /// every n-th SYNC.
    pub transmission_type: TransmissionType,
    /// Least time between two frames (event-driven types; a multiple of 100 µs).
    pub inhibit_time: Duration,
    /// A frame at least this often, changed or not (event-driven types; whole ms; zero = off).
    pub event_timer: Duration,
}

impl Transmission {
    /// On every change of a mapped value (type 255).
    pub const fn on_change() -> Self {
        Self {
            transmission_type: TransmissionType::EventProfile,
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// Every `period` (type 255 with an event timer), and on change.
    pub fn cyclic(period: impl Into<Duration>) -> Self {
        Self::on_change().with_event_timer(period)
    }

    /// After every SYNC the master produces (type 1).
    pub const fn on_sync() -> Self {
        Self::every_nth_sync(1)
    }

    /// After every `n`-th SYNC (types 1..=240; `n` is clamped to that range).
    pub const fn every_nth_sync(n: u8) -> Self {
        let n = if n == 0 {
            1
        } else if n > 240 {
            240
        } else {
            n
        };
        Self {
            transmission_type: TransmissionType::SyncCyclic(n),
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// After the SYNC that follows a change (type 0).
    pub const fn on_sync_after_change() -> Self {
        Self {
            transmission_type: TransmissionType::SyncAcyclic,
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// The same with an inhibit time.
    pub fn with_inhibit_time(mut self, d: impl Into<Duration>) -> Self {
        self.inhibit_time = d.into();
        self
    }

    /// The same with an event timer.
    pub fn with_event_timer(mut self, d: impl Into<Duration>) -> Self {
        self.event_timer = d.into();
        self
    }
}

/// The application's side of an RPDO the master transmits ([`Rpdos::start`]): set mapped
/// values, trigger, stop. Dropping it does not stop the transmission.
#[derive(Debug, Clone)]
pub struct RpdoSender {
    node: Node,
    number: u16,
}

impl RpdoSender {
    /// The node.
    pub fn node(&self) -> NodeId {
        self.node.id
    }

    /// The RPDO number (1-based).
    pub fn number(&self) -> u16 {
        self.number
    }

    /// Sets one mapped value, by name or address, converted to the object's type in the node's
    /// dictionary (without one: an integer, float or bytes of the mapped length). An
    /// event-driven RPDO goes out now if the value changed (or when its inhibit time has
    /// passed); a synchronous one at its SYNC.
    pub fn set<'k>(
        &self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(), Error> {
        self.set_many([(key, value)])
    }

    /// Sets several mapped values at once: one frame carries them all.
    pub fn set_many<'k, K, V>(&self, values: impl IntoIterator<Item = (K, V)>) -> Result<(), Error>
    where
        K: Into<ObjectKey<'k>>,
        V: Into<WriteValue>,
    {
        self.stage(values)?;
        self.node.net.flush()
    }

    /// Gives the engine the new values of [`set_many`](Self::set_many); the frames they cause
    /// are queued, not sent.
    fn stage<'k, K, V>(&self, values: impl IntoIterator<Item = (K, V)>) -> Result<(), Error>
    where
        K: Into<ObjectKey<'k>>,
        V: Into<WriteValue>,
    {
        let od = self.node.dictionary();
        let mut encoded = Vec::new();
        for (key, value) in values {
            let addr = self.node.sdo().resolve(key)?;
            // The mapping as the engine has it now (a saved RPDO may have changed it).
            let bits = match self
                .node
                .net
                .core()
                .rpdo_bits(self.node.id, self.number, addr)
            {
                None => return Err(self.stopped()),
                Some(Err(())) => {
                    return Err(Error::Value {
                        node: self.node.id,
                        entry: addr,
                        message: format!("not mapped in RPDO{}", self.number),
                    });
                }
                Some(Ok(bits)) => bits,
            };
            let bytes = encode(od.as_deref(), addr, bits, value.into()).map_err(|message| {
                Error::Value {
                    node: self.node.id,
                    entry: addr,
                    message,
                }
            })?;
            encoded.push((addr, bytes));
        }
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        core.set_rpdo_values(self.node.id, &encoded);
        Ok(())
    }

    /// Sends the RPDO now (event-driven: after its inhibit time; type 0: at the next SYNC),
    /// changed or not.
    pub fn trigger(&self) -> Result<(), Error> {
        self.queue_trigger()?;
        self.node.net.flush()
    }

    fn queue_trigger(&self) -> Result<(), Error> {
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        if core.trigger_rpdo(self.node.id, self.number) {
            Ok(())
        } else {
            Err(self.stopped())
        }
    }

    /// Stops transmitting the RPDO.
    pub fn stop(&self) -> Result<(), Error> {
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        if !core.stop_rpdo(self.node.id, self.number) {
            return Err(self.stopped());
        }
        Ok(())
    }

    fn stopped(&self) -> Error {
        Error::InvalidRequest(format!(
            "node {}: RPDO{} is not being transmitted",
            self.node.id, self.number
        ))
    }
}

/// `value` as the little-endian bytes of a mapped object of `bits` bits.
fn encode(
    od: Option<&ObjectDictionary>,
    addr: ObjectAddress,
    bits: u8,
    value: WriteValue,
) -> Result<Vec<u8>, String> {
    let len = usize::from(bits).div_ceil(8);
    if let Some(od) = od
        && let Some(sub) = od.sub(addr.index, addr.sub_index)
    {
        let typed = crate::typed::convert(value, sub.data_type).map_err(|why| {
            let t = sub.data_type;
            let t = t
                .name()
                .map_or_else(|| format!("data type {:#06x}", t.code()), str::to_string);
            format!("{} is {t}: {why}", crate::typed::object_name(od, addr))
        })?;
        let mut bytes = typed.to_le_bytes();
        if bytes.len() > len && bytes[len..].iter().any(|b| *b != 0) {
            return Err(format!("{typed:?} does not fit the {bits} mapped bits"));
        }
        bytes.resize(len, 0);
        return Ok(bytes);
    }
    // No type known: by the mapped length.
    let bytes = match value {
        WriteValue::Integer(v) => {
            let (lo, hi) = (-(1i128 << (bits - 1)), (1i128 << bits) - 1);
            if !(lo..=hi).contains(&v) {
                return Err(format!("{v} does not fit {bits} bits"));
            }
            (v as u64).to_le_bytes()[..len.min(8)].to_vec()
        }
        WriteValue::Float(f) if bits == 32 => (f as f32).to_le_bytes().to_vec(),
        WriteValue::Float(f) if bits == 64 => f.to_le_bytes().to_vec(),
        WriteValue::Float(f) => return Err(format!("a float ({f}) needs 32 or 64 mapped bits")),
        WriteValue::Bytes(b) if b.len() == len => b,
        WriteValue::Bytes(b) => return Err(format!("{} bytes given, {len} mapped", b.len())),
        WriteValue::Value(v) => {
            let b = v.to_le_bytes();
            if b.len() != len {
                return Err(format!("{} bytes given, {len} mapped", b.len()));
            }
            b
        }
        other => {
            return Err(format!(
                "{other:?} cannot be sent without the node's dictionary"
            ));
        }
    };
    Ok(bytes)
}

/// The master follows what the node holds for `p`: a TPDO is decoded with it, a transmitted
/// RPDO uses its COB-ID and mapping.
fn follow(node: &Node, p: &PdoParameters) {
    let Some(mapping) = p.mapping_lenient() else {
        return;
    };
    let mut core = node.net.core();
    match p.direction {
        Direction::Transmit => {
            if let Ok(number) = u8::try_from(p.number) {
                core.mirror_tpdo(node.id, number, PdoConfig::new(p.comm, mapping));
            }
        }
        Direction::Receive => {
            let _ = core.retarget_rpdo(node.id, p.number, p.comm, mapping);
        }
    }
}

/// How the PDO services reach a node's objects: by the blocking SDO calls, or by their async
/// twins. The services are written once, as async functions over a port; with the blocking
/// port every await is ready at once, so [`Port::run`] completes them in one poll.
#[derive(Clone, Copy)]
enum Port<'a> {
    Blocking(&'a Node),
    #[cfg(feature = "tokio")]
    Async(&'a Node),
}

impl Port<'_> {
    fn node(&self) -> &Node {
        match self {
            Port::Blocking(node) => node,
            #[cfg(feature = "tokio")]
            Port::Async(node) => node,
        }
    }

    async fn read(&self, addr: ObjectAddress) -> Result<Vec<u8>, Error> {
        match self {
            Port::Blocking(node) => node.sdo().read(addr),
            #[cfg(feature = "tokio")]
            Port::Async(node) => node.sdo().read_async(addr).await,
        }
    }

    async fn write(&self, addr: ObjectAddress, bytes: &[u8]) -> Result<(), Error> {
        match self {
            Port::Blocking(node) => node.sdo().write(addr, bytes),
            #[cfg(feature = "tokio")]
            Port::Async(node) => node.sdo().write_async(addr, bytes).await,
        }
    }

    async fn read_u32(&self, index: u16, sub: u8) -> Result<u32, Error> {
        self.read(ObjectAddress::new(index, sub))
            .await
            .map(|b| le_u32(&b))
    }

    /// An optional sub-index: per the dictionary when there is one, else as the node answers.
    async fn read_optional(
        &self,
        od: Option<&ObjectDictionary>,
        index: u16,
        sub: u8,
    ) -> Result<Option<u32>, Error> {
        if let Some(od) = od
            && od.sub(index, sub).is_none()
        {
            return Ok(None);
        }
        match self.read_u32(index, sub).await {
            Ok(v) => Ok(Some(v)),
            Err(e) if absent(&e) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// Completes a service on the blocking port: one poll, every SDO call in it has blocked
    /// until done.
    fn run<T>(self, service: impl Future<Output = Result<T, Error>>) -> Result<T, Error> {
        let mut service = std::pin::pin!(service);
        let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
        match service.as_mut().poll(&mut cx) {
            std::task::Poll::Ready(r) => r,
            // Only the async port's calls can be pending, and `run` is for the blocking one.
            std::task::Poll::Pending => Err(Error::Driver(
                "a PDO service on the blocking port did not complete".into(),
            )),
        }
    }
}

/// The async twins of the PDO services (`tokio` feature; see [`crate::asynch`]). Dropping one
/// of these futures cancels the SDO transfer it is in; a `save` dropped half-way leaves the PDO
/// as far as the sequence got (invalid on the node until saved again).
impl Node {
    /// Remaps PDO `number` (1-based) of `direction` on the node by SDO, the CiA 301 way
    /// (disable, clear mapping, write entries, set count, set parameters, enable; the plan comes
    /// from `canola_pdo::remap`; the same sequence `node.tpdo().save()` uses). After a TPDO
    /// remap the master decodes that TPDO from its COB-ID with the new mapping; after an RPDO
    /// remap an RPDO the master transmits ([`Rpdos::start`](crate::Rpdos::start)) follows.
    pub fn remap_pdo(
        &self,
        direction: canola_pdo::Direction,
        number: u16,
        comm: canola_pdo::CommParams,
        mapping: canola_pdo::Mapping,
    ) -> Result<(), Error> {
        let n = number.saturating_sub(1);
        let mut remote = canola_pdo::RemoteObjects::dynamic(direction);
        // With a dictionary, write only the sub-indices the node has.
        if let Some(od) = self.dictionary() {
            let ci = direction.comm_index(n);
            let has = |sub| od.sub(ci, sub).is_some();
            remote.has_inhibit_time = has(3);
            remote.has_event_timer = has(5);
            remote.has_sync_start = has(6);
            // Dynamic mapping (CiA 301 §7.4.8.3): sub 0 of the mapping object is writable.
            remote.mapping_writable = od
                .sub(direction.mapping_index(n), 0)
                .is_none_or(|s| s.access.is_writable());
        }
        configure(self, direction, n, &comm, mapping, &remote)
    }
}

#[cfg(feature = "tokio")]
mod asynch_twins {
    use super::{
        Direction, Error, ObjectKey, PdoParameters, PdoSet, Port, RpdoSender, Rpdos, Tpdos,
        Transmission, WriteValue, read_set, save_set,
    };
    use crate::asynch::drive;

    impl Tpdos {
        /// Reads every TPDO's parameters (async [`read`](Tpdos::read)).
        pub async fn read_async(&self) -> Result<PdoSet, Error> {
            drive::catch_up(&self.node.net)?;
            read_set(Port::Async(&self.node), Direction::Transmit).await
        }

        /// Writes the TPDOs changed since they were read (async [`save`](Tpdos::save)).
        pub async fn save_async(&self, set: &mut PdoSet) -> Result<(), Error> {
            drive::catch_up(&self.node.net)?;
            save_set(Port::Async(&self.node), Direction::Transmit, set).await
        }
    }

    impl Rpdos {
        /// Reads every RPDO's parameters (async [`read`](Rpdos::read)).
        pub async fn read_async(&self) -> Result<PdoSet, Error> {
            drive::catch_up(&self.node.net)?;
            read_set(Port::Async(&self.node), Direction::Receive).await
        }

        /// Writes the RPDOs changed since they were read (async [`save`](Rpdos::save)).
        pub async fn save_async(&self, set: &mut PdoSet) -> Result<(), Error> {
            drive::catch_up(&self.node.net)?;
            save_set(Port::Async(&self.node), Direction::Receive, set).await
        }

        /// Transmits the node's RPDO `pdo` from the master (async [`start`](Rpdos::start)).
        pub async fn start_async(
            &self,
            pdo: &PdoParameters,
            how: Transmission,
        ) -> Result<RpdoSender, Error> {
            drive::catch_up(&self.node.net)?;
            let sender = self.engage(pdo, how)?;
            drive::flush(&self.node.net).await?;
            Ok(sender)
        }
    }

    impl RpdoSender {
        /// Sets one mapped value (async [`set`](RpdoSender::set)).
        pub async fn set_async<'k>(
            &self,
            key: impl Into<ObjectKey<'k>>,
            value: impl Into<WriteValue>,
        ) -> Result<(), Error> {
            self.set_many_async([(key, value)]).await
        }

        /// Sets several mapped values at once (async [`set_many`](RpdoSender::set_many)).
        pub async fn set_many_async<'k, K, V>(
            &self,
            values: impl IntoIterator<Item = (K, V)>,
        ) -> Result<(), Error>
        where
            K: Into<ObjectKey<'k>>,
            V: Into<WriteValue>,
        {
            drive::catch_up(&self.node.net)?;
            self.stage(values)?;
            drive::flush(&self.node.net).await
        }

        /// Sends the RPDO now (async [`trigger`](RpdoSender::trigger)).
        pub async fn trigger_async(&self) -> Result<(), Error> {
            drive::catch_up(&self.node.net)?;
            self.queue_trigger()?;
            drive::flush(&self.node.net).await
        }
    }
}

/// Whether an SDO error says the object or sub-index is not there.
fn absent(e: &Error) -> bool {
    matches!(
        e.server_abort(),
        Some(AbortCode::OBJECT_DOES_NOT_EXIST | AbortCode::SUBINDEX_DOES_NOT_EXIST)
    )
}

fn le_u32(bytes: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    let n = bytes.len().min(4);
    b[..n].copy_from_slice(&bytes[..n]);
    u32::from_le_bytes(b)
}

async fn read_set(port: Port<'_>, direction: Direction) -> Result<PdoSet, Error> {
    let node = port.node();
    let od = node.dictionary();
    let numbers: Vec<u16> = match od.as_deref() {
        Some(od) => (0..canola_pdo::comm::MAX_PDOS_PER_DIRECTION)
            .filter(|n| {
                od.get(direction.comm_index(*n)).is_some()
                    && od.get(direction.mapping_index(*n)).is_some()
            })
            .collect(),
        None => (0..4).collect(),
    };
    let mut pdos = Vec::new();
    for n in numbers {
        if let Some(p) = read_pdo(port, od.clone(), direction, n).await? {
            pdos.push(p);
        }
    }
    for p in &pdos {
        follow(node, p);
    }
    Ok(PdoSet { direction, pdos })
}

/// Reads PDO `n` (0-based); `None` when the node does not have it.
async fn read_pdo(
    port: Port<'_>,
    od: Option<Arc<ObjectDictionary>>,
    direction: Direction,
    n: u16,
) -> Result<Option<PdoParameters>, Error> {
    let (ci, mi) = (direction.comm_index(n), direction.mapping_index(n));
    let cob_id = match port.read_u32(ci, 1).await {
        Ok(v) => PdoCobId(v),
        Err(e) if od.is_none() && absent(&e) => return Ok(None),
        Err(e) => return Err(e),
    };
    let transmission_type = TransmissionType::from_code(port.read_u32(ci, 2).await? as u8);
    let inhibit = port.read_optional(od.as_deref(), ci, 3).await?;
    let event = port.read_optional(od.as_deref(), ci, 5).await?;
    let sync = port.read_optional(od.as_deref(), ci, 6).await?;
    let count = port.read_u32(mi, 0).await?;
    let mut entries = Vec::new();
    let mpdo = if count > 64 {
        Some(count as u8)
    } else {
        for sub in 1..=count as u8 {
            entries.push(port.read_u32(mi, sub).await?);
        }
        None
    };
    let comm = CommParams {
        cob_id,
        transmission_type,
        inhibit_time: inhibit.unwrap_or(0) as u16,
        event_timer: event.unwrap_or(0) as u16,
        sync_start: sync.unwrap_or(0) as u8,
    };
    let mapping_writable = od
        .as_deref()
        .and_then(|od| od.sub(mi, 0))
        .is_none_or(|s| s.access.is_writable());
    let mapped = entries
        .iter()
        .map(|&raw| {
            let e = MappingEntry(raw);
            MappedVariable {
                addr: e.addr(),
                bits: e.bits(),
                name: od.as_deref().and_then(|od| name_of(od, e.addr())),
            }
        })
        .collect();
    Ok(Some(PdoParameters {
        direction,
        number: n + 1,
        comm,
        mapped,
        present: Present {
            inhibit_time: inhibit.is_some(),
            event_timer: event.is_some(),
            sync_start: sync.is_some(),
            mapping_writable,
        },
        mpdo,
        saved: (comm, entries),
        node: port.node().id,
        od,
    }))
}

async fn save_set(port: Port<'_>, direction: Direction, set: &mut PdoSet) -> Result<(), Error> {
    let node = port.node();
    if set.direction != direction {
        return Err(Error::InvalidRequest(format!(
            "a set of {}s cannot be saved as {}s",
            kind_name(set.direction),
            kind_name(direction)
        )));
    }
    for p in &set.pdos {
        if p.node != node.id {
            return Err(Error::InvalidRequest(format!(
                "these PDO parameters were read from node {}, not node {}",
                p.node, node.id
            )));
        }
    }
    for p in &mut set.pdos {
        if !p.is_changed() {
            continue;
        }
        if p.mpdo.is_some() {
            return Err(p.error("an MPDO mapping is not saved by this API".into()));
        }
        // The mapping is checked before anything is sent.
        let mapping = p.mapping()?;
        let remote = RemoteObjects {
            mapping_writable: p.present.mapping_writable,
            current_mapping: Some(&p.saved.1),
            has_inhibit_time: p.present.inhibit_time,
            has_event_timer: p.present.event_timer,
            has_sync_start: p.present.sync_start,
        };
        configure_with(port, direction, p.number - 1, &p.comm, mapping, &remote).await?;
        p.saved = (p.comm, p.raw_entries().collect());
    }
    Ok(())
}

/// Gives PDO `n` (0-based) of the node `comm` and `mapping` by SDO, the CiA 301 way (the plan
/// from `canola_pdo::remap`), then makes the master follow: a TPDO is decoded with the new
/// mapping, a transmitted RPDO uses the new COB-ID and mapping. [`Node::remap_pdo`] and
/// `save()` both come here.
pub(crate) fn configure(
    node: &Node,
    direction: Direction,
    n: u16,
    comm: &CommParams,
    mapping: Mapping,
    remote: &RemoteObjects<'_>,
) -> Result<(), Error> {
    Port::Blocking(node).run(configure_with(
        Port::Blocking(node),
        direction,
        n,
        comm,
        mapping,
        remote,
    ))
}

async fn configure_with(
    port: Port<'_>,
    direction: Direction,
    n: u16,
    comm: &CommParams,
    mapping: Mapping,
    remote: &RemoteObjects<'_>,
) -> Result<(), Error> {
    let node = port.node();
    let steps =
        canola_pdo::remap(direction, n, comm, &mapping, remote).map_err(|e| Error::Value {
            node: node.id,
            entry: ObjectAddress::new(direction.comm_index(n), 0),
            message: e.to_string(),
        })?;
    for step in &steps {
        port.write(ObjectAddress::new(step.index, step.subindex), step.value())
            .await?;
    }
    let mapping = match node.dictionary() {
        Some(od) => crate::machine::pdo::typed_mapping(&od, node.id, direction, mapping),
        None => mapping,
    };
    let mut core = node.net.core();
    match direction {
        Direction::Transmit => {
            if let Ok(number) = u8::try_from(n + 1) {
                core.mirror_tpdo(node.id, number, PdoConfig::new(*comm, mapping));
            }
        }
        Direction::Receive => {
            let _ = core.retarget_rpdo(node.id, n + 1, *comm, mapping);
        }
    }
    Ok(())
}
