//! The master machine's PDOs: TPDOs received from nodes (routed by COB-ID, decoded by the
//! mirrored mapping, handed to subscribers and callbacks) and the RPDOs it transmits to nodes
//! from its process image (CiA 301 §7.2.2).

use std::collections::VecDeque;

use canola_frame::cob::FunctionCode;
use std::sync::Arc;

use canola_frame::{CanFrame, CanId, CobId, FdFrame, Instant, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary, Value};

use super::Core;
use super::events::{NetworkEvent, PdoCallback, PdoCallbackId, PdoData, PdoReceived};
use super::sdo::{OutFrame, Outgoing};
use super::subscribers::Subscribers;
use crate::pdo_subscriber::{PdoPublisher, PdoSubscriber, pdo_subscription};

impl Core {
    pub(crate) fn subscribe_pdos(&mut self) -> PdoSubscriber {
        let (publisher, subscriber) = pdo_subscription();
        self.pdo_subs.push(publisher);
        subscriber
    }

    pub(crate) fn add_pdo_callback(&mut self, f: PdoCallback) -> PdoCallbackId {
        let id = PdoCallbackId(self.next_callback);
        self.next_callback += 1;
        self.pdo_callbacks.push((id, f));
        id
    }

    pub(crate) fn remove_pdo_callback(&mut self, id: PdoCallbackId) -> bool {
        let before = self.pdo_callbacks.len();
        self.pdo_callbacks.retain(|(i, _)| *i != id);
        self.pdo_callbacks.len() != before
    }

    /// The master's view of a node's TPDO `number` (1-based) after a remap or a read of its
    /// parameters: received frames decode with `config` from now on, from its COB-ID.
    pub(crate) fn mirror_tpdo(&mut self, node: NodeId, number: u8, config: canola_pdo::PdoConfig) {
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let pdos = slot
            .pdo
            .get_or_insert_with(crate::machine::pdo::NodePdos::new);
        pdos.mirror_tpdo(number, config, slot.od.as_deref());
        Self::pdo_touched(pdos, &mut self.pdo_next);
        self.route_pdos();
    }

    /// The master's view of a node's TPDO `number` of more than 8 bytes after a read of its
    /// parameters: decoded from CAN FD frames on `can_id` from now on.
    pub(crate) fn mirror_fd_tpdo(
        &mut self,
        node: NodeId,
        number: u8,
        can_id: CanId,
        mapping: canola_pdo::FdMapping,
    ) {
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let pdos = slot
            .pdo
            .get_or_insert_with(crate::machine::pdo::NodePdos::new);
        pdos.mirror_fd_tpdo(number, can_id, mapping, slot.od.as_deref());
        self.route_pdos();
    }

    /// Rebuilds the COB-ID routes of TPDOs outside the predefined connection set.
    pub(super) fn route_pdos(&mut self) {
        self.pdo_routes.clear();
        for (node, slot) in self.nodes.iter() {
            let Some(pdos) = &slot.pdo else {
                continue;
            };
            for (_, id) in &pdos.tpdos {
                let Some(config) = pdos.engine.rpdo(*id) else {
                    continue;
                };
                if !config.comm.cob_id.is_valid() || config.mapping.is_empty() {
                    continue;
                }
                let Ok(can_id) = config.comm.cob_id.can_id() else {
                    continue;
                };
                let predefined = can_id
                    .as_standard()
                    .and_then(CobId::classify)
                    .is_some_and(|c| {
                        matches!(c.function, FunctionCode::Tpdo(_)) && c.node == Some(node)
                    });
                if !predefined {
                    self.pdo_routes.insert(can_id, node);
                }
            }
        }
    }

