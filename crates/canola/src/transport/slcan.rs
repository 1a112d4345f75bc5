//! slcan transport (`slcan` feature): a USB serial-line CAN adapter (CANable with slcan
//! firmware, USBtin, Lawicel CANUSB) on Linux, macOS and Windows, through `canola-slcan`'s
//! [`Link`].
//!
//! What the adapter sends becomes the transport's receive stream: classic frames as
//! [`Received::Frame`] stamped with the transport's monotonic clock (the adapter's own
//! timestamps wrap after a minute and are not used for ordering), CAN FD frames as
//! [`BusEvent::FdFrame`], the kernel-style bus state lines as [`BusEvent::ErrorPassive`],
//! [`BusEvent::BusOff`] and [`BusEvent::Restarted`], bus error lines as
//! [`BusEvent::ErrorFrame`] (SocketCAN's protocol-error class, as the kernel driver makes of
//! them), a BEL after a frame as [`BusEvent::TxRefused`], and bytes that are not slcan as
//! [`BusEvent::BadInput`], counted in [`SlcanStats`].
//!
//! A vanished adapter (USB pulled, pty closed) is [`BusEvent::InterfaceDown`] once, and every
//! send fails with [`TransportError::InterfaceDown`] (the error text is kept:
//! [`Slcan::last_error`]). While down, every receive call tries to open the same path again
//! (at most every [`REOPEN_INTERVAL`]); when that works the adapter is configured as at the
//! first open and [`BusEvent::InterfaceUp`] follows. [`Slcan::reopen`] tries at once.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use canola_frame::time::MonotonicClock;
use canola_frame::{CanFrame, Instant};
pub use canola_slcan::{
    AckMode, AdapterInfo, BitrateTable, DataBitrate, Link, LinkConfig, LinkError, NominalBitrate,
    StatusFlags,
};
use canola_slcan::{BusErrors, ErrorState, Frame, Incoming};

use crate::transport::contract::{BusEvent, Received, Transport, TransportError};
use canola_frame::{FdFlags, FdFrame};

/// How often a receive call tries to open a vanished adapter again.
pub const REOPEN_INTERVAL: std::time::Duration = std::time::Duration::from_millis(250);

/// Counters of an slcan transport, readable after the transport moved into a
/// [`Network`](crate::Network) (clones share them).
#[derive(Debug, Clone, Default)]
pub struct SlcanStats {
    inner: Arc<StatsInner>,
}

#[derive(Debug, Default)]
struct StatsInner {
    frames_rx: AtomicU64,
    frames_tx: AtomicU64,
    bad_input: AtomicU64,
    refused: AtomicU64,
    vanished: AtomicU64,
    reopened: AtomicU64,
}

impl SlcanStats {
    /// Frames received (classic and FD).
    pub fn frames_rx(&self) -> u64 {
        self.inner.frames_rx.load(Ordering::Relaxed)
    }
    /// Frames written to the adapter.
    pub fn frames_tx(&self) -> u64 {
        self.inner.frames_tx.load(Ordering::Relaxed)
    }
    /// Lines from the adapter that did not decode (each one also a [`BusEvent::BadInput`]).
    pub fn bad_input(&self) -> u64 {
        self.inner.bad_input.load(Ordering::Relaxed)
    }
    /// Frames the adapter refused with BEL.
    pub fn refused(&self) -> u64 {
        self.inner.refused.load(Ordering::Relaxed)
    }
    /// Times the adapter vanished.
    pub fn vanished(&self) -> u64 {
        self.inner.vanished.load(Ordering::Relaxed)
    }
    /// Times it was opened again after vanishing.
    pub fn reopened(&self) -> u64 {
        self.inner.reopened.load(Ordering::Relaxed)
    }
}

/// SocketCAN's protocol-violation error class and its detail bits (`linux/can/error.h`).
const CAN_ERR_PROT: u32 = 0x0000_0008;
const CAN_ERR_ACK: u32 = 0x0000_0020;
const CAN_ERR_CRTL: u32 = 0x0000_0004;
const CAN_ERR_PROT_BIT0: u8 = 0x08;
const CAN_ERR_PROT_BIT1: u8 = 0x10;
const CAN_ERR_PROT_FORM: u8 = 0x02;
const CAN_ERR_PROT_STUFF: u8 = 0x04;
const CAN_ERR_PROT_LOC_CRC_SEQ: u8 = 0x08;

