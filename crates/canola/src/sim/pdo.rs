//! A simulated device's own PDOs (CiA 301 §7.2.2): the `canola-pdo` engine configured from the
//! device's current values of its PDO parameter objects, over those values as its process image.

use canola_frame::{CanId, Instant};
use canola_pdo::{Direction, ObjectAddress, ObjectStore, OdView, StoreError};

use super::values::Values;
use crate::machine::pdo::{PdoEngine, read_pdo};

/// A device's values as the PDO engine's process image.
pub(crate) struct Store<'a>(pub(crate) &'a mut Values);

impl ObjectStore for Store<'_> {
    fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError> {
        let v = self
            .0
            .get(addr.index, addr.sub_index)
            .ok_or(StoreError::NoSuchObject)?;
        let n = out.len().min(v.len());
        out[..n].copy_from_slice(&v[..n]);
        out[n..].fill(0);
        Ok(())
    }
    fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), StoreError> {
        self.0.set(addr.index, addr.sub_index, data.to_vec());
        Ok(())
    }
}

/// A device's engine: its RPDOs and TPDOs from its current values.
pub(crate) fn device_engine(view: &OdView<'_>, now: Instant) -> Box<PdoEngine> {
    let mut e = Box::new(PdoEngine::new());
    if let Ok(id) = CanId::standard(0x80) {
        e.set_sync_cob_id(Some(id));
    }
    // A PDO on a CAN identifier CiA 301 restricts (a dictionary can carry one: SDO writes of
    // one are refused, defaults are not) stays off: TPDO1 on 0x000 would send NMT commands.
    let allowed = |index: u16, c: &canola_pdo::PdoConfig| {
        crate::restricted_cob_id(index, 1, c.comm.cob_id.0).is_none()
    };
    for n in 0..4 {
        if let Some(c) = read_pdo(view, Direction::Receive, n)
            && allowed(Direction::Receive.comm_index(n), &c)
        {
            let _ = e.add_rpdo(c);
        }
        if let Some(c) = read_pdo(view, Direction::Transmit, n)
            && allowed(Direction::Transmit.comm_index(n), &c)
        {
            let _ = e.add_tpdo(now, c);
        }
    }
    e
}
