//! Full bus load on the in-memory bus, short: 64 simulated nodes, two synchronous 8-byte TPDOs
//! each per SYNC, the SYNC period loading the 1 Mbit/s timing model to 95 %; the master's
//! subscriber must see every PDO, in order per node, with the typed values the counter implies.
//! Counts only (no wall-clock figure is asserted).

use can_frame::Duration;
use canopen_bench::load::{LoadConfig, run};

#[test]
fn sixty_four_nodes_at_full_load_lose_and_reorder_nothing() {
    let config = LoadConfig::full_load(64, Duration::from_millis(300));
    let r = run(&config, &|| None).unwrap();
    assert!(r.syncs >= 19, "{r:?}");
    assert_eq!(r.sent, r.syncs * 128, "two PDOs per node per SYNC: {r:?}");
    assert_eq!(r.frames, r.sent, "{r:?}");
    assert_eq!(r.lost, 0);
    assert_eq!(r.reordered, 0);
    assert_eq!(r.gaps, 0);
    assert_eq!(r.bad_values, 0);
    assert!(r.bus_load >= 0.90, "bus load {:.3}", r.bus_load);
}
