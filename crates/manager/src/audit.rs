//! The configuration audit: read every object each slave's DCF configures from the live
//! network and list where the device differs from its DCF, and what could not be read.
//! Read-only objects are left out unless asked for (a DCF records them, the master cannot set
//! them); write-only ones cannot be read.

use canopen::od::AccessType;
use canopen::{DataType, Duration, Network, NodeId, ObjectAddress, Value};

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

/// Audits every slave of `config` on `net`, the slaves in parallel.
pub fn audit(net: &Network, config: &NetworkConfig, options: AuditOptions) -> AuditReport {
    for s in &config.slaves {
        net.add_node_with_dictionary(s.node_id, s.dictionary.clone());
    }
    let timeout = config.master.sdo_timeout;
    let slaves = std::thread::scope(|scope| {
        let handles: Vec<_> = config
            .slaves
            .iter()
            .map(|s| {
                let net = net.clone();
                scope.spawn(move || audit_slave(&net, s, options, timeout))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("an audit thread panicked"))
            .collect()
    });
    AuditReport { slaves }
}

fn audit_slave(
    net: &Network,
    slave: &SlaveConfig,
    options: AuditOptions,
    timeout: Duration,
) -> SlaveAudit {
    let node = slave.node_id;
    let mut out = SlaveAudit {
        node_id: node,
        checked: 0,
        differences: Vec::new(),
        unreadable: Vec::new(),
    };
    for (index, sub) in slave.dictionary.entries() {
        let read_only = matches!(sub.access, AccessType::Ro | AccessType::Const);
        if sub.access == AccessType::Wo || (read_only && !options.read_only) {
            continue;
        }
        let Some(expected) = sub.parameter_value().and_then(|f| f.resolve(node.get())) else {
            continue;
        };
        let object = ObjectAddress::new(index, sub.sub_index);
        out.checked += 1;
        let sdo = || net.node(node).sdo().timeout(timeout);
        match sdo().submit_read(object).wait() {
            Ok(bytes) => {
                if bytes == expected.to_le_bytes() {
                    continue;
                }
                let fixed = (options.fix && !read_only).then(|| {
                    sdo()
                        .submit_write(object, &expected)
                        .wait()
                        .map_err(|e| e.to_string())
                });
                out.differences.push(Difference {
                    object,
                    name: sub.name.to_string(),
                    data_type: sub.data_type,
                    actual: Value::from_le_bytes(sub.data_type, &bytes).ok(),
                    actual_bytes: bytes,
                    expected,
                    fixed,
                });
            }
            Err(e) => out.unreadable.push(Unreadable {
                object,
                name: sub.name.to_string(),
                abort_code: e.abort_code().map(|c| c.get()),
                error: e.to_string(),
            }),
        }
    }
    out
}
