//! `canola.Network` (python-canopen's `Network`: connect a bus, add nodes, a mapping of them),
//! and the simulation side: `canola.MemoryBus` and `canola.SimDevice`.

use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

use canola::mem::{BusConfig, ClockMode};
use canola::{NodeId, ObjectDictionary};
use pyo3::exceptions::{PyKeyError, PyNotImplementedError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyTuple};

use crate::NetworkError;
use crate::emcy::EmcyRouter;
use crate::lss::LssMaster;
use crate::node::{NmtMaster, NmtTarget, NodeLink, RemoteNode};
use crate::services::{NodeScanner, SyncProducer};

/// Locks a mutex, taking the data of one a panicking thread left behind (the data here is
/// never left half-changed).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A network's facade handle as its parts share it (`network.nmt`, `network.sync`, ...):
/// `None` while it is not connected.
pub(crate) type NetCell = Arc<Mutex<Option<canola::Network>>>;

/// The facade's network in `cell`, or the error that it is not connected.
pub(crate) fn connected(cell: &NetCell) -> PyResult<canola::Network> {
    lock(cell).clone().ok_or_else(|| {
        NetworkError::new_err(
            "the network is not connected: connect() it or make it with Network.open()",
        )
    })
}

/// Makes the node of `link` known to `net`, with its dictionary.
fn register(net: &canola::Network, link: &NodeLink) {
    match &link.od {
        Some(od) => net.add_node_with_dictionary(link.id, ObjectDictionary::clone(od)),
        None => net.add_node(link.id),
    };
}

/// A node-ID from Python, checked (1..=127).
pub(crate) fn node_id(id: i64) -> PyResult<NodeId> {
    u8::try_from(id)
        .ok()
        .and_then(|i| NodeId::new(i).ok())
        .ok_or_else(|| PyValueError::new_err(format!("node-ID {id} is not in 1..=127")))
}

/// An object dictionary from what python-canopen's `import_od` takes: a path to an EDS/DCF
/// file (str or path-like) or the file's bytes; or one `import_od` gave.
pub(crate) fn load_dictionary(source: &Bound<'_, PyAny>) -> PyResult<ObjectDictionary> {
    if let Ok(od) = source.cast::<crate::od::ObjectDictionary>() {
        return Ok(ObjectDictionary::clone(&od.get().od));
    }
    let (text, name) = eds_text(source)?;
    canola::od::parse(&text)
        .map(|parsed| parsed.od)
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
}

/// The bytes of an EDS given as a path or as bytes, and a name for messages.
fn eds_text(source: &Bound<'_, PyAny>) -> PyResult<(Vec<u8>, String)> {
    if let Ok(bytes) = source.cast::<PyBytes>() {
        return Ok((bytes.as_bytes().to_vec(), "EDS".into()));
    }
    let path: std::path::PathBuf = source.extract().map_err(|_| {
        PyTypeError::new_err("an object dictionary is a path to an EDS/DCF file or its bytes")
    })?;
    let text = std::fs::read(&path)?;
    Ok((text, path.display().to_string()))
}

/// The in-process buses that `connect(interface="virtual", channel=...)` joins, by channel, as
/// python-can's virtual interface shares one bus per channel name.
fn channels() -> &'static Mutex<HashMap<String, canola::MemoryBus>> {
    static CHANNELS: OnceLock<Mutex<HashMap<String, canola::MemoryBus>>> = OnceLock::new();
    CHANNELS.get_or_init(Default::default)
}

/// The named in-process bus `channel` (made on first use, on the host's clock).
fn channel_bus(channel: &str) -> canola::MemoryBus {
    lock(channels())
        .entry(channel.to_string())
        .or_insert_with(|| {
            canola::MemoryBus::with_config(BusConfig {
                clock: ClockMode::RealTime,
                ..BusConfig::default()
            })
        })
        .clone()
}

