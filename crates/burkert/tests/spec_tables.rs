//! The generated Bürkert dictionary against the tables of the Bürkert manual (SPEC-NOTES §1):
//! types, access, defaults and PDO mappability of every profile object.

use canola_burkert::objects::{self, DICTIONARY};
use canola_burkert::{BitRate, LedColour, LedMode, PredefinedColour, ValveModeColours};
use canola_od::entry::StaticSubObject;
use canola_od::{AccessType, DataType};

fn sub(index: u16, sub_index: u8) -> &'static StaticSubObject {
    DICTIONARY
        .iter()
        .find(|s| s.index == index && s.sub_index == sub_index)
        .unwrap_or_else(|| panic!("{index:#06x} sub {sub_index} is in the dictionary"))
}

fn default_u(index: u16, sub_index: u8) -> u64 {
    let bytes = sub(index, sub_index).default.expect("has a default");
    bytes.iter().rev().fold(0, |acc, &b| acc << 8 | b as u64)
}

#[test]
fn communication_defaults() {
    assert_eq!(default_u(0x1005, 0), 0x80, "COB-ID SYNC");
    assert_eq!(default_u(0x1017, 0), 500, "heartbeat 500 ms");
    assert_eq!(sub(0x1017, 0).data_type, DataType::Unsigned16);
    assert_eq!(default_u(0x1018, 1), 0x39, "the seed's vendor-ID");
    assert_eq!(default_u(0x1016, 0), 127, "127 consumer heartbeat entries");
    let emcy = sub(0x1014, 0);
    assert!(emcy.default_adds_node_id);
    assert_eq!(default_u(0x1014, 0), 0x80);
    for n in 0..4u16 {
        assert_eq!(
            default_u(0x1400 + n, 1),
            0x200 + 0x100 * n as u64,
            "RPDO{} COB-ID base",
            n + 1
        );
        assert!(sub(0x1400 + n, 1).default_adds_node_id);
        assert_eq!(default_u(0x1400 + n, 2), 0xFE);
        assert_eq!(
            default_u(0x1800 + n, 1),
            0x180 + 0x100 * n as u64,
            "TPDO{} COB-ID base",
            n + 1
        );
        assert_eq!(default_u(0x1800 + n, 2), 0xFE);
        assert_eq!(default_u(0x1800 + n, 3), 5000, "inhibit time in 100 µs");
        assert_eq!(default_u(0x1800 + n, 5), 1000, "event timer in ms");
    }
    assert_eq!(default_u(0x1200, 1), 0x600);
    assert_eq!(default_u(0x1200, 2), 0x580);
}

#[test]
fn device_description_0x2000() {
    let expect = [
        (1, DataType::VisibleString),
        (2, DataType::Unsigned32),
        (3, DataType::VisibleString),
        (4, DataType::Unsigned32),
        (5, DataType::Unsigned32),
        (6, DataType::Unsigned32),
        (7, DataType::Unsigned32),
        (8, DataType::Unsigned32),
        (9, DataType::Unsigned8),
    ];
    assert_eq!(default_u(0x2000, 0), 9);
    for (s, dt) in expect {
        assert_eq!(sub(0x2000, s).data_type, dt, "0x2000 sub {s}");
        assert_eq!(sub(0x2000, s).access, AccessType::Ro);
    }
}

#[test]
fn device_communication_0x2001() {
    assert_eq!(default_u(0x2001, 0), 13);
    assert_eq!(
        BitRate::from_code(default_u(0x2001, 1) as u8),
        Ok(BitRate::Kbit500)
    );
    assert!(sub(0x2001, 2).default_adds_node_id, "address = node-ID");
    assert_eq!(default_u(0x2001, 3), 1, "bUS mode default 1");
    assert_eq!(default_u(0x2001, 4), 0, "no reset");
    assert_eq!(sub(0x2001, 5).data_type, DataType::Unsigned32);
    for s in [1, 2, 3, 4, 7, 9] {
        assert_eq!(sub(0x2001, s).access, AccessType::Rw, "0x2001 sub {s}");
    }
    for s in [5, 6, 8, 0x0A, 0x0D] {
        assert_eq!(sub(0x2001, s).access, AccessType::Ro, "0x2001 sub {s}");
    }
    assert_eq!(default_u(0x2001, 0x0A), 127, "boots pre-operational");
    assert!(
        DICTIONARY
            .iter()
            .all(|s| !(s.index == 0x2001 && s.sub_index == 0x0C))
    );
}

