//! The cyclic I/O image (DeviceNet manual chapter 5, "Cyclic DeviceNet data"; the Profinet
//! variant carries the same bytes). All multi-byte fields are big-endian (MSB first).
//!
//! ```text
//! master → device, 13 bytes          device → master, 11 bytes
//!  0..2  set value    U16 0..=1000 ‰   0..2  valve position U16 0..=1000 ‰
//!  2..4  actual value U16 0..=1000 ‰   2     digital outputs U8 (bit 0 K1, bit 1 K2)
//!  4     digital inputs U8 (bits 0..3   3..11 parameter channel
//!        In W, In X, In 1, In 2)
//!  5..13 parameter channel
//! ```
//!
//! Decoding never panics and never clamps: a per-mille value above 1000 or a set bit outside the
//! documented inputs/outputs is a typed [`ImageError`].
//!
//! Ambiguity: the manual gives the valve position's bytes as "Byte 2 | Byte 3" under 5.4 while its
//! own layout table puts the position at address 0 (bytes 0..1) and the outputs at address 2. The
//! layout table wins (it is consistent with the 11-byte length and with the outputs at address 2).

use crate::channel::Channel;
use core::fmt;

/// Length of the master→device image.
pub const MASTER_IMAGE_LEN: usize = 13;
/// Length of the device→master image.
pub const DEVICE_IMAGE_LEN: usize = 11;

/// A value in per mille (0.1 %), 0..=1000.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct PerMille(u16);

impl PerMille {
    /// 0 ‰.
    pub const ZERO: PerMille = PerMille(0);
    /// 1000 ‰ (100 %).
    pub const FULL: PerMille = PerMille(1000);

    /// `value` per mille, or an error above 1000.
    pub const fn new(value: u16) -> Result<Self, ImageError> {
        if value > 1000 {
            Err(ImageError::PerMilleOutOfRange {
                field: Field::Raw,
                value,
            })
        } else {
            Ok(Self(value))
        }
    }

    /// The value in per mille.
    pub const fn get(self) -> u16 {
        self.0
    }

    fn parse(field: Field, hi: u8, lo: u8) -> Result<Self, ImageError> {
        let value = u16::from_be_bytes([hi, lo]);
        if value > 1000 {
            Err(ImageError::PerMilleOutOfRange { field, value })
        } else {
            Ok(Self(value))
        }
    }
}

impl fmt::Display for PerMille {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{} %", self.0 / 10, self.0 % 10)
    }
}

/// Which image field a value belongs to (for error messages).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Field {
    /// A value given directly to [`PerMille::new`].
    Raw,
    /// Master→device set value.
    SetValue,
    /// Master→device actual value (process controller).
    ActualValue,
    /// Device→master valve position.
    Position,
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Field::Raw => "value",
            Field::SetValue => "set value",
            Field::ActualValue => "actual value",
            Field::Position => "valve position",
        })
    }
}

/// Why an image could not be decoded or built.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The byte slice has the wrong length.
    #[error("image is {actual} bytes, expected {expected}")]
    Length {
        /// Expected length.
        expected: usize,
        /// Given length.
        actual: usize,
    },
    /// A per-mille field is above 1000.
    #[error("{field} {value} is above 1000 per mille")]
    PerMilleOutOfRange {
        /// The field.
        field: Field,
        /// The value found.
        value: u16,
    },
    /// Digital input bits 4..7 are set (the manual allows 0..0x0F).
    #[error("digital inputs 0x{0:02X} use bits above In 2 (allowed 0x00..=0x0F)")]
    InputsOutOfRange(u8),
    /// Digital output bits 2..7 are set (the manual allows 0..0x03).
    #[error("digital outputs 0x{0:02X} use bits above K2 (allowed 0x00..=0x03)")]
    OutputsOutOfRange(u8),
}

debug_as_display!(ImageError);

/// The four digital inputs the master sends (byte 4, bits 0..3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DigitalInputs {
    /// In W, bit 0.
    pub in_w: bool,
    /// In X, bit 1.
    pub in_x: bool,
    /// In 1, bit 2.
    pub in_1: bool,
    /// In 2, bit 3.
    pub in_2: bool,
}

impl DigitalInputs {
    /// The wire byte.
    pub const fn to_byte(self) -> u8 {
        (self.in_w as u8) | (self.in_x as u8) << 1 | (self.in_1 as u8) << 2 | (self.in_2 as u8) << 3
    }

