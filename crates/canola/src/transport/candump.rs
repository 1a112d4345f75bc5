//! The can-utils candump log format (`candump -l`), read and written.
//!
//! One frame per line: `(SECONDS.MICROS) IFACE FRAME`, for example
//! `(1700000000.123456) can0 123#DEADBEEF`. `FRAME` is a 3-digit hex identifier (11-bit) or an
//! 8-digit one (29-bit), `#`, then the data as hex pairs (can-utils also accepts `.` between
//! pairs), or `R` for a remote frame with an optional length digit (`123#R`, `123#R8`). An
//! 8-digit identifier with the error flag `0x20000000` is a CAN error frame. `candump -8` (and
//! `-L`, with the socket's `CAN_CTRLMODE_CC_LEN8_DLC`) writes the raw DLC 9..=F of a classic
//! frame that carries 8 bytes after them: `123#1122334455667788_C`, `123#R8_9`; it is kept in
//! [`LogEntry::len8_dlc`] and written back. A CAN FD frame is
//! `ID##F` then its data: `F` is one hex digit of flags (bit 0 bit-rate switch, bit 1 error
//! state indicator), the data 0 to 8, 12, 16, 20, 24, 32, 48 or 64 bytes. FD lines are read
//! as [`LogFrame::Fd`] (the stack's [`FdFrame`]); `canopen replay` sends them on a bus that
//! carries CAN FD.
//!
//! The reader is a total decoder of file text: every line becomes an entry or a typed
//! [`CandumpError`] with its line number; it never panics and reads at most
//! [`MAX_LINE`] bytes per line.

use std::io::{BufRead, Write};

use canola_frame::{CanFrame, CanId};

/// Longest line the reader accepts (a classic frame line is under 60 bytes).
pub const MAX_LINE: usize = 256;

/// The SocketCAN error flag in a frame identifier (`CAN_ERR_FLAG`).
pub const ERROR_FLAG: u32 = 0x2000_0000;

/// What a log line carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFrame {
    /// A data or remote frame.
    Can(CanFrame),
    /// A CAN FD frame (replayed on a bus that carries CAN FD, see
    /// [`Transport::fd_support`](crate::Transport::fd_support)).
    Fd(FdFrame),
    /// A CAN error frame: error class bits (identifier without the flag) and detail bytes.
    Error {
        /// Error class bits.
        class: u32,
        /// Detail bytes (unused ones zero).
        data: [u8; 8],
    },
}

/// A CAN FD frame of a log line: the stack's one FD frame type. The flags digit of a log line
/// is its [`FdFlags`](canola_frame::FdFlags) bits: bit 0 bit-rate switch (BRS), bit 1 error
/// state indicator (ESI), bit 2 the FD format flag (FDF) that Linux 6.2 and later set on
/// received frames.
pub use canola_frame::FdFrame;

/// The data lengths a CAN FD frame can have.
pub use canola_frame::fd::FD_LENGTHS;

/// One line of a candump log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogEntry {
    /// Time stamp in microseconds since the Unix epoch (or whatever origin the log used).
    pub timestamp_us: u64,
    /// Interface name, e.g. `can0`.
    pub interface: String,
    /// The frame.
    pub frame: LogFrame,
    /// The raw DLC 9..=15 of a classic frame of 8 bytes (a data frame with 8 data bytes, a
    /// remote frame of length 8), as `candump -8` writes it after them (`_9`..`_F`); SocketCAN's
    /// `len8_dlc`. `None` for every other frame, and for a frame whose DLC is its length.
    /// [`format_line`] writes it only where it is valid (9..=15, on such a frame).
    pub len8_dlc: Option<u8>,
}

impl LogEntry {
    /// The raw DLC its line carries: [`len8_dlc`](Self::len8_dlc) when it is 9..=15 and the
    /// frame a classic frame of 8 bytes, else `None`.
    pub fn raw_dlc(&self) -> Option<u8> {
        valid_len8_dlc(&self.frame, self.len8_dlc)
    }
}

