//! A simulated device's own PDOs (CiA 301 §7.2.2): the `canola-pdo` engine configured from the
//! device's current values of its PDO parameter objects, over those values as its process image.
//!
//! A device marked CANopen FD also runs its PDOs of more than 8 bytes ([`FdPdos`]), as CAN FD
//! frames mapped through `canola-pdo`'s [`FdMapping`]: TPDOs of types 254/255 go out when
//! their data changes and, with an event timer (sub-index 5, ms), when it elapses without a
//! transmission (CiA 301 §7.5.2.35: the timer restarts at every transmission); synchronous
//! ones (1..=240 every n-th SYNC, 0 on the SYNC after a change) go out on SYNC; received RPDOs
//! are written at once. Inhibit time and remote requests apply to the classic PDOs only.
//!
//! MPDOs (CiA 301 §7.2.3, [`DeviceMpdos`]): a TPDO whose mapping count is 0xFE produces
//! SAM-MPDOs, one per object of the object scanner list 0x1FA0 each time its value changes
//! (every object once on entering Operational); an RPDO whose mapping count is 0xFF consumes
//! DAM-MPDOs addressed to the device or to all nodes, writing the addressed object.

use canola_frame::{CanFrame, CanId, Duration, FdFrame, Instant, NodeId};
use canola_pdo::{
    CommParams, Dictionary, Direction, FdMapping, MpdoConsumer, ObjectAddress, ObjectStore, OdView,
    RawValue, SamProducer, StoreError, TransmissionType,
};

use super::values::Values;
use crate::machine::pdo::{PdoEngine, read_fd_pdo, read_pdo};

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

/// One CAN FD TPDO of a device.
struct FdTpdo {
    comm: CommParams,
    can_id: CanId,
    mapping: FdMapping,
    /// The data last sent.
    last: Option<Vec<u8>>,
    /// SYNCs counted towards the next frame of a cyclic synchronous TPDO.
    syncs: u8,
    /// When the event timer elapses (an event-driven TPDO with a non-zero event timer that
    /// has been sent at least once).
    due: Option<Instant>,
}

impl FdTpdo {
    /// Sends `data` and restarts the event timer.
    fn send(&mut self, now: Instant, data: Vec<u8>, out: &mut impl Extend<FdFrame>) {
        if let Ok(f) = FdFrame::new_padded(self.can_id, &data).map(|f| f.with_brs(true)) {
            out.extend([f]);
        }
        self.last = Some(data);
        let timer = self.comm.event_timer;
        self.due = (self.comm.transmission_type.is_event_driven() && timer > 0)
            .then(|| now + Duration::from_millis(u64::from(timer)));
    }
}

/// A device's PDOs of more than 8 bytes (see the module docs).
#[derive(Default)]
pub(crate) struct FdPdos {
    rx: Vec<(CanId, FdMapping)>,
    tx: Vec<FdTpdo>,
    /// The device's time, as of its last call from the bus (a value set by the application
    /// between two calls is sent with this time, which only starts the event timer).
    now: Instant,
}

impl FdPdos {
    /// The PDOs of more than 8 bytes among the device's RPDO1..4 and TPDO1..4.
    pub(crate) fn from_view(view: &OdView<'_>) -> Self {
        let mut out = Self::default();
        for n in 0..4 {
            if let Some((_, can_id, mapping)) = read_fd_pdo(view, Direction::Receive, n) {
                out.rx.push((can_id, mapping));
            }
            if let Some((comm, can_id, mapping)) = read_fd_pdo(view, Direction::Transmit, n) {
                out.tx.push(FdTpdo {
                    comm,
                    can_id,
                    mapping,
                    last: None,
                    syncs: 0,
                    due: None,
                });
            }
        }
        out
    }

    /// Whether the device has none.
    pub(crate) fn is_empty(&self) -> bool {
        self.rx.is_empty() && self.tx.is_empty()
    }

    /// Tells the time of the call being handled.
    pub(crate) fn set_now(&mut self, now: Instant) {
        self.now = self.now.max(now);
    }

    /// When the next event timer elapses.
    pub(crate) fn poll_timeout(&self) -> Option<Instant> {
        self.tx.iter().filter_map(|t| t.due).min()
    }

