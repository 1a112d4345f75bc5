//! NMT module control (CiA 301 §7.2.8.3.1): COB-ID 0x000, two data bytes `[cs, node]`.
//!
//! `cs` is the command specifier, `node` the addressed node-ID or 0 for all nodes. Parsing never
//! panics; unknown command specifiers and node bytes above 127 are kept, so a decode-encode round
//! trip is lossless.

use canola_frame::{CanFrame, NodeId};

use crate::error::DecodeError;
use crate::util::{data_frame, service_data};

/// COB-ID of NMT module control.
pub const NMT_COB_ID: u16 = canola_frame::cob::NMT;

/// The command specifier, byte 0 of an NMT module control frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CommandSpecifier {
    /// 0x01 start remote node: enter Operational.
    Start,
    /// 0x02 stop remote node: enter Stopped.
    Stop,
    /// 0x80 enter Pre-operational.
    EnterPreOperational,
    /// 0x81 reset node (application and communication objects).
    ResetNode,
    /// 0x82 reset communication (communication objects only).
    ResetCommunication,
    /// Any other value, kept as received.
    Unknown(u8),
}

impl CommandSpecifier {
    /// The wire value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::Start => 0x01,
            Self::Stop => 0x02,
            Self::EnterPreOperational => 0x80,
            Self::ResetNode => 0x81,
            Self::ResetCommunication => 0x82,
            Self::Unknown(v) => v,
        }
    }

    /// From the wire value; every byte maps to a variant.
    pub const fn from_u8(v: u8) -> Self {
        match v {
            0x01 => Self::Start,
            0x02 => Self::Stop,
            0x80 => Self::EnterPreOperational,
            0x81 => Self::ResetNode,
            0x82 => Self::ResetCommunication,
            v => Self::Unknown(v),
        }
    }
}

impl core::fmt::Display for CommandSpecifier {
    /// The CiA 301 service names: `Start remote node`, `Stop remote node`, `Enter
    /// pre-operational`, `Reset node`, `Reset communication`; `unknown command 0x03` else.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Start => f.write_str("Start remote node"),
            Self::Stop => f.write_str("Stop remote node"),
            Self::EnterPreOperational => f.write_str("Enter pre-operational"),
            Self::ResetNode => f.write_str("Reset node"),
            Self::ResetCommunication => f.write_str("Reset communication"),
            Self::Unknown(v) => write!(f, "unknown command {v:#04x}"),
        }
    }
}

impl From<u8> for CommandSpecifier {
    fn from(v: u8) -> Self {
        Self::from_u8(v)
    }
}

impl From<CommandSpecifier> for u8 {
    fn from(cs: CommandSpecifier) -> u8 {
        cs.to_u8()
    }
}

/// Byte 1 of an NMT module control frame: which node the command is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NmtTarget {
    /// 0: every node on the network.
    All,
    /// 1..=127: one node.
    Node(NodeId),
    /// 128..=255: not a node-ID; kept as received. No node acts on it.
    Invalid(u8),
}

impl NmtTarget {
    /// The wire value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::All => 0,
            Self::Node(n) => n.get(),
            Self::Invalid(v) => v,
        }
    }

    /// From the wire value; every byte maps to a variant.
    pub const fn from_u8(v: u8) -> Self {
        match NodeId::new(v) {
            Ok(n) => Self::Node(n),
            Err(_) if v == 0 => Self::All,
            Err(_) => Self::Invalid(v),
        }
    }

    /// Whether a node with this ID must act on the command.
    pub fn addresses(self, node: NodeId) -> bool {
        match self {
            Self::All => true,
            Self::Node(n) => n == node,
            Self::Invalid(_) => false,
        }
    }
}

impl core::fmt::Display for NmtTarget {
    /// `all nodes`, `node 5`, `invalid node-ID 128`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::All => f.write_str("all nodes"),
            Self::Node(n) => write!(f, "node {n}"),
            Self::Invalid(v) => write!(f, "invalid node-ID {v}"),
        }
    }
}

impl From<NodeId> for NmtTarget {
    fn from(n: NodeId) -> Self {
        Self::Node(n)
    }
}

/// An NMT module control message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NmtCommand {
    /// What to do.
    pub command: CommandSpecifier,
    /// To whom.
    pub target: NmtTarget,
}

impl NmtCommand {
    const NAME: &'static str = "NMT module control";

    /// A command for `target` (a [`NodeId`] converts into [`NmtTarget::Node`]).
    pub fn new(command: CommandSpecifier, target: impl Into<NmtTarget>) -> Self {
        Self {
            command,
            target: target.into(),
        }
    }

