//! Transcript tests of the PDO engine on a virtual clock: every transmission type, inhibit time
//! and event timer, SYNC start value, RTR, receive deadlines, length errors, and a master engine
//! talking to a simulated device engine.

#![cfg(feature = "alloc")]

use canola_frame::{CanFrame, CanId, Duration, Instant};
use canola_pdo::{
    CommParams, Engine, Event, MapStore, Mapping, ObjectAddress, PdoCobId, PdoConfig, RawValue,
    TransmissionType,
};
use proptest::prelude::*;

fn ms(t: u64) -> Instant {
    Instant::from_millis(t)
}

fn sid(raw: u16) -> CanId {
    CanId::standard(raw).unwrap()
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(sid(id), data).unwrap()
}

fn a(index: u16, sub: u8) -> ObjectAddress {
    ObjectAddress::new(index, sub)
}

fn four_u16() -> Mapping {
    Mapping::from_raw(&[0x6401_0110, 0x6401_0210, 0x6401_0310, 0x6401_0410]).unwrap()
}

fn drain_frames<const R: usize, const T: usize, const Q: usize>(
    e: &mut Engine<R, T, Q>,
) -> Vec<CanFrame> {
    std::iter::from_fn(|| e.poll_transmit()).collect()
}

fn drain_events<const R: usize, const T: usize>(e: &mut Engine<R, T>) -> Vec<Event> {
    std::iter::from_fn(|| e.poll_event()).collect()
}

/// A device-side store with 0x6000:1 (U8) and 0x6401:1..4 (U16).
fn device_store() -> MapStore {
    MapStore::new()
        .with(a(0x6000, 1), &[0])
        .with(a(0x6401, 1), &[0, 0])
        .with(a(0x6401, 2), &[0, 0])
        .with(a(0x6401, 3), &[0, 0])
        .with(a(0x6401, 4), &[0, 0])
}

fn tx_u8(t: TransmissionType) -> PdoConfig {
    PdoConfig::new(
        CommParams::event_driven(0x185).with_transmission_type(t),
        Mapping::from_raw(&[0x6000_0108]).unwrap(),
    )
}

#[test]
fn receive_async_decodes_writes_and_reports_changes() {
    let mut e: Engine<2, 0> = Engine::new();
    let pdo = e
        .add_rpdo(PdoConfig::new(CommParams::event_driven(0x181), four_u16()))
        .unwrap();
    let mut store = MapStore::new();
    assert!(e.handle_frame(ms(1), &frame(0x181, &[1, 0, 2, 0, 3, 0, 4, 0]), &mut store));
    assert_eq!(
        drain_events(&mut e),
        [Event::Received {
            pdo,
            changed: 0b1111
        }]
    );
    assert_eq!(store.get(a(0x6401, 3)), Some(&[3, 0][..]));
    let vals: Vec<RawValue> = e.received(pdo).unwrap().iter().map(|(_, v)| v).collect();
    assert_eq!(
        vals,
        [1, 2, 3, 4].map(RawValue::Unsigned),
        "typed values of the last reception"
    );
    // Only the third value changes.
    e.handle_frame(ms(2), &frame(0x181, &[1, 0, 2, 0, 9, 0, 4, 0]), &mut store);
    assert_eq!(
        drain_events(&mut e),
        [Event::Received {
            pdo,
            changed: 0b0100
        }]
    );
    // Frames for other identifiers are not ours.
    assert!(!e.handle_frame(ms(3), &frame(0x182, &[0; 8]), &mut store));
    assert!(drain_events(&mut e).is_empty());
}

#[test]
fn receive_length_mismatch_is_an_event_not_a_panic() {
    let mut e: Engine<1, 0> = Engine::new();
    let pdo = e
        .add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x181),
            Mapping::from_raw(&[0x6401_0110, 0x6000_0108]).unwrap(),
        ))
        .unwrap();
    let mut store = MapStore::new();
    e.handle_frame(ms(1), &frame(0x181, &[1, 2]), &mut store);
    let ev = drain_events(&mut e);
    assert_eq!(
        ev,
        [Event::LengthError {
            pdo,
            expected: 3,
            actual: 2
        }]
    );
    assert_eq!(ev[0].emcy_code(), Some(0x8210));
    assert!(store.values.is_empty(), "not processed");
    assert!(e.received(pdo).is_none());

    e.handle_frame(ms(2), &frame(0x181, &[1, 2, 3, 4, 5]), &mut store);
    let ev = drain_events(&mut e);
    assert_eq!(
        ev,
        [
            Event::LengthExceeded {
                pdo,
                expected: 3,
                actual: 5
            },
            Event::Received { pdo, changed: 0b11 }
        ]
    );
    assert_eq!(ev[0].emcy_code(), Some(0x8220));
    assert_eq!(
        store.get(a(0x6000, 1)),
        Some(&[3][..]),
        "processed from the first bytes"
    );

    // Every length 0..=8, empty and RTR frames: no panic, and an event for each data frame.
    for len in 0..=8usize {
        e.handle_frame(ms(3), &frame(0x181, &[0xFF; 8][..len]), &mut store);
        assert!(!drain_events(&mut e).is_empty());
    }
    e.handle_frame(ms(3), &CanFrame::remote(sid(0x181), 3).unwrap(), &mut store);
}

