//! The master's PDOs with each node (CiA 301 §7.2.2): per node one `canola-pdo` engine whose
//! receive side mirrors the node's TPDOs (received frames decode into values) and whose
//! transmit side produces the node's RPDOs from the master's process image ([`NodePdos`]),
//! configured from the PDO parameter objects (0x1400.., 0x1600.., 0x1800.., 0x1A00..) of the
//! node's dictionary or of what was read from it.
//!
//! On a CAN FD bus a PDO may carry up to 64 bytes (CANopen FD): a node's TPDO whose mapping
//! does not fit 8 bytes is decoded from CAN FD frames through `canola-pdo`'s [`FdMapping`]
//! beside the engine ([`FdMirror`]), and an RPDO of more than 8 bytes is transmitted as a CAN FD
//! frame ([`FdRpdo`]), event-driven: when a mapped value changes or on a trigger. The engine
//! keeps running the classic PDOs (its timers and SYNC handling are for 8-byte PDOs).

use canola_frame::{CanId, FdFrame};
use canola_od::{DataType, ObjectDictionary, Value};
use canola_pdo::{
    CommParams, Dictionary, Direction, Engine, FdMapping, MapStore, Mapping, ObjectAddress, OdView,
    PdoConfig, RawValue, RpdoId, TpdoId,
};

/// Four PDOs each way, as the predefined connection set has.
pub(crate) type PdoEngine = Engine<4, 4>;

/// The master's PDOs with one node: one engine, the receive half mirroring the node's TPDOs,
/// the transmit half producing the node's RPDOs (the master is their producer).
pub(crate) struct NodePdos {
    pub(crate) engine: Box<PdoEngine>,
    /// (TPDO number of the node, the engine's receive PDO), in the engine's order.
    pub(crate) tpdos: Vec<(u8, RpdoId)>,
    /// Per mirrored receive PDO, the data type of each mapped object (its type in the node's
    /// dictionary where that agrees with the mapping), in mapping order: received values are
    /// delivered as the dictionary types them.
    pub(super) types: Vec<(RpdoId, Vec<DataType>)>,
    /// (RPDO number of the node, the engine's transmit PDO) of the RPDOs being transmitted.
    pub(crate) rpdos: Vec<(u16, TpdoId)>,
    /// Transmit PDOs of the engine no RPDO uses any more (stopped), for reuse.
    pub(crate) idle: Vec<TpdoId>,
    /// The values the application set for the transmitted RPDOs, by mapped object.
    pub(crate) image: MapStore,
    /// The engine's `poll_timeout` as of its last input (kept so the core need not ask every
    /// node's engine at every step).
    pub(crate) next: Option<canola_frame::Instant>,
    /// The node's TPDOs of more than 8 bytes, decoded from CAN FD frames.
    pub(crate) fd_tpdos: Vec<FdMirror>,
    /// The node's RPDOs of more than 8 bytes the master transmits as CAN FD frames.
    pub(crate) fd_rpdos: Vec<FdRpdo>,
}

/// A node's TPDO of more than 8 bytes as the master decodes it.
pub(crate) struct FdMirror {
    /// The node's TPDO number (1-based).
    pub(crate) number: u8,
    pub(crate) can_id: CanId,
    pub(crate) mapping: FdMapping,
    /// The data type of each mapped object, as for classic mirrors.
    pub(crate) types: Vec<DataType>,
}

/// A node's RPDO of more than 8 bytes the master transmits (event-driven).
pub(crate) struct FdRpdo {
    /// The node's RPDO number (1-based).
    pub(crate) number: u16,
    pub(crate) can_id: CanId,
    pub(crate) mapping: FdMapping,
    /// The data last sent, to send again only on a change.
    pub(crate) last: Option<Vec<u8>>,
}

