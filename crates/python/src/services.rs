//! The network's services: `network.sync` (python-canopen's `SyncProducer`) and
//! `network.scanner` (its `NodeScanner`).

use canola::nmt::{SYNC_COB_ID, SyncMessage};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::network::{NetCell, connected, lock};
use crate::{seconds, wait};

/// The master's SYNC producer (`network.sync`), the facade's `start_sync` / `stop_sync`.
#[pyclass(module = "canola", frozen)]
pub(crate) struct SyncProducer {
    net: NetCell,
    period: std::sync::Mutex<Option<f64>>,
}

impl SyncProducer {
    pub(crate) fn new(net: NetCell) -> Self {
        Self {
            net,
            period: std::sync::Mutex::new(None),
        }
    }
}

#[pymethods]
impl SyncProducer {
    /// The COB-ID the SYNC goes out on.
    #[getter]
    fn cob_id(&self) -> u16 {
        SYNC_COB_ID
    }

    /// The period in seconds of the running producer (`None` when stopped).
    #[getter]
    fn period(&self) -> Option<f64> {
        *lock(&self.period)
    }

    /// Sends one SYNC now, with the counter byte `count` when given.
    #[pyo3(signature = (count = None))]
    fn transmit(&self, count: Option<u8>) -> PyResult<()> {
        let frame = SyncMessage { counter: count }.to_frame(SYNC_COB_ID);
        connected(&self.net)?.send(frame).map_err(crate::to_py_err)
    }

    /// Produces SYNC every `period` seconds (by the master's own timer: on a virtual-clock bus
    /// while the network is driven, by a call that waits) until `stop()`.
    #[pyo3(signature = (period = None))]
    fn start(&self, period: Option<f64>) -> PyResult<()> {
        let period = period.or(*lock(&self.period)).ok_or_else(|| {
            PyValueError::new_err("A valid transmission period has not been given")
        })?;
        let d = seconds(period)?;
        if d.as_micros() == 0 {
            return Err(PyValueError::new_err("the SYNC period is above zero"));
        }
        connected(&self.net)?.start_sync(d);
        *lock(&self.period) = Some(period);
        Ok(())
    }

    /// Stops producing SYNC.
    fn stop(&self) -> PyResult<()> {
        connected(&self.net)?.stop_sync();
        *lock(&self.period) = None;
        Ok(())
    }

    fn __repr__(&self) -> String {
        match *lock(&self.period) {
            Some(p) => format!("<canola.SyncProducer every {p} s>"),
            None => "<canola.SyncProducer stopped>".into(),
        }
    }
}

/// Finds the nodes on the bus (`network.scanner`): `search()` is the facade's `scan` (an SDO
/// read of 0x1018:01 from every node-ID), and `nodes` the node-IDs that answered.
#[pyclass(module = "canola", frozen)]
pub(crate) struct NodeScanner {
    net: NetCell,
    nodes: std::sync::Mutex<Vec<u8>>,
}

impl NodeScanner {
    pub(crate) fn new(net: NetCell) -> Self {
        Self {
            net,
            nodes: std::sync::Mutex::new(Vec::new()),
        }
    }
}

#[pymethods]
impl NodeScanner {
    /// The node-IDs found so far, in order.
    #[getter]
    fn nodes(&self) -> Vec<u16> {
        // As ints (a `Vec<u8>` would be `bytes`).
        lock(&self.nodes).iter().map(|&n| u16::from(n)).collect()
    }

    /// Asks every node-ID up to `limit` for its identity and adds those that answer within
    /// `timeout` seconds to `nodes`. Unlike python-canopen's, it returns when the scan is done
    /// (the scan's reads run all at once, so it takes about `timeout`).
    #[pyo3(signature = (limit = 127, timeout = 0.5))]
    fn search(&self, py: Python<'_>, limit: u8, timeout: f64) -> PyResult<()> {
        let op = connected(&self.net)?.scan(seconds(timeout)?);
        let found = wait(py, op)?;
        let mut nodes = lock(&self.nodes);
        for n in found {
            let id = n.node.get();
            if id <= limit && !nodes.contains(&id) {
                nodes.push(id);
            }
        }
        nodes.sort_unstable();
        Ok(())
    }

    /// Forgets the nodes found.
    fn reset(&self) {
        lock(&self.nodes).clear();
    }

    fn __repr__(&self) -> String {
        format!("<canola.NodeScanner {:?}>", lock(&self.nodes))
    }
}
