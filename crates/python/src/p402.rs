//! `canola.BaseNode402`: python-canopen's CiA 402 node (`state`, `op_mode`, `homing()`,
//! `statusword`, `controlword`, ...) on the stack's `canola_cia402::master::Drive`, and
//! `canola.Drive402Error`, the drive's typed errors.

use std::sync::Mutex;

use canola::Operation;
use canola_cia402::master::{Drive, DriveError, Timeouts};
use canola_cia402::mode::HomingStatus;
use canola_cia402::{ModeOfOperation, PlanError, State};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use crate::network::{load_dictionary, lock, node_id};
use crate::node::{NodeLink, RemoteNode};
use crate::{seconds, wait};

pyo3::create_exception!(
    canola,
    Drive402Error,
    PyRuntimeError,
    "A CiA 402 command failed: a wait timed out, the drive faulted, homing failed, no plan \
     reaches the state asked for. A RuntimeError, as python-canopen raises; `state` (the \
     drive's state name, or None) and `statusword` (int, or None) say what the drive showed."
);

/// python-canopen's state names, by the stack's state.
const STATES: [(State, &str); 8] = [
    (State::NotReadyToSwitchOn, "NOT READY TO SWITCH ON"),
    (State::SwitchOnDisabled, "SWITCH ON DISABLED"),
    (State::ReadyToSwitchOn, "READY TO SWITCH ON"),
    (State::SwitchedOn, "SWITCHED ON"),
    (State::OperationEnabled, "OPERATION ENABLED"),
    (State::QuickStopActive, "QUICK STOP ACTIVE"),
    (State::FaultReactionActive, "FAULT REACTION ACTIVE"),
    (State::Fault, "FAULT"),
];

/// python-canopen's mode names (`OperationMode.CODE2NAME`), by 0x6060/0x6061 code.
const MODES: [(i8, &str); 12] = [
    (0, "NO MODE"),
    (1, "PROFILED POSITION"),
    (2, "VELOCITY"),
    (3, "PROFILED VELOCITY"),
    (4, "PROFILED TORQUE"),
    (6, "HOMING"),
    (7, "INTERPOLATED POSITION"),
    (8, "CYCLIC SYNCHRONOUS POSITION"),
    (9, "CYCLIC SYNCHRONOUS VELOCITY"),
    (10, "CYCLIC SYNCHRONOUS TORQUE"),
    (-1, "OPEN LOOP SCALAR MODE"),
    (-2, "OPEN LOOP VECTOR MODE"),
];

fn state_name(state: Option<State>) -> &'static str {
    state
        .and_then(|s| STATES.iter().find(|(t, _)| *t == s))
        .map_or("UNKNOWN", |(_, n)| n)
}

fn mode_name(mode: ModeOfOperation) -> String {
    let code = mode.code();
    MODES
        .iter()
        .find(|(c, _)| *c == code)
        .map_or_else(|| format!("MODE {code}"), |(_, n)| (*n).to_string())
}

fn mode_of(name: &str) -> PyResult<ModeOfOperation> {
    MODES
        .iter()
        .find(|(_, n)| *n == name)
        .map(|(c, _)| ModeOfOperation::from_code(*c))
        .ok_or_else(|| {
            let names: Vec<&str> = MODES.iter().map(|(_, n)| *n).collect();
            PyValueError::new_err(format!(
                "unknown operation mode {name:?}: one of {}",
                names.join(", ")
            ))
        })
}

/// The state a name asks for: python-canopen's names; 'DISABLE VOLTAGE' (a command, not a
/// state) leads to switch on disabled. The states only the drive enters are a ValueError, as
/// in python-canopen.
fn target_state(name: &str) -> PyResult<State> {
    match name {
        "NOT READY TO SWITCH ON" | "FAULT REACTION ACTIVE" | "FAULT" => Err(PyValueError::new_err(
            format!("Target state {name} cannot be entered programmatically"),
        )),
        "DISABLE VOLTAGE" => Ok(State::SwitchOnDisabled),
        _ => STATES
            .iter()
            .find(|(_, n)| *n == name)
            .map(|(s, _)| *s)
            .ok_or_else(|| PyValueError::new_err(format!("unknown CiA 402 state {name:?}"))),
    }
}

