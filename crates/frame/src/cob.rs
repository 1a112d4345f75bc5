//! The predefined connection set (CiA 301 §7.3.5, LSS from CiA 305 §4.2): the default COB-ID
//! of every communication object, split into a function code and a node-ID and joined again.
//!
//! | function            | COB-ID         |
//! |---------------------|----------------|
//! | NMT                 | 0x000          |
//! | SYNC                | 0x080          |
//! | EMCY                | 0x080 + node   |
//! | TIME                | 0x100          |
//! | TPDO1 / RPDO1       | 0x180 / 0x200 + node |
//! | TPDO2 / RPDO2       | 0x280 / 0x300 + node |
//! | TPDO3 / RPDO3       | 0x380 / 0x400 + node |
//! | TPDO4 / RPDO4       | 0x480 / 0x500 + node |
//! | SDO server → client | 0x580 + node   |
//! | SDO client → server | 0x600 + node   |
//! | NMT error control (heartbeat, boot-up, node guarding) | 0x700 + node |
//! | LSS slave → master  | 0x7E4          |
//! | LSS master → slave  | 0x7E5          |
//!
//! Devices may be configured to use other COB-IDs (PDO and SDO parameters, 0x1005, 0x1014);
//! routing by configured COB-ID happens in the master, not here.

use core::fmt;

use crate::node::NodeId;

/// COB-ID of NMT module control.
pub const NMT: u16 = 0x000;
/// Default COB-ID of SYNC.
pub const SYNC: u16 = 0x080;
/// Default COB-ID of TIME.
pub const TIME: u16 = 0x100;
/// LSS responses, slave to master.
pub const LSS_SLAVE_TO_MASTER: u16 = 0x7E4;
/// LSS requests, master to slave.
pub const LSS_MASTER_TO_SLAVE: u16 = 0x7E5;

/// The CAN identifiers CiA 301 (§7.3.5, restricted CAN-IDs) reserves for the predefined
/// connection set's own use, as inclusive ranges: NMT, the node-ID-less reserve below SYNC,
/// the reserve after TIME, the default SDO channel, the reserve below NMT error control, NMT
/// error control, and the LSS and reserved identifiers at the top. A configurable COB-ID (a
/// PDO, EMCY, SYNC or TIME COB-ID) must not take one of them: a device transmitting there
/// would be read as NMT commands, SDO traffic or heartbeats.
pub const RESTRICTED: [(u16, u16); 8] = [
    (0x000, 0x000),
    (0x001, 0x07F),
    (0x101, 0x180),
    (0x581, 0x5FF),
    (0x601, 0x67F),
    (0x6E0, 0x6FF),
    (0x701, 0x77F),
    (0x780, 0x7FF),
];

/// Whether the 11-bit CAN identifier `can_id` is one CiA 301 restricts (see [`RESTRICTED`]).
/// Identifiers above 0x7FF are not 11-bit identifiers and are not restricted here.
pub const fn is_restricted(can_id: u16) -> bool {
    let mut i = 0;
    while i < RESTRICTED.len() {
        let (low, high) = RESTRICTED[i];
        if can_id >= low && can_id <= high {
            return true;
        }
        i += 1;
    }
    false
}

/// The communication object a COB-ID of the predefined connection set belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FunctionCode {
    /// NMT module control, 0x000 (no node-ID; the target node is in the data).
    Nmt,
    /// SYNC, 0x080.
    Sync,
    /// Emergency, 0x080 + node.
    Emcy,
    /// TIME stamp, 0x100.
    Time,
    /// Transmit PDO 1..=4 (produced by the node), 0x180/0x280/0x380/0x480 + node.
    Tpdo(PdoNumber),
    /// Receive PDO 1..=4 (consumed by the node), 0x200/0x300/0x400/0x500 + node.
    Rpdo(PdoNumber),
    /// SDO server to client (responses), 0x580 + node.
    SdoTx,
    /// SDO client to server (requests), 0x600 + node.
    SdoRx,
    /// NMT error control: heartbeat, boot-up and node guarding, 0x700 + node.
    NmtErrorControl,
    /// LSS slave to master, 0x7E4.
    LssSlaveToMaster,
    /// LSS master to slave, 0x7E5.
    LssMasterToSlave,
}

/// One of the four PDOs the predefined connection set gives default COB-IDs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PdoNumber {
    /// PDO 1.
    One = 1,
    /// PDO 2.
    Two = 2,
    /// PDO 3.
    Three = 3,
    /// PDO 4.
    Four = 4,
}

impl PdoNumber {
    /// From 1..=4.
    pub const fn new(n: u8) -> Option<Self> {
        match n {
            1 => Some(Self::One),
            2 => Some(Self::Two),
            3 => Some(Self::Three),
            4 => Some(Self::Four),
            _ => None,
        }
    }

    /// 1..=4.
    pub const fn get(self) -> u8 {
        self as u8
    }
}

