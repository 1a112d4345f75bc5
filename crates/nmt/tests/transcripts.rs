//! Transcript tests on a virtual clock: every monitor path of the master-side machines, and the
//! device-side NMT slave talking to them.

use canola_nmt::*;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn ms(t: u64) -> Instant {
    Instant::from_millis(t)
}

fn hb(n: u8, state: u8) -> CanFrame {
    Heartbeat {
        state: NmtState::from_u8(state),
    }
    .to_frame(node(n))
}

fn events<const N: usize>(c: &mut HeartbeatConsumer<N>) -> Vec<HeartbeatEvent> {
    std::iter::from_fn(|| c.poll_event()).collect()
}

fn gevents<const N: usize>(g: &mut GuardingMaster<N>) -> Vec<GuardingEvent> {
    std::iter::from_fn(|| g.poll_event()).collect()
}

fn frames(mut f: impl FnMut() -> Option<CanFrame>) -> Vec<String> {
    std::iter::from_fn(&mut f).map(|f| f.to_string()).collect()
}

#[test]
fn heartbeat_no_timeout_before_first_heartbeat() {
    let mut c = HeartbeatConsumer::<8>::new();
    c.monitor(node(5), Duration::from_millis(100)).unwrap();
    assert_eq!(
        c.poll_timeout(),
        None,
        "not armed before the first heartbeat"
    );
    c.handle_timeout(ms(10_000));
    assert!(events(&mut c).is_empty());
    assert!(!c.is_lost(node(5)));
}

#[test]
fn heartbeat_loss_after_consumer_time_and_recovery() {
    let mut c = HeartbeatConsumer::<8>::new();
    c.monitor(node(5), Duration::from_millis(100)).unwrap();
    assert_eq!(c.handle_frame(ms(1000), &hb(5, 0x7F)), Ok(true));
    assert_eq!(
        events(&mut c),
        [HeartbeatEvent::StateChanged {
            node: node(5),
            from: None,
            to: NmtState::PreOperational
        }]
    );
    assert_eq!(c.poll_timeout(), Some(ms(1100)));
    // Heartbeat at 1090 re-arms; same state, no event.
    c.handle_frame(ms(1090), &hb(5, 0x7F)).unwrap();
    assert!(events(&mut c).is_empty());
    assert_eq!(c.poll_timeout(), Some(ms(1190)));
    c.handle_timeout(ms(1189));
    assert!(
        events(&mut c).is_empty(),
        "one microsecond early is not lost"
    );
    c.handle_timeout(ms(1190));
    assert_eq!(
        events(&mut c),
        [HeartbeatEvent::Lost {
            node: node(5),
            last_state: Some(NmtState::PreOperational)
        }]
    );
    assert!(c.is_lost(node(5)));
    assert_eq!(c.poll_timeout(), None, "lost is reported once");
    c.handle_timeout(ms(5000));
    assert!(events(&mut c).is_empty());
    // Recovery in a new state.
    c.handle_frame(ms(6000), &hb(5, 0x05)).unwrap();
    assert_eq!(
        events(&mut c),
        [
            HeartbeatEvent::Recovered {
                node: node(5),
                state: NmtState::Operational
            },
            HeartbeatEvent::StateChanged {
                node: node(5),
                from: Some(NmtState::PreOperational),
                to: NmtState::Operational
            },
        ]
    );
    assert!(!c.is_lost(node(5)));
    assert_eq!(c.poll_timeout(), Some(ms(6100)));
}

