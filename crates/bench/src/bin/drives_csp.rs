//! Eight CiA 402 drives in cyclic synchronous position at 1 kHz SYNC on the in-memory bus with
//! the 1 Mbit/s timing model (see `canola_bench::drives` for the set-up).
//!
//! ```text
//! cargo run --release -p canola-bench --bin drives_csp -- [--seconds S] [--drives N]
//!     [--period-us P] [--tpdo-every N] [--stuffing] [--no-baseline]
//! ```
//!
//! Runs on the bus's virtual clock: bus time advances while the master waits, so every cycle
//! is a full period of bus time whatever the host does, and the figures are those of the bus
//! model, not of this machine's scheduler. (The CPU figures below tell whether one core could
//! keep up in real time: the thread's CPU per cycle against the period.)
//!
//! How each figure is measured:
//! * bus load: the bus model's busy time (every frame's bit times, interframe space included;
//!   `--stuffing` adds the worst-case stuff bits) over the bus time of the streaming phase;
//! * RPDOs inside their cycle: a tap endpoint records every frame with the time its last bit
//!   left the wire; a cycle runs from one SYNC to the next, and it counts when it holds exactly
//!   one target RPDO (RPDO4, 0x500 + node) of every drive. "after SYNC" is the latest end of an
//!   RPDO after its cycle's SYNC; an RPDO ending more than one period after the SYNC before it
//!   is late, and the worst lateness is how far past the period it ended (an RPDO after the
//!   next SYNC shows as a cycle without it). Each RPDO's value is also checked against the targets
//!   the master set, in order;
//! * TPDOs: the EDS's TPDO2, 3 and 4 (6 bytes each on every SYNC) would need about 2 300 bits
//!   per cycle for eight drives, more than twice what 1 Mbit/s carries in 1 ms, so TPDO3 and 4
//!   (velocity, torque) are switched off and TPDO2 (statusword, position actual value) goes on
//!   every `--tpdo-every` SYNC (default 4: two drives a cycle). TPDO2 counts SYNCs from when it
//!   becomes valid, so the drives are spread over the SYNCs at set-up (a tap sees on which SYNC
//!   a drive's first TPDO2 comes; a drive on a full SYNC is made invalid and valid again later).
//!   TPDO1 (statusword and mode on change) stays. Printed: the frames the master
//!   received and decoded through each node's dictionary (its
//!   `on_pdo` callback), and the actual values among their values (0x6064, 0x606C, 0x6077), per
//!   cycle;
//! * CPU per cycle: `CLOCK_THREAD_CPUTIME_ID` of the one thread that runs the bus, the
//!   simulated drives and the master, over the master's cycles. Blocks of 100 cycles of the
//!   master alternate with blocks in which a bare endpoint sends the SYNC and the eight RPDOs
//!   (the path continued) with the master idle; the master's share (its SYNC producer, PDO
//!   engine, TPDO decoding and the callback) is the median over the pairs of blocks of the
//!   difference per cycle. `--no-baseline` skips the bare endpoint's blocks;
//! * following error: 0x60F4 of each drive model after the last cycle (the targets ramp over
//!   the first 80 % of the cycles and then hold), and the largest |0x60F4| at the end of any
//!   cycle. The largest includes the switches from the bare endpoint's blocks back to the
//!   master (the SYNC's phase steps there); with `--no-baseline` it is the master's alone.
//!
//! Exits 1 when a cycle missed an RPDO, an RPDO was late or carried a target the master had not
//! set, or a drive ended more than 20 counts from its last target.

use std::process::ExitCode;

use canola_bench::drives::{self, DrivesConfig};
use canola_frame::Duration;

