//! USDO (CANopen FD, CiA 1301) from the master against the simulated device's USDO server on
//! the in-memory bus configured for CAN FD: expedited and segmented transfers up to 4 KiB,
//! the 1-byte abort codes and their CiA 301 meaning, several transfers at once, the node's FD
//! mark from its EDS or from the application, and the clear errors on a classic bus or a node
//! without CAN FD. Each value written by USDO is read back by classic SDO (another protocol
//! path through the same device), and the frames on the wire are checked to be CAN FD.

use canola::frame::{CanId, FdFrame};
use canola::sdo::usdo::{UsdoAbortCode, UsdoErrorKind};
use canola::{
    AbortCode, BusConfig, BusEvent, MemoryBus, Network, NetworkEvent, NodeId, SdoErrorKind,
    SimDevice, Value,
};

/// A device marked CANopen FD in its `[DeviceInfo]`, with a DOMAIN, a string, a read-only
/// and a read-write object.
const FD_EDS: &str = "[FileInfo]\nFileName=fd.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=fd device\nVendorNumber=0x39\nProductNumber=3\nCANopenFD=1\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x20191\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x39\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=2\n1=0x1008\n2=0x1017\n\
[1008]\nParameterName=Manufacturer device name\nObjectType=0x7\nDataType=0x0009\nAccessType=const\nDefaultValue=FD test device\nPDOMapping=0\n\
[1017]\nParameterName=Producer heartbeat time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n\
[ManufacturerObjects]\nSupportedObjects=2\n1=0x2000\n2=0x2100\n\
[2000]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=100\nPDOMapping=0\n\
[2100]\nParameterName=Blob\nObjectType=0x7\nDataType=0x000F\nAccessType=rw\nPDOMapping=0\n";

fn id(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn fd_bus() -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        fd: true,
        ..BusConfig::default()
    })
}

/// An FD bus with the FD device as node 5, the master knowing its dictionary.
fn setup() -> (MemoryBus, Network, canola::Node) {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(id(5), FD_EDS.as_bytes()).unwrap());
    let od = canola::od::parse(FD_EDS.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    (bus, net, node)
}

fn sdo_error(e: &canola::Error) -> &canola::SdoError {
    match e {
        canola::Error::Sdo(s) => s,
        other => panic!("not an SDO error: {other}"),
    }
}

#[test]
fn the_eds_marks_the_node_and_the_device_as_canopen_fd() {
    let (_bus, net, node) = setup();
    assert!(node.is_fd());
    assert!(net.is_fd());
    // A node without the mark in its dictionary is not FD until the application says so.
    let other = net.add_node(id(6));
    assert!(!other.is_fd());
    other.set_fd(true);
    assert!(other.is_fd());
    node.set_fd(false);
    assert!(!node.is_fd());
}

#[test]
fn expedited_reads_and_writes_typed_by_the_dictionary() {
    let (_bus, net, node) = setup();
    let events = net.subscribe();
    assert_eq!(
        node.usdo().read_typed::<u32>((0x1000, 0)).wait().unwrap(),
        0x20191
    );
    assert_eq!(
        node.usdo().read_value((0x1008, 0)).wait().unwrap(),
        Value::VisibleString("FD test device".into())
    );
    node.usdo().write((0x2000, 0), 4321u16).wait().unwrap();
    assert_eq!(
        node.usdo().read_typed::<u16>((0x2000, 0)).wait().unwrap(),
        4321
    );
    // The same value through classic SDO: the write reached the device's dictionary.
    assert_eq!(
        node.sdo().read_typed::<u16>((0x2000, 0)).wait().unwrap(),
        4321
    );
    // The device's answers were CAN FD frames on 0x580 + 5 addressed to the master.
    let answers: Vec<FdFrame> = events
        .try_iter()
        .filter_map(|e| match e {
            NetworkEvent::Bus(BusEvent::FdFrame { frame, .. }) => Some(*frame),
            _ => None,
        })
        .collect();
    assert_eq!(answers.len(), 4, "{answers:?}");
    for f in &answers {
        assert_eq!(f.id(), CanId::standard(0x585).unwrap());
        assert_eq!(f.data()[0], net.usdo_node_id().get());
    }
}

