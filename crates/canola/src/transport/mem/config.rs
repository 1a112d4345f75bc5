//! The in-memory bus's settings and timing model: how it tells time ([`ClockMode`]), the
//! faults it injects ([`Faults`]), the bit rate and stuffing it models ([`BusConfig`]), what it
//! counts ([`BusStats`]), and a frame's length on the wire (ISO 11898-1:2015, classic and
//! CAN FD).

use canola_frame::{CanFrame, CanId, Duration, FdFrame};

/// How the bus tells time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ClockMode {
    /// Deterministic simulated time starting at zero; advances only while an endpoint waits.
    #[default]
    Virtual,
    /// The host's monotonic clock.
    RealTime,
}

/// Fault injection settings. Shares are probabilities in `0.0..=1.0`, applied to every frame
/// independently, in this order: drop, corrupt, delay, duplicate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    /// Share of frames that vanish (no station receives them).
    pub drop: f64,
    /// Share of frames delivered twice.
    pub duplicate: f64,
    /// Share of frames whose data has one bit flipped (frames without data are not corrupted).
    /// Models a corruption the CRC did not catch.
    pub corrupt: f64,
    /// Share of frames held back by a random time up to [`max_delay`](Self::max_delay), which
    /// may reorder them.
    pub delay: f64,
    /// Upper bound of an injected delay.
    pub max_delay: Duration,
    /// Seed of the pseudo-random generator.
    pub seed: u64,
}

impl Default for Faults {
    fn default() -> Self {
        Self {
            drop: 0.0,
            duplicate: 0.0,
            corrupt: 0.0,
            delay: 0.0,
            max_delay: Duration::from_millis(10),
            seed: 0x5EED,
        }
    }
}

impl Faults {
    /// No faults.
    pub fn none() -> Self {
        Self::default()
    }

    /// Whether any fault can happen.
    pub(super) fn any(&self) -> bool {
        self.drop > 0.0 || self.corrupt > 0.0 || self.delay > 0.0 || self.duplicate > 0.0
    }
}

/// Configuration of an in-memory bus.
#[derive(Debug, Clone, PartialEq)]
pub struct BusConfig {
    /// Clock mode.
    pub clock: ClockMode,
    /// Bit rate for the timing model in bit/s (e.g. 125_000..=1_000_000); `None` delivers frames
    /// instantly.
    pub bitrate: Option<u32>,
    /// Count the worst-case number of stuff bits in the timing model.
    pub worst_case_stuffing: bool,
    /// Receive queue length of each endpoint; beyond it frames are dropped and reported.
    pub queue_capacity: usize,
    /// Frames each endpoint may have waiting for the wire; beyond it [`Transport::send`](crate::Transport::send) fails
    /// with [`TransportError::TxQueueFull`](crate::TransportError::TxQueueFull), as a SocketCAN socket does with `ENOBUFS`. A
    /// controller's transmit queue is bounded, so a sender that offers more than the bus
    /// carries meets back-pressure instead of an ever longer backlog.
    pub tx_queue_capacity: usize,
    /// Fault injection.
    pub faults: Faults,
    /// Whether the bus carries CAN FD frames (every controller on it is FD-capable). A
    /// classic bus (the default) refuses [`Transport::send_fd`](crate::Transport::send_fd)
    /// with [`TransportError::FdNotSupported`](crate::TransportError::FdNotSupported).
    pub fd: bool,
    /// CAN FD data-phase bit rate in bit/s (e.g. 2_000_000 or 5_000_000) for the timing model:
    /// an FD frame with the bit-rate switch set sends its data phase at this rate, the rest at
    /// [`bitrate`](Self::bitrate). `None`: the data phase runs at `bitrate` too.
    pub data_bitrate: Option<u32>,
}

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            clock: ClockMode::Virtual,
            bitrate: None,
            worst_case_stuffing: false,
            queue_capacity: 4096,
            tx_queue_capacity: 256,
            faults: Faults::none(),
            fd: false,
            data_bitrate: None,
        }
    }
}

/// Counters of what the bus did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusStats {
    /// Frames that went over the wire (duplicates counted twice).
    pub frames: u64,
    /// Frames removed by fault injection.
    pub dropped: u64,
    /// Frames duplicated by fault injection.
    pub duplicated: u64,
    /// Frames corrupted by fault injection.
    pub corrupted: u64,
    /// Frames delayed by fault injection.
    pub delayed: u64,
    /// Frames lost to full receive queues (summed over endpoints).
    pub overflowed: u64,
    /// Time the wire was busy (timing model only).
    pub busy: Duration,
}