    /// From the wire byte; bits 4..7 are an error.
    pub const fn from_byte(b: u8) -> Result<Self, ImageError> {
        if b & 0xF0 != 0 {
            return Err(ImageError::InputsOutOfRange(b));
        }
        Ok(Self {
            in_w: b & 1 != 0,
            in_x: b & 2 != 0,
            in_1: b & 4 != 0,
            in_2: b & 8 != 0,
        })
    }
}

/// The two digital outputs the device reports (byte 2, bit 0 K1, bit 1 K2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DigitalOutputs {
    /// K1, bit 0.
    pub k1: bool,
    /// K2, bit 1.
    pub k2: bool,
}

impl DigitalOutputs {
    /// The wire byte.
    pub const fn to_byte(self) -> u8 {
        (self.k1 as u8) | (self.k2 as u8) << 1
    }

    /// From the wire byte; bits 2..7 are an error.
    pub const fn from_byte(b: u8) -> Result<Self, ImageError> {
        if b & 0xFC != 0 {
            return Err(ImageError::OutputsOutOfRange(b));
        }
        Ok(Self {
            k1: b & 1 != 0,
            k2: b & 2 != 0,
        })
    }
}

/// The 13-byte master→device image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct MasterImage {
    /// Set value (Sollwert), ‰.
    pub set_value: PerMille,
    /// Actual value (Istwert) for the process controller, ‰.
    pub actual_value: PerMille,
    /// Digital inputs In W, In X, In 1, In 2.
    pub inputs: DigitalInputs,
    /// The parameter channel.
    pub channel: Channel,
}

impl MasterImage {
    /// Decodes 13 bytes. Never panics.
    pub fn parse(bytes: &[u8]) -> Result<Self, ImageError> {
        let b: &[u8; MASTER_IMAGE_LEN] = bytes.try_into().map_err(|_| ImageError::Length {
            expected: MASTER_IMAGE_LEN,
            actual: bytes.len(),
        })?;
        let set_value = PerMille::parse(Field::SetValue, b[0], b[1])?;
        let actual_value = PerMille::parse(Field::ActualValue, b[2], b[3])?;
        let inputs = DigitalInputs::from_byte(b[4])?;
        let mut ch = [0u8; 8];
        ch.copy_from_slice(&b[5..]);
        Ok(Self {
            set_value,
            actual_value,
            inputs,
            channel: Channel::from_bytes(ch),
        })
    }

    /// Encodes the 13 bytes.
    pub fn to_bytes(&self) -> [u8; MASTER_IMAGE_LEN] {
        let mut b = [0u8; MASTER_IMAGE_LEN];
        b[0..2].copy_from_slice(&self.set_value.0.to_be_bytes());
        b[2..4].copy_from_slice(&self.actual_value.0.to_be_bytes());
        b[4] = self.inputs.to_byte();
        b[5..].copy_from_slice(&self.channel.to_bytes());
        b
    }
}

/// The 11-byte device→master image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DeviceImage {
    /// Valve position (Ventilstellung), ‰. Before initialisation it refers to the
    /// potentiometer range, after InitValve to the valve range (manual 5.4).
    pub position: PerMille,
    /// Digital outputs K1, K2.
    pub outputs: DigitalOutputs,
    /// The parameter channel.
    pub channel: Channel,
}

impl DeviceImage {
    /// Decodes 11 bytes. Never panics.
    pub fn parse(bytes: &[u8]) -> Result<Self, ImageError> {
        let b: &[u8; DEVICE_IMAGE_LEN] = bytes.try_into().map_err(|_| ImageError::Length {
            expected: DEVICE_IMAGE_LEN,
            actual: bytes.len(),
        })?;
        let position = PerMille::parse(Field::Position, b[0], b[1])?;
        let outputs = DigitalOutputs::from_byte(b[2])?;
        let mut ch = [0u8; 8];
        ch.copy_from_slice(&b[3..]);
        Ok(Self {
            position,
            outputs,
            channel: Channel::from_bytes(ch),
        })
    }

