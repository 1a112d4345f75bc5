//! Objects of the CiA 301 communication profile need no EDS: the CLI knows their types
//! (0x1017 UNSIGNED16, 0x1018 RECORD of UNSIGNED32). An object of unknown type is printed as
//! its bytes, and the CLI says so. Against a simulated device in another process on the UDP bus.

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

#[test]
fn communication_objects_are_typed_without_an_eds() {
    let iface = common::udp_bus(0);
    let mut sim = common::simulator(&iface, EDS, "5", "20");
    let read = |args: &[&str]| {
        let mut all = vec!["--iface", &iface];
        all.extend_from_slice(args);
        canopen(&all)
    };
    let o = read(&["sdo", "read", "5", "0x1017"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500\n");
    assert_eq!(stderr(&o), "");
    let o = read(&["--hex", "sdo", "read", "5", "0x1018", "1"]);
    assert_eq!(stdout(&o), "0x00000039\n", "{}", stderr(&o));
    let o = read(&["sdo", "read", "5", "0x1018", "1"]);
    assert_eq!(stdout(&o), "57\n", "{}", stderr(&o));
    let o = read(&["sdo", "read", "5", "0x1008"]);
    assert_eq!(stdout(&o), "Buerkert generic device\n", "{}", stderr(&o));
    let o = read(&["--json", "sdo", "read", "5", "0x1017"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["value"], 500);
    // A write is typed the same way: 2 bytes for 0x1017.
    let o = read(&["sdo", "write", "5", "0x1017", "250"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = read(&["sdo", "read", "5", "0x1017"]);
    assert_eq!(stdout(&o), "250\n");

    // 0x2120 is manufacturer-specific (UNSIGNED32 in the EDS, which this command lacks): its
    // bytes, with a note saying why, and under --json `bytes` and no `value`.
    let o = read(&["sdo", "read", "5", "0x2120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "00000000\n");
    assert!(
        stderr(&o).contains("0x2120:00") && stderr(&o).contains("type"),
        "{}",
        stderr(&o)
    );
    let o = read(&["--json", "sdo", "read", "5", "0x2120"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["bytes"], "00000000", "{v}");
    assert!(v.get("value").is_none(), "{v}");
    let _ = sim.kill();
    let _ = sim.wait();
}
