//! The CiA 302-2 boot error codes: the letter the "boot slave" process ends with when a slave
//! cannot be booted, and what each letter means.

/// A CiA 302-2 boot slave error code (`A` .. `O`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BootErrorCode {
    /// The device is not listed in the slave assignment 0x1F81.
    A,
    /// No response to the upload of 0x1000 (device type).
    B,
    /// 0x1000 differs from the expected device type 0x1F84.
    C,
    /// 0x1018:01 differs from the expected vendor-ID 0x1F85.
    D,
    /// Heartbeat event: no heartbeat from the device.
    E,
    /// Node guarding event: no answer to a guarding request.
    F,
    /// The objects for program download are not configured or inconsistent.
    G,
    /// A software update is required but not allowed.
    H,
    /// A software update is required but the program download failed.
    I,
    /// The configuration download failed.
    J,
    /// No heartbeat while starting the error control service.
    K,
    /// The device was operational already at the start of its boot.
    L,
    /// 0x1018:02 differs from the expected product code 0x1F86.
    M,
    /// 0x1018:03 differs from the expected revision number 0x1F87.
    N,
    /// 0x1018:04 differs from the expected serial number 0x1F88.
    O,
}

impl BootErrorCode {
    /// Every code, `A` to `O`.
    pub const ALL: [Self; 15] = [
        Self::A,
        Self::B,
        Self::C,
        Self::D,
        Self::E,
        Self::F,
        Self::G,
        Self::H,
        Self::I,
        Self::J,
        Self::K,
        Self::L,
        Self::M,
        Self::N,
        Self::O,
    ];

    /// The letter.
    pub fn letter(self) -> char {
        (b'A' + Self::ALL.iter().position(|&c| c == self).unwrap_or(0) as u8) as char
    }

    /// The code for a letter (either case).
    pub fn from_letter(c: char) -> Option<Self> {
        let i = (c.to_ascii_uppercase() as u32).checked_sub('A' as u32)?;
        Self::ALL.get(i as usize).copied()
    }

    /// What the code means (CiA 302-2).
    pub fn meaning(self) -> &'static str {
        match self {
            Self::A => "the device is not listed in the slave assignment (0x1F81)",
            Self::B => "no response to the upload of the device type (0x1000)",
            Self::C => "device type (0x1000) differs from the expected one (0x1F84)",
            Self::D => "vendor-ID (0x1018:01) differs from the expected one (0x1F85)",
            Self::E => "heartbeat event: no heartbeat received from the device",
            Self::F => "node guarding event: no answer to a guarding request",
            Self::G => "objects for program download not configured or inconsistent",
            Self::H => "software update required but not allowed",
            Self::I => "software update required but the program download failed",
            Self::J => "configuration download failed",
            Self::K => "no heartbeat received while starting the error control service",
            Self::L => "the device was already operational when its boot began",
            Self::M => "product code (0x1018:02) differs from the expected one (0x1F86)",
            Self::N => "revision number (0x1018:03) differs from the expected one (0x1F87)",
            Self::O => "serial number (0x1018:04) differs from the expected one (0x1F88)",
        }
    }
}

impl core::fmt::Display for BootErrorCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}", self.letter())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_round_trip() {
        for (i, c) in BootErrorCode::ALL.iter().enumerate() {
            let letter = (b'A' + i as u8) as char;
            assert_eq!(c.letter(), letter);
            assert_eq!(BootErrorCode::from_letter(letter), Some(*c));
        }
        assert_eq!(BootErrorCode::from_letter('P'), None);
        assert_eq!(BootErrorCode::from_letter('@'), None);
    }
}