    /// Starts transmitting `node`'s RPDO `number` with `config` (see
    /// [`NodePdos::start_rpdo`](crate::machine::pdo::NodePdos::start_rpdo)).
    pub(crate) fn start_rpdo(
        &mut self,
        node: NodeId,
        number: u16,
        config: canola_pdo::PdoConfig,
    ) -> Result<(), canola_pdo::EngineError> {
        let now = self.now;
        self.add_node(node, None);
        let Some(slot) = self.nodes.get_mut(&node) else {
            return Err(canola_pdo::EngineError::UnknownPdo);
        };
        let pdos = slot
            .pdo
            .get_or_insert_with(crate::machine::pdo::NodePdos::new);
        let r = pdos.start_rpdo(now, number, config);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        r
    }

    /// Reconfigures a transmitted RPDO with the node's new COB-ID and mapping, keeping the
    /// master's transmission parameters; nothing when it is not transmitted.
    pub(crate) fn retarget_rpdo(
        &mut self,
        node: NodeId,
        number: u16,
        comm: canola_pdo::CommParams,
        mapping: canola_pdo::Mapping,
    ) -> Result<(), canola_pdo::EngineError> {
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return Ok(());
        };
        let Some(id) = pdos.rpdo_id(number) else {
            return Ok(());
        };
        let Some(old) = pdos.engine.tpdo(id).cloned() else {
            return Ok(());
        };
        let mut config = canola_pdo::PdoConfig::new(old.comm, mapping);
        config.comm.cob_id = comm.cob_id;
        let now = self.now;
        let r = pdos.start_rpdo(now, number, config);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        r
    }

    /// Stops transmitting `node`'s RPDO `number`; `false` when it was not transmitted.
    pub(crate) fn stop_rpdo(&mut self, node: NodeId, number: u16) -> bool {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return false;
        };
        let stopped = pdos.stop_rpdo(now, number) | pdos.stop_fd_rpdo(number);
        Self::pdo_touched(pdos, &mut self.pdo_next);
        stopped
    }

    /// Sets mapped values of `node`'s transmitted RPDOs (little-endian, sized as mapped) and
    /// lets the engine see the change: event-driven RPDOs go out now or after their inhibit
    /// time, synchronous acyclic ones at the next SYNC.
    pub(crate) fn set_rpdo_values(&mut self, node: NodeId, values: &[(ObjectAddress, Vec<u8>)]) {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return;
        };
        for (addr, bytes) in values {
            pdos.image.set(*addr, bytes);
        }
        pdos.engine.update(now, &mut pdos.image);
        for frame in pdos.fd_frames(None) {
            self.tx.push_back(Outgoing {
                frame: OutFrame::Fd(Box::new(frame)),
                transfer: None,
            });
        }
        Self::drain_pdos(pdos, &mut self.tx, &mut self.pdo_next);
    }

    /// Starts transmitting `node`'s RPDO `number` of more than 8 bytes as CAN FD frames on
    /// `can_id` (see [`NodePdos::start_fd_rpdo`](crate::machine::pdo::NodePdos::start_fd_rpdo));
    /// the first frame is queued.
    pub(crate) fn start_fd_rpdo(
        &mut self,
        node: NodeId,
        number: u16,
        can_id: CanId,
        mapping: canola_pdo::FdMapping,
    ) {
        self.add_node(node, None);
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let pdos = slot
            .pdo
            .get_or_insert_with(crate::machine::pdo::NodePdos::new);
        pdos.start_fd_rpdo(number, can_id, mapping);
        for frame in pdos.fd_frames(Some(number)) {
            self.tx.push_back(Outgoing {
                frame: OutFrame::Fd(Box::new(frame)),
                transfer: None,
            });
        }
        Self::pdo_touched(pdos, &mut self.pdo_next);
    }

    /// A CAN FD frame no USDO transfer took: a node's TPDO of more than 8 bytes decoded
    /// through its CAN FD mirror, or a TPDO of at most 8 bytes sent as a CAN FD frame, taken as
    /// the classic frame it would be.
    pub(super) fn handle_fd_pdo(&mut self, now: Instant, frame: &FdFrame) {
        let id = frame.id();
        let hit = self.nodes.iter().find_map(|(node, slot)| {
            slot.pdo
                .as_ref()
                .and_then(|p| p.fd_tpdo_on(id))
                .map(|n| (node, n))
        });
        if let Some((node, number)) = hit {
            let Some(slot) = self.nodes.get(&node) else {
                return;
            };
            let Some(pdos) = &slot.pdo else { return };
            let decoded = pdos.decode_fd(number, frame.data(), &mut self.pdo_scratch);
            let od = slot.od.clone();
            let data = PdoData::new(frame.data());
            if decoded {
                deliver_values(
                    &mut self.pdo_callbacks,
                    &mut self.pdo_subs,
                    &mut self.subs,
                    &mut self.pdo_scratch,
                    (node, number, data, now),
                    od.as_ref(),
                );
            } else {
                self.deliver_raw(node, number, data, now);
            }
            return;
        }
        if frame.data().len() > 8 {
            return;
        }
        let Ok(classic) = CanFrame::new(id, frame.data()) else {
            return;
        };
        if let Some(&node) = self.pdo_routes.get(&id) {
            self.handle_tpdo(now, node, None, &classic);
        } else if let Some(CobId {
            function: FunctionCode::Tpdo(n),
            node: Some(node),
        }) = id.as_standard().and_then(CobId::classify)
        {
            self.handle_tpdo(now, node, Some(n.get()), &classic);
        }
    }

    /// A PDO whose data was not decoded: the raw data to callbacks, subscribers and events.
    fn deliver_raw(&mut self, node: NodeId, number: u8, data: PdoData, now: Instant) {
        let seen = PdoReceived {
            node,
            number,
            data: &data,
            values: &[],
            at: now,
            dictionary: None,
        };
        for (_, f) in &mut self.pdo_callbacks {
            f(&seen);
        }
        for s in &mut self.pdo_subs {
            s.push(node, number, data, now, None, &[]);
        }
        self.publish(NetworkEvent::Pdo {
            node,
            number,
            data,
            at: now,
        });
    }

    /// The length in bits of `addr` in `node`'s transmitted RPDO `number`: `None` when that
    /// RPDO is not transmitted, `Some(Err(()))` when it does not map `addr`.
    pub(crate) fn rpdo_bits(
        &self,
        node: NodeId,
        number: u16,
        addr: ObjectAddress,
    ) -> Option<Result<u8, ()>> {
        self.nodes.get(&node)?.pdo.as_ref()?.rpdo_bits(number, addr)
    }

    /// An application event for `node`'s transmitted RPDO `number`.
    pub(crate) fn trigger_rpdo(&mut self, node: NodeId, number: u16) -> bool {
        let now = self.now;
        let Some(pdos) = self.nodes.get_mut(&node).and_then(|s| s.pdo.as_mut()) else {
            return false;
        };
        if pdos.fd_rpdos.iter().any(|r| r.number == number) {
            for frame in pdos.fd_frames(Some(number)) {
                self.tx.push_back(Outgoing {
                    frame: OutFrame::Fd(Box::new(frame)),
                    transfer: None,
                });
            }
            return true;
        }
        let Some(id) = pdos.rpdo_id(number) else {
            return false;
        };
        let ok = pdos.engine.trigger(now, id, &mut pdos.image).is_ok();
        Self::drain_pdos(pdos, &mut self.tx, &mut self.pdo_next);
        ok
    }

    /// Queues a node engine's frames; its events other than receptions (deadlines, store
    /// failures) have no subscriber yet and are dropped.
    pub(super) fn drain_pdos(
        pdos: &mut crate::machine::pdo::NodePdos,
        tx: &mut VecDeque<Outgoing>,
        bound: &mut Option<Instant>,
    ) {
        while let Some(frame) = pdos.engine.poll_transmit() {
            tx.push_back(Outgoing {
                frame: frame.into(),
                transfer: None,
            });
        }
        while pdos.engine.poll_event().is_some() {}
        Self::pdo_touched(pdos, bound);
    }

    /// After an input to a node's engine: its next deadline, and the core's bound lowered to
    /// it.
    pub(super) fn pdo_touched(
        pdos: &mut crate::machine::pdo::NodePdos,
        bound: &mut Option<Instant>,
    ) {
        pdos.next = pdos.engine.poll_timeout();
        if let Some(t) = pdos.next {
            *bound = Some(bound.map_or(t, |b| b.min(t)));
        }
    }

    /// A TPDO of `node` (`predefined`: its number in the predefined connection set, when it
    /// came on such a COB-ID): the raw event, then the values decoded through the mirror.
    pub(super) fn handle_tpdo(
        &mut self,
        now: Instant,
        node: NodeId,
        predefined: Option<u8>,
        frame: &CanFrame,
    ) {
        let data = PdoData::new(frame.data());
        let mut number = None;
        let mut decoded = false;
        if let Some(slot) = self.nodes.get_mut(&node)
            && let Some(pdos) = &mut slot.pdo
            && pdos
                .engine
                .handle_frame(now, frame, &mut canola_pdo::NullStore)
        {
            // The mirror arms no receive deadlines (see `machine::pdo::mirrored`), so a reception
            // leaves the engine's timers as they were.
            while let Some(ev) = pdos.engine.poll_event() {
                match ev {
                    canola_pdo::Event::Received { pdo, .. } => {
                        let Some(n) = number.or_else(|| pdos.tpdo_number(pdo)).or(predefined)
                        else {
                            continue;
                        };
                        number = Some(n);
                        if pdos.received_values(pdo, &mut self.pdo_scratch) {
                            decoded = true;
                            deliver_values(
                                &mut self.pdo_callbacks,
                                &mut self.pdo_subs,
                                &mut self.subs,
                                &mut self.pdo_scratch,
                                (node, n, data, now),
                                slot.od.as_ref(),
                            );
                        }
                    }
                    canola_pdo::Event::LengthError { pdo, .. }
                    | canola_pdo::Event::LengthExceeded { pdo, .. } => {
                        number = number.or_else(|| pdos.tpdo_number(pdo));
                    }
                    _ => {}
                }
            }
        }
        if decoded {
            return;
        }
        let Some(number) = number.or(predefined) else {
            return;
        };
        self.deliver_raw(node, number, data, now);
    }
}

