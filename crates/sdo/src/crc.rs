//! CRC-16-CCITT as SDO block transfer uses it (CiA 301 §7.2.4.3.16): polynomial
//! x^16 + x^12 + x^5 + 1 (0x1021), initial value 0, no reflection, no final XOR (the variant
//! also known as CRC-16/XMODEM). The CRC covers the object's data bytes only, not the padding of
//! the last segment.

/// One byte-step lookup table, computed at compile time.
const TABLE: [u16; 256] = {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
};

/// An incremental CRC-16-CCITT computation, for data that arrives in pieces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Crc16(u16);

impl Crc16 {
    /// A fresh computation (initial value 0).
    pub const fn new() -> Self {
        Self(0)
    }

    /// Feeds more bytes.
    pub fn update(&mut self, data: &[u8]) {
        let mut crc = self.0;
        for &byte in data {
            let pos = ((crc >> 8) as u8) ^ byte;
            crc = (crc << 8) ^ TABLE[usize::from(pos)];
        }
        self.0 = crc;
    }

    /// The CRC of everything fed so far.
    pub const fn get(self) -> u16 {
        self.0
    }
}

/// The CRC-16-CCITT of `data` in one call.
pub fn crc16(data: &[u8]) -> u16 {
    let mut crc = Crc16::new();
    crc.update(data);
    crc.get()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-by-bit reference to check the table against.
    fn bitwise(data: &[u8]) -> u16 {
        let mut crc = 0u16;
        for &b in data {
            crc ^= u16::from(b) << 8;
            for _ in 0..8 {
                crc = if crc & 0x8000 != 0 {
                    (crc << 1) ^ 0x1021
                } else {
                    crc << 1
                };
            }
        }
        crc
    }

    #[test]
    fn check_values() {
        // The standard check value of CRC-16/XMODEM.
        assert_eq!(crc16(b"123456789"), 0x31C3);
        assert_eq!(crc16(b""), 0x0000);
        assert_eq!(crc16(&[0x00]), 0x0000);
        assert_eq!(crc16(b"A"), 0x58E5);
        assert_eq!(crc16(&[0xFF, 0xFF]), 0x1D0F);
    }

    #[test]
    fn incremental_equals_one_shot() {
        let data: [u8; 100] = core::array::from_fn(|i| (i * 37 + 11) as u8);
        let mut crc = Crc16::new();
        for chunk in data.chunks(7) {
            crc.update(chunk);
        }
        assert_eq!(crc.get(), crc16(&data));
        assert_eq!(crc.get(), bitwise(&data));
    }
}