/// An in-memory CAN bus in this process, for tests and simulation. By default its clock is
/// virtual: time passes only while the network waits, and jumps to the next thing due, so a
/// test with a 10 s timeout takes microseconds and runs the same every time.
#[pyclass(module = "canola", frozen)]
pub(crate) struct MemoryBus {
    pub(crate) bus: canola::MemoryBus,
    realtime: bool,
}

#[pymethods]
impl MemoryBus {
    /// A new bus. `realtime=True` runs it on the host's clock (a network on it then runs by
    /// itself, as on a real bus); `fd=True` makes it a CAN FD bus (for `node.usdo`).
    #[new]
    #[pyo3(signature = (realtime = false, fd = false))]
    fn new(realtime: bool, fd: bool) -> Self {
        let clock = if realtime {
            ClockMode::RealTime
        } else {
            ClockMode::Virtual
        };
        Self {
            bus: canola::MemoryBus::with_config(BusConfig {
                clock,
                fd,
                ..BusConfig::default()
            }),
            realtime,
        }
    }

    /// The in-process bus named `channel`, on the host's clock: the one
    /// `Network().connect(interface="virtual", channel=channel)` joins.
    #[staticmethod]
    fn virtual_channel(channel: &str) -> Self {
        Self {
            bus: channel_bus(channel),
            realtime: true,
        }
    }

    /// Whether the bus runs on the host's clock (else its clock is virtual).
    #[getter]
    fn realtime(&self) -> bool {
        self.realtime
    }

    /// Puts a simulated device on the bus. A device goes on one bus once.
    fn attach(&self, device: &SimDevice) -> PyResult<()> {
        let dev = lock(&device.device)
            .take()
            .ok_or_else(|| PyValueError::new_err("this SimDevice is attached to a bus already"))?;
        self.bus.attach(dev);
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.MemoryBus {} clock>",
            if self.realtime {
                "real-time"
            } else {
                "virtual"
            }
        )
    }
}

/// A simulated CANopen device built from an EDS: an SDO server over its object dictionary,
/// NMT, heartbeat, boot-up and PDOs, as the real device would answer.
#[pyclass(module = "canola", frozen)]
pub(crate) struct SimDevice {
    device: Mutex<Option<canola::SimDevice>>,
    node: Option<NodeId>,
    /// The simulated CiA 402 drive behind the device's profile objects (`cia402_drive`).
    drive: Option<Arc<Mutex<canola_cia402::sim::SimDrive>>>,
}

#[pymethods]
impl SimDevice {
    /// The device of node `node_id` described by an EDS/DCF (a path, or the file's bytes).
    #[staticmethod]
    fn from_eds(eds: &Bound<'_, PyAny>, node_id: i64) -> PyResult<Self> {
        let node = self::node_id(node_id)?;
        let (text, name) = eds_text(eds)?;
        let device = canola::SimDevice::from_eds(node, &text)
            .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
        Ok(Self {
            device: Mutex::new(Some(device)),
            node: Some(node),
            drive: None,
        })
    }

    /// A device without a node-ID (CiA 305 "unconfigured") whose LSS address is `address`
    /// (vendor-ID, product code, revision number, serial number; also its 0x1018): silent but
    /// for LSS until a master gives it a node-ID (`network.lss`), then it boots with it.
    #[staticmethod]
    fn unconfigured(eds: &Bound<'_, PyAny>, address: (u32, u32, u32, u32)) -> PyResult<Self> {
        let od = load_dictionary(eds)?;
        let (v, p, r, s) = address;
        let device = canola::SimDevice::unconfigured(od, canola::lss::LssAddress::new(v, p, r, s));
        Ok(Self {
            device: Mutex::new(Some(device)),
            node: None,
            drive: None,
        })
    }

