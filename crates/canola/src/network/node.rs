//! [`Node`]: one node of a network: its SDO client, its NMT control and state, its USDO client
//! and PDO handles (every handle a node makes is made here); and [`Nmt`], NMT module control (CiA 301 §7.2.8.3.1) and a node's NMT state.

use std::sync::Arc;

use canola_frame::{Duration, Instant, NodeId};
use canola_nmt::{CommandSpecifier, NmtState, NmtTarget};
use canola_od::ObjectDictionary;

use super::handle::Network;
use super::operation::{self, Operation};
use super::request::{NodeRef, Sdo};
use crate::error::{Awaited, Error, Misuse};
use crate::pdo_access::{Mpdos, Rpdos, Tpdos};
use crate::usdo::Usdo;

/// Which parameters [`Node::store_parameters_of`] and [`Node::restore_defaults_of`] store or
/// restore: the sub-index of 0x1010 and 0x1011 (CiA 301 §7.5.2.13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParameterGroup {
    /// Sub-index 1: all parameters.
    All,
    /// Sub-index 2: the communication parameters (0x1000..=0x1FFF).
    Communication,
    /// Sub-index 3: the application parameters (0x6000..=0x9FFF).
    Application,
    /// Sub-index 4: the manufacturer-specific parameters (0x2000..=0x5FFF).
    Manufacturer,
    /// Another sub-index (5..=127: manufacturer-specific groups).
    Other(u8),
}

impl ParameterGroup {
    /// The sub-index of 0x1010 and 0x1011 for this group.
    pub const fn sub_index(self) -> u8 {
        match self {
            Self::All => 1,
            Self::Communication => 2,
            Self::Application => 3,
            Self::Manufacturer => 4,
            Self::Other(s) => s,
        }
    }

    /// Whether the group holds the object at `index` (sub-index 1 and groups of its own hold
    /// every object).
    pub const fn holds(self, index: u16) -> bool {
        match self {
            Self::Communication => index >= 0x1000 && index <= 0x1FFF,
            Self::Application => index >= 0x6000 && index <= 0x9FFF,
            Self::Manufacturer => index >= 0x2000 && index <= 0x5FFF,
            Self::All | Self::Other(_) => true,
        }
    }

    /// The group of a sub-index of 0x1010/0x1011.
    pub const fn from_sub_index(sub: u8) -> Self {
        match sub {
            1 => Self::All,
            2 => Self::Communication,
            3 => Self::Application,
            4 => Self::Manufacturer,
            s => Self::Other(s),
        }
    }
}