#[test]
fn receive_deadline_from_event_timer() {
    let mut e: Engine<1, 0> = Engine::new();
    let pdo = e
        .add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x181).with_event_timer(100),
            four_u16(),
        ))
        .unwrap();
    let mut store = MapStore::new();
    assert_eq!(e.poll_timeout(), None, "armed by the first reception");
    e.handle_frame(ms(10), &frame(0x181, &[0; 8]), &mut store);
    let _ = drain_events(&mut e);
    assert_eq!(e.poll_timeout(), Some(ms(110)));
    e.handle_frame(ms(60), &frame(0x181, &[0; 8]), &mut store);
    let _ = drain_events(&mut e);
    assert_eq!(e.poll_timeout(), Some(ms(160)), "re-armed");
    e.handle_timeout(ms(159), &mut store);
    assert!(drain_events(&mut e).is_empty());
    e.handle_timeout(ms(160), &mut store);
    assert_eq!(
        drain_events(&mut e),
        [Event::Timeout {
            pdo,
            deadline: ms(160)
        }]
    );
    e.handle_timeout(ms(500), &mut store);
    assert!(drain_events(&mut e).is_empty(), "reported once per lapse");
    assert_eq!(e.poll_timeout(), None);
}

#[test]
fn synchronous_receive_takes_effect_at_next_sync() {
    let mut e: Engine<1, 0> = Engine::new();
    let pdo = e
        .add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x201).with_transmission_type(TransmissionType::SyncCyclic(1)),
            Mapping::from_raw(&[0x6200_0108]).unwrap(),
        ))
        .unwrap();
    let mut store = MapStore::new();
    e.handle_frame(ms(1), &frame(0x201, &[7]), &mut store);
    assert!(drain_events(&mut e).is_empty());
    assert_eq!(store.get(a(0x6200, 1)), None);
    // SYNC on the default COB-ID through handle_frame.
    assert!(e.handle_frame(ms(2), &frame(0x080, &[]), &mut store));
    assert_eq!(drain_events(&mut e), [Event::Received { pdo, changed: 1 }]);
    assert_eq!(store.get(a(0x6200, 1)), Some(&[7][..]));
}

#[test]
fn type_0_synchronous_acyclic_sends_on_sync_after_an_event() {
    let mut e: Engine<0, 1> = Engine::new();
    let t = e
        .add_tpdo(ms(0), tx_u8(TransmissionType::SyncAcyclic))
        .unwrap();
    let mut s = device_store();
    e.handle_sync(ms(1), None, &mut s);
    assert_eq!(
        drain_frames(&mut e),
        [frame(0x185, &[0])],
        "first SYNC: nothing was sent before, so the value goes out"
    );
    e.handle_sync(ms(2), None, &mut s);
    assert!(drain_frames(&mut e).is_empty(), "unchanged: no frame");
    s.set(a(0x6000, 1), &[5]);
    e.update(ms(3), &mut s);
    assert!(drain_frames(&mut e).is_empty(), "waits for SYNC");
    e.handle_sync(ms(4), None, &mut s);
    assert_eq!(drain_frames(&mut e), [frame(0x185, &[5])]);
    e.trigger(ms(5), t, &mut s).unwrap();
    e.handle_sync(ms(6), None, &mut s);
    assert_eq!(
        drain_frames(&mut e),
        [frame(0x185, &[5])],
        "trigger forces a frame"
    );
    e.handle_sync(ms(7), None, &mut s);
    assert!(drain_frames(&mut e).is_empty());
}

