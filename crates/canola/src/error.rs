//! The master's errors: which node, which object (with its dictionary name when known), and
//! what went wrong — the server's abort code with its CiA 301 meaning kept apart from local
//! failures (timeout, cancel, I/O).

use canola_frame::{Duration, NodeId};
use canola_nmt::NmtState;
use canola_sdo::{AbortCode, ErrorKind};

use crate::transport::TransportError;
use canola_od::ObjectAddress;

mod value;
pub use value::{MappedUnfit, PdoProblem, Unfit, ValueProblem};

/// What ended an SDO request unsuccessfully.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum SdoErrorKind {
    /// The SDO client reported a failure: the server's abort, a timeout, a protocol violation.
    Transfer(ErrorKind),
    /// The request was cancelled before it finished.
    Cancelled,
    /// The node's client refused to start (should not happen: requests queue).
    Busy,
    /// Writing an upload into the caller's writer (or flushing it) failed.
    Io {
        /// The kind of the writer's I/O error.
        kind: std::io::ErrorKind,
        /// Its words (with what was being done, e.g. flushing the output).
        message: String,
    },
    /// The transport failed while the request ran.
    Transport(TransportFailure),
    /// The node sent a boot-up message (it was reset or power-cycled) while the transfer ran:
    /// its SDO server forgot the transfer. A transfer the server had answered ends at once; one
    /// not answered yet ends when its response timeout passes without an answer. No abort is
    /// sent. Nothing of a download is known to be stored; the next request goes to the
    /// rebooted node.
    NodeRebooted,
    /// The USDO client (CANopen FD) reported a failure: the server's 1-byte abort code, a
    /// timeout, a protocol violation ([`SdoError::server_abort`] gives the CiA 301 code of a
    /// server abort).
    Usdo(canola_sdo::usdo::UsdoErrorKind),
    /// A USDO request needs CAN FD that is not there. Nothing was sent.
    FdNotSupported(FdRefusal),
}

/// Why a USDO request was refused before anything was sent ([`SdoErrorKind::FdNotSupported`]).
#[derive(Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum FdRefusal {
    /// The bus carries classic frames only.
    ClassicBus {
        /// The bus and why it is classic-only (the transport's words).
        bus: String,
    },
    /// The node is not marked CANopen FD (its EDS has no `CANopenFD=1`, and the application
    /// did not mark it).
    NodeNotFd,
}

impl core::fmt::Display for FdRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ClassicBus { bus } => write!(f, "FD not supported on {bus}"),
            Self::NodeNotFd => f.write_str(
                "the node is not marked CANopen FD (its EDS has no CANopenFD=1; the \
                 application can mark it)",
            ),
        }
    }
}

impl core::fmt::Debug for FdRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// How the transport failed under an SDO request: a [`TransportError`] as a value that can be
/// cloned and compared, as [`SdoError`] is (an operating-system error keeps its kind and its
/// words).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TransportFailure {
    /// The interface is down (or the bus was closed).
    #[error("the CAN interface is down")]
    InterfaceDown,
    /// The controller is bus-off and cannot send.
    #[error("the CAN controller is bus-off")]
    BusOff,
    /// The transmit queue is full.
    #[error("the transmit queue is full")]
    TxQueueFull,
    /// The transport is closed for good.
    #[error("the transport is closed")]
    Closed,
    /// A CAN FD frame was to go on a bus that carries classic frames only.
    #[error("FD not supported on {bus}")]
    FdNotSupported {
        /// The bus and why it is classic-only.
        bus: String,
    },
    /// An operating-system or other local error.
    #[error("CAN I/O error: {message}")]
    Io {
        /// The kind of the operating-system error.
        kind: std::io::ErrorKind,
        /// Its words.
        message: String,
    },
}

impl TransportFailure {
    /// The kind of the operating-system error, for an [`Io`](Self::Io) failure.
    pub fn io_kind(&self) -> Option<std::io::ErrorKind> {
        match self {
            Self::Io { kind, .. } => Some(*kind),
            _ => None,
        }
    }
}

impl From<&TransportError> for TransportFailure {
    fn from(e: &TransportError) -> Self {
        match e {
            TransportError::InterfaceDown => Self::InterfaceDown,
            TransportError::BusOff => Self::BusOff,
            TransportError::TxQueueFull => Self::TxQueueFull,
            TransportError::Closed => Self::Closed,
            TransportError::FdNotSupported { bus } => Self::FdNotSupported { bus: bus.clone() },
            TransportError::Io(io) => Self::Io {
                kind: io.kind(),
                message: io.to_string(),
            },
        }
    }
}

