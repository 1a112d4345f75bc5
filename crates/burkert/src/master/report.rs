//! The profile's status objects read as one report: the typed views of 0x2000 (description),
//! 0x2001 (communication), 0x2004 (status), 0x2120..0x2122 (LED) and 0x2600 (user configuration),
//! the tables of sub-objects each is read from, and their decoding from one batch of SDO reads.

use super::*;

/// Object 0x2000, the device description. Sub-objects a device does not implement are `None`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct DeviceDescription {
    /// Sub 1.
    pub device_name: Option<String>,
    /// Sub 2.
    pub ident_number: Option<u32>,
    /// Sub 3.
    pub manufacture_date: Option<String>,
    /// Sub 4.
    pub software_ident_number: Option<u32>,
    /// Sub 5.
    pub software_version: Option<u32>,
    /// Sub 6.
    pub hardware_version: Option<u32>,
    /// Sub 7.
    pub serial_number: Option<u32>,
    /// Sub 8.
    pub product_code: Option<u32>,
    /// Sub 9.
    pub product_group: Option<u8>,
}

/// Object 0x2001, device communication, decoded. Sub-objects a device does not implement are
/// `None`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DeviceCommunication {
    /// Sub 1, the stored bit rate (effective after a reset).
    pub bit_rate: Option<BitRate>,
    /// Sub 2, the stored node-ID (effective after a reset).
    pub address: Option<u8>,
    /// Sub 3.
    pub bus_mode: Option<BusMode>,
    /// Sub 5.
    pub bus_version: Option<u32>,
    /// Sub 6.
    pub rx_error_count: Option<u8>,
    /// Sub 7.
    pub rx_error_count_max: Option<u8>,
    /// Sub 8.
    pub tx_error_count: Option<u8>,
    /// Sub 9.
    pub tx_error_count_max: Option<u8>,
    /// Sub 0x0A, the device's NMT state.
    pub can_operation_status: Option<CanOperationStatus>,
    /// Sub 0x0B.
    pub termination: Option<Termination>,
    /// Sub 0x0D.
    pub eds_version: Option<EdsVersion>,
}

/// Object 0x2002, user configuration. The manual gives sub 0 = 4 although the highest
/// sub-index is 5; both are accepted.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct UserConfiguration {
    /// Sub 0 as the device reports it (4 or 5).
    pub number_of_entries: u8,
    /// Sub 2, location.
    pub location: Option<String>,
    /// Sub 3, user description.
    pub user_description: Option<String>,
    /// Sub 4, displayed device name.
    pub displayed_name: Option<String>,
    /// Sub 5, static node-ID (0 = none).
    pub static_node_id: Option<u8>,
}

/// Objects 0x2120..=0x2122: how the status LED is configured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LedConfig {
    /// 0x2120.
    pub mode: LedMode,
    /// 0x2121.
    pub valve: ValveModeColours,
    /// 0x2122.
    pub external: LedColour,
}

/// One device read in one call: description, status, communication, LED.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceReport {
    /// 0x2000.
    pub description: DeviceDescription,
    /// 0x2004.
    pub status: DeviceStatus,
    /// 0x2001.
    pub communication: DeviceCommunication,
    /// 0x2120..=0x2122.
    pub led: LedConfig,
    /// 0x2101 sub 1 reads 1 (a locate was started and not yet set back to 0).
    pub locating: bool,
    /// 0x210A sub 1 reads 1.
    pub maintenance: bool,
}

impl DeviceReport {
    /// The colour the status LED shows, as far as the master can tell: the device's valve
    /// position is unknown to it (valve modes fall back to the NE 107 colour), and "locating"
    /// means 0x2101 sub 1 reads 1, although the device stops flashing after about 10 s.
    pub fn led_indication(&self) -> LedIndication {
        LedState {
            mode: self.led.mode,
            status: self.status.ne107.unwrap_or(Ne107Status::DiagnosisInactive),
            valve: None,
            valve_colours: self.led.valve,
            external: self.led.external,
            locating: self.locating,
        }
        .indication()
    }
}

