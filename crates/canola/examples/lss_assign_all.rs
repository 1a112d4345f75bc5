//! LSS (CiA 305): three unconfigured devices on the bus get node-IDs from a pool with one call
//! (Fastscan finds each, assigns, stores); then each boots and answers SDO. Node 21 is
//! already running on the bus: it is not handed out, and the report says so.
//!
//! `cargo run -p canola --example lss_assign_all`.

use canola::lss::{AssignConfig, LssAddress, NodeIdPool};
use canola::{Duration, MemoryBus, Network, NodeId, SimDevice};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

fn run() -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let parsed = canola::od::parse(EDS)?;
    for w in &parsed.diagnostics {
        println!("EDS line {}: {}", w.line, w.message);
    }
    let od = parsed.od;
    bus.attach(SimDevice::new(NodeId::new(21)?, od.clone())); // a node already running
    for serial in [1001, 2002, 3003] {
        let address = LssAddress::new(0x39, 0x0100_0001, 1, serial);
        bus.attach(SimDevice::unconfigured(od.clone(), address));
    }
    let pool = NodeIdPool::range(NodeId::new(20)?, NodeId::new(30)?);
    let report = net.lss().assign_all(AssignConfig::with_pool(pool)).wait()?;
    for id in report.skipped.iter() {
        println!("node-ID {id} is in use on the bus: not handed out");
    }
    net.run_for(Duration::from_millis(10)).wait()?; // the boot-ups
    let mut given = Vec::new();
    for (address, id) in report.assigned() {
        let serial = net.node(id).sdo().read((0x1018, 4)).wait()?;
        println!(
            "serial {} -> node {id} (reads back serial {:?})",
            address.serial_number, serial
        );
        given.push(id.get());
    }
    Ok(given)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run()?;
    Ok(())
}

#[cfg(test)]
#[test]
fn runs() {
    assert_eq!(run().unwrap(), [20, 22, 23]);
}
