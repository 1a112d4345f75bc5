//! Limits against hostile or broken clients on socket connections (TCP and Unix sockets):
//! a connection that sends nothing, sends a byte a second (slow-loris), sends a line without
//! end, opens connection after connection, or sends binary junk.
//!
//! * **Line time** ([`ConnLimits::line_timeout`]): once the first byte of a line arrived, the
//!   line must end within this time, else the connection is closed. On a gateway that asks
//!   for a token, the first line (`auth`) must end within this time of connecting.
//! * **Line length**: [`crate::Config::max_line`] bytes are kept of a line; the rest is read and
//!   dropped and the line answered `ERROR:600`, so an endless line costs no memory (and the
//!   line time ends it).
//! * **Connections** ([`crate::Config::max_connections`]): when the table is full, the
//!   connection that has gone longest without a complete line is closed to make room, if it
//!   has been idle for at least [`ConnLimits::evict_idle_after`]; else the newcomer is answered
//!   `ERROR:600` and closed. So idle connections cannot lock clients out, and busy ones are
//!   never cut.
//! * **Junk**: a line that is not UTF-8 or not a request is answered with an error like any
//!   other; after [`ConnLimits::max_bad_lines`] such lines in a row the connection is closed.
//!
//! Memory per connection stays bounded by the line length, [`crate::Config::max_in_flight`]
//! and [`crate::Config::max_events`]; two threads serve each connection.

use std::io::Read;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The limits of this module (part of [`crate::Config`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConnLimits {
    /// Longest time from a line's first byte to its end (and, where a token is needed, from
    /// connecting to the end of the `auth` line).
    pub line_timeout: Duration,
    /// A connection without a complete line for this long may be closed to make room for a new
    /// one when [`crate::Config::max_connections`] are open.
    pub evict_idle_after: Duration,
    /// Erroneous lines (not UTF-8, syntax errors, too long) in a row before the connection is
    /// closed.
    pub max_bad_lines: u32,
}

impl Default for ConnLimits {
    fn default() -> Self {
        Self {
            line_timeout: Duration::from_secs(10),
            evict_idle_after: Duration::from_secs(10),
            max_bad_lines: 64,
        }
    }
}

/// A socket the limits can set a read timeout on and close from another thread.
pub(crate) trait Socket: Read + Send + Sync + 'static {
    /// `std`'s `set_read_timeout`.
    fn read_timeout(&self, t: Option<Duration>) -> std::io::Result<()>;
    /// Shuts the reading direction down: the connection's reader sees the end of the stream,
    /// its threads end and the socket is closed (with unread data: reset, so a peer still
    /// sending learns at once).
    fn close(&self);
    /// Another handle to the socket.
    fn handle(&self) -> std::io::Result<Self>
    where
        Self: Sized;
}

impl Socket for std::net::TcpStream {
    fn read_timeout(&self, t: Option<Duration>) -> std::io::Result<()> {
        self.set_read_timeout(t)
    }
    fn close(&self) {
        let _ = self.shutdown(std::net::Shutdown::Read);
    }
    fn handle(&self) -> std::io::Result<Self> {
        self.try_clone()
    }
}

#[cfg(unix)]
impl Socket for std::os::unix::net::UnixStream {
    fn read_timeout(&self, t: Option<Duration>) -> std::io::Result<()> {
        self.set_read_timeout(t)
    }
    fn close(&self) {
        let _ = self.shutdown(std::net::Shutdown::Read);
    }
    fn handle(&self) -> std::io::Result<Self> {
        self.try_clone()
    }
}

/// A connection in the table.
struct Entry {
    id: u64,
    /// Milliseconds since the table's start at the last complete line (or the connect).
    last_line: AtomicU64,
    closer: Box<dyn Fn() + Send + Sync>,
    closed: AtomicBool,
}

/// The socket connections open, for eviction; and counters.
#[derive(Default)]
pub(crate) struct ConnTable {
    entries: Mutex<Vec<Arc<Entry>>>,
    next: AtomicU64,
    start: std::sync::OnceLock<Instant>,
    evicted: AtomicU64,
    timed_out: AtomicU64,
}

impl core::fmt::Debug for ConnTable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ConnTable").finish_non_exhaustive()
    }
}

/// What the connection limits did so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LimitCounters {
    /// Idle connections closed to make room for a new one.
    pub evicted: u64,
    /// Connections closed because a line did not end in time.
    pub timed_out: u64,
}

impl ConnTable {
    fn now_ms(&self) -> u64 {
        let start = *self.start.get_or_init(Instant::now);
        start.elapsed().as_millis().try_into().unwrap_or(u64::MAX)
    }

