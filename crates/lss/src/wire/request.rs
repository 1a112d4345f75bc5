//! The master-to-slave LSS messages (COB-ID 0x7E5): [`Request`], its total decoder, its
//! encoder and its CiA 305 service names.

use core::fmt;

use canola_frame::cob::LSS_MASTER_TO_SLAVE;
use canola_frame::{CanFrame, CanId};

use super::{
    BIT_CHECK_CONFIRM, DecodeError, IdentifyField, Mode, NodeIdByte, Rest, check_frame, cs, eight,
    field, get_u32, put_u32, rest,
};
use crate::address::{AddressPart, BitTiming};

#[cfg(doc)]
use super::UNCONFIGURED_NODE_ID;

/// A master-to-slave LSS message (COB-ID 0x7E5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Request {
    /// Switch mode global (0x04): every slave enters `mode`.
    SwitchModeGlobal(Mode),
    /// Switch mode selective (0x40..=0x43): one part of the address; a slave that matched all
    /// four in order enters configuration and answers 0x44.
    SwitchModeSelective(AddressPart, u32),
    /// Configure node-ID (0x11): 1..=127, or [`UNCONFIGURED_NODE_ID`]; other values are sent as
    /// given (the slave answers "invalid").
    ConfigureNodeId(u8),
    /// Configure bit timing parameters (0x13).
    ConfigureBitTiming(BitTiming),
    /// Activate bit timing parameters (0x15), switch delay in milliseconds.
    ActivateBitTiming {
        /// Each slave waits this long, switches, and waits this long again before sending.
        delay_ms: u16,
    },
    /// Store configuration (0x17).
    StoreConfiguration,
    /// Inquire identity vendor-ID / product code / revision / serial (0x5A..=0x5D).
    InquireIdentity(AddressPart),
    /// Inquire node-ID (0x5E).
    InquireNodeId,
    /// Identify remote slave (0x46..=0x4B).
    IdentifyRemoteSlave(IdentifyField, u32),
    /// Identify non-configured remote slave (0x4C).
    IdentifyNonConfigured,
    /// LSS Fastscan (0x51). Fields raw so that any value round-trips; see [`BIT_CHECK_CONFIRM`]
    /// and [`AddressPart`] for their meaning.
    Fastscan {
        /// IDNumber: the value compared with the slave's address part `lss_sub`.
        id_number: u32,
        /// BitChecked: bits `bit_check..=31` are compared (0..=31), or 0x80 = confirm/reset.
        bit_check: u8,
        /// LSSSub: the address part compared (0..=3).
        lss_sub: u8,
        /// LSSNext: the part a matching slave compares next (0..=3).
        lss_next: u8,
    },
    /// A command specifier this crate does not know, with the seven bytes after it.
    Unknown {
        /// Command specifier.
        cs: u8,
        /// Bytes 1..=7.
        data: [u8; 7],
    },
}

impl fmt::Display for Request {
    /// The CiA 305 service name and its parameters, e.g. `LSS switch state global
    /// configuration` or `LSS Fastscan id 0x00000000 bit 31 sub 0 next 0`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("LSS ")?;
        match *self {
            Self::SwitchModeGlobal(mode) => write!(f, "switch state global {mode}"),
            Self::SwitchModeSelective(part, v) => {
                write!(f, "switch state selective {part} {v:#010x}")
            }
            Self::ConfigureNodeId(id) => write!(f, "configure node-ID {}", NodeIdByte(id)),
            Self::ConfigureBitTiming(t) => write!(f, "configure bit timing {t}"),
            Self::ActivateBitTiming { delay_ms } => {
                write!(f, "activate bit timing, switch delay {delay_ms} ms")
            }
            Self::StoreConfiguration => f.write_str("store configuration"),
            Self::InquireIdentity(part) => write!(f, "inquire identity {part}"),
            Self::InquireNodeId => f.write_str("inquire node-ID"),
            Self::IdentifyRemoteSlave(field, v) => {
                write!(f, "identify remote slave {field} {v:#010x}")
            }
            Self::IdentifyNonConfigured => f.write_str("identify non-configured remote slave"),
            Self::Fastscan {
                id_number,
                bit_check,
                lss_sub,
                lss_next,
            } => {
                write!(f, "Fastscan id {id_number:#010x} bit ")?;
                if bit_check == BIT_CHECK_CONFIRM {
                    f.write_str("0x80 (confirm)")?;
                } else {
                    write!(f, "{bit_check}")?;
                }
                write!(f, " sub {lss_sub} next {lss_next}")
            }
            Self::Unknown { cs, data } => write!(f, "unknown cs {cs:#04X}: {}", Rest(data)),
        }
    }
}

const MASTER_ID: CanId = match CanId::standard(LSS_MASTER_TO_SLAVE) {
    Ok(id) => id,
    Err(_) => panic!("0x7E5 is a standard identifier"),
};

