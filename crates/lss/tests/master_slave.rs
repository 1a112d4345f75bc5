//! LSS master machines against LSS slave machines on a virtual clock (see `bus/mod.rs` for the
//! bus model: identical simultaneous answers merge into one frame, or arrive one by one).

mod bus;

use std::collections::BTreeSet;
use std::vec::Vec;

use bus::{Bus, Delivery, Rng, random_addresses};
use canola_frame::{Duration, Instant, NodeId};
use canola_lss::assign::AssignOutcome;
use canola_lss::service::{IdentifyQuery, Range};
use canola_lss::slave::SlaveState;
use canola_lss::*;

fn id(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

const DELIVERIES: [Delivery; 2] = [
    Delivery::Merged,
    Delivery::Separate {
        spread: Duration::from_millis(3),
    },
];

fn fast(policy: ResponsePolicy) -> FastscanConfig {
    FastscanConfig {
        response_timeout: Duration::from_millis(10),
        policy,
        known: [None; 4],
        skip: [false; 4],
    }
}

// ---------------------------------------------------------------------------------------------
// Fastscan

#[test]
fn fastscan_finds_one_slave_and_leaves_it_in_configuration() {
    let mut rng = Rng::new(1);
    for delivery in DELIVERIES {
        let addrs = random_addresses(&mut rng, 1);
        let mut bus = Bus::with_unconfigured(delivery, &addrs);
        let mut m = Fastscan::new(FastscanConfig::default());
        m.start(bus.now).unwrap();
        assert_eq!(m.start(bus.now), Err(LssError::Busy));
        let (r, events) = bus.run(&mut m);
        assert_eq!(r, Ok(Some(addrs[0])));
        assert_eq!(events, vec![MasterEvent::Found(addrs[0])]);
        assert_eq!(bus.slave(addrs[0]).state(), SlaveState::Configuration);
        // 1 bit check + 4 × (32 bits + 1 confirmation), every window waited out.
        assert_eq!(bus.sent.len(), 133);
        assert_eq!(
            bus.now,
            Instant::ZERO + FastscanConfig::DEFAULT_TIMEOUT.saturating_mul(133)
        );
    }
}

#[test]
fn fastscan_with_nobody_there_is_one_timeout() {
    let mut bus = Bus::new(Delivery::Merged);
    // A configured slave does not take part.
    let mut cfg = SlaveConfig::unconfigured(LssAddress::new(1, 2, 3, 4));
    cfg.node_id = 5;
    bus.add(cfg);
    let mut m = Fastscan::new(FastscanConfig::default());
    m.start(bus.now).unwrap();
    let (r, _) = bus.run(&mut m);
    assert_eq!(r, Ok(None));
    assert_eq!(bus.sent.len(), 1);
    assert_eq!(bus.now, Instant::ZERO + FastscanConfig::DEFAULT_TIMEOUT);
}

#[test]
fn fastscan_reports_a_slave_that_vanished() {
    // Answers the bit check, then never again: every bit reads 1 and the confirmation fails.
    let mut bus = Bus::new(Delivery::Merged);
    bus.scripts.push(Box::new(|r| match r {
        Request::Fastscan {
            bit_check: 0x80, ..
        } => Some(Response::IdentifySlave),
        _ => None,
    }));
    let mut m = Fastscan::new(fast(ResponsePolicy::FirstAnswer));
    m.start(bus.now).unwrap();
    let (r, _) = bus.run(&mut m);
    assert_eq!(
        r,
        Err(LssError::FastscanLost {
            part: AddressPart::Vendor
        })
    );
    match bus.sent.last().unwrap().1 {
        Request::Fastscan {
            id_number,
            bit_check,
            lss_sub,
            lss_next,
        } => {
            assert_eq!(
                (id_number, bit_check, lss_sub, lss_next),
                (u32::MAX, 0, 0, 1)
            );
        }
        r => panic!("{r:?}"),
    }
}

fn discover(n: usize, delivery: Delivery, policy: ResponsePolicy, seed: u64) {
    for real in [false, true] {
        discover_on(n, delivery, policy, seed, real);
    }
}

fn discover_on(n: usize, delivery: Delivery, policy: ResponsePolicy, seed: u64, real: bool) {
    let mut rng = Rng::new(seed);
    let addrs = random_addresses(&mut rng, n);
    let mut bus = Bus::with_slaves(delivery, &addrs, real);
    let mut m = DiscoverAll::new(fast(policy));
    m.start(bus.now).unwrap();
    let (r, events) = bus.run(&mut m);
    let found = r.unwrap();
    assert_eq!(found.len(), n, "{delivery:?} {policy:?}");
    let mut want = addrs.clone();
    want.sort();
    // Fastscan follows the numerically smallest remaining address.
    assert_eq!(found.as_slice(), want.as_slice());
    assert!(events.iter().all(|e| matches!(e, MasterEvent::Found(_))));
    // Everybody is back in waiting state, still unconfigured.
    for s in &bus.slaves {
        assert_eq!(s.state(), SlaveState::Waiting);
        assert!(s.is_unconfigured());
    }
    // The first scan is an ordinary one (133 exchanges); a successor search costs at most
    // 4 bit checks, 3 + 2 + 1 confirmations, 128 probes above the last address and one
    // ordinary scan's worth of search.
    let exchanges = bus.fastscans();
    assert!(exchanges > 133 * n as u64, "{exchanges}");
    assert!(
        exchanges <= 133 + n as u64 * (4 + 6 + 128 + 133),
        "{exchanges}"
    );
    if policy == ResponsePolicy::WholeWindow {
        // Every Fastscan exchange costs exactly one window.
        assert_eq!(
            bus.now,
            Instant::ZERO + Duration::from_millis(10).saturating_mul(exchanges)
        );
    }
}

#[test]
fn discover_all_1_2_20_slaves_every_delivery_and_policy() {
    for delivery in DELIVERIES {
        for policy in [ResponsePolicy::WholeWindow, ResponsePolicy::FirstAnswer] {
            if matches!(delivery, Delivery::Separate { .. })
                && policy == ResponsePolicy::FirstAnswer
            {
                continue; // covered below with a spread inside one frame time
            }
            for (n, seed) in [(1, 11), (2, 12), (20, 13)] {
                discover(n, delivery, policy, seed);
            }
        }
    }
    // FirstAnswer copes with separate duplicate frames that arrive before its next request.
    discover(
        20,
        Delivery::Separate {
            spread: Duration::ZERO,
        },
        ResponsePolicy::FirstAnswer,
        14,
    );
}

#[test]
fn whole_window_survives_late_duplicates() {
    // Answers spread over 8 ms of a 10 ms window: duplicates arrive long after the first.
    discover(
        20,
        Delivery::Separate {
            spread: Duration::from_millis(8),
        },
        ResponsePolicy::WholeWindow,
        15,
    );
}

#[test]
fn slaves_sharing_address_prefixes_are_told_apart() {
    // Same vendor and product, revisions and serials one bit apart.
    let addrs = [
        LssAddress::new(0x1F, 0x42, 1, 0x1000),
        LssAddress::new(0x1F, 0x42, 1, 0x1001),
        LssAddress::new(0x1F, 0x42, 2, 0x1000),
        LssAddress::new(0x1F, 0x43, 1, 0x1000),
        LssAddress::new(0, 0, 0, 0),
        LssAddress::new(u32::MAX, u32::MAX, u32::MAX, u32::MAX),
    ];
    for delivery in DELIVERIES {
        let mut bus = Bus::with_unconfigured(delivery, &addrs);
        let mut m = DiscoverAll::new(fast(ResponsePolicy::WholeWindow));
        m.start(bus.now).unwrap();
        let found = bus.run(&mut m).0.unwrap();
        let mut want = addrs.to_vec();
        want.sort();
        assert_eq!(found.as_slice(), want.as_slice());
    }
}

// ---------------------------------------------------------------------------------------------
// Assign-all workflow

fn assign_all(n: usize, delivery: Delivery, seed: u64, real: bool) {
    let mut rng = Rng::new(seed);
    let addrs = random_addresses(&mut rng, n);
    let mut bus = Bus::with_slaves(delivery, &addrs, real);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(2), id(100)));
    config.fastscan = fast(ResponsePolicy::WholeWindow);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let (r, events) = bus.run(&mut m);
    let report = r.unwrap();
    assert_eq!(report.stopped, None);
    assert_eq!(report.entries.len(), n);
    assert!(
        report
            .entries
            .iter()
            .all(|e| e.outcome == AssignOutcome::Assigned)
    );
    let ids: BTreeSet<u8> = report.assigned().map(|(_, id)| id.get()).collect();
    assert_eq!(ids.len(), n, "node-IDs are distinct");
    assert_eq!(
        ids.iter().copied().collect::<Vec<_>>(),
        (2..2 + n as u8).collect::<Vec<_>>()
    );
    let found: BTreeSet<LssAddress> = report.assigned().map(|(a, _)| a).collect();
    assert_eq!(found, addrs.iter().copied().collect());
    for (a, id) in report.assigned() {
        let s = bus.slave(a);
        assert_eq!(
            s.active_node_id(),
            id.get(),
            "node-ID active after leaving configuration"
        );
        assert_eq!(s.pending_node_id(), id.get());
        assert_eq!(s.state(), SlaveState::Waiting);
    }
    let assigned_events = events
        .iter()
        .filter(|e| matches!(e, MasterEvent::Progress(_)))
        .count();
    assert_eq!(assigned_events, n);
    // Every slave succeeded, so every scan was an ordinary one: n that found a slave and the
    // last bit check that found nobody.
    assert_eq!(bus.fastscans(), 133 * n as u64 + 1);
}

