//! `node.usdo` (CANopen FD, CiA 1301): the node's universal SDO in `node.sdo`'s shape,
//! objects by index or name as `UsdoVariable` (`raw`, `data`) and `UsdoRecord`, and the raw
//! `upload`/`download`. python-canopen has no USDO; the names follow its SDO client. The
//! node must be marked CANopen FD (`CANopenFD=1` in its EDS's `[DeviceInfo]`) and the bus
//! must carry CAN FD (`MemoryBus(fd=True)`, or an FD interface).

use std::sync::Arc;

use canola::od::{DataType, ObjectCode};
use canola::{ObjectAddress, Value, WriteValue};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::{PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyString};

use crate::node::NodeLink;
use crate::sdo::{address, data_bytes, value_to_py, write_value};
use crate::wait;

/// `value` as a value of `t` (what `node.sdo`'s `raw` setter converts; the facade's USDO
/// client writes bytes), or why not.
fn convert(value: WriteValue, t: DataType) -> Result<Value, String> {
    match value {
        WriteValue::Integer(v) if matches!(t, DataType::Real32) => Ok(Value::Real32(v as f32)),
        WriteValue::Integer(v) if matches!(t, DataType::Real64) => Ok(Value::Real64(v as f64)),
        WriteValue::Integer(v) => Value::from_i128_wrapping(t, v)
            .filter(|x| x.as_i128() == Some(v))
            .ok_or_else(|| format!("{v} does not fit {t:?}")),
        WriteValue::Float(f) if matches!(t, DataType::Real32) => Ok(Value::Real32(f as f32)),
        WriteValue::Float(f) if matches!(t, DataType::Real64) => Ok(Value::Real64(f)),
        WriteValue::Text(s) if matches!(t, DataType::VisibleString) => {
            Ok(Value::VisibleString(s.into_bytes()))
        }
        WriteValue::Text(s) if matches!(t, DataType::UnicodeString) => {
            Ok(Value::UnicodeString(s.encode_utf16().collect()))
        }
        WriteValue::Bytes(b) => {
            Value::from_le_bytes_unsized(t, &b).map_err(|e| format!("{} bytes: {e}", b.len()))
        }
        WriteValue::Value(v) => Ok(v),
        other => Err(format!("{other:?} cannot be written to {t:?}")),
    }
}

/// The node's USDO client (`node.usdo`).
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct UsdoClient {
    link: Arc<NodeLink>,
}

impl UsdoClient {
    pub(crate) fn new(link: Arc<NodeLink>) -> Self {
        Self { link }
    }
}

fn usdo(link: &NodeLink) -> PyResult<canola::Usdo> {
    Ok(link.node()?.usdo())
}

#[pymethods]
impl UsdoClient {
    /// An object by index or name (as `node.sdo[...]`): a `UsdoVariable`, or a `UsdoRecord`
    /// (records and arrays) to index further.
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let od = self.link.od.as_deref().ok_or_else(|| {
            PyKeyError::new_err(format!(
                "node {}: {key}: the node has no object dictionary (add it with an EDS)",
                self.link.id
            ))
        })?;
        let object = if let Ok(name) = key.cast::<PyString>() {
            let name: String = name.extract()?;
            match (od.find_object(&name), od.find(&name)) {
                (Some(o), _) => o,
                (None, Some(at)) => return UsdoVariable::new(&self.link, at).into_py_any(py),
                (None, None) => {
                    return Err(PyKeyError::new_err(format!(
                        "node {}: no object {name:?} in the node's dictionary",
                        self.link.id
                    )));
                }
            }
        } else {
            let index: u16 = key
                .extract()
                .map_err(|_| PyKeyError::new_err(format!("{key} is not an index or a name")))?;
            od.get(index).ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "node {}: no object 0x{index:04X} in the node's dictionary",
                    self.link.id
                ))
            })?
        };
        match object.object_code {
            ObjectCode::Array | ObjectCode::Record | ObjectCode::DefStruct => UsdoRecord {
                link: self.link.clone(),
                index: object.index,
            }
            .into_py_any(py),
            _ => UsdoVariable::new(&self.link, ObjectAddress::new(object.index, 0)).into_py_any(py),
        }
    }

    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> bool {
        self.__getitem__(py, key).is_ok()
    }

    /// Reads an object's bytes (USDO upload: expedited up to 56 bytes, segmented beyond).
    fn upload<'py>(
        &self,
        py: Python<'py>,
        index: i64,
        subindex: i64,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let op = usdo(&self.link)?.read(address(index, subindex)?);
        Ok(PyBytes::new(py, &wait(py, op)?))
    }

    /// Writes an object's bytes (USDO download, the data type announced from the dictionary).
    fn download(
        &self,
        py: Python<'_>,
        index: i64,
        subindex: i64,
        data: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let op = usdo(&self.link)?.write(address(index, subindex)?, data_bytes(data)?);
        wait(py, op)
    }

    fn __repr__(&self) -> String {
        format!("<canola.UsdoClient of node {}>", self.link.id)
    }
}

