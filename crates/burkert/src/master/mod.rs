//! [`BurkertNode`]: the Bürkert profile seen from the master, a typed view over a
//! [`canola::Node`].
//!
//! Every operation is one or more SDO transfers (CiA 301 §7.2.4) on the objects of the Bürkert
//! manual (SPEC-NOTES §1): bytes are read with the master's SDO client and decoded with the
//! generated [`crate::objects`] entries and the semantic types of this crate. Errors are the
//! master's [`canola::Error`]: an SDO failure names the node, the object and the abort code; a
//! value the manual does not define is an [`Error::Value`] naming node and object.
//!
//! Changing the node-ID or the bit rate goes through 0x2001 sub 2 / sub 1 and takes effect at
//! the next reset (0x2001 sub 4 or NMT). The alternative that works without knowing the node-ID
//! is LSS (CiA 305, the `canola-lss` crate): switch-global, configure node-ID / bit timing,
//! activate bit timing, switch-global back.
//!
//! PDO helpers remap a TPDO to carry sensor values (0x2500..=0x253F sub 1) and an RPDO to carry
//! control values (0x2540..=0x257F sub 1) with the CiA 301 remote-configuration sequence of
//! [`canola_pdo::remap`]; value types come from the node's dictionary (its EDS), falling back to
//! the generic Bürkert EDS.

use std::prelude::rust_2024::*;

use std::io::Write;
use std::sync::{Arc, Mutex};

use canola::error::{PdoProblem, ValueProblem};
use canola::{Error, NetworkEvent, Node, SdoError, SdoErrorKind, TransferProgress};
use canola_frame::{CanFrame, CanId, NodeId};
use canola_od::{DataType, Entry, EntryValue, ObjectAddress, ObjectDictionary};
use canola_pdo::{CommParams, Direction, Mapping, MappingEntry, RawValue as PdoValue, ValueKind};
use canola_sdo::{AbortCode, ErrorKind};

use crate::colour::LedColour;
use crate::comm::{BitRate, BusMode, CanOperationStatus, EdsVersion, ResetCommand, Termination};
use crate::led::{LedIndication, LedMode, LedState, ValveModeColours};
use crate::ne107::Ne107Status;
use crate::objects::{
    self, buerkert_device_description_object as desc, device_communication_object as comm,
    device_status_object as st, locating_function, trigger_maintenance_function,
    user_configuration_object as user, valve_mode_configuration as valve,
};
use crate::status::{DeviceStatus, Kelvin, TransMemStatus};
use canola_pdo::OdView;

mod pdo;
mod report;

pub use pdo::*;
pub use report::*;

/// First sensor value object (sensor 0); sensors run to 0x253F.
pub const SENSOR_VALUE_BASE: u16 = 0x2500;
/// First control value object (control 0); controls run to 0x257F.
pub const CONTROL_VALUE_BASE: u16 = 0x2540;
/// Sensor / control values per direction (0x40).
pub const VALUES_PER_KIND: u8 = 0x40;
/// Sub-index of the value in a sensor / control value object.
pub const SUB_VALUE: u8 = 1;
/// Sub-index of the precision (REAL32) in a sensor / control value object.
pub const SUB_PRECISION: u8 = 6;

const fn addr<T>(e: &Entry<T>) -> ObjectAddress {
    ObjectAddress::new(e.index(), e.sub_index())
}

/// A progress callback that is called once more with the final length when the master's last
/// report fell short of it (the master reports before the last segment / block is stored).
struct FinalProgress {
    /// The caller's callback and the last `done` it was given.
    inner: Arc<Mutex<(canola::ProgressFn, u64)>>,
}

impl FinalProgress {
    fn new(f: impl FnMut(TransferProgress) + Send + 'static) -> Self {
        Self {
            inner: Arc::new(Mutex::new((Box::new(f), 0))),
        }
    }

