//! PDOs of up to 64 bytes (CANopen FD) between the master and a simulated device marked
//! CANopen FD on the in-memory bus configured for CAN FD: a 64-byte TPDO of sixteen UNSIGNED32
//! decoded by name (events, callback, batch subscriber), a 40-byte RPDO set by name and seen in
//! the device's values, both checked on the wire as CAN FD frames; the device's event timer
//! sending the 64-byte TPDO again while its data stays the same; on a classic bus a 40-byte
//! RPDO is refused with a clear error; a TPDO of more than 8 bytes configured through `save()`
//! and `remap_pdo`, and refused in bits and bytes where the node or the bus cannot carry it.

use std::sync::{Arc, Mutex};

use canola::frame::{CanId, FdFrame};
use canola::{
    BusConfig, BusEvent, Duration, MemoryBus, Network, NetworkEvent, NodeId, SimDevice,
    Transmission, Value,
};

fn id(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// An EDS marked CANopen FD: "Inputs" (0x2000, sixteen UNSIGNED32, read-only) mapped into
/// TPDO1 (64 bytes, event-driven), "Outputs" (0x2100, ten UNSIGNED32, read-write) mapped into
/// RPDO1 (40 bytes).
fn eds(fd: bool) -> String {
    let mut s = String::from(
        "[FileInfo]\nFileName=fdpdo.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=fd pdo device\nVendorNumber=0x39\nProductNumber=4\n",
    );
    if fd {
        s.push_str("CANopenFD=1\n");
    }
    s.push_str(
        "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=5\n1=0x1017\n2=0x1400\n3=0x1600\n4=0x1800\n5=0x1A00\n\
[1017]\nParameterName=Producer heartbeat time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n",
    );
    let sub = |s: &mut String, idx: u16, sub: u8, name: &str, ty: u16, acc: &str, def: &str| {
        s.push_str(&format!(
            "[{idx:04X}sub{sub:X}]\nParameterName={name}\nObjectType=0x7\nDataType=0x{ty:04X}\n\
AccessType={acc}\nDefaultValue={def}\nPDOMapping={}\n",
            u8::from(idx >= 0x2000 && sub > 0)
        ));
    };
    for (idx, name, cob, tt) in [
        (
            0x1400u16,
            "RPDO1 communication parameter",
            "$NODEID+0x200",
            254,
        ),
        (
            0x1800,
            "TPDO1 communication parameter",
            "$NODEID+0x180",
            254,
        ),
    ] {
        // TPDO1 has an event timer (sub-index 5, ms, 0 = off).
        let timer = idx == 0x1800;
        s.push_str(&format!(
            "[{idx:04X}]\nParameterName={name}\nObjectType=0x9\nSubNumber={}\n",
            if timer { 4 } else { 3 }
        ));
        let highest = if timer { "5" } else { "2" };
        sub(&mut s, idx, 0, "Highest sub-index", 5, "ro", highest);
        if timer {
            sub(&mut s, idx, 5, "Event timer", 6, "rw", "0");
        }
        sub(&mut s, idx, 1, "COB-ID", 7, "rw", cob);
        sub(
            &mut s,
            idx,
            2,
            "Transmission type",
            5,
            "rw",
            &tt.to_string(),
        );
    }
    for (idx, name, target, count) in [
        (0x1600u16, "RPDO1 mapping parameter", 0x2100u16, 10u8),
        (0x1A00, "TPDO1 mapping parameter", 0x2000, 16),
    ] {
        s.push_str(&format!(
            "[{idx:04X}]\nParameterName={name}\nObjectType=0x9\nSubNumber={}\n",
            count + 1
        ));
        sub(
            &mut s,
            idx,
            0,
            "Number of entries",
            5,
            "rw",
            &count.to_string(),
        );
        for i in 1..=count {
            let entry = format!("0x{target:04X}{i:02X}20");
            sub(&mut s, idx, i, &format!("Entry {i}"), 7, "rw", &entry);
        }
    }
    s.push_str("[ManufacturerObjects]\nSupportedObjects=2\n1=0x2000\n2=0x2100\n");
    for (idx, name, item, count, acc) in [
        (0x2000u16, "Inputs", "Input", 16u8, "ro"),
        (0x2100, "Outputs", "Output", 10, "rw"),
    ] {
        s.push_str(&format!(
            "[{idx:04X}]\nParameterName={name}\nObjectType=0x8\nSubNumber={}\n",
            count + 1
        ));
        sub(
            &mut s,
            idx,
            0,
            "Number of entries",
            5,
            "ro",
            &count.to_string(),
        );
        for i in 1..=count {
            sub(&mut s, idx, i, &format!("{item} {i}"), 7, acc, "0");
        }
    }
    s
}

/// What the callback kept of a PDO: its number, "Inputs.Input 16" by name, the value count.
type Seen = (u8, Option<Value>, usize);

fn fd_bus() -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        fd: true,
        ..BusConfig::default()
    })
}