/// The exception of a drive error: an SDO or network error as the rest of the package raises
/// it, everything else `Drive402Error` with the state and statusword the drive showed.
fn to_py_err(e: DriveError) -> PyErr {
    let (state, sw) = match &e {
        DriveError::Sdo(_) => {
            let DriveError::Sdo(e) = e else {
                unreachable!()
            };
            return crate::to_py_err(e);
        }
        DriveError::Timeout { statusword, .. }
        | DriveError::Fault { statusword, .. }
        | DriveError::Homing { statusword, .. }
        | DriveError::Plan(PlanError::UnknownState(statusword)) => {
            (State::decode(*statusword), Some(statusword.raw()))
        }
        DriveError::NotEnabled { state, statusword }
        | DriveError::Plan(PlanError::VoltageNotEnabled { state, statusword }) => {
            (Some(*state), Some(statusword.raw()))
        }
        DriveError::Plan(PlanError::NotCommandable(s) | PlanError::FaultResetNotAllowed(s)) => {
            (Some(*s), None)
        }
        _ => (None, None),
    };
    let err = Drive402Error::new_err(e.to_string());
    Python::attach(|py| {
        let v = err.value(py);
        let _ = v.setattr("state", state.map(|s| state_name(Some(s))));
        let _ = v.setattr("statusword", sw);
    });
    err
}

/// Finishes a drive command as `wait` finishes the facade's (GIL released, Ctrl-C cancels it:
/// a motion command cancelled stops the drive).
fn run<T: Send + 'static>(py: Python<'_>, op: Operation<'static, T, DriveError>) -> PyResult<T> {
    wait(py, Operation::new(async move { Ok(op.await) }))?.map_err(to_py_err)
}

/// A CiA 402 drive (python-canopen's `BaseNode402`): a `RemoteNode` with the drive's power
/// state machine, modes and homing, on the stack's CiA 402 master (axis 0).
///
/// Where it differs from python-canopen: every statusword is read by SDO when it is needed,
/// never from a cached TPDO (python-canopen #168, #554); a failed or timed-out command raises
/// `Drive402Error` (a RuntimeError naming the state and the statusword) rather than logging
/// and going on; an operation mode the drive refuses is its SDO abort (0x6502 is not read
/// first); a command interrupted (Ctrl-C) while the drive moves stops it with a quick stop.
#[pyclass(module = "canola", frozen, extends = RemoteNode)]
pub(crate) struct BaseNode402 {
    /// The drive on the network's current connection (rebuilt when it reconnects); its clones
    /// share the last controlword (the fault reset's rising edge).
    drive: Mutex<Option<(u64, Drive)>>,
    /// The waits' limits (python-canopen's `TIMEOUT_*`), the homing default in seconds.
    timeouts: Mutex<(Timeouts, f64)>,
}

impl BaseNode402 {
    fn drive(slf: &Bound<'_, Self>) -> PyResult<Drive> {
        let link = slf.as_super().get().link.clone();
        let generation = link.generation();
        let mut cell = lock(&slf.get().drive);
        let timeouts = lock(&slf.get().timeouts).0;
        if let Some((g, d)) = cell.as_ref()
            && *g == generation
        {
            return Ok(d.clone().with_timeouts(timeouts));
        }
        let d = Drive::new(link.node()?);
        *cell = Some((generation, d.clone()));
        Ok(d.with_timeouts(timeouts))
    }

    /// Sets one of the waits' limits from seconds.
    fn set_timeout(
        &self,
        value: f64,
        set: impl FnOnce(&mut Timeouts, canola::Duration),
    ) -> PyResult<()> {
        let d = seconds(value)?;
        set(&mut lock(&self.timeouts).0, d);
        Ok(())
    }

