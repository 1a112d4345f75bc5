//! SocketCAN transport (Linux, `socketcan` feature).
//!
//! Opens a raw CAN socket with the `socketcan` crate, accepts all CAN error frames, and asks the
//! kernel for the receive-queue drop counter (`SO_RXQ_OVFL`). Frames are read with `recvmsg` so
//! that counter arrives with each frame; when it grows, a [`BusEvent::RxOverflow`] is reported
//! before the frame. Error frames become [`BusEvent`]s: bus-off, error-passive, restarted, and
//! every error frame itself. `ENETDOWN` becomes [`BusEvent::InterfaceDown`], the next successful
//! send [`BusEvent::InterfaceUp`], or the next frame received once the interface's flags say it
//! is up (frames queued before the link went down are still read while it is down).
//!
//! Receive buffer: [`SocketCan::open`] asks for [`DEFAULT_RECEIVE_BUFFER`] bytes
//! (`SO_RCVBUFFORCE`, which needs `CAP_NET_ADMIN`, else `SO_RCVBUF`, which the kernel caps at
//! `net.core.rmem_max`); [`SocketCan::set_receive_buffer`] sets another size and says what the
//! kernel granted. [`SocketCan::stats`] gives a handle to the frame and drop counters that stays
//! readable after the transport moved into a [`Network`](crate::Network).
//!
//! Waiting: [`Transport::recv_until`] blocks in `recvmsg` with the socket's receive timeout
//! (`SO_RCVTIMEO`). That is the cheapest wait the kernel offers: the timer-wheel timeout of a
//! blocking read costs less than the high-resolution timer of `ppoll` (the figure is in
//! `crates/bench/README.md`, "Figures behind design choices in the facade"). The kernel
//! rounds that timeout up to its timer tick (1 to 10 ms depending on `CONFIG_HZ`), so a wait
//! may end up to a tick after its deadline, never before it. A timeout already set is reused
//! while it lies between half and 17/16 of the wait needed, which saves a `setsockopt` per call
//! when the deadlines keep the same distance (the master's drive slice, the simulator's loop).
//! A deadline that has passed is a non-blocking read (`MSG_DONTWAIT`).
//!
//! Precise waits ([`SocketCan::set_precise_waits`], off by default): `ppoll` with the time
//! left, on the kernel's high-resolution timers, then a non-blocking read. A wait then ends
//! within the timer slack (50 µs) of its deadline instead of up to a tick late, at the cost
//! above per wait. A master producing the SYNC at 1 kHz needs it on a kernel with `HZ=250`:
//! with tick-rounded waits its SYNC intervals are 4 to 8 ms (`vcan_drives` in
//! `crates/bench` measures both).
//!
//! Receive coalescing ([`Transport::set_rx_coalescing`], off by default): a receive that finds
//! the socket empty waits for the first frame as above, then sleeps until the window has passed
//! since that frame arrived (or the deadline comes first) and reads what queued meanwhile
//! without blocking, up to the batch's `max_frames` (the rest is read at once by the next
//! receive; a sleep is not cut short by a count, so the receive buffer must hold a window's
//! traffic: the default one holds over 100 ms of a full 1 Mbit/s bus). Frames already queued
//! are read at once. With coalescing on, frames are stamped with the kernel's reception time
//! (`SO_TIMESTAMPNS`, the host's real-time clock, moved onto the transport's monotonic clock by
//! the two clocks' difference when the frame is read; never later than that read nor earlier
//! than the frame read before it), not with the time they were read, so a burst keeps its
//! arrival times. A kernel that refuses the option leaves them stamped when read (up to a
//! window late).
//!
//! CAN FD: an interface carries CAN FD when its MTU is 72 (`CANFD_MTU`, the size of a
//! `struct canfd_frame`; read from `/sys/class/net/IFACE/mtu` at open), classic frames only
//! with MTU 16 (`CAN_MTU`). [`SocketCan::open_fd`] asks an FD interface for CAN FD frames
//! (`CAN_RAW_FD_FRAMES`, what `socketcan::CanFdSocket` sets) and fails on a classic-only one
//! with [`TransportError::FdNotSupported`]; [`SocketCan::open`] leaves them off. Received FD
//! frames come as [`BusEvent::FdFrame`]; [`Transport::send_fd`] writes a 72-byte
//! `canfd_frame` (BRS and ESI from the frame's flags), and fails with `FdNotSupported` unless
//! the socket was opened for FD on an FD interface.