#[test]
fn assign_all_1_2_20_slaves() {
    for delivery in DELIVERIES {
        for (n, seed) in [(1, 21), (2, 22), (20, 23)] {
            assign_all(n, delivery, seed, false);
        }
    }
}

#[test]
fn assign_all_1_2_20_real_slaves_that_answer_fastscan_in_configuration() {
    for delivery in DELIVERIES {
        for (n, seed) in [(1, 24), (2, 25), (20, 26)] {
            assign_all(n, delivery, seed, true);
        }
    }
}

#[test]
fn assign_all_releases_slaves_left_in_configuration_first() {
    // A slave an earlier session configured (node-ID 5 pending) but left in configuration
    // state, and an unconfigured real slave. Were the configured one still in configuration
    // state when the scan puts the other one there, configure node-ID would reach both.
    for real in [false, true] {
        let left = LssAddress::new(1, 1, 1, 1);
        let new = LssAddress::new(2, 2, 2, 2);
        let mut bus = Bus::with_slaves(Delivery::Merged, &[left, new], real);
        bus.slaves[0].handle_request(bus.now, &Request::SwitchModeGlobal(Mode::Configuration));
        bus.slaves[0].handle_request(bus.now, &Request::ConfigureNodeId(5));
        assert_eq!(bus.slaves[0].state(), SlaveState::Configuration);
        let mut config = AssignConfig::with_pool(NodeIdPool::range(id(10), id(20)));
        config.fastscan = fast(ResponsePolicy::WholeWindow);
        let mut m = AssignAll::new(config);
        m.start(bus.now).unwrap();
        let report = bus.run(&mut m).0.unwrap();
        assert_eq!(report.assigned().collect::<Vec<_>>(), vec![(new, id(10))]);
        assert_eq!(bus.slave(left).active_node_id(), 5, "real: {real}");
        assert_eq!(bus.slave(new).active_node_id(), 10);
        assert_eq!(bus.sent[0].1, Request::SwitchModeGlobal(Mode::Waiting));
    }
}

#[test]
fn assign_all_skips_failed_real_slaves_in_later_scans() {
    // Real slaves left unconfigured (no node-ID to give, node-ID rejected) still answer
    // Fastscan: the workflow searches above them and ends.
    let mut rng = Rng::new(27);
    let mut addrs = random_addresses(&mut rng, 5);
    addrs.sort();
    let mut bus = Bus::with_real(Delivery::Merged, &addrs);
    let mut refusing = SlaveConfig::unconfigured_real(LssAddress::new(
        addrs[0].vendor_id,
        addrs[0].product_code,
        addrs[0].revision_number,
        addrs[0].serial_number ^ 1,
    ));
    refusing.node_id_vendor_error = Some(0x12);
    bus.add(refusing);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(3), id(6)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(report.stopped, None);
    assert_eq!(report.entries.len(), 6);
    let addresses: Vec<LssAddress> = report.entries.iter().map(|e| e.address).collect();
    let mut want = addresses.clone();
    want.sort();
    assert_eq!(addresses, want, "each slave found once, in ascending order");
    assert_eq!(report.assigned().count(), 3);
    let failed = report
        .entries
        .iter()
        .filter(|e| matches!(e.outcome, AssignOutcome::Failed(_)))
        .count();
    assert_eq!(failed, 3, "one refused, two without a node-ID");
    for s in &bus.slaves {
        assert_eq!(s.state(), SlaveState::Waiting);
    }
}

#[test]
fn assign_all_uses_the_table_first() {
    let mut rng = Rng::new(31);
    let addrs = random_addresses(&mut rng, 5);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(10), id(20)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    config.table.push((addrs[0], id(10))).unwrap(); // also in the pool: taken out of it
    config.table.push((addrs[3], id(77))).unwrap();
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    let got: std::collections::BTreeMap<LssAddress, u8> =
        report.assigned().map(|(a, i)| (a, i.get())).collect();
    assert_eq!(got[&addrs[0]], 10);
    assert_eq!(got[&addrs[3]], 77);
    let others: BTreeSet<u8> = [1, 2, 4].iter().map(|i| got[&addrs[*i]]).collect();
    assert_eq!(others, [11, 12, 13].into_iter().collect());
}

#[test]
fn assign_all_records_slaves_left_without_a_node_id() {
    let mut rng = Rng::new(41);
    let mut addrs = random_addresses(&mut rng, 4);
    addrs.sort();
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(5), id(6)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    // The largest address is in the table: it is configured although the pool ran dry before.
    config.table.push((addrs[3], id(50))).unwrap();
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(report.stopped, None);
    let outcomes: Vec<(LssAddress, Option<NodeId>, AssignOutcome)> = report
        .entries
        .iter()
        .map(|e| (e.address, e.node_id, e.outcome))
        .collect();
    assert_eq!(
        outcomes,
        vec![
            (addrs[0], Some(id(5)), AssignOutcome::Assigned),
            (addrs[1], Some(id(6)), AssignOutcome::Assigned),
            (
                addrs[2],
                None,
                AssignOutcome::Failed(LssError::NoFreeNodeId)
            ),
            (addrs[3], Some(id(50)), AssignOutcome::Assigned),
        ]
    );
    // The slave without a node-ID is back in waiting state, still unconfigured.
    assert_eq!(bus.slave(addrs[2]).state(), SlaveState::Waiting);
    assert!(bus.slave(addrs[2]).is_unconfigured());
    assert_eq!(bus.slave(addrs[3]).active_node_id(), 50);
    assert!(matches!(
        bus.sent.last().unwrap().1,
        Request::SwitchModeGlobal(Mode::Waiting)
    ));
}

#[test]
fn assign_all_records_store_failures_and_goes_on() {
    let mut rng = Rng::new(51);
    let addrs = random_addresses(&mut rng, 3);
    let mut bus = Bus::new(Delivery::Merged);
    let stores = [
        StoreSupport::NotSupported,
        StoreSupport::MediaError,
        StoreSupport::Vendor(0x21),
    ];
    for (a, store) in addrs.iter().zip(stores) {
        let mut c = SlaveConfig::unconfigured(*a);
        c.store = store;
        bus.add(c);
    }
    let mut config = AssignConfig::with_pool(NodeIdPool::all());
    config.fastscan = fast(ResponsePolicy::WholeWindow);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(report.stopped, None);
    assert_eq!(report.assigned().count(), 3);
    for e in &report.entries {
        let i = addrs.iter().position(|a| *a == e.address).unwrap();
        let error = match stores[i] {
            StoreSupport::NotSupported => ResponseError::NotSupported,
            StoreSupport::MediaError => ResponseError::StorageMediaAccess,
            StoreSupport::Vendor(x) => ResponseError::VendorSpecific(x),
            StoreSupport::Supported => unreachable!(),
        };
        assert_eq!(
            e.outcome,
            AssignOutcome::StoreFailed(LssError::Rejected {
                service: Service::StoreConfiguration,
                error
            })
        );
    }
}

