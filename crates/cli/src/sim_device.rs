//! Which simulated device a dictionary gets, for `simulate` and the in-memory bus's `--eds`
//! devices: the simulated servo for a CiA 402 drive, the Bürkert device for the Bürkert
//! profile, the generic simulator otherwise.

use canola::{NodeId, ObjectDictionary, SimDevice};
use canola_burkert::SimulatedDevice;
use canola_cia402::master::DriveHook;
use canola_cia402::sim::SimDrive;

/// Whether `od` describes a CiA 402 drive (controlword 0x6040 and statusword 0x6041).
fn is_drive(od: &ObjectDictionary) -> bool {
    od.sub(0x6040, 0).is_some() && od.sub(0x6041, 0).is_some()
}

/// The simulated device for `od`: the simulated servo ([`SimDrive`] behind a [`SimDevice`])
/// for a CiA 402 dictionary, else what [`SimulatedDevice::for_dictionary`] gives.
pub(crate) fn simulated_device(node: NodeId, od: ObjectDictionary) -> SimulatedDevice {
    if is_drive(&od) {
        let device = SimDevice::new(node, od).with_hook(DriveHook::new(SimDrive::default()));
        SimulatedDevice::Generic(Box::new(device))
    } else {
        SimulatedDevice::for_dictionary(node, od)
    }
}
