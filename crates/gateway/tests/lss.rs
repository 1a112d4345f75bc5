//! The LSS commands (CiA 305) through the gateway against unconfigured simulated devices on the
//! in-memory bus: Fastscan, switch selective, configure and inquire node-ID, inquire the
//! address, store, switch global, and the all-nodes workflow (with parts searched, ignored and
//! matched).

mod common;

use canola::lss::{LssAddress, SlaveConfig};
use canola::{MemoryBus, Network, SimDevice};
use canola_gateway::{Config, Gateway};
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
    let od = canola::od::parse(common::EDS).unwrap().od;
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

/// Devices that, as real slaves do, answer Fastscan in configuration state too.
fn bus_with_real(addresses: &[LssAddress]) -> (Gateway, MemoryBus) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(common::EDS).unwrap().od;
    for a in addresses {
        bus.attach(SimDevice::unconfigured_with(
            od.clone(),
            SlaveConfig::unconfigured_real(*a),
        ));
    }
    (Gateway::new(net, Config::default()), bus)
}

/// Reads the report of `lss_allnodes`: its lines up to and including the final `OK`.
fn report(c: &mut Client) -> Vec<String> {
    let mut lines = Vec::new();
    loop {
        let l = c.line();
        let end = l.ends_with("\r\n");
        lines.push(l);
        if end {
            return lines;
        }
    }
}

#[test]
fn all_nodes_ignoring_the_revision() {
    // Vendor-ID 0x39 matched, product code and serial number searched, revision ignored: the
    // devices differ in revision and serial number; one has another vendor-ID.
    let mut a = address(0x10);
    let mut b = address(0x20);
    let other = LssAddress::new(0x40, 0x1234, 1, 0x05);
    a.revision_number = 7;
    b.revision_number = 0x0009_0000;
    let (gw, _bus) = bus_with_real(&[b, other, a]);
    let mut c = Client::connect(&gw);
    c.send("[1] lss_allnodes 25 20 1 2 0x39 0 0 1 0 0 0\n");
    assert_eq!(
        report(&mut c),
        [
            "# Node-ID 20 assigned to: 0x00000039 0x00001234 0x00000000 0x00000010\n",
            "# Node-ID 21 assigned to: 0x00000039 0x00001234 0x00000000 0x00000020\n",
            "# Found 2 nodes, search finished.\n",
            "[1] OK\r\n",
        ]
    );
    // Each answers SDO at its new node-ID, with the revision the scan ignored.
    for (node, revision) in [(20, 7), (21, 0x0009_0000)] {
        assert_eq!(
            c.ask(&format!("[2] {node} r 0x1018 3 u32\n"), 1),
            format!("[2] {revision}\r\n")
        );
    }
    // The other vendor's device is still unconfigured: it is the one Fastscan finds now.
    assert_eq!(
        c.ask("[3] _lss_fastscan 25\n", 1),
        "[3] 0x00000040 0x00001234 0x00000001 0x00000005\r\n"
    );
}

#[test]
fn all_nodes_matching_a_product_code_after_the_searched_vendor_id() {
    // Vendor-ID searched, product code 0x1234 matched, revision and serial number searched.
    // The smallest vendor-ID belongs to a device of another product, so the search first
    // follows it and the product code turns it away; another differs from a wanted one only
    // in the product code.
    let unwanted = LssAddress::new(0x10, 0x9999, 1, 1);
    let twin = LssAddress::new(0x39, 0x1235, 0x0001_0002, 0x10);
    let late = LssAddress::new(0x50, 0x1234, 3, 3);
    let (gw, _bus) = bus_with_real(&[late, address(0x20), twin, unwanted, address(0x10)]);
    let mut c = Client::connect(&gw);
    c.send("[1] lss_allnodes 25 30 0 0 0 2 0x1234 0 0 0 0\n");
    assert_eq!(
        report(&mut c),
        [
            "# Node-ID 30 assigned to: 0x00000039 0x00001234 0x00010002 0x00000010\n",
            "# Node-ID 31 assigned to: 0x00000039 0x00001234 0x00010002 0x00000020\n",
            "# Node-ID 32 assigned to: 0x00000050 0x00001234 0x00000003 0x00000003\n",
            "# Found 3 nodes, search finished.\n",
            "[1] OK\r\n",
        ]
    );
    for (node, serial) in [(30, 0x10), (31, 0x20), (32, 3)] {
        assert_eq!(
            c.ask(&format!("[2] {node} r 0x1018 4 u32\n"), 1),
            format!("[2] {serial}\r\n")
        );
    }
    // The two other products' devices are left unconfigured.
    c.send("[3] lss_allnodes 25 40 0\n");
    assert_eq!(
        report(&mut c),
        [
            "# Node-ID 40 assigned to: 0x00000010 0x00009999 0x00000001 0x00000001\n",
            "# Node-ID 41 assigned to: 0x00000039 0x00001235 0x00010002 0x00000010\n",
            "# Found 2 nodes, search finished.\n",
            "[3] OK\r\n",
        ]
    );
}

#[test]
fn all_nodes_forms_without_a_fastscan_are_refused() {
    let (gw, _bus) = bus_with_unconfigured(&[0x10]);
    let mut c = Client::connect(&gw);
    // The vendor-ID ignored; every part after it ignored.
    assert_eq!(
        c.ask("[1] lss_allnodes 25 7 0 1 0 0 0 0 0 0 0\n", 1),
        "[1] ERROR:101\r\n"
    );
    assert_eq!(
        c.ask("[2] lss_allnodes 25 7 0 2 0x39 1 0 1 0 1 0\n", 1),
        "[2] ERROR:101\r\n"
    );
    // Nothing was sent: the device is still there to be found.
    assert_eq!(
        c.ask("[3] _lss_fastscan 25\n", 1),
        "[3] 0x00000039 0x00001234 0x00010002 0x00000010\r\n"
    );
}

#[test]
fn sdo_requests_go_on_while_an_lss_service_runs() {
    use canola::{BusConfig, ClockMode};

    // A real-time bus: a Fastscan that nobody answers lasts its response timeout (1 s), in which
    // reads from three nodes are answered. Were the LSS service run where the node queues are
    // served, the reads would wait for it.
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    for n in [5, 6, 7] {
        bus.attach(
            SimDevice::from_eds(canola::frame::NodeId::new(n).unwrap(), common::EDS).unwrap(),
        );
    }
    let gw = Gateway::new(net, Config::default());
    let mut c = Client::connect(&gw);
    c.send("[1] _lss_fastscan 1000\n[5] 5 r 0x1017 0 u16\n[6] 6 r 0x1017 0 u16\n[7] 7 r 0x1017 0 u16\n");
    let mut reads: Vec<String> = (0..3).map(|_| c.line()).collect();
    reads.sort();
    assert_eq!(reads, ["[5] 500\r\n", "[6] 500\r\n", "[7] 500\r\n"]);
    assert_eq!(c.line(), "[1] ERROR:103\r\n");
}
