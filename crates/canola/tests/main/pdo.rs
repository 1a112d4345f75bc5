//! PDOs from the master against the simulated Bürkert device on the in-memory bus: TPDO and
//! RPDO parameters read and saved by SDO, TPDOs received from the COB-IDs the node is configured
//! with, RPDOs transmitted by the master's engine (on change with inhibit time, event timer,
//! SYNC), checked by reading the device's objects back by SDO and by counting frames on the bus
//! in virtual time.

use std::sync::mpsc::Receiver;

use canola::Value;
use canola::mem::{BusConfig, ClockMode, Endpoint, MemoryBus, StationId};
use canola::pdo::{Direction, PdoCobId, TransmissionType};
use canola::transport::{Received, Transport};
use canola::{Network, NetworkEvent, ObjectAddress, SimDevice, Transmission};
use canola_frame::{CanFrame, CanId, Duration, Instant, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn od() -> canola_od::ObjectDictionary {
    canola_od::parse(EDS).unwrap().od
}

fn a(index: u16, sub: u8) -> ObjectAddress {
    ObjectAddress::new(index, sub)
}

struct Rig {
    bus: MemoryBus,
    net: Network,
    device: StationId<SimDevice>,
    /// Sees every frame on the bus, with its time.
    tap: Endpoint,
}

/// Node 5 on the bus; the master knows its EDS when `with_dictionary`.
fn rig(with_dictionary: bool) -> Rig {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let tap = bus.endpoint();
    let device = bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    if with_dictionary {
        net.add_node_with_dictionary(n(5), od());
    } else {
        net.add_node(n(5));
    }
    // No heartbeats: the bus carries only what the tests look at.
    net.node(n(5))
        .sdo()
        .write((0x1017, 0), 0u16)
        .wait()
        .unwrap();
    Rig {
        bus,
        net,
        device,
        tap,
    }
}

/// The frames the tap saw since the last call.
fn frames(tap: &mut Endpoint) -> Vec<(Instant, CanFrame)> {
    let mut out = Vec::new();
    while let Ok(Some(Received::Frame { frame, at })) = tap.try_recv() {
        out.push((at, frame));
    }
    out
}

fn on(frames: &[(Instant, CanFrame)], id: u16) -> Vec<(Instant, Vec<u8>)> {
    frames
        .iter()
        .filter(|(_, f)| f.cob_id() == Some(id) && !f.is_remote())
        .map(|(t, f)| (*t, f.data().to_vec()))
        .collect()
}

fn drain(rx: &Receiver<NetworkEvent>) -> Vec<NetworkEvent> {
    rx.try_iter().collect()
}

fn decoded(events: &[NetworkEvent], tpdo: u8) -> Vec<Vec<(ObjectAddress, Value)>> {
    events
        .iter()
        .filter_map(|e| match e {
            NetworkEvent::PdoValues { number, values, .. } if *number == tpdo => {
                Some(values.clone())
            }
            _ => None,
        })
        .collect()
}

fn device_value(r: &Rig, index: u16, sub: u8) -> Vec<u8> {
    r.net.node(n(5)).sdo().read((index, sub)).wait().unwrap()
}

#[test]
fn read_tpdos_and_rpdos_with_the_dictionary() {
    let r = rig(true);
    let node = r.net.node(n(5));
    // Changed on the device behind the dictionary's back: read() asks the node, not the EDS.
    node.sdo().write((0x1801, 5), 250u16).wait().unwrap();

    let tpdos = node.tpdo().read().wait().unwrap();
    assert_eq!(tpdos.direction(), Direction::Transmit);
    assert_eq!(tpdos.len(), 4);
    let t1 = tpdos.get(1).unwrap();
    assert_eq!(t1.comm.cob_id, PdoCobId(0x185));
    assert!(t1.is_enabled() && t1.rtr_allowed());
    assert_eq!(t1.can_id().unwrap(), CanId::standard(0x185).unwrap());
    assert_eq!(t1.transmission_type(), TransmissionType::EventManufacturer);
    assert_eq!(t1.inhibit_time(), Duration::from_millis(500));
    assert_eq!(t1.event_timer(), Duration::from_millis(1000));
    assert!(t1.has_inhibit_time() && t1.has_event_timer() && !t1.has_sync_start());
    let mapped: Vec<_> = t1
        .mapped
        .iter()
        .map(|m| (m.addr, m.bits, m.name.as_deref()))
        .collect();
    assert_eq!(
        mapped,
        [
            (a(0x2500, 1), 32, Some("Sensor Value 1.Value")),
            (a(0x2501, 1), 32, Some("Sensor Value 2.Value")),
        ]
    );
    assert_eq!(
        tpdos.get(2).unwrap().event_timer(),
        Duration::from_millis(250)
    );
    assert!(tpdos.get(5).is_none());

    let rpdos = node.rpdo().read().wait().unwrap();
    assert_eq!(rpdos.len(), 4);
    let r1 = rpdos.get(1).unwrap();
    assert_eq!(r1.comm.cob_id, PdoCobId(0x205));
    assert_eq!(r1.transmission_type(), TransmissionType::EventManufacturer);
    // The Bürkert RPDO communication objects have sub 1 and 2 only.
    assert!(!r1.has_inhibit_time() && !r1.has_event_timer() && !r1.has_sync_start());
    assert_eq!(
        r1.mapped.iter().map(|m| m.entry()).collect::<Vec<_>>(),
        [0x2540_0120, 0x2541_0120]
    );
    assert!(!r1.is_changed());
}

#[test]
fn read_without_a_dictionary_probes_the_node() {
    let r = rig(false);
    let node = r.net.node(n(5));
    let tpdos = node.tpdo().read().wait().unwrap();
    assert_eq!(tpdos.len(), 4);
    let t1 = tpdos.get(1).unwrap();
    // Sub 3 and 5 answered, sub 6 aborted with "sub-index does not exist".
    assert!(t1.has_inhibit_time() && t1.has_event_timer() && !t1.has_sync_start());
    assert_eq!(t1.mapped[0].addr, a(0x2500, 1));
    assert_eq!(t1.mapped[0].name, None);
    let rpdos = node.rpdo().read().wait().unwrap();
    assert!(!rpdos.get(1).unwrap().has_event_timer());
    // Mapping by name needs the dictionary; by address and length it does not.
    let mut rpdos = rpdos;
    let p = rpdos.get_mut(1).unwrap();
    assert!(p.map("Control Value 1.Value").is_err());
    p.clear();
    p.map_entry(a(0x2540, 1), 32);
    node.rpdo().save(&mut rpdos).wait().unwrap();
    assert_eq!(device_value(&r, 0x1600, 0), [1]);
}

/// The SDO download requests (index, sub, value) the node received.
fn sdo_writes(frames: &[(Instant, CanFrame)]) -> Vec<(u16, u8, u32)> {
    on(frames, 0x605)
        .into_iter()
        .filter(|(_, d)| d.len() == 8 && d[0] & 0xE0 == 0x20)
        .map(|(_, d)| {
            let len = if d[0] & 0x01 != 0 {
                4 - ((d[0] >> 2) & 3) as usize
            } else {
                4
            };
            let mut v = [0u8; 4];
            v[..len].copy_from_slice(&d[4..4 + len]);
            (
                u16::from_le_bytes([d[1], d[2]]),
                d[3],
                u32::from_le_bytes(v),
            )
        })
        .collect()
}

#[test]
fn save_uses_the_cia301_sequence_and_the_master_follows_the_new_cob_id() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    let events = r.net.subscribe();
    let mut tpdos = node.tpdo().read().wait().unwrap();
    let t1 = tpdos.get_mut(1).unwrap();
    t1.set_can_id(CanId::standard(0x1F0).unwrap());
    t1.set_inhibit_time(Duration::from_millis(0)).unwrap();
    t1.set_event_timer(std::time::Duration::from_millis(100))
        .unwrap();
    t1.clear();
    t1.map("Device Status Object.Device Status NamurNe107")
        .unwrap();
    t1.map("Sensor Value 1.Value").unwrap();
    assert!(t1.is_changed());
    frames(&mut r.tap);
    node.tpdo().save(&mut tpdos).wait().unwrap();
    let writes = sdo_writes(&frames(&mut r.tap));
    assert_eq!(
        writes,
        [
            (0x1800, 1, 0x8000_01F0),
            (0x1A00, 0, 0),
            (0x1A00, 1, 0x2004_0108),
            (0x1A00, 2, 0x2500_0120),
            (0x1A00, 0, 2),
            (0x1800, 2, 254),
            (0x1800, 3, 0),
            (0x1800, 5, 100),
            (0x1800, 1, 0x01F0),
        ],
        "only TPDO1 changed, so only TPDO1 is written"
    );
    assert!(!tpdos.get(1).unwrap().is_changed());
    // A second save has nothing to write.
    node.tpdo().save(&mut tpdos).wait().unwrap();
    assert!(sdo_writes(&frames(&mut r.tap)).is_empty());
    // Read back: the node holds what was saved.
    assert_eq!(node.tpdo().read().wait().unwrap(), tpdos);

    node.nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(350)).wait().unwrap();
    let now = r.bus.now();
    r.bus
        .with_station(r.device, |d| {
            d.set_value(now, 0x2500, 1, 21.5f32.to_le_bytes())
        })
        .unwrap();
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    let seen = frames(&mut r.tap);
    assert!(on(&seen, 0x185).is_empty(), "nothing on the old COB-ID");
    assert!(on(&seen, 0x1F0).len() >= 4, "{seen:?}");
    let got = decoded(&drain(&events), 1);
    assert!(got.len() >= 4, "{got:?}");
    let last = got.last().unwrap();
    assert_eq!(last[0].0, a(0x2004, 1));
    assert_eq!(last[1], (a(0x2500, 1), Value::Real32(21.5)));
}

