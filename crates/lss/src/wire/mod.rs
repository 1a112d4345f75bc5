//! The LSS messages of CiA 305 (the LSS protocols): every request a master sends on COB-ID 0x7E5 and
//! every response a slave sends on 0x7E4.
//!
//! Each message is exactly eight data bytes: the command specifier (`cs`) in byte 0, service
//! data after it, unused bytes zero. Integers are little-endian.
//!
//! | cs          | request (0x7E5)                                   | response (0x7E4)         |
//! |-------------|---------------------------------------------------|--------------------------|
//! | 0x04        | switch mode global `[cs, mode]`                   | none                     |
//! | 0x11        | configure node-ID `[cs, id]`                      | `[cs, error, spec]`      |
//! | 0x13        | configure bit timing `[cs, table, index]`         | `[cs, error, spec]`      |
//! | 0x15        | activate bit timing `[cs, delay lo, delay hi]`    | none                     |
//! | 0x17        | store configuration `[cs]`                        | `[cs, error, spec]`      |
//! | 0x40..=0x43 | switch mode selective, u32 vendor/product/rev/serial | 0x44 after the serial |
//! | 0x46..=0x4B | identify remote slave, u32 vendor, product, rev low/high, serial low/high | 0x4F |
//! | 0x4C        | identify non-configured remote slave              | 0x50                     |
//! | 0x51        | Fastscan `[cs, id u32, bit check, LSSSub, LSSNext]` | 0x4F                   |
//! | 0x5A..=0x5D | inquire vendor/product/revision/serial            | same cs, u32             |
//! | 0x5E        | inquire node-ID                                   | `[cs, node-ID]`          |
//!
//! Two levels, as elsewhere in the stack: a private `field` module holds the offsets, and the
//! typed [`Request`] / [`Response`] have a total `parse` (never panics: bytes become a value or a
//! [`DecodeError`]) and an `emit` into an eight-byte buffer. Unknown command specifiers are kept
//! with their seven data bytes, so decode-then-encode loses nothing. Reserved bytes of known
//! messages are ignored on decode and sent as zero.
//!
//! Files by concern: this one holds the frame layout (offsets, command specifiers, the
//! shared byte helpers), the decode error and the small values both directions carry
//! ([`Mode`], [`IdentifyField`]); `request` the master-to-slave [`Request`]; `response` the
//! slave-to-master [`Response`] with its status ([`ConfigStatus`], [`ResponseError`]).

use core::fmt;

use canola_frame::CanFrame;

mod request;
mod response;

pub use request::Request;
pub use response::{ConfigStatus, Response, ResponseError};

/// Byte offsets inside the eight data bytes.
mod field {
    pub(super) const CS: usize = 0;
    /// A UNSIGNED32 (identity value, Fastscan IDNumber) spans bytes 1..=4.
    pub(super) const U32: core::ops::Range<usize> = 1..5;
    /// Switch mode global mode, configure node-ID value, inquire node-ID value.
    pub(super) const BYTE1: usize = 1;
    /// Error code of a configuration response; table selector of configure bit timing.
    pub(super) const ERROR: usize = 1;
    /// Error extension of a configuration response; table index of configure bit timing.
    pub(super) const SPEC: usize = 2;
    pub(super) const BIT_CHECK: usize = 5;
    pub(super) const LSS_SUB: usize = 6;
    pub(super) const LSS_NEXT: usize = 7;
}