#[test]
fn heartbeat_boot_up_in_the_middle() {
    let mut c = HeartbeatConsumer::<8>::new();
    c.monitor(node(3), Duration::from_millis(50)).unwrap();
    c.handle_frame(ms(0), &hb(3, 0x05)).unwrap();
    let _ = events(&mut c);
    // The node resets and sends its boot-up message before the deadline.
    c.handle_frame(ms(30), &hb(3, 0x00)).unwrap();
    assert_eq!(events(&mut c), [HeartbeatEvent::BootUp { node: node(3) }]);
    assert_eq!(c.state(node(3)), Some(NmtState::BootUp));
    assert_eq!(c.poll_timeout(), None, "boot-up disarms");
    c.handle_timeout(ms(1000));
    assert!(
        events(&mut c).is_empty(),
        "no loss while the node has not been configured"
    );
    c.handle_frame(ms(1500), &hb(3, 0x7F)).unwrap();
    assert_eq!(
        events(&mut c),
        [HeartbeatEvent::StateChanged {
            node: node(3),
            from: None,
            to: NmtState::PreOperational
        }]
    );
    assert_eq!(c.poll_timeout(), Some(ms(1550)));
    // Boot-up after a loss: reported as boot-up only.
    c.handle_timeout(ms(1550));
    assert!(matches!(events(&mut c)[..], [HeartbeatEvent::Lost { .. }]));
    c.handle_frame(ms(2000), &hb(3, 0x00)).unwrap();
    assert_eq!(events(&mut c), [HeartbeatEvent::BootUp { node: node(3) }]);
    assert!(!c.is_lost(node(3)));
}

#[test]
fn heartbeat_many_nodes_and_routing() {
    let mut c = HeartbeatConsumer::<127>::new();
    for n in NodeId::all() {
        c.configure(ConsumerHeartbeatEntry {
            node: n.get(),
            time_ms: 100,
        })
        .unwrap();
    }
    for n in NodeId::all() {
        c.handle_frame(ms(u64::from(n.get())), &hb(n.get(), 0x05))
            .unwrap();
    }
    let _ = events(&mut c);
    assert_eq!(c.poll_timeout(), Some(ms(101)));
    // Everybody is lost at once: more than the event queue holds. Nothing is dropped; the rest
    // stays due for the next call.
    c.handle_timeout(ms(1000));
    let mut lost = events(&mut c).len();
    assert_eq!(lost, HEARTBEAT_EVENT_CAPACITY);
    assert!(c.poll_timeout().unwrap() <= ms(1000));
    c.handle_timeout(ms(1000));
    lost += events(&mut c).len();
    assert_eq!(lost, 127);
    assert_eq!(c.poll_timeout(), None);
    // Frames that are not heartbeats of monitored nodes are declined.
    let mut small = HeartbeatConsumer::<1>::new();
    small.monitor(node(1), Duration::ZERO).unwrap();
    assert_eq!(
        small.monitor(node(2), Duration::ZERO),
        Err(CapacityError { capacity: 1 })
    );
    assert_eq!(small.handle_frame(ms(0), &hb(2, 5)), Ok(false));
    assert_eq!(
        small.handle_frame(ms(0), &guard_request(node(1))),
        Ok(false)
    );
    assert_eq!(
        small.handle_frame(ms(0), &SyncMessage::default().to_frame(0x80)),
        Ok(false)
    );
    assert!(
        small
            .handle_frame(ms(0), &CanFrame::new(hb(1, 5).id(), &[5, 0]).unwrap())
            .is_err()
    );
    // Consumer time 0: states are tracked, nothing times out.
    small.handle_frame(ms(0), &hb(1, 4)).unwrap();
    assert_eq!(small.state(node(1)), Some(NmtState::Stopped));
    assert_eq!(small.poll_timeout(), None);
}

