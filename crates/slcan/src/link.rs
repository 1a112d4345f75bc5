//! A blocking slcan link on a serial port (USB CDC or a real UART; Linux, macOS, Windows through
//! the `serialport` crate): configure and open the adapter's channel, move frames with read
//! timeouts, ask the adapter's version, serial number and status, and notice when it vanishes.
//!
//! Opening follows what the Linux kernel driver and can-utils' `slcand` send: `C` (close
//! whatever a previous user left open), then `Sn` or `sxxyy`, optionally `Yn` and `Zn`, then `O`
//! or `L`. Lawicel-style adapters answer each command with CR (or BEL for an error); CANable's
//! official firmware answers nothing. [`AckMode::Auto`] tells the two apart by the reply to the
//! first `C`: any reply (CR or BEL) means the adapter acknowledges; silence means it does not,
//! and the link stops waiting for acknowledgements.
//!
//! Frames are written without waiting for the adapter's `z`/`Z`/CR acknowledgement (a CANable
//! sends none); acknowledgements arriving later are counted and skipped by [`Link::recv`], and a
//! BEL there is reported as [`Incoming::TxRefused`].

use std::boxed::Box;
use std::collections::VecDeque;
use std::io::{self, Read as _, Write as _};
use std::string::{String, ToString};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, SerialPort};

use crate::bitrate::{BitrateTable, Btr, DataBitrate, NominalBitrate, TimestampMode};
use crate::command::Command;
use crate::decoder::Decoder;
use crate::error::LineError;
use crate::frame::{Frame, RxFrame};
use crate::reply::{BusErrors, BusState, Item, StatusFlags};

/// The serial baud rate when none is given: what python-can and most CDC adapters use (a USB CDC
/// adapter ignores it; a UART adapter such as the CAN232 needs the right one).
pub const DEFAULT_SERIAL_BAUD: u32 = 115_200;

/// Whether the adapter acknowledges commands with CR/BEL.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AckMode {
    /// Find out from the reply to the first command (see the module docs).
    #[default]
    Auto,
    /// Lawicel-style: every command is answered with CR or BEL.
    Always,
    /// CANable official firmware: no command is answered (queries still are).
    Never,
}

/// How to open an adapter.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct LinkConfig {
    /// The serial device (`/dev/ttyACM0`, `/dev/cu.usbmodem1234`, `COM3`).
    pub path: String,
    /// The serial line's baud rate.
    pub serial_baud: u32,
    /// The nominal CAN bit rate (`Sn`); `None` leaves the adapter's setting.
    pub bitrate: Option<NominalBitrate>,
    /// SJA1000 bus timing registers (`sxxyy`) instead of `Sn`.
    pub btr: Option<Btr>,
    /// The CAN FD data bit rate (`Yn`), for FD adapters.
    pub data_bitrate: Option<DataBitrate>,
    /// Timestamps on received frames (`Zn`); `None` leaves the adapter's setting (CANable and
    /// Elmue firmware answer `Z` with an error).
    pub timestamps: Option<TimestampMode>,
    /// Open listen-only (`L`) instead of normal (`O`).
    pub listen_only: bool,
    /// Whether the adapter acknowledges commands.
    pub ack: AckMode,
    /// How long to wait for the answer to a command or query.
    pub reply_timeout: Duration,
}

