//! The simulated device's objects as its SDO servers see them (CiA 301 §7.2.4): per
//! sub-object the access and size the server checks, the current values behind them, hooks
//! consulted on every write, and the server channels (0x1200..=0x127F) the values configure.

use canola_frame::{Instant, NodeId};
use canola_od::{AccessType, ObjectDictionary};
use canola_sdo::{
    AbortCode, Access, LengthRule, Multiplexer, ObjectAccess, ObjectInfo, SdoCobIds, Server,
    ServerConfig,
};

use super::hook::{DeviceHook, HookActions};
use super::values::{KeyMap, Values, key};

/// Longest value a variable-size object (string, DOMAIN) accepts by download.
pub const MAX_VARIABLE_SIZE: u32 = 1 << 20;

/// What the SDO server asks the dictionary about a sub-object at every request.
#[derive(Debug, Clone, Copy)]
pub(super) struct SubMeta {
    pub(super) access: Access,
    /// The size of a fixed-size type.
    pub(super) fixed: Option<u32>,
}

/// Every sub-object's [`SubMeta`], by [`key`] (the dictionary never changes).
pub(super) fn sub_meta(od: &ObjectDictionary) -> KeyMap<SubMeta> {
    od.entries()
        .map(|(index, s)| {
            let fixed = match s.data_type.size() {
                Some(n) if !s.data_type.is_variable_size() => Some(n as u32),
                _ => None,
            };
            let meta = SubMeta {
                access: access(s.access),
                fixed,
            };
            (key(index, s.sub_index), meta)
        })
        .collect()
}

/// The objects as the SDO server sees them: dictionary metadata plus current values.
pub(super) struct Objects<'a> {
    pub(super) od: &'a ObjectDictionary,
    pub(super) meta: &'a KeyMap<SubMeta>,
    pub(super) values: &'a mut Values,
    pub(super) staging: &'a mut Vec<u8>,
    pub(super) hooks: &'a mut Vec<Box<dyn DeviceHook>>,
    pub(super) actions: &'a mut HookActions,
    pub(super) written: &'a mut Vec<(u16, u8)>,
    pub(super) now: Instant,
}

pub(super) fn access(a: AccessType) -> Access {
    match a {
        AccessType::Ro => Access::ReadOnly,
        AccessType::Wo => Access::WriteOnly,
        AccessType::Const => Access::Const,
        _ => Access::ReadWrite,
    }
}

impl ObjectAccess for Objects<'_> {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        let (index, sub) = (mux.index, mux.subindex);
        let Some(&meta) = self.meta.get(&key(index, sub)) else {
            return Err(if self.od.get(index).is_none() {
                AbortCode::OBJECT_DOES_NOT_EXIST
            } else {
                AbortCode::SUBINDEX_DOES_NOT_EXIST
            });
        };
        // A hook may serve the value: its length counts.
        for h in self.hooks.iter_mut() {
            if let Some(r) = h.on_read(self.now, self.values, index, sub) {
                let v = r?;
                self.values.set(index, sub, v);
                break;
            }
        }
        let len = self.values.get(index, sub).map_or(0, |v| v.len()) as u32;
        let acc = meta.access;
        Ok(match meta.fixed {
            Some(n) => ObjectInfo {
                access: acc,
                len,
                accepts: LengthRule::Exact(n),
            },
            None => ObjectInfo::variable(acc, len, MAX_VARIABLE_SIZE),
        })
    }

    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let v = self
            .values
            .get(mux.index, mux.subindex)
            .ok_or(AbortCode::NO_DATA_AVAILABLE)?;
        let start = (offset as usize).min(v.len());
        let n = buf.len().min(v.len() - start);
        buf[..n].copy_from_slice(&v[start..start + n]);
        Ok(n)
    }

    fn write(&mut self, _mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let offset = offset as usize;
        if offset == 0 {
            self.staging.clear();
        }
        let end = offset + data.len();
        if end > MAX_VARIABLE_SIZE as usize {
            return Err(AbortCode::OUT_OF_MEMORY);
        }
        if self.staging.len() < end {
            self.staging.resize(end, 0);
        }
        self.staging[offset..end].copy_from_slice(data);
        Ok(())
    }

    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        let value: Vec<u8> = self.staging.iter().take(len as usize).copied().collect();
        self.staging.clear();
        let (index, sub) = (mux.index, mux.subindex);
        // Range check against the dictionary's limits for integers.
        if let Some(s) = self.od.sub(index, sub) {
            let v = canola_od::Value::from_le_bytes(s.data_type, &value)
                .map_err(|_| AbortCode::LENGTH_MISMATCH)?;
            if let Some(x) = v.as_i128() {
                let limit = |f: Option<&canola_od::FieldValue>| {
                    f.and_then(|f| f.resolve(0)).and_then(|v| v.as_i128())
                };
                if limit(s.low_limit()).is_some_and(|lo| x < lo) {
                    return Err(AbortCode::VALUE_TOO_LOW);
                }
                if limit(s.high_limit()).is_some_and(|hi| x > hi) {
                    return Err(AbortCode::VALUE_TOO_HIGH);
                }
            }
        }
        // A COB-ID entry set to an identifier CiA 301 restricts (TPDO1 on 0x000, the NMT
        // identifier, say) would disturb the network: refused as an invalid value.
        if let Ok(raw) = <[u8; 4]>::try_from(value.as_slice())
            && crate::restricted_cob_id(index, sub, u32::from_le_bytes(raw)).is_some()
        {
            return Err(AbortCode::INVALID_VALUE);
        }
        // Store parameters and restore default parameters (CiA 301 §7.5.2.13/14): only the
        // signature `save` (`load`) is taken, and it is an order, not a value (the sub-index
        // keeps reading the device's capabilities); the device carries it out after the SDO.
        if matches!(index, 0x1010 | 0x1011) && sub >= 1 {
            let signature: &[u8] = if index == 0x1010 { b"save" } else { b"load" };
            if value != signature {
                return Err(AbortCode::CANNOT_STORE);
            }
            self.written.push((index, sub));
            return Ok(());
        }
        for h in self.hooks.iter_mut() {
            h.on_write(self.now, self.values, index, sub, &value, self.actions)?;
        }
        self.values.set(index, sub, value);
        self.written.push((index, sub));
        Ok(())
    }

    fn discard(&mut self, _mux: Multiplexer) {
        self.staging.clear();
    }
}

/// One SDO server channel (CiA 301 §7.2.4.2): its COB-IDs and its server machine.
pub(super) struct SdoChannel {
    pub(super) ids: SdoCobIds,
    pub(super) server: Server,
}

/// The device's SDO server channels: the default channel (0x1200: 0x600/0x580 + node-ID, which
/// CiA 301 fixes to the node-ID, so it follows a node-ID change) and every further server
/// parameter record 0x1201..=0x127F whose two COB-IDs are valid in the current values.
pub(super) fn sdo_channels(
    od: &ObjectDictionary,
    values: &Values,
    node: NodeId,
) -> Vec<SdoChannel> {
    let ids_of = |index: u16| {
        od.get(index)?;
        let cob = |sub| values.get_u64(index, sub).map(|v| v as u32);
        SdoCobIds::from_parameters(cob(1)?, cob(2)?)
    };
    core::iter::once(SdoCobIds::default_for(node))
        .chain((0x1201..=0x127F).filter_map(ids_of))
        .map(|ids| SdoChannel {
            ids,
            server: Server::new(ServerConfig::default()),
        })
        .collect()
}