#[test]
fn guarding_lost_after_guard_time_times_life_factor() {
    let mut g = GuardingMaster::<4>::new();
    g.guard(ms(0), node(7), Duration::from_millis(100), 3)
        .unwrap();
    assert_eq!(g.poll_timeout(), Some(ms(0)));
    g.handle_timeout(ms(0));
    assert_eq!(frames(|| g.poll_transmit_frame()), ["707#R1"]);
    // The node answers (toggle 0, pre-operational).
    assert_eq!(
        g.handle_frame(ms(2), &CanFrame::new(hb(7, 0).id(), &[0x7F]).unwrap()),
        Ok(true)
    );
    assert_eq!(
        gevents(&mut g),
        [GuardingEvent::StateChanged {
            node: node(7),
            from: None,
            to: NmtState::PreOperational
        }]
    );
    // Life time now runs to 2 + 300 = 302 ms. Polls at 100, 200, 300 go unanswered.
    for t in [100, 200, 300] {
        assert_eq!(g.poll_timeout(), Some(ms(t)));
        g.handle_timeout(ms(t));
        assert_eq!(frames(|| g.poll_transmit_frame()), ["707#R1"]);
        assert!(gevents(&mut g).is_empty());
    }
    assert_eq!(g.poll_timeout(), Some(ms(302)));
    g.handle_timeout(ms(302));
    assert_eq!(
        gevents(&mut g),
        [GuardingEvent::Lost {
            node: node(7),
            last_state: Some(NmtState::PreOperational)
        }]
    );
    assert!(g.is_lost(node(7)));
    // Polling continues; an answer (toggle 1, operational) recovers the node.
    g.handle_timeout(ms(400));
    assert_eq!(frames(|| g.poll_transmit_frame()), ["707#R1"]);
    g.handle_response(ms(401), node(7), 0x85);
    assert_eq!(
        gevents(&mut g),
        [
            GuardingEvent::Recovered {
                node: node(7),
                state: NmtState::Operational
            },
            GuardingEvent::StateChanged {
                node: node(7),
                from: Some(NmtState::PreOperational),
                to: NmtState::Operational
            },
        ]
    );
}

#[test]
fn guarding_never_answered_is_lost_after_life_time() {
    let mut g = GuardingMaster::<4>::new();
    g.guard(ms(10), node(1), Duration::from_millis(50), 2)
        .unwrap();
    g.handle_timeout(ms(10));
    g.handle_timeout(ms(60));
    assert!(gevents(&mut g).is_empty());
    g.handle_timeout(ms(110));
    assert_eq!(
        gevents(&mut g),
        [GuardingEvent::Lost {
            node: node(1),
            last_state: None
        }]
    );
    assert_eq!(frames(|| g.poll_transmit_frame()).len(), 3);
}

#[test]
fn guarding_toggle_error() {
    let mut g = GuardingMaster::<4>::new();
    g.guard(ms(0), node(2), Duration::from_millis(100), 2)
        .unwrap();
    g.handle_response(ms(1), node(2), 0x05); // toggle 0, accepted (first answer)
    let _ = gevents(&mut g);
    g.handle_response(ms(101), node(2), 0x85); // toggle 1, fine
    assert!(gevents(&mut g).is_empty());
    g.handle_response(ms(201), node(2), 0x85); // toggle 1 again: error
    assert_eq!(
        gevents(&mut g),
        [GuardingEvent::ToggleError {
            node: node(2),
            expected: false
        }]
    );
    // The bad answer is no sign of life: life time (200 ms) still counts from 101.
    g.handle_timeout(ms(300));
    assert!(gevents(&mut g).is_empty());
    g.handle_timeout(ms(301));
    assert!(matches!(gevents(&mut g)[..], [GuardingEvent::Lost { .. }]));
    // Resynchronised: the next answer alternates from the bad one.
    g.handle_response(ms(301), node(2), 0x05);
    assert!(matches!(
        gevents(&mut g)[..],
        [GuardingEvent::Recovered { .. }]
    ));
    // Boot-up: next answer must carry toggle 0.
    g.handle_response(ms(350), node(2), 0x00);
    assert_eq!(gevents(&mut g), [GuardingEvent::BootUp { node: node(2) }]);
    g.handle_response(ms(360), node(2), 0xFF);
    assert_eq!(
        gevents(&mut g),
        [GuardingEvent::ToggleError {
            node: node(2),
            expected: false
        }]
    );
}