/// `len8_dlc` when it is 9..=15 on a classic frame of 8 bytes.
fn valid_len8_dlc(frame: &LogFrame, len8_dlc: Option<u8>) -> Option<u8> {
    match (frame, len8_dlc) {
        (LogFrame::Can(f), Some(dlc @ 9..=15)) if f.dlc() == 8 => Some(dlc),
        _ => None,
    }
}

/// Why a log line could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CandumpError {
    /// The line does not start with `(SECONDS.MICROS)`.
    #[error("bad time stamp (expected `(SECONDS.MICROS)`)")]
    BadTimestamp,
    /// The interface name is missing.
    #[error("missing interface name")]
    MissingInterface,
    /// The frame field is missing or has no `#`.
    #[error("missing frame (expected `ID#DATA`)")]
    MissingFrame,
    /// The identifier is not 3 or 8 hex digits, or out of range.
    #[error("bad CAN identifier `{0}`")]
    BadId(String),
    /// The data are not hex pairs, or more than 8 bytes.
    #[error("bad frame data `{0}`")]
    BadData(String),
    /// A raw DLC suffix (`_X`, `candump -8`) that is not one hex digit 9..=F after a classic
    /// frame of 8 bytes (8 data bytes, or `R8`): the text after the `_`.
    #[error("bad raw DLC `_{0}` (candump -8 writes one hex digit 9..F after 8 data bytes or `R8`)")]
    BadRawDlc(String),
    /// A CAN FD line (`##`) whose flags digit is missing or not hex.
    #[error("bad CAN FD flags `{0}` (expected one hex digit after `##`)")]
    BadFdFlags(String),
    /// Extra text after the frame.
    #[error("unexpected text after the frame")]
    TrailingText,
    /// The line is longer than [`MAX_LINE`].
    #[error("line longer than {MAX_LINE} bytes")]
    LineTooLong,
    /// The line is not UTF-8.
    #[error("line is not UTF-8 text")]
    NotText,
    /// The last line of the log has no line end and its frame could go on (fewer data bytes
    /// than a frame carries): the file may have been cut there, and the frame with it.
    #[error("last line has no line end: the log may have been cut inside this frame")]
    MaybeCut,
}

/// An I/O failure or a bad line, with its 1-based line number.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// Reading failed.
    #[error("reading the log failed: {0}")]
    Io(#[from] std::io::Error),
    /// A line could not be decoded.
    #[error("line {line}: {error}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        error: CandumpError,
    },
}