pub(super) const DESCRIPTION: [ObjectAddress; 9] = [
    addr(&desc::DEVICE_NAME),
    addr(&desc::IDENT_NUMBER),
    addr(&desc::MANUFACTURE_DATE),
    addr(&desc::SOFTWARE_IDENT_NUMBER),
    addr(&desc::SOFTWARE_VERSION),
    addr(&desc::HARDWARE_VERSION),
    addr(&desc::SERIAL_NUMBER),
    addr(&desc::PRODUCT_CODE),
    addr(&desc::PRODUCT_GROUP),
];

pub(super) const STATUS: [ObjectAddress; 17] = [
    addr(&st::DEVICE_STATUS_NAMUR_NE107),
    addr(&st::DEVICE_TEMPERATURE),
    addr(&st::DEVICE_SUPPLY_VOLTAGE),
    addr(&st::OPERATION_TIME_S),
    addr(&st::MAXIMUM_DEVICE_TEMPERATURE),
    addr(&st::MINIMUM_DEVICE_TEMPERATURE),
    addr(&st::MAXIMUM_DEVICE_VOLTAGE),
    addr(&st::MINIMUM_DEVICE_VOLTAGE),
    addr(&st::DEVICE_CURRENT),
    addr(&st::MAXIMUM_DEVICE_CURRENT),
    addr(&st::MINIMUM_DEVICE_CURRENT),
    addr(&st::DEVICE_BOOT_COUNTER),
    addr(&st::TRANS_MEM_STATUS),
    addr(&st::BATTERY_VOLTAGE),
    addr(&st::VOLTAGE_DROP_COUNTER),
    addr(&st::OPERATION_TIME_SINCE_LAST_BOOT),
    addr(&st::ACTUATOR_SUPPLY_VOLTAGE),
];

pub(super) const COMMUNICATION: [ObjectAddress; 11] = [
    addr(&comm::BAUDRATE),
    addr(&comm::ADDRESS),
    addr(&comm::B_US_MODE),
    addr(&comm::B_US_VERSION),
    addr(&comm::RX_ERROR_COUNT),
    addr(&comm::RX_ERROR_COUNT_MAX),
    addr(&comm::TX_ERROR_COUNT),
    addr(&comm::TX_ERROR_COUNT_MAX),
    addr(&comm::CAN_OPERATION_STATUS),
    addr(&comm::TERMINATION_RESISTOR),
    addr(&comm::EDS_VERSION),
];

pub(super) const USER: [ObjectAddress; 5] = [
    addr(&user::NUMBER_OF_ENTRIES),
    addr(&user::LOCATION_INFORMATION),
    addr(&user::USER_DESCRIPTION),
    addr(&user::DISPLAYED_DEVICE_NAME),
    addr(&user::STATIC_NODE_ID),
];

pub(super) const LED: [ObjectAddress; 5] = [
    addr(&objects::LED_MODE),
    addr(&valve::COLOUR_POSITION_CLOSED),
    addr(&valve::COLOUR_POSITION_BETWEEN),
    addr(&valve::COLOUR_POSITION_OPEN),
    addr(&objects::LED_EXTERN_COLOUR),
];

pub(super) fn description_from(b: &Batch) -> Result<DeviceDescription, Error> {
    Ok(DeviceDescription {
        device_name: b.get(desc::DEVICE_NAME)?,
        ident_number: b.get(desc::IDENT_NUMBER)?,
        manufacture_date: b.get(desc::MANUFACTURE_DATE)?,
        software_ident_number: b.get(desc::SOFTWARE_IDENT_NUMBER)?,
        software_version: b.get(desc::SOFTWARE_VERSION)?,
        hardware_version: b.get(desc::HARDWARE_VERSION)?,
        serial_number: b.get(desc::SERIAL_NUMBER)?,
        product_code: b.get(desc::PRODUCT_CODE)?,
        product_group: b.get(desc::PRODUCT_GROUP)?,
    })
}

