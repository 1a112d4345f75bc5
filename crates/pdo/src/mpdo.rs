//! Multiplexed PDOs (CiA 301 §7.2.3): one COB-ID carrying one object per frame, addressed by
//! index and sub-index.
//!
//! Frame (always 8 data bytes): `[addr, index lo, index hi, subindex, data0, data1, data2,
//! data3]`, data up to 32 bits, little-endian, unused data bytes zero.
//! - `addr` bit 7 clear: SAM-MPDO (source address mode); bits 6..0 are the producer's node-ID
//!   and index/sub-index name the *producer's* object. The producer walks its object scanner
//!   list (0x1FA0..=0x1FCF); a consumer maps the producer's object to a local one through its
//!   object dispatcher list (0x1FD0..=0x1FFF).
//! - `addr` bit 7 set: DAM-MPDO (destination address mode); bits 6..0 are the destination
//!   node-ID (0 = all nodes) and index/sub-index name the *consumer's* object directly.
//!
//! A PDO is an MPDO when its mapping parameter sub 0 is 0xFE (SAM) or 0xFF (DAM); MPDOs are
//! event-driven (transmission type 254/255). Routing the MPDO COB-ID to [`MpdoConsumer`] is the
//! caller's job (the [`crate::Engine`] handles mapped PDOs only).
//!
//! Scanner entry (UNSIGNED32): bits 31..24 block size, 23..8 index, 7..0 sub-index.
//! Dispatcher entry (UNSIGNED64): bits 63..56 block size, 55..40 local index, 39..32 local
//! sub-index, 31..16 producer index, 15..8 producer sub-index, 7..0 producer node-ID.
//! A block covers `block size` consecutive sub-indices; this crate reads a block size of 0 as 1
//! (the entry names its own object) and ignores entries whose index is 0 (unused).

use canola_frame::{CanFrame, CanId, NodeId};
use heapless::Vec;

use crate::dictionary::{Dictionary, ObjectAddress, ObjectStore, ReadError, StoreError};

/// First object scanner list object.
pub const SCANNER_LIST_FIRST: u16 = 0x1FA0;
/// Last object scanner list object.
pub const SCANNER_LIST_LAST: u16 = 0x1FCF;
/// First object dispatcher list object.
pub const DISPATCHER_LIST_FIRST: u16 = 0x1FD0;
/// Last object dispatcher list object.
pub const DISPATCHER_LIST_LAST: u16 = 0x1FFF;
/// Mapping sub 0 of a SAM-MPDO.
pub const MAPPING_SAM: u8 = 0xFE;
/// Mapping sub 0 of a DAM-MPDO.
pub const MAPPING_DAM: u8 = 0xFF;

/// Byte 0 of an MPDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MpdoAddress {
    /// Source address mode: the producer's node-ID.
    Source(NodeId),
    /// Destination address mode: the destination node, `None` for all nodes.
    Destination(Option<NodeId>),
}

/// One decoded MPDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Mpdo {
    /// Mode and node.
    pub address: MpdoAddress,
    /// Object index (producer's in SAM, consumer's in DAM).
    pub index: u16,
    /// Object sub-index.
    pub subindex: u8,
    /// The four data bytes.
    pub data: [u8; 4],
}

/// An MPDO that cannot be decoded or built.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MpdoError {
    /// An MPDO has exactly eight data bytes.
    #[error("an MPDO has 8 data bytes, not {0}")]
    Length(usize),
    /// A SAM-MPDO from node-ID 0.
    #[error("SAM-MPDO with producer node-ID 0")]
    NoProducer,
    /// More than four data bytes for one MPDO.
    #[error("MPDO data is at most 4 bytes, not {0}")]
    DataTooLong(usize),
    /// The object is not in the producer's scanner list.
    #[error("object {0} is not in the object scanner list")]
    NotScanned(ObjectAddress),
    /// The scanner list is empty.
    #[error("the object scanner list is empty")]
    EmptyScannerList,
    /// The list has no room for another entry.
    #[error("the list is full")]
    ListFull,
    /// The store refused.
    #[error("object {addr}: {error}")]
    Store {
        /// The object.
        addr: ObjectAddress,
        /// The store's reason.
        error: StoreError,
    },
    /// Reading a list from a dictionary failed.
    #[error(transparent)]
    Read(#[from] ReadError),
}

