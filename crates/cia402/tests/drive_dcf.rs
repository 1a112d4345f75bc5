//! PDO mappings of the cyclic modes taken from a DCF: DCFs derived from `eds/cia402-servo.eds`
//! (the EDS parsed, PDO parameter values changed, written out as a DCF for node 5 and parsed
//! back), the `Drive` streaming csp through the DCF's PDOs to the simulated drive on the
//! in-memory bus (also after `canola-manager`'s CiA 302 boot wrote that DCF), and DCFs whose
//! PDOs cannot serve the mode giving clear errors before anything is written.

use std::sync::{Arc, Mutex};

use canola::od::{EdsValue, FieldValue, ObjectDictionary, Value};
use canola::{MemoryBus, Network, Node, NodeId, Received, Transport as _};
use canola_cia402::master::{DcfPdoError, DcfPdos, Drive, DriveError, simulated_drive};
use canola_cia402::sim::SimDrive;
use canola_cia402::{ModeOfOperation, State};
use canola_frame::Duration;

const EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");
const NODE: u8 = 5;

fn set(od: &mut ObjectDictionary, index: u16, sub: u8, value: Value) {
    let s = od
        .sub_mut(index, sub)
        .unwrap_or_else(|| panic!("the EDS has 0x{index:04X}:{sub:02X}"));
    s.extras_mut().parameter_value = Some(FieldValue::from_value(EdsValue::plain(value)));
}

/// A mapping object's entries.
fn map(od: &mut ObjectDictionary, index: u16, entries: &[u32]) {
    set(od, index, 0, Value::Unsigned8(entries.len() as u8));
    for (k, e) in entries.iter().enumerate() {
        set(od, index, k as u8 + 1, Value::Unsigned32(*e));
    }
}

/// The DCF text for node 5: the EDS's values, then `edit`.
fn dcf(edit: impl FnOnce(&mut ObjectDictionary)) -> String {
    let mut od = canola::od::parse(EDS).unwrap().od;
    edit(&mut od);
    canola::od::write_dcf(&od, NODE, Some(1000))
}

/// The DCF of a csp set-up unlike both the EDS's defaults and `Drive::start_cyclic`'s own:
/// RPDO2 (controlword, target position) event-driven for pp, RPDO3 the target position then the
/// controlword on every SYNC, RPDO4 off; TPDO3 the position actual value then the statusword
/// on every SYNC, TPDO2 and TPDO4 off.
fn csp_dcf() -> String {
    dcf(|od| {
        set(od, 0x1401, 2, Value::Unsigned8(255));
        map(od, 0x1602, &[0x607A_0020, 0x6040_0010]);
        set(od, 0x1402, 2, Value::Unsigned8(1));
        set(od, 0x1403, 1, Value::Unsigned32(0x8000_0505));
        set(od, 0x1801, 1, Value::Unsigned32(0x8000_0285));
        map(od, 0x1A02, &[0x6064_0020, 0x6041_0010]);
        set(od, 0x1802, 2, Value::Unsigned8(1));
        set(od, 0x1803, 1, Value::Unsigned32(0x8000_0485));
    })
}

struct Rig {
    bus: MemoryBus,
    net: Network,
    node: Node,
    model: Arc<Mutex<SimDrive>>,
}

fn rig() -> Rig {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(NODE).unwrap();
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS).unwrap().od);
    let (device, model) = simulated_drive(id, EDS, SimDrive::default()).unwrap();
    bus.attach(device);
    node.nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    node.nmt().start().unwrap();
    Rig {
        bus,
        net,
        node,
        model,
    }
}

fn read_u32(node: &Node, index: u16, sub: u8) -> u32 {
    let b = node.sdo().read((index, sub)).wait().unwrap();
    let mut a = [0u8; 4];
    a[..b.len().min(4)].copy_from_slice(&b[..b.len().min(4)]);
    u32::from_le_bytes(a)
}

/// The frames a tap saw: (COB-ID, data).
fn frames(tap: &mut canola::Endpoint) -> Vec<(u16, Vec<u8>)> {
    let mut out = Vec::new();
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        if let Some(id) = frame.cob_id() {
            out.push((id, frame.data().to_vec()));
        }
    }
    out
}

