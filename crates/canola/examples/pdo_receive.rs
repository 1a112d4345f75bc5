//! Receiving TPDOs as decoded values: the node is added with its EDS, so the master decodes its
//! TPDOs through the mapping and publishes `NetworkEvent::PdoValues`. The same PDOs also come
//! in batches from `Network::subscribe_pdos` — the receiver for full bus load: no allocation and
//! no channel message per frame.
//!
//! `cargo run -p canola --example pdo_receive`.

use canola::{Duration, MemoryBus, Network, NetworkEvent, NodeId, SimDevice};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

fn run() -> Result<usize, Box<dyn std::error::Error>> {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5)?;
    // The parser hands back its warnings with the dictionary: show them.
    let parsed = canola::od::parse(EDS)?;
    for d in &parsed.diagnostics {
        eprintln!("{}", d.render("burkert-generic.eds"));
    }
    net.add_node_with_dictionary(id, parsed.od);
    let device = bus.attach(SimDevice::from_eds(id, EDS)?);
    let events = net.subscribe();
    let mut batches = net.subscribe_pdos();
    net.node(id).nmt().start()?; // TPDOs flow in Operational
    net.run_for(Duration::from_millis(100)).wait()?;

    // A new sensor reading on the device; its TPDO carries it.
    let now = bus.now();
    bus.with_station(device, |d| {
        d.set_value(now, 0x2500, 1, 21.75f32.to_le_bytes())
    });
    net.run_for(Duration::from_millis(500)).wait()?;

    let mut received = 0;
    for ev in events.try_iter() {
        if let NetworkEvent::PdoValues {
            node,
            number,
            values,
            at,
            ..
        } = ev
        {
            let text: Vec<String> = values.iter().map(|(a, v)| format!("{a} = {v}")).collect();
            println!("{at}  node {node} TPDO{number}: {}", text.join(", "));
            received += 1;
        }
    }

    // Every PDO since the subscription (or the previous batch), as borrowed views.
    let batch = batches.try_recv()?;
    // A value by its name in the node's EDS.
    if let Some(v) = batch.iter().find_map(|p| p.get("Sensor Value 1.Value")) {
        println!("Sensor Value 1.Value (by name, first in the batch) = {v}");
    }
    for p in batch.iter().filter(|p| !p.values.is_empty()) {
        let text: Vec<String> = p.values.iter().map(|(a, v)| format!("{a} = {v}")).collect();
        println!(
            "{}  node {} TPDO{} (batch): {}",
            p.at,
            p.node,
            p.number,
            text.join(", ")
        );
    }
    assert_eq!(
        batch.iter().filter(|p| !p.values.is_empty()).count(),
        received
    );
    Ok(received)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run()?;
    Ok(())
}

#[cfg(test)]
#[test]
fn runs() {
    assert!(run().unwrap() > 0, "decoded TPDOs arrive");
}
