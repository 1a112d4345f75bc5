//! Values as Rust types: `TryFrom<Value>` for the scalars and `String`, a typed read on the
//! node handle, PDO values by name where the node has a dictionary, and `Identity` printed.
//! Against the simulated Bürkert device on the in-memory bus.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use canola::{Identity, MemoryBus, Network, NodeId, SimDevice, Value};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

#[test]
fn values_convert_to_rust_types() {
    assert_eq!(u16::try_from(Value::Unsigned16(500)), Ok(500));
    assert_eq!(u32::try_from(Value::Unsigned16(500)), Ok(500));
    assert_eq!(i64::try_from(Value::Integer8(-1)), Ok(-1));
    assert!(u8::try_from(Value::Unsigned16(500)).is_err());
    assert!(u16::try_from(Value::Integer8(-1)).is_err());
    assert!(u16::try_from(Value::Real32(1.0)).is_err());
    assert_eq!(bool::try_from(Value::Boolean(true)), Ok(true));
    assert_eq!(f32::try_from(Value::Real32(24.5)), Ok(24.5));
    assert_eq!(f64::try_from(Value::Real32(24.5)), Ok(24.5));
    assert_eq!(
        String::try_from(Value::VisibleString(b"valve".to_vec())),
        Ok("valve".to_string())
    );
    assert!(String::try_from(Value::Unsigned8(1)).is_err());
    let e = u8::try_from(Value::Unsigned16(500)).unwrap_err();
    assert_eq!(e.to_string(), "the UNSIGNED16 value 500 does not fit in u8");
}

#[test]
fn typed_reads_on_the_node_handle() {
    let id = NodeId::new(5).unwrap();
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(id, EDS).unwrap());
    // No dictionary: the communication profile's types.
    let node = net.node(id);
    assert_eq!(node.read_typed::<u16>((0x1017, 0)).wait().unwrap(), 500);
    assert_eq!(node.read_typed::<u32>((0x1018, 1)).wait().unwrap(), 0x39);
    assert_eq!(
        node.read_typed::<String>((0x1008, 0)).wait().unwrap(),
        "Buerkert generic device"
    );
    // 500 does not fit: an error naming the object, not a truncated number.
    let e = node.read_typed::<u8>((0x1017, 0)).wait().unwrap_err();
    assert!(e.to_string().contains("0x1017"), "{e}");
    // A manufacturer object without a dictionary: the Rust type's own CANopen type.
    assert_eq!(node.read_typed::<u32>((0x2120, 0)).wait().unwrap(), 0);
    // With a dictionary: its type (REAL32 for a sensor value).
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS).unwrap().od);
    assert_eq!(node.read_typed::<f32>((0x2500, 6)).wait().unwrap(), 0.01);
}

#[test]
fn pdo_values_by_name() {
    let id = NodeId::new(5).unwrap();
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS).unwrap().od);
    bus.attach(SimDevice::from_eds(id, EDS).unwrap());
    let seen: Arc<Mutex<Vec<Option<Value>>>> = Arc::default();
    let s = seen.clone();
    net.on_pdo(move |p| {
        if p.number == 1 {
            s.lock()
                .unwrap()
                .push(p.get("Sensor Value 1.Value").cloned());
            // A name the PDO does not carry, and one the dictionary does not know.
            assert!(p.get("Producer heartbeat time").is_none());
            assert!(p.get("no such object").is_none());
        }
    });
    let mut pdos = net.subscribe_pdos();
    node.nmt().start().unwrap();
    net.run_for(Duration::from_millis(50)).wait().unwrap();
    let seen = seen.lock().unwrap();
    assert!(!seen.is_empty());
    assert!(
        seen.iter().all(|v| matches!(v, Some(Value::Real32(_)))),
        "{seen:?}"
    );
    let batch = pdos.try_recv().unwrap();
    let tpdo1: Vec<_> = batch.iter().filter(|p| p.number == 1).collect();
    assert!(!tpdo1.is_empty());
    for p in tpdo1 {
        assert!(matches!(
            p.get("sensor value 1.value"),
            Some(Value::Real32(_))
        ));
    }
}

#[test]
fn identity_prints_in_canopen_terms() {
    let full = Identity {
        vendor_id: 0x39,
        product_code: Some(0x1234),
        revision: Some(0x0001_0002),
        serial: Some(12345678),
    };
    assert_eq!(
        full.to_string(),
        "vendor-ID 0x00000039, product code 0x00001234, revision 0x00010002, serial number 0x00BC614E"
    );
    let vendor_only = Identity {
        vendor_id: 0x39,
        ..Identity::default()
    };
    assert_eq!(vendor_only.to_string(), "vendor-ID 0x00000039");
}
