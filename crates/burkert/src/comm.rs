//! Object 0x2001, device communication: bit rate, node address, bUS/CANopen mode, reset command,
//! CAN operation status, termination resistor and the EDS version byte.

use core::fmt;

use canola_lss::BitRate as Cia;

/// Bit-rate codes of 0x2001 sub 1: an entry of the CiA 305 bit timing table 0
/// ([`canola_lss::BitRate`], the one copy of that table), without its automatic bit rate
/// detection (codes 0..=8; default 2 = 500 kbit/s).
///
/// The Bürkert manual marks 800 kbit/s as not offered and 100 kbit/s as reserved; both remain
/// typed here because they are valid CiA 305 codes — [`BitRate::offered_by_burkert`] says which
/// ones a Bürkert device accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BitRate(Cia);

// The rates keep the names they had as enum variants, so they read and match the same.
#[allow(non_upper_case_globals)]
impl BitRate {
    /// 0 — 1 Mbit/s.
    pub const Kbit1000: BitRate = BitRate(Cia::Kbit1000);
    /// 1 — 800 kbit/s (not offered by Bürkert).
    pub const Kbit800: BitRate = BitRate(Cia::Kbit800);
    /// 2 — 500 kbit/s (default).
    pub const Kbit500: BitRate = BitRate(Cia::Kbit500);
    /// 3 — 250 kbit/s.
    pub const Kbit250: BitRate = BitRate(Cia::Kbit250);
    /// 4 — 125 kbit/s.
    pub const Kbit125: BitRate = BitRate(Cia::Kbit125);
    /// 5 — 100 kbit/s (reserved in the Bürkert table).
    pub const Kbit100: BitRate = BitRate(Cia::Kbit100);
    /// 6 — 50 kbit/s.
    pub const Kbit50: BitRate = BitRate(Cia::Kbit50);
    /// 7 — 20 kbit/s.
    pub const Kbit20: BitRate = BitRate(Cia::Kbit20);
    /// 8 — 10 kbit/s.
    pub const Kbit10: BitRate = BitRate(Cia::Kbit10);
}

impl Default for BitRate {
    fn default() -> Self {
        Self::Kbit500
    }
}

impl From<BitRate> for Cia {
    fn from(rate: BitRate) -> Self {
        rate.0
    }
}

/// A value of 0x2001 that is outside the values the manual defines.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CommValueError {
    /// Bit-rate code above 8.
    #[error("bit-rate code {0} is not in the CiA 305 table (0..=8)")]
    BitRate(u8),
    /// Not a bit rate of the table.
    #[error("{0} kbit/s is not a CiA 305 bit rate")]
    Kbits(u32),
    /// bUS mode other than 0 or 1.
    #[error("bUS mode {0} is undefined (0 CANopen, 1 bUS)")]
    BusMode(u8),
    /// Reset command other than 0, 1, 2.
    #[error("reset command {0} is undefined (0 none, 1 communication, 2 device)")]
    Reset(u8),
    /// Termination other than 0 or 1.
    #[error("termination value {0} is undefined (0 inactive, 1 active)")]
    Termination(u8),
}

debug_as_display!(CommValueError);

impl BitRate {
    /// All codes in table order.
    pub const ALL: [BitRate; 9] = [
        Self::Kbit1000,
        Self::Kbit800,
        Self::Kbit500,
        Self::Kbit250,
        Self::Kbit125,
        Self::Kbit100,
        Self::Kbit50,
        Self::Kbit20,
        Self::Kbit10,
    ];

    /// From the table index (0x2001 sub 1, or the LSS configure-bit-timing index).
    pub const fn from_code(code: u8) -> Result<Self, CommValueError> {
        match Cia::from_index(code) {
            Some(rate) if rate.bits_per_second().is_some() => Ok(Self(rate)),
            _ => Err(CommValueError::BitRate(code)),
        }
    }

    /// The table index.
    pub const fn code(self) -> u8 {
        self.0.index()
    }

    /// The bit rate in kbit/s.
    pub const fn kbits(self) -> u32 {
        match self.0.bits_per_second() {
            Some(bits) => bits / 1000,
            // Not constructible: `from_code` refuses automatic detection.
            None => 0,
        }
    }

    /// From kbit/s.
    pub fn from_kbits(kbits: u32) -> Result<Self, CommValueError> {
        Self::ALL
            .into_iter()
            .find(|b| b.kbits() == kbits)
            .ok_or(CommValueError::Kbits(kbits))
    }

    /// Whether a Bürkert device offers this bit rate (not 800k, not the reserved 100k).
    pub const fn offered_by_burkert(self) -> bool {
        !matches!(self.0, Cia::Kbit800 | Cia::Kbit100)
    }
}

impl fmt::Display for BitRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.kbits() == 1000 {
            f.write_str("1 Mbit/s")
        } else {
            write!(f, "{} kbit/s", self.kbits())
        }
    }
}

/// 0x2001 sub 3: which protocol the device speaks (default 1, bUS).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BusMode {
    /// 0 — CANopen.
    CanOpen,
    /// 1 — Bürkert's büS.
    Bus,
}

impl BusMode {
    /// Decodes sub 3.
    pub const fn from_u8(v: u8) -> Result<Self, CommValueError> {
        match v {
            0 => Ok(Self::CanOpen),
            1 => Ok(Self::Bus),
            other => Err(CommValueError::BusMode(other)),
        }
    }

