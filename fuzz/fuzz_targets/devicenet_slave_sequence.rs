//! Random frame sequences against the DeviceNet slave with the simulated cPos behind it, on a
//! virtual clock: no panic, bounded output, every frame it sends is DeviceNet of its own MAC.
//! Each 11-byte chunk is [selector, dt, dlc, data 0..8]: the selector picks one of the
//! identifiers the slave listens to (or any identifier), dt advances the clock in ms.
#![no_main]

use canola_devicenet::{DnId, MacId, Predefined, Slave};
use canola_frame::{CanFrame, CanId, Duration, Instant};
use canola_gemu::SimulatedCpos;
use canola_gemu::over_devicenet::{CposSlave, ImageSizes, cpos_slave_config};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mac = MacId::new(63).unwrap();
    let mut slave = Slave::new(
        cpos_slave_config(mac, ImageSizes::STANDARD, 1),
        CposSlave::new(SimulatedCpos::default()),
    );
    let mut now = Instant::ZERO;
    slave.start(now);
    // Usually on line first, so the connection paths are reached.
    if data.first().is_some_and(|b| b & 1 == 0) {
        now += Duration::from_millis(1000);
        slave.handle_timeout(now);
        now += Duration::from_millis(1000);
        slave.handle_timeout(now);
    }
    for chunk in data.chunks(11) {
        let [sel, dt, dlc, body @ ..] = chunk else {
            break;
        };
        now += Duration::from_millis(u64::from(*dt));
        if slave.poll_timeout().is_some_and(|t| t <= now) {
            slave.handle_timeout(now);
        }
        let id = match sel % 6 {
            0 => Predefined::UnconnectedRequest(mac).can_id(),
            1 => Predefined::MasterExplicitRequest(mac).can_id(),
            2 => Predefined::MasterPollCommand(mac).can_id(),
            3 => Predefined::DuplicateMacCheck(mac).can_id(),
            _ => CanId::standard(u16::from(*sel) << 3 | u16::from(*dlc) & 7).unwrap(),
        };
        let n = usize::from(*dlc % 9).min(body.len());
        let frame = CanFrame::new(id, &body[..n]).unwrap();
        slave.handle_frame(now, &frame);
        let mut sent = 0;
        while let Some(f) = slave.poll_transmit() {
            sent += 1;
            assert!(sent <= 32);
            let own = match DnId::of(f.id()).and_then(Predefined::from_id) {
                Some(Predefined::SlaveExplicitResponse(m))
                | Some(Predefined::SlavePollResponse(m))
                | Some(Predefined::DuplicateMacCheck(m)) => m == mac,
                _ => false,
            };
            assert!(own, "unexpected frame {f}");
        }
        while slave.poll_event().is_some() {}
    }
});
