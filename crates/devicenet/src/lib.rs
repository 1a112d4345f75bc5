//! DeviceNet (CIP on CAN, ODVA DeviceNet specification volume 3) for a master of group 2 only
//! slaves through the Predefined Master/Slave Connection Set: what a GEMÜ 1436 cPos and most
//! simple DeviceNet devices speak.
//!
//! Layers, bottom up:
//! - [`id`]: the 11-bit identifier of message groups 1..=4 and the predefined set's messages.
//! - [`status`]: CIP general status codes ([`GeneralStatus`], [`CipError`]).
//! - [`fragment`]: the explicit (acknowledged) and I/O fragmentation protocols.
//! - [`explicit`]: the explicit message header, frames and the services used here
//!   (Get/Set_Attribute_Single, Allocate/Release_Master/Slave_Connection_Set, Error Response).
//! - [`identity`]: the Identity object's attributes and the Duplicate MAC ID check message.
//! - [`frame`]: any CAN frame decoded as DeviceNet, with a one-line `Display` (for monitors).
//! - [`master`] and [`slave`]: sans-IO machines. Feed `handle_frame(now, frame)` and
//!   `handle_timeout(now)`, drain `poll_transmit()` and `poll_event()`, call again at
//!   `poll_timeout()`. No sockets, threads or clocks inside.
//!
//! Every decoder is total: bytes become a typed value or a typed error, never a panic.
//! `#![no_std]` without an allocator when built with `default-features = false`.
//!
//! Left out: UCMM (group 3 unconnected messaging) and dynamic I/O connections, bit-strobe,
//! multicast poll, change-of-state and cyclic connections, the 8/16, 16/8 and 16/16 message body
//! formats, the offline connection set and faulted-node recovery, Get_Attributes_All, and the
//! physical layer (bit timing is the CAN controller's business).

#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(any(test, feature = "std"))]
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

pub mod explicit;
pub mod fragment;
pub mod frame;
pub mod id;
pub mod identity;
mod link;
pub mod master;
pub mod slave;
pub mod status;

pub use explicit::{AllocationChoice, ExplicitFrame, Header, Path, Request, Response};
pub use frame::{Decoded, decode};
pub use id::{DnId, MacId, Predefined};
pub use identity::{DuplicateMacCheck, Identity};
pub use master::{Master, MasterConfig, MasterEvent, MasterState};
pub use slave::{Application, Slave, SlaveConfig, SlaveEvent};
pub use status::{CipError, GeneralStatus};

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
        let e = crate::MacId::new(64).unwrap_err();
        assert_eq!(e.to_string(), "MAC ID 64 is out of range (0..=63)");
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
