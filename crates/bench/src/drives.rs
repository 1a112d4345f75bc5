//! Eight CiA 402 drives in cyclic synchronous position (csp) on the in-memory bus: the core of
//! the `drives_csp` binary and of its test.
//!
//! Set-up: a [`MemoryBus`] on the virtual clock with the 1 Mbit/s timing model; `drives`
//! simulated servos (`canola_cia402::master::simulated_drive` from `eds/cia402-servo.eds`, nodes
//! 1..=`drives`); the master a [`Network`] on an endpoint of the same bus, every node added with
//! the EDS as its dictionary (so the master decodes the TPDOs). Each drive is started
//! (NMT), enabled and put in csp by [`Drive::start_cyclic`] on RPDO4 (0x607A alone, transmission
//! type 1); the master produces the SYNC every `period`. Per cycle the master sets one new
//! target per drive ([`CyclicStream::set_target`]) and runs the network for one period, so its
//! PDO engine sends the eight RPDOs after each SYNC. The EDS's TPDOs 3 and 4 (velocity, torque)
//! are switched off (with TPDO2 they would need 2 300 bits a cycle, over twice what the bus
//! carries in 1 ms); TPDO2 (statusword, position actual value) goes on every
//! [`DrivesConfig::tpdo_every`]-th SYNC, the drives spread over the SYNCs; TPDO1 (statusword,
//! mode display) on change.
//!
//! The targets follow a smoothstep from the start position over `ramp` of the cycles (drive
//! `n` moves `n × amplitude`), then hold, so the drives end at rest on their last target.
//!
//! What is measured (see [`Report`]): a tap endpoint records every frame with its reception time
//! (the end of the frame on the wire); a cycle is the interval between two SYNCs, and it is
//! complete when it holds exactly one RPDO of every drive. Bus load is the bus model's busy time
//! ([`canola::transport::mem::BusStats::busy`], the bit times of every frame) over the bus time elapsed. CPU: the
//! calling thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`) over the cycles; on the virtual clock
//! that thread runs the bus, the eight simulated drives and the master. Blocks of [`BLOCK`]
//! cycles of the master alternate with blocks in which a bare endpoint sends the same traffic
//! (SYNC and eight RPDOs continuing the path each cycle) with the master idle; the median over
//! the pairs of the difference per cycle is the master's share (pairs close in time, as the
//! machine's load changes).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use canola::{
    BusConfig, CanFrame, CanId, CommandSpecifier, MemoryBus, Network, NodeId, Received,
    Transport as _,
};
use canola_cia402::ModeOfOperation;
use canola_cia402::master::{CyclicStream, Drive, simulated_drive};
use canola_cia402::objects as obj;
use canola_cia402::sim::{SimConfig, SimDrive};
use canola_frame::{Duration, Instant};

use crate::{BenchError, thread_cpu_seconds};

/// The 402 servo's EDS the simulated drives are built from.
pub const SERVO_EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");

/// Cycles per block: with a baseline, blocks of the master streaming alternate with blocks of a
/// bare endpoint sending the same frames.
pub const BLOCK: u32 = 100;

/// The RPDO the targets travel in (RPDO4: COB-ID 0x500 + node).
pub const TARGET_RPDO: u16 = 4;

/// What to run.
#[derive(Clone, Debug)]
pub struct DrivesConfig {
    /// Number of drives (nodes 1..=drives).
    pub drives: u8,
    /// Cycles the master streams (SYNC periods); with `baseline`, the bare endpoint's blocks
    /// come on top.
    pub cycles: u32,
    /// The SYNC period.
    pub period: Duration,
    /// Bit rate of the bus model.
    pub bitrate: u32,
    /// Count worst-case stuff bits in the bus model.
    pub stuffing: bool,
    /// Share of the cycles the targets ramp over (the rest holds the last target).
    pub ramp: f64,
    /// Distance drive 1 moves at most, counts; drive `n` moves `n` times the distance of drive 1.
    pub amplitude: i32,
    /// Peak acceleration of drive 1's ramp, counts/s² (drive `n`: `n` times this); a short run
    /// moves less than `amplitude` so that the drives can follow.
    pub acceleration: f64,
    /// Transmission type of each drive's TPDO2 (statusword, 0x6064): every n-th SYNC.
    pub tpdo_every: u8,
    /// Alternate blocks of [`BLOCK`] cycles of the master with blocks of a bare endpoint sending
    /// the same frames (master idle), for the master's CPU share.
    pub baseline: bool,
}

