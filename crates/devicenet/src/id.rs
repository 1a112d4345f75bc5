//! The 11-bit CAN identifier of DeviceNet (ODVA DeviceNet specification, volume 3, "Message
//! Groups", and the Predefined Master/Slave Connection Set's identifier table).
//!
//! ```text
//! bits 10 9 8 7 6 5 4 3 2 1 0        range
//! group 1  0 [msg id 4 ] [ MAC ID 6  ]   0x000..=0x3FF  (MAC = source)
//! group 2  1 0 [ MAC ID 6 ] [msg id 3]   0x400..=0x5FF  (MAC = source or destination)
//! group 3  1 1 [msg 3] [ MAC ID 6  ]     0x600..=0x7BF  (MAC = source; msg id 0..=6)
//! group 4  1 1 1 1 1 [ msg id 6 ]        0x7C0..=0x7EF  (msg id 0..=0x2F)
//! invalid  1 1 1 1 1 1 1 [ x x x x ]      0x7F0..=0x7FF
//! ```
//!
//! [`Predefined`] names the identifiers the Predefined Master/Slave Connection Set uses; the
//! rest of group 1 and group 3 is left to dynamically created connections (not used here).

use core::fmt;

use canola_frame::{CanId, StandardId};

/// A DeviceNet MAC ID (node address), 0..=63.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MacId(u8);

/// A MAC ID above 63.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("MAC ID {0} is out of range (0..=63)")]
pub struct MacIdError(pub u8);

debug_as_display!(MacIdError);

impl MacId {
    /// The address a DeviceNet device ships with (the cPos among them).
    pub const DEFAULT: MacId = MacId(63);

    /// `raw` as a MAC ID, or an error above 63.
    pub const fn new(raw: u8) -> Result<Self, MacIdError> {
        if raw > 63 {
            Err(MacIdError(raw))
        } else {
            Ok(Self(raw))
        }
    }

    /// The low six bits of `raw` (for fields that are six bits wide on the wire).
    pub const fn from_bits(raw: u8) -> Self {
        Self(raw & 0x3F)
    }

    /// The address.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for MacId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "MAC {}", self.0)
    }
}

/// A DeviceNet identifier split into message group, message ID and MAC ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DnId {
    /// Group 1: message ID 0..=15, source MAC ID.
    Group1 {
        /// Message ID (4 bits).
        message: u8,
        /// Source MAC ID.
        mac: MacId,
    },
    /// Group 2: MAC ID (source or destination, by message), message ID 0..=7.
    Group2 {
        /// MAC ID.
        mac: MacId,
        /// Message ID (3 bits).
        message: u8,
    },
    /// Group 3: message ID 0..=6, source MAC ID.
    Group3 {
        /// Message ID (3 bits, 7 is not group 3).
        message: u8,
        /// Source MAC ID.
        mac: MacId,
    },
    /// Group 4: message ID 0..=0x2F.
    Group4 {
        /// Message ID (6 bits, at most 0x2F).
        message: u8,
    },
    /// 0x7F0..=0x7FF: not a valid DeviceNet identifier.
    Invalid(u16),
}

impl DnId {
    /// Splits an 11-bit identifier (bits above 10 are ignored). Total.
    pub const fn from_raw(raw: u16) -> Self {
        let raw = raw & 0x7FF;
        if raw & 0x400 == 0 {
            DnId::Group1 {
                message: (raw >> 6) as u8 & 0x0F,
                mac: MacId::from_bits(raw as u8),
            }
        } else if raw & 0x200 == 0 {
            DnId::Group2 {
                mac: MacId::from_bits((raw >> 3) as u8),
                message: raw as u8 & 0x07,
            }
        } else if raw < 0x7C0 {
            DnId::Group3 {
                message: (raw >> 6) as u8 & 0x07,
                mac: MacId::from_bits(raw as u8),
            }
        } else if raw < 0x7F0 {
            DnId::Group4 {
                message: raw as u8 & 0x3F,
            }
        } else {
            DnId::Invalid(raw)
        }
    }

