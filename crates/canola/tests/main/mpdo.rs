//! Multiplexed PDOs (CiA 301 §7.2.3) between the master and a simulated device on the
//! in-memory bus: the device produces SAM-MPDOs from its object scanner list (TPDO1 mapping
//! count 0xFE) and consumes DAM-MPDOs (RPDO1 mapping count 0xFF); the master takes SAM-MPDOs
//! through its scanner list and DAM-MPDOs addressed to it, delivering them like PDOs (events,
//! callback, batch subscriber), and writes the device's objects with DAM-MPDOs. The frames on
//! the wire are checked byte by byte against the CiA 301 layout: byte 0 = address type (bit 7)
//! and node-ID, bytes 1..3 = index (little-endian) and sub-index, bytes 4..7 = data.

use std::sync::{Arc, Mutex};

use canola::frame::{CanFrame, CanId};
use canola::pdo::ScannerEntry;
use canola::{
    Duration, Endpoint, MemoryBus, Network, NetworkEvent, NodeId, SimDevice, Transport, Value,
};

fn id(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// TPDO1 a SAM-MPDO producer over the scanner list 0x1FA0 (three temperatures, the position),
/// RPDO1 a DAM-MPDO consumer; "Setpoint" (UNSIGNED16), "Mode" (UNSIGNED8) and "Label"
/// (UNSIGNED64, too long for an MPDO) writable.
const EDS: &str = "[FileInfo]\nFileName=mpdo.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=mpdo device\nVendorNumber=0x39\nProductNumber=5\n\
[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=6\n1=0x1017\n2=0x1400\n3=0x1600\n4=0x1800\n5=0x1A00\n6=0x1FA0\n\
[1017]\nParameterName=Producer heartbeat time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n\
[1400]\nParameterName=RPDO1 communication parameter\nObjectType=0x9\nSubNumber=3\n\
[1400sub0]\nParameterName=Highest sub-index\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\nPDOMapping=0\n\
[1400sub1]\nParameterName=COB-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x200\nPDOMapping=0\n\
[1400sub2]\nParameterName=Transmission type\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=254\nPDOMapping=0\n\
[1600]\nParameterName=RPDO1 mapping parameter\nObjectType=0x9\nSubNumber=1\n\
[1600sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=0xFF\nPDOMapping=0\n\
[1800]\nParameterName=TPDO1 communication parameter\nObjectType=0x9\nSubNumber=3\n\
[1800sub0]\nParameterName=Highest sub-index\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\nPDOMapping=0\n\
[1800sub1]\nParameterName=COB-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x180\nPDOMapping=0\n\
[1800sub2]\nParameterName=Transmission type\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=254\nPDOMapping=0\n\
[1A00]\nParameterName=TPDO1 mapping parameter\nObjectType=0x9\nSubNumber=1\n\
[1A00sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=0xFE\nPDOMapping=0\n\
[1FA0]\nParameterName=Object scanner list 1\nObjectType=0x8\nSubNumber=3\n\
[1FA0sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\nPDOMapping=0\n\
[1FA0sub1]\nParameterName=Entry 1\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x03200001\nPDOMapping=0\n\
[1FA0sub2]\nParameterName=Entry 2\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x01200100\nPDOMapping=0\n\
[ManufacturerObjects]\nSupportedObjects=5\n1=0x2000\n2=0x2001\n3=0x2100\n4=0x2101\n5=0x2102\n\
[2000]\nParameterName=Temperatures\nObjectType=0x8\nSubNumber=4\n\
[2000sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=3\nPDOMapping=0\n\
[2000sub1]\nParameterName=Temperature 1\nObjectType=0x7\nDataType=0x0006\nAccessType=ro\nDefaultValue=201\nPDOMapping=1\n\
[2000sub2]\nParameterName=Temperature 2\nObjectType=0x7\nDataType=0x0006\nAccessType=ro\nDefaultValue=202\nPDOMapping=1\n\
[2000sub3]\nParameterName=Temperature 3\nObjectType=0x7\nDataType=0x0006\nAccessType=ro\nDefaultValue=203\nPDOMapping=1\n\
[2001]\nParameterName=Position\nObjectType=0x7\nDataType=0x0004\nAccessType=ro\nDefaultValue=0\nPDOMapping=1\n\
[2100]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=1\n\
[2101]\nParameterName=Mode\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=0\nPDOMapping=1\n\
[2102]\nParameterName=Label\nObjectType=0x7\nDataType=0x001B\nAccessType=rw\nDefaultValue=0\nPDOMapping=1\n";

struct Rig {
    bus: MemoryBus,
    net: Network,
    device: canola::mem::StationId<SimDevice>,
    node: canola::Node,
    tap: Endpoint,
}

fn rig() -> Rig {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let tap = bus.endpoint();
    let device = bus.attach(SimDevice::from_eds(id(5), EDS.as_bytes()).unwrap());
    let node = net.add_node_with_dictionary(id(5), canola::od::parse(EDS.as_bytes()).unwrap().od);
    Rig {
        bus,
        net,
        device,
        node,
        tap,
    }
}

/// The data of the frames the tap saw on `can_id` since the last call.
fn on(tap: &mut Endpoint, can_id: u16) -> Vec<Vec<u8>> {
    let want = CanId::standard(can_id).unwrap();
    let mut out = Vec::new();
    while let Ok(Some(r)) = tap.try_recv() {
        if let canola::Received::Frame { frame, .. } = r
            && frame.id() == want
        {
            out.push(frame.data().to_vec());
        }
    }
    out
}

fn run(net: &Network) {
    net.run_for(Duration::from_millis(5)).wait().unwrap();
}

/// (number, address, value) of each MPDO value the events carried.
fn values(events: &std::sync::mpsc::Receiver<NetworkEvent>) -> Vec<(u8, (u16, u8), Value)> {
    events
        .try_iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues { number, values, .. } => Some((number, values)),
            _ => None,
        })
        .flat_map(|(n, vs)| {
            vs.into_iter()
                .map(move |(a, v)| (n, (a.index, a.sub_index), v))
        })
        .collect()
}

