//! CIP general status codes (CIP volume 1, appendix B "Status Codes"), the first byte of an
//! Error Response (service 0x14, 0x94 on the wire) and the status of every CIP reply.
//!
//! [`GeneralStatus`] is an open enum: a code the table does not name is kept as
//! [`GeneralStatus::Unknown`], so decoding and encoding round-trip losslessly and an unknown
//! code still prints.

use core::fmt;

macro_rules! general_status {
    ($($(#[$doc:meta])* $name:ident = $code:literal, $text:literal;)*) => {
        /// A CIP general status code.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum GeneralStatus {
            $($(#[$doc])* $name,)*
            /// A code this table does not name.
            Unknown(u8),
        }

        impl GeneralStatus {
            /// The status of a wire byte.
            pub const fn from_u8(code: u8) -> Self {
                match code {
                    $($code => GeneralStatus::$name,)*
                    other => GeneralStatus::Unknown(other),
                }
            }

            /// The wire byte.
            pub const fn to_u8(self) -> u8 {
                match self {
                    $(GeneralStatus::$name => $code,)*
                    GeneralStatus::Unknown(c) => c,
                }
            }

            /// What the specification calls it, if the table names it.
            pub const fn meaning(self) -> Option<&'static str> {
                match self.to_u8() {
                    $($code => Some($text),)*
                    _ => None,
                }
            }
        }
    };
}

general_status! {
    /// 0x00: the service was performed.
    Success = 0x00, "success";
    /// 0x01: a connection-related service failed.
    ConnectionFailure = 0x01, "connection failure";
    /// 0x02: a resource needed for the service is unavailable.
    ResourceUnavailable = 0x02, "resource unavailable";
    /// 0x03: a parameter of the request is invalid.
    InvalidParameterValue = 0x03, "invalid parameter value";
    /// 0x04: the path could not be parsed.
    PathSegmentError = 0x04, "path segment error";
    /// 0x05: the path names an unknown class, instance or structure.
    PathDestinationUnknown = 0x05, "path destination unknown";
    /// 0x06: only part of the expected data was transferred.
    PartialTransfer = 0x06, "partial transfer";
    /// 0x07: the messaging connection was lost.
    ConnectionLost = 0x07, "connection lost";
    /// 0x08: the service is not supported by the object.
    ServiceNotSupported = 0x08, "service not supported";
    /// 0x09: invalid attribute data.
    InvalidAttributeValue = 0x09, "invalid attribute value";
    /// 0x0A: an attribute in a list has a non-zero status.
    AttributeListError = 0x0A, "attribute list error";
    /// 0x0B: the object is already in the requested mode or state.
    AlreadyInRequestedState = 0x0B, "already in requested mode/state";
    /// 0x0C: the object cannot perform the service in its current state.
    ObjectStateConflict = 0x0C, "object state conflict";
    /// 0x0D: the object to be created already exists.
    ObjectAlreadyExists = 0x0D, "object already exists";
    /// 0x0E: the attribute cannot be set.
    AttributeNotSettable = 0x0E, "attribute not settable";
    /// 0x0F: a permission or privilege check failed.
    PrivilegeViolation = 0x0F, "privilege violation";
    /// 0x10: the device's mode or state forbids the service.
    DeviceStateConflict = 0x10, "device state conflict";
    /// 0x11: the reply is larger than the response buffer.
    ReplyDataTooLarge = 0x11, "reply data too large";
    /// 0x12: the service would fragment a primitive value.
    FragmentationOfPrimitive = 0x12, "fragmentation of a primitive value";
    /// 0x13: the request carries too little data.
    NotEnoughData = 0x13, "not enough data";
    /// 0x14: the attribute is not supported.
    AttributeNotSupported = 0x14, "attribute not supported";
    /// 0x15: the request carries too much data.
    TooMuchData = 0x15, "too much data";
    /// 0x16: the object does not exist.
    ObjectDoesNotExist = 0x16, "object does not exist";
    /// 0x17: no fragmentation sequence is in progress.
    FragmentationNotInProgress = 0x17, "service fragmentation sequence not in progress";
    /// 0x18: no stored attribute data.
    NoStoredAttributeData = 0x18, "no stored attribute data";
    /// 0x19: storing the data failed.
    StoreOperationFailure = 0x19, "store operation failure";
    /// 0x1A: the request was too large to route.
    RequestTooLarge = 0x1A, "routing failure, request packet too large";
    /// 0x1B: the response was too large to route.
    ResponseTooLarge = 0x1B, "routing failure, response packet too large";
    /// 0x1C: an attribute list entry lacks data.
    MissingAttributeListData = 0x1C, "missing attribute list entry data";
    /// 0x1D: an attribute value list is invalid.
    InvalidAttributeValueList = 0x1D, "invalid attribute value list";
    /// 0x1E: an embedded service failed.
    EmbeddedServiceError = 0x1E, "embedded service error";
    /// 0x1F: a vendor-specific error (see the additional code).
    VendorSpecific = 0x1F, "vendor specific error";
    /// 0x20: a parameter of the request is invalid.
    InvalidParameter = 0x20, "invalid parameter";
    /// 0x21: a write-once value was already written.
    WriteOnceWritten = 0x21, "write-once value or medium already written";
    /// 0x22: an invalid reply was received.
    InvalidReply = 0x22, "invalid reply received";
    /// 0x25: the key segment of the path does not match.
    KeyFailureInPath = 0x25, "key failure in path";
    /// 0x26: the path size is invalid.
    PathSizeInvalid = 0x26, "path size invalid";
    /// 0x27: an attribute in the list was not expected.
    UnexpectedAttributeInList = 0x27, "unexpected attribute in list";
    /// 0x28: the member ID does not exist.
    InvalidMemberId = 0x28, "invalid member ID";
    /// 0x29: the member cannot be set.
    MemberNotSettable = 0x29, "member not settable";
    /// 0x2A: a group 2 only server could not perform the service.
    Group2OnlyServerFailure = 0x2A, "group 2 only server general failure";
}

impl fmt::Display for GeneralStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.meaning() {
            Some(m) => write!(f, "CIP status 0x{:02X} ({m})", self.to_u8()),
            None => write!(f, "CIP status 0x{:02X}", self.to_u8()),
        }
    }
}

/// The status a device returned in an Error Response: general code and additional code (0xFF
/// when the device gives none).
#[derive(Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("{general}, additional code 0x{additional:02X}")]
pub struct CipError {
    /// General status.
    pub general: GeneralStatus,
    /// Additional code (0xFF = none).
    pub additional: u8,
}

debug_as_display!(CipError);

impl CipError {
    /// An error without an additional code.
    pub const fn new(general: GeneralStatus) -> Self {
        Self {
            general,
            additional: 0xFF,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_round_trips_and_prints() {
        for b in 0..=255u8 {
            let s = GeneralStatus::from_u8(b);
            assert_eq!(s.to_u8(), b);
            let mut buf = heapless::String::<80>::new();
            core::fmt::write(&mut buf, format_args!("{s}")).unwrap();
            assert!(buf.starts_with("CIP status 0x"));
        }
        assert_eq!(
            GeneralStatus::from_u8(0x16),
            GeneralStatus::ObjectDoesNotExist
        );
        assert_eq!(GeneralStatus::from_u8(0x23), GeneralStatus::Unknown(0x23));
        assert_eq!(
            GeneralStatus::AttributeNotSupported.meaning(),
            Some("attribute not supported")
        );
    }
}