/// Command specifiers (CiA 305).
pub mod cs {
    /// Switch mode global.
    pub const SWITCH_MODE_GLOBAL: u8 = 0x04;
    /// Configure node-ID.
    pub const CONFIGURE_NODE_ID: u8 = 0x11;
    /// Configure bit timing parameters.
    pub const CONFIGURE_BIT_TIMING: u8 = 0x13;
    /// Activate bit timing parameters.
    pub const ACTIVATE_BIT_TIMING: u8 = 0x15;
    /// Store configuration.
    pub const STORE_CONFIGURATION: u8 = 0x17;
    /// Switch mode selective, vendor-ID (product 0x41, revision 0x42, serial 0x43 follow).
    pub const SWITCH_SELECTIVE_VENDOR: u8 = 0x40;
    /// Switch mode selective response.
    pub const SWITCH_SELECTIVE_RESPONSE: u8 = 0x44;
    /// Identify remote slave, vendor-ID (product 0x47, revision low/high 0x48/0x49, serial
    /// low/high 0x4A/0x4B follow).
    pub const IDENTIFY_REMOTE_VENDOR: u8 = 0x46;
    /// Identify non-configured remote slave.
    pub const IDENTIFY_NON_CONFIGURED: u8 = 0x4C;
    /// Identify slave (the response to identify remote slave and to Fastscan).
    pub const IDENTIFY_SLAVE: u8 = 0x4F;
    /// Identify non-configured slave (the response to 0x4C).
    pub const IDENTIFY_NON_CONFIGURED_SLAVE: u8 = 0x50;
    /// LSS Fastscan.
    pub const FASTSCAN: u8 = 0x51;
    /// Inquire identity vendor-ID (product 0x5B, revision 0x5C, serial 0x5D follow).
    pub const INQUIRE_VENDOR: u8 = 0x5A;
    /// Inquire node-ID.
    pub const INQUIRE_NODE_ID: u8 = 0x5E;
}

/// The node-ID value that means "unconfigured" in configure node-ID and inquire node-ID.
pub const UNCONFIGURED_NODE_ID: u8 = 0xFF;

/// The Fastscan bit-check value that asks "is any unconfigured slave there?" and resets every
/// slave's scan position.
pub const BIT_CHECK_CONFIRM: u8 = 0x80;

/// Why bytes are not an LSS message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// LSS messages are always eight bytes.
    #[error("an LSS message has 8 data bytes, not {0}")]
    Length(usize),
    /// The frame is not on the LSS COB-ID of this direction.
    #[error("COB-ID {0:#05X} is not the expected LSS COB-ID")]
    WrongCobId(u32),
    /// A remote frame.
    #[error("LSS messages are never remote frames")]
    Remote,
}

/// The two states of an LSS slave (CiA 305), as carried by switch mode global.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// LSS waiting state (0).
    Waiting,
    /// LSS configuration state (1).
    Configuration,
    /// A reserved mode value, kept for lossless decoding.
    Unknown(u8),
}

impl Mode {
    /// The wire value.
    pub const fn raw(self) -> u8 {
        match self {
            Self::Waiting => 0,
            Self::Configuration => 1,
            Self::Unknown(v) => v,
        }
    }

    /// The mode for a wire value.
    pub const fn from_raw(v: u8) -> Self {
        match v {
            0 => Self::Waiting,
            1 => Self::Configuration,
            v => Self::Unknown(v),
        }
    }
}

/// Which value identify remote slave (0x46..=0x4B) carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IdentifyField {
    /// Vendor-ID (0x46), must be equal.
    Vendor,
    /// Product code (0x47), must be equal.
    Product,
    /// Lowest revision number (0x48).
    RevisionLow,
    /// Highest revision number (0x49).
    RevisionHigh,
    /// Lowest serial number (0x4A).
    SerialLow,
    /// Highest serial number (0x4B); the last message, slaves in range answer 0x4F.
    SerialHigh,
}

impl IdentifyField {
    /// In protocol order.
    pub const ALL: [IdentifyField; 6] = [
        Self::Vendor,
        Self::Product,
        Self::RevisionLow,
        Self::RevisionHigh,
        Self::SerialLow,
        Self::SerialHigh,
    ];

    const fn offset(self) -> u8 {
        match self {
            Self::Vendor => 0,
            Self::Product => 1,
            Self::RevisionLow => 2,
            Self::RevisionHigh => 3,
            Self::SerialLow => 4,
            Self::SerialHigh => 5,
        }
    }

    /// The command specifier.
    pub const fn cs(self) -> u8 {
        cs::IDENTIFY_REMOTE_VENDOR + self.offset()
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Waiting => f.write_str("waiting"),
            Self::Configuration => f.write_str("configuration"),
            Self::Unknown(v) => write!(f, "reserved mode {v}"),
        }
    }
}