#[test]
fn assign_all_goes_on_after_a_rejected_node_id() {
    let mut bus = Bus::new(Delivery::Merged);
    let a = LssAddress::new(7, 7, 7, 7);
    let b = LssAddress::new(8, 8, 8, 8);
    let mut c = SlaveConfig::unconfigured(a);
    c.node_id_vendor_error = Some(0x99);
    bus.add(c);
    bus.add(SlaveConfig::unconfigured(b));
    let mut config = AssignConfig::with_pool(NodeIdPool::all());
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    let e = LssError::Rejected {
        service: Service::ConfigureNodeId,
        error: ResponseError::VendorSpecific(0x99),
    };
    assert_eq!(report.stopped, None);
    assert_eq!(report.entries.len(), 2);
    assert_eq!(report.entries[0].address, a);
    assert_eq!(report.entries[0].outcome, AssignOutcome::Failed(e));
    assert_eq!(report.entries[1].address, b);
    assert_eq!(report.entries[1].outcome, AssignOutcome::Assigned);
    assert_eq!(bus.slave(a).state(), SlaveState::Waiting);
    assert!(bus.slave(a).is_unconfigured());
    // Node-ID 1 went to the slave that refused it; the next one got 2.
    assert_eq!(bus.slave(b).active_node_id(), 2);
}

#[test]
fn assign_all_reports_a_lost_scan_and_configures_the_found() {
    // A real slave, and a script that answers the bit check only: the first scan finds the real
    // slave (its answers cover the script's silence), the second loses the phantom.
    let a = LssAddress::new(1, 1, 1, 1);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    bus.scripts.push(Box::new(|r| match r {
        Request::Fastscan {
            bit_check: 0x80, ..
        } => Some(Response::IdentifySlave),
        _ => None,
    }));
    let mut config = AssignConfig::with_pool(NodeIdPool::all());
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(
        report.stopped,
        Some(LssError::FastscanLost {
            part: AddressPart::Vendor
        })
    );
    assert_eq!(report.assigned().collect::<Vec<_>>(), vec![(a, id(1))]);
}

/// A scripted unconfigured slave: a real slave's Fastscan answers, but a chosen answer to
/// configure node-ID (or none).
fn scripted_fastscan_slave(bus: &mut Bus, address: LssAddress, configure: Option<Response>) {
    let mut inner = LssSlave::new(SlaveConfig::unconfigured(address));
    bus.scripts.push(Box::new(move |r| match r {
        Request::ConfigureNodeId(_) => configure,
        _ => {
            inner.handle_request(Instant::ZERO, r);
            inner.poll_transmit()
        }
    }));
}

#[test]
fn assign_all_configure_node_id_invalid_and_timeout() {
    let a = LssAddress::new(1, 2, 3, 4);
    let cases = [
        (
            Some(Response::ConfigureNodeId(ConfigStatus {
                code: 1,
                extension: 0,
            })),
            LssError::Rejected {
                service: Service::ConfigureNodeId,
                error: ResponseError::NotSupported,
            },
        ),
        (
            None,
            LssError::Timeout {
                service: Service::ConfigureNodeId,
                timeout: Duration::from_millis(100),
            },
        ),
    ];
    for (answer, expect) in cases {
        let mut bus = Bus::new(Delivery::Merged);
        scripted_fastscan_slave(&mut bus, a, answer);
        let mut config = AssignConfig::with_pool(NodeIdPool::all());
        config.fastscan = fast(ResponsePolicy::FirstAnswer);
        let mut m = AssignAll::new(config);
        m.start(bus.now).unwrap();
        let report = bus.run(&mut m).0.unwrap();
        assert_eq!(report.stopped, None);
        assert_eq!(report.entries[0].outcome, AssignOutcome::Failed(expect));
        assert_eq!(report.entries[0].address, a);
        assert_eq!(report.entries[0].node_id, Some(id(1)));
    }
}

#[test]
fn assign_all_store_timeout_is_recorded() {
    let a = LssAddress::new(1, 2, 3, 4);
    let mut bus = Bus::new(Delivery::Merged);
    let mut inner = LssSlave::new(SlaveConfig::unconfigured(a));
    bus.scripts.push(Box::new(move |r| {
        inner.handle_request(Instant::ZERO, r);
        let answer = inner.poll_transmit();
        if matches!(r, Request::StoreConfiguration) {
            None
        } else {
            answer
        }
    }));
    let mut config = AssignConfig::with_pool(NodeIdPool::all());
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(report.stopped, None);
    assert_eq!(
        report.entries[0].outcome,
        AssignOutcome::StoreFailed(LssError::Timeout {
            service: Service::StoreConfiguration,
            timeout: Duration::from_secs(1)
        })
    );
}

// ---------------------------------------------------------------------------------------------
// Single services and the seed's procedures

fn run_procedure(
    bus: &mut Bus,
    p: Procedure,
) -> (
    Result<ServiceReport, LssError>,
    Vec<MasterEvent<ServiceReport>>,
) {
    let mut m = LssMaster::new(MasterConfig::default());
    m.start(bus.now, p).unwrap();
    bus.run(&mut m)
}

#[test]
fn seed_change_bit_rate() {
    let a = LssAddress::new(0x78, 1, 1, 1);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let t0 = bus.now;
    let (r, events) = run_procedure(
        &mut bus,
        Procedure::change_bit_rate(BitRate::Kbit125.into(), 50),
    );
    r.unwrap();
    assert_eq!(
        events,
        vec![MasterEvent::SwitchBitRate {
            bit_timing: BitRate::Kbit125.into(),
            at: t0 + Duration::from_micros(500) + Duration::from_millis(50)
        }]
    );
    let reqs: Vec<Request> = bus.sent.iter().map(|s| s.1).collect();
    assert_eq!(
        reqs,
        vec![
            Request::SwitchModeGlobal(Mode::Configuration),
            Request::ConfigureBitTiming(BitRate::Kbit125.into()),
            Request::ActivateBitTiming { delay_ms: 50 },
            Request::SwitchModeGlobal(Mode::Waiting),
        ]
    );
    // Switch mode global (waiting) goes out after both delays.
    assert_eq!(bus.sent[3].0 - bus.sent[2].0, Duration::from_millis(100));
    let s = bus.slave(a);
    assert_eq!(s.active_bit_timing(), BitRate::Kbit125.into());
    assert_eq!(s.state(), SlaveState::Waiting);
}

#[test]
fn bit_timing_not_supported_and_timeout() {
    let a = LssAddress::new(0x78, 1, 1, 1);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let (r, events) = run_procedure(
        &mut bus,
        Procedure::change_bit_rate(BitTiming { table: 0, index: 9 }, 10),
    );
    assert_eq!(
        r,
        Err(LssError::Rejected {
            service: Service::ConfigureBitTiming,
            error: ResponseError::NotSupported
        })
    );
    assert!(events.is_empty());
    assert_eq!(bus.sent.len(), 2, "nothing after the rejection");
    let mut bus = Bus::new(Delivery::Merged);
    let (r, _) = run_procedure(
        &mut bus,
        Procedure::change_bit_rate(BitRate::Kbit250.into(), 10),
    );
    assert_eq!(
        r,
        Err(LssError::Timeout {
            service: Service::ConfigureBitTiming,
            timeout: Duration::from_millis(100)
        })
    );
    assert_eq!(bus.now, Instant::from_millis(100));
}

#[test]
fn vendor_specific_bit_timing_error() {
    let mut bus = Bus::new(Delivery::Merged);
    bus.scripts.push(Box::new(|r| match r {
        Request::ConfigureBitTiming(_) => Some(Response::ConfigureBitTiming(ConfigStatus {
            code: 255,
            extension: 0x0E,
        })),
        _ => None,
    }));
    let (r, _) = run_procedure(
        &mut bus,
        Procedure::single(Step::ConfigureBitTiming(BitRate::Kbit10.into())),
    );
    assert_eq!(
        r,
        Err(LssError::Rejected {
            service: Service::ConfigureBitTiming,
            error: ResponseError::VendorSpecific(0x0E)
        })
    );
}

