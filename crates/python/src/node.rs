//! `canola.RemoteNode` (a node on the network, with its `sdo`, `nmt`, `tpdo`, `rpdo`
//! and `emcy`) and `canola.NmtMaster`
//! (`node.nmt`: the node's state, NMT commands, waits for boot-up and heartbeat).

use std::sync::{Arc, Mutex};

use canola::pdo::Direction;
use canola::{NmtState, NodeId, ObjectDictionary};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::emcy::{EmcyConsumer, EmcyShared};
use crate::network::{NetCell, Network, connected, load_dictionary, lock, node_id};
use crate::pdo::{Pdo, PdoBase};
use crate::sdo::SdoClient;
use crate::usdo::UsdoClient;
use crate::{NetworkError, NmtError, dispatch, seconds, wait};

/// What every handle of one node shares: its ID, its dictionary, and the network it was added
/// to (looked up at each call, so a disconnected network fails the call).
pub(crate) struct NodeLink {
    pub(crate) id: NodeId,
    pub(crate) od: Option<Arc<ObjectDictionary>>,
    network: Mutex<Option<Py<Network>>>,
}

impl NodeLink {
    pub(crate) fn new(id: NodeId, od: Option<ObjectDictionary>) -> Arc<Self> {
        Arc::new(Self {
            id,
            od: od.map(Arc::new),
            network: Mutex::new(None),
        })
    }

    /// The node now belongs to `network`.
    pub(crate) fn attach(&self, network: Py<Network>) {
        *lock(&self.network) = Some(network);
    }

    /// The facade's handle of the node, on the network it was added to.
    pub(crate) fn node(&self) -> PyResult<canola::Node> {
        let net = lock(&self.network)
            .as_ref()
            .ok_or_else(|| {
                NetworkError::new_err(format!(
                    "node {} is not on a network: network.add_node() it first",
                    self.id
                ))
            })?
            .get()
            .connected()?;
        Ok(net.node(self.id))
    }

    /// Which connection of its network the node is on now (0 before it is added).
    pub(crate) fn generation(&self) -> u64 {
        lock(&self.network)
            .as_ref()
            .map_or(0, |n| n.get().generation())
    }
}

/// A CANopen node as the master sees it (python-canopen's `RemoteNode`): `sdo`, `nmt`, `tpdo`, `rpdo`,
/// `emcy`.
#[pyclass(module = "canola", frozen, subclass)]
pub(crate) struct RemoteNode {
    pub(crate) link: Arc<NodeLink>,
    sdo: Py<SdoClient>,
    nmt: Py<NmtMaster>,
    tpdo: Py<PdoBase>,
    rpdo: Py<PdoBase>,
    pub(crate) emcy: Py<EmcyConsumer>,
    pdo: Py<Pdo>,
    usdo: Py<UsdoClient>,
}

/// A new handle object (allocating one fails only when memory is gone).
fn handle<T>(made: PyResult<Py<T>>) -> Py<T> {
    made.expect("allocating a handle")
}

impl RemoteNode {
    /// A node over `link`, its handles made (needs the GIL: they are Python objects).
    pub(crate) fn from_link(link: Arc<NodeLink>) -> Self {
        Python::attach(|py| {
            let tpdo = handle(Py::new(py, PdoBase::new(link.clone(), Direction::Transmit)));
            let rpdo = handle(Py::new(py, PdoBase::new(link.clone(), Direction::Receive)));
            Self {
                sdo: handle(Py::new(py, SdoClient::new(link.clone()))),
                usdo: handle(Py::new(py, UsdoClient::new(link.clone()))),
                nmt: handle(Py::new(
                    py,
                    NmtMaster {
                        target: NmtTarget::Node(link.clone(), HeartbeatWatch::new(link.clone())),
                    },
                )),
                pdo: handle(Py::new(
                    py,
                    Pdo {
                        tx: tpdo.clone_ref(py),
                        rx: rpdo.clone_ref(py),
                    },
                )),
                tpdo,
                rpdo,
                emcy: handle(Py::new(
                    py,
                    EmcyConsumer {
                        shared: EmcyShared::new(link.clone()),
                    },
                )),
                link,
            }
        })
    }
}

#[pymethods]
impl RemoteNode {
    /// The node `node_id` described by `object_dictionary` (an EDS/DCF path or bytes); add it
    /// to a network with `network.add_node(node)`.
    #[new]
    #[pyo3(signature = (node_id, object_dictionary = None))]
    fn new(node_id: i64, object_dictionary: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let id = self::node_id(node_id)?;
        let od = object_dictionary.map(load_dictionary).transpose()?;
        Ok(Self::from_link(NodeLink::new(id, od)))
    }

