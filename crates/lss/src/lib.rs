//! Layer Setting Services (LSS, CiA 305) for the CANopen stack: configure a device's node-ID and
//! bit rate over the bus, and find devices that have no node-ID yet.
//!
//! Layers, bottom up:
//! - [`address`]: the LSS address (identity object 0x1018) and the bit timing tables.
//! - [`wire`]: every LSS message of CiA 305 §6, typed, with a total decoder ([`Request`] on
//!   COB-ID 0x7E5 master→slave, [`Response`] on 0x7E4 slave→master).
//! - Master machines, sans-IO (time and responses in, requests and events out), all driven
//!   through [`LssMachine`]:
//!   - [`LssMaster`] runs one service or a procedure of several ([`Procedure`]: the seed's
//!     change-bit-rate and assign-node-ID sequences, selective variants, store, inquire,
//!     identify);
//!   - [`Fastscan`] finds one unconfigured slave's address, [`DiscoverAll`] every one;
//!   - [`Slowscan`] finds slaves by binary search over serial (and revision) ranges with
//!     identify remote slave;
//!   - [`AssignAll`] is the commissioning workflow: find every unconfigured slave, give each a
//!     node-ID from a table keyed by LSS address or from a pool, store, and report.
//! - [`LssSlave`]: the device side (for the simulator), including the Fastscan responder.
//!
//! No sockets, threads or clocks: callers pass [`can_frame::Instant`]s in. The crate is
//! `#![no_std]` without an allocator (fixed-size `heapless` lists, at most 127 slaves per
//! result since that is how many node-IDs exist); the `std` feature (default) only adds
//! `std::error::Error` through `can-frame`.
#![no_std]

#[cfg(any(feature = "std", test))]
extern crate std;

pub mod address;
pub mod assign;
pub mod error;
pub mod fastscan;
pub mod machine;
pub mod service;
pub mod slave;
pub mod slowscan;
pub mod wire;

pub use address::{AddressPart, BitRate, BitTiming, LssAddress};
pub use assign::{AssignAll, AssignConfig, AssignEntry, AssignOutcome, AssignReport, NodeIdPool};
pub use error::{LssError, Service};
pub use fastscan::{DiscoverAll, Fastscan, FastscanConfig};
pub use machine::{LssMachine, MasterEvent, ResponsePolicy};
pub use service::{LssMaster, MasterConfig, Procedure, ServiceReport, Step};
pub use slave::{LssSlave, SlaveConfig, SlaveEvent, SlaveState, StoreSupport};
pub use slowscan::{Slowscan, SlowscanConfig};
pub use wire::{ConfigStatus, DecodeError, IdentifyField, Mode, Request, Response, ResponseError};
