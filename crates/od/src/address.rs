//! The address of one sub-object in an object dictionary: a 16-bit index and an 8-bit
//! sub-index (CiA 301 §7.4.1; the SDO protocol calls the pair its multiplexer, and a PDO mapping
//! entry carries it in its upper 24 bits). A VAR object is sub-index 0 of its index.
//!
//! [`ObjectAddress`] is untyped: the typed `Entry<T>` of the `entry` module adds the data type and
//! the Rust type of the value on top of it. No allocator needed.

use core::fmt;
use core::str::FromStr;

/// Index and sub-index of one sub-object (a VAR is sub-index 0).
///
/// Displays as `0x1018:01` (the index in four upper-case hex digits, the sub-index in two), and
/// parses from that form back (see [`FromStr`](#impl-FromStr-for-ObjectAddress)). Ordered by
/// index, then sub-index, as a dictionary lists its objects.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObjectAddress {
    /// The object index (0x1000..=0x1FFF communication profile, 0x2000..=0x5FFF manufacturer,
    /// 0x6000..=0x9FFF device profiles).
    pub index: u16,
    /// The sub-index (0 for a VAR; the number of entries for an ARRAY or RECORD).
    pub sub_index: u8,
}

impl ObjectAddress {
    /// The sub-object `index`:`sub_index`.
    pub const fn new(index: u16, sub_index: u8) -> Self {
        Self { index, sub_index }
    }

    /// The multiplexer as an SDO initiate or block request carries it: the index little-endian,
    /// then the sub-index (CiA 301 §7.2.4.3).
    pub const fn to_multiplexer(self) -> [u8; 3] {
        let [lo, hi] = self.index.to_le_bytes();
        [lo, hi, self.sub_index]
    }

    /// The address from the three multiplexer bytes of an SDO message.
    pub const fn from_multiplexer(bytes: [u8; 3]) -> Self {
        Self::new(u16::from_le_bytes([bytes[0], bytes[1]]), bytes[2])
    }
}

impl From<(u16, u8)> for ObjectAddress {
    fn from((index, sub_index): (u16, u8)) -> Self {
        Self::new(index, sub_index)
    }
}

impl From<ObjectAddress> for (u16, u8) {
    fn from(a: ObjectAddress) -> Self {
        (a.index, a.sub_index)
    }
}

impl fmt::Display for ObjectAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:04X}:{:02X}", self.index, self.sub_index)
    }
}

impl fmt::Debug for ObjectAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ObjectAddress({self})")
    }
}

/// Why text is not an [`ObjectAddress`].
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AddressError {
    /// No `:` between index and sub-index.
    #[error("expected INDEX:SUB, e.g. 0x1018:01")]
    Form,
    /// The index is not 1 to 4 hex digits.
    #[error("the index is not a 16-bit hex number")]
    Index,
    /// The sub-index is not 1 or 2 hex digits.
    #[error("the sub-index is not an 8-bit hex number")]
    SubIndex,
}

debug_as_display!(AddressError);

/// Reads `INDEX:SUB` with both parts in hex, as CANopen writes them: `0x1018:01`, `1018:1`,
/// `0x1A00:0x02` (an optional `0x` on each part, any case).
impl FromStr for ObjectAddress {
    type Err = AddressError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (index, sub) = s.trim().split_once(':').ok_or(AddressError::Form)?;
        let index = hex(index, 4).ok_or(AddressError::Index)?;
        let sub = hex(sub, 2).ok_or(AddressError::SubIndex)?;
        Ok(Self::new(index as u16, sub as u8))
    }
}

/// 1 to `max_digits` hex digits, with an optional `0x` prefix.
fn hex(s: &str, max_digits: usize) -> Option<u32> {
    let s = s.trim();
    let digits = s
        .strip_prefix("0x")
        .or_else(|| s.strip_prefix("0X"))
        .unwrap_or(s);
    if digits.is_empty()
        || digits.len() > max_digits
        || !digits.bytes().all(|b| b.is_ascii_hexdigit())
    {
        return None;
    }
    u32::from_str_radix(digits, 16).ok()
}

#[cfg(test)]
mod tests {
    extern crate alloc;
    use super::*;
    use alloc::format;

    #[test]
    fn display_parse_and_multiplexer() {
        let a = ObjectAddress::new(0x1A00, 2);
        assert_eq!(format!("{a}"), "0x1A00:02");
        assert_eq!(format!("{a:?}"), "ObjectAddress(0x1A00:02)");
        assert_eq!("0x1A00:02".parse(), Ok(a));
        assert_eq!("1a00:2".parse(), Ok(a));
        assert_eq!(" 0X1A00:0x02 ".parse(), Ok(a));
        assert_eq!("1A00".parse::<ObjectAddress>(), Err(AddressError::Form));
        assert_eq!("10000:0".parse::<ObjectAddress>(), Err(AddressError::Index));
        assert_eq!(
            "1018:100".parse::<ObjectAddress>(),
            Err(AddressError::SubIndex)
        );
        assert_eq!(
            "1018:".parse::<ObjectAddress>(),
            Err(AddressError::SubIndex)
        );
        assert_eq!(
            "1018:+1".parse::<ObjectAddress>(),
            Err(AddressError::SubIndex)
        );
        // CiA 301 §7.2.4.3: index 0x1018 sub 1 travels as 18 10 01.
        let id = ObjectAddress::new(0x1018, 1);
        assert_eq!(id.to_multiplexer(), [0x18, 0x10, 0x01]);
        assert_eq!(ObjectAddress::from_multiplexer([0x18, 0x10, 0x01]), id);
        assert!(ObjectAddress::new(0x1018, 0) < id && id < ObjectAddress::new(0x1019, 0));
        assert_eq!(<(u16, u8)>::from(id), (0x1018, 1));
    }
}
