//! The lowest layer of the CANopen stack: what travels on a classic or CAN FD bus, and the clock.
//!
//! - [`CanId`] — an 11-bit standard or 29-bit extended identifier, validated on construction.
//! - [`CanFrame`] — a classic CAN data or remote frame with 0..=8 data bytes; implements
//!   [`embedded_can::Frame`].
//! - [`FdFrame`] — a CAN FD frame with 0..=64 data bytes, [`FdFlags`] (BRS, ESI) and the DLC
//!   table in [`fd`]; converts to and from [`CanFrame`] where nothing is lost.
//! - [`NodeId`] — a CANopen node-ID, 1..=127 (CiA 301 §7.5.2.1).
//! - [`cob`] — the predefined connection set of CiA 301 §7.3.5 (and CiA 305 for LSS): which
//!   function a COB-ID belongs to and for which node, and the CAN identifiers CiA 301
//!   restricts ([`is_restricted`]).
//! - [`time`] — microsecond [`Instant`] and [`Duration`]. The protocol crates never read a clock;
//!   callers pass the current instant in, so every timeout is testable on a virtual clock.
//! - [`timer`] — [`Periodic`] timers for producers, [`is_due`] and [`earliest`] for deadlines.
//!
//! The crate is `#![no_std]` without an allocator; the `std` feature (default) adds
//! `Instant::now`-style conveniences where a real clock exists and `std::error::Error` through
//! `core::error::Error`.
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

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

mod bitrate;
pub mod cob;
pub mod fd;
mod frame;
pub mod id;
mod node;
pub mod time;
pub mod timer;

pub use bitrate::parse_bitrate;
pub use cob::{CobId, FunctionCode, PdoNumber, is_restricted};
pub use fd::{FdFlags, FdFrame};
pub use frame::{CanFrame, FrameError, HexBytes};
pub use id::{CanId, Candump, ExtendedId, IdError, StandardId};
pub use node::{NodeId, NodeIdError};
pub use time::{Duration, Instant};
pub use timer::{Periodic, earliest, is_due};

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
        let e = crate::NodeId::new(0).unwrap_err();
        assert_eq!(e.to_string(), "node-ID 0 is outside 1..=127");
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
