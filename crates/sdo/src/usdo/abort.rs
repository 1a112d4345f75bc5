//! The 1-byte USDO abort codes (CiA 1301 table 31, as SOFA-CANopenFD names them) with their
//! meanings and their mapping to and from the CiA 301 SDO [`AbortCode`]s.
//!
//! [`UsdoAbortCode`] is an open newtype: every `u8` is a value, the named constants and meanings
//! come from one table, and an unknown code still prints. The table is the subset SOFA defines;
//! codes 0x71..=0xFF are reserved by CiA (SOFA uses 0xC0..=0xCF privately). The mapping to CiA
//! 301 pairs each code with the SDO code of the same meaning; 0x15 (wrong size in a segmented
//! transfer) and 0x21 (unknown session) have none and map to 0x06070010 and 0x08000000. From
//! CiA 301 every code of the table maps back, plus the toggle-bit and sequence-number codes to
//! 0x14; any other CiA 301 code has no 1-byte equivalent ([`UsdoAbortCode::from_cia301`] gives
//! `None`; [`UsdoAbortCode::from_cia301_or_general`] sends [`ABORT_GENERAL`]).

use core::fmt;

use super::assumed::ABORT_GENERAL;
use crate::abort::AbortCode;

/// A 1-byte USDO abort code. Unknown codes are kept as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct UsdoAbortCode(pub u8);

macro_rules! usdo_abort_codes {
    ($($name:ident = $value:literal => $cia301:ident, $text:literal;)*) => {
        impl UsdoAbortCode {
            $(
                #[doc = concat!("`", stringify!($value), "`: ", $text, " (CiA 301: [`AbortCode::", stringify!($cia301), "`])")]
                pub const $name: UsdoAbortCode = UsdoAbortCode($value);
            )*
        }

        /// Code, meaning, CiA 301 equivalent.
        const TABLE: &[(u8, &str, AbortCode)] = &[$(($value, $text, AbortCode::$cia301),)*];
    };
}

usdo_abort_codes! {
    INVALID_COMMAND = 0x13 => INVALID_COMMAND, "Unknown, unexpected or unsupported command specifier";
    INVALID_COUNTER = 0x14 => INVALID_SEQUENCE_NUMBER, "Invalid value in the USDO segment counter";
    WRONG_SIZE = 0x15 => LENGTH_MISMATCH, "Incorrect data size in a segmented transfer";
    UNKNOWN_SESSION = 0x21 => GENERAL_ERROR, "USDO session-ID wrong or unknown";
    WRITE_ONLY = 0x31 => WRITE_ONLY, "Attempt to read a write-only object";
    READ_ONLY = 0x32 => READ_ONLY, "Attempt to write a read-only object";
    OBJECT_DOES_NOT_EXIST = 0x33 => OBJECT_DOES_NOT_EXIST, "Object does not exist in the object dictionary";
    SUBINDEX_DOES_NOT_EXIST = 0x34 => SUBINDEX_DOES_NOT_EXIST, "Sub-index does not exist";
    LENGTH_MISMATCH = 0x36 => LENGTH_MISMATCH, "Data type or length of service parameter does not match";
    LENGTH_TOO_HIGH = 0x37 => LENGTH_TOO_HIGH, "Length of service parameter too high";
    LENGTH_TOO_LOW = 0x38 => LENGTH_TOO_LOW, "Length of service parameter too low";
    CANNOT_STORE = 0x60 => CANNOT_STORE, "Data cannot be transferred or stored to the application";
    DEVICE_STATE = 0x62 => CANNOT_STORE_DEVICE_STATE, "Access rejected because of the present device state";
}

