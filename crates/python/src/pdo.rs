//! `node.tpdo` / `node.rpdo` (python-canopen's `TPDO` / `RPDO`, here both `canola.PdoBase`),
//! their maps (`canola.PdoMap`) and mapped objects (`canola.PdoVariable`).
//!
//! Everything on the bus is the facade's: `read()` is `Tpdos::read` / `Rpdos::read`, `save()`
//! is their `save` (the CiA 301 remap sequence, only for the PDOs changed), received TPDOs are
//! decoded by the master (`Network::on_pdo`), and an RPDO is sent by the master's PDO engine
//! (`Rpdos::start`, `RpdoSender`). This module keeps what python-canopen's objects hold between
//! calls: the parameters read, the latest reception of each TPDO, the values given to each
//! RPDO, and the Python callbacks.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, Weak};

use canola::pdo::{Direction, TransmissionType};
use canola::{
    Duration, Instant, ObjectAddress, Operation, PdoCallbackId, PdoParameters, PdoSet, RpdoSender,
    Transmission, Value, WriteValue,
};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::{PyKeyError, PyNotImplementedError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};

use crate::network::lock;
use crate::node::NodeLink;
use crate::sdo::{value_to_py, write_value};
use crate::{dispatch, seconds, to_py_err, wait};

/// The latest reception of one TPDO.
struct Received {
    data: Vec<u8>,
    values: Vec<(ObjectAddress, Value)>,
    at: Instant,
    /// Receptions so far (a wait looks for a new one).
    count: u64,
}

/// What every handle of one node's TPDOs or RPDOs shares.
pub(crate) struct PdoShared {
    link: Arc<NodeLink>,
    direction: Direction,
    /// The parameters as last read or saved (`None` before `read()`).
    set: Mutex<Option<PdoSet>>,
    /// TPDOs: the latest reception of each, by number.
    received: Mutex<HashMap<u16, Received>>,
    /// TPDOs: the Python callbacks of each, by number.
    callbacks: Mutex<HashMap<u16, Vec<Py<PyAny>>>>,
    /// TPDOs: the facade callback that fills `received` (added by the first read or save on
    /// each connection of the network, with the connection's generation). It stays with the
    /// network: it holds this only weakly, and removing it when this goes could happen inside
    /// it (the network locked), which would wait for itself.
    subscription: Mutex<Option<(u64, PdoCallbackId)>>,
    /// RPDOs: the values given to each (`rpdo[1]["x"].raw = v`), by number, in order.
    values: Mutex<HashMap<u16, Vec<(ObjectAddress, WriteValue)>>>,
    /// RPDOs: each one the master transmits, with the values last handed to it and whether it
    /// is periodic (`start()`) rather than sent on `transmit()` only.
    senders: Mutex<HashMap<u16, Sender>>,
    /// RPDOs: the period of `start()`, by number.
    periods: Mutex<HashMap<u16, f64>>,
}

struct Sender {
    sender: RpdoSender,
    sent: Option<Vec<(ObjectAddress, WriteValue)>>,
    periodic: bool,
}

/// PDO number 1..=512 from python-canopen's keys: the number, or the mapping object's index.
fn pdo_number(direction: Direction, key: i64) -> Option<u16> {
    let base = i64::from(direction.mapping_index(0));
    let n = if (1..=512).contains(&key) {
        key
    } else if (base..base + 512).contains(&key) {
        key - base + 1
    } else {
        return None;
    };
    u16::try_from(n).ok()
}

fn kind(direction: Direction) -> &'static str {
    match direction {
        Direction::Transmit => "TPDO",
        Direction::Receive => "RPDO",
    }
}

/// python-canopen's name of a mapped object: the object's name for a VAR,
/// `"Object.Sub-object"` for an entry of an ARRAY or RECORD.
fn py_name(od: Option<&canola::ObjectDictionary>, addr: ObjectAddress) -> Option<String> {
    let obj = od?.get(addr.index)?;
    Some(match obj.sub(addr.sub_index) {
        Some(sub) if !obj.is_simple() => format!("{}.{}", obj.name, sub.name),
        _ => obj.name.to_string(),
    })
}

fn secs(at: Instant) -> f64 {
    at.as_micros() as f64 / 1e6
}