use std::collections::VecDeque;
use std::io::IoSliceMut;
use std::os::fd::AsRawFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, CanId, Instant};
use nix::sys::socket::{ControlMessageOwned, MsgFlags, getsockopt, recvmsg, setsockopt, sockopt};
use socketcan::{EmbeddedFrame, Socket, SocketOptions};

use crate::transport::contract::{BusEvent, Received, RxCoalescing, Transport, TransportError};
use canola_frame::fd::FD_LENGTHS;
use canola_frame::{FdFlags, FdFrame};

const CAN_EFF_FLAG: u32 = 0x8000_0000;
const CAN_RTR_FLAG: u32 = 0x4000_0000;
const CAN_ERR_FLAG: u32 = 0x2000_0000;
const CAN_ERR_CRTL: u32 = 0x0000_0004;
const CAN_ERR_BUSOFF: u32 = 0x0000_0040;
const CAN_ERR_RESTARTED: u32 = 0x0000_0100;
const CAN_ERR_CRTL_RX_PASSIVE: u8 = 0x10;
const CAN_ERR_CRTL_TX_PASSIVE: u8 = 0x20;
/// The size of a `struct canfd_frame`, what a read returns for a CAN FD frame.
const CANFD_MTU: usize = 72;

/// The receive buffer [`SocketCan::open`] asks for, in bytes (the `SO_RCVBUF` value; the kernel
/// doubles it for its bookkeeping and reports the doubled value).
///
/// Sized for a stall of the reading thread of 100 ms at the densest traffic a 1 Mbit/s classic
/// CAN bus carries (0-byte frames of 47 bits: 21,300 frames/s, so 2,130 frames). The kernel
/// charges each queued classic frame with its buffer's true size: measured in the `tests/vcan`
/// guest (Linux 6.1, x86-64), the usual default of 212,992 bytes held 278 frames, 766 bytes
/// each, which is 13 ms of that traffic or 31 ms of 8-byte frames (9,000 frames/s). 1 MiB
/// (2 MiB of accounting room) held 2,731 frames: 128 ms of 0-byte frames, 300 ms of 8-byte
/// ones. Without `CAP_NET_ADMIN` the kernel grants at most `net.core.rmem_max`.
pub const DEFAULT_RECEIVE_BUFFER: usize = 1 << 20;

/// Counters of one [`SocketCan`] transport, shared: a clone taken before the transport moves
/// into a [`Network`](crate::Network) keeps counting. Frames the kernel drops before any socket
/// sees them (its input backlog, counted in the interface's `rx_dropped` statistic) are not
/// in these counts.
#[derive(Debug, Clone, Default)]
pub struct SocketCanStats {
    inner: Arc<StatsInner>,
}

#[derive(Debug, Default)]
struct StatsInner {
    frames: AtomicU64,
    dropped: AtomicU64,
}

impl SocketCanStats {
    /// Frames received (data and remote frames, not error frames).
    pub fn frames_received(&self) -> u64 {
        self.inner.frames.load(Ordering::Relaxed)
    }

    /// Frames the kernel dropped because the socket's receive queue was full, as far as
    /// reported so far (`SO_RXQ_OVFL` arrives with the next frame received after the drops;
    /// each report is also a [`BusEvent::RxOverflow`]).
    pub fn rx_dropped(&self) -> u64 {
        self.inner.dropped.load(Ordering::Relaxed)
    }
}

/// A CAN interface opened through SocketCAN.
pub struct SocketCan {
    socket: socketcan::CanSocket,
    iface: String,
    stats: SocketCanStats,
    clock: MonotonicClock,
    last_drops: u32,
    down: bool,
    events: VecDeque<Received>,
    /// The receive timeout set on the socket (`None`: the kernel's default, none).
    read_timeout: Option<std::time::Duration>,
    /// Wait with `ppoll` (high-resolution timer) instead of the receive timeout.
    precise: bool,
    /// The interface's MTU at open (`None`: unknown).
    mtu: Option<usize>,
    /// CAN FD frames enabled on the socket (`CAN_RAW_FD_FRAMES`).
    fd: bool,
    /// Receive coalescing (see the module docs).
    coalescing: RxCoalescing,
    /// The kernel stamps received frames (`SO_TIMESTAMPNS`, set with coalescing).
    kernel_stamps: bool,
    /// The stamp of the frame read last (a kernel stamp is never put before it).
    last_stamp: Instant,
}