#[test]
fn cyclic_every_nth_sync() {
    let mut e: Engine<0, 1> = Engine::new();
    e.add_tpdo(ms(0), tx_u8(TransmissionType::SyncCyclic(3)))
        .unwrap();
    let mut s = device_store();
    let mut sent_at = vec![];
    for k in 1..=10u64 {
        s.set(a(0x6000, 1), &[k as u8]);
        e.handle_sync(ms(k), None, &mut s);
        for f in drain_frames(&mut e) {
            assert_eq!(f.data(), &[k as u8], "sampled at the SYNC");
            sent_at.push(k);
        }
    }
    assert_eq!(sent_at, [3, 6, 9]);
}

#[test]
fn sync_start_value_with_sync_counter() {
    let mut e: Engine<0, 1> = Engine::new();
    let mut cfg = tx_u8(TransmissionType::SyncCyclic(2));
    cfg.comm.sync_start = 4;
    e.add_tpdo(ms(0), cfg.clone()).unwrap();
    let mut s = device_store();
    let mut sent_on = vec![];
    // Counter runs 1..=5 (overflow value 5), twice.
    for (k, counter) in [1u8, 2, 3, 4, 5, 1, 2, 3, 4, 5].into_iter().enumerate() {
        e.handle_frame(ms(k as u64), &frame(0x080, &[counter]), &mut s);
        if !drain_frames(&mut e).is_empty() {
            sent_on.push(counter);
        }
    }
    assert_eq!(e.last_sync_counter(), Some(5));
    assert_eq!(
        sent_on,
        [4, 1, 3, 5],
        "first on counter 4, then every 2nd SYNC"
    );

    // A SYNC without counter: the start value does not apply.
    let mut e: Engine<0, 1> = Engine::new();
    e.add_tpdo(ms(0), cfg).unwrap();
    let mut n = 0;
    for k in 1..=4 {
        e.handle_sync(ms(k), None, &mut s);
        n += drain_frames(&mut e).len();
    }
    assert_eq!(n, 2);
}

#[test]
fn rtr_only_types() {
    let mut s = device_store();
    let rtr = CanFrame::remote(sid(0x185), 1).unwrap();

    // 252: sampled at SYNC, sent on RTR.
    let mut e: Engine<0, 1> = Engine::new();
    let mut cfg = tx_u8(TransmissionType::RtrSync);
    cfg.comm.cob_id = cfg.comm.cob_id.with_rtr_allowed(true);
    e.add_tpdo(ms(0), cfg).unwrap();
    assert!(e.handle_frame(ms(1), &rtr, &mut s));
    assert!(
        drain_frames(&mut e).is_empty(),
        "nothing sampled before the first SYNC"
    );
    s.set(a(0x6000, 1), &[1]);
    e.handle_sync(ms(2), None, &mut s);
    assert!(drain_frames(&mut e).is_empty(), "SYNC only samples");
    s.set(a(0x6000, 1), &[2]);
    e.handle_frame(ms(3), &rtr, &mut s);
    assert_eq!(
        drain_frames(&mut e),
        [frame(0x185, &[1])],
        "the value of the SYNC"
    );

    // 253: sampled and sent on RTR.
    let mut e: Engine<0, 1> = Engine::new();
    let mut cfg = tx_u8(TransmissionType::RtrEvent);
    cfg.comm.cob_id = cfg.comm.cob_id.with_rtr_allowed(true);
    e.add_tpdo(ms(0), cfg).unwrap();
    e.handle_frame(ms(1), &rtr, &mut s);
    assert_eq!(drain_frames(&mut e), [frame(0x185, &[2])]);
    e.handle_sync(ms(2), None, &mut s);
    assert!(drain_frames(&mut e).is_empty());

    // RTR not allowed (bit 30 set): ignored.
    let mut e: Engine<0, 1> = Engine::new();
    e.add_tpdo(ms(0), tx_u8(TransmissionType::RtrEvent))
        .unwrap();
    assert!(e.handle_frame(ms(1), &rtr, &mut s));
    assert!(drain_frames(&mut e).is_empty());
}

