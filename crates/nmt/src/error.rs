//! Error types. Decoding errors (bad bytes from the bus) are kept apart from local configuration
//! and capacity errors.

/// Why bytes from the bus are not a valid message of the expected service.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// The data length does not fit the message.
    #[error("{message}: unexpected data length {actual}")]
    Length {
        /// Which message was being decoded.
        message: &'static str,
        /// The data length found.
        actual: usize,
    },
    /// A remote frame where a data frame was expected.
    #[error("{message}: unexpected remote frame")]
    UnexpectedRemote {
        /// Which message was being decoded.
        message: &'static str,
    },
    /// The frame's identifier does not belong to this service (or is a 29-bit identifier).
    #[error("COB-ID {0:#x} does not belong to this service")]
    WrongCobId(u32),
}

debug_as_display!(DecodeError);

/// A bounded table (monitored nodes, queued messages) is full.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("table is full (capacity {capacity})")]
pub struct CapacityError {
    /// The table's capacity.
    pub capacity: usize,
}

debug_as_display!(CapacityError);

/// A configuration value (from an object dictionary entry) that CiA 301 does not allow.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// 0x1019 synchronous counter overflow value 1 or 241..=255 (reserved by CiA 301).
    #[error("synchronous counter overflow value {0} is reserved (allowed: 0 or 2..=240)")]
    ReservedSyncOverflow(u8),
    /// A COB-ID object with the 29-bit frame bit set; this stack sends 11-bit identifiers only.
    #[error("COB-ID {0:#x} selects a 29-bit identifier, which is not supported")]
    ExtendedCobId(u32),
    /// Milliseconds after midnight do not fit the 28-bit field of TIME_OF_DAY.
    #[error("{0} ms does not fit the 28-bit milliseconds field")]
    MillisOutOfRange(u32),
}

debug_as_display!(ConfigError);