/// The CAN FD frames the tap saw on `can_id` since the last call.
fn fd_frames(tap: &mut canola::Endpoint, can_id: u16) -> Vec<FdFrame> {
    use canola::Transport as _;
    let want = CanId::standard(can_id).unwrap();
    let mut out = Vec::new();
    while let Ok(Some(r)) = tap.try_recv() {
        if let canola::Received::Event(BusEvent::FdFrame { frame, .. }) = r
            && frame.id() == want
        {
            out.push(*frame);
        }
    }
    out
}

#[test]
fn a_64_byte_tpdo_of_sixteen_unsigned32_is_decoded_by_name() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    let device = bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let od = canola::od::parse(text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);

    let seen: Arc<Mutex<Vec<Seen>>> = Arc::default();
    let sink = seen.clone();
    net.on_pdo(move |p| {
        sink.lock()
            .unwrap()
            .push((p.number, p.get("Inputs.Input 16").cloned(), p.values.len()))
    });
    let mut batches = net.subscribe_pdos();
    let events = net.subscribe();
    node.nmt().start().unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    // Entering Operational sends the first (all-zero) TPDO1.
    seen.lock().unwrap().clear();
    let _ = batches.try_recv();
    let _ = events.try_iter().count();

    bus.with_station(device, |d: &mut SimDevice| {
        for i in 1..=16u8 {
            let v = 0x0101_0101u32 * u32::from(i);
            d.set_value(canola::Instant::ZERO, 0x2000, i, v.to_le_bytes().to_vec());
        }
    });
    net.run_for(Duration::from_millis(5)).wait().unwrap();

    let all: Vec<NetworkEvent> = events.try_iter().collect();
    let wire: Vec<&FdFrame> = all
        .iter()
        .filter_map(|e| match e {
            NetworkEvent::Bus(BusEvent::FdFrame { frame, .. })
                if frame.id() == CanId::standard(0x185).unwrap() =>
            {
                Some(&**frame)
            }
            _ => None,
        })
        .collect();
    let last = wire.last().expect("TPDO1 as a CAN FD frame");
    assert_eq!(last.data().len(), 64);
    assert_eq!(&last.data()[60..64], &0x1010_1010u32.to_le_bytes());

    let values: Vec<_> = all
        .iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues {
                node: n,
                number: 1,
                values,
                data,
                ..
            } if *n == id(5) => Some((values.clone(), data.len())),
            _ => None,
        })
        .collect();
    let (last_values, len) = values.last().expect("decoded TPDO1 values").clone();
    assert_eq!(len, 64);
    assert_eq!(last_values.len(), 16);
    for (i, (addr, v)) in last_values.iter().enumerate() {
        let sub = i as u8 + 1;
        assert_eq!((addr.index, addr.sub_index), (0x2000, sub));
        assert_eq!(*v, Value::Unsigned32(0x0101_0101 * u32::from(sub)));
    }

    let seen = seen.lock().unwrap().clone();
    let (number, by_name, count) = seen.last().expect("the callback saw TPDO1").clone();
    assert_eq!((number, count), (1, 16));
    assert_eq!(by_name, Some(Value::Unsigned32(0x1010_1010)));

    let batch = batches.try_recv().expect("a batch");
    let last = batch.iter().last().expect("TPDO1 in the batch");
    assert_eq!(last.number, 1);
    assert_eq!(last.data.len(), 64);
    assert_eq!(
        last.value((0x2000, 7)),
        Some(&Value::Unsigned32(0x0707_0707))
    );
}

