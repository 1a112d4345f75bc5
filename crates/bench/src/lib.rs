//! SDO throughput benchmarks of the `canola` master.
//!
//! Two programs share the definitions of this library:
//! * the bench `bus_bound` (`cargo bench -p canola-bench --bench bus_bound`): expedited,
//!   segmented and block uploads from a simulated device ([`canola::SimDevice`]) to the master
//!   ([`canola::Network`]) on the in-memory bus with the 1 Mbit/s timing model, in bus time, as
//!   a share of the CAN bus bound computed here ([`Bounds`]);
//! * the binary `vcan_sdo` (run by `tests/vcan/run-all` in the QEMU guest): the same workload on
//!   vcan0 by this master and by python-canopen's `RemoteNode` (`py/remote_sdo_bench.py`), both
//!   against one simulated device, side by side.
//!
//! The binary `soak` and the full-load tests use [`load`]: 64 simulated nodes sending
//! synchronous PDOs at 95 % of a 1 Mbit/s bus, optionally with SDO traffic to every node.
//!
//! The binary `drives_csp` uses [`drives`]: eight simulated CiA 402 servos in cyclic synchronous
//! position at 1 kHz SYNC, one target per drive per cycle.
//!
//! The workload (CiA 301 §7.2.4 SDO uploads): expedited reads of [`EXPEDITED_ENTRY`] (4 bytes),
//! and a [`LARGE_LEN`]-byte upload of [`LARGE_ENTRY`], segmented and by block transfer.

pub mod drives;
pub mod load;

use canola::SimDevice;
use canola_frame::NodeId;

/// The EDS of the simulated device: the vcan rig's test device (`tests/vcan/test-device.eds`).
pub const EDS: &[u8] = include_bytes!("../../../tests/vcan/test-device.eds");

/// Object read by expedited transfers: 0x1000 device type (UNSIGNED32).
pub const EXPEDITED_ENTRY: (u16, u8) = (0x1000, 0);

/// The value of [`EXPEDITED_ENTRY`] in [`EDS`].
pub const EXPEDITED_VALUE: u32 = 0x0002_0191;

/// Object holding the large value: 0x2001 "Test text" (VISIBLE_STRING, variable size).
pub const LARGE_ENTRY: (u16, u8) = (0x2001, 0);

/// Size of the large upload: 64 KiB.
pub const LARGE_LEN: usize = 64 * 1024;

/// The large value: byte `i` is `(13 i + 7) mod 251` (`py/remote_sdo_bench.py` checks the same).
pub fn payload(len: usize) -> Vec<u8> {
    (0..len).map(|i| ((i * 13 + 7) % 251) as u8).collect()
}

/// A simulated device from [`EDS`] with node-ID `node` whose [`LARGE_ENTRY`] holds
/// [`payload`]`(large_len)`.
///
/// # Panics
/// If the bundled EDS does not parse (a build-time constant).
pub fn device(node: NodeId, large_len: usize) -> SimDevice {
    let mut dev = SimDevice::from_eds(node, EDS).expect("the bundled EDS parses");
    dev.values_mut()
        .set(LARGE_ENTRY.0, LARGE_ENTRY.1, payload(large_len));
    dev
}

/// Throughput in KiB/s.
pub fn kib_per_s(bytes: usize, secs: f64) -> f64 {
    bytes as f64 / 1024.0 / secs
}

/// Lower bounds of SDO transfers on a CAN bus: the frames a transfer cannot do without, each
/// 8 data bytes long (CiA 301 §7.2.4.3 SDO frames always carry 8 bytes), times the bits of such a
/// frame ([`frame_bits`](Self::frame_bits), from the timing model of [`canola::mem`]), at a bit
/// rate. Bus idle time, processing time of either side and other traffic are zero here, so no
/// implementation can be faster.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bounds {
    /// Bit rate in bit/s.
    pub bitrate: u32,
    /// Count the worst-case number of stuff bits.
    pub worst_case_stuffing: bool,
}