impl From<&Error> for TransportFailure {
    /// The failure that ends the requests in flight when a driving step fails: the transport's
    /// own (the only kind a step returns), or any other local error by its words.
    fn from(e: &Error) -> Self {
        match e {
            Error::Transport(t) => t.into(),
            other => Self::Io {
                kind: std::io::ErrorKind::Other,
                message: other.to_string(),
            },
        }
    }
}

/// An SDO request failed. Its `Debug` prints what its `Display` says, so an error that ends
/// `main` or an `unwrap` reads as a sentence (abort codes as `0x06020000 (Object does not
/// exist in the object dictionary)`).
#[derive(Clone, PartialEq, Eq)]
pub struct SdoError {
    /// The node.
    pub node: NodeId,
    /// The object.
    pub entry: ObjectAddress,
    /// The object's name from the node's dictionary, if it has one.
    pub name: Option<String>,
    /// What went wrong.
    pub kind: SdoErrorKind,
}

impl SdoError {
    /// The abort code the server sent, when the server refused.
    /// A USDO server's 1-byte code comes as the CiA 301 code it stands for (0x33 as
    /// 0x06020000); one without a CiA 301 meaning as 0x08000000 (general error).
    pub fn server_abort(&self) -> Option<AbortCode> {
        match self.kind {
            SdoErrorKind::Transfer(ErrorKind::ServerAbort(code)) => Some(code),
            SdoErrorKind::Usdo(canola_sdo::usdo::UsdoErrorKind::ServerAbort(code)) => {
                Some(usdo_to_cia301(code))
            }
            _ => None,
        }
    }

    /// The abort code that went over the bus in either direction, if any (a USDO code as its
    /// CiA 301 code, see [`server_abort`](Self::server_abort)).
    pub fn abort_code(&self) -> Option<AbortCode> {
        match self.kind {
            SdoErrorKind::Transfer(k) => Some(k.abort_code()),
            SdoErrorKind::Usdo(k) => Some(usdo_to_cia301(k.abort_code())),
            _ => None,
        }
    }

    /// The 1-byte USDO abort code that went over the bus, for a USDO request.
    pub fn usdo_abort_code(&self) -> Option<canola_sdo::usdo::UsdoAbortCode> {
        match self.kind {
            SdoErrorKind::Usdo(k) => Some(k.abort_code()),
            _ => None,
        }
    }
}

impl core::fmt::Display for SdoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        // The address as every message writes one: `0x1018:01`.
        write!(f, "node {}, object {}", self.node, self.entry)?;
        if let Some(name) = &self.name {
            write!(f, " \"{name}\"")?;
        }
        f.write_str(": ")?;
        match &self.kind {
            SdoErrorKind::Transfer(ErrorKind::ServerAbort(code)) => {
                write!(f, "SDO abort {code}")
            }
            SdoErrorKind::Transfer(ErrorKind::Timeout) => {
                f.write_str("no response from the node (SDO timeout; sent abort 0x05040000)")
            }
            SdoErrorKind::Transfer(k) => write!(f, "{k}"),
            SdoErrorKind::Cancelled => f.write_str("request cancelled"),
            SdoErrorKind::Busy => f.write_str("the node's SDO client is busy"),
            SdoErrorKind::Io { message, .. } => write!(f, "local I/O error: {message}"),
            SdoErrorKind::Transport(e) => write!(f, "transport failed: {e}"),
            SdoErrorKind::NodeRebooted => write!(
                f,
                "node {} rebooted (boot-up message received) during the transfer; the \
                 transfer ended without an abort, the device has forgotten it",
                self.node
            ),
            SdoErrorKind::Usdo(canola_sdo::usdo::UsdoErrorKind::ServerAbort(code)) => {
                write!(f, "USDO abort {code}")
            }
            SdoErrorKind::Usdo(k) => write!(f, "USDO: {k}"),
            SdoErrorKind::FdNotSupported(FdRefusal::NodeNotFd) => write!(
                f,
                "node {} is not marked CANopen FD (its EDS has no CANopenFD=1; the application \
                 can mark it)",
                self.node
            ),
            SdoErrorKind::FdNotSupported(why) => write!(f, "{why}"),
        }
    }
}

/// The CiA 301 code a 1-byte USDO code stands for; general error (0x08000000) without one.
fn usdo_to_cia301(code: canola_sdo::usdo::UsdoAbortCode) -> AbortCode {
    code.to_cia301().unwrap_or(AbortCode(0x0800_0000))
}

