//! A Bürkert device from an application: `BurkertNode` over `canola::Network`, against the
//! simulated device on the in-memory bus (no hardware; `cargo run -p canola-burkert --features
//! master --example burkert_valve`). With a real bus, `Network::open("can0")` replaces the two
//! bus lines and the device is the one on the wire.
//!
//! Reads the device's description and NE 107 status, names it, maps sensor value 1 into TPDO1
//! with the manual's defaults, starts the node and prints the readings its TPDO brings.

use canola::{Duration, MemoryBus, Network, NodeId};
use canola_burkert::master::generic_od;
use canola_burkert::{BurkertDevice, BurkertNode};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let readings = run()?;
    println!("{readings} sensor readings received");
    Ok(())
}

/// The walk-through; returns how many sensor readings arrived by TPDO.
fn run() -> Result<usize, Box<dyn std::error::Error>> {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(10)?;
    let valve = BurkertNode::new(net.add_node_with_dictionary(id, (**generic_od()).clone()));
    let dev = bus.attach(BurkertDevice::new(id));
    bus.with_station(dev, |d| d.pin_sensor(1, 4.25));
    valve
        .node()
        .nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()?;

    let (description, status) = valve.read_description_and_status()?;
    println!(
        "node {id}: {} (serial {}), NE 107 {}",
        description.device_name.as_deref().unwrap_or("?"),
        description.serial_number.unwrap_or_default(),
        valve.ne107()?
    );
    if let (Some(t), Some(v)) = (status.temperature, status.supply_voltage) {
        println!("temperature {t}, supply {v} V");
    }
    valve.set_location("line 3, tank 2")?;

    let tpdo = valve.map_sensor_values_to_tpdo(1, &[1], None)?;
    let events = net.subscribe();
    valve.node().nmt().start()?;
    net.run_for(Duration::from_secs(3)).wait()?;
    let mut count = 0;
    for event in events.try_iter() {
        if let Some(Ok(values)) = tpdo.from_event(&event) {
            for r in values {
                println!("sensor {}: {}", r.sensor, r.value);
                count += 1;
            }
        }
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    #[test]
    fn runs() {
        assert!(super::run().expect("the walk-through runs") > 0);
    }
}