    /// The node-ID.
    #[getter]
    fn id(&self) -> u8 {
        self.link.id.get()
    }

    /// The SDO client: objects by index or name, `upload`, `download`.
    #[getter]
    fn sdo(&self, py: Python<'_>) -> Py<SdoClient> {
        self.sdo.clone_ref(py)
    }

    /// The node's universal SDO (CANopen FD): objects by index or name, `upload`, `download`.
    /// The node must be marked CANopen FD (`CANopenFD=1` in its EDS, or `is_fd = True`) and
    /// the bus must carry CAN FD.
    #[getter]
    fn usdo(&self, py: Python<'_>) -> Py<UsdoClient> {
        self.usdo.clone_ref(py)
    }

    /// Whether the node is marked CANopen FD (by its EDS's `CANopenFD=1`, or set here).
    #[getter]
    fn is_fd(&self) -> PyResult<bool> {
        Ok(self.link.node()?.is_fd())
    }

    #[setter]
    fn set_is_fd(&self, fd: bool) -> PyResult<()> {
        self.link.node()?.set_fd(fd);
        Ok(())
    }

    /// The node's NMT: state, commands, waits.
    #[getter]
    fn nmt(&self, py: Python<'_>) -> Py<NmtMaster> {
        self.nmt.clone_ref(py)
    }

    /// Both directions (python-canopen's `node.pdo`): `tx`, `rx`, maps by mapping index.
    #[getter]
    fn pdo(&self, py: Python<'_>) -> Py<Pdo> {
        self.pdo.clone_ref(py)
    }

    /// The node's object dictionary (`None` when it was added without one).
    #[getter]
    fn object_dictionary(&self) -> Option<crate::od::ObjectDictionary> {
        self.link
            .od
            .clone()
            .map(|od| crate::od::ObjectDictionary::new(od, Some(self.link.id.get())))
    }

    /// The node's transmit PDOs: `read()`, maps by number, values as received.
    #[getter]
    fn tpdo(&self, py: Python<'_>) -> Py<PdoBase> {
        self.tpdo.clone_ref(py)
    }

    /// The node's receive PDOs: `read()`, maps by number, sent by the master.
    #[getter]
    fn rpdo(&self, py: Python<'_>) -> Py<PdoBase> {
        self.rpdo.clone_ref(py)
    }

    /// Stores parameters in the node's non-volatile memory: the signature `save` to
    /// 0x1010 `subindex` (1 all, 2 communication, 3 application, 4 manufacturer-specific).
    #[pyo3(signature = (subindex = 1))]
    fn store(&self, py: Python<'_>, subindex: u8) -> PyResult<()> {
        let group = canola::ParameterGroup::from_sub_index(subindex);
        wait(py, self.link.node()?.store_parameters_of(group))
    }

    /// Restores the default parameters (at the node's next reset): the signature `load` to
    /// 0x1011 `subindex` (as for `store`).
    #[pyo3(signature = (subindex = 1))]
    fn restore(&self, py: Python<'_>, subindex: u8) -> PyResult<()> {
        let group = canola::ParameterGroup::from_sub_index(subindex);
        wait(py, self.link.node()?.restore_defaults_of(group))
    }

    /// The node's emergencies: `active`, `log`, callbacks, `wait()`.
    #[getter]
    fn emcy(&self, py: Python<'_>) -> Py<EmcyConsumer> {
        self.emcy.clone_ref(py)
    }

    fn __repr__(&self) -> String {
        format!("<canola.RemoteNode {}>", self.link.id)
    }
}

/// python-canopen's name of an NMT state.
fn state_name(state: Option<NmtState>) -> String {
    match state {
        None | Some(NmtState::BootUp) => "INITIALISING".into(),
        Some(NmtState::Stopped) => "STOPPED".into(),
        Some(NmtState::Operational) => "OPERATIONAL".into(),
        Some(NmtState::PreOperational) => "PRE-OPERATIONAL".into(),
        Some(NmtState::Unknown(v)) => format!("UNKNOWN STATE {v}"),
    }
}