    /// The 11-bit identifier. Fields wider than their bits are masked (group 3 message 7 and
    /// group 4 messages above 0x2F have no identifier and map into the invalid range).
    pub const fn to_raw(self) -> u16 {
        match self {
            DnId::Group1 { message, mac } => ((message as u16 & 0x0F) << 6) | mac.0 as u16,
            DnId::Group2 { mac, message } => 0x400 | ((mac.0 as u16) << 3) | (message as u16 & 7),
            DnId::Group3 { message, mac } => {
                if message >= 7 {
                    0x7F0
                } else {
                    0x600 | ((message as u16) << 6) | mac.0 as u16
                }
            }
            DnId::Group4 { message } => {
                if message > 0x2F {
                    0x7F0
                } else {
                    0x7C0 | message as u16
                }
            }
            DnId::Invalid(raw) => raw & 0x7FF,
        }
    }

    /// The identifier as a CAN standard identifier.
    pub fn can_id(self) -> CanId {
        match StandardId::new(self.to_raw()) {
            Ok(id) => CanId::Standard(id),
            // to_raw is masked to 11 bits.
            Err(_) => CanId::Standard(StandardId::new(0x7FF).unwrap_or_else(|_| unreachable!())),
        }
    }

    /// The DeviceNet identifier of a frame's CAN identifier; extended identifiers are not
    /// DeviceNet.
    pub const fn of(id: CanId) -> Option<Self> {
        match id.as_standard() {
            Some(raw) => Some(Self::from_raw(raw)),
            None => None,
        }
    }
}

/// Group 1 message ID of the slave's poll response (and COS/cyclic acknowledge).
pub const G1_SLAVE_POLL_RESPONSE: u8 = 0x0F;
/// Group 1 message ID of the slave's bit-strobe response.
pub const G1_SLAVE_BIT_STROBE_RESPONSE: u8 = 0x0E;
/// Group 1 message ID of the slave's change-of-state or cyclic message.
pub const G1_SLAVE_COS_CYCLIC: u8 = 0x0D;
/// Group 1 message ID of the slave's multicast poll response.
pub const G1_SLAVE_MULTICAST_POLL_RESPONSE: u8 = 0x0C;
/// Group 2 message ID of the master's bit-strobe command (MAC = master).
pub const G2_MASTER_BIT_STROBE: u8 = 0;
/// Group 2 message ID of the master's multicast poll command (MAC = master).
pub const G2_MASTER_MULTICAST_POLL: u8 = 1;
/// Group 2 message ID of the master's COS/cyclic acknowledge (MAC = slave).
pub const G2_MASTER_COS_ACK: u8 = 2;
/// Group 2 message ID of the slave's explicit and unconnected responses (MAC = slave).
pub const G2_SLAVE_EXPLICIT_RESPONSE: u8 = 3;
/// Group 2 message ID of the master's explicit requests (MAC = slave).
pub const G2_MASTER_EXPLICIT_REQUEST: u8 = 4;
/// Group 2 message ID of the master's poll command and COS/cyclic messages (MAC = slave).
pub const G2_MASTER_POLL_COMMAND: u8 = 5;
/// Group 2 message ID of the Group 2 Only Unconnected Explicit Request (MAC = slave).
pub const G2_UNCONNECTED_REQUEST: u8 = 6;
/// Group 2 message ID of the Duplicate MAC ID check (MAC = the checked address).
pub const G2_DUPLICATE_MAC_CHECK: u8 = 7;

/// The messages of the Predefined Master/Slave Connection Set, by identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Predefined {
    /// Group 1 0xF: the slave's poll response or COS/cyclic acknowledge (source = slave).
    SlavePollResponse(MacId),
    /// Group 1 0xE: the slave's bit-strobe response.
    SlaveBitStrobeResponse(MacId),
    /// Group 1 0xD: the slave's change-of-state or cyclic message.
    SlaveCosCyclic(MacId),
    /// Group 1 0xC: the slave's multicast poll response.
    SlaveMulticastPollResponse(MacId),
    /// Group 2 0: the master's bit-strobe command (MAC = master).
    MasterBitStrobe(MacId),
    /// Group 2 1: the master's multicast poll command (MAC = master).
    MasterMulticastPoll(MacId),
    /// Group 2 2: the master's COS/cyclic acknowledge (MAC = slave).
    MasterCosAck(MacId),
    /// Group 2 3: the slave's explicit or unconnected response (MAC = slave).
    SlaveExplicitResponse(MacId),
    /// Group 2 4: the master's explicit request (MAC = slave).
    MasterExplicitRequest(MacId),
    /// Group 2 5: the master's poll command or COS/cyclic message (MAC = slave).
    MasterPollCommand(MacId),
    /// Group 2 6: a Group 2 Only Unconnected Explicit Request (MAC = slave).
    UnconnectedRequest(MacId),
    /// Group 2 7: a Duplicate MAC ID check message (MAC = the checked address).
    DuplicateMacCheck(MacId),
}

