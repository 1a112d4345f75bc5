//! CAN identifiers (ISO 11898-1): 11-bit standard and 29-bit extended.

use core::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD: u16 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED: u32 = 0x1FFF_FFFF;

/// A CAN identifier. Constructed only through validating functions, so the raw value always fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CanId {
    /// 11-bit identifier (CAN 2.0A). CANopen's predefined connection set lives here.
    Standard(StandardId),
    /// 29-bit identifier (CAN 2.0B).
    Extended(ExtendedId),
}

/// An 11-bit identifier, 0..=0x7FF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StandardId(u16);

/// A 29-bit identifier, 0..=0x1FFF_FFFF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExtendedId(u32);

/// An identifier value that does not fit its format.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum IdError {
    /// A standard identifier above 0x7FF.
    #[error("standard CAN identifier {0:#x} is above 0x7FF")]
    StandardOutOfRange(u32),
    /// An extended identifier above 0x1FFF_FFFF.
    #[error("extended CAN identifier {0:#x} is above 0x1FFFFFFF")]
    ExtendedOutOfRange(u32),
}

debug_as_display!(IdError);

impl StandardId {
    /// Validates an 11-bit identifier.
    pub const fn new(raw: u16) -> Result<Self, IdError> {
        if raw <= MAX_STANDARD {
            Ok(Self(raw))
        } else {
            Err(IdError::StandardOutOfRange(raw as u32))
        }
    }

    /// The raw 11-bit value.
    pub const fn as_raw(self) -> u16 {
        self.0
    }
}

impl ExtendedId {
    /// Validates a 29-bit identifier.
    pub const fn new(raw: u32) -> Result<Self, IdError> {
        if raw <= MAX_EXTENDED {
            Ok(Self(raw))
        } else {
            Err(IdError::ExtendedOutOfRange(raw))
        }
    }

    /// The raw 29-bit value.
    pub const fn as_raw(self) -> u32 {
        self.0
    }
}

impl CanId {
    /// A standard identifier; fails above 0x7FF.
    pub const fn standard(raw: u16) -> Result<Self, IdError> {
        match StandardId::new(raw) {
            Ok(id) => Ok(Self::Standard(id)),
            Err(e) => Err(e),
        }
    }

    /// An extended identifier; fails above 0x1FFF_FFFF.
    pub const fn extended(raw: u32) -> Result<Self, IdError> {
        match ExtendedId::new(raw) {
            Ok(id) => Ok(Self::Extended(id)),
            Err(e) => Err(e),
        }
    }

    /// The raw identifier value, without the format.
    pub const fn as_raw(self) -> u32 {
        match self {
            Self::Standard(id) => id.0 as u32,
            Self::Extended(id) => id.0,
        }
    }

    /// Whether this is a 29-bit identifier.
    pub const fn is_extended(self) -> bool {
        matches!(self, Self::Extended(_))
    }

    /// The 11-bit value if this is a standard identifier.
    pub const fn as_standard(self) -> Option<u16> {
        match self {
            Self::Standard(id) => Some(id.0),
            Self::Extended(_) => None,
        }
    }
}

impl CanId {
    /// The identifier as candump writes it: three hex digits for a standard, eight for an
    /// extended identifier, no prefix (`181`, `18FF0001`).
    pub const fn candump(self) -> Candump {
        Candump(self)
    }
}

impl fmt::Display for CanId {
    /// `0x181` (three upper-case hex digits) for a standard identifier, `0x18FF0001` (eight)
    /// for an extended one. [`CanId::candump`] writes it without the prefix.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("0x")?;
        self.candump().fmt(f)
    }
}

/// A [`CanId`] written as candump does (see [`CanId::candump`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candump(CanId);

impl fmt::Display for Candump {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            CanId::Standard(id) => write!(f, "{:03X}", id.0),
            CanId::Extended(id) => write!(f, "{:08X}", id.0),
        }
    }
}

impl From<StandardId> for CanId {
    fn from(id: StandardId) -> Self {
        Self::Standard(id)
    }
}

impl From<ExtendedId> for CanId {
    fn from(id: ExtendedId) -> Self {
        Self::Extended(id)
    }
}

impl From<CanId> for embedded_can::Id {
    fn from(id: CanId) -> Self {
        match id {
            // Both values were validated on construction, so the conversions cannot fail; the
            // fallbacks only exist to avoid a panic path.
            CanId::Standard(s) => embedded_can::StandardId::new(s.0)
                .map(Self::Standard)
                .unwrap_or(Self::Standard(embedded_can::StandardId::ZERO)),
            CanId::Extended(e) => embedded_can::ExtendedId::new(e.0)
                .map(Self::Extended)
                .unwrap_or(Self::Extended(embedded_can::ExtendedId::ZERO)),
        }
    }
}

impl From<embedded_can::Id> for CanId {
    fn from(id: embedded_can::Id) -> Self {
        match id {
            embedded_can::Id::Standard(s) => Self::Standard(StandardId(s.as_raw())),
            embedded_can::Id::Extended(e) => Self::Extended(ExtendedId(e.as_raw())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds() {
        assert!(CanId::standard(0x7FF).is_ok());
        assert_eq!(
            CanId::standard(0x800),
            Err(IdError::StandardOutOfRange(0x800))
        );
        assert!(CanId::extended(0x1FFF_FFFF).is_ok());
        assert_eq!(
            CanId::extended(0x2000_0000),
            Err(IdError::ExtendedOutOfRange(0x2000_0000))
        );
    }

    #[test]
    fn display_with_prefix_and_like_candump() {
        assert_eq!(format!("{}", CanId::standard(0x5).unwrap()), "0x005");
        assert_eq!(format!("{}", CanId::standard(0x7E5).unwrap()), "0x7E5");
        assert_eq!(format!("{}", CanId::extended(0x5).unwrap()), "0x00000005");
        let id = CanId::standard(0x181).unwrap();
        assert_eq!(format!("{}", id.candump()), "181");
        assert_eq!(
            format!("{}", CanId::extended(0x18FF_0001).unwrap().candump()),
            "18FF0001"
        );
    }

    #[test]
    fn embedded_can_round_trip() {
        for id in [
            CanId::standard(0x123).unwrap(),
            CanId::extended(0x1ABC_DEF0).unwrap(),
        ] {
            let e: embedded_can::Id = id.into();
            assert_eq!(CanId::from(e), id);
        }
    }

    extern crate std;
    use std::format;
}
