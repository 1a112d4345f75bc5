//! The CANopen object dictionary: the single source of truth for what a device holds.
//!
//! - [`address`] — [`ObjectAddress`], index and sub-index of one sub-object, `0x1018:01` (no
//!   allocator).
//! - [`entry`] — typed entries (index, sub-index and Rust value type) for generated code (no allocator).
//! - [`types`] — CiA 301 data type indices, object codes and CiA 306 access types (no allocator).
//! - [`profile`] — the data types CiA 301 fixes for the communication profile objects
//!   (0x1017 UNSIGNED16, 0x1018:01 UNSIGNED32), for access without an EDS (no allocator).
//! - [`value`] — typed values of every basic data type with two codecs: little-endian bytes
//!   (SDO/PDO payloads) and CiA 306 EDS text including `$NODEID` expressions, and a `Display`
//!   in CANopen terms (`57`, `24.58`, `01 02 0A`; `{:#}` for hex) (`alloc`).
//! - [`model`] — the dictionary: objects, sub-objects, file and device information (`alloc`).
//! - [`parse`](mod@parse) — the CiA 306 EDS/DCF parser with warnings and errors by line ([`diag`]).
//! - [`write`](mod@write) — EDS, DCF and concise DCF (0x1F22) writers.
//! - [`lint`](mod@lint) — consistency checks (SubNumber, object lists, limits, PDO mappings, codes).
//! - `file` — load/save by path (`std`).
//!
//! The crate is `#![no_std]`. Without features only [`types`], [`profile`], [`address`] and [`entry`] are available (no
//! allocator); `alloc` adds the value codec, the model, parser, writer and linter; `std`
//! (default) adds file I/O conveniences.
//!
//! ```
//! let eds = "[1017]\nParameterName=Producer heartbeat time\nDataType=0x0006\nAccessType=rw\nDefaultValue=1000\n";
//! let parsed = canola_od::parse(eds.as_bytes()).expect("parses");
//! let hb = parsed.od.sub(0x1017, 0).expect("present");
//! assert_eq!(hb.data_type, canola_od::DataType::Unsigned16);
//! assert_eq!(hb.effective_value(5), Some(canola_od::Value::Unsigned16(1000)));
//! ```
#![no_std]

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

pub mod address;
#[cfg(feature = "alloc")]
pub mod diag;
pub mod entry;
#[cfg(feature = "std")]
pub mod file;
#[cfg(feature = "alloc")]
pub mod lint;
#[cfg(feature = "alloc")]
pub mod model;
#[cfg(feature = "alloc")]
pub mod parse;
pub mod profile;
pub mod types;
#[cfg(feature = "alloc")]
pub mod value;
#[cfg(feature = "alloc")]
pub mod write;

pub use address::{AddressError, ObjectAddress};
/// The string type of names and value texts in the model (inline up to 24 bytes: most EDS
/// names and values need no allocation of their own).
#[cfg(feature = "alloc")]
pub use compact_str::CompactString;
#[cfg(feature = "alloc")]
pub use diag::{Diagnostic, DiagnosticKind, Severity};
pub use entry::{Entry, EntryError, EntryValue};
#[cfg(feature = "std")]
pub use file::{LoadError, LoadedFile, load};
#[cfg(feature = "alloc")]
pub use lint::{lint, lint_source};
#[cfg(feature = "alloc")]
pub use model::{
    DeviceCommissioning, DeviceInfo, FieldValue, FileInfo, Line, Object, ObjectDictionary,
    RawSection, SubObject, SubObjectExtras, SubObjects,
};
#[cfg(feature = "alloc")]
pub use parse::{ParseError, ParseOptions, Parsed, parse, parse_with};
pub use types::{AccessType, BASIC_DATA_TYPES, DataType, ObjectCode};
#[cfg(feature = "alloc")]
pub use value::{BytesError, ConvertError, EdsValue, TextError, TextNotes, Value, ValueType};
#[cfg(feature = "alloc")]
pub use write::{concise_dcf, write_dcf, write_eds};

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
        let e = crate::parse(b"garbage\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 1: error: `garbage` is neither a [section] header, a key=value pair nor a `;` \
             comment (2 error(s) in total)"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
