//! PDOs from the master: read a node's PDO configuration, change and save it, and transmit its
//! RPDOs. The master moves the device's TPDO1 to COB-ID 0x1F0 (decoded from there at once),
//! then sends RPDO1 (two REAL32 control values) on change with a 10 ms inhibit time and RPDO2
//! every 50 ms; the device's objects, read back by SDO, show what arrived.
//!
//! `cargo run -p canola --example pdo_transmit`.

use canola::pdo::TransmissionType;
use canola::{CanId, Duration, MemoryBus, Network, NetworkEvent, NodeId, SimDevice, Transmission};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

fn run() -> Result<(f32, usize), Box<dyn std::error::Error>> {
    let bus = MemoryBus::new(); // virtual clock: `run_for` advances it
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5)?;
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS)?.od);
    bus.attach(SimDevice::from_eds(id, EDS)?);
    let events = net.subscribe();

    // TPDO1: as python-canopen's node.tpdo.read() / save().
    let mut tpdos = node.tpdo().read().wait()?;
    for p in tpdos.iter() {
        let mapped: Vec<_> = p.mapped.iter().filter_map(|m| m.name.clone()).collect();
        println!(
            "TPDO{} on {:#x}, type {}: {}",
            p.number(),
            p.comm.cob_id.0,
            p.transmission_type().code(),
            mapped.join(", ")
        );
    }
    if let Some(t1) = tpdos.get_mut(1) {
        t1.set_can_id(CanId::standard(0x1F0)?);
        t1.set_transmission_type(TransmissionType::EventProfile);
        t1.set_inhibit_time(Duration::ZERO)?;
        t1.set_event_timer(Duration::from_millis(100))?;
        t1.clear();
        t1.map("Sensor Value 1.Value")?;
    }
    node.tpdo().save(&mut tpdos).wait()?;

    // RPDOs: the master produces them.
    let rpdos = node.rpdo().read().wait()?;
    let (Some(r1), Some(r2)) = (rpdos.get(1), rpdos.get(2)) else {
        return Err("the device has no RPDO1/RPDO2".into());
    };
    let on_change = Transmission::on_change().with_inhibit_time(Duration::from_millis(10));
    let setpoints = node.rpdo().start(r1, on_change)?;
    let cyclic = node
        .rpdo()
        .start(r2, Transmission::cyclic(Duration::from_millis(50)))?;
    node.nmt().start()?;

    cyclic.set("Control Value 3.Value", 1.5f32)?;
    for step in 0..20u8 {
        // A new setpoint every 2 ms: the inhibit time lets one frame out per 10 ms.
        setpoints.set_many([
            ("Control Value 1.Value", f32::from(step) * 0.5),
            ("Control Value 2.Value", -1.0),
        ])?;
        net.run_for(Duration::from_millis(2)).wait()?;
    }
    net.run_for(Duration::from_millis(300)).wait()?;

    let got = node.sdo().get("Control Value 1.Value").wait()?;
    println!("device: Control Value 1 = {got}");
    let at_device = f32::from_le_bytes(
        node.sdo()
            .read((0x2540, 1))
            .wait()?
            .try_into()
            .map_err(|_| "REAL32 has four bytes")?,
    );
    let tpdo1 = events
        .try_iter()
        .filter(|e| matches!(e, NetworkEvent::PdoValues { number: 1, .. }))
        .count();
    println!("TPDO1 frames decoded from 0x1F0: {tpdo1}");
    Ok((at_device, tpdo1))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run()?;
    Ok(())
}

#[cfg(test)]
#[test]
fn runs() {
    let (value, tpdo1) = run().unwrap();
    assert_eq!(value, 9.5, "the last setpoint reached the device");
    assert!(tpdo1 >= 3, "TPDO1 decoded from its new COB-ID");
}
