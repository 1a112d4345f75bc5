//! PDO communication parameters (CiA 301 §7.4.8, objects 0x1400..=0x15FF for receive PDOs and
//! 0x1800..=0x19FF for transmit PDOs).
//!
//! | sub | name                  | type       | notes                                          |
//! |-----|-----------------------|------------|------------------------------------------------|
//! | 1   | COB-ID used by PDO    | UNSIGNED32 | bit 31 invalid, bit 30 no RTR, bit 29 extended |
//! | 2   | transmission type     | UNSIGNED8  | see [`TransmissionType`]                       |
//! | 3   | inhibit time          | UNSIGNED16 | TPDO only, units of 100 µs                     |
//! | 4   | reserved/compatibility| UNSIGNED8  | unused                                         |
//! | 5   | event timer           | UNSIGNED16 | ms; TPDO: maximum spacing, RPDO: deadline      |
//! | 6   | SYNC start value      | UNSIGNED8  | TPDO only, cyclic types with a SYNC counter    |

use canola_frame::{CanId, Duration};

/// First receive PDO communication parameter object.
pub const RPDO_COMM_BASE: u16 = 0x1400;
/// First receive PDO mapping parameter object.
pub const RPDO_MAPPING_BASE: u16 = 0x1600;
/// First transmit PDO communication parameter object.
pub const TPDO_COMM_BASE: u16 = 0x1800;
/// First transmit PDO mapping parameter object.
pub const TPDO_MAPPING_BASE: u16 = 0x1A00;
/// Number of PDOs per direction CiA 301 reserves objects for (0x1400..=0x15FF and so on).
pub const MAX_PDOS_PER_DIRECTION: u16 = 512;

/// Sub-index of the COB-ID.
pub const SUB_COB_ID: u8 = 1;
/// Sub-index of the transmission type.
pub const SUB_TRANSMISSION_TYPE: u8 = 2;
/// Sub-index of the inhibit time.
pub const SUB_INHIBIT_TIME: u8 = 3;
/// Sub-index of the event timer.
pub const SUB_EVENT_TIMER: u8 = 5;
/// Sub-index of the SYNC start value.
pub const SUB_SYNC_START: u8 = 6;

/// Which way a PDO travels, seen from the device whose object dictionary holds its parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Receive PDO (RPDO): consumed, written into the objects it maps (they must be writable).
    Receive,
    /// Transmit PDO (TPDO): produced from the objects it maps (they must be readable).
    Transmit,
}

impl Direction {
    /// The communication parameter object of PDO `n` (0-based, below 512).
    pub const fn comm_index(self, n: u16) -> u16 {
        match self {
            Self::Receive => RPDO_COMM_BASE + n,
            Self::Transmit => TPDO_COMM_BASE + n,
        }
    }

    /// The mapping parameter object of PDO `n` (0-based, below 512).
    pub const fn mapping_index(self, n: u16) -> u16 {
        match self {
            Self::Receive => RPDO_MAPPING_BASE + n,
            Self::Transmit => TPDO_MAPPING_BASE + n,
        }
    }
}

/// The UNSIGNED32 "COB-ID used by PDO" (sub 1), kept raw so every bit round-trips.
///
/// Bit 31: 0 = PDO exists (valid), 1 = PDO does not exist (invalid). Bit 30: 0 = RTR allowed,
/// 1 = no RTR allowed. Bit 29: 0 = 11-bit identifier, 1 = 29-bit identifier. Bits 28..0: the
/// identifier (bits 28..11 must be zero for an 11-bit identifier).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PdoCobId(pub u32);

/// Bit 31 of the COB-ID: set when the PDO is not valid.
pub const COB_ID_INVALID: u32 = 1 << 31;
/// Bit 30 of the COB-ID: set when remote requests are not allowed.
pub const COB_ID_NO_RTR: u32 = 1 << 30;
/// Bit 29 of the COB-ID: set for a 29-bit identifier.
pub const COB_ID_EXTENDED: u32 = 1 << 29;

impl PdoCobId {
    /// A valid PDO on an 11-bit identifier with RTR not allowed (the usual configuration).
    pub const fn standard(id: u16) -> Self {
        Self(COB_ID_NO_RTR | (id as u32 & 0x7FF))
    }

    /// Whether the PDO exists (bit 31 clear).
    pub const fn is_valid(self) -> bool {
        self.0 & COB_ID_INVALID == 0
    }

    /// Whether remote transmission requests are allowed (bit 30 clear).
    pub const fn rtr_allowed(self) -> bool {
        self.0 & COB_ID_NO_RTR == 0
    }

