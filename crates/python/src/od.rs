//! `canola.import_od` and the dictionary it gives (python-canopen's `ObjectDictionary`,
//! `ODVariable`, `ODRecord`, `ODArray`), read-only views of the stack's parsed EDS/DCF
//! (`canola::od`): what a program looks up about an object without the bus.

use std::sync::Arc;

use canola::od::{FieldValue, Object, ObjectCode, SubObject};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::network::load_dictionary;
use crate::sdo::value_to_py;

/// An object dictionary (`canola.import_od(...)`, `node.object_dictionary`): objects by index
/// or name.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct ObjectDictionary {
    pub(crate) od: Arc<canola::ObjectDictionary>,
    /// The node-ID `$NODEID` stands for in values (0 when none was given).
    node_id: Option<u8>,
}

impl ObjectDictionary {
    pub(crate) fn new(od: Arc<canola::ObjectDictionary>, node_id: Option<u8>) -> Self {
        Self { od, node_id }
    }

    fn handle(&self, py: Python<'_>, object: &Object) -> PyResult<Py<PyAny>> {
        let view = ObjectView {
            od: self.od.clone(),
            index: object.index,
            node_id: self.node_id,
        };
        match object.object_code {
            ObjectCode::Array => ODArray(view).into_py_any(py),
            ObjectCode::Record | ObjectCode::DefStruct => ODRecord(view).into_py_any(py),
            _ => ODVariable { view, subindex: 0 }.into_py_any(py),
        }
    }
}

/// Loads an object dictionary from an EDS or DCF file (a path, or the file's bytes);
/// `node_id` resolves `$NODEID` in its values.
#[pyfunction]
#[pyo3(signature = (source, node_id = None))]
pub(crate) fn import_od(
    source: &Bound<'_, PyAny>,
    node_id: Option<u8>,
) -> PyResult<ObjectDictionary> {
    let od = load_dictionary(source)?;
    Ok(ObjectDictionary::new(Arc::new(od), node_id))
}

#[pymethods]
impl ObjectDictionary {
    /// An object by index or name (`"Identity object"`), or a sub-object by
    /// `"Object.Sub-object"`.
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let missing = || PyKeyError::new_err(format!("{key} was not found in Object Dictionary"));
        if let Ok(name) = key.cast::<PyString>() {
            let name: String = name.extract()?;
            if let Some(object) = self.od.find_object(&name) {
                return self.handle(py, object);
            }
            let at = self.od.find(&name).ok_or_else(missing)?;
            return ODVariable {
                view: ObjectView {
                    od: self.od.clone(),
                    index: at.index,
                    node_id: self.node_id,
                },
                subindex: at.sub_index,
            }
            .into_py_any(py);
        }
        let index: u16 = key.extract().map_err(|_| missing())?;
        let object = self.od.get(index).ok_or_else(missing)?;
        self.handle(py, object)
    }

    fn __contains__(&self, key: &Bound<'_, PyAny>) -> bool {
        if let Ok(name) = key.extract::<String>() {
            return self.od.find_object(&name).is_some() || self.od.find(&name).is_some();
        }
        key.extract::<u16>().is_ok_and(|i| self.od.get(i).is_some())
    }

    fn __len__(&self) -> usize {
        self.od.objects.len()
    }

    /// The indices, in order.
    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let keys = pyo3::types::PyList::new(py, self.od.objects.keys().copied())?;
        Ok(keys.try_iter()?.into_any().unbind())
    }

    /// The node-ID `$NODEID` stands for (`None` when none was given).
    #[getter]
    fn node_id(&self) -> Option<u8> {
        self.node_id
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.ObjectDictionary of {} objects>",
            self.od.objects.len()
        )
    }
}

/// One object of a dictionary.
#[derive(Clone)]
struct ObjectView {
    od: Arc<canola::ObjectDictionary>,
    index: u16,
    node_id: Option<u8>,
}

impl ObjectView {
    fn object(&self) -> &Object {
        self.od
            .get(self.index)
            .expect("a view is made of an object in the dictionary")
    }

    fn sub_by_key(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let object = self.object();
        let sub = if let Ok(name) = key.extract::<String>() {
            object.subs.values().find(|s| s.name.as_str() == name)
        } else {
            key.extract::<u8>().ok().and_then(|s| object.sub(s))
        };
        let sub = sub.ok_or_else(|| {
            PyKeyError::new_err(format!(
                "{key} was not found in {} (0x{:04X})",
                object.name, self.index
            ))
        })?;
        ODVariable {
            view: self.clone(),
            subindex: sub.sub_index,
        }
        .into_py_any(py)
    }