impl PdoShared {
    pub(crate) fn new(link: Arc<NodeLink>, direction: Direction) -> Arc<Self> {
        Arc::new(Self {
            link,
            direction,
            set: Mutex::new(None),
            received: Mutex::new(HashMap::new()),
            callbacks: Mutex::new(HashMap::new()),
            subscription: Mutex::new(None),
            values: Mutex::new(HashMap::new()),
            senders: Mutex::new(HashMap::new()),
            periods: Mutex::new(HashMap::new()),
        })
    }

    /// Runs `f` on the parameters of PDO `number` as read.
    fn with<R>(&self, number: u16, f: impl FnOnce(&mut PdoParameters) -> R) -> PyResult<R> {
        let mut set = lock(&self.set);
        let set = set.as_mut().ok_or_else(|| {
            PyValueError::new_err(format!(
                "node {}: the {}s are not read yet: call {}.read() first",
                self.link.id,
                kind(self.direction),
                kind(self.direction).to_lowercase()
            ))
        })?;
        let p = set.get_mut(number).ok_or_else(|| {
            PyKeyError::new_err(format!(
                "node {} has no {}{number}",
                self.link.id,
                kind(self.direction)
            ))
        })?;
        Ok(f(p))
    }

    /// Follows the node's TPDOs from now on (once): each reception is kept and queues the
    /// Python callbacks of its PDO.
    fn subscribe(self: &Arc<Self>) -> PyResult<()> {
        if self.direction != Direction::Transmit {
            return Ok(());
        }
        let mut sub = lock(&self.subscription);
        let generation = self.link.generation();
        if sub.is_some_and(|(g, _)| g == generation) {
            return Ok(());
        }
        let net = self.link.node()?.network().clone();
        let me: Weak<Self> = Arc::downgrade(self);
        let node = self.link.id;
        let id = net.on_pdo(move |p| {
            if p.node != node {
                return;
            }
            let Some(me) = me.upgrade() else { return };
            let number = u16::from(p.number);
            {
                let mut received = lock(&me.received);
                let count = received.get(&number).map_or(0, |r| r.count) + 1;
                received.insert(
                    number,
                    Received {
                        data: p.data.to_vec(),
                        values: p.values.to_vec(),
                        at: p.at,
                        count,
                    },
                );
            }
            if lock(&me.callbacks)
                .get(&number)
                .is_some_and(|c| !c.is_empty())
            {
                dispatch::push(Box::new(move |py| me.run_callbacks(py, number)));
            }
        });
        *sub = Some((generation, id));
        Ok(())
    }

    fn run_callbacks(self: &Arc<Self>, py: Python<'_>, number: u16) {
        let callbacks: Vec<Py<PyAny>> = lock(&self.callbacks)
            .get(&number)
            .map(|c| c.iter().map(|c| c.clone_ref(py)).collect())
            .unwrap_or_default();
        let Ok(map) = Bound::new(
            py,
            PdoMap {
                shared: self.clone(),
                number,
            },
        ) else {
            return;
        };
        for cb in &callbacks {
            dispatch::call(py, cb, map.as_any());
        }
    }

    /// Reads the direction's parameters from the node.
    fn read(self: &Arc<Self>, py: Python<'_>) -> PyResult<()> {
        let node = self.link.node()?;
        let op = match self.direction {
            Direction::Transmit => node.tpdo().read(),
            Direction::Receive => node.rpdo().read(),
        };
        let set = wait(py, op)?;
        *lock(&self.set) = Some(set);
        self.subscribe()
    }

    /// Saves the PDOs changed since they were read.
    fn save(self: &Arc<Self>, py: Python<'_>) -> PyResult<()> {
        let Some(mut set) = lock(&self.set).clone() else {
            return self.with(1, |_| ()).map(drop);
        };
        let node = self.link.node()?;
        let direction = self.direction;
        let op = Operation::new(async move {
            match direction {
                Direction::Transmit => node.tpdo().save(&mut set).await?,
                Direction::Receive => node.rpdo().save(&mut set).await?,
            }
            Ok(set)
        });
        let saved = wait(py, op)?;
        *lock(&self.set) = Some(saved);
        self.subscribe()
    }

    fn numbers(&self) -> Vec<u16> {
        lock(&self.set)
            .as_ref()
            .map(|s| s.iter().map(PdoParameters::number).collect())
            .unwrap_or_default()
    }