    /// The object value.
    pub const fn to_u8(self) -> u8 {
        self as u8
    }
}

/// 0x2001 sub 4: a reset requested through the object dictionary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ResetCommand {
    /// 0 — no reset.
    None,
    /// 1 — communication reset.
    Communication,
    /// 2 — device reset.
    Device,
}

impl ResetCommand {
    /// Decodes sub 4.
    pub const fn from_u8(v: u8) -> Result<Self, CommValueError> {
        match v {
            0 => Ok(Self::None),
            1 => Ok(Self::Communication),
            2 => Ok(Self::Device),
            other => Err(CommValueError::Reset(other)),
        }
    }

    /// The object value.
    pub const fn to_u8(self) -> u8 {
        self as u8
    }
}

/// 0x2001 sub 0x0A: the CAN operation status, the device's NMT state in the heartbeat's codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CanOperationStatus {
    /// 4 — stopped.
    Stopped,
    /// 5 — operational.
    Operational,
    /// 127 — pre-operational.
    PreOperational,
    /// A value the manual does not list.
    Unknown(u8),
}

impl CanOperationStatus {
    /// Decodes sub 0x0A.
    pub const fn from_u8(v: u8) -> Self {
        match v {
            4 => Self::Stopped,
            5 => Self::Operational,
            127 => Self::PreOperational,
            other => Self::Unknown(other),
        }
    }

    /// The object value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::Stopped => 4,
            Self::Operational => 5,
            Self::PreOperational => 127,
            Self::Unknown(v) => v,
        }
    }
}

impl fmt::Display for CanOperationStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Stopped => f.write_str("stopped"),
            Self::Operational => f.write_str("operational"),
            Self::PreOperational => f.write_str("pre-operational"),
            Self::Unknown(v) => write!(f, "unknown ({v})"),
        }
    }
}

/// 0x2001 sub 0x0B: the device-internal termination resistor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Termination {
    /// 0 — inactive.
    Inactive,
    /// 1 — active.
    Active,
}

impl Termination {
    /// Decodes sub 0x0B.
    pub const fn from_u8(v: u8) -> Result<Self, CommValueError> {
        match v {
            0 => Ok(Self::Inactive),
            1 => Ok(Self::Active),
            other => Err(CommValueError::Termination(other)),
        }
    }

    /// The object value.
    pub const fn to_u8(self) -> u8 {
        self as u8
    }
}

/// 0x2001 sub 0x0D: the EDS version the device software uses. The manual's example: 50 =
/// 0x32 means EDS version 3.2 — the high nibble is the version, the low nibble the revision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EdsVersion {
    /// High nibble.
    pub version: u8,
    /// Low nibble.
    pub revision: u8,
}

impl EdsVersion {
    /// Splits the byte.
    pub const fn from_u8(v: u8) -> Self {
        Self {
            version: v >> 4,
            revision: v & 0x0F,
        }
    }

    /// Joins the nibbles (each masked to four bits).
    pub const fn to_u8(self) -> u8 {
        (self.version & 0x0F) << 4 | (self.revision & 0x0F)
    }
}

impl fmt::Display for EdsVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.version, self.revision)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_rate_table() {
        let table = [
            (0, 1000),
            (1, 800),
            (2, 500),
            (3, 250),
            (4, 125),
            (5, 100),
            (6, 50),
            (7, 20),
            (8, 10),
        ];
        for (code, kbits) in table {
            let b = BitRate::from_code(code).unwrap();
            assert_eq!(b.kbits(), kbits);
            assert_eq!(b.code(), code);
            assert_eq!(BitRate::from_kbits(kbits), Ok(b));
        }
        assert_eq!(BitRate::from_code(9), Err(CommValueError::BitRate(9)));
        assert_eq!(BitRate::default(), BitRate::Kbit500);
        assert!(!BitRate::Kbit800.offered_by_burkert());
        assert!(!BitRate::Kbit100.offered_by_burkert());
        assert!(BitRate::Kbit125.offered_by_burkert());
    }

    #[test]
    fn small_enums() {
        assert_eq!(BusMode::from_u8(0), Ok(BusMode::CanOpen));
        assert_eq!(BusMode::from_u8(1), Ok(BusMode::Bus));
        assert!(BusMode::from_u8(2).is_err());
        assert_eq!(ResetCommand::from_u8(1), Ok(ResetCommand::Communication));
        assert_eq!(ResetCommand::from_u8(2), Ok(ResetCommand::Device));
        assert!(ResetCommand::from_u8(3).is_err());
        for (v, s) in [
            (4, CanOperationStatus::Stopped),
            (5, CanOperationStatus::Operational),
            (127, CanOperationStatus::PreOperational),
        ] {
            assert_eq!(CanOperationStatus::from_u8(v), s);
            assert_eq!(s.to_u8(), v);
        }
        assert_eq!(CanOperationStatus::from_u8(9).to_u8(), 9);
        assert_eq!(Termination::from_u8(1), Ok(Termination::Active));
        assert!(Termination::from_u8(2).is_err());
    }

    #[test]
    fn eds_version_manual_example() {
        let v = EdsVersion::from_u8(50);
        assert_eq!((v.version, v.revision), (3, 2));
        assert_eq!(v.to_u8(), 0x32);
        extern crate std;
        assert_eq!(std::format!("{v}"), "3.2");
    }
}
