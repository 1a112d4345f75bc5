//! Dictionary-aware SDO access: objects named as in the node's dictionary (or addressed), values
//! typed by it.
//!
//! [`Sdo::get`] and [`Sdo::set`] take an [`ObjectKey`]: a name resolved the way python-canopen
//! resolves them (`"Producer heartbeat time"`, `"Identity object.Vendor-ID"`, case-insensitive;
//! see [`ObjectDictionary::find`](canola_od::ObjectDictionary::find)) or an address. A write
//! takes a [`WriteValue`] (any integer, float, bool, string, bytes or [`Value`]) and converts it
//! to the object's data type before anything is sent: `200` written to an UNSIGNED16 goes out
//! as 2 bytes, and a value that does not fit is a local [`Error::Value`] naming the object and
//! its type.

use canola_od::{DataType, ObjectAddress, ObjectDictionary, Value};

use crate::error::{Error, Unfit, Unresolved, ValueProblem};
use crate::network::Operation;
use crate::network::Sdo;

/// An object by name (as the node's dictionary spells it, any case) or by address.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectKey<'a> {
    /// A name: `"Producer heartbeat time"`, or a sub-object after a slash or a dot
    /// (`"Identity object/Vendor ID"`, `"Identity object.Vendor ID"`); see
    /// [`ObjectDictionary::find`](canola_od::ObjectDictionary::find).
    Name(&'a str),
    /// An index and sub-index.
    Address(ObjectAddress),
}

impl<'a> From<&'a str> for ObjectKey<'a> {
    fn from(name: &'a str) -> Self {
        Self::Name(name)
    }
}
impl<'a> From<&'a String> for ObjectKey<'a> {
    fn from(name: &'a String) -> Self {
        Self::Name(name)
    }
}
impl From<ObjectAddress> for ObjectKey<'_> {
    fn from(a: ObjectAddress) -> Self {
        Self::Address(a)
    }
}
impl From<(u16, u8)> for ObjectKey<'_> {
    fn from((index, sub): (u16, u8)) -> Self {
        Self::Address(ObjectAddress::new(index, sub))
    }
}

/// A value to write, converted to the object's data type by [`Sdo::set`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum WriteValue {
    /// An integer (any Rust integer type, or `bool`): range-checked against the type.
    Integer(i128),
    /// A float: REAL32 or REAL64 objects only.
    Float(f64),
    /// Text: string objects only.
    Text(String),
    /// Raw bytes: DOMAIN and OCTET_STRING objects, or exactly the type's size.
    Bytes(Vec<u8>),
    /// A typed value: written as it is when its type is the object's, else converted like an
    /// integer.
    Value(Value),
}

macro_rules! from_integer {
    ($($t:ty),*) => {$(
        impl From<$t> for WriteValue {
            fn from(v: $t) -> Self {
                Self::Integer(i128::from(v))
            }
        }
    )*};
}
from_integer!(u8, u16, u32, u64, i8, i16, i32, i64, bool);

impl From<f32> for WriteValue {
    fn from(v: f32) -> Self {
        Self::Float(f64::from(v))
    }
}
impl From<f64> for WriteValue {
    fn from(v: f64) -> Self {
        Self::Float(v)
    }
}
impl From<&str> for WriteValue {
    fn from(v: &str) -> Self {
        Self::Text(v.into())
    }
}
impl From<String> for WriteValue {
    fn from(v: String) -> Self {
        Self::Text(v)
    }
}
impl From<&[u8]> for WriteValue {
    fn from(v: &[u8]) -> Self {
        Self::Bytes(v.to_vec())
    }
}
impl From<Vec<u8>> for WriteValue {
    fn from(v: Vec<u8>) -> Self {
        Self::Bytes(v)
    }
}
impl From<Value> for WriteValue {
    fn from(v: Value) -> Self {
        Self::Value(v)
    }
}

/// The object's name for messages ([`ObjectDictionary::display_name`], else its address).
pub(crate) fn object_name(od: &ObjectDictionary, at: ObjectAddress) -> String {
    od.display_name(at).unwrap_or_else(|| at.to_string())
}

