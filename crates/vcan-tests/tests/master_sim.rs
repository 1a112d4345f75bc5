//! The master (`canopen::Network` on the SocketCAN transport) against this project's device
//! simulator (`canopen::SimDevice`, on a second socket) over the real kernel CAN stack: every SDO
//! method, NMT, heartbeat boot-up, loss when the simulator stops and recovery when it returns.
//!
//! Ignored on the host; `tests/vcan/run-all` runs them in the QEMU guest with `--ignored`. Each
//! test uses its own node-ID, so they may run in parallel on the shared bus.

mod common;

use std::sync::mpsc::Receiver;

use can_frame::Duration;
use canopen::socketcan::SocketCan;
use canopen::{Network, NetworkEvent};
use canopen_nmt::{HeartbeatEvent, NmtState};
use canopen_sdo::AbortCode;
use common::{RunningSim, device, node};

fn network() -> Network {
    Network::new(SocketCan::open(&vcan_tests::interface()).expect("open the master's socket"))
}

/// Drives the network for up to `limit` until an event satisfies `want`.
fn wait_event(
    net: &Network,
    events: &Receiver<NetworkEvent>,
    limit: Duration,
    what: &str,
    want: impl Fn(&NetworkEvent) -> bool,
) {
    let deadline = net.now() + limit;
    let mut seen = Vec::new();
    while net.now() < deadline {
        net.run_for(Duration::from_millis(50))
            .expect("drive the network");
        for e in events.try_iter() {
            if want(&e) {
                return;
            }
            seen.push(e);
        }
    }
    panic!("no {what} within {limit:?}; events seen: {seen:?}");
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn every_sdo_method_against_the_simulator() {
    let _sim = RunningSim::start(device(0x41));
    let net = network();
    let n = net.node(node(0x41));

    // Expedited upload and download.
    assert_eq!(
        n.sdo().read((0x1000, 0)).unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
    assert_eq!(n.sdo().read((0x1018, 1)).unwrap(), 0x0ABCu32.to_le_bytes());
    n.sdo().write((0x2000, 0), 0xCAFE_BABEu32).unwrap();
    assert_eq!(
        n.sdo().read((0x2000, 0)).unwrap(),
        0xCAFE_BABEu32.to_le_bytes()
    );
    assert_eq!(
        n.sdo().read((0x2002, 3)).unwrap(),
        (-32768i16).to_le_bytes()
    );

    // Segmented upload and download.
    assert_eq!(
        n.sdo().read((0x1008, 0)).unwrap(),
        b"canopen-rs vcan test device"
    );
    let text = "segmented download through the kernel CAN stack, then read back";
    n.sdo().write((0x2001, 0), text).unwrap();
    assert_eq!(n.sdo().read((0x2001, 0)).unwrap(), text.as_bytes());

    // Block download and upload of 4 KiB (several blocks of up to 127 segments).
    let data: Vec<u8> = (0..4096u32).map(|i| b'A' + (i % 26) as u8).collect();
    n.sdo()
        .block(true)
        .write((0x2001, 0), data.as_slice())
        .unwrap();
    assert_eq!(n.sdo().block(true).read((0x2001, 0)).unwrap(), data);
    // And the same value by segmented upload, to cross-check the block path.
    assert_eq!(n.sdo().read((0x2001, 0)).unwrap(), data);

    // Aborts carry the server's code.
    let e = n.sdo().read((0x5FFF, 0)).unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0602_0000)), "{e}");
    let e = n.sdo().write((0x1000, 0), 1u32).unwrap_err();
    assert!(
        e.server_abort().is_some(),
        "writing a read-only object: {e}"
    );
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn boot_up_nmt_start_heartbeat_loss_and_recovery() {
    let net = network();
    let events = net.subscribe();
    // The test EDS produces a heartbeat every 100 ms.
    net.monitor_heartbeat(node(0x42), Duration::from_millis(500));

    let sim = RunningSim::start(device(0x42));
    wait_event(&net, &events, Duration::from_secs(10), "boot-up", |e| {
        *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(0x42) })
    });

    net.node(node(0x42)).nmt().start().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat OPERATIONAL",
        |e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged { node: n, to: NmtState::Operational, .. }) if *n == node(0x42)),
    );
    assert_eq!(net.last_state(node(0x42)), Some(NmtState::Operational));

    // The simulator goes silent: a loss after 500 ms without heartbeat.
    let dev = sim.stop();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat loss",
        |e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::Lost { node: n, .. }) if *n == node(0x42)),
    );

    // It returns with its state (no reboot): recovery.
    let _sim = RunningSim::start(dev);
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat recovery",
        |e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::Recovered { node: n, state: NmtState::Operational }) if *n == node(0x42)),
    );
    // And it still serves SDO.
    assert_eq!(
        net.node(node(0x42)).sdo().read((0x1018, 4)).unwrap(),
        0x00C0_FFEEu32.to_le_bytes()
    );
}