impl LinkConfig {
    /// `path` at [`DEFAULT_SERIAL_BAUD`], bit rate left as it is, normal mode, acknowledgements
    /// detected, 200 ms per reply.
    pub fn new(path: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            serial_baud: DEFAULT_SERIAL_BAUD,
            bitrate: None,
            btr: None,
            data_bitrate: None,
            timestamps: None,
            listen_only: false,
            ack: AckMode::Auto,
            reply_timeout: Duration::from_millis(200),
        }
    }

    /// Parses `PATH[@BITRATE]` (the part after `slcan:` of the interface spec): the CAN bit rate
    /// in bit/s. 800 000 selects S7 on Lawicel-table adapters, 750 000 and 83 333 (or 83 300)
    /// the CANable-table codes S7 and S9; other rates are the same in both tables.
    pub fn from_spec(spec: &str) -> Result<Self, LinkError> {
        let (path, rate) = match spec.rsplit_once('@') {
            Some((p, r)) => (p, Some(r)),
            None => (spec, None),
        };
        if path.is_empty() {
            return Err(LinkError::BadSpec(spec.to_string()));
        }
        let mut config = Self::new(path);
        if let Some(rate) = rate {
            let bps = canola_frame::parse_bitrate(rate)
                .ok_or_else(|| LinkError::BadSpec(spec.to_string()))?;
            config.bitrate = Some(
                NominalBitrate::from_bps(bps, BitrateTable::Lawicel)
                    .or_else(|| NominalBitrate::from_bps(bps, BitrateTable::Canable))
                    .ok_or(LinkError::UnsupportedBitrate(bps))?,
            );
        }
        Ok(config)
    }
}

/// What [`Link::recv`] returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Incoming {
    /// A frame from the bus, with the adapter's timestamp if timestamps are on.
    Frame(RxFrame),
    /// A bus state line (kernel-style `s`).
    BusState(BusState),
    /// A bus error line (kernel-style `e`).
    BusErrors(BusErrors),
    /// Status flags the adapter sent without being asked.
    Status(StatusFlags),
    /// A BEL outside a command: the adapter refused a frame written earlier (channel closed,
    /// transmit queue full, bad line).
    TxRefused,
    /// A line that did not decode (counted in [`LinkStats::bad_lines`]); the link carries on at
    /// the next line.
    BadLine(LineError),
}

/// The adapter's answers to `V`, `N` and `F`; `None` where it did not answer or refused.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AdapterInfo {
    /// The version reply as text: Lawicel `hhss` after the `V`, or CANable's free text.
    pub version: Option<String>,
    /// Hardware and software version of a Lawicel `Vhhss` reply.
    pub hw_sw: Option<(u8, u8)>,
    /// The serial number after the `N`.
    pub serial: Option<String>,
    /// The status flags (reading them clears them).
    pub status: Option<StatusFlags>,
    /// Whether the adapter acknowledges commands (Lawicel) or not (CANable).
    pub acknowledges: bool,
}

/// Counters of a link since it was created (they survive [`Link::reopen`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkStats {
    /// Frames received.
    pub frames_rx: u64,
    /// Frames written.
    pub frames_tx: u64,
    /// CR, `z` and `Z` acknowledgements skipped by `recv`.
    pub acks: u64,
    /// BEL replies outside commands.
    pub refused: u64,
    /// Lines that did not decode, and bytes that are not slcan.
    pub bad_lines: u64,
    /// Other lines skipped by `recv` (late query answers, free text).
    pub other_lines: u64,
    /// Times the adapter vanished.
    pub vanished: u64,
}

/// Failures of a [`Link`].
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// The serial port could not be opened or configured.
    #[error("cannot open serial port {path}: {source}")]
    Open {
        /// The device path.
        path: String,
        /// Why.
        source: serialport::Error,
    },
    /// The adapter went away (USB pulled, pty closed): a read or write failed or hit the end of
    /// the stream. [`Link::reopen`] tries again.
    #[error("the slcan adapter on {path} vanished: {source}")]
    Vanished {
        /// The device path.
        path: String,
        /// The failed read or write.
        source: io::Error,
    },
    /// The adapter did not answer a command or query in time.
    #[error("the slcan adapter did not answer '{command}'")]
    NoReply {
        /// The command letter.
        command: char,
    },
    /// The adapter answered a command with BEL.
    #[error("the slcan adapter refused '{command}' (BEL)")]
    Refused {
        /// The command letter.
        command: char,
    },
    /// A write did not complete within the reply timeout (the adapter does not read).
    #[error("writing to the slcan adapter timed out")]
    WriteTimeout,
    /// The link was closed or the adapter vanished; reopen it first.
    #[error("the slcan link is closed")]
    Closed,
    /// `PATH[@BITRATE]` did not parse.
    #[error("bad slcan spec `{0}`: expected PATH[@BITRATE]")]
    BadSpec(String),
    /// No `Sn` code has this bit rate.
    #[error(
        "no slcan bit rate code for {0} bit/s (10k, 20k, 50k, 100k, 125k, 250k, 500k, 750k, 800k, 1M, 83.3k)"
    )]
    UnsupportedBitrate(u32),
}