/// Bounds at 1 Mbit/s without stuff bits (the figures of the machine facts: expedited
/// 4 505 transfers/s, segmented 30.8 KiB/s, block 61.1 KiB/s).
pub const BOUNDS_1M: Bounds = Bounds {
    bitrate: 1_000_000,
    worst_case_stuffing: false,
};

/// Segments in one block of a block transfer when both sides use the largest legal block size
/// (CiA 301 §7.2.4.3.9: `blksize` 1..=127).
pub const MAX_BLKSIZE: u32 = 127;

impl Bounds {
    /// Bits of one 8-byte data frame with an 11-bit identifier, interframe space included
    /// (111 without stuffing, 135 with the worst case).
    pub fn frame_bits(&self) -> u32 {
        let frame = canola_frame::CanFrame::new(
            canola_frame::CanId::standard(0x581).expect("0x581 is an 11-bit identifier"),
            &[0; 8],
        )
        .expect("8 data bytes fit a classic frame");
        canola::mem::frame_bits(&frame, self.worst_case_stuffing)
    }

    /// Seconds `frames` 8-byte frames occupy the bus.
    pub fn seconds(&self, frames: u64) -> f64 {
        (frames * u64::from(self.frame_bits())) as f64 / f64::from(self.bitrate)
    }

    /// Expedited transfers per second: request and response per transfer.
    pub fn expedited_per_s(&self) -> f64 {
        1.0 / self.seconds(EXPEDITED_FRAMES)
    }

    /// Segmented upload throughput in KiB/s for long values: a request and a response of 7
    /// data bytes per segment.
    pub fn segmented_kib_per_s(&self) -> f64 {
        7.0 / 1024.0 / self.seconds(2)
    }

    /// Block upload throughput in KiB/s for long values: `blksize` segments of 7 bytes and one
    /// acknowledgement per block.
    pub fn block_kib_per_s(&self, blksize: u32) -> f64 {
        f64::from(7 * blksize) / 1024.0 / self.seconds(u64::from(blksize) + 1)
    }
}

/// Frames of one expedited upload: initiate request and response.
pub const EXPEDITED_FRAMES: u64 = 2;

fn segments(len: usize) -> u64 {
    (len as u64).div_ceil(7)
}

/// Frames of a segmented upload of `len` (> 4) bytes, up to the client holding the data:
/// initiate request and response, then one request and one response per segment of 7 bytes.
pub fn segmented_upload_frames(len: usize) -> u64 {
    2 + 2 * segments(len)
}

/// Frames of a block upload of `len` bytes with `blksize` segments per block, up to the client
/// holding the data: initiate request, initiate response, start request, the segments, one
/// acknowledgement per block, the server's end request. The client's end response (one more
/// frame) follows; it does not delay the data.
pub fn block_upload_frames(len: usize, blksize: u32) -> u64 {
    let segs = segments(len).max(1);
    3 + segs + segs.div_ceil(u64::from(blksize)) + 1
}

/// One measured workload.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// What was done.
    pub label: &'static str,
    /// Completed transfers.
    pub transfers: u64,
    /// Payload bytes received in all.
    pub bytes: usize,
    /// Elapsed time on the transport's clock in seconds (bus time on a virtual-clock bus).
    pub seconds: f64,
    /// Frames on the bus (in-memory bus only).
    pub frames: u64,
    /// Seconds the wire was busy (in-memory bus with the timing model only).
    pub busy: f64,
    /// Host time the measurement took, in seconds.
    pub host_seconds: f64,
    /// CPU time (user and system) of the calling thread during the measurement, in seconds.
    /// The blocking API of [`canola::Network`] does all of the master's work in the thread
    /// that waits, so on a real bus this is the master's cost, apart from the waiting.
    pub cpu_seconds: f64,
    /// Context switches of the calling thread during the measurement (Linux; 0 elsewhere).
    pub switches: u64,
    /// CPU time of the peer (the simulated device's thread) during the measurement, in seconds,
    /// where the caller can tell (0 otherwise).
    pub peer_cpu_seconds: f64,
    /// Context switches of the peer during the measurement, where the caller can tell.
    pub peer_switches: u64,
}