debug_as_display!(MpdoError);

mod field {
    pub(super) const ADDR: usize = 0;
    pub(super) const INDEX: core::ops::Range<usize> = 1..3;
    pub(super) const SUBINDEX: usize = 3;
    pub(super) const DATA: core::ops::Range<usize> = 4..8;
    pub(super) const DAM_BIT: u8 = 0x80;
}

impl Mpdo {
    /// Decodes MPDO data bytes. Total: never panics.
    pub fn parse(data: &[u8]) -> Result<Self, MpdoError> {
        let bytes: &[u8; 8] = data.try_into().map_err(|_| MpdoError::Length(data.len()))?;
        let a = bytes[field::ADDR];
        let node = a & 0x7F;
        let address = if a & field::DAM_BIT != 0 {
            MpdoAddress::Destination(NodeId::new(node).ok())
        } else {
            MpdoAddress::Source(NodeId::new(node).map_err(|_| MpdoError::NoProducer)?)
        };
        let mut d = [0u8; 4];
        d.copy_from_slice(&bytes[field::DATA]);
        Ok(Self {
            address,
            index: u16::from_le_bytes([bytes[field::INDEX.start], bytes[field::INDEX.end - 1]]),
            subindex: bytes[field::SUBINDEX],
            data: d,
        })
    }

    /// Encodes the eight data bytes.
    pub fn emit(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        out[field::ADDR] = match self.address {
            MpdoAddress::Source(n) => n.get(),
            MpdoAddress::Destination(n) => field::DAM_BIT | n.map_or(0, NodeId::get),
        };
        out[field::INDEX].copy_from_slice(&self.index.to_le_bytes());
        out[field::SUBINDEX] = self.subindex;
        out[field::DATA].copy_from_slice(&self.data);
        out
    }

    /// The frame on `cob_id`.
    pub fn to_frame(&self, cob_id: CanId) -> CanFrame {
        CanFrame::from_array(cob_id, self.emit())
    }

    /// The object named in the frame.
    pub const fn addr(&self) -> ObjectAddress {
        ObjectAddress::new(self.index, self.subindex)
    }

    /// A DAM-MPDO writing `value` (at most 4 bytes, little-endian) into `addr` of `destination`
    /// (`None`: every node).
    pub fn dam(
        destination: Option<NodeId>,
        addr: ObjectAddress,
        value: &[u8],
    ) -> Result<Self, MpdoError> {
        if value.len() > 4 {
            return Err(MpdoError::DataTooLong(value.len()));
        }
        let mut data = [0u8; 4];
        data[..value.len()].copy_from_slice(value);
        Ok(Self {
            address: MpdoAddress::Destination(destination),
            index: addr.index,
            subindex: addr.sub_index,
            data,
        })
    }
}

/// An object scanner list entry (UNSIGNED32).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScannerEntry(pub u32);

impl ScannerEntry {
    /// Builds an entry for `block` sub-indices starting at `index:subindex`.
    pub const fn new(block: u8, index: u16, subindex: u8) -> Self {
        Self((block as u32) << 24 | (index as u32) << 8 | subindex as u32)
    }

    /// Number of consecutive sub-indices (0 read as 1).
    pub const fn block_size(self) -> u8 {
        let b = (self.0 >> 24) as u8;
        if b == 0 { 1 } else { b }
    }

    /// Object index.
    pub const fn index(self) -> u16 {
        (self.0 >> 8) as u16
    }

    /// First sub-index.
    pub const fn subindex(self) -> u8 {
        self.0 as u8
    }

    /// Whether the entry is unused (index 0).
    pub const fn is_unused(self) -> bool {
        self.index() == 0
    }

    /// Whether the entry covers `addr`.
    pub fn covers(self, addr: ObjectAddress) -> bool {
        !self.is_unused()
            && addr.index == self.index()
            && addr.sub_index >= self.subindex()
            && (addr.sub_index - self.subindex()) < self.block_size()
    }
}