debug_as_display!(LinkError);

/// A blocking slcan adapter connection; see the module docs.
///
/// Call order: [`open`](Self::open), then any number of [`send`](Self::send),
/// [`recv`](Self::recv) and queries from one thread; [`close`](Self::close) at the end. After
/// [`LinkError::Vanished`] every call fails with [`LinkError::Closed`] until
/// [`reopen`](Self::reopen) succeeds.
pub struct Link {
    config: LinkConfig,
    port: Option<Box<dyn SerialPort>>,
    decoder: Decoder,
    rbuf: Box<[u8; 1024]>,
    rpos: usize,
    rend: usize,
    /// Frames and events that arrived while a command waited for its reply.
    pending: VecDeque<Incoming>,
    acks: bool,
    /// The timeout last given to the port.
    port_timeout: Duration,
    stats: LinkStats,
}

impl core::fmt::Debug for Link {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Link")
            .field("path", &self.config.path)
            .field("open", &self.port.is_some())
            .field("acks", &self.acks)
            .field("stats", &self.stats)
            .finish()
    }
}

impl Link {
    /// Opens the serial port, configures the adapter and opens its CAN channel.
    pub fn open(config: LinkConfig) -> Result<Self, LinkError> {
        let mut link = Self::new(config);
        link.start()?;
        Ok(link)
    }

    /// Runs the open sequence on a port the caller opened: a pseudo-terminal master from
    /// `serialport::TTYPort::pair`, or a port with settings [`LinkConfig`] has no field for.
    /// `config.path` names it in errors; [`reopen`](Self::reopen) opens `config.path` as a
    /// serial port.
    pub fn with_port(config: LinkConfig, port: Box<dyn SerialPort>) -> Result<Self, LinkError> {
        let mut link = Self::new(config);
        link.configure(port)?;
        Ok(link)
    }

    fn new(config: LinkConfig) -> Self {
        Self {
            config,
            port: None,
            decoder: Decoder::new(),
            rbuf: Box::new([0; 1024]),
            rpos: 0,
            rend: 0,
            pending: VecDeque::new(),
            acks: true,
            port_timeout: Duration::ZERO,
            stats: LinkStats::default(),
        }
    }

    /// Opens the same path again with the same configuration (after the adapter vanished and came
    /// back, or after [`close`](Self::close)). Counters are kept.
    pub fn reopen(&mut self) -> Result<(), LinkError> {
        self.port = None;
        self.start()
    }

    fn start(&mut self) -> Result<(), LinkError> {
        let path = self.config.path.clone();
        let port = serialport::new(&path, self.config.serial_baud)
            .timeout(self.config.reply_timeout)
            .open()
            .map_err(|source| LinkError::Open {
                path: path.clone(),
                source,
            })?;
        self.configure(port)
    }

