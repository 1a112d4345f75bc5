//! The master (`canola::Network` on the SocketCAN transport) against this project's device
//! simulator (`canola::SimDevice`, on a second socket) over the real kernel CAN stack: every SDO
//! method (expedited, segmented and block, both ways; forced segmented download; queued,
//! streamed and reader-fed requests), every NMT command with its effect, heartbeat boot-up, loss
//! when the simulator stops and recovery when it returns, PDO events (TPDO decoded through the
//! dictionary, changed by SDO, remapped by SDO; RPDO applied; none outside Operational).
//!
//! Ignored on the host; `tests/vcan/run-all` runs them in the QEMU guest with `--ignored`. Each
//! test uses its own node-ID, so they may run in parallel on the shared bus.

mod common;

use std::sync::{Arc, Mutex};

use canola::socketcan::SocketCan;
use canola::{Network, NetworkEvent, ObjectAddress};
use canola_frame::{CanFrame, CanId, Duration};
use canola_nmt::{HeartbeatEvent, NmtState};
use canola_od::Value;
use canola_sdo::{AbortCode, Method};
use common::{EDS, RunningSim, device, events_during, node, wait_event};

fn network() -> Network {
    Network::new(SocketCan::open(&vcan_tests::interface()).expect("open the master's socket"))
}

/// A writer that keeps what it gets where the test can see it.
#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().expect("not poisoned").extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn every_sdo_method_against_the_simulator() {
    let _sim = RunningSim::start(device(0x41));
    let net = network();
    let n = net.node(node(0x41));

    // Expedited upload and download.
    assert_eq!(
        n.sdo().read((0x1000, 0)).wait().unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
    assert_eq!(
        n.sdo().read((0x1018, 1)).wait().unwrap(),
        0x0ABCu32.to_le_bytes()
    );
    n.sdo().write((0x2000, 0), 0xCAFE_BABEu32).wait().unwrap();
    assert_eq!(
        n.sdo().read((0x2000, 0)).wait().unwrap(),
        0xCAFE_BABEu32.to_le_bytes()
    );
    assert_eq!(
        n.sdo().read((0x2002, 3)).wait().unwrap(),
        (-32768i16).to_le_bytes()
    );

    // Segmented upload and download.
    assert_eq!(
        n.sdo().read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    let text = "segmented download through the kernel CAN stack, then read back";
    n.sdo().write((0x2001, 0), text).wait().unwrap();
    assert_eq!(n.sdo().read((0x2001, 0)).wait().unwrap(), text.as_bytes());

    // Block download and upload of 4 KiB (several blocks of up to 127 segments).
    let data: Vec<u8> = (0..4096u32).map(|i| b'A' + (i % 26) as u8).collect();
    n.sdo()
        .block(true)
        .write((0x2001, 0), data.as_slice())
        .wait()
        .unwrap();
    assert_eq!(n.sdo().block(true).read((0x2001, 0)).wait().unwrap(), data);
    // And the same value by segmented upload, to cross-check the block path.
    assert_eq!(n.sdo().read((0x2001, 0)).wait().unwrap(), data);
    // Block upload of an object shorter than one block (the server may switch protocols).
    assert_eq!(
        n.sdo().block(true).read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );

    // A 4-byte value downloaded segmented on request (Method::Segmented), read back expedited.
    n.sdo()
        .method(Method::Segmented)
        .write((0x2003, 0), 0x0102_0304u32)
        .wait()
        .unwrap();
    assert_eq!(
        n.sdo().read((0x2003, 0)).wait().unwrap(),
        0x0102_0304u32.to_le_bytes()
    );

    // Queued requests (submit, then wait): they run one after the other on the node's channel.
    let a = n.sdo().submit_read((0x1018, 2));
    let b = n.sdo().submit_write((0x2002, 1), 77i16);
    let c = n.sdo().submit_read((0x2002, 1));
    assert_eq!(a.wait().unwrap(), 0x42u32.to_le_bytes().to_vec());
    b.wait().unwrap();
    assert_eq!(c.wait().unwrap(), 77i16.to_le_bytes().to_vec());

    // Streamed upload into a writer and download from a reader (block and segmented).
    let streamed: Vec<u8> = (0..3000u32).map(|i| (i * 31 % 253) as u8).collect();
    let sent = n
        .sdo()
        .block(true)
        .download_from((0x2001, 0), streamed.as_slice())
        .wait()
        .unwrap();
    assert_eq!(sent, 3000);
    let sink = Shared::default();
    let got = n.sdo().upload_to((0x2001, 0), sink.clone()).wait().unwrap();
    assert_eq!(got, 3000);
    assert_eq!(*sink.0.lock().unwrap(), streamed);
    let sink = Shared::default();
    n.sdo()
        .block(true)
        .upload_to((0x2001, 0), sink.clone())
        .wait()
        .unwrap();
    assert_eq!(*sink.0.lock().unwrap(), streamed);

    // Aborts carry the server's code.
    let e = n.sdo().read((0x5FFF, 0)).wait().unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0602_0000)), "{e}");
    let e = n.sdo().write((0x1000, 0), 1u32).wait().unwrap_err();
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
        net.node(node(0x42)).sdo().read((0x1018, 4)).wait().unwrap(),
        0x00C0_FFEEu32.to_le_bytes()
    );
}

