//! Store parameters (0x1010) and restore default parameters (0x1011), CiA 301 §7.5.2.13/14:
//! the `save` and `load` signatures, sub-index 1 for all parameters, against the simulated
//! device, which keeps what was stored over an NMT reset node.

use std::time::Duration;

use canola::{AbortCode, MemoryBus, Network, NodeId, ParameterGroup, SimDevice};

/// A device with 0x1010/0x1011 (all parameters, communication, application, manufacturer)
/// and a manufacturer-specific parameter.
const STORING_EDS: &str = "[FileInfo]\nFileName=storing.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=storing\nVendorNumber=0x39\nProductNumber=2\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x39\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=3\n1=0x1010\n2=0x1011\n3=0x1017\n\
[1010]\nParameterName=Store parameters\nObjectType=0x8\nSubNumber=5\n\
[1010sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=4\nPDOMapping=0\n\
[1010sub1]\nParameterName=Save all parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1010sub2]\nParameterName=Save communication parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1010sub3]\nParameterName=Save application parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1010sub4]\nParameterName=Save manufacturer parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1011]\nParameterName=Restore default parameters\nObjectType=0x8\nSubNumber=5\n\
[1011sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=4\nPDOMapping=0\n\
[1011sub1]\nParameterName=Restore all default parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1011sub2]\nParameterName=Restore communication default parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1011sub3]\nParameterName=Restore application default parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1011sub4]\nParameterName=Restore manufacturer default parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1017]\nParameterName=Producer heartbeat time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n\
[2000]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=100\nPDOMapping=0\n";

fn setup(eds: &[u8]) -> (MemoryBus, Network, canola::Node) {
    let id = NodeId::new(5).unwrap();
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(id, eds).unwrap());
    let node = net.node(id);
    (bus, net, node)
}

fn abort(e: &canola::Error) -> Option<AbortCode> {
    match e {
        canola::Error::Sdo(s) => s.abort_code(),
        _ => None,
    }
}

fn reset(node: &canola::Node) {
    node.nmt().reset_node().unwrap();
    node.nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
}

#[test]
fn stored_parameters_survive_a_reset_and_defaults_come_back() {
    let (_bus, _net, node) = setup(STORING_EDS.as_bytes());
    node.sdo().write((0x2000, 0), 321u16).wait().unwrap();
    node.sdo().write((0x1017, 0), 250u16).wait().unwrap();
    // Not stored: a reset node brings the stored (here: default) values back.
    reset(&node);
    assert_eq!(node.read_typed::<u16>((0x2000, 0)).wait().unwrap(), 100);
    node.sdo().write((0x2000, 0), 321u16).wait().unwrap();
    node.sdo().write((0x1017, 0), 250u16).wait().unwrap();
    node.store_parameters().wait().unwrap();
    // The write of `save` does not change what the sub-index reads (its capabilities).
    assert_eq!(node.read_typed::<u32>((0x1010, 1)).wait().unwrap(), 1);
    reset(&node);
    assert_eq!(node.read_typed::<u16>((0x2000, 0)).wait().unwrap(), 321);
    assert_eq!(node.read_typed::<u16>((0x1017, 0)).wait().unwrap(), 250);
    // Restore the communication parameters only: 0x1017 back to default, 0x2000 kept.
    node.restore_defaults_of(ParameterGroup::Communication)
        .wait()
        .unwrap();
    // Still the current values until the reset.
    assert_eq!(node.read_typed::<u16>((0x1017, 0)).wait().unwrap(), 250);
    reset(&node);
    assert_eq!(node.read_typed::<u16>((0x1017, 0)).wait().unwrap(), 0);
    assert_eq!(node.read_typed::<u16>((0x2000, 0)).wait().unwrap(), 321);
    node.restore_defaults().wait().unwrap();
    reset(&node);
    assert_eq!(node.read_typed::<u16>((0x2000, 0)).wait().unwrap(), 100);
}

#[test]
fn a_wrong_signature_and_a_device_without_storage_are_refused() {
    let (_bus, _net, node) = setup(STORING_EDS.as_bytes());
    // CiA 301: a wrong signature is refused with 0x08000020 and nothing is stored.
    node.sdo().write((0x2000, 0), 321u16).wait().unwrap();
    let e = node.sdo().write((0x1010, 1), *b"load").wait().unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::CANNOT_STORE), "{e}");
    // The object as every message writes an address.
    assert!(
        e.to_string()
            .starts_with("node 5, object 0x1010:01: SDO abort 0x08000020"),
        "{e}"
    );
    let e = node.sdo().write((0x1011, 1), *b"save").wait().unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::CANNOT_STORE), "{e}");
    reset(&node);
    assert_eq!(node.read_typed::<u16>((0x2000, 0)).wait().unwrap(), 100);
    // A sub-index the device does not have.
    let e = node
        .store_parameters_of(ParameterGroup::Other(9))
        .wait()
        .unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::SUBINDEX_DOES_NOT_EXIST), "{e}");

    // The Bürkert device has no 0x1010: the abort says storing is not supported.
    let eds = include_bytes!("../../../../eds/burkert-generic.eds");
    let (_bus, _net, node) = setup(eds);
    let e = node.store_parameters().wait().unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::OBJECT_DOES_NOT_EXIST), "{e}");
    let e = node.restore_defaults().wait().unwrap_err();
    assert_eq!(abort(&e), Some(AbortCode::OBJECT_DOES_NOT_EXIST), "{e}");
}
