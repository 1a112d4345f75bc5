//! The cyclic synchronous modes (csp, csv, cst): [`CyclicStream`], the target in an RPDO sent
//! on every SYNC, set up on a mapping of its own ([`Drive::start_cyclic`]) or on the PDOs a DCF
//! configures ([`Drive::start_cyclic_from_dcf`]).

use std::prelude::rust_2024::*;

use canola::{Duration, Operation};

use super::super::dcf::{DcfPdo, DcfPdos};
use crate::mode::ModeOfOperation;
use crate::objects::{self as obj};
use crate::state::State;
use crate::words::Controlword;

use super::{CyclicSetup, Drive, DriveError, DriveOp, lock};

/// A cyclic synchronous stream (csp, csv, cst) of one drive: its target goes in an RPDO the
/// master's PDO engine sends after every SYNC the master produces (see
/// [`Drive::start_cyclic`]). Set the next target once per cycle; nothing here waits.
///
/// Dropped without [`stop`](Self::stop) (a task cancelled, a panic unwinding, a `?` leaving
/// early), it stops the RPDO and the drive as [`Drive::on_cancel`] says (a quick stop unless set
/// otherwise; see [`OnCancel`](super::OnCancel) for what a panic leaves).
#[derive(Debug)]
pub struct CyclicStream {
    drive: Drive,
    sender: canola::RpdoSender,
    target: (u16, u8),
    /// Ended by [`stop`](Self::stop): nothing for the drop to do.
    stopped: bool,
}

impl Drop for CyclicStream {
    fn drop(&mut self) {
        if !self.stopped {
            // The controlword goes into the RPDO too when it maps it, before it stops.
            self.drive.stop_unwaited(self.drive.on_cancel);
            let _ = self.end();
        }
    }
}

impl CyclicStream {
    /// The target the next SYNC's RPDO carries (position in counts for csp, velocity in
    /// counts/s for csv, torque in ‰ for cst; range-checked against the object's type).
    pub fn set_target(&self, value: i32) -> Result<(), DriveError> {
        self.sender.set(self.target, value)?;
        Ok(())
    }

    /// The drive.
    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The RPDO number the stream sends.
    pub fn rpdo(&self) -> u16 {
        self.sender.number()
    }

    /// Stops sending the RPDO (the drive keeps its last target and goes on as commanded: this
    /// is the planned end, which does not stop the drive). Does not wait.
    pub fn stop(mut self) -> Result<(), DriveError> {
        self.stopped = true;
        self.end()
    }

    fn end(&self) -> Result<(), DriveError> {
        let mut slot = lock(&self.drive.shared.stream_controlword);
        if slot
            .as_ref()
            .is_some_and(|(s, _)| s.number() == self.sender.number())
        {
            *slot = None;
        }
        drop(slot);
        self.sender.stop()?;
        Ok(())
    }
}

