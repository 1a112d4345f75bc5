//! `SimDevice::from_eds` hands back the parser's warnings, as `canola_od::parse` does.

use canola::{NodeId, SimDevice};

#[test]
fn a_simulated_device_keeps_its_eds_warnings() {
    let eds = "[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\n\
               AccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
               [2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\n\
               DefaultValue=0x1Z\nPDOMapping=0\n";
    let parsed = canola::od::parse(eds.as_bytes()).unwrap();
    let device = SimDevice::from_eds(NodeId::new(5).unwrap(), eds.as_bytes()).unwrap();
    assert!(
        device
            .warnings()
            .iter()
            .any(|d| d.message.contains("kept as text")),
        "{:?}",
        device.warnings()
    );
    assert_eq!(device.warnings(), parsed.diagnostics.as_slice());
    let clean = include_bytes!("../../../../eds/burkert-generic.eds");
    let device = SimDevice::from_eds(NodeId::new(5).unwrap(), clean).unwrap();
    let parsed = canola::od::parse(&clean[..]).unwrap();
    assert_eq!(device.warnings(), parsed.diagnostics.as_slice());
}