#[test]
fn the_dcf_gives_csp_its_rpdo_and_tpdos() {
    let pdos = DcfPdos::parse(csp_dcf().as_bytes(), NodeId::new(NODE).unwrap()).unwrap();
    let m = pdos
        .for_mode(ModeOfOperation::CyclicSyncPosition, 0)
        .unwrap();
    // RPDO2 maps the target too, but is event-driven: RPDO3 is the synchronous one.
    assert_eq!(m.rpdo.number, 3);
    assert_eq!(m.rpdo.entries, [0x607A_0020, 0x6040_0010]);
    assert_eq!(m.rpdo.comm.cob_id.0, 0x405);
    assert_eq!(m.target, (0x607A, 0));
    assert_eq!(
        m.tpdos.iter().map(|t| t.number).collect::<Vec<_>>(),
        [3],
        "TPDO2 is off in the DCF"
    );
    assert_eq!(m.tpdos[0].comm.cob_id.0, 0x385);
    // csv: the EDS's RPDO3 carried 0x60FF; this DCF maps it nowhere.
    let e = pdos
        .for_mode(ModeOfOperation::CyclicSyncVelocity, 0)
        .unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, DcfPdoError::Missing { index: 0x60FF, .. }),
        "{text}"
    );
    // Profile position is not a cyclic mode.
    assert!(matches!(
        pdos.for_mode(ModeOfOperation::ProfilePosition, 0),
        Err(DcfPdoError::NotCyclic(_))
    ));
}

