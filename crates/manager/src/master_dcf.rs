//! The CiA 302 master objects, so descriptions made with other tools and this one meet: 0x1F80
//! NMT startup, 0x1F81 slave assignment, 0x1F84..0x1F88 expected device type, vendor-ID, product
//! code, revision and serial number, 0x1F22 concise DCFs, 0x1F89 boot time, and for the software
//! check (CiA 302-3) 0x1F53/0x1F54 expected application software date and time and 0x1F58
//! program data — written from a
//! [`NetworkConfig`] into a master dictionary (and so a master DCF), and read back from one.

use std::collections::BTreeMap;

use canola::od::write::{ConciseSelection, concise_dcf, decode_concise};
use canola::od::{AccessType, FieldValue, Object, ObjectCode, ObjectDictionary, SubObject};
use canola::{DataType, NodeId};

use crate::config::{
    IdentityCheck, NetworkConfig, Program, SoftwareCheck, StartPolicy, configured_values,
};

/// 0x1F80 bit 0: the device is the NMT master.
pub const STARTUP_NMT_MASTER: u32 = 1 << 0;
/// 0x1F80 bit 1: start all nodes with one broadcast.
pub const STARTUP_START_ALL: u32 = 1 << 1;
/// 0x1F80 bit 3: the application, not the master, starts the slaves.
pub const STARTUP_NO_START: u32 = 1 << 3;
/// 0x1F81 bit 0: the node is a slave of this master.
pub const ASSIGN_SLAVE: u32 = 1 << 0;
/// 0x1F81 bit 2: boot the slave (check and configure it).
pub const ASSIGN_BOOT: u32 = 1 << 2;
/// 0x1F81 bit 3: the slave is mandatory.
pub const ASSIGN_MANDATORY: u32 = 1 << 3;
/// 0x1F81 bit 4: keep-alive, do not reset the slave when it is operational.
pub const ASSIGN_KEEP_ALIVE: u32 = 1 << 4;
/// 0x1F81 bit 5: verify the slave's application software version (0x1F52 against 0x1F53/0x1F54).
pub const ASSIGN_VERIFY_SOFTWARE: u32 = 1 << 5;
/// 0x1F81 bit 6: an automatic software update (program download) is allowed.
pub const ASSIGN_UPDATE_SOFTWARE: u32 = 1 << 6;

/// What the master objects say about one slave.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SlaveObjects {
    /// 0x1F81 sub node.
    pub assignment: u32,
    /// 0x1F84..0x1F88 sub node (0 there means "not checked").
    pub identity: IdentityCheck,
    /// 0x1F22 sub node, the concise DCF.
    pub concise_dcf: Option<Vec<u8>>,
    /// With 0x1F81 bit 5: 0x1F53/0x1F54 sub node, bit 6, and 0x1F58 sub node.
    pub software: Option<SoftwareCheck>,
}

impl SlaveObjects {
    /// Whether 0x1F81 marks the slave mandatory.
    pub fn mandatory(&self) -> bool {
        self.assignment & ASSIGN_MANDATORY != 0
    }

    /// Whether 0x1F81 sets the keep-alive bit.
    pub fn keep_alive(&self) -> bool {
        self.assignment & ASSIGN_KEEP_ALIVE != 0
    }
}

/// The master objects of a network.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MasterObjects {
    /// 0x1F80 NMT startup.
    pub startup: u32,
    /// 0x1F89 boot time in ms (0: no limit).
    pub boot_time_ms: u32,
    /// The slaves 0x1F81 assigns, by node-ID.
    pub slaves: BTreeMap<u8, SlaveObjects>,
}

const IDENTITY: [(u16, &str); 5] = [
    (0x1F84, "Device Type Identification"),
    (0x1F85, "Vendor Identification"),
    (0x1F86, "Product Code"),
    (0x1F87, "Revision Number"),
    (0x1F88, "Serial Number"),
];

fn identity_field(id: &IdentityCheck, i: usize) -> Option<u32> {
    [
        id.device_type,
        id.vendor_id,
        id.product_code,
        id.revision,
        id.serial,
    ][i]
}