fn parse() -> Result<DrivesConfig, String> {
    let mut cfg = DrivesConfig::default();
    let mut seconds = 5.0f64;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--seconds" => {
                seconds = value("--seconds")?
                    .parse()
                    .map_err(|e| format!("--seconds: {e}"))?
            }
            "--drives" => {
                cfg.drives = value("--drives")?
                    .parse()
                    .map_err(|e| format!("--drives: {e}"))?
            }
            "--period-us" => {
                let us: u64 = value("--period-us")?
                    .parse()
                    .map_err(|e| format!("--period-us: {e}"))?;
                cfg.period = Duration::from_micros(us);
            }
            "--tpdo-every" => {
                cfg.tpdo_every = value("--tpdo-every")?
                    .parse()
                    .map_err(|e| format!("--tpdo-every: {e}"))?
            }
            "--stuffing" => cfg.stuffing = true,
            "--no-baseline" => cfg.baseline = false,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !(1..=240).contains(&cfg.tpdo_every) {
        return Err("--tpdo-every must be 1..=240".into());
    }
    if !(1..=127).contains(&cfg.drives) {
        return Err("--drives must be 1..=127".into());
    }
    if cfg.period.as_micros() == 0 || !seconds.is_finite() || seconds <= 0.0 {
        return Err("--seconds and --period-us must be positive".into());
    }
    let cycles = seconds * 1e6 / cfg.period.as_micros() as f64;
    cfg.cycles = (cycles.round() as u32).max(1);
    Ok(cfg)
}

fn main() -> ExitCode {
    let cfg = match parse() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("drives_csp: {e}");
            return ExitCode::from(2);
        }
    };
    let r = match drives::run(&cfg) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("drives_csp: {}", e.0);
            return ExitCode::FAILURE;
        }
    };
    let period_us = cfg.period.as_micros() as f64;
    println!(
        "{} drives, csp, SYNC every {} µs, {} bit/s{}, {} cycles on the virtual clock",
        cfg.drives,
        cfg.period.as_micros(),
        cfg.bitrate,
        if cfg.stuffing {
            " (worst-case stuff bits)"
        } else {
            ""
        },
        cfg.cycles
    );
    println!(
        "bus load: {:.2} % ({:.0} bits per cycle)",
        r.bus_load * 100.0,
        r.bits_per_cycle
    );
    println!(
        "cycles with every RPDO inside: {} of {} (RPDOs per cycle {}..{}); latest RPDO end after its SYNC {} µs; late RPDOs {} (worst lateness {} µs); wrong targets {}",
        r.cycles_all_rpdos,
        r.cycles,
        r.rpdos_per_cycle.0,
        r.rpdos_per_cycle.1,
        r.worst_rpdo_after_sync.as_micros(),
        r.late_rpdos,
        r.worst_lateness.as_micros(),
        r.wrong_targets
    );
    println!(
        "TPDOs received per cycle: {:.2} frames, {:.2} actual values (TPDO2 on every {}th SYNC, {}..{} per cycle on the wire)",
        r.tpdos_per_cycle,
        r.actual_values_per_cycle,
        cfg.tpdo_every,
        r.position_tpdos_per_cycle.0,
        r.position_tpdos_per_cycle.1
    );
    print!(
        "CPU per cycle: {:.1} µs all ({:.1} % of the period)",
        r.cpu_per_cycle * 1e6,
        r.cpu_per_cycle * 1e6 / period_us * 100.0
    );
    match (r.baseline_cpu_per_cycle, r.master_cpu_per_cycle) {
        (Some(b), Some(m)) => println!(
            ", {:.1} µs bus and drives, {:.1} µs master ({:.1} % of the period)",
            b * 1e6,
            m * 1e6,
            m * 1e6 / period_us * 100.0
        ),
        _ => println!(),
    }
    let mut bad_end = false;
    for d in &r.drives {
        let off = d.position - f64::from(d.target);
        bad_end |= off.abs() > 20.0;
        println!(
            "node {}: {} -> {} counts, position {:.1}, following error {} (max {})",
            d.node, d.start, d.target, d.position, d.following_error, d.max_following_error
        );
    }
    let ok = r.cycles_all_rpdos == r.cycles
        && r.cycles > 0
        && r.late_rpdos == 0
        && r.wrong_targets == 0
        && !bad_end;
    if ok {
        ExitCode::SUCCESS
    } else {
        eprintln!("drives_csp: a check failed (see above)");
        ExitCode::FAILURE
    }
}
