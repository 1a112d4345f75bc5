//! The Identity object (CIP class 0x01, instance 1) and the Duplicate MAC ID check message
//! (DeviceNet volume 3, "Network Access": the message on group 2 message ID 7).
//!
//! Identity attributes, all read with Get_Attribute_Single; integers are little-endian:
//!
//! | attr | name          | type                          |
//! |------|---------------|-------------------------------|
//! | 1    | vendor ID     | UINT                          |
//! | 2    | device type   | UINT                          |
//! | 3    | product code  | UINT                          |
//! | 4    | revision      | USINT major, USINT minor      |
//! | 5    | status        | WORD                          |
//! | 6    | serial number | UDINT                         |
//! | 7    | product name  | SHORT_STRING (length + chars) |
//!
//! Duplicate MAC ID check message (7 bytes):
//! `[R/R bit 7 | physical port 0..6, vendor ID (UINT), serial number (UDINT)]`, R/R 0 = request,
//! 1 = response.

use core::fmt;

/// Identity attribute IDs.
pub mod attr {
    /// Vendor ID.
    pub const VENDOR_ID: u8 = 1;
    /// Device type.
    pub const DEVICE_TYPE: u8 = 2;
    /// Product code.
    pub const PRODUCT_CODE: u8 = 3;
    /// Revision.
    pub const REVISION: u8 = 4;
    /// Status.
    pub const STATUS: u8 = 5;
    /// Serial number.
    pub const SERIAL_NUMBER: u8 = 6;
    /// Product name.
    pub const PRODUCT_NAME: u8 = 7;
}

/// Longest product name kept (SHORT_STRING allows 255; real devices use up to 32).
pub const MAX_NAME: usize = 32;

/// Why attribute data could not be decoded.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AttributeError {
    /// The data has the wrong length for the attribute's type.
    #[error("attribute {attribute}: {actual} bytes, expected {expected}")]
    Length {
        /// Attribute ID.
        attribute: u8,
        /// Expected length.
        expected: usize,
        /// Given length.
        actual: usize,
    },
    /// The product name is longer than [`MAX_NAME`] or not UTF-8.
    #[error("product name is not a readable string of at most {MAX_NAME} bytes")]
    Name,
}

debug_as_display!(AttributeError);

/// The Identity object's attributes 1..=7.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Identity {
    /// Vendor ID (GEMÜ: 272).
    pub vendor_id: u16,
    /// Device type.
    pub device_type: u16,
    /// Product code (cPos: 1436).
    pub product_code: u16,
    /// Major revision.
    pub major_revision: u8,
    /// Minor revision.
    pub minor_revision: u8,
    /// Status word.
    pub status: u16,
    /// Serial number.
    pub serial_number: u32,
    /// Product name ("1436 cPos").
    pub product_name: heapless::String<MAX_NAME>,
}

fn fixed<const N: usize>(attribute: u8, data: &[u8]) -> Result<[u8; N], AttributeError> {
    data.try_into().map_err(|_| AttributeError::Length {
        attribute,
        expected: N,
        actual: data.len(),
    })
}

impl Identity {
    /// Stores one attribute's data. Never panics.
    pub fn set_attribute(&mut self, attribute: u8, data: &[u8]) -> Result<(), AttributeError> {
        match attribute {
            attr::VENDOR_ID => self.vendor_id = u16::from_le_bytes(fixed(attribute, data)?),
            attr::DEVICE_TYPE => self.device_type = u16::from_le_bytes(fixed(attribute, data)?),
            attr::PRODUCT_CODE => self.product_code = u16::from_le_bytes(fixed(attribute, data)?),
            attr::REVISION => {
                let [a, b] = fixed(attribute, data)?;
                self.major_revision = a;
                self.minor_revision = b;
            }
            attr::STATUS => self.status = u16::from_le_bytes(fixed(attribute, data)?),
            attr::SERIAL_NUMBER => self.serial_number = u32::from_le_bytes(fixed(attribute, data)?),
            attr::PRODUCT_NAME => {
                let (&n, rest) = data.split_first().ok_or(AttributeError::Length {
                    attribute,
                    expected: 1,
                    actual: 0,
                })?;
                if rest.len() != n as usize {
                    return Err(AttributeError::Length {
                        attribute,
                        expected: 1 + n as usize,
                        actual: data.len(),
                    });
                }
                let s = core::str::from_utf8(rest).map_err(|_| AttributeError::Name)?;
                let mut name = heapless::String::new();
                name.push_str(s).map_err(|_| AttributeError::Name)?;
                self.product_name = name;
            }
            _ => {}
        }
        Ok(())
    }

