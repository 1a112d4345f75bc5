//! The controlword (0x6040) and the statusword (0x6041), CiA 402-2 §6.1 and §6.3 (Tables of
//! the controlword and statusword bits).
//!
//! Both are `UNSIGNED16` bit sets. The general bits have named constants and accessors here; the
//! operation-mode-specific bits (controlword 4..6, 8, 9; statusword 10, 12, 13) are read and
//! written through the per-mode views of [`crate::mode`].

use core::fmt;

macro_rules! bit_word {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub struct $name(u16);

        impl $name {
            /// The word from its raw value; every value is valid.
            pub const fn from_raw(raw: u16) -> Self {
                Self(raw)
            }
            /// The raw value.
            pub const fn raw(self) -> u16 {
                self.0
            }
            /// Whether every bit of `bits` is set.
            pub const fn contains(self, bits: u16) -> bool {
                self.0 & bits == bits
            }
            /// Whether bit `n` (0..=15) is set; bits above 15 read as clear.
            pub const fn bit(self, n: u32) -> bool {
                n < 16 && self.0 & (1 << n) != 0
            }
            /// The word with `bits` set (`on`) or cleared.
            #[must_use]
            pub const fn with(self, bits: u16, on: bool) -> Self {
                if on { Self(self.0 | bits) } else { Self(self.0 & !bits) }
            }
            /// The little-endian payload of an SDO or PDO.
            pub const fn to_le_bytes(self) -> [u8; 2] {
                self.0.to_le_bytes()
            }
            /// From a little-endian payload.
            pub const fn from_le_bytes(bytes: [u8; 2]) -> Self {
                Self(u16::from_le_bytes(bytes))
            }
        }

        impl From<u16> for $name {
            fn from(raw: u16) -> Self {
                Self(raw)
            }
        }
        impl From<$name> for u16 {
            fn from(w: $name) -> u16 {
                w.0
            }
        }
        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!(stringify!($name), "({:#06x})"), self.0)
            }
        }
        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{:#06x}", self.0)
            }
        }
    };
}

bit_word! {
    /// Controlword 0x6040: the master's commands to the drive.
    Controlword
}

bit_word! {
    /// Statusword 0x6041: the drive's state and status flags.
    Statusword
}

impl Controlword {
    /// Bit 0: switch on.
    pub const SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: enable voltage (a 0 is the "disable voltage" command).
    pub const ENABLE_VOLTAGE: u16 = 1 << 1;
    /// Bit 2: quick stop, active-low (a 0 is the "quick stop" command).
    pub const QUICK_STOP: u16 = 1 << 2;
    /// Bit 3: enable operation.
    pub const ENABLE_OPERATION: u16 = 1 << 3;
    /// Bit 4: operation-mode-specific (pp new set-point, hm start, ip enable, vl ramp enable).
    pub const OMS_4: u16 = 1 << 4;
    /// Bit 5: operation-mode-specific (pp change set immediately, vl ramp unlock).
    pub const OMS_5: u16 = 1 << 5;
    /// Bit 6: operation-mode-specific (pp absolute/relative, vl use reference).
    pub const OMS_6: u16 = 1 << 6;
    /// Bit 7: fault reset, acting on its rising edge.
    pub const FAULT_RESET: u16 = 1 << 7;
    /// Bit 8: halt.
    pub const HALT: u16 = 1 << 8;
    /// Bit 9: operation-mode-specific (pp change on set-point).
    pub const OMS_9: u16 = 1 << 9;
    /// Bits 0..3 and 7: the bits of the device-control commands.
    pub const COMMAND_BITS: u16 = 0x008F;
    /// Bits 4..6, 8 and 9: the bits an operating mode gives a meaning to.
    pub const MODE_BITS: u16 = 0x0370;

