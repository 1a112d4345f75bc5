//! The master against simulated devices on the in-memory bus (virtual clock, deterministic).

use std::sync::mpsc::Receiver;

use canola::mem::{BusConfig, Faults, MemoryBus, StationId};
use canola::transport::{Received, Transport};
use canola::{Error, Network, NetworkEvent, SdoErrorKind, SimDevice};
use canola_frame::{CanFrame, Duration, NodeId};
use canola_nmt::{DeviceState, Emcy, EmcyCode, ErrorRegister, HeartbeatEvent};
use canola_sdo::{AbortCode, ErrorKind};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn device(id: u8) -> SimDevice {
    SimDevice::from_eds(n(id), EDS).expect("the Bürkert EDS parses")
}

fn od() -> canola_od::ObjectDictionary {
    canola_od::parse(EDS).unwrap().od
}

struct Rig {
    bus: MemoryBus,
    net: Network,
    devices: Vec<StationId<SimDevice>>,
}

fn rig_with(config: BusConfig, ids: &[u8]) -> Rig {
    let bus = MemoryBus::with_config(config);
    let net = Network::new(bus.endpoint());
    let devices = ids.iter().map(|id| bus.attach(device(*id))).collect();
    for id in ids {
        net.add_node_with_dictionary(n(*id), od());
    }
    Rig { bus, net, devices }
}

fn rig(ids: &[u8]) -> Rig {
    rig_with(BusConfig::default(), ids)
}

fn logbook(len: usize) -> Vec<u8> {
    (0..len).map(|i| b"<log entry=\"x\"/>\n"[i % 17]).collect()
}

#[test]
fn expedited_read_and_write() {
    let r = rig(&[5]);
    let node = r.net.node(n(5));
    assert_eq!(
        node.sdo().read((0x1018, 1)).wait().unwrap(),
        0x39u32.to_le_bytes()
    );
    assert_eq!(
        node.sdo().read((0x1017, 0)).wait().unwrap(),
        500u16.to_le_bytes()
    );
    node.sdo().write((0x1017, 0), 100u16).wait().unwrap();
    assert_eq!(
        node.sdo().read((0x1017, 0)).wait().unwrap(),
        100u16.to_le_bytes()
    );
    let v = node.sdo().read_value((0x1017, 0)).wait().unwrap();
    assert_eq!(v, canola_od::Value::Unsigned16(100));
    assert_eq!(
        r.bus
            .with_station(r.devices[0], |d| d.values().get_u64(0x1017, 0)),
        Some(Some(100))
    );
}

#[test]
fn segmented_read_and_write() {
    let r = rig(&[5]);
    let node = r.net.node(n(5));
    assert_eq!(
        node.sdo().read((0x1008, 0)).wait().unwrap(),
        b"Buerkert generic device"
    );
    node.sdo()
        .write((0x2002, 2), "Hall 3, line 7, valve island A")
        .wait()
        .unwrap();
    assert_eq!(
        node.sdo().read((0x2002, 2)).wait().unwrap(),
        b"Hall 3, line 7, valve island A"
    );
}