/// A RECORD or ARRAY object over USDO: sub-objects by sub-index or name.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct UsdoRecord {
    link: Arc<NodeLink>,
    index: u16,
}

#[pymethods]
impl UsdoRecord {
    fn __getitem__(&self, key: &Bound<'_, PyAny>) -> PyResult<UsdoVariable> {
        let object = self.link.od.as_deref().and_then(|od| od.get(self.index));
        let found = match key.cast::<PyString>() {
            Ok(name) => {
                let name: String = name.extract()?;
                object.and_then(|o| {
                    o.subs
                        .values()
                        .find(|s| s.name.eq_ignore_ascii_case(&name))
                        .map(|s| s.sub_index)
                })
            }
            Err(_) => {
                let sub: u8 = key.extract().map_err(|_| {
                    PyKeyError::new_err(format!("{key} is not a sub-index or a name"))
                })?;
                object.and_then(|o| o.sub(sub)).map(|s| s.sub_index)
            }
        };
        match found {
            Some(sub) => Ok(UsdoVariable::new(
                &self.link,
                ObjectAddress::new(self.index, sub),
            )),
            None => Err(PyKeyError::new_err(format!(
                "node {}: object 0x{:04X} has no sub-object {key} in the node's dictionary",
                self.link.id, self.index
            ))),
        }
    }

    /// The object's index.
    #[getter]
    fn index(&self) -> u16 {
        self.index
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.UsdoRecord 0x{:04X} of node {}>",
            self.index, self.link.id
        )
    }
}

/// One value of the node's dictionary over USDO.
#[pyclass(module = "canola", frozen)]
pub(crate) struct UsdoVariable {
    link: Arc<NodeLink>,
    at: ObjectAddress,
}

impl UsdoVariable {
    fn new(link: &Arc<NodeLink>, at: ObjectAddress) -> Self {
        Self {
            link: link.clone(),
            at,
        }
    }
}

#[pymethods]
impl UsdoVariable {
    /// The value, decoded with the object's data type (read by USDO); setting it converts
    /// the value to that type (an error before anything is sent if it does not fit) and
    /// writes it.
    #[getter]
    fn raw(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let value = wait(py, usdo(&self.link)?.read_value(self.at))?;
        value_to_py(py, value)
    }

    #[setter]
    fn set_raw(&self, py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let data_type = self
            .link
            .od
            .as_deref()
            .and_then(|od| od.sub(self.at.index, self.at.sub_index))
            .map(|s| s.data_type)
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "node {}: {}: the node's dictionary does not describe this object",
                    self.link.id, self.at
                ))
            })?;
        let typed = convert(write_value(value)?, data_type).map_err(|why| {
            PyValueError::new_err(format!("node {}: {}: {why}", self.link.id, self.at))
        })?;
        wait(py, usdo(&self.link)?.write(self.at, typed))
    }

    /// The object's bytes (read by USDO); setting writes bytes as given.
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let data = wait(py, usdo(&self.link)?.read(self.at))?;
        Ok(PyBytes::new(py, &data))
    }

    #[setter]
    fn set_data(&self, py: Python<'_>, data: &Bound<'_, PyAny>) -> PyResult<()> {
        wait(py, usdo(&self.link)?.write(self.at, data_bytes(data)?))
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

    fn __repr__(&self) -> String {
        format!(
            "<canola.UsdoVariable at {} of node {}>",
            self.at, self.link.id
        )
    }
}
