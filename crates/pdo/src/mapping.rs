//! PDO mapping parameters (CiA 301 §7.4.8, objects 0x1600..=0x17FF and 0x1A00..=0x1BFF).
//!
//! Sub 0 holds the number of mapped objects (0..=64; 0 disables the PDO). Each of sub 1..=64 is
//! an UNSIGNED32 `index << 16 | subindex << 8 | length in bits`. Objects are laid out in order
//! from bit 0 of data byte 0 upward (little-endian bit order), without padding, and together may
//! not exceed 64 bits (the eight data bytes of a classic CAN frame).
//!
//! Dummy mapping: an entry whose index is a data type index 0x0001..=0x0007 (BOOLEAN,
//! INTEGER8/16/32, UNSIGNED8/16/32) reserves room without an object behind it; on reception its
//! bits are skipped, on transmission they are zero. Which dummy types a device accepts is its EDS
//! `[DummyUsage]` section ([`Catalog::dummy_supported`]).
//!
//! A CAN FD mapping ([`crate::fd`]) passes the same checks under its own length limit: they
//! are written once here, generic over the mapping type.

use heapless::Vec;

use crate::comm::Direction;
use crate::dictionary::{Catalog, Dictionary, ObjectAddress, ReadError};

/// Most objects one PDO maps (sub-indices 1..=64).
pub const MAX_ENTRIES: usize = 64;
/// Most bits one PDO carries (eight data bytes).
pub const MAX_BITS: u32 = 64;

/// One raw mapping entry, `index << 16 | subindex << 8 | length`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MappingEntry(pub u32);

impl MappingEntry {
    /// Builds the entry from its parts.
    pub const fn new(index: u16, subindex: u8, bits: u8) -> Self {
        Self((index as u32) << 16 | (subindex as u32) << 8 | bits as u32)
    }

    /// The mapped object's index.
    pub const fn index(self) -> u16 {
        (self.0 >> 16) as u16
    }

    /// The mapped object's sub-index.
    pub const fn subindex(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// The mapped length in bits.
    pub const fn bits(self) -> u8 {
        self.0 as u8
    }

    /// The mapped object.
    pub const fn addr(self) -> ObjectAddress {
        ObjectAddress::new(self.index(), self.subindex())
    }

    /// Whether this is a dummy entry (index 0x0001..=0x0007, a data type).
    pub const fn is_dummy(self) -> bool {
        matches!(self.index(), 0x0001..=0x0007)
    }
}

/// How the bits of a mapped object are turned into a [`crate::RawValue`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ValueKind {
    /// BOOLEAN.
    Boolean,
    /// UNSIGNED8..UNSIGNED64, including 24/40/48/56 bits; also unknown types.
    Unsigned,
    /// INTEGER8..INTEGER64, sign-extended from the mapped length.
    Signed,
    /// REAL32 (32 bits).
    Real32,
    /// REAL64 (64 bits).
    Real64,
    /// Strings, OCTET_STRING, DOMAIN, TIME_OF_DAY, TIME_DIFFERENCE: raw bytes.
    Bytes,
}

impl ValueKind {
    /// The kind for a CiA 301 data type index; unknown indices are treated as unsigned.
    pub const fn from_data_type(data_type: u16) -> Self {
        match data_type {
            0x0001 => Self::Boolean,
            0x0002..=0x0004 | 0x0010 | 0x0012..=0x0015 => Self::Signed,
            0x0008 => Self::Real32,
            0x0011 => Self::Real64,
            0x0009..=0x000D | 0x000F => Self::Bytes,
            _ => Self::Unsigned,
        }
    }

    /// Whether a mapping of this kind must be a whole number of bytes.
    pub const fn needs_whole_bytes(self) -> bool {
        matches!(self, Self::Bytes)
    }
}

/// Bit size of the dummy mapping data types 0x0001..=0x0007.
pub(crate) const fn dummy_bits(data_type: u16) -> Option<u8> {
    match data_type {
        0x0001 => Some(1),
        0x0002 | 0x0005 => Some(8),
        0x0003 | 0x0006 => Some(16),
        0x0004 | 0x0007 => Some(32),
        _ => None,
    }
}

