//! Helpers for tests that need a real Linux SocketCAN bus (`vcan0`).
//!
//! The development and CI machines run a kernel without CAN support, so these tests run inside
//! the QEMU guest of `tests/vcan/rig`, which loads the kernel's CAN modules and brings up `vcan0`
//! (see `tests/vcan/README.md`). The convention for every real-bus test:
//!
//! - mark it `#[ignore = "needs vcan0: run by tests/vcan/run-all"]`, so a plain `cargo test` on the
//!   host lists it as ignored instead of failing or passing without testing anything;
//! - `tests/vcan/run-all` builds the test binary on the host and runs it inside the guest with
//!   `--ignored`;
//! - inside the guest a missing interface is an error, never a silent skip: open the bus with
//!   [`open`], whose error names the interface and says how to get one.

use std::io;
use std::time::{Duration, Instant};

use socketcan::{CanFrame, CanSocket, Socket};

/// The interface the rig creates.
pub const DEFAULT_INTERFACE: &str = "vcan0";

/// The interface the tests use: `CANOPEN_VCAN_IFACE` when set, else [`DEFAULT_INTERFACE`].
pub fn interface() -> String {
    std::env::var("CANOPEN_VCAN_IFACE").unwrap_or_else(|_| DEFAULT_INTERFACE.to_owned())
}

/// Opens a raw CAN socket on [`interface()`].
///
/// The error says which interface failed and how to run the test where one exists.
pub fn open() -> io::Result<CanSocket> {
    open_interface(&interface())
}

/// Opens a raw CAN socket on the interface `name`, with the error of [`open`].
pub fn open_interface(name: &str) -> io::Result<CanSocket> {
    CanSocket::open(name).map_err(|e| {
        io::Error::new(
            e.kind(),
            format!(
                "cannot open SocketCAN interface {name}: {e} \
                 (real-bus tests run inside the QEMU guest: tests/vcan/run-all)"
            ),
        )
    })
}

/// Opens a raw CAN socket on [`interface()`] that receives only frames passing `filters`.
///
/// A socket receives every frame from the moment it is opened, and setting filters afterwards
/// does not remove what is already queued: frames of tests running in parallel may have
/// arrived in between. They are read and dropped here, so that after this returns the socket
/// holds only frames its filters pass.
pub fn open_filtered(filters: &[socketcan::CanFilter]) -> io::Result<CanSocket> {
    use socketcan::SocketOptions;
    let socket = open()?;
    socket.set_filters(filters)?;
    socket.set_nonblocking(true)?;
    loop {
        match socket.read_frame() {
            Ok(_) => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
            Err(e) => return Err(e),
        }
    }
    socket.set_nonblocking(false)?;
    Ok(socket)
}

/// Reads frames from `socket` until one satisfies `wanted`, skipping the others.
///
/// Fails with [`io::ErrorKind::TimedOut`] when no such frame arrives within `timeout`.
pub fn recv_matching(
    socket: &CanSocket,
    timeout: Duration,
    mut wanted: impl FnMut(&CanFrame) -> bool,
) -> io::Result<CanFrame> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(io::Error::new(
                io::ErrorKind::TimedOut,
                format!("no matching CAN frame within {timeout:?}"),
            ));
        }
        let frame = socket.read_frame_timeout(left)?;
        if wanted(&frame) {
            return Ok(frame);
        }
    }
}
