//! `node.sdo` (python-canopen's `SdoClient`): objects by index or name as `SdoVariable`,
//! `SdoRecord` and `SdoArray`, values decoded by the node's dictionary (`.raw`), and the raw
//! `upload`/`download`, each with an awaitable twin (`aget_raw`, `aset_raw`, `aupload`,
//! `adownload`).

use std::sync::Arc;

use canola::od::{Object, ObjectCode};
use canola::{ObjectAddress, Value, WriteValue};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyByteArray, PyBytes, PyFloat, PyInt, PyString};

use crate::node::NodeLink;
use crate::{awaitable, wait};

/// A decoded value as python-canopen gives it: `int`, `bool`, `float`, `str` for the string
/// types (trailing NULs stripped), `bytes` for the rest.
pub(crate) fn value_to_py(py: Python<'_>, v: Value) -> PyResult<Py<PyAny>> {
    let text = |s: String| s.trim_end_matches('\0').to_string();
    match v {
        Value::Boolean(b) => b.into_py_any(py),
        Value::Real32(f) => f64::from(f).into_py_any(py),
        Value::Real64(f) => f.into_py_any(py),
        Value::VisibleString(b) => text(String::from_utf8_lossy(&b).into_owned()).into_py_any(py),
        Value::UnicodeString(u) => text(String::from_utf16_lossy(&u)).into_py_any(py),
        Value::OctetString(b) | Value::Domain(b) => PyBytes::new(py, &b).into_py_any(py),
        other => match other.as_i128() {
            Some(i) => i.into_py_any(py),
            None => PyBytes::new(py, &other.to_le_bytes()).into_py_any(py),
        },
    }
}

