//! Random request sequences against the LSS slave (either kind: answering Fastscan in
//! configuration state or not) and random response sequences against the assign-all master, on
//! a virtual clock: no panic, bounded output, and the slave's node-IDs stay valid (1..=127 or
//! 0xFF).
#![no_main]

use canola_frame::{Duration, Instant, NodeId};
use canola_lss::{
    AssignAll, AssignConfig, LssAddress, LssMachine, LssSlave, NodeIdPool, Request, Response,
    SlaveConfig,
};
use libfuzzer_sys::fuzz_target;

fn valid(id: u8) -> bool {
    id == 0xFF || NodeId::new(id).is_ok()
}

fuzz_target!(|data: &[u8]| {
    let Some((&kind, data)) = data.split_first() else {
        return;
    };
    let mut config = SlaveConfig::unconfigured(LssAddress::new(0x78, 0x1234, 2, 0xCAFE));
    config.fastscan_in_configuration = kind & 1 != 0;
    let mut slave = LssSlave::new(config);
    let mut master = AssignAll::new(AssignConfig::with_pool(NodeIdPool::all()));
    let mut now = Instant::ZERO;
    let _ = master.start(now);
    for chunk in data.chunks(10) {
        let [sel, dt, body @ ..] = chunk else { break };
        now += Duration::from_millis(u64::from(*dt));
        slave.handle_timeout(now);
        master.handle_timeout(now);
        if sel & 1 == 0 {
            if let Ok(r) = Request::parse(body) {
                slave.handle_request(now, &r);
            }
        } else if let Ok(r) = Response::parse(body) {
            master.handle_response(now, &r);
        }
        let mut n = 0;
        while slave.poll_transmit().is_some() || slave.poll_event().is_some() {
            n += 1;
            assert!(n < 16);
        }
        n = 0;
        while master.poll_transmit().is_some() {
            n += 1;
            assert!(n < 32);
        }
        while master.poll_event().is_some() {}
        assert!(valid(slave.active_node_id()) && valid(slave.pending_node_id()));
        if master.is_finished() {
            master = AssignAll::new(AssignConfig::with_pool(NodeIdPool::all()));
            let _ = master.start(now);
        }
    }
});