/// The checks of one entry on its own: not empty, fixed-width kinds with their width (BOOLEAN 1
/// or 8, REAL32 32, REAL64 64 bits), bytes in whole bytes.
fn check_entry_shape(entry: MappingEntry, kind: ValueKind) -> Result<(), MappingError> {
    if entry.bits() == 0 {
        return Err(MappingError::ZeroLength(entry.addr()));
    }
    // A kind with a fixed width must be mapped with exactly that width, so decoding and
    // encoding stay lossless. A BOOLEAN is one bit (CiA 301) or, as many devices map it,
    // one byte: the entry's length decides.
    let fixed = match kind {
        ValueKind::Boolean if entry.bits() == 8 => None,
        ValueKind::Boolean => Some(1),
        ValueKind::Real32 => Some(32),
        ValueKind::Real64 => Some(64),
        ValueKind::Bytes if !entry.bits().is_multiple_of(8) => {
            return Err(MappingError::NotWholeBytes {
                addr: entry.addr(),
                mapped_bits: entry.bits(),
            });
        }
        _ => None,
    };
    if let Some(width) = fixed
        && width != entry.bits()
    {
        return Err(MappingError::LengthMismatch {
            addr: entry.addr(),
            object_bits: width as u16,
            mapped_bits: entry.bits(),
        });
    }
    Ok(())
}

/// One mapped object with its place in the PDO and how to read its bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MappedObject {
    /// The raw mapping entry.
    pub entry: MappingEntry,
    /// Bit offset of the object inside the PDO data.
    pub offset: u8,
    /// How its bits become a value.
    pub kind: ValueKind,
    /// The object's bits in the PDO data word (precomputed for the receive hot path).
    mask: u64,
}

impl MappedObject {
    /// The mapped object.
    pub const fn addr(&self) -> ObjectAddress {
        self.entry.addr()
    }

    /// The mapped length in bits.
    pub const fn bits(&self) -> u8 {
        self.entry.bits()
    }

    /// Bytes needed to hold the value: `ceil(bits / 8)`.
    pub const fn byte_len(&self) -> usize {
        (self.entry.bits() as usize).div_ceil(8)
    }

    /// Whether the entry is a dummy (no object behind it).
    pub const fn is_dummy(&self) -> bool {
        self.entry.is_dummy()
    }

    /// Mask of the object's bits in the PDO data read as a little-endian `u64`.
    #[inline]
    pub const fn mask(&self) -> u64 {
        self.mask
    }
}

/// `bits` low bits set (0..=64).
#[inline]
pub(crate) const fn field_mask(bits: u8) -> u64 {
    if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    }
}

/// A validated PDO mapping: at most 64 entries, at most 64 bits, no zero-length entry.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct Mapping {
    objects: Vec<MappedObject, MAX_ENTRIES>,
    bits: u8,
}