#[test]
fn read_makes_the_master_decode_a_tpdo_configured_elsewhere() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    let events = r.net.subscribe();
    // Configured by another tool (raw SDO writes): TPDO2 on 0x2F1, every 20 ms.
    node.sdo()
        .write((0x1801, 1), 0x8000_02F1u32)
        .wait()
        .unwrap();
    node.sdo().write((0x1801, 3), 0u16).wait().unwrap();
    node.sdo().write((0x1801, 5), 20u16).wait().unwrap();
    node.sdo()
        .write((0x1801, 1), 0x0000_02F1u32)
        .wait()
        .unwrap();
    node.nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert!(!on(&frames(&mut r.tap), 0x2F1).is_empty());
    assert!(decoded(&drain(&events), 2).is_empty(), "unknown COB-ID");

    let tpdos = node.tpdo().read().wait().unwrap();
    assert_eq!(tpdos.get(2).unwrap().comm.cob_id, PdoCobId(0x2F1));
    r.net.run_for(Duration::from_millis(100)).wait().unwrap();
    let events = drain(&events);
    let got = decoded(&events, 2);
    assert!(got.len() >= 4, "{events:?}");
    // One event per frame: decoded, with the frame's data.
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, NetworkEvent::Pdo { node, number: 2, .. } if *node == n(5))),
        "{events:?}"
    );
    assert!(events.iter().any(|e| matches!(e.pdo_data(),
        Some((node, 2, data)) if node == n(5) && !data.is_empty())));
}