impl MasterObjects {
    /// The objects that stand for `config`.
    pub fn from_config(config: &NetworkConfig) -> Self {
        let startup = STARTUP_NMT_MASTER
            | match config.master.start {
                StartPolicy::All => STARTUP_START_ALL,
                StartPolicy::Individually => 0,
                StartPolicy::None => STARTUP_NO_START,
            };
        let slaves = config
            .slaves
            .iter()
            .map(|s| {
                let mut assignment = ASSIGN_SLAVE | ASSIGN_BOOT;
                if s.mandatory {
                    assignment |= ASSIGN_MANDATORY;
                }
                if s.keep_alive {
                    assignment |= ASSIGN_KEEP_ALIVE;
                }
                if let Some(w) = &s.software {
                    assignment |= ASSIGN_VERIFY_SOFTWARE;
                    if w.update {
                        assignment |= ASSIGN_UPDATE_SOFTWARE;
                    }
                }
                let values = configured_values(s);
                let concise = (!values.is_empty()).then(|| {
                    concise_dcf(
                        &s.dictionary,
                        s.node_id.get(),
                        ConciseSelection::ParameterValues,
                    )
                });
                (
                    s.node_id.get(),
                    SlaveObjects {
                        assignment,
                        identity: s.identity,
                        concise_dcf: concise,
                        software: s.software.clone(),
                    },
                )
            })
            .collect();
        Self {
            startup,
            boot_time_ms: u32::try_from(config.master.boot_timeout.as_micros() / 1000)
                .unwrap_or(u32::MAX),
            slaves,
        }
    }

    /// The start policy 0x1F80 gives.
    pub fn start_policy(&self) -> StartPolicy {
        if self.startup & STARTUP_NO_START != 0 {
            StartPolicy::None
        } else if self.startup & STARTUP_START_ALL != 0 {
            StartPolicy::All
        } else {
            StartPolicy::Individually
        }
    }

    /// The objects in a master dictionary (arrays with all 127 node sub-indices; write it with
    /// `canola::od::write_dcf`).
    pub fn to_dictionary(&self) -> ObjectDictionary {
        let mut od = ObjectDictionary::default();
        let u32_var = |index: u16, name: &str, v: u32| {
            let mut sub = SubObject::new(0, name, DataType::Unsigned32, AccessType::Rw)
                .with_default_text("0");
            sub.extras_mut().parameter_value =
                Some(text(DataType::Unsigned32, &format!("{v:#010x}")));
            Object::var(index, sub)
        };
        od.insert(u32_var(0x1F80, "NMT Startup", self.startup));
        od.insert(u32_var(0x1F89, "Boot Time", self.boot_time_ms));
        let array = |index: u16,
                     name: &str,
                     dt: DataType,
                     value: &dyn Fn(&SlaveObjects) -> Option<String>| {
            let mut subs = vec![
                SubObject::new(0, "Number of Entries", DataType::Unsigned8, AccessType::Ro)
                    .with_default_text("127"),
            ];
            for node in 1..=127u8 {
                let default = if dt == DataType::Domain { "" } else { "0" };
                let mut sub = SubObject::new(node, format!("Node {node}"), dt, AccessType::Rw);
                if !default.is_empty() {
                    sub = sub.with_default_text(default);
                }
                if let Some(v) = self.slaves.get(&node).and_then(value) {
                    sub.extras_mut().parameter_value = Some(text(dt, &v));
                }
                subs.push(sub);
            }
            Object::complex(index, name, ObjectCode::Array, subs)
        };
        od.insert(array(
            0x1F81,
            "Slave Assignment",
            DataType::Unsigned32,
            &|s| Some(format!("{:#010x}", s.assignment)),
        ));
        for (i, (index, name)) in IDENTITY.iter().enumerate() {
            od.insert(array(*index, name, DataType::Unsigned32, &|s| {
                identity_field(&s.identity, i).map(|v| format!("{v:#010x}"))
            }));
        }
        od.insert(array(0x1F22, "Concise DCF", DataType::Domain, &|s| {
            s.concise_dcf.as_ref().map(|b| hex(b))
        }));
        od.insert(array(
            0x1F53,
            "Expected Application SW Date",
            DataType::Unsigned32,
            &|s| s.software.as_ref()?.date.map(|v| format!("{v:#010x}")),
        ));
        od.insert(array(
            0x1F54,
            "Expected Application SW Time",
            DataType::Unsigned32,
            &|s| s.software.as_ref()?.time.map(|v| format!("{v:#010x}")),
        ));
        od.insert(array(0x1F58, "Program Data", DataType::Domain, &|s| {
            s.software.as_ref()?.program.as_ref().map(|p| hex(&p.data))
        }));
        od.rebuild_object_lists();
        od
    }