    /// The RPDO `number` started in the master's engine (event-driven unless running
    /// periodically already).
    fn sender<R>(
        &self,
        number: u16,
        f: impl FnOnce(&mut Sender) -> Result<R, canola::Error>,
    ) -> PyResult<R> {
        let mut senders = lock(&self.senders);
        if let std::collections::hash_map::Entry::Vacant(slot) = senders.entry(number) {
            let params = self.with(number, |p| p.clone())?;
            let sender = self
                .link
                .node()?
                .rpdo()
                .start(&params, Transmission::on_change())
                .map_err(to_py_err)?;
            slot.insert(Sender {
                sender,
                sent: None,
                periodic: false,
            });
        }
        let s = senders.get_mut(&number).expect("inserted above");
        f(s).map_err(to_py_err)
    }

    /// The values given to RPDO `number`'s objects that it maps now (a remap may have dropped
    /// some).
    fn values(&self, number: u16) -> Vec<(ObjectAddress, WriteValue)> {
        let mapped: Vec<ObjectAddress> = self
            .with(number, |p| p.mapped.iter().map(|m| m.addr).collect())
            .unwrap_or_default();
        lock(&self.values)
            .get(&number)
            .map(|vs| {
                vs.iter()
                    .filter(|(a, _)| mapped.contains(a))
                    .cloned()
                    .collect()
            })
            .unwrap_or_default()
    }
}

/// Hands `values` to a started RPDO: one frame when any differs from what it sent last
/// (the engine sends an event-driven RPDO on a change), else a frame by trigger when `force`.
fn hand_over(
    s: &mut Sender,
    values: Vec<(ObjectAddress, WriteValue)>,
    force: bool,
) -> Result<(), canola::Error> {
    if s.sent.as_ref() != Some(&values) {
        s.sender
            .set_many(values.iter().map(|(a, v)| (*a, v.clone())))?;
        s.sent = Some(values);
    } else if force {
        s.sender.trigger()?;
    }
    Ok(())
}

/// A node's TPDOs or RPDOs (`node.tpdo`, `node.rpdo`): maps by number, `read()`, `save()`.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct PdoBase {
    shared: Arc<PdoShared>,
}

impl PdoBase {
    pub(crate) fn new(link: Arc<NodeLink>, direction: Direction) -> Self {
        Self {
            shared: PdoShared::new(link, direction),
        }
    }
}

#[pymethods]
impl PdoBase {
    /// Reads every PDO's parameters (communication and mapping) from the node by SDO. After
    /// it, the master decodes the TPDOs the node sends.
    #[pyo3(signature = (from_od = false))]
    fn read(&self, py: Python<'_>, from_od: bool) -> PyResult<()> {
        if from_od {
            return Err(PyNotImplementedError::new_err(
                "read(from_od=True) is not supported: read the PDOs from the node",
            ));
        }
        self.shared.read(py)
    }

    /// Writes the PDOs changed since they were read, each by the CiA 301 sequence (invalidate,
    /// clear the mapping, write the entries, the count and the parameters, validate).
    fn save(&self, py: Python<'_>) -> PyResult<()> {
        self.shared.save(py)
    }

    /// The maps (this object: `node.tpdo.map[1]` is `node.tpdo[1]`).
    #[getter]
    fn map(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    /// A map by number (1..=512) or mapping index (0x1A00.. / 0x1600..), or a mapped object by
    /// name, searched in every map.
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let direction = self.shared.direction;
        if let Ok(name) = key.cast::<PyString>() {
            let name: String = name.extract()?;
            for number in self.shared.numbers() {
                let map = PdoMap {
                    shared: self.shared.clone(),
                    number,
                };
                if let Ok(var) = map.variable(&name) {
                    return var.into_py_any(py);
                }
            }
            return Err(PyKeyError::new_err(format!(
                "PDO: {name} was not found in any map"
            )));
        }
        let key: i64 = key.extract()?;
        let number = pdo_number(direction, key)
            .ok_or_else(|| PyKeyError::new_err(format!("no {} {key}", kind(direction))))?;
        PdoMap {
            shared: self.shared.clone(),
            number,
        }
        .into_py_any(py)
    }

    /// The PDO numbers (after `read()`).
    fn keys(&self) -> Vec<u16> {
        self.shared.numbers()
    }

    fn __len__(&self) -> usize {
        self.shared.numbers().len()
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let keys = pyo3::types::PyList::new(py, self.shared.numbers())?;
        Ok(keys.try_iter()?.into_any().unbind())
    }

