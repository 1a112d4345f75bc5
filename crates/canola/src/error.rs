//! The master's errors: which node, which object (with its dictionary name when known), and
//! what went wrong — the server's abort code with its CiA 301 meaning kept apart from local
//! failures (timeout, cancel, I/O).

use canola_frame::{Duration, NodeId};
use canola_nmt::NmtState;
use canola_sdo::{AbortCode, ErrorKind};

use crate::transport::TransportError;
use canola_od::ObjectAddress;

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

/// What is wrong with a value, an object or a PDO's parameters ([`Error::Value`]): one case
/// per kind of problem, carrying the typed error of the crate that found it where there is
/// one, so a program matches instead of parsing the message.
#[non_exhaustive]
pub enum ValueProblem {
    /// The node's dictionary does not describe the object (or the node has no dictionary to
    /// take its type from).
    NotDescribed,
    /// The bytes do not decode as the data type (read by SDO or USDO, or taken from a PDO).
    Bytes(canola_od::BytesError),
    /// The value read does not convert to the Rust type asked for (500 read as `u8`).
    Convert(canola_od::ConvertError),
    /// A typed entry ([`canola_od::Entry`]) could not decode or encode its value.
    Entry(canola_od::EntryError),
    /// A value to write does not fit the object's data type. Nothing was sent.
    Unfit {
        /// The object's name in the node's dictionary (its address when it has none).
        object: String,
        /// The object's data type.
        data_type: canola_od::DataType,
        /// Why the value does not fit.
        why: Unfit,
    },
    /// A value for a mapped object does not fit its mapped bits. Nothing was sent.
    Mapped(MappedUnfit),
    /// The object is not mapped in the RPDO being transmitted.
    NotMapped {
        /// The RPDO number (1-based).
        rpdo: u16,
    },
    /// The object is longer than a PDO can map.
    TooWideForPdo {
        /// The object's length in bits.
        bits: u32,
    },
    /// An MPDO carries objects of 1 to 4 bytes; the dictionary gives this one another size.
    MpdoObjectSize,
    /// The MPDO COB-ID does not hold a CAN identifier.
    MpdoCobId {
        /// The COB-ID.
        cob_id: u32,
        /// What is wrong with it.
        error: canola_pdo::CommError,
    },
    /// The master could not send the MPDO.
    Mpdo(canola_pdo::MpdoError),
    /// No plan to give the PDO its new parameters (CiA 301 remap order).
    Remap(canola_pdo::RemapError),
    /// A PDO's parameters, mapping or data cannot be used as asked.
    Pdo {
        /// TPDO or RPDO (seen from the node).
        direction: canola_pdo::Direction,
        /// The PDO number (1-based).
        number: u16,
        /// What is wrong.
        problem: PdoProblem,
    },
    /// A rule of a device profile the value breaks (a crate for one maker's devices, such as
    /// `canola-burkert`, puts its own typed error here: downcast it).
    Profile(Box<dyn std::error::Error + Send + Sync>),
}

/// The name of a data type for messages (`UNSIGNED16`, else its index).
pub(crate) fn type_name(t: canola_od::DataType) -> String {
    t.name()
        .map_or_else(|| format!("data type {:#06x}", t.code()), str::to_string)
}

impl core::fmt::Display for ValueProblem {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotDescribed => {
                f.write_str("the node's dictionary does not describe this object")
            }
            Self::Bytes(e) => write!(f, "{e}"),
            Self::Convert(e) => write!(f, "{e}"),
            Self::Entry(e) => write!(f, "{e}"),
            Self::Unfit {
                object,
                data_type,
                why,
            } => write!(f, "{object} is {}: {why}", type_name(*data_type)),
            Self::Mapped(why) => write!(f, "{why}"),
            Self::NotMapped { rpdo } => write!(f, "not mapped in RPDO{rpdo}"),
            Self::TooWideForPdo { bits } => write!(f, "{bits} bits do not fit a PDO"),
            Self::MpdoObjectSize => f.write_str("an MPDO carries objects of 1 to 4 bytes"),
            Self::MpdoCobId { cob_id, error } => write!(f, "MPDO COB-ID {cob_id:#x}: {error}"),
            Self::Mpdo(e) => write!(f, "{e}"),
            Self::Remap(e) => write!(f, "{e}"),
            Self::Pdo {
                direction,
                number,
                problem,
            } => write!(f, "{}{number}: {problem}", pdo_kind(*direction)),
            Self::Profile(e) => write!(f, "{e}"),
        }
    }
}