    fn configure(&mut self, mut port: Box<dyn SerialPort>) -> Result<(), LinkError> {
        // Bytes from before this open (a previous session's frames) mean nothing now.
        let _ = port.clear(ClearBuffer::All);
        let _ = port.set_timeout(self.config.reply_timeout);
        self.port_timeout = self.config.reply_timeout;
        self.port = Some(port);
        self.decoder.reset();
        self.rpos = 0;
        self.rend = 0;
        self.pending.clear();

        // `C` first, as the kernel and slcand do; its answer tells whether the adapter
        // acknowledges. A Lawicel adapter that was closed answers BEL, which is fine here.
        self.acks = self.config.ack != AckMode::Never;
        self.write_command(&Command::Close)?;
        if self.acks {
            match self.wait_reply('C') {
                Ok(_) | Err(LinkError::Refused { .. }) => {}
                Err(LinkError::NoReply { .. }) if self.config.ack == AckMode::Auto => {
                    self.acks = false;
                }
                Err(e) => return Err(e),
            }
        }
        self.pending.clear();
        if let Some(b) = self.config.bitrate {
            self.command(&Command::Bitrate(b))?;
        }
        if let Some(b) = self.config.btr {
            self.command(&Command::Btr(b))?;
        }
        if let Some(b) = self.config.data_bitrate {
            self.command(&Command::DataBitrate(b))?;
        }
        if let Some(m) = self.config.timestamps {
            self.command(&Command::Timestamps(m))?;
        }
        let open = if self.config.listen_only {
            Command::ListenOnly
        } else {
            Command::Open
        };
        self.command(&open)
    }

    /// Closes the adapter's channel (`C`) and the serial port. [`reopen`](Self::reopen) opens
    /// both again.
    pub fn close(&mut self) -> Result<(), LinkError> {
        if self.port.is_none() {
            return Ok(());
        }
        let result = self.command(&Command::Close);
        self.port = None;
        result
    }

    /// Whether the serial port is open.
    pub fn is_open(&self) -> bool {
        self.port.is_some()
    }

    /// The configuration the link was opened with.
    pub fn config(&self) -> &LinkConfig {
        &self.config
    }

    /// Whether the adapter acknowledges commands (found out at open under [`AckMode::Auto`]).
    pub fn acknowledges(&self) -> bool {
        self.acks
    }

    /// The counters.
    pub fn stats(&self) -> LinkStats {
        LinkStats {
            bad_lines: self.decoder.errors(),
            ..self.stats
        }
    }

    /// Writes one frame line. Does not wait for the adapter's acknowledgement.
    pub fn send(&mut self, frame: &Frame) -> Result<(), LinkError> {
        self.write_command(&Command::Transmit(*frame))?;
        self.stats.frames_tx += 1;
        Ok(())
    }

