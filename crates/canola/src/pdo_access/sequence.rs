//! The SDO sequences behind the PDO handles, written once for the blocking and the async API
//! over a [`Port`]: reading a direction's PDOs, saving the changed ones the CiA 301 way
//! (invalidate, clear the mapping, entries, count, parameters, COB-ID), and
//! [`Node::remap_pdo`].

use std::sync::Arc;

use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::{
    CommParams, Direction, Mapping, MappingEntry, PdoCobId, PdoConfig, RemoteObjects,
    TransmissionType,
};
use canola_sdo::AbortCode;

use crate::error::Error;
use crate::network::Node;

use super::params::{MappedVariable, PdoParameters, PdoSet, Present, kind_name, name_of};

/// The master follows what the node holds for `p`: a TPDO is decoded with it, a transmitted
/// RPDO uses its COB-ID and mapping.
pub(super) fn follow(node: &Node, p: &PdoParameters) {
    let Some(mapping) = p.mapping_lenient() else {
        return;
    };
    let mut core = node.net.core();
    match p.direction {
        Direction::Transmit => {
            if let Ok(number) = u8::try_from(p.number) {
                core.mirror_tpdo(node.id, number, PdoConfig::new(p.comm, mapping));
            }
        }
        Direction::Receive => {
            let _ = core.retarget_rpdo(node.id, p.number, p.comm, mapping);
        }
    }
}