/// Making node handles: the node handles are this module's, so their constructors are too.
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
        Node::new(self.clone(), id)
    }
}

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

    /// A handle to node `id` on `net`.
    pub(crate) fn new(net: Network, id: NodeId) -> Self {
        Node { net, id }
    }

    /// The network this node is on.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// The same device under another node-ID, after a node-ID change (by LSS, or a
    /// manufacturer object and a reset): node `id` on the same network, added with this
    /// node's dictionary.
    pub fn with_node_id(&self, id: NodeId) -> Node {
        let od = self.dictionary();
        self.net.core().add_node(id, od);
        Node::new(self.net.clone(), id)
    }

    /// What the PDO handles hold of this node.
    fn node_ref(&self) -> NodeRef {
        NodeRef {
            net: self.net.clone(),
            id: self.id,
        }
    }

    /// The node's SDO client with default settings (normal transfer, 1 s response timeout).
    pub fn sdo(&self) -> Sdo {
        Sdo::new(self.net.clone(), self.id)
    }

    /// NMT commands to this node, and its state (see [`Nmt::state`]).
    pub fn nmt(&self) -> Nmt {
        Nmt::new(&self.net, NmtTarget::Node(self.id))
    }

    /// The node's dictionary, if it was added with one.
    pub fn dictionary(&self) -> Option<Arc<ObjectDictionary>> {
        self.net.core().dictionary(self.id)
    }

    /// Stores all parameters in the device's non-volatile memory: writes the signature `save`
    /// to 0x1010:01 (CiA 301 §7.5.2.13). A device that cannot store answers with an abort,
    /// the error here: 0x06020000 when it has no 0x1010, 0x08000020 when it refuses.
    pub fn store_parameters(&self) -> Operation<'static, ()> {
        self.store_parameters_of(ParameterGroup::All)
    }

    /// Stores one group of parameters (0x1010 at the group's sub-index), see
    /// [`store_parameters`](Self::store_parameters).
    pub fn store_parameters_of(&self, group: ParameterGroup) -> Operation<'static, ()> {
        self.sdo().write((0x1010, group.sub_index()), *b"save")
    }

    /// Restores all parameters to their defaults: writes the signature `load` to 0x1011:01
    /// (CiA 301 §7.5.2.14). The defaults take effect at the device's next reset (NMT reset
    /// node; reset communication for the communication parameters). Errors as for
    /// [`store_parameters`](Self::store_parameters).
    pub fn restore_defaults(&self) -> Operation<'static, ()> {
        self.restore_defaults_of(ParameterGroup::All)
    }

    /// Restores one group of parameters (0x1011 at the group's sub-index), see
    /// [`restore_defaults`](Self::restore_defaults).
    pub fn restore_defaults_of(&self, group: ParameterGroup) -> Operation<'static, ()> {
        self.sdo().write((0x1011, group.sub_index()), *b"load")
    }

    /// Reads an object as a Rust value with the default SDO client: `read_typed::<u16>((0x1017,
    /// 0))` is 500 on a device with a 500 ms heartbeat. See [`Sdo::read_typed`] for how the
    /// object's type is found.
    pub fn read_typed<'t, T: canola_od::ValueType + 't>(
        &self,
        entry: impl Into<canola_od::ObjectAddress>,
    ) -> Operation<'t, T> {
        self.sdo().read_typed(entry)
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

    /// Queues `cmd` and puts it on the bus (see [`Network::send`]).
    fn send(&self, cmd: CommandSpecifier) -> Result<(), Error> {
        self.net.shared().catch_up_on_runtime()?;
        self.net.core().nmt(cmd, self.target);
        self.net.shared().send_queued_now()
    }

    fn node(&self) -> Result<NodeId, Error> {
        match self.target {
            NmtTarget::Node(id) => Ok(id),
            _ => Err(Error::InvalidRequest(Misuse::StateOfAll)),
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
    pub fn wait_for_bootup(&self, timeout: impl Into<Duration>) -> Operation<'static, ()> {
        let timeout: Duration = timeout.into();
        let net = self.net.clone();
        let node = self.node();
        Operation::new(async move {
            let node = node?;
            operation::catch_up(net.shared())?;
            let deadline = net.now() + timeout;
            operation::until(net.shared(), Some(deadline), move |c| {
                let boots = c.boot_count(node);
                if boots > c.boots_taken(node) {
                    c.take_boots(node, boots);
                    Some(Ok(()))
                } else if c.now() >= deadline {
                    Some(Err(Error::Timeout {
                        awaited: Awaited::BootUp { node },
                        after: timeout,
                    }))
                } else {
                    None
                }
            })
            .await?
        })
    }

    /// Waits (driving the network) until the node reports `state`; returns at once if it is in
    /// it already. Times out after `timeout` on the network's clock.
    pub fn wait_for_state(
        &self,
        state: NmtState,
        timeout: impl Into<Duration>,
    ) -> Operation<'static, ()> {
        let timeout: Duration = timeout.into();
        let net = self.net.clone();
        let node = self.node();
        Operation::new(async move {
            let node = node?;
            operation::catch_up(net.shared())?;
            let deadline = net.now() + timeout;
            operation::until(net.shared(), Some(deadline), move |c| {
                if c.last_state(node) == Some(state) {
                    Some(Ok(()))
                } else if c.now() >= deadline {
                    Some(Err(Error::Timeout {
                        awaited: Awaited::State { node, state },
                        after: timeout,
                    }))
                } else {
                    None
                }
            })
            .await?
        })
    }

    /// Waits (driving the network) for a sign of life of the node, as a master checks one after
    /// starting its error control (CiA 302-2): a state change or a recovery that its heartbeat
    /// or node guarding reports after this call, or, with `heartbeat_after`, any heartbeat
    /// (or boot-up) received after that instant. `Ok(false)` when the network's clock reaches
    /// `deadline` first.
    pub fn wait_for_life(
        &self,
        heartbeat_after: Option<Instant>,
        deadline: Instant,
    ) -> Operation<'static, bool> {
        let net = self.net.clone();
        let node = match self.node() {
            Ok(node) => node,
            Err(e) => return Operation::ready(Err(e)),
        };
        // Counted now: what was reported before the call is no sign of life.
        let reported = net.core().life_reports(node);
        Operation::new(async move {
            operation::until(net.shared(), Some(deadline), move |c| {
                let heard = heartbeat_after
                    .is_some_and(|since| c.last_heartbeat(node).is_some_and(|t| t > since));
                if heard || c.life_reports(node) > reported {
                    Some(true)
                } else if c.now() >= deadline {
                    Some(false)
                } else {
                    None
                }
            })
            .await
        })
    }

    // The commands are unconfirmed (CiA 301 §7.2.8.3.1): each is queued and sent at once when
    // the transport is free, else by whoever drives it next; nothing waits.

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