#[test]
fn a_csp_stream_runs_on_the_dcf_mapping() {
    let r = rig();
    let pdos = DcfPdos::parse(csp_dcf().as_bytes(), r.node.id()).unwrap();
    let drive = Drive::new(r.node.clone());
    drive.follow_tpdos(Duration::from_millis(20));
    drive.enable().wait().unwrap();
    r.net.start_sync(Duration::from_millis(1));
    let stream = drive
        .start_cyclic_from_dcf(
            ModeOfOperation::CyclicSyncPosition,
            &pdos,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    assert_eq!(stream.rpdo(), 3);
    assert_eq!(
        drive.mode().wait().unwrap(),
        ModeOfOperation::CyclicSyncPosition
    );
    // The device holds the DCF's PDOs.
    assert_eq!(read_u32(&r.node, 0x1602, 0), 2);
    assert_eq!(read_u32(&r.node, 0x1602, 1), 0x607A_0020);
    assert_eq!(read_u32(&r.node, 0x1602, 2), 0x6040_0010);
    assert_eq!(read_u32(&r.node, 0x1402, 2), 1);
    assert_eq!(read_u32(&r.node, 0x1A02, 1), 0x6064_0020);
    assert_eq!(read_u32(&r.node, 0x1A02, 2), 0x6041_0010);
    // Only the PDOs csp runs on are written: TPDO2 (off in the DCF) is left as it was.
    assert_eq!(read_u32(&r.node, 0x1801, 1), 0x285);

    let mut tap = r.bus.endpoint();
    for i in 1..=300 {
        stream.set_target(i * 10).unwrap();
        r.net.run_for(Duration::from_millis(1)).wait().unwrap();
    }
    r.net.run_for(Duration::from_millis(300)).wait().unwrap();
    let seen = frames(&mut tap);
    // RPDO3 on 0x405 after every SYNC: the target (4 bytes) then the controlword 0x000F.
    let syncs = seen.iter().filter(|(id, _)| *id == 0x080).count();
    let rpdo3: Vec<&Vec<u8>> = seen
        .iter()
        .filter(|(id, _)| *id == 0x405)
        .map(|(_, d)| d)
        .collect();
    assert!(syncs >= 590, "{syncs}");
    assert!(rpdo3.len() + 2 >= syncs, "{} {syncs}", rpdo3.len());
    for d in &rpdo3 {
        assert_eq!(d.len(), 6);
        assert_eq!(&d[4..], &[0x0F, 0x00]);
    }
    let last = i32::from_le_bytes(rpdo3.last().unwrap()[..4].try_into().unwrap());
    assert_eq!(last, 3_000);
    assert!(
        !seen.iter().any(|(id, _)| *id == 0x505),
        "no RPDO4 of its own"
    );
    // TPDO3 on 0x385: the position then the statusword.
    let tpdo3: Vec<&Vec<u8>> = seen
        .iter()
        .filter(|(id, _)| *id == 0x385)
        .map(|(_, d)| d)
        .collect();
    assert!(tpdo3.len() + 2 >= syncs, "{} {syncs}", tpdo3.len());
    let p = i32::from_le_bytes(tpdo3.last().unwrap()[..4].try_into().unwrap());
    assert!((p - 3_000).abs() <= 20, "{p}");
    assert!((r.model.lock().unwrap().position() - 3_000.0).abs() <= 20.0);
    // The actual position comes from the DCF's TPDO3, not by SDO.
    let pos = drive.position().wait().unwrap();
    assert!((pos - 3_000).abs() <= 20, "{pos}");
    let uploads_of_6064 = frames(&mut tap)
        .iter()
        .filter(|(id, d)| *id == 0x605 && d.len() == 8 && d[0] == 0x40 && d[1..3] == [0x64, 0x60])
        .count();
    assert_eq!(uploads_of_6064, 0);

    // A state change by SDO is not undone by the next RPDO3, which carries the controlword.
    drive.disable().wait().unwrap();
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    assert_eq!(drive.state().wait().unwrap(), State::SwitchOnDisabled);
    let after: Vec<(u16, Vec<u8>)> = frames(&mut tap)
        .into_iter()
        .filter(|(id, _)| *id == 0x405)
        .collect();
    assert!(after.len() >= 40);
    // The RPDO carries the controlword the transition wrote (disable voltage: bit 1 clear).
    let cw = u16::from_le_bytes(after.last().unwrap().1[4..6].try_into().unwrap());
    assert_eq!(cw, read_u32(&r.node, 0x6040, 0) as u16);
    assert_eq!(cw & 0x0002, 0, "{cw:#06x}");
    drive.enable().wait().unwrap();
    r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    assert_eq!(drive.state().wait().unwrap(), State::OperationEnabled);
    stream.stop().unwrap();

    // Started again (as after a CiA 302 boot that wrote this DCF): the device holds the DCF's
    // PDOs already, so no PDO parameter is written again.
    let _ = frames(&mut tap);
    let again = drive
        .start_cyclic_from_dcf(
            ModeOfOperation::CyclicSyncPosition,
            &pdos,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    let pdo_writes = frames(&mut tap)
        .iter()
        .filter(|(id, d)| {
            let index = d.get(1..3).map(|b| u16::from_le_bytes([b[0], b[1]]));
            *id == 0x605
                && d.first().is_some_and(|b| b & 0xE0 == 0x20)
                && index.is_some_and(|i| (0x1400..=0x1BFF).contains(&i))
        })
        .count();
    assert_eq!(pdo_writes, 0);
    again.set_target(3_100).unwrap();
    r.net.run_for(Duration::from_millis(300)).wait().unwrap();
    assert!((r.model.lock().unwrap().position() - 3_100.0).abs() <= 20.0);
}

#[test]
fn a_dcf_without_the_target_in_a_synchronous_rpdo_is_refused_before_anything_is_written() {
    // The EDS's RPDO2 (controlword, 0x607A) made event-driven, RPDO3 and 4 off: no synchronous
    // RPDO carries the target position.
    let text = dcf(|od| {
        set(od, 0x1401, 2, Value::Unsigned8(255));
        set(od, 0x1402, 1, Value::Unsigned32(0x8000_0405));
        set(od, 0x1403, 1, Value::Unsigned32(0x8000_0505));
    });
    let r = rig();
    let pdos = DcfPdos::parse(text.as_bytes(), r.node.id()).unwrap();
    let drive = Drive::new(r.node.clone());
    drive.enable().wait().unwrap();
    let mut tap = r.bus.endpoint();
    let e = drive
        .start_cyclic_from_dcf(
            ModeOfOperation::CyclicSyncPosition,
            &pdos,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            DriveError::Dcf(DcfPdoError::Missing {
                index: 0x607A,
                sub_index: 0,
                ..
            })
        ),
        "{msg}"
    );
    assert!(
        msg.starts_with(
            "csp needs the target position (0x607A:00) in a valid synchronous RPDO; the DCF maps it in none."
        ),
        "{msg}"
    );
    assert!(
        msg.contains("RPDO2 (COB-ID 0x305, type 255): 0x6040:00, 0x607A:00"),
        "{msg}"
    );
    assert!(msg.contains("RPDO3 (not valid)"), "{msg}");
    // Nothing went to the device: no SDO download at all.
    let downloads = frames(&mut tap)
        .iter()
        .filter(|(id, d)| *id == 0x605 && d.first().is_some_and(|b| b & 0xE0 == 0x20))
        .count();
    assert_eq!(downloads, 0);
    assert_eq!(drive.mode().wait().unwrap(), ModeOfOperation::NoMode);
}

#[test]
fn a_dcf_without_the_actual_value_in_a_tpdo_names_its_tpdos() {
    // csp's RPDO is there (the EDS's RPDO2 is synchronous), but no valid TPDO maps 0x6064.
    let text = dcf(|od| {
        set(od, 0x1801, 1, Value::Unsigned32(0x8000_0285));
    });
    let pdos = DcfPdos::parse(text.as_bytes(), NodeId::new(NODE).unwrap()).unwrap();
    let e = pdos
        .for_mode(ModeOfOperation::CyclicSyncPosition, 0)
        .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with(
            "csp needs the position actual value (0x6064:00) in a valid TPDO; the DCF maps it in none. Its TPDOs: TPDO1 (COB-ID 0x185, type 255): 0x6041:00, 0x6061:00; TPDO2 (not valid): 0x6041:00, 0x6064:00;"
        ),
        "{msg}"
    );
}

