//! Errors of the LSS master machines: what the slave said no with ([`ResponseError`], the peer's
//! answer) is kept apart from local failures (timeouts, a busy machine, a scan that lost its
//! device, a full buffer).

use core::fmt;

use canola_frame::Duration;

use crate::address::AddressPart;
use crate::wire::ResponseError;

/// The LSS service a master machine was performing when it failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Service {
    /// Switch mode selective (waiting for 0x44).
    SwitchModeSelective,
    /// Configure node-ID.
    ConfigureNodeId,
    /// Configure bit timing parameters.
    ConfigureBitTiming,
    /// Store configuration.
    StoreConfiguration,
    /// Inquire identity (one part).
    InquireIdentity(AddressPart),
    /// Inquire node-ID.
    InquireNodeId,
    /// Identify remote slave.
    IdentifyRemoteSlave,
    /// Identify non-configured remote slave.
    IdentifyNonConfigured,
    /// LSS Fastscan.
    Fastscan,
}

impl fmt::Display for Service {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::SwitchModeSelective => f.write_str("switch mode selective"),
            Self::ConfigureNodeId => f.write_str("configure node-ID"),
            Self::ConfigureBitTiming => f.write_str("configure bit timing"),
            Self::StoreConfiguration => f.write_str("store configuration"),
            Self::InquireIdentity(part) => write!(f, "inquire {part}"),
            Self::InquireNodeId => f.write_str("inquire node-ID"),
            Self::IdentifyRemoteSlave => f.write_str("identify remote slave"),
            Self::IdentifyNonConfigured => f.write_str("identify non-configured remote slave"),
            Self::Fastscan => f.write_str("LSS Fastscan"),
        }
    }
}

/// Why an LSS master operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LssError {
    /// The slave answered with an error code (the peer said no).
    #[error("the LSS slave rejected {service}: {error}")]
    Rejected {
        /// The service.
        service: Service,
        /// The slave's error.
        error: ResponseError,
    },
    /// No answer within the response timeout (local failure).
    #[error("no LSS answer to {service} within {timeout}")]
    Timeout {
        /// The service.
        service: Service,
        /// The timeout that elapsed.
        timeout: Duration,
    },
    /// A command was given while the machine was still running another one.
    #[error("the LSS master machine is busy")]
    Busy,
    /// Fastscan determined every bit of `part` but no slave confirmed the value: a slave left
    /// the bus or changed state during the scan.
    #[error("LSS Fastscan lost the slave while confirming its {part}")]
    FastscanLost {
        /// The address part whose confirmation failed.
        part: AddressPart,
    },
    /// Several slaves are in configuration state where exactly one must be: configure node-ID
    /// after switch mode global would give each the same node-ID. Two answers came to one
    /// inquiry: `first` and `second` (equal when the slaves share that part; a real bus may
    /// merge equal answers into one frame, which is why every part is inquired). The slaves
    /// were switched back to waiting state.
    #[error(
        "several LSS slaves are in configuration state (inquire {part} was answered with \
         {first:#010X} and {second:#010X}): one node-ID would go to each of them"
    )]
    SeveralSlaves {
        /// The address part whose inquiry was answered twice.
        part: AddressPart,
        /// The first answer.
        first: u32,
        /// The second answer.
        second: u32,
    },
    /// The workflow's node-ID pool had no free node-ID left for a found slave.
    #[error("no free node-ID left for the slave")]
    NoFreeNodeId,
    /// The node-ID is in use on the bus (a node with it was found by a scan, or its boot-up or
    /// heartbeat was heard): it is not given to another slave.
    #[error("node-ID {0} is in use on the bus")]
    NodeIdInUse(u8),
    /// More results than the fixed-size result list holds (no allocator in the core).
    #[error("more than {0} results; the list is full")]
    TooMany(usize),
    /// A configuration value the caller gave is not valid (duplicate node-ID in the table,
    /// an empty range, a procedure with too many steps).
    #[error("invalid LSS master configuration: {0}")]
    InvalidConfig(&'static str),
}
