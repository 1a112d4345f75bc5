//! [`Node`]: one node of a [`Network`]: its SDO client, its NMT control and state, PDO
//! remapping; and [`Nmt`], NMT module control (CiA 301 §7.2.8.3.1) and a node's NMT state.

use std::sync::Arc;

use canola_frame::{Duration, NodeId};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget};
use canola_od::ObjectDictionary;
use canola_sdo::{Method, SdoCobIds};

use super::handle::{DEFAULT_SDO_TIMEOUT, Network};
use super::request::Sdo;
use crate::error::Error;

/// A node on the network.
#[derive(Clone, Debug)]
pub struct Node {
    pub(crate) net: Network,
    pub(crate) id: NodeId,
}

impl Node {
    /// The node-ID.
    pub fn id(&self) -> NodeId {
        self.id
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// The node's SDO client with default settings (normal transfer, 1 s response timeout).
    pub fn sdo(&self) -> Sdo {
        Sdo {
            net: self.net.clone(),
            node: self.id,
            channel: SdoCobIds::default_for(self.id),
            method: Method::Normal,
            timeout: DEFAULT_SDO_TIMEOUT,
            progress: None,
        }
    }

    /// NMT commands to this node, and its state (see [`Nmt::state`]).
    pub fn nmt(&self) -> Nmt {
        Nmt::new(&self.net, NmtTarget::Node(self.id))
    }

    /// The node's dictionary, if it was added with one.
    pub fn dictionary(&self) -> Option<Arc<ObjectDictionary>> {
        self.net.core().dictionary(self.id)
    }
}

/// NMT module control (CiA 301 §7.2.8.3.1) for one node or all, and a node's NMT state as its
/// heartbeats, boot-up and guarding answers report it.
///
/// Boot-ups are counted per node, not sampled: [`wait_for_bootup`](Self::wait_for_bootup)
/// returns for a boot-up received since the node was added ([`Network::add_node`]; for a node
/// never added, since the network started), since the last NMT command to it (or to all), or
/// since the last wait that returned, whichever came last. It does not matter when the handle
/// was made, nor whether a heartbeat with the next state followed at once (or the background
/// driver received both before the wait began). So `nmt.reset_node()` then
/// `nmt.wait_for_bootup(t)` cannot miss the boot-up, and after a reset of all nodes, the
/// boot-up of a node whose handle is made after waiting for another one is not lost.
#[derive(Debug, Clone)]
pub struct Nmt {
    pub(crate) net: Network,
    pub(crate) target: NmtTarget,
}

impl Nmt {
    fn new(net: &Network, target: NmtTarget) -> Self {
        Self {
            net: net.clone(),
            target,
        }
    }

    /// NMT commands to all nodes (node-ID 0).
    pub fn all(net: &Network) -> Self {
        Self::new(net, NmtTarget::All)
    }

    fn send(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        let mut core = self.net.core();
        core.nmt(cmd, self.target);
        drop(core);
        self.net.flush()
    }

    fn node(&self) -> Result<NodeId, Error> {
        match self.target {
            NmtTarget::Node(id) => Ok(id),
            _ => Err(Error::InvalidRequest(
                "node states are per node: use node.nmt(), not Nmt::all".into(),
            )),
        }
    }

    /// The node's last reported NMT state (`None` before anything was heard from it; `BootUp`
    /// between its boot-up message and its first heartbeat). `None` for [`Nmt::all`].
    pub fn state(&self) -> Option<NmtState> {
        match self.target {
            NmtTarget::Node(id) => self.net.last_state(id),
            _ => None,
        }
    }

    /// Waits (driving the network) for a boot-up of the node not accounted for yet (see the
    /// type's docs), and accounts for it. Times out after `timeout` on the network's clock.
    pub fn wait_for_bootup(&self, timeout: impl Into<Duration>) -> Result<(), Error> {
        let timeout: Duration = timeout.into();
        let node = self.node()?;
        let deadline = self.net.now() + timeout;
        self.net.wait_for(|c| {
            let boots = c.boot_count(node);
            if boots > c.boots_taken(node) {
                c.take_boots(node, boots);
                Some(Ok(()))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "no boot-up from node {node} within {timeout}"
                ))))
            } else {
                None
            }
        })?
    }

    /// Waits (driving the network) until the node reports `state`; returns at once if it is in
    /// it already. Times out after `timeout` on the network's clock.
    pub fn wait_for_state(
        &self,
        state: NmtState,
        timeout: impl Into<Duration>,
    ) -> Result<(), Error> {
        let timeout: Duration = timeout.into();
        let node = self.node()?;
        let deadline = self.net.now() + timeout;
        self.net.wait_for(|c| {
            if c.last_state(node) == Some(state) {
                Some(Ok(()))
            } else if c.now() >= deadline {
                Some(Err(Error::Timeout(format!(
                    "node {node} not {state} within {timeout}"
                ))))
            } else {
                None
            }
        })?
    }

    /// Start remote node (to Operational).
    pub fn start(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::Start)
    }
    /// Stop remote node (to Stopped).
    pub fn stop(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::Stop)
    }
    /// Enter Pre-Operational.
    pub fn enter_preoperational(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::EnterPreOperational)
    }
    /// Reset node (application reset).
    pub fn reset_node(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::ResetNode)
    }
    /// Reset communication.
    pub fn reset_communication(&self) -> Result<(), Error> {
        self.send(CommandSpecifier::ResetCommunication)
    }
}

impl Network {
    /// Adds a node without a dictionary (values are raw bytes).
    pub fn add_node(&self, id: NodeId) -> Node {
        self.core().add_node(id, None);
        self.node(id)
    }

    /// Adds a node with its object dictionary (from an EDS/DCF or generated code): errors then
    /// name objects, and typed reads decode values.
    pub fn add_node_with_dictionary(&self, id: NodeId, od: ObjectDictionary) -> Node {
        self.core().add_node(id, Some(Arc::new(od)));
        self.node(id)
    }

    /// A handle to a node (added on first use if needed).
    pub fn node(&self, id: NodeId) -> Node {
        Node {
            net: self.clone(),
            id,
        }
    }
}
