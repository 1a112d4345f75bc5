//! PDOs of up to 64 data bytes on CAN FD (CANopen FD, CiA 1301): mapping, packing and
//! unpacking.
//!
//! Public sources establish only that CANopen FD PDOs carry up to 64 bytes; the CiA 1301 mapping
//! rules are not public. This module keeps CiA 301's mapping layout (§7.4.8: entries
//! `index << 16 | subindex << 8 | bits`, objects in order from bit 0 of byte 0, little-endian,
//! no padding, up to 64 entries, dummy entries) and lifts the total limit from 64 to 512 bits.
//! Each mapped object holds at most 64 bits, as in classic PDOs ([`RawValue`] is the same).
//!
//! [`FdMapping::byte_len`] is what the mapping needs; on the bus the frame is padded with zeros
//! to the next CAN FD length ([`FdMapping::frame_len`], `canola_frame::FdFrame::new_padded`).
//! A classic [`Mapping`] converts losslessly ([`FdMapping::from`]) and packs to the same bytes.
//!
//! [`unpack_fd`] is total: any data gives values or a [`PackError`]; bits are gathered from the
//! bytes an object spans, so unaligned objects across byte boundaries work as in classic PDOs.

use heapless::Vec;

use crate::comm::Direction;
use crate::dictionary::{Catalog, Dictionary};
use crate::mapping::{
    MAX_ENTRIES, Mapping, MappingEntry, MappingError, PdoMapping, ValueKind, field_mask,
    mapping_from_raw, mapping_from_raw_checked, push_checked, read_mapping,
};
use crate::pack::{PackError, RawValue};

/// Most bits a CAN FD PDO carries (64 data bytes).
pub const MAX_FD_BITS: u32 = 512;
/// Most data bytes of a CAN FD PDO.
pub const MAX_FD_BYTES: usize = 64;

/// One object of an [`FdMapping`] with its bit offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FdMappedObject {
    /// The raw mapping entry.
    pub entry: MappingEntry,
    /// Bit offset inside the PDO data (0..512).
    pub offset: u16,
    /// How its bits become a value.
    pub kind: ValueKind,
}

impl FdMappedObject {
    /// The mapped length in bits.
    pub const fn bits(&self) -> u8 {
        self.entry.bits()
    }
}

/// A validated CAN FD PDO mapping: at most 64 entries, at most 512 bits, each entry 1..=64
/// bits with the checks of [`Mapping::push`].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct FdMapping {
    objects: Vec<FdMappedObject, MAX_ENTRIES>,
    bits: u16,
}

impl FdMapping {
    /// An empty mapping.
    pub const fn new() -> Self {
        Self {
            objects: Vec::new(),
            bits: 0,
        }
    }

    /// Appends an object of `kind`.
    pub fn push(&mut self, entry: MappingEntry, kind: ValueKind) -> Result<(), MappingError> {
        push_checked(self, entry, kind)
    }

    /// Builder form of [`push`](Self::push).
    pub fn with(mut self, entry: MappingEntry, kind: ValueKind) -> Result<Self, MappingError> {
        self.push(entry, kind)?;
        Ok(self)
    }

    /// A mapping from raw entries without a dictionary, as [`Mapping::from_raw`]: dummies get
    /// their data type's kind, everything else [`ValueKind::Unsigned`].
    pub fn from_raw(entries: &[u32]) -> Result<Self, MappingError> {
        mapping_from_raw(entries)
    }

    /// A mapping from raw entries checked against `catalog` as [`Mapping::from_raw_checked`]
    /// does (mappable, access for `direction`, lengths), under the CAN FD limits.
    pub fn from_raw_checked<C: Catalog + ?Sized>(
        direction: Direction,
        entries: &[u32],
        catalog: &C,
    ) -> Result<Self, MappingError> {
        mapping_from_raw_checked(direction, entries, catalog)
    }

    /// Reads mapping parameter object `index` from `dict` (sub 0 = count, subs 1.. = entries)
    /// as [`Mapping::read_from`] does, under the CAN FD limits. An MPDO (sub 0 = 0xFE/0xFF)
    /// is [`MappingError::Mpdo`].
    pub fn read_from<D: Dictionary + ?Sized>(
        dict: &D,
        direction: Direction,
        index: u16,
    ) -> Result<Self, MappingError> {
        read_mapping(dict, direction, index)
    }