/// An object dispatcher list entry (UNSIGNED64).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DispatcherEntry(pub u64);

impl DispatcherEntry {
    /// Builds an entry: `block` sub-indices of the producer's `producer_index:producer_sub`
    /// from `producer` land in `local_index:local_sub` onward.
    pub const fn new(
        block: u8,
        local_index: u16,
        local_sub: u8,
        producer_index: u16,
        producer_sub: u8,
        producer: u8,
    ) -> Self {
        Self(
            (block as u64) << 56
                | (local_index as u64) << 40
                | (local_sub as u64) << 32
                | (producer_index as u64) << 16
                | (producer_sub as u64) << 8
                | producer as u64,
        )
    }

    /// Number of consecutive sub-indices (0 read as 1).
    pub const fn block_size(self) -> u8 {
        let b = (self.0 >> 56) as u8;
        if b == 0 { 1 } else { b }
    }

    /// The first local object.
    pub const fn local(self) -> ObjectAddress {
        ObjectAddress::new((self.0 >> 40) as u16, (self.0 >> 32) as u8)
    }

    /// The producer's first object.
    pub const fn producer_object(self) -> ObjectAddress {
        ObjectAddress::new((self.0 >> 16) as u16, (self.0 >> 8) as u8)
    }

    /// The producer's node-ID byte.
    pub const fn producer_node(self) -> u8 {
        self.0 as u8
    }

    /// The local object a SAM-MPDO of `producer` about its `object` goes to, if this entry
    /// covers it.
    pub fn dispatch(self, producer: NodeId, object: ObjectAddress) -> Option<ObjectAddress> {
        let first = self.producer_object();
        if first.index == 0 || self.producer_node() != producer.get() || object.index != first.index
        {
            return None;
        }
        let offset = object.sub_index.checked_sub(first.sub_index)?;
        if offset >= self.block_size() {
            return None;
        }
        let local = self.local();
        Some(ObjectAddress::new(
            local.index,
            local.sub_index.checked_add(offset)?,
        ))
    }
}

/// A SAM-MPDO producer: its node-ID and object scanner list (up to `N` entries).
#[derive(Debug, Clone)]
pub struct SamProducer<const N: usize> {
    node: NodeId,
    list: Vec<ScannerEntry, N>,
    /// Next entry and sub-index offset within its block for [`SamProducer::next`].
    cursor: (usize, u8),
}

impl<const N: usize> SamProducer<N> {
    /// A producer with an empty scanner list.
    pub const fn new(node: NodeId) -> Self {
        Self {
            node,
            list: Vec::new(),
            cursor: (0, 0),
        }
    }

    /// Appends a scanner list entry (unused entries are skipped).
    pub fn push(&mut self, entry: ScannerEntry) -> Result<(), MpdoError> {
        if entry.is_unused() {
            return Ok(());
        }
        self.list.push(entry).map_err(|_| MpdoError::ListFull)
    }

    /// Appends the entries of scanner list object `index` (sub 0 = count, sub 1.. = entries).
    pub fn read_from<D: Dictionary + ?Sized>(
        &mut self,
        dict: &D,
        index: u16,
    ) -> Result<(), MpdoError> {
        let n = dict.read_u32(index, 0)?.min(254) as u8;
        for sub in 1..=n {
            self.push(ScannerEntry(dict.read_u32(index, sub)?))?;
        }
        Ok(())
    }

    /// The scanner list.
    pub fn entries(&self) -> &[ScannerEntry] {
        &self.list
    }

    /// The MPDO for one object, which must be in the scanner list (an application event on it).
    pub fn produce<S: ObjectStore + ?Sized>(
        &self,
        addr: ObjectAddress,
        store: &mut S,
    ) -> Result<Mpdo, MpdoError> {
        if !self.list.iter().any(|e| e.covers(addr)) {
            return Err(MpdoError::NotScanned(addr));
        }
        self.frame(addr, store)
    }