impl Drive {
    /// Starts a cyclic stream in `mode` through the node's RPDO number `rpdo`, which is remapped
    /// to carry only the mode's target on every SYNC (type 1): csp 0x607A, csv 0x60FF, cst
    /// 0x6071, or interpolated position (ip) 0x60C1:1, the interpolation data record. 0x60C2 is
    /// set to `period`, the SYNC period the master produces (start it with
    /// [`Network::start_sync`](canola::Network::start_sync)); the node must be operational for
    /// its RPDOs to count.
    ///
    /// The first target is the present actual value for csp and ip (the drive does not jump:
    /// ethercat_driver_ros2 #125) and 0 for csv and cst; it is in the RPDO before the mode is
    /// switched, so the drive never takes a stale target. The power state is not changed.
    ///
    /// For ip, the linear sub-mode is selected (0x60C0 = 0; a drive without 0x60C0 has only
    /// that one), and a drive in operation enabled gets controlword bit 4 (enable ip mode), so
    /// it follows the set-points at once; a drive enabled later needs that bit written
    /// ([`write_controlword`](Self::write_controlword)`(0x001F)`).
    pub fn start_cyclic(
        &self,
        mode: ModeOfOperation,
        rpdo: u16,
        period: Duration,
    ) -> DriveOp<CyclicStream> {
        let d = self.clone();
        Operation::new(async move {
            let (target, bits, first) = match mode {
                ModeOfOperation::CyclicSyncPosition => (
                    d.at(obj::TARGET_POSITION),
                    32,
                    i64::from(d.position().await?),
                ),
                ModeOfOperation::CyclicSyncVelocity => (d.at(obj::TARGET_VELOCITY), 32, 0),
                ModeOfOperation::CyclicSyncTorque => (d.at(obj::TARGET_TORQUE), 16, 0),
                ModeOfOperation::InterpolatedPosition => (
                    d.at(obj::INTERPOLATION_DATA_RECORD),
                    32,
                    i64::from(d.position().await?),
                ),
                m => return Err(DriveError::NotCyclic(m)),
            };
            if mode == ModeOfOperation::InterpolatedPosition {
                let sub_mode = d.at(obj::INTERPOLATION_SUB_MODE_SELECT);
                match d.node.sdo().write(sub_mode, 0i16).await {
                    // Without 0x60C0 the drive has only linear interpolation.
                    Err(e) if e.server_abort().is_some_and(|c| c.0 == 0x0602_0000) => {}
                    r => r?,
                }
            }
            d.write_interpolation_period(period).await?;
            let rpdos = d.node.rpdo();
            let mut set = rpdos.read().await?;
            let p = set
                .get_mut(rpdo)
                .ok_or(DriveError::Cyclic(CyclicSetup::NoRpdo(rpdo)))?;
            p.clear();
            p.map_entry(canola::ObjectAddress::new(target.0, target.1), bits);
            p.set_transmission_type(canola::pdo::TransmissionType::SyncCyclic(1));
            p.set_enabled(true);
            rpdos.save(&mut set).await?;
            let p = set
                .get(rpdo)
                .ok_or(DriveError::Cyclic(CyclicSetup::NoRpdo(rpdo)))?;
            let sender = rpdos.start(p, canola::Transmission::on_sync())?;
            sender.set(target, first)?;
            // Also by SDO, so the target is in place before the mode switch whatever the SYNC
            // does.
            match bits {
                16 => d.node.sdo().write(target, first as i16).await?,
                _ => d.node.sdo().write(target, first as i32).await?,
            }
            d.select_mode(mode).await?;
            if mode == ModeOfOperation::InterpolatedPosition
                && State::decode(d.statusword().await?) == Some(State::OperationEnabled)
            {
                d.put_controlword(Controlword::from_raw(0x001F)).await?;
            }
            Ok(CyclicStream {
                drive: d,
                sender,
                target,
                stopped: false,
            })
        })
    }

    /// 0x60C2 (interpolation time period) set to `period`.
    async fn write_interpolation_period(&self, period: Duration) -> Result<(), DriveError> {
        let ip = obj::InterpolationPeriod::from_micros(period.as_micros())
            .ok_or(DriveError::Cyclic(CyclicSetup::Period(period)))?;
        let sdo = || self.node.sdo();
        sdo()
            .write(self.at(obj::INTERPOLATION_TIME_PERIOD_VALUE), ip.value)
            .await?;
        sdo()
            .write(self.at(obj::INTERPOLATION_TIME_INDEX), ip.index)
            .await?;
        Ok(())
    }