impl fmt::Display for IdentifyField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Vendor => "vendor-ID",
            Self::Product => "product code",
            Self::RevisionLow => "revision number low",
            Self::RevisionHigh => "revision number high",
            Self::SerialLow => "serial number low",
            Self::SerialHigh => "serial number high",
        })
    }
}

/// A node-ID byte of configure node-ID or inquire node-ID.
struct NodeIdByte(u8);

impl fmt::Display for NodeIdByte {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            UNCONFIGURED_NODE_ID => f.write_str("unconfigured (0xFF)"),
            1..=127 => write!(f, "{}", self.0),
            v => write!(f, "{v} (invalid)"),
        }
    }
}

/// The seven data bytes of an unknown command specifier, as hex.
struct Rest([u8; 7]);

impl fmt::Display for Rest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, b) in self.0.iter().enumerate() {
            let sep = if i == 0 { "" } else { " " };
            write!(f, "{sep}{b:02X}")?;
        }
        Ok(())
    }
}

/// The 8 bytes of `data`, or the length error. The only place that looks at the length.
fn eight(data: &[u8]) -> Result<&[u8; 8], DecodeError> {
    data.try_into().map_err(|_| DecodeError::Length(data.len()))
}

fn get_u32(b: &[u8; 8]) -> u32 {
    let [_, b1, b2, b3, b4, ..] = *b;
    u32::from_le_bytes([b1, b2, b3, b4])
}

fn rest(b: &[u8; 8]) -> [u8; 7] {
    let [_, r @ ..] = *b;
    r
}

fn put_u32(buf: &mut [u8; 8], v: u32) {
    buf[field::U32].copy_from_slice(&v.to_le_bytes());
}

fn check_frame(frame: &CanFrame, cob: u16) -> Result<&[u8], DecodeError> {
    if frame.cob_id() != Some(cob) {
        return Err(DecodeError::WrongCobId(frame.id().as_raw()));
    }
    if frame.is_remote() {
        return Err(DecodeError::Remote);
    }
    Ok(frame.data())
}

#[cfg(test)]
mod tests {
    use super::response::SLAVE_ID;
    use super::*;
    use crate::address::{AddressPart, BitRate, BitTiming};
    use proptest::prelude::*;
    use std::vec;

    fn req(r: Request, bytes: [u8; 8]) {
        assert_eq!(r.emit(), bytes, "{r:?}");
        assert_eq!(Request::parse(&bytes), Ok(r));
        let f = r.to_frame();
        assert_eq!(f.cob_id(), Some(0x7E5));
        assert_eq!(f.dlc(), 8);
        assert_eq!(Request::from_frame(&f), Ok(r));
    }

    fn resp(r: Response, bytes: [u8; 8]) {
        assert_eq!(r.emit(), bytes, "{r:?}");
        assert_eq!(Response::parse(&bytes), Ok(r));
        let f = r.to_frame();
        assert_eq!(f.cob_id(), Some(0x7E4));
        assert_eq!(Response::from_frame(&f), Ok(r));
    }