/// A COB-ID of the predefined connection set: the function and, for per-node objects, the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CobId {
    /// Which communication object.
    pub function: FunctionCode,
    /// The node it belongs to; `None` for NMT, SYNC, TIME and LSS.
    pub node: Option<NodeId>,
}

impl CobId {
    /// A per-node COB-ID, e.g. `CobId::node(FunctionCode::SdoRx, id)` for 0x600 + id.
    pub const fn node(function: FunctionCode, node: NodeId) -> Self {
        Self {
            function,
            node: Some(node),
        }
    }

    /// Classifies an 11-bit COB-ID. Returns `None` for identifiers outside the predefined set
    /// (for example 0x780..=0x7E3) and for per-node bases with node-ID 0 (0x180, 0x580, ...).
    pub fn classify(raw: u16) -> Option<Self> {
        let global = |function| {
            Some(Self {
                function,
                node: None,
            })
        };
        match raw {
            NMT => return global(FunctionCode::Nmt),
            SYNC => return global(FunctionCode::Sync),
            TIME => return global(FunctionCode::Time),
            LSS_SLAVE_TO_MASTER => return global(FunctionCode::LssSlaveToMaster),
            LSS_MASTER_TO_SLAVE => return global(FunctionCode::LssMasterToSlave),
            _ => {}
        }
        if raw > 0x77F {
            return None;
        }
        let node = NodeId::new((raw & 0x7F) as u8).ok()?;
        let function = match raw >> 7 {
            0x1 => FunctionCode::Emcy,
            0x3 => FunctionCode::Tpdo(PdoNumber::One),
            0x4 => FunctionCode::Rpdo(PdoNumber::One),
            0x5 => FunctionCode::Tpdo(PdoNumber::Two),
            0x6 => FunctionCode::Rpdo(PdoNumber::Two),
            0x7 => FunctionCode::Tpdo(PdoNumber::Three),
            0x8 => FunctionCode::Rpdo(PdoNumber::Three),
            0x9 => FunctionCode::Tpdo(PdoNumber::Four),
            0xA => FunctionCode::Rpdo(PdoNumber::Four),
            0xB => FunctionCode::SdoTx,
            0xC => FunctionCode::SdoRx,
            0xE => FunctionCode::NmtErrorControl,
            _ => return None,
        };
        Some(Self {
            function,
            node: Some(node),
        })
    }

    /// The 11-bit COB-ID. A per-node function without a node yields its base (e.g. 0x580).
    pub const fn raw(self) -> u16 {
        let base = self.function.base();
        match self.node {
            Some(n) if self.function.is_per_node() => base + n.get() as u16,
            _ => base,
        }
    }
}

impl FunctionCode {
    /// The COB-ID base: the COB-ID itself for global objects, the value to add the node-ID to
    /// for per-node objects.
    pub const fn base(self) -> u16 {
        match self {
            Self::Nmt => NMT,
            Self::Sync | Self::Emcy => 0x080,
            Self::Time => TIME,
            Self::Tpdo(n) => 0x080 + 0x100 * n.get() as u16,
            Self::Rpdo(n) => 0x100 + 0x100 * n.get() as u16,
            Self::SdoTx => 0x580,
            Self::SdoRx => 0x600,
            Self::NmtErrorControl => 0x700,
            Self::LssSlaveToMaster => LSS_SLAVE_TO_MASTER,
            Self::LssMasterToSlave => LSS_MASTER_TO_SLAVE,
        }
    }

    /// Whether the COB-ID carries a node-ID in its low seven bits.
    pub const fn is_per_node(self) -> bool {
        matches!(
            self,
            Self::Emcy
                | Self::Tpdo(_)
                | Self::Rpdo(_)
                | Self::SdoTx
                | Self::SdoRx
                | Self::NmtErrorControl
        )
    }

    /// The default COB-ID of this function for `node` (the node is ignored by global objects).
    pub const fn cob_id(self, node: NodeId) -> u16 {
        CobId {
            function: self,
            node: Some(node),
        }
        .raw()
    }
}

impl fmt::Display for FunctionCode {
    /// The CiA 301 / CiA 305 name: `NMT`, `SYNC`, `EMCY`, `TIME`, `TPDO1`, `RPDO4`,
    /// `SDO server-to-client`, `SDO client-to-server`, `NMT error control`,
    /// `LSS slave-to-master`, `LSS master-to-slave`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Nmt => f.write_str("NMT"),
            Self::Sync => f.write_str("SYNC"),
            Self::Emcy => f.write_str("EMCY"),
            Self::Time => f.write_str("TIME"),
            Self::Tpdo(n) => write!(f, "TPDO{}", n.get()),
            Self::Rpdo(n) => write!(f, "RPDO{}", n.get()),
            Self::SdoTx => f.write_str("SDO server-to-client"),
            Self::SdoRx => f.write_str("SDO client-to-server"),
            Self::NmtErrorControl => f.write_str("NMT error control"),
            Self::LssSlaveToMaster => f.write_str("LSS slave-to-master"),
            Self::LssMasterToSlave => f.write_str("LSS master-to-slave"),
        }
    }
}