    /// The raw entries in PDO order (the values of sub 1..=n).
    pub fn raw_entries(&self) -> impl Iterator<Item = u32> + '_ {
        self.objects.iter().map(|o| o.entry.0)
    }

    /// The mapped objects in PDO order.
    pub fn objects(&self) -> &[FdMappedObject] {
        &self.objects
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether nothing is mapped.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Total mapped bits.
    pub const fn bit_len(&self) -> u32 {
        self.bits as u32
    }

    /// Data bytes the mapping needs: `ceil(bits / 8)`.
    pub const fn byte_len(&self) -> usize {
        (self.bits as usize).div_ceil(8)
    }

    /// The CAN FD frame length the PDO travels in: [`byte_len`](Self::byte_len) rounded up to
    /// the next CAN FD length.
    pub fn frame_len(&self) -> usize {
        canola_frame::fd::padded_len(self.byte_len()).unwrap_or(MAX_FD_BYTES)
    }
}

impl PdoMapping for FdMapping {
    const MAX_BITS: u32 = MAX_FD_BITS;

    fn too_long(bits: u32) -> MappingError {
        MappingError::FdTooLong(bits)
    }

    fn empty() -> Self {
        Self::new()
    }

    fn used(&self) -> (u32, usize) {
        (self.bit_len(), self.len())
    }

    fn append(&mut self, entry: MappingEntry, kind: ValueKind) {
        let obj = FdMappedObject {
            entry,
            offset: self.bits,
            kind,
        };
        // Cannot fail: `push_checked` found room for one more entry.
        let _ = self.objects.push(obj);
        // At most 512: `push_checked` checked the total.
        self.bits += u16::from(entry.bits());
    }
}

impl From<&Mapping> for FdMapping {
    /// The same objects at the same offsets (a classic mapping is a valid FD mapping).
    fn from(m: &Mapping) -> Self {
        let mut fd = Self::new();
        for o in m.objects() {
            // Cannot fail: the classic mapping passed the same checks under tighter limits.
            let _ = fd.push(o.entry, o.kind);
        }
        fd
    }
}

impl From<Mapping> for FdMapping {
    /// The same objects at the same offsets (see [`From<&Mapping>`](#impl-From%3C%26Mapping%3E-for-FdMapping)).
    fn from(m: Mapping) -> Self {
        Self::from(&m)
    }
}

impl TryFrom<&FdMapping> for Mapping {
    type Error = MappingError;

    /// The classic mapping of the same objects, when they fit eight bytes
    /// ([`MappingError::TooLong`] otherwise).
    fn try_from(fd: &FdMapping) -> Result<Self, MappingError> {
        let mut m = Mapping::new();
        for o in fd.objects() {
            m.push(o.entry, o.kind)?;
        }
        Ok(m)
    }
}

/// The `bits` bits at bit `offset` of `data` (which holds them).
fn read_field(data: &[u8], offset: u16, bits: u8) -> u64 {
    let first = usize::from(offset / 8);
    let shift = u32::from(offset % 8);
    let span = (shift as usize + usize::from(bits)).div_ceil(8);
    let mut acc = 0u128;
    for (i, b) in data[first..first + span].iter().enumerate() {
        acc |= u128::from(*b) << (8 * i);
    }
    ((acc >> shift) as u64) & field_mask(bits)
}

/// ORs `raw` (at most `bits` bits) into `out` at bit `offset`.
fn write_field(out: &mut [u8], offset: u16, bits: u8, raw: u64) {
    let first = usize::from(offset / 8);
    let shift = u32::from(offset % 8);
    let span = (shift as usize + usize::from(bits)).div_ceil(8);
    let acc = u128::from(raw & field_mask(bits)) << shift;
    for (i, b) in out[first..first + span].iter_mut().enumerate() {
        *b |= (acc >> (8 * i)) as u8;
    }
}

