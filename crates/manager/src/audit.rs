//! The configuration audit: read every object each slave's DCF configures from the live
//! network and list where the device differs from its DCF, and what could not be read.
//! Read-only objects are left out unless asked for (a DCF records them, the master cannot set
//! them); write-only ones cannot be read. Each slave's audit is one straight-line body of
//! awaited SDO transfers, one request in flight per slave; every slave's body runs together on
//! the caller's thread (`canola::wait_all_with`), as the boot's do.

use std::convert::Infallible;
use std::sync::mpsc;

use canola::od::{AccessType, SubObject};
use canola::{DataType, Duration, Network, NodeId, ObjectAddress, Operation, Value};

use crate::config::{NetworkConfig, SlaveConfig};

/// What the audit compares.
#[derive(Debug, Clone, Copy, Default)]
pub struct AuditOptions {
    /// Also compare read-only and const objects that carry a `ParameterValue`.
    pub read_only: bool,
    /// Write every difference back (a second audit of the fixed objects confirms it).
    pub fix: bool,
}

/// An object whose live value is not the DCF's.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// The object.
    pub object: ObjectAddress,
    /// Its name in the DCF.
    pub name: String,
    /// Its type.
    pub data_type: DataType,
    /// The DCF's value.
    pub expected: Value,
    /// The device's value (as decoded by the type; `None` when the bytes do not decode).
    pub actual: Option<Value>,
    /// The device's raw bytes.
    pub actual_bytes: Vec<u8>,
    /// With `fix`: whether writing the DCF's value back succeeded.
    pub fixed: Option<Result<(), String>>,
}

/// An object that could not be read.
#[derive(Debug, Clone, PartialEq)]
pub struct Unreadable {
    /// The object.
    pub object: ObjectAddress,
    /// Its name in the DCF.
    pub name: String,
    /// Why (the SDO abort or timeout).
    pub error: String,
    /// The abort code, when there was one.
    pub abort_code: Option<u32>,
}

/// The audit of one slave.
#[derive(Debug, Clone, PartialEq)]
pub struct SlaveAudit {
    /// The slave.
    pub node_id: NodeId,
    /// How many objects were compared.
    pub checked: usize,
    /// The differences.
    pub differences: Vec<Difference>,
    /// What could not be read.
    pub unreadable: Vec<Unreadable>,
}

/// The audit of the network.
#[derive(Debug, Clone, PartialEq)]
pub struct AuditReport {
    /// Per slave, in description order.
    pub slaves: Vec<SlaveAudit>,
}

impl AuditReport {
    /// Whether every device matches its DCF and every object could be read.
    pub fn is_clean(&self) -> bool {
        self.slaves
            .iter()
            .all(|s| s.differences.is_empty() && s.unreadable.is_empty())
    }
}

/// Progress of an audit.
#[derive(Debug, Clone, PartialEq)]
pub enum AuditEvent {
    /// A slave's audit began.
    SlaveStarted(NodeId),
    /// An object differs from the DCF (with `fix`: after the write back).
    Difference(NodeId, Difference),
    /// An object could not be read.
    Unreadable(NodeId, Unreadable),
    /// A slave's audit is over.
    SlaveDone(SlaveAudit),
}

/// Audits every slave of `config` on `net`, the slaves in parallel.
pub fn audit(net: &Network, config: &NetworkConfig, options: AuditOptions) -> AuditReport {
    audit_with(net, config, options, |_| {})
}