impl core::fmt::Debug for ValueProblem {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// Why a value to write does not fit the object's data type ([`ValueProblem::Unfit`]).
#[derive(Clone, PartialEq)]
#[non_exhaustive]
pub enum Unfit {
    /// An integer given for an object that is not a number.
    Integer(i128),
    /// An integer outside the range of the object's type.
    OutOfRange {
        /// The integer.
        value: i128,
        /// The least the type holds.
        min: i128,
        /// The most the type holds.
        max: i128,
    },
    /// A float given for an object that is not REAL32 or REAL64.
    Float(f64),
    /// Text given for an object that is not a string.
    Text(String),
    /// A number of bytes other than the type's size.
    ByteCount {
        /// The bytes given.
        given: usize,
        /// The type's size in bytes.
        takes: usize,
    },
    /// The bytes given do not decode as the type.
    Bytes(canola_od::BytesError),
    /// A typed value whose type is not the object's and that is not an integer.
    ValueType(canola_od::DataType),
}

impl core::fmt::Display for Unfit {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Integer(v) => write!(f, "an integer ({v}) cannot be written to it"),
            Self::OutOfRange { value, min, max } => {
                write!(f, "{value} does not fit (range {min}..={max})")
            }
            Self::Float(v) => write!(f, "a float ({v}) cannot be written to it"),
            Self::Text(s) => write!(f, "text (\"{s}\") cannot be written to it"),
            Self::ByteCount { given, takes } => write!(f, "{given} bytes given, it takes {takes}"),
            Self::Bytes(e) => write!(f, "{e}"),
            Self::ValueType(t) => write!(f, "a {} value cannot be written to it", type_name(*t)),
        }
    }
}

impl core::fmt::Debug for Unfit {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// Why a value does not fit the bits mapped for its object ([`ValueProblem::Mapped`]).
#[derive(Clone)]
#[non_exhaustive]
pub enum MappedUnfit {
    /// The value, converted to the object's type, is wider than the mapped bits.
    Value {
        /// The value.
        value: canola_od::Value,
        /// The mapped length.
        bits: u8,
    },
    /// An integer (no type known) outside what the mapped bits hold.
    Integer {
        /// The integer.
        value: i128,
        /// The mapped length.
        bits: u8,
    },
    /// A float (no type known) for a mapping of other than 32 or 64 bits.
    Float {
        /// The float.
        value: f64,
        /// The mapped length.
        bits: u8,
    },
    /// Bytes (no type known) of another length than mapped.
    ByteCount {
        /// The bytes given.
        given: usize,
        /// The mapped bytes.
        mapped: usize,
    },
    /// Text cannot be sent without the node's dictionary to give the object's type.
    NeedsDictionary(String),
}

impl core::fmt::Display for MappedUnfit {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Value { value, bits } => {
                write!(f, "{value} does not fit the {bits} mapped bits")
            }
            Self::Integer { value, bits } => write!(f, "{value} does not fit {bits} bits"),
            Self::Float { value, .. } => {
                write!(f, "a float ({value}) needs 32 or 64 mapped bits")
            }
            Self::ByteCount { given, mapped } => write!(f, "{given} bytes given, {mapped} mapped"),
            Self::NeedsDictionary(s) => write!(
                f,
                "text (\"{s}\") cannot be sent without the node's dictionary"
            ),
        }
    }
}

impl core::fmt::Debug for MappedUnfit {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(self, f)
    }
}

