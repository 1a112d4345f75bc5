//! The per-node state of the master ([`NodeSlot`]: its SDO channels, its dictionary and its
//! PDOs) and the table of nodes, indexed by node-ID.

use std::sync::Arc;

use canola_frame::NodeId;
use canola_od::ObjectDictionary;
use canola_sdo::SdoCobIds;

use super::sdo::SdoChannel;

/// What the master keeps per node it knows: its dictionary (for typed values and object
/// names in errors), its PDO state and its SDO client channels. Heartbeat, guarding and EMCY
/// state live in the machines of `canola-nmt`, which keep every node themselves.
pub(super) struct NodeSlot {
    /// The node's object dictionary, when the application gave one.
    pub(super) od: Option<Arc<ObjectDictionary>>,
    /// The node's TPDOs mirrored as receive PDOs, and its RPDOs the master transmits.
    pub(super) pdo: Option<crate::machine::pdo::NodePdos>,
    /// The node's SDO channels: the default one first, then those opened on other COB-IDs.
    pub(super) channels: Vec<SdoChannel>,
    /// CANopen FD as the application set it (`None`: as the dictionary says).
    pub(super) fd: Option<bool>,
}

impl NodeSlot {
    pub(super) fn new(node: NodeId, od: Option<Arc<ObjectDictionary>>) -> Self {
        Self {
            pdo: od
                .as_deref()
                .map(|od| crate::machine::pdo::mirror_engine(od, node)),
            od,
            channels: vec![SdoChannel::new(SdoCobIds::default_for(node))],
            fd: None,
        }
    }
}

/// The nodes by node-ID, indexed directly (node-IDs are 1..=127): a frame's node is found
/// without a search. Iterates in node-ID order.
pub(super) struct NodeTable {
    pub(super) slots: Vec<Option<Box<NodeSlot>>>,
    pub(super) len: usize,
}

impl NodeTable {
    pub(super) fn new() -> Self {
        Self {
            slots: (0..=127).map(|_| None).collect(),
            len: 0,
        }
    }

    pub(super) fn get(&self, node: &NodeId) -> Option<&NodeSlot> {
        self.slots.get(usize::from(node.get()))?.as_deref()
    }

    pub(super) fn get_mut(&mut self, node: &NodeId) -> Option<&mut NodeSlot> {
        self.slots.get_mut(usize::from(node.get()))?.as_deref_mut()
    }

    pub(super) fn contains_key(&self, node: &NodeId) -> bool {
        self.get(node).is_some()
    }

    pub(super) fn insert(&mut self, node: NodeId, slot: NodeSlot) {
        if let Some(s) = self.slots.get_mut(usize::from(node.get())) {
            self.len += usize::from(s.is_none());
            *s = Some(Box::new(slot));
        }
    }

    pub(super) fn len(&self) -> usize {
        self.len
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = (NodeId, &NodeSlot)> {
        self.slots.iter().enumerate().filter_map(|(i, s)| {
            let node = NodeId::new(u8::try_from(i).ok()?).ok()?;
            Some((node, s.as_deref()?))
        })
    }

    pub(super) fn values(&self) -> impl Iterator<Item = &NodeSlot> {
        self.slots.iter().filter_map(|s| s.as_deref())
    }

    pub(super) fn values_mut(&mut self) -> impl Iterator<Item = &mut NodeSlot> {
        self.slots.iter_mut().filter_map(|s| s.as_deref_mut())
    }
}
