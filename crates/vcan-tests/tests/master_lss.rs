//! LSS (CiA 305) on the real kernel CAN stack: the master's Fastscan finds several simulated
//! unconfigured devices (each on its own socket), then the assign-all workflow gives each a
//! node-ID, after which they boot and answer SDO with their own identity.
//!
//! LSS has one channel per bus (0x7E5/0x7E4), so this binary holds a single test; run-all runs
//! the binaries one after another. Ignored on the host.

mod common;

use std::collections::BTreeSet;

use canola::socketcan::SocketCan;
use canola::{Network, NetworkEvent, SimDevice};
use canola_frame::Duration;
use canola_lss::{AssignConfig, FastscanConfig, LssAddress, NodeIdPool, ResponsePolicy};
use canola_nmt::HeartbeatEvent;
use common::{EDS, RunningSim, node};

#[test]
#[ignore = "needs vcan0: run by tests/vcan/run-all"]
fn fastscan_finds_every_unconfigured_device_and_assign_all_commissions_them() {
    let od = || canola_od::parse(EDS).expect("the test EDS parses").od;
    let addresses: Vec<LssAddress> = [1001, 2002, 3003]
        .into_iter()
        .map(|serial| LssAddress::new(0x0ABC, 0x42, 0x0001_0002, serial))
        .collect();
    let _sims: Vec<RunningSim> = addresses
        .iter()
        .map(|a| RunningSim::start(SimDevice::unconfigured(od(), *a)))
        .collect();

    let net = Network::new(SocketCan::open(&vcan_tests::interface()).expect("open the socket"));
    let events = net.subscribe();
    net.run_for(Duration::from_millis(300)).wait().unwrap();
    let early: Vec<NetworkEvent> = events.try_iter().collect();
    assert!(
        !early
            .iter()
            .any(|e| matches!(e, NetworkEvent::Heartbeat(_))),
        "unconfigured devices must stay silent: {early:?}"
    );

    // Several slaves answer the same request, so wait out each whole window (an answer arriving
    // after the master moved on would be taken for the next request's). Threads under
    // emulation on a loaded host answer late at times, hence a window six times the default;
    // to keep that affordable the master knows the vendor-ID, product code and revision (each
    // confirmed with one request) and searches the serial numbers bit by bit.
    let scan = FastscanConfig {
        response_timeout: Duration::from_millis(150),
        policy: ResponsePolicy::WholeWindow,
        known: [Some(0x0ABC), Some(0x42), Some(0x0001_0002), None],
        skip: [false; 4],
    };
    let found: BTreeSet<LssAddress> = net
        .lss()
        .discover_all(scan)
        .wait()
        .expect("Fastscan discovery")
        .into_iter()
        .collect();
    let want: BTreeSet<LssAddress> = addresses.iter().copied().collect();
    assert_eq!(found, want);

    let mut config = AssignConfig::with_pool(NodeIdPool::range(node(0x50), node(0x5F)));
    config.fastscan = scan;
    let report = net.lss().assign_all(config).wait().expect("assign all");
    let assigned: Vec<(LssAddress, canola_frame::NodeId)> = report.assigned().collect();
    assert_eq!(assigned.len(), 3, "{report:?}");
    let ids: BTreeSet<u8> = assigned.iter().map(|(_, id)| id.get()).collect();
    assert_eq!(ids.len(), 3, "node-IDs must differ: {assigned:?}");

    // Each boots with its new node-ID and answers SDO with its own serial number.
    let deadline = net.now() + Duration::from_secs(10);
    let mut booted = BTreeSet::new();
    while booted.len() < 3 && net.now() < deadline {
        net.run_for(Duration::from_millis(50)).wait().unwrap();
        for e in events.try_iter() {
            if let NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: n }) = e {
                booted.insert(n.get());
            }
        }
    }
    assert_eq!(booted, ids, "boot-up messages");
    for (address, id) in assigned {
        let serial = net
            .node(id)
            .sdo()
            .timeout(Duration::from_secs(5))
            .read((0x1018, 4))
            .wait()
            .expect("SDO to a commissioned device");
        assert_eq!(serial, address.serial_number.to_le_bytes(), "node {id}");
    }
}
