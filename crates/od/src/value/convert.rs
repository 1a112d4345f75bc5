//! [`Value`] to Rust types: `u16::try_from(value)`, `String::try_from(value)`, and the
//! [`ValueType`] trait that gives each of these Rust types its own CANopen type.
//!
//! An integer converts to any Rust integer type that holds its number (an UNSIGNED8 `5` is a
//! `u16` 5 too, an INTEGER8 `-1` is no `u16`); a float only to a float type (REAL32 to `f32`
//! and `f64`, REAL64 to `f64`); BOOLEAN only to `bool`; VISIBLE_STRING (UTF-8 text) and
//! UNICODE_STRING to `String`. Anything else is a [`ConvertError`], never a truncated value.

use alloc::string::String;

use super::Value;
use crate::types::DataType;

/// Why a [`Value`] is not a value of a Rust type.
#[derive(Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// The value's type has no conversion to the Rust type.
    #[error("a {data_type} value is not a {rust_type}")]
    Type {
        /// The value's type.
        data_type: DataType,
        /// The Rust type asked for.
        rust_type: &'static str,
    },
    /// An integer that the Rust type cannot hold.
    #[error("the {data_type} value {value} does not fit in {rust_type}")]
    Range {
        /// The value's type.
        data_type: DataType,
        /// The value.
        value: i128,
        /// The Rust type asked for.
        rust_type: &'static str,
    },
    /// A string whose bytes are not text.
    #[error("the {data_type} value is not valid text")]
    Text {
        /// The value's type.
        data_type: DataType,
    },
}

debug_as_display!(ConvertError);

/// A Rust type that a [`Value`] converts to, with the CANopen type it stands for (`u16` is
/// UNSIGNED16): the type a typed read decodes with when nothing else says the object's type.
pub trait ValueType: TryFrom<Value, Error = ConvertError> {
    /// The CANopen data type of this Rust type.
    const DATA_TYPE: DataType;
}

fn integer(v: &Value) -> Option<i128> {
    match v {
        Value::Boolean(_) => None,
        other => other.as_i128(),
    }
}

macro_rules! integers {
    ($($t:ty => $dt:ident),* $(,)?) => {$(
        impl TryFrom<Value> for $t {
            type Error = ConvertError;
            fn try_from(v: Value) -> Result<Self, ConvertError> {
                Self::try_from(&v)
            }
        }
        impl TryFrom<&Value> for $t {
            type Error = ConvertError;
            fn try_from(v: &Value) -> Result<Self, ConvertError> {
                let data_type = v.data_type();
                let rust_type = stringify!($t);
                let n = integer(v).ok_or(ConvertError::Type { data_type, rust_type })?;
                <$t>::try_from(n).map_err(|_| ConvertError::Range { data_type, value: n, rust_type })
            }
        }
        impl ValueType for $t {
            const DATA_TYPE: DataType = DataType::$dt;
        }
    )*};
}

integers!(
    u8 => Unsigned8, u16 => Unsigned16, u32 => Unsigned32, u64 => Unsigned64,
    i8 => Integer8, i16 => Integer16, i32 => Integer32, i64 => Integer64,
);

macro_rules! by_ref {
    ($($t:ty),*) => {$(
        impl TryFrom<Value> for $t {
            type Error = ConvertError;
            fn try_from(v: Value) -> Result<Self, ConvertError> {
                Self::try_from(&v)
            }
        }
    )*};
}
by_ref!(bool, f32, f64);

impl TryFrom<&Value> for bool {
    type Error = ConvertError;
    fn try_from(v: &Value) -> Result<Self, ConvertError> {
        match *v {
            Value::Boolean(b) => Ok(b),
            ref other => Err(ConvertError::Type {
                data_type: other.data_type(),
                rust_type: "bool",
            }),
        }
    }
}
impl ValueType for bool {
    const DATA_TYPE: DataType = DataType::Boolean;
}

impl TryFrom<&Value> for f32 {
    type Error = ConvertError;
    fn try_from(v: &Value) -> Result<Self, ConvertError> {
        match *v {
            Value::Real32(x) => Ok(x),
            ref other => Err(ConvertError::Type {
                data_type: other.data_type(),
                rust_type: "f32",
            }),
        }
    }
}
impl ValueType for f32 {
    const DATA_TYPE: DataType = DataType::Real32;
}

impl TryFrom<&Value> for f64 {
    type Error = ConvertError;
    fn try_from(v: &Value) -> Result<Self, ConvertError> {
        match *v {
            Value::Real32(x) => Ok(f64::from(x)),
            Value::Real64(x) => Ok(x),
            ref other => Err(ConvertError::Type {
                data_type: other.data_type(),
                rust_type: "f64",
            }),
        }
    }
}
impl ValueType for f64 {
    const DATA_TYPE: DataType = DataType::Real64;
}

impl TryFrom<Value> for String {
    type Error = ConvertError;
    fn try_from(v: Value) -> Result<Self, ConvertError> {
        let data_type = v.data_type();
        match v {
            Value::VisibleString(b) => {
                String::from_utf8(b).map_err(|_| ConvertError::Text { data_type })
            }
            Value::UnicodeString(u) => {
                String::from_utf16(&u).map_err(|_| ConvertError::Text { data_type })
            }
            _ => Err(ConvertError::Type {
                data_type,
                rust_type: "String",
            }),
        }
    }
}
impl TryFrom<&Value> for String {
    type Error = ConvertError;
    fn try_from(v: &Value) -> Result<Self, ConvertError> {
        Self::try_from(v.clone())
    }
}
impl ValueType for String {
    const DATA_TYPE: DataType = DataType::VisibleString;
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;

    #[test]
    fn integers_convert_when_they_fit() {
        assert_eq!(u64::try_from(Value::Unsigned40(1 << 39)), Ok(1 << 39));
        assert_eq!(i8::try_from(&Value::Integer24(-128)), Ok(-128));
        assert_eq!(
            i8::try_from(Value::Integer24(-129)),
            Err(ConvertError::Range {
                data_type: DataType::Integer24,
                value: -129,
                rust_type: "i8"
            })
        );
        assert!(u8::try_from(Value::Boolean(true)).is_err());
        assert_eq!(
            u8::try_from(Value::Real64(1.0)).unwrap_err().to_string(),
            "a REAL64 value is not a u8"
        );
        assert!(String::try_from(Value::VisibleString(alloc::vec![0xFF])).is_err());
        assert_eq!(
            String::try_from(Value::UnicodeString(alloc::vec![0x48, 0x69])),
            Ok("Hi".into())
        );
        assert!(f32::try_from(Value::Real64(1.0)).is_err());
    }
}