    /// Whether the identifier is a 29-bit one (bit 29 set).
    pub const fn is_extended(self) -> bool {
        self.0 & COB_ID_EXTENDED != 0
    }

    /// The same COB-ID with bit 31 set or cleared.
    pub const fn with_valid(self, valid: bool) -> Self {
        if valid {
            Self(self.0 & !COB_ID_INVALID)
        } else {
            Self(self.0 | COB_ID_INVALID)
        }
    }

    /// The same COB-ID with bit 30 cleared (`true`) or set (`false`).
    pub const fn with_rtr_allowed(self, allowed: bool) -> Self {
        if allowed {
            Self(self.0 & !COB_ID_NO_RTR)
        } else {
            Self(self.0 | COB_ID_NO_RTR)
        }
    }

    /// The CAN identifier. Fails when bit 29 is clear but bits 28..11 are not zero.
    pub fn can_id(self) -> Result<CanId, CommError> {
        if self.is_extended() {
            CanId::extended(self.0 & 0x1FFF_FFFF).map_err(|_| CommError::CobId(self.0))
        } else if self.0 & 0x1FFF_F800 != 0 {
            Err(CommError::CobId(self.0))
        } else {
            CanId::standard((self.0 & 0x7FF) as u16).map_err(|_| CommError::CobId(self.0))
        }
    }
}

/// The transmission type (sub 2). Reserved codes are kept so a read-write round trip is
/// lossless; they are refused when a PDO is configured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TransmissionType {
    /// 0: synchronous, acyclic. A TPDO goes out on the SYNC after an event (a trigger or a changed
    /// value); an RPDO's data takes effect at the next SYNC.
    SyncAcyclic,
    /// 1..=240: synchronous, cyclic. A TPDO goes out on every n-th SYNC.
    SyncCyclic(u8),
    /// 241..=251: reserved.
    Reserved(u8),
    /// 252: RTR-only, synchronous: data sampled at SYNC, sent on a remote request.
    RtrSync,
    /// 253: RTR-only, event-driven: data sampled and sent on a remote request.
    RtrEvent,
    /// 254: event-driven, manufacturer-specific event.
    EventManufacturer,
    /// 255: event-driven, device-profile / application-profile event.
    EventProfile,
}

impl TransmissionType {
    /// Decodes the UNSIGNED8 code. Total.
    pub const fn from_code(code: u8) -> Self {
        match code {
            0 => Self::SyncAcyclic,
            1..=240 => Self::SyncCyclic(code),
            241..=251 => Self::Reserved(code),
            252 => Self::RtrSync,
            253 => Self::RtrEvent,
            254 => Self::EventManufacturer,
            255 => Self::EventProfile,
        }
    }

    /// The UNSIGNED8 code.
    pub const fn code(self) -> u8 {
        match self {
            Self::SyncAcyclic => 0,
            Self::SyncCyclic(n) | Self::Reserved(n) => n,
            Self::RtrSync => 252,
            Self::RtrEvent => 253,
            Self::EventManufacturer => 254,
            Self::EventProfile => 255,
        }
    }

    /// Types 0..=240: tied to SYNC (for an RPDO: data takes effect at the next SYNC).
    pub const fn is_synchronous(self) -> bool {
        matches!(self, Self::SyncAcyclic | Self::SyncCyclic(_))
    }

    /// Types 254 and 255: event-driven, bounded by inhibit time and event timer.
    pub const fn is_event_driven(self) -> bool {
        matches!(self, Self::EventManufacturer | Self::EventProfile)
    }
}

/// The communication parameters of one PDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CommParams {
    /// Sub 1.
    pub cob_id: PdoCobId,
    /// Sub 2.
    pub transmission_type: TransmissionType,
    /// Sub 3, in units of 100 µs (TPDO; 0 = none).
    pub inhibit_time: u16,
    /// Sub 5, in ms (0 = off). TPDO: at least one frame per event time (types 254/255).
    /// RPDO: deadline after which a missing PDO is reported.
    pub event_timer: u16,
    /// Sub 6 (TPDO, cyclic types): the SYNC counter value of the first transmission; 0 = unused.
    pub sync_start: u8,
}

impl CommParams {
    /// Event-driven (255) parameters on an 11-bit COB-ID, RTR not allowed, no timers.
    pub const fn event_driven(cob_id: u16) -> Self {
        Self {
            cob_id: PdoCobId::standard(cob_id),
            transmission_type: TransmissionType::EventProfile,
            inhibit_time: 0,
            event_timer: 0,
            sync_start: 0,
        }
    }

    /// The same parameters with another transmission type.
    pub const fn with_transmission_type(mut self, t: TransmissionType) -> Self {
        self.transmission_type = t;
        self
    }