    fn __contains__(&self, number: i64) -> bool {
        pdo_number(self.shared.direction, number)
            .is_some_and(|n| self.shared.numbers().contains(&n))
    }

    /// Stops every RPDO the master transmits.
    fn stop(&self) -> PyResult<()> {
        let senders: Vec<Sender> = lock(&self.shared.senders).drain().map(|(_, s)| s).collect();
        for s in senders {
            // A stopped RPDO (its node reset, say) is stopped already.
            let _ = s.sender.stop();
        }
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.PdoBase {}s of node {}>",
            kind(self.shared.direction),
            self.shared.link.id
        )
    }
}

/// One PDO of a node (python-canopen's `PdoMap`): parameters, mapped objects, values.
#[pyclass(module = "canola", frozen)]
pub(crate) struct PdoMap {
    shared: Arc<PdoShared>,
    number: u16,
}

impl PdoMap {
    fn variables(&self) -> PyResult<Vec<PdoVariable>> {
        self.shared.with(self.number, |p| {
            p.mapped
                .iter()
                .map(|m| PdoVariable {
                    shared: self.shared.clone(),
                    number: self.number,
                    addr: m.addr,
                    bits: m.bits,
                    name: py_name(self.shared.link.od.as_deref(), m.addr),
                })
                .collect()
        })
    }

    fn variable(&self, name: &str) -> PyResult<PdoVariable> {
        let vars = self.variables()?;
        let names: Vec<String> = vars.iter().map(PdoVariable::display_name).collect();
        let hex = name
            .strip_prefix("0x")
            .and_then(|h| u16::from_str_radix(h, 16).ok());
        // The dictionary's own lookup takes the other spellings ("Object / Sub", any case).
        let found = self.shared.link.od.as_deref().and_then(|od| od.find(name));
        vars.into_iter()
            .find(|v| {
                v.name.as_deref() == Some(name)
                    || found == Some(v.addr)
                    || hex == Some(v.addr.index)
            })
            .ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "{name} not found in map. Valid entries are {}",
                    names.join(", ")
                ))
            })
    }
}

#[pymethods]
impl PdoMap {
    /// The PDO number (1-based).
    #[getter]
    fn number(&self) -> u16 {
        self.number
    }

    /// The COB-ID's CAN identifier (without the valid and RTR bits). Setting it keeps them.
    #[getter]
    fn cob_id(&self) -> PyResult<u32> {
        self.shared
            .with(self.number, |p| p.comm.cob_id.0 & 0x1FFF_FFFF)
    }

    #[setter]
    fn set_cob_id(&self, cob_id: u32) -> PyResult<()> {
        let id = if cob_id <= 0x7FF {
            canola::CanId::standard(cob_id as u16)
        } else {
            canola::CanId::extended(cob_id)
        }
        .map_err(|e| PyValueError::new_err(format!("COB-ID 0x{cob_id:X}: {e}")))?;
        self.shared.with(self.number, |p| p.set_can_id(id))
    }

    /// Whether the PDO exists on the node (COB-ID bit 31 clear).
    #[getter]
    fn enabled(&self) -> PyResult<bool> {
        self.shared.with(self.number, |p| p.is_enabled())
    }

    #[setter]
    fn set_enabled(&self, enabled: bool) -> PyResult<()> {
        self.shared.with(self.number, |p| p.set_enabled(enabled))
    }

    /// Whether remote requests are allowed (COB-ID bit 30 clear).
    #[getter]
    fn rtr_allowed(&self) -> PyResult<bool> {
        self.shared.with(self.number, |p| p.rtr_allowed())
    }

    /// The transmission type (0..=255).
    #[getter]
    fn trans_type(&self) -> PyResult<u8> {
        self.shared
            .with(self.number, |p| p.transmission_type().code())
    }

    #[setter]
    fn set_trans_type(&self, t: u8) -> PyResult<()> {
        self.shared.with(self.number, |p| {
            p.set_transmission_type(TransmissionType::from_code(t))
        })
    }

    /// The inhibit time in units of 100 µs (`None` when the node has none for this PDO).
    #[getter]
    fn inhibit_time(&self) -> PyResult<Option<u16>> {
        self.shared.with(self.number, |p| {
            p.has_inhibit_time().then_some(p.comm.inhibit_time)
        })
    }