    /// The frames of event-driven TPDOs whose event timer elapsed at `now`: sent with the
    /// current data, changed or not.
    pub(crate) fn handle_timeout(
        &mut self,
        now: Instant,
        values: &Values,
        out: &mut impl Extend<FdFrame>,
    ) {
        self.now = now;
        for t in &mut self.tx {
            if t.due.is_none_or(|d| d > now) {
                continue;
            }
            match pack(&t.mapping, values) {
                Some(data) => t.send(now, data, out),
                None => t.due = None,
            }
        }
    }

    /// The frames of event-driven TPDOs whose data changed since they were last sent.
    pub(crate) fn changed(&mut self, values: &Values, out: &mut impl Extend<FdFrame>) {
        let now = self.now;
        for t in &mut self.tx {
            let tt = t.comm.transmission_type;
            if !tt.is_event_driven() && tt != TransmissionType::SyncAcyclic {
                continue;
            }
            let Some(data) = pack(&t.mapping, values) else {
                continue;
            };
            if t.last.as_deref() == Some(&data[..]) || tt == TransmissionType::SyncAcyclic {
                continue;
            }
            t.send(now, data, out);
        }
    }

    /// The frames of synchronous TPDOs due at a SYNC.
    pub(crate) fn sync(&mut self, values: &Values, out: &mut impl Extend<FdFrame>) {
        let now = self.now;
        for t in &mut self.tx {
            let due = match t.comm.transmission_type {
                TransmissionType::SyncAcyclic => true,
                TransmissionType::SyncCyclic(n) => {
                    t.syncs = t.syncs.saturating_add(1);
                    if t.syncs >= n {
                        t.syncs = 0;
                        true
                    } else {
                        false
                    }
                }
                _ => false,
            };
            if !due {
                continue;
            }
            let Some(data) = pack(&t.mapping, values) else {
                continue;
            };
            let acyclic = t.comm.transmission_type == TransmissionType::SyncAcyclic;
            if acyclic && t.last.as_deref() == Some(&data[..]) {
                continue;
            }
            t.send(now, data, out);
        }
    }

    /// Writes a received CAN FD RPDO into `values`; `false` when it is none of the device's
    /// (or shorter than its mapping).
    pub(crate) fn receive(&self, frame: &FdFrame, values: &mut Values) -> bool {
        let Some((_, mapping)) = self.rx.iter().find(|(id, _)| *id == frame.id()) else {
            return false;
        };
        let Ok(raw) = canola_pdo::unpack_fd(mapping, frame.data()) else {
            return false;
        };
        for (o, v) in mapping.objects().iter().zip(raw.iter()) {
            if o.entry.is_dummy() {
                continue;
            }
            let bits = o.bits();
            let word = v.to_raw(o.kind, bits).unwrap_or(0);
            let len = usize::from(bits).div_ceil(8);
            let addr = o.entry.addr();
            values.set(
                addr.index,
                addr.sub_index,
                word.to_le_bytes()[..len].to_vec(),
            );
        }
        true
    }
}

/// The TPDO data of `mapping` from `values` (objects without a value are zero).
fn pack(mapping: &FdMapping, values: &Values) -> Option<Vec<u8>> {
    let raw: Vec<RawValue> = mapping
        .objects()
        .iter()
        .map(|o| {
            let mut word = [0u8; 8];
            if let Some(b) = values.get(o.entry.index(), o.entry.subindex()) {
                let n = b.len().min(8);
                word[..n].copy_from_slice(&b[..n]);
            }
            let bits = o.bits();
            let mask = if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            };
            RawValue::from_raw(o.kind, u64::from_le_bytes(word) & mask, bits)
        })
        .collect();
    let mut buf = [0u8; canola_pdo::MAX_FD_BYTES];
    let len = canola_pdo::pack_fd(mapping, &raw, &mut buf).ok()?;
    Some(buf[..len].to_vec())
}

/// Most object scanner list entries a simulated SAM producer takes.
const SCANNER_ENTRIES: usize = 254;

/// A SAM-MPDO producing TPDO: its COB-ID, scanner list, and the data last sent per object.
type SamTpdo = (
    CanId,
    Box<SamProducer<SCANNER_ENTRIES>>,
    Vec<(ObjectAddress, [u8; 4])>,
);