#[test]
fn segmented_transfers_up_to_4_kib() {
    let (_bus, net, node) = setup();
    let events = net.subscribe();
    // Around the expedited limit (56) and the segment size (60), then 4 KiB.
    for len in [56usize, 57, 60, 61, 120, 121, 1000, 4096] {
        let data: Vec<u8> = (0..len).map(|i| (i * 7 + len) as u8).collect();
        node.usdo().write((0x2100, 0), &data[..]).wait().unwrap();
        assert_eq!(
            node.usdo().read((0x2100, 0)).wait().unwrap(),
            data,
            "{len} bytes"
        );
        assert_eq!(
            node.sdo().read((0x2100, 0)).wait().unwrap(),
            data,
            "{len} bytes by SDO"
        );
    }
    // 4096 bytes went as full 64-byte segments: at least 4096 / 60 of them each way.
    let full = events
        .try_iter()
        .filter(|e| matches!(e, NetworkEvent::Bus(BusEvent::FdFrame { frame, .. }) if frame.data().len() == 64))
        .count();
    assert!(full >= 4096 / 60, "{full} full frames");
}

#[test]
fn several_transfers_run_at_once() {
    let (_bus, _net, node) = setup();
    let a = node.usdo().submit_read((0x1000, 0));
    let b = node.usdo().submit_read((0x1008, 0));
    let c = node.usdo().submit_write((0x2100, 0), vec![9u8; 300]);
    let d = node.usdo().submit_read((0x2000, 0));
    c.wait().unwrap();
    assert_eq!(d.wait().unwrap(), 100u16.to_le_bytes());
    assert_eq!(b.wait().unwrap(), b"FD test device");
    assert_eq!(a.wait().unwrap(), 0x20191u32.to_le_bytes());
    assert_eq!(
        node.usdo().read((0x2100, 0)).wait().unwrap(),
        vec![9u8; 300]
    );
}

#[test]
fn server_aborts_map_to_cia301_codes() {
    let (_bus, _net, node) = setup();
    let cases: [(u16, u8, bool, u8, u32); 4] = [
        (0x3000, 0, false, 0x33, 0x0602_0000),
        (0x1018, 7, false, 0x34, 0x0609_0011),
        (0x1000, 0, true, 0x32, 0x0601_0002),
        (0x1008, 0, true, 0x32, 0x0601_0002),
    ];
    for (index, sub, write, usdo_code, cia301) in cases {
        let r = if write {
            node.usdo().write((index, sub), 1u32).wait()
        } else {
            node.usdo().read((index, sub)).wait().map(|_| ())
        };
        let e = r.unwrap_err();
        let s = sdo_error(&e);
        assert_eq!(
            s.kind,
            SdoErrorKind::Usdo(UsdoErrorKind::ServerAbort(UsdoAbortCode(usdo_code))),
            "{index:04X}:{sub}"
        );
        assert_eq!(s.usdo_abort_code(), Some(UsdoAbortCode(usdo_code)));
        assert_eq!(s.server_abort(), Some(AbortCode(cia301)), "{e}");
        assert!(e.to_string().contains("USDO abort"), "{e}");
    }
}

#[test]
fn a_node_without_can_fd_or_a_classic_bus_is_a_clear_error_and_nothing_is_sent() {
    // The node is not marked FD.
    let (bus, net, _node) = setup();
    let plain = net.add_node(id(6));
    let before = bus.stats().frames;
    let e = plain.usdo().read((0x1000, 0)).wait().unwrap_err();
    assert!(
        matches!(sdo_error(&e).kind, SdoErrorKind::FdNotSupported(_)),
        "{e}"
    );
    assert!(e.to_string().contains("not marked CANopen FD"), "{e}");
    assert_eq!(bus.stats().frames, before);

    // The bus is classic.
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(id(5), FD_EDS.as_bytes()).unwrap());
    net.run_for(std::time::Duration::from_millis(10))
        .wait()
        .unwrap();
    let node = net.node(id(5));
    node.set_fd(true);
    assert!(!net.is_fd());
    let before = bus.stats().frames;
    let e = node.usdo().write((0x2000, 0), 1u16).wait().unwrap_err();
    assert!(
        e.to_string()
            .contains("FD not supported on the in-memory bus"),
        "{e}"
    );
    assert_eq!(bus.stats().frames, before);
    let e = net
        .send_fd(FdFrame::new(CanId::standard(0x123).unwrap(), &[1; 12]).unwrap())
        .unwrap_err();
    assert!(e.to_string().contains("FD not supported on"), "{e}");
    // Classic SDO still works on it.
    assert_eq!(
        node.sdo().read_typed::<u16>((0x2000, 0)).wait().unwrap(),
        100
    );
}

#[test]
fn a_silent_server_times_out_with_the_usdo_abort() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    // A device that does not serve USDO, marked FD by the application.
    bus.attach(
        SimDevice::from_eds(id(5), FD_EDS.as_bytes())
            .unwrap()
            .with_fd(false),
    );
    let node = net.node(id(5));
    node.set_fd(true);
    let start = net.now();
    let e = node.usdo().read((0x1000, 0)).wait().unwrap_err();
    assert!(
        matches!(
            sdo_error(&e).kind,
            SdoErrorKind::Usdo(UsdoErrorKind::Timeout(_))
        ),
        "{e}"
    );
    let waited = net.now() - start;
    assert!(
        waited >= canola::Duration::from_millis(1000)
            && waited < canola::Duration::from_millis(1100),
        "{waited:?}"
    );
}