/// Why a mapping is not acceptable. Named after what the device would answer (SDO abort
/// 0x0604_0041 "object cannot be mapped", 0x0604_0042 "would exceed PDO length", ...).
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MappingError {
    /// More than 64 entries (or sub 0 above 64 and not an MPDO code).
    #[error("{0} mapping entries; a PDO maps at most 64")]
    TooManyEntries(usize),
    /// The entries add up to more than 64 bits (the eight data bytes of a classic CAN frame).
    #[error(
        "the mapped objects need {0} bits ({bytes} bytes); a classic CAN PDO carries at most 64 \
         bits (8 bytes)",
        bytes = .0.div_ceil(8)
    )]
    TooLong(u32),
    /// The entries of a CAN FD PDO add up to more than 512 bits (64 data bytes).
    #[error(
        "the mapped objects need {0} bits ({bytes} bytes); a CAN FD PDO carries at most 512 bits \
         (64 bytes)",
        bytes = .0.div_ceil(8)
    )]
    FdTooLong(u32),
    /// One entry of a CAN FD PDO longer than 64 bits (the packer holds each value in 64 bits).
    #[error("mapping entry {addr} has {mapped_bits} bits; one mapped object holds at most 64")]
    EntryTooLong {
        /// The object.
        addr: ObjectAddress,
        /// The length in the mapping entry.
        mapped_bits: u8,
    },
    /// An entry of length 0.
    #[error("mapping entry {0} has length 0")]
    ZeroLength(ObjectAddress),
    /// The mapped object does not exist.
    #[error("mapped object {0} does not exist")]
    NoSuchObject(ObjectAddress),
    /// The object's PDO mapping flag is not set.
    #[error("object {0} is not PDO-mappable")]
    NotMappable(ObjectAddress),
    /// An RPDO maps an object that is not writable, or a TPDO one that is not readable.
    #[error("object {addr} cannot be mapped into a {} PDO: access type forbids it", match direction { Direction::Receive => "receive", Direction::Transmit => "transmit" })]
    AccessDenied {
        /// The object.
        addr: ObjectAddress,
        /// The PDO's direction.
        direction: Direction,
    },
    /// The mapped length differs from the object's size.
    #[error("object {addr} has {object_bits} bits but is mapped with {mapped_bits}")]
    LengthMismatch {
        /// The object.
        addr: ObjectAddress,
        /// Its size.
        object_bits: u16,
        /// The length in the mapping entry.
        mapped_bits: u8,
    },
    /// A string/domain object mapped with a length that is not a whole number of bytes.
    #[error("object {addr} must be mapped in whole bytes, not {mapped_bits} bits")]
    NotWholeBytes {
        /// The object.
        addr: ObjectAddress,
        /// The length in the mapping entry.
        mapped_bits: u8,
    },
    /// A dummy entry for a data type the device does not support as dummy.
    #[error("dummy mapping of data type {0:#06x} is not supported")]
    DummyNotSupported(u16),
    /// Sub 0 is 0xFE (SAM-MPDO) or 0xFF (DAM-MPDO): not a plain mapping.
    #[error("mapping sub 0 = {0:#04x} selects an MPDO, not a mapped PDO")]
    Mpdo(u8),
    /// A mapping parameter could not be read.
    #[error("reading the mapping failed: {0}")]
    Read(ReadError),
}

debug_as_display!(MappingError);

impl From<ReadError> for MappingError {
    fn from(e: ReadError) -> Self {
        Self::Read(e)
    }
}

impl Mapping {
    /// An empty mapping (a disabled PDO).
    pub const fn new() -> Self {
        Self {
            objects: Vec::new(),
            bits: 0,
        }
    }

    /// Appends an object of `kind`. Checks the entry count, the zero length, the 64-bit limit and
    /// that fixed-width kinds have their width (BOOLEAN 1, REAL32 32, REAL64 64 bits; bytes whole
    /// bytes) — not the dictionary; see [`Mapping::from_raw_checked`].
    pub fn push(&mut self, entry: MappingEntry, kind: ValueKind) -> Result<(), MappingError> {
        push_checked(self, entry, kind)
    }

    /// Builder form of [`Mapping::push`].
    pub fn with(mut self, entry: MappingEntry, kind: ValueKind) -> Result<Self, MappingError> {
        self.push(entry, kind)?;
        Ok(self)
    }

    /// A mapping from raw entries without a dictionary: dummy entries of their type's size get
    /// their data type's kind, every other entry is read as [`ValueKind::Unsigned`].
    pub fn from_raw(entries: &[u32]) -> Result<Self, MappingError> {
        mapping_from_raw(entries)
    }