impl NodePdos {
    /// No PDOs yet. The engine takes no SYNC from frames: the master produces SYNC itself and
    /// feeds it with `handle_sync`.
    pub(crate) fn new() -> Self {
        let mut engine = Box::new(PdoEngine::new());
        engine.set_sync_cob_id(None);
        Self {
            engine,
            tpdos: Vec::new(),
            types: Vec::new(),
            rpdos: Vec::new(),
            idle: Vec::new(),
            image: MapStore::new(),
            next: None,
            fd_tpdos: Vec::new(),
            fd_rpdos: Vec::new(),
        }
    }

    /// Decodes the node's TPDO `number` of more than 8 bytes from CAN FD frames on `can_id`
    /// from now on (replacing a classic mirror of the same number).
    pub(crate) fn mirror_fd_tpdo(
        &mut self,
        number: u8,
        can_id: CanId,
        mapping: FdMapping,
        od: Option<&ObjectDictionary>,
    ) {
        let types = mapping
            .objects()
            .iter()
            .map(|o| {
                let declared = od
                    .filter(|_| !o.entry.is_dummy())
                    .and_then(|od| od.sub(o.entry.index(), o.entry.subindex()))
                    .map(|s| s.data_type);
                o.value_type(declared)
            })
            .collect();
        if let Some((_, id)) = self.tpdos.iter().find(|(n, _)| *n == number)
            && let Some(mut config) = self.engine.rpdo(*id).cloned()
        {
            config.comm.cob_id = config.comm.cob_id.with_valid(false);
            let _ = self.engine.set_rpdo(*id, config);
        }
        self.fd_tpdos.retain(|m| m.number != number);
        self.fd_tpdos.push(FdMirror {
            number,
            can_id,
            mapping,
            types,
        });
    }

    /// The TPDO number of the CAN FD mirror on `can_id`.
    pub(crate) fn fd_tpdo_on(&self, can_id: CanId) -> Option<u8> {
        self.fd_tpdos
            .iter()
            .find(|m| m.can_id == can_id)
            .map(|m| m.number)
    }

    /// The values of `data` received on the CAN FD mirror of TPDO `number`, typed as for
    /// classic mirrors, into `out` (cleared first); `false` when the data is shorter than the
    /// mapping.
    pub(crate) fn decode_fd(
        &self,
        number: u8,
        data: &[u8],
        out: &mut Vec<(ObjectAddress, Value)>,
    ) -> bool {
        out.clear();
        let Some(m) = self.fd_tpdos.iter().find(|m| m.number == number) else {
            return false;
        };
        let Ok(raw) = canola_pdo::unpack_fd(&m.mapping, data) else {
            return false;
        };
        out.extend(
            m.mapping
                .objects()
                .iter()
                .zip(raw.iter())
                .enumerate()
                .map(|(i, (o, v))| {
                    let ty = m.types.get(i).copied().unwrap_or_else(|| o.data_type());
                    let value = v
                        .to_value(ty)
                        .or_else(|_| v.to_value(o.data_type()))
                        .unwrap_or(Value::Unsigned64(0));
                    (o.entry.addr(), value)
                }),
        );
        true
    }

    /// Starts (or reconfigures) transmitting the node's RPDO `number` of more than 8 bytes as
    /// CAN FD frames on `can_id`. Mapped objects the application has not set yet are zero.
    pub(crate) fn start_fd_rpdo(&mut self, number: u16, can_id: CanId, mapping: FdMapping) {
        for o in mapping.objects() {
            let addr = o.entry.addr();
            if !o.entry.is_dummy() && self.image.get(addr).is_none() {
                self.image
                    .set(addr, &vec![0; usize::from(o.bits()).div_ceil(8)]);
            }
        }
        // A classic transmission of the same RPDO stops.
        let _ = self.stop_rpdo(canola_frame::Instant::ZERO, number);
        self.fd_rpdos.retain(|r| r.number != number);
        self.fd_rpdos.push(FdRpdo {
            number,
            can_id,
            mapping,
            last: None,
        });
    }