    /// Decodes the two data bytes. Never panics; any other length is an error.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        match *data {
            [cs, node] => Ok(Self {
                command: CommandSpecifier::from_u8(cs),
                target: NmtTarget::from_u8(node),
            }),
            _ => Err(DecodeError::Length {
                message: Self::NAME,
                actual: data.len(),
            }),
        }
    }

    /// Decodes a whole frame: COB-ID 0x000, data frame, two bytes.
    pub fn from_frame(frame: &CanFrame) -> Result<Self, DecodeError> {
        Self::parse(service_data(frame, NMT_COB_ID, Self::NAME)?)
    }

    /// The two data bytes.
    pub const fn emit(&self) -> [u8; 2] {
        [self.command.to_u8(), self.target.to_u8()]
    }

    /// The frame to send (COB-ID 0x000).
    pub fn to_frame(&self) -> CanFrame {
        data_frame(NMT_COB_ID, &self.emit())
    }
}

impl core::fmt::Display for NmtCommand {
    /// `NMT Start remote node, all nodes`, `NMT Reset communication, node 5`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "NMT {}, {}", self.command, self.target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn byte_vectors() {
        // CiA 301 / Bürkert manual: start node 5 is 000#0105; start all is 000#0100.
        let start5 = NmtCommand::new(CommandSpecifier::Start, node(5));
        assert_eq!(start5.emit(), [0x01, 0x05]);
        assert_eq!(start5.to_frame().cob_id(), Some(0));
        assert_eq!(start5.to_frame().data(), &[0x01, 0x05]);
        let cases: [([u8; 2], CommandSpecifier, NmtTarget); 6] = [
            ([0x01, 0x00], CommandSpecifier::Start, NmtTarget::All),
            (
                [0x02, 0x7F],
                CommandSpecifier::Stop,
                NmtTarget::Node(node(127)),
            ),
            (
                [0x80, 0x01],
                CommandSpecifier::EnterPreOperational,
                NmtTarget::Node(node(1)),
            ),
            (
                [0x81, 0x0A],
                CommandSpecifier::ResetNode,
                NmtTarget::Node(node(10)),
            ),
            (
                [0x82, 0x00],
                CommandSpecifier::ResetCommunication,
                NmtTarget::All,
            ),
            (
                [0x03, 0x80],
                CommandSpecifier::Unknown(3),
                NmtTarget::Invalid(0x80),
            ),
        ];
        for (bytes, cs, target) in cases {
            let c = NmtCommand::parse(&bytes).unwrap();
            assert_eq!((c.command, c.target), (cs, target));
            assert_eq!(c.emit(), bytes);
        }
    }

    #[test]
    fn rejects_bad_frames() {
        assert_eq!(
            NmtCommand::parse(&[1]),
            Err(DecodeError::Length {
                message: "NMT module control",
                actual: 1
            })
        );
        assert!(NmtCommand::parse(&[1, 2, 3]).is_err());
        assert!(NmtCommand::parse(&[]).is_err());
        let wrong = data_frame(0x080, &[1, 0]);
        assert_eq!(
            NmtCommand::from_frame(&wrong),
            Err(DecodeError::WrongCobId(0x80))
        );
        let rtr = crate::util::remote_frame(0, 2);
        assert!(matches!(
            NmtCommand::from_frame(&rtr),
            Err(DecodeError::UnexpectedRemote { .. })
        ));
    }

    #[test]
    fn texts() {
        extern crate std;
        use std::string::ToString;
        let text = |b: [u8; 2]| NmtCommand::parse(&b).unwrap().to_string();
        assert_eq!(text([0x01, 0x00]), "NMT Start remote node, all nodes");
        assert_eq!(text([0x02, 0x05]), "NMT Stop remote node, node 5");
        assert_eq!(text([0x80, 0x7F]), "NMT Enter pre-operational, node 127");
        assert_eq!(text([0x81, 0x01]), "NMT Reset node, node 1");
        assert_eq!(text([0x82, 0x00]), "NMT Reset communication, all nodes");
        assert_eq!(
            text([0x03, 0x80]),
            "NMT unknown command 0x03, invalid node-ID 128"
        );
    }

    #[test]
    fn addressing() {
        assert!(NmtTarget::All.addresses(node(9)));
        assert!(NmtTarget::Node(node(9)).addresses(node(9)));
        assert!(!NmtTarget::Node(node(8)).addresses(node(9)));
        assert!(!NmtTarget::Invalid(200).addresses(node(9)));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn round_trip(cs in any::<u8>(), target in any::<u8>()) {
            let c = NmtCommand::parse(&[cs, target]).unwrap();
            prop_assert_eq!(c.emit(), [cs, target]);
            prop_assert_eq!(NmtCommand::from_frame(&c.to_frame()), Ok(c));
        }
    }
}