#[test]
fn sam_mpdos_are_taken_through_the_masters_scanner_list() {
    let mut r = rig();
    // The master takes temperatures 1 and 2 and the position, not temperature 3.
    r.node
        .mpdo()
        .receive(
            1,
            0x185,
            &[
                ScannerEntry::new(2, 0x2000, 1),
                ScannerEntry::new(1, 0x2001, 0),
            ],
        )
        .unwrap();
    let named: Arc<Mutex<Vec<Option<Value>>>> = Arc::default();
    let sink = named.clone();
    r.net.on_pdo(move |p| {
        sink.lock()
            .unwrap()
            .push(p.get("Temperatures.Temperature 2").cloned())
    });
    let mut batches = r.net.subscribe_pdos();
    let events = r.net.subscribe();
    r.node.nmt().start().unwrap();
    run(&r.net);

    // Entering Operational, the device sends each scanned object once, one per frame.
    assert_eq!(
        on(&mut r.tap, 0x185),
        [
            [0x05, 0x00, 0x20, 0x01, 201, 0, 0, 0],
            [0x05, 0x00, 0x20, 0x02, 202, 0, 0, 0],
            [0x05, 0x00, 0x20, 0x03, 203, 0, 0, 0],
            [0x05, 0x01, 0x20, 0x00, 0, 0, 0, 0],
        ]
    );
    assert_eq!(
        values(&events),
        [
            (1, (0x2000, 1), Value::Unsigned16(201)),
            (1, (0x2000, 2), Value::Unsigned16(202)),
            (1, (0x2001, 0), Value::Integer32(0)),
        ]
    );
    assert!(
        named
            .lock()
            .unwrap()
            .contains(&Some(Value::Unsigned16(202)))
    );
    let batch = batches.try_recv().unwrap();
    assert_eq!(batch.len(), 3);

    // Changes: one MPDO per changed object; temperature 3 is on the bus, not taken.
    r.bus.with_station(r.device, |d: &mut SimDevice| {
        d.set_value(
            canola::Instant::ZERO,
            0x2001,
            0,
            (-5i32).to_le_bytes().to_vec(),
        );
        d.set_value(
            canola::Instant::ZERO,
            0x2000,
            3,
            250u16.to_le_bytes().to_vec(),
        );
    });
    run(&r.net);
    assert_eq!(
        on(&mut r.tap, 0x185),
        [
            [0x05, 0x01, 0x20, 0x00, 0xFB, 0xFF, 0xFF, 0xFF],
            [0x05, 0x00, 0x20, 0x03, 250, 0, 0, 0],
        ]
    );
    assert_eq!(values(&events), [(1, (0x2001, 0), Value::Integer32(-5))]);

    // A SAM-MPDO naming another producer on this COB-ID is not taken.
    r.tap
        .send(
            &CanFrame::new(
                CanId::standard(0x185).unwrap(),
                &[0x06, 0x01, 0x20, 0, 1, 0, 0, 0],
            )
            .unwrap(),
        )
        .unwrap();
    run(&r.net);
    assert!(values(&events).is_empty());

    // Stopped: MPDOs on 0x185 are raw PDOs again.
    assert!(r.node.mpdo().stop_receiving(0x185));
    r.bus.with_station(r.device, |d: &mut SimDevice| {
        d.set_value(
            canola::Instant::ZERO,
            0x2001,
            0,
            7i32.to_le_bytes().to_vec(),
        );
    });
    run(&r.net);
    assert!(values(&events).is_empty());
}

