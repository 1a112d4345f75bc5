//! GEMÜ 1436 cPos valve positioner: the fieldbus-neutral cyclic I/O image, its 8-byte parameter
//! channel, the actions, the parameter table of the manual's chapter 6, a sans-IO client and a
//! simulated positioner.
//!
//! Source: the GEMÜ 1436 cPos DeviceNet manual (chapters 5 and 6) and the Profinet manual's
//! chapter 5.6 (same channel, same actions). The DeviceNet and Profinet variants carry the same
//! bytes; the core does not care what carries them (a fieldbus gateway, a PDO pair, a test
//! harness), and [`over_devicenet`] carries them on DeviceNet itself.
//!
//! Layers, bottom up:
//! - [`image`]: the 13-byte master→device and 11-byte device→master images (big-endian).
//! - [`channel`]: the parameter channel `[toggle, instruction, id_hi, id_lo, v3, v2, v1, v0]`,
//!   the "action already active" answer and the external diagnostic codes.
//! - [`params`]: the parameter table as static data with typed enumerations and range checks.
//! - [`action`]: every action with its request functions and status codes; the error-list codes.
//! - [`client`]: a sans-IO client (request queue, toggle byte, 'N' after queries, one action at a
//!   time, progress and parameter-change events, timeouts).
//! - [`sim`]: a simulated cPos behind the same image, for tests, the CLI and demos.
//! - [`over_devicenet`]: the image in a DeviceNet poll connection (crate `canola-devicenet`): the
//!   client through a DeviceNet master, the simulator behind a DeviceNet slave.
//!
//! Every decoder is total: bytes become a typed value or a typed error, never a panic.
//! `#![no_std]` without an allocator when built with `default-features = false`.
//!
//! # Example: the client against the simulated positioner
//!
//! ```
//! use canola_frame::{Duration, Instant};
//! use canola_gemu::client::{Client, ClientConfig, Event, Reply};
//! use canola_gemu::params::{Mode, ParamId};
//! use canola_gemu::SimulatedCpos;
//!
//! let mut client = Client::new(ClientConfig::default());
//! let mut cpos = SimulatedCpos::default();
//! let mut now = Instant::ZERO;
//! let id = client.set(now, ParamId::MODE, Mode::Manual.to_raw()).unwrap();
//! // The request in the channel is the manual's example: [tg, 'S', 0x00, 0x64, 0, 0, 0, 2].
//! assert_eq!(client.image().channel.to_bytes()[1..], [0x53, 0x00, 0x64, 0, 0, 0, 2]);
//! let mut done = None;
//! while done.is_none() {
//!     now += Duration::from_millis(10); // one bus cycle
//!     cpos.handle_master_image(now, &client.image());
//!     while let Some(d) = cpos.poll_diagnostic() {
//!         client.handle_diagnostic(now, d);
//!     }
//!     client.handle_image(now, &cpos.device_image());
//!     while let Some(e) = client.poll_event() {
//!         if let Event::Completed { id: i, result } = e {
//!             assert_eq!(i, id);
//!             done = Some(result);
//!         }
//!     }
//! }
//! assert_eq!(done, Some(Ok(Reply::Value { param: ParamId::MODE, value: 2 })));
//! ```
//!
//! # Ambiguities of the manuals and how they are resolved
//!
//! Each is explained where it matters; in short:
//! - [`image`]: the valve position's byte numbers under 5.4 contradict the layout table; the
//!   table (bytes 0..1) wins.
//! - [`channel`]: layout of the "action already active" answer (v3 = 0xFF, v2 = source,
//!   v1:v0 = action number); split of the 'D'/'W' value (count v3:v2, code v1:v0, from the two
//!   examples); 'E' error information (code in v1:v0); signed parameter values as two's
//!   complement; diagnostics travel outside the channel.
//! - [`action`]: NoInit's function in the high byte and its overlap with "cannot be started";
//!   what ends each action (GoClose/GoOpen end with "reached" after adopt; "not cleared / not
//!   loaded" keeps the action active; "inactive" is 1 for four actions); GoOpen "adopt" is 0x02
//!   (the German copy prints 0x01); adjust time's status list misplaced in the German OCR.
//! - [`params`]: In 2 = 0x0CE7, DeviceNet Adr = 0x1450, unreadable enumerations as integers
//!   (range 0..=1 from the two-line cells), CalPointQty [1..9], spelling fixes.
//! - [`client`]: while an action runs, the channel keeps its 'A' request (other requests wait),
//!   because the device shows a status only as the answer to the current request; a carrier's
//!   diagnostic is attributed to the request in flight.
//! - [`sim`]: everything the manual leaves open about the device's behaviour (answers to 'S' on a
//!   read-only parameter, error-list size, when an action "cannot be started", the answer to a
//!   refused NoInit, the toggle byte of change notices, defaults).

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

pub mod action;
pub mod channel;
pub mod client;
pub mod image;
pub mod over_devicenet;
pub mod params;
pub mod sim;

pub use action::{ActionId, ActionRequest, ActionStatus, ErrorCode};
pub use channel::{ActionBusy, ActionSource, Channel, DiagnosticCode, Instruction};
pub use client::{
    ActionOutcome, Client, ClientConfig, ClientError, Event, Failure, Refusal, Reply, RequestId,
};
pub use sim::{SimConfig, SimulatedCpos};

pub use image::{DeviceImage, DigitalInputs, DigitalOutputs, ImageError, MasterImage, PerMille};
pub use params::{Access, ParamDef, ParamId, RangeError, Unit, ValueKind};

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
        let e = crate::Channel::parse(&[0; 7]).unwrap_err();
        assert_eq!(e.to_string(), "parameter channel is 7 bytes, expected 8");
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