    pub(crate) fn counters(&self) -> LimitCounters {
        LimitCounters {
            evicted: self.evicted.load(Ordering::Relaxed),
            timed_out: self.timed_out.load(Ordering::Relaxed),
        }
    }

    /// Closes the connection idle longest if it has been idle at least `min_idle`; whether
    /// one was closed.
    pub(crate) fn evict_idlest(&self, min_idle: Duration) -> bool {
        let now = self.now_ms();
        let min = u64::try_from(min_idle.as_millis()).unwrap_or(u64::MAX);
        let victim = {
            let entries = self
                .entries
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            entries
                .iter()
                .filter(|e| !e.closed.load(Ordering::Relaxed))
                .min_by_key(|e| e.last_line.load(Ordering::Relaxed))
                .filter(|e| now.saturating_sub(e.last_line.load(Ordering::Relaxed)) >= min)
                .cloned()
        };
        let Some(v) = victim else { return false };
        v.closed.store(true, Ordering::Relaxed);
        (v.closer)();
        self.evicted.fetch_add(1, Ordering::Relaxed);
        true
    }

    /// Enters `socket` in the table; the guard takes it out when dropped.
    pub(crate) fn register<S: Socket>(
        self: &Arc<Self>,
        socket: &S,
    ) -> std::io::Result<Registration> {
        let handle = socket.handle()?;
        let entry = Arc::new(Entry {
            id: self.next.fetch_add(1, Ordering::Relaxed),
            last_line: AtomicU64::new(self.now_ms()),
            closer: Box::new(move || handle.close()),
            closed: AtomicBool::new(false),
        });
        self.entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(entry.clone());
        Ok(Registration {
            table: self.clone(),
            entry,
        })
    }
}

/// A connection's place in the [`ConnTable`].
pub(crate) struct Registration {
    table: Arc<ConnTable>,
    entry: Arc<Entry>,
}

impl Registration {
    fn touch(&self) {
        self.entry
            .last_line
            .store(self.table.now_ms(), Ordering::Relaxed);
    }
}

impl Drop for Registration {
    fn drop(&mut self) {
        let id = self.entry.id;
        self.table
            .entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .retain(|e| e.id != id);
    }
}

/// The reading half of a socket connection under the line time.
pub(crate) struct Guarded<S: Socket> {
    socket: S,
    reg: Registration,
    line_timeout: Duration,
    /// When the line being read must end (`None`: no line begun).
    deadline: Option<Instant>,
    timeout_set: Option<Option<Duration>>,
}

impl<S: Socket> Guarded<S> {
    /// `first_line_due`: the first line must end within the line time of now (a token is
    /// needed).
    pub(crate) fn new(
        socket: S,
        reg: Registration,
        limits: &ConnLimits,
        first_line_due: bool,
    ) -> Self {
        Self {
            socket,
            reg,
            line_timeout: limits.line_timeout,
            deadline: first_line_due.then(|| Instant::now() + limits.line_timeout),
            timeout_set: None,
        }
    }

    fn timed_out(&self) -> std::io::Error {
        self.reg.table.timed_out.fetch_add(1, Ordering::Relaxed);
        self.socket.close();
        std::io::Error::new(std::io::ErrorKind::TimedOut, "line not ended in time")
    }
}

impl<S: Socket> Read for Guarded<S> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let want = match self.deadline {
            None => None,
            Some(d) => match d.checked_duration_since(Instant::now()) {
                Some(left) if !left.is_zero() => Some(left.max(Duration::from_millis(1))),
                _ => return Err(self.timed_out()),
            },
        };
        if self.timeout_set != Some(want) {
            self.socket.read_timeout(want)?;
            self.timeout_set = Some(want);
        }
        let n = match self.socket.read(buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return Err(self.timed_out());
            }
            Err(e) => return Err(e),
        };
        let got = &buf[..n];
        if let Some(last) = got.iter().rposition(|&b| b == b'\n') {
            self.reg.touch();
            // Bytes after the last line end begin the next line.
            self.deadline = (last + 1 < n).then(|| Instant::now() + self.line_timeout);
        } else if n > 0 && self.deadline.is_none() {
            self.deadline = Some(Instant::now() + self.line_timeout);
        }
        Ok(n)
    }
}

/// Counts erroneous lines in a row.
#[derive(Debug, Default)]
pub(crate) struct BadLines(u32);

impl BadLines {
    /// Notes one line; whether the connection is to be closed.
    pub(crate) fn note(&mut self, bad: bool, limits: &ConnLimits) -> bool {
        self.0 = if bad { self.0.saturating_add(1) } else { 0 };
        self.0 >= limits.max_bad_lines.max(1)
    }
}