/// A Python value to write, converted to the object's type by the facade.
pub(crate) fn write_value(v: &Bound<'_, PyAny>) -> PyResult<WriteValue> {
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(WriteValue::from(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        if let Ok(i) = v.extract::<i64>() {
            return Ok(WriteValue::Integer(i.into()));
        }
        let u: u64 = v
            .extract()
            .map_err(|_| PyValueError::new_err(format!("{v} does not fit any CANopen integer")))?;
        return Ok(WriteValue::Integer(u.into()));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(WriteValue::Float(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(WriteValue::Text(s.extract()?));
    }
    if v.is_instance_of::<PyBytes>() || v.is_instance_of::<PyByteArray>() {
        return Ok(WriteValue::Bytes(v.extract()?));
    }
    Err(PyTypeError::new_err(format!(
        "a value to write is an int, bool, float, str or bytes, not {}",
        v.get_type().name()?
    )))
}

/// The writable raw file `open("wb")` gives: it collects what is written and downloads it
/// when closed (a Python class: an `io.RawIOBase` subclass).
const SDO_WRITER: &std::ffi::CStr = cr#"
import io

class SdoWriter(io.RawIOBase):
    """An SDO object's value opened for writing: downloaded whole on close()."""

    def __init__(self, variable, block_transfer):
        super().__init__()
        self._variable = variable
        self._block_transfer = block_transfer
        self._data = bytearray()

    def writable(self):
        return True

    def write(self, b):
        self._data += b
        return len(b)

    def close(self):
        if not self.closed:
            try:
                self._variable._download(bytes(self._data), self._block_transfer)
            finally:
                super().close()
"#;

static SDO_WRITER_TYPE: pyo3::sync::PyOnceLock<Py<pyo3::types::PyType>> =
    pyo3::sync::PyOnceLock::new();

fn sdo_writer_type(py: Python<'_>) -> PyResult<&Bound<'_, pyo3::types::PyType>> {
    SDO_WRITER_TYPE
        .get_or_try_init(py, || {
            let module = PyModule::from_code(
                py,
                SDO_WRITER,
                c"canola_sdo_writer.py",
                c"canola_sdo_writer",
            )?;
            Ok::<_, PyErr>(
                module
                    .getattr("SdoWriter")?
                    .cast_into::<pyo3::types::PyType>()?
                    .unbind(),
            )
        })
        .map(|t| t.bind(py))
}

/// Bytes from Python (`bytes`, `bytearray` or any buffer of bytes).
pub(crate) fn data_bytes(data: &Bound<'_, PyAny>) -> PyResult<Vec<u8>> {
    data.extract()
        .map_err(|_| PyTypeError::new_err("data to download is bytes or bytearray"))
}

/// An SDO address from Python, checked.
pub(crate) fn address(index: i64, subindex: i64) -> PyResult<ObjectAddress> {
    match (u16::try_from(index), u8::try_from(subindex)) {
        (Ok(i), Ok(s)) => Ok(ObjectAddress::new(i, s)),
        _ => Err(PyValueError::new_err(format!(
            "0x{index:X}:{subindex} is not an object address (index 0..=0xFFFF, sub-index 0..=255)"
        ))),
    }
}

/// The SDO client of a node (`node.sdo`).
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct SdoClient {
    link: Arc<NodeLink>,
}

impl SdoClient {
    pub(crate) fn new(link: Arc<NodeLink>) -> Self {
        Self { link }
    }

    /// The facade's SDO handle of the node, segmented when `force_segment`.
    fn sdo(&self, force_segment: bool) -> PyResult<canola::Sdo> {
        let sdo = self.link.node()?.sdo();
        Ok(if force_segment {
            sdo.method(canola::Method::Segmented)
        } else {
            sdo
        })
    }

    /// The node's dictionary, or the error that `key` cannot be looked up without one.
    fn dictionary(&self, key: &dyn std::fmt::Display) -> PyResult<&canola::ObjectDictionary> {
        self.link.od.as_deref().ok_or_else(|| {
            PyKeyError::new_err(format!(
                "node {}: {key}: the node has no object dictionary (add it with an EDS)",
                self.link.id
            ))
        })
    }
}

/// The Python handle of `object` in the dictionary of `link`'s node.
fn object_handle(py: Python<'_>, link: &Arc<NodeLink>, object: &Object) -> PyResult<Py<PyAny>> {
    match object.object_code {
        ObjectCode::Array => SdoArray {
            link: link.clone(),
            index: object.index,
        }
        .into_py_any(py),
        ObjectCode::Record | ObjectCode::DefStruct => SdoRecord {
            link: link.clone(),
            index: object.index,
        }
        .into_py_any(py),
        _ => SdoVariable::new(link, ObjectAddress::new(object.index, 0)).into_py_any(py),
    }
}

#[pymethods]
impl SdoClient {
    /// An object by index (`0x1017`) or name (`"Producer heartbeat time"`, or
    /// `"Identity object.Vendor-ID"` for a sub-object): an `SdoVariable`, or an `SdoRecord` /
    /// `SdoArray` to index further.
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let od = self.dictionary(&key.str()?)?;
        let missing = |what: String| {
            PyKeyError::new_err(format!(
                "node {}: no object {what} in the node's dictionary",
                self.link.id
            ))
        };
        if let Ok(name) = key.cast::<PyString>() {
            let name: String = name.extract()?;
            let name = name.as_str();
            if let Some(object) = od.find_object(name) {
                return object_handle(py, &self.link, object);
            }
            return match od.find(name) {
                Some(at) => SdoVariable::new(&self.link, at).into_py_any(py),
                None => Err(missing(format!("{name:?}"))),
            };
        }
        let index: u16 = key
            .extract()
            .map_err(|_| PyKeyError::new_err(format!("{key} is not an index or a name")))?;
        match od.get(index) {
            Some(object) => object_handle(py, &self.link, object),
            None => Err(missing(format!("0x{index:04X}"))),
        }
    }

    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> bool {
        self.__getitem__(py, key).is_ok()
    }

    /// Reads an object's bytes (SDO upload).
    fn upload<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        subindex: i64,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let op = self.sdo(false)?.read(address(index, subindex)?);
        Ok(PyBytes::new(py, &wait(py, op)?))
    }

    /// Writes an object's bytes (SDO download); `force_segment` sends even 4 bytes or fewer
    /// segmented.
    #[pyo3(signature = (index, subindex, data, force_segment = false))]
    fn download(
        &self,
        py: Python<'_>,
        index: i64,
        subindex: i64,
        data: &Bound<'_, PyAny>,
        force_segment: bool,
    ) -> PyResult<()> {
        let op = self
            .sdo(force_segment)?
            .write(address(index, subindex)?, data_bytes(data)?);
        wait(py, op)
    }

    /// `upload`, awaitable.
    fn aupload<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        subindex: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let op = self.sdo(false)?.read(address(index, subindex)?);
        awaitable(py, op, |data| {
            Ok(Python::attach(|py| PyBytes::new(py, &data).unbind()))
        })
    }

    /// `download`, awaitable.
    #[pyo3(signature = (index, subindex, data, force_segment = false))]
    fn adownload<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        subindex: i64,
        data: &Bound<'py, PyAny>,
        force_segment: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let op = self
            .sdo(force_segment)?
            .write(address(index, subindex)?, data_bytes(data)?);
        awaitable(py, op, |()| Ok(()))
    }

    fn __repr__(&self) -> String {
        format!("<canola.SdoClient node {}>", self.link.id)
    }
}

