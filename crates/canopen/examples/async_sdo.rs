//! The async API (`tokio` feature): the network's driver runs as a task on the caller's
//! runtime, SDO reads run as futures, several at once.
//!
//! `cargo run -p canopen --features tokio --example async_sdo`. The in-memory bus runs on the
//! real clock here: a background driver on the virtual clock would run simulated time as fast
//! as the CPU allows.

use canopen::mem::{BusConfig, ClockMode};
use canopen::{MemoryBus, Network, NodeId, SimDevice};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

async fn run() -> Result<(), Box<dyn std::error::Error>> {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    net.start_driver_on_runtime();
    let ids: Vec<NodeId> = (1..=3).filter_map(|i| NodeId::new(i).ok()).collect();
    for &id in &ids {
        bus.attach(SimDevice::from_eds(id, EDS)?);
    }
    // One read per node, concurrently: requests to different nodes run in parallel.
    let reads = ids.iter().map(|&id| {
        let sdo = net.node(id).sdo();
        tokio::spawn(async move { (id, sdo.read_async((0x1018, 4)).await) })
    });
    for r in reads {
        let (id, serial) = r.await?;
        println!("node {id}: serial number {:02X?}", serial?);
    }
    net.stop_driver()?;
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
