//! The device simulator: a CANopen slave built from any object dictionary (EDS/DCF or generated).
//!
//! A [`SimDevice`] composes the device-side machines of the protocol crates:
//! * NMT slave with boot-up and heartbeat producer (`canola-nmt`, CiA 301 §7.2.8, §7.3.2);
//! * SDO server for expedited, segmented and block transfers (`canola-sdo`, CiA 301 §7.2.4)
//!   over the dictionary's values;
//! * EMCY producer (`canola-nmt`, CiA 301 §7.2.7);
//! * TPDOs and RPDOs by the `canola-pdo` engine, configured from the device's PDO objects
//!   (0x1400.., 0x1600.., 0x1800.., 0x1A00..) when it enters Operational; SYNC, event timers,
//!   inhibit times and change-of-state ([`SimDevice::set_value`]) as the engine implements them;
//! * LSS slave (`canola-lss`, CiA 305) with the identity from 0x1018 as its LSS address. A
//!   device made with [`SimDevice::unconfigured`] has no node-ID: it only answers LSS until a
//!   master assigns one, then boots with it.
//!
//! It implements [`Station`](crate::transport::Station), so it runs attached to an in-memory bus
//! ([`MemoryBus::attach`](crate::transport::mem::MemoryBus::attach), deterministic on the virtual clock) or
//! on any transport with [`run_station`](crate::transport::run_station) (e.g. SocketCAN for
//! `canopen simulate`). Several devices share one bus.
//!
//! Device-specific behaviour plugs in through [`DeviceHook`]: hooks see every SDO write before it
//! is stored (and may refuse it with an abort code), may serve reads themselves (a generated
//! DOMAIN such as a logbook), get their own timers, and can request a reset or an emergency.
//!
//! Communication objects with side effects handled here: 0x1017 producer heartbeat time.
//!
//! Files by job: `device` (the [`SimDevice`] station), `objects` (the objects as the SDO server
//! sees them), `values` ([`Values`]), `hook` ([`DeviceHook`]), `pdo` (the device's own PDOs), `quirks` ([`Quirks`]: habits of
//! real devices it can copy, such as expedited answers without the size).

mod device;
mod hook;
mod objects;
mod pdo;
mod quirks;
mod values;

pub use device::SimDevice;
pub use hook::{DeviceHook, HookActions};
pub use objects::MAX_VARIABLE_SIZE;
pub use quirks::Quirks;
pub use values::Values;