    /// Waits at most `timeout` for a frame or bus event; `Ok(None)` when none came.
    /// Acknowledgements and stray replies are counted and skipped.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<Incoming>, LinkError> {
        self.recv_until(Instant::now() + timeout)
    }

    /// [`recv`](Self::recv) with an absolute deadline; a deadline in the past still takes what
    /// has arrived, without waiting.
    pub fn recv_until(&mut self, deadline: Instant) -> Result<Option<Incoming>, LinkError> {
        if let Some(i) = self.pending.pop_front() {
            return Ok(Some(i));
        }
        loop {
            let Some(item) = self.next_item(deadline)? else {
                return Ok(None);
            };
            if let Some(incoming) = self.classify(item) {
                return Ok(Some(incoming));
            }
        }
    }

    /// Whether a frame or event is already decoded, or a complete line is buffered, so
    /// [`recv`](Self::recv) returns without waiting for the port (the line may still turn out to
    /// be an acknowledgement that `recv` skips).
    pub fn has_pending(&self) -> bool {
        !self.pending.is_empty()
            || self.rbuf[self.rpos..self.rend]
                .iter()
                .any(|&b| b == crate::CR || b == crate::BEL)
    }

    /// Asks `V`, `N` and `F` and collects what the adapter answers.
    pub fn info(&mut self) -> Result<AdapterInfo, LinkError> {
        let mut info = AdapterInfo {
            acknowledges: self.acks,
            ..AdapterInfo::default()
        };
        match self.query(Command::Version) {
            Ok(item) => {
                info.hw_sw = item.lawicel_version();
                info.version = match item {
                    Item::Version(t) | Item::Other(t) => Some(t.as_str().to_string()),
                    _ => None,
                };
            }
            Err(LinkError::NoReply { .. } | LinkError::Refused { .. }) => {}
            Err(e) => return Err(e),
        }
        match self.query(Command::Serial) {
            Ok(Item::Serial(t)) => info.serial = Some(t.as_str().to_string()),
            Ok(_) | Err(LinkError::NoReply { .. } | LinkError::Refused { .. }) => {}
            Err(e) => return Err(e),
        }
        match self.query(Command::Status) {
            Ok(Item::Status(s)) => info.status = Some(s),
            Ok(_) | Err(LinkError::NoReply { .. } | LinkError::Refused { .. }) => {}
            Err(e) => return Err(e),
        }
        Ok(info)
    }

    /// Reads and clears the status flags (`F`).
    pub fn status(&mut self) -> Result<StatusFlags, LinkError> {
        match self.query(Command::Status)? {
            Item::Status(s) => Ok(s),
            _ => Err(LinkError::NoReply { command: 'F' }),
        }
    }

    /// Sends a query (`V`, `N`, `F`) and waits for its answer: the matching item, or for `V` any
    /// free-text line (CANable). Frames arriving meanwhile are kept for `recv`.
    fn query(&mut self, cmd: Command) -> Result<Item, LinkError> {
        let letter = letter(&cmd);
        self.write_command(&cmd)?;
        let deadline = Instant::now() + self.config.reply_timeout;
        loop {
            let Some(item) = self.next_item(deadline)? else {
                return Err(LinkError::NoReply { command: letter });
            };
            match (letter, item) {
                ('V', Ok(i @ (Item::Version(_) | Item::Other(_))))
                | ('N', Ok(i @ Item::Serial(_)))
                | ('F', Ok(i @ Item::Status(_))) => return Ok(i),
                (_, Ok(Item::Error)) => return Err(LinkError::Refused { command: letter }),
                (_, other) => {
                    if let Some(i) = self.classify(other) {
                        self.pending.push_back(i);
                    }
                }
            }
        }
    }

    /// Sends a command and, if the adapter acknowledges, waits for CR (BEL is an error).
    fn command(&mut self, cmd: &Command) -> Result<(), LinkError> {
        self.write_command(cmd)?;
        if self.acks {
            self.wait_reply(letter(cmd))?;
        }
        Ok(())
    }

    fn wait_reply(&mut self, command: char) -> Result<(), LinkError> {
        let deadline = Instant::now() + self.config.reply_timeout;
        loop {
            match self.next_item(deadline)? {
                None => return Err(LinkError::NoReply { command }),
                Some(Ok(Item::Ok)) => return Ok(()),
                Some(Ok(Item::Error)) => return Err(LinkError::Refused { command }),
                Some(other) => {
                    if let Some(i) = self.classify(other) {
                        self.pending.push_back(i);
                    }
                }
            }
        }
    }

    /// What `recv` makes of an item: `None` for what it skips.
    fn classify(&mut self, item: Result<Item, LineError>) -> Option<Incoming> {
        match item {
            Ok(Item::Frame(rx)) => {
                self.stats.frames_rx += 1;
                Some(Incoming::Frame(rx))
            }
            Ok(Item::BusState(s)) => Some(Incoming::BusState(s)),
            Ok(Item::BusErrors(e)) => Some(Incoming::BusErrors(e)),
            Ok(Item::Status(s)) => Some(Incoming::Status(s)),
            Ok(Item::Error) => {
                self.stats.refused += 1;
                Some(Incoming::TxRefused)
            }
            Ok(Item::Ok | Item::TxAck { .. }) => {
                self.stats.acks += 1;
                None
            }
            Ok(_) => {
                self.stats.other_lines += 1;
                None
            }
            Err(e) => Some(Incoming::BadLine(e)),
        }
    }

    fn write_command(&mut self, cmd: &Command) -> Result<(), LinkError> {
        let mut buf = [0u8; crate::MAX_COMMAND];
        // MAX_COMMAND fits every command.
        let n = cmd.encode(&mut buf).map_err(|_| LinkError::Closed)?;
        self.set_port_timeout(self.config.reply_timeout)?;
        let port = self.port.as_mut().ok_or(LinkError::Closed)?;
        match port.write_all(&buf[..n]) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Err(LinkError::WriteTimeout),
            Err(e) => Err(self.vanished(e)),
        }
    }

    /// The next decoded item, reading the port until `deadline`; `None` at the deadline. Reads
    /// at least once (without waiting when the deadline has passed), so a zero timeout still
    /// picks up what the adapter has sent.
    fn next_item(
        &mut self,
        deadline: Instant,
    ) -> Result<Option<Result<Item, LineError>>, LinkError> {
        loop {
            while self.rpos < self.rend {
                let (used, item) = self.decoder.decode(&self.rbuf[self.rpos..self.rend]);
                self.rpos += used;
                if item.is_some() {
                    return Ok(item);
                }
            }
            self.set_port_timeout(deadline.saturating_duration_since(Instant::now()))?;
            let port = self.port.as_mut().ok_or(LinkError::Closed)?;
            match port.read(&mut self.rbuf[..]) {
                Ok(0) => {
                    let eof = io::Error::new(io::ErrorKind::UnexpectedEof, "end of stream");
                    return Err(self.vanished(eof));
                }
                Ok(n) => {
                    self.rpos = 0;
                    self.rend = n;
                }
                Err(e) if e.kind() == io::ErrorKind::TimedOut => return Ok(None),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.vanished(e)),
            }
        }
    }

    /// Sets the port's timeout if it differs (on Windows each change is a system call).
    fn set_port_timeout(&mut self, timeout: Duration) -> Result<(), LinkError> {
        if self.port_timeout == timeout {
            return Ok(());
        }
        let port = self.port.as_mut().ok_or(LinkError::Closed)?;
        match port.set_timeout(timeout) {
            Ok(()) => {
                self.port_timeout = timeout;
                Ok(())
            }
            Err(e) => Err(self.vanished(e.into())),
        }
    }

    fn vanished(&mut self, source: io::Error) -> LinkError {
        self.port = None;
        self.stats.vanished += 1;
        LinkError::Vanished {
            path: self.config.path.clone(),
            source,
        }
    }
}