#[test]
fn a_tpdo_on_a_29_bit_identifier() {
    let r = rig(true);
    let node = r.net.node(n(5));
    let events = r.net.subscribe();
    let mut tpdos = node.tpdo().read().wait().unwrap();
    let t3 = tpdos.get_mut(3).unwrap();
    t3.set_can_id(CanId::extended(0x0123_4567).unwrap());
    t3.set_inhibit_time(Duration::ZERO).unwrap();
    t3.set_event_timer(Duration::from_millis(10)).unwrap();
    t3.set_enabled(true);
    node.tpdo().save(&mut tpdos).wait().unwrap();
    assert_eq!(
        device_value(&r, 0x1802, 1),
        (0x2000_0000u32 | 0x0123_4567).to_le_bytes()
    );
    node.nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert!(decoded(&drain(&events), 3).len() >= 5);
}

#[test]
fn save_checks_the_mapping_before_sending_anything() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    let mut tpdos = node.tpdo().read().wait().unwrap();
    let t1 = tpdos.get_mut(1).unwrap();
    t1.clear();
    t1.map("Producer heartbeat time").unwrap(); // not PDO-mappable
    frames(&mut r.tap);
    let e = node.tpdo().save(&mut tpdos).wait().unwrap_err();
    assert!(e.to_string().contains("not PDO-mappable"), "{e}");
    assert!(sdo_writes(&frames(&mut r.tap)).is_empty());
    assert_eq!(device_value(&r, 0x1800, 1), 0x185u32.to_le_bytes());

    let mut rpdos = node.rpdo().read().wait().unwrap();
    let p = rpdos.get_mut(1).unwrap();
    assert!(
        p.set_inhibit_time(Duration::from_millis(1)).is_err(),
        "no sub 3"
    );
    let mut tpdos = node.tpdo().read().wait().unwrap();
    let t1 = tpdos.get_mut(1).unwrap();
    assert!(t1.set_inhibit_time(Duration::from_micros(150)).is_err());
    assert!(t1.set_event_timer(Duration::from_secs(70)).is_err());
    assert!(
        node.tpdo().save(&mut rpdos).wait().is_err(),
        "RPDOs saved as TPDOs"
    );
}