#[test]
fn event_driven_inhibit_and_event_timer() {
    let mut e: Engine<0, 1> = Engine::new();
    let cfg = PdoConfig::new(
        CommParams::event_driven(0x185)
            .with_inhibit_time(100) // 10 ms
            .with_event_timer(50),
        Mapping::from_raw(&[0x6000_0108]).unwrap(),
    );
    e.add_tpdo(ms(0), cfg).unwrap();
    let mut s = device_store();
    assert_eq!(
        e.poll_timeout(),
        Some(ms(50)),
        "event timer runs from the start"
    );

    s.set(a(0x6000, 1), &[1]);
    e.update(ms(1), &mut s);
    assert_eq!(
        drain_frames(&mut e),
        [frame(0x185, &[1])],
        "change of state"
    );
    assert_eq!(e.poll_timeout(), Some(ms(51)));

    s.set(a(0x6000, 1), &[2]);
    e.update(ms(3), &mut s);
    assert!(drain_frames(&mut e).is_empty(), "inside the inhibit time");
    assert_eq!(e.poll_timeout(), Some(ms(11)));
    s.set(a(0x6000, 1), &[3]);
    e.update(ms(5), &mut s);
    e.handle_timeout(ms(10), &mut s);
    assert!(drain_frames(&mut e).is_empty(), "not yet");
    e.handle_timeout(ms(11), &mut s);
    assert_eq!(
        drain_frames(&mut e),
        [frame(0x185, &[3])],
        "postponed frame carries the values at the end of the inhibit time"
    );

    // No change: the event timer sends 50 ms after the last frame.
    assert_eq!(e.poll_timeout(), Some(ms(61)));
    e.handle_timeout(ms(61), &mut s);
    assert_eq!(drain_frames(&mut e), [frame(0x185, &[3])]);
    // An unchanged value is not a change of state.
    e.update(ms(80), &mut s);
    assert!(drain_frames(&mut e).is_empty());
}

#[test]
fn disabled_engine_is_silent() {
    let mut e: Engine<1, 1> = Engine::new();
    e.add_rpdo(PdoConfig::new(CommParams::event_driven(0x181), four_u16()))
        .unwrap();
    e.add_tpdo(ms(0), tx_u8(TransmissionType::SyncCyclic(1)))
        .unwrap();
    let mut s = device_store();
    e.set_enabled(ms(0), false);
    assert!(!e.handle_frame(ms(1), &frame(0x181, &[0; 8]), &mut s));
    e.handle_sync(ms(1), None, &mut s);
    assert!(drain_frames(&mut e).is_empty());
    assert!(drain_events(&mut e).is_empty());
    assert_eq!(e.poll_timeout(), None);
    e.set_enabled(ms(2), true);
    e.handle_sync(ms(3), None, &mut s);
    assert_eq!(drain_frames(&mut e).len(), 1);
}

#[test]
fn invalid_cob_id_pdo_takes_no_part() {
    let mut e: Engine<1, 1> = Engine::new();
    let mut cfg = PdoConfig::new(CommParams::event_driven(0x181), four_u16());
    cfg.comm.cob_id = PdoCobId(0x8000_0181);
    e.add_rpdo(cfg).unwrap();
    let mut t = tx_u8(TransmissionType::SyncCyclic(1));
    t.comm.cob_id = PdoCobId(0xC000_0185);
    e.add_tpdo(ms(0), t).unwrap();
    let mut s = device_store();
    assert!(!e.handle_frame(ms(1), &frame(0x181, &[0; 8]), &mut s));
    e.handle_sync(ms(2), None, &mut s);
    assert!(drain_frames(&mut e).is_empty());
    // Reserved transmission type is refused.
    assert!(
        e.add_tpdo(ms(0), tx_u8(TransmissionType::Reserved(241)))
            .is_err()
    );
}