    #[setter]
    fn set_inhibit_time(&self, units: u16) -> PyResult<()> {
        self.shared
            .with(self.number, |p| {
                p.set_inhibit_time(Duration::from_micros(u64::from(units) * 100))
            })?
            .map_err(to_py_err)
    }

    /// The event timer in ms (`None` when the node has none for this PDO; 0 = off).
    #[getter]
    fn event_timer(&self) -> PyResult<Option<u16>> {
        self.shared.with(self.number, |p| {
            p.has_event_timer().then_some(p.comm.event_timer)
        })
    }

    #[setter]
    fn set_event_timer(&self, ms: u16) -> PyResult<()> {
        self.shared
            .with(self.number, |p| {
                p.set_event_timer(Duration::from_millis(u64::from(ms)))
            })?
            .map_err(to_py_err)
    }

    /// The mapped objects, in PDO order.
    #[getter]
    fn map(&self) -> PyResult<Vec<PdoVariable>> {
        self.variables()
    }

    /// The mapped length in bits.
    #[getter]
    fn length(&self) -> PyResult<u32> {
        self.shared.with(self.number, |p| {
            p.mapped.iter().map(|m| u32::from(m.bits)).sum()
        })
    }

    /// A mapped object by position (0..=7), index or name.
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        if let Ok(name) = key.cast::<PyString>() {
            return self.variable(&name.extract::<String>()?)?.into_py_any(py);
        }
        let key: i64 = key.extract()?;
        let vars = self.variables()?;
        let found = if (0..8).contains(&key) {
            vars.into_iter().nth(key as usize)
        } else {
            vars.into_iter().find(|v| i64::from(v.addr.index) == key)
        };
        found
            .ok_or_else(|| PyKeyError::new_err(format!("{key} not found in map")))?
            .into_py_any(py)
    }

    fn __len__(&self) -> PyResult<usize> {
        self.shared.with(self.number, |p| p.mapped.len())
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let vars = pyo3::types::PyList::new(py, self.variables()?)?;
        Ok(vars.try_iter()?.into_any().unbind())
    }

    /// python-canopen's name of the PDO: `TxPDO1_node5`, `RxPDO1_node5`.
    #[getter]
    fn name(&self) -> String {
        let dir = match self.shared.direction {
            Direction::Transmit => "Tx",
            Direction::Receive => "Rx",
        };
        format!("{dir}PDO{}_node{}", self.number, self.shared.link.id)
    }

    /// Removes every mapped object (`save()` writes the change).
    fn clear(&self) -> PyResult<()> {
        self.shared.with(self.number, |p| p.clear())
    }

    /// Maps one more object: by index and sub-index or by name, `length` bits (by default the
    /// object's size in the node's dictionary). `save()` writes the change.
    #[pyo3(signature = (index, subindex = None, length = None))]
    fn add_variable(
        &self,
        index: &Bound<'_, PyAny>,
        subindex: Option<&Bound<'_, PyAny>>,
        length: Option<u8>,
    ) -> PyResult<PdoVariable> {
        let od = self.shared.link.od.clone();
        let addr = if let Ok(name) = index.cast::<PyString>() {
            let mut name: String = name.extract()?;
            if let Some(sub) = subindex {
                if let Ok(s) = sub.cast::<PyString>() {
                    name = format!("{name}.{}", s.extract::<String>()?);
                } else {
                    let s: u8 = sub.extract()?;
                    let at = od
                        .as_deref()
                        .and_then(|od| od.find_object(&name).map(|o| o.index))
                        .ok_or_else(|| {
                            PyKeyError::new_err(format!("no object {name:?} in the dictionary"))
                        })?;
                    return self.add_at(ObjectAddress::new(at, s), length);
                }
            }
            od.as_deref().and_then(|od| od.find(&name)).ok_or_else(|| {
                PyKeyError::new_err(format!("no object {name:?} in the dictionary"))
            })?
        } else {
            let i: i64 = index.extract()?;
            let s: i64 = subindex.map(|s| s.extract()).transpose()?.unwrap_or(0);
            crate::sdo::address(i, s)?
        };
        self.add_at(addr, length)
    }

    /// Writes the node's PDOs changed since they were read (this one and any other changed
    /// in the same direction) by the CiA 301 sequence.
    fn save(&self, py: Python<'_>) -> PyResult<()> {
        self.shared.save(py)
    }

    /// Reads the PDO parameters from the node (those of the whole direction).
    #[pyo3(signature = (from_od = false))]
    fn read(&self, py: Python<'_>, from_od: bool) -> PyResult<()> {
        if from_od {
            return Err(PyNotImplementedError::new_err(
                "read(from_od=True) is not supported: read the PDOs from the node",
            ));
        }
        self.shared.read(py)
    }

    /// The data of the latest reception of this TPDO (empty before one, and for an RPDO).
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let received = lock(&self.shared.received);
        PyBytes::new(
            py,
            received
                .get(&self.number)
                .map_or(&[][..], |r| r.data.as_slice()),
        )
    }

    /// When the latest reception came, in seconds on the network's clock (`None` before one).
    #[getter]
    fn timestamp(&self) -> Option<f64> {
        lock(&self.shared.received)
            .get(&self.number)
            .map(|r| secs(r.at))
    }

    /// Waits for the next reception of this TPDO: its timestamp, or `None` after `timeout`
    /// seconds without one.
    #[pyo3(signature = (timeout = 10.0))]
    fn wait_for_reception(&self, py: Python<'_>, timeout: f64) -> PyResult<Option<f64>> {
        let net = self.shared.link.node()?.network().clone();
        let deadline = net.now() + seconds(timeout)?;
        let shared = self.shared.clone();
        let number = self.number;
        let count = move |s: &PdoShared| lock(&s.received).get(&number).map(|r| (r.count, r.at));
        let before = count(&shared).map_or(0, |c| c.0);
        let op = Operation::new(async move {
            loop {
                if let Some((n, at)) = count(&shared)
                    && n > before
                {
                    return Ok(Some(secs(at)));
                }
                let now = net.now();
                if now >= deadline {
                    return Ok(None);
                }
                // Look again every millisecond of bus time (a virtual clock jumps them).
                let step = (now + Duration::from_millis(1)).min(deadline);
                net.run_until(step).await?;
            }
        });
        wait(py, op)
    }

    /// Calls `callback(pdo_map)` on every reception of this TPDO (between the driving steps of
    /// a blocking call, or on a thread of this package when none runs).
    fn add_callback(&self, callback: Py<PyAny>) -> PyResult<()> {
        self.shared.subscribe()?;
        lock(&self.shared.callbacks)
            .entry(self.number)
            .or_default()
            .push(callback);
        dispatch::start_dispatcher();
        Ok(())
    }

    /// Sends this RPDO once, from the master, with the values given to its mapped objects
    /// (zero for the others).
    fn transmit(&self) -> PyResult<()> {
        self.rpdo_only()?;
        let values = self.shared.values(self.number);
        self.shared
            .sender(self.number, |s| hand_over(s, values, true))
    }

    /// Sends this RPDO every `period` seconds (whole milliseconds) from the master, and at
    /// once when a mapped value changes, until `stop()`. Without `period`, the `period` set
    /// before.
    #[pyo3(signature = (period = None))]
    fn start(&self, period: Option<f64>) -> PyResult<()> {
        self.rpdo_only()?;
        let period = period
            .or_else(|| lock(&self.shared.periods).get(&self.number).copied())
            .ok_or_else(|| {
                PyValueError::new_err("A valid transmission period has not been given")
            })?;
        let every = seconds(period)?;
        self.stop()?;
        let params = self.shared.with(self.number, |p| p.clone())?;
        let sender = self
            .shared
            .link
            .node()?
            .rpdo()
            .start(&params, Transmission::cyclic(every))
            .map_err(to_py_err)?;
        let mut s = Sender {
            sender,
            sent: None,
            periodic: true,
        };
        hand_over(&mut s, self.shared.values(self.number), false).map_err(to_py_err)?;
        lock(&self.shared.senders).insert(self.number, s);
        lock(&self.shared.periods).insert(self.number, period);
        Ok(())
    }

    /// The period in seconds of `start()` (`None` before one is given).
    #[getter]
    fn period(&self) -> Option<f64> {
        lock(&self.shared.periods).get(&self.number).copied()
    }

    #[setter]
    fn set_period(&self, period: Option<f64>) -> PyResult<()> {
        let mut periods = lock(&self.shared.periods);
        match period {
            Some(p) => {
                seconds(p)?;
                periods.insert(self.number, p);
            }
            None => {
                periods.remove(&self.number);
            }
        }
        Ok(())
    }

    /// Whether the PDO goes out regularly: a period given, or a synchronous transmission type.
    #[getter]
    fn is_periodic(&self) -> PyResult<bool> {
        if self.period().is_some() {
            return Ok(true);
        }
        self.shared
            .with(self.number, |p| p.transmission_type().is_synchronous())
    }

    /// The SYNC start value (sub 6; `None` when the node has none for this PDO).
    #[getter]
    fn sync_start_value(&self) -> PyResult<Option<u8>> {
        self.shared.with(self.number, |p| {
            p.has_sync_start().then_some(p.comm.sync_start)
        })
    }

    /// Hands the values given to a started RPDO's objects to the master's engine (python-canopen
    /// needs it after a change; here a started RPDO takes a change at once).
    fn update(&self) -> PyResult<()> {
        let values = self.shared.values(self.number);
        if let Some(s) = lock(&self.shared.senders).get_mut(&self.number) {
            hand_over(s, values, false).map_err(to_py_err)?;
        }
        Ok(())
    }

    /// Asks the node for this TPDO by a remote frame (nothing when the PDO is not valid or
    /// allows no remote request).
    fn remote_request(&self) -> PyResult<()> {
        let (ok, id, len) = self.shared.with(self.number, |p| {
            let bytes = p
                .mapped
                .iter()
                .map(|m| usize::from(m.bits))
                .sum::<usize>()
                .div_ceil(8);
            (p.is_enabled() && p.rtr_allowed(), p.can_id(), bytes.min(8))
        })?;
        if !ok {
            return Ok(());
        }
        let frame = canola::CanFrame::remote(id.map_err(to_py_err)?, len)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        self.shared
            .link
            .node()?
            .network()
            .send(frame)
            .map_err(to_py_err)
    }

    /// Stops transmitting this RPDO.
    fn stop(&self) -> PyResult<()> {
        if let Some(s) = lock(&self.shared.senders).remove(&self.number) {
            let _ = s.sender.stop();
        }
        Ok(())
    }

    fn __repr__(&self) -> String {
        let cob = self
            .cob_id()
            .map_or_else(|_| "?".into(), |c| format!("0x{c:X}"));
        format!("<canola.PdoMap {:?} at COB-ID {cob}>", self.name())
    }
}

