//! Random frame sequences against the DeviceNet master of the cPos client, on a virtual clock:
//! no panic and bounded output. Each 11-byte chunk is [selector, dt, dlc, data 0..8].
#![no_main]

use canola_devicenet::{MacId, Predefined};
use canola_frame::{CanFrame, CanId, Duration, Instant};
use canola_gemu::over_devicenet::{CposMaster, CposMasterConfig, SIM_DIAGNOSTIC_PATH};
use canola_gemu::params::ParamId;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let slave = MacId::new(63).unwrap();
    let mut config = CposMasterConfig::new(slave);
    config.expected_sizes = None;
    config.diagnostics = Some(SIM_DIAGNOSTIC_PATH);
    let mut m = CposMaster::new(config);
    let mut now = Instant::ZERO;
    m.start(now);
    for _ in 0..2 {
        now += Duration::from_millis(1000);
        m.handle_timeout(now);
    }
    for chunk in data.chunks(11) {
        let [sel, dt, dlc, body @ ..] = chunk else {
            break;
        };
        now += Duration::from_millis(u64::from(*dt));
        if m.poll_timeout().is_some_and(|t| t <= now) {
            m.handle_timeout(now);
        }
        let id = match sel % 5 {
            0 | 1 => Predefined::SlaveExplicitResponse(slave).can_id(),
            2 => Predefined::SlavePollResponse(slave).can_id(),
            3 => Predefined::DuplicateMacCheck(MacId::new(0).unwrap()).can_id(),
            _ => CanId::standard(u16::from(*sel) << 3 | u16::from(*dlc) & 7).unwrap(),
        };
        let n = usize::from(*dlc % 9).min(body.len());
        m.handle_frame(now, &CanFrame::new(id, &body[..n]).unwrap());
        if m.is_connected() && sel & 0x80 != 0 {
            let _ = m.client_mut().get(now, ParamId::MODE);
        }
        let mut sent = 0;
        while m.poll_transmit().is_some() {
            sent += 1;
            assert!(sent <= 40);
        }
        while m.poll_event().is_some() {}
    }
});
