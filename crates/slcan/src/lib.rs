//! slcan: CAN over a serial line, the ASCII protocol of Lawicel's CAN232/CANUSB and of the
//! adapters that copied it (CANable with its slcan firmware, USBtin, the Linux kernel's `slcan`
//! line discipline, can-utils' `slcanpty`).
//!
//! Two layers, in the sans-IO manner of the protocol crates:
//!
//! - **The line codec** (no_std, no allocator): [`Command`] is what a host sends (open `O`,
//!   listen-only `L`, close `C`, bit rates `Sn`/`sxxyy`/`Yn`, timestamps `Zn`, queries `V`/`N`/`F`,
//!   and the frame lines `t`/`T`/`r`/`R`/`d`/`D`/`b`/`B`); [`Item`] is what an adapter sends back
//!   (the CR acknowledgement, the BEL error, `z`/`Z` transmit acknowledgements, received frames
//!   with optional timestamps, version, serial number, status flags, and the kernel's bus state
//!   and error lines). [`Decoder`] turns a byte stream in arbitrary chunks into items and typed
//!   [`LineError`]s; a bad line is counted and skipped up to the next CR or BEL, never a panic.
//! - **The link** (feature `serial`, default on): [`Link`] opens a serial port (Linux, macOS,
//!   Windows, through the `serialport` crate), configures the adapter and moves frames with
//!   read timeouts. An adapter that vanishes is [`LinkError::Vanished`]; [`Link::reopen`] starts
//!   again on the same path.
//!
//! Which firmware does what is collected in the crate README with sources; in short: replies are
//! CR (OK) and BEL (error, no CR after it) on Lawicel-style firmware and nothing at all on
//! CANable's official firmware; `S7` is 800 kbit/s on Lawicel and the kernel but 750 kbit/s on
//! CANable ([`BitrateTable`]).
//!
//! CAN FD frames are `canola_frame`'s [`FdFrame`](canola_frame::FdFrame) (its DLC table too):
//! the bit rate switch is its BRS flag.
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
mod command;
mod decoder;
mod error;
mod frame;
mod hex;
#[cfg(feature = "serial")]
mod link;
mod reply;

pub use bitrate::{BitrateTable, Btr, DataBitrate, NominalBitrate, TimestampMode};
pub use command::Command;
pub use decoder::{Decoder, Items};
pub use error::{EncodeError, LineError};
pub use frame::{Frame, RxFrame, Timestamp};
#[cfg(feature = "serial")]
pub use link::{
    AckMode, AdapterInfo, DEFAULT_SERIAL_BAUD, Incoming, Link, LinkConfig, LinkError, LinkStats,
};
pub use reply::{BusErrors, BusState, ErrorState, Item, StatusFlags, Text};

/// The longest line the decoder accepts, without its terminator: an extended CAN FD frame with
/// 64 data bytes (`B` + 8 + 1 + 128 = 138 characters) plus an 8-digit microsecond timestamp and
/// an ESI digit is 147; the rest is room for longer free-text replies.
pub const MAX_LINE: usize = 160;

/// The longest line a [`Command`] encodes to, terminator included (`B`/`D` with 64 bytes).
pub const MAX_COMMAND: usize = 139;

/// Carriage return: ends every command and every reply line, and alone means "OK".
pub const CR: u8 = b'\r';

/// BEL: the error reply. Adapters send it without a CR after it.
pub const BEL: u8 = 0x07;

/// The README's example, compiled as a doctest.
#[cfg(all(doctest, feature = "serial"))]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` that
/// returns this crate's error with `?` prints `Error: ` and the text.
#[cfg(test)]
mod error_convention {
    extern crate std;
    use std::{format, string::ToString};

    #[test]
    fn main_prints_the_text() {
        let e = crate::Decoder::new()
            .decode(b"t12G0\r")
            .1
            .unwrap()
            .unwrap_err();
        assert_eq!(e.to_string(), "'G' is not a hexadecimal digit");
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