#[test]
fn a_40_byte_rpdo_set_by_name_reaches_the_device() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    let device = bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let od = canola::od::parse(text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_change())
        .unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let mut tap = bus.endpoint();
    tx.set("Outputs.Output 1", 0xDEAD_BEEFu32).unwrap();
    tx.set_many([
        ("Outputs.Output 10", 7u32),
        ("Outputs.Output 4", 0x0102_0304u32),
    ])
    .unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    // Unchanged: no frame.
    tx.set("Outputs.Output 10", 7u32).unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();

    let sent = fd_frames(&mut tap, 0x205);
    assert_eq!(sent.len(), 2, "one frame per change");
    let data = sent[1].data();
    // 40 bytes travel in a 48-byte CAN FD frame, padded with zeros, its data phase switched
    // to the data bit rate.
    assert!(sent.iter().all(FdFrame::brs));
    assert_eq!(data.len(), 48);
    assert_eq!(&data[..4], &0xDEAD_BEEFu32.to_le_bytes());
    assert_eq!(&data[12..16], &0x0102_0304u32.to_le_bytes());
    assert_eq!(&data[36..40], &7u32.to_le_bytes());
    assert!(data[40..].iter().all(|&b| b == 0));

    let value = |sub: u8| {
        bus.with_station(device, |d: &mut SimDevice| {
            d.values().get(0x2100, sub).map(<[u8]>::to_vec)
        })
        .flatten()
    };
    assert_eq!(value(1), Some(0xDEAD_BEEFu32.to_le_bytes().to_vec()));
    assert_eq!(value(4), Some(0x0102_0304u32.to_le_bytes().to_vec()));
    assert_eq!(value(10), Some(7u32.to_le_bytes().to_vec()));
    assert_eq!(value(2), Some(0u32.to_le_bytes().to_vec()));

    // A trigger sends it again unchanged; after stop nothing goes out.
    tx.trigger().unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    assert_eq!(fd_frames(&mut tap, 0x205).len(), 1);
    tx.stop().unwrap();
    assert!(tx.set("Outputs.Output 1", 1u32).is_err());
    assert!(tx.set("Inputs.Input 1", 1u32).is_err());
}

#[test]
fn a_classic_bus_refuses_an_rpdo_of_more_than_8_bytes() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let od = canola::od::parse(text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    let rpdos = node.rpdo().read().wait().unwrap();
    let err = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_change())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("RPDO1") && err.contains("40 bytes") && err.contains("no CAN FD"),
        "{err}"
    );

    // On an FD bus, a node not marked CANopen FD is refused too, and so is SYNC timing.
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let classic_text = eds(false);
    bus.attach(SimDevice::from_eds(id(5), classic_text.as_bytes()).unwrap());
    let od = canola::od::parse(classic_text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    let rpdos = node.rpdo().read().wait().unwrap();
    let pdo = rpdos.get(1).unwrap();
    let err = node
        .rpdo()
        .start(pdo, Transmission::on_change())
        .unwrap_err()
        .to_string();
    assert!(err.contains("not marked CANopen FD"), "{err}");
    node.set_fd(true);
    assert!(
        node.rpdo()
            .start(pdo, Transmission::on_sync_after_change())
            .is_err()
    );
    assert!(node.rpdo().start(pdo, Transmission::on_change()).is_ok());
}

#[test]
fn a_64_byte_tpdo_read_by_sdo_is_decoded_without_a_dictionary() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    let device = bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let node = net.add_node(id(5));
    let tpdos = node.tpdo().read().wait().unwrap();
    assert_eq!(tpdos.get(1).unwrap().mapped.len(), 16);
    node.nmt().start().unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let events = net.subscribe();
    bus.with_station(device, |d: &mut SimDevice| {
        d.set_value(
            canola::Instant::ZERO,
            0x2000,
            16,
            77u32.to_le_bytes().to_vec(),
        );
    });
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let values: Vec<_> = events
        .try_iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues {
                number: 1, values, ..
            } => Some(values),
            _ => None,
        })
        .collect();
    assert_eq!(values.len(), 1);
    assert_eq!(values[0].len(), 16);
    assert_eq!(values[0][15].1, Value::Unsigned32(77));
    assert_eq!(values[0][0].1, Value::Unsigned32(0));
}

