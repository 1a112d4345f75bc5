//! What the master reports ([`MasterEvent`]) and how its work can fail.

use crate::fragment::MessageBuf;
use crate::identity::{AttributeError, DuplicateMacCheck, Identity};
use crate::status::CipError;

/// Why a connect attempt failed.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ConnectError {
    /// The slave refused a step.
    #[error("{step}: the slave answered {error}")]
    Refused {
        /// The step.
        step: &'static str,
        /// Its status.
        error: CipError,
    },
    /// No answer.
    #[error("{step}: no answer from the slave")]
    Timeout {
        /// The step.
        step: &'static str,
    },
    /// An answer that does not fit the step.
    #[error("{step}: malformed answer")]
    Malformed {
        /// The step.
        step: &'static str,
    },
    /// The slave announced a message body format other than 8/8 (1 = 8/16, 2 = 16/16,
    /// 3 = 16/8; 0xFF = none given).
    #[error("the slave uses message body format {0}; only 8/8 (0) is supported")]
    UnsupportedBodyFormat(u8),
    /// Identity data that does not decode.
    #[error("identity: {0}")]
    Identity(AttributeError),
}

debug_as_display!(ConnectError);

/// How an application's explicit request ended.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ExplicitFailure {
    /// The slave answered with an Error Response.
    #[error("{0}")]
    Refused(CipError),
    /// No answer within the response timeout.
    #[error("no answer within the response timeout")]
    Timeout,
    /// The connection is not (or no longer) established.
    #[error("not connected")]
    NotConnected,
}

debug_as_display!(ExplicitFailure);

/// A local refusal of [`Master::get_attribute`](super::Master::get_attribute) /
/// [`Master::set_attribute`](super::Master::set_attribute).
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MasterError {
    /// Not connected.
    #[error("not connected to the slave")]
    NotConnected,
    /// The request queue is full.
    #[error("explicit request queue is full")]
    QueueFull,
    /// The data does not fit a message.
    #[error("request data too long")]
    TooLong,
}

debug_as_display!(MasterError);

/// Handle of an application's explicit request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Handle(pub u32);

/// What the master reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MasterEvent {
    /// The Duplicate MAC ID check passed.
    Online,
    /// Another station uses the master's MAC ID.
    DuplicateMac(DuplicateMacCheck),
    /// The connection set is allocated and the poll connection established.
    Connected {
        /// The slave's Identity object.
        identity: Identity,
        /// Poll response size (the slave's produced connection size).
        produced_size: u16,
        /// Poll command size (the slave's consumed connection size).
        consumed_size: u16,
    },
    /// A connect attempt failed; the master tries again after the reconnect delay.
    ConnectFailed(ConnectError),
    /// A complete poll response.
    Input(MessageBuf),
    /// The connection was lost; the master tries again after the reconnect delay.
    ConnectionLost,
    /// An application's explicit request ended.
    ExplicitDone {
        /// The request.
        handle: Handle,
        /// Response data, or why not.
        result: Result<MessageBuf, ExplicitFailure>,
    },
}