#[test]
fn seed_assign_node_id_global() {
    let a = LssAddress::new(0x78, 1, 1, 1);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(42), false));
    r.unwrap();
    let report = r.unwrap();
    let reqs: Vec<Request> = bus.sent.iter().map(|s| s.1).collect();
    // The seed's steps 1, 4, 5, with the check between 1 and 4 that one slave answers.
    assert_eq!(
        reqs,
        vec![
            Request::SwitchModeGlobal(Mode::Configuration),
            Request::InquireIdentity(AddressPart::Vendor),
            Request::InquireIdentity(AddressPart::Product),
            Request::InquireIdentity(AddressPart::Revision),
            Request::InquireIdentity(AddressPart::Serial),
            Request::ConfigureNodeId(42),
            Request::SwitchModeGlobal(Mode::Waiting),
        ]
    );
    assert_eq!(bus.slave(a).active_node_id(), 42);
    assert_eq!(report.address(), Some(a));
}

/// Switch mode global puts every LSS slave in configuration state (CiA 305), configured or
/// not, and each one answers configure node-ID: the global assignment refuses to configure
/// unless exactly one answers, and leaves them all in waiting state as it found them.
#[test]
fn global_assign_refuses_several_slaves_in_configuration() {
    let mut rng = Rng::new(62);
    let same_product = [
        LssAddress::new(0x39, 0x0100_0001, 1, 1001),
        LssAddress::new(0x39, 0x0100_0001, 1, 1002),
    ];
    let mut configured = SlaveConfig::unconfigured(LssAddress::new(0x39, 0x0100_0001, 1, 1003));
    configured.node_id = 5;
    for delivery in DELIVERIES {
        for (slaves, extra) in [
            (same_product.to_vec(), None),
            (random_addresses(&mut rng, 3), None),
            (same_product[..1].to_vec(), Some(configured)),
        ] {
            let mut bus = Bus::with_unconfigured(delivery, &slaves);
            if let Some(c) = extra {
                bus.add(c);
            }
            let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(9), true));
            let Err(LssError::SeveralSlaves {
                part,
                first,
                second,
            }) = r
            else {
                panic!("{delivery:?} {slaves:?}: {r:?}");
            };
            if delivery == Delivery::Merged {
                // Equal answers merge on the bus: two different values show the second slave.
                assert_ne!(first, second, "{part}");
            }
            let reqs: Vec<Request> = bus.sent.iter().map(|s| s.1).collect();
            assert!(
                !reqs
                    .iter()
                    .any(|r| matches!(r, Request::ConfigureNodeId(_))),
                "{reqs:?}"
            );
            assert_eq!(reqs.last(), Some(&Request::SwitchModeGlobal(Mode::Waiting)));
            for s in &bus.slaves {
                assert_eq!(s.state(), SlaveState::Waiting);
                assert_ne!(s.pending_node_id(), 9);
            }
        }
    }
    // The error says what was found, and what it would have done.
    let e = LssError::SeveralSlaves {
        part: AddressPart::Serial,
        first: 1001,
        second: 1002,
    };
    assert_eq!(
        e.to_string(),
        "several LSS slaves are in configuration state (inquire serial number was answered \
         with 0x000003E9 and 0x000003EA): one node-ID would go to each of them"
    );
}

#[test]
fn selective_assign_touches_only_its_slave() {
    let mut rng = Rng::new(61);
    let addrs = random_addresses(&mut rng, 3);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let (r, _) = run_procedure(
        &mut bus,
        Procedure::assign_node_id_selective(addrs[1], id(9), true),
    );
    r.unwrap();
    assert_eq!(bus.slave(addrs[1]).active_node_id(), 9);
    assert!(bus.slave(addrs[0]).is_unconfigured());
    assert!(bus.slave(addrs[2]).is_unconfigured());
    // Inquire it back.
    let p = Procedure::single(Step::SwitchModeSelective(addrs[1]));
    let p = Procedure::inquire_all()
        .steps()
        .iter()
        .fold(p, |p, s| p.then(*s).unwrap());
    let p = p.then(Step::SwitchModeGlobal(Mode::Waiting)).unwrap();
    let report = run_procedure(&mut bus, p).0.unwrap();
    assert_eq!(report.address(), Some(addrs[1]));
    assert_eq!(report.node_id, Some(9));
    // A wrong address: nobody answers the selective switch.
    let mut wrong = addrs[1];
    wrong.serial_number ^= 1;
    let (r, _) = run_procedure(
        &mut bus,
        Procedure::assign_node_id_selective(wrong, id(10), false),
    );
    assert_eq!(
        r,
        Err(LssError::Timeout {
            service: Service::SwitchModeSelective,
            timeout: Duration::from_millis(100)
        })
    );
}

#[test]
fn unconfigure_makes_a_slave_findable_again() {
    let a = LssAddress::new(5, 6, 7, 8);
    let mut c = SlaveConfig::unconfigured(a);
    c.node_id = 12;
    let mut bus = Bus::new(Delivery::Merged);
    bus.add(c);
    let (r, _) = run_procedure(&mut bus, Procedure::unconfigure_selective(a));
    r.unwrap();
    assert_eq!(bus.slave(a).pending_node_id(), 0xFF);
    // Still active until NMT reset communication.
    assert_eq!(bus.slave(a).active_node_id(), 12);
    bus.slaves[0].reset_communication();
    let mut m = Fastscan::new(fast(ResponsePolicy::FirstAnswer));
    m.start(bus.now).unwrap();
    assert_eq!(bus.run(&mut m).0, Ok(Some(a)));
}

#[test]
fn store_error_paths() {
    let a = LssAddress::new(1, 1, 1, 1);
    for (store, error) in [
        (StoreSupport::NotSupported, ResponseError::NotSupported),
        (StoreSupport::MediaError, ResponseError::StorageMediaAccess),
        (
            StoreSupport::Vendor(0xAB),
            ResponseError::VendorSpecific(0xAB),
        ),
    ] {
        let mut c = SlaveConfig::unconfigured(a);
        c.store = store;
        let mut bus = Bus::new(Delivery::Merged);
        bus.add(c);
        let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(3), true));
        if store == StoreSupport::NotSupported {
            // Assigned, not stored: the procedure goes on and the node-ID takes effect.
            assert_eq!(r.unwrap().stored, Some(false));
            assert_eq!(bus.slave(a).state(), SlaveState::Waiting);
            assert_eq!(bus.slave(a).active_node_id(), 3);
            continue;
        }
        assert_eq!(
            r,
            Err(LssError::Rejected {
                service: Service::StoreConfiguration,
                error
            })
        );
        // The procedure stopped before switch mode global (waiting).
        assert_eq!(bus.slave(a).state(), SlaveState::Configuration);
    }
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(3), true));
    assert_eq!(r.unwrap().stored, Some(true));
    let mut bus = Bus::new(Delivery::Merged);
    let (r, _) = run_procedure(&mut bus, Procedure::single(Step::StoreConfiguration));
    assert_eq!(
        r,
        Err(LssError::Timeout {
            service: Service::StoreConfiguration,
            timeout: Duration::from_secs(1)
        })
    );
}

#[test]
fn configure_node_id_errors() {
    let a = LssAddress::new(1, 1, 1, 1);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let p = Procedure::single(Step::SwitchModeGlobal(Mode::Configuration))
        .then(Step::ConfigureNodeId(0))
        .unwrap();
    let (r, _) = run_procedure(&mut bus, p);
    assert_eq!(
        r,
        Err(LssError::Rejected {
            service: Service::ConfigureNodeId,
            error: ResponseError::NotSupported
        })
    );
    let mut c = SlaveConfig::unconfigured(a);
    c.node_id_vendor_error = Some(3);
    let mut bus = Bus::new(Delivery::Merged);
    bus.add(c);
    let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(4), false));
    assert_eq!(
        r,
        Err(LssError::Rejected {
            service: Service::ConfigureNodeId,
            error: ResponseError::VendorSpecific(3)
        })
    );
    // Nobody there: the check that one slave is in configuration state hears nothing.
    let mut bus = Bus::new(Delivery::Merged);
    let (r, _) = run_procedure(&mut bus, Procedure::assign_node_id(id(4), false));
    assert_eq!(
        r,
        Err(LssError::Timeout {
            service: Service::InquireIdentity(AddressPart::Vendor),
            timeout: Duration::from_millis(100)
        })
    );
    let (r, _) = run_procedure(
        &mut bus,
        Procedure::single(Step::SwitchModeGlobal(Mode::Configuration))
            .then(Step::ConfigureNodeId(4))
            .unwrap(),
    );
    assert_eq!(
        r,
        Err(LssError::Timeout {
            service: Service::ConfigureNodeId,
            timeout: Duration::from_millis(100)
        })
    );
}