/// The master transmits RPDO1 (two REAL32 control values); the device takes them.
#[test]
fn rpdo_on_change_reaches_the_device() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_change())
        .unwrap();
    frames(&mut r.tap);
    tx.set("Control Value 1.Value", 12.5f32).unwrap();
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    tx.set_many([((0x2540, 1), 1.25f32), ((0x2541, 1), -3.0f32)])
        .unwrap();
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    // Unchanged: no frame.
    tx.set((0x2541, 1), -3.0f32).unwrap();
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    let sent = on(&frames(&mut r.tap), 0x205);
    let mut first = 12.5f32.to_le_bytes().to_vec();
    first.extend(0f32.to_le_bytes());
    let mut second = 1.25f32.to_le_bytes().to_vec();
    second.extend((-3.0f32).to_le_bytes());
    assert_eq!(
        sent.iter().map(|(_, d)| d.clone()).collect::<Vec<_>>(),
        [first, second]
    );
    assert_eq!(device_value(&r, 0x2540, 1), 1.25f32.to_le_bytes());
    assert_eq!(device_value(&r, 0x2541, 1), (-3.0f32).to_le_bytes());

    // Values are checked locally.
    assert!(tx.set("Control Value 1.Value", "text").is_err());
    assert!(tx.set((0x2500, 1), 1.0f32).is_err(), "not mapped in RPDO1");
    tx.stop().unwrap();
    assert!(tx.set((0x2540, 1), 2.0f32).is_err(), "stopped");
    assert!(tx.trigger().is_err());
    assert!(tx.stop().is_err());
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    assert!(on(&frames(&mut r.tap), 0x205).is_empty());
    assert!(
        node.rpdo()
            .start(
                node.tpdo().read().wait().unwrap().get(1).unwrap(),
                Transmission::on_change()
            )
            .is_err(),
        "a TPDO is not the master's to send"
    );
}

#[test]
fn rpdo_inhibit_time_is_enforced() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(
            rpdos.get(1).unwrap(),
            Transmission::on_change().with_inhibit_time(Duration::from_millis(10)),
        )
        .unwrap();
    frames(&mut r.tap);
    let start = r.net.now();
    // A new value every millisecond for 100 ms.
    for i in 0..100 {
        tx.set((0x2540, 1), i as f32).unwrap();
        r.net.run_for(Duration::from_millis(1)).wait().unwrap();
    }
    r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    let sent = on(&frames(&mut r.tap), 0x205);
    let times: Vec<u64> = sent.iter().map(|(t, _)| (*t - start).as_micros()).collect();
    assert!(
        (10..=11).contains(&sent.len()),
        "one frame per 10 ms: {times:?}"
    );
    for w in times.windows(2) {
        assert!(w[1] - w[0] >= 10_000, "inhibit time broken: {times:?}");
    }
    // The postponed frame carries the value of its moment: the last one arrives.
    assert_eq!(device_value(&r, 0x2540, 1), 99f32.to_le_bytes());
}

#[test]
fn rpdo_event_timer_cadence() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(
            rpdos.get(2).unwrap(),
            Transmission::cyclic(Duration::from_millis(50)),
        )
        .unwrap();
    tx.set("Control Value 3.Value", 7.0f32).unwrap();
    frames(&mut r.tap);
    let start = r.net.now();
    r.net.run_for(Duration::from_millis(505)).wait().unwrap();
    let sent = on(&frames(&mut r.tap), 0x305);
    let times: Vec<u64> = sent
        .iter()
        .map(|(t, _)| (*t - start).as_micros() / 1000)
        .collect();
    assert_eq!(times.len(), 10, "{times:?}");
    for w in times.windows(2) {
        assert_eq!(w[1] - w[0], 50, "{times:?}");
    }
}