/// How a vanished adapter is opened again: by default [`Link::reopen`] on the same path;
/// [`Slcan::with_reopen`] sets another way (a pseudo-terminal master has no path).
type Reopen = Box<dyn FnMut(&LinkConfig) -> Result<Link, LinkError> + Send>;

/// An slcan adapter as a [`Transport`]; see the module docs.
pub struct Slcan {
    link: Link,
    reopen: Option<Reopen>,
    clock: MonotonicClock,
    stats: SlcanStats,
    events: VecDeque<Received>,
    /// Set while the adapter is gone: the error that said so.
    down: Option<String>,
    last_try: Option<std::time::Instant>,
    /// The controller state from the last bus state line.
    state: ErrorState,
    /// The adapter sent a CAN FD frame (so it speaks CAN FD).
    fd_seen: bool,
}

impl core::fmt::Debug for Slcan {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Slcan")
            .field("link", &self.link)
            .field("down", &self.down)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl Slcan {
    /// Opens the adapter as `config` says (serial port, bit rate, open sequence).
    pub fn open(config: LinkConfig) -> Result<Self, LinkError> {
        Ok(Self::with_link(Link::open(config)?))
    }

    /// Opens `PATH[@BITRATE]` (the part after `slcan:` of a bus spec, see
    /// [`LinkConfig::from_spec`]).
    pub fn open_spec(spec: &str) -> Result<Self, LinkError> {
        Self::open(LinkConfig::from_spec(spec)?)
    }

    /// A transport on a link already open (for instance one made with [`Link::with_port`] on a
    /// pseudo-terminal).
    pub fn with_link(link: Link) -> Self {
        Self {
            link,
            reopen: None,
            clock: MonotonicClock::new(),
            stats: SlcanStats::default(),
            events: VecDeque::new(),
            down: None,
            last_try: None,
            state: ErrorState::Active,
            fd_seen: false,
        }
    }

    /// [`with_link`](Self::with_link), opening the adapter again after it vanished with
    /// `reopen` (given the configuration) instead of by its path: for a port without a path,
    /// such as a pseudo-terminal master whose successor the caller makes.
    pub fn with_reopen(
        link: Link,
        reopen: impl FnMut(&LinkConfig) -> Result<Link, LinkError> + Send + 'static,
    ) -> Self {
        let mut t = Self::with_link(link);
        t.reopen = Some(Box::new(reopen));
        t
    }

    /// The adapter's version, serial number and status flags (`V`, `N`, `F`). Frames arriving
    /// meanwhile are kept for the next receive.
    pub fn info(&mut self) -> Result<AdapterInfo, LinkError> {
        let r = self.link.info();
        self.note(&r);
        r
    }

    /// The link underneath (its configuration, whether the adapter acknowledges commands).
    pub fn link(&self) -> &Link {
        &self.link
    }

    /// A handle to the counters.
    pub fn stats(&self) -> SlcanStats {
        self.stats.clone()
    }

    /// Why the adapter is down, while it is.
    pub fn last_error(&self) -> Option<&str> {
        self.down.as_deref()
    }

    /// Opens the adapter's path again now (after it vanished, or to start over). On success a
    /// transport that was down reports [`BusEvent::InterfaceUp`].
    pub fn reopen(&mut self) -> Result<(), LinkError> {
        self.last_try = Some(std::time::Instant::now());
        match &mut self.reopen {
            Some(reopen) => self.link = reopen(self.link.config())?,
            None => self.link.reopen()?,
        }
        self.state = ErrorState::Active;
        if self.down.take().is_some() {
            self.stats.inner.reopened.fetch_add(1, Ordering::Relaxed);
            self.events
                .push_back(Received::Event(BusEvent::InterfaceUp));
        }
        Ok(())
    }

    /// Closes the adapter's channel and the serial port.
    pub fn close(&mut self) -> Result<(), LinkError> {
        self.link.close()
    }

    /// Notes a vanished adapter from a link result.
    fn note<T>(&mut self, r: &Result<T, LinkError>) {
        if let Err(e @ LinkError::Vanished { .. }) = r {
            self.went_down(e.to_string());
        }
    }

    fn went_down(&mut self, why: String) {
        if self.down.is_none() {
            self.stats.inner.vanished.fetch_add(1, Ordering::Relaxed);
            self.events
                .push_back(Received::Event(BusEvent::InterfaceDown));
        }
        self.down = Some(why);
        self.last_try = Some(std::time::Instant::now());
    }

    /// What one item from the adapter becomes (nothing for what changes no state).
    fn incoming(&mut self, item: Incoming) {
        let ev = match item {
            Incoming::Frame(rx) => {
                self.stats.inner.frames_rx.fetch_add(1, Ordering::Relaxed);
                let at = self.clock.now();
                match rx.frame {
                    Frame::Classic(frame) => {
                        self.events.push_back(Received::Frame { frame, at });
                        return;
                    }
                    Frame::Fd(fd) => {
                        self.fd_seen = true;
                        // FDF as Linux 6.2 and later set it; ESI from the adapter's trailer.
                        let mut flags = fd.flags().union(FdFlags::FDF);
                        if rx.esi == Some(true) {
                            flags = flags.union(FdFlags::ESI);
                        }
                        BusEvent::FdFrame {
                            frame: Box::new(fd.with_flags(flags)),
                            at,
                        }
                    }
                }
            }
            Incoming::BusState(s) => {
                let before = std::mem::replace(&mut self.state, s.state);
                match s.state {
                    _ if s.state == before => return,
                    ErrorState::Passive => BusEvent::ErrorPassive,
                    ErrorState::BusOff => BusEvent::BusOff,
                    ErrorState::Active | ErrorState::Warning if before == ErrorState::BusOff => {
                        BusEvent::Restarted
                    }
                    ErrorState::Active | ErrorState::Warning => return,
                }
            }
            Incoming::BusErrors(e) => bus_error_frame(e),
            Incoming::Status(flags)
                if flags.contains(StatusFlags::ERROR_PASSIVE)
                    && self.state != ErrorState::Passive =>
            {
                self.state = ErrorState::Passive;
                BusEvent::ErrorPassive
            }
            Incoming::TxRefused => {
                self.stats.inner.refused.fetch_add(1, Ordering::Relaxed);
                BusEvent::TxRefused
            }
            Incoming::BadLine(e) => {
                let total = self.stats.inner.bad_input.fetch_add(1, Ordering::Relaxed) + 1;
                BusEvent::BadInput {
                    detail: e.to_string(),
                    total,
                }
            }
            _ => return,
        };
        self.events.push_back(Received::Event(ev));
    }

    /// While down: tries to reopen if the last try is long enough ago, else waits towards
    /// `deadline` (at most until the next try).
    fn wait_down(&mut self, deadline: Instant) {
        let due = self.last_try.is_none_or(|t| t.elapsed() >= REOPEN_INTERVAL);
        if due && self.reopen().is_ok() {
            return;
        }
        let now = self.clock.now();
        if now >= deadline {
            return;
        }
        let until_try = self.last_try.map_or(REOPEN_INTERVAL, |t| {
            REOPEN_INTERVAL.saturating_sub(t.elapsed())
        });
        let wait: std::time::Duration = (deadline - now).into();
        std::thread::sleep(wait.min(until_try));
    }
}

/// A kernel-style `e` line as the SocketCAN error frame the kernel driver makes of it.
fn bus_error_frame(e: BusErrors) -> BusEvent {
    let mut class = CAN_ERR_PROT;
    let mut data = [0u8; 8];
    if e.0 & BusErrors::ACK != 0 {
        class |= CAN_ERR_ACK;
    }
    for (bit, prot) in [
        (BusErrors::BIT0, CAN_ERR_PROT_BIT0),
        (BusErrors::BIT1, CAN_ERR_PROT_BIT1),
        (BusErrors::FORM, CAN_ERR_PROT_FORM),
        (BusErrors::STUFF, CAN_ERR_PROT_STUFF),
    ] {
        if e.0 & bit != 0 {
            data[2] |= prot;
        }
    }
    if e.0 & BusErrors::CRC != 0 {
        data[3] = CAN_ERR_PROT_LOC_CRC_SEQ;
    }
    // Controller overruns: the controller-problem class, RX/TX overflow in byte 1.
    if e.0 & BusErrors::RX_OVERRUN != 0 {
        class |= CAN_ERR_CRTL;
        data[1] |= 0x01;
    }
    if e.0 & BusErrors::TX_OVERRUN != 0 {
        class |= CAN_ERR_CRTL;
        data[1] |= 0x02;
    }
    BusEvent::ErrorFrame { class, data }
}

impl Transport for Slcan {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        if self.down.is_some() {
            return Err(TransportError::InterfaceDown);
        }
        match self.link.send(&Frame::Classic(*frame)) {
            Ok(()) => {
                self.stats.inner.frames_tx.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(e @ LinkError::Vanished { .. }) => {
                self.went_down(e.to_string());
                Err(TransportError::InterfaceDown)
            }
            Err(LinkError::WriteTimeout) => Err(TransportError::TxQueueFull),
            Err(LinkError::Closed) => Err(TransportError::InterfaceDown),
            Err(e) => Err(TransportError::Io(std::io::Error::other(e.to_string()))),
        }
    }

