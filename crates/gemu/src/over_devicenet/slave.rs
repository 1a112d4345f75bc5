//! The simulated cPos as the application of a DeviceNet slave.

use canola_devicenet::explicit::Path;
use canola_devicenet::fragment::MessageBuf;
use canola_devicenet::{Application, CipError, GeneralStatus, Identity, MacId, SlaveConfig};
use canola_frame::{Duration, Instant};
use heapless::Deque;

use super::{ImageSizes, PRODUCT_CODE, PRODUCT_NAME, SIM_DIAGNOSTIC_PATH, VENDOR_ID};
use crate::image::{MASTER_IMAGE_LEN, MasterImage};
use crate::sim::SimulatedCpos;

/// The Identity object of the simulated cPos. The device type and revision are not in the
/// manual: 0 (generic device) and 1.1 here.
pub fn cpos_identity(serial_number: u32) -> Identity {
    let mut product_name = heapless::String::new();
    let _ = product_name.push_str(PRODUCT_NAME);
    Identity {
        vendor_id: VENDOR_ID,
        device_type: 0,
        product_code: PRODUCT_CODE,
        major_revision: 1,
        minor_revision: 1,
        status: 0,
        serial_number,
        product_name,
    }
}

/// A slave configuration for a cPos at `mac` with the given image sizes (500 kbit/s).
pub fn cpos_slave_config(mac: MacId, sizes: ImageSizes, serial_number: u32) -> SlaveConfig {
    SlaveConfig {
        mac,
        identity: cpos_identity(serial_number),
        produced_size: sizes.receive,
        consumed_size: sizes.send,
        baud_rate: 2,
        dup_mac_wait: Duration::from_millis(1000),
    }
}

/// The simulated cPos behind a DeviceNet slave: poll commands become the master image (the
/// bytes a shorter "Data send" setting leaves out keep their last value, zero at first), the
/// device image is the poll response, and external diagnostics wait at
/// [`SIM_DIAGNOSTIC_PATH`] until read.
#[derive(Debug)]
pub struct CposSlave {
    sim: SimulatedCpos,
    master: [u8; MASTER_IMAGE_LEN],
    diagnostics: Deque<u8, 8>,
    idle_count: u32,
    timeouts: u32,
}

impl CposSlave {
    /// The application around a simulator.
    pub fn new(sim: SimulatedCpos) -> Self {
        Self {
            sim,
            master: [0; MASTER_IMAGE_LEN],
            diagnostics: Deque::new(),
            idle_count: 0,
            timeouts: 0,
        }
    }
    /// The simulator.
    pub fn sim(&self) -> &SimulatedCpos {
        &self.sim
    }
    /// The simulator, mutable (to raise errors, inject faults, ...).
    pub fn sim_mut(&mut self) -> &mut SimulatedCpos {
        &mut self.sim
    }
    /// Zero-length (idle) poll commands seen.
    pub fn idle_count(&self) -> u32 {
        self.idle_count
    }
    /// Poll connection timeouts seen.
    pub fn timeouts(&self) -> u32 {
        self.timeouts
    }

    fn drain_diagnostics(&mut self) {
        while let Some(d) = self.sim.poll_diagnostic() {
            if self.diagnostics.is_full() {
                self.diagnostics.pop_front();
            }
            let _ = self.diagnostics.push_back(d.0);
        }
    }
}

impl Application for CposSlave {
    fn consume(&mut self, now: Instant, data: &[u8]) {
        let n = data.len().min(MASTER_IMAGE_LEN);
        self.master[..n].copy_from_slice(&data[..n]);
        // An image outside the documented ranges is ignored, like a frame the device rejects.
        if let Ok(image) = MasterImage::parse(&self.master) {
            self.sim.handle_master_image(now, &image);
        }
        self.drain_diagnostics();
    }

    fn produce(&mut self, _now: Instant, out: &mut MessageBuf) {
        let _ = out.extend_from_slice(&self.sim.device_image().to_bytes());
    }

    fn idle(&mut self, _now: Instant) {
        self.idle_count += 1;
    }

    fn connection_timed_out(&mut self, _now: Instant) {
        self.timeouts += 1;
    }

    fn get_attribute(
        &mut self,
        _now: Instant,
        path: Path,
        out: &mut MessageBuf,
    ) -> Result<(), CipError> {
        if path == SIM_DIAGNOSTIC_PATH {
            let _ = out.push(self.diagnostics.pop_front().unwrap_or(0));
            return Ok(());
        }
        Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
    }

    fn set_attribute(&mut self, _now: Instant, path: Path, _data: &[u8]) -> Result<(), CipError> {
        if path == SIM_DIAGNOSTIC_PATH {
            return Err(CipError::new(GeneralStatus::AttributeNotSettable));
        }
        Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
    }

    fn poll_timeout(&self) -> Option<Instant> {
        self.sim.poll_timeout()
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.sim.handle_timeout(now);
        self.drain_diagnostics();
    }
}
