//! `node.emcy` (python-canopen's `EmcyConsumer`): the emergencies a node sent, as
//! `canola.EmcyError` exceptions, with `active`, `log`, callbacks and a wait.
//!
//! The master decodes every EMCY (`NetworkEvent::Emcy`, from `Network::subscribe`); this module
//! keeps python-canopen's lists of them. One subscription per network (`EmcyRouter`) is
//! drained wherever this package polls (see `dispatch`): between the driving steps of a
//! blocking call, on the dispatcher thread, and when the lists are read.

use std::collections::HashMap;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex, Weak};

use canola::nmt::EmcyEvent;
use canola::{Duration, NetworkEvent, Operation};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBytes, PyList, PyType};

use crate::network::lock;
use crate::node::NodeLink;
use crate::{dispatch, seconds, wait};

/// `canola.EmcyError`: python-canopen's exception of an emergency (code, register, data,
/// timestamp, `get_desc()`), a Python class: an exception class with attributes is not
/// something PyO3 makes under the stable ABI of Python 3.9. Its description comes from the
/// stack (`EmcyCode::description`).
const EMCY_ERROR: &std::ffi::CStr = cr#"
class EmcyError(Exception):
    """An emergency message of a node (CiA 301 EMCY): `code`, `register` (the error
    register), `data` (the 5 manufacturer-specific bytes), `timestamp` (seconds on the
    network's clock)."""

    def __init__(self, code, register, data, timestamp, description=""):
        super().__init__(code, register, data, timestamp)
        self.code = code
        self.register = register
        self.data = data
        self.timestamp = timestamp
        self._description = description

    def get_desc(self):
        """The CiA 301 meaning of the code ("" when it has none)."""
        return self._description

    def __str__(self):
        text = f"Code 0x{self.code:04X}"
        if self._description:
            text += ", " + self._description
        return text

EmcyError.__module__ = "canola"
"#;

static EMCY_ERROR_TYPE: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// The class `canola.EmcyError`.
pub(crate) fn emcy_error_type(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    EMCY_ERROR_TYPE
        .get_or_try_init(py, || {
            let module = PyModule::from_code(py, EMCY_ERROR, c"canola_emcy.py", c"canola_emcy")?;
            Ok::<_, PyErr>(module.getattr("EmcyError")?.cast_into::<PyType>()?.unbind())
        })
        .map(|t| t.bind(py))
}

/// An `EmcyError` of `e`.
fn emcy_error(py: Python<'_>, e: &EmcyEvent) -> PyResult<Py<PyAny>> {
    let desc = e.emcy.code.description().unwrap_or("");
    Ok(emcy_error_type(py)?
        .call1((
            e.emcy.code.0,
            e.emcy.register.0,
            PyBytes::new(py, &e.emcy.manufacturer),
            e.at.as_micros() as f64 / 1e6,
            desc,
        ))?
        .unbind())
}

/// A network's one subscription to its events, handing each node's EMCYs to its `node.emcy`
/// (one subscription per network, not per node: each gets every event of the network). It
/// subscribes once a node is added: a network without nodes pays nothing for it.
pub(crate) struct EmcyRouter {
    /// The network connected now.
    net: Mutex<Option<canola::Network>>,
    rx: Mutex<Option<Receiver<NetworkEvent>>>,
    nodes: Mutex<HashMap<u8, Weak<EmcyShared>>>,
}

impl EmcyRouter {
    /// A router, polled (see `dispatch`) as long as it exists.
    pub(crate) fn new() -> Arc<Self> {
        let router = Arc::new(Self {
            net: Mutex::new(None),
            rx: Mutex::new(None),
            nodes: Mutex::new(HashMap::new()),
        });
        let me = Arc::downgrade(&router);
        dispatch::add_poller(Box::new(move || match me.upgrade() {
            Some(me) => {
                me.poll();
                true
            }
            None => false,
        }));
        router
    }

    /// Follows the events of `net` (the network connected now; `None`: none).
    pub(crate) fn attach(&self, net: Option<&canola::Network>) {
        *lock(&self.net) = net.cloned();
        *lock(&self.rx) = None;
        if !lock(&self.nodes).is_empty() {
            self.subscribe();
        }
    }

    /// Subscribes to the network connected now, if not yet.
    fn subscribe(&self) {
        let mut rx = lock(&self.rx);
        if rx.is_some() {
            return;
        }
        if let Some(net) = lock(&self.net).as_ref() {
            *rx = Some(net.subscribe());
            // Drained by the dispatcher thread too, the subscription does not grow while the
            // program makes no call (a network driven in the background).
            dispatch::start_dispatcher();
        }
    }

    /// Routes the EMCYs of node `shared` to it from now on.
    pub(crate) fn add(self: &Arc<Self>, shared: &Arc<EmcyShared>) {
        *lock(&shared.router) = Arc::downgrade(self);
        lock(&self.nodes).insert(shared.link.id.get(), Arc::downgrade(shared));
        self.subscribe();
    }

    /// Takes the events that came: each node's EMCYs go to its lists and queue its callbacks.
    fn poll(&self) {
        let mut emcys = Vec::new();
        {
            let rx = lock(&self.rx);
            let Some(r) = rx.as_ref() else { return };
            while let Ok(event) = r.try_recv() {
                if let NetworkEvent::Emcy(e) = event {
                    emcys.push(e);
                }
            }
        }
        if emcys.is_empty() {
            return;
        }
        let nodes = lock(&self.nodes);
        for e in emcys {
            if let Some(shared) = nodes.get(&e.node.get()).and_then(Weak::upgrade) {
                shared.received(e);
            }
        }
    }
}