impl Default for DrivesConfig {
    fn default() -> Self {
        Self {
            drives: 8,
            cycles: 5_000,
            period: Duration::from_millis(1),
            bitrate: 1_000_000,
            stuffing: false,
            ramp: 0.8,
            amplitude: 20_000,
            acceleration: 12_000.0,
            tpdo_every: 4,
            baseline: true,
        }
    }
}

/// One drive at the end of the stream.
#[derive(Clone, Debug)]
pub struct DriveEnd {
    /// Node-ID.
    pub node: u8,
    /// The last target streamed, counts.
    pub target: i32,
    /// Where the drive started, counts.
    pub start: i32,
    /// The drive model's position after the last cycle, counts.
    pub position: f64,
    /// 0x60F4 following error actual value after the last cycle.
    pub following_error: i64,
    /// The largest |0x60F4| seen at the end of any cycle.
    pub max_following_error: i64,
}

/// The figures of one run.
#[derive(Clone, Debug)]
pub struct Report {
    /// Complete SYNC-to-SYNC intervals seen by the tap while streaming.
    pub cycles: u64,
    /// Cycles with exactly one RPDO of every drive between their SYNC and the next.
    pub cycles_all_rpdos: u64,
    /// Fewest and most target RPDOs in one cycle.
    pub rpdos_per_cycle: (usize, usize),
    /// RPDOs whose value was not the target the master set for that SYNC.
    pub wrong_targets: u64,
    /// Latest end of an RPDO on the wire after its cycle's SYNC.
    pub worst_rpdo_after_sync: Duration,
    /// RPDOs that ended more than one period after the SYNC before them (the SYNC itself came
    /// late). An RPDO that ends after the next SYNC shows as a cycle without it (and the next
    /// cycle with two): see [`cycles_all_rpdos`](Self::cycles_all_rpdos).
    pub late_rpdos: u64,
    /// See [`late_rpdos`](Self::late_rpdos); zero when none was late.
    pub worst_lateness: Duration,
    /// Fewest and most TPDO2s (position actual value) on the wire in one cycle.
    pub position_tpdos_per_cycle: (usize, usize),
    /// TPDO frames the master received per cycle.
    pub tpdos_per_cycle: f64,
    /// Actual values (0x6064, 0x606C, 0x6077) the master decoded from TPDOs per cycle.
    pub actual_values_per_cycle: f64,
    /// Bits on the wire per cycle (busy time × bit rate).
    pub bits_per_cycle: f64,
    /// Busy time of the bus model over the bus time elapsed.
    pub bus_load: f64,
    /// Thread CPU per cycle with the master streaming (bus, drives and master), seconds.
    pub cpu_per_cycle: f64,
    /// Thread CPU per cycle of the bare endpoint's blocks (bus and drives, the master idle), if
    /// run.
    pub baseline_cpu_per_cycle: Option<f64>,
    /// The master's CPU per cycle: the median over the pairs of blocks of the master's block's
    /// CPU per cycle minus that of the bare endpoint's block after it.
    pub master_cpu_per_cycle: Option<f64>,
    /// Each drive at the end.
    pub drives: Vec<DriveEnd>,
}

fn err(what: &str, e: impl std::fmt::Debug) -> BenchError {
    BenchError(format!("{what}: {e:?}"))
}

