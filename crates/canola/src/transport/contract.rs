//! The contract every transport fulfils: the [`Transport`] trait, what it receives
//! ([`Received`], [`BusEvent`]), its errors, and the [`Station`] a bus steps with
//! [`run_station`].
//!
//! CAN FD (ISO 11898-1:2015): a transport says whether it carries FD frames
//! ([`Transport::fd_support`]); one that does sends them with [`Transport::send_fd`] and
//! reports received ones as [`BusEvent::FdFrame`]. On a classic-only bus (a SocketCAN
//! interface with MTU 16, an slcan adapter without a data bit rate, an in-memory bus
//! configured classic) `send_fd` fails with [`TransportError::FdNotSupported`], naming the bus.

use canola_frame::{CanFrame, Duration, FdFrame, Instant, is_due};

/// Something that happened on the bus other than a received frame.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum BusEvent {
    /// The controller reported a CAN error frame. `class` holds the SocketCAN error class bits
    /// (`CAN_ERR_*` in `linux/can/error.h`), `data` the eight detail bytes.
    ErrorFrame {
        /// Error class bits (the error frame's identifier without the error flag).
        class: u32,
        /// Detail bytes of the error frame.
        data: [u8; 8],
    },
    /// The controller went error-passive (transmit or receive error counter above 127).
    ErrorPassive,
    /// The controller went bus-off (transmit error counter above 255); it sends nothing until
    /// restarted.
    BusOff,
    /// The controller restarted after bus-off.
    Restarted,
    /// The network interface went down; sends fail until it is up again.
    InterfaceDown,
    /// The network interface came (back) up.
    InterfaceUp,
    /// The receive queue overflowed; `dropped` frames were lost since the last report.
    RxOverflow {
        /// Frames lost since the previous overflow report.
        dropped: u64,
    },
    /// The adapter refused a frame written earlier (an slcan adapter's BEL after a frame line:
    /// channel closed, transmit queue full).
    TxRefused,
    /// The adapter sent bytes that are not its protocol (a serial-line adapter's line that did
    /// not decode); the transport skipped them and carries on. `total` counts them since the
    /// transport was opened.
    BadInput {
        /// What was wrong with them.
        detail: String,
        /// Bad inputs since the transport was opened.
        total: u64,
    },
    /// A CAN FD frame arrived. Only a transport that carries CAN FD reports them (see
    /// [`Transport::fd_support`]); the master routes USDO responses from them and hands every
    /// one to its subscribers.
    FdFrame {
        /// The frame.
        frame: Box<FdFrame>,
        /// When it was received, on the transport's clock.
        at: Instant,
    },
}

impl core::fmt::Display for BusEvent {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ErrorFrame { class, data } => {
                write!(f, "CAN error frame, class {class:#010x}, data {data:02X?}")
            }
            Self::ErrorPassive => f.write_str("controller is error-passive"),
            Self::BusOff => f.write_str("controller is bus-off"),
            Self::Restarted => f.write_str("controller restarted"),
            Self::InterfaceDown => f.write_str("interface is down"),
            Self::InterfaceUp => f.write_str("interface is up"),
            Self::RxOverflow { dropped } => {
                write!(f, "receive queue overflow: {dropped} frame(s) dropped")
            }
            Self::TxRefused => f.write_str("the adapter refused a frame"),
            Self::BadInput { detail, total } => {
                write!(f, "bad input from the adapter ({total} so far): {detail}")
            }
            Self::FdFrame { frame, .. } => write!(f, "CAN FD frame {frame}"),
        }
    }
}

/// What a receive call returns: a frame with its reception time, or a bus event.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Received {
    /// A frame from another station, stamped with the transport's clock.
    Frame {
        /// The frame.
        frame: CanFrame,
        /// When it was received, on the transport's clock.
        at: Instant,
    },
    /// A bus event.
    Event(BusEvent),
}