/// The bits of an integer value (python-canopen's `Bits`, `var.bits`): the value as read when
/// it was made; setting bits writes the whole value back.
#[pyclass(module = "canola", frozen)]
pub(crate) struct SdoBits {
    var: Py<SdoVariable>,
    raw: std::sync::Mutex<i128>,
}

/// The bit numbers `key` names: an int, a slice with start and stop, or a list of ints.
fn bit_numbers(key: &Bound<'_, PyAny>) -> PyResult<Vec<u32>> {
    let numbers: Vec<i64> = if let Ok(n) = key.extract::<i64>() {
        vec![n]
    } else if let Ok(slice) = key.cast::<pyo3::types::PySlice>() {
        let part = |name: &str| -> PyResult<Option<i64>> { slice.getattr(name)?.extract() };
        let (Some(start), Some(stop)) = (part("start")?, part("stop")?) else {
            return Err(PyValueError::new_err(
                "a slice of bits gives start and stop",
            ));
        };
        let step = part("step")?.unwrap_or(1);
        if step <= 0 {
            return Err(PyValueError::new_err("a slice of bits steps upwards"));
        }
        (start..stop).step_by(step as usize).collect()
    } else {
        key.extract().map_err(|_| {
            PyKeyError::new_err(
                "bits are named by number, slice or list (the dictionary names no bits)",
            )
        })?
    };
    if numbers.is_empty() {
        return Err(PyValueError::new_err("no bits named"));
    }
    numbers
        .into_iter()
        .map(|n| {
            u32::try_from(n)
                .ok()
                .filter(|n| *n < 64)
                .ok_or_else(|| PyValueError::new_err(format!("bit {n} is not in 0..64")))
        })
        .collect()
}

#[pymethods]
impl SdoBits {
    /// The bits' value: `(raw & mask) >> lowest bit`.
    fn __getitem__(&self, key: &Bound<'_, PyAny>) -> PyResult<i128> {
        let bits = bit_numbers(key)?;
        let mask = bits.iter().fold(0i128, |m, b| m | 1 << b);
        let low = bits.iter().min().copied().unwrap_or(0);
        Ok((*crate::network::lock(&self.raw) & mask) >> low)
    }

    /// Sets the bits to `value` (shifted to the lowest bit) and writes the value.
    fn __setitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>, value: i128) -> PyResult<()> {
        let bits = bit_numbers(key)?;
        let mask = bits.iter().fold(0i128, |m, b| m | 1 << b);
        let low = bits.iter().min().copied().unwrap_or(0);
        let raw = {
            let mut raw = crate::network::lock(&self.raw);
            *raw = (*raw & !mask) | ((value << low) & mask);
            *raw
        };
        let raw = raw.into_pyobject(py)?;
        self.var.get().set_raw(py, raw.as_any())
    }
}

/// One value of a node's dictionary, read and written over SDO (python-canopen's
/// `SdoVariable`).
#[pyclass(module = "canola", frozen)]
pub(crate) struct SdoVariable {
    link: Arc<NodeLink>,
    at: ObjectAddress,
}

impl SdoVariable {
    fn new(link: &Arc<NodeLink>, at: ObjectAddress) -> Self {
        Self {
            link: link.clone(),
            at,
        }
    }

    fn sdo(&self) -> PyResult<canola::Sdo> {
        Ok(self.link.node()?.sdo())
    }

    fn object(&self) -> Option<&Object> {
        self.link.od.as_deref()?.get(self.at.index)
    }
}

#[pymethods]
impl SdoVariable {
    /// The value, decoded with the object's data type (reading it over SDO); setting it
    /// converts the value to that type (an error before anything is sent if it does not fit)
    /// and writes it.
    #[getter]
    fn raw(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let value = wait(py, self.sdo()?.read_value(self.at))?;
        value_to_py(py, value)
    }

    #[setter]
    fn set_raw(&self, py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let op = self.sdo()?.set(self.at, write_value(value)?);
        wait(py, op)
    }