impl core::fmt::Debug for SocketCan {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SocketCan")
            .field("fd", &self.socket.as_raw_fd())
            .finish_non_exhaustive()
    }
}

/// What a raw `struct can_frame` decodes to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum RawFrame {
    Frame(CanFrame),
    Error { class: u32, data: [u8; 8] },
}

/// Decodes the 16 bytes of a Linux `struct can_frame` (identifier in host byte order).
/// Total: bad lengths or identifiers give `None`.
pub(crate) fn decode_raw(buf: &[u8]) -> Option<RawFrame> {
    let id_bytes: [u8; 4] = buf.get(0..4)?.try_into().ok()?;
    let raw_id = u32::from_ne_bytes(id_bytes);
    let len = usize::from(*buf.get(4)?);
    let mut data = [0u8; 8];
    data.copy_from_slice(buf.get(8..16)?);
    if raw_id & CAN_ERR_FLAG != 0 {
        return Some(RawFrame::Error {
            class: raw_id & 0x1FFF_FFFF,
            data,
        });
    }
    let id = if raw_id & CAN_EFF_FLAG != 0 {
        CanId::extended(raw_id & 0x1FFF_FFFF).ok()?
    } else {
        CanId::standard((raw_id & 0x7FF) as u16).ok()?
    };
    let frame = if raw_id & CAN_RTR_FLAG != 0 {
        CanFrame::remote(id, len).ok()?
    } else {
        CanFrame::new(id, data.get(..len)?).ok()?
    };
    Some(RawFrame::Frame(frame))
}

/// Decodes the 72 bytes of a Linux `struct canfd_frame`: identifier, length, the flags digit
/// candump prints (low four bits of `flags`: BRS, ESI, FDF) and the data, padded with zeros to
/// the next CAN FD length as the wire carries it. Total: bad lengths or identifiers give `None`.
pub(crate) fn decode_raw_fd(buf: &[u8]) -> Option<FdFrame> {
    let id_bytes: [u8; 4] = buf.get(0..4)?.try_into().ok()?;
    let raw_id = u32::from_ne_bytes(id_bytes);
    if raw_id & (CAN_ERR_FLAG | CAN_RTR_FLAG) != 0 {
        return None;
    }
    let len = usize::from(*buf.get(4)?);
    let flags = *buf.get(5)? & 0x0F;
    let id = if raw_id & CAN_EFF_FLAG != 0 {
        CanId::extended(raw_id & 0x1FFF_FFFF).ok()?
    } else {
        CanId::standard((raw_id & 0x7FF) as u16).ok()?
    };
    let padded = *FD_LENGTHS.iter().find(|&&l| l >= len)?;
    let mut data = [0u8; 64];
    data[..len].copy_from_slice(buf.get(8..8 + len)?);
    FdFrame::new(id, &data[..padded])
        .ok()
        .map(|f| f.with_flags(FdFlags::from_bits_truncate(flags)))
}

/// Encodes `frame` as the 72 bytes of a Linux `struct canfd_frame`: identifier with the EFF
/// flag, length, flags (BRS and ESI; FDF is the kernel's to set), two reserved bytes, the data
/// padded with zeros.
pub(crate) fn encode_raw_fd(frame: &FdFrame) -> [u8; CANFD_MTU] {
    let mut buf = [0u8; CANFD_MTU];
    let id = match frame.id() {
        CanId::Standard(_) => frame.id().as_raw(),
        CanId::Extended(_) => frame.id().as_raw() | CAN_EFF_FLAG,
    };
    buf[0..4].copy_from_slice(&id.to_ne_bytes());
    buf[4] = frame.dlc() as u8;
    buf[5] = frame.flags().bits() & (FdFlags::BRS.bits() | FdFlags::ESI.bits());
    buf[8..].copy_from_slice(frame.data_padded());
    buf
}