    /// A mapping from raw entries checked against a dictionary for a PDO of `direction`: every
    /// object exists, is PDO-mappable, has the access the direction needs (RPDO: writable,
    /// TPDO: readable) and is mapped with its own size (strings and domains: whole bytes, at
    /// most their size); dummy entries are of a supported type and size. Kinds come from the
    /// objects' data types.
    pub fn from_raw_checked<C: Catalog + ?Sized>(
        direction: Direction,
        entries: &[u32],
        catalog: &C,
    ) -> Result<Self, MappingError> {
        mapping_from_raw_checked(direction, entries, catalog)
    }

    /// Reads mapping object `index` (sub 0, then sub 1..=n) from a dictionary and checks it as
    /// [`Mapping::from_raw_checked`] does.
    pub fn read_from<D: Dictionary + ?Sized>(
        dict: &D,
        direction: Direction,
        index: u16,
    ) -> Result<Self, MappingError> {
        read_mapping(dict, direction, index)
    }

    /// The mapped objects in PDO order.
    pub fn objects(&self) -> &[MappedObject] {
        &self.objects
    }

    /// The raw entries in PDO order (the values of sub 1..=n).
    pub fn raw_entries(&self) -> impl Iterator<Item = u32> + '_ {
        self.objects.iter().map(|o| o.entry.0)
    }

    /// Number of mapped objects (the value of sub 0).
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether nothing is mapped (the PDO is disabled).
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Total mapped length in bits.
    pub const fn bit_len(&self) -> u32 {
        self.bits as u32
    }

    /// Data bytes of the PDO: `ceil(bits / 8)`.
    pub const fn byte_len(&self) -> usize {
        (self.bits as usize).div_ceil(8)
    }
}

/// A BOOLEAN mapped with 8 bits: accepted beside CiA 301's 1 bit, since many devices map it so.
const fn boolean_as_byte(kind: ValueKind, bits: u8) -> bool {
    matches!(kind, ValueKind::Boolean) && bits == 8
}

fn check_entry<C: Catalog + ?Sized>(
    direction: Direction,
    e: MappingEntry,
    catalog: &C,
) -> Result<ValueKind, MappingError> {
    let addr = e.addr();
    if e.bits() == 0 {
        return Err(MappingError::ZeroLength(addr));
    }
    if e.is_dummy() {
        if !catalog.dummy_supported(e.index()) {
            return Err(MappingError::DummyNotSupported(e.index()));
        }
        return match dummy_bits(e.index()) {
            Some(b) if b == e.bits() => Ok(ValueKind::from_data_type(e.index())),
            Some(b) => Err(MappingError::LengthMismatch {
                addr,
                object_bits: b as u16,
                mapped_bits: e.bits(),
            }),
            None => Err(MappingError::DummyNotSupported(e.index())),
        };
    }
    let info = catalog
        .object_info(addr)
        .ok_or(MappingError::NoSuchObject(addr))?;
    if !info.pdo_mappable {
        return Err(MappingError::NotMappable(addr));
    }
    let allowed = match direction {
        Direction::Receive => info.writable,
        Direction::Transmit => info.readable,
    };
    if !allowed {
        return Err(MappingError::AccessDenied { addr, direction });
    }
    let kind = ValueKind::from_data_type(info.data_type);
    if kind.needs_whole_bytes() {
        if !e.bits().is_multiple_of(8) {
            return Err(MappingError::NotWholeBytes {
                addr,
                mapped_bits: e.bits(),
            });
        }
        if e.bits() as u16 > info.bits {
            return Err(MappingError::LengthMismatch {
                addr,
                object_bits: info.bits,
                mapped_bits: e.bits(),
            });
        }
    } else if e.bits() as u16 != info.bits && !boolean_as_byte(kind, e.bits()) {
        return Err(MappingError::LengthMismatch {
            addr,
            object_bits: info.bits,
            mapped_bits: e.bits(),
        });
    }
    Ok(kind)
}

/// How an entry is read when no dictionary says: a dummy entry of its type's size as that type,
/// every other entry as [`ValueKind::Unsigned`] (the `from_raw` constructors).
fn raw_entry_kind(e: MappingEntry) -> ValueKind {
    if dummy_bits(e.index()) == Some(e.bits()) {
        ValueKind::from_data_type(e.index())
    } else {
        ValueKind::Unsigned
    }
}