#[test]
fn sync_counter_wraps_at_overflow() {
    let cfg = SyncConfig::new(Duration::from_millis(10), 3).unwrap();
    let mut p = SyncProducer::new(cfg);
    assert_eq!(p.poll_timeout(), None);
    p.start(ms(100));
    let mut sent = Vec::new();
    for i in 0..7 {
        let now = p.poll_timeout().unwrap();
        assert_eq!(now, ms(100 + 10 * i));
        p.handle_timeout(now);
        sent.push(p.poll_transmit_frame().unwrap().to_string());
        assert_eq!(p.poll_transmit_frame(), None);
    }
    assert_eq!(
        sent,
        [
            "080#01", "080#02", "080#03", "080#01", "080#02", "080#03", "080#01"
        ]
    );
    // A late caller gets one SYNC, not a burst, and the counter continues.
    p.handle_timeout(ms(1000));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["080#02"]);
    assert_eq!(p.poll_timeout(), Some(ms(1010)));
    // Restart resets the counter to 1.
    p.stop();
    assert_eq!(p.poll_timeout(), None);
    p.start(ms(2000));
    p.handle_timeout(ms(2000));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["080#01"]);
    // Without counter: empty SYNC.
    let mut p = SyncProducer::new(SyncConfig::new(Duration::from_millis(1), 0).unwrap());
    p.start(ms(0));
    p.handle_timeout(ms(0));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["080#"]);
    // Overflow 240: 240 then 1.
    let mut p = SyncProducer::new(SyncConfig::new(Duration::from_millis(1), 240).unwrap());
    p.start(ms(0));
    let counters: Vec<u8> = (0..241)
        .map(|i| {
            p.handle_timeout(ms(i));
            p.poll_transmit_frame().unwrap().data()[0]
        })
        .collect();
    assert_eq!(counters[239], 240);
    assert_eq!(counters[240], 1);
}

#[test]
fn time_epoch_on_the_wire() {
    let mut p = TimeProducer::new(TIME_COB_ID, Duration::ZERO);
    // Monotonic 7 s == 1984-01-01 00:00:00.000 UTC.
    p.set_clock(ms(7000), EPOCH_1984_UNIX_DAYS * 86_400_000);
    assert_eq!(p.poll_timeout(), None, "no period, no schedule");
    assert!(p.publish(ms(7000)));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["100#000000000000"]);
    // One day and 1.5 s later.
    assert!(p.publish(ms(7000 + 86_401_500)));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["100#DC0500000100"]);
}