/// The target of drive `k` (0-based) in cycle `i`.
fn target(cfg: &DrivesConfig, start: i32, k: usize, i: u32) -> i32 {
    let ramp_cycles = (f64::from(cfg.cycles) * cfg.ramp).max(1.0);
    let x = (f64::from(i) / ramp_cycles).min(1.0);
    let s = x * x * (3.0 - 2.0 * x);
    let ramp_s = ramp_cycles * cfg.period.as_micros() as f64 / 1e6;
    // A smoothstep over T peaks at an acceleration of 6 × distance / T².
    let distance =
        f64::from(cfg.amplitude).min(cfg.acceleration * ramp_s * ramp_s / 6.0) * (k as f64 + 1.0);
    start + (distance * s).round() as i32
}

/// Runs the benchmark; see the module documentation.
pub fn run(cfg: &DrivesConfig) -> Result<Report, BenchError> {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(cfg.bitrate),
        worst_case_stuffing: cfg.stuffing,
        // Room for every frame of the run in the tap and the idle master (no overflow).
        queue_capacity: (cfg.cycles as usize + 1_000) * (usize::from(cfg.drives) * 5 + 4),
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(SERVO_EDS).map_err(|e| err("EDS", e))?.od;
    let mut models = Vec::new();
    let mut drives = Vec::new();
    for n in 1..=cfg.drives {
        let id = NodeId::new(n).map_err(|e| err("node-ID", e))?;
        let node = net.add_node_with_dictionary(id, od.clone());
        let (device, model) = simulated_drive(id, SERVO_EDS, SimDrive::new(SimConfig::default()))
            .map_err(|e| err("EDS", e))?;
        bus.attach(device);
        node.nmt()
            .wait_for_bootup(Duration::from_secs(1))
            .wait()
            .map_err(|e| err("boot-up", e))?;
        models.push(model);
        drives.push(Drive::new(node));
    }
    net.nmt_all(CommandSpecifier::Start)
        .map_err(|e| err("NMT start", e))?;
    // TPDO2..4 of the EDS (6 bytes each on every SYNC) would need 2 300 bits per cycle for
    // eight drives, over twice what 1 Mbit/s carries in 1 ms: TPDO3 and 4 (velocity, torque)
    // off, TPDO2 (statusword, position) invalid until it is staggered below.
    let cob_off = 0x8000_0000u32;
    for (k, d) in drives.iter().enumerate() {
        let n = k as u32 + 1;
        let sdo = || d.node().sdo();
        for (tpdo, base) in [(0x1801u16, 0x280u32), (0x1802, 0x380), (0x1803, 0x480)] {
            sdo()
                .write((tpdo, 1u8), cob_off | (base + n))
                .wait()
                .map_err(|e| err("TPDO off", e))?;
        }
        sdo()
            .write((0x1801u16, 2u8), cfg.tpdo_every)
            .wait()
            .map_err(|e| err("TPDO2 type", e))?;
        d.enable().wait().map_err(|e| err("enable", e))?;
    }
    net.start_sync(cfg.period);
    let streams: Vec<CyclicStream> = drives
        .iter()
        .map(|d| {
            d.start_cyclic(ModeOfOperation::CyclicSyncPosition, TARGET_RPDO, cfg.period)
                .wait()
        })
        .collect::<Result<_, _>>()
        .map_err(|e| err("start_cyclic", e))?;
    stagger_tpdo2(&bus, &net, &drives, cfg)?;
    let starts: Vec<i32> = models
        .iter()
        .map(|m| {
            m.lock()
                .unwrap_or_else(|p| p.into_inner())
                .position()
                .round() as i32
        })
        .collect();

    // What the master decodes from TPDOs.
    let tpdo_counts: Arc<Mutex<(u64, u64)>> = Arc::default();
    let sink = Arc::clone(&tpdo_counts);
    let actuals = [
        (obj::POSITION_ACTUAL_VALUE.index(), 0),
        (obj::VELOCITY_ACTUAL_VALUE.index(), 0),
        (obj::TORQUE_ACTUAL_VALUE.index(), 0),
    ];
    net.on_pdo(move |p| {
        let n = p
            .values
            .iter()
            .filter(|(a, _)| actuals.contains(&(a.index, a.sub_index)))
            .count() as u64;
        let mut c = sink.lock().unwrap_or_else(|e| e.into_inner());
        c.0 += 1;
        c.1 += n;
    });

    let mut tap = bus.endpoint();
    let mut max_fe = vec![0i64; drives.len()];
    let following_errors = |max_fe: &mut [i64]| {
        for (m, fe) in models.iter().zip(max_fe.iter_mut()) {
            let v = m
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .value(obj::FOLLOWING_ERROR_ACTUAL_VALUE);
            *fe = (*fe).max(v.abs());
        }
    };
    // The targets set before each cycle, to check what each RPDO carried.
    let mut sent: Vec<Vec<i32>> = vec![Vec::with_capacity(cfg.cycles as usize); drives.len()];
    // The path runs over the master's cycles and the bare endpoint's between them.
    let traj = DrivesConfig {
        cycles: if cfg.baseline {
            cfg.cycles.saturating_mul(2)
        } else {
            cfg.cycles
        },
        ..cfg.clone()
    };
    let mut raw = bus.endpoint();
    let sync = CanFrame::new(CanId::standard(0x080).map_err(|e| err("id", e))?, &[])
        .map_err(|e| err("frame", e))?;
    let rpdo_ids: Vec<CanId> = (1..=u16::from(cfg.drives))
        .map(|n| CanId::standard(0x100 + 0x100 * TARGET_RPDO + n))
        .collect::<Result<_, _>>()
        .map_err(|e| err("id", e))?;
    let sync_time = canola::transport::mem::frame_time(&sync, cfg.bitrate, cfg.stuffing);
    let counts = || *tpdo_counts.lock().unwrap_or_else(|p| p.into_inner());

    let mut frames = Vec::new();
    let (mut tpdos, mut values) = (0u64, 0u64);
    let (mut cpu_master, mut cpu_bare) = (0.0f64, 0.0f64);
    let mut pairs = Vec::new();
    let busy0 = bus.stats().busy;
    let t0 = bus.now();
    let mut i = 0u32;
    let mut done = 0u32;
    while done < cfg.cycles {
        let n = BLOCK.min(cfg.cycles - done);
        let before = counts();
        let cpu0 = thread_cpu_seconds();
        for _ in 0..n {
            i += 1;
            for (k, s) in streams.iter().enumerate() {
                let t = target(&traj, starts[k], k, i);
                s.set_target(t).map_err(|e| err("set_target", e))?;
                sent[k].push(t);
            }
            net.run_for(cfg.period).wait().map_err(|e| err("run", e))?;
            following_errors(&mut max_fe);
        }
        let master_block = thread_cpu_seconds() - cpu0;
        cpu_master += master_block;
        let after = counts();
        tpdos += after.0 - before.0;
        values += after.1 - before.1;
        done += n;
        while let Ok(Some(r)) = tap.try_recv() {
            if let Received::Frame { frame, at } = r {
                frames.push((frame, at));
            }
        }
        if !cfg.baseline || done >= cfg.cycles {
            continue;
        }
        // The same traffic from the bare endpoint, the master not producing SYNC: its SYNCs
        // on the master's phase (from the start of the last SYNC the tap saw).
        let Some(last_sync) = frames
            .iter()
            .rev()
            .find(|(f, _)| f.cob_id() == Some(0x080))
            .map(|(_, at)| *at)
        else {
            return Err(BenchError("no SYNC in a block".into()));
        };
        let mut next = last_sync - sync_time + cfg.period;
        net.stop_sync();
        // The last cycle's RPDOs may still be on their way: up to the next SYNC they count.
        net.run_until(next).wait().map_err(|e| err("run", e))?;
        while let Ok(Some(r)) = tap.try_recv() {
            if let Received::Frame { frame, at } = r {
                frames.push((frame, at));
            }
        }
        let cpu0 = thread_cpu_seconds();
        for _ in 0..n {
            i += 1;
            // The master keeps receiving (it decodes the TPDOs as in its own blocks).
            net.run_until(next).wait().map_err(|e| err("run", e))?;
            raw.send(&sync).map_err(|e| err("send", e))?;
            for (k, id) in rpdo_ids.iter().enumerate() {
                let t = target(&traj, starts[k], k, i);
                let f = CanFrame::new(*id, &t.to_le_bytes()).map_err(|e| err("frame", e))?;
                raw.send(&f).map_err(|e| err("send", e))?;
            }
            next += cfg.period;
            following_errors(&mut max_fe);
        }
        net.run_until(next).wait().map_err(|e| err("run", e))?;
        let bare_block = thread_cpu_seconds() - cpu0;
        cpu_bare += bare_block;
        pairs.push((master_block - bare_block) / f64::from(n));
        // Outside the figures: what the tap and the bare endpoint received.
        while let Ok(Some(_)) = tap.try_recv() {}
        while let Ok(Some(_)) = raw.try_recv() {}
        // The master's first SYNC goes at once: its RPDOs must carry the path's present target.
        for (k, st) in streams.iter().enumerate() {
            let t = target(&traj, starts[k], k, i);
            st.set_target(t).map_err(|e| err("set_target", e))?;
            sent[k].push(t);
        }
        net.start_sync(cfg.period);
    }
    let elapsed = bus.now() - t0;
    let busy = bus.stats().busy - busy0;

    let ends: Vec<DriveEnd> = models
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let m = m.lock().unwrap_or_else(|p| p.into_inner());
            DriveEnd {
                node: k as u8 + 1,
                target: target(&traj, starts[k], k, i),
                start: starts[k],
                position: m.position(),
                following_error: m.value(obj::FOLLOWING_ERROR_ACTUAL_VALUE),
                max_following_error: max_fe[k],
            }
        })
        .collect();
    let cycles = check_cycles(&frames, cfg, &sent);
    let bare_cycles = f64::from(cfg.cycles.saturating_sub(BLOCK.min(cfg.cycles)));
    pairs.sort_by(f64::total_cmp);
    let (baseline_cpu_per_cycle, master_cpu_per_cycle) = if pairs.is_empty() {
        (None, None)
    } else {
        (Some(cpu_bare / bare_cycles), Some(pairs[pairs.len() / 2]))
    };
    let cpu = cpu_master;
    let n_cycles = f64::from(cfg.cycles);
    Ok(Report {
        cycles: cycles.cycles,
        cycles_all_rpdos: cycles.complete,
        rpdos_per_cycle: cycles.per_cycle,
        position_tpdos_per_cycle: cycles.tpdo2,
        wrong_targets: cycles.wrong,
        worst_rpdo_after_sync: cycles.worst_after_sync,
        late_rpdos: cycles.late,
        worst_lateness: cycles.worst_lateness,
        tpdos_per_cycle: tpdos as f64 / n_cycles,
        actual_values_per_cycle: values as f64 / n_cycles,
        bits_per_cycle: busy.as_micros() as f64 * f64::from(cfg.bitrate)
            / 1e6
            / (elapsed.as_micros() as f64 / cfg.period.as_micros() as f64),
        bus_load: busy.as_micros() as f64 / elapsed.as_micros() as f64,
        cpu_per_cycle: cpu / n_cycles,
        baseline_cpu_per_cycle,
        master_cpu_per_cycle,
        drives: ends,
    })
}