/// Most bits one mapped object holds (the packer keeps each value in 64 bits).
const MAX_OBJECT_BITS: u32 = 64;

/// A PDO mapping under its length limit: [`Mapping`] (classic CAN, 64 bits) or
/// [`FdMapping`](crate::FdMapping) (CAN FD, 512 bits). The entries of both are validated by
/// the functions below ([`push_checked`] and the readers built on it); each type only says its
/// limit and stores what passed.
pub(crate) trait PdoMapping: Sized {
    /// Most bits the PDO carries.
    const MAX_BITS: u32;

    /// The error of entries that add up to `bits`, more than [`MAX_BITS`](Self::MAX_BITS).
    fn too_long(bits: u32) -> MappingError;

    /// A mapping without entries.
    fn empty() -> Self;

    /// The bits mapped so far, and the number of entries.
    fn used(&self) -> (u32, usize);

    /// Appends `entry` after the objects mapped so far. [`push_checked`] calls it once the
    /// entry passed every check, so it fits: there is room for one more entry and its bits.
    fn append(&mut self, entry: MappingEntry, kind: ValueKind);
}

/// Appends an object of `kind` to `m` after the checks of [`Mapping::push`] under `M`'s
/// length limit, in this order: the entry's shape; an object longer than 64 bits (the packer
/// holds each value in 64 bits; in a classic PDO the total below says it); the total length;
/// the entry count.
pub(crate) fn push_checked<M: PdoMapping>(
    m: &mut M,
    entry: MappingEntry,
    kind: ValueKind,
) -> Result<(), MappingError> {
    check_entry_shape(entry, kind)?;
    if M::MAX_BITS > MAX_OBJECT_BITS && u32::from(entry.bits()) > MAX_OBJECT_BITS {
        return Err(MappingError::EntryTooLong {
            addr: entry.addr(),
            mapped_bits: entry.bits(),
        });
    }
    let (bits, count) = m.used();
    let total = bits + u32::from(entry.bits());
    if total > M::MAX_BITS {
        return Err(M::too_long(total));
    }
    if count >= MAX_ENTRIES {
        return Err(MappingError::TooManyEntries(MAX_ENTRIES + 1));
    }
    m.append(entry, kind);
    Ok(())
}

/// A mapping from raw entries without a dictionary (see [`Mapping::from_raw`]).
pub(crate) fn mapping_from_raw<M: PdoMapping>(entries: &[u32]) -> Result<M, MappingError> {
    if entries.len() > MAX_ENTRIES {
        return Err(MappingError::TooManyEntries(entries.len()));
    }
    let mut m = M::empty();
    for &raw in entries {
        let e = MappingEntry(raw);
        push_checked(&mut m, e, raw_entry_kind(e))?;
    }
    Ok(m)
}

/// A mapping from raw entries checked against `catalog` (see [`Mapping::from_raw_checked`]).
pub(crate) fn mapping_from_raw_checked<M: PdoMapping, C: Catalog + ?Sized>(
    direction: Direction,
    entries: &[u32],
    catalog: &C,
) -> Result<M, MappingError> {
    if entries.len() > MAX_ENTRIES {
        return Err(MappingError::TooManyEntries(entries.len()));
    }
    let mut m = M::empty();
    for &raw in entries {
        let e = MappingEntry(raw);
        let kind = check_entry(direction, e, catalog)?;
        push_checked(&mut m, e, kind)?;
    }
    Ok(m)
}