/// A node's heartbeat callbacks (`node.nmt.add_heartbeat_callback`). The master keeps when
/// the node's latest heartbeat came (`Network::last_heartbeat`); this looks at it wherever
/// the package polls (see `dispatch`) and calls the callbacks with the node's state when a
/// newer one came: once per look, however many came since the previous.
pub(crate) struct HeartbeatWatch {
    link: Arc<NodeLink>,
    last: Mutex<Option<canola::Instant>>,
    callbacks: Mutex<Vec<Py<PyAny>>>,
}

impl HeartbeatWatch {
    pub(crate) fn new(link: Arc<NodeLink>) -> Arc<Self> {
        Arc::new(Self {
            link,
            last: Mutex::new(None),
            callbacks: Mutex::new(Vec::new()),
        })
    }

    fn add(self: &Arc<Self>, callback: Py<PyAny>) -> PyResult<()> {
        let node = self.link.node()?;
        let first = {
            let mut callbacks = lock(&self.callbacks);
            callbacks.push(callback);
            callbacks.len() == 1
        };
        if first {
            // Heartbeats from now on.
            *lock(&self.last) = node.network().last_heartbeat(self.link.id);
            let me = Arc::downgrade(self);
            dispatch::add_poller(Box::new(move || match me.upgrade() {
                Some(me) => {
                    me.poll();
                    true
                }
                None => false,
            }));
            dispatch::start_dispatcher();
        }
        Ok(())
    }

    fn poll(self: &Arc<Self>) {
        let Ok(node) = self.link.node() else { return };
        let net = node.network();
        let Some(at) = net.last_heartbeat(self.link.id) else {
            return;
        };
        {
            let mut last = lock(&self.last);
            if *last == Some(at) {
                return;
            }
            *last = Some(at);
        }
        let state = net.last_state(self.link.id).map_or(0, NmtState::to_u8);
        let me = self.clone();
        dispatch::push(Box::new(move |py| {
            let callbacks: Vec<Py<PyAny>> = lock(&me.callbacks)
                .iter()
                .map(|c| c.clone_ref(py))
                .collect();
            let Ok(state) = state.into_py_any(py) else {
                return;
            };
            for cb in &callbacks {
                dispatch::call(py, cb, state.bind(py));
            }
        }));
    }
}

/// What an `NmtMaster` commands: one node, or every node (`network.nmt`, node-ID 0).
pub(crate) enum NmtTarget {
    Node(Arc<NodeLink>, Arc<HeartbeatWatch>),
    /// The network's facade handle, and the state last commanded to all nodes.
    All(NetCell, Mutex<String>),
}

/// python-canopen's state name after an NMT command.
fn commanded_state(code: u8) -> &'static str {
    match code {
        0x01 => "OPERATIONAL",
        0x02 => "STOPPED",
        0x80 => "PRE-OPERATIONAL",
        _ => "INITIALISING",
    }
}

/// A node's NMT (python-canopen's `NmtMaster`, `node.nmt`), or the network's (`network.nmt`),
/// whose commands go to every node.
#[pyclass(module = "canola", frozen)]
pub(crate) struct NmtMaster {
    pub(crate) target: NmtTarget,
}

impl NmtMaster {
    /// The facade's NMT handle of the target.
    fn nmt(&self) -> PyResult<canola::Nmt> {
        match &self.target {
            NmtTarget::Node(link, _) => Ok(link.node()?.nmt()),
            NmtTarget::All(net, _) => Ok(canola::Nmt::all(&connected(net)?)),
        }
    }

    /// The node, for what only a node has (its state, its boot-up, its heartbeat).
    fn link(&self) -> PyResult<&Arc<NodeLink>> {
        match &self.target {
            NmtTarget::Node(link, _) => Ok(link),
            NmtTarget::All(..) => Err(PyValueError::new_err(
                "network.nmt commands every node; a node's state and waits are node.nmt's",
            )),
        }
    }
}

#[pymethods]
impl NmtMaster {
    /// The node's state as it last reported it (heartbeat, node guarding or boot-up):
    /// `"INITIALISING"` (nothing heard yet, or its boot-up), `"PRE-OPERATIONAL"`,
    /// `"OPERATIONAL"`, `"STOPPED"`; for `network.nmt` the state last commanded. Setting it
    /// sends the NMT command: `"OPERATIONAL"`, `"STOPPED"`, `"PRE-OPERATIONAL"`, `"RESET"`,
    /// `"RESET COMMUNICATION"`.
    #[getter]
    fn state(&self) -> PyResult<String> {
        match &self.target {
            NmtTarget::Node(link, _) => Ok(state_name(link.node()?.nmt().state())),
            NmtTarget::All(_, commanded) => Ok(lock(commanded).clone()),
        }
    }