/// Makes TPDO2 of each drive valid so that at most `ceil(drives / tpdo_every)` drives send on
/// the same SYNC. TPDO2 counts SYNCs from when it becomes valid; a tap watches the drive's first
/// TPDO2 and the SYNCs before it, and a drive that lands on a SYNC (counted modulo
/// `tpdo_every`) that already has its share is made invalid and valid again after a wait that differs
/// from one try to the next.
fn stagger_tpdo2(
    bus: &MemoryBus,
    net: &Network,
    drives: &[Drive],
    cfg: &DrivesConfig,
) -> Result<(), BenchError> {
    let every = usize::from(cfg.tpdo_every.max(1));
    let share = drives.len().div_ceil(every);
    let mut taken = vec![0usize; every];
    let mut tap = bus.endpoint();
    let mut syncs = 0usize;
    for (k, d) in drives.iter().enumerate() {
        let cob = 0x280u16 + k as u16 + 1;
        let mut placed = false;
        for attempt in 0..4 * every {
            let set = |valid: bool| {
                let flag = if valid { 0 } else { 0x8000_0000u32 };
                d.node()
                    .sdo()
                    .write((0x1801u16, 1u8), flag | u32::from(cob))
                    .wait()
                    .map_err(|e| err("TPDO2 valid", e))
            };
            set(true)?;
            let mut phase = None;
            for _ in 0..every + 4 {
                net.run_for(cfg.period).wait().map_err(|e| err("run", e))?;
                while let Ok(Some(r)) = tap.try_recv() {
                    if let Received::Frame { frame, .. } = r {
                        match frame.cob_id() {
                            Some(0x080) => syncs += 1,
                            Some(id) if id == cob && phase.is_none() => phase = Some(syncs % every),
                            _ => {}
                        }
                    }
                }
                if phase.is_some() {
                    break;
                }
            }
            if let Some(p) = phase
                && taken[p] < share
            {
                taken[p] += 1;
                placed = true;
                break;
            }
            set(false)?;
            // A different wait each time, so the next try lands on another SYNC.
            let wait = cfg.period.as_micros() * (attempt as u64 % every as u64 + 1);
            net.run_for(Duration::from_micros(wait))
                .wait()
                .map_err(|e| err("run", e))?;
        }
        if !placed {
            return Err(BenchError(format!(
                "node {}: no free SYNC for TPDO2 (every {every} SYNCs, {share} a SYNC)",
                k + 1
            )));
        }
    }
    Ok(())
}

