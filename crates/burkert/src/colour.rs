//! Bürkert LED colour codes (manual §1.6), the values of objects 0x2121 and 0x2122.
//!
//! A colour is an UNSIGNED32: either one of seven predefined codes 0x10000000..=0x10000006, or a
//! user-defined RGB value `0x00BBGGRR` (blue, green, red, each 0..=255). Every other value
//! (a high byte other than 0x00 and 0x10, or 0x10000007 and above) is reserved and rejected.

use core::fmt;

/// The predefined colours, with their codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PredefinedColour {
    /// 0x10000000 — LED off.
    Off,
    /// 0x10000001.
    White,
    /// 0x10000002.
    Green,
    /// 0x10000003.
    Blue,
    /// 0x10000004.
    Yellow,
    /// 0x10000005.
    Orange,
    /// 0x10000006.
    Red,
}

/// A colour the status LED can show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LedColour {
    /// One of the predefined codes.
    Predefined(PredefinedColour),
    /// A user-defined colour, sent as `0x00BBGGRR`.
    Rgb {
        /// Red, 0..=255.
        r: u8,
        /// Green, 0..=255.
        g: u8,
        /// Blue, 0..=255.
        b: u8,
    },
}

/// A colour value that is not a Bürkert colour code.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ColourError {
    /// A reserved UNSIGNED32 code.
    #[error(
        "{0:#010x} is not a Bürkert colour code (predefined 0x10000000..=0x10000006 or RGB 0x00BBGGRR)"
    )]
    Reserved(u32),
    /// A colour name that is neither predefined nor `#RRGGBB`.
    #[error("unknown colour name (use off, white, green, blue, yellow, orange, red or #RRGGBB)")]
    UnknownName,
}

debug_as_display!(ColourError);

const PREDEFINED_BASE: u32 = 0x1000_0000;

impl PredefinedColour {
    /// All predefined colours in code order.
    pub const ALL: [PredefinedColour; 7] = [
        Self::Off,
        Self::White,
        Self::Green,
        Self::Blue,
        Self::Yellow,
        Self::Orange,
        Self::Red,
    ];

    /// The UNSIGNED32 code.
    pub const fn code(self) -> u32 {
        PREDEFINED_BASE + self as u32
    }

    /// English name, lower case (as the CLI accepts it).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::White => "white",
            Self::Green => "green",
            Self::Blue => "blue",
            Self::Yellow => "yellow",
            Self::Orange => "orange",
            Self::Red => "red",
        }
    }

    /// German name, as the manual has it.
    pub const fn name_de(self) -> &'static str {
        match self {
            Self::Off => "aus",
            Self::White => "weiß",
            Self::Green => "grün",
            Self::Blue => "blau",
            Self::Yellow => "gelb",
            Self::Orange => "orange",
            Self::Red => "rot",
        }
    }

    /// An approximate RGB rendering, for drawing the LED on a terminal.
    pub const fn approx_rgb(self) -> (u8, u8, u8) {
        match self {
            Self::Off => (0, 0, 0),
            Self::White => (255, 255, 255),
            Self::Green => (0, 200, 0),
            Self::Blue => (0, 80, 255),
            Self::Yellow => (255, 220, 0),
            Self::Orange => (255, 140, 0),
            Self::Red => (230, 0, 0),
        }
    }
}

impl LedColour {
    /// LED off.
    pub const OFF: LedColour = LedColour::Predefined(PredefinedColour::Off);