    /// A CiA 402 servo drive of node `node_id`: the dictionary from `eds` (e.g. the
    /// repository's `eds/cia402-servo.eds`), the stack's simulated drive (power state machine,
    /// modes, homing, motion; axis 0) behind its profile objects, as `canopen simulate` runs it.
    #[staticmethod]
    fn cia402_drive(eds: &Bound<'_, PyAny>, node_id: i64) -> PyResult<Self> {
        let node = self::node_id(node_id)?;
        let (text, name) = eds_text(eds)?;
        let drive = canola_cia402::sim::SimDrive::new(canola_cia402::sim::SimConfig::default());
        let (device, shared) = canola_cia402::master::simulated_drive(node, &text, drive)
            .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
        Ok(Self {
            device: Mutex::new(Some(device)),
            node: Some(node),
            drive: Some(shared),
        })
    }

    /// Runs the device on a real bus named by a bus spec of this stack (`"udp:GROUP:PORT"`,
    /// `"vcan0"`, ...), as `canopen simulate` does, on a thread of its own, so that another
    /// program (python-canopen, the CLI) talks to it. A device is served or attached once.
    /// Returns the service: `stop()` it, or use it as a context manager.
    fn serve(&self, py: Python<'_>, spec: &str) -> PyResult<SimService> {
        let mut dev = lock(&self.device)
            .take()
            .ok_or_else(|| PyValueError::new_err("this SimDevice is attached to a bus already"))?;
        let parsed =
            canola::BusSpec::parse(spec).map_err(|e| NetworkError::new_err(e.to_string()))?;
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let stopped = stop.clone();
        let (opened_tx, opened_rx) = std::sync::mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("canola-sim-serve".into())
            .spawn(move || {
                let mut transport = match parsed.open() {
                    Ok(t) => {
                        let _ = opened_tx.send(Ok(()));
                        t
                    }
                    Err(e) => {
                        let _ = opened_tx.send(Err(e.to_string()));
                        return Ok(());
                    }
                };
                canola::run_station(&mut *transport, &mut dev, || {
                    stopped.load(Ordering::Relaxed)
                })
                .map_err(|e| e.to_string())
            })?;
        let opened = py.detach(move || opened_rx.recv());
        match opened {
            Ok(Ok(())) => Ok(SimService {
                stop,
                thread: Mutex::new(Some(thread)),
            }),
            Ok(Err(e)) => Err(NetworkError::new_err(format!("{spec}: {e}"))),
            Err(_) => Err(NetworkError::new_err(format!(
                "{spec}: the device thread ended"
            ))),
        }
    }

    /// Puts a `cia402_drive` into fault with `error_code` (0x603F and its EMCY), as a drive
    /// detecting e.g. a following error (0x8611) does.
    fn inject_fault(&self, error_code: u16) -> PyResult<()> {
        let drive = self
            .drive
            .as_ref()
            .ok_or_else(|| PyValueError::new_err("this SimDevice is not a cia402_drive"))?;
        lock(drive).inject_fault(canola_cia402::sim::SimFault::Other(
            canola_cia402::ErrorCode(error_code),
        ));
        Ok(())
    }

    /// The device's node-ID (`None` for an unconfigured one, as made).
    #[getter]
    fn id(&self) -> Option<u8> {
        self.node.map(NodeId::get)
    }

    fn __repr__(&self) -> String {
        match self.node {
            Some(n) => format!("<canola.SimDevice node {n}>"),
            None => "<canola.SimDevice unconfigured>".into(),
        }
    }
}

/// A simulated device served on a real bus (`SimDevice.serve`).
#[pyclass(module = "canola", frozen)]
pub(crate) struct SimService {
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Mutex<Option<std::thread::JoinHandle<Result<(), String>>>>,
}

#[pymethods]
impl SimService {
    /// Stops the device (within 50 ms) and waits for its thread; a bus failure that ended it
    /// earlier is raised here.
    fn stop(&self, py: Python<'_>) -> PyResult<()> {
        self.stop.store(true, Ordering::Relaxed);
        let Some(thread) = lock(&self.thread).take() else {
            return Ok(());
        };
        match py.detach(|| thread.join()) {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(NetworkError::new_err(e)),
            Err(_) => Err(NetworkError::new_err("the device thread panicked")),
        }
    }