#[test]
fn block_upload_and_download_with_progress() {
    let r = rig(&[5]);
    let data = logbook(5000);
    r.bus
        .with_station(r.devices[0], |d| {
            d.values_mut().set(0x2003, 4, data.clone())
        })
        .unwrap();
    let node = r.net.node(n(5));
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let seen2 = seen.clone();
    let got = node
        .sdo()
        .block(true)
        .on_progress(move |p| seen2.lock().unwrap().push((p.done, p.total)))
        .read((0x2003, 4))
        .wait()
        .unwrap();
    assert_eq!(got, data);
    let seen = seen.lock().unwrap();
    assert!(seen.len() > 3, "{seen:?}");
    assert_eq!(seen.last().unwrap().1, Some(5000));

    // Streaming upload into a writer.
    let buf = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    struct W(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);
    impl std::io::Write for W {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let len = node
        .sdo()
        .upload_to((0x2003, 4), W(buf.clone()))
        .wait()
        .unwrap();
    assert_eq!(len, 5000);
    assert_eq!(*buf.lock().unwrap(), data);

    let text = logbook(3000);
    let len = node
        .sdo()
        .block(true)
        .download_from((0x2002, 3), text.as_slice())
        .wait()
        .unwrap();
    assert_eq!(len, 3000);
    assert_eq!(
        node.sdo().block(true).read((0x2002, 3)).wait().unwrap(),
        text
    );
}

#[test]
fn abort_is_explained_with_node_object_and_meaning() {
    let r = rig(&[5]);
    let node = r.net.node(n(5));
    let e = node.sdo().read((0x1234, 0)).wait().unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode::OBJECT_DOES_NOT_EXIST));
    let text = e.to_string();
    assert!(text.contains("node 5"), "{text}");
    assert!(text.contains("0x1234"), "{text}");
    assert!(text.contains("0x06020000"), "{text}");
    // Read-only object: the dictionary name appears.
    let e = node.sdo().write((0x1008, 0), "x").wait().unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode::READ_ONLY));
    assert!(e.to_string().contains("Manufacturer Device Name"), "{e}");
}

#[test]
fn no_device_times_out_cleanly() {
    let r = rig(&[5]);
    let node = r.net.node(n(9));
    let e = node
        .sdo()
        .timeout(Duration::from_millis(100))
        .read((0x1000, 0))
        .wait()
        .unwrap_err();
    match e {
        Error::Sdo(s) => {
            assert_eq!(s.node, n(9));
            assert_eq!(s.kind, SdoErrorKind::Transfer(ErrorKind::Timeout));
        }
        other => panic!("{other}"),
    }
}

#[test]
fn parallel_nodes_and_same_node_order() {
    let r = rig(&[5, 6, 7]);
    let tap_bus = r.bus.clone();
    let mut tap = tap_bus.endpoint();
    // Three requests to node 5 and one each to 6 and 7, all submitted before any runs.
    let a1 = r.net.node(n(5)).sdo().submit_write((0x2002, 2), "first");
    let a2 = r.net.node(n(5)).sdo().submit_read((0x2002, 2));
    let a3 = r.net.node(n(5)).sdo().submit_write((0x2002, 2), "third");
    let b = r.net.node(n(6)).sdo().submit_read((0x1018, 1));
    let c = r.net.node(n(7)).sdo().submit_read((0x1017, 0));
    // Waiting for the last one drives all of them.
    assert!(matches!(a3.wait(), Ok(())));
    assert!(a1.is_done() && a2.is_done());
    a1.wait().unwrap();
    assert_eq!(a2.wait().unwrap(), b"first".to_vec());
    assert_eq!(b.wait().unwrap(), 0x39u32.to_le_bytes().to_vec());
    assert_eq!(c.wait().unwrap(), 500u16.to_le_bytes().to_vec());

    // On the wire, the requests to 6 and 7 went out before node 5's first transfer ended.
    let mut order = Vec::new();
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        if let Some(id) = frame.cob_id()
            && (0x600..0x680).contains(&id)
        {
            order.push(id - 0x600);
        }
    }
    let first6 = order.iter().position(|x| *x == 6).unwrap();
    let last5 = order.iter().rposition(|x| *x == 5).unwrap();
    assert!(first6 < last5, "{order:?}");
}

#[test]
fn threads_share_one_network() {
    let r = rig(&[5, 6]);
    let handles: Vec<_> = [5u8, 6]
        .into_iter()
        .map(|id| {
            let net = r.net.clone();
            std::thread::spawn(move || {
                for i in 0..20u16 {
                    net.node(n(id))
                        .sdo()
                        .write((0x1017, 0), i + u16::from(id))
                        .wait()
                        .unwrap();
                    let v = net.node(n(id)).sdo().read((0x1017, 0)).wait().unwrap();
                    assert_eq!(v, (i + u16::from(id)).to_le_bytes());
                }
            })
        })
        .collect();
    for h in handles {
        h.join().unwrap();
    }
}

