//! The two small traits through which this crate sees objects it does not own.
//!
//! - [`Catalog`]: what the object dictionary says about an object (data type, size, access type,
//!   PDO mapping flag) and which dummy mapping types the device supports (EDS `[DummyUsage]`).
//!   Mapping validation ([`crate::Mapping::from_raw_checked`]) needs nothing else.
//! - [`Dictionary`]: a catalog that can also read UNSIGNED values, so PDO parameters can be
//!   read from objects 0x1400..=0x1BFF ([`crate::CommParams::read_from`],
//!   [`crate::Mapping::read_from`]).
//! - [`ObjectStore`]: the live values of mapped objects, read when a PDO is produced and written
//!   when one is consumed. The master's process image and the device simulator's object
//!   dictionary both implement it; the engine never owns values.
//!
//! None of them needs an allocator. Under the `alloc` feature [`MapStore`] is a ready store
//! backed by a `BTreeMap`.

/// An object dictionary entry: index and sub-index (the workspace's one address type, from
/// `canola-od`).
pub use canola_od::ObjectAddress;

/// What the dictionary says about one object, as far as PDO mapping cares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ObjectInfo {
    /// CiA 301 §7.4.7 data type index (0x0007 = UNSIGNED32, ...).
    pub data_type: u16,
    /// Size of the object in bits (for strings and domains: its length in bytes times 8).
    pub bits: u16,
    /// The entry's `PDOMapping` flag.
    pub pdo_mappable: bool,
    /// Readable over the bus (ro, rw, rwr, rww, const).
    pub readable: bool,
    /// Writable over the bus (wo, rw, rwr, rww).
    pub writable: bool,
}

/// Object metadata for mapping validation.
pub trait Catalog {
    /// The entry at `addr`, or `None` if the object does not exist.
    fn object_info(&self, addr: ObjectAddress) -> Option<ObjectInfo>;

    /// Whether the device accepts data type `data_type` (0x0001..=0x0007) as a dummy mapping
    /// entry (EDS `[DummyUsage]` `Dummy000n=1`). The default accepts all seven.
    fn dummy_supported(&self, data_type: u16) -> bool {
        (0x0001..=0x0007).contains(&data_type)
    }
}

/// A catalog that can also read integer values (PDO parameters).
pub trait Dictionary: Catalog {
    /// The value of an UNSIGNED8/16/32 entry, widened to `u32`.
    fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError>;
}

/// Why a parameter could not be read from a [`Dictionary`].
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// The entry does not exist.
    #[error("object 0x{index:04X}:{subindex:02X} does not exist")]
    NoSuchObject {
        /// Index.
        index: u16,
        /// Sub-index.
        subindex: u8,
    },
    /// The entry exists but is not an unsigned integer of at most 32 bits.
    #[error("object 0x{index:04X}:{subindex:02X} is not an UNSIGNED8/16/32")]
    NotAnInteger {
        /// Index.
        index: u16,
        /// Sub-index.
        subindex: u8,
    },
}

debug_as_display!(ReadError);

/// Why an [`ObjectStore`] refused a read or write. The variants mirror the SDO abort codes a
/// device would give for the same access, so a simulator can report them unchanged.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum StoreError {
    /// No such object (abort 0x0602_0000 / 0x0609_0011).
    #[error("object does not exist")]
    NoSuchObject,
    /// The object may not be accessed this way (abort 0x0601_0000).
    #[error("access not allowed")]
    AccessDenied,
    /// The value is out of the object's range (abort 0x0609_0030).
    #[error("value out of range")]
    ValueRange,
    /// The store's own reason, as an SDO abort code.
    #[error("refused with abort code {0:#010x}")]
    Other(u32),
}

debug_as_display!(StoreError);

/// The live values of mapped objects, little-endian as on the bus.
///
/// For a mapped entry of `n` bits the engine passes buffers of exactly `ceil(n / 8)` bytes; an
/// MPDO consumer passes the four MPDO data bytes and the store takes as many as its object
/// holds. Dummy entries (index 0x0001..=0x0007) never reach the store.
pub trait ObjectStore {
    /// Fills `out` with the current value of `addr` (little-endian, `out.len()` bytes).
    fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError>;

    /// Stores `data` (little-endian) as the new value of `addr`.
    fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), StoreError>;
}

/// A store that keeps nothing: reads give zeros, writes are accepted and dropped. For a master
/// that takes received values from the engine's events instead of a process image.
#[derive(Debug, Clone, Copy, Default)]
pub struct NullStore;

impl ObjectStore for NullStore {
    fn read(&mut self, _addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError> {
        out.fill(0);
        Ok(())
    }

    fn write(&mut self, _addr: ObjectAddress, _data: &[u8]) -> Result<(), StoreError> {
        Ok(())
    }
}

impl<S: ObjectStore + ?Sized> ObjectStore for &mut S {
    fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError> {
        (**self).read(addr, out)
    }

    fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), StoreError> {
        (**self).write(addr, data)
    }
}

#[cfg(feature = "alloc")]
mod map_store {
    use alloc::collections::BTreeMap;
    use alloc::vec::Vec;

    use super::{ObjectAddress, ObjectStore, StoreError};

    /// A heap-backed [`ObjectStore`]: a map from entry to little-endian bytes. Reading an entry
    /// that was never written gives [`StoreError::NoSuchObject`]; reads shorter or longer than the
    /// stored value are truncated or zero-padded. Writes replace the value.
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct MapStore {
        /// The values.
        pub values: BTreeMap<ObjectAddress, Vec<u8>>,
    }

    impl MapStore {
        /// An empty store.
        pub fn new() -> Self {
            Self::default()
        }

        /// Sets `addr` to `data` and returns `self` (for building test stores).
        pub fn with(mut self, addr: ObjectAddress, data: &[u8]) -> Self {
            self.values.insert(addr, data.to_vec());
            self
        }

        /// The bytes stored at `addr`.
        pub fn get(&self, addr: ObjectAddress) -> Option<&[u8]> {
            self.values.get(&addr).map(Vec::as_slice)
        }

        /// Replaces the value at `addr`.
        pub fn set(&mut self, addr: ObjectAddress, data: &[u8]) {
            self.values.insert(addr, data.to_vec());
        }
    }

    impl ObjectStore for MapStore {
        fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError> {
            let v = self.values.get(&addr).ok_or(StoreError::NoSuchObject)?;
            out.fill(0);
            let n = v.len().min(out.len());
            out[..n].copy_from_slice(&v[..n]);
            Ok(())
        }

        fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), StoreError> {
            let slot = self.values.entry(addr).or_default();
            if !slot.is_empty() && slot.len() < data.len() {
                // An existing object keeps its size (an MPDO write carries four bytes).
                let n = slot.len();
                slot.copy_from_slice(&data[..n]);
            } else {
                slot.clear();
                slot.extend_from_slice(data);
            }
            Ok(())
        }
    }
}

#[cfg(feature = "alloc")]
pub use map_store::MapStore;