    fn timeout(&self, get: impl FnOnce(&Timeouts) -> canola::Duration) -> f64 {
        get(&lock(&self.timeouts).0).as_micros() as f64 / 1e6
    }
}

#[pymethods]
impl BaseNode402 {
    /// The drive `node_id` described by `object_dictionary` (an EDS/DCF path or bytes); add it
    /// with `network.add_node(node)`.
    #[new]
    fn new(
        node_id: i64,
        object_dictionary: &Bound<'_, PyAny>,
    ) -> PyResult<PyClassInitializer<Self>> {
        let id = self::node_id(node_id)?;
        let od = Some(load_dictionary(object_dictionary)?);
        Ok(
            PyClassInitializer::from(RemoteNode::from_link(NodeLink::new(id, od))).add_subclass(
                Self {
                    drive: Mutex::new(None),
                    timeouts: Mutex::new((Timeouts::default(), 30.0)),
                },
            ),
        )
    }

    /// Longest wait for one state transition, in seconds (1.0; python-canopen's 0.4). Each
    /// step of a walk to a state has it: a walk has no limit of its own.
    #[getter(TIMEOUT_SWITCH_STATE_SINGLE)]
    fn timeout_switch_state_single(&self) -> f64 {
        self.timeout(|t| t.transition)
    }

    #[setter(TIMEOUT_SWITCH_STATE_SINGLE)]
    fn set_timeout_switch_state_single(&self, value: f64) -> PyResult<()> {
        self.set_timeout(value, |t, d| t.transition = d)
    }

    /// Accepted for python-canopen's programs and unused: each step of a walk has
    /// `TIMEOUT_SWITCH_STATE_SINGLE`, which this shows.
    #[getter(TIMEOUT_SWITCH_STATE_FINAL)]
    fn timeout_switch_state_final(&self) -> f64 {
        self.timeout(|t| t.transition)
    }

    #[setter(TIMEOUT_SWITCH_STATE_FINAL)]
    fn set_timeout_switch_state_final(&self, value: f64) -> PyResult<()> {
        seconds(value).map(|_| ())
    }

    /// Longest wait for 0x6061 to show a new mode, in seconds (1.0; python-canopen's 0.5).
    #[getter(TIMEOUT_SWITCH_OP_MODE)]
    fn timeout_switch_op_mode(&self) -> f64 {
        self.timeout(|t| t.mode)
    }

    #[setter(TIMEOUT_SWITCH_OP_MODE)]
    fn set_timeout_switch_op_mode(&self, value: f64) -> PyResult<()> {
        self.set_timeout(value, |t, d| t.mode = d)
    }

    /// Longest wait for a fault to clear: one transition's, the same limit as
    /// `TIMEOUT_SWITCH_STATE_SINGLE` (setting one sets both).
    #[getter(TIMEOUT_RESET_FAULT)]
    fn timeout_reset_fault(&self) -> f64 {
        self.timeout(|t| t.transition)
    }

    #[setter(TIMEOUT_RESET_FAULT)]
    fn set_timeout_reset_fault(&self, value: f64) -> PyResult<()> {
        self.set_timeout(value, |t, d| t.transition = d)
    }

    /// `homing()`'s limit when it is given none, in seconds (30, as python-canopen's).
    #[getter(TIMEOUT_HOMING_DEFAULT)]
    fn timeout_homing_default(&self) -> f64 {
        lock(&self.timeouts).1
    }

    #[setter(TIMEOUT_HOMING_DEFAULT)]
    fn set_timeout_homing_default(&self, value: f64) -> PyResult<()> {
        seconds(value)?;
        lock(&self.timeouts).1 = value;
        Ok(())
    }

