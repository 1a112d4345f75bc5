//! CANopen network manager (CiA 302-2): boots a whole network from its description
//! (`bus.toml`, [`config`]) — every slave in parallel through device present, identity,
//! configuration, error control and NMT start ([`mod@boot`]) — reports per slave what failed with its
//! CiA 302-2 boot error code ([`codes`]), and audits the live configuration of every device
//! against its DCF ([`mod@audit`]); [`mod@supervise`] boots slaves again that appear late or reset. [`simulate`] puts the described slaves on an in-memory bus.
//!
//! ```
//! use canola::{MemoryBus, Network};
//! use canola_manager::{NetworkConfig, SlaveStatus, boot, simulate};
//!
//! let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
//! let config = NetworkConfig::load(format!("{dir}/three.toml")).unwrap();
//! let bus = MemoryBus::new();
//! let net = Network::new(bus.endpoint());
//! simulate::attach_slaves(&bus, &config, &[]);
//! let report = boot::boot(&net, &config);
//! assert!(report.slaves.iter().all(|s| s.status == SlaveStatus::Operational));
//! ```

#[cfg(feature = "tokio")]
pub mod asynch;
pub mod audit;
pub mod boot;
pub mod codes;
pub mod config;
pub mod json;
pub mod master_dcf;
pub mod simulate;
pub mod supervise;

pub use audit::{AuditEvent, AuditOptions, AuditReport, audit, audit_with};
pub use boot::{
    BootEvent, BootReport, BootStep, SlaveReport, SlaveStatus, SoftwareOutcome, boot, boot_with,
};
pub use codes::BootErrorCode;
pub use config::{ConfigError, NetworkConfig, SoftwareCheck, StartPolicy};
pub use supervise::{SuperviseEvent, supervise};

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}
