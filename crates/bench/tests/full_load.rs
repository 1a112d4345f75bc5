//! Full bus load on the in-memory bus, short: 64 simulated nodes, two synchronous 8-byte TPDOs
//! each per SYNC, the SYNC period loading the 1 Mbit/s timing model to 95 %; the master's
//! subscriber must see every PDO, in order per node, with the typed values the counter implies.
//! Counts only (no wall-clock figure is asserted).

use can_frame::Duration;
use canopen_bench::load::{LoadConfig, run};

#[test]
fn sixty_four_nodes_at_full_load_lose_and_reorder_nothing() {
    let config = LoadConfig::full_load(64, Duration::from_secs(3));
    let r = run(&config, &|| None).unwrap();
    assert!(r.syncs >= 199, "{r:?}");
    assert_eq!(r.sent, r.syncs * 128, "two PDOs per node per SYNC: {r:?}");
    assert_eq!(r.frames, r.sent, "{r:?}");
    assert_eq!(r.lost, 0);
    assert_eq!(r.reordered, 0);
    assert_eq!(r.gaps, 0);
    assert_eq!(r.bad_values, 0);
    assert!(r.bus_load >= 0.90, "bus load {:.3}", r.bus_load);
}

#[test]
fn sdo_traffic_to_every_node_at_full_load_never_returns_wrong_data() {
    let mut config = LoadConfig::full_load(16, Duration::from_millis(1500));
    config.sync_period = canopen_bench::load::sync_period_for(16, 1_000_000, false, 0.90);
    config.sdo = true;
    let r = run(&config, &|| None).unwrap();
    let sdo = r.sdo.clone().unwrap();
    assert_eq!(
        (r.lost, r.reordered, r.gaps, r.bad_values),
        (0, 0, 0, 0),
        "{r:?}"
    );
    assert_eq!(sdo.wrong_data, 0, "{sdo:?}");
    assert!(sdo.reads_ok > 0, "{sdo:?}");
}