    #[setter]
    fn set_state(&self, state: &str) -> PyResult<()> {
        let code = match state.to_ascii_uppercase().as_str() {
            "OPERATIONAL" => 0x01,
            "STOPPED" => 0x02,
            "PRE-OPERATIONAL" => 0x80,
            "RESET" | "INITIALISING" => 0x81,
            "RESET COMMUNICATION" => 0x82,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "{state:?} is not an NMT command of CiA 301: OPERATIONAL, STOPPED, \
                     PRE-OPERATIONAL, RESET or RESET COMMUNICATION"
                )));
            }
        };
        self.send_command(code)
    }

    /// Sends the NMT command `code`: 0x01 start, 0x02 stop, 0x80 enter pre-operational, 0x81
    /// reset node, 0x82 reset communication.
    fn send_command(&self, code: u8) -> PyResult<()> {
        let nmt = self.nmt()?;
        let sent = match code {
            0x01 => nmt.start(),
            0x02 => nmt.stop(),
            0x80 => nmt.enter_preoperational(),
            0x81 => nmt.reset_node(),
            0x82 => nmt.reset_communication(),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "0x{code:02X} is not an NMT command of CiA 301 (0x01, 0x02, 0x80, 0x81, 0x82)"
                )));
            }
        };
        sent.map_err(crate::to_py_err)?;
        if let NmtTarget::All(_, commanded) = &self.target {
            *lock(commanded) = commanded_state(code).into();
        }
        Ok(())
    }

    /// Calls `callback(state)` when a heartbeat of the node came, with the state it reports
    /// (0 boot-up, 4 stopped, 5 operational, 127 pre-operational).
    fn add_heartbeat_callback(&self, callback: Py<PyAny>) -> PyResult<()> {
        match &self.target {
            NmtTarget::Node(_, watch) => watch.add(callback),
            NmtTarget::All(..) => Err(PyValueError::new_err(
                "network.nmt commands every node; heartbeats are node.nmt's",
            )),
        }
    }

    /// Guards the node (CiA 301 node guarding): a remote request every `period` seconds, whose
    /// answers give the node's state (as heartbeats do).
    fn start_node_guarding(&self, period: f64) -> PyResult<()> {
        let link = self.link()?;
        let every = seconds(period)?;
        if every.as_micros() == 0 {
            return Err(PyValueError::new_err("the guarding period is above zero"));
        }
        if !link.node()?.network().guard_node(link.id, every, 1) {
            return Err(PyValueError::new_err(format!(
                "node {} cannot be guarded every {period} s",
                link.id
            )));
        }
        Ok(())
    }

    /// Stops guarding the node.
    fn stop_node_guarding(&self) -> PyResult<()> {
        let link = self.link()?;
        link.node()?
            .network()
            .guard_node(link.id, canola::Duration::ZERO, 1);
        Ok(())
    }

    /// Waits for a boot-up message of the node not waited for yet (one that came before the
    /// call counts, so a reset and then this wait cannot miss it). Raises `NmtError` after
    /// `timeout` seconds.
    #[pyo3(signature = (timeout = 10.0))]
    fn wait_for_bootup(&self, py: Python<'_>, timeout: f64) -> PyResult<()> {
        let op = self
            .link()?
            .node()?
            .nmt()
            .wait_for_bootup(seconds(timeout)?);
        wait(py, op)
    }

    /// Waits for the node's next heartbeat (or another sign of life) and returns its state.
    /// Raises `NmtError` after `timeout` seconds.
    #[pyo3(signature = (timeout = 10.0))]
    fn wait_for_heartbeat(&self, py: Python<'_>, timeout: f64) -> PyResult<String> {
        let link = self.link()?;
        let node = link.node()?;
        let net = node.network().clone();
        let now = net.now();
        let op = node.nmt().wait_for_life(Some(now), now + seconds(timeout)?);
        if !wait(py, op)? {
            return Err(NmtError::new_err(format!(
                "no heartbeat from node {} within {timeout} s",
                link.id
            )));
        }
        self.state()
    }

    fn __repr__(&self) -> String {
        match &self.target {
            NmtTarget::Node(link, _) => format!("<canola.NmtMaster node {}>", link.id),
            NmtTarget::All(..) => "<canola.NmtMaster all nodes>".into(),
        }
    }
}