pub(super) fn status_from(b: &Batch) -> Result<DeviceStatus, Error> {
    Ok(DeviceStatus {
        ne107: b
            .get(st::DEVICE_STATUS_NAMUR_NE107)?
            .map(Ne107Status::from_raw),
        temperature: b.get(st::DEVICE_TEMPERATURE)?.map(Kelvin),
        supply_voltage: b.get(st::DEVICE_SUPPLY_VOLTAGE)?,
        operation_time_s: b.get(st::OPERATION_TIME_S)?,
        max_temperature_k: b.get(st::MAXIMUM_DEVICE_TEMPERATURE)?,
        min_temperature_k: b.get(st::MINIMUM_DEVICE_TEMPERATURE)?,
        max_voltage: b.get(st::MAXIMUM_DEVICE_VOLTAGE)?,
        min_voltage: b.get(st::MINIMUM_DEVICE_VOLTAGE)?,
        current: b.get(st::DEVICE_CURRENT)?,
        max_current: b.get(st::MAXIMUM_DEVICE_CURRENT)?,
        min_current: b.get(st::MINIMUM_DEVICE_CURRENT)?,
        boot_counter: b.get(st::DEVICE_BOOT_COUNTER)?,
        trans_mem: b.get(st::TRANS_MEM_STATUS)?.map(TransMemStatus::from_u8),
        battery_voltage: b.get(st::BATTERY_VOLTAGE)?,
        voltage_drop_counter: b.get(st::VOLTAGE_DROP_COUNTER)?,
        time_since_boot_s: b.get(st::OPERATION_TIME_SINCE_LAST_BOOT)?,
        actuator_voltage: b.get(st::ACTUATOR_SUPPLY_VOLTAGE)?,
    })
}

pub(super) fn typed<T, E: std::error::Error + Send + Sync + 'static>(
    node: NodeId,
    e: ObjectAddress,
    v: Option<u8>,
    f: impl FnOnce(u8) -> Result<T, E>,
) -> Result<Option<T>, Error> {
    v.map(f)
        .transpose()
        .map_err(|err| undefined(node, e, ValueProblem::Profile(Box::new(err))))
}

pub(super) fn communication_from(b: &Batch) -> Result<DeviceCommunication, Error> {
    let n = b.node;
    Ok(DeviceCommunication {
        bit_rate: typed(
            n,
            addr(&comm::BAUDRATE),
            b.get(comm::BAUDRATE)?,
            BitRate::from_code,
        )?,
        address: b.get(comm::ADDRESS)?,
        bus_mode: typed(
            n,
            addr(&comm::B_US_MODE),
            b.get(comm::B_US_MODE)?,
            BusMode::from_u8,
        )?,
        bus_version: b.get(comm::B_US_VERSION)?,
        rx_error_count: b.get(comm::RX_ERROR_COUNT)?,
        rx_error_count_max: b.get(comm::RX_ERROR_COUNT_MAX)?,
        tx_error_count: b.get(comm::TX_ERROR_COUNT)?,
        tx_error_count_max: b.get(comm::TX_ERROR_COUNT_MAX)?,
        can_operation_status: b
            .get(comm::CAN_OPERATION_STATUS)?
            .map(CanOperationStatus::from_u8),
        termination: typed(
            n,
            addr(&comm::TERMINATION_RESISTOR),
            b.get(comm::TERMINATION_RESISTOR)?,
            Termination::from_u8,
        )?,
        eds_version: b.get(comm::EDS_VERSION)?.map(EdsVersion::from_u8),
    })
}

pub(super) fn colour(b: &Batch, e: Entry<u32>, default: LedColour) -> Result<LedColour, Error> {
    match b.get(e)? {
        None => Ok(default),
        Some(raw) => LedColour::from_u32(raw)
            .map_err(|err| undefined(b.node, addr(&e), ValueProblem::Profile(Box::new(err)))),
    }
}

pub(super) fn led_from(b: &Batch) -> Result<LedConfig, Error> {
    let d = ValveModeColours::default();
    let mode = match b.get(objects::LED_MODE)? {
        None => LedMode::default(),
        Some(raw) => LedMode::from_u32(raw).map_err(|err| {
            let problem = ValueProblem::Profile(Box::new(err));
            undefined(b.node, addr(&objects::LED_MODE), problem)
        })?,
    };
    Ok(LedConfig {
        mode,
        valve: ValveModeColours {
            closed: colour(b, valve::COLOUR_POSITION_CLOSED, d.closed)?,
            between: colour(b, valve::COLOUR_POSITION_BETWEEN, d.between)?,
            open: colour(b, valve::COLOUR_POSITION_OPEN, d.open)?,
        },
        external: colour(
            b,
            objects::LED_EXTERN_COLOUR,
            crate::colour::PredefinedColour::White.into(),
        )?,
    })
}