    fn callback(&self) -> impl FnMut(TransferProgress) + Send + 'static {
        let inner = self.inner.clone();
        move |p| {
            if let Ok(mut g) = inner.lock() {
                g.1 = p.done;
                (g.0)(p);
            }
        }
    }

    fn finish(&self, node: NodeId, entry: ObjectAddress, len: u64) {
        if let Ok(mut g) = self.inner.lock()
            && g.1 != len
        {
            g.1 = len;
            (g.0)(TransferProgress {
                node,
                entry,
                done: len,
                total: Some(len),
            });
        }
    }
}

/// The Bürkert profile of one node. See the module docs.
#[derive(Debug, Clone)]
pub struct BurkertNode {
    node: Node,
}

/// Whether an SDO failure means "the device does not implement this sub-object".
fn is_absent(e: &SdoError) -> bool {
    matches!(
        e.server_abort(),
        Some(
            AbortCode::OBJECT_DOES_NOT_EXIST
                | AbortCode::SUBINDEX_DOES_NOT_EXIST
                | AbortCode::NO_DATA_AVAILABLE
        )
    )
}

/// Bytes read in a batch, by object.
struct Batch {
    node: NodeId,
    results: Vec<(ObjectAddress, Result<Vec<u8>, SdoError>)>,
}

impl Batch {
    fn raw(&self, a: ObjectAddress) -> Result<Option<&[u8]>, Error> {
        match self.results.iter().find(|(x, _)| *x == a) {
            Some((_, Ok(v))) => Ok(Some(v.as_slice())),
            Some((_, Err(e))) if is_absent(e) => Ok(None),
            Some((_, Err(e))) => Err(Error::Sdo(e.clone())),
            None => Ok(None),
        }
    }

    fn get<T: EntryValue>(&self, e: Entry<T>) -> Result<Option<T>, Error> {
        match self.raw(addr(&e))? {
            None => Ok(None),
            Some(bytes) => decode(self.node, &e, bytes).map(Some),
        }
    }
}

fn decode<T: EntryValue>(node: NodeId, e: &Entry<T>, bytes: &[u8]) -> Result<T, Error> {
    e.decode(bytes).map_err(|err| Error::Value {
        node,
        entry: addr(e),
        problem: ValueProblem::Entry(err),
    })
}

fn undefined(node: NodeId, e: ObjectAddress, problem: ValueProblem) -> Error {
    Error::Value {
        node,
        entry: e,
        problem,
    }
}

/// What the Bürkert manual does not define, refused before anything is sent or when a device
/// reports it: the [`ValueProblem::Profile`] of an [`Error::Value`] (downcast it to match).
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum OutsideManual {
    /// 0x2002 sub 0 is neither 4 (the manual's value) nor 5 (the highest sub-index).
    #[error("{0} entries; the Bürkert profile has 4 (manual) or 5")]
    EntryCount(u8),
    /// A bit rate Bürkert devices do not offer (800k, 100k).
    #[error("{0} is not offered by Bürkert devices")]
    BitRate(BitRate),
    /// A process value number outside 0..=63.
    #[error("value number {0} is outside 0..=63")]
    ValueNumber(u8),
    /// A PDO number outside 1..=4 (the predefined connection set).
    #[error("PDO number {0} is outside 1..=4 (predefined connection set)")]
    PdoNumber(u8),
    /// A process value whose data type cannot be mapped into a PDO.
    #[error("{0} cannot be mapped into a PDO")]
    NotMappable(DataType),
}

debug_as_display!(OutsideManual);

/// An [`OutsideManual`] as the problem of an [`Error::Value`].
fn outside(rule: OutsideManual) -> ValueProblem {
    ValueProblem::Profile(Box::new(rule))
}

impl BurkertNode {
    /// A view over `node`. Add the node with its EDS (`add_node_with_dictionary`) so errors
    /// carry object names and PDO helpers see the device's value types.
    pub fn new(node: Node) -> Self {
        Self { node }
    }

    /// The underlying master node.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// The node-ID.
    pub fn id(&self) -> NodeId {
        self.node.id()
    }