impl Predefined {
    /// Which predefined message an identifier carries, if any.
    pub const fn from_id(id: DnId) -> Option<Self> {
        Some(match id {
            DnId::Group1 { message, mac } => match message {
                G1_SLAVE_POLL_RESPONSE => Predefined::SlavePollResponse(mac),
                G1_SLAVE_BIT_STROBE_RESPONSE => Predefined::SlaveBitStrobeResponse(mac),
                G1_SLAVE_COS_CYCLIC => Predefined::SlaveCosCyclic(mac),
                G1_SLAVE_MULTICAST_POLL_RESPONSE => Predefined::SlaveMulticastPollResponse(mac),
                _ => return None,
            },
            DnId::Group2 { mac, message } => match message {
                G2_MASTER_BIT_STROBE => Predefined::MasterBitStrobe(mac),
                G2_MASTER_MULTICAST_POLL => Predefined::MasterMulticastPoll(mac),
                G2_MASTER_COS_ACK => Predefined::MasterCosAck(mac),
                G2_SLAVE_EXPLICIT_RESPONSE => Predefined::SlaveExplicitResponse(mac),
                G2_MASTER_EXPLICIT_REQUEST => Predefined::MasterExplicitRequest(mac),
                G2_MASTER_POLL_COMMAND => Predefined::MasterPollCommand(mac),
                G2_UNCONNECTED_REQUEST => Predefined::UnconnectedRequest(mac),
                _ => Predefined::DuplicateMacCheck(mac),
            },
            _ => return None,
        })
    }

    /// The identifier of this message.
    pub fn id(self) -> DnId {
        use Predefined as P;
        let g1 = |message, mac| DnId::Group1 { message, mac };
        let g2 = |mac, message| DnId::Group2 { mac, message };
        match self {
            P::SlavePollResponse(m) => g1(G1_SLAVE_POLL_RESPONSE, m),
            P::SlaveBitStrobeResponse(m) => g1(G1_SLAVE_BIT_STROBE_RESPONSE, m),
            P::SlaveCosCyclic(m) => g1(G1_SLAVE_COS_CYCLIC, m),
            P::SlaveMulticastPollResponse(m) => g1(G1_SLAVE_MULTICAST_POLL_RESPONSE, m),
            P::MasterBitStrobe(m) => g2(m, G2_MASTER_BIT_STROBE),
            P::MasterMulticastPoll(m) => g2(m, G2_MASTER_MULTICAST_POLL),
            P::MasterCosAck(m) => g2(m, G2_MASTER_COS_ACK),
            P::SlaveExplicitResponse(m) => g2(m, G2_SLAVE_EXPLICIT_RESPONSE),
            P::MasterExplicitRequest(m) => g2(m, G2_MASTER_EXPLICIT_REQUEST),
            P::MasterPollCommand(m) => g2(m, G2_MASTER_POLL_COMMAND),
            P::UnconnectedRequest(m) => g2(m, G2_UNCONNECTED_REQUEST),
            P::DuplicateMacCheck(m) => g2(m, G2_DUPLICATE_MAC_CHECK),
        }
    }

    /// The CAN identifier of this message.
    pub fn can_id(self) -> CanId {
        self.id().can_id()
    }
}