#[test]
fn slave_against_master_machines() {
    let n = node(4);
    let mut dev = NmtSlave::new(
        n,
        SlaveConfig {
            heartbeat_ms: 100,
            guard_time_ms: 0,
            life_time_factor: 0,
        },
    );
    let mut hbc = HeartbeatConsumer::<4>::new();
    hbc.monitor(n, Duration::from_millis(150)).unwrap();
    assert!(!dev.allows(Service::Sdo));
    assert_eq!(dev.poll_timeout(), None);
    dev.boot(ms(0));
    assert_eq!(dev.state(), DeviceState::PreOperational);
    assert!(dev.allows(Service::Sdo) && !dev.allows(Service::Pdo));
    let wire = frames(|| dev.poll_transmit_frame());
    assert_eq!(wire, ["704#00"]);
    hbc.handle_frame(ms(0), &hb(4, 0)).unwrap();
    assert_eq!(events(&mut hbc), [HeartbeatEvent::BootUp { node: n }]);
    assert_eq!(
        dev.poll_event(),
        Some(SlaveEvent::StateChanged {
            from: DeviceState::Initialising,
            to: DeviceState::PreOperational
        })
    );
    // Heartbeat every 100 ms.
    assert_eq!(dev.poll_timeout(), Some(ms(100)));
    dev.handle_timeout(ms(100));
    let f = dev.poll_transmit_frame().unwrap();
    assert_eq!(f.to_string(), "704#7F");
    hbc.handle_frame(ms(100), &f).unwrap();
    // Start all nodes.
    let start = NmtCommand::new(CommandSpecifier::Start, NmtTarget::All).to_frame();
    assert_eq!(start.to_string(), "000#0100");
    assert_eq!(dev.handle_frame(ms(120), &start), Ok(true));
    assert_eq!(dev.state(), DeviceState::Operational);
    assert!(dev.allows(Service::Pdo));
    dev.handle_timeout(ms(200));
    hbc.handle_frame(ms(200), &dev.poll_transmit_frame().unwrap())
        .unwrap();
    let _ = events(&mut hbc);
    // Stop node 4 only; a command for node 5 is ignored.
    let stop5 = NmtCommand::new(CommandSpecifier::Stop, node(5)).to_frame();
    assert_eq!(dev.handle_frame(ms(210), &stop5), Ok(true));
    assert_eq!(dev.state(), DeviceState::Operational);
    dev.handle_frame(
        ms(220),
        &NmtCommand::new(CommandSpecifier::Stop, n).to_frame(),
    )
    .unwrap();
    assert_eq!(dev.state(), DeviceState::Stopped);
    assert!(!dev.allows(Service::Sdo) && dev.allows(Service::ErrorControl));
    dev.handle_timeout(ms(300));
    let f = dev.poll_transmit_frame().unwrap();
    assert_eq!(f.to_string(), "704#04", "heartbeat continues in Stopped");
    hbc.handle_frame(ms(300), &f).unwrap();
    assert_eq!(
        events(&mut hbc),
        [HeartbeatEvent::StateChanged {
            node: n,
            from: Some(NmtState::Operational),
            to: NmtState::Stopped
        }]
    );
    // Reset communication: event, silence until the application boots again.
    while dev.poll_event().is_some() {}
    dev.handle_frame(
        ms(310),
        &NmtCommand::new(CommandSpecifier::ResetCommunication, n).to_frame(),
    )
    .unwrap();
    assert_eq!(dev.state(), DeviceState::Initialising);
    let evs: Vec<_> = std::iter::from_fn(|| dev.poll_event()).collect();
    assert_eq!(evs.last(), Some(&SlaveEvent::ResetCommunication));
    assert_eq!(dev.poll_timeout(), None);
    hbc.handle_timeout(ms(450));
    assert_eq!(
        events(&mut hbc),
        [HeartbeatEvent::Lost {
            node: n,
            last_state: Some(NmtState::Stopped)
        }]
    );
    dev.boot(ms(500));
    assert_eq!(frames(|| dev.poll_transmit_frame()), ["704#00"]);
    hbc.handle_frame(ms(500), &hb(4, 0)).unwrap();
    assert_eq!(events(&mut hbc), [HeartbeatEvent::BootUp { node: n }]);
    // Unknown command specifier: reported, state unchanged.
    while dev.poll_event().is_some() {}
    dev.handle_frame(ms(510), &CanFrame::new(start.id(), &[0x42, 4]).unwrap())
        .unwrap();
    assert_eq!(dev.poll_event(), Some(SlaveEvent::UnknownCommand(0x42)));
    assert!(
        dev.handle_frame(ms(510), &CanFrame::new(start.id(), &[1]).unwrap())
            .is_err()
    );
}

