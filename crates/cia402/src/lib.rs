//! CiA 402 (drives and motion control), the device profile most CANopen masters command.
//!
//! Layers, bottom up, all sans-IO (no bus, no clock):
//! - [`objects`]: the profile's objects as typed entries (index, sub-index, data type), the
//!   multi-axis offset (axis n at index + n × 0x800), the option codes 0x605A..0x605E, the error
//!   code 0x603F, supported modes 0x6502 and the interpolation period 0x60C2.
//! - [`words`]: the controlword 0x6040 and statusword 0x6041 with their named bits.
//! - [`mode`]: modes of operation 0x6060/0x6061 (an open enum keeping unknown and manufacturer
//!   codes) and the per-mode meaning of controlword bits 4..6, 8, 9 and statusword bits 10, 12, 13.
//! - [`state`]: the power drive state machine of CiA 402-2 §6: the states with their statusword
//!   masks, the device-control commands, the transitions 0..16 and a [`Planner`]
//!   that gives the controlword sequence from any state to a target state, or says why the
//!   target cannot be reached.
//! - [`device`]: the same state machine from the drive's side (controlword in, state out), with
//!   fault reset on the rising edge of bit 7 and quick stop ending by 0x605A.
//! - `sim` (feature `std`): a simulated servo drive with motion, homing, faults and a
//!   safe-torque-off input, behind an object-dictionary read/write interface (with feature
//!   `pdo`, also a `canola_pdo::ObjectStore` for the PDO engine).
//! - `master` (feature `master`): `Drive`, one axis of a drive commanded over the `canola`
//!   facade, and `DriveHook`, the simulated drive behind a `canola::SimDevice` on the bus.
//!
//! Facts come from CiA 402-2 and from what public drives and masters do (python-canopen,
//! ros2_canopen, Maxon EPOS4, Elmo, Synapticon, Toshiba, Beckhoff's EtherCAT SSC); each item
//! names its sources. Where the sources disagree the majority is the default and the minority is
//! selectable (see [`device::DeviceConfig`]).
//!
//! Every decoder is total: any statusword, controlword, mode code or option code decodes to a
//! value (unknown codes are kept), never a panic. `#![no_std]` without an allocator when built
//! with `default-features = false`.
//!
//! # Example: enable a drive
//!
//! ```
//! use canola_cia402::state::{Planner, State};
//! use canola_cia402::words::Statusword;
//!
//! // The drive reports "switch on disabled" (0x0250); the master wants it enabled.
//! let sw = Statusword::from_raw(0x0250);
//! assert_eq!(State::decode(sw), Some(State::SwitchOnDisabled));
//! let plan = Planner::default().plan(sw, State::OperationEnabled).unwrap();
//! let words: Vec<u16> = plan.controlwords().map(|cw| cw.raw()).collect();
//! assert_eq!(words, [0x0006, 0x0007, 0x000F]);
//! ```
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(any(feature = "std", test))]
extern crate std;

pub mod device;
#[cfg(feature = "master")]
pub mod master;
pub mod mode;
pub mod objects;
#[cfg(feature = "std")]
pub mod sim;
pub mod state;
pub mod words;

pub use device::{DeviceConfig, DeviceStateMachine};
pub use mode::ModeOfOperation;
pub use objects::{ErrorCode, QuickStopOption, SupportedModes};
pub use state::{Command, PlanError, Planner, State, StateMasks, Transition};
pub use words::{Controlword, Statusword};

/// The README's example, compiled and run as a doctest.
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
