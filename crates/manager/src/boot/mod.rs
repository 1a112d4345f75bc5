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
use crate::config::{NetworkConfig, SlaveConfig, StartPolicy};

mod failure;
mod life;
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
/// Each slave's boot is one straight-line body of awaited operations, finished on a thread of
/// its own: the threads drive the network together (whoever waits drives), so the slaves'
/// SDOs run in parallel on the bus. `on_event` is called on the calling thread, in order for
/// each slave (the events of different slaves interleave as they happen).
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
    let run = |slave: &SlaveConfig, tx: mpsc::Sender<BootEvent>| {
        let emit = move |e| {
            // The receiving end lives until every slave is done.
            let _ = tx.send(e);
        };
        let body = slave::boot_slave(net, config, slave, individually, t0, &emit);
        match Operation::new(async { Ok::<_, std::convert::Infallible>(body.await) }).wait() {
            Ok(r) => r,
            Err(never) => match never {},
        }
    };
    let mut reports: Vec<SlaveReport> = std::thread::scope(|s| {
        let mut threads = Vec::with_capacity(config.slaves.len());
        let mut inline = Vec::new();
        for (i, slave) in config.slaves.iter().enumerate() {
            let tx = tx.clone();
            let spawned = std::thread::Builder::new()
                .name(format!("boot-{}", slave.node_id))
                .spawn_scoped(s, move || run(slave, tx));
            match spawned {
                Ok(t) => threads.push((i, t)),
                // No thread to be had: that slave boots on this thread, after the others
                // started (its events come once it is done).
                Err(_) => inline.push(i),
            }
        }
        drop(tx);
        let mut reports: Vec<Option<SlaveReport>> = vec![None; config.slaves.len()];
        for i in inline {
            let (tx, rx) = mpsc::channel();
            reports[i] = Some(run(&config.slaves[i], tx));
            rx.try_iter().for_each(|e| on_event(&e));
        }
        // Until every slave's thread let go of its sender.
        for e in &events {
            on_event(&e);
        }
        for (i, t) in threads {
            match t.join() {
                Ok(r) => reports[i] = Some(r),
                Err(p) => std::panic::resume_unwind(p),
            }
        }
        reports.into_iter().flatten().collect()
    });

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