    /// The CAN FD frames of the transmitted FD RPDOs whose data changed (all of them when
    /// `force` names none; only RPDO `force` otherwise, changed or not).
    pub(crate) fn fd_frames(&mut self, force: Option<u16>) -> Vec<FdFrame> {
        let mut out = Vec::new();
        for r in &mut self.fd_rpdos {
            if force.is_some_and(|n| n != r.number) {
                continue;
            }
            let values: Vec<RawValue> = r
                .mapping
                .objects()
                .iter()
                .map(|o| {
                    let mut word = [0u8; 8];
                    if !o.entry.is_dummy()
                        && let Some(b) = self.image.get(o.entry.addr())
                    {
                        let n = b.len().min(8);
                        word[..n].copy_from_slice(&b[..n]);
                    }
                    let bits = o.bits();
                    let raw = u64::from_le_bytes(word)
                        & if bits >= 64 {
                            u64::MAX
                        } else {
                            (1u64 << bits) - 1
                        };
                    RawValue::from_raw(o.kind, raw, bits)
                })
                .collect();
            let mut buf = [0u8; canola_pdo::MAX_FD_BYTES];
            let Ok(len) = canola_pdo::pack_fd(&r.mapping, &values, &mut buf) else {
                continue;
            };
            let data = &buf[..len];
            if force.is_none() && r.last.as_deref() == Some(data) {
                continue;
            }
            if let Ok(frame) = FdFrame::new_padded(r.can_id, data).map(|f| f.with_brs(true)) {
                r.last = Some(data.to_vec());
                out.push(frame);
            }
        }
        out
    }

    /// Stops transmitting the FD RPDO `number`; `false` when it was not transmitted.
    pub(crate) fn stop_fd_rpdo(&mut self, number: u16) -> bool {
        let before = self.fd_rpdos.len();
        self.fd_rpdos.retain(|r| r.number != number);
        self.fd_rpdos.len() != before
    }

    /// Decodes the node's TPDO `number` with `config` from now on (mirrored event-driven),
    /// typing its values by `od` (the node's dictionary, if it has one).
    /// With four mirrored already, the slot of one that is not valid is taken over.
    pub(crate) fn mirror_tpdo(
        &mut self,
        number: u8,
        config: PdoConfig,
        od: Option<&ObjectDictionary>,
    ) {
        let types: Vec<DataType> = config
            .mapping
            .objects()
            .iter()
            .map(|o| {
                let declared = od
                    .filter(|_| !o.is_dummy())
                    .and_then(|od| od.sub(o.entry.index(), o.entry.subindex()))
                    .map(|s| s.data_type);
                o.value_type(declared)
            })
            .collect();
        let config = mirrored(config);
        self.fd_tpdos.retain(|m| m.number != number);
        let id = if let Some((_, id)) = self.tpdos.iter().find(|(n, _)| *n == number) {
            let _ = self.engine.set_rpdo(*id, config);
            Some(*id)
        } else {
            match self.engine.add_rpdo(config.clone()) {
                Ok(id) => {
                    self.tpdos.push((number, id));
                    Some(id)
                }
                Err(_) => {
                    let engine = &self.engine;
                    let unused = self.tpdos.iter_mut().find(|(_, id)| {
                        engine
                            .rpdo(*id)
                            .is_none_or(|c| !c.comm.cob_id.is_valid() || c.mapping.is_empty())
                    });
                    match unused {
                        Some(slot) if self.engine.set_rpdo(slot.1, config).is_ok() => {
                            slot.0 = number;
                            Some(slot.1)
                        }
                        _ => None,
                    }
                }
            }
        };
        if let Some(id) = id {
            self.types.retain(|(r, _)| *r != id);
            self.types.push((id, types));
        }
    }