    /// The device-control bits (0..3, 7) of this word.
    pub const fn command_bits(self) -> u16 {
        self.0 & Self::COMMAND_BITS
    }
    /// The same word with its device-control bits (0..3, 7) replaced by those of `command`,
    /// keeping the mode-specific and manufacturer bits.
    #[must_use]
    pub const fn with_command_bits(self, command: Controlword) -> Self {
        Self((self.0 & !Self::COMMAND_BITS) | (command.0 & Self::COMMAND_BITS))
    }
    /// Bit 8, halt.
    pub const fn halt(self) -> bool {
        self.contains(Self::HALT)
    }
    /// Bit 7, fault reset (the level; the drive acts on its rising edge).
    pub const fn fault_reset(self) -> bool {
        self.contains(Self::FAULT_RESET)
    }
}

impl Statusword {
    /// Bit 0: ready to switch on.
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: switched on.
    pub const SWITCHED_ON: u16 = 1 << 1;
    /// Bit 2: operation enabled.
    pub const OPERATION_ENABLED: u16 = 1 << 2;
    /// Bit 3: fault.
    pub const FAULT: u16 = 1 << 3;
    /// Bit 4: voltage enabled (high voltage present at the power stage).
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Bit 5: quick stop, active-low (0 = a quick stop is in progress).
    pub const QUICK_STOP: u16 = 1 << 5;
    /// Bit 6: switch on disabled.
    pub const SWITCH_ON_DISABLED: u16 = 1 << 6;
    /// Bit 7: warning.
    pub const WARNING: u16 = 1 << 7;
    /// Bit 8: manufacturer-specific.
    pub const MANUFACTURER_8: u16 = 1 << 8;
    /// Bit 9: remote (the controlword is processed).
    pub const REMOTE: u16 = 1 << 9;
    /// Bit 10: target reached (its exact meaning depends on the mode).
    pub const TARGET_REACHED: u16 = 1 << 10;
    /// Bit 11: internal limit active.
    pub const INTERNAL_LIMIT_ACTIVE: u16 = 1 << 11;
    /// Bit 12: operation-mode-specific.
    pub const OMS_12: u16 = 1 << 12;
    /// Bit 13: operation-mode-specific.
    pub const OMS_13: u16 = 1 << 13;
    /// Bits 0..3, 5 and 6: the bits that code the power state.
    pub const STATE_BITS: u16 = 0x006F;

    /// Bit 3.
    pub const fn fault(self) -> bool {
        self.contains(Self::FAULT)
    }
    /// Bit 4.
    pub const fn voltage_enabled(self) -> bool {
        self.contains(Self::VOLTAGE_ENABLED)
    }
    /// Bit 5 is clear: a quick stop is in progress (the bit is active-low).
    pub const fn quick_stop_active(self) -> bool {
        !self.contains(Self::QUICK_STOP)
    }
    /// Bit 7.
    pub const fn warning(self) -> bool {
        self.contains(Self::WARNING)
    }
    /// Bit 9.
    pub const fn remote(self) -> bool {
        self.contains(Self::REMOTE)
    }
    /// Bit 10, target reached. Read this, not bit 4 (voltage enabled), for the end of a move.
    pub const fn target_reached(self) -> bool {
        self.contains(Self::TARGET_REACHED)
    }
    /// Bit 11.
    pub const fn internal_limit_active(self) -> bool {
        self.contains(Self::INTERNAL_LIMIT_ACTIVE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_bits_are_the_spec_positions() {
        let sw = Statusword::from_raw(0x0637);
        assert!(sw.remote() && sw.target_reached() && sw.voltage_enabled());
        assert!(!sw.quick_stop_active() && !sw.fault() && !sw.warning());
        assert!(Statusword::from_raw(0x0017).quick_stop_active());
        assert!(!sw.bit(16));
        let cw = Controlword::from_raw(0x011F);
        assert!(cw.halt() && !cw.fault_reset());
        assert_eq!(cw.command_bits(), 0x000F);
        assert_eq!(
            cw.with_command_bits(Controlword::from_raw(0x0006)).raw(),
            0x0116
        );
        assert_eq!(Controlword::from_le_bytes([0x1F, 0x01]), cw);
        assert_eq!(std::format!("{cw:?}"), "Controlword(0x011f)");
    }
}
