//! Random frames, configuration changes and time steps into the canola-nmt machines (heartbeat
//! consumer, guarding master, EMCY consumer, NMT slave, SYNC producer). No panic, bounded output,
//! and after `handle_timeout(now)` no machine reports a deadline at or before `now`.
#![no_main]

use arbitrary::Arbitrary;
use canola_frame::{CanFrame, CanId, Duration, Instant, NodeId};
use canola_nmt::{
    EmcyConsumer, GuardingMaster, HeartbeatConsumer, NmtSlave, SlaveConfig, SyncConfig,
    SyncProducer,
};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
enum Op {
    Frame {
        cob: u16,
        rtr: bool,
        len: u8,
        data: [u8; 8],
    },
    /// A frame on 0x700 + node with one byte: heartbeats, boot-ups and guarding answers.
    ErrorControl {
        node: u8,
        byte: u8,
    },
    Advance(u32),
    Monitor {
        node: u8,
        ms: u16,
    },
    Guard {
        node: u8,
        ms: u16,
        factor: u8,
    },
    Remove(u8),
    SlaveConfig {
        heartbeat_ms: u16,
        guard_ms: u16,
        factor: u8,
    },
    Boot,
}

fn node(n: u8) -> NodeId {
    NodeId::new(n % 127 + 1).unwrap_or(NodeId::MIN)
}

fuzz_target!(|ops: Vec<Op>| {
    let mut now = Instant::ZERO;
    let mut hb = HeartbeatConsumer::<8>::new();
    let mut gm = GuardingMaster::<8>::new();
    let mut emcy = EmcyConsumer::new();
    let mut slave = NmtSlave::new(
        node(4),
        SlaveConfig {
            heartbeat_ms: 10,
            guard_time_ms: 5,
            life_time_factor: 2,
        },
    );
    let mut sync = SyncProducer::new(SyncConfig::new(Duration::from_millis(3), 5).unwrap());
    sync.start(now);
    slave.boot(now);
    for op in ops.into_iter().take(512) {
        match op {
            Op::Frame {
                cob,
                rtr,
                len,
                data,
            } => {
                let Ok(id) = CanId::standard(cob & 0x7FF) else {
                    continue;
                };
                let len = usize::from(len % 9);
                let f = if rtr {
                    CanFrame::remote(id, len)
                } else {
                    CanFrame::new(id, &data[..len])
                };
                let Ok(f) = f else { continue };
                let _ = hb.handle_frame(now, &f);
                let _ = gm.handle_frame(now, &f);
                let _ = emcy.handle_frame(now, &f);
                let _ = slave.handle_frame(now, &f);
            }
            Op::ErrorControl { node: n, byte } => {
                let Ok(id) = CanId::standard(0x700 + u16::from(node(n).get())) else {
                    continue;
                };
                let Ok(f) = CanFrame::new(id, &[byte]) else {
                    continue;
                };
                let _ = hb.handle_frame(now, &f);
                let _ = gm.handle_frame(now, &f);
            }
            Op::Advance(us) => now += Duration::from_micros(u64::from(us)),
            Op::Monitor { node: n, ms } => {
                let _ = hb.monitor(node(n), Duration::from_millis(u64::from(ms)));
            }
            Op::Guard {
                node: n,
                ms,
                factor,
            } => {
                let _ = gm.guard(now, node(n), Duration::from_millis(u64::from(ms)), factor);
            }
            Op::Remove(n) => {
                hb.remove(node(n));
                gm.remove(node(n));
            }
            Op::SlaveConfig {
                heartbeat_ms,
                guard_ms,
                factor,
            } => {
                slave.set_heartbeat_time(now, heartbeat_ms);
                slave.set_guarding(guard_ms, factor);
            }
            Op::Boot => slave.boot(now),
        }
        hb.handle_timeout(now);
        gm.handle_timeout(now);
        slave.handle_timeout(now);
        sync.handle_timeout(now);
        let mut out = 0usize;
        while hb.poll_event().is_some() {
            out += 1;
        }
        while gm.poll_event().is_some() {
            out += 1;
        }
        while gm.poll_transmit().is_some() {
            out += 1;
        }
        while emcy.poll_event().is_some() {
            out += 1;
        }
        while slave.poll_event().is_some() {
            out += 1;
        }
        while slave.poll_transmit().is_some() {
            out += 1;
        }
        while sync.poll_transmit().is_some() {
            out += 1;
        }
        assert!(out <= 64, "output is bounded per step");
        for deadline in [
            hb.poll_timeout(),
            gm.poll_timeout(),
            slave.poll_timeout(),
            sync.poll_timeout(),
        ] {
            assert!(
                deadline.is_none_or(|d| d > now),
                "deadline {deadline:?} not after {now:?}"
            );
        }
    }
});