#[test]
fn cancel_sends_abort_and_late_response_is_ignored() {
    let r = rig(&[5]);
    let mut tap = r.bus.endpoint();
    // Slow the device down: detach it, so the request gets no answer.
    let dev = r.bus.detach(r.devices[0]).unwrap();
    let pending = r.net.node(n(5)).sdo().submit_read((0x1018, 1));
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    drop(pending); // cancel
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    let mut frames = Vec::new();
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        frames.push(frame);
    }
    let abort = frames
        .iter()
        .find(|f| f.cob_id() == Some(0x605) && f.data()[0] == 0x80)
        .expect("an SDO abort was sent");
    assert_eq!(&abort.data()[1..4], &[0x18, 0x10, 0x01]);
    assert_eq!(&abort.data()[4..8], &0x0800_0000u32.to_le_bytes());

    // A late answer to the cancelled read arrives while the next request (0x1017) runs: it
    // must not complete the new request.
    r.bus.attach(dev);
    let next = r.net.node(n(5)).sdo().submit_read((0x1017, 0));
    let late = CanFrame::new(
        canola_frame::CanId::standard(0x585).unwrap(),
        &[0x43, 0x18, 0x10, 0x01, 0xEF, 0xBE, 0xAD, 0xDE],
    )
    .unwrap();
    tap.send(&late).unwrap();
    assert_eq!(next.wait().unwrap(), 500u16.to_le_bytes().to_vec());
}

fn drain(rx: &Receiver<NetworkEvent>) -> Vec<NetworkEvent> {
    rx.try_iter().collect()
}

#[test]
fn boot_up_nmt_and_heartbeat_loss_and_recovery() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let events = net.subscribe();
    net.monitor_heartbeat(n(5), Duration::from_millis(750));
    let dev = bus.attach(device(5));
    net.run_for(Duration::from_millis(100)).wait().unwrap();
    let ev = drain(&events);
    assert!(
        ev.contains(&NetworkEvent::Heartbeat(HeartbeatEvent::BootUp {
            node: n(5)
        })),
        "{ev:?}"
    );
    net.node(n(5)).nmt().start().unwrap();
    net.run_for(Duration::from_millis(600)).wait().unwrap();
    assert_eq!(
        bus.with_station(dev, |d| d.state()),
        Some(DeviceState::Operational)
    );
    assert_eq!(
        net.last_state(n(5)),
        Some(canola_nmt::NmtState::Operational)
    );
    // The device disappears: loss after 750 ms without heartbeat.
    let d = bus.detach(dev).unwrap();
    net.run_for(Duration::from_secs(2)).wait().unwrap();
    let ev = drain(&events);
    assert!(
        ev.iter().any(|e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::Lost { node, .. }) if *node == n(5))),
        "{ev:?}"
    );
    // It comes back (same state, no reboot): recovery.
    bus.attach(d);
    net.run_for(Duration::from_secs(1)).wait().unwrap();
    let ev = drain(&events);
    assert!(
        ev.iter().any(|e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::Recovered { node, .. }) if *node == n(5))),
        "{ev:?}"
    );
}

#[test]
fn emcy_reaches_subscribers() {
    let r = rig(&[5]);
    let events = r.net.subscribe();
    let now = r.bus.now();
    r.bus
        .with_station(r.devices[0], |d| {
            d.signal_emcy(now, Emcy::new(EmcyCode(0x4210), ErrorRegister(0x09)))
        })
        .unwrap();
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    let ev = drain(&r.events_or(events));
    assert!(
        ev.iter().any(|e| matches!(e, NetworkEvent::Emcy(x) if x.node == n(5) && x.emcy.code == EmcyCode(0x4210))),
        "{ev:?}"
    );
}

impl Rig {
    fn events_or(&self, rx: Receiver<NetworkEvent>) -> Receiver<NetworkEvent> {
        rx
    }
}

#[test]
fn nmt_reset_node_reboots_with_defaults() {
    let r = rig(&[5]);
    let events = r.net.subscribe();
    let node = r.net.node(n(5));
    node.sdo().write((0x1017, 0), 200u16).wait().unwrap();
    node.nmt().reset_node().unwrap();
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    assert!(
        drain(&events).contains(&NetworkEvent::Heartbeat(HeartbeatEvent::BootUp {
            node: n(5)
        }))
    );
    assert_eq!(
        node.sdo().read((0x1017, 0)).wait().unwrap(),
        500u16.to_le_bytes()
    );
}

