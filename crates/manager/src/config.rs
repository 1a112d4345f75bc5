//! The network description, `bus.toml`: the master's settings (`[master]`) and one `[[slave]]`
//! table per device with its DCF (or an EDS plus `[slave.values]`), whether it is mandatory, the
//! identity it must have and how its error control runs. The CiA 302 master objects these
//! settings stand for: 0x1F80 (start policy), 0x1F81 (slave assignment: mandatory), 0x1F84..0x1F88
//! (expected device type, vendor-ID, product code, revision, serial number), 0x1F81 bits 4..6
//! with 0x1F53/0x1F54/0x1F58 (keep-alive; the application software check against the expected
//! date and time; the program download that may update it, CiA 302-3).
//!
//! Paths are relative to the file. Every error names the file, the line and the key.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use canola::od::{AccessType, FieldValue, ObjectDictionary};
use canola::{Duration, NodeId};
use serde::Deserialize;
use toml::Spanned;

/// An error in the network description: where (file, line, key) and what.
#[derive(Debug, Clone, PartialEq, Eq)]
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

/// A date as `bus.toml` gives it: days since 1984-01-01, or `"YYYY-MM-DD"`.
fn parse_date(v: &toml::Value) -> Result<u32, String> {
    match v {
        toml::Value::Integer(n) => {
            u32::try_from(*n).map_err(|_| format!("{n} is not a day count (0..=4294967295)"))
        }
        toml::Value::String(s) => {
            let bad = || format!("`{s}` is not a date (YYYY-MM-DD)");
            let mut parts = s.splitn(3, '-');
            let mut next = || parts.next().and_then(|p| p.parse::<u32>().ok());
            let (y, m, d) = (
                next().ok_or_else(bad)?,
                next().ok_or_else(bad)?,
                next().ok_or_else(bad)?,
            );
            let y = i32::try_from(y).map_err(|_| bad())?;
            days_since_1984(y, m, d)
                .ok_or_else(|| format!("`{s}` is not a date from 1984-01-01 on"))
        }
        other => Err(format!("a {} is no date", other.type_str())),
    }
    .and_then(|days| match days {
        // 0x1F53 keeps 0 for "not configured" (CiA 302-3): taken as a date it would fail the
        // boot with error G instead of checking anything.
        0 => {
            Err("day 0 (1984-01-01) is 0x1F53's \"not configured\"; give the program's date".into())
        }
        days => Ok(days),
    })
}

