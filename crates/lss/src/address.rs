//! The LSS address (CiA 305): the 128-bit identity of a device, made of the four
//! UNSIGNED32 values of its identity object 0x1018 (vendor-ID, product code, revision number,
//! serial number), and the bit timing tables of configure bit timing (CiA 305).

use core::fmt;

/// One of the four parts of an LSS address, numbered as in the `LSSSub` / `LSSNext` fields of
/// LSS Fastscan (0 = vendor-ID .. 3 = serial number), which is also the 0x1018 subindex minus one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AddressPart {
    /// Vendor-ID (0x1018 sub 1).
    Vendor = 0,
    /// Product code (0x1018 sub 2).
    Product = 1,
    /// Revision number (0x1018 sub 3).
    Revision = 2,
    /// Serial number (0x1018 sub 4).
    Serial = 3,
}

impl AddressPart {
    /// All four parts in Fastscan order.
    pub const ALL: [AddressPart; 4] = [
        AddressPart::Vendor,
        AddressPart::Product,
        AddressPart::Revision,
        AddressPart::Serial,
    ];

    /// The part with Fastscan number `n` (0..=3).
    pub const fn from_index(n: u8) -> Option<Self> {
        match n {
            0 => Some(Self::Vendor),
            1 => Some(Self::Product),
            2 => Some(Self::Revision),
            3 => Some(Self::Serial),
            _ => None,
        }
    }

    /// The Fastscan number, 0..=3.
    pub const fn index(self) -> u8 {
        self as u8
    }

    /// The part after this one, wrapping from serial back to vendor (Fastscan `LSSNext`).
    pub const fn next(self) -> Self {
        match self {
            Self::Vendor => Self::Product,
            Self::Product => Self::Revision,
            Self::Revision => Self::Serial,
            Self::Serial => Self::Vendor,
        }
    }
}

impl fmt::Display for AddressPart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Vendor => "vendor-ID",
            Self::Product => "product code",
            Self::Revision => "revision number",
            Self::Serial => "serial number",
        })
    }
}

/// An LSS address: the identity object 0x1018 sub 1..=4 of one device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct LssAddress {
    /// Vendor-ID, assigned by CiA.
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number.
    pub revision_number: u32,
    /// Serial number.
    pub serial_number: u32,
}

impl LssAddress {
    /// An address from its four parts.
    pub const fn new(
        vendor_id: u32,
        product_code: u32,
        revision_number: u32,
        serial_number: u32,
    ) -> Self {
        Self {
            vendor_id,
            product_code,
            revision_number,
            serial_number,
        }
    }

    /// One part of the address.
    pub const fn get(&self, part: AddressPart) -> u32 {
        match part {
            AddressPart::Vendor => self.vendor_id,
            AddressPart::Product => self.product_code,
            AddressPart::Revision => self.revision_number,
            AddressPart::Serial => self.serial_number,
        }
    }

    /// Sets one part of the address.
    pub fn set(&mut self, part: AddressPart, value: u32) {
        match part {
            AddressPart::Vendor => self.vendor_id = value,
            AddressPart::Product => self.product_code = value,
            AddressPart::Revision => self.revision_number = value,
            AddressPart::Serial => self.serial_number = value,
        }
    }
}

impl fmt::Display for LssAddress {
    /// `vendor:product:revision:serial` in hexadecimal, the way LSS tools usually print it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:08X}:{:08X}:{:08X}:{:08X}",
            self.vendor_id, self.product_code, self.revision_number, self.serial_number
        )
    }
}

/// A bit rate of the CiA bit timing table (table selector 0, CiA 305 configure bit timing).
///
/// Index 5 is 100 kbit/s as in DSP 305 V2.x and the project's seed notes (newer CiA 305
/// editions mark it reserved; a slave that does not offer it answers "not supported").
/// Index 9 is automatic bit rate detection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BitRate {
    /// 1 Mbit/s (index 0).
    Kbit1000,
    /// 800 kbit/s (index 1).
    Kbit800,
    /// 500 kbit/s (index 2).
    Kbit500,
    /// 250 kbit/s (index 3).
    Kbit250,
    /// 125 kbit/s (index 4).
    Kbit125,
    /// 100 kbit/s (index 5).
    Kbit100,
    /// 50 kbit/s (index 6).
    Kbit50,
    /// 20 kbit/s (index 7).
    Kbit20,
    /// 10 kbit/s (index 8).
    Kbit10,
    /// Automatic bit rate detection (index 9).
    Auto,
}