    /// Reads one entry and decodes it with its generated type.
    pub fn read<T: EntryValue>(&self, e: Entry<T>) -> Result<T, Error> {
        self.node.sdo().read_entry(&e).wait()
    }

    /// Encodes a value with its generated type and writes it.
    pub fn write<T: EntryValue>(&self, e: Entry<T>, value: &T) -> Result<(), Error> {
        self.node.sdo().write_entry(&e, value).wait()
    }

    /// Submits every read together (the master queues them on the node and runs them back to
    /// back; other nodes progress meanwhile), then waits for all of them.
    fn batch(&self, entries: &[ObjectAddress]) -> Batch {
        let pending: Vec<_> = entries
            .iter()
            .map(|&a| (a, self.node.sdo().submit_read(a)))
            .collect();
        let results = pending.into_iter().map(|(a, p)| (a, p.wait())).collect();
        Batch {
            node: self.id(),
            results,
        }
    }

    /// Reads 0x2000, 0x2001, 0x2004, 0x2101, 0x210A and 0x2120..=0x2122 in one batch of
    /// parallel-submitted SDO reads (see [`DeviceReport`]). Sub-objects the device does not
    /// implement (abort 0x06020000 / 0x06090011 / 0x08000024) are `None`.
    pub fn read_report(&self) -> Result<DeviceReport, Error> {
        let mut all: Vec<ObjectAddress> = Vec::new();
        all.extend(DESCRIPTION.iter().copied());
        all.extend(STATUS.iter().copied());
        all.extend(COMMUNICATION.iter().copied());
        all.extend(LED.iter().copied());
        all.push(addr(&locating_function::CALL_CANCEL));
        all.push(addr(&trigger_maintenance_function::CALL_CANCEL));
        let b = self.batch(&all);
        Ok(DeviceReport {
            description: description_from(&b)?,
            status: status_from(&b)?,
            communication: communication_from(&b)?,
            led: led_from(&b)?,
            locating: b.get(locating_function::CALL_CANCEL)?.unwrap_or(0) != 0,
            maintenance: b
                .get(trigger_maintenance_function::CALL_CANCEL)?
                .unwrap_or(0)
                != 0,
        })
    }

    /// Reads the whole device description (0x2000) and device status (0x2004) in one call:
    /// all SDO reads are submitted together, then awaited.
    pub fn read_description_and_status(&self) -> Result<(DeviceDescription, DeviceStatus), Error> {
        let mut all: Vec<ObjectAddress> = DESCRIPTION.to_vec();
        all.extend(STATUS.iter().copied());
        let b = self.batch(&all);
        Ok((description_from(&b)?, status_from(&b)?))
    }

    /// Reads 0x2000.
    pub fn read_description(&self) -> Result<DeviceDescription, Error> {
        description_from(&self.batch(&DESCRIPTION))
    }

    /// Reads 0x2004.
    pub fn read_status(&self) -> Result<DeviceStatus, Error> {
        status_from(&self.batch(&STATUS))
    }

    /// Reads 0x2001.
    pub fn read_communication(&self) -> Result<DeviceCommunication, Error> {
        communication_from(&self.batch(&COMMUNICATION))
    }

    /// Reads 0x2002 in one batch. Sub 0 must be 4 (the manual's value) or 5 (the highest
    /// sub-index); anything else is an [`Error::Value`].
    pub fn read_user_configuration(&self) -> Result<UserConfiguration, Error> {
        let b = self.batch(&USER);
        let count = b.get(user::NUMBER_OF_ENTRIES)?.unwrap_or(5);
        if !matches!(count, 4 | 5) {
            return Err(undefined(
                self.id(),
                addr(&user::NUMBER_OF_ENTRIES),
                outside(OutsideManual::EntryCount(count)),
            ));
        }
        Ok(UserConfiguration {
            number_of_entries: count,
            location: b.get(user::LOCATION_INFORMATION)?,
            user_description: b.get(user::USER_DESCRIPTION)?,
            displayed_name: b.get(user::DISPLAYED_DEVICE_NAME)?,
            static_node_id: b.get(user::STATIC_NODE_ID)?,
        })
    }