/// CANopen FD: the node's USDO client (see the `usdo` module).
impl Node {
    /// The node's universal SDO (CANopen FD, CiA 1301). The node must be marked CANopen FD
    /// ([`set_fd`](Self::set_fd), or `CANopenFD=1` in the `[DeviceInfo]` of its dictionary)
    /// and the bus must carry CAN FD.
    pub fn usdo(&self) -> Usdo {
        Usdo {
            net: self.net.clone(),
            node: self.id,
        }
    }

    /// Marks the node as a CANopen FD device (`true`) or not (`false`), whatever its
    /// dictionary says.
    pub fn set_fd(&self, fd: bool) {
        self.net.core().set_node_fd(self.id, fd);
    }

    /// Whether the node is marked CANopen FD: by [`set_fd`](Self::set_fd), else by its
    /// dictionary ([`eds_marks_fd`](crate::usdo::eds_marks_fd)).
    pub fn is_fd(&self) -> bool {
        self.net.core().node_fd(self.id)
    }
}

/// PDOs: the node's PDO handles and remapping (see the `pdo_access` module).
impl Node {
    /// The node's transmit PDOs: read and save their parameters (python-canopen's
    /// `node.tpdo.read()` / `save()`); after either, the master decodes them as the node sends
    /// them.
    pub fn tpdo(&self) -> Tpdos {
        Tpdos {
            node: self.node_ref(),
        }
    }

    /// The node's receive PDOs: read and save their parameters, and transmit them from the
    /// master ([`Rpdos::start`]).
    pub fn rpdo(&self) -> Rpdos {
        Rpdos {
            node: self.node_ref(),
        }
    }

    /// The node's multiplexed PDOs (MPDOs).
    pub fn mpdo(&self) -> Mpdos {
        Mpdos {
            node: self.node_ref(),
        }
    }

    /// Remaps PDO `number` (1-based) of `direction` on the node by SDO, the CiA 301 way
    /// (disable, clear mapping, write entries, set count, set parameters, enable; the plan comes
    /// from `canola_pdo::remap`; the same sequence `node.tpdo().save()` uses). After a TPDO
    /// remap the master decodes that TPDO from its COB-ID with the new mapping; after an RPDO
    /// remap an RPDO the master transmits ([`Rpdos::start`](crate::Rpdos::start)) follows.
    ///
    /// `mapping` is a classic [`Mapping`](canola_pdo::Mapping) (up to 8 bytes) or an
    /// [`FdMapping`](canola_pdo::FdMapping) of up to 64 bytes, which a node marked CANopen FD
    /// ([`set_fd`](Self::set_fd)) on a CAN FD bus takes; elsewhere a mapping of more than 8
    /// bytes is refused before anything is sent, saying why.
    pub fn remap_pdo(
        &self,
        direction: canola_pdo::Direction,
        number: u16,
        comm: canola_pdo::CommParams,
        mapping: impl Into<canola_pdo::FdMapping>,
    ) -> Operation<'static, ()> {
        crate::pdo_access::remap(self.node_ref(), direction, number, comm, mapping.into())
    }
}