impl BitRate {
    /// Every entry of table 0 in index order.
    pub const ALL: [BitRate; 10] = [
        Self::Kbit1000,
        Self::Kbit800,
        Self::Kbit500,
        Self::Kbit250,
        Self::Kbit125,
        Self::Kbit100,
        Self::Kbit50,
        Self::Kbit20,
        Self::Kbit10,
        Self::Auto,
    ];

    /// The table-0 index.
    pub const fn index(self) -> u8 {
        match self {
            Self::Kbit1000 => 0,
            Self::Kbit800 => 1,
            Self::Kbit500 => 2,
            Self::Kbit250 => 3,
            Self::Kbit125 => 4,
            Self::Kbit100 => 5,
            Self::Kbit50 => 6,
            Self::Kbit20 => 7,
            Self::Kbit10 => 8,
            Self::Auto => 9,
        }
    }

    /// The entry at table-0 index `index`.
    pub const fn from_index(index: u8) -> Option<Self> {
        if (index as usize) < Self::ALL.len() {
            Some(Self::ALL[index as usize])
        } else {
            None
        }
    }

    /// Bits per second, `None` for automatic detection.
    pub const fn bits_per_second(self) -> Option<u32> {
        Some(match self {
            Self::Kbit1000 => 1_000_000,
            Self::Kbit800 => 800_000,
            Self::Kbit500 => 500_000,
            Self::Kbit250 => 250_000,
            Self::Kbit125 => 125_000,
            Self::Kbit100 => 100_000,
            Self::Kbit50 => 50_000,
            Self::Kbit20 => 20_000,
            Self::Kbit10 => 10_000,
            Self::Auto => return None,
        })
    }
}

impl fmt::Display for BitRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.bits_per_second() {
            Some(b) => write!(f, "{} kbit/s", b / 1000),
            None => f.write_str("automatic bit rate detection"),
        }
    }
}

/// The two bytes of configure bit timing: a table selector and an index into that table.
/// Table 0 is the CiA table ([`BitRate`]); 1..=127 are reserved and 128..=255 are
/// manufacturer-specific, so any pair is representable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BitTiming {
    /// Table selector.
    pub table: u8,
    /// Index into the table.
    pub index: u8,
}

impl BitTiming {
    /// The table selector of the CiA bit timing table.
    pub const CIA_TABLE: u8 = 0;

    /// A rate of the CiA table.
    pub const fn standard(rate: BitRate) -> Self {
        Self {
            table: Self::CIA_TABLE,
            index: rate.index(),
        }
    }

    /// The CiA table entry, if this names one.
    pub const fn bit_rate(self) -> Option<BitRate> {
        if self.table == Self::CIA_TABLE {
            BitRate::from_index(self.index)
        } else {
            None
        }
    }
}

impl From<BitRate> for BitTiming {
    fn from(rate: BitRate) -> Self {
        Self::standard(rate)
    }
}

impl fmt::Display for BitTiming {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.bit_rate() {
            Some(rate) => rate.fmt(f),
            None => write!(f, "table {} index {}", self.table, self.index),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn cia_table_matches_the_seed() {
        // SPEC-NOTES §1: 0 = 1M, 1 = 800k, 2 = 500k (the Bürkert default), 3 = 250k, 4 = 125k,
        // 5 = 100k, 6 = 50k, 7 = 20k, 8 = 10k.
        let expect = [
            1_000_000, 800_000, 500_000, 250_000, 125_000, 100_000, 50_000, 20_000, 10_000,
        ];
        for (i, bps) in expect.iter().enumerate() {
            let rate = BitRate::from_index(i as u8).unwrap();
            assert_eq!(rate.bits_per_second(), Some(*bps));
            assert_eq!(rate.index(), i as u8);
        }
        assert_eq!(BitRate::from_index(9), Some(BitRate::Auto));
        assert_eq!(BitRate::from_index(10), None);
        assert_eq!(
            BitTiming::standard(BitRate::Kbit500),
            BitTiming { table: 0, index: 2 }
        );
        assert_eq!(BitTiming { table: 1, index: 2 }.bit_rate(), None);
    }

    #[test]
    fn parts_wrap_in_fastscan_order() {
        assert_eq!(AddressPart::Serial.next(), AddressPart::Vendor);
        for p in AddressPart::ALL {
            assert_eq!(AddressPart::from_index(p.index()), Some(p));
        }
        assert_eq!(AddressPart::from_index(4), None);
        let mut a = LssAddress::default();
        a.set(AddressPart::Revision, 7);
        assert_eq!(a.get(AddressPart::Revision), 7);
        assert_eq!(
            LssAddress::new(1, 2, 3, 0xABCD).to_string(),
            "00000001:00000002:00000003:0000ABCD"
        );
    }
}
