//! The data types CiA 301 itself gives the objects of the communication profile area
//! (0x1000..=0x1FFF, CiA 301 §7.5.2), so a tool can type a read or a write of one of them
//! without the device's EDS: 0x1017 is UNSIGNED16 on every device, 0x1018:01 UNSIGNED32.
//!
//! Only objects whose type the standard fixes are listed; an object whose type a device
//! chooses (none in this area of CiA 301), a manufacturer-specific or a device profile object
//! gives `None`. Needs no allocator.

use crate::types::DataType;

/// The data type CiA 301 defines for `index`, `sub`, or `None` when the standard does not fix
/// it (an index outside the communication profile, a sub-index the object does not have).
///
/// Sub-index 0 of an ARRAY or RECORD ("highest sub-index supported") is UNSIGNED8.
///
/// ```
/// use canola_od::{DataType, profile::communication_type};
/// assert_eq!(communication_type(0x1017, 0), Some(DataType::Unsigned16));
/// assert_eq!(communication_type(0x1018, 1), Some(DataType::Unsigned32));
/// assert_eq!(communication_type(0x1018, 0), Some(DataType::Unsigned8));
/// assert_eq!(communication_type(0x1018, 5), None);
/// assert_eq!(communication_type(0x6000, 0), None);
/// ```
pub fn communication_type(index: u16, sub: u8) -> Option<DataType> {
    use DataType::{Domain, OctetString, Unsigned8, Unsigned16, Unsigned32, VisibleString};
    // A VAR: only sub-index 0 exists.
    let var = |t: DataType| if sub == 0 { Some(t) } else { None };
    // An ARRAY of `t` with sub-indices 1..=last.
    let array = |t: DataType, last: u8| match sub {
        0 => Some(Unsigned8),
        s if s <= last => Some(t),
        _ => None,
    };
    match index {
        // Device type, manufacturer status register.
        0x1000 | 0x1002 => var(Unsigned32),
        // Error register.
        0x1001 => var(Unsigned8),
        // Pre-defined error field.
        0x1003 => array(Unsigned32, 254),
        // COB-ID SYNC, communication cycle period, synchronous window length.
        0x1005..=0x1007 => var(Unsigned32),
        // Manufacturer device name, hardware version, software version.
        0x1008..=0x100A => var(VisibleString),
        // Guard time.
        0x100C => var(Unsigned16),
        // Life time factor.
        0x100D => var(Unsigned8),
        // Store parameters, restore default parameters (the signatures `save`, `load`).
        0x1010 | 0x1011 => array(Unsigned32, 127),
        // COB-ID TIME, high resolution time stamp, COB-ID EMCY.
        0x1012..=0x1014 => var(Unsigned32),
        // Inhibit time EMCY.
        0x1015 => var(Unsigned16),
        // Consumer heartbeat time.
        0x1016 => array(Unsigned32, 127),
        // Producer heartbeat time.
        0x1017 => var(Unsigned16),
        // Identity object: vendor-ID, product code, revision number, serial number.
        0x1018 => array(Unsigned32, 4),
        // Synchronous counter overflow value.
        0x1019 => var(Unsigned8),
        // Verify configuration: configuration date and time.
        0x1020 => array(Unsigned32, 2),
        // Store EDS.
        0x1021 => var(Domain),
        // Store format.
        0x1022 => var(Unsigned8),
        // OS command, OS debugger interface: command, status, reply.
        0x1023 | 0x1025 => match sub {
            0 | 2 => Some(Unsigned8),
            1 | 3 => Some(OctetString),
            _ => None,
        },
        // OS command mode.
        0x1024 => var(Unsigned8),
        // OS prompt.
        0x1026 => array(Unsigned8, 3),
        // Module list.
        0x1027 => array(Unsigned16, 254),
        // Emergency consumer object.
        0x1028 => array(Unsigned32, 127),
        // Error behaviour object.
        0x1029 => array(Unsigned8, 254),
        // SDO server and client parameters: COB-IDs client->server, server->client, node-ID.
        0x1200..=0x12FF => match sub {
            0 | 3 => Some(Unsigned8),
            1 | 2 => Some(Unsigned32),
            _ => None,
        },
        // RPDO and TPDO communication parameters: COB-ID, transmission type, inhibit time,
        // (4 reserved), event timer, SYNC start value.
        0x1400..=0x15FF | 0x1800..=0x19FF => match sub {
            0 | 2 | 6 => Some(Unsigned8),
            1 => Some(Unsigned32),
            3 | 5 => Some(Unsigned16),
            _ => None,
        },
        // RPDO and TPDO mapping parameters.
        0x1600..=0x17FF | 0x1A00..=0x1BFF => array(Unsigned32, 64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_types_of_the_objects_every_device_has() {
        assert_eq!(communication_type(0x1000, 0), Some(DataType::Unsigned32));
        assert_eq!(communication_type(0x1001, 0), Some(DataType::Unsigned8));
        assert_eq!(communication_type(0x1008, 0), Some(DataType::VisibleString));
        assert_eq!(communication_type(0x1017, 0), Some(DataType::Unsigned16));
        assert_eq!(communication_type(0x1017, 1), None);
        assert_eq!(communication_type(0x1018, 4), Some(DataType::Unsigned32));
        assert_eq!(communication_type(0x1010, 1), Some(DataType::Unsigned32));
        assert_eq!(communication_type(0x1010, 128), None);
        assert_eq!(communication_type(0x1800, 1), Some(DataType::Unsigned32));
        assert_eq!(communication_type(0x1800, 3), Some(DataType::Unsigned16));
        assert_eq!(communication_type(0x1800, 4), None);
        assert_eq!(communication_type(0x1A00, 8), Some(DataType::Unsigned32));
        assert_eq!(communication_type(0x1A00, 65), None);
        assert_eq!(communication_type(0x1004, 0), None);
        assert_eq!(communication_type(0x2000, 0), None);
    }
}
