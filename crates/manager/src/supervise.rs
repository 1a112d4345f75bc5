//! After the boot: the CiA 302-2 reactions to what the slaves do later. A boot-up message from a
//! described slave (an optional slave that appears late, or one that reset and lost its
//! configuration) boots that slave again; a slave whose error control reports it lost and that
//! is marked `restart_on_loss` gets NMT reset communication, and its boot-up then boots it. A
//! boot-up from a device the description does not list is the boot slave process's error A
//! (not in the slave assignment 0x1F81): reported, and the device is left alone.

use canola::nmt::GuardingEvent;
use canola::{Duration, HeartbeatEvent, Instant, Network, NetworkEvent, NodeId};

use crate::boot::{BootEvent, BootReport, SlaveStatus, boot_with};
use crate::codes::BootErrorCode;
use crate::config::{NetworkConfig, StartPolicy};

/// What the supervision did.
#[derive(Debug, Clone, PartialEq)]
pub enum SuperviseEvent {
    /// A slave sent boot-up and is being booted again.
    Rebooting(NodeId),
    /// A slave was lost; NMT reset communication was sent (restart on loss).
    Reset(NodeId),
    /// A slave was lost and is not restarted.
    Lost(NodeId),
    /// A step of a re-boot.
    Boot(BootEvent),
    /// A device that is not a slave of this network sent boot-up: it is not booted (CiA 302-2
    /// boot slave error `code`, always [`BootErrorCode::A`]).
    NotListed {
        /// The device's node-ID.
        node: NodeId,
        /// The boot slave error code.
        code: BootErrorCode,
    },
}

/// Supervises the network until `until` on its clock, keeping `report` current (a re-booted
/// slave's entry is replaced by its new boot's).
pub fn supervise(
    net: &Network,
    config: &NetworkConfig,
    report: &mut BootReport,
    until: Instant,
    mut on_event: impl FnMut(&SuperviseEvent),
) {
    let events = net.subscribe();
    // Re-boots start a slave on its own, never with a broadcast that would also start slaves
    // that failed.
    let mut single = config.clone();
    single.master.sync_period = None;
    single.master.start = match config.master.start {
        StartPolicy::None => StartPolicy::None,
        _ if !report.mandatory_ok => StartPolicy::None,
        _ => StartPolicy::Individually,
    };
    while net.now() < until {
        let mut booted = Vec::new();
        for ev in events.try_iter() {
            match ev {
                NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node })
                | NetworkEvent::Guarding(GuardingEvent::BootUp { node }) => booted.push(node),
                NetworkEvent::Heartbeat(HeartbeatEvent::Lost { node, .. })
                | NetworkEvent::Guarding(GuardingEvent::Lost { node, .. }) => {
                    let Some(slave) = config.slave(node) else {
                        continue;
                    };
                    if slave.restart_on_loss {
                        let _ = net.node(node).nmt().reset_communication();
                        on_event(&SuperviseEvent::Reset(node));
                    } else {
                        on_event(&SuperviseEvent::Lost(node));
                    }
                    if let Some(r) = report.slaves.iter_mut().find(|r| r.node_id == node) {
                        r.status = SlaveStatus::Absent;
                    }
                }
                _ => {}
            }
        }
        booted.dedup();
        for node in booted {
            let Some(slave) = config.slave(node) else {
                on_event(&SuperviseEvent::NotListed {
                    node,
                    code: BootErrorCode::A,
                });
                continue;
            };
            on_event(&SuperviseEvent::Rebooting(node));
            single.slaves = vec![slave.clone()];
            let again = boot_with(net, &single, |e| on_event(&SuperviseEvent::Boot(e.clone())));
            if let (Some(new), Some(old)) = (
                again.slaves.into_iter().next(),
                report.slaves.iter_mut().find(|r| r.node_id == node),
            ) {
                *old = new;
            }
        }
        let _ = net.run_for(Duration::from_millis(1)).wait();
    }
}