#[test]
fn raw_fd_frames_go_both_ways_on_the_network() {
    let bus = fd_bus();
    let net = Network::new(bus.endpoint());
    let mut peer = bus.endpoint();
    let events = net.subscribe();
    let f = FdFrame::new(CanId::standard(0x321).unwrap(), &[0xA5; 64])
        .unwrap()
        .with_brs(true);
    net.send_fd(f).unwrap();
    use canola::Transport as _;
    let got = peer
        .recv_timeout(canola::Duration::from_millis(10))
        .unwrap();
    assert!(
        matches!(&got, Some(canola::Received::Event(BusEvent::FdFrame { frame, .. })) if **frame == f),
        "{got:?}"
    );
    let back = FdFrame::new(CanId::standard(0x322).unwrap(), &[1, 2, 3]).unwrap();
    peer.send_fd(&back).unwrap();
    net.run_for(std::time::Duration::from_millis(1))
        .wait()
        .unwrap();
    assert!(events.try_iter().any(
        |e| matches!(e, NetworkEvent::Bus(BusEvent::FdFrame { frame, .. }) if *frame == back)
    ));
}

#[test]
fn a_dropped_request_is_aborted_on_the_bus_and_the_next_one_runs() {
    // 1 Mbit/s arbitration, 5 Mbit/s data: a 4 KiB transfer takes milliseconds of bus time.
    let bus = MemoryBus::with_config(BusConfig {
        fd: true,
        bitrate: Some(1_000_000),
        data_bitrate: Some(5_000_000),
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(id(5), FD_EDS.as_bytes()).unwrap());
    let node =
        net.add_node_with_dictionary(id(5), canola::od::parse(FD_EDS.as_bytes()).unwrap().od);
    node.usdo()
        .write((0x2100, 0), vec![3u8; 4096])
        .wait()
        .unwrap();
    let mut tap = bus.endpoint();
    let pending = node.usdo().submit_read((0x2100, 0));
    net.run_for(std::time::Duration::from_millis(2))
        .wait()
        .unwrap();
    assert!(!pending.is_done());
    drop(pending);
    net.run_for(std::time::Duration::from_millis(2))
        .wait()
        .unwrap();
    use canola::Transport as _;
    let mut aborts = Vec::new();
    while let Ok(Some(r)) = tap.try_recv() {
        if let canola::Received::Event(BusEvent::FdFrame { frame, .. }) = r
            && frame.id() == CanId::standard(0x67F).unwrap()
            && frame.data()[1] == 0x7F
        {
            aborts.push(*frame);
        }
    }
    // One abort from the master (0x600 + 127) to node 5.
    assert_eq!(aborts.len(), 1, "{aborts:?}");
    assert_eq!(aborts[0].data()[0], 5);
    assert_eq!(
        node.usdo().read((0x2100, 0)).wait().unwrap(),
        vec![3u8; 4096]
    );
}

/// `Network::open_fd` on the UDP bus (which carries CAN FD): the network sends FD frames, and
/// a USDO request reaches a simulated FD device on another attachment of the same bus.
#[cfg(all(feature = "socketcan", target_os = "linux"))]
#[test]
fn a_network_opened_for_fd_on_the_udp_bus() {
    let port = 20000 + (std::process::id() % 20000) as u16;
    let spec = format!("udp:239.74.163.43:{port}");
    let group = std::net::SocketAddrV4::new(std::net::Ipv4Addr::new(239, 74, 163, 43), port);
    let mut device_side = canola::udp::UdpMulticast::open(group).unwrap();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stopped = stop.clone();
    let device = std::thread::spawn(move || {
        let mut dev = SimDevice::from_eds(id(5), FD_EDS.as_bytes()).unwrap();
        canola::run_station(&mut device_side, &mut dev, || {
            stopped.load(std::sync::atomic::Ordering::Relaxed)
        })
    });
    let net = Network::open_fd(&spec).unwrap();
    assert!(net.is_fd());
    let od = canola::od::parse(FD_EDS.as_bytes()).unwrap().od;
    let node = net.add_node_with_dictionary(id(5), od);
    let mut name = None;
    for _ in 0..20 {
        if let Ok(v) = node.usdo().read_value((0x1008, 0)).wait() {
            name = Some(v);
            break;
        }
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    device.join().unwrap().unwrap();
    assert_eq!(name, Some(Value::VisibleString("FD test device".into())));
}
