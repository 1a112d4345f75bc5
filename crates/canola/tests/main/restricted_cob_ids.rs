//! CAN identifiers CiA 301 restricts (0x000 NMT, 0x001..0x07F, the default SDO, heartbeat and
//! LSS identifiers, ...) never reach a COB-ID entry: the simulated device refuses one written
//! by SDO (abort 0x06090030), the master refuses to configure one, and a device built from an
//! EDS whose communication object has a value that does not parse is refused.

use canola::mem::MemoryBus;
use canola::{Error, Network, SimDevice};
use canola_frame::{CanId, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn rig() -> (MemoryBus, Network) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    net.add_node_with_dictionary(n(5), canola_od::parse(EDS).unwrap().od);
    (bus, net)
}

#[test]
fn the_simulated_device_refuses_a_restricted_cob_id_by_sdo() {
    let (_bus, net) = rig();
    let sdo = || net.node(n(5)).sdo();
    for (index, sub, value) in [
        (0x1800u16, 1u8, 0x0000_0000u32), // TPDO1 on the NMT identifier
        (0x1400, 1, 0x0000_0605),         // RPDO1 on node 5's SDO request identifier
        (0x1005, 0, 0x0000_0001),         // SYNC on 0x001
    ] {
        let e = sdo().write((index, sub), value).wait().unwrap_err();
        assert_eq!(
            e.server_abort().map(|a| a.get()),
            Some(0x0609_0030),
            "0x{index:04X}:{sub:02X} = 0x{value:08X}: {e}"
        );
    }
    // Still the EDS values.
    let cob = sdo().read((0x1800, 1)).wait().unwrap();
    assert_ne!(u32::from_le_bytes(cob.try_into().unwrap()) & 0x7FF, 0);
    // Switching a PDO off (bit 31) and an allowed identifier pass.
    sdo().write((0x1800, 1), 0x8000_0185u32).wait().unwrap();
    sdo().write((0x1800, 1), 0x0000_01F0u32).wait().unwrap();
}

#[test]
fn the_master_refuses_to_remap_a_pdo_onto_a_restricted_cob_id() {
    let (_bus, net) = rig();
    let node = net.node(n(5));
    let mut tpdos = node.tpdo().read().wait().unwrap();
    let before = node.sdo().read((0x1800, 1)).wait().unwrap();
    let t1 = tpdos.get_mut(1).unwrap();
    t1.set_can_id(CanId::standard(0x000).unwrap());
    let e = node.tpdo().save(&mut tpdos).wait().unwrap_err();
    match &e {
        Error::RestrictedCobId {
            node: id,
            entry,
            can_id,
        } => {
            assert_eq!(*id, n(5));
            assert_eq!((entry.index, entry.sub_index), (0x1800, 1));
            assert_eq!(*can_id, 0x000);
        }
        other => panic!("{other}"),
    }
    let text = e.to_string();
    assert!(
        text.contains("node 5") && text.contains("0x1800:01") && text.contains("0x000"),
        "{text}"
    );
    // Nothing was written: the PDO is as it was.
    assert_eq!(node.sdo().read((0x1800, 1)).wait().unwrap(), before);
}

/// An EDS whose TPDO1 COB-ID does not parse (`$NODEID+0xZZ`): kept as text it would put the
/// TPDO on 0x000.
fn broken_eds() -> Vec<u8> {
    let text = String::from_utf8_lossy(EDS).into_owned();
    let start = text.find("[1800sub1]").expect("the EDS has 0x1800:01");
    let default = start + text[start..].find("DefaultValue=").unwrap();
    let end = default + text[default..].find('\n').unwrap();
    let mut out = text[..default].to_string();
    out.push_str("DefaultValue=$NODEID+0xZZ");
    out.push_str(&text[end..]);
    out.into_bytes()
}

#[test]
fn from_eds_refuses_a_communication_object_value_that_does_not_parse() {
    let e = SimDevice::from_eds(n(5), &broken_eds()).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("$NODEID+0xZZ") || text.contains("0xZZ"),
        "{text}"
    );
    let e =
        SimDevice::from_eds_with(n(5), &broken_eds(), canola_od::ParseOptions::new()).unwrap_err();
    assert!(!e.to_string().is_empty());
}

#[test]
fn from_eds_with_hands_back_the_warnings() {
    // A warning the parser reports: a key in lower case.
    let text = String::from_utf8_lossy(EDS).replacen("ParameterName=", "parametername=", 1);
    let (dev, warnings) =
        SimDevice::from_eds_with(n(5), text.as_bytes(), canola_od::ParseOptions::new()).unwrap();
    assert_eq!(dev.node(), n(5));
    assert!(!warnings.is_empty());
    assert!(
        warnings
            .iter()
            .all(|d| d.severity == canola_od::Severity::Warning),
        "{warnings:?}"
    );
}

#[test]
fn the_master_does_not_transmit_an_rpdo_on_a_restricted_cob_id() {
    let (_bus, net) = rig();
    let node = net.node(n(5));
    let mut rpdos = node.rpdo().read().wait().unwrap();
    // As read from a device whose RPDO1 COB-ID is the NMT identifier.
    rpdos
        .get_mut(1)
        .unwrap()
        .set_can_id(CanId::standard(0x000).unwrap());
    let e = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), canola::Transmission::on_change())
        .unwrap_err();
    assert!(
        matches!(e, Error::RestrictedCobId { can_id: 0, entry, .. } if entry.index == 0x1400),
        "{e}"
    );
}

/// A device built from a dictionary whose TPDO1 COB-ID is 0x000 (parsed, but restricted: `eds
/// lint` flags it) never sends its TPDO on the NMT identifier.
#[test]
fn a_simulated_device_does_not_send_a_tpdo_on_a_restricted_cob_id() {
    use canola::transport::{Received, Transport};
    let text = String::from_utf8_lossy(EDS).into_owned();
    let start = text.find("[1800sub1]").unwrap();
    let text = format!(
        "{}{}",
        &text[..start],
        text[start..].replacen("DefaultValue=$NODEID+0x180", "DefaultValue=0x00000000", 1)
    );
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut tap = bus.endpoint();
    bus.attach(SimDevice::from_eds(n(5), text.as_bytes()).unwrap());
    net.run_for(canola::Duration::from_millis(10))
        .wait()
        .unwrap();
    net.node(n(5)).nmt().start().unwrap();
    net.run_for(canola::Duration::from_secs(3)).wait().unwrap();
    let until = tap.now() + canola::Duration::from_millis(1);
    let mut on_nmt = Vec::new();
    while let Ok(Some(r)) = tap.recv_until(until) {
        if let Received::Frame { frame, .. } = r
            && frame.cob_id() == Some(0x000)
        {
            on_nmt.push(frame.data().to_vec());
        }
    }
    // Only the master's NMT start command.
    assert_eq!(on_nmt, [vec![0x01, 0x05]]);
}