#[test]
fn inquire_timeouts() {
    for step in [
        Step::InquireIdentity(AddressPart::Product),
        Step::InquireNodeId,
    ] {
        let mut bus = Bus::new(Delivery::Merged);
        let (r, _) = run_procedure(&mut bus, Procedure::single(step));
        let service = match step {
            Step::InquireNodeId => Service::InquireNodeId,
            _ => Service::InquireIdentity(AddressPart::Product),
        };
        assert_eq!(
            r,
            Err(LssError::Timeout {
                service,
                timeout: Duration::from_millis(100)
            })
        );
    }
}

#[test]
fn identify_services_report_presence() {
    let mut rng = Rng::new(71);
    let addrs = random_addresses(&mut rng, 4);
    for delivery in DELIVERIES {
        let mut bus = Bus::with_unconfigured(delivery, &addrs);
        let r = run_procedure(&mut bus, Procedure::single(Step::IdentifyNonConfigured))
            .0
            .unwrap();
        assert_eq!(r.present, Some(true));
        let q = IdentifyQuery {
            vendor_id: addrs[2].vendor_id,
            product_code: addrs[2].product_code,
            revision: Range::ALL,
            serial: Range::exactly(addrs[2].serial_number),
        };
        let r = run_procedure(&mut bus, Procedure::single(Step::IdentifyRemoteSlave(q)))
            .0
            .unwrap();
        assert_eq!(r.present, Some(true));
        let q = IdentifyQuery {
            serial: Range::exactly(addrs[2].serial_number ^ 1),
            ..q
        };
        let r = run_procedure(&mut bus, Procedure::single(Step::IdentifyRemoteSlave(q)))
            .0
            .unwrap();
        assert_eq!(r.present, Some(false));
    }
    let mut bus = Bus::new(Delivery::Merged);
    let r = run_procedure(&mut bus, Procedure::single(Step::IdentifyNonConfigured))
        .0
        .unwrap();
    assert_eq!(r.present, Some(false));
}

#[test]
fn busy_master_refuses_a_second_procedure() {
    let mut m = LssMaster::new(MasterConfig::default());
    m.start(Instant::ZERO, Procedure::single(Step::InquireNodeId))
        .unwrap();
    assert_eq!(
        m.start(Instant::ZERO, Procedure::single(Step::InquireNodeId)),
        Err(LssError::Busy)
    );
    let mut p = Procedure::new();
    for _ in 0..canola_lss::service::MAX_STEPS {
        p = p.then(Step::InquireNodeId).unwrap();
    }
    assert!(matches!(
        p.then(Step::InquireNodeId),
        Err(LssError::InvalidConfig(_))
    ));
}

// ---------------------------------------------------------------------------------------------
// Slowscan

#[test]
fn slowscan_finds_every_matching_slave() {
    let mut rng = Rng::new(81);
    let vendor = 0x0000_0078;
    let product = 0x0000_1234;
    let mut want = Vec::new();
    let mut bus = Bus::new(DELIVERIES[1]);
    for i in 0..20 {
        let a = LssAddress::new(vendor, product, (rng.below(3)) as u32, rng.next_u32());
        let mut c = SlaveConfig::unconfigured(a);
        if i % 3 == 0 {
            c.node_id = (i + 1) as u8; // configured slaves are found too
        }
        bus.add(c);
        want.push(a);
    }
    // Another product with equal serials must not show up.
    bus.add(SlaveConfig::unconfigured(LssAddress::new(
        vendor,
        product + 1,
        0,
        want[0].serial_number,
    )));
    let mut config = SlowscanConfig::product(vendor, product);
    config.response_timeout = Duration::from_millis(10);
    let mut m = Slowscan::new(config);
    m.start(bus.now).unwrap();
    let (r, events) = bus.run(&mut m);
    let found = r.unwrap();
    want.sort_by_key(|a| (a.serial_number, a.revision_number));
    assert_eq!(found.as_slice(), want.as_slice());
    assert_eq!(events.len(), 20);
}

#[test]
fn slowscan_ranges() {
    let addrs = [
        LssAddress::new(1, 2, 5, 100),
        LssAddress::new(1, 2, 6, 100),
        LssAddress::new(1, 2, 5, 101),
        LssAddress::new(1, 2, 5, 300),
    ];
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = SlowscanConfig::product(1, 2);
    config.revision = Range { low: 5, high: 5 };
    config.serial = Range {
        low: 100,
        high: 200,
    };
    config.policy = ResponsePolicy::FirstAnswer;
    let mut m = Slowscan::new(config);
    m.start(bus.now).unwrap();
    let found = bus.run(&mut m).0.unwrap();
    assert_eq!(found.as_slice(), &[addrs[0], addrs[2]]);
    config.serial = Range { low: 5, high: 4 };
    assert!(matches!(
        Slowscan::new(config).start(bus.now),
        Err(LssError::InvalidConfig(_))
    ));
    // Nobody there: a single probe.
    let mut bus = Bus::new(Delivery::Merged);
    let mut m = Slowscan::new(SlowscanConfig::product(1, 2));
    m.start(bus.now).unwrap();
    assert_eq!(bus.run(&mut m).0.unwrap().len(), 0);
    assert_eq!(bus.sent.len(), 6);
}

// ---------------------------------------------------------------------------------------------
// The figure for the issue note