/// The values of every mapped object (dummies included) in `data`. Fails only when `data` is
/// shorter than the mapping; bytes after it (CAN FD padding) are ignored.
pub fn unpack_fd(
    mapping: &FdMapping,
    data: &[u8],
) -> Result<Vec<RawValue, MAX_ENTRIES>, PackError> {
    let needed = mapping.byte_len();
    if data.len() < needed {
        return Err(PackError::TooShort {
            needed,
            actual: data.len(),
        });
    }
    let mut values = Vec::new();
    for o in mapping.objects() {
        let raw = read_field(&data[..needed], o.offset, o.bits());
        // Cannot fail: at most MAX_ENTRIES objects.
        let _ = values.push(RawValue::from_raw(o.kind, raw, o.bits()));
    }
    Ok(values)
}

/// Packs `values` (one per mapped object, dummies included) into `out`, zero after the mapped
/// bits; returns [`FdMapping::byte_len`].
pub fn pack_fd(
    mapping: &FdMapping,
    values: &[RawValue],
    out: &mut [u8; MAX_FD_BYTES],
) -> Result<usize, PackError> {
    if values.len() != mapping.len() {
        return Err(PackError::ValueCount {
            expected: mapping.len(),
            actual: values.len(),
        });
    }
    let mut buf = [0u8; MAX_FD_BYTES];
    for (position, (o, v)) in mapping.objects().iter().zip(values).enumerate() {
        if v.kind() != o.kind {
            return Err(PackError::WrongKind { position });
        }
        let raw = v.to_raw(o.kind, o.bits()).ok_or(PackError::OutOfRange {
            position,
            bits: o.bits(),
        })?;
        write_field(&mut buf, o.offset, o.bits(), raw);
    }
    *out = buf;
    Ok(mapping.byte_len())
}

#[cfg(test)]
mod tests {
    extern crate std;

    use proptest::prelude::*;

    use super::*;
    use crate::pack::{pack, unpack};

    #[test]
    fn sixty_four_bytes_of_objects() {
        // Sixteen UNSIGNED32 (0x6000:01..10) fill a 64-byte PDO.
        let mut m = FdMapping::new();
        for sub in 1..=16u8 {
            m.push(MappingEntry::new(0x6000, sub, 32), ValueKind::Unsigned)
                .unwrap();
        }
        assert_eq!((m.bit_len(), m.byte_len(), m.frame_len()), (512, 64, 64));
        assert_eq!(
            m.clone()
                .with(MappingEntry::new(0x0005, 0, 8), ValueKind::Unsigned),
            Err(MappingError::FdTooLong(520))
        );
        let values: std::vec::Vec<RawValue> = (0..16u64)
            .map(|i| RawValue::Unsigned(0x0101_0101 * i))
            .collect();
        let mut out = [0u8; 64];
        assert_eq!(pack_fd(&m, &values, &mut out), Ok(64));
        assert_eq!(&out[4..8], &[1, 1, 1, 1]);
        assert_eq!(&out[60..64], &[15, 15, 15, 15]);
        assert_eq!(unpack_fd(&m, &out).unwrap().as_slice(), &values[..]);
        assert_eq!(
            unpack_fd(&m, &out[..63]),
            Err(PackError::TooShort {
                needed: 64,
                actual: 63
            })
        );
    }

    #[test]
    fn unaligned_objects_and_padding() {
        // A BOOLEAN, then an INTEGER16 across bytes 0..2, then 9 bytes of UNSIGNED8 (80 bits
        // in 10 bytes: the frame is padded to 12).
        let mut m = FdMapping::new()
            .with(MappingEntry::new(0x2000, 1, 1), ValueKind::Boolean)
            .unwrap()
            .with(MappingEntry::new(0x2000, 2, 16), ValueKind::Signed)
            .unwrap();
        for sub in 3..=9u8 {
            m.push(MappingEntry::new(0x2000, sub, 8), ValueKind::Unsigned)
                .unwrap();
        }
        assert_eq!((m.byte_len(), m.frame_len()), (10, 12));
        let mut values = std::vec![RawValue::Bool(true), RawValue::Signed(-2)];
        values.extend((3..=9u64).map(RawValue::Unsigned));
        let mut out = [0u8; 64];
        assert_eq!(pack_fd(&m, &values, &mut out), Ok(10));
        // bit 0 = 1, bits 1..17 = 0xFFFE.
        assert_eq!(&out[..3], &[0xFD, 0xFF, 0x01 | (3 << 1)]);
        assert_eq!(unpack_fd(&m, &out[..12]).unwrap().as_slice(), &values[..]);
        assert!(out[10..].iter().all(|&b| b == 0));
        assert_eq!(
            pack_fd(&m, &values[..3], &mut out),
            Err(PackError::ValueCount {
                expected: 9,
                actual: 3
            })
        );
        let mut wrong = values.clone();
        wrong[2] = RawValue::Unsigned(256);
        assert_eq!(
            pack_fd(&m, &wrong, &mut out),
            Err(PackError::OutOfRange {
                position: 2,
                bits: 8
            })
        );
        assert_eq!(
            FdMapping::new().with(MappingEntry::new(0x2000, 1, 72), ValueKind::Unsigned),
            Err(MappingError::EntryTooLong {
                addr: MappingEntry::new(0x2000, 1, 72).addr(),
                mapped_bits: 72
            })
        );
    }

