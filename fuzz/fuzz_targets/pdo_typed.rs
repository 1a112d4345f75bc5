//! Typed PDOs (what `canola-codegen` generates from an EDS) against random frames and values:
//! a struct with a 1-bit BOOLEAN, a 1-bit dummy, an INTEGER24 at bit 2, an UNSIGNED8 dummy, a
//! REAL32 field that straddles bytes and a 2-byte string decodes any frame, any `(address,
//! value)` list and packs any field values without panicking; what decodes packs back to the
//! same fields.
#![no_main]

use canola_frame::{CanFrame, CanId};
use canola_pdo::typed::{PdoField, field};
use canola_pdo::{
    DefaultCobId, Direction, ObjectAddress, RawValue, TypedPdo, TypedPdoError, ValueKind,
};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Sample {
    flag: bool,
    level: i32,
    reading: f32,
    tag: [u8; 1],
}

impl TypedPdo for Sample {
    const DIRECTION: Direction = Direction::Transmit;
    const NUMBER: u16 = 1;
    const ENTRIES: &'static [(u32, ValueKind)] = &[
        (0x2000_0101, ValueKind::Boolean),
        (0x0001_0001, ValueKind::Boolean),
        (0x2001_0018, ValueKind::Signed),
        (0x0005_0008, ValueKind::Unsigned),
        (0x2002_0020, ValueKind::Real32),
        (0x2003_0008, ValueKind::Bytes),
    ];
    const DEFAULT_COB_ID: Option<DefaultCobId> = Some(DefaultCobId {
        raw: 0x180,
        adds_node_id: true,
    });
    fn from_values(values: &[RawValue]) -> Result<Self, TypedPdoError> {
        Ok(Self {
            flag: field(values, 0, 0x2000_0101)?,
            level: field(values, 2, 0x2001_0018)?,
            reading: field(values, 4, 0x2002_0020)?,
            tag: field(values, 5, 0x2003_0008)?,
        })
    }
    fn value_at(&self, position: usize) -> Option<RawValue> {
        match position {
            0 => Some(self.flag.to_value()),
            2 => Some(self.level.to_value()),
            4 => Some(self.reading.to_value()),
            5 => Some(self.tag.to_value()),
            _ => None,
        }
    }
}

fn value(kind: u8, raw: u64) -> RawValue {
    match kind % 6 {
        0 => RawValue::Bool(raw & 1 == 1),
        1 => RawValue::Unsigned(raw),
        2 => RawValue::Signed(raw as i64),
        3 => RawValue::Real32(f32::from_bits(raw as u32)),
        4 => RawValue::Real64(f64::from_bits(raw)),
        _ => RawValue::from_raw(ValueKind::Bytes, raw, (kind / 6 % 9) * 8),
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&head, rest)) = data.split_first() else {
        return;
    };
    let len = (head & 0x0F) as usize;
    let payload = &rest[..len.min(8).min(rest.len())];
    if let Ok(id) = CanId::standard(0x180 + u16::from(head >> 4)) {
        let frame = if head & 0x80 != 0 {
            CanFrame::remote(id, payload.len())
        } else {
            CanFrame::new(id, payload)
        };
        if let Ok(frame) = frame
            && let Ok(s) = Sample::from_frame(&frame)
        {
            let mut out = [0u8; 8];
            let n = s.pack(&mut out).expect("decoded fields pack");
            // NaN payloads compare unequal; compare the bits.
            let back = Sample::from_data(&out[..n]).expect("packed data decodes");
            assert_eq!(back.reading.to_bits(), s.reading.to_bits());
            assert_eq!((back.flag, back.level, back.tag), (s.flag, s.level, s.tag));
        }
    }
    // Random (address, value) pairs, nine bytes each: index low byte, kind, seven value bytes.
    let pairs: Vec<(ObjectAddress, RawValue)> = rest
        .chunks_exact(9)
        .map(|c| {
            let raw = u64::from_le_bytes([c[2], c[3], c[4], c[5], c[6], c[7], c[8], 0]);
            (
                ObjectAddress::new(0x2000 + u16::from(c[0] % 5), 0),
                value(c[1], raw),
            )
        })
        .collect();
    let _ = Sample::from_pairs(&pairs);
    // Random field values: packing fails with a typed error when one does not fit.
    if rest.len() >= 9 {
        let s = Sample {
            flag: rest[0] & 1 == 1,
            level: i32::from_le_bytes([rest[1], rest[2], rest[3], rest[4]]),
            reading: f32::from_bits(u32::from_le_bytes([rest[5], rest[6], rest[7], rest[8]])),
            tag: [rest[0]],
        };
        let mut out = [0u8; 8];
        let _ = s.pack(&mut out);
        let _ = s.to_frame(canola_frame::NodeId::MIN);
    }
});
