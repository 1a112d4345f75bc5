//! Simulated slaves for a network description: each slave of a [`NetworkConfig`] as a
//! [`SimDevice`] on an in-memory bus, fresh from the factory — its dictionary's default values,
//! not the DCF's parameter values, so the boot has a configuration to write — with the identity
//! its file gives (a file whose 0x1018 differs from the expected identity fails its check as a
//! real device would). Slaves may be left off the bus to play absent devices.

use canopen::mem::StationId;
use canopen::{MemoryBus, NodeId, ObjectDictionary, SimDevice};

use crate::config::NetworkConfig;

/// `od` as a device holds it before configuration: every `ParameterValue` removed.
pub fn factory_dictionary(od: &ObjectDictionary) -> ObjectDictionary {
    let mut od = od.clone();
    for object in od.objects.values_mut() {
        for sub in object.subs.values_mut() {
            if sub.parameter_value().is_some() {
                sub.extras_mut().parameter_value = None;
            }
        }
    }
    od
}

/// The devices of `config` except those in `absent`, as (node-ID, factory dictionary).
pub fn devices(config: &NetworkConfig, absent: &[NodeId]) -> Vec<(NodeId, ObjectDictionary)> {
    config
        .slaves
        .iter()
        .filter(|s| !absent.contains(&s.node_id))
        .map(|s| (s.node_id, factory_dictionary(&s.dictionary)))
        .collect()
}

/// Attaches every slave of `config` except those in `absent` to `bus` as a simulated device.
/// Returns the node-IDs with their stations (for changing a device behind the master's back).
pub fn attach_slaves(
    bus: &MemoryBus,
    config: &NetworkConfig,
    absent: &[NodeId],
) -> Vec<(NodeId, StationId<SimDevice>)> {
    devices(config, absent)
        .into_iter()
        .map(|(node, od)| (node, bus.attach(SimDevice::new(node, od))))
        .collect()
}