    /// Encodes the 11 bytes.
    pub fn to_bytes(&self) -> [u8; DEVICE_IMAGE_LEN] {
        let mut b = [0u8; DEVICE_IMAGE_LEN];
        b[0..2].copy_from_slice(&self.position.0.to_be_bytes());
        b[2] = self.outputs.to_byte();
        b[3..].copy_from_slice(&self.channel.to_bytes());
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::channel::Instruction;
    use proptest::prelude::*;

    #[test]
    fn master_image_layout_is_big_endian() {
        let img = MasterImage {
            set_value: PerMille::new(1000).unwrap(),
            actual_value: PerMille::new(0x0102).unwrap(),
            inputs: DigitalInputs {
                in_w: true,
                in_x: false,
                in_1: false,
                in_2: true,
            },
            channel: Channel::request(0x07, Instruction::Set, 0x0064, 2),
        };
        assert_eq!(
            img.to_bytes(),
            [
                0x03, 0xE8, 0x01, 0x02, 0x09, 0x07, 0x53, 0x00, 0x64, 0x00, 0x00, 0x00, 0x02
            ]
        );
        assert_eq!(MasterImage::parse(&img.to_bytes()), Ok(img));
    }

    #[test]
    fn device_image_layout() {
        let bytes = [
            0x01, 0xF4, 0x02, 0x00, 0x44, 0x00, 0x01, 0x00, 0x01, 0x00, 0x14,
        ];
        let img = DeviceImage::parse(&bytes).unwrap();
        assert_eq!(img.position.get(), 500);
        assert_eq!(
            img.outputs,
            DigitalOutputs {
                k1: false,
                k2: true
            }
        );
        assert_eq!(img.channel.instruction, Instruction::ActiveErrors);
        assert_eq!(img.to_bytes(), bytes);
    }

    #[test]
    fn out_of_range_is_rejected_not_clamped() {
        assert_eq!(
            PerMille::new(1001),
            Err(ImageError::PerMilleOutOfRange {
                field: Field::Raw,
                value: 1001
            })
        );
        let mut m = [0u8; 13];
        m[0] = 0x03;
        m[1] = 0xE9;
        assert_eq!(
            MasterImage::parse(&m),
            Err(ImageError::PerMilleOutOfRange {
                field: Field::SetValue,
                value: 1001
            })
        );
        m[0] = 0;
        m[2] = 0xFF;
        assert!(matches!(
            MasterImage::parse(&m),
            Err(ImageError::PerMilleOutOfRange {
                field: Field::ActualValue,
                ..
            })
        ));
        m[2] = 0;
        m[4] = 0x10;
        assert_eq!(
            MasterImage::parse(&m),
            Err(ImageError::InputsOutOfRange(0x10))
        );
        let mut d = [0u8; 11];
        d[2] = 0x04;
        assert_eq!(
            DeviceImage::parse(&d),
            Err(ImageError::OutputsOutOfRange(0x04))
        );
        d[2] = 0;
        d[0] = 0x04;
        assert!(matches!(
            DeviceImage::parse(&d),
            Err(ImageError::PerMilleOutOfRange {
                field: Field::Position,
                value: 0x0400
            })
        ));
        assert_eq!(
            DeviceImage::parse(&d[..10]),
            Err(ImageError::Length {
                expected: 11,
                actual: 10
            })
        );
        assert_eq!(
            MasterImage::parse(&[0; 14]),
            Err(ImageError::Length {
                expected: 13,
                actual: 14
            })
        );
    }

    fn per_mille() -> impl Strategy<Value = PerMille> {
        (0u16..=1000).prop_map(|v| PerMille::new(v).unwrap())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn master_round_trip(sv in per_mille(), av in per_mille(), inp in 0u8..16, ch in any::<[u8; 8]>()) {
            let img = MasterImage {
                set_value: sv, actual_value: av,
                inputs: DigitalInputs::from_byte(inp).unwrap(),
                channel: Channel::from_bytes(ch),
            };
            let bytes = img.to_bytes();
            prop_assert_eq!(MasterImage::parse(&bytes), Ok(img));
        }

        #[test]
        fn device_round_trip(pos in per_mille(), out in 0u8..4, ch in any::<[u8; 8]>()) {
            let img = DeviceImage {
                position: pos,
                outputs: DigitalOutputs::from_byte(out).unwrap(),
                channel: Channel::from_bytes(ch),
            };
            prop_assert_eq!(DeviceImage::parse(&img.to_bytes()), Ok(img));
        }

        #[test]
        fn device_parse_is_total_and_lossless(bytes in proptest::collection::vec(any::<u8>(), 0..16)) {
            if let Ok(img) = DeviceImage::parse(&bytes) {
                prop_assert_eq!(&img.to_bytes()[..], &bytes[..]);
            }
        }

        #[test]
        fn master_parse_is_total_and_lossless(bytes in proptest::collection::vec(any::<u8>(), 0..16)) {
            if let Ok(img) = MasterImage::parse(&bytes) {
                prop_assert_eq!(&img.to_bytes()[..], &bytes[..]);
            }
        }
    }
}
