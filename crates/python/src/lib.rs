//! The Python package `canola`: the canola CANopen master, spoken in python-canopen's vocabulary
//! (`Network`, `add_node`, `node.sdo[...].raw`, `node.nmt.state`, `SdoAbortedError`), with the
//! in-memory bus and the device simulator for tests. Built by maturin into an abi3 wheel.
//!
//! This crate wraps the `canola` facade and holds no protocol logic. What it adds is what
//! Python needs: every wait releases the GIL and checks for signals (Ctrl-C) while it runs
//! (`wait`), every awaitable twin runs the facade's own async operation and resolves an
//! asyncio future (`awaitable`), and the facade's errors become the exceptions python-canopen
//! programs catch (`to_py_err`).

use std::future::IntoFuture;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::Poll;

use canola::{Error, Operation, SdoErrorKind};
use pyo3::exceptions::{PyException, PyKeyError, PyValueError};
use pyo3::prelude::*;

mod dispatch;
mod emcy;
mod lss;
mod network;
mod node;
mod od;
mod p402;
mod pdo;
mod sdo;
mod services;
mod usdo;

pyo3::create_exception!(
    canola,
    SdoError,
    PyException,
    "An SDO transfer failed (base of SdoAbortedError and SdoCommunicationError)."
);
pyo3::create_exception!(
    canola,
    SdoAbortedError,
    SdoError,
    "The node refused an SDO transfer: `code` is its abort code (CiA 301)."
);
pyo3::create_exception!(
    canola,
    SdoCommunicationError,
    SdoError,
    "No or no valid answer to an SDO transfer (timeout, protocol error, bus failure)."
);
pyo3::create_exception!(
    canola,
    NmtError,
    PyException,
    "An NMT wait ended without what it waited for (no boot-up, no heartbeat)."
);
pyo3::create_exception!(
    canola,
    NetworkError,
    PyException,
    "The bus could not be opened, failed, or is not connected."
);

/// How often a blocking wait looks for a pending signal (Ctrl-C): often enough that an
/// interrupt feels immediate, seldom enough that taking the GIL costs nothing measurable.
const SIGNAL_CHECK: std::time::Duration = std::time::Duration::from_millis(20);

/// Finishes `op` on this thread with the GIL released, driving the network as the facade's
/// blocking wait does. Every [`SIGNAL_CHECK`] it takes the GIL back for a moment to run
/// Python's signal handlers: when one raises (KeyboardInterrupt on Ctrl-C), the operation is
/// dropped, which cancels it (a running SDO transfer is aborted on the bus), and the handler's
/// exception is returned.
pub(crate) fn wait<T: Send + 'static>(py: Python<'_>, op: Operation<'static, T>) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    let stopped = stop.clone();
    let mut body = op.into_future();
    // The operation, ended early (`None`) once `stop` is set.
    let guarded = Operation::new(async move {
        std::future::poll_fn(|cx| {
            if stopped.load(Ordering::Relaxed) {
                return Poll::Ready(Ok(None));
            }
            body.as_mut().poll(cx).map(|r| r.map(Some))
        })
        .await
    });
    let mut interrupt: Option<PyErr> = None;
    let waiting = dispatch::Waiting::enter();
    let result = py.detach(|| {
        let mut last = std::time::Instant::now();
        canola::wait_all_with([guarded], || {
            dispatch::poll();
            if dispatch::pending() {
                Python::attach(dispatch::run_pending);
            }
            if interrupt.is_some() || last.elapsed() < SIGNAL_CHECK {
                return;
            }
            last = std::time::Instant::now();
            if let Err(e) = Python::attach(|py| py.check_signals()) {
                interrupt = Some(e);
                stop.store(true, Ordering::Relaxed);
            }
        })
        .pop()
    });
    // The callbacks of what came during the wait run before it returns.
    dispatch::poll();
    dispatch::run_pending(py);
    drop(waiting);
    match result {
        Some(Ok(Some(v))) => Ok(v),
        Some(Err(e)) => Err(to_py_err(e)),
        // Ended by a signal handler's exception.
        Some(Ok(None)) | None => Err(interrupt
            .unwrap_or_else(|| NetworkError::new_err("the operation ended without a result"))),
    }
}

/// An asyncio awaitable of `op`: the operation runs as the facade's async operation on the
/// shared tokio runtime (no thread per call), and its result (converted by `convert` with the
/// GIL held) resolves the awaitable on the caller's event loop.
pub(crate) fn awaitable<'py, T, R>(
    py: Python<'py>,
    op: Operation<'static, T>,
    convert: impl FnOnce(T) -> PyResult<R> + Send + 'static,
) -> PyResult<Bound<'py, PyAny>>
where
    T: Send + 'static,
    R: for<'a> IntoPyObject<'a> + Send + 'static,
{
    pyo3_async_runtimes::tokio::future_into_py(py, async move {
        match op.await {
            Ok(v) => convert(v),
            Err(e) => Err(to_py_err(e)),
        }
    })
}

