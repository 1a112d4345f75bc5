//! Remote PDO configuration end to end: the master's plan is executed against a simulated
//! device dictionary that enforces the CiA 301 rules (entries only while sub 0 is 0, sub 0 = n
//! only for a mappable set, COB-ID and inhibit time only while the PDO is invalid); the device
//! then reads its new parameters and its engine sends the remapped TPDO.

#![cfg(feature = "alloc")]

use std::collections::BTreeMap;

use canola_frame::{CanFrame, CanId, Instant};
use canola_pdo::{
    Catalog, CommParams, Dictionary, Direction, Engine, MapStore, Mapping, MappingError,
    ObjectAddress, ObjectInfo, PdoConfig, ReadError, RemoteObjects, SdoWrite, TransmissionType,
    remap,
};

/// A device's PDO objects and application objects, as its SDO server sees them.
struct Device {
    values: BTreeMap<(u16, u8), u32>,
}

/// SDO abort codes the simulated server answers with.
const ABORT_CANNOT_MAP: u32 = 0x0604_0041;
const ABORT_TOO_LONG: u32 = 0x0604_0042;
const ABORT_STATE: u32 = 0x0800_0022;
const ABORT_READ_ONLY: u32 = 0x0601_0002;

impl Catalog for Device {
    fn object_info(&self, addr: ObjectAddress) -> Option<ObjectInfo> {
        let (data_type, bits, readable, writable) = match (addr.index, addr.sub_index) {
            (0x6000, 1..=8) => (0x0001, 1, true, false), // BOOLEAN inputs
            (0x6401, 1..=4) => (0x0003, 16, true, false), // INTEGER16 analogue inputs
            (0x2010, 0) => (0x0010, 24, true, false),    // INTEGER24 counter
            _ => return None,
        };
        Some(ObjectInfo {
            data_type,
            bits,
            pdo_mappable: true,
            readable,
            writable,
        })
    }
}

impl Dictionary for Device {
    fn read_u32(&self, index: u16, subindex: u8) -> Result<u32, ReadError> {
        self.values
            .get(&(index, subindex))
            .copied()
            .ok_or(ReadError::NoSuchObject { index, subindex })
    }
}

impl Device {
    fn new(static_mapping: bool) -> Self {
        let mut values = BTreeMap::new();
        values.insert((0x1800, 1), 0x4000_0185);
        values.insert((0x1800, 2), 0xFE);
        values.insert((0x1800, 3), 0);
        values.insert((0x1800, 5), 0);
        values.insert((0x1800, 6), 0);
        values.insert((0x1A00, 0), 1);
        values.insert((0x1A00, 1), 0x6401_0110);
        // Marker the server checks: sub 0xFF present = mapping is read-only.
        if static_mapping {
            values.insert((0x1A00, 0xFF), 1);
        }
        Self { values }
    }

    fn pdo_valid(&self) -> bool {
        self.values
            .get(&(0x1800, 1))
            .is_some_and(|v| v & 0x8000_0000 == 0)
    }

    /// The SDO server's download handler for the PDO objects.
    fn write(&mut self, w: &SdoWrite) -> Result<(), u32> {
        let v = w.value_u32();
        match (w.index, w.subindex) {
            (0x1A00, _) if self.values.contains_key(&(0x1A00, 0xFF)) => Err(ABORT_READ_ONLY),
            (0x1A00, 0) if v == 0 => {
                self.values.insert((0x1A00, 0), 0);
                Ok(())
            }
            (0x1A00, 0) => {
                let raw: Vec<u32> = (1..=v as u8)
                    .map(|s| self.values.get(&(0x1A00, s)).copied().unwrap_or(0))
                    .collect();
                match Mapping::from_raw_checked(Direction::Transmit, &raw, self) {
                    Ok(_) => {
                        self.values.insert((0x1A00, 0), v);
                        Ok(())
                    }
                    Err(MappingError::TooLong(_)) => Err(ABORT_TOO_LONG),
                    Err(_) => Err(ABORT_CANNOT_MAP),
                }
            }
            (0x1A00, _) if self.values.get(&(0x1A00, 0)) != Some(&0) => Err(ABORT_STATE),
            (0x1800, 1) if self.pdo_valid() && v & 0x8000_0000 == 0 => {
                // Changing the identifier of an existing PDO is refused; same value is fine.
                if self.values.get(&(0x1800, 1)) == Some(&v) {
                    Ok(())
                } else {
                    Err(ABORT_STATE)
                }
            }
            (0x1800, 3) if self.pdo_valid() => Err(ABORT_STATE),
            (i, s) => {
                self.values.insert((i, s), v);
                Ok(())
            }
        }
    }
}

