//! The LSS commands (CiA 305) through the gateway against unconfigured simulated devices on the
//! in-memory bus: Fastscan, switch selective, configure and inquire node-ID, inquire the
//! address, store, switch global, and the all-nodes workflow.

mod common;

use canopen::{MemoryBus, Network, SimDevice};
use canopen_gateway::{Config, Gateway};
use canopen_lss::LssAddress;
use common::Client;

fn address(serial: u32) -> LssAddress {
    LssAddress {
        vendor_id: 0x39,
        product_code: 0x1234,
        revision_number: 0x0001_0002,
        serial_number: serial,
    }
}

fn bus_with_unconfigured(serials: &[u32]) -> (Gateway, MemoryBus) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canopen_od::parse(common::EDS).unwrap().od;
    for &s in serials {
        bus.attach(SimDevice::unconfigured(od.clone(), address(s)));
    }
    (Gateway::new(net, Config::default()), bus)
}

#[test]
fn configure_one_device_step_by_step() {
    let (gw, _bus) = bus_with_unconfigured(&[0xA1]);
    let mut c = Client::connect(&gw);
    assert_eq!(
        c.ask("[1] _lss_fastscan 25\n", 1),
        "[1] 0x00000039 0x00001234 0x00010002 0x000000A1\r\n"
    );
    assert_eq!(c.ask("[2] lss_switch_glob 0\n", 1), "[2] OK\r\n");
    assert_eq!(
        c.ask("[3] lss_switch_sel 0x39 0x1234 0x00010002 0xA1\n", 1),
        "[3] OK\r\n"
    );
    assert_eq!(c.ask("[4] lss_inquire_addr 3\n", 1), "[4] 0x000000A1\r\n");
    assert_eq!(
        c.ask("[5] lss_inquire_addr\n", 1),
        "[5] 0x00000039 0x00001234 0x00010002 0x000000A1\r\n"
    );
    assert_eq!(c.ask("[6] lss_set_node 9\n", 1), "[6] OK\r\n");
    // Inquire node-ID reports the active node-ID: none (255) until the reset.
    assert_eq!(c.ask("[7] lss_get_node\n", 1), "[7] 255\r\n");
    assert_eq!(c.ask("[8] lss_conf_bitrate 0 2\n", 1), "[8] OK\r\n");
    assert_eq!(c.ask("[9] lss_store\n", 1), "[9] OK\r\n");
    assert_eq!(c.ask("[10] 1 lss_switch_glob 0\n", 1), "[10] OK\r\n");
    // The device boots with node-ID 9 at the reset and answers SDO there.
    assert_eq!(c.ask("[11] 0 reset comm\n", 1), "[11] OK\r\n");
    assert_eq!(c.ask("[12] 9 r 0x1018 4 x32\n", 1), "[12] 0x000000A1\r\n");
    assert_eq!(c.ask("[15] lss_switch_glob 1\n", 1), "[15] OK\r\n");
    assert_eq!(c.ask("[16] lss_get_node\n", 1), "[16] 9\r\n");
    assert_eq!(c.ask("[17] lss_switch_glob 0\n", 1), "[17] OK\r\n");
    // LSS on another net: unsupported.
    assert_eq!(c.ask("[13] 2 lss_store\n", 1), "[13] ERROR:106\r\n");
    // Nobody left unconfigured: Fastscan times out.
    assert_eq!(c.ask("[14] _lss_fastscan\n", 1), "[14] ERROR:103\r\n");
    // Activate bit timing is unconfirmed: OK after twice the switch delay.
    assert_eq!(c.ask("[18] lss_activate_bitrate 5\n", 1), "[18] OK\r\n");
}

#[test]
fn all_nodes_gives_each_device_a_node_id() {
    let (gw, _bus) = bus_with_unconfigured(&[0x10, 0x20, 0x30]);
    let mut c = Client::connect(&gw);
    c.send("[1] lss_allnodes 25 20 1\n");
    // CANopenNode's report: one comment line per slave, a summary, then OK.
    let mut lines: Vec<String> = (0..5).map(|_| c.line()).collect();
    assert_eq!(lines.pop().unwrap(), "[1] OK\r\n");
    assert_eq!(lines.pop().unwrap(), "# Found 3 nodes, search finished.\n");
    lines.sort();
    assert_eq!(
        lines,
        [
            "# Node-ID 20 assigned to: 0x00000039 0x00001234 0x00010002 0x00000010\n",
            "# Node-ID 21 assigned to: 0x00000039 0x00001234 0x00010002 0x00000020\n",
            "# Node-ID 22 assigned to: 0x00000039 0x00001234 0x00010002 0x00000030\n",
        ]
    );
    // Each answers SDO at its new node-ID.
    for (node, serial) in [(20, 0x10), (21, 0x20), (22, 0x30)] {
        assert_eq!(
            c.ask(&format!("[2] {node} r 0x1018 4 u32\n"), 1),
            format!("[2] {serial}\r\n")
        );
    }
}
