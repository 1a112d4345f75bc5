//! The generated PDO structs and node client, compiled and run: the checked-in output of the
//! facade preset for `tests/data/pdo-device.eds` (kept current by the golden test) against a
//! simulated device on the in-memory bus. The device transmits its TPDOs, which the structs
//! decode from raw frames, from the master's PDO events and from its decoded values; the master
//! sends an RPDO built by a struct, and the client reads what the device took from it.

use canola::transport::Transport;
use canola::{Duration, MemoryBus, Network, NetworkEvent, NodeId, SimDevice};

// The workspace warns on `pub` items a crate does not export; a test crate exports none.
#[allow(unreachable_pub)]
mod device {
    include!("golden/pdo-device.rs");
}
use device::client::Device;
use device::{Rpdo1, Tpdo1, Tpdo2};

const EDS: &[u8] = include_bytes!("data/pdo-device.eds");

fn node() -> NodeId {
    NodeId::new(0x2A).unwrap()
}

#[test]
fn tpdos_from_the_simulator_decode_into_the_structs() {
    let bus = MemoryBus::new();
    let mut raw = bus.endpoint();
    let net = Network::new(bus.endpoint());
    net.add_node_with_dictionary(node(), canola::od::parse(EDS).unwrap().od);
    let device = bus.attach(SimDevice::from_eds(node(), EDS).unwrap());
    let events = net.subscribe();
    net.node(node()).nmt().start().unwrap();
    let now = bus.now();
    bus.with_station(device, |d| {
        d.set_value(now, 0x2000, 0, [1]);
        d.set_value(now, 0x2006, 0, [0]);
        d.set_value(now, 0x2001, 0, (-123_456i32).to_le_bytes()[..3].to_vec());
        d.set_value(now, 0x2002, 0, [0x5A]);
        d.set_value(now, 0x2003, 0, 21.75f32.to_le_bytes());
        d.set_value(now, 0x2005, 0, *b"OK");
    });
    net.run_for(Duration::from_millis(350)).wait().unwrap();

    let want1 = Tpdo1 {
        valve_open: true,
        alarm: false,
        pressure: -123_456,
        status_code: 0x5A,
    };
    let want2 = Tpdo2 {
        temperature: 21.75,
        tag: *b"OK",
    };
    // Raw frames, as any transport delivers them: picked by the default COB-ID with `$NODEID`
    // resolved, decoded in one call.
    let tpdo1_id = Tpdo1::cob_id(node()).unwrap().can_id().unwrap();
    let tpdo2_id = Tpdo2::cob_id(node()).unwrap().can_id().unwrap();
    assert_eq!(tpdo1_id.as_raw(), 0x180 + 0x2A);
    let (mut seen1, mut seen2) = (None, None);
    let mut last1 = canola::CanFrame::new(tpdo1_id, &[]).unwrap();
    while let Some(received) = raw.try_recv().unwrap() {
        let canola::Received::Frame { frame, .. } = received else {
            continue;
        };
        if frame.id() == tpdo1_id {
            seen1 = Some(Tpdo1::from_frame(&frame).unwrap());
            last1 = frame;
        } else if frame.id() == tpdo2_id {
            seen2 = Some(Tpdo2::from_frame(&frame).unwrap());
        }
    }
    assert_eq!(seen1, Some(want1));
    // The layout worked out by hand (CiA 301 §7.4.8: objects from bit 0 of byte 0 upward): bit 0
    // valve open = 1, bit 1 dummy, bit 2 alarm = 0, bits 3..27 pressure -123456 = 0xFE1DC0 in 24
    // bits, bits 27..35 dummy, bits 35..43 status 0x5A: the word 0x02D0_07F0_EE01.
    assert_eq!(last1.data(), [0x01, 0xEE, 0xF0, 0x07, 0xD0, 0x02]);
    assert_eq!(seen2, Some(want2));

    // The master's events: raw data and values decoded through the node's dictionary. The first
    // ones carry the values from before the device's application set them.
    let (mut from_data, mut from_pairs) = (Vec::new(), Vec::new());
    for ev in events.try_iter() {
        match ev {
            NetworkEvent::PdoValues {
                number: 1, data, ..
            } => from_data.push(Tpdo1::from_data(&data).unwrap()),
            NetworkEvent::PdoValues {
                number: 2, values, ..
            } => from_pairs.push(Tpdo2::from_pairs(&values).unwrap()),
            _ => {}
        }
    }
    assert_eq!(from_data.first(), Some(&Tpdo1::default()));
    assert_eq!(from_data.last(), Some(&want1));
    assert_eq!(from_pairs.last(), Some(&want2));
}