    /// Writes the location (0x2002 sub 2).
    pub fn set_location(&self, text: &str) -> Result<(), Error> {
        self.node
            .sdo()
            .write(addr(&user::LOCATION_INFORMATION), text)
            .wait()
    }

    /// Writes the user description (0x2002 sub 3).
    pub fn set_user_description(&self, text: &str) -> Result<(), Error> {
        self.node
            .sdo()
            .write(addr(&user::USER_DESCRIPTION), text)
            .wait()
    }

    /// Writes the displayed device name (0x2002 sub 4).
    pub fn set_displayed_name(&self, text: &str) -> Result<(), Error> {
        self.node
            .sdo()
            .write(addr(&user::DISPLAYED_DEVICE_NAME), text)
            .wait()
    }

    /// Writes the static node-ID (0x2002 sub 5; 0 = none).
    pub fn set_static_node_id(&self, id: Option<NodeId>) -> Result<(), Error> {
        self.write(user::STATIC_NODE_ID, &id.map_or(0, NodeId::get))
    }

    /// Reads the NAMUR NE 107 status (0x2004 sub 1).
    pub fn ne107(&self) -> Result<Ne107Status, Error> {
        self.read(st::DEVICE_STATUS_NAMUR_NE107)
            .map(Ne107Status::from_raw)
    }

    /// Reads 0x2120..=0x2122.
    pub fn read_led_config(&self) -> Result<LedConfig, Error> {
        led_from(&self.batch(&LED))
    }

    /// Writes the LED mode (0x2120).
    pub fn set_led_mode(&self, mode: LedMode) -> Result<(), Error> {
        self.write(objects::LED_MODE, &mode.to_u32())
    }

    /// Writes the valve-mode colours (0x2121 sub 1..=3).
    pub fn set_valve_colours(&self, colours: &ValveModeColours) -> Result<(), Error> {
        self.write(valve::COLOUR_POSITION_CLOSED, &colours.closed.to_u32())?;
        self.write(valve::COLOUR_POSITION_BETWEEN, &colours.between.to_u32())?;
        self.write(valve::COLOUR_POSITION_OPEN, &colours.open.to_u32())
    }

    /// Writes the external (fixed-mode) colour (0x2122).
    pub fn set_external_colour(&self, colour: LedColour) -> Result<(), Error> {
        self.write(objects::LED_EXTERN_COLOUR, &colour.to_u32())
    }

    /// Starts the locating function (0x2101 sub 1 = 1; the LED flashes for about 10 s). The
    /// manual requires the object to be set back to 0 before a new start, so a 1 still standing
    /// from an earlier locate is first overwritten with 0.
    pub fn start_locating(&self) -> Result<(), Error> {
        if self.read(locating_function::CALL_CANCEL)? != 0 {
            self.write(locating_function::CALL_CANCEL, &0)?;
        }
        self.write(locating_function::CALL_CANCEL, &1)
    }

    /// Cancels the locating function (0x2101 sub 1 = 0).
    pub fn stop_locating(&self) -> Result<(), Error> {
        self.write(locating_function::CALL_CANCEL, &0)
    }

    /// Whether 0x2101 sub 1 reads 1.
    pub fn locating(&self) -> Result<bool, Error> {
        Ok(self.read(locating_function::CALL_CANCEL)? != 0)
    }

    /// Puts the device into (`true`) or out of the maintenance state (0x210A sub 1). In the
    /// maintenance state the NE 107 status is "maintenance required" (LED blue) unless an event
    /// of higher priority is active.
    pub fn set_maintenance(&self, on: bool) -> Result<(), Error> {
        self.write(trigger_maintenance_function::CALL_CANCEL, &u8::from(on))
    }

    /// Whether 0x210A sub 1 reads 1.
    pub fn maintenance(&self) -> Result<bool, Error> {
        Ok(self.read(trigger_maintenance_function::CALL_CANCEL)? != 0)
    }

