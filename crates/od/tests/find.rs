//! Finding objects by name: case-insensitive, `object.sub-object` for entries of records and
//! arrays, names that contain dots.

use canola_od::{
    AccessType, DataType, Object, ObjectAddress, ObjectCode, ObjectDictionary, SubObject,
};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

#[test]
fn names_of_the_burkert_dictionary() {
    let od = canola_od::parse(EDS).unwrap().od;
    assert_eq!(
        od.find("Producer Heartbeat Time"),
        Some(ObjectAddress::new(0x1017, 0))
    );
    assert_eq!(
        od.find("producer heartbeat time"),
        Some(ObjectAddress::new(0x1017, 0))
    );
    assert_eq!(
        od.find("IDENTITY OBJECT.vendor id"),
        Some(ObjectAddress::new(0x1018, 1))
    );
    assert_eq!(
        od.find_object("identity object").map(|o| o.index),
        Some(0x1018)
    );
    // A record alone has no single value; unknown names and sub-names find nothing.
    assert_eq!(od.find("Identity Object"), None);
    assert_eq!(od.find("Identity Object.Colour"), None);
    assert_eq!(od.find("No such object"), None);
    assert_eq!(od.find(""), None);
    assert_eq!(od.find("."), None);
}

#[test]
fn names_with_dots() {
    let mut od = ObjectDictionary::default();
    let rw = AccessType::Rw;
    od.insert(Object::var(
        0x2000,
        SubObject::new(0, "Firmware v1.2", DataType::Unsigned32, rw),
    ));
    od.insert(Object::complex(
        0x2001,
        "Axis 1.0",
        ObjectCode::Record,
        [
            SubObject::new(0, "Highest sub-index supported", DataType::Unsigned8, rw),
            SubObject::new(1, "Gain.P", DataType::Integer16, rw),
        ],
    ));
    assert_eq!(
        od.find("firmware V1.2"),
        Some(ObjectAddress::new(0x2000, 0))
    );
    assert_eq!(
        od.find("axis 1.0.gain.p"),
        Some(ObjectAddress::new(0x2001, 1))
    );
    assert_eq!(
        od.find("Axis 1.0.Highest sub-index supported"),
        Some(ObjectAddress::new(0x2001, 0))
    );
}
