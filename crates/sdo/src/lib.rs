//! CANopen SDO (service data objects, CiA 301 §7.2.4): read and write any object of a device's
//! object dictionary, expedited, segmented or by block.
//!
//! The crate has two layers, like smoltcp:
//!
//! - [`wire`]: the messages. [`ClientRequest`], [`ServerResponse`] and [`BlockSegment`] parse
//!   eight data bytes (totally: never a panic) and emit them again. [`AbortCode`] holds the
//!   CiA 301 abort code table, [`crc16`] the CRC of block transfers.
//! - [`client`] and [`server`]: sans-IO state machines. They take the current
//!   [`Instant`](canola_frame::Instant) and the received bytes, and give back bytes to send,
//!   events and their next deadline; no clock, socket or thread inside. [`SdoCobIds`] turns
//!   their bytes into CAN frames for a node.
//!
//! - [`usdo`]: the universal SDO of CANopen FD (CiA 1301) over CAN FD frames: its codec, its
//!   1-byte abort codes and sans-IO client and server machines with several sessions.
//!
//! A client and a server wired back to back:
//!
//! ```
//! use canola_frame::Instant;
//! use canola_sdo::{
//!     AbortCode, Access, Client, ClientConfig, Event, Method, Multiplexer, ObjectAccess,
//!     ObjectInfo, Server, ServerConfig,
//! };
//!
//! /// One read-only UNSIGNED32 at 0x1000:00.
//! struct DeviceType;
//! impl ObjectAccess for DeviceType {
//!     fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
//!         match (mux.index, mux.subindex) {
//!             (0x1000, 0) => Ok(ObjectInfo::fixed(Access::ReadOnly, 4)),
//!             (0x1000, _) => Err(AbortCode::SUBINDEX_DOES_NOT_EXIST),
//!             _ => Err(AbortCode::OBJECT_DOES_NOT_EXIST),
//!         }
//!     }
//!     fn read(&mut self, _: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
//!         let value = 0x0002_0191u32.to_le_bytes();
//!         let rest = &value[(offset as usize).min(4)..];
//!         let n = rest.len().min(buf.len());
//!         buf[..n].copy_from_slice(&rest[..n]);
//!         Ok(n)
//!     }
//!     fn write(&mut self, _: Multiplexer, _: u32, _: &[u8]) -> Result<(), AbortCode> {
//!         Err(AbortCode::READ_ONLY)
//!     }
//!     fn commit(&mut self, _: Multiplexer, _: u32) -> Result<(), AbortCode> {
//!         Err(AbortCode::READ_ONLY)
//!     }
//! }
//!
//! let now = Instant::ZERO;
//! let mut client: Client<heapless::Vec<u8, 16>, &[u8]> = Client::new(ClientConfig::default());
//! let mut server = Server::new(ServerConfig::default());
//! client
//!     .start_upload(now, Multiplexer::new(0x1000, 0), heapless::Vec::new(), Method::Normal)
//!     .unwrap();
//! while let Some(request) = client.poll_transmit() {
//!     server.handle_request(now, &request, &mut DeviceType);
//!     while let Some(response) = server.poll_transmit() {
//!         client.handle_response(now, &response);
//!     }
//! }
//! match client.poll_event() {
//!     Some(Event::Uploaded { sink, .. }) => assert_eq!(&sink[..], &[0x91, 0x01, 0x02, 0x00]),
//!     other => panic!("{other:?}"),
//! }
//! ```
//!
//! # Wiring it into a master or a device
//!
//! - Master: one [`Client`] per server channel (e.g. `Client<Vec<u8>, Vec<u8>>` with
//!   `alloc`), one transfer at a time; queue further requests until [`Client::is_idle`]. The
//!   channel's [`SdoCobIds`] is the one path to its identifiers: [`SdoCobIds::default_for`] the
//!   node (0x600 / 0x580 + node), or [`SdoCobIds::from_parameters`] with the COB-IDs of a
//!   parameter record (a device's second server 0x1201, a changed 0x1200, or 0x1280). Send
//!   [`Client::poll_transmit_frame`] and offer received frames to [`Client::handle_frame`]
//!   (the frame adapters over [`Client::poll_transmit`] / [`Client::handle_response`]). A failed transfer gives a
//!   [`TransferError`] with index, sub-index and [`TransferError::abort_code`];
//!   [`TransferError::is_server_abort`] tells the device's refusal from local failures. The
//!   node is the master's to add.
//! - Device simulator: one [`Server`] per SDO channel, fed with [`Server::handle_frame`] (or
//!   [`Server::handle_request`] with the data bytes) and an [`ObjectAccess`] implementation over
//!   the object dictionary; its answers from [`Server::poll_transmit_frame`].
//!
//! The machines take and give the eight data bytes rather than parsed messages: the segments
//! of a block transfer's sub-block cannot be told from other messages by their bytes, so only
//! the machine, which knows whether it expects a sub-block, can parse what arrives (see
//! [`wire`]).
//!
//! The crate is `#![no_std]` without an allocator; `alloc` adds [`Sink`]/[`Source`] for `Vec`
//! and `Box`, `std` (default) implies `alloc`.
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(feature = "alloc")]
extern crate alloc;
#[cfg(feature = "std")]
extern crate std;

/// Implements `Debug` as the `Display` text for this crate's error types (the error
/// convention in `docs/STYLE.md`): a `main` that returns one of them with `?` prints readable
/// English, not the structure; a program inspects the structure through its fields.
macro_rules! debug_as_display {
    ($name:ident $(<$($g:ident),+>)?) => {
        impl$(<$($g),+>)? core::fmt::Debug for $name$(<$($g),+>)?
        where
            Self: core::fmt::Display,
        {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                core::fmt::Display::fmt(self, f)
            }
        }
    };
}

mod abort;
pub mod buffer;
pub mod client;
mod cob;
mod crc;
mod error;
mod queue;
pub mod server;
mod subblock;
pub mod usdo;
pub mod wire;

/// How many sub-blocks in a row may end without a single segment in sequence before the
/// receiving side of a block transfer aborts it (0x05040003, invalid sequence number).
///
/// CiA 301 sets no limit: a receiver acknowledges the last good segment and the sender repeats
/// from there, and each of those rounds rearms the receiver's timeout. A lost frame costs one
/// round. But two block machines out of step (a block upload client fed a server's stale block
/// download acknowledgements, which parse as segments, and the server taking the client's
/// acknowledgements as segments in turn) can acknowledge each other forever without a timeout
/// ever firing; this bound ends that after a few frames.
pub const MAX_FRUITLESS_SUB_BLOCKS: u8 = 8;

pub use abort::AbortCode;
pub use buffer::{Full, Sink, SliceSink, Source};
pub use client::{
    Buffer, Busy, Client, ClientConfig, Direction, ErrorKind, Event, Method, Progress,
    TransferError, Violation,
};
pub use cob::{SDO_CLIENT_PARAMETER, SDO_SERVER_PARAMETER, SdoCobIds};
pub use crc::{Crc16, crc16};
pub use server::{Access, LengthRule, ObjectAccess, ObjectInfo, Server, ServerConfig, ServerEvent};
pub use wire::{
    BlockSegment, ClientRequest, DecodeError, Initiate, Multiplexer, Segment, ServerResponse,
};

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` that
/// returns this crate's error with `?` prints `Error: ` and the text.
#[cfg(test)]
mod error_convention {
    extern crate std;
    use std::{format, string::ToString};

    #[test]
    fn main_prints_the_text() {
        let e = crate::ServerResponse::parse(&[]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "an SDO message has 1..=8 data bytes, this one has 0"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