/// Every SDO method under 5 % drop and 5 % duplication: correct data or a clean error.
#[test]
fn sdo_under_drop_and_duplication() {
    for (drop, duplicate, seed) in [(0.05, 0.0, 1u64), (0.0, 0.05, 2), (0.05, 0.05, 3)] {
        let r = rig_with(
            BusConfig {
                faults: Faults {
                    drop,
                    duplicate,
                    seed,
                    ..Faults::none()
                },
                ..BusConfig::default()
            },
            &[5],
        );
        let data = logbook(2000);
        r.bus
            .with_station(r.devices[0], |d| {
                d.values_mut().set(0x2003, 4, data.clone())
            })
            .unwrap();
        let node = r.net.node(n(5));
        let (mut ok, mut failed) = (0, 0);
        for i in 0..30u16 {
            let t = Duration::from_millis(100);
            let results: Vec<Result<(), Error>> = vec![
                node.sdo()
                    .timeout(t)
                    .write((0x1017, 0), 100 + i)
                    .wait()
                    .map(|_| ()),
                node.sdo()
                    .timeout(t)
                    .read((0x1018, 1))
                    .wait()
                    .map(|v| assert_eq!(v, 0x39u32.to_le_bytes())),
                node.sdo()
                    .timeout(t)
                    .read((0x1008, 0))
                    .wait()
                    .map(|v| assert_eq!(v, b"Buerkert generic device")),
                node.sdo()
                    .timeout(t)
                    .write((0x2002, 2), "segmented location text")
                    .wait()
                    .map(|_| ()),
                node.sdo()
                    .timeout(t)
                    .block(true)
                    .read((0x2003, 4))
                    .wait()
                    .map(|v| assert_eq!(v, data)),
                node.sdo()
                    .timeout(t)
                    .block(true)
                    .write((0x2002, 3), logbook(300))
                    .wait()
                    .map(|_| ()),
            ];
            for res in results {
                match res {
                    Ok(()) => ok += 1,
                    Err(Error::Sdo(e)) => {
                        failed += 1;
                        // A clean error names the node and object and carries an abort code.
                        assert_eq!(e.node, n(5));
                        assert!(e.abort_code().is_some(), "{e}");
                        assert!(e.to_string().contains("node 5"));
                    }
                    Err(other) => panic!("unexpected error {other}"),
                }
            }
        }
        eprintln!("drop {drop} dup {duplicate}: {ok} ok, {failed} failed cleanly");
        assert!(
            ok > 0,
            "drop {drop} dup {duplicate}: {ok} ok, {failed} failed"
        );
        // After faults, a clean read still works and returns the right data.
        r.bus.set_faults(Faults::none());
        assert_eq!(
            node.sdo().read((0x1018, 1)).wait().unwrap(),
            0x39u32.to_le_bytes()
        );
    }
}

#[test]
fn timing_model_bus_works_end_to_end() {
    let r = rig_with(
        BusConfig {
            bitrate: Some(125_000),
            worst_case_stuffing: true,
            ..BusConfig::default()
        },
        &[5],
    );
    let data = logbook(1000);
    r.bus
        .with_station(r.devices[0], |d| {
            d.values_mut().set(0x2003, 4, data.clone())
        })
        .unwrap();
    let t0 = r.net.now();
    assert_eq!(
        r.net
            .node(n(5))
            .sdo()
            .block(true)
            .read((0x2003, 4))
            .wait()
            .unwrap(),
        data
    );
    let took = r.net.now() - t0;
    // 1000 bytes = 143 segments of 135 bits at 125 kbit/s is at least 154 ms of wire time.
    assert!(took >= Duration::from_millis(154), "{took}");
}