    /// Whether the device still runs.
    #[getter]
    fn running(&self) -> bool {
        lock(&self.thread)
            .as_ref()
            .is_some_and(|t| !t.is_finished())
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __exit__(
        &self,
        py: Python<'_>,
        _exc_type: &Bound<'_, PyAny>,
        _exc: &Bound<'_, PyAny>,
        _tb: &Bound<'_, PyAny>,
    ) -> PyResult<bool> {
        self.stop(py)?;
        Ok(false)
    }
}

impl Drop for SimService {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// A CANopen network: the master side of one CAN bus, and a mapping of node-ID to node, as
/// python-canopen's `Network`. `with Network(...) as net:` disconnects at the end.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct Network {
    net: NetCell,
    nodes: Mutex<BTreeMap<u8, Py<RemoteNode>>>,
    nmt: Py<NmtMaster>,
    sync: Py<SyncProducer>,
    scanner: Py<NodeScanner>,
    lss: Py<LssMaster>,
    emcy: Arc<EmcyRouter>,
    /// Connections made so far: a handle that subscribed to an earlier one subscribes again.
    generation: AtomicU64,
}

impl Network {
    fn with(net: Option<canola::Network>) -> Self {
        let emcy = EmcyRouter::new();
        emcy.attach(net.as_ref());
        let net: NetCell = Arc::new(Mutex::new(net));
        Python::attach(|py| Self {
            nmt: Py::new(
                py,
                NmtMaster {
                    target: NmtTarget::All(net.clone(), Mutex::new("INITIALISING".into())),
                },
            )
            .expect("allocating a handle"),
            sync: Py::new(py, SyncProducer::new(net.clone())).expect("allocating a handle"),
            scanner: Py::new(py, NodeScanner::new(net.clone())).expect("allocating a handle"),
            lss: Py::new(py, LssMaster::new(net.clone())).expect("allocating a handle"),
            net,
            nodes: Mutex::new(BTreeMap::new()),
            emcy,
            generation: AtomicU64::new(0),
        })
    }

    /// The facade's network, or the error that it is not connected.
    pub(crate) fn connected(&self) -> PyResult<canola::Network> {
        connected(&self.net)
    }

    /// Which connection this is (see `generation`).
    pub(crate) fn generation(&self) -> u64 {
        self.generation.load(Ordering::SeqCst)
    }

    /// Connects to the bus `spec` names (a bus spec of this stack), running the background
    /// driver.
    fn connect_spec(&self, spec: &str) -> PyResult<()> {
        let net = canola::Network::open(spec).map_err(crate::to_py_err)?;
        self.replace(Some(net))
    }

    /// Puts `net` in place of the network connected now, which is disconnected.
    fn replace(&self, net: Option<canola::Network>) -> PyResult<()> {
        self.emcy.attach(net.as_ref());
        if let Some(net) = &net {
            // The nodes added stay: the new connection knows them and their dictionaries.
            for node in lock(&self.nodes).values() {
                register(net, &node.get().link);
            }
        }
        self.generation.fetch_add(1, Ordering::SeqCst);
        let old = std::mem::replace(&mut *lock(&self.net), net);
        match old {
            Some(old) if old.is_driven() => old.stop_driver().map_err(crate::to_py_err),
            _ => Ok(()),
        }
    }
}

#[pymethods]
impl Network {
    /// A network on `bus` (a `MemoryBus`), or an unconnected one to `connect()` later.
    #[new]
    #[pyo3(signature = (bus = None))]
    fn new(bus: Option<&MemoryBus>) -> PyResult<Self> {
        let Some(bus) = bus else {
            return Ok(Self::with(None));
        };
        let net = canola::Network::new(bus.bus.endpoint());
        if bus.realtime {
            net.start_driver().map_err(crate::to_py_err)?;
        }
        Ok(Self::with(Some(net)))
    }