fn tpdo1_values(e: &NetworkEvent, id: u8) -> Option<Vec<(ObjectAddress, Value)>> {
    match e {
        NetworkEvent::PdoValues {
            node: n,
            number: 1,
            values,
            ..
        } if *n == node(id) => Some(values.clone()),
        _ => None,
    }
}

fn is_pdo_of(e: &NetworkEvent, id: u8) -> bool {
    matches!(e, NetworkEvent::Pdo { node: n, .. } | NetworkEvent::PdoValues { node: n, .. } if *n == node(id))
}

fn state_changed(e: &NetworkEvent, id: u8, state: NmtState) -> bool {
    matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged { node: n, to, .. }) if *n == node(id) && *to == state)
}

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn nmt_commands_and_pdo_events_against_the_simulator() {
    use canola_pdo::{CommParams, Direction, Mapping};
    const ID: u8 = 0x47;
    let net = network();
    let events = net.subscribe();
    let od = canola_od::parse(EDS).expect("the test EDS parses").od;
    let n = net.add_node_with_dictionary(node(ID), od);
    net.monitor_heartbeat(node(ID), Duration::from_secs(2));
    let _sim = RunningSim::start(device(ID));
    wait_event(&net, &events, Duration::from_secs(10), "boot-up", |e| {
        *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) })
    });

    // Pre-operational: heartbeats, no PDOs (the event timer of TPDO1 is 100 ms).
    let early = events_during(&net, &events, Duration::from_millis(600), |e| {
        is_pdo_of(e, ID)
    });
    assert!(early.is_empty(), "PDOs in Pre-operational: {early:?}");

    // Start: the heartbeat says Operational and TPDO1 arrives, decoded through the dictionary.
    n.nmt().start().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat OPERATIONAL",
        |e| state_changed(e, ID, NmtState::Operational),
    );
    let first = wait_event(&net, &events, Duration::from_secs(10), "TPDO1", |e| {
        tpdo1_values(e, ID).is_some()
    });
    assert_eq!(
        tpdo1_values(&first, ID).unwrap(),
        [(
            ObjectAddress::new(0x2000, 0),
            Value::Unsigned32(0x1234_5678)
        )]
    );
    // A decoded PDO carries its raw data too: 0x2000 as four bytes, little-endian.
    let raw = wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "raw TPDO1",
        |e| matches!(e.pdo_data(), Some((x, 1, _)) if x == node(ID)),
    );
    let Some((_, _, data)) = raw.pdo_data() else {
        unreachable!("matched above")
    };
    assert_eq!(data, 0x1234_5678u32.to_le_bytes());

    // A value written by SDO goes out in the following TPDOs.
    n.sdo().write((0x2000, 0), 0xCAFE_BABEu32).wait().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "TPDO1 with the value written by SDO",
        |e| {
            tpdo1_values(e, ID)
                == Some(vec![(
                    ObjectAddress::new(0x2000, 0),
                    Value::Unsigned32(0xCAFE_BABE),
                )])
        },
    );

    // Remapped by SDO (0x2000 and the INTEGER16 0x2002:02): the device sends, and the master
    // decodes, the new layout.
    n.remap_pdo(
        Direction::Transmit,
        1,
        CommParams::event_driven(0x180 + u16::from(ID)).with_event_timer(100),
        Mapping::from_raw(&[0x2000_0020, 0x2002_0210]).unwrap(),
    )
    .wait()
    .unwrap();
    assert_eq!(n.sdo().read((0x1A00, 0)).wait().unwrap(), [2]);
    let two = |v: i16| {
        vec![
            (
                ObjectAddress::new(0x2000, 0),
                Value::Unsigned32(0xCAFE_BABE),
            ),
            (ObjectAddress::new(0x2002, 2), Value::Integer16(v)),
        ]
    };
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "remapped TPDO1",
        |e| tpdo1_values(e, ID) == Some(two(300)),
    );

    // RPDO1 from the master (0x2003 and 0x2002:02): applied by the device, seen by SDO and in
    // the next TPDO1.
    let rpdo = [
        0x1357_2468u32.to_le_bytes().as_slice(),
        &(-321i16).to_le_bytes(),
    ]
    .concat();
    net.send(CanFrame::new(CanId::standard(0x200 + u16::from(ID)).unwrap(), &rpdo).unwrap())
        .unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "TPDO1 with 0x2002:02 set by the RPDO",
        |e| tpdo1_values(e, ID) == Some(two(-321)),
    );
    assert_eq!(
        n.sdo().read((0x2003, 0)).wait().unwrap(),
        0x1357_2468u32.to_le_bytes()
    );

    // Stop: the heartbeat says Stopped, the PDOs cease, SDO is not served.
    n.nmt().stop().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat STOPPED",
        |e| state_changed(e, ID, NmtState::Stopped),
    );
    let late = events_during(&net, &events, Duration::from_millis(800), |e| {
        is_pdo_of(e, ID)
    });
    assert!(late.is_empty(), "PDOs in Stopped: {late:?}");
    let e = n
        .sdo()
        .timeout(Duration::from_millis(500))
        .read((0x1000, 0))
        .wait()
        .expect_err("no SDO in Stopped");
    assert!(e.to_string().contains("no response"), "{e}");

    // Pre-operational again: SDO works, still no PDOs.
    n.nmt().enter_preoperational().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat PRE-OPERATIONAL",
        |e| state_changed(e, ID, NmtState::PreOperational),
    );
    assert_eq!(
        n.sdo().read((0x2000, 0)).wait().unwrap(),
        0xCAFE_BABEu32.to_le_bytes()
    );
    let late = events_during(&net, &events, Duration::from_millis(600), |e| {
        is_pdo_of(e, ID)
    });
    assert!(late.is_empty(), "PDOs in Pre-operational: {late:?}");

    // Reset communication: boot-up, the application's values kept.
    n.nmt().reset_communication().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "boot-up after reset communication",
        |e| *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) }),
    );
    assert_eq!(
        n.sdo().read((0x2000, 0)).wait().unwrap(),
        0xCAFE_BABEu32.to_le_bytes()
    );

    // Reset node: boot-up, every value back to the EDS default (the mapping too).
    n.nmt().reset_node().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "boot-up after reset node",
        |e| *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) }),
    );
    assert_eq!(
        n.sdo().read((0x2000, 0)).wait().unwrap(),
        0x1234_5678u32.to_le_bytes()
    );
    assert_eq!(n.sdo().read((0x1A00, 0)).wait().unwrap(), [1]);
    // After the boot-up, the heartbeats say Pre-operational.
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat PRE-OPERATIONAL after the reset",
        |e| state_changed(e, ID, NmtState::PreOperational),
    );
    assert_eq!(net.last_state(node(ID)), Some(NmtState::PreOperational));
}
