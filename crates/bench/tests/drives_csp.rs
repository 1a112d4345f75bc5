//! The core of `drives_csp` for a short run: eight simulated 402 servos in cyclic synchronous
//! position at 1 kHz SYNC on the 1 Mbit/s bus model. Every cycle must carry exactly one target
//! RPDO per drive, each with a target the master set and on the wire before the next SYNC, the
//! master must decode the drives' position TPDOs, and the drives must end on their last
//! targets. Counts and bus time only (no wall-clock figure is asserted).

use canola_bench::drives::{DrivesConfig, run};

#[test]
fn eight_drives_in_csp_get_every_rpdo_in_its_cycle_and_reach_their_targets() {
    let cfg = DrivesConfig {
        cycles: 600,
        ramp: 0.6,
        baseline: false,
        ..DrivesConfig::default()
    };
    let r = run(&cfg).unwrap();
    assert!(r.cycles >= 598, "{r:?}");
    assert_eq!(r.cycles_all_rpdos, r.cycles, "{r:?}");
    assert_eq!(r.rpdos_per_cycle, (8, 8), "{r:?}");
    assert_eq!(r.late_rpdos, 0, "{r:?}");
    assert_eq!(r.wrong_targets, 0, "{r:?}");
    assert!(r.worst_rpdo_after_sync < cfg.period, "{r:?}");
    // SYNC and eight 4-byte RPDOs alone take 682 bits of the 1 000 of a cycle.
    assert!((0.68..1.0).contains(&r.bus_load), "{r:?}");
    // TPDO2 on every 4th SYNC, two drives a SYNC.
    assert!(r.actual_values_per_cycle >= 1.9, "{r:?}");
    assert_eq!(r.position_tpdos_per_cycle, (2, 2), "{r:?}");
    assert_eq!(r.drives.len(), 8);
    for d in &r.drives {
        assert!(
            (d.target - d.start).abs() >= 100,
            "the targets moved: {d:?}"
        );
        assert!(
            (d.position - f64::from(d.target)).abs() <= 2.0,
            "drive reached its target: {d:?}"
        );
        assert!(d.following_error.abs() <= 2, "{d:?}");
    }
}
