//! Adapters between the `canopen-od` dictionary model and the `canopen-pdo` traits
//! ([`Catalog`], [`Dictionary`]), so PDO mappings of Bürkert objects can be checked against an
//! EDS (master side) and against a simulated device's current mapping entries.
//!
//! The `canopen-pdo` crate plans its own `od` adapter; until it exists this small one lives here.

use std::prelude::rust_2024::*;

use canopen::Values;
use canopen_od::ObjectDictionary;
use canopen_pdo::{Catalog, Dictionary, ObjectAddr, ObjectInfo, ReadError};

/// What a dictionary says about `addr`, in the PDO crate's terms.
fn info(od: &ObjectDictionary, addr: ObjectAddr) -> Option<ObjectInfo> {
    let s = od.sub(addr.index, addr.subindex)?;
    Some(ObjectInfo {
        data_type: s.data_type.code(),
        bits: (s.data_type.size().unwrap_or(0) * 8).min(u16::MAX as usize) as u16,
        pdo_mappable: s.pdo_mapping,
        readable: s.access.is_readable(),
        writable: s.access.is_writable(),
    })
}

/// A dictionary as a mapping catalog (metadata only).
pub(crate) struct OdCatalog<'a>(pub(crate) &'a ObjectDictionary);

impl Catalog for OdCatalog<'_> {
    fn object_info(&self, addr: ObjectAddr) -> Option<ObjectInfo> {
        info(self.0, addr)
    }
}

/// A simulated device's dictionary and current values, readable as PDO parameters.
pub(crate) struct ValuesDict<'a> {
    pub(crate) od: &'a ObjectDictionary,
    pub(crate) values: &'a Values,
}

impl Catalog for ValuesDict<'_> {
    fn object_info(&self, addr: ObjectAddr) -> Option<ObjectInfo> {
        info(self.od, addr)
    }
}

impl Dictionary for ValuesDict<'_> {
    fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError> {
        let s = self
            .od
            .sub(index, subindex)
            .ok_or(ReadError::NoSuchObject { index, subindex })?;
        match s.data_type.size() {
            Some(1..=4) if !s.data_type.is_signed() => {}
            _ => return Err(ReadError::NotAnInteger { index, subindex }),
        }
        let bytes = self.values.get(index, subindex).unwrap_or(&[]);
        let mut word = [0u8; 4];
        let n = bytes.len().min(4);
        word[..n].copy_from_slice(&bytes[..n]);
        Ok(u32::from_le_bytes(word))
    }
}