fn letter(cmd: &Command) -> char {
    let mut buf = [0u8; crate::MAX_COMMAND];
    match cmd.encode(&mut buf) {
        Ok(_) => char::from(buf[0]),
        Err(_) => '?',
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;

    #[test]
    fn specs() {
        let c = LinkConfig::from_spec("/dev/ttyACM0@500000").unwrap();
        assert_eq!(c.path, "/dev/ttyACM0");
        assert_eq!(c.bitrate.map(NominalBitrate::code), Some(6));
        let c = LinkConfig::from_spec("COM3@1M").unwrap();
        assert_eq!(c.bitrate.map(NominalBitrate::code), Some(8));
        assert_eq!(
            LinkConfig::from_spec("x@800k")
                .unwrap()
                .bitrate
                .map(NominalBitrate::code),
            Some(7)
        );
        assert_eq!(
            LinkConfig::from_spec("x@750000")
                .unwrap()
                .bitrate
                .map(NominalBitrate::code),
            Some(7)
        );
        assert_eq!(
            LinkConfig::from_spec("x@83.3k")
                .unwrap()
                .bitrate
                .map(NominalBitrate::code),
            Some(9)
        );
        assert_eq!(LinkConfig::from_spec("/dev/ttyUSB0").unwrap().bitrate, None);
        assert!(matches!(
            LinkConfig::from_spec("x@333333"),
            Err(LinkError::UnsupportedBitrate(333_333))
        ));
        assert!(matches!(
            LinkConfig::from_spec("x@fast"),
            Err(LinkError::BadSpec(_))
        ));
        assert!(matches!(
            LinkConfig::from_spec("@500k"),
            Err(LinkError::BadSpec(_))
        ));
        let _ = format!("{}", LinkError::NoReply { command: 'V' });
    }
}
