//! The Bürkert CANopen device profile, objects 0x2000..0x257F, as typed Rust.
//!
//! Bürkert fluid-control devices (valves, sensors) follow CiA 301 and CiA 305 and add a
//! manufacturer profile documented in Bürkert's "CANopen network configuration" manual. This crate
//! types every object and rule of that profile:
//!
//! - [`ne107`] — the NAMUR NE 107 device status of 0x2004 sub 1 and its priority order.
//! - [`colour`] — LED colour codes: seven predefined colours and user RGB `0x00BBGGRR`.
//! - [`comm`] — 0x2001 device communication: bit-rate codes, bUS mode, reset, CAN status, EDS version.
//! - [`status`] — 0x2004 device status: temperatures, voltages, counters, transferable memory.
//! - [`led`] — LED modes (0x2120), valve-mode colours (0x2121), the external colour (0x2122) and
//!   the colour the status LED shows for a given device state.
//!
//! - [`objects`] — a typed [`canola_od::Entry`] for every sub-object of
//!   `eds/burkert-generic.eds` (communication objects included), generated at build time by
//!   `canola-codegen`, plus the static dictionary `objects::DICTIONARY`.
//!
//! The core is `#![no_std]` without an allocator; the `alloc` feature (on with `std`) types the
//! string and DOMAIN entries as owned values.
//!
//! The `master` feature (std, depends on the `canola` master) adds:
//! - `master` — `BurkertNode`, the profile's operations over a `canola::Node`;
//! - `sim` — `BurkertDevice`, a simulated Bürkert device for the in-memory bus or SocketCAN;
//! - `demo` — a short walkthrough (status with the LED colour, locate, logbook download).
#![no_std]

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

pub mod colour;
pub mod comm;
pub mod led;
pub mod ne107;

/// Typed entries generated from `eds/burkert-generic.eds`: VAR objects as constants, ARRAY and
/// RECORD objects as modules (e.g. `objects::device_status_object::DEVICE_STATUS_NAMUR_NE107`).
pub mod objects {
    include!(concat!(env!("OUT_DIR"), "/burkert-generic.rs"));
}
pub mod status;

#[cfg(feature = "master")]
pub mod demo;
#[cfg(feature = "master")]
pub mod master;
#[cfg(feature = "master")]
pub mod sim;

/// The generic Bürkert EDS (`eds/burkert-generic.eds`) the entries are generated from.
pub const GENERIC_EDS: &str = include_str!("../burkert-generic.eds");

pub use colour::{ColourError, LedColour, PredefinedColour};
pub use comm::{
    BitRate, BusMode, CanOperationStatus, CommValueError, EdsVersion, ResetCommand, Termination,
};
pub use led::{LedIndication, LedMode, LedModeError, LedState, ValveModeColours, ValvePosition};
pub use ne107::Ne107Status;
pub use status::{DeviceStatus, Kelvin, TransMemStatus};

#[cfg(feature = "master")]
pub use master::{BurkertNode, DeviceReport, OutsideManual};
#[cfg(feature = "master")]
pub use sim::{BurkertDevice, SimulatedDevice};

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
        let e = crate::led::LedMode::from_u32(5).unwrap_err();
        assert_eq!(
            e.to_string(),
            "5 is not a Bürkert LED mode (0 NAMUR, 2 valve, 3 valve + warnings, 4 fixed colour, 6 off)"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
