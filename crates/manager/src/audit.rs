//! The configuration audit: read every object each slave's DCF configures from the live
//! network and list where the device differs from its DCF, and what could not be read.
//! Read-only objects are left out unless asked for (a DCF records them, the master cannot set
//! them); write-only ones cannot be read. Every slave is audited at once, one request in flight
//! per slave, all driven from the caller's thread.

use canola::od::AccessType;
use canola::{DataType, Duration, Network, NodeId, ObjectAddress, Pending, Value};

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

/// How finely the audit loop drives the network between looking at its slaves' requests.
const TICK: Duration = Duration::from_micros(20);

/// [`audit`], calling `on_event` as each slave's audit goes.
///
/// One thread audits every slave: each is a small machine with one SDO request in flight, and
/// the facade runs requests to different nodes together on the bus (no thread per slave).
pub fn audit_with(
    net: &Network,
    config: &NetworkConfig,
    options: AuditOptions,
    mut on_event: impl FnMut(&AuditEvent),
) -> AuditReport {
    for s in &config.slaves {
        net.add_node_with_dictionary(s.node_id, s.dictionary.clone());
    }
    let timeout = config.master.sdo_timeout;
    let mut slaves: Vec<SlaveRun<'_>> = config
        .slaves
        .iter()
        .map(|s| SlaveRun::new(net, s, options, timeout))
        .collect();
    for s in &slaves {
        on_event(&AuditEvent::SlaveStarted(s.out.node_id));
    }
    loop {
        let mut running = false;
        for s in &mut slaves {
            s.poll(&mut on_event);
            running |= !s.done;
        }
        if !running {
            break;
        }
        if net.run_for(TICK).wait().is_err() {
            // A failed transport fails every request, which the next poll reports.
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
    AuditReport {
        slaves: slaves.into_iter().map(|s| s.out).collect(),
    }
}

/// One object the audit compares.
struct Check<'a> {
    object: ObjectAddress,
    sub: &'a canola::od::SubObject,
    expected: Value,
    read_only: bool,
}

enum Step {
    /// Start the next object's read.
    Next,
    /// Reading object `checks[i]`.
    Read(usize, Pending<Vec<u8>>),
    /// Writing the DCF's value of the difference just found back.
    Fix(usize, Vec<u8>, Pending<()>),
}

struct SlaveRun<'a> {
    net: &'a Network,
    timeout: Duration,
    fix: bool,
    checks: Vec<Check<'a>>,
    next: usize,
    step: Step,
    out: SlaveAudit,
    done: bool,
}

impl<'a> SlaveRun<'a> {
    fn new(
        net: &'a Network,
        slave: &'a SlaveConfig,
        options: AuditOptions,
        timeout: Duration,
    ) -> Self {
        let node = slave.node_id;
        let checks: Vec<Check<'a>> = slave
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
            .collect();
        Self {
            net,
            timeout,
            fix: options.fix,
            out: SlaveAudit {
                node_id: node,
                checked: checks.len(),
                differences: Vec::new(),
                unreadable: Vec::new(),
            },
            checks,
            next: 0,
            step: Step::Next,
            done: false,
        }
    }

    fn sdo(&self) -> canola::Sdo {
        self.net.node(self.out.node_id).sdo().timeout(self.timeout)
    }

    fn poll(&mut self, on_event: &mut impl FnMut(&AuditEvent)) {
        let node = self.out.node_id;
        while !self.done {
            match std::mem::replace(&mut self.step, Step::Next) {
                Step::Next => match self.checks.get(self.next) {
                    Some(c) => {
                        let read = self.sdo().submit_read(c.object);
                        self.step = Step::Read(self.next, read);
                        self.next += 1;
                    }
                    None => {
                        self.done = true;
                        on_event(&AuditEvent::SlaveDone(self.out.clone()));
                    }
                },
                Step::Read(i, p) if !p.is_done() => {
                    self.step = Step::Read(i, p);
                    return;
                }
                Step::Read(i, p) => {
                    let c = &self.checks[i];
                    match p.wait() {
                        Ok(bytes) if bytes == c.expected.to_le_bytes() => {}
                        Ok(bytes) if self.fix && !c.read_only => {
                            // A restricted COB-ID is not written back.
                            match crate::config::restricted_value(node, c.object, &c.expected) {
                                Some(e) => {
                                    self.differ(i, bytes, Some(Err(e.to_string())), on_event)
                                }
                                None => {
                                    let write = self.sdo().submit_write(c.object, &c.expected);
                                    self.step = Step::Fix(i, bytes, write);
                                }
                            }
                        }
                        Ok(bytes) => self.differ(i, bytes, None, on_event),
                        Err(e) => {
                            let u = Unreadable {
                                object: c.object,
                                name: c.sub.name.to_string(),
                                abort_code: e.abort_code().map(|c| c.get()),
                                error: e.to_string(),
                            };
                            on_event(&AuditEvent::Unreadable(node, u.clone()));
                            self.out.unreadable.push(u);
                        }
                    }
                }
                Step::Fix(i, bytes, p) if !p.is_done() => {
                    self.step = Step::Fix(i, bytes, p);
                    return;
                }
                Step::Fix(i, bytes, p) => {
                    let fixed = p.wait().map_err(|e| e.to_string());
                    self.differ(i, bytes, Some(fixed), on_event);
                }
            }
        }
    }

    fn differ(
        &mut self,
        i: usize,
        bytes: Vec<u8>,
        fixed: Option<Result<(), String>>,
        on_event: &mut impl FnMut(&AuditEvent),
    ) {
        let c = &self.checks[i];
        let d = Difference {
            object: c.object,
            name: c.sub.name.to_string(),
            data_type: c.sub.data_type,
            actual: Value::from_le_bytes(c.sub.data_type, &bytes).ok(),
            actual_bytes: bytes,
            expected: c.expected.clone(),
            fixed,
        };
        on_event(&AuditEvent::Difference(self.out.node_id, d.clone()));
        self.out.differences.push(d);
    }
}