#[test]
fn lss_assign_all_then_the_devices_boot_and_answer_sdo() {
    use canola_lss::{AssignConfig, FastscanConfig, LssAddress, NodeIdPool, Procedure};
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let events = net.subscribe();
    let a = LssAddress::new(0x39, 0x0100_0001, 1, 1001);
    let b = LssAddress::new(0x39, 0x0100_0001, 1, 2002);
    let da = bus.attach(SimDevice::unconfigured(od(), a));
    let db = bus.attach(SimDevice::unconfigured(od(), b));
    net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert!(
        drain(&events).is_empty(),
        "unconfigured devices stay silent"
    );

    // Fastscan finds one of them.
    let found = net
        .lss()
        .fastscan(FastscanConfig::default())
        .wait()
        .unwrap();
    assert!(found == Some(a) || found == Some(b), "{found:?}");
    // Leave configuration state again for the workflow.
    net.lss()
        .procedure(Procedure::single(canola_lss::Step::SwitchModeGlobal(
            canola_lss::Mode::Waiting,
        )))
        .wait()
        .unwrap();

    let pool = NodeIdPool::range(n(20), n(30));
    let report = net
        .lss()
        .assign_all(AssignConfig::with_pool(pool))
        .wait()
        .unwrap();
    let assigned: Vec<_> = report.assigned().collect();
    assert_eq!(assigned.len(), 2, "{report:?}");
    net.run_for(Duration::from_millis(10)).wait().unwrap();
    let boots: Vec<_> = drain(&events)
        .into_iter()
        .filter_map(|e| match e {
            NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node }) => Some(node.get()),
            _ => None,
        })
        .collect();
    assert_eq!(boots.len(), 2, "{boots:?}");
    for (addr, id) in assigned {
        let serial = net.node(id).sdo().read((0x1018, 4)).wait().unwrap();
        assert_eq!(serial, addr.serial_number.to_le_bytes());
    }
    assert!(bus.with_station(da, |d| d.is_configured()).unwrap());
    assert!(bus.with_station(db, |d| d.is_configured()).unwrap());
}

#[test]
fn pdos_flow_when_operational_and_decode_through_the_dictionary() {
    let r = rig(&[5]);
    let events = r.net.subscribe();
    r.net.run_for(Duration::from_secs(2)).wait().unwrap();
    assert!(
        !drain(&events).iter().any(|e| e.pdo_data().is_some()),
        "no PDOs in Pre-operational"
    );
    r.net.node(n(5)).nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(2100)).wait().unwrap();
    let pdos: Vec<_> = drain(&events)
        .into_iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues {
                node,
                number,
                values,
                ..
            } => Some((node, number, values)),
            _ => None,
        })
        .collect();
    // TPDO1 (sensor values 1 and 2) and TPDO2 (3 and 4) at start and then every 1000 ms.
    let tpdo1: Vec<_> = pdos.iter().filter(|p| p.1 == 1).collect();
    assert!(tpdo1.len() >= 2, "{pdos:?}");
    let entries: Vec<_> = tpdo1[0].2.iter().map(|(e, _)| *e).collect();
    assert_eq!(
        entries,
        [
            canola::ObjectAddress::new(0x2500, 1),
            canola::ObjectAddress::new(0x2501, 1)
        ]
    );

    // A new sensor reading goes out on change (after the inhibit time at the latest).
    let now = r.bus.now();
    r.bus
        .with_station(r.devices[0], |d| {
            d.set_value(now, 0x2500, 1, 12.5f32.to_le_bytes())
        })
        .unwrap();
    r.net.run_for(Duration::from_millis(600)).wait().unwrap();
    let seen = drain(&events).into_iter().any(|e| {
        matches!(&e, NetworkEvent::PdoValues { number: 1, values, .. }
            if values.first().map(|v| &v.1) == Some(&canola::Value::Real32(12.5)))
    });
    assert!(seen);

    // The master writes control values by RPDO1 (0x205).
    let frame = CanFrame::new(
        canola_frame::CanId::standard(0x205).unwrap(),
        &[1.5f32.to_le_bytes(), 2.5f32.to_le_bytes()].concat(),
    )
    .unwrap();
    r.net.send(frame).unwrap();
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    let got = r
        .bus
        .with_station(r.devices[0], |d| {
            d.values().get(0x2540, 1).map(<[u8]>::to_vec)
        })
        .unwrap();
    assert_eq!(got, Some(1.5f32.to_le_bytes().to_vec()));
}