/// The master consumes the device's TPDO1 and produces the device's RPDO1; both sides run the
/// same engine, the device with its object store, the master with its process image.
#[test]
fn master_and_simulated_device() {
    let tpdo1 = PdoConfig::new(
        CommParams::event_driven(0x185).with_inhibit_time(10),
        four_u16(),
    );
    let rpdo1 = PdoConfig::new(
        CommParams::event_driven(0x205),
        Mapping::from_raw(&[0x6200_0108]).unwrap(),
    );
    let mut device: Engine<1, 1> = Engine::new();
    let mut master: Engine<1, 1> = Engine::new();
    device.add_tpdo(ms(0), tpdo1.clone()).unwrap();
    let dev_rx = device.add_rpdo(rpdo1.clone()).unwrap();
    let m_rx = master.add_rpdo(tpdo1).unwrap();
    let m_tx = master.add_tpdo(ms(0), rpdo1).unwrap();

    let mut dev_store = device_store();
    let mut image = MapStore::new().with(a(0x6200, 1), &[0]);

    dev_store.set(a(0x6401, 2), &[0x34, 0x12]);
    device.update(ms(1), &mut dev_store);
    for f in drain_frames(&mut device) {
        assert!(master.handle_frame(ms(1), &f, &mut image));
    }
    assert_eq!(
        drain_events(&mut master),
        [Event::Received {
            pdo: m_rx,
            changed: 0b1111
        }]
    );
    assert_eq!(
        master.received(m_rx).unwrap().get(1),
        Some(RawValue::Unsigned(0x1234))
    );
    assert_eq!(image.get(a(0x6401, 2)), Some(&[0x34, 0x12][..]));

    image.set(a(0x6200, 1), &[0x5A]);
    master.trigger(ms(2), m_tx, &mut image).unwrap();
    for f in drain_frames(&mut master) {
        assert!(device.handle_frame(ms(2), &f, &mut dev_store));
    }
    assert_eq!(
        drain_events(&mut device),
        [Event::Received {
            pdo: dev_rx,
            changed: 1
        }]
    );
    assert_eq!(dev_store.get(a(0x6200, 1)), Some(&[0x5A][..]));
}

#[test]
fn master_requests_rtr_pdo() {
    let mut cfg = tx_u8(TransmissionType::RtrEvent);
    cfg.comm.cob_id = cfg.comm.cob_id.with_rtr_allowed(true);
    let mut device: Engine<0, 1> = Engine::new();
    device.add_tpdo(ms(0), cfg.clone()).unwrap();
    let mut master: Engine<1, 0> = Engine::new();
    let rx = master.add_rpdo(cfg).unwrap();
    let mut dev_store = device_store();
    dev_store.set(a(0x6000, 1), &[42]);
    let mut image = MapStore::new();
    master.request(rx).unwrap();
    let rtr = drain_frames(&mut master);
    assert_eq!(rtr, [CanFrame::remote(sid(0x185), 1).unwrap()]);
    device.handle_frame(ms(1), &rtr[0], &mut dev_store);
    for f in drain_frames(&mut device) {
        master.handle_frame(ms(1), &f, &mut image);
    }
    assert_eq!(
        master.received(rx).unwrap().get(0),
        Some(RawValue::Unsigned(42))
    );
}

/// Advances the virtual clock to `until`, serving every deadline on the way.
fn run_until(
    e: &mut Engine<0, 1>,
    s: &mut MapStore,
    until: Instant,
    sent: &mut Vec<(Instant, u8)>,
) {
    while let Some(t) = e.poll_timeout() {
        if t > until {
            break;
        }
        e.handle_timeout(t, s);
        for f in std::iter::from_fn(|| e.poll_transmit()) {
            sent.push((t, f.data()[0]));
        }
    }
}

#[derive(Debug, Clone)]
enum Op {
    /// Change the value at this many ms after the previous step.
    Change(u64, u8),
    /// Only let time pass.
    Wait(u64),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (0u64..30, any::<u8>()).prop_map(|(d, v)| Op::Change(d, v)),
        (0u64..80).prop_map(Op::Wait),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Whatever the application does, frames of an event-driven TPDO are never closer than the
    /// inhibit time, never further apart than the event time, and the last value sent is the
    /// current one once the inhibit time has passed.
    #[test]
    fn inhibit_and_event_timer_hold(inhibit_100us in 1u16..200, event_ms in 25u16..100, ops in proptest::collection::vec(op(), 1..60)) {
        let inhibit = Duration::from_micros(inhibit_100us as u64 * 100);
        let event = Duration::from_millis(event_ms as u64);
        prop_assume!(event > inhibit);
        let mut e: Engine<0, 1> = Engine::new();
        e.add_tpdo(ms(0), PdoConfig::new(
            CommParams::event_driven(0x185).with_inhibit_time(inhibit_100us).with_event_timer(event_ms),
            Mapping::from_raw(&[0x6000_0108]).unwrap(),
        )).unwrap();
        let mut s = device_store();
        let mut now = ms(0);
        let mut sent: Vec<(Instant, u8)> = vec![];
        for op in ops {
            let (d, change) = match op { Op::Change(d, v) => (d, Some(v)), Op::Wait(d) => (d, None) };
            let next = now + Duration::from_millis(d);
            run_until(&mut e, &mut s, next, &mut sent);
            now = next;
            if let Some(v) = change {
                s.set(a(0x6000, 1), &[v]);
                e.update(now, &mut s);
                for f in std::iter::from_fn(|| e.poll_transmit()) { sent.push((now, f.data()[0])); }
            }
        }
        let end = now + Duration::from_millis(200);
        run_until(&mut e, &mut s, end, &mut sent);
        prop_assert!(!sent.is_empty());
        for w in sent.windows(2) {
            let gap = w[1].0 - w[0].0;
            prop_assert!(gap >= inhibit, "frames {:?} closer than {}", w, inhibit);
            prop_assert!(gap <= event, "frames {:?} further apart than {}", w, event);
        }
        prop_assert_eq!(sent.last().map(|x| x.1), s.get(a(0x6000, 1)).map(|b| b[0]));
    }
}