impl PdoMap {
    fn rpdo_only(&self) -> PyResult<()> {
        if self.shared.direction != Direction::Receive {
            return Err(PyValueError::new_err(format!(
                "{}: the master transmits RPDOs only; a TPDO is the node's to send",
                self.name()
            )));
        }
        Ok(())
    }

    /// Maps `addr` with `length` bits, or with its size in the node's dictionary (the
    /// facade's `map`).
    fn add_at(&self, addr: ObjectAddress, length: Option<u8>) -> PyResult<PdoVariable> {
        let mapped = self.shared.with(self.number, |p| {
            match length {
                Some(bits) => p.map_entry(addr, bits),
                None => p.map(addr)?,
            }
            Ok(p.mapped.last().cloned())
        })?;
        let m = mapped
            .map_err(to_py_err)?
            .expect("an object was just mapped");
        Ok(PdoVariable {
            shared: self.shared.clone(),
            number: self.number,
            addr: m.addr,
            bits: m.bits,
            name: py_name(self.shared.link.od.as_deref(), m.addr),
        })
    }
}

/// One object mapped into a PDO (python-canopen's `PdoVariable`).
#[pyclass(module = "canola", frozen)]
pub(crate) struct PdoVariable {
    shared: Arc<PdoShared>,
    number: u16,
    addr: ObjectAddress,
    bits: u8,
    name: Option<String>,
}