/// The MTU of `iface` from `/sys/class/net/IFACE/mtu`; `None` when it cannot be read.
pub fn interface_mtu(iface: &str) -> Option<usize> {
    std::fs::read_to_string(format!("/sys/class/net/{iface}/mtu"))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// The events an error frame stands for: the frame itself, then state changes it signals.
pub(crate) fn error_events(class: u32, data: [u8; 8]) -> Vec<BusEvent> {
    let mut out = vec![BusEvent::ErrorFrame { class, data }];
    if class & CAN_ERR_CRTL != 0
        && data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE) != 0
    {
        out.push(BusEvent::ErrorPassive);
    }
    if class & CAN_ERR_BUSOFF != 0 {
        out.push(BusEvent::BusOff);
    }
    if class & CAN_ERR_RESTARTED != 0 {
        out.push(BusEvent::Restarted);
    }
    out
}

/// Whether a receive timeout `set` on the socket serves a wait of `wanted`: it ends the wait
/// at most `wanted / 16` late (less than the kernel's own rounding to its tick), and early
/// at most by half (the caller then waits again for the rest).
pub(crate) fn reuse_timeout(set: std::time::Duration, wanted: std::time::Duration) -> bool {
    set <= wanted + wanted / 16 && set >= wanted / 2
}

/// A frame's reception time on the transport's clock, from the kernel's stamp `received` (the
/// real-time clock, since the Unix epoch): as long before `now` (the transport's clock, read
/// with `real_now` of the real-time clock) as the stamp is before `real_now`. Kept between the
/// previous frame's stamp `floor` and `now`, so a step of the real-time clock (or a stamp from
/// the future) cannot reorder frames or date them after their reading.
pub(crate) fn kernel_stamp(
    received: std::time::Duration,
    real_now: std::time::Duration,
    now: Instant,
    floor: Instant,
) -> Instant {
    let age = real_now.saturating_sub(received);
    let age =
        canola_frame::Duration::from_micros(u64::try_from(age.as_micros()).unwrap_or(u64::MAX));
    let at = Instant::from_micros(now.as_micros().saturating_sub(age.as_micros()));
    at.max(floor).min(now)
}

/// Whether `iface` is up (`IFF_UP` in `/sys/class/net/IFACE/flags`); true when that file
/// cannot be read.
fn link_is_up(iface: &str) -> bool {
    std::fs::read_to_string(format!("/sys/class/net/{iface}/flags"))
        .ok()
        .and_then(|s| u32::from_str_radix(s.trim().trim_start_matches("0x"), 16).ok())
        .is_none_or(|flags| flags & 1 != 0)
}

fn is_down(e: &std::io::Error) -> bool {
    matches!(e.raw_os_error(), Some(libc_enetdown) if libc_enetdown == nix::errno::Errno::ENETDOWN as i32)
}

impl SocketCan {
    /// Opens `iface` (e.g. `can0`, `vcan0`) with a receive buffer of
    /// [`DEFAULT_RECEIVE_BUFFER`] bytes, or what the kernel grants of it.
    pub fn open(iface: &str) -> Result<Self, TransportError> {
        let mut t = Self::open_default_buffer(iface)?;
        // A kernel that refuses the size keeps its default; the transport works with it.
        let _ = t.set_receive_buffer(DEFAULT_RECEIVE_BUFFER);
        Ok(t)
    }

    /// Opens `iface` and leaves the socket's receive buffer at the kernel's default
    /// (`net.core.rmem_default`).
    pub fn open_default_buffer(iface: &str) -> Result<Self, TransportError> {
        let socket = socketcan::CanSocket::open(iface)?;
        socket.set_error_filter_accept_all()?;
        // Ask for the drop counter with every received frame; not every kernel offers it, and
        // the transport still works without it.
        let _ = setsockopt(socket.as_raw_socket(), sockopt::RxqOvfl, &1);
        Ok(Self {
            socket,
            iface: iface.to_owned(),
            stats: SocketCanStats::default(),
            clock: MonotonicClock::new(),
            last_drops: 0,
            down: false,
            events: VecDeque::new(),
            read_timeout: None,
            precise: false,
            mtu: interface_mtu(iface),
            fd: false,
            coalescing: RxCoalescing::OFF,
            kernel_stamps: false,
            last_stamp: Instant::ZERO,
        })
    }

