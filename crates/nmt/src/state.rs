//! NMT states (CiA 301 §7.3.2): the state byte carried by heartbeat and node-guarding messages,
//! and the device-side state with the services each state allows (CiA 301 §7.3.2.2, table
//! "states and communication objects").

/// The NMT state as transmitted in a heartbeat or node-guarding message (CiA 301 §7.2.8.3.2).
///
/// Every byte maps to a variant; unknown values are kept, so decode-encode round trips are
/// lossless.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NmtState {
    /// 0x00: the boot-up message (the node has just finished initialisation).
    BootUp,
    /// 0x04: Stopped.
    Stopped,
    /// 0x05: Operational.
    Operational,
    /// 0x7F: Pre-operational.
    PreOperational,
    /// Any other value, kept as received.
    Unknown(u8),
}

impl NmtState {
    /// The wire value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::BootUp => 0x00,
            Self::Stopped => 0x04,
            Self::Operational => 0x05,
            Self::PreOperational => 0x7F,
            Self::Unknown(v) => v,
        }
    }

    /// From the wire value.
    pub const fn from_u8(v: u8) -> Self {
        match v {
            0x00 => Self::BootUp,
            0x04 => Self::Stopped,
            0x05 => Self::Operational,
            0x7F => Self::PreOperational,
            v => Self::Unknown(v),
        }
    }
}

impl From<u8> for NmtState {
    fn from(v: u8) -> Self {
        Self::from_u8(v)
    }
}

impl From<NmtState> for u8 {
    fn from(s: NmtState) -> u8 {
        s.to_u8()
    }
}

impl core::fmt::Display for NmtState {
    /// The CiA 301 state names: `Operational`, `Pre-operational`, `Stopped`; `boot-up` for the
    /// boot-up byte and `unknown state 0x42` for any other.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BootUp => f.write_str("boot-up"),
            Self::Stopped => f.write_str("Stopped"),
            Self::Operational => f.write_str("Operational"),
            Self::PreOperational => f.write_str("Pre-operational"),
            Self::Unknown(v) => write!(f, "unknown state {v:#04x}"),
        }
    }
}

/// The NMT state of a device (the NMT slave state machine of CiA 301 §7.3.2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeviceState {
    /// Initialisation: after power-on, reset node or reset communication, until the boot-up
    /// message has been sent.
    Initialising,
    /// Pre-operational: SDO, SYNC, TIME, EMCY, NMT and error control; no PDOs.
    PreOperational,
    /// Operational: every service.
    Operational,
    /// Stopped: only NMT and error control (heartbeat, node guarding).
    Stopped,
}

impl core::fmt::Display for DeviceState {
    /// The CiA 301 state names: `Initialisation`, `Pre-operational`, `Operational`, `Stopped`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Initialising => "Initialisation",
            Self::PreOperational => "Pre-operational",
            Self::Operational => "Operational",
            Self::Stopped => "Stopped",
        })
    }
}

impl core::fmt::Display for Service {
    /// `PDO`, `SDO`, `SYNC`, `TIME`, `EMCY`, `boot-up`, `NMT`, `error control`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Pdo => "PDO",
            Self::Sdo => "SDO",
            Self::Sync => "SYNC",
            Self::Time => "TIME",
            Self::Emcy => "EMCY",
            Self::BootUp => "boot-up",
            Self::Nmt => "NMT",
            Self::ErrorControl => "error control",
        })
    }
}

/// A communication service whose availability depends on the NMT state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Service {
    /// Process data objects.
    Pdo,
    /// Service data objects.
    Sdo,
    /// SYNC production and consumption.
    Sync,
    /// TIME production and consumption.
    Time,
    /// Emergency messages.
    Emcy,
    /// The boot-up message.
    BootUp,
    /// NMT module control (reception of NMT commands).
    Nmt,
    /// Error control: heartbeat and node guarding.
    ErrorControl,
}

impl DeviceState {
    /// Whether `service` may be used in this state (CiA 301 §7.3.2.2).
    pub const fn allows(self, service: Service) -> bool {
        use Service::*;
        match self {
            Self::Initialising => matches!(service, BootUp),
            Self::PreOperational => !matches!(service, Pdo | BootUp),
            Self::Operational => !matches!(service, BootUp),
            Self::Stopped => matches!(service, Nmt | ErrorControl),
        }
    }

    /// The state byte this device puts into heartbeat and node-guarding messages.
    pub const fn wire(self) -> NmtState {
        match self {
            Self::Initialising => NmtState::BootUp,
            Self::PreOperational => NmtState::PreOperational,
            Self::Operational => NmtState::Operational,
            Self::Stopped => NmtState::Stopped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_bytes() {
        for (b, s) in [
            (0x00, NmtState::BootUp),
            (0x04, NmtState::Stopped),
            (0x05, NmtState::Operational),
            (0x7F, NmtState::PreOperational),
            (0x42, NmtState::Unknown(0x42)),
        ] {
            assert_eq!(NmtState::from_u8(b), s);
            assert_eq!(s.to_u8(), b);
        }
        for b in 0..=255u8 {
            assert_eq!(NmtState::from_u8(b).to_u8(), b);
        }
        extern crate std;
        use std::string::ToString;
        assert_eq!(NmtState::PreOperational.to_string(), "Pre-operational");
        assert_eq!(NmtState::Operational.to_string(), "Operational");
        assert_eq!(NmtState::Stopped.to_string(), "Stopped");
        assert_eq!(NmtState::BootUp.to_string(), "boot-up");
        assert_eq!(NmtState::Unknown(0x42).to_string(), "unknown state 0x42");
        assert_eq!(DeviceState::Initialising.to_string(), "Initialisation");
        assert_eq!(DeviceState::PreOperational.to_string(), "Pre-operational");
        assert_eq!(Service::ErrorControl.to_string(), "error control");
    }

    #[test]
    fn services_per_state() {
        use DeviceState::*;
        use Service::*;
        let all = [Pdo, Sdo, Sync, Time, Emcy, BootUp, Nmt, ErrorControl];
        let allowed = |s: DeviceState| all.iter().filter(|&&x| s.allows(x)).count();
        assert!(Operational.allows(Pdo) && Operational.allows(Sdo));
        assert!(!PreOperational.allows(Pdo) && PreOperational.allows(Sdo));
        assert!(PreOperational.allows(Emcy) && PreOperational.allows(Sync));
        assert!(!Stopped.allows(Sdo) && !Stopped.allows(Emcy) && !Stopped.allows(Pdo));
        assert!(Stopped.allows(Nmt) && Stopped.allows(ErrorControl));
        assert!(Initialising.allows(BootUp) && !Initialising.allows(Nmt));
        assert_eq!(allowed(Initialising), 1);
        assert_eq!(allowed(PreOperational), 6);
        assert_eq!(allowed(Operational), 7);
        assert_eq!(allowed(Stopped), 2);
    }
}
