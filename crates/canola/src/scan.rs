//! Finding the nodes on a bus: an SDO upload of the identity object (0x1018, CiA 301 §7.5.2.13)
//! from every node-ID at once; the nodes that answer are there.
//!
//! All 127 first reads are submitted together (different nodes run in parallel), so a scan
//! takes about one response timeout, not 127 of them.

use canola_frame::{Duration, NodeId};

use crate::network::operation::{self, Req};
use crate::network::{Network, Operation, Sdo};

/// The identity object (0x1018) of a node: sub-index 1 (vendor-ID) is mandatory, the others
/// are `None` when the node does not implement them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Identity {
    /// 0x1018:01.
    pub vendor_id: u32,
    /// 0x1018:02.
    pub product_code: Option<u32>,
    /// 0x1018:03.
    pub revision: Option<u32>,
    /// 0x1018:04.
    pub serial: Option<u32>,
}

/// `vendor-ID 0x00000039, product code 0x00001234, revision 0x00010002, serial number
/// 0x00BC614E`: each value as CANopen writes identity values, the ones the node does not
/// implement left out.
impl core::fmt::Display for Identity {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "vendor-ID 0x{:08X}", self.vendor_id)?;
        for (name, v) in [
            ("product code", self.product_code),
            ("revision", self.revision),
            ("serial number", self.serial),
        ] {
            if let Some(v) = v {
                write!(f, ", {name} 0x{v:08X}")?;
            }
        }
        Ok(())
    }
}

/// A node that answered a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScannedNode {
    /// Its node-ID.
    pub node: NodeId,
    /// Its identity object.
    pub identity: Identity,
}

fn u32_of(bytes: &[u8]) -> Option<u32> {
    bytes
        .get(..4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

impl Network {
    /// The nodes that answer an SDO read of 0x1018:01 within `timeout`, in node-ID order, with
    /// their identity (sub-indices 2..=4 read from each node found, all at once). Dropping the
    /// operation cancels the reads.
    pub fn scan(&self, timeout: impl Into<Duration>) -> Operation<'static, Vec<ScannedNode>> {
        scan_on(self, timeout.into())
    }
}

/// The scan of [`Network::scan`] on `net`.
fn scan_on(net: &Network, timeout: Duration) -> Operation<'static, Vec<ScannedNode>> {
    let net = net.clone();
    Operation::new(async move {
        operation::catch_up(net.shared())?;
        let read = |node: NodeId, sub: u8| {
            Sdo::new(net.clone(), node)
                .timeout(timeout)
                .submit_read((0x1018, sub))
                .into_req()
        };
        let first: Vec<Req> = NodeId::all().filter_map(|n| read(n, 1)).collect();
        let found: Vec<(NodeId, u32)> = operation::wait_requests(net.shared(), first.clone())
            .await
            .into_iter()
            .zip(&first)
            .filter_map(|(r, req)| Some((req.node, u32_of(&r.ok()?.data)?)))
            .collect();
        let rest: Vec<Req> = found
            .iter()
            .flat_map(|&(node, _)| (2..=4u8).filter_map(move |s| read(node, s)))
            .collect();
        let mut values = operation::wait_requests(net.shared(), rest)
            .await
            .into_iter()
            .map(|r| r.ok().as_ref().and_then(|c| u32_of(&c.data)));
        let mut next = || values.next().flatten();
        Ok(found
            .into_iter()
            .map(|(node, vendor_id)| ScannedNode {
                node,
                identity: Identity {
                    vendor_id,
                    product_code: next(),
                    revision: next(),
                    serial: next(),
                },
            })
            .collect())
    })
}