    /// Starts a cyclic synchronous stream in `mode` (csp, csv or cst) on the PDOs a DCF
    /// configures for it ([`DcfPdos::for_mode`]) instead of a mapping of its own: the valid
    /// synchronous RPDO that carries the mode's target, as the DCF maps it (with whatever else
    /// it maps, e.g. the controlword), and the valid TPDOs carrying the actual value. Both are
    /// written to the device as the DCF has them (COB-ID, transmission type, timers, mapping;
    /// what the device holds already is not written again), so the master decodes the TPDOs
    /// with that mapping (see [`follow_tpdos`](Self::follow_tpdos)) and sends the RPDO on
    /// every SYNC it produces.
    ///
    /// A DCF without such PDOs fails with [`DriveError::Dcf`] before anything is written. The
    /// other objects the RPDO maps start at their present values (read by SDO): the
    /// controlword at the last one written, which every later controlword write also updates
    /// (so the RPDO never undoes a state change), the mode of operation (0x6060) at `mode`.
    /// The first target is the actual position for csp and 0 for csv and cst, as in
    /// [`start_cyclic`](Self::start_cyclic); 0x60C2 is set to `period`; the power state is not
    /// changed.
    pub fn start_cyclic_from_dcf(
        &self,
        mode: ModeOfOperation,
        pdos: &DcfPdos,
        period: Duration,
    ) -> DriveOp<CyclicStream> {
        let m = pdos.for_mode(mode, self.axis);
        let d = self.clone();
        Operation::new(async move {
            let m = m?;
            let first = match mode {
                ModeOfOperation::CyclicSyncPosition => i64::from(d.position().await?),
                _ => 0,
            };
            d.write_interpolation_period(period).await?;
            let tpdos = d.node.tpdo();
            let mut set = tpdos.read().await?;
            for t in &m.tpdos {
                apply_dcf_pdo(&mut set, t)?;
            }
            tpdos.save(&mut set).await?;
            let rpdos = d.node.rpdo();
            let mut set = rpdos.read().await?;
            apply_dcf_pdo(&mut set, &m.rpdo)?;
            rpdos.save(&mut set).await?;
            let p = set
                .get(m.rpdo.number)
                .ok_or(DriveError::Cyclic(CyclicSetup::NoRpdo(m.rpdo.number)))?;
            let sender = rpdos.start(p, canola::Transmission::on_sync())?;
            let cw_at = d.at(obj::CONTROLWORD);
            let mode_at = d.at(obj::MODES_OF_OPERATION);
            let mut cw_mapped = false;
            for (index, sub, bits) in m.rpdo.objects() {
                let at = (index, sub);
                if at == m.target {
                    sender.set(at, first)?;
                } else if at == cw_at {
                    let cw = match d.last_controlword() {
                        Some(cw) => cw.raw(),
                        None => u16::from_le_bytes(d.read_at(cw_at).await?),
                    };
                    sender.set(at, cw)?;
                    cw_mapped = true;
                } else if at == mode_at {
                    sender.set(at, mode.code())?;
                } else if index >= 0x1000 && bits % 8 == 0 {
                    // Anything else keeps the value the device has.
                    let mut data = d.node.sdo().read(at).await?;
                    data.resize(usize::from(bits / 8), 0);
                    sender.set(at, data)?;
                }
            }
            if cw_mapped {
                *lock(&d.shared.stream_controlword) = Some((sender.clone(), cw_at));
            }
            // Also by SDO, so the target is in place before the mode switch whatever the SYNC
            // does.
            match m.target_bits {
                16 => d.node.sdo().write(m.target, first as i16).await?,
                _ => d.node.sdo().write(m.target, first as i32).await?,
            }
            d.select_mode(mode).await?;
            Ok(CyclicStream {
                drive: d,
                sender,
                target: m.target,
                stopped: false,
            })
        })
    }
}

/// Sets PDO `d.number` of `set` to the DCF's parameters and mapping.
fn apply_dcf_pdo(set: &mut canola::PdoSet, d: &DcfPdo) -> Result<(), DriveError> {
    let direction = set.direction();
    let p = set
        .get_mut(d.number)
        .ok_or(DriveError::Cyclic(CyclicSetup::NoPdoForDcf {
            direction,
            number: d.number,
        }))?;
    p.clear();
    for (index, sub, bits) in d.objects() {
        p.map_entry(canola::ObjectAddress::new(index, sub), bits);
    }
    p.comm = d.comm;
    Ok(())
}
