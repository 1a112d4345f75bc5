//! CiA 309-3 ASCII gateway ("ASCII mapping"): drive a CANopen network from any language with
//! text lines over TCP, a Unix socket or stdio.
//!
//! Layers:
//! * [`value`]: the data types of the mapping and their text forms.
//! * [`command`]: typed requests, responses and event lines, and the formatter back to text.
//! * [`parse`]: the nom parser from a line to a [`Request`].
//! * [`server`]: the [`Gateway`]: connections over TCP, a Unix socket, stdio or any byte
//!   stream in front of one `canola::Network`, with one request queue per node.
//! * [`access`]: tokens (`auth <token>`), read and write roles, the client allow-list,
//!   read-only; [`audit_log`]: a line per request that changes the network;
//!   [`conn_limits`]: limits against hostile clients (line time, idle eviction, junk).
//!
//! # Compatibility
//!
//! No copy of the CiA 309-3 text was at hand; the forms follow the two independent gateways that
//! document theirs, CANopenNode's `canopend` (`309/CO_gateway_ascii.c`, the CANopenDemo
//! tutorials) and Lely's (`src/co/gw_txt.c`), and `tests/peers.rs` replays their documented
//! exchanges byte for byte. Where they differ from each other or from this gateway:
//! * Replies as CANopenNode writes them: `ERROR:<code>` and `ERROR:0x<abort>` (Lely writes
//!   `ERROR: <code> (<text>)`; canopend's default build appends ` #<text>`, a comment), `u8` to
//!   `u64` in decimal with `x8` to `x64` for hex (Lely, and port GmbH's gateway by its manual,
//!   print unsigned values in hex), a multi-line reply's inner lines ending in LF and its last
//!   in CR LF (CANopenNode's maintainer: the standard ends a command with CR LF, the LF alone
//!   tells lines of help apart from the end).
//! * Event lines and `info version` as Lely writes them (CANopenNode has neither): `<net>
//!   <node> BOOT_UP`, `<net> <node> ERROR <code> (<text>)`, `<net> <node> EMCY <code> <reg>
//!   <5 bytes>`; `<vendor> <product> <rev>.<rev> <serial> <class> <309-1 version> <version>`
//!   (the field order port GmbH's and Nanotec's manuals show too).
//! * `lss_get_node` in decimal, as Lely (CANopenNode writes `0x%02X`); `lss_inquire_addr`
//!   takes CANopenNode's part 0..3 and Lely's command specifier 0x5A..0x5D.
//! * A read without a type shows the node's dictionary type when the gateway knows the
//!   dictionary, else hex as canopend (Lely needs a type).
//! * Reals in the shortest form that reads back to the same value (canopend prints `%g`, six
//!   digits, which loses precision); a visible string's bytes that are not UTF-8 become U+FFFD
//!   and its line ends blanks (canopend writes the raw bytes), so that every reply is one line of
//!   text.
//! * An empty or comment-only line gets no reply, as in Lely (canopend answers an empty line).
//!   A request without `[seq]` is served and answered without one (canopend answers it with a
//!   syntax error; Lely reads a leading number as the sequence number even without brackets).
//! * A line longer than [`Config::max_line`] is refused with 600, running out of memory, the
//!   code Lely gives for the command size service (CANopenNode streams long values through a
//!   fixed buffer and answers a token over its 20-byte limit with 101).
//! * A written number outside its type's range (`w 0x1017 0 u16 70000`) is answered
//!   `ERROR:0x06090031` (value too high) or `ERROR:0x06090032` (too low), the SDO abort a
//!   device gives for it: CiA 309-3's gateway error codes have no range error, and 101 (syntax,
//!   what canopend answers) would tell the user the line is malformed when it is not.
//! * `lss_allnodes` takes CANopenNode's scan types per part (0 search, 1 ignore, 2 match the
//!   value given) in any mix; a form that leaves no Fastscan (the vendor-ID ignored, or the
//!   three parts after it) is a syntax error, 101 (CANopenNode's master refuses it as an illegal
//!   argument). An ignored part reads 0 in the report, as in CANopenNode.
//!
//! ```
//! use canola_gateway::{Command, parse_line};
//!
//! let req = parse_line("[1] 4 read 0x1017 0 u16\r\n").unwrap().unwrap();
//! assert_eq!(req.node, Some(4));
//! assert!(matches!(req.command, Command::Read { index: 0x1017, .. }));
//! assert_eq!(req.to_string(), "[1] 4 read 0x1017 0 u16");
//! ```

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

pub mod access;
pub mod audit_log;
pub mod command;
pub mod conn_limits;
mod exec;
pub mod parse;
pub mod server;
pub mod value;

pub use access::{Access, AccessCounters, AllowNet, Role, Token};
pub use audit_log::AuditLog;
pub use command::{Command, ErrorCode, Event, EventKind, NmtService, Reply, Request, Response};
pub use conn_limits::{ConnLimits, LimitCounters};
pub use parse::{ParseError, parse_line};
pub use server::{Config, Gateway, Version};
pub use value::{DataType, Value};

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` that
/// returns this crate's error with `?` prints `Error: ` and the text.
#[cfg(test)]
mod error_convention {
    #[test]
    fn main_prints_the_text() {
        let e = "10.0.0.1/33".parse::<crate::AllowNet>().unwrap_err();
        assert_eq!(e.to_string(), "`10.0.0.1/33` is not ADDR or ADDR/PREFIX");
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
