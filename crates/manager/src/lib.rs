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

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` that
/// returns this crate's error with `?` prints `Error: ` and the text.
#[cfg(test)]
mod error_convention {
    #[test]
    fn main_prints_the_text() {
        let e =
            crate::NetworkConfig::parse("nodes = [", std::path::Path::new("net.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "net.toml:1: nodes: unclosed array, expected `]`"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
