//! COB-IDs of an SDO channel (CiA 301 §7.2.4.2 and objects 0x1200 / 0x1280): requests go
//! client → server on 0x600 + node, responses server → client on 0x580 + node in the
//! predefined connection set; other channels are configured in the SDO parameter records.
//!
//! [`SdoCobIds`] is the one path from a channel to its identifiers, for the client and the
//! server side alike:
//!
//! - the default channel of a node: [`SdoCobIds::default_for`];
//! - any other channel — a device's further SDO servers 0x1201..=0x127F, a changed 0x1200, or
//!   the master's client parameters 0x1280..=0x12FF — from the COB-ID entries of its parameter
//!   record: [`SdoCobIds::from_parameters`] with sub-index 1 (client → server) and 2 (server →
//!   client), e.g. after reading 0x1201:01 and 0x1201:02 over the default channel;
//!   [`SdoCobIds::to_parameters`] gives the values to write into such a record;
//! - identifiers known otherwise: [`SdoCobIds::new`].
//!
//! The machines take and give the eight data bytes; [`Client::handle_frame`](crate::Client::handle_frame),
//! [`Client::poll_transmit_frame`](crate::Client::poll_transmit_frame) and their
//! [`Server`](crate::Server) twins are the frame adapters over one `SdoCobIds`.

use canola_frame::{CanFrame, CanId, NodeId};

/// The pair of CAN identifiers one SDO channel uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SdoCobIds {
    /// Client → server (requests).
    pub request: CanId,
    /// Server → client (responses).
    pub response: CanId,
}

/// Bit 31 of an SDO parameter COB-ID: the channel is not valid.
const COB_INVALID: u32 = 1 << 31;
/// Bit 29: 29-bit (extended) identifier.
const COB_EXTENDED: u32 = 1 << 29;

/// The index of a device's first SDO server parameter record (0x1200); servers 2..=128 follow
/// at 0x1201..=0x127F.
pub const SDO_SERVER_PARAMETER: u16 = 0x1200;
/// The index of the first SDO client parameter record (0x1280); clients 2..=128 follow at
/// 0x1281..=0x12FF.
pub const SDO_CLIENT_PARAMETER: u16 = 0x1280;

impl SdoCobIds {
    /// A channel with requests on `request` (client → server) and responses on `response`.
    pub const fn new(request: CanId, response: CanId) -> Self {
        Self { request, response }
    }

    /// The default SDO channel of `node`: requests 0x600 + node, responses 0x580 + node.
    #[inline]
    pub fn default_for(node: NodeId) -> Self {
        let id = |base: u16| {
            CanId::standard(base + u16::from(node.get())).unwrap_or_else(|_| unreachable!())
        };
        Self {
            request: id(0x600),
            response: id(0x580),
        }
    }

    /// From the COB-ID entries of an SDO parameter record (sub-index 1: client → server,
    /// sub-index 2: server → client, as in 0x1280 / 0x1200). `None` when either is marked not
    /// valid (bit 31) or out of range.
    pub fn from_parameters(client_to_server: u32, server_to_client: u32) -> Option<Self> {
        Some(Self {
            request: parameter_id(client_to_server)?,
            response: parameter_id(server_to_client)?,
        })
    }

    /// The COB-ID entries of an SDO parameter record for this channel: (sub-index 1, client →
    /// server; sub-index 2, server → client), valid, with bit 29 set for 29-bit identifiers.
    /// [`from_parameters`](Self::from_parameters) reads them back.
    pub fn to_parameters(&self) -> (u32, u32) {
        (
            parameter_value(self.request),
            parameter_value(self.response),
        )
    }

    /// A request frame (client side) carrying `data`.
    #[inline]
    pub fn request_frame(&self, data: [u8; 8]) -> CanFrame {
        CanFrame::from_array(self.request, data)
    }

    /// A response frame (server side) carrying `data`.
    #[inline]
    pub fn response_frame(&self, data: [u8; 8]) -> CanFrame {
        CanFrame::from_array(self.response, data)
    }

    /// Whether `frame` is a data frame on this channel's response identifier.
    #[inline]
    pub fn is_response(&self, frame: &CanFrame) -> bool {
        frame.id() == self.response && !frame.is_remote()
    }

    /// Whether `frame` is a data frame on this channel's request identifier.
    #[inline]
    pub fn is_request(&self, frame: &CanFrame) -> bool {
        frame.id() == self.request && !frame.is_remote()
    }
}

fn parameter_value(id: CanId) -> u32 {
    if id.is_extended() {
        COB_EXTENDED | id.as_raw()
    } else {
        id.as_raw()
    }
}

fn parameter_id(raw: u32) -> Option<CanId> {
    if raw & COB_INVALID != 0 {
        return None;
    }
    if raw & COB_EXTENDED != 0 {
        CanId::extended(raw & 0x1FFF_FFFF).ok()
    } else {
        u16::try_from(raw & 0x1FFF_FFFF)
            .ok()
            .and_then(|id| CanId::standard(id).ok())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_channel() {
        let node = NodeId::new(5).unwrap();
        let ids = SdoCobIds::default_for(node);
        assert_eq!(ids.request, CanId::standard(0x605).unwrap());
        assert_eq!(ids.response, CanId::standard(0x585).unwrap());
        let frame = ids.request_frame([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
        assert!(ids.is_request(&frame));
        assert!(!ids.is_response(&frame));
        assert_eq!(frame.data(), &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    }

    #[test]
    fn parameters() {
        assert_eq!(
            SdoCobIds::from_parameters(0x605, 0x585),
            Some(SdoCobIds::default_for(NodeId::new(5).unwrap()))
        );
        assert_eq!(SdoCobIds::from_parameters(0x8000_0605, 0x585), None);
        assert_eq!(SdoCobIds::from_parameters(0x800, 0x585), None);
        let ext = SdoCobIds::from_parameters(0x2000_1234, 0x585).unwrap();
        assert_eq!(ext.request, CanId::extended(0x1234).unwrap());
        assert_eq!(ext.to_parameters(), (0x2000_1234, 0x585));
        // A second server channel of node 5 on 0x641 / 0x5C1 (0x1201:01 / 0x1201:02).
        let second = SdoCobIds::from_parameters(0x641, 0x5C1).unwrap();
        assert_eq!(
            second,
            SdoCobIds::new(
                CanId::standard(0x641).unwrap(),
                CanId::standard(0x5C1).unwrap()
            )
        );
        assert_eq!(second.to_parameters(), (0x641, 0x5C1));
        let default = SdoCobIds::default_for(NodeId::new(5).unwrap());
        assert!(!second.is_response(&default.response_frame([0; 8])));
    }
}