    #[test]
    fn sixty_four_entries_at_most() {
        let mut m = FdMapping::new();
        for sub in 1..=64u8 {
            m.push(MappingEntry::new(0x2000, sub, 1), ValueKind::Unsigned)
                .unwrap();
        }
        assert_eq!(
            m.push(MappingEntry::new(0x2001, 1, 1), ValueKind::Unsigned),
            Err(MappingError::TooManyEntries(65))
        );
        assert_eq!((m.len(), m.bit_len()), (64, 64));
    }

    fn entries() -> impl Strategy<Value = std::vec::Vec<(u8, u64)>> {
        proptest::collection::vec((1u8..=64, any::<u64>()), 0..=40)
    }

    proptest! {
        #[test]
        fn pack_unpack_round_trip(objs in entries()) {
            let mut m = FdMapping::new();
            let mut values = std::vec::Vec::new();
            for (i, (bits, v)) in objs.iter().enumerate() {
                if m.push(MappingEntry::new(0x2000, i as u8 + 1, *bits), ValueKind::Unsigned).is_err() {
                    break;
                }
                values.push(RawValue::Unsigned(v & field_mask(*bits)));
            }
            let mut out = [0u8; 64];
            let n = pack_fd(&m, &values, &mut out).unwrap();
            prop_assert_eq!(n, m.byte_len());
            prop_assert!(out[n..].iter().all(|&b| b == 0));
            let back = unpack_fd(&m, &out[..m.frame_len()]).unwrap();
            prop_assert_eq!(back.as_slice(), &values[..]);
        }

        #[test]
        fn classic_mappings_pack_alike(objs in proptest::collection::vec((1u8..=16, any::<u64>()), 0..=8), data in proptest::array::uniform8(any::<u8>())) {
            let mut m = Mapping::new();
            let mut values = std::vec::Vec::new();
            for (i, (bits, v)) in objs.iter().enumerate() {
                if m.push(MappingEntry::new(0x2000, i as u8 + 1, *bits), ValueKind::Signed).is_err() {
                    break;
                }
                values.push(RawValue::from_raw(ValueKind::Signed, v & field_mask(*bits), *bits));
            }
            let fd = FdMapping::from(&m);
            let mut classic = [0u8; 8];
            let mut wide = [0u8; 64];
            let n = pack(&m, &values, &mut classic).unwrap();
            prop_assert_eq!(pack_fd(&fd, &values, &mut wide), Ok(n));
            prop_assert_eq!(&classic[..n], &wide[..n]);
            // Any received data decodes the same both ways.
            let a: std::vec::Vec<RawValue> = unpack(&m, &data).unwrap().iter().map(|(_, v)| v).collect();
            let b = unpack_fd(&fd, &data).unwrap();
            prop_assert_eq!(b.as_slice(), &a[..]);
        }

        #[test]
        fn any_data_unpacks_or_fails(data in proptest::collection::vec(any::<u8>(), 0..=64), objs in entries()) {
            let mut m = FdMapping::new();
            for (i, (bits, _)) in objs.iter().enumerate() {
                let _ = m.push(MappingEntry::new(0x2000, i as u8 + 1, *bits), ValueKind::Signed);
            }
            match unpack_fd(&m, &data) {
                Ok(v) => prop_assert_eq!(v.len(), m.len()),
                Err(PackError::TooShort { needed, actual }) => prop_assert!(actual < needed),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }
}