/// Context switches (voluntary and involuntary) of the task whose `/proc/.../status` file is
/// `path`; 0 when unavailable.
pub fn context_switches(path: &str) -> u64 {
    std::fs::read_to_string(path).map_or(0, |s| {
        s.lines()
            .filter(|l| l.contains("ctxt_switches:"))
            .filter_map(|l| l.split_whitespace().last()?.parse::<u64>().ok())
            .sum()
    })
}

/// CPU time (user and system) the calling thread has used, in seconds; 0 where the clock is
/// unavailable.
pub fn thread_cpu_seconds() -> f64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_THREAD_CPUTIME_ID)
        .map_or(0.0, |t| t.tv_sec() as f64 + t.tv_nsec() as f64 / 1e9)
}

/// Failure of a benchmark run: a transfer failed or returned wrong data.
#[derive(Debug)]
pub struct BenchError(pub String);

impl core::fmt::Display for BenchError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BenchError {}

impl From<canola::Error> for BenchError {
    fn from(e: canola::Error) -> Self {
        Self(e.to_string())
    }
}

/// Runs the workload with the master `node`: `expedited` reads of [`EXPEDITED_ENTRY`], then a
/// segmented and a block upload of [`LARGE_ENTRY`] (`large_len` bytes), checking every value.
/// `stats` gives the bus's frame count and busy time where the transport knows them; `peer`
/// the CPU seconds and context switches of the device's thread so far (zeros where unknown);
/// `settle`
/// lets the bus go idle between the parts (the block transfer's last frame, the client's end
/// response, leaves after the data is complete).
pub fn run_workload(
    node: &canola::Node,
    expedited: u64,
    large_len: usize,
    stats: &dyn Fn() -> (u64, f64),
    peer: &dyn Fn() -> (f64, u64),
    settle: &dyn Fn() -> Result<(), BenchError>,
) -> Result<[Measured; 3], BenchError> {
    let net = node.network();
    let measure = |label: &'static str,
                   f: &mut dyn FnMut() -> Result<(u64, usize), BenchError>|
     -> Result<Measured, BenchError> {
        settle()?;
        let (frames0, busy0) = stats();
        let t0 = net.now();
        let host0 = std::time::Instant::now();
        let own = "/proc/thread-self/status";
        let (peer_cpu0, peer_switches0) = peer();
        let switches0 = context_switches(own);
        let cpu0 = thread_cpu_seconds();
        let (transfers, bytes) = f()?;
        let cpu_seconds = thread_cpu_seconds() - cpu0;
        let switches = context_switches(own) - switches0;
        let (peer_cpu1, peer_switches1) = peer();
        let host_seconds = host0.elapsed().as_secs_f64();
        let seconds = (net.now() - t0).as_micros() as f64 / 1e6;
        let (frames1, busy1) = stats();
        Ok(Measured {
            label,
            transfers,
            bytes,
            seconds,
            frames: frames1 - frames0,
            busy: busy1 - busy0,
            host_seconds,
            cpu_seconds,
            switches,
            peer_cpu_seconds: peer_cpu1 - peer_cpu0,
            peer_switches: peer_switches1 - peer_switches0,
        })
    };
    let want = payload(large_len);
    let check_large = |got: Vec<u8>, how: &str| {
        if got == want {
            Ok((1, got.len()))
        } else {
            Err(BenchError(format!(
                "{how} upload of {} bytes returned {} bytes that differ",
                want.len(),
                got.len()
            )))
        }
    };
    let expedited = measure("expedited read", &mut || {
        for _ in 0..expedited {
            let got = node.sdo().read(EXPEDITED_ENTRY).wait()?;
            if got != EXPEDITED_VALUE.to_le_bytes() {
                return Err(BenchError(format!("expedited read returned {got:02x?}")));
            }
        }
        Ok((expedited, 4 * expedited as usize))
    })?;
    let segmented = measure("segmented upload", &mut || {
        check_large(node.sdo().read(LARGE_ENTRY).wait()?, "segmented")
    })?;
    let block = measure("block upload", &mut || {
        check_large(node.sdo().block(true).read(LARGE_ENTRY).wait()?, "block")
    })?;
    settle()?;
    Ok([expedited, segmented, block])
}