#[test]
fn sync_producer_runs_on_the_network_clock() {
    let r = rig(&[]);
    let mut tap = r.bus.endpoint();
    r.net.start_sync(Duration::from_millis(10));
    r.net.run_for(Duration::from_millis(95)).wait().unwrap();
    let mut times = Vec::new();
    while let Ok(Some(Received::Frame { frame, at })) = tap.try_recv() {
        if frame.cob_id() == Some(0x80) {
            times.push(at.as_micros() / 1000);
        }
    }
    assert_eq!(times, [0, 10, 20, 30, 40, 50, 60, 70, 80, 90]);
    r.net.stop_sync();
}

#[test]
fn remap_a_tpdo_by_sdo_and_decode_it() {
    use canola_pdo::{CommParams, Direction, Mapping};
    let r = rig(&[5]);
    let events = r.net.subscribe();
    let node = r.net.node(n(5));
    // TPDO3: NE 107 status (0x2004:01, 8 bit) and sensor value 1 (0x2500:01, REAL32),
    // every 100 ms.
    let mapping = Mapping::from_raw(&[0x2004_0108, 0x2500_0120]).unwrap();
    let comm = CommParams::event_driven(0x385).with_event_timer(100);
    node.remap_pdo(Direction::Transmit, 3, comm, mapping)
        .wait()
        .unwrap();
    assert_eq!(node.sdo().read((0x1A02, 0)).wait().unwrap(), [2]);
    assert_eq!(
        node.sdo().read((0x1A02, 2)).wait().unwrap(),
        0x2500_0120u32.to_le_bytes()
    );
    node.nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(350)).wait().unwrap();
    let tpdo3: Vec<_> = drain(&events)
        .into_iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues {
                number: 3, values, ..
            } => Some(values),
            _ => None,
        })
        .collect();
    assert!(tpdo3.len() >= 3, "{tpdo3:?}");
    let entries: Vec<_> = tpdo3[0].iter().map(|(e, _)| *e).collect();
    assert_eq!(
        entries,
        [
            canola::ObjectAddress::new(0x2004, 1),
            canola::ObjectAddress::new(0x2500, 1)
        ]
    );
}

#[test]
fn typed_entries_from_generated_code() {
    use canola_od::{DataType, Entry};
    const PRODUCER_HEARTBEAT_TIME: Entry<u16> = Entry::new(0x1017, 0, DataType::Unsigned16);
    const VENDOR_ID: Entry<u32> = Entry::new(0x1018, 1, DataType::Unsigned32);
    let r = rig(&[5]);
    let node = r.net.node(n(5));
    assert_eq!(node.sdo().read_entry(&VENDOR_ID).wait().unwrap(), 0x39);
    node.sdo()
        .write_entry(&PRODUCER_HEARTBEAT_TIME, &250)
        .wait()
        .unwrap();
    assert_eq!(
        node.sdo()
            .read_entry(&PRODUCER_HEARTBEAT_TIME)
            .wait()
            .unwrap(),
        250
    );
}

#[test]
fn node_guarding_loss_and_recovery() {
    use canola_nmt::GuardingEvent;
    let r = rig(&[5]);
    let events = r.net.subscribe();
    // Heartbeats off, so only guarding tells whether the node is there.
    r.net
        .node(n(5))
        .sdo()
        .write((0x1017, 0), 0u16)
        .wait()
        .unwrap();
    r.net.guard_node(n(5), Duration::from_millis(100), 3);
    r.net.run_for(Duration::from_secs(1)).wait().unwrap();
    let ev = drain(&events);
    assert!(
        !ev.iter()
            .any(|e| matches!(e, NetworkEvent::Guarding(GuardingEvent::Lost { .. }))),
        "{ev:?}"
    );
    let dev = r.bus.detach(r.devices[0]).unwrap();
    r.net.run_for(Duration::from_secs(1)).wait().unwrap();
    assert!(drain(&events).iter().any(
        |e| matches!(e, NetworkEvent::Guarding(GuardingEvent::Lost { node, .. }) if *node == n(5))
    ));
    r.bus.attach(dev);
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    let ev = drain(&events);
    assert!(
        ev.iter()
            .any(|e| matches!(e, NetworkEvent::Guarding(GuardingEvent::Recovered { node, .. }) if *node == n(5))),
        "{ev:?}"
    );
}

