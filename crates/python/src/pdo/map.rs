//! A PDO's map (`canola.PdoMap`: python-canopen's `PdoMap`, its parameters and the calls on
//! one PDO) and its mapped objects (`canola.PdoVariable`), over the state [`PdoShared`] keeps.

use super::*;

/// One PDO of a node (python-canopen's `PdoMap`): parameters, mapped objects, values.
#[pyclass(module = "canola", frozen)]
pub(crate) struct PdoMap {
    pub(super) shared: Arc<PdoShared>,
    pub(super) number: u16,
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

    pub(super) fn variable(&self, name: &str) -> PyResult<PdoVariable> {
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
    pub(super) shared: Arc<PdoShared>,
    pub(super) number: u16,
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
