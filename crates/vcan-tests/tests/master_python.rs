//! Interop: the master (`canola::Network` on the SocketCAN transport) against an independent
//! implementation, python-canopen's LocalNode built from `tests/vcan/test-device.eds`, in another
//! process on the real kernel CAN stack: boot-up, expedited and segmented upload and download,
//! the server's abort code, block upload answered by the protocol switch to a plain upload, a
//! refused block download ending cleanly, NMT start seen in the
//! heartbeat, and TPDO reception (including a value changed by SDO).
//!
//! Ignored on the host; `tests/vcan/run-all` runs it in the QEMU guest with `--ignored` and
//! `CANOPEN_PYTHON` set to the project's venv.

mod common;

use canola::socketcan::SocketCan;
use canola::{Network, NetworkEvent};
use canola_frame::Duration;
use canola_nmt::{HeartbeatEvent, NmtState};
use canola_sdo::AbortCode;
use common::{PythonDevice, node, wait_event};

fn pdo_from(e: &NetworkEvent, id: u8) -> Option<Vec<u8>> {
    match e {
        NetworkEvent::Pdo {
            node: n,
            number: 1,
            data,
            ..
        } if *n == node(id) => Some(data.to_vec()),
        _ => None,
    }
}

#[test]
#[ignore = "needs vcan0 and python-canopen: run by tests/vcan/run-all"]
fn master_against_python_canopen_local_node() {
    const ID: u8 = 0x43;
    let net = Network::new(SocketCan::open(&vcan_tests::interface()).expect("open the socket"));
    let events = net.subscribe();
    net.monitor_heartbeat(node(ID), Duration::from_secs(2));

    let device = PythonDevice::start(&["--tpdo-ms", "100", "0x43"]);
    // The boot-up message went out before READY; it waits in the socket's queue.
    wait_event(&net, &events, Duration::from_secs(10), "boot-up", |e| {
        *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) })
    });

    let n = net.node(node(ID));
    let sdo = || n.sdo().timeout(Duration::from_secs(5));
    // Expedited uploads.
    assert_eq!(
        sdo().read((0x1000, 0)).wait().unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
    assert_eq!(
        sdo().read((0x1018, 1)).wait().unwrap(),
        0x0ABCu32.to_le_bytes()
    );
    assert_eq!(
        sdo().read((0x2002, 3)).wait().unwrap(),
        (-32768i16).to_le_bytes()
    );
    // Segmented upload.
    assert_eq!(
        sdo().read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    // Segmented download, read back.
    let text = "written by the canopen-rs master, segmented, to python-canopen";
    sdo().write((0x2001, 0), text).wait().unwrap();
    assert_eq!(sdo().read((0x2001, 0)).wait().unwrap(), text.as_bytes());
    // The server's abort code reaches the caller.
    let e = sdo().read((0x5FFF, 0)).wait().unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0602_0000)), "{e}");
    // python-canopen's LocalNode has no block transfer. To a block upload request it answers
    // with a plain upload response (the protocol switch CiA 301 allows); the master follows.
    assert_eq!(
        sdo().block(true).read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    // A block download it refuses with an abort: the request ends with that error, not a hang,
    // and the next transfer works.
    let e = sdo()
        .block(true)
        .write((0x2001, 0), text)
        .wait()
        .unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0504_0001)), "{e}");
    assert_eq!(
        sdo().read((0x1018, 2)).wait().unwrap(),
        0x42u32.to_le_bytes()
    );

    // NMT start, seen in the heartbeat.
    n.nmt().start().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat OPERATIONAL",
        |e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged { node: x, to: NmtState::Operational, .. }) if *x == node(ID)),
    );
    assert_eq!(net.last_state(node(ID)), Some(NmtState::Operational));

    // TPDO1 carries 0x2000; an expedited download changes what the following PDOs carry.
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "TPDO1 with the EDS default",
        |e| pdo_from(e, ID) == Some(0x1234_5678u32.to_le_bytes().to_vec()),
    );
    sdo().write((0x2000, 0), 0xCAFE_BABEu32).wait().unwrap();
    assert_eq!(
        sdo().read((0x2000, 0)).wait().unwrap(),
        0xCAFE_BABEu32.to_le_bytes()
    );
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "TPDO1 with the new value",
        |e| pdo_from(e, ID) == Some(0xCAFE_BABEu32.to_le_bytes().to_vec()),
    );

    let status = device.stop();
    assert!(status.success(), "python-canopen LocalNode exit: {status}");
}