#[test]
fn transport_failure_names_the_node_and_object() {
    let r = rig(&[5]);
    let pending = r.net.node(n(5)).sdo().submit_read((0x1008, 0));
    r.bus
        .inject_event(canola::transport::BusEvent::InterfaceDown);
    let e = pending.wait().unwrap_err();
    assert!(matches!(e.kind, SdoErrorKind::Transport(_)), "{e:?}");
    let text = e.to_string();
    assert!(text.contains("node 5"), "{text}");
    assert!(text.contains("0x1008"), "{text}");
    assert!(text.contains("Manufacturer Device Name"), "{text}");
    assert!(
        text.ends_with(": transport failed: the CAN interface is down"),
        "{text}"
    );
}

#[test]
fn transfer_gap_is_settable() {
    // 100 expedited reads of one node on the 1 Mbit/s timing model: the default 1 ms gap between
    // transfers dominates; without it the reads go back to back.
    let bus_time = |gap: Option<Duration>| {
        let r = rig_with(
            BusConfig {
                bitrate: Some(1_000_000),
                ..BusConfig::default()
            },
            &[5],
        );
        // No heartbeats from the device: only SDO frames on the bus.
        r.net
            .node(n(5))
            .sdo()
            .write((0x1017, 0), 0u16)
            .wait()
            .unwrap();
        if let Some(g) = gap {
            r.net.set_transfer_gap(g);
        }
        let start = r.net.now();
        for _ in 0..100 {
            r.net.node(n(5)).sdo().read((0x1000, 0)).wait().unwrap();
        }
        r.net.now() - start
    };
    let with_gap = bus_time(None);
    let without = bus_time(Some(Duration::ZERO));
    assert!(with_gap >= Duration::from_millis(100), "{with_gap}");
    assert!(
        without < Duration::from_millis(50),
        "two frames of 111 bits per read: {without}"
    );
}

/// A BOOLEAN mapped with CiA 301's usual 1 bit and with 8 bits, as many devices map it: remapped
/// by SDO, transmitted by the simulated device, decoded by the master. The device's BOOLEAN
/// object 0x2100 is added to the Bürkert dictionary for the test.
#[test]
fn boolean_tpdo_with_one_bit_and_with_eight_bits() {
    use canola_od::{AccessType, DataType, EdsValue, Object, SubObject, Value as OdValue};
    use canola_pdo::{CommParams, Direction, Mapping};
    let mut dictionary = od();
    dictionary.insert(Object::var(
        0x2100,
        SubObject::new(0, "Valve open", DataType::Boolean, AccessType::Rw)
            .with_pdo_mapping(true)
            .with_default(EdsValue::plain(OdValue::Boolean(false))),
    ));
    for bits in [1u32, 8] {
        let bus = MemoryBus::new();
        let net = Network::new(bus.endpoint());
        let device = bus.attach(SimDevice::new(n(5), dictionary.clone()));
        let node = net.add_node_with_dictionary(n(5), dictionary.clone());
        let events = net.subscribe();
        // TPDO3: the BOOLEAN, then the NE 107 status byte behind it.
        let mapping = Mapping::from_raw(&[0x2100_0000 | bits, 0x2004_0108]).unwrap();
        node.remap_pdo(
            Direction::Transmit,
            3,
            CommParams::event_driven(0x385),
            mapping,
        )
        .wait()
        .unwrap();
        assert_eq!(
            node.sdo().read((0x1A02, 1)).wait().unwrap(),
            (0x2100_0000 | bits).to_le_bytes()
        );
        node.nmt().start().unwrap();
        net.run_for(Duration::from_millis(20)).wait().unwrap();
        let now = bus.now();
        bus.with_station(device, |d| d.set_value(now, 0x2100, 0, [1u8]))
            .unwrap();
        net.run_for(Duration::from_millis(20)).wait().unwrap();
        let decoded: Vec<_> = drain(&events)
            .into_iter()
            .filter_map(|e| match e {
                NetworkEvent::PdoValues {
                    number: 3, values, ..
                } => Some(values),
                _ => None,
            })
            .collect();
        let last = decoded.last().expect("TPDO3 arrived");
        assert_eq!(
            last[0].1,
            OdValue::Boolean(true),
            "{bits}-bit BOOLEAN: {decoded:?}"
        );
        assert_eq!(decoded.first().unwrap()[0].1, OdValue::Boolean(false));
    }
}

