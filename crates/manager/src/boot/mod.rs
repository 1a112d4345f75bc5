//! Network boot-up the CiA 302-2 way: every slave at once (the facade runs different nodes' SDOs
//! in parallel), each through the "boot slave" steps — device present (0x1000), identity (0x1000
//! and 0x1018 against the expected values), for a keep-alive slave the node state by its
//! heartbeat or guarding (an operational slave is left running: no reset, no configuration,
//! code L; any other gets NMT reset communication), the application software version (0x1F52
//! against the expected date and time, with the CiA 302-3 program download through 0x1F51
//! program control and 0x1F50 program data when an update is needed and allowed), configuration
//! (the DCF's values, skipped when 0x1020 already holds the DCF's configuration date and time;
//! 0x1020 written last), error control start (heartbeat consumer from 0x1017, or node guarding)
//! — then NMT start, per slave or all together once every mandatory slave has booted.

use std::time::Instant as WallInstant;

use canola::nmt::GuardingEvent;
use canola::{CommandSpecifier, Duration, HeartbeatEvent, Network, NetworkEvent};

pub use crate::config::configured_values;
use crate::config::{NetworkConfig, StartPolicy};

mod failure;
mod report;
mod slave;
mod steps;

use failure::Seen;
pub use report::{
    BootEvent, BootReport, BootStep, ConfigOutcome, SlaveReport, SlaveStatus, SoftwareOutcome,
};
use slave::SlaveBoot;

/// Boots the network `net` as `config` describes; blocks until done.
pub fn boot(net: &Network, config: &NetworkConfig) -> BootReport {
    boot_with(net, config, |_| {})
}

/// How finely the boot loop drives the network between looking at its slaves' requests: a
/// finished SDO is followed up at most this late.
const TICK: Duration = Duration::from_micros(20);

/// [`boot`], calling `on_event` for every step of every slave.
///
/// One thread drives every slave's boot: each slave is a small machine with at most one SDO
/// request in flight, and the facade runs requests to different nodes together on the bus. (One
/// thread rather than one per slave keeps a virtual-clock bus deterministic.)
pub fn boot_with(
    net: &Network,
    config: &NetworkConfig,
    mut on_event: impl FnMut(&BootEvent),
) -> BootReport {
    let wall = WallInstant::now();
    let t0 = net.now();
    for s in &config.slaves {
        net.add_node_with_dictionary(s.node_id, s.dictionary.clone());
    }
    let individually = config.master.start == StartPolicy::Individually;
    if individually && let Some(p) = config.master.sync_period {
        net.start_sync(p);
    }
    let events = net.subscribe();
    let mut seen = Seen::default();
    let mut slaves: Vec<SlaveBoot<'_>> = config
        .slaves
        .iter()
        .map(|s| SlaveBoot::new(net, config, s, individually))
        .collect();
    loop {
        for ev in events.try_iter() {
            match ev {
                NetworkEvent::Heartbeat(
                    HeartbeatEvent::StateChanged { node, .. }
                    | HeartbeatEvent::Recovered { node, .. },
                )
                | NetworkEvent::Guarding(
                    GuardingEvent::StateChanged { node, .. }
                    | GuardingEvent::Recovered { node, .. },
                ) => seen.life.push(node),
                NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node })
                | NetworkEvent::Guarding(GuardingEvent::BootUp { node }) => {
                    seen.boot_ups.push(node)
                }
                _ => {}
            }
        }
        let mut running = false;
        for s in &mut slaves {
            s.poll(&mut seen, &mut on_event);
            running |= !s.finished;
        }
        seen.life.clear();
        seen.boot_ups.clear();
        if !running {
            break;
        }
        if net.run_for(TICK).wait().is_err() {
            // A failed transport fails every request, which the next poll reports.
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
    let mut reports: Vec<SlaveReport> = slaves.into_iter().map(|s| s.report).collect();

    let mandatory_ok = reports.iter().all(|r| !r.mandatory || r.booted());
    if config.master.start == StartPolicy::All && mandatory_ok {
        if let Some(p) = config.master.sync_period {
            net.start_sync(p);
        }
        let all_booted = reports.iter().all(SlaveReport::booted);
        // A broadcast when every slave booted; otherwise only the booted ones, so a slave that
        // failed its checks is not started unconfigured.
        let started = if all_booted {
            net.nmt_all(CommandSpecifier::Start).is_ok()
        } else {
            reports
                .iter()
                .filter(|r| r.status == SlaveStatus::PreOperational)
                .all(|r| net.node(r.node_id).nmt().start().is_ok())
        };
        if started {
            for r in &mut reports {
                if r.status == SlaveStatus::PreOperational {
                    r.status = SlaveStatus::Operational;
                    on_event(&BootEvent::StepDone {
                        node: r.node_id,
                        step: BootStep::Start,
                    });
                }
            }
        }
    }
    let mandatory_ok = reports.iter().all(|r| !r.mandatory || r.booted());
    BootReport {
        slaves: reports,
        mandatory_ok,
        elapsed: net.now().saturating_duration_since(t0),
        wall: wall.elapsed(),
    }
}