struct Cycles {
    cycles: u64,
    complete: u64,
    per_cycle: (usize, usize),
    tpdo2: (usize, usize),
    wrong: u64,
    worst_after_sync: Duration,
    late: u64,
    worst_lateness: Duration,
}

/// Splits the tap's frames into SYNC-to-SYNC cycles and checks the target RPDOs of each.
fn check_cycles(frames: &[(CanFrame, Instant)], cfg: &DrivesConfig, sent: &[Vec<i32>]) -> Cycles {
    let rpdo_base = 0x100 + 0x100 * TARGET_RPDO; // RPDO4: 0x500 + node
    let is_target_rpdo = |id: u16| id > rpdo_base && id <= rpdo_base + u16::from(cfg.drives);
    let syncs: Vec<Instant> = frames
        .iter()
        .filter(|(f, _)| f.cob_id() == Some(0x080))
        .map(|(_, at)| *at)
        .collect();
    let mut out = Cycles {
        cycles: syncs.len().saturating_sub(1) as u64,
        complete: 0,
        per_cycle: (usize::MAX, 0),
        tpdo2: (usize::MAX, 0),
        wrong: 0,
        worst_after_sync: Duration::ZERO,
        late: 0,
        worst_lateness: Duration::ZERO,
    };
    // Per cycle: the nodes whose RPDO arrived in it.
    let mut in_cycle: Vec<HashMap<u16, usize>> = vec![HashMap::new(); syncs.len()];
    // Each node's RPDOs in order, with the cycle they fell in.
    let mut seen_per_node: HashMap<u16, Vec<i32>> = HashMap::new();
    let mut tpdo2 = vec![0usize; syncs.len()];
    let mut cycle: Option<usize> = None;
    for (f, at) in frames {
        let Some(id) = f.cob_id() else { continue };
        if id == 0x080 {
            cycle = Some(cycle.map_or(0, |c| c + 1));
            continue;
        }
        let Some(c) = cycle else { continue };
        if id > 0x280 && id <= 0x280 + u16::from(cfg.drives) {
            tpdo2[c] += 1;
        }
        if !is_target_rpdo(id) {
            continue;
        }
        *in_cycle[c].entry(id).or_default() += 1;
        let after = *at - syncs[c];
        out.worst_after_sync = out.worst_after_sync.max(after);
        // Past the deadline one period after the SYNC (frames are in wire order, so an RPDO
        // after the next SYNC falls in the next cycle and leaves this one short).
        if after > cfg.period {
            out.late += 1;
            out.worst_lateness = out.worst_lateness.max(after - cfg.period);
        }
        let d = f.data();
        if d.len() == 4 {
            seen_per_node
                .entry(id)
                .or_default()
                .push(i32::from_le_bytes([d[0], d[1], d[2], d[3]]));
        } else {
            out.wrong += 1;
        }
    }
    // Complete cycles: the last SYNC's interval is cut short by the end of the run.
    for &n in tpdo2.iter().take(out.cycles as usize) {
        out.tpdo2 = (out.tpdo2.0.min(n), out.tpdo2.1.max(n));
    }
    if out.tpdo2.0 == usize::MAX {
        out.tpdo2.0 = 0;
    }
    for counts in in_cycle.iter().take(out.cycles as usize) {
        let total: usize = counts.values().sum();
        out.per_cycle.0 = out.per_cycle.0.min(total);
        out.per_cycle.1 = out.per_cycle.1.max(total);
        if counts.len() == usize::from(cfg.drives) && counts.values().all(|&n| n == 1) {
            out.complete += 1;
        }
    }
    if out.per_cycle.0 == usize::MAX {
        out.per_cycle.0 = 0;
    }
    // Each RPDO carries a target the master set, in the order it set them (a SYNC that comes
    // before the next `set_target` repeats the last one).
    for (k, targets) in sent.iter().enumerate() {
        let id = rpdo_base + k as u16 + 1;
        let mut next = 0usize;
        for v in seen_per_node.get(&id).map_or(&[][..], Vec::as_slice) {
            match targets[next..].iter().position(|t| t == v) {
                Some(p) => next += p,
                None => out.wrong += 1,
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(CanId::standard(id).unwrap(), data).unwrap()
    }

    #[test]
    fn a_missing_a_late_and_a_wrong_rpdo_are_counted() {
        let cfg = DrivesConfig {
            drives: 2,
            ..DrivesConfig::default()
        };
        let at = Instant::from_micros;
        let t = |v: i32| v.to_le_bytes();
        let frames = vec![
            // Cycle 0: both RPDOs, the second ending 900 µs after the SYNC.
            (frame(0x080, &[]), at(1_000)),
            (frame(0x501, &t(10)), at(1_100)),
            (frame(0x502, &t(20)), at(1_900)),
            // Cycle 1: node 2's RPDO is missing; node 1's carries a target never set.
            (frame(0x080, &[]), at(2_000)),
            (frame(0x501, &t(99)), at(2_100)),
            // Cycle 2: node 2's RPDO of this cycle ends after the next SYNC.
            (frame(0x080, &[]), at(3_000)),
            (frame(0x501, &t(11)), at(3_100)),
            (frame(0x080, &[]), at(4_000)),
            (frame(0x502, &t(21)), at(4_100)),
            (frame(0x501, &t(12)), at(4_200)),
            (frame(0x080, &[]), at(5_000)),
        ];
        let sent = vec![vec![10, 11, 12], vec![20, 21, 22]];
        let c = check_cycles(&frames, &cfg, &sent);
        assert_eq!(c.cycles, 4);
        // Only cycle 0 and cycle 3 (node 2's RPDO of cycle 2 arriving there) hold one of each:
        // a late RPDO shows as a short cycle.
        assert_eq!(c.complete, 2);
        assert_eq!(c.per_cycle, (1, 2));
        assert_eq!(c.wrong, 1);
        assert_eq!(c.worst_after_sync, Duration::from_micros(900));
        assert_eq!(c.late, 0);
    }
}
