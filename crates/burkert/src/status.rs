//! Object 0x2004, device status: NE 107 status, temperatures (kelvin), voltages, currents,
//! counters and the transferable-memory status.

use core::fmt;

use crate::ne107::Ne107Status;

/// 0 °C in kelvin.
const ZERO_CELSIUS_K: f32 = 273.15;

/// A temperature as the device reports it, in kelvin.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Kelvin(pub f32);

impl Kelvin {
    /// In degrees Celsius.
    pub fn celsius(self) -> f32 {
        self.0 - ZERO_CELSIUS_K
    }

    /// From degrees Celsius.
    pub fn from_celsius(c: f32) -> Self {
        Self(c + ZERO_CELSIUS_K)
    }
}

impl fmt::Display for Kelvin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.2} K ({:.1} °C)", self.0, self.celsius())
    }
}

/// 0x2004 sub 0x0E: transferable-memory status (values 0..=11 of the manual; others kept).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TransMemStatus {
    /// 0 — unknown status.
    Unknown,
    /// 1 — memory available.
    Available,
    /// 2 — memory not available.
    NotAvailable,
    /// 3 — memory not available (the manual lists the same meaning twice; the code is kept).
    NotAvailableAlt,
    /// 4 — memory optional.
    Optional,
    /// 5 — memory in progress.
    InProgress,
    /// 6 — device searching for a provider.
    SearchingProvider,
    /// 7 — device managed by a provider.
    ManagedByProvider,
    /// 8 — changes present.
    ChangesPresent,
    /// 9 — provider search switched off.
    ProviderSearchOff,
    /// 10 — device waiting for a provider.
    WaitingForProvider,
    /// 11 — device was reconfigured.
    Reconfigured,
    /// A value above 11.
    Other(u8),
}

impl TransMemStatus {
    /// Decodes the object value.
    pub const fn from_u8(v: u8) -> Self {
        match v {
            0 => Self::Unknown,
            1 => Self::Available,
            2 => Self::NotAvailable,
            3 => Self::NotAvailableAlt,
            4 => Self::Optional,
            5 => Self::InProgress,
            6 => Self::SearchingProvider,
            7 => Self::ManagedByProvider,
            8 => Self::ChangesPresent,
            9 => Self::ProviderSearchOff,
            10 => Self::WaitingForProvider,
            11 => Self::Reconfigured,
            other => Self::Other(other),
        }
    }

    /// The object value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::Unknown => 0,
            Self::Available => 1,
            Self::NotAvailable => 2,
            Self::NotAvailableAlt => 3,
            Self::Optional => 4,
            Self::InProgress => 5,
            Self::SearchingProvider => 6,
            Self::ManagedByProvider => 7,
            Self::ChangesPresent => 8,
            Self::ProviderSearchOff => 9,
            Self::WaitingForProvider => 10,
            Self::Reconfigured => 11,
            Self::Other(v) => v,
        }
    }

    /// English meaning.
    pub const fn meaning(self) -> &'static str {
        match self {
            Self::Unknown => "unknown status",
            Self::Available => "memory available",
            Self::NotAvailable | Self::NotAvailableAlt => "memory not available",
            Self::Optional => "memory optional",
            Self::InProgress => "memory in progress",
            Self::SearchingProvider => "device searching for a provider",
            Self::ManagedByProvider => "device managed by a provider",
            Self::ChangesPresent => "changes present",
            Self::ProviderSearchOff => "provider search switched off",
            Self::WaitingForProvider => "device waiting for a provider",
            Self::Reconfigured => "device was reconfigured",
            Self::Other(_) => "undefined transferable-memory status",
        }
    }
}

/// The readable part of 0x2004 in one value. Fields a device does not implement are `None`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DeviceStatus {
    /// Sub 1.
    pub ne107: Option<Ne107Status>,
    /// Sub 2, device temperature.
    pub temperature: Option<Kelvin>,
    /// Sub 3, supply voltage in V.
    pub supply_voltage: Option<f32>,
    /// Sub 4, operation time in s.
    pub operation_time_s: Option<u32>,
    /// Sub 5, highest temperature ever measured (whole kelvin).
    pub max_temperature_k: Option<u16>,
    /// Sub 6, lowest temperature ever measured (whole kelvin).
    pub min_temperature_k: Option<u16>,
    /// Sub 7, highest supply voltage ever measured, V.
    pub max_voltage: Option<f32>,
    /// Sub 8, lowest supply voltage ever measured, V.
    pub min_voltage: Option<f32>,
    /// Sub 0x0A, device current in A.
    pub current: Option<f32>,
    /// Sub 0x0B, highest current, A.
    pub max_current: Option<f32>,
    /// Sub 0x0C, lowest current, A.
    pub min_current: Option<f32>,
    /// Sub 0x0D, boot counter.
    pub boot_counter: Option<u32>,
    /// Sub 0x0E, transferable memory status.
    pub trans_mem: Option<TransMemStatus>,
    /// Sub 0x10, battery voltage, V.
    pub battery_voltage: Option<f32>,
    /// Sub 0x11, voltage drops since the last start.
    pub voltage_drop_counter: Option<u32>,
    /// Sub 0x12, operation time since the last boot, s.
    pub time_since_boot_s: Option<u32>,
    /// Sub 0x13, actuator supply voltage, V.
    pub actuator_voltage: Option<f32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trans_mem_table() {
        for v in 0..=11u8 {
            let s = TransMemStatus::from_u8(v);
            assert!(!matches!(s, TransMemStatus::Other(_)), "{v}");
            assert_eq!(s.to_u8(), v);
        }
        assert_eq!(TransMemStatus::from_u8(12), TransMemStatus::Other(12));
        assert_eq!(
            TransMemStatus::from_u8(3).meaning(),
            TransMemStatus::from_u8(2).meaning()
        );
    }

    #[test]
    fn kelvin_celsius() {
        assert!((Kelvin(293.15).celsius() - 20.0).abs() < 1e-4);
        assert!((Kelvin::from_celsius(-40.0).0 - 233.15).abs() < 1e-4);
    }
}