#[test]
fn the_event_timer_sends_an_unchanged_64_byte_tpdo_again() {
    // CiA 301 §7.5.2.35: an event-driven TPDO with an event timer is sent when the timer
    // elapses, and the timer restarts at every transmission (a change of data included).
    let bus = fd_bus();
    let mut tap = bus.endpoint();
    let net = Network::new(bus.endpoint());
    let device = bus.attach(SimDevice::from_eds(id(5), eds(true).as_bytes()).unwrap());
    let node = net.add_node(id(5));
    node.sdo().write((0x1800, 5), 50u16).wait().unwrap();
    node.nmt().start().unwrap();
    net.run_for(Duration::from_millis(2)).wait().unwrap();
    let first = fd_frames(&mut tap, 0x185);
    assert_eq!(first.len(), 1, "the TPDO on entering Operational");
    assert_eq!(first[0].data().len(), 64);

    // Nothing changes for 1 s: the timer sends it every 50 ms, the same data each time.
    net.run_for(Duration::from_millis(1000)).wait().unwrap();
    let timed = fd_frames(&mut tap, 0x185);
    assert!((19..=20).contains(&timed.len()), "{} frames", timed.len());
    assert!(timed.iter().all(|f| f.data() == first[0].data()));

    // A change 20 ms after a timed transmission goes out at once and restarts the timer:
    // nothing more until 50 ms after the change.
    net.run_for(Duration::from_millis(20)).wait().unwrap();
    let _ = fd_frames(&mut tap, 0x185);
    let now = net.now();
    bus.with_station(device, |d: &mut SimDevice| {
        d.set_value(now, 0x2000, 1, 9u32.to_le_bytes().to_vec());
    });
    net.run_for(Duration::from_millis(45)).wait().unwrap();
    let after = fd_frames(&mut tap, 0x185);
    assert_eq!(after.len(), 1, "only the change within 45 ms of it");
    assert_eq!(after[0].data()[..4], 9u32.to_le_bytes());
    net.run_for(Duration::from_millis(10)).wait().unwrap();
    assert_eq!(
        fd_frames(&mut tap, 0x185).len(),
        1,
        "the timer 50 ms after the change"
    );

    // Stopped: no more TPDOs.
    node.nmt().stop().unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let _ = fd_frames(&mut tap, 0x185);
    net.run_for(Duration::from_millis(200)).wait().unwrap();
    assert!(fd_frames(&mut tap, 0x185).is_empty());
}

/// The TPDO1 mapping node 5 holds (0x1A00), read by SDO.
fn tpdo1_entries(node: &canola::Node) -> Vec<u32> {
    let count = node.sdo().read((0x1A00, 0)).wait().unwrap()[0];
    (1..=count)
        .map(|sub| {
            let b = node.sdo().read((0x1A00, sub)).wait().unwrap();
            u32::from_le_bytes(b[..4].try_into().unwrap())
        })
        .collect()
}

/// The values of the TPDO1 events since `events` was made.
fn tpdo1_values(
    events: &std::sync::mpsc::Receiver<NetworkEvent>,
) -> Vec<Vec<(canola::od::ObjectAddress, Value)>> {
    events
        .try_iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues {
                number: 1, values, ..
            } => Some(values),
            _ => None,
        })
        .collect()
}

/// A PDO of more than 8 bytes configured through the API on a node marked CANopen FD on a CAN
/// FD bus: `save()` of three entries (96 bits) read back from the node and decoded from its CAN
/// FD frames, then `remap_pdo` of an `FdMapping` of twelve (48 bytes).
#[test]
fn a_pdo_of_more_than_8_bytes_is_saved_and_remapped_on_an_fd_node() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    let device = bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let od = canola::od::parse(text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);

    let mut set = node.tpdo().read().wait().unwrap();
    let pdo = set.get_mut(1).unwrap();
    pdo.clear();
    for name in ["Inputs.Input 3", "Inputs.Input 1", "Inputs.Input 2"] {
        pdo.map(name).unwrap();
    }
    node.tpdo().save(&mut set).wait().unwrap();
    assert_eq!(
        tpdo1_entries(&node),
        [0x2000_0320, 0x2000_0120, 0x2000_0220]
    );

    node.nmt().start().unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let events = net.subscribe();
    bus.with_station(device, |d: &mut SimDevice| {
        d.set_value(
            canola::Instant::ZERO,
            0x2000,
            3,
            33u32.to_le_bytes().to_vec(),
        );
    });
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let values = tpdo1_values(&events);
    let last = values.last().expect("TPDO1 decoded");
    assert_eq!(last.len(), 3);
    assert_eq!(last[0].1, Value::Unsigned32(33));

    // remap_pdo with twelve entries.
    let raw: Vec<u32> = (1..=12u32).map(|s| 0x2000_0020 | (s << 8)).collect();
    let mapping = canola::pdo::FdMapping::from_raw(&raw).unwrap();
    let comm = set.get(1).unwrap().comm;
    node.remap_pdo(canola::pdo::Direction::Transmit, 1, comm, mapping)
        .wait()
        .unwrap();
    assert_eq!(tpdo1_entries(&node), raw);
    let events = net.subscribe();
    bus.with_station(device, |d: &mut SimDevice| {
        d.set_value(
            canola::Instant::ZERO,
            0x2000,
            12,
            12u32.to_le_bytes().to_vec(),
        );
    });
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let values = tpdo1_values(&events);
    let last = values.last().expect("TPDO1 decoded after the remap");
    assert_eq!(last.len(), 12);
    assert_eq!(last[11].1, Value::Unsigned32(12));
    assert_eq!(last[2].1, Value::Unsigned32(33));
}

