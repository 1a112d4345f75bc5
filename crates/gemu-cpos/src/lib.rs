//! GEMÜ 1436 cPos valve positioner: the fieldbus-neutral cyclic I/O image, its 8-byte parameter
//! channel, the actions, the parameter table of the manual's chapter 6, a sans-IO client and a
//! simulated positioner.
//!
//! Source: the GEMÜ 1436 cPos DeviceNet manual (chapters 5 and 6) and the Profinet manual's
//! chapter 5.6 (same channel, same actions). The DeviceNet and Profinet variants carry the same
//! bytes; the crate does not care what carries them (a fieldbus gateway, a PDO pair, a test
//! harness).
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
//!
//! Every decoder is total: bytes become a typed value or a typed error, never a panic.
//! `#![no_std]` without an allocator when built with `default-features = false`.
//!
//! Ambiguities of the manuals and how this crate resolves them are listed in the module docs of
//! [`channel`], [`action`], [`params`] and [`sim`], each at the place it matters.

#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(feature = "std")]
extern crate std;

pub mod action;
pub mod channel;
pub mod client;
pub mod image;
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
