//! The actual values (position 0x6064, velocity 0x606C, torque 0x6077): by SDO, or from the
//! node's TPDOs while fresh when [`Drive::follow_tpdos`] was called (the cache it fills).

use std::collections::HashMap;
use std::prelude::rust_2024::*;
use std::sync::{Arc, Mutex};

use canola::{Duration, Operation};

use crate::objects::{self as obj};

use super::{Drive, DriveOp, lock};

/// The TPDO values a [`Drive`] follows (see [`Drive::follow_tpdos`]).
#[derive(Debug)]
pub(super) struct Following {
    pub(super) callback: canola::PdoCallbackId,
    pub(super) cache: Arc<Mutex<ActualsCache>>,
    pub(super) max_age: Duration,
}

/// The latest value of each followed object, with its reception time.
pub(super) type ActualsCache = HashMap<(u16, u8), (i64, canola::Instant)>;

impl Drive {
    /// Takes the actual values (position 0x6064, velocity 0x606C, torque 0x6077) from the
    /// node's TPDOs as they arrive, each while it is at most `max_age` old; an older
    /// or never received value is read by SDO. TPDOs are decoded through the node's dictionary
    /// (a node added with [`Network::add_node_with_dictionary`](canola::Network::add_node_with_dictionary)),
    /// with the mapping the master knows. The statusword and the mode are always read by SDO:
    /// the state machine and mode changes wait on fresh ones (python-canopen #554).
    pub fn follow_tpdos(&self, max_age: Duration) {
        let cache: Arc<Mutex<ActualsCache>> = Arc::default();
        let sink = Arc::clone(&cache);
        let me = self.node.id();
        let watched = [
            self.at(obj::POSITION_ACTUAL_VALUE),
            self.at(obj::VELOCITY_ACTUAL_VALUE),
            self.at(obj::TORQUE_ACTUAL_VALUE),
        ];
        let callback = self.node.network().on_pdo(move |p| {
            if p.node != me {
                return;
            }
            let mut c = lock(&sink);
            for (addr, value) in p.values {
                let key = (addr.index, addr.sub_index);
                if let (true, Some(v)) = (watched.contains(&key), value.as_i128()) {
                    c.insert(key, (v as i64, p.at));
                }
            }
        });
        let old = lock(&self.shared.tpdo).replace(Following {
            callback,
            cache,
            max_age,
        });
        if let Some(f) = old {
            self.node.network().remove_pdo_callback(f.callback);
        }
    }

    /// A followed TPDO value of `e`, if fresh enough.
    fn tpdo_value<T>(&self, e: canola::od::Entry<T>) -> Option<i64> {
        let guard = lock(&self.shared.tpdo);
        let f = guard.as_ref()?;
        let (v, at) = *lock(&f.cache).get(&self.at(e))?;
        (self.node.network().now() - at <= f.max_age).then_some(v)
    }

    /// An actual value: the followed TPDO's while fresh, else `N` bytes by SDO.
    pub(super) fn actual<const N: usize, E, T: Send + 'static>(
        &self,
        e: canola::od::Entry<E>,
        from_tpdo: fn(i64) -> T,
        from_bytes: fn([u8; N]) -> T,
    ) -> DriveOp<T> {
        let cached = self.tpdo_value(e).map(from_tpdo);
        let d = self.clone();
        let at = self.at(e);
        Operation::new(async move {
            match cached {
                Some(v) => Ok(v),
                None => Ok(from_bytes(d.read_at(at).await?)),
            }
        })
    }

    /// The actual position 0x6064, counts (from a TPDO when followed and fresh).
    pub fn position(&self) -> DriveOp<i32> {
        self.actual(obj::POSITION_ACTUAL_VALUE, |v| v as i32, i32::from_le_bytes)
    }

    /// The actual velocity 0x606C, counts/s (from a TPDO when followed and fresh).
    pub fn velocity(&self) -> DriveOp<i32> {
        self.actual(obj::VELOCITY_ACTUAL_VALUE, |v| v as i32, i32::from_le_bytes)
    }

    /// The actual torque 0x6077, ‰ of rated torque (from a TPDO when followed and fresh).
    pub fn torque(&self) -> DriveOp<i16> {
        self.actual(obj::TORQUE_ACTUAL_VALUE, |v| v as i16, i16::from_le_bytes)
    }
}
