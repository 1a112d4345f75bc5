//! [`Network`], the top of the API: it opens or wraps a bus and makes the handles (nodes, the
//! LSS master, event streams, scans). Everything else it does is its [`Driver`]'s, which it
//! derefs to; the handles hold that driver, not the network, so nothing below this file
//! names it.

use std::sync::Arc;

use canola_frame::{Duration, NodeId};
use canola_od::ObjectDictionary;

use super::driver::Driver;
use super::node::Node;
use super::operation::Operation;
use crate::error::Error;
use crate::lss::Lss;
use crate::scan::ScannedNode;
use crate::transport::Transport;

/// A CANopen network: the master side of one CAN bus. Cheap to clone (a shared handle).
///
/// A network derefs to its [`Driver`]: the clock, subscriptions, SYNC, raw frames and the
/// driving calls ([`run_for`](Driver::run_for), [`start_driver`](Driver::start_driver), ...)
/// are the driver's, and every handle made here can reach them too
/// ([`Node::network`](crate::Node::network)).
#[derive(Clone)]
pub struct Network {
    driver: Driver,
}

impl core::fmt::Debug for Network {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Network").finish_non_exhaustive()
    }
}

impl core::ops::Deref for Network {
    type Target = Driver;
    fn deref(&self) -> &Driver {
        &self.driver
    }
}

impl Network {
    /// A network on `transport` (its clock is the network's clock).
    pub fn new(transport: impl Transport + 'static) -> Self {
        Self {
            driver: Driver::new(transport),
        }
    }

    /// Opens a bus by the name `canopen --iface` takes (see [`BusSpec`](crate::BusSpec)):
    /// a SocketCAN interface (`"can0"`, `"vcan0"`), `"udp[:GROUP[:PORT]][@IFACE]"`, or an
    /// slcan adapter (`"slcan:/dev/ttyACM0@500k"`, `"slcan:COM3"`), and starts the background
    /// driver: the network runs by itself from the first line. A failure is
    /// [`Error::Open`]: it names the bus and carries a hint.
    ///
    /// ```no_run
    /// let net = canola::Network::open("can0")?;
    /// # Ok::<(), canola::Error>(())
    /// ```
    pub fn open(spec: &str) -> Result<Self, Error> {
        let net = Self::new(crate::transport::BusSpec::parse(spec)?.open()?);
        net.start_driver()?;
        Ok(net)
    }

    /// [`Network::open`] for CAN FD: the bus must carry FD frames (a SocketCAN interface with
    /// MTU 72, the UDP bus, an slcan adapter with a data bit rate); a classic-only one is an
    /// [`Error::Open`] saying `FD not supported on ...`.
    pub fn open_fd(spec: &str) -> Result<Self, Error> {
        let net = Self::new(crate::transport::BusSpec::parse(spec)?.open_fd()?);
        net.start_driver()?;
        Ok(net)
    }

    /// The network's driver (what it derefs to), to hand to code that needs no handle
    /// constructors.
    pub fn driver(&self) -> &Driver {
        &self.driver
    }

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
        Node::new(self.driver.clone(), id)
    }

    /// The LSS master (CiA 305).
    pub fn lss(&self) -> Lss {
        Lss {
            net: self.driver.clone(),
        }
    }

    /// The nodes that answer an SDO read of 0x1018:01 within `timeout`, in node-ID order, with
    /// their identity (sub-indices 2..=4 read from each node found, all at once). Dropping the
    /// operation cancels the reads.
    pub fn scan(&self, timeout: impl Into<Duration>) -> Operation<'static, Vec<ScannedNode>> {
        crate::scan::scan(&self.driver, timeout.into())
    }

    /// Subscribes to the network's events as a [`Stream`](futures_core::Stream), with a queue
    /// of [`DEFAULT_EVENT_CAPACITY`](crate::asynch::DEFAULT_EVENT_CAPACITY) events (see
    /// [`events_with_capacity`](Self::events_with_capacity)).
    #[cfg(feature = "tokio")]
    pub fn events(&self) -> crate::asynch::EventStream {
        self.events_with_capacity(crate::asynch::DEFAULT_EVENT_CAPACITY)
    }

    /// Subscribes to the network's events as a [`Stream`](futures_core::Stream) whose queue
    /// holds `capacity` events (at least one). Each subscriber has its own queue; when it is
    /// full the oldest event goes and the stream yields `Err(Lagged(n))` in place of the `n`
    /// lost ones.
    #[cfg(feature = "tokio")]
    pub fn events_with_capacity(&self, capacity: usize) -> crate::asynch::EventStream {
        crate::asynch::EventStream::new(&self.driver, capacity)
    }
}
