//! USDO, the universal SDO of CANopen FD (CiA 1301): read and write any object of a device's
//! object dictionary over CAN FD frames of up to 64 bytes, several transfers at once.
//!
//! - [`wire`]: the frames. [`UsdoPacket`] is the raw view, [`UsdoMessage`] the typed frame with
//!   a total `parse` and an `emit`; [`UsdoAbortCode`] the 1-byte abort codes and their mapping
//!   to and from CiA 301 [`AbortCode`](crate::AbortCode)s.
//! - [`assumed`]: every value that public sources do not establish, in one table.
//!
//! # Sources
//!
//! The CiA 1301 text is not public. This module follows:
//!
//! - **CiA and tool-vendor prose** (can-cia.org "Universal SDO" pages, emotas and
//!   canopensolutions.com USDO pages): one USDO service per node with the source node-ID in the
//!   CAN-ID; a destination byte; a session-ID as transaction number so a client runs several
//!   accesses to one server in parallel; a data type byte the receiver can check; expedited
//!   transfers of up to 56 data bytes; every segment confirmed; a client-side response timeout
//!   after which late responses are ignored.
//! - **SOFA-CANopenFD** (EmSA, Gen 1, `fbsec_co_fd_usdo.{h,c}`, citing CiA 1301 v1.1 tables 22,
//!   31, 32; one code base, not cross-checked): the byte layout (sub-index before index), the
//!   command specifier values, the 60-byte segments with a counter from 0 and no toggle bit,
//!   the 7-byte abort with code 0x7F and a 1-byte abort code, the abort code values, the
//!   CAN-IDs 0x600 / 0x580 + sender, zero padding. All of it is listed in [`assumed`].
//! - **Own choices** where nothing is published (also in [`assumed`]): the abort codes sent on
//!   timeout, cancel and a busy server, the counter wrapping modulo 256, the default timeout.
//!
//! Not implemented because not established: broadcast and multicast destinations, bulk
//! transfer, remote (routed) services.
//!
//! The master's `node.usdo()`, the device simulator's USDO server and the CLI's `canopen usdo`
//! run these machines over CAN FD frames in the `canola` facade.

mod abort;
pub mod assumed;
pub mod client;
pub mod server;
pub mod wire;

pub use abort::UsdoAbortCode;
pub use client::{
    UsdoBusy, UsdoClient, UsdoClientConfig, UsdoErrorKind, UsdoEvent, UsdoTransferError,
};
pub use server::{MAX_SESSIONS, UsdoBytes, UsdoServer, UsdoServerConfig, UsdoServerEvent};
pub use wire::{
    DataType, MAX_EXPEDITED, MAX_FRAME, UsdoBody, UsdoDecodeError, UsdoEncodeError, UsdoMessage,
    UsdoPacket,
};

#[cfg(test)]
mod tests;
