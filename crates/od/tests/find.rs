//! Finding objects by name: case-insensitive, `object/sub-object` or `object.sub-object` for
//! entries of records and arrays, names that contain separators; the printed name found back.

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

#[test]
fn both_separators_and_the_printed_name() {
    let od = canola_od::parse(EDS).unwrap().od;
    let vendor = Some(ObjectAddress::new(0x1018, 1));
    assert_eq!(od.find("Identity object/Vendor ID"), vendor);
    assert_eq!(od.find("Identity object.Vendor ID"), vendor);
    assert_eq!(od.find("identity object / vendor id"), vendor);
    assert_eq!(
        od.find("  Producer heartbeat time "),
        Some(ObjectAddress::new(0x1017, 0))
    );
    assert_eq!(od.find("Identity object/"), None);
    assert_eq!(od.find("/Vendor ID"), None);
    // One printed form, and `find` takes every printed name back.
    assert_eq!(
        od.display_name(ObjectAddress::new(0x1018, 1)).as_deref(),
        Some("Identity Object / Vendor ID")
    );
    assert_eq!(
        od.display_name(ObjectAddress::new(0x1017, 0)).as_deref(),
        Some("Producer Heartbeat Time")
    );
    assert_eq!(od.display_name(ObjectAddress::new(0x0FFF, 0)), None);
    for (index, sub) in od.entries() {
        let at = ObjectAddress::new(index, sub.sub_index);
        let name = od.display_name(at).unwrap();
        assert_eq!(od.find(&name), Some(at), "{name}");
    }
}

#[test]
fn separators_inside_names() {
    let mut od = ObjectDictionary::default();
    let rw = AccessType::Rw;
    od.insert(Object::complex(
        0x2002,
        "Load/Save",
        ObjectCode::Record,
        [
            SubObject::new(0, "Highest sub-index supported", DataType::Unsigned8, rw),
            SubObject::new(1, "In/Out", DataType::Unsigned8, rw),
        ],
    ));
    assert_eq!(
        od.find("load/save/in/out"),
        Some(ObjectAddress::new(0x2002, 1))
    );
    assert_eq!(
        od.find("Load/Save.In/Out"),
        Some(ObjectAddress::new(0x2002, 1))
    );
    assert_eq!(
        od.find(&od.display_name(ObjectAddress::new(0x2002, 1)).unwrap()),
        Some(ObjectAddress::new(0x2002, 1))
    );
}