/// A second SDO server channel (0x1201, CiA 301 §7.2.4.2) on its own COB-IDs: the master reaches
/// it through `Sdo::channel`, in parallel with the default channel; a channel configured at run
/// time (0x1202 written by SDO) is served from then on.
#[test]
fn sdo_on_a_second_server_channel() {
    use canola::SdoCobIds;
    use canola_od::{AccessType, DataType, EdsValue, Object, ObjectCode, SubObject, Value};
    let record = |index: u16, request: u32, response: u32| {
        Object::complex(
            index,
            "SDO server parameter",
            ObjectCode::Record,
            [
                (0, DataType::Unsigned8, Value::Unsigned8(2)),
                (1, DataType::Unsigned32, Value::Unsigned32(request)),
                (2, DataType::Unsigned32, Value::Unsigned32(response)),
            ]
            .into_iter()
            .map(|(sub, t, v)| {
                SubObject::new(sub, "COB-ID", t, AccessType::Rw).with_default(EdsValue::plain(v))
            }),
        )
    };
    let mut dictionary = od();
    dictionary.insert(record(0x1201, 0x6A5, 0x6B5));
    dictionary.insert(record(0x1202, 0x8000_06A6, 0x8000_06B6));
    let bus = MemoryBus::new();
    let mut tap = bus.endpoint();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::new(n(5), dictionary.clone()));
    let node = net.add_node_with_dictionary(n(5), dictionary);
    let second = SdoCobIds::from_parameters(0x6A5, 0x6B5).unwrap();

    let a = node.sdo().channel(second).submit_read((0x1018, 1));
    let b = node.sdo().submit_read((0x1017, 0));
    assert_eq!(a.wait().unwrap(), 0x39u32.to_le_bytes());
    assert_eq!(b.wait().unwrap(), 500u16.to_le_bytes());
    node.sdo()
        .channel(second)
        .write((0x1017, 0), 250u16)
        .wait()
        .unwrap();
    assert_eq!(
        node.sdo().read((0x1017, 0)).wait().unwrap(),
        250u16.to_le_bytes()
    );
    let mut ids = Vec::new();
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        ids.push(frame.cob_id().unwrap());
    }
    for id in [0x6A5, 0x6B5, 0x605, 0x585] {
        assert!(ids.contains(&id), "{id:#x} missing in {ids:x?}");
    }

    // 0x1202 is not valid (bit 31): nothing answers on it until the master configures it.
    let third = SdoCobIds::from_parameters(0x6A6, 0x6B6).unwrap();
    let err = node
        .sdo()
        .channel(third)
        .timeout(Duration::from_millis(50))
        .read((0x1018, 1))
        .wait()
        .unwrap_err();
    assert!(
        matches!(
            err,
            Error::Sdo(canola::SdoError {
                kind: SdoErrorKind::Transfer(canola_sdo::ErrorKind::Timeout),
                ..
            })
        ),
        "{err}"
    );
    node.sdo().write((0x1202, 1), 0x6A6u32).wait().unwrap();
    node.sdo().write((0x1202, 2), 0x6B6u32).wait().unwrap();
    assert_eq!(
        node.sdo().channel(third).read((0x1018, 1)).wait().unwrap(),
        0x39u32.to_le_bytes()
    );
}