/// Where a PDO of more than 8 bytes cannot be (a node not marked CANopen FD, a classic bus)
/// `save()` and `remap_pdo` say so in bits and bytes, and why, before anything is written.
#[test]
fn a_pdo_of_more_than_8_bytes_is_refused_in_bits_and_bytes_where_it_cannot_be() {
    for (fd_bus_, fd_node, why) in [
        (true, false, "node 5 is not marked CANopen FD"),
        (false, true, "carries no CAN FD"),
    ] {
        let bus = if fd_bus_ { fd_bus() } else { MemoryBus::new() };
        let net = Network::new(bus.endpoint());
        let text = eds(true);
        bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
        let od = canola::od::parse(text.as_bytes()).unwrap().od;
        let node = net.add_node_with_dictionary(id(5), od);
        node.set_fd(fd_node);
        let before = tpdo1_entries(&node);
        let mut set = node.tpdo().read().wait().unwrap();
        let pdo = set.get_mut(1).unwrap();
        pdo.clear();
        for name in ["Inputs.Input 1", "Inputs.Input 2", "Inputs.Input 3"] {
            pdo.map(name).unwrap();
        }
        let err = node.tpdo().save(&mut set).wait().unwrap_err().to_string();
        for part in ["TPDO1", "96 bits (12 bytes)", "64 bits (8 bytes)", why] {
            assert!(err.contains(part), "{part}: {err}");
        }
        let raw = [0x2000_0120, 0x2000_0220, 0x2000_0320];
        let mapping = canola::pdo::FdMapping::from_raw(&raw).unwrap();
        let comm = set.get(1).unwrap().comm;
        let err = node
            .remap_pdo(canola::pdo::Direction::Transmit, 1, comm, mapping)
            .wait()
            .unwrap_err()
            .to_string();
        for part in ["TPDO1", "96 bits (12 bytes)", why] {
            assert!(err.contains(part), "{part}: {err}");
        }
        assert_eq!(tpdo1_entries(&node), before, "nothing was written");
    }
}

/// A program tells the problems of a too-long mapping apart by their variants, with the bits
/// as a number: checked as a classic mapping it is too long; saved on a node not marked
/// CANopen FD it is refused for want of CAN FD.
#[test]
fn a_too_long_mapping_is_a_typed_problem_with_its_bits() {
    use canola::Error;
    use canola::error::{FdRefusal, PdoProblem, ValueProblem};
    use canola::pdo::{Direction, MappingError};

    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let text = eds(true);
    bus.attach(SimDevice::from_eds(id(5), text.as_bytes()).unwrap());
    let od = canola::od::parse(text.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    node.set_fd(false);
    let mut set = node.tpdo().read().wait().unwrap();
    let pdo = set.get_mut(1).unwrap();
    pdo.clear();
    for name in ["Inputs.Input 1", "Inputs.Input 2", "Inputs.Input 3"] {
        pdo.map(name).unwrap();
    }
    let e = pdo.mapping().unwrap_err();
    let Error::Value {
        node: at,
        problem:
            ValueProblem::Pdo {
                direction,
                number,
                problem: PdoProblem::Mapping(MappingError::TooLong(bits)),
            },
        ..
    } = &e
    else {
        panic!("expected a too-long mapping, got {e}");
    };
    assert_eq!(
        (*at, *direction, *number, *bits),
        (id(5), Direction::Transmit, 1, 96)
    );

    let e = node.tpdo().save(&mut set).wait().unwrap_err();
    assert!(
        matches!(
            &e,
            Error::Value {
                problem: ValueProblem::Pdo {
                    problem: PdoProblem::NeedsFd {
                        bits: 96,
                        refusal: FdRefusal::NodeNotFd,
                        ..
                    },
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
}