/// `value` as a value of `t`, or why not.
pub(crate) fn convert(value: WriteValue, t: DataType) -> Result<Value, Unfit> {
    let integer = |v: i128| -> Result<Value, Unfit> {
        match t {
            DataType::Real32 => return Ok(Value::Real32(v as f32)),
            DataType::Real64 => return Ok(Value::Real64(v as f64)),
            _ => {}
        }
        let Some(bits) = t.integer_bits() else {
            return Err(Unfit::Integer(v));
        };
        let (lo, hi) = if t == DataType::Boolean {
            (0, 1)
        } else if t.is_signed() {
            (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
        } else {
            (0, (1i128 << bits) - 1)
        };
        if !(lo..=hi).contains(&v) {
            return Err(Unfit::OutOfRange {
                value: v,
                min: lo,
                max: hi,
            });
        }
        Value::from_i128_wrapping(t, v).ok_or(Unfit::OutOfRange {
            value: v,
            min: lo,
            max: hi,
        })
    };
    match value {
        WriteValue::Integer(v) => integer(v),
        WriteValue::Float(f) => match t {
            DataType::Real32 => Ok(Value::Real32(f as f32)),
            DataType::Real64 => Ok(Value::Real64(f)),
            _ => Err(Unfit::Float(f)),
        },
        WriteValue::Text(s) => match t {
            DataType::VisibleString => Ok(Value::VisibleString(s.into_bytes())),
            DataType::OctetString => Ok(Value::OctetString(s.into_bytes())),
            DataType::UnicodeString => Ok(Value::UnicodeString(s.encode_utf16().collect())),
            _ => Err(Unfit::Text(s)),
        },
        WriteValue::Bytes(b) => match (t, t.size()) {
            (DataType::Domain, _) => Ok(Value::Domain(b)),
            (DataType::OctetString, _) => Ok(Value::OctetString(b)),
            (_, Some(n)) if n != b.len() => Err(Unfit::ByteCount {
                given: b.len(),
                takes: n,
            }),
            _ => Value::from_le_bytes(t, &b).map_err(Unfit::Bytes),
        },
        WriteValue::Value(v) if v.data_type() == t => Ok(v),
        WriteValue::Value(v) => match v.as_i128() {
            Some(i) => integer(i),
            None => Err(Unfit::ValueType(v.data_type())),
        },
    }
}

impl Sdo {
    /// The dictionary of the node, or an error saying it has none, naming `wanted` (the name
    /// or address asked for).
    fn typed_dictionary(&self, wanted: &str) -> Result<std::sync::Arc<ObjectDictionary>, Error> {
        let node = self.node_id();
        self.network()
            .core()
            .dictionary(node)
            .ok_or_else(|| Error::UnknownObject {
                node,
                name: wanted.into(),
                reason: Unresolved::NoDictionary,
            })
    }

    /// The address `key` names in the node's dictionary.
    pub fn resolve<'k>(&self, key: impl Into<ObjectKey<'k>>) -> Result<ObjectAddress, Error> {
        match key.into() {
            ObjectKey::Address(a) => Ok(a),
            ObjectKey::Name(name) => {
                let od = self.typed_dictionary(name)?;
                od.find(name).ok_or_else(|| Error::UnknownObject {
                    node: self.node_id(),
                    name: name.into(),
                    reason: if od.find_object(name).is_some() {
                        Unresolved::NotOneValue
                    } else {
                        Unresolved::NotFound
                    },
                })
            }
        }
    }

    /// Reads an object by name or address and decodes it with its type in the node's
    /// dictionary (`node.sdo().get("Producer heartbeat time")`).
    pub fn get<'k>(self, key: impl Into<ObjectKey<'k>>) -> Operation<'static, Value> {
        match self.resolve(key) {
            Ok(at) => self.read_value(at),
            Err(e) => Operation::ready(Err(e)),
        }
    }

    /// Writes an object by name or address, the value converted to the object's type in the
    /// node's dictionary first (`node.sdo().set("Producer heartbeat time", 200)` sends 2 bytes
    /// to an UNSIGNED16). A value that does not fit, or an object the dictionary does not
    /// describe, is an error before anything is sent.
    pub fn set<'k>(
        self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Operation<'static, ()> {
        match self.typed_write(key, value) {
            Ok((at, typed)) => self.write(at, typed),
            Err(e) => Operation::ready(Err(e)),
        }
    }

    /// The address `key` names and `value` converted to its type: what [`set`](Self::set)
    /// writes.
    pub(crate) fn typed_write<'k>(
        &self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(ObjectAddress, Value), Error> {
        let at = self.resolve(key)?;
        let od = self.typed_dictionary(&at.to_string())?;
        let node = self.node_id();
        let Some(sub) = od.sub(at.index, at.sub_index) else {
            return Err(Error::Value {
                node,
                entry: at,
                problem: ValueProblem::NotDescribed,
            });
        };
        let data_type = sub.data_type;
        let typed = convert(value.into(), data_type).map_err(|why| Error::Value {
            node,
            entry: at,
            problem: ValueProblem::Unfit {
                object: object_name(&od, at),
                data_type,
                why,
            },
        })?;
        Ok((at, typed))
    }
}
