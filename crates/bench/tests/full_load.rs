//! Full bus load on the in-memory bus: 64 simulated nodes, two synchronous 8-byte TPDOs each
//! per SYNC, the SYNC period loading the 1 Mbit/s timing model to 95 %; the master's
//! subscriber must see every PDO, in order per node, with the typed values the counter implies.
//! A short run of PDOs alone, and a two-minute run (bus time) with SDO traffic of random sizes
//! to every node at once on top. Counts only (no wall-clock figure is asserted).

use canola_bench::load::{LoadConfig, Tables, run};
use canola_frame::Duration;

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
fn two_minutes_of_full_load_with_sdo_traffic_to_every_node() {
    let seconds = 120;
    let mut config = LoadConfig::full_load(64, Duration::from_secs(seconds));
    config.sdo = true;
    config.sample_every = Duration::from_secs(5);
    let r = run(&config, &|| None).unwrap();
    let sdo = r.sdo.clone().unwrap();
    println!(
        "{} SYNCs, {} PDOs, bus load {:.2} %, SDO {} downloads + {} uploads checked, \
         errors {:?}",
        r.syncs,
        r.frames,
        r.bus_load * 100.0,
        sdo.writes_ok,
        sdo.reads_ok,
        sdo.errors
    );
    // Every SYNC went out on time, though the SDO clients offer more than the bus carries:
    // the SYNC goes ahead of the master's SDO frames.
    let periods = seconds * 1_000_000 / config.sync_period.as_micros();
    assert!(r.syncs + 1 >= periods, "{} SYNCs of {periods}", r.syncs);
    assert_eq!(r.sent, r.syncs * 128, "{r:?}");
    assert_eq!(
        (r.lost, r.reordered, r.gaps, r.bad_values),
        (0, 0, 0, 0),
        "{r:?}"
    );
    assert!(r.bus_load >= 0.95, "bus load {:.3}", r.bus_load);
    assert_eq!(sdo.wrong_data, 0, "{sdo:?}");
    assert!(sdo.reads_ok > 100, "{sdo:?}");
    // No table grows: the keyed ones keep their size, the queues stay within their bounds
    // (the transmit queue; a block of segments per node; one request per node).
    let mid = r.samples.len() / 2;
    for (k, (name, _)) in Tables::default().named().iter().enumerate() {
        let max = |part: &[canola_bench::load::Sample]| {
            part.iter().map(|s| s.tables.named()[k].1).max().unwrap()
        };
        let (first, second) = (max(&r.samples[1..mid]), max(&r.samples[mid..]));
        if Tables::KEYED.contains(name) {
            assert!(second <= first, "{name}: {first} then {second}");
        }
    }
    for s in &r.samples {
        let t = &s.tables;
        assert!(t.master.requests <= 64, "{t:?}");
        assert!(t.master.queued_requests <= 64, "{t:?}");
        assert!(t.master.unsent_frames <= 64 * 128, "{t:?}");
        assert!(t.bus_backlog <= config.tx_queue + 64 * 128, "{t:?}");
    }
}
