//! The network description, `bus.toml`: the master's settings (`[master]`) and one `[[slave]]`
//! table per device with its DCF (or an EDS plus `[slave.values]`), whether it is mandatory, the
//! identity it must have and how its error control runs. The CiA 302 master objects these
//! settings stand for: 0x1F80 (start policy), 0x1F81 (slave assignment: mandatory), 0x1F84..0x1F88
//! (expected device type, vendor-ID, product code, revision, serial number), 0x1F81 bits 4..6
//! with 0x1F53/0x1F54/0x1F58 (keep-alive; the application software check against the expected
//! date and time; the program download that may update it, CiA 302-3).
//!
//! Paths are relative to the file. Every error names the file, the line and the key.

use std::path::PathBuf;
use std::sync::Arc;

use canola::od::{AccessType, ObjectDictionary};
use canola::{Duration, NodeId, ObjectAddress, Value};
use serde::Deserialize;

/// An error in the network description: where (file, line, key) and what.
#[derive(Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// The description file.
    pub path: PathBuf,
    /// The 1-based line, when the error has a place in the file.
    pub line: Option<usize>,
    /// The key the error is about (`slave[2].dcf`), when known.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}

debug_as_display!(ConfigError);

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(key) = &self.key {
            write!(f, ": {key}")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

/// When the master sends NMT start (CiA 302 object 0x1F80).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StartPolicy {
    /// Start every slave together once every mandatory slave has booted (0x1F80 bit 1); no
    /// slave is started when a mandatory one failed.
    All,
    /// Start each slave as soon as its own boot finished.
    Individually,
    /// Leave every slave pre-operational (the application starts them).
    None,
}

/// How the master watches a slave after its boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorControl {
    /// Heartbeat when the slave's 0x1017 is non-zero, else node guarding when its 0x100C is,
    /// else none.
    #[default]
    Auto,
    /// Heartbeat consumer from the slave's producer time 0x1017.
    Heartbeat,
    /// Node guarding with the slave's 0x100C guard time and 0x100D life time factor.
    Guarding,
    /// No error control.
    None,
}

/// The master's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MasterConfig {
    /// The master's own node-ID.
    pub node_id: NodeId,
    /// SYNC period (0x1006), started before the slaves are; `None`: no SYNC.
    pub sync_period: Option<Duration>,
    /// Heartbeat consumer time as a multiple of the slave's producer time, in percent.
    pub heartbeat_consumer_percent: u32,
    /// How long a slave has to answer its first SDO (device present, 0x1000) — retried until then.
    pub boot_timeout: Duration,
    /// The response timeout of each SDO request of the boot.
    pub sdo_timeout: Duration,
    /// When slaves are started.
    pub start: StartPolicy,
}

/// The identity a slave must have (each `Some` is checked against its 0x1000 / 0x1018).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentityCheck {
    /// Expected device type 0x1000 (CiA 302 0x1F84).
    pub device_type: Option<u32>,
    /// Expected vendor-ID 0x1018:01 (0x1F85).
    pub vendor_id: Option<u32>,
    /// Expected product code 0x1018:02 (0x1F86).
    pub product_code: Option<u32>,
    /// Expected revision number 0x1018:03 (0x1F87).
    pub revision: Option<u32>,
    /// Expected serial number 0x1018:04 (0x1F88).
    pub serial: Option<u32>,
}

/// The application software a slave must run (CiA 302-2 "check software version", CiA 302-3
/// program download): its 0x1F52 date and time against the expected ones.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SoftwareCheck {
    /// Expected application software date 0x1F53 (days since 1984-01-01); `None` or 0: not
    /// configured, which fails the boot with error G.
    pub date: Option<u32>,
    /// Expected application software time 0x1F54 (ms after midnight); `None` or 0: not
    /// configured (error G).
    pub time: Option<u32>,
    /// Whether the manager may download the program when the slave's differs (0x1F81 bit 6).
    pub update: bool,
    /// The program to download (0x1F58), if any: its bytes and the file they came from.
    pub program: Option<Program>,
}

/// A program image for the download to 0x1F50:01.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// The file it was read from.
    pub path: PathBuf,
    /// The image.
    pub data: Arc<Vec<u8>>,
}

impl SoftwareCheck {
    /// The expected (date, time) when both are configured (non-zero).
    pub fn expected(&self) -> Option<(u32, u32)> {
        match (self.date, self.time) {
            (Some(d), Some(t)) if d != 0 && t != 0 => Some((d, t)),
            _ => None,
        }
    }
}