impl PdoVariable {
    fn display_name(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.addr.to_string())
    }
}

#[pymethods]
impl PdoVariable {
    /// The object's name in the node's dictionary (`"Object.Sub-object"` for a sub-object).
    #[getter]
    fn name(&self) -> String {
        self.display_name()
    }

    #[getter]
    fn index(&self) -> u16 {
        self.addr.index
    }

    #[getter]
    fn subindex(&self) -> u8 {
        self.addr.sub_index
    }

    /// The mapped length in bits.
    #[getter]
    fn length(&self) -> u8 {
        self.bits
    }

    /// A TPDO's object: its value in the latest reception, decoded by the node's dictionary
    /// (`None` before one). An RPDO's: the value given to it (`None` before one); setting it
    /// gives the value the next `transmit()` sends (a started RPDO sends it at once).
    #[getter]
    fn raw(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        match self.shared.direction {
            Direction::Transmit => {
                let value = lock(&self.shared.received).get(&self.number).and_then(|r| {
                    r.values
                        .iter()
                        .find(|(a, _)| *a == self.addr)
                        .map(|(_, v)| v.clone())
                });
                match value {
                    Some(v) => value_to_py(py, v),
                    None => Ok(py.None()),
                }
            }
            Direction::Receive => {
                let value = lock(&self.shared.values).get(&self.number).and_then(|vs| {
                    vs.iter()
                        .find(|(a, _)| *a == self.addr)
                        .map(|(_, v)| v.clone())
                });
                match value {
                    Some(WriteValue::Integer(i)) => i.into_py_any(py),
                    Some(WriteValue::Float(f)) => f.into_py_any(py),
                    Some(WriteValue::Text(t)) => t.into_py_any(py),
                    Some(WriteValue::Bytes(b)) => PyBytes::new(py, &b).into_py_any(py),
                    Some(WriteValue::Value(v)) => value_to_py(py, v),
                    Some(other) => format!("{other:?}").into_py_any(py),
                    None => Ok(py.None()),
                }
            }
        }
    }