/// Number of bits a classic data or remote frame occupies on the wire, interframe space included.
///
/// With `worst_case_stuffing`, adds the most stuff bits the frame can need: one per four bits of
/// the stuffed region (start of frame to the end of the CRC sequence) after the first.
pub fn frame_bits(frame: &CanFrame, worst_case_stuffing: bool) -> u32 {
    let n = if frame.is_remote() {
        0
    } else {
        frame.data().len() as u32 * 8
    };
    let (fixed, stuffed) = if frame.id().is_extended() {
        (67, 54)
    } else {
        (47, 34)
    };
    let stuff = if worst_case_stuffing {
        (stuffed + n - 1) / 4
    } else {
        0
    };
    fixed + n + stuff
}

/// On-wire time of `frame` at `bitrate` bit/s, rounded up to a whole microsecond.
pub fn frame_time(frame: &CanFrame, bitrate: u32, worst_case_stuffing: bool) -> Duration {
    let bits = u64::from(frame_bits(frame, worst_case_stuffing));
    let rate = u64::from(bitrate.max(1));
    Duration::from_micros((bits * 1_000_000).div_ceil(rate))
}

/// The bits of a CAN FD frame on the wire, by phase: `(nominal, data)`. The nominal phase
/// (arbitration bit rate) runs from the start of frame to the bit-rate switch, and from the
/// CRC delimiter to the end of the interframe space; the data phase from the error state
/// indicator to the end of the CRC (ISO 11898-1:2015 FD frame formats):
///
/// * nominal, 11-bit identifier: SOF, 11 identifier bits, RRS, IDE, FDF, res, BRS = 17; a
///   29-bit identifier adds SRR and 18 identifier bits = 36; then CRC delimiter, ACK slot,
///   ACK delimiter, 7 EOF bits and 3 interframe bits = 13;
/// * data: ESI, 4 DLC bits, the data, the 4-bit stuff count (3 bits and parity), the CRC (17
///   bits up to 16 data bytes, 21 above) and its fixed stuff bits (one before the stuff count,
///   then one after every 4 bits: 6 for CRC-17, 7 for CRC-21).
///
/// With `worst_case_stuffing`, adds the most dynamic stuff bits: one per four bits of the
/// dynamically stuffed region (start of frame to the end of the data) after the first, counted
/// in the phase they fall in.
pub fn fd_frame_bits(frame: &FdFrame, worst_case_stuffing: bool) -> (u32, u32) {
    let n = frame.data().len() as u32 * 8;
    let head = if frame.id().is_extended() { 36 } else { 17 };
    let crc = if frame.data().len() > 16 {
        21 + 7
    } else {
        17 + 6
    };
    let mut nominal = head + 13;
    let mut data = 1 + 4 + n + 4 + crc;
    if worst_case_stuffing {
        // The region SOF..data: `head` nominal bits, then ESI, DLC and the data.
        nominal += (head - 1) / 4;
        data += (5 + n) / 4;
    }
    (nominal, data)
}

/// On-wire time of a CAN FD frame: the nominal phase at `bitrate`, the data phase at
/// `data_bitrate` when its bit-rate switch is set (else at `bitrate` too), rounded up to a whole
/// microsecond.
pub fn fd_frame_time(
    frame: &FdFrame,
    bitrate: u32,
    data_bitrate: Option<u32>,
    worst_case_stuffing: bool,
) -> Duration {
    let (nominal, data) = fd_frame_bits(frame, worst_case_stuffing);
    let rate = u64::from(bitrate.max(1));
    let data_rate = match data_bitrate {
        Some(r) if frame.brs() => u64::from(r.max(1)),
        _ => rate,
    };
    // Each phase in nanoseconds, summed, then rounded up to the microsecond.
    let ns = (u64::from(nominal) * 1_000_000_000).div_ceil(rate)
        + (u64::from(data) * 1_000_000_000).div_ceil(data_rate);
    Duration::from_micros(ns.div_ceil(1000))
}

/// Arbitration value: lower wins (ISO 11898-1 identifier priority, data beats remote). A CAN FD
/// frame arbitrates as a classic data frame with its identifier (its RRS bit is dominant where
/// a classic frame has RTR).
pub(super) fn arbitration_key(id: CanId, remote: bool) -> u64 {
    let (base, ide, ext) = match id {
        CanId::Standard(s) => (u64::from(s.as_raw()), 0, 0),
        CanId::Extended(e) => {
            let raw = u64::from(e.as_raw());
            (raw >> 18, 1, raw & 0x3_FFFF)
        }
    };
    // base id, then (SRR/RTR, IDE) — an 11-bit frame's RTR bit sits where a 29-bit frame has a
    // recessive SRR — then the extension and the final RTR bit.
    let rtr = u64::from(remote);
    let std_rtr = if ide == 1 { 1 } else { rtr };
    (base << 22) | (std_rtr << 21) | (ide << 20) | (ext << 1) | if ide == 1 { rtr } else { 0 }
}

/// SplitMix64: small, seedable, good enough for fault injection.
#[derive(Debug, Clone)]
pub(super) struct Rng(pub(super) u64);

impl Rng {
    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[0, 1)`.
    pub(super) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub(super) fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.unit() < p
    }
}