    /// The values of receive PDO `id`'s last reception, typed by the node's dictionary, with
    /// their addresses, in mapping order (dummy entries included), into `out` (cleared first);
    /// `false` when it has none.
    pub(crate) fn received_values(
        &self,
        id: RpdoId,
        out: &mut Vec<(ObjectAddress, Value)>,
    ) -> bool {
        out.clear();
        let Some(unpacked) = self.engine.received(id) else {
            return false;
        };
        let types = self
            .types
            .iter()
            .find(|(r, _)| *r == id)
            .map_or(&[][..], |(_, t)| t.as_slice());
        out.extend(unpacked.iter().enumerate().map(|(i, (obj, raw))| {
            let ty = types.get(i).copied().unwrap_or_else(|| obj.data_type());
            // The type was chosen to agree with the mapping, so this always converts; the
            // fallback keeps a value should a dictionary say otherwise.
            let value = raw
                .to_value(ty)
                .or_else(|_| raw.to_value(obj.data_type()))
                .unwrap_or(Value::Unsigned64(0));
            (obj.addr(), value)
        }));
        true
    }

    /// The node's TPDO number of the engine's receive PDO `id`.
    pub(crate) fn tpdo_number(&self, id: RpdoId) -> Option<u8> {
        self.tpdos.iter().find(|(_, r)| *r == id).map(|(n, _)| *n)
    }

    /// Starts (or reconfigures) transmitting the node's RPDO `number` with `config` (the
    /// node's COB-ID and mapping, the master's transmission parameters). Mapped objects the
    /// application has not set yet are zero.
    pub(crate) fn start_rpdo(
        &mut self,
        now: canola_frame::Instant,
        number: u16,
        config: PdoConfig,
    ) -> Result<(), canola_pdo::EngineError> {
        for o in config.mapping.objects() {
            if !o.is_dummy() && self.image.get(o.addr()).is_none() {
                self.image.set(o.addr(), &vec![0; o.byte_len()]);
            }
        }
        if let Some((_, id)) = self.rpdos.iter().find(|(n, _)| *n == number) {
            return self.engine.set_tpdo(now, *id, config);
        }
        let id = match self.idle.pop() {
            Some(id) => match self.engine.set_tpdo(now, id, config) {
                Ok(()) => id,
                Err(e) => {
                    self.idle.push(id);
                    return Err(e);
                }
            },
            None => self.engine.add_tpdo(now, config)?,
        };
        self.rpdos.push((number, id));
        Ok(())
    }

    /// Stops transmitting the node's RPDO `number`; `false` when it was not transmitted.
    pub(crate) fn stop_rpdo(&mut self, now: canola_frame::Instant, number: u16) -> bool {
        let Some(i) = self.rpdos.iter().position(|(n, _)| *n == number) else {
            return false;
        };
        let (_, id) = self.rpdos.swap_remove(i);
        // An invalid COB-ID makes the engine's PDO take part in nothing.
        if let Some(mut config) = self.engine.tpdo(id).cloned() {
            config.comm.cob_id = config.comm.cob_id.with_valid(false);
            let _ = self.engine.set_tpdo(now, id, config);
        }
        self.idle.push(id);
        true
    }

    /// The engine's transmit PDO of the node's RPDO `number`, when it is being transmitted.
    pub(crate) fn rpdo_id(&self, number: u16) -> Option<TpdoId> {
        self.rpdos
            .iter()
            .find(|(n, _)| *n == number)
            .map(|(_, id)| *id)
    }
}

/// Reads PDO `n` (0-based) of `direction` from the view; `None` when absent or unusable.
pub(crate) fn read_pdo(view: &impl Dictionary, direction: Direction, n: u16) -> Option<PdoConfig> {
    let comm = CommParams::read_from(view, direction.comm_index(n)).ok()?;
    let mapping = Mapping::read_from(view, direction, direction.mapping_index(n)).ok()?;
    Some(PdoConfig::new(comm, mapping))
}