    /// Reads the node's PDO configuration (`read_pdos`, as python-canopen does: `node.tpdo`
    /// and `node.rpdo` hold it after) and checks that the drive answers with a statusword.
    /// python-canopen follows the statusword in TPDOs from here on; this one reads it by SDO
    /// when needed (a TPDO's value may be stale: python-canopen #168, #554).
    #[pyo3(signature = (read_pdos = true))]
    fn setup_402_state_machine(slf: &Bound<'_, Self>, read_pdos: bool) -> PyResult<()> {
        Self::setup_pdos(slf, read_pdos)?;
        run(slf.py(), Self::drive(slf)?.statusword()).map(|_| ())
    }

    /// `upload`: reads the node's PDO configuration by SDO (`node.pdo.read()`); without it,
    /// nothing (the master follows the TPDOs it knows already).
    #[pyo3(signature = (upload = true))]
    fn setup_pdos(slf: &Bound<'_, Self>, upload: bool) -> PyResult<()> {
        if upload {
            slf.getattr("pdo")?.call_method0("read")?;
        }
        Ok(())
    }

    /// The statusword 0x6041, read now.
    #[getter]
    fn statusword(slf: &Bound<'_, Self>) -> PyResult<u16> {
        run(slf.py(), Self::drive(slf)?.statusword()).map(|s| s.raw())
    }

    /// The statusword read now (python-canopen waits for the next TPDO; `timeout` is
    /// accepted and unused).
    #[pyo3(signature = (timeout = None))]
    fn check_statusword(slf: &Bound<'_, Self>, timeout: Option<f64>) -> PyResult<u16> {
        let _ = timeout;
        Self::statusword(slf)
    }

    /// Write-only, as in python-canopen: reading it is a RuntimeError.
    #[getter]
    fn controlword(&self) -> PyResult<u16> {
        Err(PyRuntimeError::new_err("The Controlword is write-only."))
    }

    /// Writes the controlword 0x6040 (by SDO).
    #[setter]
    fn set_controlword(slf: &Bound<'_, Self>, value: u16) -> PyResult<()> {
        let cw = canola_cia402::Controlword::from_raw(value);
        run(slf.py(), Self::drive(slf)?.write_controlword(cw))
    }