    /// Reads the objects from a master dictionary (a parsed master DCF): each entry's
    /// `ParameterValue`, else its `DefaultValue`. Slaves are the nodes 0x1F81 marks with bit 0.
    pub fn from_dictionary(od: &ObjectDictionary) -> Self {
        let value = |index: u16, sub: u8| od.sub(index, sub).and_then(|s| s.effective_value(0));
        let u32_at = |index: u16, sub: u8| {
            value(index, sub)
                .and_then(|v| v.as_i128())
                .and_then(|v| u32::try_from(v).ok())
                .unwrap_or(0)
        };
        let mut slaves = BTreeMap::new();
        for node in 1..=127u8 {
            let assignment = u32_at(0x1F81, node);
            if assignment & ASSIGN_SLAVE == 0 {
                continue;
            }
            let id = |i: usize| Some(u32_at(IDENTITY[i].0, node)).filter(|&v| v != 0);
            let domain = |index: u16| match value(index, node) {
                Some(canola::Value::Domain(b)) if !b.is_empty() => Some(b),
                _ => None,
            };
            let concise = domain(0x1F22);
            let nonzero = |index: u16| Some(u32_at(index, node)).filter(|&v| v != 0);
            let software = (assignment & ASSIGN_VERIFY_SOFTWARE != 0).then(|| SoftwareCheck {
                date: nonzero(0x1F53),
                time: nonzero(0x1F54),
                update: assignment & ASSIGN_UPDATE_SOFTWARE != 0,
                program: domain(0x1F58).map(|data| Program {
                    path: format!("0x1F58:{node:02X}").into(),
                    data: std::sync::Arc::new(data),
                }),
            });
            slaves.insert(
                node,
                SlaveObjects {
                    assignment,
                    identity: IdentityCheck {
                        device_type: id(0),
                        vendor_id: id(1),
                        product_code: id(2),
                        revision: id(3),
                        serial: id(4),
                    },
                    concise_dcf: concise,
                    software,
                },
            );
        }
        Self {
            startup: u32_at(0x1F80, 0),
            boot_time_ms: u32_at(0x1F89, 0),
            slaves,
        }
    }

    /// The master DCF text for `config` (master node-ID from its `[master]`).
    pub fn write_master_dcf(config: &NetworkConfig) -> String {
        let mut od = Self::from_config(config).to_dictionary();
        od.file_info.file_name = Some("master.dcf".into());
        od.file_info.description = Some("CANopen manager objects (CiA 302)".into());
        canola::od::write_dcf(&od, config.master.node_id.get(), None)
    }
}

/// Bytes as the hex text of a DOMAIN value.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|x| format!("{x:02X}")).collect()
}

/// A field from text the writer produced itself (always valid for its type).
fn text(dt: DataType, t: &str) -> FieldValue {
    FieldValue::from_text(dt, t).0
}

trait DefaultText {
    fn with_default_text(self, t: &str) -> Self;
}

impl DefaultText for SubObject {
    fn with_default_text(mut self, t: &str) -> Self {
        self.default_value = Some(text(self.data_type, t));
        self
    }
}

/// A slave dictionary from a concise DCF: one DOMAIN entry per value, its bytes as the
/// `ParameterValue`, so the boot writes them as they are and the audit compares them byte by byte.
pub fn dictionary_from_concise(bytes: &[u8]) -> Result<ObjectDictionary, String> {
    let entries = decode_concise(bytes).map_err(|e| e.to_string())?;
    let mut od = ObjectDictionary::default();
    for e in entries {
        let hex: String = e.data.iter().map(|x| format!("{x:02X}")).collect();
        let mut sub = SubObject::new(
            e.sub_index,
            format!("{:#06x}:{:02x}", e.index, e.sub_index),
            DataType::Domain,
            AccessType::Rw,
        );
        sub.extras_mut().parameter_value = Some(text(DataType::Domain, &hex));
        match od.objects.get_mut(&e.index) {
            Some(o) => {
                o.subs.insert(sub);
                o.object_code = ObjectCode::Record;
            }
            None if e.sub_index == 0 => {
                od.insert(Object::var(e.index, sub));
            }
            None => {
                let name = format!("{:#06x}", e.index);
                od.insert(Object::complex(e.index, name, ObjectCode::Record, [sub]));
            }
        }
    }
    Ok(od)
}

