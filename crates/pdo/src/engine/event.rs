//! What the engine reports: the events a drain of [`Engine::poll_event`](super::Engine::poll_event)
//! returns, and why a configuration call was refused.

use canola_frame::Instant;

use super::{RpdoId, TpdoId};
use crate::comm::CommError;
use crate::dictionary::{ObjectAddress, StoreError};

/// Either kind of PDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PdoRef {
    /// A receive PDO.
    Rx(RpdoId),
    /// A transmit PDO.
    Tx(TpdoId),
}

/// What happened, for the owner to act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Event {
    /// A receive PDO took effect: its values are in the store and in [`Engine::received`](super::Engine::received).
    /// Bit `i` of `changed` is set when mapped object `i` differs from the previous reception
    /// (all bits on the first one).
    Received {
        /// Which PDO.
        pdo: RpdoId,
        /// Changed mapped objects, bit `i` for object `i`.
        changed: u64,
    },
    /// A receive PDO did not arrive within its event time after the previous one.
    Timeout {
        /// Which PDO.
        pdo: RpdoId,
        /// When the deadline passed.
        deadline: Instant,
    },
    /// A receive PDO with fewer data bytes than mapped; not processed (EMCY 0x8210).
    LengthError {
        /// Which PDO.
        pdo: RpdoId,
        /// Bytes the mapping needs.
        expected: u8,
        /// Bytes received.
        actual: u8,
    },
    /// A receive PDO with more data bytes than mapped; processed from its first bytes
    /// (EMCY 0x8220).
    LengthExceeded {
        /// Which PDO.
        pdo: RpdoId,
        /// Bytes the mapping needs.
        expected: u8,
        /// Bytes received.
        actual: u8,
    },
    /// The store refused to read (transmit PDO: not sent) or write (receive PDO: the other
    /// objects were written) a mapped object.
    StoreFailed {
        /// Which PDO.
        pdo: PdoRef,
        /// The object.
        addr: ObjectAddress,
        /// The store's reason.
        error: StoreError,
    },
}

impl Event {
    /// The CiA 301 emergency error code a device reports for this event, if any:
    /// 0x8210 "PDO not processed due to length error", 0x8220 "PDO length exceeded".
    pub const fn emcy_code(&self) -> Option<u16> {
        match self {
            Self::LengthError { .. } => Some(0x8210),
            Self::LengthExceeded { .. } => Some(0x8220),
            _ => None,
        }
    }
}

/// Why the engine refused a configuration call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum EngineError {
    /// The communication parameters cannot be used.
    #[error(transparent)]
    Comm(#[from] CommError),
    /// The engine's table for this direction is full.
    #[error("the engine holds no more PDOs of this direction")]
    Full,
    /// No such PDO in this engine.
    #[error("no such PDO")]
    UnknownPdo,
    /// The PDO's COB-ID is marked invalid (bit 31): it does not exist on the bus.
    #[error("the PDO's COB-ID is not valid")]
    NotValid,
}
