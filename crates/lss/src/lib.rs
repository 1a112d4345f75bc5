//! Layer Setting Services (LSS, CiA 305) for the CANopen stack: configure a device's node-ID and
//! bit rate over the bus, and find devices that have no node-ID yet.
//!
//! Layers, bottom up:
//! - [`address`]: the LSS address (identity object 0x1018) and the bit timing tables.
//! - [`wire`]: every LSS message of CiA 305, typed, with a total decoder ([`Request`] on
//!   COB-ID 0x7E5 master→slave, [`Response`] on 0x7E4 slave→master).
//! - Master machines, sans-IO (time and responses in, requests and events out), all driven
//!   through [`LssMachine`]:
//!   - [`LssMaster`] runs one service or a procedure of several ([`Procedure`]: the seed's
//!     change-bit-rate and assign-node-ID sequences, selective variants, store, inquire,
//!     identify);
//!   - [`Fastscan`] finds one unconfigured slave's address, [`DiscoverAll`] every one;
//!   - [`Slowscan`] finds slaves by binary search over serial (and revision) ranges with
//!     identify remote slave;
//!   - [`AssignAll`] is the commissioning workflow: find an unconfigured slave, give it a
//!     node-ID from a table keyed by LSS address or from a pool, store, release it, and again
//!     until none is left; then report.
//! - [`LssSlave`]: the device side (for the simulator), including the Fastscan responder;
//!   [`SlaveConfig::fastscan_in_configuration`] makes it answer Fastscan in configuration state
//!   too, as real slaves do, which the master machines are tested against.
//!
//! No sockets, threads or clocks: callers pass [`canola_frame::Instant`]s in. The crate is
//! `#![no_std]` without an allocator (fixed-size `heapless` lists, at most 127 slaves per
//! result since that is how many node-IDs exist); the `std` feature (default) only adds
//! `std::error::Error` through `canola-frame`.
//!
//! # Driving a machine
//! Every master machine has the same loop (see [`machine`] for the details): put
//! [`LssMachine::poll_transmit_frame`] frames on the bus, feed received frames to
//! [`LssMachine::handle_frame`], call [`LssMachine::handle_timeout`] at
//! [`LssMachine::poll_timeout`], and read [`LssMachine::poll_event`] until
//! [`MasterEvent::Done`]. Here two simulated slaves stand in for the bus, on a virtual clock:
//!
//! ```
//! use canola_frame::{Instant, NodeId};
//! use canola_lss::{
//!     AssignAll, AssignConfig, LssAddress, LssMachine, LssSlave, MasterEvent, NodeIdPool,
//!     SlaveConfig,
//! };
//!
//! let mut slaves = [
//!     LssSlave::new(SlaveConfig::unconfigured(LssAddress::new(0x78, 1, 1, 100))),
//!     LssSlave::new(SlaveConfig::unconfigured(LssAddress::new(0x78, 1, 1, 200))),
//! ];
//! let pool = NodeIdPool::range(NodeId::new(10).unwrap(), NodeId::new(20).unwrap());
//! let mut master = AssignAll::new(AssignConfig::with_pool(pool));
//! let mut now = Instant::ZERO;
//! master.start(now).unwrap();
//! let report = loop {
//!     while let Some(frame) = master.poll_transmit_frame() {
//!         for slave in &mut slaves {
//!             slave.handle_frame(now, &frame);
//!         }
//!     }
//!     // Identical answers of several slaves reach the master as one frame here.
//!     let mut answers: Vec<_> = slaves.iter_mut().filter_map(|s| s.poll_transmit_frame()).collect();
//!     answers.dedup();
//!     for frame in &answers {
//!         master.handle_frame(now, frame);
//!     }
//!     if let Some(MasterEvent::Done(result)) = master.poll_event() {
//!         break result.unwrap();
//!     }
//!     if answers.is_empty() && let Some(t) = master.poll_timeout() {
//!         now = t;
//!         master.handle_timeout(now);
//!     }
//! };
//! let ids: Vec<u8> = report.assigned().map(|(_, id)| id.get()).collect();
//! assert_eq!(ids, [10, 11]);
//! assert_eq!(slaves[1].active_node_id(), 11);
//! ```
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

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}