fn hex_val(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

fn parse_hex_u32(s: &str) -> Option<u32> {
    if s.is_empty() || s.len() > 8 {
        return None;
    }
    s.bytes()
        .try_fold(0u32, |acc, b| Some((acc << 4) | u32::from(hex_val(b)?)))
}

fn parse_timestamp(s: &str) -> Result<u64, CandumpError> {
    let inner = s
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .ok_or(CandumpError::BadTimestamp)?;
    let (secs, frac) = inner.split_once('.').ok_or(CandumpError::BadTimestamp)?;
    if secs.is_empty()
        || secs.len() > 12
        || frac.is_empty()
        || frac.len() > 9
        || !secs.bytes().all(|b| b.is_ascii_digit())
        || !frac.bytes().all(|b| b.is_ascii_digit())
    {
        return Err(CandumpError::BadTimestamp);
    }
    let secs: u64 = secs.parse().map_err(|_| CandumpError::BadTimestamp)?;
    // Scale the fraction to microseconds (candump writes 6 digits; accept 1..=9).
    let mut frac_us: u64 = 0;
    for (i, b) in frac.bytes().enumerate() {
        if i < 6 {
            frac_us = frac_us * 10 + u64::from(b - b'0');
        }
    }
    for _ in frac.len()..6 {
        frac_us *= 10;
    }
    secs.checked_mul(1_000_000)
        .and_then(|us| us.checked_add(frac_us))
        .ok_or(CandumpError::BadTimestamp)
}

/// Decodes hex pairs (`.` between them allowed) into `out`; `None` when they are not hex
/// pairs or do not fit.
fn hex_pairs(text: &str, out: &mut [u8]) -> Option<usize> {
    let mut len = 0usize;
    let mut digits = text.bytes().filter(|b| *b != b'.');
    while let Some(hi) = digits.next() {
        let lo = digits.next()?;
        *out.get_mut(len)? = (hex_val(hi)? << 4) | hex_val(lo)?;
        len += 1;
    }
    Some(len)
}

/// Decodes the `ID#DATA` field. A raw DLC suffix (`_C`) is checked but not returned: see
/// [`parse_frame_len8`].
pub fn parse_frame(s: &str) -> Result<LogFrame, CandumpError> {
    parse_frame_len8(s).map(|(frame, _)| frame)
}

/// The raw DLC of a `_X` suffix: one hex digit 9..=F, else [`CandumpError::BadRawDlc`].
fn raw_dlc(text: &str) -> Result<u8, CandumpError> {
    match text.as_bytes() {
        [d] => match hex_val(*d) {
            Some(v) if v > 8 => Ok(v),
            _ => Err(CandumpError::BadRawDlc(text.into())),
        },
        _ => Err(CandumpError::BadRawDlc(text.into())),
    }
}

/// Decodes the `ID#DATA` field and its raw DLC (`_9`..`_F` after a classic frame of 8 bytes,
/// see [`LogEntry::len8_dlc`]).
pub fn parse_frame_len8(s: &str) -> Result<(LogFrame, Option<u8>), CandumpError> {
    let (id, data) = s.split_once('#').ok_or(CandumpError::MissingFrame)?;
    let raw = parse_hex_u32(id).ok_or_else(|| CandumpError::BadId(id.into()))?;
    let bad_id = || CandumpError::BadId(id.into());
    if let Some(fd) = data.strip_prefix('#') {
        let can_id = match id.len() {
            3 => CanId::standard(raw as u16).map_err(|_| bad_id())?,
            8 => CanId::extended(raw).map_err(|_| bad_id())?,
            _ => return Err(bad_id()),
        };
        let mut chars = fd.chars();
        let flags = chars
            .next()
            .and_then(|c| c.to_digit(16))
            .ok_or_else(|| CandumpError::BadFdFlags(fd.chars().take(1).collect()))?;
        let rest = chars.as_str();
        let bad_data = || CandumpError::BadData(rest.into());
        let mut bytes = [0u8; 64];
        let len = hex_pairs(rest, &mut bytes).ok_or_else(bad_data)?;
        return FdFrame::new(can_id, &bytes[..len])
            .map(|f| {
                let flags = canola_frame::FdFlags::from_bits_truncate(flags as u8);
                (LogFrame::Fd(f.with_flags(flags)), None)
            })
            .map_err(|_| bad_data());
    }
    let error_frame = id.len() == 8 && raw & ERROR_FLAG != 0;
    let can_id = match id.len() {
        3 => Some(CanId::standard(raw as u16).map_err(|_| bad_id())?),
        8 if error_frame => None,
        8 => Some(CanId::extended(raw).map_err(|_| bad_id())?),
        _ => return Err(bad_id()),
    };
    let bad_data = || CandumpError::BadData(data.into());
    // candump -8 writes a classic frame's raw DLC above 8 after its 8 bytes (`_9`..`_F`, see
    // can-utils' lib.h: `123#1122334455667788_E`, `123#R8_9`).
    let (data, suffix) = match data.split_once('_') {
        Some((d, dlc)) => (d, Some(dlc)),
        None => (data, None),
    };
    if let Some(rest) = data.strip_prefix(['R', 'r']) {
        let Some(can_id) = can_id else {
            return Err(bad_data());
        };
        let dlc = match rest.as_bytes() {
            [] => 0,
            [d] if d.is_ascii_digit() && *d <= b'8' => usize::from(d - b'0'),
            _ => return Err(bad_data()),
        };
        let len8_dlc = match suffix {
            Some(text) if dlc == 8 => Some(raw_dlc(text)?),
            Some(text) => return Err(CandumpError::BadRawDlc(text.into())),
            None => None,
        };
        return CanFrame::remote(can_id, dlc)
            .map(|f| (LogFrame::Can(f), len8_dlc))
            .map_err(|_| bad_data());
    }
    let mut bytes = [0u8; 8];
    let len = hex_pairs(data, &mut bytes).ok_or_else(bad_data)?;
    let len8_dlc = match suffix {
        // Error frames have no DLC of their own to keep.
        Some(text) if len == 8 && can_id.is_some() => Some(raw_dlc(text)?),
        Some(text) => return Err(CandumpError::BadRawDlc(text.into())),
        None => None,
    };
    match can_id {
        Some(can_id) => CanFrame::new(can_id, &bytes[..len])
            .map(|f| (LogFrame::Can(f), len8_dlc))
            .map_err(|_| bad_data()),
        None => Ok((
            LogFrame::Error {
                class: raw & !ERROR_FLAG,
                data: bytes,
            },
            None,
        )),
    }
}

/// Decodes one log line.
pub fn parse_line(line: &str) -> Result<LogEntry, CandumpError> {
    let mut fields = line.split_ascii_whitespace();
    let ts = parse_timestamp(fields.next().ok_or(CandumpError::BadTimestamp)?)?;
    let iface = fields.next().ok_or(CandumpError::MissingInterface)?;
    let (frame, len8_dlc) = parse_frame_len8(fields.next().ok_or(CandumpError::MissingFrame)?)?;
    // candump -l may append a direction marker ("T"/"R") in some versions; anything else is an error.
    match fields.next() {
        None | Some("T" | "R") => {}
        Some(_) => return Err(CandumpError::TrailingText),
    }
    if fields.next().is_some() {
        return Err(CandumpError::TrailingText);
    }
    Ok(LogEntry {
        timestamp_us: ts,
        interface: iface.into(),
        frame,
        len8_dlc,
    })
}

/// Formats the `ID#DATA` field.
pub fn format_frame(frame: &LogFrame) -> String {
    match frame {
        LogFrame::Can(f) => f.to_string(),
        LogFrame::Fd(f) => f.to_string(),
        LogFrame::Error { class, data } => {
            let mut s = format!("{:08X}#", class | ERROR_FLAG);
            for b in data {
                s.push_str(&format!("{b:02X}"));
            }
            s
        }
    }
}

/// Formats the `ID#DATA` field with a raw DLC as `candump -8` writes it (`_C` after a
/// classic frame of 8 bytes, when `len8_dlc` is 9..=15; otherwise as [`format_frame`]).
pub fn format_frame_len8(frame: &LogFrame, len8_dlc: Option<u8>) -> String {
    let mut s = format_frame(frame);
    if let Some(dlc) = valid_len8_dlc(frame, len8_dlc) {
        s.push('_');
        s.push(char::from(b"0123456789ABCDEF"[usize::from(dlc)]));
    }
    s
}

/// Formats one log line (without the line break).
pub fn format_line(entry: &LogEntry) -> String {
    format!(
        "({}.{:06}) {} {}",
        entry.timestamp_us / 1_000_000,
        entry.timestamp_us % 1_000_000,
        entry.interface,
        format_frame_len8(&entry.frame, entry.len8_dlc)
    )
}

/// Reads a candump log line by line. Empty lines are skipped.
#[derive(Debug)]
pub struct Reader<R> {
    inner: R,
    line: usize,
    buf: Vec<u8>,
}

impl<R: BufRead> Reader<R> {
    /// Wraps a buffered reader.
    pub fn new(inner: R) -> Self {
        Self {
            inner,
            line: 0,
            buf: Vec::with_capacity(MAX_LINE),
        }
    }

    /// The 1-based number of the last line read (0 before the first).
    pub fn line(&self) -> usize {
        self.line
    }

    /// Reads one line of at most `MAX_LINE` bytes (the rest of a longer line is skipped):
    /// whether it was too long, and whether it ended with a line break.
    fn read_line(&mut self) -> Result<Option<(bool, bool)>, std::io::Error> {
        self.buf.clear();
        let mut too_long = false;
        let mut any = false;
        loop {
            let avail = self.inner.fill_buf()?;
            if avail.is_empty() {
                return Ok(any.then_some((too_long, false)));
            }
            any = true;
            let (chunk, done) = match avail.iter().position(|b| *b == b'\n') {
                Some(i) => (&avail[..i], Some(i + 1)),
                None => (avail, None),
            };
            let room = MAX_LINE.saturating_sub(self.buf.len());
            if chunk.len() > room {
                too_long = true;
            }
            self.buf.extend_from_slice(&chunk[..chunk.len().min(room)]);
            let consumed = done.unwrap_or(avail.len());
            self.inner.consume(consumed);
            if done.is_some() {
                return Ok(Some((too_long, true)));
            }
        }
    }
}

impl<R: BufRead> Iterator for Reader<R> {
    type Item = Result<LogEntry, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let (too_long, ended) = match self.read_line() {
                Ok(Some(t)) => t,
                Ok(None) => return None,
                Err(e) => return Some(Err(e.into())),
            };
            self.line += 1;
            let line = self.line;
            let err = |error| Some(Err(ReadError::Line { line, error }));
            if too_long {
                return err(CandumpError::LineTooLong);
            }
            let Ok(text) = std::str::from_utf8(&self.buf) else {
                return err(CandumpError::NotText);
            };
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            return Some(match parse_line(text) {
                // candump and `canopen record` end every line: a last line without its end
                // whose frame could be longer was probably cut when the log was copied or the
                // recorder killed, and would replay as a shorter frame.
                Ok(_) if !ended && may_be_cut(text) => Err(ReadError::Line {
                    line,
                    error: CandumpError::MaybeCut,
                }),
                r => r.map_err(|error| ReadError::Line { line, error }),
            });
        }
    }
}

