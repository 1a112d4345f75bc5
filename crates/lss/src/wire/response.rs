//! The slave-to-master LSS messages (COB-ID 0x7E4): [`Response`], the status the
//! configuration responses carry ([`ConfigStatus`], [`ResponseError`]), the total decoder, the
//! encoder and the CiA 305 response names.

use core::fmt;

use canola_frame::cob::LSS_SLAVE_TO_MASTER;
use canola_frame::{CanFrame, CanId};

use super::{DecodeError, NodeIdByte, Rest, check_frame, cs, eight, field, get_u32, put_u32, rest};
use crate::address::AddressPart;

/// The status carried by the configure node-ID, configure bit timing and store configuration
/// responses: an error code and a manufacturer-specific extension, kept raw so that decoding
/// is lossless. [`ConfigStatus::result`] gives the typed meaning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ConfigStatus {
    /// 0 = success, 1 = not supported / invalid, 2 = storage media error (store only),
    /// 255 = see `extension`, other values reserved.
    pub code: u8,
    /// Manufacturer-specific error, meaningful when `code` is 255.
    pub extension: u8,
}

impl ConfigStatus {
    /// Success.
    pub const OK: ConfigStatus = ConfigStatus {
        code: 0,
        extension: 0,
    };

    /// The status that reports `error`.
    pub const fn from_error(error: ResponseError) -> Self {
        match error {
            ResponseError::NotSupported => Self {
                code: 1,
                extension: 0,
            },
            ResponseError::StorageMediaAccess => Self {
                code: 2,
                extension: 0,
            },
            ResponseError::VendorSpecific(extension) => Self {
                code: 255,
                extension,
            },
            ResponseError::Reserved { code, extension } => Self { code, extension },
        }
    }

    /// `Ok` for code 0, otherwise what the slave reported.
    pub const fn result(self) -> Result<(), ResponseError> {
        match self.code {
            0 => Ok(()),
            1 => Err(ResponseError::NotSupported),
            2 => Err(ResponseError::StorageMediaAccess),
            255 => Err(ResponseError::VendorSpecific(self.extension)),
            code => Err(ResponseError::Reserved {
                code,
                extension: self.extension,
            }),
        }
    }
}

/// What a slave said no with (CiA 305 configure node-ID, configure bit timing, store configuration): the peer's answer, never a local
/// failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum ResponseError {
    /// Code 1: configure node-ID — node-ID out of range; configure bit timing — bit timing not
    /// supported; store configuration — store not supported.
    #[error("not supported or invalid (error code 1)")]
    NotSupported,
    /// Code 2 (store configuration): storage media access error.
    #[error("storage media access error (error code 2)")]
    StorageMediaAccess,
    /// Code 255: a manufacturer-specific error, given by the extension byte.
    #[error("manufacturer-specific error {0:#04X} (error code 255)")]
    VendorSpecific(u8),
    /// A code the standard reserves.
    #[error("reserved error code {code} (extension {extension:#04X})")]
    Reserved {
        /// The error code.
        code: u8,
        /// The extension byte.
        extension: u8,
    },
}

/// A slave-to-master LSS message (COB-ID 0x7E4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Response {
    /// Switch mode selective response (0x44).
    SwitchModeSelective,
    /// Configure node-ID response (0x11).
    ConfigureNodeId(ConfigStatus),
    /// Configure bit timing response (0x13).
    ConfigureBitTiming(ConfigStatus),
    /// Store configuration response (0x17).
    StoreConfiguration(ConfigStatus),
    /// Inquire identity response (0x5A..=0x5D).
    InquireIdentity(AddressPart, u32),
    /// Inquire node-ID response (0x5E): the active node-ID, 0xFF when unconfigured.
    InquireNodeId(u8),
    /// Identify slave (0x4F): answer to identify remote slave and to Fastscan.
    IdentifySlave,
    /// Identify non-configured slave (0x50).
    IdentifyNonConfiguredSlave,
    /// A command specifier this crate does not know, with the seven bytes after it.
    Unknown {
        /// Command specifier.
        cs: u8,
        /// Bytes 1..=7.
        data: [u8; 7],
    },
}

impl fmt::Display for ConfigStatus {
    /// `success`, or the error the slave reported.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.result() {
            Ok(()) => f.write_str("success"),
            Err(e) => write!(f, "error: {e}"),
        }
    }
}

