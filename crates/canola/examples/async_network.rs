//! The async API (`tokio` feature) on one network: the driver as a task of the caller's
//! runtime, events as a stream, a scan, LSS assign-all, NMT commands and state waits, SDO
//! reads by name and several at once, and a `tokio::time::timeout` that cancels a read (the
//! node gets an SDO abort).
//!
//! `cargo run -p canola --features tokio --example async_network`. The in-memory bus runs on
//! the real clock here, as a real bus does. (A virtual-clock bus would follow tokio's clock
//! instead: real time here, a jumping one under a paused test clock; see `canola::asynch`.)

use canola::lss::{AssignConfig, LssAddress, NodeIdPool, SlaveConfig};
use canola::mem::{BusConfig, ClockMode};
use canola::{
    Duration, HeartbeatEvent, Lagged, MemoryBus, Network, NetworkEvent, NmtState, NodeId, SimDevice,
};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

async fn run() -> Result<(), Box<dyn std::error::Error>> {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    net.start_driver_on_runtime();
    let od = canola::od::parse(EDS)?.od;

    // Two configured devices, and one that LSS will give a node-ID.
    let ids: Vec<NodeId> = [2, 3]
        .into_iter()
        .filter_map(|i| NodeId::new(i).ok())
        .collect();
    for &id in &ids {
        bus.attach(SimDevice::new(id, od.clone()));
    }
    let address = LssAddress::new(0x39, 0x0100_0001, 1, 4242);
    bus.attach(SimDevice::unconfigured_with(
        od.clone(),
        SlaveConfig::unconfigured_real(address),
    ));

    // Every event from now on, in a task of its own.
    let mut events = net.events();
    let watcher = tokio::spawn(async move {
        let mut changes = 0;
        while let Some(item) = events.next().await {
            match item {
                Ok(NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged { node, to, .. })) => {
                    println!("event: node {node} is {to}");
                    changes += 1;
                }
                Ok(_) => {}
                Err(Lagged(n)) => println!("event: {n} lost (this subscriber fell behind)"),
            }
        }
        changes
    });

    let report = net
        .lss()
        .assign_all(AssignConfig::with_pool(NodeIdPool::range(
            NodeId::new(10)?,
            NodeId::MAX,
        )))
        .await?;
    for (a, id) in report.assigned() {
        println!("LSS: serial number {} is node {id}", a.serial_number);
    }

    let found = net.scan(Duration::from_millis(50)).await?;
    for s in &found {
        println!(
            "scan: node {} vendor {:#010x} serial {:?}",
            s.node, s.identity.vendor_id, s.identity.serial
        );
    }

    // Each node: faster heartbeats (by name, typed by the EDS), start, wait until it says so.
    for s in &found {
        let node = net.add_node_with_dictionary(s.node, od.clone());
        node.sdo().set("Producer heartbeat time", 50).await?;
        let nmt = node.nmt();
        nmt.start()?;
        nmt.wait_for_state(NmtState::Operational, Duration::from_secs(1))
            .await?;
    }

    // Reads to different nodes run at once.
    let reads = found.iter().map(|s| {
        let sdo = net.node(s.node).sdo();
        tokio::spawn(async move { sdo.get("Manufacturer device name").await })
    });
    for r in reads {
        println!("device name: {}", r.await??);
    }

    // A read nobody answers, given up after 20 ms: dropping it aborts the transfer.
    let absent = net.node(NodeId::new(99)?).sdo().read((0x1000, 0));
    let r = tokio::time::timeout(std::time::Duration::from_millis(20), absent).await;
    println!(
        "node 99: {}",
        if r.is_err() {
            "no answer in 20 ms"
        } else {
            "answered"
        }
    );

    net.stop_driver()?;
    drop(net);
    let changes = watcher.await?;
    println!("{changes} state changes seen");
    assert!(
        changes >= found.len(),
        "each started node reported Operational"
    );
    Ok(())
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    run().await
}

#[cfg(test)]
#[test]
fn runs() {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
        .block_on(run())
        .unwrap();
}