/// Mapping parameter object `index` read from `dict` and checked (see [`Mapping::read_from`]);
/// sub 0 = 0xFE or 0xFF (an MPDO) is [`MappingError::Mpdo`].
pub(crate) fn read_mapping<M: PdoMapping, D: Dictionary + ?Sized>(
    dict: &D,
    direction: Direction,
    index: u16,
) -> Result<M, MappingError> {
    let count = dict.read_u32(index, 0)?;
    match count {
        0xFE | 0xFF => return Err(MappingError::Mpdo(count as u8)),
        n if n as usize > MAX_ENTRIES => {
            return Err(MappingError::TooManyEntries(n as usize));
        }
        _ => {}
    }
    let mut raw: Vec<u32, MAX_ENTRIES> = Vec::new();
    for sub in 1..=count as u8 {
        // `count` is at most 64, so the push cannot fail.
        let _ = raw.push(dict.read_u32(index, sub)?);
    }
    mapping_from_raw_checked(direction, &raw, dict)
}

impl PdoMapping for Mapping {
    const MAX_BITS: u32 = MAX_BITS;

    fn too_long(bits: u32) -> MappingError {
        MappingError::TooLong(bits)
    }

    fn empty() -> Self {
        Self::new()
    }

    fn used(&self) -> (u32, usize) {
        (self.bit_len(), self.len())
    }