    /// The state the statusword shows now ('SWITCH ON DISABLED', 'OPERATION ENABLED', 'FAULT',
    /// ..., 'UNKNOWN' for a pattern no state has). Set it to walk the state machine there: from
    /// any state, a fault reset on the way when needed; raises `Drive402Error` when a step is not
    /// confirmed in time (1 s per transition) or the drive faults or has no voltage, ValueError
    /// for a state only the drive enters.
    #[getter]
    fn state(slf: &Bound<'_, Self>) -> PyResult<&'static str> {
        let sw = run(slf.py(), Self::drive(slf)?.statusword())?;
        Ok(state_name(State::decode(sw)))
    }

    #[setter]
    fn set_state(slf: &Bound<'_, Self>, target: &str) -> PyResult<()> {
        let target = target_state(target)?;
        run(slf.py(), Self::drive(slf)?.set_state(target)).map(|_| ())
    }

    /// The operation mode 0x6061 shows ('PROFILED POSITION', 'HOMING', 'CYCLIC SYNCHRONOUS
    /// POSITION', ...; 'MODE n' for a code python-canopen has no name for). Set it to write
    /// 0x6060 and wait until 0x6061 shows it; the power state is not changed. A mode the drive
    /// refuses is its SdoAbortedError, no confirmation in time a `Drive402Error` (python-canopen
    /// logs these and goes on).
    #[getter]
    fn op_mode(slf: &Bound<'_, Self>) -> PyResult<String> {
        run(slf.py(), Self::drive(slf)?.mode()).map(mode_name)
    }

    #[setter]
    fn set_op_mode(slf: &Bound<'_, Self>, mode: &str) -> PyResult<()> {
        let mode = mode_of(mode)?;
        run(slf.py(), Self::drive(slf)?.set_mode(mode)).map(|_| ())
    }

    /// Whether 0x6502 (supported drive modes) lists `mode` (read by SDO each time).
    fn is_op_mode_supported(slf: &Bound<'_, Self>, mode: &str) -> PyResult<bool> {
        let code = mode_of(mode)?.code();
        if code <= 0 {
            // python-canopen's table has no bit for these: it answers with a KeyError, this
            // one with False.
            return Ok(code == 0);
        }
        let node = Self::drive(slf)?.node().clone();
        let bits: u32 = wait(slf.py(), node.read_typed((0x6502, 0)))?;
        // python-canopen's `OperationMode.SUPPORTED`: bit n-1 for mode n.
        let bit = 1u32 << (code - 1);
        Ok(bits & bit == bit)
    }

    /// Whether the statusword shows a fault.
    fn is_faulted(slf: &Bound<'_, Self>) -> PyResult<bool> {
        let sw = run(slf.py(), Self::drive(slf)?.statusword())?;
        Ok(State::decode(sw) == Some(State::Fault))
    }

    /// A drive in fault: resets the fault (a rising edge of controlword bit 7) and enables it
    /// (operation enabled), as python-canopen does; a drive not in fault is left as it is.
    /// Raises `Drive402Error` when the fault does not clear in time.
    fn reset_from_fault(slf: &Bound<'_, Self>) -> PyResult<()> {
        let d = Self::drive(slf)?;
        run(
            slf.py(),
            Operation::new(async move {
                let report = d.fault_reset().await?;
                if matches!(report.from, State::Fault | State::FaultReactionActive) {
                    d.enable().await?;
                }
                Ok(())
            }),
        )
    }

    /// Homes with the method 0x6098 holds: mode homing, operation enabled, the start edge, then
    /// waits until homing is attained. Returns True. `timeout` in seconds (default
    /// `TIMEOUT_HOMING_DEFAULT`, 30; 0 for none). `restore_op_mode`: the mode before is selected again at the end, whatever the
    /// result. Where python-canopen logs a failure and returns False, this one raises
    /// `Drive402Error` (homing error, fault, timeout, with the statusword); interrupted
    /// (Ctrl-C), it stops the drive with a quick stop.
    #[pyo3(signature = (timeout = None, restore_op_mode = false))]
    fn homing(
        slf: &Bound<'_, Self>,
        timeout: Option<f64>,
        restore_op_mode: bool,
    ) -> PyResult<bool> {
        let limit = match timeout.unwrap_or(lock(&slf.get().timeouts).1) {
            0.0 => seconds(1e9)?,
            t => seconds(t)?,
        };
        let d = Self::drive(slf)?;
        let d = d.clone().with_timeouts(Timeouts {
            homing: limit,
            ..d.timeouts()
        });
        run(
            slf.py(),
            Operation::new(async move {
                let before = d.set_mode(ModeOfOperation::Homing).await?;
                d.enable().await?;
                let result = d.home(None).await;
                if restore_op_mode && before != ModeOfOperation::Homing {
                    let restored = d.set_mode(before).await;
                    result?;
                    restored?;
                } else {
                    result?;
                }
                Ok(true)
            }),
        )
    }

    /// Whether homing is attained: selects mode homing (when another runs) and reads the
    /// statusword (bits 10, 12, 13). `restore_op_mode`: the mode before is selected again.
    #[pyo3(signature = (restore_op_mode = false))]
    fn is_homed(slf: &Bound<'_, Self>, restore_op_mode: bool) -> PyResult<bool> {
        let d = Self::drive(slf)?;
        run(
            slf.py(),
            Operation::new(async move {
                let before = d.set_mode(ModeOfOperation::Homing).await?;
                let sw = d.statusword().await?;
                if restore_op_mode && before != ModeOfOperation::Homing {
                    d.set_mode(before).await?;
                }
                Ok(matches!(
                    HomingStatus::decode(sw),
                    HomingStatus::Attained | HomingStatus::Completed
                ))
            }),
        )
    }

    fn __repr__(slf: &Bound<'_, Self>) -> String {
        format!("<canola.BaseNode402 {}>", slf.as_super().get().link.id)
    }
}