/// Simulated time for Fastscan to find 20 slaves of random addresses, and for the assign-all
/// workflow to commission them, under several response timeouts. Run with `--nocapture` to see
/// the table. Answers arrive 0.5 ms after each request (bus model).
#[test]
fn fastscan_timing_figure() {
    let mut rng = Rng::new(2026);
    let mut addrs = random_addresses(&mut rng, 20);
    // One vendor (Bürkert's CiA vendor-ID is 0x78), random product, revision, serial.
    for a in &mut addrs {
        a.vendor_id = 0x78;
    }
    println!(
        "20 real slaves\ntimeout  policy        vendor   discover-20 [s]  assign-20 [s]  Fastscan requests(discover)"
    );
    for (timeout_ms, policy, known_vendor) in [
        (25, ResponsePolicy::WholeWindow, false),
        (25, ResponsePolicy::FirstAnswer, false),
        (25, ResponsePolicy::WholeWindow, true),
        (10, ResponsePolicy::WholeWindow, false),
        (5, ResponsePolicy::WholeWindow, false),
        (5, ResponsePolicy::FirstAnswer, false),
        (5, ResponsePolicy::FirstAnswer, true),
    ] {
        let config = FastscanConfig {
            response_timeout: Duration::from_millis(timeout_ms),
            policy,
            known: [known_vendor.then_some(0x78), None, None, None],
            skip: [false; 4],
        };
        let mut bus = Bus::with_real(Delivery::Merged, &addrs);
        let mut m = DiscoverAll::new(config);
        m.start(bus.now).unwrap();
        assert_eq!(bus.run(&mut m).0.unwrap().len(), 20);
        let discover = bus.now - Instant::ZERO;
        let requests = bus.fastscans();
        let exchanges = requests;
        let all_windows = Duration::from_millis(timeout_ms).saturating_mul(exchanges);
        if policy == ResponsePolicy::WholeWindow {
            assert_eq!(discover, all_windows);
        } else {
            assert!(discover < all_windows);
        }

        let mut bus = Bus::with_real(Delivery::Merged, &addrs);
        let mut assign = AssignConfig::with_pool(NodeIdPool::all());
        assign.fastscan = config;
        let mut m = AssignAll::new(assign);
        m.start(bus.now).unwrap();
        assert_eq!(bus.run(&mut m).0.unwrap().assigned().count(), 20);
        let commission = bus.now - Instant::ZERO;
        println!(
            "{timeout_ms:>4} ms  {policy:<12?}  {:<7}  {:>15.3}  {:>13.3}  {requests}",
            if known_vendor { "known" } else { "search" },
            discover.as_micros() as f64 / 1e6,
            commission.as_micros() as f64 / 1e6
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Properties

mod props {
    use super::*;
    use proptest::prelude::*;

    /// Addresses drawn from few values, so that slaves share long prefixes.
    fn address() -> impl Strategy<Value = LssAddress> {
        let part = prop_oneof![
            Just(0u32),
            Just(1),
            Just(0x8000_0000),
            Just(u32::MAX),
            any::<u32>()
        ];
        (part.clone(), part.clone(), part.clone(), part)
            .prop_map(|(v, p, r, s)| LssAddress::new(v, p, r, s))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// Discover-all and assign-all find exactly the unconfigured slaves, however their
        /// addresses collide, and assign-all never repeats a node-ID.
        #[test]
        fn scans_find_exactly_the_unconfigured(
            addrs in proptest::collection::btree_set(address(), 1..6),
            configured in proptest::collection::vec(address(), 0..3),
            merged in any::<bool>(),
            real in any::<bool>(),
        ) {
            let delivery = if merged { DELIVERIES[0] } else { DELIVERIES[1] };
            let addrs: Vec<LssAddress> = addrs.into_iter().collect();
            let mut bus = Bus::with_slaves(delivery, &addrs, real);
            for (i, a) in configured.iter().enumerate() {
                let mut c = SlaveConfig::unconfigured(*a);
                c.node_id = 100 + i as u8;
                bus.add(c);
            }
            let mut m = DiscoverAll::new(fast(ResponsePolicy::WholeWindow));
            m.start(bus.now).unwrap();
            let found = bus.run(&mut m).0.unwrap();
            prop_assert_eq!(found.as_slice(), addrs.as_slice());

            let mut config = AssignConfig::with_pool(NodeIdPool::range(id(1), id(99)));
            config.fastscan = fast(ResponsePolicy::WholeWindow);
            let mut m = AssignAll::new(config);
            m.start(bus.now).unwrap();
            let report = bus.run(&mut m).0.unwrap();
            prop_assert_eq!(report.stopped, None);
            let got: Vec<LssAddress> = report.assigned().map(|(a, _)| a).collect();
            prop_assert_eq!(got.as_slice(), addrs.as_slice());
            let ids: BTreeSet<NodeId> = report.assigned().map(|(_, i)| i).collect();
            prop_assert_eq!(ids.len(), addrs.len());
        }
    }

    /// A scan of each part that selects a slave: the vendor-ID searched or known, the other
    /// parts searched, known (from the same few values as the addresses) or skipped, not all
    /// skipped.
    fn parts() -> impl Strategy<Value = [Part; 4]> {
        let value = prop_oneof![Just(0u32), Just(1), Just(0x8000_0000), Just(u32::MAX)];
        let vendor = prop_oneof![
            2 => Just(Part::Scan),
            1 => value.clone().prop_map(Part::Known)
        ];
        let other = prop_oneof![
            2 => Just(Part::Scan),
            1 => Just(Part::Skip),
            1 => value.prop_map(Part::Known)
        ];
        (vendor, other.clone(), other.clone(), other)
            .prop_map(|(v, p, r, s)| [v, p, r, s])
            .prop_filter("one part after the vendor-ID named", |p| {
                p[1..].iter().any(|x| *x != Part::Skip)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// With any mix of searched, known and skipped parts, discover-all finds each slave
        /// with the known values once, as Fastscan tells them apart (skipped parts 0), in
        /// ascending order; assign-all gives each such slave a node-ID and no other slave one
        /// (slaves that differ only in skipped parts, selected together, share theirs).
        #[test]
        fn scans_with_known_and_skipped_parts(
            addrs in proptest::collection::btree_set(address(), 1..7),
            parts in parts(),
            merged in any::<bool>(),
            real in any::<bool>(),
            first_answer in any::<bool>(),
        ) {
            let delivery = if merged { DELIVERIES[0] } else { DELIVERIES[1] };
            let addrs: Vec<LssAddress> = addrs.into_iter().collect();
            let want = expected(&addrs, parts);
            let mut config = scan_config(parts);
            // Moving on at the first answer is only safe where simultaneous answers merge
            // (a late duplicate would be taken for the next request's answer).
            if first_answer && merged {
                config.policy = ResponsePolicy::FirstAnswer;
            }
            let mut bus = Bus::with_slaves(delivery, &addrs, real);
            let mut m = DiscoverAll::new(config);
            m.start(bus.now).unwrap();
            let found = bus.run(&mut m).0.unwrap();
            prop_assert_eq!(found.as_slice(), want.as_slice());

            let mut assign = AssignConfig::with_pool(NodeIdPool::range(id(1), id(99)));
            assign.fastscan = config;
            let mut m = AssignAll::new(assign);
            m.start(bus.now).unwrap();
            let report = bus.run(&mut m).0.unwrap();
            prop_assert_eq!(report.stopped, None);
            let got: Vec<LssAddress> = report.assigned().map(|(a, _)| a).collect();
            prop_assert_eq!(got.as_slice(), want.as_slice());
            for s in &bus.slaves {
                let seen = expected(&[s.address()], parts);
                let node = report
                    .assigned()
                    .find(|(a, _)| seen.first() == Some(a))
                    .map_or(0xFF, |(_, n)| n.get());
                prop_assert_eq!(s.active_node_id(), node);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// The successor search finds every real slave once, in ascending order, from any
        /// starting scan, however the addresses share prefixes.
        #[test]
        fn discover_all_finds_each_real_slave_once(
            addrs in proptest::collection::btree_set(address(), 1..8),
        ) {
            let addrs: Vec<LssAddress> = addrs.into_iter().collect();
            let mut bus = Bus::with_real(Delivery::Merged, &addrs);
            let mut m = DiscoverAll::new(fast(ResponsePolicy::FirstAnswer));
            m.start(bus.now).unwrap();
            let found = bus.run(&mut m).0.unwrap();
            prop_assert_eq!(found.as_slice(), addrs.as_slice());
            prop_assert!(bus.fastscans() <= 133 + addrs.len() as u64 * (4 + 6 + 128 + 133));
        }
    }
}

#[test]
fn known_vendor_and_product_are_confirmed_not_searched() {
    let mut rng = Rng::new(91);
    let mut addrs = random_addresses(&mut rng, 6);
    for a in addrs.iter_mut().take(4) {
        a.vendor_id = 0x78;
        a.product_code = 0x42;
    }
    addrs[4].vendor_id = 0x78; // same vendor, other product: not wanted
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = fast(ResponsePolicy::WholeWindow);
    config.known = [Some(0x78), Some(0x42), None, None];
    let mut m = DiscoverAll::new(config);
    m.start(bus.now).unwrap();
    let found = bus.run(&mut m).0.unwrap();
    let mut want = addrs[..4].to_vec();
    want.sort();
    assert_eq!(found.as_slice(), want.as_slice());
    // Vendor-ID and product code are only ever confirmed (bit check 0), never searched.
    for (_, r) in &bus.sent {
        if let Request::Fastscan {
            bit_check, lss_sub, ..
        } = *r
        {
            assert!(lss_sub >= 2 || bit_check == 0 || bit_check == 0x80, "{r}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Known parts after searched ones, skipped parts

/// Per part: searched, known (this value) or skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Scan,
    Known(u32),
    Skip,
}

fn scan_config(parts: [Part; 4]) -> FastscanConfig {
    let mut c = fast(ResponsePolicy::WholeWindow);
    for (i, p) in parts.iter().enumerate() {
        match *p {
            Part::Scan => {}
            Part::Known(v) => c.known[i] = Some(v),
            Part::Skip => c.skip[i] = true,
        }
    }
    c
}

/// What a scan with `parts` finds of `addrs`: the slaves with the known values, with their
/// skipped parts 0, in ascending order, each once.
fn expected(addrs: &[LssAddress], parts: [Part; 4]) -> Vec<LssAddress> {
    let mut want: BTreeSet<LssAddress> = BTreeSet::new();
    'slave: for a in addrs {
        let mut p = *a;
        for (part, mode) in AddressPart::ALL.iter().zip(parts) {
            match mode {
                Part::Scan => {}
                Part::Known(v) if a.get(*part) == v => {}
                Part::Known(_) => continue 'slave,
                Part::Skip => p.set(*part, 0),
            }
        }
        want.insert(p);
    }
    want.into_iter().collect()
}

/// The Fastscan requests' (`LSSSub`, `BitChecked`, `LSSNext`), bit checks left out.
fn fastscan_fields(bus: &Bus) -> Vec<(u8, u8, u8)> {
    bus.sent
        .iter()
        .filter_map(|(_, r)| match *r {
            Request::Fastscan {
                bit_check,
                lss_sub,
                lss_next,
                ..
            } if bit_check != 0x80 => Some((lss_sub, bit_check, lss_next)),
            _ => None,
        })
        .collect()
}

#[test]
fn known_part_after_a_searched_one_is_confirmed_not_searched() {
    let a = LssAddress::new(0x78, 0x42, 7, 0xCAFE);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let parts = [Part::Scan, Part::Known(0x42), Part::Scan, Part::Scan];
    let mut m = Fastscan::new(scan_config(parts));
    m.start(bus.now).unwrap();
    assert_eq!(bus.run(&mut m).0, Ok(Some(a)));
    // 133 less the product code's 32 bits.
    assert_eq!(bus.sent.len(), 101);
    let product: Vec<_> = fastscan_fields(&bus)
        .into_iter()
        .filter(|f| f.0 == 1)
        .collect();
    assert_eq!(product, vec![(1, 0, 2)]);
    assert_eq!(bus.slave(a).state(), SlaveState::Configuration);
}

#[test]
fn known_part_after_a_searched_one_finds_only_the_wanted_slaves() {
    // The smallest vendor-IDs belong to slaves of other products, so the search first follows
    // slaves that the known product code then turns away. Some addresses differ only in the
    // known part.
    let addrs = [
        LssAddress::new(0x10, 0x41, 1, 5),
        LssAddress::new(0x10, 0x43, 1, 5),
        LssAddress::new(0x20, 0x42, 1, 5),
        LssAddress::new(0x20, 0x41, 1, 5),
        LssAddress::new(0x20, 0x42, 2, 5),
        LssAddress::new(0x30, 0x44, 9, 9),
        LssAddress::new(0x40, 0x42, 0, 0),
        LssAddress::new(0x40, 0x43, 0, 0),
    ];
    let parts = [Part::Scan, Part::Known(0x42), Part::Scan, Part::Scan];
    let want = expected(&addrs, parts);
    assert_eq!(want.len(), 3);
    for delivery in DELIVERIES {
        for real in [false, true] {
            let mut bus = Bus::with_slaves(delivery, &addrs, real);
            let mut m = DiscoverAll::new(scan_config(parts));
            m.start(bus.now).unwrap();
            let found = bus.run(&mut m).0.unwrap();
            assert_eq!(
                found.as_slice(),
                want.as_slice(),
                "{delivery:?} real {real}"
            );
            // The product code is only ever confirmed.
            assert!(fastscan_fields(&bus).iter().all(|f| f.0 != 1 || f.1 == 0));

            let mut config = AssignConfig::with_pool(NodeIdPool::range(id(2), id(127)));
            config.fastscan = scan_config(parts);
            let mut m = AssignAll::new(config);
            m.start(bus.now).unwrap();
            let report = bus.run(&mut m).0.unwrap();
            assert_eq!(report.stopped, None);
            let got: Vec<(LssAddress, u8)> = report.assigned().map(|(a, n)| (a, n.get())).collect();
            assert_eq!(got, vec![(want[0], 2), (want[1], 3), (want[2], 4)]);
            for s in &bus.slaves {
                let wanted = want.iter().position(|w| *w == s.address());
                let node = wanted.map_or(0xFF, |i| 2 + i as u8);
                assert_eq!(s.active_node_id(), node, "{}", s.address());
            }
        }
    }
}

#[test]
fn skipped_part_is_never_named() {
    let a = LssAddress::new(0x78, 0x42, 7, 0xCAFE);
    for (skipped, next_after) in [
        (AddressPart::Product, (0, 2)),
        (AddressPart::Revision, (1, 3)),
    ] {
        let mut parts = [Part::Scan; 4];
        parts[usize::from(skipped.index())] = Part::Skip;
        let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
        let mut m = Fastscan::new(scan_config(parts));
        m.start(bus.now).unwrap();
        let mut want = a;
        want.set(skipped, 0);
        assert_eq!(bus.run(&mut m).0, Ok(Some(want)));
        assert_eq!(bus.sent.len(), 1 + 3 * 33);
        let fields = fastscan_fields(&bus);
        assert!(
            fields
                .iter()
                .all(|f| f.0 != skipped.index() && f.2 != skipped.index())
        );
        // The confirmation before the skipped part names the part after it.
        let confirms: Vec<(u8, u8)> = fields
            .iter()
            .filter(|f| f.1 == 0 && f.0 != f.2)
            .map(|f| (f.0, f.2))
            .collect();
        assert!(confirms.contains(&next_after), "{confirms:?}");
        assert_eq!(confirms.last(), Some(&(3, 0)));
        assert_eq!(bus.slave(a).state(), SlaveState::Configuration);
    }
    // Serial number skipped: confirming the revision number with LSSNext = vendor-ID selects.
    let parts = [Part::Known(0x78), Part::Scan, Part::Scan, Part::Skip];
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let mut m = Fastscan::new(scan_config(parts));
    m.start(bus.now).unwrap();
    assert_eq!(
        bus.run(&mut m).0,
        Ok(Some(LssAddress::new(0x78, 0x42, 7, 0)))
    );
    assert_eq!(bus.sent.len(), 1 + 1 + 2 * 33);
    assert_eq!(fastscan_fields(&bus).last(), Some(&(2, 0, 0)));
    assert_eq!(bus.slave(a).state(), SlaveState::Configuration);
}

#[test]
fn slaves_differing_only_in_a_skipped_part_are_one_to_fastscan() {
    // What real slaves do: they compare only the parts named, so the scan selects both.
    let a = LssAddress::new(0x78, 0x42, 1, 0xCAFE);
    let b = LssAddress::new(0x78, 0x42, 2, 0xCAFE);
    let c = LssAddress::new(0x78, 0x42, 2, 0xCAFF);
    let parts = [Part::Scan, Part::Scan, Part::Skip, Part::Scan];
    for real in [false, true] {
        let mut bus = Bus::with_slaves(Delivery::Merged, &[a, b, c], real);
        let mut m = Fastscan::new(scan_config(parts));
        m.start(bus.now).unwrap();
        assert_eq!(
            bus.run(&mut m).0,
            Ok(Some(LssAddress::new(0x78, 0x42, 0, 0xCAFE)))
        );
        assert_eq!(bus.slave(a).state(), SlaveState::Configuration);
        assert_eq!(bus.slave(b).state(), SlaveState::Configuration);
        assert_eq!(bus.slave(c).state(), SlaveState::Waiting);

        let mut bus = Bus::with_slaves(Delivery::Merged, &[a, b, c], real);
        let mut m = DiscoverAll::new(scan_config(parts));
        m.start(bus.now).unwrap();
        let found = bus.run(&mut m).0.unwrap();
        assert_eq!(found.as_slice(), expected(&[a, b, c], parts).as_slice());
        assert_eq!(found.len(), 2);
    }
}

/// Side-by-side figures: Fastscan requests to discover and to commission 20 wanted real
/// slaves (vendor-ID 0x78, product code 0x42) among 10 of other products, per scan type mix.
#[test]
fn scan_type_figure() {
    let mut rng = Rng::new(5);
    let mut addrs = random_addresses(&mut rng, 30);
    for (i, a) in addrs.iter_mut().enumerate() {
        a.vendor_id = 0x78;
        a.product_code = if i < 20 { 0x42 } else { 0x40 + (i as u32 % 3) };
    }
    println!(
        "20 wanted of 30 real slaves\nvendor  product  revision  serial   discover  assign  (Fastscan requests)"
    );
    let k = |v| Part::Known(v);
    for parts in [
        [Part::Scan, Part::Scan, Part::Scan, Part::Scan],
        [k(0x78), k(0x42), Part::Scan, Part::Scan],
        [Part::Scan, k(0x42), Part::Scan, Part::Scan],
        [k(0x78), k(0x42), Part::Skip, Part::Scan],
        [Part::Scan, k(0x42), Part::Skip, Part::Scan],
    ] {
        let config = scan_config(parts);
        let want = expected(&addrs, parts);
        let mut bus = Bus::with_real(Delivery::Merged, &addrs);
        let mut m = DiscoverAll::new(config);
        m.start(bus.now).unwrap();
        assert_eq!(bus.run(&mut m).0.unwrap().as_slice(), want.as_slice());
        let discover = bus.fastscans();
        let mut bus = Bus::with_real(Delivery::Merged, &addrs);
        let mut assign = AssignConfig::with_pool(NodeIdPool::all());
        assign.fastscan = config;
        let mut m = AssignAll::new(assign);
        m.start(bus.now).unwrap();
        assert_eq!(bus.run(&mut m).0.unwrap().assigned().count(), want.len());
        let name = |p: Part| match p {
            Part::Scan => "search",
            Part::Known(_) => "known",
            Part::Skip => "skip",
        };
        println!(
            "{:<7} {:<8} {:<9} {:<8} {discover:>8} {:>7}",
            name(parts[0]),
            name(parts[1]),
            name(parts[2]),
            name(parts[3]),
            bus.fastscans()
        );
    }
}

#[test]
fn scans_that_cannot_select_a_slave_are_refused() {
    for parts in [
        [Part::Skip, Part::Scan, Part::Scan, Part::Scan],
        [Part::Scan, Part::Skip, Part::Skip, Part::Skip],
        [Part::Known(1), Part::Skip, Part::Skip, Part::Skip],
    ] {
        let config = scan_config(parts);
        assert!(matches!(config.validate(), Err(LssError::InvalidConfig(_))));
        assert!(matches!(
            Fastscan::new(config).start(Instant::ZERO),
            Err(LssError::InvalidConfig(_))
        ));
        assert!(matches!(
            DiscoverAll::new(config).start(Instant::ZERO),
            Err(LssError::InvalidConfig(_))
        ));
        let mut assign = AssignConfig::with_pool(NodeIdPool::all());
        assign.fastscan = config;
        assert!(matches!(
            AssignAll::new(assign).start(Instant::ZERO),
            Err(LssError::InvalidConfig(_))
        ));
    }
    let mut both = fast(ResponsePolicy::WholeWindow);
    both.known[2] = Some(1);
    both.skip[2] = true;
    assert!(matches!(both.validate(), Err(LssError::InvalidConfig(_))));
    assert_eq!(
        scan_config([Part::Scan, Part::Skip, Part::Skip, Part::Known(3)]).validate(),
        Ok(())
    );
}

/// Fastscan for one slave as a frame transcript with timestamps: answered exchanges take the
/// 0.5 ms answer latency, silent ones (a 1 bit) the 10 ms timeout.
#[test]
fn fastscan_transcript() {
    let a = LssAddress::new(0x78, 1, 2, 3);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[a]);
    let mut m = Fastscan::new(fast(ResponsePolicy::FirstAnswer));
    m.start(bus.now).unwrap();
    assert_eq!(bus.run(&mut m).0, Ok(Some(a)));
    let frames: Vec<(u64, [u8; 8])> = bus
        .sent
        .iter()
        .map(|(t, r)| (t.as_micros(), r.to_frame().data().try_into().unwrap()))
        .collect();
    assert_eq!(frames[0], (0, [0x51, 0, 0, 0, 0, 0x80, 0, 0]));
    assert_eq!(frames[1], (500, [0x51, 0, 0, 0, 0, 31, 0, 0]));
    assert_eq!(frames[2], (1000, [0x51, 0, 0, 0, 0, 30, 0, 0]));
    // Bits 31..7 of 0x78 are 0 (answered); bit 6 is 1: its request goes unanswered.
    assert_eq!(frames[26], (13_000, [0x51, 0, 0, 0, 0, 6, 0, 0]));
    assert_eq!(frames[27], (23_000, [0x51, 0x40, 0, 0, 0, 5, 0, 0]));
    // Confirmations move every part on; the serial's wraps to the vendor-ID.
    let confirm = |sub: u8, v: u8, next: u8| [0x51, v, 0, 0, 0, 0, sub, next];
    let confirms: Vec<[u8; 8]> = frames
        .iter()
        .map(|f| f.1)
        .filter(|d| d[5] == 0 && d[6] != d[7])
        .collect();
    assert_eq!(
        confirms,
        vec![
            confirm(0, 0x78, 1),
            confirm(1, 1, 2),
            confirm(2, 2, 3),
            confirm(3, 3, 0)
        ]
    );
    // 133 exchanges, 8 of them silent (the 1 bits of 0x78, 1, 2, 3).
    assert_eq!(frames.len(), 133);
    assert_eq!(bus.now, Instant::from_micros(8 * 10_000 + 125 * 500));
}

// ---------------------------------------------------------------------------------------------
// Node-IDs already on the bus

/// Nodes 5 and 6 run; the pool is 4..=10. The four new slaves get 4, 7, 8 and 9, never 5 or 6,
/// and each skip is reported.
#[test]
fn assign_all_never_hands_out_a_node_id_in_use() {
    let mut rng = Rng::new(41);
    let addrs = random_addresses(&mut rng, 4);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(4), id(10)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    config.in_use.insert(id(5));
    config.in_use.insert(id(6));
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let (r, events) = bus.run(&mut m);
    let report = r.unwrap();
    let ids: BTreeSet<u8> = report.assigned().map(|(_, i)| i.get()).collect();
    assert_eq!(ids, [4, 7, 8, 9].into_iter().collect());
    let skipped: Vec<NodeId> = events
        .iter()
        .filter_map(|e| match e {
            MasterEvent::NodeIdInUse(i) => Some(*i),
            _ => None,
        })
        .collect();
    assert_eq!(skipped, [id(5), id(6)]);
    assert_eq!(report.skipped, [id(5), id(6)].into_iter().collect());
}

/// A node-ID heard during the run (a boot-up or heartbeat the caller reports) leaves the pool;
/// the node-IDs this run handed out, heard as their slaves boot, do not count.
#[test]
fn assign_all_drops_a_node_id_that_appears_during_the_run() {
    let mut rng = Rng::new(42);
    let addrs = random_addresses(&mut rng, 3);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &addrs);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(4), id(10)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let (r, events) = bus.run_with(&mut m, |m, e| {
        if let MasterEvent::Progress(entry) = e {
            // The slave just configured boots with its node-ID; node 5 starts sending
            // heartbeats.
            m.node_id_heard(entry.node_id.unwrap());
            m.node_id_heard(id(5));
        }
    });
    let report = r.unwrap();
    let ids: Vec<u8> = report.assigned().map(|(_, i)| i.get()).collect();
    assert_eq!(ids, [4, 6, 7]);
    assert!(events.contains(&MasterEvent::NodeIdInUse(id(5))));
    assert_eq!(report.skipped, [id(5)].into_iter().collect());
}

/// A table entry whose node-ID is in use: that slave is not configured, and says why.
#[test]
fn assign_all_refuses_a_table_node_id_in_use() {
    let addr = LssAddress::new(9, 9, 9, 9);
    let mut bus = Bus::with_unconfigured(Delivery::Merged, &[addr]);
    let mut config = AssignConfig::with_pool(NodeIdPool::range(id(20), id(30)));
    config.fastscan = fast(ResponsePolicy::FirstAnswer);
    config.table.push((addr, id(5))).unwrap();
    config.in_use.insert(id(5));
    let mut m = AssignAll::new(config);
    m.start(bus.now).unwrap();
    let report = bus.run(&mut m).0.unwrap();
    assert_eq!(report.entries.len(), 1);
    assert_eq!(
        report.entries[0].outcome,
        AssignOutcome::Failed(LssError::NodeIdInUse(5))
    );
    assert_eq!(report.entries[0].node_id, Some(id(5)));
    assert_eq!(bus.slave(addr).active_node_id(), 0xFF, "left unconfigured");
}

/// The node-ID being configured is heard on the bus before the slave made it active: the
/// slave is configured again with the next free one.
#[test]
fn assign_all_reconfigures_when_its_node_id_appears_meanwhile() {
    for store in [true, false] {
        let addr = LssAddress::new(7, 7, 7, 7);
        let mut bus = Bus::with_unconfigured(Delivery::Merged, &[addr]);
        let mut config = AssignConfig::with_pool(NodeIdPool::range(id(4), id(10)));
        config.fastscan = fast(ResponsePolicy::FirstAnswer);
        config.store = store;
        let mut m = AssignAll::new(config);
        m.start(bus.now).unwrap();
        let (r, events) = bus.run_with(&mut m, |m, e| {
            if let MasterEvent::Found(_) = e {
                m.node_id_heard(id(4));
            }
        });
        let report = r.unwrap();
        assert_eq!(report.assigned().collect::<Vec<_>>(), [(addr, id(5))]);
        assert_eq!(report.skipped, [id(4)].into_iter().collect());
        assert!(events.contains(&MasterEvent::NodeIdInUse(id(4))));
        assert_eq!(bus.slave(addr).active_node_id(), 5, "store: {store}");
    }
}