    /// The MPDO for the next object of the scanner list, walking it cyclically, one object per
    /// frame (block entries yield each sub-index in turn).
    pub fn next<S: ObjectStore + ?Sized>(&mut self, store: &mut S) -> Result<Mpdo, MpdoError> {
        let (mut i, mut off) = self.cursor;
        let entry = match self.list.get(i) {
            Some(e) => *e,
            None => {
                i = 0;
                off = 0;
                *self.list.first().ok_or(MpdoError::EmptyScannerList)?
            }
        };
        let addr = ObjectAddress::new(entry.index(), entry.subindex().wrapping_add(off));
        off += 1;
        self.cursor = if off >= entry.block_size() || entry.subindex().checked_add(off).is_none() {
            (i + 1, 0)
        } else {
            (i, off)
        };
        self.frame(addr, store)
    }

    fn frame<S: ObjectStore + ?Sized>(
        &self,
        addr: ObjectAddress,
        store: &mut S,
    ) -> Result<Mpdo, MpdoError> {
        let mut data = [0u8; 4];
        store
            .read(addr, &mut data)
            .map_err(|error| MpdoError::Store { addr, error })?;
        Ok(Mpdo {
            address: MpdoAddress::Source(self.node),
            index: addr.index,
            subindex: addr.sub_index,
            data,
        })
    }
}

/// What an MPDO consumer did with a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// The data was written to this local object.
    Written(ObjectAddress),
    /// A DAM-MPDO for another node, or a SAM-MPDO no dispatcher entry covers: ignored.
    Ignored,
}

/// An MPDO consumer: its own node-ID and object dispatcher list (up to `N` entries).
#[derive(Debug, Clone)]
pub struct MpdoConsumer<const N: usize> {
    node: NodeId,
    list: Vec<DispatcherEntry, N>,
}

impl<const N: usize> MpdoConsumer<N> {
    /// A consumer with an empty dispatcher list (it still takes DAM-MPDOs).
    pub const fn new(node: NodeId) -> Self {
        Self {
            node,
            list: Vec::new(),
        }
    }

    /// Appends a dispatcher list entry.
    pub fn push(&mut self, entry: DispatcherEntry) -> Result<(), MpdoError> {
        self.list.push(entry).map_err(|_| MpdoError::ListFull)
    }

    /// The dispatcher list.
    pub fn entries(&self) -> &[DispatcherEntry] {
        &self.list
    }

    /// The local object a SAM-MPDO about `object` from `producer` goes to.
    pub fn dispatch(&self, producer: NodeId, object: ObjectAddress) -> Option<ObjectAddress> {
        self.list.iter().find_map(|e| e.dispatch(producer, object))
    }

    /// Handles a decoded MPDO: a DAM-MPDO for this node (or all nodes) is written to the named
    /// object, a SAM-MPDO to the object its dispatcher entry names. The store gets the four
    /// data bytes and keeps as many as its object holds.
    pub fn handle<S: ObjectStore + ?Sized>(
        &self,
        mpdo: &Mpdo,
        store: &mut S,
    ) -> Result<Delivery, MpdoError> {
        let target = match mpdo.address {
            MpdoAddress::Destination(Some(n)) if n != self.node => return Ok(Delivery::Ignored),
            MpdoAddress::Destination(_) => mpdo.addr(),
            MpdoAddress::Source(producer) => match self.dispatch(producer, mpdo.addr()) {
                Some(local) => local,
                None => return Ok(Delivery::Ignored),
            },
        };
        store
            .write(target, &mpdo.data)
            .map_err(|error| MpdoError::Store {
                addr: target,
                error,
            })?;
        Ok(Delivery::Written(target))
    }

    /// Decodes and handles MPDO data bytes.
    pub fn handle_data<S: ObjectStore + ?Sized>(
        &self,
        data: &[u8],
        store: &mut S,
    ) -> Result<Delivery, MpdoError> {
        self.handle(&Mpdo::parse(data)?, store)
    }
}

