//! Dictionary-aware access through `Sdo::get` / `Sdo::set` against the simulator on the
//! virtual-clock in-memory bus: names, addresses, writes typed by the dictionary, local errors.

use canola::error::ValueProblem;
use canola::mem::MemoryBus;
use canola::{Error, Network, ObjectAddress, SimDevice, Value};
use canola_frame::NodeId;

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
fn read_by_name_and_by_address() {
    let (_bus, net) = rig();
    let node = net.node(n(5));
    assert_eq!(
        node.sdo().get("Producer heartbeat time").wait().unwrap(),
        Value::Unsigned16(500)
    );
    // A sub-object after a dot or a slash, or in the printed form `Object / Sub-object`
    // (the CLI takes the same three).
    for name in [
        "identity object.vendor id",
        "Identity object/Vendor ID",
        "Identity object / Vendor ID",
    ] {
        assert_eq!(
            node.sdo().get(name).wait().unwrap(),
            Value::Unsigned32(0x39),
            "{name}"
        );
    }
    assert_eq!(
        node.sdo().get((0x1018, 1)).wait().unwrap(),
        Value::Unsigned32(0x39)
    );
    assert_eq!(
        node.sdo().get("Manufacturer device name").wait().unwrap(),
        Value::VisibleString(b"Buerkert generic device".to_vec())
    );
}

/// Without the dictionary's type the literal `200` is an i32: 4 bytes to an UNSIGNED16, which
/// the device refuses. Typed by the dictionary it goes out as 2 bytes.
#[test]
fn writes_are_typed_by_the_dictionary() {
    let (_bus, net) = rig();
    let node = net.node(n(5));
    let untyped = node.sdo().write((0x1017, 0), 200).wait().unwrap_err();
    assert_eq!(
        untyped.server_abort().map(|a| a.get()),
        Some(0x0607_0012),
        "{untyped}"
    );
    node.sdo()
        .set("Producer heartbeat time", 200)
        .wait()
        .unwrap();
    assert_eq!(
        node.sdo().read((0x1017, 0)).wait().unwrap(),
        200u16.to_le_bytes()
    );
    node.sdo().set((0x1017, 0), 300u64).wait().unwrap();
    assert_eq!(
        node.sdo().get((0x1017, 0)).wait().unwrap(),
        Value::Unsigned16(300)
    );
    node.sdo()
        .set("Producer Heartbeat Time", Value::Unsigned32(400))
        .wait()
        .unwrap();
    assert_eq!(
        node.sdo().get((0x1017, 0)).wait().unwrap(),
        Value::Unsigned16(400)
    );
}

#[test]
fn values_that_do_not_fit_fail_before_anything_is_sent() {
    let (bus, net) = rig();
    let node = net.node(n(5));
    let before = bus.stats();
    for (value, why) in [
        (canola::WriteValue::from(70_000), "70000 does not fit"),
        (canola::WriteValue::from(-1), "-1 does not fit"),
        (canola::WriteValue::from(1.5), "a float"),
        (canola::WriteValue::from("fast"), "text"),
    ] {
        let e = node
            .sdo()
            .set("Producer heartbeat time", value)
            .wait()
            .unwrap_err();
        let Error::Value {
            node: at,
            entry,
            problem,
        } = &e
        else {
            panic!("expected a value error, got {e}");
        };
        assert_eq!((*at, *entry), (n(5), ObjectAddress::new(0x1017, 0)));
        let message = problem.to_string();
        assert!(
            message.contains("Producer Heartbeat Time is UNSIGNED16") && message.contains(why),
            "{message}"
        );
        let ValueProblem::Unfit {
            object, data_type, ..
        } = problem
        else {
            panic!("expected an unfit value, got {problem}");
        };
        assert_eq!(
            (object.as_str(), *data_type),
            ("Producer Heartbeat Time", canola::od::DataType::Unsigned16)
        );
    }
    assert_eq!(bus.stats(), before, "nothing was sent");

    let e = node.sdo().get("No such thing").wait().unwrap_err();
    assert!(matches!(e, Error::UnknownObject { .. }), "{e}");
    let e = node.sdo().get("Identity Object").wait().unwrap_err();
    assert!(e.to_string().contains("array or record"), "{e}");
    // A node without a dictionary has no names; the error keeps the name asked for.
    let e = net.node(n(6)).sdo().get("Device type").wait().unwrap_err();
    assert!(e.to_string().contains("without a dictionary"), "{e}");
    assert!(
        matches!(&e, Error::UnknownObject { name, .. } if name == "Device type"),
        "{e}"
    );
    assert!(e.to_string().contains("\"Device type\""), "{e}");
    // A write by address to such a node names the address.
    let e = net
        .node(n(6))
        .sdo()
        .set((0x1017, 0), 100u16)
        .wait()
        .unwrap_err();
    assert!(
        matches!(&e, Error::UnknownObject { name, .. } if name == "0x1017:00"),
        "{e}"
    );
}

/// A program tells "the dictionary does not describe this object" from other value problems by
/// the variant, not by the words.
#[test]
fn an_object_the_dictionary_lacks_is_a_typed_problem() {
    let (bus, net) = rig();
    let node = net.node(n(5));
    let before = bus.stats();
    let e = node.sdo().read_value((0x2FFF, 0)).wait().unwrap_err();
    assert!(
        matches!(
            &e,
            Error::Value {
                problem: ValueProblem::NotDescribed,
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "node 5, object 0x2FFF:00: the node's dictionary does not describe this object"
    );
    assert_eq!(format!("{e:?}"), e.to_string());
    assert_eq!(bus.stats(), before, "nothing was sent");
}
