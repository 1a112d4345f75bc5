//! Reading `bus.toml`: the TOML tables into a [`NetworkConfig`], the DCF and EDS files they
//! name loaded and checked, `[slave.values]` set as parameter values, and a master DCF's
//! CiA 302 objects ([`crate::master_dcf`]) merged in. Every error names the file, the line and
//! the key.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use canola::od::{AccessType, FieldValue, ObjectDictionary};
use canola::{Duration, NodeId};
use serde::Deserialize;
use toml::Spanned;

use super::{
    ConfigError, ErrorControl, IdentityCheck, MasterConfig, NetworkConfig, Program, SlaveConfig,
    SoftwareCheck, StartPolicy, days_since_1984,
};

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
    use std::path::PathBuf;

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