/// How the PDO services reach a node's objects: by the blocking SDO calls, or by their async
/// twins. The services are written once, as async functions over a port; with the blocking
/// port every await is ready at once, so [`Port::run`] completes them in one poll.
#[derive(Clone, Copy)]
pub(super) enum Port<'a> {
    Blocking(&'a Node),
    #[cfg(feature = "tokio")]
    Async(&'a Node),
}

impl Port<'_> {
    pub(super) fn node(&self) -> &Node {
        match self {
            Port::Blocking(node) => node,
            #[cfg(feature = "tokio")]
            Port::Async(node) => node,
        }
    }

    pub(super) async fn read(&self, addr: ObjectAddress) -> Result<Vec<u8>, Error> {
        match self {
            Port::Blocking(node) => node.sdo().read(addr),
            #[cfg(feature = "tokio")]
            Port::Async(node) => node.sdo().read_async(addr).await,
        }
    }

    pub(super) async fn write(&self, addr: ObjectAddress, bytes: &[u8]) -> Result<(), Error> {
        match self {
            Port::Blocking(node) => node.sdo().write(addr, bytes),
            #[cfg(feature = "tokio")]
            Port::Async(node) => node.sdo().write_async(addr, bytes).await,
        }
    }

    pub(super) async fn read_u32(&self, index: u16, sub: u8) -> Result<u32, Error> {
        self.read(ObjectAddress::new(index, sub))
            .await
            .map(|b| le_u32(&b))
    }

    /// An optional sub-index: per the dictionary when there is one, else as the node answers.
    pub(super) async fn read_optional(
        &self,
        od: Option<&ObjectDictionary>,
        index: u16,
        sub: u8,
    ) -> Result<Option<u32>, Error> {
        if let Some(od) = od
            && od.sub(index, sub).is_none()
        {
            return Ok(None);
        }
        match self.read_u32(index, sub).await {
            Ok(v) => Ok(Some(v)),
            Err(e) if absent(&e) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// Completes a service on the blocking port: one poll, every SDO call in it has blocked
    /// until done.
    pub(super) fn run<T>(
        self,
        service: impl Future<Output = Result<T, Error>>,
    ) -> Result<T, Error> {
        let mut service = std::pin::pin!(service);
        let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
        match service.as_mut().poll(&mut cx) {
            std::task::Poll::Ready(r) => r,
            // Only the async port's calls can be pending, and `run` is for the blocking one.
            std::task::Poll::Pending => Err(Error::Driver(
                "a PDO service on the blocking port did not complete".into(),
            )),
        }
    }
}

/// The async twins of the PDO services (`tokio` feature; see the `asynch` module). Dropping one
/// of these futures cancels the SDO transfer it is in; a `save` dropped half-way leaves the PDO
/// as far as the sequence got (invalid on the node until saved again).
impl Node {
    /// Remaps PDO `number` (1-based) of `direction` on the node by SDO, the CiA 301 way
    /// (disable, clear mapping, write entries, set count, set parameters, enable; the plan comes
    /// from `canola_pdo::remap`; the same sequence `node.tpdo().save()` uses). After a TPDO
    /// remap the master decodes that TPDO from its COB-ID with the new mapping; after an RPDO
    /// remap an RPDO the master transmits ([`Rpdos::start`](crate::Rpdos::start)) follows.
    pub fn remap_pdo(
        &self,
        direction: canola_pdo::Direction,
        number: u16,
        comm: canola_pdo::CommParams,
        mapping: canola_pdo::Mapping,
    ) -> Result<(), Error> {
        let n = number.saturating_sub(1);
        let mut remote = canola_pdo::RemoteObjects::dynamic(direction);
        // With a dictionary, write only the sub-indices the node has.
        if let Some(od) = self.dictionary() {
            let ci = direction.comm_index(n);
            let has = |sub| od.sub(ci, sub).is_some();
            remote.has_inhibit_time = has(3);
            remote.has_event_timer = has(5);
            remote.has_sync_start = has(6);
            // Dynamic mapping (CiA 301 §7.4.8.3): sub 0 of the mapping object is writable.
            remote.mapping_writable = od
                .sub(direction.mapping_index(n), 0)
                .is_none_or(|s| s.access.is_writable());
        }
        configure(self, direction, n, &comm, mapping, &remote)
    }
}

/// Whether an SDO error says the object or sub-index is not there.
pub(super) fn absent(e: &Error) -> bool {
    matches!(
        e.server_abort(),
        Some(AbortCode::OBJECT_DOES_NOT_EXIST | AbortCode::SUBINDEX_DOES_NOT_EXIST)
    )
}

pub(super) fn le_u32(bytes: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    let n = bytes.len().min(4);
    b[..n].copy_from_slice(&bytes[..n]);
    u32::from_le_bytes(b)
}

pub(super) async fn read_set(port: Port<'_>, direction: Direction) -> Result<PdoSet, Error> {
    let node = port.node();
    let od = node.dictionary();
    let numbers: Vec<u16> = match od.as_deref() {
        Some(od) => (0..canola_pdo::comm::MAX_PDOS_PER_DIRECTION)
            .filter(|n| {
                od.get(direction.comm_index(*n)).is_some()
                    && od.get(direction.mapping_index(*n)).is_some()
            })
            .collect(),
        None => (0..4).collect(),
    };
    let mut pdos = Vec::new();
    for n in numbers {
        if let Some(p) = read_pdo(port, od.clone(), direction, n).await? {
            pdos.push(p);
        }
    }
    for p in &pdos {
        follow(node, p);
    }
    Ok(PdoSet { direction, pdos })
}

/// Reads PDO `n` (0-based); `None` when the node does not have it.
pub(super) async fn read_pdo(
    port: Port<'_>,
    od: Option<Arc<ObjectDictionary>>,
    direction: Direction,
    n: u16,
) -> Result<Option<PdoParameters>, Error> {
    let (ci, mi) = (direction.comm_index(n), direction.mapping_index(n));
    let cob_id = match port.read_u32(ci, 1).await {
        Ok(v) => PdoCobId(v),
        Err(e) if od.is_none() && absent(&e) => return Ok(None),
        Err(e) => return Err(e),
    };
    let transmission_type = TransmissionType::from_code(port.read_u32(ci, 2).await? as u8);
    let inhibit = port.read_optional(od.as_deref(), ci, 3).await?;
    let event = port.read_optional(od.as_deref(), ci, 5).await?;
    let sync = port.read_optional(od.as_deref(), ci, 6).await?;
    let count = port.read_u32(mi, 0).await?;
    let mut entries = Vec::new();
    let mpdo = if count > 64 {
        Some(count as u8)
    } else {
        for sub in 1..=count as u8 {
            entries.push(port.read_u32(mi, sub).await?);
        }
        None
    };
    let comm = CommParams {
        cob_id,
        transmission_type,
        inhibit_time: inhibit.unwrap_or(0) as u16,
        event_timer: event.unwrap_or(0) as u16,
        sync_start: sync.unwrap_or(0) as u8,
    };
    let mapping_writable = od
        .as_deref()
        .and_then(|od| od.sub(mi, 0))
        .is_none_or(|s| s.access.is_writable());
    let mapped = entries
        .iter()
        .map(|&raw| {
            let e = MappingEntry(raw);
            MappedVariable {
                addr: e.addr(),
                bits: e.bits(),
                name: od.as_deref().and_then(|od| name_of(od, e.addr())),
            }
        })
        .collect();
    Ok(Some(PdoParameters {
        direction,
        number: n + 1,
        comm,
        mapped,
        present: Present {
            inhibit_time: inhibit.is_some(),
            event_timer: event.is_some(),
            sync_start: sync.is_some(),
            mapping_writable,
        },
        mpdo,
        saved: (comm, entries),
        node: port.node().id,
        od,
    }))
}

pub(super) async fn save_set(
    port: Port<'_>,
    direction: Direction,
    set: &mut PdoSet,
) -> Result<(), Error> {
    let node = port.node();
    if set.direction != direction {
        return Err(Error::InvalidRequest(format!(
            "a set of {}s cannot be saved as {}s",
            kind_name(set.direction),
            kind_name(direction)
        )));
    }
    for p in &set.pdos {
        if p.node != node.id {
            return Err(Error::InvalidRequest(format!(
                "these PDO parameters were read from node {}, not node {}",
                p.node, node.id
            )));
        }
    }
    for p in &mut set.pdos {
        if !p.is_changed() {
            continue;
        }
        if p.mpdo.is_some() {
            return Err(p.error("an MPDO mapping is not saved by this API".into()));
        }
        // The mapping is checked before anything is sent.
        let mapping = p.mapping()?;
        let remote = RemoteObjects {
            mapping_writable: p.present.mapping_writable,
            current_mapping: Some(&p.saved.1),
            has_inhibit_time: p.present.inhibit_time,
            has_event_timer: p.present.event_timer,
            has_sync_start: p.present.sync_start,
        };
        configure_with(port, direction, p.number - 1, &p.comm, mapping, &remote).await?;
        p.saved = (p.comm, p.raw_entries().collect());
    }
    Ok(())
}

/// Gives PDO `n` (0-based) of the node `comm` and `mapping` by SDO, the CiA 301 way (the plan
/// from `canola_pdo::remap`), then makes the master follow: a TPDO is decoded with the new
/// mapping, a transmitted RPDO uses the new COB-ID and mapping. [`Node::remap_pdo`] and
/// `save()` both come here.
pub(crate) fn configure(
    node: &Node,
    direction: Direction,
    n: u16,
    comm: &CommParams,
    mapping: Mapping,
    remote: &RemoteObjects<'_>,
) -> Result<(), Error> {
    Port::Blocking(node).run(configure_with(
        Port::Blocking(node),
        direction,
        n,
        comm,
        mapping,
        remote,
    ))
}

pub(super) async fn configure_with(
    port: Port<'_>,
    direction: Direction,
    n: u16,
    comm: &CommParams,
    mapping: Mapping,
    remote: &RemoteObjects<'_>,
) -> Result<(), Error> {
    let node = port.node();
    let steps =
        canola_pdo::remap(direction, n, comm, &mapping, remote).map_err(|e| Error::Value {
            node: node.id,
            entry: ObjectAddress::new(direction.comm_index(n), 0),
            message: e.to_string(),
        })?;
    // No step is sent when one would give the PDO a restricted identifier.
    for step in &steps {
        if let Some(can_id) = crate::restricted_cob_id(step.index, step.subindex, step.value_u32())
        {
            return Err(Error::RestrictedCobId {
                node: node.id,
                entry: ObjectAddress::new(step.index, step.subindex),
                can_id,
            });
        }
    }
    for step in &steps {
        port.write(ObjectAddress::new(step.index, step.subindex), step.value())
            .await?;
    }
    let mapping = match node.dictionary() {
        Some(od) => crate::machine::pdo::typed_mapping(&od, node.id, direction, mapping),
        None => mapping,
    };
    let mut core = node.net.core();
    match direction {
        Direction::Transmit => {
            if let Ok(number) = u8::try_from(n + 1) {
                core.mirror_tpdo(node.id, number, PdoConfig::new(*comm, mapping));
            }
        }
        Direction::Receive => {
            let _ = core.retarget_rpdo(node.id, n + 1, *comm, mapping);
        }
    }
    Ok(())
}