/// [`audit`], calling `on_event` as each slave's audit goes.
///
/// Each slave's audit is one straight-line body of awaited SDO transfers; all of them run
/// together on the calling thread ([`canola::wait_all_with`]: the bodies are polled in turn and
/// the network is driven one step between rounds), so requests to different nodes run
/// together on the bus with no thread per slave. `on_event` is called on the calling thread:
/// every [`AuditEvent::SlaveStarted`] first, then the events of each slave in order as they
/// happen (those of different slaves interleave).
pub fn audit_with(
    net: &Network,
    config: &NetworkConfig,
    options: AuditOptions,
    mut on_event: impl FnMut(&AuditEvent),
) -> AuditReport {
    for s in &config.slaves {
        net.add_node_with_dictionary(s.node_id, s.dictionary.clone());
    }
    for s in &config.slaves {
        on_event(&AuditEvent::SlaveStarted(s.node_id));
    }
    let timeout = config.master.sdo_timeout;
    let (tx, events) = mpsc::channel();
    let emit = move |e| {
        // The receiving end lives until every slave is done.
        let _ = tx.send(e);
    };
    let bodies = config.slaves.iter().map(|slave| {
        let body = audit_slave(net, slave, options, timeout, &emit);
        Operation::new(async { Ok::<_, Infallible>(body.await) })
    });
    let results = canola::wait_all_with(bodies, || events.try_iter().for_each(|e| on_event(&e)));
    events.try_iter().for_each(|e| on_event(&e));
    AuditReport {
        slaves: results
            .into_iter()
            .map(|r| match r {
                Ok(s) => s,
                Err(never) => match never {},
            })
            .collect(),
    }
}

/// Where the events of a slave's audit go (a channel the audit empties into the caller's
/// callback).
type Emit<'a> = &'a (dyn Fn(AuditEvent) + Sync);

/// One object the audit compares.
struct Check<'a> {
    object: ObjectAddress,
    sub: &'a SubObject,
    expected: Value,
    read_only: bool,
}

/// The objects of `slave` the audit compares, in dictionary order: those with a DCF value
/// that can be read (read-only ones only when asked for).
fn checks(slave: &SlaveConfig, options: AuditOptions) -> Vec<Check<'_>> {
    let node = slave.node_id;
    slave
        .dictionary
        .entries()
        .filter_map(|(index, sub)| {
            let read_only = matches!(sub.access, AccessType::Ro | AccessType::Const);
            if sub.access == AccessType::Wo || (read_only && !options.read_only) {
                return None;
            }
            let expected = sub.parameter_value()?.resolve(node.get())?;
            Some(Check {
                object: ObjectAddress::new(index, sub.sub_index),
                sub,
                expected,
                read_only,
            })
        })
        .collect()
}

/// One slave's audit: each object read in turn and compared with the DCF's value; with `fix`,
/// a difference is written back before the next read (a restricted COB-ID is not). The events
/// go to `emit` as they happen, [`AuditEvent::SlaveDone`] last.
async fn audit_slave(
    net: &Network,
    slave: &SlaveConfig,
    options: AuditOptions,
    timeout: Duration,
    emit: Emit<'_>,
) -> SlaveAudit {
    let node = slave.node_id;
    let checks = checks(slave, options);
    let mut out = SlaveAudit {
        node_id: node,
        checked: checks.len(),
        differences: Vec::new(),
        unreadable: Vec::new(),
    };
    let sdo = || net.node(node).sdo().timeout(timeout);
    for c in &checks {
        let bytes = match sdo().read(c.object).await {
            Ok(bytes) if bytes == c.expected.to_le_bytes() => continue,
            Ok(bytes) => bytes,
            Err(e) => {
                let u = Unreadable {
                    object: c.object,
                    name: c.sub.name.to_string(),
                    abort_code: abort_code(&e),
                    error: e.to_string(),
                };
                emit(AuditEvent::Unreadable(node, u.clone()));
                out.unreadable.push(u);
                continue;
            }
        };
        let fixed = if options.fix && !c.read_only {
            // A restricted COB-ID is not written back.
            Some(
                match crate::config::restricted_value(node, c.object, &c.expected) {
                    Some(e) => Err(e.to_string()),
                    None => sdo()
                        .write(c.object, &c.expected)
                        .await
                        .map_err(|e| e.to_string()),
                },
            )
        } else {
            None
        };
        let d = Difference {
            object: c.object,
            name: c.sub.name.to_string(),
            data_type: c.sub.data_type,
            actual: Value::from_le_bytes(c.sub.data_type, &bytes).ok(),
            actual_bytes: bytes,
            expected: c.expected.clone(),
            fixed,
        };
        emit(AuditEvent::Difference(node, d.clone()));
        out.differences.push(d);
    }
    emit(AuditEvent::SlaveDone(out.clone()));
    out
}

/// The SDO abort code that went over the bus in either direction, if any.
fn abort_code(e: &canola::Error) -> Option<u32> {
    match e {
        canola::Error::Sdo(e) => e.abort_code().map(|c| c.get()),
        _ => None,
    }
}