    /// Whether [`Transport::recv_until`] waits with `ppoll` on a high-resolution timer, so it
    /// returns within the timer slack of its deadline (see the module docs), instead of the
    /// socket's receive timeout, which the kernel rounds up to its tick. Off by default.
    pub fn set_precise_waits(&mut self, on: bool) {
        self.precise = on;
    }

    /// The transport with precise waits on or off (see
    /// [`set_precise_waits`](Self::set_precise_waits)).
    pub fn with_precise_waits(mut self, on: bool) -> Self {
        self.precise = on;
        self
    }

    /// Waits with `ppoll` until the socket is readable or `wait` has passed; then one
    /// non-blocking read.
    fn poll_wait(&mut self, wait: std::time::Duration) -> Result<(), TransportError> {
        use nix::poll::{PollFd, PollFlags, ppoll};
        use std::os::fd::AsFd;
        let ready = {
            let mut fds = [PollFd::new(self.socket.as_fd(), PollFlags::POLLIN)];
            ppoll(&mut fds, Some(nix::sys::time::TimeSpec::from(wait)), None)
        };
        match ready {
            Ok(0) | Err(nix::errno::Errno::EINTR) => Ok(()),
            Ok(_) => self.read_one(MsgFlags::MSG_DONTWAIT).map(|_| ()),
            Err(e) => Err(std::io::Error::from(e).into()),
        }
    }

    /// Reads what the socket holds without blocking, `reads` reads at most (a frame, an error
    /// frame, or a report of the interface going down each).
    fn read_queued(&mut self, reads: usize) -> Result<(), TransportError> {
        for _ in 0..reads {
            if !self.read_one(MsgFlags::MSG_DONTWAIT)? {
                break;
            }
        }
        Ok(())
    }

    /// The coalescing wait after the first frame of a burst arrived (see the module docs):
    /// sleeps until the window has passed since it arrived or `deadline` comes, then reads
    /// what queued meanwhile, up to the batch's size.
    fn coalesce(&mut self, deadline: Instant) -> Result<(), TransportError> {
        let now = self.clock.now();
        let first = match self.events.front() {
            Some(Received::Frame { at, .. } | Received::Event(BusEvent::FdFrame { at, .. })) => *at,
            _ => now,
        };
        let until = (first + self.coalescing.window()).min(deadline);
        if until > now {
            std::thread::sleep((until - now).into());
        }
        let room = self
            .coalescing
            .max_frames()
            .saturating_sub(self.events.len());
        self.read_queued(room)
    }

    /// Opens `iface` as [`open`](Self::open) does for CAN FD: FD frames are received (as
    /// [`BusEvent::FdFrame`]s) and sent ([`Transport::send_fd`]). Fails with
    /// [`TransportError::FdNotSupported`] when the interface is classic-only (MTU 16).
    pub fn open_fd(iface: &str) -> Result<Self, TransportError> {
        let mut t = Self::open(iface)?;
        t.fd_support_of_interface()?;
        t.socket
            .set_socket_option_int(nix::libc::SOL_CAN_RAW, nix::libc::CAN_RAW_FD_FRAMES, 1)?;
        t.fd = true;
        Ok(t)
    }

    /// The interface's MTU as read at open: 72 for CAN FD, 16 for classic CAN.
    pub fn mtu(&self) -> Option<usize> {
        self.mtu
    }

    /// Whether the interface (not the socket) carries CAN FD: its MTU is 72.
    fn fd_support_of_interface(&self) -> Result<(), TransportError> {
        match self.mtu {
            Some(CANFD_MTU) => Ok(()),
            Some(mtu) => Err(TransportError::fd_not_supported(format!(
                "{} (MTU {mtu}: classic CAN only; `ip link set {} mtu 72` while it is down makes it CAN FD)",
                self.iface, self.iface
            ))),
            None => Err(TransportError::fd_not_supported(format!(
                "{} (its MTU could not be read)",
                self.iface
            ))),
        }
    }

