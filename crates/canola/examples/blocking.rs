//! The blocking API against a simulated Bürkert device on the in-memory bus (no hardware):
//! wait for the boot-up, read and write by name with types from the EDS, start the node.
//!
//! `cargo run -p canola --example blocking`. On a real bus, replace the first three lines of
//! `run` with `let net = Network::open("can0")?;` (`socketcan` feature).

use canola::{Duration, MemoryBus, Network, NmtState, NodeId, SimDevice};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let bus = MemoryBus::new(); // virtual clock: the example runs in no time, deterministically
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5)?;
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS)?.od);
    let nmt = node.nmt();
    bus.attach(SimDevice::from_eds(id, EDS)?); // the device powers on

    nmt.wait_for_bootup(Duration::from_secs(1)).wait()?;
    println!("node {id} booted");
    println!(
        "device name: {}",
        node.sdo().get("Manufacturer device name").wait()?
    );
    println!(
        "vendor-ID: {}",
        node.sdo().get("Identity object.Vendor ID").wait()?
    );
    node.sdo().set("Producer heartbeat time", 200).wait()?; // sent as the UNSIGNED16 it is
    println!(
        "heartbeat: {} ms",
        node.sdo().get("Producer heartbeat time").wait()?
    );
    nmt.start()?;
    nmt.wait_for_state(NmtState::Operational, Duration::from_secs(1))
        .wait()?;
    println!("node {id} is {}", nmt.state().ok_or("no state")?);
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run()
}

#[cfg(test)]
#[test]
fn runs() {
    run().unwrap();
}