#[test]
fn slave_guarding_against_master() {
    let n = node(9);
    let mut dev = NmtSlave::new(
        n,
        SlaveConfig {
            heartbeat_ms: 0,
            guard_time_ms: 100,
            life_time_factor: 2,
        },
    );
    let mut gm = GuardingMaster::<2>::new();
    dev.boot(ms(0));
    let _ = frames(|| dev.poll_transmit_frame());
    while dev.poll_event().is_some() {}
    gm.guard(ms(0), n, Duration::from_millis(100), 2).unwrap();
    let mut now = ms(0);
    let mut answers = Vec::new();
    for _ in 0..4 {
        gm.handle_timeout(now);
        for req in frames(|| gm.poll_transmit_frame()) {
            assert_eq!(req, "709#R1");
            dev.handle_guard_request(now);
        }
        while let Some(f) = dev.poll_transmit_frame() {
            answers.push(f.to_string());
            gm.handle_frame(now, &f).unwrap();
        }
        now += Duration::from_millis(100);
    }
    assert_eq!(answers, ["709#7F", "709#FF", "709#7F", "709#FF"]);
    assert_eq!(
        gevents(&mut gm),
        [GuardingEvent::StateChanged {
            node: n,
            from: None,
            to: NmtState::PreOperational
        }]
    );
    // The master stops guarding: the device reports a life guarding event after 200 ms.
    assert_eq!(dev.poll_timeout(), Some(ms(500)));
    dev.handle_timeout(ms(500));
    assert_eq!(dev.poll_event(), Some(SlaveEvent::LifeGuardingLost));
    dev.handle_guard_request(ms(900));
    assert_eq!(dev.poll_event(), Some(SlaveEvent::LifeGuardingResumed));
    assert_eq!(frames(|| dev.poll_transmit_frame()), ["709#7F"]);
}

#[test]
fn emcy_from_device_to_master() {
    let mut p = EmcyProducer::new(emcy_cob_id(node(6)), 0);
    let mut c = EmcyConsumer::new();
    let e = Emcy {
        code: EmcyCode::RPDO_TIMEOUT,
        register: ErrorRegister::GENERIC | ErrorRegister::COMMUNICATION,
        manufacturer: [0xDE, 0xAD, 0, 0, 1],
    };
    p.signal(ms(5), e).unwrap();
    p.signal(ms(5), Emcy::new(EmcyCode::NO_ERROR, ErrorRegister::EMPTY))
        .unwrap();
    let wire = frames(|| p.poll_transmit_frame());
    assert_eq!(wire, ["086#508211DEAD000001", "086#0000000000000000"]);
    let f = e.to_frame(emcy_cob_id(node(6)));
    assert_eq!(c.handle_frame(ms(6), &f), Ok(true));
    let ev = c.poll_event().unwrap();
    assert_eq!((ev.node, ev.emcy), (node(6), e));
    assert_eq!(ev.emcy.code.description(), Some("RPDO timeout"));
}

#[test]
fn producer_reconfiguration() {
    // Heartbeat producer: 0x1017 written while running restarts the period; 0 pauses it.
    let mut p = HeartbeatProducer::new(node(2), 100);
    p.set_period(ms(0), 50);
    assert_eq!(p.poll_timeout(), None, "not started yet");
    p.start(ms(0));
    assert_eq!(p.poll_timeout(), Some(ms(50)));
    p.set_state(NmtState::Operational);
    p.handle_timeout(ms(50));
    assert_eq!(frames(|| p.poll_transmit_frame()), ["702#05"]);
    p.set_period(ms(60), 0);
    assert_eq!(p.poll_timeout(), None);
    p.set_period(ms(70), 200);
    assert_eq!(p.poll_timeout(), Some(ms(270)));
    p.stop();
    p.set_period(ms(80), 10);
    assert_eq!(p.poll_timeout(), None);

    // SYNC producer: a new period restarts a running producer (counter back to 1).
    let mut s = SyncProducer::new(SyncConfig::new(Duration::from_millis(10), 4).unwrap());
    s.start(ms(0));
    s.handle_timeout(ms(0));
    s.handle_timeout(ms(10));
    assert_eq!(
        frames(|| s.poll_transmit_frame()),
        ["080#02"],
        "an undrained SYNC is replaced"
    );
    s.reconfigure(
        ms(15),
        SyncConfig::new(Duration::from_millis(20), 4).unwrap(),
    );
    assert_eq!(s.poll_timeout(), Some(ms(15)));
    s.handle_timeout(ms(15));
    assert_eq!(frames(|| s.poll_transmit_frame()), ["080#01"]);
    assert_eq!(s.poll_timeout(), Some(ms(35)));
    s.reconfigure(ms(20), SyncConfig::new(Duration::ZERO, 0).unwrap());
    assert!(!s.is_running());
}