/// Hands decoded PDO values (in `scratch`) to the callbacks, the batch subscribers and the
/// event subscribers, in that order. The last taker gets the values without a copy of each
/// (the scratch starts again with room for as many).
pub(super) fn deliver_values(
    callbacks: &mut [(PdoCallbackId, PdoCallback)],
    pdo_subs: &mut [PdoPublisher],
    subs: &mut Subscribers,
    scratch: &mut Vec<(ObjectAddress, Value)>,
    (node, number, data, now): (NodeId, u8, PdoData, Instant),
    od: Option<&Arc<ObjectDictionary>>,
) {
    let seen = PdoReceived {
        node,
        number,
        data: &data,
        values: scratch,
        at: now,
        dictionary: od.map(|d| &**d),
    };
    for (_, f) in callbacks.iter_mut() {
        f(&seen);
    }
    if let Some((last, others)) = pdo_subs.split_last_mut() {
        for s in others {
            s.push(node, number, data, now, od, scratch);
        }
        if subs.is_empty() {
            last.push_moving(node, number, data, now, od, scratch);
            return;
        }
        last.push(node, number, data, now, od, scratch);
    }
    if !subs.is_empty() {
        let room = scratch.len();
        let values = core::mem::replace(scratch, Vec::with_capacity(room));
        subs.deliver(NetworkEvent::PdoValues {
            node,
            number,
            data,
            values,
            at: now,
        });
    }
}