/// Reads PDO `n` (0-based) of `direction` as a CAN FD PDO of more than 8 bytes: its
/// communication parameters, CAN identifier and mapping; `None` when absent, not valid, or
/// fitting a classic PDO.
pub(crate) fn read_fd_pdo(
    view: &impl Dictionary,
    direction: Direction,
    n: u16,
) -> Option<(CommParams, CanId, FdMapping)> {
    let comm = CommParams::read_from(view, direction.comm_index(n)).ok()?;
    if !comm.cob_id.is_valid() {
        return None;
    }
    let mapping = FdMapping::read_from(view, direction, direction.mapping_index(n)).ok()?;
    (mapping.byte_len() > 8).then_some((comm, comm.cob_id.can_id().ok()?, mapping))
}

/// The master's PDOs for one node with a dictionary: the node's TPDOs (from its dictionary,
/// `$NODEID` resolved) mirrored as receive PDOs.
pub(crate) fn mirror_engine(od: &ObjectDictionary, node: canola_frame::NodeId) -> NodePdos {
    let mut pdos = NodePdos::new();
    pdos.mirror_dictionary(od, node);
    pdos
}

impl NodePdos {
    /// Mirrors the TPDO1..4 of the node's dictionary (`$NODEID` resolved); RPDOs being
    /// transmitted stay as they are.
    pub(crate) fn mirror_dictionary(&mut self, od: &ObjectDictionary, node: canola_frame::NodeId) {
        let view = OdView::new(od, node.get());
        for n in 0..4u16 {
            if let Some(c) = read_pdo(&view, Direction::Transmit, n) {
                self.fd_tpdos.retain(|m| m.number != n as u8 + 1);
                self.mirror_tpdo(n as u8 + 1, c, Some(od));
            } else if let Some((_, can_id, mapping)) = read_fd_pdo(&view, Direction::Transmit, n) {
                self.mirror_fd_tpdo(n as u8 + 1, can_id, mapping, Some(od));
            }
        }
    }

    /// The length in bits of `addr` in the node's transmitted RPDO `number`; `None` when the
    /// RPDO is not transmitted or does not map it.
    pub(crate) fn rpdo_bits(&self, number: u16, addr: ObjectAddress) -> Option<Result<u8, ()>> {
        if let Some(r) = self.fd_rpdos.iter().find(|r| r.number == number) {
            return Some(
                r.mapping
                    .objects()
                    .iter()
                    .find(|o| !o.entry.is_dummy() && o.entry.addr() == addr)
                    .map(|o| o.bits())
                    .ok_or(()),
            );
        }
        let config = self.engine.tpdo(self.rpdo_id(number)?)?;
        Some(
            config
                .mapping
                .objects()
                .iter()
                .find(|o| !o.is_dummy() && o.addr() == addr)
                .map(|o| o.bits())
                .ok_or(()),
        )
    }
}

/// A node's TPDO as the master's receive PDO: taken the moment it arrives. A synchronous TPDO
/// mirrored as a synchronous RPDO would wait for the next SYNC, which the master (the SYNC
/// producer) never receives; so the mirror is event-driven whatever the node's type.
///
/// The mirror arms no receive deadline (the event timer is cleared): the master reports no
/// missing TPDOs, and a deadline re-armed by every reception would cost each received frame a
/// timer update.
pub(crate) fn mirrored(mut config: PdoConfig) -> PdoConfig {
    config.comm = config
        .comm
        .with_transmission_type(canola_pdo::TransmissionType::EventManufacturer)
        .with_event_timer(0);
    config
}

/// `mapping` with value kinds from the node's dictionary (a mapping built from raw entries
/// decodes everything as unsigned); unchanged when the dictionary refuses it.
pub(crate) fn typed_mapping(
    od: &ObjectDictionary,
    node: canola_frame::NodeId,
    direction: Direction,
    mapping: Mapping,
) -> Mapping {
    let view = OdView::new(od, node.get());
    let raw: Vec<u32> = mapping.raw_entries().collect();
    Mapping::from_raw_checked(direction, &raw, &view).unwrap_or(mapping)
}