/// A time of day as `bus.toml` gives it: ms after midnight, or `"HH:MM[:SS[.mmm]]"`.
fn parse_time(v: &toml::Value) -> Result<u32, String> {
    const DAY_MS: u32 = 86_400_000;
    let ms = match v {
        toml::Value::Integer(n) => {
            u32::try_from(*n).map_err(|_| format!("{n} is not a time in ms"))?
        }
        toml::Value::String(s) => {
            let bad = || format!("`{s}` is not a time of day (HH:MM[:SS[.mmm]])");
            let (hms, frac) = s.split_once('.').unwrap_or((s, ""));
            let parts: Vec<u32> = hms
                .split(':')
                .map(|p| p.parse::<u32>().map_err(|_| bad()))
                .collect::<Result<_, _>>()?;
            let (h, m, sec) = match parts[..] {
                [h, m] => (h, m, 0),
                [h, m, sec] => (h, m, sec),
                _ => return Err(bad()),
            };
            let millis = match frac.len() {
                0 => 0,
                1..=3 => frac.parse::<u32>().map_err(|_| bad())? * 10u32.pow(3 - frac.len() as u32),
                _ => return Err(bad()),
            };
            if h > 23 || m > 59 || sec > 59 {
                return Err(bad());
            }
            ((h * 60 + m) * 60 + sec) * 1000 + millis
        }
        other => return Err(format!("a {} is no time of day", other.type_str())),
    };
    if ms >= DAY_MS {
        return Err(format!("{ms} ms is not within a day (< {DAY_MS})"));
    }
    if ms == 0 {
        // As for the date: 0x1F54 keeps 0 for "not configured" (CiA 302-3).
        return Err(
            "0 ms (midnight) is 0x1F54's \"not configured\"; give the program's time".into(),
        );
    }
    Ok(ms)
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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    master: Option<RawMaster>,
    #[serde(default)]
    slave: Vec<RawSlave>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaster {
    node_id: Option<Spanned<u8>>,
    sync_period_ms: Option<u32>,
    heartbeat_consumer_percent: Option<Spanned<u32>>,
    boot_timeout_ms: Option<u32>,
    sdo_timeout_ms: Option<Spanned<u32>>,
    start: Option<StartPolicy>,
    dcf: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSlave {
    node_id: Spanned<u8>,
    dcf: Option<Spanned<String>>,
    eds: Option<Spanned<String>>,
    #[serde(default)]
    values: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    #[serde(default)]
    mandatory: bool,
    #[serde(default)]
    identity: IdentityCheck,
    #[serde(default)]
    error_control: ErrorControl,
    #[serde(default)]
    restart_on_loss: bool,
    #[serde(default)]
    keep_alive: bool,
    software: Option<RawSoftware>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSoftware {
    date: Option<Spanned<toml::Value>>,
    time: Option<Spanned<toml::Value>>,
    #[serde(default)]
    update: bool,
    program: Option<Spanned<String>>,
}

/// The 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The key written on a line (`node_id = 5` → `node_id`), for errors the parser reports by place.
fn key_on_line(text: &str, line: usize) -> Option<String> {
    let l = text.lines().nth(line.checked_sub(1)?)?;
    let (key, _) = l.split_once('=')?;
    let key = key.trim();
    (!key.is_empty() && !key.starts_with('#')).then(|| key.to_owned())
}

impl NetworkConfig {
    /// Reads and checks a description file, and the DCF/EDS files it names.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            path: path.to_owned(),
            line: None,
            key: None,
            message: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses description `text` as if read from `path` (relative paths resolve against its
    /// folder).
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        Self::parse_with_files(text, path, &|p| std::fs::read(p))
    }

    /// [`parse`](Self::parse), reading the files the description names (DCF, EDS, program,
    /// master DCF) through `read` instead of the file system.
    pub fn parse_with_files(
        text: &str,
        path: &Path,
        read: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
    ) -> Result<Self, ConfigError> {
        let err = |span: Option<core::ops::Range<usize>>, key: Option<String>, message: String| {
            ConfigError {
                path: path.to_owned(),
                line: span.map(|s| line_of(text, s.start)),
                key,
                message,
            }
        };
        let raw: RawFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of(text, s.start));
            ConfigError {
                path: path.to_owned(),
                line,
                key: line.and_then(|l| key_on_line(text, l)),
                message: e.message().to_owned(),
            }
        })?;
        let base = path.parent().unwrap_or(Path::new("."));

        let m = raw.master;
        let master = {
            let node = m.as_ref().and_then(|m| m.node_id.clone());
            let node_id = match node {
                Some(n) => NodeId::new(*n.get_ref()).map_err(|e| {
                    err(Some(n.span()), Some("master.node_id".into()), e.to_string())
                })?,
                None => NodeId::new(1).expect("1 is a node-ID"),
            };
            let pct = m
                .as_ref()
                .and_then(|m| m.heartbeat_consumer_percent.clone());
            let heartbeat_consumer_percent = match pct {
                Some(p) if *p.get_ref() < 100 => {
                    return Err(err(
                        Some(p.span()),
                        Some("master.heartbeat_consumer_percent".into()),
                        "must be at least 100 (the consumer waits longer than the producer's period)"
                            .into(),
                    ));
                }
                Some(p) => p.into_inner(),
                None => 150,
            };
            let sdo = m.as_ref().and_then(|m| m.sdo_timeout_ms.clone());
            let sdo_timeout = match sdo {
                Some(t) if *t.get_ref() == 0 => {
                    return Err(err(
                        Some(t.span()),
                        Some("master.sdo_timeout_ms".into()),
                        "must be more than 0".into(),
                    ));
                }
                Some(t) => Duration::from_millis(u64::from(t.into_inner())),
                None => Duration::from_millis(500),
            };
            MasterConfig {
                node_id,
                sync_period: m
                    .as_ref()
                    .and_then(|m| m.sync_period_ms)
                    .filter(|&p| p > 0)
                    .map(|p| Duration::from_millis(u64::from(p))),
                heartbeat_consumer_percent,
                boot_timeout: Duration::from_millis(u64::from(
                    m.as_ref().and_then(|m| m.boot_timeout_ms).unwrap_or(2000),
                )),
                sdo_timeout,
                start: m.as_ref().and_then(|m| m.start).unwrap_or(StartPolicy::All),
            }
        };

        let mut slaves: Vec<SlaveConfig> = Vec::new();
        for (i, s) in raw.slave.into_iter().enumerate() {
            let key = |k: &str| Some(format!("slave[{}].{k}", i + 1));
            let node_id = NodeId::new(*s.node_id.get_ref())
                .map_err(|e| err(Some(s.node_id.span()), key("node_id"), e.to_string()))?;
            if node_id == master.node_id {
                return Err(err(
                    Some(s.node_id.span()),
                    key("node_id"),
                    format!("node {node_id} is the master's own node-ID"),
                ));
            }
            if let Some(other) = slaves.iter().position(|o| o.node_id == node_id) {
                return Err(err(
                    Some(s.node_id.span()),
                    key("node_id"),
                    format!("node {node_id} is already slave[{}]", other + 1),
                ));
            }
            let (file, is_dcf) = match (&s.dcf, &s.eds) {
                (Some(d), None) => (d, true),
                (None, Some(e)) => (e, false),
                (Some(d), Some(_)) => {
                    return Err(err(
                        Some(d.span()),
                        key("dcf"),
                        "give either dcf or eds, not both".into(),
                    ));
                }
                (None, None) => {
                    return Err(err(
                        Some(s.node_id.span()),
                        key("dcf"),
                        "missing: every slave needs a dcf (or an eds)".into(),
                    ));
                }
            };
            let file_key = if is_dcf { "dcf" } else { "eds" };
            let source = base.join(file.get_ref());
            let bytes = read(&source).map_err(|e| {
                err(
                    Some(file.span()),
                    key(file_key),
                    format!("{}: {e}", source.display()),
                )
            })?;
            let mut dictionary = canola::od::parse(&bytes)
                .map_err(|e| {
                    err(
                        Some(file.span()),
                        key(file_key),
                        format!("{}: {e}", source.display()),
                    )
                })?
                .od;
            if is_dcf && !s.values.is_empty() {
                let (k, _) = s.values.iter().next().expect("not empty");
                return Err(err(
                    Some(k.span()),
                    key("values"),
                    "values go with an eds; a dcf carries its own".into(),
                ));
            }
            for (k, v) in &s.values {
                set_value(&mut dictionary, k.get_ref(), v.get_ref()).map_err(|m| {
                    err(
                        Some(k.span()),
                        Some(format!("slave[{}].values.\"{}\"", i + 1, k.get_ref())),
                        m,
                    )
                })?;
            }
            let software = match s.software {
                None => None,
                Some(w) => {
                    let field =
                        |v: Option<Spanned<toml::Value>>,
                         name: &str,
                         parse: fn(&toml::Value) -> Result<u32, String>| {
                            v.map(|v| {
                                parse(v.get_ref()).map_err(|m| {
                                    err(Some(v.span()), key(&format!("software.{name}")), m)
                                })
                            })
                            .transpose()
                        };
                    let date = field(w.date, "date", parse_date)?;
                    let time = field(w.time, "time", parse_time)?;
                    let program = match w.program {
                        None => None,
                        Some(p) => {
                            let path = base.join(p.get_ref());
                            let data = read(&path).map_err(|e| {
                                err(
                                    Some(p.span()),
                                    key("software.program"),
                                    format!("{}: {e}", path.display()),
                                )
                            })?;
                            if data.is_empty() {
                                return Err(err(
                                    Some(p.span()),
                                    key("software.program"),
                                    format!("{}: the program file is empty", path.display()),
                                ));
                            }
                            Some(Program {
                                path,
                                data: Arc::new(data),
                            })
                        }
                    };
                    Some(SoftwareCheck {
                        date,
                        time,
                        update: w.update,
                        program,
                    })
                }
            };
            slaves.push(SlaveConfig {
                node_id,
                dictionary,
                source,
                mandatory: s.mandatory,
                identity: s.identity,
                error_control: s.error_control,
                restart_on_loss: s.restart_on_loss,
                keep_alive: s.keep_alive,
                software,
            });
        }
        let mut config = Self {
            path: path.to_owned(),
            master,
            slaves,
        };
        if let Some(file) = m.as_ref().and_then(|m| m.dcf.clone()) {
            let source = base.join(file.get_ref());
            let fail = |message: String| err(Some(file.span()), Some("master.dcf".into()), message);
            let bytes = read(&source).map_err(|e| fail(format!("{}: {e}", source.display())))?;
            let od = canola::od::parse(&bytes)
                .map_err(|e| fail(format!("{}: {e}", source.display())))?
                .od;
            let objects = crate::master_dcf::MasterObjects::from_dictionary(&od);
            let start_given = m.as_ref().is_some_and(|m| m.start.is_some());
            let start = config.master.start;
            for node in crate::master_dcf::apply(&objects, &mut config) {
                let o = &objects.slaves[&node.get()];
                let Some(concise) = &o.concise_dcf else {
                    return Err(fail(format!(
                        "0x1F81 assigns node {node}, which has neither a [[slave]] entry nor a concise DCF in 0x1F22"
                    )));
                };
                let dictionary = crate::master_dcf::dictionary_from_concise(concise)
                    .map_err(|e| fail(format!("0x1F22 sub {node}: {e}")))?;
                config.slaves.push(SlaveConfig {
                    node_id: node,
                    dictionary,
                    source: source.clone(),
                    mandatory: o.mandatory(),
                    identity: o.identity,
                    error_control: ErrorControl::Auto,
                    restart_on_loss: false,
                    keep_alive: o.keep_alive(),
                    software: o.software.clone(),
                });
            }
            if start_given {
                config.master.start = start;
            }
        }
        Ok(config)
    }

    /// The slave with node-ID `node`.
    pub fn slave(&self, node: NodeId) -> Option<&SlaveConfig> {
        self.slaves.iter().find(|s| s.node_id == node)
    }
}

