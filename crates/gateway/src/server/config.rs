//! The gateway's settings ([`Config`]: bounds per connection, timeouts) and the identity it
//! reports for `info version` ([`Version`]).

use canola::frame::Duration;

/// What `info version` reports: `<vendor-ID> <product code> <revision major>.<minor> <serial>
/// <gateway class> <protocol major>.<minor> <implementation major>.<minor>` (the fields and
/// their order as Lely's gateway prints them: the identity of the gateway's own device, gateway
/// class 3 for a gateway that is the NMT master, the CiA 309-1 version, then the
/// implementation's version).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Version {
    /// Vendor-ID of the gateway (0: none assigned).
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number (major in the high 16 bits).
    pub revision: u32,
    /// Serial number.
    pub serial: u32,
    /// Gateway class (3: the gateway is the NMT master, as this one is; 1: not).
    pub class: u8,
    /// The version of CiA 309-1 implemented (major, minor).
    pub protocol: (u8, u8),
    /// Implementation version (major, minor).
    pub implementation: (u8, u8),
}

impl Default for Version {
    fn default() -> Self {
        let num = |s: &str| s.parse::<u8>().unwrap_or(0);
        let major = num(env!("CARGO_PKG_VERSION_MAJOR"));
        let minor = num(env!("CARGO_PKG_VERSION_MINOR"));
        Self {
            vendor_id: 0,
            product_code: 0,
            revision: (u32::from(major) << 16) | u32::from(minor),
            serial: 0,
            class: 3,
            protocol: (2, 0),
            implementation: (major, minor),
        }
    }
}

/// Settings of a [`Gateway`](crate::Gateway).
#[derive(Debug, Clone)]
pub struct Config {
    /// The network number of the one network (CiA 309-3 `net`), also every connection's
    /// default net.
    pub net: u16,
    /// SDO timeout a connection starts with (`set sdo_timeout` changes it).
    pub sdo_timeout: Duration,
    /// Longest request line in bytes, line end included.
    pub max_line: usize,
    /// Requests a connection may have waiting or unsent.
    pub max_in_flight: usize,
    /// Event lines a connection may have unsent.
    pub max_events: usize,
    /// Connections at once; one more is answered `ERROR:600` and closed.
    pub max_connections: usize,
    /// Longest upload in bytes (a longer one is aborted: `ERROR:0x05040005`).
    pub max_upload: usize,
    /// Whether the dispatcher drives the network while no request runs, and in steps of at
    /// most how long (a virtual clock is then kept near real time); `None` drives it only while
    /// requests run, leaving the rest to the application (`Network::start_driver`).
    pub drive_period: Option<std::time::Duration>,
    /// What `info version` reports.
    pub version: Version,
    /// Who may do what ([`crate::access`]); the default admits everyone to everything.
    pub access: crate::access::Access,
    /// Where the requests that change the network are logged ([`crate::audit_log`]).
    pub audit: Option<std::sync::Arc<crate::audit_log::AuditLog>>,
    /// Limits against hostile clients on sockets ([`crate::conn_limits`]).
    pub limits: crate::conn_limits::ConnLimits,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            net: 1,
            sdo_timeout: Duration::from_millis(500),
            max_line: 4096,
            max_in_flight: 64,
            max_events: 256,
            max_connections: 256,
            max_upload: 64 * 1024,
            drive_period: Some(std::time::Duration::from_millis(10)),
            version: Version::default(),
            access: crate::access::Access::default(),
            audit: None,
            limits: crate::conn_limits::ConnLimits::default(),
        }
    }
}