impl Request {
    /// Decodes eight data bytes. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        let b = eight(data)?;
        let c = b[field::CS];
        Ok(match c {
            cs::SWITCH_MODE_GLOBAL => Self::SwitchModeGlobal(Mode::from_raw(b[field::BYTE1])),
            cs::CONFIGURE_NODE_ID => Self::ConfigureNodeId(b[field::BYTE1]),
            cs::CONFIGURE_BIT_TIMING => Self::ConfigureBitTiming(BitTiming {
                table: b[field::ERROR],
                index: b[field::SPEC],
            }),
            cs::ACTIVATE_BIT_TIMING => Self::ActivateBitTiming {
                delay_ms: u16::from_le_bytes([b[1], b[2]]),
            },
            cs::STORE_CONFIGURATION => Self::StoreConfiguration,
            0x40..=0x43 => match AddressPart::from_index(c - cs::SWITCH_SELECTIVE_VENDOR) {
                Some(part) => Self::SwitchModeSelective(part, get_u32(b)),
                None => Self::Unknown {
                    cs: c,
                    data: rest(b),
                },
            },
            0x46..=0x4B => {
                let field = IdentifyField::ALL[usize::from(c - cs::IDENTIFY_REMOTE_VENDOR) % 6];
                Self::IdentifyRemoteSlave(field, get_u32(b))
            }
            cs::IDENTIFY_NON_CONFIGURED => Self::IdentifyNonConfigured,
            cs::FASTSCAN => Self::Fastscan {
                id_number: get_u32(b),
                bit_check: b[field::BIT_CHECK],
                lss_sub: b[field::LSS_SUB],
                lss_next: b[field::LSS_NEXT],
            },
            0x5A..=0x5D => match AddressPart::from_index(c - cs::INQUIRE_VENDOR) {
                Some(part) => Self::InquireIdentity(part),
                None => Self::Unknown {
                    cs: c,
                    data: rest(b),
                },
            },
            cs::INQUIRE_NODE_ID => Self::InquireNodeId,
            _ => Self::Unknown {
                cs: c,
                data: rest(b),
            },
        })
    }

    /// The command specifier.
    pub const fn cs(&self) -> u8 {
        match *self {
            Self::SwitchModeGlobal(_) => cs::SWITCH_MODE_GLOBAL,
            Self::SwitchModeSelective(part, _) => cs::SWITCH_SELECTIVE_VENDOR + part.index(),
            Self::ConfigureNodeId(_) => cs::CONFIGURE_NODE_ID,
            Self::ConfigureBitTiming(_) => cs::CONFIGURE_BIT_TIMING,
            Self::ActivateBitTiming { .. } => cs::ACTIVATE_BIT_TIMING,
            Self::StoreConfiguration => cs::STORE_CONFIGURATION,
            Self::InquireIdentity(part) => cs::INQUIRE_VENDOR + part.index(),
            Self::InquireNodeId => cs::INQUIRE_NODE_ID,
            Self::IdentifyRemoteSlave(field, _) => field.cs(),
            Self::IdentifyNonConfigured => cs::IDENTIFY_NON_CONFIGURED,
            Self::Fastscan { .. } => cs::FASTSCAN,
            Self::Unknown { cs, .. } => cs,
        }
    }

    /// Encodes into eight bytes, unused bytes zero.
    pub fn emit(&self) -> [u8; 8] {
        let mut buf = [0u8; 8];
        buf[field::CS] = self.cs();
        match *self {
            Self::SwitchModeGlobal(mode) => buf[field::BYTE1] = mode.raw(),
            Self::SwitchModeSelective(_, v) | Self::IdentifyRemoteSlave(_, v) => {
                put_u32(&mut buf, v)
            }
            Self::ConfigureNodeId(id) => buf[field::BYTE1] = id,
            Self::ConfigureBitTiming(t) => {
                buf[field::ERROR] = t.table;
                buf[field::SPEC] = t.index;
            }
            Self::ActivateBitTiming { delay_ms } => {
                buf[1..3].copy_from_slice(&delay_ms.to_le_bytes())
            }
            Self::Fastscan {
                id_number,
                bit_check,
                lss_sub,
                lss_next,
            } => {
                put_u32(&mut buf, id_number);
                buf[field::BIT_CHECK] = bit_check;
                buf[field::LSS_SUB] = lss_sub;
                buf[field::LSS_NEXT] = lss_next;
            }
            Self::Unknown { data, .. } => buf[1..].copy_from_slice(&data),
            Self::StoreConfiguration
            | Self::InquireIdentity(_)
            | Self::InquireNodeId
            | Self::IdentifyNonConfigured => {}
        }
        buf
    }

    /// The frame on COB-ID 0x7E5.
    pub fn to_frame(&self) -> CanFrame {
        CanFrame::from_array(MASTER_ID, self.emit())
    }

    /// Decodes a frame, checking that it is a data frame on COB-ID 0x7E5.
    pub fn from_frame(frame: &CanFrame) -> Result<Self, DecodeError> {
        Self::parse(check_frame(frame, LSS_MASTER_TO_SLAVE)?)
    }
}
