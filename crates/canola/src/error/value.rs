//! What is wrong with a value, an object or a PDO's parameters ([`Error::Value`]): the
//! [`ValueProblem`] a program matches, with the typed reasons it carries ([`Unfit`],
//! [`MappedUnfit`], [`PdoProblem`]) and their sentences.

use super::*;

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
fn type_name(t: canola_od::DataType) -> String {
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
