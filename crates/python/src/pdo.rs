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

mod map;
pub(crate) use map::{PdoMap, PdoVariable};

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
