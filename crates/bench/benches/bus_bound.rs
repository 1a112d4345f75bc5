//! SDO throughput on the in-memory bus with the bit-rate timing model, as a share of the CAN
//! bus bound.
//!
//! `cargo bench -p canola-bench --bench bus_bound` prints one table per timing model (1 Mbit/s
//! without stuff bits, then with the worst-case number of stuff bits): 1000 expedited reads, a
//! 64 KiB segmented upload and a 64 KiB block upload from a simulated device to the master, timed
//! on the bus's virtual clock. Two bounds per row:
//! * "frames": the frames the transfer cannot do without (counted in `canola_bench`, checked
//!   against the bus's frame counter) times the model's bits per frame — the exact bound for
//!   this transfer;
//! * "long": the asymptotic bound for long transfers (expedited 4 505/s, segmented 30.8 KiB/s,
//!   block 61.1 KiB/s at 1 Mbit/s without stuffing), which ignores the few frames of
//!   initiation and end.
//!
//! Settings: block size 127 on both sides (the largest CiA 301 allows; the default of master and
//! simulator), CRC on, no response delay in the simulator (the virtual clock charges no
//! processing time to either side), the simulator's heartbeat switched off so that only SDO
//! frames use the bus.

use canola::{BusConfig, ClockMode};
use canola_bench::{
    BOUNDS_1M, Bounds, EXPEDITED_FRAMES, LARGE_LEN, MAX_BLKSIZE, Measured, block_upload_frames,
    in_memory, kib_per_s, segmented_upload_frames,
};
use canola_frame::NodeId;

const EXPEDITED: u64 = 1000;

fn main() {
    // `cargo bench` passes `--bench`; a filter argument is ignored.
    let node = NodeId::new(0x5B).expect("valid node-ID");
    let mut failed = false;
    for bounds in [
        BOUNDS_1M,
        Bounds {
            worst_case_stuffing: true,
            ..BOUNDS_1M
        },
    ] {
        let config = BusConfig {
            clock: ClockMode::Virtual,
            bitrate: Some(bounds.bitrate),
            worst_case_stuffing: bounds.worst_case_stuffing,
            ..Default::default()
        };
        println!(
            "\n{} bit/s, {} ({} bits per 8-byte frame); time on the bus's virtual clock",
            bounds.bitrate,
            if bounds.worst_case_stuffing {
                "worst-case stuff bits"
            } else {
                "no stuff bits"
            },
            bounds.frame_bits()
        );
        match in_memory(config, node, EXPEDITED, LARGE_LEN) {
            Ok(rows) => table(&bounds, &rows),
            Err(e) => {
                eprintln!("transfer failed: {e}");
                failed = true;
            }
        }
    }
    if failed {
        std::process::exit(1);
    }
}

fn table(bounds: &Bounds, rows: &[Measured; 3]) {
    println!(
        "{:<18} {:>9} {:>10} {:>7} {:>6} {:>14} {:>14} {:>7} {:>14} {:>7} {:>8}",
        "workload",
        "bytes",
        "bus time",
        "frames",
        "busy",
        "measured",
        "bound(frames)",
        "share",
        "bound(long)",
        "share",
        "host"
    );
    let [expedited, segmented, block] = rows;
    let min_frames = [
        EXPEDITED_FRAMES * expedited.transfers,
        segmented_upload_frames(segmented.bytes),
        block_upload_frames(block.bytes, MAX_BLKSIZE),
    ];
    for (m, min_frames) in rows.iter().zip(min_frames) {
        let bound_s = bounds.seconds(min_frames);
        let (measured, exact, long, unit) = if m.label == expedited.label {
            (
                m.transfers as f64 / m.seconds,
                m.transfers as f64 / bound_s,
                bounds.expedited_per_s(),
                "/s",
            )
        } else {
            let long = if m.label == segmented.label {
                bounds.segmented_kib_per_s()
            } else {
                bounds.block_kib_per_s(MAX_BLKSIZE)
            };
            (
                kib_per_s(m.bytes, m.seconds),
                kib_per_s(m.bytes, bound_s),
                long,
                " KiB/s",
            )
        };
        println!(
            "{:<18} {:>9} {:>9.4}s {:>7} {:>5.1}% {:>14} {:>14} {:>6.2}% {:>14} {:>6.2}% {:>7.3}s",
            m.label,
            m.bytes,
            m.seconds,
            m.frames,
            100.0 * m.busy / m.seconds,
            format!("{measured:.1}{unit}"),
            format!("{exact:.1}{unit}"),
            100.0 * measured / exact,
            format!("{long:.1}{unit}"),
            100.0 * measured / long,
            m.host_seconds,
        );
    }
    println!(
        "frames = frames on the bus from the first request until the master holds the data \
         (minimum for the transfer: {} / {} / {}); busy = share of the bus time the wire carried \
         a frame; host = host time to simulate",
        min_frames[0], min_frames[1], min_frames[2]
    );
    println!(
        "the master runs with Network::set_transfer_gap(0) (a clean bus); its default 1 ms pause \
         between transfers to one node, kept for buses that duplicate frames, would cap the \
         {} expedited reads at about 800/s",
        expedited.transfers
    );
}