/// Applies what a master DCF says to the slaves `config` lists: its start policy, its identity
/// checks where the description gives none, and mandatory where 0x1F81 says so. Returns the nodes 0x1F81 assigns that the
/// description does not list.
pub fn apply(objects: &MasterObjects, config: &mut NetworkConfig) -> Vec<NodeId> {
    config.master.start = objects.start_policy();
    for s in &mut config.slaves {
        if let Some(o) = objects.slaves.get(&s.node_id.get()) {
            if s.identity == IdentityCheck::default() {
                s.identity = o.identity;
            }
            s.mandatory |= o.mandatory();
            s.keep_alive |= o.keep_alive();
            if s.software.is_none() {
                s.software = o.software.clone();
            }
        }
    }
    objects
        .slaves
        .keys()
        .filter_map(|&n| NodeId::new(n).ok())
        .filter(|n| config.slave(*n).is_none())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn three() -> NetworkConfig {
        NetworkConfig::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/three.toml"
        ))
        .unwrap()
    }

    #[test]
    fn master_dcf_round_trip() {
        let config = three();
        let objects = MasterObjects::from_config(&config);
        assert_eq!(objects.startup, STARTUP_NMT_MASTER | STARTUP_START_ALL);
        assert_eq!(objects.slaves[&5].assignment, 0x0D);
        assert_eq!(objects.slaves[&7].assignment, 0x05);
        let text = MasterObjects::write_master_dcf(&config);
        let od = canola::od::parse(text.as_bytes())
            .expect("the written DCF parses")
            .od;
        let back = MasterObjects::from_dictionary(&od);
        assert_eq!(back, objects);
        assert_eq!(back.slaves[&5].identity.vendor_id, Some(0x39));
        assert_eq!(back.slaves[&5].identity.product_code, Some(0x1234));
        assert_eq!(back.slaves[&6].identity, IdentityCheck::default());
        assert_eq!(back.start_policy(), StartPolicy::All);
        assert_eq!(back.boot_time_ms, 300);
        // The concise DCF holds what the boot writes (plus 0x1020, which the boot writes last).
        let entries = decode_concise(back.slaves[&7].concise_dcf.as_ref().unwrap()).unwrap();
        let expected = configured_values(&config.slaves[2]);
        assert_eq!(entries.len(), expected.len());
        for (e, (addr, v)) in entries.iter().zip(&expected) {
            assert_eq!((e.index, e.sub_index), (addr.index, addr.sub_index));
            assert_eq!(e.data, v.to_le_bytes());
        }
    }

    #[test]
    fn keep_alive_and_software_objects_round_trip() {
        let mut config = three();
        config.slaves[0].keep_alive = true;
        config.slaves[1].software = Some(SoftwareCheck {
            date: Some(15400),
            time: Some(36_000_000),
            update: true,
            program: Some(Program {
                path: "0x1F58:06".into(),
                data: std::sync::Arc::new(vec![1, 2, 3, 0xFE]),
            }),
        });
        config.slaves[2].software = Some(SoftwareCheck {
            date: Some(9),
            ..SoftwareCheck::default()
        });
        let objects = MasterObjects::from_config(&config);
        assert_eq!(objects.slaves[&5].assignment, 0x1D);
        assert_eq!(objects.slaves[&6].assignment, 0x6D);
        assert_eq!(objects.slaves[&7].assignment, 0x25);
        let text = MasterObjects::write_master_dcf(&config);
        let od = canola::od::parse(text.as_bytes()).unwrap().od;
        let back = MasterObjects::from_dictionary(&od);
        assert_eq!(back, objects);
        assert!(back.slaves[&5].keep_alive());
        assert_eq!(back.slaves[&7].software.as_ref().unwrap().expected(), None);
    }

    #[test]
    fn apply_takes_policy_identity_and_mandatory() {
        let mut config = three();
        let mut objects = MasterObjects::from_config(&config);
        objects.startup = STARTUP_NMT_MASTER;
        objects.slaves.get_mut(&6).unwrap().identity.vendor_id = Some(0x77);
        objects.slaves.get_mut(&7).unwrap().assignment |= ASSIGN_MANDATORY;
        objects.slaves.insert(
            9,
            SlaveObjects {
                assignment: 1,
                ..SlaveObjects::default()
            },
        );
        let extra = apply(&objects, &mut config);
        assert_eq!(extra, [NodeId::new(9).unwrap()]);
        assert_eq!(config.master.start, StartPolicy::Individually);
        assert_eq!(config.slaves[1].identity.vendor_id, Some(0x77));
        assert_eq!(config.slaves[0].identity.product_code, Some(0x1234));
        assert!(config.slaves[2].mandatory);
    }
}