#[test]
fn rpdo_on_the_masters_sync() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let mut rpdos = node.rpdo().read().wait().unwrap();
    // The node takes RPDO1 at the SYNC after it arrives (type 1).
    rpdos
        .get_mut(1)
        .unwrap()
        .set_transmission_type(TransmissionType::SyncCyclic(1));
    node.rpdo().save(&mut rpdos).wait().unwrap();
    let tx = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::every_nth_sync(2))
        .unwrap();
    tx.set((0x2540, 1), 4.5f32).unwrap();
    frames(&mut r.tap);
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    assert!(
        on(&frames(&mut r.tap), 0x205).is_empty(),
        "no SYNC, no frame"
    );
    assert_eq!(device_value(&r, 0x2540, 1), 0f32.to_le_bytes());

    r.net.start_sync(Duration::from_millis(10));
    r.net.run_for(Duration::from_millis(95)).wait().unwrap();
    r.net.stop_sync();
    let seen = frames(&mut r.tap);
    let syncs = on(&seen, 0x080);
    let sent = on(&seen, 0x205);
    assert_eq!(syncs.len(), 10);
    assert_eq!(sent.len(), 5, "every second SYNC: {sent:?}");
    // Each frame follows a SYNC at once (same instant, next frame on the bus).
    for (t, _) in &sent {
        let i = seen
            .iter()
            .position(|(at, f)| at == t && f.cob_id() == Some(0x205));
        let prev = &seen[i.unwrap() - 1].1;
        assert_eq!(prev.cob_id(), Some(0x080));
    }
    // Taken by the device at a SYNC after reception.
    assert_eq!(device_value(&r, 0x2540, 1), 4.5f32.to_le_bytes());
}

#[test]
fn rpdo_sync_after_change_sends_once() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_sync_after_change())
        .unwrap();
    r.net.start_sync(Duration::from_millis(10));
    tx.set((0x2540, 1), 1.0f32).unwrap();
    r.net.run_for(Duration::from_millis(45)).wait().unwrap();
    tx.trigger().unwrap();
    r.net.run_for(Duration::from_millis(40)).wait().unwrap();
    let sent = on(&frames(&mut r.tap), 0x205);
    assert_eq!(
        sent.len(),
        2,
        "once after the change, once after the trigger"
    );
}

#[test]
fn a_transmitted_rpdo_follows_a_saved_cob_id() {
    let mut r = rig(true);
    let node = r.net.node(n(5));
    node.nmt().start().unwrap();
    let mut rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_change())
        .unwrap();
    let r1 = rpdos.get_mut(1).unwrap();
    r1.set_can_id(CanId::standard(0x222).unwrap());
    r1.clear();
    r1.map("Control Value 2.Value").unwrap();
    node.rpdo().save(&mut rpdos).wait().unwrap();
    frames(&mut r.tap);
    assert!(
        tx.set("Control Value 1.Value", 8.0f32).is_err(),
        "no longer mapped"
    );
    tx.set("Control Value 2.Value", 8.0f32).unwrap();
    r.net.run_for(Duration::from_millis(5)).wait().unwrap();
    let seen = frames(&mut r.tap);
    assert!(on(&seen, 0x205).is_empty());
    let sent: Vec<_> = on(&seen, 0x222).into_iter().map(|(_, d)| d).collect();
    assert_eq!(
        sent,
        [8.0f32.to_le_bytes().to_vec()],
        "4 bytes: the new mapping"
    );
    assert_eq!(device_value(&r, 0x2541, 1), 8.0f32.to_le_bytes());
}

/// With the background driver on a real-time bus, cyclic RPDOs flow while the application
/// sleeps.
#[test]
fn rpdo_cyclic_with_the_background_driver() {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let mut tap = bus.endpoint();
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    let node = net.add_node_with_dictionary(n(5), od());
    net.start_driver().unwrap();
    node.nmt().start().unwrap();
    let rpdos = node.rpdo().read().wait().unwrap();
    let tx = node
        .rpdo()
        .start(
            rpdos.get(1).unwrap(),
            Transmission::cyclic(Duration::from_millis(10)),
        )
        .unwrap();
    tx.set((0x2540, 1), 3.0f32).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(200));
    assert_eq!(
        node.sdo().read((0x2540, 1)).wait().unwrap(),
        3.0f32.to_le_bytes()
    );
    net.stop_driver().unwrap();
    // The tap received while the bus ran; count what it holds.
    let mut count = 0;
    while let Ok(Some(r)) = tap.recv_until(tap.now()) {
        if let Received::Frame { frame, .. } = r
            && frame.cob_id() == Some(0x205)
        {
            count += 1;
        }
    }
    assert!(
        count >= 5,
        "cyclic frames while the application slept: {count}"
    );
}