    /// A network on the bus named by this stack's bus specs, running by itself: a SocketCAN
    /// interface (`"can0"`, `"vcan0"`), `"udp[:GROUP[:PORT]][@IFACE]"` (python-can's
    /// udp_multicast bus) or an slcan adapter (`"slcan:/dev/ttyACM0@500k"`).
    #[staticmethod]
    fn open(spec: &str) -> PyResult<Self> {
        let this = Self::with(None);
        this.connect_spec(spec)?;
        Ok(this)
    }

    /// Connects to a bus as python-can's `can.Bus(...)` is told: `interface` (or the old
    /// `bustype`) `"socketcan"`, `"udp_multicast"`, `"slcan"` or `"virtual"` (an in-process bus
    /// shared by channel name), `channel`, `bitrate`. Returns the network.
    #[pyo3(signature = (*args, **kwargs))]
    fn connect<'py>(
        slf: Bound<'py, Self>,
        args: &Bound<'py, PyTuple>,
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, Self>> {
        let arg = |pos: usize, name: &str| -> PyResult<Option<Bound<'py, PyAny>>> {
            if let Some(v) = kwargs.map(|k| k.get_item(name)).transpose()?.flatten() {
                return Ok(Some(v));
            }
            Ok(args.get_item(pos).ok())
        };
        let channel: Option<String> = arg(0, "channel")?.map(|v| v.str()?.extract()).transpose()?;
        let interface: Option<String> = match arg(usize::MAX, "interface")? {
            Some(v) => Some(v.extract()?),
            None => arg(usize::MAX, "bustype")?
                .map(|v| v.extract())
                .transpose()?,
        };
        let bitrate: Option<u32> = arg(usize::MAX, "bitrate")?
            .map(|v| v.extract())
            .transpose()?;
        let interface = interface.unwrap_or_else(|| "socketcan".into());
        let this = slf.get();
        match interface.as_str() {
            "virtual" => {
                let bus = channel_bus(channel.as_deref().unwrap_or("channel-0"));
                let net = canola::Network::new(bus.endpoint());
                net.start_driver().map_err(crate::to_py_err)?;
                this.replace(Some(net))?;
            }
            "socketcan" => this.connect_spec(channel.as_deref().unwrap_or("can0"))?,
            "udp_multicast" => match channel {
                Some(group) => this.connect_spec(&format!("udp:{group}"))?,
                None => this.connect_spec("udp")?,
            },
            "slcan" => {
                let path = channel.ok_or_else(|| {
                    PyValueError::new_err("slcan needs channel= (the serial port)")
                })?;
                let spec = match bitrate {
                    Some(b) if b % 1000 == 0 => format!("slcan:{path}@{}k", b / 1000),
                    Some(b) => format!("slcan:{path}@{b}"),
                    None => format!("slcan:{path}"),
                };
                this.connect_spec(&spec)?;
            }
            other => {
                return Err(PyNotImplementedError::new_err(format!(
                    "interface {other:?} is not supported: use socketcan, udp_multicast, slcan \
                     or virtual, or Network.open() with a bus spec"
                )));
            }
        }
        Ok(slf)
    }

    /// Disconnects from the bus: stops the network's driver and closes the bus. Nodes made on
    /// the network stay, and fail until it is connected again.
    fn disconnect(&self) -> PyResult<()> {
        self.replace(None)
    }

    /// Adds a node: a node-ID with its object dictionary (an EDS/DCF path or bytes), or a
    /// `RemoteNode`. Returns the node.
    #[pyo3(signature = (node, object_dictionary = None, upload_eds = false))]
    fn add_node(
        slf: Bound<'_, Self>,
        node: &Bound<'_, PyAny>,
        object_dictionary: Option<&Bound<'_, PyAny>>,
        upload_eds: bool,
    ) -> PyResult<Py<RemoteNode>> {
        let py = slf.py();
        if upload_eds {
            return Err(PyNotImplementedError::new_err(
                "upload_eds is not supported yet: give the EDS file",
            ));
        }
        let node: Py<RemoteNode> = match node.cast::<RemoteNode>() {
            Ok(n) => n.clone().unbind(),
            Err(_) => {
                let id = self::node_id(node.extract()?)?;
                let od = object_dictionary.map(load_dictionary).transpose()?;
                Py::new(py, RemoteNode::from_link(NodeLink::new(id, od)))?
            }
        };
        let link = node.get().link.clone();
        link.attach(slf.clone().unbind());
        let this = slf.get();
        let net = this.connected()?;
        register(&net, &link);
        this.emcy.add(&node.get().emcy.get().shared);
        lock(&this.nodes).insert(link.id.get(), node.clone_ref(py));
        Ok(node)
    }