fn wanted() -> (CommParams, Mapping) {
    let comm = CommParams::event_driven(0x285)
        .with_transmission_type(TransmissionType::SyncCyclic(2))
        .with_inhibit_time(20);
    let mapping = Mapping::from_raw(&[0x6000_0101, 0x6000_0201, 0x2010_0018, 0x6401_0210]).unwrap();
    (comm, mapping)
}

#[test]
fn plan_executes_on_a_strict_device_and_the_engine_follows() {
    let mut dev = Device::new(false);
    let (comm, mapping) = wanted();
    let steps = remap(
        Direction::Transmit,
        0,
        &comm,
        &mapping,
        &RemoteObjects::dynamic(Direction::Transmit),
    )
    .unwrap();
    for s in &steps {
        dev.write(s)
            .unwrap_or_else(|abort| panic!("step {s:?} aborted with {abort:#010x}"));
    }

    // The device reads back its parameters and runs them.
    let comm_back = CommParams::read_from(&dev, 0x1800).unwrap();
    let map_back = Mapping::read_from(&dev, Direction::Transmit, 0x1A00).unwrap();
    assert_eq!(comm_back, comm);
    assert_eq!(
        map_back.raw_entries().collect::<Vec<_>>(),
        mapping.raw_entries().collect::<Vec<_>>()
    );

    let mut engine: Engine<0, 1> = Engine::new();
    engine
        .add_tpdo(Instant::ZERO, PdoConfig::new(comm_back, map_back))
        .unwrap();
    let a = ObjectAddress::new;
    let mut store = MapStore::new()
        .with(a(0x6000, 1), &[1])
        .with(a(0x6000, 2), &[0])
        .with(a(0x2010, 0), &[0xFE, 0xFF, 0xFF]) // -2 as INTEGER24
        .with(a(0x6401, 2), &[0x34, 0x12]);
    engine.handle_sync(Instant::from_millis(1), None, &mut store);
    assert!(
        engine.poll_transmit().is_none(),
        "type 2: every second SYNC"
    );
    engine.handle_sync(Instant::from_millis(2), None, &mut store);
    // bit 0 = 1, bit 1 = 0, bits 2..26 = 0xFFFFFE, bits 26..42 = 0x1234.
    let word: u64 = 1 | 0xFF_FFFE << 2 | 0x1234 << 26;
    let bytes = word.to_le_bytes();
    assert_eq!(
        engine.poll_transmit(),
        Some(CanFrame::new(CanId::standard(0x285).unwrap(), &bytes[..6]).unwrap())
    );
}

#[test]
fn wrong_orders_are_refused_by_the_device() {
    let (comm, mapping) = wanted();
    let steps = remap(
        Direction::Transmit,
        0,
        &comm,
        &mapping,
        &RemoteObjects::dynamic(Direction::Transmit),
    )
    .unwrap();
    // Entries before "sub 0 = 0": refused.
    let mut dev = Device::new(false);
    dev.write(&steps[0]).unwrap();
    assert_eq!(dev.write(&steps[2]), Err(ABORT_STATE));
    // Inhibit time while the PDO is still valid: refused.
    let mut dev = Device::new(false);
    let inhibit = steps
        .iter()
        .find(|w| (w.index, w.subindex) == (0x1800, 3))
        .unwrap();
    assert_eq!(dev.write(inhibit), Err(ABORT_STATE));
    // A mapping the device cannot take is refused at "sub 0 = n".
    let mut dev = Device::new(false);
    let bad = Mapping::from_raw(&[0x6401_0110, 0x6401_0510]).unwrap();
    let steps = remap(
        Direction::Transmit,
        0,
        &comm,
        &bad,
        &RemoteObjects::dynamic(Direction::Transmit),
    )
    .unwrap();
    let results: Vec<Result<(), u32>> = steps.iter().map(|s| dev.write(s)).collect();
    assert_eq!(
        results[4],
        Err(ABORT_CANNOT_MAP),
        "sub 0 = 2 with 0x6401:05"
    );
}

#[test]
fn static_mapping_is_caught_before_any_write() {
    let (comm, mapping) = wanted();
    let fixed = [0x6401_0110u32];
    let node = RemoteObjects {
        mapping_writable: false,
        current_mapping: Some(&fixed),
        ..RemoteObjects::dynamic(Direction::Transmit)
    };
    let err = remap(Direction::Transmit, 0, &comm, &mapping, &node).unwrap_err();
    assert_eq!(
        err.to_string(),
        "mapping object 0x1A00 is read-only (static mapping) and differs from the wanted mapping"
    );
    // Keeping the fixed mapping only changes the communication parameters, and the strict
    // device accepts every step.
    let same = Mapping::from_raw(&fixed).unwrap();
    let steps = remap(Direction::Transmit, 0, &comm, &same, &node).unwrap();
    let mut dev = Device::new(true);
    for s in &steps {
        assert_eq!(dev.write(s), Ok(()), "{s:?}");
    }
    assert_eq!(CommParams::read_from(&dev, 0x1800).unwrap(), comm);
}
