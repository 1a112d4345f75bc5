//! PDO glue (CiA 301 §7.2.2): the `canopen-pdo` engine configured from a dictionary's PDO
//! parameter objects (0x1400.., 0x1600.., 0x1800.., 0x1A00..), for the simulator (a device's own
//! TPDOs and RPDOs over its current values) and for the master (a node's TPDOs mirrored as
//! receive PDOs, so received frames decode into values).

use can_frame::{CanId, Instant};
use canopen_od::ObjectDictionary;
use canopen_pdo::{
    CommParams, Dictionary, Direction, Engine, Mapping, ObjectAddress, ObjectStore, OdView,
    PdoConfig, RpdoId, StoreError,
};

use crate::sim::Values;

/// Four PDOs each way, as the predefined connection set has.
pub(crate) type PdoEngine = Engine<4, 4>;

/// The master's mirror of a node's TPDOs: the engine and (TPDO number, receive PDO id) pairs.
pub(crate) type Mirror = (Box<PdoEngine>, Vec<(u8, RpdoId)>);

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

/// Reads PDO `n` (0-based) of `direction` from the view; `None` when absent or unusable.
fn read_pdo(view: &impl Dictionary, direction: Direction, n: u16) -> Option<PdoConfig> {
    let comm = CommParams::read_from(view, direction.comm_index(n)).ok()?;
    let mapping = Mapping::read_from(view, direction, direction.mapping_index(n)).ok()?;
    Some(PdoConfig::new(comm, mapping))
}

/// A device's engine: its RPDOs and TPDOs from its current values.
pub(crate) fn device_engine(view: &OdView<'_>, now: Instant) -> Box<PdoEngine> {
    let mut e = Box::new(PdoEngine::new());
    if let Ok(id) = CanId::standard(0x80) {
        e.set_sync_cob_id(Some(id));
    }
    for n in 0..4 {
        if let Some(c) = read_pdo(view, Direction::Receive, n) {
            let _ = e.add_rpdo(c);
        }
        if let Some(c) = read_pdo(view, Direction::Transmit, n) {
            let _ = e.add_tpdo(now, c);
        }
    }
    e
}

/// The master's engine for one node: the node's TPDOs (from its dictionary, `$NODEID`
/// resolved) as receive PDOs. Returns the engine and the TPDO number (1-based) of each RPDO.
pub(crate) fn mirror_engine(od: &ObjectDictionary, node: can_frame::NodeId) -> Mirror {
    let view = OdView::new(od, node.get());
    let mut e = Box::new(PdoEngine::new());
    let mut numbers = Vec::new();
    for n in 0..4u16 {
        if let Some(c) = read_pdo(&view, Direction::Transmit, n)
            && let Ok(id) = e.add_rpdo(mirrored(c))
        {
            numbers.push((n as u8 + 1, id));
        }
    }
    e.set_enabled(Instant::ZERO, true);
    (e, numbers)
}

/// A node's TPDO as the master's receive PDO: taken the moment it arrives. A synchronous TPDO
/// mirrored as a synchronous RPDO would wait for the next SYNC, which the master (the SYNC
/// producer) never receives; so the mirror is event-driven whatever the node's type.
pub(crate) fn mirrored(mut config: PdoConfig) -> PdoConfig {
    config.comm = config
        .comm
        .with_transmission_type(canopen_pdo::TransmissionType::EventManufacturer);
    config
}

/// `mapping` with value kinds from the node's dictionary (a mapping built from raw entries
/// decodes everything as unsigned); unchanged when the dictionary refuses it.
pub(crate) fn typed_mapping(
    od: &ObjectDictionary,
    node: can_frame::NodeId,
    direction: Direction,
    mapping: Mapping,
) -> Mapping {
    let view = OdView::new(od, node.get());
    let raw: Vec<u32> = mapping.raw_entries().collect();
    Mapping::from_raw_checked(direction, &raw, &view).unwrap_or(mapping)
}
