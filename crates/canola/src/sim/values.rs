//! A simulated device's current object values (little-endian bytes, CiA 301 §7.1), by
//! index and sub-index.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use canola_frame::NodeId;
use canola_od::ObjectDictionary;

/// The device's current object values (little-endian bytes, CiA 301 §7.1).
#[derive(Clone, Default)]
pub struct Values {
    /// By [`key`], hashed: an SDO request looks a value up twice, and a tree of a few hundred
    /// entries costs several times a hash lookup.
    pub(super) map: KeyMap<Vec<u8>>,
}

/// The key of `index:sub` (ordered as `(index, sub)`).
pub(super) fn key(index: u16, sub: u8) -> u32 {
    (u32::from(index) << 8) | u32::from(sub)
}

/// A map by [`key`].
pub(super) type KeyMap<V> = HashMap<u32, V, BuildHasherDefault<KeyHasher>>;

/// A multiplicative hash for the [`key`]s (the device's own entries, no untrusted input): the
/// default SipHash would cost more than the tree lookup it replaces.
#[derive(Default, Clone, Copy)]
pub(super) struct KeyHasher(pub(super) u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(self.0.rotate_left(8) ^ u64::from(*b));
        }
    }

    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }

    fn write_u64(&mut self, x: u64) {
        // The high bits mixed into the low ones, which pick the bucket.
        let h = x.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = h ^ (h >> 32);
    }
}

impl core::fmt::Debug for Values {
    /// As the `(index, sub)` map it stands for, in that order.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut entries: Vec<_> = self.map.iter().collect();
        entries.sort_unstable_by_key(|(k, _)| **k);
        f.debug_map()
            .entries(
                entries
                    .into_iter()
                    .map(|(k, v)| (((k >> 8) as u16, *k as u8), v)),
            )
            .finish()
    }
}

impl Values {
    /// The value of `index:sub`.
    pub fn get(&self, index: u16, sub: u8) -> Option<&[u8]> {
        self.map.get(&key(index, sub)).map(Vec::as_slice)
    }

    /// Sets the value of `index:sub`.
    pub fn set(&mut self, index: u16, sub: u8, value: impl Into<Vec<u8>>) {
        self.map.insert(key(index, sub), value.into());
    }

    /// An unsigned value of up to 8 bytes.
    pub fn get_u64(&self, index: u16, sub: u8) -> Option<u64> {
        let b = self.get(index, sub)?;
        let mut buf = [0u8; 8];
        let n = b.len().min(8);
        buf[..n].copy_from_slice(&b[..n]);
        Some(u64::from_le_bytes(buf))
    }

    pub(super) fn defaults(od: &ObjectDictionary, node: NodeId) -> Self {
        let mut map = KeyMap::default();
        for (index, sub) in od.entries() {
            let bytes = sub
                .effective_value(node.get())
                .map(|v| v.to_le_bytes())
                .unwrap_or_else(|| vec![0; sub.data_type.size().unwrap_or(0)]);
            map.insert(key(index, sub.sub_index), bytes);
        }
        Self { map }
    }
}

impl canola_pdo::ValueSource for Values {
    fn value(&self, index: u16, subindex: u8) -> Option<&[u8]> {
        self.get(index, subindex)
    }
}