/// Days from 1984-01-01 (the CANopen TIME_OF_DAY epoch) to `year-month-day`; `None` for a
/// date that does not exist or lies outside the years 1984..=9999 (a `YYYY-MM-DD` year, and
/// far below the end of the UNSIGNED32 day count).
pub fn days_since_1984(year: i32, month: u32, day: u32) -> Option<u32> {
    if !(1..=12).contains(&month) || day == 0 {
        return None;
    }
    let leap = |y: i32| (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let month_days = [
        31,
        if leap(year) { 29 } else { 28 },
        31,
        30,
        31,
        30,
        31,
        31,
        30,
        31,
        30,
        31,
    ];
    if day > month_days[month as usize - 1] || !(1984..=9999).contains(&year) {
        return None;
    }
    let years: u32 = (1984..year).map(|y| if leap(y) { 366 } else { 365 }).sum();
    let months: u32 = month_days[..month as usize - 1].iter().sum();
    Some(years + months + day - 1)
}

/// One slave of the network.
#[derive(Debug, Clone)]
pub struct SlaveConfig {
    /// Its node-ID.
    pub node_id: NodeId,
    /// Its dictionary: the DCF, or the EDS with `[slave.values]` as parameter values. The
    /// configuration written at boot is every writable entry with a `ParameterValue`.
    pub dictionary: ObjectDictionary,
    /// The DCF or EDS file it came from.
    pub source: PathBuf,
    /// Whether the network cannot run without it (0x1F81 bit 3).
    pub mandatory: bool,
    /// The identity checks.
    pub identity: IdentityCheck,
    /// How its error control runs.
    pub error_control: ErrorControl,
    /// Whether the manager resets it (NMT reset communication) when its error control reports
    /// it lost, so it boots again ([`crate::supervise()`]).
    pub restart_on_loss: bool,
    /// Keep-alive (0x1F81 bit 4): the manager must not reset the slave when it is operational;
    /// its boot first checks the node state by its heartbeat (or guarding).
    pub keep_alive: bool,
    /// The application software check and update (0x1F81 bits 5 and 6), if asked for.
    pub software: Option<SoftwareCheck>,
}

/// A parsed network description.
#[derive(Debug, Clone)]
pub struct NetworkConfig {
    /// The file it was read from.
    pub path: PathBuf,
    /// The master's settings.
    pub master: MasterConfig,
    /// The slaves in file order.
    pub slaves: Vec<SlaveConfig>,
}

impl NetworkConfig {
    /// The slave with node-ID `node`.
    pub fn slave(&self, node: NodeId) -> Option<&SlaveConfig> {
        self.slaves.iter().find(|s| s.node_id == node)
    }
}

/// The values the DCF configures: every writable entry with a `ParameterValue`, in index
/// order, without 0x1020 (written last, as the mark of a finished configuration).
pub fn configured_values(slave: &SlaveConfig) -> Vec<(ObjectAddress, Value)> {
    let node = slave.node_id.get();
    slave
        .dictionary
        .entries()
        .filter(|(index, s)| {
            *index != 0x1020
                && !matches!(s.access, AccessType::Ro | AccessType::Const)
                && s.parameter_value().is_some()
        })
        .filter_map(|(index, s)| {
            let v = s.parameter_value()?.resolve(node)?;
            Some((ObjectAddress::new(index, s.sub_index), v))
        })
        .collect()
}

/// The first of `writes` that would configure a COB-ID entry of node `node` with a CAN
/// identifier CiA 301 restricts ([`canola::restricted_cob_id`]), as the error the master
/// refuses it with.
pub fn restricted_write(node: NodeId, writes: &[(ObjectAddress, Value)]) -> Option<canola::Error> {
    writes
        .iter()
        .find_map(|(at, v)| restricted_value(node, *at, v))
}

/// Whether writing `value` to `at` of node `node` configures a restricted COB-ID, as the
/// error the master refuses it with.
pub fn restricted_value(node: NodeId, at: ObjectAddress, value: &Value) -> Option<canola::Error> {
    let raw = u32::try_from(value.as_i128()?).ok()?;
    let can_id = canola::restricted_cob_id(at.index, at.sub_index, raw)?;
    Some(canola::Error::RestrictedCobId {
        node,
        entry: at,
        can_id,
    })
}

mod load;