    fn subindices(&self) -> Vec<u8> {
        self.object().subs.keys().collect()
    }
}

/// A RECORD object (python-canopen's `ODRecord`): sub-objects by sub-index or name.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct ODRecord(ObjectView);

/// An ARRAY object (python-canopen's `ODArray`): elements by sub-index or name.
#[pyclass(module = "canola", frozen, mapping)]
pub(crate) struct ODArray(ObjectView);

macro_rules! complex_methods {
    ($t:ty, $kind:literal) => {
        #[pymethods]
        impl $t {
            /// The object's name.
            #[getter]
            fn name(&self) -> String {
                self.0.object().name.to_string()
            }

            /// The object's index.
            #[getter]
            fn index(&self) -> u16 {
                self.0.index
            }

            fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
                self.0.sub_by_key(py, key)
            }

            fn __contains__(&self, key: &Bound<'_, PyAny>) -> bool {
                Python::attach(|py| self.0.sub_by_key(py, key).is_ok())
            }

            fn __len__(&self) -> usize {
                self.0.subindices().len()
            }

            /// The sub-indices, in order.
            fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
                let keys =
                    pyo3::types::PyList::new(py, self.0.subindices().into_iter().map(u16::from))?;
                Ok(keys.try_iter()?.into_any().unbind())
            }

            fn __repr__(&self) -> String {
                format!(
                    "<canola.{} {:?} at 0x{:04X}>",
                    $kind,
                    self.0.object().name.as_str(),
                    self.0.index
                )
            }
        }
    };
}

complex_methods!(ODRecord, "ODRecord");
complex_methods!(ODArray, "ODArray");

/// One value of a dictionary (python-canopen's `ODVariable`): its data type, access, default
/// and limits.
#[pyclass(module = "canola", frozen)]
pub(crate) struct ODVariable {
    view: ObjectView,
    subindex: u8,
}

impl ODVariable {
    fn sub(&self) -> &SubObject {
        self.view
            .object()
            .sub(self.subindex)
            .expect("a view is made of a sub-object in the dictionary")
    }

    fn field(&self, py: Python<'_>, v: Option<&FieldValue>) -> PyResult<Py<PyAny>> {
        match v.and_then(|v| v.resolve(self.view.node_id.unwrap_or(0))) {
            Some(v) => value_to_py(py, v),
            None => Ok(py.None()),
        }
    }
}

#[pymethods]
impl ODVariable {
    /// The name (a sub-object's own name).
    #[getter]
    fn name(&self) -> String {
        self.sub().name.to_string()
    }

    /// `"Object.Sub-object"` for a sub-object, else the name.
    #[getter]
    fn qualname(&self) -> String {
        let object = self.view.object();
        if object.is_simple() {
            object.name.to_string()
        } else {
            format!("{}.{}", object.name, self.sub().name)
        }
    }

    #[getter]
    fn index(&self) -> u16 {
        self.view.index
    }

    #[getter]
    fn subindex(&self) -> u8 {
        self.subindex
    }

    /// The CiA 301 data type code (0x0007 UNSIGNED32, ...).
    #[getter]
    fn data_type(&self) -> u16 {
        self.sub().data_type.code()
    }

    /// `"ro"`, `"wo"`, `"rw"`, `"rwr"`, `"rww"` or `"const"`.
    #[getter]
    fn access_type(&self) -> &'static str {
        self.sub().access.as_str()
    }

    /// Whether it may be mapped into a PDO.
    #[getter]
    fn pdo_mappable(&self) -> bool {
        self.sub().pdo_mapping
    }

    /// The default value (`$NODEID` resolved), `None` when the file gives none.
    #[getter]
    fn default(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, self.sub().default_value.as_ref())
    }

    /// A DCF's configured value (`ParameterValue`), `None` when absent.
    #[getter]
    fn value(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, self.sub().parameter_value())
    }

    /// The lowest value allowed (`LowLimit`), `None` when absent.
    #[getter]
    fn min(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, self.sub().low_limit())
    }

    /// The highest value allowed (`HighLimit`), `None` when absent.
    #[getter]
    fn max(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, self.sub().high_limit())
    }

    fn __repr__(&self) -> String {
        format!(
            "<canola.ODVariable {:?} at 0x{:04X}:{:02X}>",
            self.qualname(),
            self.view.index,
            self.subindex
        )
    }
}