    /// The same parameters with an inhibit time in units of 100 µs.
    pub const fn with_inhibit_time(mut self, hundreds_of_micros: u16) -> Self {
        self.inhibit_time = hundreds_of_micros;
        self
    }

    /// The same parameters with an event timer in ms.
    pub const fn with_event_timer(mut self, millis: u16) -> Self {
        self.event_timer = millis;
        self
    }

    /// The same parameters with a SYNC start value.
    pub const fn with_sync_start(mut self, start: u8) -> Self {
        self.sync_start = start;
        self
    }

    /// The inhibit time as a duration.
    pub const fn inhibit(&self) -> Duration {
        Duration::from_micros(self.inhibit_time as u64 * 100)
    }

    /// The event timer as a duration (zero = off).
    pub const fn event_time(&self) -> Duration {
        Duration::from_millis(self.event_timer as u64)
    }

    /// Checks the parameters an engine needs: a usable COB-ID and a defined transmission type.
    pub fn validate(&self) -> Result<(), CommError> {
        if let TransmissionType::Reserved(code) = self.transmission_type {
            return Err(CommError::ReservedTransmissionType(code));
        }
        self.cob_id.can_id().map(|_| ())
    }

    /// Reads sub 1, 2, 3, 5 and 6 of communication object `index` from a dictionary. Sub 3, 5
    /// and 6 are optional: a dictionary answering "no such sub-index" gives 0.
    pub fn read_from<D: crate::dictionary::Dictionary + ?Sized>(
        dict: &D,
        index: u16,
    ) -> Result<Self, crate::dictionary::ReadError> {
        let cob_id = PdoCobId(dict.read_u32(index, SUB_COB_ID)?);
        let transmission_type =
            TransmissionType::from_code(dict.read_u32(index, SUB_TRANSMISSION_TYPE)? as u8);
        let optional = |sub| match dict.read_u32(index, sub) {
            Ok(v) => Ok(v),
            Err(crate::dictionary::ReadError::NoSuchObject { .. }) => Ok(0),
            Err(e) => Err(e),
        };
        Ok(Self {
            cob_id,
            transmission_type,
            inhibit_time: optional(SUB_INHIBIT_TIME)? as u16,
            event_timer: optional(SUB_EVENT_TIMER)? as u16,
            sync_start: optional(SUB_SYNC_START)? as u8,
        })
    }
}

/// A communication parameter an engine cannot use.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CommError {
    /// The COB-ID's identifier does not fit its format (bit 29 clear, bits 28..11 set).
    #[error("COB-ID {0:#010x} does not hold a valid CAN identifier")]
    CobId(u32),
    /// Transmission type 241..=251 is reserved.
    #[error("transmission type {0} is reserved")]
    ReservedTransmissionType(u8),
}

debug_as_display!(CommError);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cob_id_bits() {
        let c = PdoCobId(0x8000_0185);
        assert!(!c.is_valid());
        assert!(c.rtr_allowed());
        assert!(!c.is_extended());
        assert_eq!(c.can_id().ok(), CanId::standard(0x185).ok());
        assert_eq!(c.with_valid(true), PdoCobId(0x185));
        assert_eq!(PdoCobId::standard(0x185), PdoCobId(0x4000_0185));
        assert_eq!(
            PdoCobId(0x2012_3456).can_id().ok(),
            CanId::extended(0x0012_3456).ok()
        );
        assert_eq!(
            PdoCobId(0x0000_0985).can_id(),
            Err(CommError::CobId(0x985)),
            "11-bit COB-ID with bit 11 set"
        );
    }

    #[test]
    fn transmission_type_codes_round_trip() {
        for code in 0..=255u8 {
            assert_eq!(TransmissionType::from_code(code).code(), code);
        }
        assert_eq!(
            TransmissionType::from_code(0),
            TransmissionType::SyncAcyclic
        );
        assert_eq!(
            TransmissionType::from_code(240),
            TransmissionType::SyncCyclic(240)
        );
        assert_eq!(
            TransmissionType::from_code(241),
            TransmissionType::Reserved(241)
        );
        assert_eq!(TransmissionType::from_code(252), TransmissionType::RtrSync);
        assert!(TransmissionType::from_code(254).is_event_driven());
        assert!(
            CommParams::event_driven(0x181)
                .with_transmission_type(TransmissionType::Reserved(245))
                .validate()
                .is_err()
        );
    }

    #[test]
    fn timer_units() {
        let p = CommParams::event_driven(0x181)
            .with_inhibit_time(5000)
            .with_event_timer(1000);
        assert_eq!(p.inhibit(), Duration::from_millis(500));
        assert_eq!(p.event_time(), Duration::from_secs(1));
    }
}