    /// Uploads the logbook (0x2003 sub 4, a DOMAIN holding an XML document) into `out`, by
    /// block transfer when `block` is set (segmented otherwise), calling `progress` as it goes;
    /// the last call always reports the whole length. Returns the byte count.
    pub fn download_logbook(
        &self,
        out: impl Write + Send + 'static,
        block: bool,
        progress: impl FnMut(TransferProgress) + Send + 'static,
    ) -> Result<u64, Error> {
        let e = objects::error_management_object::LOGBOOK_DOWNLOAD;
        let p = FinalProgress::new(progress);
        let n = self
            .node
            .sdo()
            .block(block)
            .on_progress(p.callback())
            .upload_to(addr(&e), out)
            .wait()?;
        p.finish(self.id(), addr(&e), n);
        Ok(n)
    }

    /// Uploads the logbook into memory (see [`download_logbook`](Self::download_logbook)).
    pub fn read_logbook(
        &self,
        block: bool,
        progress: impl FnMut(TransferProgress) + Send + 'static,
    ) -> Result<Vec<u8>, Error> {
        let e = objects::error_management_object::LOGBOOK_DOWNLOAD;
        let p = FinalProgress::new(progress);
        let data = self
            .node
            .sdo()
            .block(block)
            .on_progress(p.callback())
            .read(addr(&e))
            .wait()?;
        p.finish(self.id(), addr(&e), data.len() as u64);
        Ok(data)
    }

    /// Stores a new node-ID in 0x2001 sub 2. It takes effect at the next communication or
    /// device reset ([`reset`](Self::reset)). LSS (CiA 305) is the alternative that does not
    /// need the current node-ID.
    pub fn set_node_id(&self, id: NodeId) -> Result<(), Error> {
        self.write(comm::ADDRESS, &id.get())
    }

    /// Stores a new bit rate in 0x2001 sub 1 (effective after a reset; every node on the bus
    /// must change too). Bit rates Bürkert does not offer (800k, 100k) are refused locally.
    /// LSS configure/activate bit timing (CiA 305) is the alternative.
    pub fn set_bit_rate(&self, rate: BitRate) -> Result<(), Error> {
        if !rate.offered_by_burkert() {
            return Err(undefined(
                self.id(),
                addr(&comm::BAUDRATE),
                outside(OutsideManual::BitRate(rate)),
            ));
        }
        self.write(comm::BAUDRATE, &rate.code())
    }

    /// Switches the device's termination resistor (0x2001 sub 0x0B).
    pub fn set_termination(&self, t: Termination) -> Result<(), Error> {
        self.write(comm::TERMINATION_RESISTOR, &t.to_u8())
    }

    /// Selects CANopen or büS (0x2001 sub 3; effective after a reset).
    pub fn set_bus_mode(&self, mode: BusMode) -> Result<(), Error> {
        self.write(comm::B_US_MODE, &mode.to_u8())
    }

    /// Requests a reset through 0x2001 sub 4 (1 communication, 2 device). A device may restart
    /// before it confirms the write, so an SDO timeout on this write counts as success.
    pub fn reset(&self, kind: ResetCommand) -> Result<(), Error> {
        match self.write(comm::RESET, &kind.to_u8()) {
            Err(Error::Sdo(e))
                if kind != ResetCommand::None
                    && e.kind == SdoErrorKind::Transfer(ErrorKind::Timeout) =>
            {
                Ok(())
            }
            r => r,
        }
    }

    /// Stores `id` in 0x2001 sub 2 and resets communication, then returns the view of the node
    /// under its new ID (added to the network with this node's dictionary). Wait for its
    /// boot-up (heartbeat event) before relying on it when the device is slow to restart.
    pub fn change_node_id(&self, id: NodeId) -> Result<BurkertNode, Error> {
        self.set_node_id(id)?;
        self.reset(ResetCommand::Communication)?;
        Ok(BurkertNode::new(self.node.with_node_id(id)))
    }