/// `Network::on_pdo`: a callback sees every TPDO with the same typed values the events carry,
/// raw data alone for a node without a dictionary, and nothing once removed.
#[test]
fn pdo_callbacks_see_what_the_events_carry() {
    use std::sync::{Arc, Mutex};
    for with_dictionary in [true, false] {
        let r = rig(with_dictionary);
        let events = r.net.subscribe();
        type Seen = Vec<(NodeId, u8, Vec<u8>, Vec<(ObjectAddress, Value)>)>;
        let seen: Arc<Mutex<Seen>> = Arc::default();
        let sink = seen.clone();
        let id = r.net.on_pdo(move |p| {
            sink.lock()
                .unwrap()
                .push((p.node, p.number, p.data.to_vec(), p.values.to_vec()));
        });
        r.net.node(n(5)).nmt().start().unwrap();
        r.net.run_for(Duration::from_millis(20)).wait().unwrap();
        let now = r.bus.now();
        r.bus
            .with_station(r.device, |d| {
                d.set_value(now, 0x2500, 1, 21.5f32.to_le_bytes())
            })
            .unwrap();
        r.net.run_for(Duration::from_millis(1200)).wait().unwrap();
        let from_events: Seen = drain(&events)
            .iter()
            .filter_map(|e| {
                let (node, number, data) = e.pdo_data()?;
                let values = match e {
                    NetworkEvent::PdoValues { values, .. } => values.clone(),
                    _ => Vec::new(),
                };
                Some((node, number, data.to_vec(), values))
            })
            .collect();
        let got = std::mem::take(&mut *seen.lock().unwrap());
        assert!(!got.is_empty());
        assert_eq!(got, from_events);
        let tpdo1 = got.iter().rfind(|p| p.1 == 1).expect("TPDO1");
        assert_eq!(&tpdo1.2[..4], 21.5f32.to_le_bytes());
        if with_dictionary {
            assert_eq!(tpdo1.3[0], (a(0x2500, 1), Value::Real32(21.5)));
        } else {
            assert!(got.iter().all(|p| p.3.is_empty()), "nothing to decode with");
        }
        assert!(r.net.remove_pdo_callback(id));
        assert!(!r.net.remove_pdo_callback(id));
        r.net.run_for(Duration::from_millis(1200)).wait().unwrap();
        assert!(seen.lock().unwrap().is_empty());
        assert!(drain(&events).iter().any(|e| e.pdo_data().is_some()));
    }
}

