//! An application whose device code is generated from the device's EDS in `build.rs`
//! (`canola_codegen::Config::for_canola`), on the in-memory bus with a simulated Bürkert
//! device: typed SDO through the generated client, the device's TPDO1 decoded into its
//! generated struct in one call, and an RPDO built from its struct.
//!
//! `cargo run -p codegen-app`. `cargo test -p codegen-app` runs it as a test (CI does).

use canola::{Duration, MemoryBus, Network, NetworkEvent, NodeId, SimDevice};
use codegen_app::burkert::client::Device;
use codegen_app::burkert::{Rpdo1, Tpdo1};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

/// What the run saw: the last TPDO1 and the control value the device took from the RPDO.
struct Outcome {
    tpdo1: Tpdo1,
    control_value_1: f32,
    heartbeat: u16,
}

fn run() -> Result<Outcome, Box<dyn std::error::Error>> {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5)?;
    let device = bus.attach(SimDevice::from_eds(id, EDS)?);
    let dev = Device::new(net.node(id));

    // Typed SDO: one method per object; `write(200)` sends the two bytes of an UNSIGNED16, and
    // a read-only object has no `write` at all.
    let vendor = dev.identity_object().vendor_id().read().wait()?;
    dev.producer_heartbeat_time().write(200).wait()?;
    let heartbeat = dev.producer_heartbeat_time().read().wait()?;
    println!("node {id}: vendor {vendor:#010x}, heartbeat {heartbeat} ms");

    let events = net.subscribe();
    net.node(id).nmt().start()?; // TPDOs flow in Operational
    net.run_for(Duration::from_millis(100)).wait()?;
    // New sensor readings in the device; its TPDO1 maps the first two.
    let now = bus.now();
    bus.with_station(device, |d| {
        d.set_value(now, 0x2500, 1, 21.75f32.to_le_bytes());
        d.set_value(now, 0x2501, 1, 3.5f32.to_le_bytes());
    });
    net.run_for(Duration::from_millis(500)).wait()?;
    let mut tpdo1 = None;
    for ev in events.try_iter() {
        if let NetworkEvent::Pdo {
            number: 1,
            data,
            at,
            ..
        } = ev
        {
            let t = Tpdo1::from_data(&data)?;
            println!(
                "{at}  TPDO1: sensor 1 = {}, sensor 2 = {}",
                t.sensor_value_1_value, t.sensor_value_2_value
            );
            tpdo1 = Some(t);
        }
    }

    // A set-point to the device in its RPDO1, built from the struct on the default COB-ID.
    let rpdo1 = Rpdo1 {
        control_value_1_value: 42.5,
        control_value_2_value: -1.0,
    };
    net.send(rpdo1.to_frame(id)?)?;
    net.run_for(Duration::from_millis(10)).wait()?;
    let control_value_1 = dev.control_value_1().value().read().wait()?;
    println!("control value 1 on the device: {control_value_1}");

    Ok(Outcome {
        tpdo1: tpdo1.ok_or("no TPDO1 arrived")?,
        control_value_1,
        heartbeat,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let o = run()?;
    println!(
        "done: heartbeat {} ms, last TPDO1 {:?}, control value 1 = {}",
        o.heartbeat, o.tpdo1, o.control_value_1
    );
    Ok(())
}

#[cfg(test)]
#[test]
fn runs() {
    let o = run().unwrap();
    assert_eq!(o.heartbeat, 200);
    assert_eq!(
        o.tpdo1,
        Tpdo1 {
            sensor_value_1_value: 21.75,
            sensor_value_2_value: 3.5
        }
    );
    assert_eq!(o.control_value_1, 42.5);
}