    /// Asks for a receive buffer of `bytes` (the `SO_RCVBUF` value) and returns what the kernel
    /// then reports (`getsockopt(SO_RCVBUF)`: twice the value granted). `SO_RCVBUFFORCE` is
    /// tried first: it needs `CAP_NET_ADMIN` and ignores `net.core.rmem_max`; without the
    /// capability `SO_RCVBUF` is used, which the kernel caps at `rmem_max`.
    pub fn set_receive_buffer(&mut self, bytes: usize) -> Result<usize, TransportError> {
        let fd = self.socket.as_raw_socket();
        if setsockopt(fd, sockopt::RcvBufForce, &bytes).is_err() {
            setsockopt(fd, sockopt::RcvBuf, &bytes).map_err(std::io::Error::from)?;
        }
        self.receive_buffer()
    }

    /// The receive buffer as the kernel reports it (`getsockopt(SO_RCVBUF)`), in bytes.
    pub fn receive_buffer(&self) -> Result<usize, TransportError> {
        Ok(getsockopt(self.socket.as_raw_socket(), sockopt::RcvBuf)
            .map_err(std::io::Error::from)?)
    }

    /// A handle to this transport's counters (frames received, frames the kernel dropped).
    pub fn stats(&self) -> SocketCanStats {
        self.stats.clone()
    }

    fn came_up(&mut self) {
        if self.down {
            self.down = false;
            self.events
                .push_back(Received::Event(BusEvent::InterfaceUp));
        }
    }

    fn went_down(&mut self) {
        if !self.down {
            self.down = true;
            self.events
                .push_back(Received::Event(BusEvent::InterfaceDown));
        }
    }

    /// Sets the receive timeout for a blocking read that should return after `wait`, unless
    /// the one already set serves (see the module docs).
    fn set_wait(&mut self, wait: std::time::Duration) -> Result<(), TransportError> {
        // A zero timeout would mean "block forever" to the kernel.
        let wait = wait.max(std::time::Duration::from_micros(100));
        if let Some(set) = self.read_timeout
            && reuse_timeout(set, wait)
        {
            return Ok(());
        }
        self.socket.set_read_timeout(wait)?;
        self.read_timeout = Some(wait);
        Ok(())
    }

    /// One `recvmsg`: blocking with the socket's read timeout, or not blocking with
    /// `MSG_DONTWAIT`. `Ok(false)`: nothing arrived.
    fn read_one(&mut self, flags: MsgFlags) -> Result<bool, TransportError> {
        let mut buf = [0u8; CANFD_MTU];
        let mut cmsg = nix::cmsg_space!(u32, nix::sys::time::TimeSpec);
        let (n, drops, kernel_at) = {
            let mut iov = [IoSliceMut::new(&mut buf)];
            let msg = match recvmsg::<()>(self.socket.as_raw_fd(), &mut iov, Some(&mut cmsg), flags)
            {
                Ok(m) => m,
                Err(nix::errno::Errno::EAGAIN | nix::errno::Errno::EINTR) => return Ok(false),
                Err(nix::errno::Errno::ENETDOWN) => {
                    self.went_down();
                    return Ok(true);
                }
                Err(e) => return Err(std::io::Error::from(e).into()),
            };
            let (mut drops, mut kernel_at) = (None, None);
            if let Ok(cmsgs) = msg.cmsgs() {
                for c in cmsgs {
                    match c {
                        ControlMessageOwned::RxqOvfl(d) => drops = Some(d),
                        ControlMessageOwned::ScmTimestampns(t) => kernel_at = Some(t),
                        _ => {}
                    }
                }
            }
            (msg.bytes, drops, kernel_at)
        };
        if self.down && link_is_up(&self.iface) {
            self.came_up();
        }
        if let Some(d) = drops
            && d != self.last_drops
        {
            let dropped = u64::from(d.wrapping_sub(self.last_drops));
            self.last_drops = d;
            self.stats
                .inner
                .dropped
                .fetch_add(dropped, Ordering::Relaxed);
            self.events
                .push_back(Received::Event(BusEvent::RxOverflow { dropped }));
        }
        let now = self.clock.now();
        let at = match kernel_at {
            Some(t) if self.kernel_stamps => {
                let received = std::time::Duration::new(
                    u64::try_from(t.tv_sec()).unwrap_or(0),
                    u32::try_from(t.tv_nsec()).unwrap_or(0),
                );
                let real_now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .unwrap_or_default();
                kernel_stamp(received, real_now, now, self.last_stamp)
            }
            _ => now,
        };
        self.last_stamp = at;
        if n == CANFD_MTU {
            if let Some(frame) = decode_raw_fd(&buf) {
                let frame = Box::new(frame);
                self.events
                    .push_back(Received::Event(BusEvent::FdFrame { frame, at }));
            }
            return Ok(true);
        }
        match buf.get(..n).and_then(decode_raw) {
            Some(RawFrame::Frame(frame)) => {
                self.stats.inner.frames.fetch_add(1, Ordering::Relaxed);
                self.events.push_back(Received::Frame { frame, at });
            }
            Some(RawFrame::Error { class, data }) => {
                for e in error_events(class, data) {
                    self.events.push_back(Received::Event(e));
                }
            }
            None => {}
        }
        Ok(true)
    }
}