/// A device's MPDOs (see the module docs).
pub(crate) struct DeviceMpdos {
    /// SAM-MPDO producers.
    sam: Vec<SamTpdo>,
    /// COB-IDs of the RPDOs that consume DAM-MPDOs.
    dam: Vec<CanId>,
    consumer: MpdoConsumer<1>,
}

impl DeviceMpdos {
    /// No MPDOs (until the PDOs are built from the device's values).
    pub(crate) fn none(node: NodeId) -> Self {
        Self {
            sam: Vec::new(),
            dam: Vec::new(),
            consumer: MpdoConsumer::new(node),
        }
    }

    /// The MPDOs among the device's RPDO1..4 and TPDO1..4.
    pub(crate) fn from_view(view: &OdView<'_>, node: NodeId) -> Self {
        let mut out = Self::none(node);
        for n in 0..4 {
            let is = |direction: Direction, count: u32| {
                view.read_u32(direction.mapping_index(n), 0) == Ok(count)
            };
            let cob = |direction: Direction| {
                CommParams::read_from(view, direction.comm_index(n))
                    .ok()
                    .filter(|c| c.cob_id.is_valid())
                    .and_then(|c| c.cob_id.can_id().ok())
            };
            if is(
                Direction::Transmit,
                u32::from(canola_pdo::mpdo::MAPPING_SAM),
            ) && let Some(id) = cob(Direction::Transmit)
            {
                let mut p = Box::new(SamProducer::new(node));
                if p.read_from(view, canola_pdo::mpdo::SCANNER_LIST_FIRST)
                    .is_ok()
                {
                    out.sam.push((id, p, Vec::new()));
                }
            }
            if is(Direction::Receive, u32::from(canola_pdo::mpdo::MAPPING_DAM))
                && let Some(id) = cob(Direction::Receive)
            {
                out.dam.push(id);
            }
        }
        out
    }

    /// Whether the device has none.
    pub(crate) fn is_empty(&self) -> bool {
        self.sam.is_empty() && self.dam.is_empty()
    }

    /// SAM-MPDOs for the scanned objects whose value changed since they were last sent.
    pub(crate) fn changed(&mut self, values: &mut Values, out: &mut impl Extend<CanFrame>) {
        for (id, producer, last) in &mut self.sam {
            let objects: Vec<ObjectAddress> = producer
                .entries()
                .iter()
                .flat_map(|e| {
                    (0..e.block_size()).filter_map(move |off| {
                        Some(ObjectAddress::new(
                            e.index(),
                            e.subindex().checked_add(off)?,
                        ))
                    })
                })
                .collect();
            for addr in objects {
                let Ok(mpdo) = producer.produce(addr, &mut Store(values)) else {
                    continue;
                };
                match last.iter_mut().find(|(a, _)| *a == addr) {
                    Some((_, d)) if *d == mpdo.data => continue,
                    Some((_, d)) => *d = mpdo.data,
                    None => last.push((addr, mpdo.data)),
                }
                out.extend([mpdo.to_frame(*id)]);
            }
        }
    }

    /// Writes a DAM-MPDO for the device into `values`; `false` when `frame` is not on a DAM
    /// RPDO's COB-ID (or not for this device).
    pub(crate) fn receive(&self, frame: &CanFrame, values: &mut Values) -> bool {
        self.dam.contains(&frame.id())
            && matches!(
                self.consumer
                    .handle_data(frame.data(), &mut Existing(values)),
                Ok(canola_pdo::mpdo::Delivery::Written(_))
            )
    }
}

/// The device's values for an MPDO's four data bytes: an object that exists keeps as many
/// bytes as it holds; one that does not is refused (an MPDO creates no object).
struct Existing<'a>(&'a mut Values);

impl ObjectStore for Existing<'_> {
    fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), StoreError> {
        Store(self.0).read(addr, out)
    }
    fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), StoreError> {
        let len = self
            .0
            .get(addr.index, addr.sub_index)
            .ok_or(StoreError::NoSuchObject)?
            .len();
        self.0.set(
            addr.index,
            addr.sub_index,
            data[..len.min(data.len())].to_vec(),
        );
        Ok(())
    }
}
