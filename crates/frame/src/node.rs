//! CANopen node-IDs (CiA 301 §7.5.2.1): 1..=127. Zero is reserved for "all nodes" in NMT and
//! 0xFF means "unconfigured" in LSS (CiA 305); neither is a `NodeId`.

use core::fmt;

/// A CANopen node-ID, always within 1..=127.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u8);

/// A value outside 1..=127.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("node-ID {0} is outside 1..=127")]
pub struct NodeIdError(pub u32);

debug_as_display!(NodeIdError);

impl NodeId {
    /// The smallest node-ID.
    pub const MIN: NodeId = NodeId(1);
    /// The largest node-ID.
    pub const MAX: NodeId = NodeId(127);

    /// Validates a node-ID.
    pub const fn new(raw: u8) -> Result<Self, NodeIdError> {
        if raw >= 1 && raw <= 127 {
            Ok(Self(raw))
        } else {
            Err(NodeIdError(raw as u32))
        }
    }

    /// The raw value, 1..=127.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// Every node-ID in order, 1 to 127.
    pub fn all() -> impl Iterator<Item = NodeId> {
        (1..=127u8).map(NodeId)
    }
}

impl TryFrom<u8> for NodeId {
    type Error = NodeIdError;
    fn try_from(raw: u8) -> Result<Self, Self::Error> {
        Self::new(raw)
    }
}

impl TryFrom<u32> for NodeId {
    type Error = NodeIdError;
    fn try_from(raw: u32) -> Result<Self, Self::Error> {
        u8::try_from(raw)
            .map_err(|_| NodeIdError(raw))
            .and_then(Self::new)
    }
}

impl From<NodeId> for u8 {
    fn from(id: NodeId) -> u8 {
        id.0
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range() {
        assert!(NodeId::new(0).is_err());
        assert_eq!(NodeId::new(1).map(NodeId::get), Ok(1));
        assert_eq!(NodeId::new(127).map(NodeId::get), Ok(127));
        assert_eq!(NodeId::new(128), Err(NodeIdError(128)));
        assert_eq!(NodeId::try_from(300u32), Err(NodeIdError(300)));
        assert_eq!(NodeId::all().count(), 127);
    }
}