    /// The node's dictionary, or the generic Bürkert EDS when the node was added without one.
    fn dictionary(&self) -> Arc<ObjectDictionary> {
        self.node
            .dictionary()
            .unwrap_or_else(|| generic_od().clone())
    }

    fn value_entry(
        &self,
        od: &ObjectDictionary,
        base: u16,
        number: u8,
    ) -> Result<(MappingEntry, DataType), Error> {
        let index = base + u16::from(number);
        let a = ObjectAddress::new(index, SUB_VALUE);
        if number >= VALUES_PER_KIND {
            return Err(undefined(
                self.id(),
                a,
                outside(OutsideManual::ValueNumber(number)),
            ));
        }
        let sub = od
            .sub(index, SUB_VALUE)
            .ok_or_else(|| undefined(self.id(), a, ValueProblem::NotDescribed))?;
        let bits = sub.data_type.size().unwrap_or(0) * 8;
        if bits == 0 || bits > 64 {
            return Err(undefined(
                self.id(),
                a,
                outside(OutsideManual::NotMappable(sub.data_type)),
            ));
        }
        Ok((
            MappingEntry::new(index, SUB_VALUE, bits as u8),
            sub.data_type,
        ))
    }

    fn remap(
        &self,
        direction: Direction,
        number: u8,
        base: u16,
        values: &[u8],
        comm: Option<CommParams>,
    ) -> Result<(Mapping, u32), Error> {
        let id = self.id();
        let (comm_base, fc) = match direction {
            Direction::Receive => (0x1400u16, 0x200u16),
            Direction::Transmit => (0x1800u16, 0x180u16),
        };
        if !(1..=4).contains(&number) {
            return Err(undefined(
                id,
                ObjectAddress::new(comm_base, 1),
                outside(OutsideManual::PdoNumber(number)),
            ));
        }
        let n = u16::from(number) - 1;
        let od = self.dictionary();
        let mut raw = Vec::with_capacity(values.len());
        for &v in values {
            raw.push(self.value_entry(&od, base, v)?.0.0);
        }
        let mapping = Mapping::from_raw_checked(direction, &raw, &OdView::new(&od, id.get()))
            .map_err(|e| {
                let problem = ValueProblem::Pdo {
                    direction,
                    number: n + 1,
                    problem: PdoProblem::Mapping(e),
                };
                undefined(
                    id,
                    ObjectAddress::new(direction.mapping_index(n), 0),
                    problem,
                )
            })?;
        let comm = comm.unwrap_or_else(|| {
            let cob = fc + 0x100 * n + u16::from(id.get());
            match direction {
                // The manual's defaults: event-driven (0xFE), inhibit 500 ms, event timer 1 s.
                Direction::Transmit => CommParams::event_driven(cob)
                    .with_transmission_type(canola_pdo::TransmissionType::EventManufacturer)
                    .with_inhibit_time(5000)
                    .with_event_timer(1000),
                Direction::Receive => CommParams::event_driven(cob)
                    .with_transmission_type(canola_pdo::TransmissionType::EventManufacturer),
            }
        });
        self.node
            .remap_pdo(direction, u16::from(number), comm, mapping.clone())
            .wait()?;
        Ok((mapping, comm.cob_id.0))
    }

    /// Maps sensor values (`0x2500 + s`, sub 1, for each `s` in `sensors`) into TPDO `number`
    /// (1..=4) with the CiA 301 remote-configuration sequence, using `comm` or, when `None`,
    /// the manual's defaults (COB-ID 0x180 + 0x100·(n−1) + node-ID, type 0xFE, inhibit time
    /// 500 ms, event timer 1 s). The device sends the TPDO while Operational; decode received
    /// PDOs with [`SensorTpdo::from_event`].
    pub fn map_sensor_values_to_tpdo(
        &self,
        number: u8,
        sensors: &[u8],
        comm: Option<CommParams>,
    ) -> Result<SensorTpdo, Error> {
        let (mapping, cob_id) = self.remap(
            Direction::Transmit,
            number,
            SENSOR_VALUE_BASE,
            sensors,
            comm,
        )?;
        Ok(SensorTpdo {
            node: self.id(),
            number,
            sensors: sensors.to_vec(),
            mapping,
            cob_id,
        })
    }