/// Local failures of a transport.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    /// The interface is down (or the bus was closed).
    #[error("the CAN interface is down")]
    InterfaceDown,
    /// The controller is bus-off and cannot send.
    #[error("the CAN controller is bus-off")]
    BusOff,
    /// The transmit queue is full.
    #[error("the transmit queue is full")]
    TxQueueFull,
    /// The transport is closed for good.
    #[error("the transport is closed")]
    Closed,
    /// An operating-system error.
    #[error("CAN I/O error: {0}")]
    Io(#[from] std::io::Error),
    /// A CAN FD frame was to be sent on a bus that carries classic frames only. `bus` names
    /// it and says why (e.g. `vcan0 (MTU 16: classic CAN only)`).
    #[error("FD not supported on {bus}")]
    FdNotSupported {
        /// The bus and why it is classic-only.
        bus: String,
    },
}

impl TransportError {
    /// The error of a classic-only `bus` asked for CAN FD.
    pub fn fd_not_supported(bus: impl Into<String>) -> Self {
        Self::FdNotSupported { bus: bus.into() }
    }
}

/// Receive wake-up coalescing, an opt-in setting of a transport
/// ([`Transport::set_rx_coalescing`]): a blocking [`recv_until`](Transport::recv_until) that
/// finds nothing queued waits for the first frame or event, then goes on waiting until
/// `window` has passed since it arrived, until `max_frames` are queued (where the transport
/// can count them without reading them: the in-memory bus; SocketCAN sleeps out the window and
/// then reads at most `max_frames`), or until its own deadline, whichever comes first, and so hands a burst over with one wake-up instead of one
/// per frame. What is queued already is returned at once as without it; received frames keep
/// their reception times; the deadline is never passed (the network's timers are not delayed).
/// The cost is latency: a frame may reach the caller up to `window` after it arrived.
///
/// Meant for a receiver that looks at the bus at its own slower pace (a view drawn ten times a
/// second), not for a master waiting for SDO answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RxCoalescing {
    window: Duration,
    max_frames: usize,
}

impl RxCoalescing {
    /// No coalescing: every wait ends at the first frame (what a transport does by default).
    pub const OFF: Self = Self {
        window: Duration::ZERO,
        max_frames: 1,
    };

    /// How many frames end a coalescing wait early unless set otherwise
    /// ([`with_max_frames`](Self::with_max_frames)): at 1 Mbit/s a classic bus carries at most
    /// about 21 000 frames a second, so this is over 10 ms of the densest traffic.
    pub const DEFAULT_MAX_FRAMES: usize = 256;

    /// Coalescing over `window` (zero: off), ended early by
    /// [`DEFAULT_MAX_FRAMES`](Self::DEFAULT_MAX_FRAMES) frames.
    pub const fn new(window: Duration) -> Self {
        Self {
            window,
            max_frames: Self::DEFAULT_MAX_FRAMES,
        }
    }

    /// The same window, ended early once `max_frames` (at least 1) frames and events are
    /// queued (see the type's docs for SocketCAN), and at most that many handed over per wait.
    pub const fn with_max_frames(self, max_frames: usize) -> Self {
        Self {
            window: self.window,
            max_frames: if max_frames == 0 { 1 } else { max_frames },
        }
    }

    /// How long a wait goes on after its first frame.
    pub const fn window(&self) -> Duration {
        self.window
    }

    /// How many queued frames and events end the wait early.
    pub const fn max_frames(&self) -> usize {
        self.max_frames
    }

    /// Whether this setting coalesces at all (a window above zero, more than one frame).
    pub fn is_on(&self) -> bool {
        self.window > Duration::ZERO && self.max_frames > 1
    }
}

impl Default for RxCoalescing {
    fn default() -> Self {
        Self::OFF
    }
}

/// A CAN bus attachment: send frames, receive frames and events, tell the time.
///
/// Call order: any number of [`send`](Self::send) and [`recv_until`](Self::recv_until) calls
/// from one thread at a time (the trait takes `&mut self`). `recv_until` returns `Ok(None)` when
/// the deadline passes without a frame or event; with a virtual clock, waiting is what makes
/// time advance.
pub trait Transport: Send {
    /// Queues one frame for transmission. Does not wait for room: a full queue is
    /// [`TransportError::TxQueueFull`] (the network sends with its protocol core locked, and
    /// tries again later).
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError>;