/// The workload on the in-memory bus configured by `config` (use a virtual clock and a bit
/// rate for bus time), against a [`device`] with node-ID `node` whose heartbeat is switched off
/// first (0x1017 = 0) so that only SDO frames use the bus.
pub fn in_memory(
    config: canola::BusConfig,
    node: NodeId,
    expedited: u64,
    large_len: usize,
) -> Result<[Measured; 3], BenchError> {
    let bus = canola::MemoryBus::with_config(config);
    let net = canola::Network::new(bus.endpoint());
    // A clean bus: no pause between transfers to one node (see Network::set_transfer_gap).
    net.set_transfer_gap(canola_frame::Duration::ZERO);
    bus.attach(device(node, large_len));
    let n = net.node(node);
    n.sdo().write((0x1017, 0), 0u16).wait()?;
    let stats = || {
        let s = bus.stats();
        (s.frames, s.busy.as_micros() as f64 / 1e6)
    };
    let settle = || Ok(net.run_for(canola_frame::Duration::from_millis(5)).wait()?);
    run_workload(&n, expedited, large_len, &stats, &|| (0.0, 0), &settle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_at_1_mbit_match_the_wire_limits() {
        assert_eq!(BOUNDS_1M.frame_bits(), 111);
        let worst = Bounds {
            worst_case_stuffing: true,
            ..BOUNDS_1M
        };
        assert_eq!(worst.frame_bits(), 135);
        assert_eq!(BOUNDS_1M.expedited_per_s().round(), 4505.0);
        assert_eq!((BOUNDS_1M.segmented_kib_per_s() * 10.0).round(), 308.0);
        assert_eq!(
            (BOUNDS_1M.block_kib_per_s(MAX_BLKSIZE) * 10.0).round(),
            611.0
        );
    }

    #[test]
    fn frame_counts_of_64_kib() {
        // 65 536 / 7 = 9 362.3: 9 363 segments in 74 blocks (73 of 127, one of 92).
        assert_eq!(segmented_upload_frames(LARGE_LEN), 2 + 2 * 9363);
        assert_eq!(block_upload_frames(LARGE_LEN, 127), 3 + 9363 + 74 + 1);
        assert_eq!(block_upload_frames(7 * 127, 127), 3 + 127 + 1 + 1);
    }

    /// On the virtual clock with the timing model the transfers use exactly the frames the
    /// bounds count, and the bus time is the frames' wire time: this is what makes the bench's
    /// share of the bound meaningful.
    #[test]
    fn in_memory_transfers_use_the_counted_frames() {
        let config = canola::BusConfig {
            bitrate: Some(1_000_000),
            ..Default::default()
        };
        let node = NodeId::new(0x5B).unwrap();
        let len = 4 * 7 * 127 + 3;
        let [e, s, b] = in_memory(config, node, 10, len).unwrap();
        assert_eq!((e.transfers, e.frames), (10, 10 * EXPEDITED_FRAMES));
        assert_eq!((s.bytes, s.frames), (len, segmented_upload_frames(len)));
        // Counted when the master holds the data: the client's end response is still queued.
        assert_eq!((b.bytes, b.frames), (len, block_upload_frames(len, 127)));
        for m in [&e, &s, &b] {
            let bound = BOUNDS_1M.seconds(m.frames);
            // Busy time is booked when a frame starts: the client's end response of the block
            // upload may be on the wire already.
            let one = BOUNDS_1M.seconds(1);
            assert!(
                m.busy > bound - 1e-9 && m.busy < bound + one + 1e-9,
                "{m:?}"
            );
            assert!(m.seconds >= bound, "{m:?}");
        }
        // The uploads keep the wire busy; expedited reads do not (the master's quiet time
        // between two transfers to one node; see the bench).
        for m in [&s, &b] {
            assert!(m.seconds < BOUNDS_1M.seconds(m.frames) * 1.001, "{m:?}");
        }
    }

    #[test]
    fn payload_pattern() {
        assert_eq!(&payload(300)[..3], &[7, 20, 33]);
        assert_eq!(payload(300)[251], 7);
    }
}