impl fmt::Display for Response {
    /// The CiA 305 response name and its parameters, e.g. `LSS configure node-ID response:
    /// success` or `LSS identify slave`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("LSS ")?;
        match *self {
            Self::SwitchModeSelective => f.write_str("switch state selective response"),
            Self::ConfigureNodeId(s) => write!(f, "configure node-ID response: {s}"),
            Self::ConfigureBitTiming(s) => write!(f, "configure bit timing response: {s}"),
            Self::StoreConfiguration(s) => write!(f, "store configuration response: {s}"),
            Self::InquireIdentity(part, v) => {
                write!(f, "inquire identity {part} response {v:#010x}")
            }
            Self::InquireNodeId(id) => write!(f, "inquire node-ID response {}", NodeIdByte(id)),
            Self::IdentifySlave => f.write_str("identify slave"),
            Self::IdentifyNonConfiguredSlave => f.write_str("identify non-configured slave"),
            Self::Unknown { cs, data } => write!(f, "unknown cs {cs:#04X}: {}", Rest(data)),
        }
    }
}

fn status(b: &[u8; 8]) -> ConfigStatus {
    ConfigStatus {
        code: b[field::ERROR],
        extension: b[field::SPEC],
    }
}

fn put_status(buf: &mut [u8; 8], s: ConfigStatus) {
    buf[field::ERROR] = s.code;
    buf[field::SPEC] = s.extension;
}

pub(super) const SLAVE_ID: CanId = match CanId::standard(LSS_SLAVE_TO_MASTER) {
    Ok(id) => id,
    Err(_) => panic!("0x7E4 is a standard identifier"),
};

impl Response {
    /// Decodes eight data bytes. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        let b = eight(data)?;
        let c = b[field::CS];
        Ok(match c {
            cs::SWITCH_SELECTIVE_RESPONSE => Self::SwitchModeSelective,
            cs::CONFIGURE_NODE_ID => Self::ConfigureNodeId(status(b)),
            cs::CONFIGURE_BIT_TIMING => Self::ConfigureBitTiming(status(b)),
            cs::STORE_CONFIGURATION => Self::StoreConfiguration(status(b)),
            0x5A..=0x5D => match AddressPart::from_index(c - cs::INQUIRE_VENDOR) {
                Some(part) => Self::InquireIdentity(part, get_u32(b)),
                None => Self::Unknown {
                    cs: c,
                    data: rest(b),
                },
            },
            cs::INQUIRE_NODE_ID => Self::InquireNodeId(b[field::BYTE1]),
            cs::IDENTIFY_SLAVE => Self::IdentifySlave,
            cs::IDENTIFY_NON_CONFIGURED_SLAVE => Self::IdentifyNonConfiguredSlave,
            _ => Self::Unknown {
                cs: c,
                data: rest(b),
            },
        })
    }

    /// The command specifier.
    pub const fn cs(&self) -> u8 {
        match *self {
            Self::SwitchModeSelective => cs::SWITCH_SELECTIVE_RESPONSE,
            Self::ConfigureNodeId(_) => cs::CONFIGURE_NODE_ID,
            Self::ConfigureBitTiming(_) => cs::CONFIGURE_BIT_TIMING,
            Self::StoreConfiguration(_) => cs::STORE_CONFIGURATION,
            Self::InquireIdentity(part, _) => cs::INQUIRE_VENDOR + part.index(),
            Self::InquireNodeId(_) => cs::INQUIRE_NODE_ID,
            Self::IdentifySlave => cs::IDENTIFY_SLAVE,
            Self::IdentifyNonConfiguredSlave => cs::IDENTIFY_NON_CONFIGURED_SLAVE,
            Self::Unknown { cs, .. } => cs,
        }
    }

    /// Encodes into eight bytes, unused bytes zero.
    pub fn emit(&self) -> [u8; 8] {
        let mut buf = [0u8; 8];
        buf[field::CS] = self.cs();
        match *self {
            Self::ConfigureNodeId(s)
            | Self::ConfigureBitTiming(s)
            | Self::StoreConfiguration(s) => put_status(&mut buf, s),
            Self::InquireIdentity(_, v) => put_u32(&mut buf, v),
            Self::InquireNodeId(id) => buf[field::BYTE1] = id,
            Self::Unknown { data, .. } => buf[1..].copy_from_slice(&data),
            Self::SwitchModeSelective | Self::IdentifySlave | Self::IdentifyNonConfiguredSlave => {}
        }
        buf
    }

    /// The frame on COB-ID 0x7E4.
    pub fn to_frame(&self) -> CanFrame {
        CanFrame::from_array(SLAVE_ID, self.emit())
    }

    /// Decodes a frame, checking that it is a data frame on COB-ID 0x7E4.
    pub fn from_frame(frame: &CanFrame) -> Result<Self, DecodeError> {
        Self::parse(check_frame(frame, LSS_SLAVE_TO_MASTER)?)
    }
}
