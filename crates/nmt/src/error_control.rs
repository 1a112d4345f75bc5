//! Error control messages (CiA 301 §7.2.8.3.2) on COB-ID 0x700 + node-ID: boot-up, heartbeat
//! and node guarding.
//!
//! - Boot-up and heartbeat: a data frame with one byte, the [`NmtState`] (0x00 = boot-up).
//! - Node guarding: the NMT master sends a remote frame; the node answers with one byte, bit 7 the
//!   toggle bit (0 in the first answer after the guarding protocol starts, then alternating), bits
//!   0..=6 the state.
//!
//! Heartbeat and guarding answers look the same on the wire; which one a byte is depends on the
//! protocol the master runs for that node, so [`ErrorControlFrame`] hands the raw byte over and
//! [`Heartbeat::parse`] / [`GuardResponse::parse`] interpret it. Parsing never panics.

use core::fmt;

use canola_frame::cob::FunctionCode;
use canola_frame::{CanFrame, NodeId};

use crate::error::DecodeError;
use crate::state::NmtState;
use crate::util::{data_frame, remote_frame};

/// The error-control COB-ID of `node` (0x700 + node-ID).
pub const fn error_control_cob_id(node: NodeId) -> u16 {
    FunctionCode::NmtErrorControl.cob_id(node)
}

fn one_byte(data: &[u8], message: &'static str) -> Result<u8, DecodeError> {
    match *data {
        [b] => Ok(b),
        _ => Err(DecodeError::Length {
            message,
            actual: data.len(),
        }),
    }
}

/// A heartbeat or boot-up message: one byte, the producer's NMT state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Heartbeat {
    /// The producer's state; [`NmtState::BootUp`] for the boot-up message.
    pub state: NmtState,
}

impl Heartbeat {
    /// The boot-up message.
    pub const BOOT_UP: Heartbeat = Heartbeat {
        state: NmtState::BootUp,
    };

    /// Decodes the data bytes (exactly one).
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        one_byte(data, "heartbeat").map(|b| Self {
            state: NmtState::from_u8(b),
        })
    }

    /// The data byte.
    pub const fn emit(&self) -> u8 {
        self.state.to_u8()
    }

    /// Whether this is the boot-up message.
    pub fn is_boot_up(&self) -> bool {
        self.state == NmtState::BootUp
    }

    /// The frame `node` sends.
    pub fn to_frame(&self, node: NodeId) -> CanFrame {
        data_frame(error_control_cob_id(node), &[self.emit()])
    }
}

impl fmt::Display for Heartbeat {
    /// `heartbeat Operational`; `boot-up` for the boot-up message.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_boot_up() {
            f.write_str("boot-up")
        } else {
            write!(f, "heartbeat {}", self.state)
        }
    }
}

/// A node's answer to a node-guarding request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GuardResponse {
    /// Bit 7.
    pub toggle: bool,
    /// Bits 0..=6. A state wider than seven bits loses bit 7 when emitted.
    pub state: NmtState,
}

impl GuardResponse {
    /// Decodes the data bytes (exactly one).
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        one_byte(data, "node-guarding response").map(Self::from_byte)
    }

    /// Splits the byte into toggle bit and state.
    pub const fn from_byte(b: u8) -> Self {
        Self {
            toggle: b & 0x80 != 0,
            state: NmtState::from_u8(b & 0x7F),
        }
    }

    /// The data byte.
    pub const fn emit(&self) -> u8 {
        ((self.toggle as u8) << 7) | (self.state.to_u8() & 0x7F)
    }

    /// The frame `node` sends.
    pub fn to_frame(&self, node: NodeId) -> CanFrame {
        data_frame(error_control_cob_id(node), &[self.emit()])
    }
}

impl fmt::Display for GuardResponse {
    /// `node guarding response Operational, toggle 1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "node guarding response {}, toggle {}",
            self.state,
            u8::from(self.toggle)
        )
    }
}

/// The node-guarding request the master sends: a remote frame on 0x700 + node-ID with DLC 1.
pub fn guard_request(node: NodeId) -> CanFrame {
    remote_frame(error_control_cob_id(node), 1)
}

/// A frame on an error-control COB-ID, split by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorControlFrame {
    /// A remote frame: a node-guarding request (master to node).
    GuardRequest,
    /// A one-byte data frame: boot-up, heartbeat or node-guarding response (node to master).
    Payload(u8),
}

impl ErrorControlFrame {
    /// Classifies a frame on 0x701..=0x77F and returns the node it belongs to.
    pub fn from_frame(frame: &CanFrame) -> Result<(NodeId, Self), DecodeError> {
        let raw = frame.cob_id();
        let node = match raw {
            Some(cob @ 0x701..=0x77F) => NodeId::new((cob & 0x7F) as u8).ok(),
            _ => None,
        };
        let Some(node) = node else {
            return Err(DecodeError::WrongCobId(frame.id().as_raw()));
        };
        if frame.is_remote() {
            return Ok((node, Self::GuardRequest));
        }
        one_byte(frame.data(), "error control").map(|b| (node, Self::Payload(b)))
    }
}

/// A frame on an error-control COB-ID with the node it belongs to: what a bus monitor shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ErrorControlMessage {
    /// The node (0x700 + node-ID).
    pub node: NodeId,
    /// What the frame is.
    pub kind: ErrorControlFrame,
}

impl ErrorControlMessage {
    /// Classifies a frame on 0x701..=0x77F (see [`ErrorControlFrame::from_frame`]).
    pub fn from_frame(frame: &CanFrame) -> Result<Self, DecodeError> {
        ErrorControlFrame::from_frame(frame).map(|(node, kind)| Self { node, kind })
    }