    /// An adapter speaks CAN FD when it was opened with a data bit rate (its `Y` command
    /// accepted: slcan has no capability query) or has sent a CAN FD frame.
    fn fd_support(&self) -> Result<(), TransportError> {
        if self.link.config().data_bitrate.is_some() || self.fd_seen {
            Ok(())
        } else {
            Err(TransportError::fd_not_supported(format!(
                "slcan:{} (opened without a data bit rate: classic CAN only; an adapter with CAN FD \
                 firmware needs one in its LinkConfig::data_bitrate)",
                self.link.config().path
            )))
        }
    }

    fn send_fd(&mut self, frame: &FdFrame) -> Result<(), TransportError> {
        self.fd_support()?;
        if self.down.is_some() {
            return Err(TransportError::InterfaceDown);
        }
        match self.link.send(&Frame::Fd(*frame)) {
            Ok(()) => {
                self.stats.inner.frames_tx.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(e @ LinkError::Vanished { .. }) => {
                self.went_down(e.to_string());
                Err(TransportError::InterfaceDown)
            }
            Err(LinkError::WriteTimeout) => Err(TransportError::TxQueueFull),
            Err(LinkError::Closed) => Err(TransportError::InterfaceDown),
            Err(e) => Err(TransportError::Io(std::io::Error::other(e.to_string()))),
        }
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<Received>, TransportError> {
        loop {
            if let Some(r) = self.events.pop_front() {
                return Ok(Some(r));
            }
            let now = self.clock.now();
            if self.down.is_some() {
                self.wait_down(deadline);
                if self.events.is_empty() && self.clock.now() >= deadline {
                    return Ok(None);
                }
                continue;
            }
            let left: std::time::Duration = if now >= deadline {
                std::time::Duration::ZERO
            } else {
                (deadline - now).into()
            };
            match self.link.recv_until(std::time::Instant::now() + left) {
                Ok(Some(item)) => self.incoming(item),
                Ok(None) => return Ok(self.events.pop_front()),
                Err(e @ LinkError::Vanished { .. }) => self.went_down(e.to_string()),
                Err(LinkError::Closed) => self.went_down("the slcan link is closed".into()),
                Err(e) => return Err(TransportError::Io(std::io::Error::other(e.to_string()))),
            }
        }
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }

    fn has_pending(&self) -> bool {
        !self.events.is_empty() || (self.down.is_none() && self.link.has_pending())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_error_lines_become_protocol_error_frames() {
        let BusEvent::ErrorFrame { class, data } =
            bus_error_frame(BusErrors(BusErrors::ACK | BusErrors::CRC | BusErrors::BIT0))
        else {
            panic!("not an error frame")
        };
        assert_eq!(class, CAN_ERR_PROT | CAN_ERR_ACK);
        assert_eq!(data[2], CAN_ERR_PROT_BIT0);
        assert_eq!(data[3], CAN_ERR_PROT_LOC_CRC_SEQ);
    }
}
