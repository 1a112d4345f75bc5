//! Adapter from the `canopen-od` object dictionary model (an EDS or DCF file) to this crate's
//! [`Catalog`] and [`Dictionary`] (feature `od`).
//!
//! With it a master validates mappings against a node's EDS and a simulator reads its PDO
//! parameters from its DCF: `Mapping::read_from(&OdView::new(&od, node_id), direction, 0x1A00)`.

use canopen_od::{DataType, ObjectDictionary};

use crate::dictionary::{Catalog, Dictionary, ObjectAddr, ObjectInfo, ReadError};

/// A read-only view of an object dictionary model for one node (`$NODEID` in default values
/// resolves to `node_id`). Values are the DCF `ParameterValue` if present, else `DefaultValue`.
#[derive(Debug, Clone, Copy)]
pub struct OdView<'a> {
    od: &'a ObjectDictionary,
    node_id: u8,
}

impl<'a> OdView<'a> {
    /// A view of `od` as node `node_id`.
    pub fn new(od: &'a ObjectDictionary, node_id: u8) -> Self {
        Self { od, node_id }
    }
}

/// Size in bits of an entry as a PDO sees it: BOOLEAN is one bit, fixed-size types their size,
/// strings and domains the length of their value (at most 64 bits; 64 when there is none).
fn bits_of(data_type: DataType, value_len: Option<usize>) -> u16 {
    match data_type {
        DataType::Boolean => 1,
        t => match t.size() {
            Some(bytes) => (bytes * 8) as u16,
            None => value_len.map_or(64, |n| (n.min(8) * 8) as u16),
        },
    }
}

impl Catalog for OdView<'_> {
    fn object_info(&self, addr: ObjectAddr) -> Option<ObjectInfo> {
        let sub = self.od.sub(addr.index, addr.subindex)?;
        let value_len = sub
            .effective_value(self.node_id)
            .map(|v| v.to_le_bytes().len());
        Some(ObjectInfo {
            data_type: sub.data_type.code(),
            bits: bits_of(sub.data_type, value_len),
            pdo_mappable: sub.pdo_mapping,
            readable: sub.access.is_readable(),
            writable: sub.access.is_writable(),
        })
    }

    /// The EDS `[DummyUsage]` section decides; a file without the section accepts the seven
    /// dummy types (many EDS files leave it out).
    fn dummy_supported(&self, data_type: u16) -> bool {
        if self.od.dummy_usage.is_empty() {
            return (0x0001..=0x0007).contains(&data_type);
        }
        self.od
            .dummy_usage
            .get(&data_type)
            .copied()
            .unwrap_or(false)
    }
}

impl Dictionary for OdView<'_> {
    fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError> {
        let sub = self
            .od
            .sub(index, subindex)
            .ok_or(ReadError::NoSuchObject { index, subindex })?;
        sub.effective_value(self.node_id)
            .and_then(|v| v.as_i128())
            .and_then(|v| u32::try_from(v).ok())
            .ok_or(ReadError::NotAnInteger { index, subindex })
    }
}

#[cfg(test)]
mod tests {
    use canopen_od::{AccessType, EdsValue, Object, ObjectCode, SubObject, Value as OdValue};

    use super::*;
    use crate::comm::{CommParams, Direction, TransmissionType};
    use crate::mapping::{Mapping, MappingError};

    fn var(
        index: u16,
        t: DataType,
        access: AccessType,
        mappable: bool,
        v: Option<OdValue>,
    ) -> Object {
        let mut s = SubObject::new(0, "x", t, access).with_pdo_mapping(mappable);
        if let Some(v) = v {
            s = s.with_default(EdsValue::plain(v));
        }
        Object::var(index, s)
    }

    #[test]
    fn reads_tpdo_parameters_from_a_model() {
        let mut od = ObjectDictionary::default();
        od.insert(var(0x6000, DataType::Unsigned8, AccessType::Ro, true, None));
        od.insert(var(0x6401, DataType::Integer16, AccessType::Ro, true, None));
        od.insert(var(
            0x6200,
            DataType::Unsigned8,
            AccessType::Rww,
            true,
            None,
        ));
        od.insert(var(
            0x2000,
            DataType::Unsigned32,
            AccessType::Rw,
            false,
            None,
        ));
        let record = |index: u16, subs: &[(u8, DataType, OdValue)]| {
            Object::complex(
                index,
                "pdo parameter",
                ObjectCode::Record,
                subs.iter().map(|(sub, t, v)| {
                    SubObject::new(*sub, "p", *t, AccessType::Rw)
                        .with_default(EdsValue::plain(v.clone()))
                }),
            )
        };
        od.insert(record(
            0x1800,
            &[
                (0, DataType::Unsigned8, OdValue::Unsigned8(5)),
                (1, DataType::Unsigned32, OdValue::Unsigned32(0x4000_0185)),
                (2, DataType::Unsigned8, OdValue::Unsigned8(254)),
                (3, DataType::Unsigned16, OdValue::Unsigned16(50)),
                (5, DataType::Unsigned16, OdValue::Unsigned16(1000)),
            ],
        ));
        od.insert(record(
            0x1A00,
            &[
                (0, DataType::Unsigned8, OdValue::Unsigned8(2)),
                (1, DataType::Unsigned32, OdValue::Unsigned32(0x6000_0008)),
                (2, DataType::Unsigned32, OdValue::Unsigned32(0x6401_0010)),
            ],
        ));

        let view = OdView::new(&od, 5);
        let c = CommParams::read_from(&view, 0x1800).unwrap();
        assert_eq!(c.transmission_type, TransmissionType::EventManufacturer);
        assert_eq!((c.inhibit_time, c.event_timer, c.sync_start), (50, 1000, 0));
        let m = Mapping::read_from(&view, Direction::Transmit, 0x1A00).unwrap();
        assert_eq!(m.bit_len(), 24);
        assert_eq!(
            Mapping::read_from(&view, Direction::Receive, 0x1A00),
            Err(MappingError::AccessDenied {
                addr: ObjectAddr::new(0x6000, 0),
                direction: Direction::Receive
            })
        );
        assert_eq!(
            Mapping::from_raw_checked(Direction::Transmit, &[0x2000_0020], &view),
            Err(MappingError::NotMappable(ObjectAddr::new(0x2000, 0)))
        );
        assert!(Mapping::from_raw_checked(Direction::Receive, &[0x6200_0008], &view).is_ok());
        od.dummy_usage.insert(0x0005, false);
        let view = OdView::new(&od, 5);
        assert_eq!(
            Mapping::from_raw_checked(Direction::Receive, &[0x0005_0008], &view),
            Err(MappingError::DummyNotSupported(5))
        );
    }
}
