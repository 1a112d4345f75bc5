//! `canopen store NODE` and `canopen restore NODE` (0x1010/0x1011) against simulated devices in
//! another process on the UDP bus: what is stored survives `nmt reset`, restored defaults
//! come back at the next one, and a device without 0x1010 says so.

mod common;
use common::{canopen, stderr, stdout};

const BURKERT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

/// A device with 0x1010/0x1011 (sub-index 1: all parameters) and a parameter 0x2000.
const STORING_EDS: &str = "[FileInfo]\nFileName=storing.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=storing\nVendorNumber=0x39\nProductNumber=2\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x39\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=2\n1=0x1010\n2=0x1011\n\
[1010]\nParameterName=Store parameters\nObjectType=0x8\nSubNumber=2\n\
[1010sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1010sub1]\nParameterName=Save all parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[1011]\nParameterName=Restore default parameters\nObjectType=0x8\nSubNumber=2\n\
[1011sub0]\nParameterName=Highest sub-index supported\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1011sub1]\nParameterName=Restore all default parameters\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\nPDOMapping=0\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n\
[2000]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=100\nPDOMapping=0\n";

#[test]
fn store_and_restore_across_resets() {
    let iface = common::udp_bus(0);
    let dir = std::env::temp_dir().join(format!("canopen-store-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let eds = dir.join("storing.eds");
    std::fs::write(&eds, STORING_EDS).unwrap();
    let mut sim = common::simulator(&iface, eds.to_str().unwrap(), "5", "30");
    let mut other = common::simulator(&iface, BURKERT, "6", "30");
    let run = |args: &[&str]| {
        let mut all = vec!["--iface", &iface];
        all.extend_from_slice(args);
        canopen(&all)
    };
    let ok = |args: &[&str]| {
        let o = run(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        stdout(&o)
    };
    // Waits for the reset node to finish: the device answers again.
    let reset = || {
        ok(&["nmt", "reset", "5"]);
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    let setpoint = || ok(&["sdo", "read", "5", "0x2000", "--type", "u16"]);

    ok(&["sdo", "write", "5", "0x2000", "321", "--type", "u16"]);
    reset();
    assert_eq!(setpoint(), "100\n", "not stored: the default after a reset");
    ok(&["sdo", "write", "5", "0x2000", "321", "--type", "u16"]);
    let o = run(&["store", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "node 5: all parameters stored (0x1010:01)\n");
    reset();
    assert_eq!(setpoint(), "321\n");
    let o = run(&["--json", "restore", "5"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["index"], 0x1011);
    assert_eq!(v["sub"], 1);
    assert_eq!(setpoint(), "321\n", "restored defaults wait for the reset");
    reset();
    assert_eq!(setpoint(), "100\n");

    // Node 6 has no 0x1010: the device's abort, exit 1.
    let o = run(&["store", "6"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("0x06020000"), "{}", stderr(&o));
    for c in [&mut sim, &mut other] {
        let _ = c.kill();
        let _ = c.wait();
    }
}
