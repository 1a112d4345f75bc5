//! The SDO sequences behind the PDO handles, as straight-line async code over the node's SDO
//! operations: reading a direction's PDOs, saving the changed ones the CiA 301 way (invalidate,
//! clear the mapping, entries, count, parameters, COB-ID), and [`Node::remap_pdo`].

use std::sync::Arc;

use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::{
    CommParams, Direction, FdMapping, Mapping, MappingEntry, PdoCobId, PdoConfig, RemoteObjects,
    TransmissionType,
};
use canola_sdo::AbortCode;

use crate::error::{Error, FdRefusal, Misuse, PdoProblem, ValueProblem};
use crate::network::Operation;
use crate::network::request::NodeRef;

use super::params::{MappedVariable, PdoParameters, PdoSet, Present, name_of};

/// The master follows what the node holds for `p`: a TPDO is decoded with it, a transmitted
/// RPDO uses its COB-ID and mapping.
pub(super) fn follow(node: &NodeRef, p: &PdoParameters) {
    let Some(mapping) = p.mapping_lenient() else {
        // A TPDO of more than 8 bytes (CANopen FD) is decoded from its CAN FD frames.
        if p.direction == Direction::Transmit
            && p.comm.cob_id.is_valid()
            && let Ok(number) = u8::try_from(p.number)
            && let Some(fd) = p.fd_mapping_lenient()
            && let Ok(can_id) = p.comm.cob_id.can_id()
        {
            node.net.core().mirror_fd_tpdo(node.id, number, can_id, fd);
        }
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

/// Reads a 32-bit value (or fewer bits, zero-extended) of the node.
async fn read_u32(node: &NodeRef, index: u16, sub: u8) -> Result<u32, Error> {
    node.sdo()
        .read(ObjectAddress::new(index, sub))
        .await
        .map(|b| le_u32(&b))
}

/// An optional sub-index: per the dictionary when there is one, else as the node answers.
async fn read_optional(
    node: &NodeRef,
    od: Option<&ObjectDictionary>,
    index: u16,
    sub: u8,
) -> Result<Option<u32>, Error> {
    if let Some(od) = od
        && od.sub(index, sub).is_none()
    {
        return Ok(None);
    }
    match read_u32(node, index, sub).await {
        Ok(v) => Ok(Some(v)),
        Err(e) if absent(&e) => Ok(None),
        Err(e) => Err(e),
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

pub(super) async fn read_set(node: &NodeRef, direction: Direction) -> Result<PdoSet, Error> {
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
        if let Some(p) = read_pdo(node, od.clone(), direction, n).await? {
            pdos.push(p);
        }
    }
    for p in &pdos {
        follow(node, p);
    }
    Ok(PdoSet { direction, pdos })
}

/// Reads PDO `n` (0-based); `None` when the node does not have it.
async fn read_pdo(
    node: &NodeRef,
    od: Option<Arc<ObjectDictionary>>,
    direction: Direction,
    n: u16,
) -> Result<Option<PdoParameters>, Error> {
    let (ci, mi) = (direction.comm_index(n), direction.mapping_index(n));
    let cob_id = match read_u32(node, ci, 1).await {
        Ok(v) => PdoCobId(v),
        Err(e) if od.is_none() && absent(&e) => return Ok(None),
        Err(e) => return Err(e),
    };
    let transmission_type = TransmissionType::from_code(read_u32(node, ci, 2).await? as u8);
    let inhibit = read_optional(node, od.as_deref(), ci, 3).await?;
    let event = read_optional(node, od.as_deref(), ci, 5).await?;
    let sync = read_optional(node, od.as_deref(), ci, 6).await?;
    let count = read_u32(node, mi, 0).await?;
    let mut entries = Vec::new();
    let mpdo = if count > 64 {
        Some(count as u8)
    } else {
        for sub in 1..=count as u8 {
            entries.push(read_u32(node, mi, sub).await?);
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
        node: node.id,
        od,
    }))
}

pub(super) async fn save_set(
    node: &NodeRef,
    direction: Direction,
    set: &mut PdoSet,
) -> Result<(), Error> {
    if set.direction != direction {
        return Err(Error::InvalidRequest(Misuse::PdoDirection {
            set: set.direction,
            saved_as: direction,
        }));
    }
    for p in &set.pdos {
        if p.node != node.id {
            return Err(Error::InvalidRequest(Misuse::PdoOfOtherNode {
                read_from: p.node,
                saved_to: node.id,
            }));
        }
    }
    for p in &mut set.pdos {
        if !p.is_changed() {
            continue;
        }
        if p.mpdo.is_some() {
            return Err(p.error(PdoProblem::MpdoNotSaved));
        }
        // The mapping is checked before anything is sent.
        let mapping = match p.mapping() {
            Ok(m) => PdoMapping::Classic(Box::new(m)),
            // More than 8 bytes: a CANopen FD PDO, where the node and the bus allow it.
            Err(classic) => match p.fd_mapping() {
                Ok(fd) => fd_allowed(node, fd).map_err(|why| p.error(why))?,
                Err(_) => return Err(classic),
            },
        };
        let remote = RemoteObjects {
            mapping_writable: p.present.mapping_writable,
            current_mapping: Some(&p.saved.1),
            has_inhibit_time: p.present.inhibit_time,
            has_event_timer: p.present.event_timer,
            has_sync_start: p.present.sync_start,
        };
        configure(node, direction, p.number - 1, &p.comm, mapping, &remote).await?;
        p.saved = (p.comm, p.raw_entries().collect());
    }
    Ok(())
}

/// A mapping checked under the limit of its PDO: classic CAN (8 bytes) or CAN FD (64 bytes).
enum PdoMapping {
    Classic(Box<Mapping>),
    Fd(Box<FdMapping>),
}

/// `fd` as a PDO mapping when it fits a classic frame, or when the node is marked CANopen FD
/// and the bus carries CAN FD; otherwise why not, in bits and bytes.
fn fd_allowed(node: &NodeRef, fd: FdMapping) -> Result<PdoMapping, PdoProblem> {
    if let Ok(classic) = Mapping::try_from(&fd) {
        return Ok(PdoMapping::Classic(Box::new(classic)));
    }
    let bus = node.net.core().classic_bus().map(|b| b.to_string());
    let refusal = if let Some(bus) = bus {
        FdRefusal::ClassicBus { bus }
    } else if !node.is_fd() {
        FdRefusal::NodeNotFd
    } else {
        return Ok(PdoMapping::Fd(Box::new(fd)));
    };
    Err(PdoProblem::NeedsFd {
        bits: fd.bit_len(),
        node: node.id,
        refusal,
    })
}

/// Gives PDO `n` (0-based) of the node `comm` and `mapping` by SDO, the CiA 301 way (the plan
/// from `canola_pdo::remap`), then makes the master follow: a TPDO is decoded with the new
/// mapping, a transmitted RPDO uses the new COB-ID and mapping. [`Node::remap_pdo`] and
/// `save()` both come here.
async fn configure(
    node: &NodeRef,
    direction: Direction,
    n: u16,
    comm: &CommParams,
    mapping: PdoMapping,
    remote: &RemoteObjects<'_>,
) -> Result<(), Error> {
    let steps = match &mapping {
        PdoMapping::Classic(m) => canola_pdo::remap(direction, n, comm, m, remote),
        PdoMapping::Fd(m) => canola_pdo::remap_fd(direction, n, comm, m, remote),
    }
    .map_err(|e| Error::Value {
        node: node.id,
        entry: ObjectAddress::new(direction.comm_index(n), 0),
        problem: ValueProblem::Remap(e),
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
        node.sdo()
            .write(ObjectAddress::new(step.index, step.subindex), step.value())
            .await?;
    }
    let mapping = match mapping {
        PdoMapping::Classic(m) => *m,
        PdoMapping::Fd(fd) => {
            // A TPDO of more than 8 bytes is decoded from its CAN FD frames from now on; an
            // RPDO of more than 8 bytes is transmitted by `Rpdos::start` with what was saved.
            if direction == Direction::Transmit
                && comm.cob_id.is_valid()
                && let Ok(number) = u8::try_from(n + 1)
                && let Ok(can_id) = comm.cob_id.can_id()
            {
                node.net.core().mirror_fd_tpdo(node.id, number, can_id, *fd);
            }
            return Ok(());
        }
    };
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

/// The remap of [`Node::remap_pdo`](crate::Node::remap_pdo): PDO `number` (1-based) of
/// `direction` on `node`. A mapping of more than 8 bytes needs a node marked CANopen FD on a
/// CAN FD bus (checked before anything is sent).
pub(crate) fn remap(
    node: NodeRef,
    direction: canola_pdo::Direction,
    number: u16,
    comm: canola_pdo::CommParams,
    mapping: FdMapping,
) -> Operation<'static, ()> {
    let n = number.saturating_sub(1);
    let mapping = fd_allowed(&node, mapping).map_err(|problem| Error::Value {
        node: node.id,
        entry: ObjectAddress::new(direction.comm_index(n), 0),
        problem: ValueProblem::Pdo {
            direction,
            number,
            problem,
        },
    });
    let mut remote = canola_pdo::RemoteObjects::dynamic(direction);
    // With a dictionary, write only the sub-indices the node has.
    if let Some(od) = node.dictionary() {
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
    Operation::new(async move { configure(&node, direction, n, &comm, mapping?, &remote).await })
}