#[test]
fn an_rpdo_built_by_its_struct_reaches_the_device_and_the_client_reads_it_back() {
    let bus = MemoryBus::new();
    let mut raw = bus.endpoint();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(node(), EDS).unwrap());
    let dev = Device::new(net.node(node()));
    net.node(node()).nmt().start().unwrap();
    net.run_for(Duration::from_millis(10)).wait().unwrap();

    let rpdo = Rpdo1 {
        setpoint_1: -300,
        setpoint_2: 1200,
    };
    let frame = rpdo.to_frame(node()).unwrap();
    assert_eq!(frame.id().as_raw(), 0x200 + 0x2A);
    assert_eq!(frame.data(), [0xD4, 0xFE, 0xB0, 0x04]);
    raw.send(&frame).unwrap();
    net.run_for(Duration::from_millis(10)).wait().unwrap();

    assert_eq!(dev.setpoints().setpoint_1().read().wait().unwrap(), -300);
    assert_eq!(dev.setpoints().setpoint_2().read().wait().unwrap(), 1200);
}

#[test]
fn the_client_reads_and_writes_typed_objects() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(node(), EDS).unwrap());
    let dev = Device::new(net.node(node()));

    assert_eq!(dev.producer_heartbeat_time().read().wait().unwrap(), 0);
    dev.producer_heartbeat_time().write(200).wait().unwrap();
    assert_eq!(dev.producer_heartbeat_time().read().wait().unwrap(), 200);
    // A u16 object goes out as two bytes: the raw read shows the device holds exactly that.
    assert_eq!(
        net.node(node()).sdo().read((0x1017, 0)).wait().unwrap(),
        200u16.to_le_bytes()
    );
    assert_eq!(
        dev.identity_object().vendor_id().read().wait().unwrap(),
        0xFFF
    );
    assert_eq!(
        dev.identity_object().serial_number().read().wait().unwrap(),
        7
    );
    assert_eq!(
        dev.manufacturer_device_name().read().wait().unwrap(),
        "PDO test device"
    );
    // The TPDO1 event timer through the record's client.
    let timer = dev.tpdo1_communication_parameter().event_timer();
    assert_eq!(timer.read().wait().unwrap(), 100);
    timer.write(250).wait().unwrap();
    assert_eq!(timer.read().wait().unwrap(), 250);
    assert_eq!(
        timer.entry().address(),
        canola::ObjectAddress::new(0x1800, 5)
    );
    // A node that does not answer: the facade's SDO error, naming node and object.
    let absent = Device::new(net.node(NodeId::new(9).unwrap()));
    let err = absent.producer_heartbeat_time().read().wait().unwrap_err();
    assert!(matches!(err, canola::Error::Sdo(_)), "{err}");
}

#[test]
fn fixed_and_predefined_cob_ids_and_a_struct_of_dummies() {
    // TPDO5 maps one UNSIGNED16 dummy on the fixed COB-ID 0x40000485 (no `$NODEID`): a struct
    // without fields, two zero bytes on 0x485 whatever the node.
    assert_eq!(device::Tpdo5::DATA_LEN, 2);
    let frame = device::Tpdo5 {}.to_frame(node()).unwrap();
    assert_eq!((frame.id().as_raw(), frame.data()), (0x485, &[0u8, 0][..]));
    assert_eq!(
        device::Tpdo5::from_data(&[0xFF, 0xFF]),
        Ok(device::Tpdo5 {})
    );
    // RPDO2 has no communication parameter in the file: the predefined connection set's.
    assert_eq!(
        device::Rpdo2::cob_id(node())
            .unwrap()
            .can_id()
            .unwrap()
            .as_raw(),
        0x300 + 0x2A
    );
}
