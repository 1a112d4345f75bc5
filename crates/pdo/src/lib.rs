//! CANopen process data: PDOs and MPDOs (CiA 301 §7.2.2, §7.2.3, objects §7.4.8).
//!
//! Layers, bottom up:
//! - [`comm`] — communication parameters (0x1400.., 0x1800..): COB-ID bits, transmission
//!   type, inhibit time, event timer, SYNC start value.
//! - [`mapping`] — mapping parameters (0x1600.., 0x1A00..): up to 64 entries and 64 bits,
//!   dummy entries, validation against an object dictionary through [`Catalog`].
//! - [`mod@pack`] — bit-level [`fn@pack`] and [`unpack`] into typed
//!   [`RawValue`]s (unaligned fields, 1-bit booleans, 24/40/48/56-bit integers, sign extension).
//! - [`engine`] — the sans-IO [`Engine`] a master and a device simulator both run: consumes
//!   receive PDOs into an [`ObjectStore`] and produces transmit PDOs from it, by transmission
//!   type, with inhibit time, event timer, SYNC counter and receive deadlines. Its docs give the
//!   call order.
//! - [`fd`] — CAN FD PDOs of up to 64 bytes (CANopen FD): [`FdMapping`] up to 512 bits,
//!   [`pack_fd`] and [`unpack_fd`]; the engine still runs classic 8-byte PDOs.
//! - [`remote`] — the SDO writes that remap a node's PDO the CiA 301 way, as data.
//! - [`mpdo`] — SAM/DAM multiplexed PDOs with object scanner and dispatcher lists.
//! - [`typed`] — [`TypedPdo`]: PDOs as structs with named, typed fields (what
//!   `canola-codegen` generates from an EDS's default mappings), packed through [`fn@pack`].
//!
//! The crate is `#![no_std]` and needs no allocator; tables are `heapless`. The `alloc` feature
//! adds [`MapStore`], a `BTreeMap` object store for simulators and tests; `std` (default) implies
//! it. The `od` feature adapts the `canola-od` model (EDS/DCF) to [`Catalog`] and [`Dictionary`]
//! (`od::OdView`).
//!
//! # A master consuming a device's TPDO1
//!
//! ```
//! use canola_frame::{CanFrame, CanId, Instant};
//! use canola_pdo::{CommParams, Engine, Event, Mapping, NullStore, PdoConfig, RawValue};
//!
//! // One engine per node: up to 4 PDOs each way. The device's TPDO1 (0x185, four UNSIGNED16)
//! // is a receive PDO of the master.
//! let mut engine: Engine<4, 4> = Engine::new();
//! let mapping = Mapping::from_raw(&[0x6401_0110, 0x6401_0210, 0x6401_0310, 0x6401_0410])?;
//! let tpdo1 = engine.add_rpdo(PdoConfig::new(CommParams::event_driven(0x185), mapping))?;
//!
//! let frame = CanFrame::new(CanId::standard(0x185)?, &[1, 0, 2, 0, 3, 0, 4, 0])?;
//! let now = Instant::from_millis(10);
//! assert!(engine.handle_frame(now, &frame, &mut NullStore));
//! while let Some(event) = engine.poll_event() {
//!     if let Event::Received { pdo, changed } = event {
//!         assert_eq!((pdo, changed), (tpdo1, 0b1111));
//!         let values: Vec<RawValue> = engine.received(pdo).unwrap().iter().map(|(_, v)| v).collect();
//!         assert_eq!(values, [1, 2, 3, 4].map(RawValue::Unsigned));
//!     }
//! }
//! while let Some(frame) = engine.poll_transmit() { /* send it */ let _ = frame; }
//! assert_eq!(engine.poll_timeout(), None); // no timers configured
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Every decoder of bus bytes here is total: frames of any length and content give a typed
//! value, a typed error or an [`Event`], never a panic.
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

pub mod comm;
pub mod dictionary;
pub mod engine;
pub mod fd;
pub mod mapping;
pub mod mpdo;
#[cfg(feature = "od")]
pub mod od;
pub mod pack;
pub mod remote;
pub mod typed;

pub use comm::{CommError, CommParams, Direction, PdoCobId, TransmissionType};
#[cfg(feature = "alloc")]
pub use dictionary::MapStore;
pub use dictionary::{
    Catalog, Dictionary, NullStore, ObjectAddress, ObjectInfo, ObjectStore, ReadError, StoreError,
};
pub use engine::{Engine, EngineError, Event, PdoConfig, PdoRef, RpdoId, TpdoId};
pub use fd::{FdMappedObject, FdMapping, MAX_FD_BITS, MAX_FD_BYTES, pack_fd, unpack_fd};
pub use mapping::{MappedObject, Mapping, MappingEntry, MappingError, ValueKind};
pub use mpdo::{
    DispatcherEntry, Mpdo, MpdoAddress, MpdoConsumer, MpdoError, SamProducer, ScannerEntry,
};
#[cfg(feature = "od")]
pub use od::{OdView, ValueSource};
pub use pack::{PackError, RawValue, Unpacked, pack, unpack};
pub use remote::{RemapError, RemapSteps, RemoteObjects, SdoWrite, remap, remap_fd};
pub use typed::{DefaultCobId, PairValue, PdoField, TypedPdo, TypedPdoError};

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
        let e = crate::Mapping::from_raw(&[0x6000_0140, 0x6001_0140]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the mapped objects need 128 bits (16 bytes); a classic CAN PDO carries at most 64 bits \
             (8 bytes)"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