#[test]
fn dam_mpdos_addressed_to_the_master_are_taken() {
    let mut r = rig();
    r.node.mpdo().receive(1, 0x185, &[]).unwrap();
    let events = r.net.subscribe();
    run(&r.net);
    let frame = |a: u8| {
        CanFrame::new(
            CanId::standard(0x185).unwrap(),
            &[a, 0x00, 0x21, 0x00, 0x34, 0x12, 0, 0],
        )
        .unwrap()
    };
    // To the master (its node-ID, 127 by default), to all, to another node.
    for a in [0x80 | 127, 0x80, 0x80 | 9] {
        r.tap.send(&frame(a)).unwrap();
    }
    run(&r.net);
    assert_eq!(
        values(&events),
        [
            (1, (0x2100, 0), Value::Unsigned32(0x1234)),
            (1, (0x2100, 0), Value::Unsigned32(0x1234)),
        ]
    );
}

#[test]
fn the_master_writes_objects_with_dam_mpdos() {
    let mut r = rig();
    let dam = r.node.mpdo().dam(0x205).unwrap();
    let value = |r: &Rig, index: u16| {
        r.bus
            .with_station(r.device, |d: &mut SimDevice| {
                d.values().get(index, 0).map(<[u8]>::to_vec)
            })
            .flatten()
    };
    // Pre-operational: MPDOs are PDOs, the device ignores them.
    dam.write("Setpoint", 1234u16).unwrap();
    run(&r.net);
    assert_eq!(value(&r, 0x2100), Some(vec![0, 0]));
    r.node.nmt().start().unwrap();
    run(&r.net);
    on(&mut r.tap, 0x205);

    dam.write("Setpoint", 1234u16).unwrap();
    dam.write((0x2101, 0), 7u8).unwrap();
    run(&r.net);
    assert_eq!(
        on(&mut r.tap, 0x205),
        [
            [0x85, 0x00, 0x21, 0x00, 0xD2, 0x04, 0, 0],
            [0x85, 0x01, 0x21, 0x00, 7, 0, 0, 0],
        ]
    );
    assert_eq!(value(&r, 0x2100), Some(1234u16.to_le_bytes().to_vec()));
    assert_eq!(value(&r, 0x2101), Some(vec![7]));

    // A DAM-MPDO for another node is not applied.
    r.tap
        .send(
            &CanFrame::new(
                CanId::standard(0x205).unwrap(),
                &[0x86, 0x00, 0x21, 0, 1, 0, 0, 0],
            )
            .unwrap(),
        )
        .unwrap();
    run(&r.net);
    assert_eq!(value(&r, 0x2100), Some(1234u16.to_le_bytes().to_vec()));

    // Checked locally: an object of more than 4 bytes, a value out of range, a restricted
    // COB-ID.
    assert!(dam.write("Label", 1u64).is_err());
    assert!(dam.write("Mode", 300u16).is_err());
    assert!(r.node.mpdo().dam(0x000).is_err());
    assert!(on(&mut r.tap, 0x205).is_empty());
}