/// A store that refuses every write to 0x6200:1.
struct Picky(MapStore);

impl canola_pdo::ObjectStore for Picky {
    fn read(&mut self, addr: ObjectAddress, out: &mut [u8]) -> Result<(), canola_pdo::StoreError> {
        self.0.read(addr, out)
    }

    fn write(&mut self, addr: ObjectAddress, data: &[u8]) -> Result<(), canola_pdo::StoreError> {
        if addr == a(0x6200, 1) {
            return Err(canola_pdo::StoreError::ValueRange);
        }
        self.0.write(addr, data)
    }
}

#[test]
fn store_failures_are_events_without_retry_storms() {
    use canola_pdo::{PdoRef, StoreError};
    // Transmit side: a mapped object the store does not have.
    let mut e: Engine<1, 1> = Engine::new();
    let t = e
        .add_tpdo(
            ms(0),
            PdoConfig::new(
                CommParams::event_driven(0x185).with_event_timer(100),
                Mapping::from_raw(&[0x7000_0108]).unwrap(),
            ),
        )
        .unwrap();
    let mut s = Picky(device_store());
    e.trigger(ms(1), t, &mut s).unwrap();
    assert!(drain_frames(&mut e).is_empty());
    assert_eq!(
        drain_events(&mut e),
        [Event::StoreFailed {
            pdo: PdoRef::Tx(t),
            addr: a(0x7000, 1),
            error: StoreError::NoSuchObject
        }]
    );
    assert_eq!(e.poll_timeout(), Some(ms(100)));
    e.handle_timeout(ms(100), &mut s);
    assert_eq!(drain_events(&mut e).len(), 1);
    assert_eq!(
        e.poll_timeout(),
        Some(ms(200)),
        "retried at the next event time only"
    );

    // Receive side: the other objects are written and the reception is reported.
    let r = e
        .add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x205),
            Mapping::from_raw(&[0x6200_0108, 0x6200_0208]).unwrap(),
        ))
        .unwrap();
    e.handle_frame(ms(2), &frame(0x205, &[1, 2]), &mut s);
    assert_eq!(
        drain_events(&mut e),
        [
            Event::StoreFailed {
                pdo: PdoRef::Rx(r),
                addr: a(0x6200, 1),
                error: StoreError::ValueRange
            },
            Event::Received {
                pdo: r,
                changed: 0b11
            }
        ]
    );
    assert_eq!(s.0.get(a(0x6200, 2)), Some(&[2][..]));
}

#[test]
fn queue_capacity_is_a_parameter_and_overflow_is_counted() {
    let mut e: Engine<0, 3, 2> = Engine::new();
    for n in 0..3u16 {
        let mut cfg = tx_u8(TransmissionType::SyncCyclic(1));
        cfg.comm.cob_id = PdoCobId::standard(0x185 + 0x100 * n);
        e.add_tpdo(ms(0), cfg).unwrap();
    }
    let mut s = device_store();
    e.handle_sync(ms(1), None, &mut s);
    assert_eq!(drain_frames(&mut e).len(), 2);
    assert_eq!(e.lost_frames(), 1);
    let mut big: Engine<0, 3, 3> = Engine::new();
    for n in 0..3u16 {
        let mut cfg = tx_u8(TransmissionType::SyncCyclic(1));
        cfg.comm.cob_id = PdoCobId::standard(0x185 + 0x100 * n);
        big.add_tpdo(ms(0), cfg).unwrap();
    }
    big.handle_sync(ms(1), None, &mut s);
    let ids: Vec<u16> = std::iter::from_fn(|| big.poll_transmit())
        .filter_map(|f| f.cob_id())
        .collect();
    assert_eq!(ids, [0x185, 0x285, 0x385]);
    assert_eq!(big.lost_frames(), 0);
}