impl Transport for SocketCan {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let id: socketcan::Id = frame.id().into();
        let out = if frame.is_remote() {
            socketcan::CanFrame::new_remote(id, frame.dlc())
        } else {
            socketcan::CanFrame::new(id, frame.data())
        };
        let Some(out) = out else {
            return Err(TransportError::Io(std::io::Error::other(
                "frame not representable",
            )));
        };
        match self.socket.write_frame(&out) {
            Ok(()) => {
                self.came_up();
                Ok(())
            }
            Err(e) if is_down(&e) => {
                self.went_down();
                Err(TransportError::InterfaceDown)
            }
            Err(e) if e.raw_os_error() == Some(nix::errno::Errno::ENOBUFS as i32) => {
                Err(TransportError::TxQueueFull)
            }
            Err(e) => Err(e.into()),
        }
    }

    fn fd_support(&self) -> Result<(), TransportError> {
        self.fd_support_of_interface()?;
        if self.fd {
            Ok(())
        } else {
            Err(TransportError::fd_not_supported(format!(
                "{} (opened for classic CAN; open it for CAN FD)",
                self.iface
            )))
        }
    }

    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        self.fd_support()?;
        let buf = encode_raw_fd(frame);
        match nix::sys::socket::send(self.socket.as_raw_fd(), &buf, MsgFlags::empty()) {
            Ok(_) => {
                self.came_up();
                Ok(())
            }
            Err(nix::errno::Errno::ENETDOWN) => {
                self.went_down();
                Err(TransportError::InterfaceDown)
            }
            Err(nix::errno::Errno::ENOBUFS | nix::errno::Errno::EAGAIN) => {
                Err(TransportError::TxQueueFull)
            }
            Err(e) => Err(std::io::Error::from(e).into()),
        }
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        // Whether this call waited on the socket (what it holds now arrived meanwhile).
        let mut waited = false;
        loop {
            if !self.events.is_empty() {
                if waited && self.coalescing.is_on() {
                    self.coalesce(deadline)?;
                }
                return Ok(self.events.pop_front());
            }
            let now = self.clock.now();
            if now >= deadline {
                // Something already queued?
                self.read_one(MsgFlags::MSG_DONTWAIT)?;
                return Ok(self.events.pop_front());
            }
            if self.coalescing.is_on() && !waited {
                // What the socket holds already comes at once: coalescing is for a burst that
                // starts while the receive waits.
                self.read_queued(self.coalescing.max_frames())?;
                if let Some(r) = self.events.pop_front() {
                    return Ok(Some(r));
                }
            }
            waited = true;
            if self.precise {
                self.poll_wait((deadline - now).into())?;
                continue;
            }
            self.set_wait((deadline - now).into())?;
            self.read_one(MsgFlags::empty())?;
        }
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }

    fn has_pending(&self) -> bool {
        !self.events.is_empty()
    }

    fn set_rx_coalescing(&mut self, coalescing: RxCoalescing) -> bool {
        self.coalescing = coalescing;
        let on = coalescing.is_on();
        // Kernel stamps only with coalescing: without it a frame is read as it arrives.
        if on != self.kernel_stamps {
            let fd = self.socket.as_raw_socket();
            self.kernel_stamps = setsockopt(fd, sockopt::ReceiveTimestampns, &on).is_ok() && on;
        }
        on
    }
}

#[cfg(test)]
mod tests;
