//! The in-memory CAN bus for tests and simulation.
//!
//! Several [`Endpoint`]s (each a [`Transport`](crate::Transport)) and any number of attached [`Station`](crate::Station)s share one
//! bus. A frame sent by one participant reaches every other participant (not the sender, like a
//! SocketCAN socket without `CAN_RAW_RECV_OWN_MSGS`).
//!
//! * **Clock.** [`ClockMode::Virtual`] (the default) is deterministic: time stands still while
//!   code runs and jumps to the next event (a frame leaving the wire, a station timer, the
//!   caller's deadline) when an endpoint waits in [`Transport::recv_until`](crate::Transport::recv_until). Run one driving
//!   thread per virtual bus and attach simulated devices with [`MemoryBus::attach`], so they are
//!   stepped by the same loop. [`ClockMode::RealTime`] follows the host's monotonic clock; a
//!   service thread steps attached stations, and endpoints may be used from several threads.
//!   Under the async API (`tokio` feature) a virtual clock follows tokio's clock: real time on
//!   a normal runtime, jumps under a paused one, so tokio's timers and the bus's timeouts fire
//!   in their order (see `canola::asynch`).
//! * **Timing model** (optional, [`BusConfig::bitrate`]). Each frame occupies the wire for its
//!   length in bits (ISO 11898-1 classic frame: 47 + 8·n bits for an 11-bit identifier, 67 + 8·n
//!   for a 29-bit one, including the 3-bit interframe space), optionally with the worst-case
//!   number of stuff bits. When the wire goes idle, the pending frame with the lowest arbitration
//!   value (lowest identifier; an 11-bit identifier beats a 29-bit one with the same base; a data
//!   frame beats a remote frame) is sent next.
//! * **CAN FD** ([`BusConfig::fd`]): a bus configured FD carries FD frames
//!   ([`Transport::send_fd`](crate::Transport::send_fd), received as
//!   [`BusEvent::FdFrame`](crate::BusEvent::FdFrame), and by attached stations through
//!   [`Station::handle_fd_frame`](crate::Station::handle_fd_frame) /
//!   [`Station::poll_transmit_fd`](crate::Station::poll_transmit_fd)); a classic bus (the
//!   default) refuses them with [`TransportError::FdNotSupported`](crate::TransportError). In the
//!   timing model an FD frame's arbitration phase runs at [`BusConfig::bitrate`] and its data
//!   phase at [`BusConfig::data_bitrate`] when the bit-rate switch is set ([`fd_frame_bits`]).
//! * **Fault injection** ([`Faults`]): drop, duplicate, delay or corrupt a chosen share of frames,
//!   from a seeded generator so every run is reproducible.
//! * **Bus state.** [`MemoryBus::inject_event`] delivers [`BusEvent`](crate::BusEvent)s (error frames, bus-off,
//!   interface down/up); a full endpoint receive queue drops frames, counts them and reports a
//!   [`BusEvent::RxOverflow`](crate::BusEvent::RxOverflow) before the next frame.
//!
//! * **Receive coalescing** ([`Transport::set_rx_coalescing`](crate::Transport::set_rx_coalescing),
//!   real clock only): an endpoint's blocking receive hands over a burst of frames with one
//!   wake-up; a virtual clock ignores it.
//!
//! Files by job: `config` (settings and timing model), `state` (the shared state every
//! participant steps), `bus` ([`MemoryBus`] and its [`Endpoint`]s), `coalescing_tests` (the
//! receive coalescing against its contract).

mod bus;
#[cfg(test)]
mod coalescing_tests;
mod config;
mod state;
#[cfg(test)]
mod tests;

pub use bus::{Endpoint, MemoryBus, StationId};
pub use config::{
    BusConfig, BusStats, ClockMode, Faults, fd_frame_bits, fd_frame_time, frame_bits, frame_time,
};
