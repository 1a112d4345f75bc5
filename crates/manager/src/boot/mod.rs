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

use std::sync::mpsc;
use std::time::Instant as WallInstant;

use canola::{CommandSpecifier, Network, Operation};

pub use crate::config::configured_values;
use crate::config::{NetworkConfig, StartPolicy};

mod failure;
mod report;
mod slave;
mod steps;

pub use report::{
    BootEvent, BootReport, BootStep, ConfigOutcome, SlaveReport, SlaveStatus, SoftwareOutcome,
};

/// Boots the network `net` as `config` describes; blocks until done.
pub fn boot(net: &Network, config: &NetworkConfig) -> BootReport {
    boot_with(net, config, |_| {})
}

/// [`boot`], calling `on_event` for every step of every slave.
///
/// Each slave's boot is one straight-line body of awaited operations; all of them run together
/// on the calling thread ([`canola::wait_all_with`]: the bodies are polled in turn and the
/// network is driven one step between rounds), so the slaves' SDOs run in parallel on the bus
/// and a virtual-clock bus stays deterministic. `on_event` is called on the calling thread
/// after each driving step, in order for each slave (the events of different slaves
/// interleave as they happen).
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
    let (tx, events) = mpsc::channel();
    let emit = move |e| {
        // The receiving end lives until every slave is done.
        let _ = tx.send(e);
    };
    let bodies = config.slaves.iter().map(|slave| {
        let body = slave::boot_slave(net, config, slave, individually, t0, &emit);
        Operation::new(async { Ok::<_, std::convert::Infallible>(body.await) })
    });
    let results = canola::wait_all_with(bodies, || events.try_iter().for_each(|e| on_event(&e)));
    events.try_iter().for_each(|e| on_event(&e));
    let mut reports: Vec<SlaveReport> = results
        .into_iter()
        .map(|r| match r {
            Ok(r) => r,
            Err(never) => match never {},
        })
        .collect();

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