/// Whether a line that reads could be the beginning of a longer one: its frame field is last
/// (no direction marker after it) and more data digits could follow (fewer than 8 bytes in a
/// classic frame or 64 in an FD frame, a remote frame without its length digit).
fn may_be_cut(line: &str) -> bool {
    let Some(field) = line.split_ascii_whitespace().next_back() else {
        return false;
    };
    let Some((_, data)) = field.split_once('#') else {
        return false;
    };
    let digits = |t: &str| t.bytes().filter(|b| *b != b'.').count();
    if let Some(fd) = data.strip_prefix('#') {
        return digits(fd.get(1..).unwrap_or("")) < 128;
    }
    if let Some(rest) = data.strip_prefix(['R', 'r']) {
        return rest.is_empty();
    }
    !data.contains('_') && digits(data) < 16
}

/// Writes candump log lines.
#[derive(Debug)]
pub struct Writer<W> {
    inner: W,
}

impl<W: Write> Writer<W> {
    /// Wraps a writer.
    pub fn new(inner: W) -> Self {
        Self { inner }
    }

    /// Writes one entry and a line break.
    pub fn write(&mut self, entry: &LogEntry) -> std::io::Result<()> {
        writeln!(self.inner, "{}", format_line(entry))
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }

    /// Returns the underlying writer.
    pub fn into_inner(self) -> W {
        self.inner
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    #[test]
    fn reads_can_utils_lines() {
        let e = parse_line("(1700000000.123456) can0 123#DEADBEEF").unwrap();
        assert_eq!(e.timestamp_us, 1_700_000_000_123_456);
        assert_eq!(e.interface, "can0");
        assert_eq!(
            e.frame,
            LogFrame::Can(CanFrame::new(sid(0x123), &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap())
        );
        let r = parse_line("(0.000001) vcan0 705#R").unwrap();
        assert_eq!(
            r.frame,
            LogFrame::Can(CanFrame::remote(sid(0x705), 0).unwrap())
        );
        let r1 = parse_line("(0.5) vcan0 705#R1").unwrap();
        assert_eq!(r1.timestamp_us, 500_000);
        assert_eq!(
            r1.frame,
            LogFrame::Can(CanFrame::remote(sid(0x705), 1).unwrap())
        );
        let empty = parse_line("(1.000000) can1 080#").unwrap();
        assert_eq!(
            empty.frame,
            LogFrame::Can(CanFrame::new(sid(0x80), &[]).unwrap())
        );
        let dotted = parse_line("(1.000000) can1 601#40.17.10.00").unwrap();
        assert_eq!(
            dotted.frame,
            LogFrame::Can(CanFrame::new(sid(0x601), &[0x40, 0x17, 0x10, 0]).unwrap())
        );
        let ext = parse_line("(1.000000) can0 1ABCDEF0#01").unwrap();
        assert_eq!(
            ext.frame,
            LogFrame::Can(CanFrame::new(CanId::extended(0x1ABC_DEF0).unwrap(), &[1]).unwrap())
        );
        let err = parse_line("(1.000000) can0 20000004#0004000000000000").unwrap();
        assert_eq!(
            err.frame,
            LogFrame::Error {
                class: 4,
                data: [0, 4, 0, 0, 0, 0, 0, 0]
            }
        );
    }

    #[test]
    fn rejects_bad_lines_with_typed_errors() {
        use CandumpError::*;
        let cases = [
            ("", BadTimestamp),
            ("1.0 can0 123#00", BadTimestamp),
            ("(1) can0 123#00", BadTimestamp),
            ("(1.x) can0 123#00", BadTimestamp),
            ("(1.0)", MissingInterface),
            ("(1.0) can0", MissingFrame),
            ("(1.0) can0 12300", MissingFrame),
            ("(1.0) can0 800#00", BadId("800".into())),
            ("(1.0) can0 12#00", BadId("12".into())),
            ("(1.0) can0 123#0", BadData("0".into())),
            (
                "(1.0) can0 123#000102030405060708",
                BadData("000102030405060708".into()),
            ),
            ("(1.0) can0 123#zz", BadData("zz".into())),
            ("(1.0) can0 123#R9", BadData("R9".into())),
            ("(1.0) can0 123##", BadFdFlags(String::new())),
            ("(1.0) can0 123##x00", BadFdFlags("x".into())),
            (
                "(1.0) can0 123##1000102030405060708",
                BadData("000102030405060708".into()),
            ),
            ("(1.0) can0 12##100", BadId("12".into())),
            ("(1.0) can0 123#00 extra", TrailingText),
            ("(99999999999999.0) can0 123#00", BadTimestamp),
        ];
        for (line, want) in cases {
            assert_eq!(parse_line(line), Err(want), "{line:?}");
        }
    }

    #[test]
    fn reads_and_writes_can_fd_lines() {
        let line = "(1.000000) can0 123##1000102030405060708090A0B";
        let e = parse_line(line).unwrap();
        let LogFrame::Fd(fd) = e.frame else {
            panic!("{e:?}")
        };
        assert_eq!(fd.id(), sid(0x123));
        assert_eq!(fd.flags().bits(), 1);
        assert_eq!(fd.data(), (0u8..12).collect::<Vec<_>>());
        assert_eq!(format_line(&e), line);
        let ext = parse_line("(1.000000) can0 1ABCDEF0##0").unwrap();
        assert_eq!(format_line(&ext), "(1.000000) can0 1ABCDEF0##0");
        let long = format!("(1.000000) can0 7FF##3{}", "AB".repeat(64));
        assert_eq!(format_line(&parse_line(&long).unwrap()), long);
    }

    #[test]
    fn writes_what_it_reads() {
        let line = "(1700000000.000042) can0 605#4017100000000000";
        assert_eq!(format_line(&parse_line(line).unwrap()), line);
        assert_eq!(
            format_line(&parse_line("(3.000000) can0 705#R").unwrap()),
            "(3.000000) can0 705#R"
        );
    }

    #[test]
    fn reader_numbers_lines_and_bounds_them() {
        let text = format!(
            "(1.000000) can0 123#01\n\n(x) can0 1#\n{}\n(2.000000) can0 124#02\n",
            "A".repeat(1000)
        );
        let out: Vec<_> = Reader::new(text.as_bytes()).collect();
        assert_eq!(out.len(), 4);
        assert!(out[0].is_ok());
        assert!(matches!(
            out[1],
            Err(ReadError::Line {
                line: 3,
                error: CandumpError::BadTimestamp
            })
        ));
        assert!(matches!(
            out[2],
            Err(ReadError::Line {
                line: 4,
                error: CandumpError::LineTooLong
            })
        ));
        assert_eq!(out[3].as_ref().unwrap().timestamp_us, 2_000_000);
    }

    #[test]
    fn keeps_candump_8s_raw_dlc_above_8_and_writes_it_back() {
        let line = "(1.000000) can0 123#1122334455667788_C";
        let e = parse_line(line).unwrap();
        assert_eq!(
            e.frame,
            LogFrame::Can(
                CanFrame::new(
                    sid(0x123),
                    &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]
                )
                .unwrap()
            )
        );
        assert_eq!(e.len8_dlc, Some(12));
        assert_eq!(format_line(&e), line);
        // Lower-case digits read; they are written as candump writes them.
        let lower = parse_line("(1.000000) can0 123#1122334455667788_f").unwrap();
        assert_eq!(lower.len8_dlc, Some(15));
        assert!(format_line(&lower).ends_with("_F"));
        // A remote frame of length 8 (`123#R8_9` in can-utils' lib.h).
        let remote = "(1.000000) can0 12345678#R8_9";
        let r = parse_line(remote).unwrap();
        assert_eq!(r.len8_dlc, Some(9));
        assert_eq!(format_line(&r), remote);
        // Without the suffix there is none; one set on a frame it does not fit is not written.
        assert_eq!(
            parse_line("(1.0) can0 123#1122334455667788")
                .unwrap()
                .len8_dlc,
            None
        );
        let short = LogEntry {
            len8_dlc: Some(12),
            ..parse_line("(1.000000) can0 123#11").unwrap()
        };
        assert_eq!(format_line(&short), "(1.000000) can0 123#11");
        assert_eq!(short.raw_dlc(), None);
        assert_eq!(e.raw_dlc(), Some(12));
        // A whole line: not cut.
        let out: Vec<_> = Reader::new("(1.0) can0 123#1122334455667788_9".as_bytes()).collect();
        assert_eq!(out[0].as_ref().unwrap().len8_dlc, Some(9), "{out:?}");
    }

    #[test]
    fn a_raw_dlc_of_8_or_less_or_not_hex_or_after_fewer_bytes_is_a_typed_error() {
        // Only after 8 bytes, only one hex digit 9..F.
        for (bad, text) in [
            ("(1.0) can0 123#1122334455667788_8", "8"),
            ("(1.0) can0 123#1122334455667788_0", "0"),
            ("(1.0) can0 123#1122334455667788_G", "G"),
            ("(1.0) can0 123#1122334455667788_", ""),
            ("(1.0) can0 123#1122334455667788_CC", "CC"),
            ("(1.0) can0 123#11_C", "C"),
            ("(1.0) can0 123#_C", "C"),
            ("(1.0) can0 123#R7_C", "C"),
            ("(1.0) can0 123#R_C", "C"),
            ("(1.0) can0 123#R8_8", "8"),
            ("(1.0) can0 20000004#0004000000000000_C", "C"),
        ] {
            assert_eq!(
                parse_line(bad),
                Err(CandumpError::BadRawDlc(text.into())),
                "{bad}"
            );
        }
        // Bad data before the suffix is bad data.
        assert!(matches!(
            parse_line("(1.0) can0 123#11223344556677zz_C"),
            Err(CandumpError::BadData(_))
        ));
        // Through the reader: with its line number, and a sentence naming the suffix.
        let text = "(1.000000) can0 123#1122334455667788_C\n(1.1) can0 123#1122334455667788_8\n";
        let out: Vec<_> = Reader::new(text.as_bytes()).collect();
        assert!(out[0].is_ok());
        let err = out[1].as_ref().unwrap_err();
        assert!(
            matches!(
                err,
                ReadError::Line {
                    line: 2,
                    error: CandumpError::BadRawDlc(t)
                } if t == "8"
            ),
            "{err:?}"
        );
        assert_eq!(
            err.to_string(),
            "line 2: bad raw DLC `_8` (candump -8 writes one hex digit 9..F after 8 data bytes or `R8`)"
        );
    }

    #[test]
    fn a_last_line_cut_at_a_byte_boundary_is_reported() {
        let whole = "(1.000000) can0 705#05\n(1.100000) can0 185#2E93\n";
        assert!(Reader::new(whole.as_bytes()).all(|e| e.is_ok()));
        // The same log cut after `2E93` (its line end lost): the frame may have had more bytes.
        let cut = &whole[..whole.len() - 1];
        let out: Vec<_> = Reader::new(cut.as_bytes()).collect();
        assert!(out[0].is_ok());
        assert!(
            matches!(
                out[1],
                Err(ReadError::Line {
                    line: 2,
                    error: CandumpError::MaybeCut
                })
            ),
            "{out:?}"
        );
        assert!(
            out[1]
                .as_ref()
                .unwrap_err()
                .to_string()
                .starts_with("line 2: ")
        );
        // A last line without its end that cannot go on reads: 8 data bytes, a remote frame with
        // its length, a direction marker after the frame, a 64-byte FD frame.
        for last in [
            "(1.0) can0 185#0102030405060708",
            "(1.0) can0 185#R8",
            "(1.0) can0 185#01 R",
            &format!("(1.0) can0 185##1{}", "00".repeat(64)),
        ] {
            let out: Vec<_> = Reader::new(last.as_bytes()).collect();
            assert!(out.len() == 1 && out[0].is_ok(), "{last}: {out:?}");
        }
        for cut in [
            "(1.0) can0 080#",
            "(1.0) can0 185#R",
            "(1.0) can0 185##1000102",
        ] {
            let out: Vec<_> = Reader::new(cut.as_bytes()).collect();
            assert!(
                matches!(
                    out[0],
                    Err(ReadError::Line {
                        line: 1,
                        error: CandumpError::MaybeCut
                    })
                ),
                "{cut}: {out:?}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn never_panics(s in ".{0,80}") {
            let _ = parse_line(&s);
        }

        #[test]
        fn round_trip(ts in 0u64..=4_000_000_000_000_000, raw in 0u16..=0x7FF,
                      data in proptest::collection::vec(any::<u8>(), 0..=8), remote in any::<bool>(),
                      raw_dlc in proptest::option::of(9u8..=15)) {
            let frame = if remote {
                CanFrame::remote(sid(raw), data.len()).unwrap()
            } else {
                CanFrame::new(sid(raw), &data).unwrap()
            };
            // A raw DLC only where candump -8 writes one: a frame of 8 bytes.
            let len8_dlc = raw_dlc.filter(|_| data.len() == 8);
            let e = LogEntry {
                timestamp_us: ts,
                interface: "can0".into(),
                frame: LogFrame::Can(frame),
                len8_dlc,
            };
            prop_assert_eq!(parse_line(&format_line(&e)), Ok(e));
        }
    }
}