#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;
    use crate::dictionary::MapStore;
    use proptest::prelude::*;

    fn n(x: u8) -> NodeId {
        NodeId::new(x).unwrap()
    }

    #[test]
    fn frame_layout() {
        let sam = Mpdo {
            address: MpdoAddress::Source(n(5)),
            index: 0x6000,
            subindex: 1,
            data: [0x11, 0x22, 0x33, 0x44],
        };
        assert_eq!(sam.emit(), [0x05, 0x00, 0x60, 0x01, 0x11, 0x22, 0x33, 0x44]);
        let dam = Mpdo::dam(Some(n(0x12)), ObjectAddress::new(0x6200, 2), &[0xAB]).unwrap();
        assert_eq!(dam.emit(), [0x92, 0x00, 0x62, 0x02, 0xAB, 0, 0, 0]);
        let all = Mpdo::dam(None, ObjectAddress::new(0x6200, 2), &[1, 2]).unwrap();
        assert_eq!(all.emit()[0], 0x80);
        assert_eq!(Mpdo::parse(&all.emit()), Ok(all));
        assert_eq!(Mpdo::parse(&sam.emit()), Ok(sam));
        assert_eq!(Mpdo::parse(&[0; 7]), Err(MpdoError::Length(7)));
        assert_eq!(Mpdo::parse(&[0; 8]), Err(MpdoError::NoProducer));
        assert_eq!(
            Mpdo::dam(None, ObjectAddress::new(1, 1), &[0; 5]),
            Err(MpdoError::DataTooLong(5))
        );
    }

    #[test]
    fn entries_bit_layout() {
        let s = ScannerEntry(0x0360_0001);
        assert_eq!((s.block_size(), s.index(), s.subindex()), (3, 0x6000, 1));
        assert_eq!(ScannerEntry::new(3, 0x6000, 1), s);
        assert!(s.covers(ObjectAddress::new(0x6000, 3)));
        assert!(!s.covers(ObjectAddress::new(0x6000, 4)));
        assert!(!s.covers(ObjectAddress::new(0x6000, 0)));
        let d = DispatcherEntry(0x0262_0001_6000_0105);
        assert_eq!(d.block_size(), 2);
        assert_eq!(d.local(), ObjectAddress::new(0x6200, 1));
        assert_eq!(d.producer_object(), ObjectAddress::new(0x6000, 1));
        assert_eq!(d.producer_node(), 5);
        assert_eq!(DispatcherEntry::new(2, 0x6200, 1, 0x6000, 1, 5), d);
        assert_eq!(
            d.dispatch(n(5), ObjectAddress::new(0x6000, 2)),
            Some(ObjectAddress::new(0x6200, 2))
        );
        assert_eq!(d.dispatch(n(5), ObjectAddress::new(0x6000, 3)), None);
        assert_eq!(d.dispatch(n(6), ObjectAddress::new(0x6000, 1)), None);
    }

    #[test]
    fn sam_producer_walks_scanner_list_one_object_per_frame() {
        let mut store = MapStore::new()
            .with(ObjectAddress::new(0x6000, 1), &[1])
            .with(ObjectAddress::new(0x6000, 2), &[2])
            .with(ObjectAddress::new(0x6401, 1), &[0x34, 0x12]);
        let mut p: SamProducer<4> = SamProducer::new(n(7));
        p.push(ScannerEntry::new(2, 0x6000, 1)).unwrap();
        p.push(ScannerEntry(0)).unwrap();
        p.push(ScannerEntry::new(1, 0x6401, 1)).unwrap();
        let frames: std::vec::Vec<[u8; 8]> =
            (0..4).map(|_| p.next(&mut store).unwrap().emit()).collect();
        assert_eq!(
            frames,
            [
                [7, 0x00, 0x60, 1, 1, 0, 0, 0],
                [7, 0x00, 0x60, 2, 2, 0, 0, 0],
                [7, 0x01, 0x64, 1, 0x34, 0x12, 0, 0],
                [7, 0x00, 0x60, 1, 1, 0, 0, 0],
            ]
        );
        assert_eq!(
            p.produce(ObjectAddress::new(0x6401, 1), &mut store)
                .unwrap()
                .data,
            [0x34, 0x12, 0, 0]
        );
        assert_eq!(
            p.produce(ObjectAddress::new(0x6401, 2), &mut store),
            Err(MpdoError::NotScanned(ObjectAddress::new(0x6401, 2)))
        );
        let mut empty: SamProducer<1> = SamProducer::new(n(7));
        assert_eq!(empty.next(&mut store), Err(MpdoError::EmptyScannerList));
    }

    #[test]
    fn sam_consumer_dispatches_and_dam_consumer_filters() {
        let mut c: MpdoConsumer<4> = MpdoConsumer::new(n(9));
        c.push(DispatcherEntry::new(2, 0x2100, 1, 0x6000, 1, 7))
            .unwrap();
        let mut store = MapStore::new().with(ObjectAddress::new(0x2100, 2), &[0]);
        // SAM from node 7 about 0x6000:2 lands in 0x2100:2 (one byte object keeps one byte).
        let d = c
            .handle_data(&[7, 0x00, 0x60, 2, 0xAA, 0xBB, 0, 0], &mut store)
            .unwrap();
        assert_eq!(d, Delivery::Written(ObjectAddress::new(0x2100, 2)));
        assert_eq!(store.get(ObjectAddress::new(0x2100, 2)), Some(&[0xAA][..]));
        // Not covered: other producer, other sub-index.
        assert_eq!(
            c.handle_data(&[8, 0x00, 0x60, 2, 1, 0, 0, 0], &mut store),
            Ok(Delivery::Ignored)
        );
        assert_eq!(
            c.handle_data(&[7, 0x00, 0x60, 3, 1, 0, 0, 0], &mut store),
            Ok(Delivery::Ignored)
        );
        // DAM to us, to all, to another node.
        assert_eq!(
            c.handle_data(&[0x89, 0x00, 0x62, 1, 5, 0, 0, 0], &mut store),
            Ok(Delivery::Written(ObjectAddress::new(0x6200, 1)))
        );
        assert_eq!(
            c.handle_data(&[0x80, 0x00, 0x62, 2, 6, 0, 0, 0], &mut store),
            Ok(Delivery::Written(ObjectAddress::new(0x6200, 2)))
        );
        assert_eq!(
            c.handle_data(&[0x8A, 0x00, 0x62, 3, 7, 0, 0, 0], &mut store),
            Ok(Delivery::Ignored)
        );
        assert_eq!(store.get(ObjectAddress::new(0x6200, 3)), None);
    }

    #[test]
    fn scanner_list_from_a_dictionary() {
        struct D;
        impl crate::dictionary::Catalog for D {
            fn object_info(&self, _: ObjectAddress) -> Option<crate::dictionary::ObjectInfo> {
                None
            }
        }
        impl Dictionary for D {
            fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError> {
                match (index, subindex) {
                    (0x1FA0, 0) => Ok(2),
                    (0x1FA0, 1) => Ok(0x0260_0001),
                    (0x1FA0, 2) => Ok(0x0164_0101),
                    _ => Err(ReadError::NoSuchObject { index, subindex }),
                }
            }
        }
        let mut p: SamProducer<2> = SamProducer::new(n(3));
        p.read_from(&D, SCANNER_LIST_FIRST).unwrap();
        assert_eq!(
            p.entries(),
            [
                ScannerEntry::new(2, 0x6000, 1),
                ScannerEntry::new(1, 0x6401, 1)
            ]
        );
        assert_eq!(
            p.read_from(&D, 0x1FA1),
            Err(MpdoError::Read(ReadError::NoSuchObject {
                index: 0x1FA1,
                subindex: 0
            }))
        );
        let mut full: SamProducer<1> = SamProducer::new(n(3));
        assert_eq!(full.read_from(&D, 0x1FA0), Err(MpdoError::ListFull));
    }

    proptest! {
        #[test]
        fn parse_is_total_and_round_trips(data in proptest::collection::vec(any::<u8>(), 0..=9)) {
            if let Ok(m) = Mpdo::parse(&data) {
                prop_assert_eq!(&m.emit()[..], &data[..]);
            }
        }
    }

    extern crate std;
}