impl UsdoAbortCode {
    /// The meaning of this code, or `None` for a code not in the table.
    pub fn description(self) -> Option<&'static str> {
        TABLE.iter().find(|e| e.0 == self.0).map(|e| e.1)
    }

    /// Every code with a known meaning, in table order.
    pub fn known() -> impl Iterator<Item = UsdoAbortCode> {
        TABLE.iter().map(|e| UsdoAbortCode(e.0))
    }

    /// The raw value.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// The CiA 301 SDO abort code of the same meaning; `None` for a code not in the table.
    pub fn to_cia301(self) -> Option<AbortCode> {
        TABLE.iter().find(|e| e.0 == self.0).map(|e| e.2)
    }

    /// The 1-byte code for a CiA 301 abort code, or `None` when there is none. Where two
    /// 1-byte codes share a CiA 301 code (0x15 and 0x36 both map to 0x06070010), the one whose
    /// meaning is the CiA 301 text is chosen (0x36).
    pub fn from_cia301(code: AbortCode) -> Option<Self> {
        match code {
            AbortCode::LENGTH_MISMATCH => Some(Self::LENGTH_MISMATCH),
            AbortCode::GENERAL_ERROR => None,
            AbortCode::TOGGLE_BIT_NOT_ALTERNATED => Some(Self::INVALID_COUNTER),
            _ => TABLE
                .iter()
                .find(|e| e.2 == code)
                .map(|e| UsdoAbortCode(e.0)),
        }
    }

    /// [`from_cia301`](Self::from_cia301), falling back to [`ABORT_GENERAL`].
    pub fn from_cia301_or_general(code: AbortCode) -> Self {
        Self::from_cia301(code).unwrap_or(ABORT_GENERAL)
    }
}

impl fmt::Display for UsdoAbortCode {
    /// `0x33 (Object does not exist in the object dictionary)`; an unknown code prints as
    /// `0x99 (unknown USDO abort code)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.description() {
            Some(text) => write!(f, "{:#04x} ({text})", self.0),
            None => write!(f, "{:#04x} (unknown USDO abort code)", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    #[test]
    fn table_values_follow_sofa() {
        let codes: std::vec::Vec<u8> = UsdoAbortCode::known().map(UsdoAbortCode::get).collect();
        assert_eq!(
            codes,
            [
                0x13, 0x14, 0x15, 0x21, 0x31, 0x32, 0x33, 0x34, 0x36, 0x37, 0x38, 0x60, 0x62
            ]
        );
        assert_eq!(
            UsdoAbortCode(0x33).to_string(),
            "0x33 (Object does not exist in the object dictionary)"
        );
        assert_eq!(
            UsdoAbortCode(0x99).to_string(),
            "0x99 (unknown USDO abort code)"
        );
    }

    #[test]
    fn cia301_mapping() {
        assert_eq!(
            UsdoAbortCode::OBJECT_DOES_NOT_EXIST.to_cia301(),
            Some(AbortCode::OBJECT_DOES_NOT_EXIST)
        );
        assert_eq!(UsdoAbortCode(0x99).to_cia301(), None);
        assert_eq!(
            UsdoAbortCode::from_cia301(AbortCode::READ_ONLY),
            Some(UsdoAbortCode::READ_ONLY)
        );
        assert_eq!(
            UsdoAbortCode::from_cia301(AbortCode::TOGGLE_BIT_NOT_ALTERNATED),
            Some(UsdoAbortCode::INVALID_COUNTER)
        );
        assert_eq!(UsdoAbortCode::from_cia301(AbortCode::INVALID_VALUE), None);
        assert_eq!(
            UsdoAbortCode::from_cia301_or_general(AbortCode::INVALID_VALUE),
            ABORT_GENERAL
        );
        // Every 1-byte code survives the trip through CiA 301, except the two that share
        // their CiA 301 code with a closer match.
        for code in UsdoAbortCode::known() {
            let back = UsdoAbortCode::from_cia301(code.to_cia301().unwrap());
            match code {
                UsdoAbortCode::WRONG_SIZE => assert_eq!(back, Some(UsdoAbortCode::LENGTH_MISMATCH)),
                UsdoAbortCode::UNKNOWN_SESSION => assert_eq!(back, None),
                _ => assert_eq!(back, Some(code), "{code}"),
            }
        }
    }
}
