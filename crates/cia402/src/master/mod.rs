//! The master side of CiA 402 over the `canola` facade (feature `master`): [`Drive`], one axis of
//! a drive commanded by SDO, each command an operation (`.wait()` or `.await`) ([`DcfPdos`]: the PDOs of the cyclic modes taken
//! from a DCF), and [`DriveHook`], the simulated drive
//! ([`SimDrive`](crate::sim::SimDrive)) behind a device on the simulated bus.

mod dcf;
mod drive;
mod sim_device;

pub use dcf::{DcfPdo, DcfPdoError, DcfPdos, ModePdos};
pub use drive::{
    Awaited, CyclicSetup, CyclicStream, Drive, DriveError, DriveStatus, FaultReport, Homing, Move,
    OnCancel, Reached, Timeouts,
};
pub use sim_device::{DriveHook, simulated_drive};