    /// The object's bytes as they go over the bus (reading); setting writes bytes as given.
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let data = wait(py, self.sdo()?.read(self.at))?;
        Ok(PyBytes::new(py, &data))
    }

    #[setter]
    fn set_data(&self, py: Python<'_>, data: &Bound<'_, PyAny>) -> PyResult<()> {
        let op = self.sdo()?.write(self.at, data_bytes(data)?);
        wait(py, op)
    }

    /// The physical value: `raw` times the object's factor, which is 1 (the stack's
    /// dictionary has no `Factor`, a python-canopen extension of EDS); setting it sets `raw`.
    #[getter]
    fn phys(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.raw(py)
    }

    #[setter]
    fn set_phys(&self, py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set_raw(py, value)
    }

    /// The bits of the (integer) value, read now: `var.bits[3]`, `var.bits[0:4]`,
    /// `var.bits[[0, 2]]`; setting some writes the value back.
    #[getter]
    fn bits(slf: Bound<'_, Self>) -> PyResult<SdoBits> {
        let py = slf.py();
        let raw = slf.get().raw(py)?;
        let raw: i128 = raw.bind(py).extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "{} is not an integer: it has no bits",
                slf.get().name()
            ))
        })?;
        Ok(SdoBits {
            var: slf.unbind(),
            raw: std::sync::Mutex::new(raw),
        })
    }

    /// Reads the value; `fmt` is `"raw"` or `"phys"`.
    #[pyo3(signature = (fmt = "raw"))]
    fn read(&self, py: Python<'_>, fmt: &str) -> PyResult<Py<PyAny>> {
        match fmt {
            "raw" => self.raw(py),
            "phys" => self.phys(py),
            _ => Err(PyValueError::new_err(format!(
                "format {fmt:?} is not supported (\"raw\" or \"phys\"; no value descriptions)"
            ))),
        }
    }

    /// Writes the value; `fmt` is `"raw"` or `"phys"`.
    #[pyo3(signature = (value, fmt = "raw"))]
    fn write(&self, py: Python<'_>, value: &Bound<'_, PyAny>, fmt: &str) -> PyResult<()> {
        match fmt {
            "raw" => self.set_raw(py, value),
            "phys" => self.set_phys(py, value),
            _ => Err(PyValueError::new_err(format!(
                "format {fmt:?} is not supported (\"raw\" or \"phys\"; no value descriptions)"
            ))),
        }
    }

    /// The value as a file (python-canopen's `open`): `"rb"` / `"r"` read it (uploaded whole
    /// when the file is opened), `"wb"` / `"w"` write it (downloaded whole when the file is
    /// closed); text (no `"b"`) in `encoding`. `block_transfer` uses SDO block transfer.
    /// `buffering`, `size` and `request_crc_support` are accepted for python-canopen's
    /// signature (block transfers always check the CRC).
    #[pyo3(signature = (
        mode = "rb", encoding = "ascii", buffering = 1024, size = None, block_transfer = false,
        request_crc_support = true
    ))]
    #[allow(clippy::too_many_arguments)]
    fn open(
        slf: Bound<'_, Self>,
        mode: &str,
        encoding: &str,
        buffering: i64,
        size: Option<u64>,
        block_transfer: bool,
        request_crc_support: bool,
    ) -> PyResult<Py<PyAny>> {
        let _ = (buffering, size, request_crc_support);
        let py = slf.py();
        let io = py.import("io")?;
        let text = !mode.contains('b');
        let file = if mode.contains('r') {
            let sdo = slf.get().sdo()?.block(block_transfer);
            let data = wait(py, sdo.read(slf.get().at))?;
            io.getattr("BytesIO")?.call1((PyBytes::new(py, &data),))?
        } else if mode.contains('w') {
            let writer = sdo_writer_type(py)?.call1((slf.clone(), block_transfer))?;
            if text {
                io.getattr("BufferedWriter")?.call1((writer,))?
            } else {
                writer
            }
        } else {
            return Err(PyValueError::new_err(format!(
                "mode {mode:?} neither reads (r) nor writes (w)"
            )));
        };
        if text {
            let kwargs = pyo3::types::PyDict::new(py);
            kwargs.set_item("encoding", encoding)?;
            return Ok(io
                .getattr("TextIOWrapper")?
                .call((file,), Some(&kwargs))?
                .unbind());
        }
        Ok(file.unbind())
    }

    /// Downloads `data` (what a file from `open("wb")` does when it is closed).
    #[pyo3(signature = (data, block_transfer = false))]
    fn _download(
        &self,
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        block_transfer: bool,
    ) -> PyResult<()> {
        let op = self
            .sdo()?
            .block(block_transfer)
            .write(self.at, data_bytes(data)?);
        wait(py, op)
    }

    /// `raw`, awaitable: `value = await var.aget_raw()`.
    fn aget_raw<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let op = self.sdo()?.read_value(self.at);
        awaitable(py, op, |v| Python::attach(|py| value_to_py(py, v)))
    }

    /// `raw = value`, awaitable: `await var.aset_raw(value)`.
    fn aset_raw<'py>(
        &self,
        py: Python<'py>,
        value: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let op = self.sdo()?.set(self.at, write_value(value)?);
        awaitable(py, op, |()| Ok(()))
    }

    /// The object's index.
    #[getter]
    fn index(&self) -> u16 {
        self.at.index
    }

    /// The sub-index.
    #[getter]
    fn subindex(&self) -> u8 {
        self.at.sub_index
    }

    /// The name in the dictionary (a sub-object's own name, as python-canopen gives it).
    #[getter]
    fn name(&self) -> String {
        let Some(object) = self.object() else {
            return String::new();
        };
        if object.is_simple() {
            return object.name.to_string();
        }
        object
            .sub(self.at.sub_index)
            .map_or_else(String::new, |s| s.name.to_string())
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.SdoVariable {:?} at {} of node {}>",
            self.name(),
            self.at,
            self.link.id
        )
    }
}