/// What `node.emcy` holds.
pub(crate) struct EmcyShared {
    link: Arc<NodeLink>,
    /// The router of the network the node was added to.
    router: Mutex<Weak<EmcyRouter>>,
    state: Mutex<EmcyState>,
    callbacks: Mutex<Vec<Py<PyAny>>>,
}

#[derive(Default)]
struct EmcyState {
    /// Every EMCY received (python-canopen's `log`), until `reset()`.
    log: Vec<EmcyEvent>,
    /// Those since the last error reset (code 0x00xx).
    active: Vec<EmcyEvent>,
    /// EMCYs received in all (a wait looks for a new one).
    count: u64,
    /// Every EMCY by its count, kept for waits (cleared as `log` is not).
    recent: Vec<(u64, EmcyEvent)>,
}

impl EmcyShared {
    pub(crate) fn new(link: Arc<NodeLink>) -> Arc<Self> {
        Arc::new(Self {
            link,
            router: Mutex::new(Weak::new()),
            state: Mutex::new(EmcyState::default()),
            callbacks: Mutex::new(Vec::new()),
        })
    }

    /// Takes what the network's subscription holds now.
    fn poll(&self) {
        let router = lock(&self.router).upgrade();
        if let Some(r) = router {
            r.poll();
        }
    }

    fn received(self: &Arc<Self>, e: EmcyEvent) {
        {
            let mut s = lock(&self.state);
            if e.emcy.code.0 & 0xFF00 == 0 {
                s.active.clear();
            } else {
                s.active.push(e);
            }
            s.log.push(e);
            s.count += 1;
            let n = s.count;
            s.recent.push((n, e));
            if s.recent.len() > 256 {
                s.recent.drain(..128);
            }
        }
        if !lock(&self.callbacks).is_empty() {
            let me = self.clone();
            dispatch::push(Box::new(move |py| {
                let callbacks: Vec<Py<PyAny>> = lock(&me.callbacks)
                    .iter()
                    .map(|c| c.clone_ref(py))
                    .collect();
                let Ok(err) = emcy_error(py, &e) else { return };
                for cb in &callbacks {
                    dispatch::call(py, cb, err.bind(py));
                }
            }));
        }
    }

    fn list(self: &Arc<Self>, py: Python<'_>, active: bool) -> PyResult<Py<PyList>> {
        self.poll();
        let events = {
            let s = lock(&self.state);
            if active {
                s.active.clone()
            } else {
                s.log.clone()
            }
        };
        let errors = events
            .iter()
            .map(|e| emcy_error(py, e))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(PyList::new(py, errors)?.unbind())
    }
}

/// A node's emergency consumer (`node.emcy`).
#[pyclass(module = "canola", frozen)]
pub(crate) struct EmcyConsumer {
    pub(crate) shared: Arc<EmcyShared>,
}

#[pymethods]
impl EmcyConsumer {
    /// The EMCYs since the last error reset (an EMCY with code 0x00xx clears it).
    #[getter]
    fn active(&self, py: Python<'_>) -> PyResult<Py<PyList>> {
        self.shared.list(py, true)
    }

    /// Every EMCY received since the node was added (or `reset()`).
    #[getter]
    fn log(&self, py: Python<'_>) -> PyResult<Py<PyList>> {
        self.shared.list(py, false)
    }

    /// Calls `callback(emcy_error)` on every EMCY of the node (between the driving steps of a
    /// blocking call, or on a thread of this package when none runs).
    fn add_callback(&self, callback: Py<PyAny>) {
        lock(&self.shared.callbacks).push(callback);
        dispatch::start_dispatcher();
    }

    /// Empties `log` and `active`.
    fn reset(&self) {
        self.shared.poll();
        let mut s = lock(&self.shared.state);
        s.log.clear();
        s.active.clear();
    }

    /// Waits for the next EMCY of the node (with `emcy_code`, when given): its `EmcyError`,
    /// or `None` after `timeout` seconds without one.
    #[pyo3(signature = (emcy_code = None, timeout = 10.0))]
    fn wait(
        &self,
        py: Python<'_>,
        emcy_code: Option<u16>,
        timeout: f64,
    ) -> PyResult<Option<Py<PyAny>>> {
        let shared = self.shared.clone();
        shared.poll();
        let net = shared.link.node()?.network().clone();
        let deadline = net.now() + seconds(timeout)?;
        let before = lock(&shared.state).count;
        let found = move |s: &Arc<EmcyShared>| {
            s.poll();
            let st = lock(&s.state);
            st.recent
                .iter()
                .find(|(n, e)| *n > before && emcy_code.is_none_or(|c| e.emcy.code.0 == c))
                .map(|(_, e)| *e)
        };
        let op = Operation::new(async move {
            loop {
                if let Some(e) = found(&shared) {
                    return Ok(Some(e));
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
        match wait(py, op)? {
            Some(e) => Ok(Some(emcy_error(py, &e)?)),
            None => Ok(None),
        }
    }

    fn __repr__(&self) -> String {
        format!("<canola.EmcyConsumer node {}>", self.shared.link.id)
    }
}