    #[setter]
    fn set_raw(&self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        if self.shared.direction != Direction::Receive {
            return Err(PyValueError::new_err(
                "a TPDO's values are the node's: set the RPDO's, or write by SDO",
            ));
        }
        let value = write_value(value)?;
        {
            let mut all = lock(&self.shared.values);
            let vs = all.entry(self.number).or_default();
            match vs.iter_mut().find(|(a, _)| *a == self.addr) {
                Some(slot) => slot.1 = value,
                None => vs.push((self.addr, value)),
            }
        }
        let values = self.shared.values(self.number);
        let mut senders = lock(&self.shared.senders);
        if let Some(s) = senders.get_mut(&self.number)
            && s.periodic
        {
            hand_over(s, values, false).map_err(to_py_err)?;
        }
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.PdoVariable {:?} at 0x{:04X}:{:02X}>",
            self.display_name(),
            self.addr.index,
            self.addr.sub_index
        )
    }
}

/// Both directions at once (python-canopen's `PDO`, `node.pdo`): `tx` the TPDOs, `rx` the
/// RPDOs; maps by mapping index (0x1A00.. a TPDO, 0x1600.. an RPDO).
#[pyclass(module = "canola", frozen, name = "PDO")]
pub(crate) struct Pdo {
    pub(crate) tx: Py<PdoBase>,
    pub(crate) rx: Py<PdoBase>,
}

#[pymethods]
impl Pdo {
    /// The TPDOs (`node.tpdo`).
    #[getter]
    fn tx(&self, py: Python<'_>) -> Py<PdoBase> {
        self.tx.clone_ref(py)
    }

    /// The RPDOs (`node.rpdo`).
    #[getter]
    fn rx(&self, py: Python<'_>) -> Py<PdoBase> {
        self.rx.clone_ref(py)
    }

    /// Reads the TPDOs' and the RPDOs' parameters.
    #[pyo3(signature = (from_od = false))]
    fn read(&self, py: Python<'_>, from_od: bool) -> PyResult<()> {
        self.tx.get().read(py, from_od)?;
        self.rx.get().read(py, from_od)
    }

    /// Saves the TPDOs and RPDOs changed since they were read.
    fn save(&self, py: Python<'_>) -> PyResult<()> {
        self.tx.get().save(py)?;
        self.rx.get().save(py)
    }

    /// A map by mapping index (0x1A00.. a TPDO, 0x1600.. an RPDO), or a mapped object by name
    /// (the TPDOs searched first).
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        if key.cast::<PyString>().is_ok() {
            return self
                .tx
                .get()
                .__getitem__(py, key)
                .or_else(|_| self.rx.get().__getitem__(py, key));
        }
        let index: i64 = key.extract()?;
        let base = match index {
            0x1A00..=0x1BFF => &self.tx,
            0x1600..=0x17FF => &self.rx,
            _ => {
                return Err(PyKeyError::new_err(format!(
                    "0x{index:X} is not a PDO mapping index (0x1600.. RPDO, 0x1A00.. TPDO)"
                )));
            }
        };
        base.get().__getitem__(py, key)
    }

    /// Stops every RPDO the master transmits.
    fn stop(&self) -> PyResult<()> {
        self.rx.get().stop()
    }
}