    /// A user RGB colour.
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Self::Rgb { r, g, b }
    }

    /// Decodes an object value; reserved codes are an error.
    pub const fn from_u32(raw: u32) -> Result<Self, ColourError> {
        match raw >> 24 {
            0x00 => Ok(Self::Rgb {
                r: raw as u8,
                g: (raw >> 8) as u8,
                b: (raw >> 16) as u8,
            }),
            0x10 if raw - PREDEFINED_BASE < 7 => Ok(Self::Predefined(
                PredefinedColour::ALL[(raw - PREDEFINED_BASE) as usize],
            )),
            _ => Err(ColourError::Reserved(raw)),
        }
    }

    /// The object value.
    pub const fn to_u32(self) -> u32 {
        match self {
            Self::Predefined(p) => p.code(),
            Self::Rgb { r, g, b } => (b as u32) << 16 | (g as u32) << 8 | r as u32,
        }
    }

    /// Parses a predefined name (English or German, any case) or `#RRGGBB`.
    pub fn from_name(name: &str) -> Result<Self, ColourError> {
        let name = name.trim();
        for p in PredefinedColour::ALL {
            if name.eq_ignore_ascii_case(p.name()) || name.eq_ignore_ascii_case(p.name_de()) {
                return Ok(Self::Predefined(p));
            }
        }
        let hex = name.strip_prefix('#').ok_or(ColourError::UnknownName)?;
        if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(ColourError::UnknownName);
        }
        let v = u32::from_str_radix(hex, 16).map_err(|_| ColourError::UnknownName)?;
        Ok(Self::rgb((v >> 16) as u8, (v >> 8) as u8, v as u8))
    }

    /// Some devices support only 0 and 255 for the blue channel (manual §1.6). This rounds blue
    /// to the nearer of the two (128 and above becomes 255) and leaves everything else alone.
    pub const fn quantise_blue(self) -> Self {
        match self {
            Self::Rgb { r, g, b } => Self::Rgb {
                r,
                g,
                b: if b >= 128 { 255 } else { 0 },
            },
            p => p,
        }
    }

    /// An RGB rendering for a terminal (exact for user colours, approximate for predefined).
    pub const fn approx_rgb(self) -> (u8, u8, u8) {
        match self {
            Self::Predefined(p) => p.approx_rgb(),
            Self::Rgb { r, g, b } => (r, g, b),
        }
    }
}

impl From<PredefinedColour> for LedColour {
    fn from(p: PredefinedColour) -> Self {
        Self::Predefined(p)
    }
}

impl TryFrom<u32> for LedColour {
    type Error = ColourError;
    fn try_from(raw: u32) -> Result<Self, ColourError> {
        Self::from_u32(raw)
    }
}

impl From<LedColour> for u32 {
    fn from(c: LedColour) -> u32 {
        c.to_u32()
    }
}

impl fmt::Display for LedColour {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Predefined(p) => f.write_str(p.name()),
            Self::Rgb { r, g, b } => write!(f, "#{r:02X}{g:02X}{b:02X}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn manual_codes() {
        let table = [
            ("aus", 0x1000_0000),
            ("weiß", 0x1000_0001),
            ("grün", 0x1000_0002),
            ("blau", 0x1000_0003),
            ("gelb", 0x1000_0004),
            ("orange", 0x1000_0005),
            ("rot", 0x1000_0006),
        ];
        for (name, code) in table {
            let c = LedColour::from_name(name).unwrap();
            assert_eq!(c.to_u32(), code, "{name}");
            assert_eq!(LedColour::from_u32(code), Ok(c));
        }
    }

    #[test]
    fn manual_rgb_examples() {
        // turquoise 0x00FFFF00: blue 0xFF, green 0xFF, red 0x00; pink 0x00FF00FF.
        assert_eq!(
            LedColour::from_u32(0x00FF_FF00),
            Ok(LedColour::rgb(0, 255, 255))
        );
        assert_eq!(
            LedColour::from_u32(0x00FF_00FF),
            Ok(LedColour::rgb(255, 0, 255))
        );
        assert_eq!(
            LedColour::from_name("#00FFFF").unwrap().to_u32(),
            0x00FF_FF00
        );
    }

    #[test]
    fn reserved_codes_rejected() {
        for raw in [
            0x1000_0007,
            0x1000_00FF,
            0x0100_0000,
            0x2000_0000,
            0xFFFF_FFFF,
        ] {
            assert_eq!(LedColour::from_u32(raw), Err(ColourError::Reserved(raw)));
        }
        assert_eq!(
            LedColour::from_name("purple"),
            Err(ColourError::UnknownName)
        );
        assert_eq!(
            LedColour::from_name("#12345"),
            Err(ColourError::UnknownName)
        );
    }

    #[test]
    fn blue_quantisation() {
        assert_eq!(
            LedColour::rgb(1, 2, 127).quantise_blue(),
            LedColour::rgb(1, 2, 0)
        );
        assert_eq!(
            LedColour::rgb(1, 2, 128).quantise_blue(),
            LedColour::rgb(1, 2, 255)
        );
        assert_eq!(LedColour::OFF.quantise_blue(), LedColour::OFF);
    }

    proptest! {
        #[test]
        fn u32_round_trip(raw in any::<u32>()) {
            if let Ok(c) = LedColour::from_u32(raw) {
                prop_assert_eq!(c.to_u32(), raw);
            }
        }
    }
}