#[test]
fn user_configuration_and_logbook() {
    for s in [2, 3, 4] {
        assert_eq!(sub(0x2002, s).data_type, DataType::VisibleString);
        assert_eq!(sub(0x2002, s).access, AccessType::Rw);
    }
    assert_eq!(default_u(0x2002, 5), 0, "static node-ID default 0");
    assert_eq!(sub(0x2003, 4).data_type, DataType::Domain);
    assert_eq!(sub(0x2003, 4).access, AccessType::Ro);
    assert_eq!(
        objects::error_management_object::LOGBOOK_DOWNLOAD.index(),
        0x2003
    );
}

#[test]
fn device_status_0x2004() {
    let expect = [
        (1, DataType::Unsigned8),
        (2, DataType::Real32),
        (3, DataType::Real32),
        (4, DataType::Unsigned32),
        (5, DataType::Unsigned16),
        (6, DataType::Unsigned16),
        (7, DataType::Real32),
        (8, DataType::Real32),
        (0x0A, DataType::Real32),
        (0x0B, DataType::Real32),
        (0x0C, DataType::Real32),
        (0x0D, DataType::Unsigned32),
        (0x0E, DataType::Unsigned8),
        (0x10, DataType::Real32),
        (0x11, DataType::Unsigned32),
        (0x12, DataType::Unsigned32),
        (0x13, DataType::Real32),
    ];
    for (s, dt) in expect {
        assert_eq!(sub(0x2004, s).data_type, dt, "0x2004 sub {s:#x}");
    }
    assert!(sub(0x2004, 1).pdo_mapping, "NE 107 status is PDO-mappable");
    let ne107 = objects::device_status_object::DEVICE_STATUS_NAMUR_NE107;
    assert_eq!((ne107.index(), ne107.sub_index()), (0x2004, 1));
}

#[test]
fn locating_maintenance_and_led_objects() {
    for index in [0x2101, 0x210A] {
        assert_eq!(default_u(index, 1), 0);
        assert_eq!(sub(index, 1).access, AccessType::Rw);
    }
    assert_eq!(
        LedMode::from_u32(default_u(0x2120, 0) as u32),
        Ok(LedMode::Namur)
    );
    let d = ValveModeColours::default();
    assert_eq!(default_u(0x2121, 1) as u32, d.closed.to_u32());
    assert_eq!(default_u(0x2121, 2) as u32, d.between.to_u32());
    assert_eq!(default_u(0x2121, 3) as u32, d.open.to_u32());
    assert_eq!(
        LedColour::from_u32(default_u(0x2122, 0) as u32),
        Ok(LedColour::Predefined(PredefinedColour::White))
    );
}

#[test]
fn sensor_and_control_values() {
    for i in 0..4 {
        let s = sub(0x2500 + i, 1);
        assert!(
            s.pdo_mapping && s.access.is_readable(),
            "sensor value {i} is TPDO-mappable"
        );
        let c = sub(0x2540 + i, 1);
        assert!(
            c.pdo_mapping && c.access.is_writable(),
            "control value {i} is RPDO-mappable"
        );
        assert_eq!(
            sub(0x2500 + i, 6).data_type,
            DataType::Real32,
            "precision is REAL32"
        );
        assert_eq!(sub(0x2540 + i, 6).data_type, DataType::Real32);
    }
    // Default mapping: TPDO1 carries sensor values 1 and 2, RPDO1 control values 1 and 2.
    assert_eq!(default_u(0x1A00, 0), 2);
    assert_eq!(default_u(0x1A00, 1), 0x2500_0120);
    assert_eq!(default_u(0x1600, 1), 0x2540_0120);
}