    /// [`send`](Self::send) by a caller that read this transport's clock at `now` a moment
    /// before: a transport that stamps frames with its clock may take `now` instead of reading
    /// the clock again (a real clock's reading is a noticeable part of a short driving step).
    /// Stamps must still never go back in time.
    /// Default: [`send`](Self::send).
    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        let _ = now;
        self.send(frame)
    }

    /// Whether this bus carries CAN FD frames: `Ok(())`, or the
    /// [`TransportError::FdNotSupported`] that [`send_fd`](Self::send_fd) fails with, naming
    /// the bus. Default: classic only.
    fn fd_support(&self) -> Result<(), TransportError> {
        Err(TransportError::fd_not_supported(
            "this transport (classic CAN only)",
        ))
    }

    /// Queues one CAN FD frame (as [`send`](Self::send)). Default (a classic-only
    /// transport): the error of [`fd_support`](Self::fd_support).
    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        let _ = frame;
        match self.fd_support() {
            Err(e) => Err(e),
            Ok(()) => Err(TransportError::fd_not_supported("this transport")),
        }
    }

    /// Waits until a frame or event arrives or the clock reaches `deadline`.
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError>;

    /// The current time on this transport's clock.
    fn now(&self) -> Instant;

    /// Waits at most `timeout` for a frame or event.
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<Received>, TransportError> {
        let deadline = self.now() + timeout;
        self.recv_until(deadline)
    }

    /// Returns a frame or event that is already waiting, without blocking.
    fn try_recv(&mut self) -> Result<Option<Received>, TransportError> {
        let now = self.now();
        self.recv_until(now)
    }

    /// Whether a frame or event is waiting that [`recv_until`](Self::recv_until) returns at
    /// once, known without asking the operating system (queued inside the transport). A
    /// driving step takes such frames together, under one lock; `false` (the default) makes
    /// it take one frame per step, so a quiet socket costs no extra system call.
    fn has_pending(&self) -> bool {
        false
    }

    /// Sets receive wake-up coalescing (see [`RxCoalescing`]; [`RxCoalescing::OFF`] turns it
    /// off). Returns whether this transport coalesces: the in-memory bus on the host's clock
    /// and SocketCAN do; the default (and a virtual clock, which never blocks) ignores the
    /// setting and returns `false`. Set it before the transport moves into a
    /// [`Network`](crate::Network): the driving step takes a burst that is queued at once,
    /// up to its receive batch, so the network needs nothing else.
    fn set_rx_coalescing(&mut self, coalescing: RxCoalescing) -> bool {
        let _ = coalescing;
        false
    }

    /// Whether the clock is virtual: it stands still until [`recv_until`](Self::recv_until)
    /// waits, and then jumps to the next event or the deadline at once (no real time passes).
    /// The async API ties such a clock to tokio's (see `canola::asynch`). Default: `false`.
    fn is_virtual(&self) -> bool {
        false
    }

    /// On a virtual clock: when the transport next has something to deliver or do by itself
    /// (a received frame already waiting: now; a frame leaving the wire; a timer of a station
    /// on the bus). `None` when nothing is pending, and always on a real clock (the default).
    fn next_event(&self) -> Option<Instant> {
        None
    }

    /// A handle that ends a [`recv_until`](Self::recv_until) of this transport blocked in
    /// another thread (see [`TransportWaker`]). `None` (the default): a wait runs to its
    /// deadline or the next frame. The UDP bus and the in-memory bus on the host's clock have
    /// one (SocketCAN and slcan not yet: their waits end at the drive slice); a
    /// [`Network`](crate::Network) calls it
    /// when a request is submitted while another thread waits on the transport, so the request
    /// leaves at once instead of at the end of that wait.
    fn waker(&self) -> Option<TransportWaker> {
        None
    }
}

/// Ends a blocked [`Transport::recv_until`] from another thread: the wait returns `Ok(None)`
/// early. A wake that comes while nobody waits is kept: the next wait returns at once (at
/// most once for any number of such wakes). Cheap to clone; waking costs one system call on
/// the transports that have one.
#[derive(Clone)]
pub struct TransportWaker(std::sync::Arc<dyn Fn() + Send + Sync>);

impl TransportWaker {
    /// A waker that runs `wake`.
    pub fn new(wake: impl Fn() + Send + Sync + 'static) -> Self {
        Self(std::sync::Arc::new(wake))
    }

    /// Ends the transport's current (or next) wait.
    pub fn wake(&self) {
        (self.0)();
    }
}