    /// NMT commands to every node (`network.nmt.state = "OPERATIONAL"`,
    /// `network.nmt.send_command(0x01)`).
    #[getter]
    fn nmt(&self, py: Python<'_>) -> Py<NmtMaster> {
        self.nmt.clone_ref(py)
    }

    /// The master's SYNC producer: `start(period)`, `stop()`, `transmit()`.
    #[getter]
    fn sync(&self, py: Python<'_>) -> Py<SyncProducer> {
        self.sync.clone_ref(py)
    }

    /// The node scanner: `search()`, then the node-IDs found in `nodes`.
    #[getter]
    fn scanner(&self, py: Python<'_>) -> Py<NodeScanner> {
        self.scanner.clone_ref(py)
    }

    /// The LSS master (CiA 305): switch state, configure and inquire, Fastscan.
    #[getter]
    fn lss(&self, py: Python<'_>) -> Py<LssMaster> {
        self.lss.clone_ref(py)
    }

    /// Sends one CAN frame: `can_id` (11-bit, or 29-bit when above 0x7FF or `extended`),
    /// up to 8 bytes of `data`, or a remote request of `len(data)` bytes when `remote`.
    #[pyo3(signature = (can_id, data, remote = false, extended = false))]
    fn send_message(
        &self,
        can_id: u32,
        data: &Bound<'_, PyAny>,
        remote: bool,
        extended: bool,
    ) -> PyResult<()> {
        let data: Vec<u8> = data
            .extract()
            .map_err(|_| PyTypeError::new_err("data is bytes, bytearray or a list of ints"))?;
        let id = if extended || can_id > 0x7FF {
            canola::CanId::extended(can_id)
        } else {
            canola::CanId::standard(can_id as u16)
        }
        .map_err(|e| PyValueError::new_err(format!("CAN-ID 0x{can_id:X}: {e}")))?;
        let frame = if remote {
            canola::CanFrame::remote(id, data.len())
        } else {
            canola::CanFrame::new(id, &data)
        }
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
        self.connected()?.send(frame).map_err(crate::to_py_err)
    }

    fn __getitem__(&self, py: Python<'_>, id: u8) -> PyResult<Py<RemoteNode>> {
        lock(&self.nodes)
            .get(&id)
            .map(|n| n.clone_ref(py))
            .ok_or_else(|| PyKeyError::new_err(id))
    }

    fn __contains__(&self, id: u8) -> bool {
        lock(&self.nodes).contains_key(&id)
    }

    fn __len__(&self) -> usize {
        lock(&self.nodes).len()
    }

    /// The node-IDs of the nodes added, in order.
    fn keys(&self) -> Vec<u16> {
        // As ints (a `Vec<u8>` would be `bytes`).
        lock(&self.nodes).keys().map(|&k| u16::from(k)).collect()
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let keys = pyo3::types::PyList::new(py, self.keys())?;
        Ok(keys.try_iter()?.into_any().unbind())
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __exit__(
        &self,
        _exc_type: &Bound<'_, PyAny>,
        _exc: &Bound<'_, PyAny>,
        _tb: &Bound<'_, PyAny>,
    ) -> PyResult<bool> {
        self.disconnect()?;
        Ok(false)
    }

    fn __repr__(&self) -> String {
        let connected = lock(&self.net).is_some();
        format!(
            "<canola.Network {}, {} node(s)>",
            if connected {
                "connected"
            } else {
                "not connected"
            },
            lock(&self.nodes).len()
        )
    }
}