/// `0x2000:01` (or `0x2000`, sub-index 0) = value: set as the entry's parameter value.
fn set_value(od: &mut ObjectDictionary, key: &str, value: &toml::Value) -> Result<(), String> {
    let full = if key.contains(':') {
        key.to_owned()
    } else {
        format!("{key}:00")
    };
    let addr: canola::ObjectAddress = full
        .parse()
        .map_err(|e| format!("`{key}` is not an object address (0xIIII:SS): {e}"))?;
    let sub = od
        .sub_mut(addr.index, addr.sub_index)
        .ok_or_else(|| format!("the EDS has no object {addr}"))?;
    if matches!(sub.access, AccessType::Ro | AccessType::Const) {
        return Err(format!("object {addr} is read-only"));
    }
    let text = match value {
        toml::Value::Integer(n) => n.to_string(),
        toml::Value::Float(x) => x.to_string(),
        toml::Value::Boolean(b) => u8::from(*b).to_string(),
        toml::Value::String(s) => s.clone(),
        other => return Err(format!("a {} is no object value", other.type_str())),
    };
    let (field, result) = FieldValue::from_text(sub.data_type, &text);
    result.map_err(|e| format!("`{text}` for a {:?}: {e}", sub.data_type))?;
    sub.extras_mut().parameter_value = Some(field);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bus.toml")
    }

    fn error(text: &str) -> ConfigError {
        NetworkConfig::parse(text, &data()).expect_err("an error")
    }

    #[test]
    fn defaults_and_paths_relative_to_the_file() {
        let c =
            NetworkConfig::parse("[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\n", &data()).unwrap();
        assert_eq!(c.master.node_id.get(), 1);
        assert_eq!(c.master.start, StartPolicy::All);
        assert_eq!(c.master.heartbeat_consumer_percent, 150);
        assert!(!c.slaves[0].mandatory);
        assert!(c.slaves[0].source.ends_with("tests/data/valve.dcf"));
        assert_eq!(c.slaves[0].error_control, ErrorControl::Auto);
    }

    #[test]
    fn errors_name_line_and_key() {
        let e = error("[master]\nnode_id = 1\n[[slave]]\nnode_id = 0\ndcf = \"valve.dcf\"\n");
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(4), Some("slave[1].node_id"))
        );
        let e = error("[[slave]]\nnode_id = 5\ndcf = \"missing.dcf\"\n");
        assert_eq!((e.line, e.key.as_deref()), (Some(3), Some("slave[1].dcf")));
        assert!(e.message.contains("missing.dcf"), "{e}");
        let e = error("[[slave]]\nnode_id = 5\n");
        assert_eq!(e.key.as_deref(), Some("slave[1].dcf"));
        let e = error("[master]\nstart = \"sometimes\"\n");
        assert_eq!((e.line, e.key.as_deref()), (Some(2), Some("start")));
        let e = error("[master]\nnode_id = 1\nspeed = 3\n");
        assert_eq!(e.line, Some(3));
        assert!(e.message.contains("speed"), "{e}");
        let e = error(
            "[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\n[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\n",
        );
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(5), Some("slave[2].node_id"))
        );
        let e = error("[[slave]]\nnode_id = 1\ndcf = \"valve.dcf\"\n");
        assert!(e.message.contains("master"), "{e}");
        let shown = e.to_string();
        assert!(shown.contains("bus.toml:2: slave[1].node_id: "), "{shown}");
    }

    #[test]
    fn keep_alive_and_software_keys() {
        let c = NetworkConfig::parse(
            "[[slave]]\nnode_id = 5\ndcf = \"valve-boot.dcf\"\nkeep_alive = true\n[slave.software]\ndate = \"2026-03-01\"\ntime = \"10:00:01.5\"\nupdate = true\nprogram = \"valve-v2.bin\"\n",
            &data(),
        )
        .unwrap();
        let s = &c.slaves[0];
        assert!(s.keep_alive);
        let w = s.software.as_ref().unwrap();
        assert_eq!(w.expected(), Some((15400, 36_001_500)));
        assert!(w.update);
        assert_eq!(w.program.as_ref().unwrap().data.len(), 208);
        assert_eq!(days_since_1984(1984, 1, 1), Some(0));
        assert_eq!(days_since_1984(1985, 3, 1), Some(366 + 59));
        assert_eq!(days_since_1984(2023, 2, 29), None);
        assert_eq!(days_since_1984(9999, 12, 31), Some(2_927_783));
        // Found by the manager_bus_toml fuzz target: a nine-digit year overflowed the sum
        // (and took 400 million steps to get there).
        assert_eq!(days_since_1984(10_000, 1, 1), None);
        assert_eq!(days_since_1984(405_030_021, 5, 3), None);

        let base = "[[slave]]\nnode_id = 5\ndcf = \"valve-boot.dcf\"\n[slave.software]\n";
        let e = error(&format!("{base}date = \"2026-13-01\"\n"));
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(5), Some("slave[1].software.date"))
        );
        let e = error(&format!("{base}date = 1\ntime = \"24:00\"\n"));
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(6), Some("slave[1].software.time"))
        );
        let e = error(&format!("{base}time = 86400000\n"));
        assert!(e.message.contains("within a day"), "{e}");
        // 0 is "not configured" in 0x1F53/0x1F54; a master DCF written from it read back as
        // no check at all (found by the manager_bus_toml fuzz target).
        let e = error(&format!(
            "{base}date = \"2007-03-01\"\ntime = \"00:00:00.00\"\n"
        ));
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(6), Some("slave[1].software.time"))
        );
        assert!(e.message.contains("not configured"), "{e}");
        let e = error(&format!("{base}date = \"1984-01-01\"\n"));
        assert_eq!(e.key.as_deref(), Some("slave[1].software.date"));
        let e = error(&format!("{base}program = \"missing.bin\"\n"));
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(5), Some("slave[1].software.program"))
        );
        let e = error(&format!("{base}version = 3\n"));
        assert_eq!(e.line, Some(5));
        assert!(e.message.contains("version"), "{e}");
        let e = error("[[slave]]\nnode_id = 5\ndcf = \"valve.dcf\"\nkeep_alive = 3\n");
        assert_eq!((e.line, e.key.as_deref()), (Some(4), Some("keep_alive")));
    }

    #[test]
    fn eds_values_are_checked() {
        let base = "[[slave]]\nnode_id = 5\neds = \"valve-nostamp.dcf\"\n[slave.values]\n";
        let c =
            NetworkConfig::parse(&format!("{base}\"0x2001:00\" = \"0x55\"\n"), &data()).unwrap();
        let v = c.slaves[0]
            .dictionary
            .sub(0x2001, 0)
            .unwrap()
            .parameter_value()
            .unwrap();
        assert_eq!(v.resolve(5).unwrap().as_i128(), Some(0x55));
        let e = error(&format!("{base}\"0x1018:01\" = 3\n"));
        assert!(e.message.contains("read-only"), "{e}");
        assert_eq!(e.line, Some(5));
        let e = error(&format!("{base}\"0x3000\" = 3\n"));
        assert!(e.message.contains("no object"), "{e}");
        let e = error(&format!("{base}\"0x2002\" = 300\n"));
        assert!(e.key.as_deref().unwrap().contains("0x2002"), "{e}");
        let e = error(&format!("{base}\"nonsense\" = 3\n"));
        assert!(e.message.contains("object address"), "{e}");
    }
}