impl core::fmt::Debug for TransportWaker {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("TransportWaker")
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        (**self).send(frame)
    }
    fn send_at(&mut self, frame: &CanFrame, now: Instant) -> Result<(), TransportError> {
        (**self).send_at(frame, now)
    }
    fn fd_support(&self) -> Result<(), TransportError> {
        (**self).fd_support()
    }
    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        (**self).send_fd(frame)
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        (**self).recv_until(deadline)
    }
    fn now(&self) -> Instant {
        (**self).now()
    }
    fn is_virtual(&self) -> bool {
        (**self).is_virtual()
    }
    fn set_rx_coalescing(&mut self, coalescing: RxCoalescing) -> bool {
        (**self).set_rx_coalescing(coalescing)
    }
    fn has_pending(&self) -> bool {
        (**self).has_pending()
    }
    fn next_event(&self) -> Option<Instant> {
        (**self).next_event()
    }
    fn waker(&self) -> Option<TransportWaker> {
        (**self).waker()
    }
}

/// A sans-IO station that a driver loop can run on any transport: the simulator's devices
/// implement it, and the in-memory bus can host such stations directly (see
/// [`MemoryBus::attach`](crate::transport::mem::MemoryBus::attach)).
///
/// Call order per step: [`handle_frame`](Self::handle_frame) for each received frame,
/// [`handle_timeout`](Self::handle_timeout) when [`poll_timeout`](Self::poll_timeout) has passed,
/// then drain [`poll_transmit`](Self::poll_transmit) until it returns `None`.
pub trait Station: Send {
    /// Feeds one received frame.
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame);
    /// Lets timers that are due fire.
    fn handle_timeout(&mut self, now: Instant);
    /// The next frame to send, if any.
    fn poll_transmit(&mut self) -> Option<CanFrame>;
    /// When [`handle_timeout`](Self::handle_timeout) wants to be called next.
    fn poll_timeout(&self) -> Option<Instant>;
    /// Feeds a bus event (default: ignored).
    fn handle_bus_event(&mut self, _now: Instant, _event: &BusEvent) {}
    /// Feeds one received CAN FD frame (default: ignored, as a classic controller would).
    fn handle_fd_frame(&mut self, _now: Instant, _frame: &FdFrame) {}
    /// The next CAN FD frame to send, if any (drained after
    /// [`poll_transmit`](Self::poll_transmit)). Default: none.
    fn poll_transmit_fd(&mut self) -> Option<FdFrame> {
        None
    }
}

/// Runs a [`Station`] on a transport until `stop` returns true or the transport fails.
///
/// This is the loop behind `canopen simulate` on a real interface: receive until the station's
/// next deadline, feed, fire timers that are due, send what it produced. `stop` is checked at
/// least every 50 ms.
///
/// The loop keeps the clock reads down to what the transport needs: a received frame's
/// reception time serves as the current time for the timers checked right after it, and
/// [`Station::handle_timeout`] is only called when [`Station::poll_timeout`] has passed (as
/// the call order above asks; the in-memory bus does the same).
pub fn run_station<T: Transport + ?Sized, S: Station + ?Sized>(
    transport: &mut T,
    station: &mut S,
    mut stop: impl FnMut() -> bool,
) -> Result<(), TransportError> {
    // Upper bound on one wait so `stop` is polled regularly.
    let slice = Duration::from_millis(50);
    let mut now = transport.now();
    loop {
        if is_due(station.poll_timeout(), now) {
            station.handle_timeout(now);
        }
        while let Some(frame) = station.poll_transmit() {
            transport.send(&frame)?;
        }
        while let Some(frame) = station.poll_transmit_fd() {
            transport.send_fd(&frame)?;
        }
        if stop() {
            return Ok(());
        }
        let deadline = match station.poll_timeout() {
            Some(t) if t < now + slice => t,
            _ => now + slice,
        };
        match transport.recv_until(deadline)? {
            Some(Received::Frame { frame, at }) => {
                station.handle_frame(at, &frame);
                now = at;
            }
            Some(Received::Event(BusEvent::FdFrame { frame, at })) => {
                station.handle_fd_frame(at, &frame);
                now = at;
            }
            Some(Received::Event(ev)) => {
                now = transport.now();
                station.handle_bus_event(now, &ev);
            }
            None => now = transport.now(),
        }
    }
}
