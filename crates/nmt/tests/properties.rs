//! Property tests: the heartbeat consumer and the guarding master against small reference
//! models, on random frame sequences and random time steps (including steps that skip several
//! deadlines and `handle_timeout` calls at arbitrary instants, not only at `poll_timeout`).

use canola_nmt::*;
use proptest::prelude::*;

#[derive(Debug, Clone)]
enum Step {
    /// Advance the clock by this many ms, then call `handle_timeout`.
    Wait(u16),
    /// A one-byte error-control frame from node index 0..3.
    Byte(usize, u8),
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        (0u16..400).prop_map(Step::Wait),
        (
            0usize..3,
            prop_oneof![
                Just(0x00u8),
                Just(0x04),
                Just(0x05),
                Just(0x7F),
                Just(0x85),
                Just(0xFF),
                any::<u8>()
            ]
        )
            .prop_map(|(n, b)| Step::Byte(n, b)),
    ]
}

fn node(i: usize) -> NodeId {
    NodeId::new(10 + i as u8).unwrap()
}

#[derive(Default, Clone)]
struct HbModel {
    deadline: Option<u64>,
    lost: bool,
    state: Option<u8>,
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn heartbeat_consumer_matches_model(
        timeouts in proptest::array::uniform3(0u16..300),
        steps in proptest::collection::vec(step(), 0..120),
    ) {
        let mut c = HeartbeatConsumer::<3>::new();
        let mut model = [HbModel::default(), HbModel::default(), HbModel::default()];
        for (i, t) in timeouts.iter().enumerate() {
            c.monitor(node(i), Duration::from_millis(u64::from(*t))).unwrap();
        }
        let mut now_ms = 0u64;
        for s in steps {
            let mut expected = Vec::new();
            match s {
                Step::Wait(dt) => {
                    now_ms += u64::from(dt);
                    c.handle_timeout(Instant::from_millis(now_ms));
                    for (i, m) in model.iter_mut().enumerate() {
                        if m.deadline.is_some_and(|d| d <= now_ms) {
                            m.deadline = None;
                            m.lost = true;
                            expected.push(HeartbeatEvent::Lost {
                                node: node(i),
                                last_state: m.state.map(NmtState::from_u8),
                            });
                        }
                    }
                }
                Step::Byte(i, b) => {
                    let f = Heartbeat { state: NmtState::from_u8(b) }.to_frame(node(i));
                    prop_assert_eq!(c.handle_frame(Instant::from_millis(now_ms), &f), Ok(true));
                    let m = &mut model[i];
                    if b == 0 {
                        *m = HbModel::default();
                        expected.push(HeartbeatEvent::BootUp { node: node(i) });
                    } else {
                        if m.lost {
                            expected.push(HeartbeatEvent::Recovered { node: node(i), state: NmtState::from_u8(b) });
                        }
                        if m.state != Some(b) {
                            expected.push(HeartbeatEvent::StateChanged {
                                node: node(i),
                                from: m.state.map(NmtState::from_u8),
                                to: NmtState::from_u8(b),
                            });
                        }
                        m.lost = false;
                        m.state = Some(b);
                        m.deadline = (timeouts[i] != 0).then(|| now_ms + u64::from(timeouts[i]));
                    }
                }
            }
            let got: Vec<_> = std::iter::from_fn(|| c.poll_event()).collect();
            // Loss events come in table order; compare as sets of the same length.
            prop_assert_eq!(got.len(), expected.len());
            for e in &expected {
                prop_assert!(got.contains(e), "missing {:?} in {:?}", e, got);
            }
            let model_next = model.iter().filter_map(|m| m.deadline).min().map(Instant::from_millis);
            prop_assert_eq!(c.poll_timeout(), model_next);
            for (i, m) in model.iter().enumerate() {
                prop_assert_eq!(c.is_lost(node(i)), m.lost);
            }
        }
    }

    /// One guarded node: requests go out once per guard time whatever the step sizes, and "lost"
    /// is reported exactly when the life time has passed without a valid answer.
    #[test]
    fn guarding_master_matches_model(
        guard_ms in 1u16..200,
        factor in 0u8..5,
        steps in proptest::collection::vec(step(), 0..120),
    ) {
        let n = node(0);
        let guard = u64::from(guard_ms);
        let life = guard * u64::from(factor.max(1));
        let mut g = GuardingMaster::<1>::new();
        g.guard(Instant::ZERO, n, Duration::from_millis(guard), factor).unwrap();
        let mut now_ms = 0u64;
        let mut next_poll = 0u64;
        let mut life_deadline = Some(life);
        let mut expected_toggle: Option<bool> = None;
        let mut lost = false;
        let mut state: Option<u8> = None;
        for s in steps {
            let mut expected = Vec::new();
            let mut expected_requests = 0;
            match s {
                Step::Wait(dt) => {
                    now_ms += u64::from(dt);
                    g.handle_timeout(Instant::from_millis(now_ms));
                    if next_poll <= now_ms {
                        expected_requests = 1;
                        next_poll = if next_poll + guard <= now_ms { now_ms + guard } else { next_poll + guard };
                    }
                    if life_deadline.is_some_and(|d| d <= now_ms) {
                        life_deadline = None;
                        lost = true;
                        expected.push(GuardingEvent::Lost { node: n, last_state: state.map(NmtState::from_u8) });
                    }
                }
                Step::Byte(_, b) => {
                    g.handle_response(Instant::from_millis(now_ms), n, b);
                    if b == 0 {
                        state = None;
                        expected_toggle = Some(false);
                        lost = false;
                        life_deadline = Some(now_ms + life);
                        expected.push(GuardingEvent::BootUp { node: n });
                    } else {
                        let toggle = b & 0x80 != 0;
                        let st = b & 0x7F;
                        if expected_toggle.is_some_and(|e| e != toggle) {
                            expected.push(GuardingEvent::ToggleError { node: n, expected: !toggle });
                        } else {
                            if lost {
                                lost = false;
                                expected.push(GuardingEvent::Recovered { node: n, state: NmtState::from_u8(st) });
                            }
                            if state != Some(st) {
                                expected.push(GuardingEvent::StateChanged {
                                    node: n,
                                    from: state.map(NmtState::from_u8),
                                    to: NmtState::from_u8(st),
                                });
                            }
                            state = Some(st);
                            life_deadline = Some(now_ms + life);
                        }
                        expected_toggle = Some(!toggle);
                    }
                }
            }
            let got: Vec<_> = std::iter::from_fn(|| g.poll_event()).collect();
            prop_assert_eq!(got, expected);
            let requests: Vec<_> = std::iter::from_fn(|| g.poll_transmit_frame()).collect();
            prop_assert_eq!(requests.len(), expected_requests);
            prop_assert!(requests.iter().all(|f| f.is_remote() && f.cob_id() == Some(0x70A)));
            let model_next = Some(Instant::from_millis(life_deadline.map_or(next_poll, |d| d.min(next_poll))));
            prop_assert_eq!(g.poll_timeout(), model_next);
            prop_assert_eq!(g.is_lost(n), lost);
        }
    }
}