    fn append(&mut self, entry: MappingEntry, kind: ValueKind) {
        let obj = MappedObject {
            entry,
            offset: self.bits,
            kind,
            mask: field_mask(entry.bits()) << self.bits,
        };
        // Cannot fail: `push_checked` found room for one more entry.
        let _ = self.objects.push(obj);
        // At most 64: `push_checked` checked the total.
        self.bits += entry.bits();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dictionary::ObjectInfo;

    struct Cat;
    impl Catalog for Cat {
        fn object_info(&self, addr: ObjectAddress) -> Option<ObjectInfo> {
            let (data_type, bits, mappable, r, w) = match (addr.index, addr.sub_index) {
                (0x6000, 1) => (0x0005, 8, true, true, false), // U8 ro
                (0x6200, 1) => (0x0005, 8, true, true, true),  // U8 rw
                (0x6401, 1) => (0x0003, 16, true, true, false), // I16 ro
                (0x2000, 0) => (0x0007, 32, false, true, true), // not mappable
                (0x2001, 0) => (0x0009, 48, true, true, true), // VISIBLE_STRING, 6 bytes
                (0x2002, 0) => (0x0010, 24, true, true, true), // INTEGER24
                _ => return None,
            };
            Some(ObjectInfo {
                data_type,
                bits,
                pdo_mappable: mappable,
                readable: r,
                writable: w,
            })
        }
        fn dummy_supported(&self, dt: u16) -> bool {
            dt != 0x0001
        }
    }

    #[test]
    fn entry_fields() {
        let e = MappingEntry(0x6000_0108);
        assert_eq!(e.index(), 0x6000);
        assert_eq!(e.subindex(), 1);
        assert_eq!(e.bits(), 8);
        assert_eq!(MappingEntry::new(0x6000, 1, 8), e);
        assert!(MappingEntry(0x0005_0008).is_dummy());
        assert!(!MappingEntry(0x0008_0020).is_dummy());
    }

    #[test]
    fn offsets_accumulate() {
        let m = Mapping::from_raw(&[0x6000_0101, 0x6000_0207, 0x6401_0110]).unwrap();
        let offs: std::vec::Vec<u8> = m.objects().iter().map(|o| o.offset).collect();
        assert_eq!(offs, [0, 1, 8]);
        assert_eq!(m.bit_len(), 24);
        assert_eq!(m.byte_len(), 3);
    }

    #[test]
    fn kinds_keep_their_width() {
        let mut m = Mapping::new();
        assert!(matches!(
            m.push(MappingEntry(0x2000_0110), ValueKind::Boolean),
            Err(MappingError::LengthMismatch { object_bits: 1, .. })
        ));
        // A BOOLEAN is one bit or, as many devices map it, one byte.
        m.push(MappingEntry(0x2000_0101), ValueKind::Boolean)
            .unwrap();
        m.push(MappingEntry(0x2000_0208), ValueKind::Boolean)
            .unwrap();
        let mut m = Mapping::new();
        assert!(matches!(
            m.push(MappingEntry(0x2000_0110), ValueKind::Real32),
            Err(MappingError::LengthMismatch {
                object_bits: 32,
                ..
            })
        ));
        assert!(matches!(
            m.push(MappingEntry(0x2000_010C), ValueKind::Bytes),
            Err(MappingError::NotWholeBytes { .. })
        ));
        // An odd-sized "dummy" without a catalog is just unsigned bits.
        let m = Mapping::from_raw(&[0x0001_0009]).unwrap();
        assert_eq!(m.objects()[0].kind, ValueKind::Unsigned);
        let m = Mapping::from_raw(&[0x0001_0001]).unwrap();
        assert_eq!(m.objects()[0].kind, ValueKind::Boolean);
    }

    #[test]
    fn limits() {
        assert_eq!(
            Mapping::from_raw(&[0x6000_0120, 0x6000_0220, 0x6000_0301]),
            Err(MappingError::TooLong(65))
        );
        // One object longer than 64 bits: in a classic PDO it is the total that is too long.
        assert_eq!(
            Mapping::from_raw(&[0x6000_0148]),
            Err(MappingError::TooLong(72))
        );
        assert_eq!(
            Mapping::from_raw(&[0x6000_0100]),
            Err(MappingError::ZeroLength(ObjectAddress::new(0x6000, 1)))
        );
        let bits = [0x6000_0101u32; 65];
        assert_eq!(
            Mapping::from_raw(&bits),
            Err(MappingError::TooManyEntries(65))
        );
        assert_eq!(Mapping::from_raw(&bits[..64]).unwrap().bit_len(), 64);
    }

    #[test]
    fn checked_against_catalog() {
        let tx = Direction::Transmit;
        let rx = Direction::Receive;
        assert!(Mapping::from_raw_checked(tx, &[0x6000_0108, 0x6401_0110], &Cat).is_ok());
        assert_eq!(
            Mapping::from_raw_checked(rx, &[0x6000_0108], &Cat),
            Err(MappingError::AccessDenied {
                addr: ObjectAddress::new(0x6000, 1),
                direction: rx
            })
        );
        assert!(Mapping::from_raw_checked(rx, &[0x6200_0108], &Cat).is_ok());
        assert_eq!(
            Mapping::from_raw_checked(tx, &[0x2000_0020], &Cat),
            Err(MappingError::NotMappable(ObjectAddress::new(0x2000, 0)))
        );
        assert_eq!(
            Mapping::from_raw_checked(tx, &[0x7000_0108], &Cat),
            Err(MappingError::NoSuchObject(ObjectAddress::new(0x7000, 1)))
        );
        assert_eq!(
            Mapping::from_raw_checked(tx, &[0x6401_0108], &Cat),
            Err(MappingError::LengthMismatch {
                addr: ObjectAddress::new(0x6401, 1),
                object_bits: 16,
                mapped_bits: 8
            })
        );
        assert_eq!(
            Mapping::from_raw_checked(tx, &[0x2001_000C], &Cat),
            Err(MappingError::NotWholeBytes {
                addr: ObjectAddress::new(0x2001, 0),
                mapped_bits: 12
            })
        );
        let s = Mapping::from_raw_checked(tx, &[0x2001_0020, 0x2002_0018], &Cat).unwrap();
        assert_eq!(s.objects()[0].kind, ValueKind::Bytes);
        assert_eq!(s.objects()[1].kind, ValueKind::Signed);
        // Dummies: UNSIGNED16 fine, BOOLEAN not supported by this device, wrong size refused.
        assert!(Mapping::from_raw_checked(rx, &[0x0006_0010, 0x6200_0108], &Cat).is_ok());
        assert_eq!(
            Mapping::from_raw_checked(rx, &[0x0001_0001], &Cat),
            Err(MappingError::DummyNotSupported(1))
        );
        assert!(matches!(
            Mapping::from_raw_checked(rx, &[0x0006_0008], &Cat),
            Err(MappingError::LengthMismatch { .. })
        ));
    }

    extern crate std;
}