    #[test]
    fn seed_examples() {
        // Bürkert manual §2.3.1 steps 1..5.
        req(
            Request::SwitchModeGlobal(Mode::Configuration),
            [0x04, 1, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::ConfigureBitTiming(BitRate::Kbit125.into()),
            [0x13, 0, 4, 0, 0, 0, 0, 0],
        );
        resp(
            Response::ConfigureBitTiming(ConfigStatus::OK),
            [0x13, 0, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::ActivateBitTiming { delay_ms: 0x1234 },
            [0x15, 0x34, 0x12, 0, 0, 0, 0, 0],
        );
        req(Request::ConfigureNodeId(5), [0x11, 5, 0, 0, 0, 0, 0, 0]);
        resp(
            Response::ConfigureNodeId(ConfigStatus {
                code: 1,
                extension: 0,
            }),
            [0x11, 1, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::SwitchModeGlobal(Mode::Waiting),
            [0x04, 0, 0, 0, 0, 0, 0, 0],
        );
    }

    #[test]
    fn every_request() {
        req(
            Request::SwitchModeSelective(AddressPart::Vendor, 0x0000_0078),
            [0x40, 0x78, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::SwitchModeSelective(AddressPart::Product, 0x1122_3344),
            [0x41, 0x44, 0x33, 0x22, 0x11, 0, 0, 0],
        );
        req(
            Request::SwitchModeSelective(AddressPart::Revision, 2),
            [0x42, 2, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::SwitchModeSelective(AddressPart::Serial, 0xDEAD_BEEF),
            [0x43, 0xEF, 0xBE, 0xAD, 0xDE, 0, 0, 0],
        );
        req(
            Request::ConfigureNodeId(0xFF),
            [0x11, 0xFF, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::ConfigureBitTiming(BitTiming {
                table: 0x80,
                index: 3,
            }),
            [0x13, 0x80, 3, 0, 0, 0, 0, 0],
        );
        req(Request::StoreConfiguration, [0x17, 0, 0, 0, 0, 0, 0, 0]);
        req(
            Request::InquireIdentity(AddressPart::Vendor),
            [0x5A, 0, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::InquireIdentity(AddressPart::Product),
            [0x5B, 0, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::InquireIdentity(AddressPart::Revision),
            [0x5C, 0, 0, 0, 0, 0, 0, 0],
        );
        req(
            Request::InquireIdentity(AddressPart::Serial),
            [0x5D, 0, 0, 0, 0, 0, 0, 0],
        );
        req(Request::InquireNodeId, [0x5E, 0, 0, 0, 0, 0, 0, 0]);
        let idents = [0x46, 0x47, 0x48, 0x49, 0x4A, 0x4B];
        for (f, c) in IdentifyField::ALL.iter().zip(idents) {
            req(
                Request::IdentifyRemoteSlave(*f, 0x0102_0304),
                [c, 4, 3, 2, 1, 0, 0, 0],
            );
        }
        req(Request::IdentifyNonConfigured, [0x4C, 0, 0, 0, 0, 0, 0, 0]);
        req(
            Request::Fastscan {
                id_number: 0,
                bit_check: 0x80,
                lss_sub: 0,
                lss_next: 0,
            },
            [0x51, 0, 0, 0, 0, 0x80, 0, 0],
        );
        req(
            Request::Fastscan {
                id_number: 0x8000_0001,
                bit_check: 31,
                lss_sub: 3,
                lss_next: 0,
            },
            [0x51, 1, 0, 0, 0x80, 31, 3, 0],
        );
        req(
            Request::Unknown {
                cs: 0x99,
                data: [1, 2, 3, 4, 5, 6, 7],
            },
            [0x99, 1, 2, 3, 4, 5, 6, 7],
        );
        req(
            Request::SwitchModeGlobal(Mode::Unknown(7)),
            [0x04, 7, 0, 0, 0, 0, 0, 0],
        );
    }

    #[test]
    fn every_response() {
        resp(Response::SwitchModeSelective, [0x44, 0, 0, 0, 0, 0, 0, 0]);
        resp(
            Response::StoreConfiguration(ConfigStatus {
                code: 2,
                extension: 0,
            }),
            [0x17, 2, 0, 0, 0, 0, 0, 0],
        );
        resp(
            Response::StoreConfiguration(ConfigStatus {
                code: 255,
                extension: 0x42,
            }),
            [0x17, 255, 0x42, 0, 0, 0, 0, 0],
        );
        resp(
            Response::InquireIdentity(AddressPart::Serial, 0x0A0B_0C0D),
            [0x5D, 0x0D, 0x0C, 0x0B, 0x0A, 0, 0, 0],
        );
        resp(
            Response::InquireNodeId(0x7F),
            [0x5E, 0x7F, 0, 0, 0, 0, 0, 0],
        );
        resp(Response::IdentifySlave, [0x4F, 0, 0, 0, 0, 0, 0, 0]);
        resp(
            Response::IdentifyNonConfiguredSlave,
            [0x50, 0, 0, 0, 0, 0, 0, 0],
        );
        resp(
            Response::Unknown {
                cs: 0x04,
                data: [9; 7],
            },
            [0x04, 9, 9, 9, 9, 9, 9, 9],
        );
    }

    #[test]
    fn status_codes_are_typed() {
        assert_eq!(ConfigStatus::OK.result(), Ok(()));
        assert_eq!(
            ConfigStatus {
                code: 1,
                extension: 9
            }
            .result(),
            Err(ResponseError::NotSupported)
        );
        assert_eq!(
            ConfigStatus {
                code: 2,
                extension: 0
            }
            .result(),
            Err(ResponseError::StorageMediaAccess)
        );
        assert_eq!(
            ConfigStatus {
                code: 255,
                extension: 0x33
            }
            .result(),
            Err(ResponseError::VendorSpecific(0x33))
        );
        assert_eq!(
            ConfigStatus {
                code: 7,
                extension: 1
            }
            .result(),
            Err(ResponseError::Reserved {
                code: 7,
                extension: 1
            })
        );
        for e in [
            ResponseError::NotSupported,
            ResponseError::StorageMediaAccess,
            ResponseError::VendorSpecific(4),
            ResponseError::Reserved {
                code: 9,
                extension: 1,
            },
        ] {
            assert_eq!(ConfigStatus::from_error(e).result(), Err(e));
        }
    }

    #[test]
    fn bad_frames_are_errors() {
        assert_eq!(Request::parse(&[0x04, 1]), Err(DecodeError::Length(2)));
        assert_eq!(Response::parse(&[]), Err(DecodeError::Length(0)));
        assert_eq!(Response::parse(&[0; 9]), Err(DecodeError::Length(9)));
        let f = Request::SwitchModeGlobal(Mode::Waiting).to_frame();
        assert_eq!(
            Response::from_frame(&f),
            Err(DecodeError::WrongCobId(0x7E5))
        );
        let rtr = CanFrame::remote(SLAVE_ID, 8).unwrap();
        assert_eq!(Response::from_frame(&rtr), Err(DecodeError::Remote));
        // Reserved bytes are ignored on decode.
        assert_eq!(
            Request::parse(&[0x17, 1, 2, 3, 4, 5, 6, 7]),
            Ok(Request::StoreConfiguration)
        );
    }

    #[test]
    fn messages_print_in_cia_vocabulary() {
        use std::string::ToString;
        let cases: [(Request, &str); 8] = [
            (
                Request::SwitchModeGlobal(Mode::Configuration),
                "LSS switch state global configuration",
            ),
            (
                Request::SwitchModeGlobal(Mode::Unknown(7)),
                "LSS switch state global reserved mode 7",
            ),
            (
                Request::Fastscan {
                    id_number: 0,
                    bit_check: 31,
                    lss_sub: 0,
                    lss_next: 0,
                },
                "LSS Fastscan id 0x00000000 bit 31 sub 0 next 0",
            ),
            (
                Request::Fastscan {
                    id_number: 0,
                    bit_check: 0x80,
                    lss_sub: 0,
                    lss_next: 0,
                },
                "LSS Fastscan id 0x00000000 bit 0x80 (confirm) sub 0 next 0",
            ),
            (
                Request::SwitchModeSelective(AddressPart::Serial, 0xCAFE),
                "LSS switch state selective serial number 0x0000cafe",
            ),
            (
                Request::ConfigureNodeId(0xFF),
                "LSS configure node-ID unconfigured (0xFF)",
            ),
            (
                Request::ConfigureBitTiming(BitRate::Kbit125.into()),
                "LSS configure bit timing 125 kbit/s",
            ),
            (
                Request::Unknown {
                    cs: 0x99,
                    data: [1, 2, 3, 4, 5, 6, 0xAB],
                },
                "LSS unknown cs 0x99: 01 02 03 04 05 06 AB",
            ),
        ];
        for (r, text) in cases {
            assert_eq!(r.to_string(), text);
        }
        let cases: [(Response, &str); 4] = [
            (
                Response::StoreConfiguration(ConfigStatus {
                    code: 1,
                    extension: 0,
                }),
                "LSS store configuration response: error: not supported or invalid (error code 1)",
            ),
            (
                Response::ConfigureNodeId(ConfigStatus::OK),
                "LSS configure node-ID response: success",
            ),
            (
                Response::InquireIdentity(AddressPart::Vendor, 0x78),
                "LSS inquire identity vendor-ID response 0x00000078",
            ),
            (Response::IdentifySlave, "LSS identify slave"),
        ];
        for (r, text) in cases {
            assert_eq!(r.to_string(), text);
        }
    }

    proptest! {
        /// Every request and response prints without Rust debug syntax.
        #[test]
        fn display_never_shows_debug(bytes in any::<[u8; 8]>()) {
            use std::string::ToString;
            for text in [
                Request::parse(&bytes).unwrap().to_string(),
                Response::parse(&bytes).unwrap().to_string(),
            ] {
                prop_assert!(text.starts_with("LSS "));
                for debug in ["{", "}", "::", "Some(", "Unknown", "Fastscan {", "_id"] {
                    prop_assert!(!text.contains(debug), "{text}");
                }
            }
        }
    }

    fn any_part() -> impl Strategy<Value = AddressPart> {
        (0u8..4).prop_map(|i| AddressPart::from_index(i).unwrap())
    }

    fn any_status() -> impl Strategy<Value = ConfigStatus> {
        (any::<u8>(), any::<u8>()).prop_map(|(code, extension)| ConfigStatus { code, extension })
    }

    fn any_request() -> impl Strategy<Value = Request> {
        prop_oneof![
            any::<u8>().prop_map(|m| Request::SwitchModeGlobal(Mode::from_raw(m))),
            (any_part(), any::<u32>()).prop_map(|(p, v)| Request::SwitchModeSelective(p, v)),
            any::<u8>().prop_map(Request::ConfigureNodeId),
            (any::<u8>(), any::<u8>())
                .prop_map(|(table, index)| Request::ConfigureBitTiming(BitTiming { table, index })),
            any::<u16>().prop_map(|delay_ms| Request::ActivateBitTiming { delay_ms }),
            Just(Request::StoreConfiguration),
            any_part().prop_map(Request::InquireIdentity),
            Just(Request::InquireNodeId),
            (0usize..6, any::<u32>())
                .prop_map(|(f, v)| Request::IdentifyRemoteSlave(IdentifyField::ALL[f], v)),
            Just(Request::IdentifyNonConfigured),
            (any::<u32>(), any::<u8>(), any::<u8>(), any::<u8>()).prop_map(|(i, b, s, n)| {
                Request::Fastscan {
                    id_number: i,
                    bit_check: b,
                    lss_sub: s,
                    lss_next: n,
                }
            }),
        ]
    }

    fn any_response() -> impl Strategy<Value = Response> {
        prop_oneof![
            Just(Response::SwitchModeSelective),
            any_status().prop_map(Response::ConfigureNodeId),
            any_status().prop_map(Response::ConfigureBitTiming),
            any_status().prop_map(Response::StoreConfiguration),
            (any_part(), any::<u32>()).prop_map(|(p, v)| Response::InquireIdentity(p, v)),
            any::<u8>().prop_map(Response::InquireNodeId),
            Just(Response::IdentifySlave),
            Just(Response::IdentifyNonConfiguredSlave),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn request_round_trip(r in any_request()) {
            prop_assert_eq!(Request::parse(&r.emit()), Ok(r));
        }

        #[test]
        fn response_round_trip(r in any_response()) {
            prop_assert_eq!(Response::parse(&r.emit()), Ok(r));
        }

        /// Any eight bytes decode; the re-encoding decodes to the same value (unknown command
        /// specifiers keep all bytes).
        #[test]
        fn any_bytes_decode(bytes in any::<[u8; 8]>()) {
            let r = Request::parse(&bytes).unwrap();
            prop_assert_eq!(Request::parse(&r.emit()), Ok(r));
            if let Request::Unknown { .. } = r {
                prop_assert_eq!(r.emit(), bytes);
            }
            let s = Response::parse(&bytes).unwrap();
            prop_assert_eq!(Response::parse(&s.emit()), Ok(s));
            if let Response::Unknown { .. } = s {
                prop_assert_eq!(s.emit(), bytes);
            }
        }
    }
}