impl core::fmt::Debug for SdoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for SdoError {}

/// Errors of the master API. `Debug` prints what `Display` says (see [`SdoError`]), so
/// `fn main() -> Result<(), Box<dyn std::error::Error>>` reports a readable message.
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An SDO request failed.
    #[error("{0}")]
    Sdo(#[from] SdoError),
    /// The transport failed.
    #[error("transport: {0}")]
    Transport(#[from] TransportError),
    /// The bus could not be opened ([`Network::open`](crate::Network::open)): the message
    /// names the bus and may carry a hint on a second line.
    #[error("{0}")]
    Open(#[from] crate::transport::OpenError),
    /// A value did not match the object's type, or could not be converted; or a PDO's
    /// parameters or mapping cannot be used as asked.
    #[error("node {node}, object {entry}: {problem}")]
    Value {
        /// The node.
        node: NodeId,
        /// The object.
        entry: ObjectAddress,
        /// What is wrong, for a program to match on.
        problem: ValueProblem,
    },
    /// What was awaited did not happen within the time allowed (for services without their
    /// own timeout).
    #[error("timed out after {after} waiting for {awaited}")]
    Timeout {
        /// What was awaited.
        awaited: Awaited,
        /// The time allowed, on the network's clock.
        after: Duration,
    },
    /// An LSS service failed (CiA 305).
    #[error("LSS: {0}")]
    Lss(canola_lss::LssError),
    /// A local I/O error (file, writer, reader).
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
    /// A name the node's dictionary does not resolve to one value.
    #[error("node {node}, object \"{name}\": {reason}")]
    UnknownObject {
        /// The node.
        node: NodeId,
        /// The name asked for (for a write by address to a node without a dictionary, the
        /// address).
        name: String,
        /// Why it does not resolve.
        reason: Unresolved,
    },
    /// The master refused to configure a COB-ID entry with a CAN identifier CiA 301
    /// restricts (see [`restricted_cob_id`](crate::restricted_cob_id)): nothing was written.
    #[error(
        "node {node}, object {entry}: COB-ID 0x{can_id:03X} is a CAN identifier CiA 301 \
         restricts (0x000, 0x001..0x07F, 0x101..0x180, 0x581..0x5FF, 0x601..0x67F, \
         0x6E0..0x6FF, 0x701..0x77F, 0x780..0x7FF): not configured"
    )]
    RestrictedCobId {
        /// The node.
        node: NodeId,
        /// The COB-ID entry.
        entry: ObjectAddress,
        /// The restricted 11-bit identifier.
        can_id: u16,
    },
    /// A request the API cannot serve as asked.
    #[error("{0}")]
    InvalidRequest(Misuse),
    /// The background driver ended because the transport failed.
    #[error("the network's driver stopped{}: {failure}", on_bus(bus))]
    Driver {
        /// The bus, when the network was opened by name ([`Network::open`](crate::Network::open)).
        bus: Option<String>,
        /// How the transport failed.
        failure: TransportFailure,
    },
    /// A task of the async API ended before its work was done (it panicked, or its runtime
    /// shut down).
    #[error("a task of the async API ended before its work was done")]
    TaskEnded,
}

/// `" on BUS"` when the bus is known.
pub(crate) fn on_bus(bus: &Option<String>) -> String {
    bus.as_ref()
        .map_or_else(String::new, |b| format!(" on {b}"))
}

/// What a wait that timed out waited for ([`Error::Timeout`]).
#[derive(Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Awaited {
    /// A boot-up message of the node.
    BootUp {
        /// The node.
        node: NodeId,
    },
    /// The node reporting an NMT state.
    State {
        /// The node.
        node: NodeId,
        /// The state awaited.
        state: NmtState,
    },
}

impl core::fmt::Display for Awaited {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BootUp { node } => write!(f, "a boot-up from node {node}"),
            Self::State { node, state } => write!(f, "node {node} to report {state}"),
        }
    }
}

impl core::fmt::Debug for Awaited {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// Why a name does not resolve in a node's dictionary ([`Error::UnknownObject`]).
#[derive(Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Unresolved {
    /// The node was added without a dictionary
    /// ([`Network::add_node_with_dictionary`](crate::Network::add_node_with_dictionary)).
    NoDictionary,
    /// The dictionary has no object of that name.
    NotFound,
    /// The name is an array or record: a sub-object has to be named.
    NotOneValue,
}

