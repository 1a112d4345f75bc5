//! The cPos over DeviceNet: the cyclic image travels in a polled I/O connection of the
//! Predefined Master/Slave Connection Set (crate `canola-devicenet`).
//!
//! - [`CposMaster`]: the [`Client`](crate::Client) driven through a `devicenet` master. It
//!   checks the poll connection's sizes at connect against the sizes the cPos offers (menu
//!   "Data send" 0/2/4/5/13 bytes master → cPos, "Data receive" 0/2/3/11 bytes cPos → master;
//!   13/11 with the standard EDS `G1436a.eds`), sends the first "send" bytes of the client's
//!   13-byte image and widens the "receive" bytes the cPos sends back to the 11-byte image.
//! - [`CposSlave`]: the [`SimulatedCpos`](crate::SimulatedCpos) as the application of a
//!   `devicenet` slave with the cPos's identity (vendor 272, product code 1436, "1436 cPos").
//!
//! The shorter images drop the tail: without the 11-byte receive image there is no parameter
//! channel, so only the cyclic values work ([`CposMaster::has_channel`]).
//!
//! External diagnostics: the manual says the cPos "generates an external diagnostic error" with
//! a code (0x20, 0x21, 0x22, 0x34, 0x40, 0x42) but not how DeviceNet carries it, and the EDS
//! that would say is not among the sources. [`CposMasterConfig::diagnostics`] names an attribute
//! that holds the latest code (0 = none, reading clears it); the master reads it over the
//! explicit connection whenever the channel in the device's image changes, before it hands the
//! image to the client, so the code reaches the request it belongs to. The simulator serves it
//! at [`SIM_DIAGNOSTIC_PATH`], a vendor-specific class of this crate's choosing; for a real
//! cPos leave it `None` until the device's attribute is known (refusals then show as the
//! answers alone: an unchanged value after 'S', 0 after 'G' of an unknown ID).

mod master;
mod slave;

pub use master::{CposEvent, CposMaster, CposMasterConfig};
pub use slave::{CposSlave, cpos_identity, cpos_slave_config};

use core::fmt;

use canola_devicenet::explicit::Path;

/// Where the simulated cPos keeps its latest external diagnostic code: vendor-specific class
/// 0x64, instance 1, attribute 1 (USINT, 0 = none, cleared by reading). The simulator's choice;
/// not from the manual.
pub const SIM_DIAGNOSTIC_PATH: Path = Path::new(0x64, 1, 1);

/// The cPos's vendor ID on DeviceNet.
pub const VENDOR_ID: u16 = 272;
/// The cPos's product code on DeviceNet.
pub const PRODUCT_CODE: u16 = 1436;
/// The cPos's product name.
pub const PRODUCT_NAME: &str = "1436 cPos";

/// Sizes of the cyclic data the device is set to ("Data send" = master → cPos, "Data receive"
/// = cPos → master).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ImageSizes {
    /// Bytes the master sends (0, 2, 4, 5 or 13).
    pub send: u16,
    /// Bytes the cPos sends (0, 2, 3 or 11).
    pub receive: u16,
}

/// "Data send" sizes the cPos offers.
pub const SEND_SIZES: [u16; 5] = [0, 2, 4, 5, 13];
/// "Data receive" sizes the cPos offers.
pub const RECEIVE_SIZES: [u16; 4] = [0, 2, 3, 11];

impl ImageSizes {
    /// The standard EDS setting: 13 bytes out, 11 bytes in.
    pub const STANDARD: ImageSizes = ImageSizes {
        send: 13,
        receive: 11,
    };

    /// Checks that both sizes are ones the cPos offers.
    pub fn check(self) -> Result<Self, SizeError> {
        if !SEND_SIZES.contains(&self.send) || !RECEIVE_SIZES.contains(&self.receive) {
            return Err(SizeError::NotOffered(self));
        }
        Ok(self)
    }
}

impl fmt::Display for ImageSizes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "send {} / receive {} bytes", self.send, self.receive)
    }
}

/// The poll connection's sizes do not fit.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SizeError {
    /// Sizes the cPos does not offer (the device is not a cPos, or misconfigured).
    #[error("{0} is not a cPos setting (send 0/2/4/5/13, receive 0/2/3/11)")]
    NotOffered(ImageSizes),
    /// Not the sizes the application asked for.
    #[error("the device is set to {actual}, expected {expected}")]
    Unexpected {
        /// What the application expects.
        expected: ImageSizes,
        /// What the device is set to.
        actual: ImageSizes,
    },
}

debug_as_display!(SizeError);
