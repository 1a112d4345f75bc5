//! The boot and the audit from tokio: every slave's every step arrives as an event while the
//! boot runs, then the report; the audit's events name the difference it found and fixed.

use std::path::Path;

use canola::{MemoryBus, Network, NodeId};
use canola_manager::asynch::{audit_async, spawn_audit, spawn_boot};
use canola_manager::simulate::attach_slaves;
use canola_manager::{AuditEvent, AuditOptions, BootEvent, BootStep, NetworkConfig, SlaveStatus};

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn boot_and_audit_from_tokio_with_events() {
    let config =
        NetworkConfig::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/three.toml"))
            .unwrap();
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let stations = attach_slaves(&bus, &config, &[]);

    let mut boot = spawn_boot(&net, &config);
    let mut events = Vec::new();
    while let Some(e) = boot.next_event().await {
        events.push(e);
    }
    let report = boot.finish().await;
    assert!(report.mandatory_ok, "{report:?}");
    for n in [5, 6, 7] {
        let steps: Vec<BootStep> = events
            .iter()
            .filter_map(|e| match e {
                BootEvent::StepDone { node: m, step } if *m == node(n) => Some(*step),
                _ => None,
            })
            .collect();
        assert_eq!(
            steps,
            [
                BootStep::DevicePresent,
                BootStep::Identity,
                BootStep::Configuration,
                BootStep::ErrorControl,
                BootStep::Start
            ],
            "node {n}"
        );
        let done = events
            .iter()
            .filter(|e| matches!(e, BootEvent::SlaveDone(r) if r.node_id == node(n)));
        assert_eq!(done.count(), 1);
    }
    assert!(
        report
            .slaves
            .iter()
            .all(|s| s.status == SlaveStatus::Operational)
    );

    // A value changed behind the master's back: the audit's events name it, --fix repairs it.
    let now = bus.now();
    bus.with_station(stations[1].1, |d| {
        d.set_value(now, 0x2001, 0, 77u32.to_le_bytes())
    });
    let fix = AuditOptions {
        fix: true,
        ..AuditOptions::default()
    };
    let mut audit = spawn_audit(&net, &config, fix);
    let mut events = Vec::new();
    while let Some(e) = audit.next_event().await {
        events.push(e);
    }
    let fixed = audit.finish().await;
    assert_eq!(fixed.slaves[1].differences.len(), 1);
    let diffs: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            AuditEvent::Difference(n, d) => Some((*n, d.object.to_string(), d.fixed.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(diffs, [(node(6), "0x2001:00".to_string(), Some(Ok(())))]);
    assert_eq!(
        events
            .iter()
            .filter(|e| matches!(e, AuditEvent::SlaveDone(_)))
            .count(),
        3
    );
    assert!(
        audit_async(&net, &config, AuditOptions::default())
            .await
            .is_clean()
    );
}