#[test]
fn a_dcf_mapping_an_object_the_device_lacks_is_a_pdo_error() {
    let text = dcf(|od| {
        map(od, 0x1601, &[0x6040_0010, 0x2FFF_0020]);
    });
    let e = DcfPdos::parse(text.as_bytes(), NodeId::new(NODE).unwrap()).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(
            &e,
            DcfPdoError::Pdo {
                direction: canola::pdo::Direction::Receive,
                number: 2,
                ..
            }
        ),
        "{msg}"
    );
    assert!(msg.contains("0x1601"), "{msg}");
    // Not a DCF at all.
    assert!(matches!(
        DcfPdos::parse(b"no sections here", NodeId::new(NODE).unwrap()),
        Err(DcfPdoError::Parse(_))
    ));
}

#[test]
fn axis_1_looks_for_its_objects_800h_higher() {
    let pdos = DcfPdos::parse(csp_dcf().as_bytes(), NodeId::new(NODE).unwrap()).unwrap();
    let e = pdos
        .for_mode(ModeOfOperation::CyclicSyncPosition, 1)
        .unwrap_err();
    assert!(
        matches!(e, DcfPdoError::Missing { index: 0x687A, .. }),
        "{e}"
    );
}

#[test]
fn after_a_cia_302_boot_of_the_dcf_the_stream_writes_no_pdo_parameter() {
    // The DCF as a configuration tool writes it: `ParameterValue`s on the entries it configures
    // (the PDOs of `csp_dcf`), the EDS's defaults elsewhere.
    let mut od = canola::od::parse(EDS).unwrap().od;
    set(&mut od, 0x1401, 2, Value::Unsigned8(255));
    map(&mut od, 0x1602, &[0x607A_0020, 0x6040_0010]);
    set(&mut od, 0x1402, 2, Value::Unsigned8(1));
    set(&mut od, 0x1403, 1, Value::Unsigned32(0x8000_0505));
    set(&mut od, 0x1801, 1, Value::Unsigned32(0x8000_0285));
    map(&mut od, 0x1A02, &[0x6064_0020, 0x6041_0010]);
    set(&mut od, 0x1802, 2, Value::Unsigned8(1));
    set(&mut od, 0x1803, 1, Value::Unsigned32(0x8000_0485));
    let text = canola::od::write_eds(&od);
    let config = canola_manager::NetworkConfig::parse_with_files(
        "[[slave]]\nnode_id = 5\ndcf = \"drive5.dcf\"\nmandatory = true\n",
        std::path::Path::new("net.toml"),
        &|_| Ok(text.clone().into_bytes()),
    )
    .unwrap();

    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(NODE).unwrap();
    let (device, model) = simulated_drive(id, EDS, SimDrive::default()).unwrap();
    bus.attach(device);
    let report = canola_manager::boot(&net, &config);
    assert!(report.mandatory_ok, "{report:?}");
    assert_eq!(
        report.slaves[0].status,
        canola_manager::SlaveStatus::Operational
    );
    let node = net.node(id);
    assert_eq!(
        read_u32(&node, 0x1602, 1),
        0x607A_0020,
        "the boot wrote RPDO3"
    );

    let pdos = DcfPdos::parse(text.as_bytes(), id).unwrap();
    let drive = Drive::new(node);
    drive.enable().wait().unwrap();
    net.start_sync(Duration::from_millis(1));
    let mut tap = bus.endpoint();
    let stream = drive
        .start_cyclic_from_dcf(
            ModeOfOperation::CyclicSyncPosition,
            &pdos,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    for i in 1..=100 {
        stream.set_target(i * 10).unwrap();
        net.run_for(Duration::from_millis(1)).wait().unwrap();
    }
    net.run_for(Duration::from_millis(300)).wait().unwrap();
    let seen = frames(&mut tap);
    let pdo_writes = seen
        .iter()
        .filter(|(id, d)| {
            let index = d.get(1..3).map(|b| u16::from_le_bytes([b[0], b[1]]));
            *id == 0x605
                && d.first().is_some_and(|b| b & 0xE0 == 0x20)
                && index.is_some_and(|i| (0x1400..=0x1BFF).contains(&i))
        })
        .count();
    assert_eq!(pdo_writes, 0, "the boot configured them");
    assert!(seen.iter().any(|(id, d)| *id == 0x405 && d.len() == 6));
    assert!((model.lock().unwrap().position() - 1_000.0).abs() <= 20.0);
}