/// The exception a python-canopen program expects for a facade error. Its text is the facade's
/// message (node, object and the abort code's meaning); SDO errors carry `node`, `index` and
/// `subindex` too, and an abort its `code`.
pub(crate) fn to_py_err(e: Error) -> PyErr {
    let text = e.to_string();
    match e {
        Error::Sdo(sdo) => {
            let err = match (&sdo.kind, sdo.server_abort()) {
                (_, Some(code)) => {
                    let err = SdoAbortedError::new_err(text);
                    set_attr(&err, "code", code.0);
                    err
                }
                (SdoErrorKind::Io { .. }, None) => PyValueError::new_err(text),
                _ => SdoCommunicationError::new_err(text),
            };
            set_attr(&err, "node", sdo.node.get());
            set_attr(&err, "index", sdo.entry.index);
            set_attr(&err, "subindex", sdo.entry.sub_index);
            err
        }
        Error::UnknownObject { .. } => PyKeyError::new_err(text),
        Error::Value { .. } => PyValueError::new_err(text),
        Error::Timeout { .. } => NmtError::new_err(text),
        Error::Lss(_) => lss::LssError::new_err(text),
        _ => NetworkError::new_err(text),
    }
}

/// Sets an attribute of an exception's value (best effort: an exception object takes any).
fn set_attr<V: for<'py> IntoPyObject<'py>>(err: &PyErr, name: &str, value: V) {
    // The GIL is held wherever errors are made into Python's; attaching again is cheap.
    Python::attach(|py| {
        let _ = err.value(py).setattr(name, value);
    });
}

/// The longest time in seconds a call takes (about 31 years): beyond it a deadline would leave
/// the clock's range.
const MAX_SECONDS: f64 = 1e9;

/// A duration in seconds from Python (a timeout), refused when negative, not finite or beyond
/// [`MAX_SECONDS`].
pub(crate) fn seconds(s: f64) -> PyResult<canola::Duration> {
    if !(0.0..=MAX_SECONDS).contains(&s) {
        return Err(PyValueError::new_err(format!(
            "a time in seconds is in 0..={MAX_SECONDS}, not {s}"
        )));
    }
    Ok(canola::Duration::from_micros((s * 1e6).round() as u64))
}

/// The module `canola`.
#[pymodule]
#[pyo3(name = "canola")]
fn canola_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SdoError", py.get_type::<SdoError>())?;
    m.add("SdoAbortedError", py.get_type::<SdoAbortedError>())?;
    m.add(
        "SdoCommunicationError",
        py.get_type::<SdoCommunicationError>(),
    )?;
    m.add("NmtError", py.get_type::<NmtError>())?;
    m.add("NetworkError", py.get_type::<NetworkError>())?;
    m.add_class::<network::Network>()?;
    m.add_class::<network::MemoryBus>()?;
    m.add_class::<network::SimDevice>()?;
    m.add_class::<network::SimService>()?;
    m.add_class::<node::RemoteNode>()?;
    m.add_class::<node::NmtMaster>()?;
    m.add_class::<sdo::SdoClient>()?;
    m.add_class::<sdo::SdoVariable>()?;
    m.add_class::<sdo::SdoRecord>()?;
    m.add_class::<sdo::SdoArray>()?;
    m.add_class::<sdo::SdoBits>()?;
    m.add("EmcyError", emcy::emcy_error_type(py)?)?;
    m.add_class::<emcy::EmcyConsumer>()?;
    m.add("LssError", py.get_type::<lss::LssError>())?;
    m.add_class::<lss::LssMaster>()?;
    m.add_class::<services::SyncProducer>()?;
    m.add_class::<services::NodeScanner>()?;
    m.add_function(wrap_pyfunction!(od::import_od, m)?)?;
    m.add_class::<od::ObjectDictionary>()?;
    m.add_class::<od::ODVariable>()?;
    m.add_class::<od::ODRecord>()?;
    m.add_class::<od::ODArray>()?;
    m.add_class::<pdo::Pdo>()?;
    m.add_class::<pdo::PdoBase>()?;
    m.add_class::<pdo::PdoMap>()?;
    m.add_class::<pdo::PdoVariable>()?;
    m.add_class::<p402::BaseNode402>()?;
    m.add_class::<usdo::UsdoClient>()?;
    m.add_class::<usdo::UsdoRecord>()?;
    m.add_class::<usdo::UsdoVariable>()?;
    m.add("Drive402Error", py.get_type::<p402::Drive402Error>())?;
    Ok(())
}
