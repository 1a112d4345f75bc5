//! SDO abort codes (CiA 301 §7.2.4.3.17, table 22): the UNSIGNED32 in the last four bytes of an
//! abort transfer message.
//!
//! [`AbortCode`] is an open newtype: every `u32` is a valid value, the named constants and the
//! meanings come from one table, and an unknown code still prints (as its hex value).

use core::fmt;

/// An SDO abort code. Unknown codes are kept as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AbortCode(pub u32);

macro_rules! abort_codes {
    ($($name:ident = $value:literal, $text:literal;)*) => {
        impl AbortCode {
            $(
                #[doc = concat!("`", stringify!($value), "`: ", $text)]
                pub const $name: AbortCode = AbortCode($value);
            )*
        }

        /// Every code CiA 301 defines, with its meaning.
        const TABLE: &[(u32, &str)] = &[$(($value, $text),)*];
    };
}

abort_codes! {
    TOGGLE_BIT_NOT_ALTERNATED = 0x0503_0000, "Toggle bit not alternated";
    TIMEOUT = 0x0504_0000, "SDO protocol timed out";
    INVALID_COMMAND = 0x0504_0001, "Client/server command specifier not valid or unknown";
    INVALID_BLOCK_SIZE = 0x0504_0002, "Invalid block size (block mode only)";
    INVALID_SEQUENCE_NUMBER = 0x0504_0003, "Invalid sequence number (block mode only)";
    CRC_ERROR = 0x0504_0004, "CRC error (block mode only)";
    OUT_OF_MEMORY = 0x0504_0005, "Out of memory";
    UNSUPPORTED_ACCESS = 0x0601_0000, "Unsupported access to an object";
    WRITE_ONLY = 0x0601_0001, "Attempt to read a write only object";
    READ_ONLY = 0x0601_0002, "Attempt to write a read only object";
    OBJECT_DOES_NOT_EXIST = 0x0602_0000, "Object does not exist in the object dictionary";
    NOT_MAPPABLE = 0x0604_0041, "Object cannot be mapped to the PDO";
    PDO_LENGTH_EXCEEDED = 0x0604_0042, "The number and length of the objects to be mapped would exceed PDO length";
    PARAMETER_INCOMPATIBILITY = 0x0604_0043, "General parameter incompatibility reason";
    INTERNAL_INCOMPATIBILITY = 0x0604_0047, "General internal incompatibility in the device";
    HARDWARE_ERROR = 0x0606_0000, "Access failed due to a hardware error";
    LENGTH_MISMATCH = 0x0607_0010, "Data type does not match, length of service parameter does not match";
    LENGTH_TOO_HIGH = 0x0607_0012, "Data type does not match, length of service parameter too high";
    LENGTH_TOO_LOW = 0x0607_0013, "Data type does not match, length of service parameter too low";
    SUBINDEX_DOES_NOT_EXIST = 0x0609_0011, "Sub-index does not exist";
    INVALID_VALUE = 0x0609_0030, "Invalid value for parameter (download only)";
    VALUE_TOO_HIGH = 0x0609_0031, "Value of parameter written too high (download only)";
    VALUE_TOO_LOW = 0x0609_0032, "Value of parameter written too low (download only)";
    MAX_LESS_THAN_MIN = 0x0609_0036, "Maximum value is less than minimum value";
    RESOURCE_NOT_AVAILABLE = 0x060A_0023, "Resource not available: SDO connection";
    GENERAL_ERROR = 0x0800_0000, "General error";
    CANNOT_STORE = 0x0800_0020, "Data cannot be transferred or stored to the application";
    CANNOT_STORE_LOCAL_CONTROL = 0x0800_0021, "Data cannot be transferred or stored to the application because of local control";
    CANNOT_STORE_DEVICE_STATE = 0x0800_0022, "Data cannot be transferred or stored to the application because of the present device state";
    NO_OBJECT_DICTIONARY = 0x0800_0023, "Object dictionary dynamic generation fails or no object dictionary is present";
    NO_DATA_AVAILABLE = 0x0800_0024, "No data available";
}

impl AbortCode {
    /// The CiA 301 meaning of this code, or `None` for a code the standard does not define.
    pub fn description(self) -> Option<&'static str> {
        TABLE
            .iter()
            .find(|(code, _)| *code == self.0)
            .map(|(_, text)| *text)
    }

    /// Every code with a CiA 301 meaning, in table order.
    pub fn known() -> impl Iterator<Item = AbortCode> {
        TABLE.iter().map(|(code, _)| AbortCode(*code))
    }

    /// The raw value.
    pub const fn get(self) -> u32 {
        self.0
    }
}

impl From<u32> for AbortCode {
    fn from(raw: u32) -> Self {
        Self(raw)
    }
}

impl From<AbortCode> for u32 {
    fn from(code: AbortCode) -> u32 {
        code.0
    }
}

impl fmt::Display for AbortCode {
    /// `0x06020000 (Object does not exist in the object dictionary)`; an unknown code prints
    /// as `0x12345678 (unknown abort code)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.description() {
            Some(text) => write!(f, "{:#010x} ({text})", self.0),
            None => write!(f, "{:#010x} (unknown abort code)", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn table_is_complete_and_unique() {
        assert_eq!(AbortCode::known().count(), 31);
        let mut codes: std::vec::Vec<u32> = AbortCode::known().map(AbortCode::get).collect();
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), 31);
    }

    #[test]
    fn display() {
        assert_eq!(
            AbortCode::OBJECT_DOES_NOT_EXIST.to_string(),
            "0x06020000 (Object does not exist in the object dictionary)"
        );
        assert_eq!(
            AbortCode(0x1234_5678).to_string(),
            "0x12345678 (unknown abort code)"
        );
        assert_eq!(
            AbortCode(0x0504_0000).description(),
            Some("SDO protocol timed out")
        );
        assert_eq!(AbortCode::SUBINDEX_DOES_NOT_EXIST.get(), 0x0609_0011);
    }
}