impl fmt::Display for Predefined {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Predefined as P;
        let (what, mac) = match *self {
            P::SlavePollResponse(m) => ("poll response from", m),
            P::SlaveBitStrobeResponse(m) => ("bit-strobe response from", m),
            P::SlaveCosCyclic(m) => ("COS/cyclic message from", m),
            P::SlaveMulticastPollResponse(m) => ("multicast poll response from", m),
            P::MasterBitStrobe(m) => ("bit-strobe command from", m),
            P::MasterMulticastPoll(m) => ("multicast poll command from", m),
            P::MasterCosAck(m) => ("COS/cyclic acknowledge to", m),
            P::SlaveExplicitResponse(m) => ("explicit response from", m),
            P::MasterExplicitRequest(m) => ("explicit request to", m),
            P::MasterPollCommand(m) => ("poll command to", m),
            P::UnconnectedRequest(m) => ("unconnected explicit request to", m),
            P::DuplicateMacCheck(m) => ("duplicate MAC ID check of", m),
        };
        write!(f, "{what} {mac}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mac(n: u8) -> MacId {
        MacId::new(n).unwrap()
    }

    #[test]
    fn group_boundaries() {
        assert_eq!(
            DnId::from_raw(0x000),
            DnId::Group1 {
                message: 0,
                mac: mac(0)
            }
        );
        assert_eq!(
            DnId::from_raw(0x3FF),
            DnId::Group1 {
                message: 15,
                mac: mac(63)
            }
        );
        assert_eq!(
            DnId::from_raw(0x400),
            DnId::Group2 {
                mac: mac(0),
                message: 0
            }
        );
        assert_eq!(
            DnId::from_raw(0x5FF),
            DnId::Group2 {
                mac: mac(63),
                message: 7
            }
        );
        assert_eq!(
            DnId::from_raw(0x600),
            DnId::Group3 {
                message: 0,
                mac: mac(0)
            }
        );
        assert_eq!(
            DnId::from_raw(0x7BF),
            DnId::Group3 {
                message: 6,
                mac: mac(63)
            }
        );
        assert_eq!(DnId::from_raw(0x7C0), DnId::Group4 { message: 0 });
        assert_eq!(DnId::from_raw(0x7EF), DnId::Group4 { message: 0x2F });
        assert_eq!(DnId::from_raw(0x7F0), DnId::Invalid(0x7F0));
        assert_eq!(DnId::from_raw(0x7FF), DnId::Invalid(0x7FF));
    }

    #[test]
    fn predefined_identifiers_of_mac_63() {
        // The identifier table of the Predefined Master/Slave Connection Set, MAC 63 = 0b111111.
        let m = mac(63);
        let cases = [
            (Predefined::SlavePollResponse(m), 0x3FF),
            (Predefined::SlaveCosCyclic(m), 0x37F),
            (Predefined::SlaveBitStrobeResponse(m), 0x3BF),
            (Predefined::SlaveMulticastPollResponse(m), 0x33F),
            (Predefined::SlaveExplicitResponse(m), 0x5FB),
            (Predefined::MasterExplicitRequest(m), 0x5FC),
            (Predefined::MasterPollCommand(m), 0x5FD),
            (Predefined::UnconnectedRequest(m), 0x5FE),
            (Predefined::DuplicateMacCheck(m), 0x5FF),
            (Predefined::MasterBitStrobe(mac(0)), 0x400),
            (Predefined::MasterMulticastPoll(mac(0)), 0x401),
            (Predefined::MasterCosAck(mac(1)), 0x40A),
        ];
        for (p, raw) in cases {
            assert_eq!(p.id().to_raw(), raw, "{p}");
            assert_eq!(Predefined::from_id(DnId::from_raw(raw)), Some(p));
        }
        assert_eq!(Predefined::from_id(DnId::from_raw(0x000)), None);
        assert_eq!(Predefined::from_id(DnId::from_raw(0x600)), None);
    }

    #[test]
    fn mac_range() {
        assert!(MacId::new(63).is_ok());
        assert_eq!(MacId::new(64), Err(MacIdError(64)));
    }

    proptest::proptest! {
        #[test]
        fn raw_round_trip(raw in 0u16..0x800) {
            proptest::prop_assert_eq!(DnId::from_raw(raw).to_raw(), raw);
        }
    }
}