/// The sub-object of `index` that `key` (a sub-index or a sub-object's name) names.
fn sub_object(
    py: Python<'_>,
    link: &Arc<NodeLink>,
    index: u16,
    key: &Bound<'_, PyAny>,
) -> PyResult<Py<SdoVariable>> {
    let object = link.od.as_deref().and_then(|od| od.get(index));
    let found = match key.cast::<PyString>() {
        Ok(name) => {
            let name: String = name.extract()?;
            let name = name.as_str();
            object.and_then(|o| {
                o.subs
                    .values()
                    .find(|s| s.name.eq_ignore_ascii_case(name))
                    .map(|s| s.sub_index)
            })
        }
        Err(_) => {
            let sub: u8 = key
                .extract()
                .map_err(|_| PyKeyError::new_err(format!("{key} is not a sub-index or a name")))?;
            object.and_then(|o| o.sub(sub)).map(|s| s.sub_index)
        }
    };
    match found {
        Some(sub) => Py::new(py, SdoVariable::new(link, ObjectAddress::new(index, sub))),
        None => Err(PyKeyError::new_err(format!(
            "node {}: object 0x{index:04X} has no sub-object {key} in the node's dictionary",
            link.id
        ))),
    }
}

/// The sub-indices `index` has in the dictionary of `link`'s node.
fn sub_indices(link: &NodeLink, index: u16) -> Vec<u8> {
    link.od
        .as_deref()
        .and_then(|od| od.get(index))
        .map(|o| o.subs.values().map(|s| s.sub_index).collect())
        .unwrap_or_default()
}

/// A RECORD object (python-canopen's `SdoRecord`): sub-objects by sub-index or name.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct SdoRecord {
    link: Arc<NodeLink>,
    index: u16,
}

#[pymethods]
impl SdoRecord {
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<SdoVariable>> {
        sub_object(py, &self.link, self.index, key)
    }

    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> bool {
        sub_object(py, &self.link, self.index, key).is_ok()
    }

    /// The number of sub-objects in the dictionary.
    fn __len__(&self) -> usize {
        sub_indices(&self.link, self.index).len()
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let subs = pyo3::types::PyList::new(py, sub_indices(&self.link, self.index))?;
        Ok(subs.try_iter()?.into_any().unbind())
    }

    /// The object's index.
    #[getter]
    fn index(&self) -> u16 {
        self.index
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.SdoRecord 0x{:04X} of node {}>",
            self.index, self.link.id
        )
    }
}

/// An ARRAY object (python-canopen's `SdoArray`): elements by sub-index or name; its length is
/// the element count the node reports at sub-index 0.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct SdoArray {
    link: Arc<NodeLink>,
    index: u16,
}

#[pymethods]
impl SdoArray {
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<SdoVariable>> {
        sub_object(py, &self.link, self.index, key)
    }

    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> bool {
        sub_object(py, &self.link, self.index, key).is_ok()
    }

    /// The number of elements, read from the node (sub-index 0), as python-canopen does.
    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        let op = self
            .link
            .node()?
            .sdo()
            .read_typed::<u8>(ObjectAddress::new(self.index, 0));
        Ok(usize::from(wait(py, op)?))
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let subs = pyo3::types::PyList::new(py, sub_indices(&self.link, self.index))?;
        Ok(subs.try_iter()?.into_any().unbind())
    }

    /// The object's index.
    #[getter]
    fn index(&self) -> u16 {
        self.index
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.SdoArray 0x{:04X} of node {}>",
            self.index, self.link.id
        )
    }
}