impl core::fmt::Display for Unresolved {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NoDictionary => {
                "the node was added without a dictionary (Network::add_node_with_dictionary)"
            }
            Self::NotFound => "no such object in the node's dictionary",
            Self::NotOneValue => {
                "it is an array or record: name a sub-object as \"object.sub-object\""
            }
        })
    }
}

impl core::fmt::Debug for Unresolved {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// A call the API cannot serve as asked ([`Error::InvalidRequest`]).
#[derive(Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Misuse {
    /// A node's state asked of the NMT handle of all nodes ([`Nmt::all`](crate::Nmt::all)).
    StateOfAll,
    /// An RPDO written or triggered that is not being transmitted (never started, or
    /// stopped).
    RpdoNotTransmitted {
        /// The node.
        node: NodeId,
        /// The RPDO number (1-based).
        rpdo: u16,
    },
    /// A set of PDO parameters saved as the other direction's (TPDOs as RPDOs).
    PdoDirection {
        /// The direction the set was read as.
        set: canola_pdo::Direction,
        /// The direction it was to be saved as.
        saved_as: canola_pdo::Direction,
    },
    /// PDO parameters read from one node saved to another.
    PdoOfOtherNode {
        /// The node they were read from.
        read_from: NodeId,
        /// The node they were to be saved to.
        saved_to: NodeId,
    },
}

fn pdo_kind(d: canola_pdo::Direction) -> &'static str {
    match d {
        canola_pdo::Direction::Transmit => "TPDO",
        canola_pdo::Direction::Receive => "RPDO",
    }
}

impl core::fmt::Display for Misuse {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::StateOfAll => {
                f.write_str("node states are per node: use node.nmt(), not Nmt::all")
            }
            Self::RpdoNotTransmitted { node, rpdo } => {
                write!(f, "node {node}: RPDO{rpdo} is not being transmitted")
            }
            Self::PdoDirection { set, saved_as } => write!(
                f,
                "a set of {}s cannot be saved as {}s",
                pdo_kind(*set),
                pdo_kind(*saved_as)
            ),
            Self::PdoOfOtherNode {
                read_from,
                saved_to,
            } => write!(
                f,
                "these PDO parameters were read from node {read_from}, not node {saved_to}"
            ),
        }
    }
}

impl core::fmt::Debug for Misuse {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

impl core::fmt::Debug for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

impl Error {
    /// The SDO abort code the server sent, if this is a server abort.
    pub fn server_abort(&self) -> Option<AbortCode> {
        match self {
            Self::Sdo(e) => e.server_abort(),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn debug_prints_what_display_says_with_the_abort_code_in_words() {
        let e = SdoError {
            node: NodeId::new(5).unwrap(),
            entry: ObjectAddress::new(0x2000, 1),
            name: Some("Setpoint".into()),
            kind: SdoErrorKind::Transfer(ErrorKind::ServerAbort(AbortCode(0x0602_0000))),
        };
        let text = e.to_string();
        assert!(
            text.contains("0x06020000 (Object does not exist in the object dictionary)"),
            "{text}"
        );
        assert_eq!(format!("{e:?}"), text);
        let e = Error::from(e);
        assert_eq!(format!("{e:?}"), e.to_string());
        assert!(!format!("{e:?}").contains("AbortCode("));
        let e = Error::Transport(TransportError::BusOff);
        assert_eq!(format!("{e:?}"), "transport: the CAN controller is bus-off");
    }

    #[test]
    fn a_value_problem_reads_as_the_message_did() {
        let e = Error::Value {
            node: NodeId::new(5).unwrap(),
            entry: ObjectAddress::new(0x1800, 0),
            problem: ValueProblem::Pdo {
                direction: canola_pdo::Direction::Transmit,
                number: 1,
                problem: PdoProblem::Mapping(canola_pdo::MappingError::TooLong(96)),
            },
        };
        let text = "node 5, object 0x1800:00: TPDO1: the mapped objects need 96 bits (12 \
                    bytes); a classic CAN PDO carries at most 64 bits (8 bytes)";
        assert_eq!(e.to_string(), text);
        assert_eq!(format!("{e:?}"), text);
        let unfit = ValueProblem::Unfit {
            object: "Producer Heartbeat Time".into(),
            data_type: canola_od::DataType::Unsigned16,
            why: Unfit::OutOfRange {
                value: 70_000,
                min: 0,
                max: 65_535,
            },
        };
        assert_eq!(
            format!("{unfit:?}"),
            "Producer Heartbeat Time is UNSIGNED16: 70000 does not fit (range 0..=65535)"
        );
    }
}