/// `Network::subscribe_pdos`: the batches hold every PDO the callback sees, in order, with the
/// same data and typed values (two subscribers each get all of them); blocking receives work
/// with the background driver; a network that is gone ends the subscription.
#[test]
fn pdo_batches_carry_what_the_callback_sees() {
    use std::sync::mpsc::{RecvTimeoutError, TryRecvError};
    use std::sync::{Arc, Mutex};
    type Seen1 = (NodeId, u8, Vec<u8>, Vec<(ObjectAddress, Value)>, Instant);
    type Seen = Vec<Seen1>;
    fn own(p: &canola::PdoReceived<'_>) -> Seen1 {
        (p.node, p.number, p.data.to_vec(), p.values.to_vec(), p.at)
    }
    for with_dictionary in [true, false] {
        let r = rig(with_dictionary);
        let seen: Arc<Mutex<Seen>> = Arc::default();
        let sink = seen.clone();
        r.net.on_pdo(move |p| sink.lock().unwrap().push(own(p)));
        let mut first = r.net.subscribe_pdos();
        let mut second = r.net.subscribe_pdos();
        assert_eq!(first.try_recv().unwrap_err(), TryRecvError::Empty);
        r.net.node(n(5)).nmt().start().unwrap();
        let mut got: Seen = Vec::new();
        for value in [21.5f32, -3.25, 1e6] {
            let now = r.bus.now();
            r.bus
                .with_station(r.device, |d| {
                    d.set_value(now, 0x2500, 1, value.to_le_bytes())
                })
                .unwrap();
            r.net.run_for(Duration::from_millis(700)).wait().unwrap();
            // Several steps' PDOs in one batch, read as the callback's views.
            let batch = first.try_recv().unwrap();
            assert_eq!(batch.iter().len(), batch.len());
            got.extend(batch.iter().map(|p| own(&p)));
        }
        let from_callback = std::mem::take(&mut *seen.lock().unwrap());
        assert!(from_callback.len() >= 3, "{from_callback:?}");
        assert_eq!(got, from_callback);
        let second_got: Seen = second
            .try_recv()
            .unwrap()
            .into_iter()
            .map(|p| own(&p))
            .collect();
        assert_eq!(second_got, got);
        let last = got.iter().rfind(|p| p.1 == 1).expect("TPDO1");
        assert_eq!(&last.2[..4], 1e6f32.to_le_bytes());
        if with_dictionary {
            assert_eq!(last.3[0], (a(0x2500, 1), Value::Real32(1e6)));
        } else {
            assert!(got.iter().all(|p| p.3.is_empty()), "nothing to decode with");
        }
        assert_eq!(first.try_recv().unwrap_err(), TryRecvError::Empty);

        // With the background driver, a blocking receive wakes for the next batch.
        drop(second);
        r.net.start_driver().unwrap();
        let now = r.bus.now();
        r.bus
            .with_station(r.device, |d| {
                d.set_value(now, 0x2500, 1, 7.5f32.to_le_bytes())
            })
            .unwrap();
        let new_value =
            |p: canola::PdoReceived<'_>| p.number == 1 && p.data[..4] == 7.5f32.to_le_bytes();
        let mut batches = 0;
        while !first
            .recv_timeout(std::time::Duration::from_secs(10))
            .expect("TPDOs with the driver running")
            .iter()
            .any(new_value)
        {
            batches += 1;
            assert!(batches < 1000, "the new value never came");
        }
        r.net.stop_driver().unwrap();
        drop(r);
        // The network is gone: what was left is still delivered, then the end.
        while first.try_recv().is_ok() {}
        assert_eq!(first.try_recv().unwrap_err(), TryRecvError::Disconnected);
        assert_eq!(
            first
                .recv_timeout(std::time::Duration::from_secs(10))
                .unwrap_err(),
            RecvTimeoutError::Disconnected
        );
    }
}

/// Frames already waiting in the transport, as a socket with a full receive queue holds them.
struct Backlog(std::collections::VecDeque<CanFrame>);

impl Transport for Backlog {
    fn send(&mut self, _: &CanFrame) -> Result<(), canola::TransportError> {
        Ok(())
    }
    fn recv_until(&mut self, _: Instant) -> Result<Option<Received>, canola::TransportError> {
        Ok(self.0.pop_front().map(|frame| Received::Frame {
            frame,
            at: Instant::ZERO,
        }))
    }
    fn now(&self) -> Instant {
        Instant::ZERO
    }
    fn has_pending(&self) -> bool {
        !self.0.is_empty()
    }
}

/// A subscriber blocked on another thread is woken at the end of a step that leaves frames in
/// the transport when no background driver follows it up: the stepping thread may not step
/// again soon (only a driver's wake-up waits for the burst's end).
#[test]
fn a_step_that_leaves_a_backlog_wakes_a_blocked_batch_subscriber() {
    let frames = (0..100u8)
        .map(|k| CanFrame::new(CanId::standard(0x185).unwrap(), &[k]).unwrap())
        .collect();
    let net = Network::new(Backlog(frames));
    net.add_node(n(5));
    let mut pdos = net.subscribe_pdos();
    let (done, result) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        // Blocks for up to an hour: a missed wake-up shows as no result below.
        let batch = pdos
            .recv()
            .wait()
            .map(|b| b.iter().map(|p| p.data[0]).collect::<Vec<_>>());
        done.send(batch)
    });
    // Let the reader block first (were it late, it would find the batch without a wake-up).
    std::thread::sleep(std::time::Duration::from_millis(100));
    net.run_until(net.now()).wait().unwrap();
    let got = result
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("the blocked subscriber was woken")
        .unwrap();
    assert!(
        !got.is_empty() && got.len() < 100,
        "one step's PDOs: {got:?}"
    );
    assert_eq!(got, (0..got.len() as u8).collect::<Vec<_>>());
}