impl fmt::Display for CobId {
    /// The function, and the node for per-node objects: `TPDO1 node 5`, `SYNC`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.node {
            Some(n) if self.function.is_per_node() => write!(f, "{} node {n}", self.function),
            _ => fmt::Display::fmt(&self.function, f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restricted_identifiers() {
        // The edges of every range of CiA 301's table, and the identifiers between them.
        for id in [
            0x000, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701,
            0x77F, 0x780, 0x7E4, 0x7E5, 0x7FF,
        ] {
            assert!(is_restricted(id), "{id:#05x}");
        }
        for id in [
            0x080, 0x081, 0x0FF, 0x100, 0x181, 0x1FF, 0x200, 0x580, 0x600, 0x680, 0x6DF, 0x700,
            0x800,
        ] {
            assert!(!is_restricted(id), "{id:#05x}");
        }
        // Every default PDO and EMCY identifier of nodes 1..=127 is free; every default SDO
        // and heartbeat identifier is restricted (for use other than their own).
        for node in 1..=127u16 {
            for base in [
                0x080, 0x180, 0x200, 0x280, 0x300, 0x380, 0x400, 0x480, 0x500,
            ] {
                assert!(!is_restricted(base + node), "{:#05x}", base + node);
            }
            for base in [0x580, 0x600, 0x700] {
                assert!(is_restricted(base + node), "{:#05x}", base + node);
            }
        }
    }

    fn n(raw: u8) -> NodeId {
        NodeId::new(raw).unwrap()
    }

    #[test]
    fn predefined_set() {
        let id = n(5);
        assert_eq!(FunctionCode::Emcy.cob_id(id), 0x085);
        assert_eq!(FunctionCode::Tpdo(PdoNumber::One).cob_id(id), 0x185);
        assert_eq!(FunctionCode::Rpdo(PdoNumber::One).cob_id(id), 0x205);
        assert_eq!(FunctionCode::Tpdo(PdoNumber::Two).cob_id(id), 0x285);
        assert_eq!(FunctionCode::Rpdo(PdoNumber::Two).cob_id(id), 0x305);
        assert_eq!(FunctionCode::Tpdo(PdoNumber::Three).cob_id(id), 0x385);
        assert_eq!(FunctionCode::Rpdo(PdoNumber::Three).cob_id(id), 0x405);
        assert_eq!(FunctionCode::Tpdo(PdoNumber::Four).cob_id(id), 0x485);
        assert_eq!(FunctionCode::Rpdo(PdoNumber::Four).cob_id(id), 0x505);
        assert_eq!(FunctionCode::SdoTx.cob_id(id), 0x585);
        assert_eq!(FunctionCode::SdoRx.cob_id(id), 0x605);
        assert_eq!(FunctionCode::NmtErrorControl.cob_id(id), 0x705);
        assert_eq!(FunctionCode::Nmt.cob_id(id), 0x000);
        assert_eq!(FunctionCode::Sync.cob_id(id), 0x080);
        assert_eq!(FunctionCode::LssMasterToSlave.cob_id(id), 0x7E5);
    }

    #[test]
    fn classify_round_trips_every_standard_id() {
        for raw in 0..=0x7FFu16 {
            if let Some(c) = CobId::classify(raw) {
                assert_eq!(c.raw(), raw, "{raw:#x}");
            }
        }
        assert_eq!(CobId::classify(0x080).unwrap().function, FunctionCode::Sync);
        assert_eq!(
            CobId::classify(0x0FF),
            Some(CobId::node(FunctionCode::Emcy, n(127)))
        );
        assert_eq!(
            CobId::classify(0x7E4).unwrap().function,
            FunctionCode::LssSlaveToMaster
        );
        assert_eq!(CobId::classify(0x580), None, "node-ID 0 is not a node");
        assert_eq!(CobId::classify(0x780), None);
        assert_eq!(
            CobId::classify(0x680),
            None,
            "0x680..0x6FF is not predefined"
        );
    }

    #[test]
    fn names() {
        extern crate std;
        use std::string::ToString;
        let name = |raw: u16| CobId::classify(raw).unwrap().to_string();
        assert_eq!(name(0x000), "NMT");
        assert_eq!(name(0x080), "SYNC");
        assert_eq!(name(0x085), "EMCY node 5");
        assert_eq!(name(0x100), "TIME");
        assert_eq!(name(0x185), "TPDO1 node 5");
        assert_eq!(name(0x50A), "RPDO4 node 10");
        assert_eq!(name(0x585), "SDO server-to-client node 5");
        assert_eq!(name(0x605), "SDO client-to-server node 5");
        assert_eq!(name(0x77F), "NMT error control node 127");
        assert_eq!(name(0x7E4), "LSS slave-to-master");
        assert_eq!(name(0x7E5), "LSS master-to-slave");
    }
}