    /// The frame on 0x700 + node: a remote frame (DLC 1) for a guarding request, else one
    /// data byte.
    pub fn to_frame(&self) -> CanFrame {
        match self.kind {
            ErrorControlFrame::GuardRequest => guard_request(self.node),
            ErrorControlFrame::Payload(b) => data_frame(error_control_cob_id(self.node), &[b]),
        }
    }
}

impl fmt::Display for ErrorControlMessage {
    /// `node guarding request node 5`, `boot-up node 5`, `heartbeat node 5 Operational`, or
    /// `node guarding response node 5 Operational, toggle 1`.
    ///
    /// A data byte with bit 7 set can only be a node-guarding answer (toggle 1); one with bit 7
    /// clear reads as a heartbeat, though a node that is guarded sends the same byte as its
    /// answer with toggle 0: which one it is depends on the protocol the master runs.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let node = self.node;
        match self.kind {
            ErrorControlFrame::GuardRequest => write!(f, "node guarding request node {node}"),
            ErrorControlFrame::Payload(0) => write!(f, "boot-up node {node}"),
            ErrorControlFrame::Payload(b) if b & 0x80 != 0 => {
                let r = GuardResponse::from_byte(b);
                write!(
                    f,
                    "node guarding response node {node} {}, toggle {}",
                    r.state,
                    u8::from(r.toggle)
                )
            }
            ErrorControlFrame::Payload(b) => {
                write!(f, "heartbeat node {node} {}", NmtState::from_u8(b))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;
    use proptest::prelude::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn byte_vectors() {
        // Boot-up of node 5: 705#00; heartbeat pre-operational 705#7F; operational 705#05.
        assert_eq!(Heartbeat::BOOT_UP.to_frame(node(5)).to_string(), "705#00");
        let hb = Heartbeat::parse(&[0x7F]).unwrap();
        assert_eq!(hb.state, NmtState::PreOperational);
        assert_eq!(
            Heartbeat {
                state: NmtState::Operational
            }
            .to_frame(node(0x7F))
            .to_string(),
            "77F#05"
        );
        assert_eq!(Heartbeat::parse(&[0x04]).unwrap().state, NmtState::Stopped);
        assert_eq!(
            Heartbeat::parse(&[0x33]).unwrap().state,
            NmtState::Unknown(0x33)
        );
        assert!(Heartbeat::parse(&[]).is_err());
        assert!(Heartbeat::parse(&[0, 0]).is_err());

        // Guarding: request 705#R1; answers 0x85 (toggle 1, operational), 0x7F (toggle 0, pre-op).
        assert_eq!(guard_request(node(5)).to_string(), "705#R1");
        let r = GuardResponse::parse(&[0x85]).unwrap();
        assert!(r.toggle);
        assert_eq!(r.state, NmtState::Operational);
        let r = GuardResponse::parse(&[0x7F]).unwrap();
        assert!(!r.toggle);
        assert_eq!(r.state, NmtState::PreOperational);
        assert_eq!(
            GuardResponse {
                toggle: true,
                state: NmtState::Stopped
            }
            .to_frame(node(1))
            .to_string(),
            "701#84"
        );
    }

    #[test]
    fn classify() {
        assert_eq!(
            ErrorControlFrame::from_frame(&guard_request(node(3))),
            Ok((node(3), ErrorControlFrame::GuardRequest))
        );
        assert_eq!(
            ErrorControlFrame::from_frame(&data_frame(0x77F, &[5])),
            Ok((node(127), ErrorControlFrame::Payload(5)))
        );
        assert_eq!(
            ErrorControlFrame::from_frame(&data_frame(0x700, &[5])),
            Err(DecodeError::WrongCobId(0x700))
        );
        assert_eq!(
            ErrorControlFrame::from_frame(&data_frame(0x585, &[5])),
            Err(DecodeError::WrongCobId(0x585))
        );
        assert!(ErrorControlFrame::from_frame(&data_frame(0x705, &[5, 5])).is_err());
    }

    #[test]
    fn texts() {
        let text = |f: CanFrame| ErrorControlMessage::from_frame(&f).unwrap().to_string();
        assert_eq!(text(guard_request(node(5))), "node guarding request node 5");
        assert_eq!(text(Heartbeat::BOOT_UP.to_frame(node(5))), "boot-up node 5");
        assert_eq!(
            text(data_frame(0x705, &[0x05])),
            "heartbeat node 5 Operational"
        );
        assert_eq!(
            text(data_frame(0x70A, &[0x7F])),
            "heartbeat node 10 Pre-operational"
        );
        assert_eq!(
            text(data_frame(0x705, &[0x84])),
            "node guarding response node 5 Stopped, toggle 1"
        );
        assert_eq!(
            text(data_frame(0x705, &[0x33])),
            "heartbeat node 5 unknown state 0x33"
        );
        assert_eq!(
            Heartbeat {
                state: NmtState::Stopped
            }
            .to_string(),
            "heartbeat Stopped"
        );
        assert_eq!(Heartbeat::BOOT_UP.to_string(), "boot-up");
        assert_eq!(
            GuardResponse::from_byte(0x85).to_string(),
            "node guarding response Operational, toggle 1"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn round_trips(b in any::<u8>()) {
            prop_assert_eq!(Heartbeat::parse(&[b]).unwrap().emit(), b);
            let g = GuardResponse::parse(&[b]).unwrap();
            prop_assert_eq!(g.emit(), b);
            prop_assert_eq!(GuardResponse::from_byte(g.emit()), g);
        }
    }
}
