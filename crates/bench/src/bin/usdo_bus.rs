//! USDO (CANopen FD) against classic SDO on the in-memory bus's timing model: a 64 KiB
//! segmented USDO upload at 1 Mbit/s arbitration with a 2 and a 5 Mbit/s data phase, and a
//! 64 KiB classic SDO block upload (block size 127) at 1 Mbit/s, each timed on the bus's
//! virtual clock from the first request until the master holds the data, and each against its
//! bus-time bound: the frames the transfer cannot do without, each timed from its bit count
//! (`canola::mem::fd_frame_time` / `frame_bits`, no stuff bits).
//!
//! USDO segmented upload of `len` bytes (the frame sizes of the documented layout, see
//! `../shared/spec/usdo.md` §6): upload request (6 bytes), initiate response (12), then per
//! 60-byte segment a segment request (4) and a segment response (64), the last one an end
//! response of 4 + the remaining bytes. Every USDO frame has the bit-rate switch set.
//!
//! `cargo run --release -p canola-bench --bin usdo_bus`

use canola::mem::{fd_frame_time, frame_bits};
use canola::{BusConfig, ClockMode, MemoryBus, Network};
use canola_bench::{
    BOUNDS_1M, LARGE_ENTRY, LARGE_LEN, MAX_BLKSIZE, block_upload_frames, device, in_memory,
    kib_per_s, payload,
};
use canola_frame::{CanId, Duration, FdFrame, NodeId};

const ARBITRATION: u32 = 1_000_000;
/// Data bytes of a full USDO upload segment response.
const SEGMENT: usize = 60;

/// The frame sizes of a segmented USDO upload of `len` bytes (more than 56), in bus order.
fn usdo_upload_frames(len: usize) -> Vec<usize> {
    let full = len / SEGMENT;
    let rest = len % SEGMENT;
    let mut out = vec![6, 12];
    for _ in 0..full {
        out.extend([4, 64]);
    }
    if rest > 0 || full == 0 {
        out.extend([4, 4 + rest]);
    }
    out
}

/// Bus time of `sizes` as CAN FD frames with the bit-rate switch.
fn fd_bound(sizes: &[usize], data_bitrate: u32) -> Result<f64, String> {
    let id = CanId::standard(0x600).map_err(|e| e.to_string())?;
    let mut micros = 0u64;
    for &n in sizes {
        let f = FdFrame::new_padded(id, &vec![0; n])
            .map_err(|e| e.to_string())?
            .with_brs(true);
        micros += fd_frame_time(&f, ARBITRATION, Some(data_bitrate), false).as_micros();
    }
    Ok(micros as f64 / 1e6)
}

struct Row {
    label: String,
    seconds: f64,
    frames: u64,
    bound_frames: u64,
    bound_seconds: f64,
}

fn usdo_row(data_bitrate: u32) -> Result<Row, String> {
    let node = NodeId::new(0x5B).map_err(|e| e.to_string())?;
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::Virtual,
        bitrate: Some(ARBITRATION),
        fd: true,
        data_bitrate: Some(data_bitrate),
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    net.set_transfer_gap(Duration::ZERO);
    bus.attach(device(node, LARGE_LEN).with_fd(true));
    let n = net.node(node);
    n.set_fd(true);
    n.sdo()
        .write((0x1017, 0), 0u16)
        .wait()
        .map_err(|e| e.to_string())?;
    net.run_for(Duration::from_millis(5))
        .wait()
        .map_err(|e| e.to_string())?;
    let frames0 = bus.stats().frames;
    let t0 = net.now();
    let data = n
        .usdo()
        .read(LARGE_ENTRY)
        .wait()
        .map_err(|e| e.to_string())?;
    let seconds = (net.now() - t0).as_micros() as f64 / 1e6;
    let frames = bus.stats().frames - frames0;
    if data != payload(LARGE_LEN) {
        return Err("the USDO upload returned other data".into());
    }
    let sizes = usdo_upload_frames(LARGE_LEN);
    Ok(Row {
        label: format!(
            "USDO segmented, 1 Mbit/s + {} Mbit/s data",
            data_bitrate / 1_000_000
        ),
        seconds,
        frames,
        bound_frames: sizes.len() as u64,
        bound_seconds: fd_bound(&sizes, data_bitrate)?,
    })
}

fn sdo_block_row() -> Result<Row, String> {
    let node = NodeId::new(0x5B).map_err(|e| e.to_string())?;
    let config = BusConfig {
        clock: ClockMode::Virtual,
        bitrate: Some(ARBITRATION),
        ..BusConfig::default()
    };
    let [_, _, block] = in_memory(config, node, 1, LARGE_LEN).map_err(|e| e.0)?;
    let bound_frames = block_upload_frames(LARGE_LEN, MAX_BLKSIZE);
    // Every frame of a block upload carries 8 data bytes (11-bit identifiers).
    let id = CanId::standard(0x580).map_err(|e| e.to_string())?;
    let bits = frame_bits(
        &canola_frame::CanFrame::new(id, &[0; 8]).map_err(|e| e.to_string())?,
        false,
    );
    debug_assert_eq!(bits, BOUNDS_1M.frame_bits());
    Ok(Row {
        label: "classic SDO block (127), 1 Mbit/s".into(),
        seconds: block.seconds,
        frames: block.frames,
        bound_frames,
        bound_seconds: bound_frames as f64 * f64::from(bits) / f64::from(ARBITRATION),
    })
}

fn main() {
    let mut rows = Vec::new();
    let mut failed = false;
    for r in [usdo_row(2_000_000), usdo_row(5_000_000), sdo_block_row()] {
        match r {
            Ok(r) => rows.push(r),
            Err(e) => {
                eprintln!("error: {e}");
                failed = true;
            }
        }
    }
    println!(
        "64 KiB upload, bus model without stuff bits, virtual clock\n\
         {:<44} {:>9} {:>10} {:>7} {:>7} {:>9} {:>10} {:>7}",
        "transfer", "ms", "KiB/s", "frames", "bound", "bound ms", "bound KiB/s", "share"
    );
    for r in &rows {
        println!(
            "{:<44} {:>9.1} {:>10.1} {:>7} {:>7} {:>9.1} {:>10.1} {:>6.1}%",
            r.label,
            r.seconds * 1e3,
            kib_per_s(LARGE_LEN, r.seconds),
            r.frames,
            r.bound_frames,
            r.bound_seconds * 1e3,
            kib_per_s(LARGE_LEN, r.bound_seconds),
            100.0 * r.bound_seconds / r.seconds
        );
        if r.frames != r.bound_frames {
            eprintln!(
                "error: {} used {} frames, {} expected",
                r.label, r.frames, r.bound_frames
            );
            failed = true;
        }
    }
    if failed {
        std::process::exit(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usdo_frame_sizes_of_64_kib() {
        // 65 536 = 1 092 × 60 + 16: 1 093 requests, 1 092 full responses, an end of 20 bytes.
        let f = usdo_upload_frames(LARGE_LEN);
        assert_eq!(f.len(), 2 + 2 * 1093);
        assert_eq!(f[..4], [6, 12, 4, 64]);
        assert_eq!(f[f.len() - 2..], [4, 20]);
    }
}