    /// One attribute's data, or `None` for an attribute outside 1..=7.
    pub fn attribute(&self, attribute: u8) -> Option<heapless::Vec<u8, { MAX_NAME + 1 }>> {
        let mut v = heapless::Vec::new();
        let r = match attribute {
            attr::VENDOR_ID => v.extend_from_slice(&self.vendor_id.to_le_bytes()),
            attr::DEVICE_TYPE => v.extend_from_slice(&self.device_type.to_le_bytes()),
            attr::PRODUCT_CODE => v.extend_from_slice(&self.product_code.to_le_bytes()),
            attr::REVISION => v.extend_from_slice(&[self.major_revision, self.minor_revision]),
            attr::STATUS => v.extend_from_slice(&self.status.to_le_bytes()),
            attr::SERIAL_NUMBER => v.extend_from_slice(&self.serial_number.to_le_bytes()),
            attr::PRODUCT_NAME => v
                .push(self.product_name.len() as u8)
                .map_err(|_| ())
                .and_then(|()| v.extend_from_slice(self.product_name.as_bytes())),
            _ => return None,
        };
        r.ok()?;
        Some(v)
    }
}

impl fmt::Display for Identity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:?}: vendor {}, device type {}, product code {}, revision {}.{:03}, serial 0x{:08X}, status 0x{:04X}",
            self.product_name.as_str(),
            self.vendor_id,
            self.device_type,
            self.product_code,
            self.major_revision,
            self.minor_revision,
            self.serial_number,
            self.status
        )
    }
}

/// A Duplicate MAC ID check message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DuplicateMacCheck {
    /// Response (true) or request (false).
    pub response: bool,
    /// Physical port number, 0..=127.
    pub port: u8,
    /// Sender's vendor ID.
    pub vendor_id: u16,
    /// Sender's serial number.
    pub serial_number: u32,
}

/// A Duplicate MAC ID check message that is not 7 bytes long.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("duplicate MAC ID check message is {0} bytes, expected 7")]
pub struct DuplicateMacError(pub usize);

debug_as_display!(DuplicateMacError);

impl DuplicateMacCheck {
    /// Decodes the 7 data bytes. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DuplicateMacError> {
        let b: &[u8; 7] = data.try_into().map_err(|_| DuplicateMacError(data.len()))?;
        Ok(Self {
            response: b[0] & 0x80 != 0,
            port: b[0] & 0x7F,
            vendor_id: u16::from_le_bytes([b[1], b[2]]),
            serial_number: u32::from_le_bytes([b[3], b[4], b[5], b[6]]),
        })
    }

    /// The 7 data bytes.
    pub fn emit(&self) -> [u8; 7] {
        let v = self.vendor_id.to_le_bytes();
        let s = self.serial_number.to_le_bytes();
        [
            (self.response as u8) << 7 | (self.port & 0x7F),
            v[0],
            v[1],
            s[0],
            s[1],
            s[2],
            s[3],
        ]
    }
}

impl fmt::Display for DuplicateMacCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} port {} vendor {} serial 0x{:08X}",
            if self.response { "response" } else { "request" },
            self.port,
            self.vendor_id,
            self.serial_number
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_attributes() {
        let mut id = Identity::default();
        id.set_attribute(attr::VENDOR_ID, &[0x10, 0x01]).unwrap();
        assert_eq!(id.vendor_id, 272);
        id.set_attribute(attr::PRODUCT_CODE, &1436u16.to_le_bytes())
            .unwrap();
        id.set_attribute(attr::PRODUCT_NAME, b"\x091436 cPos")
            .unwrap();
        assert_eq!(id.product_name.as_str(), "1436 cPos");
        assert_eq!(
            &id.attribute(attr::PRODUCT_NAME).unwrap()[..],
            b"\x091436 cPos"
        );
        assert_eq!(
            id.set_attribute(attr::PRODUCT_NAME, b"\x0a1436 cPos"),
            Err(AttributeError::Length {
                attribute: 7,
                expected: 11,
                actual: 10
            })
        );
        assert!(id.set_attribute(attr::SERIAL_NUMBER, &[1, 2, 3]).is_err());
        assert_eq!(id.attribute(8), None);
    }

    #[test]
    fn duplicate_mac_bytes() {
        let m = DuplicateMacCheck {
            response: false,
            port: 0,
            vendor_id: 272,
            serial_number: 0x12345678,
        };
        assert_eq!(m.emit(), [0x00, 0x10, 0x01, 0x78, 0x56, 0x34, 0x12]);
        assert_eq!(DuplicateMacCheck::parse(&m.emit()), Ok(m));
        assert_eq!(
            DuplicateMacCheck::parse(&[0x80; 6]),
            Err(DuplicateMacError(6))
        );
        let r = DuplicateMacCheck::parse(&[0x81, 0, 0, 0, 0, 0, 0]).unwrap();
        assert!(r.response);
        assert_eq!(r.port, 1);
    }

    proptest::proptest! {
        #[test]
        fn duplicate_mac_round_trip(b in proptest::array::uniform7(proptest::num::u8::ANY)) {
            proptest::prop_assert_eq!(DuplicateMacCheck::parse(&b).unwrap().emit(), b);
        }

        #[test]
        fn identity_attribute_round_trip(attribute in 1u8..=7, data in proptest::collection::vec(proptest::num::u8::ANY, 0..40)) {
            let mut id = Identity::default();
            if id.set_attribute(attribute, &data).is_ok() {
                proptest::prop_assert_eq!(&id.attribute(attribute).unwrap()[..], &data[..]);
            }
        }
    }
}