    /// Maps control values (`0x2540 + c`, sub 1) into RPDO `number` (1..=4), as
    /// [`map_sensor_values_to_tpdo`](Self::map_sensor_values_to_tpdo) does for sensors
    /// (default COB-ID 0x200 + 0x100·(n−1) + node-ID, type 0xFE). Send values with
    /// [`send_control_values`](Self::send_control_values).
    pub fn map_control_values_to_rpdo(
        &self,
        number: u8,
        controls: &[u8],
        comm: Option<CommParams>,
    ) -> Result<ControlRpdo, Error> {
        let (mapping, cob_id) = self.remap(
            Direction::Receive,
            number,
            CONTROL_VALUE_BASE,
            controls,
            comm,
        )?;
        Ok(ControlRpdo {
            node: self.id(),
            number,
            controls: controls.to_vec(),
            mapping,
            cob_id,
        })
    }

    /// Sends one RPDO with a value per control (of the control objects' types, e.g.
    /// `Value::Real32` for the generic device). The device applies it while Operational.
    pub fn send_control_values(
        &self,
        rpdo: &ControlRpdo,
        values: &[canola_od::Value],
    ) -> Result<(), Error> {
        let frame = rpdo.encode(values)?;
        self.node.network().send(frame)
    }

    /// Reads sensor value `sensor` (0x2500 + sensor, sub 1) by SDO, typed by the dictionary.
    pub fn read_sensor_value(&self, sensor: u8) -> Result<canola_od::Value, Error> {
        self.read_value(SENSOR_VALUE_BASE, sensor)
    }

    /// Reads control value `control` (0x2540 + control, sub 1) by SDO, typed by the dictionary.
    pub fn read_control_value(&self, control: u8) -> Result<canola_od::Value, Error> {
        self.read_value(CONTROL_VALUE_BASE, control)
    }

    /// Reads the precision (sub 6, REAL32) of sensor value `sensor`.
    pub fn read_sensor_precision(&self, sensor: u8) -> Result<f32, Error> {
        self.read_precision(SENSOR_VALUE_BASE, sensor)
    }

    /// Reads the precision (sub 6, REAL32) of control value `control`.
    pub fn read_control_precision(&self, control: u8) -> Result<f32, Error> {
        self.read_precision(CONTROL_VALUE_BASE, control)
    }

    fn read_precision(&self, base: u16, number: u8) -> Result<f32, Error> {
        let a = ObjectAddress::new(base + u16::from(number), SUB_PRECISION);
        if number >= VALUES_PER_KIND {
            return Err(undefined(
                self.id(),
                a,
                outside(OutsideManual::ValueNumber(number)),
            ));
        }
        let e: Entry<f32> = Entry::new(a.index, a.sub_index, DataType::Real32);
        self.read(e)
    }

    fn read_value(&self, base: u16, number: u8) -> Result<canola_od::Value, Error> {
        let od = self.dictionary();
        let (e, dt) = self.value_entry(&od, base, number)?;
        let a = ObjectAddress::new(e.index(), SUB_VALUE);
        let bytes = self.node.sdo().read(a).wait()?;
        canola_od::Value::from_le_bytes(dt, &bytes)
            .map_err(|err| undefined(self.id(), a, ValueProblem::Bytes(err)))
    }
}

/// The generic Bürkert dictionary (eds/burkert-generic.eds), parsed once.
pub fn generic_od() -> &'static Arc<ObjectDictionary> {
    static OD: std::sync::OnceLock<Arc<ObjectDictionary>> = std::sync::OnceLock::new();
    OD.get_or_init(|| {
        Arc::new(
            canola_od::parse(crate::GENERIC_EDS.as_bytes())
                .map(|p| p.od)
                .unwrap_or_default(),
        )
    })
}