/// What is wrong with a PDO's parameters, mapping or data ([`ValueProblem::Pdo`]).
#[derive(Clone)]
#[non_exhaustive]
pub enum PdoProblem {
    /// A TPDO was to be transmitted by the master: the master transmits RPDOs.
    NotAnRpdo,
    /// The PDO is not valid on the node (COB-ID bit 31 set).
    NotValid,
    /// The mapping does not fit a PDO, classic or CAN FD.
    DoesNotFit,
    /// Nothing is mapped.
    NothingMapped,
    /// The node has no inhibit time (sub 3) for this PDO.
    NoInhibitTime,
    /// The node has no event timer (sub 5) for this PDO.
    NoEventTimer,
    /// An inhibit time that is not a multiple of 100 µs.
    InhibitTimeNotMultiple(Duration),
    /// An inhibit time longer than 6.5535 s.
    InhibitTimeTooLong(Duration),
    /// An event timer that is not whole milliseconds.
    EventTimerNotWholeMs(Duration),
    /// An event timer longer than 65.535 s.
    EventTimerTooLong(Duration),
    /// The mapping is not valid (or not valid for the node's dictionary).
    Mapping(canola_pdo::MappingError),
    /// The COB-ID or another communication parameter cannot be used.
    Comm(canola_pdo::CommError),
    /// The master's PDO engine refused the PDO.
    Engine(canola_pdo::EngineError),
    /// A mapping longer than a classic CAN frame, where CAN FD is not there.
    NeedsFd {
        /// The mapped bits.
        bits: u32,
        /// The node.
        node: NodeId,
        /// Why CAN FD is not there: a classic bus, or a node not marked CANopen FD.
        refusal: FdRefusal,
    },
    /// An RPDO of more than 8 bytes is sent on a change or a trigger only.
    FdNotEventDriven,
    /// An MPDO mapping is not saved by this API.
    MpdoNotSaved,
    /// The PDO's data does not unpack, or its values do not pack, by the mapping.
    Pack(canola_pdo::PackError),
    /// A mapped object's bits do not decode as its data type.
    Data(canola_od::BytesError),
    /// A value does not fit its mapped field.
    Field {
        /// The value.
        value: canola_od::Value,
        /// The kind of the mapped field.
        kind: canola_pdo::ValueKind,
    },
    /// The COB-ID does not hold an 11-bit identifier.
    NotStandardCobId(u32),
    /// The PDO's data does not make a CAN frame.
    Frame(canola_frame::FrameError),
}

fn value_kind(k: canola_pdo::ValueKind) -> &'static str {
    match k {
        canola_pdo::ValueKind::Boolean => "BOOLEAN",
        canola_pdo::ValueKind::Unsigned => "unsigned",
        canola_pdo::ValueKind::Signed => "signed",
        canola_pdo::ValueKind::Real32 => "REAL32",
        canola_pdo::ValueKind::Real64 => "REAL64",
        canola_pdo::ValueKind::Bytes => "bytes",
    }
}

impl core::fmt::Display for PdoProblem {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotAnRpdo => f.write_str("the master transmits a node's RPDOs, not its TPDOs"),
            Self::NotValid => f.write_str("the PDO is not valid on the node (COB-ID bit 31)"),
            Self::DoesNotFit => f.write_str("the mapping does not fit a PDO"),
            Self::NothingMapped => f.write_str("nothing is mapped"),
            Self::NoInhibitTime => f.write_str("the node has no inhibit time (sub 3) for this PDO"),
            Self::NoEventTimer => f.write_str("the node has no event timer (sub 5) for this PDO"),
            Self::InhibitTimeNotMultiple(d) => {
                write!(f, "inhibit time {d} is not a multiple of 100 µs")
            }
            Self::InhibitTimeTooLong(d) => write!(f, "inhibit time {d} exceeds 6.5535 s"),
            Self::EventTimerNotWholeMs(d) => write!(f, "event timer {d} is not whole milliseconds"),
            Self::EventTimerTooLong(d) => write!(f, "event timer {d} exceeds 65.535 s"),
            Self::Mapping(e) => write!(f, "{e}"),
            Self::Comm(e) => write!(f, "{e}"),
            Self::Engine(e) => write!(f, "{e}"),
            Self::NeedsFd {
                bits,
                node,
                refusal,
            } => {
                write!(
                    f,
                    "the mapped objects need {bits} bits ({} bytes), more than the 64 bits (8 \
                     bytes) of a classic CAN frame, and ",
                    bits.div_ceil(8)
                )?;
                match refusal {
                    FdRefusal::ClassicBus { bus } => write!(f, "{bus} carries no CAN FD")?,
                    FdRefusal::NodeNotFd => write!(f, "node {node} is not marked CANopen FD")?,
                }
                f.write_str(
                    ": a PDO of up to 64 bytes needs a node marked CANopen FD on a CAN FD bus",
                )
            }
            Self::FdNotEventDriven => f.write_str(
                "an RPDO of more than 8 bytes is sent on a change or a trigger only (no SYNC, \
                 inhibit time or event timer)",
            ),
            Self::MpdoNotSaved => f.write_str("an MPDO mapping is not saved by this API"),
            Self::Pack(e) => write!(f, "{e}"),
            Self::Data(e) => write!(f, "data: {e}"),
            Self::Field { value, kind } => write!(
                f,
                "{value} does not fit the mapped {} field",
                value_kind(*kind)
            ),
            Self::NotStandardCobId(c) => write!(f, "COB-ID {c:#x} is not an 11-bit identifier"),
            Self::Frame(e) => write!(f, "{e}"),
        }
    }
}

impl core::fmt::Debug for PdoProblem {
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
