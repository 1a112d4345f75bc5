//! The audit log: one line for every request that changes the network (an SDO `write`, NMT,
//! LSS; see [`crate::access::Class::Change`]), served or refused.
//!
//! A line is `<UTC time> <client> <request> -> <reply>`, for example
//! `2026-12-03T01:02:03.456Z tcp:127.0.0.1:50712 [4] 5 write 0x1017 0 u16 250 -> [4] OK`.
//! The request is the line as the client sent it (line end trimmed, control characters shown
//! as `?` so that a client cannot forge a line of its own); the reply is the gateway's. A file
//! log is opened for appending, never truncated, and every line is flushed as it is written.

use std::io::Write;
use std::sync::{Arc, Mutex};
use std::time::{SystemTime, UNIX_EPOCH};

/// Where audit lines go.
pub struct AuditLog {
    out: Mutex<Box<dyn Write + Send>>,
}

impl AuditLog {
    /// Appends to the file at `path` (created if missing, never truncated).
    pub fn append_to(path: &std::path::Path) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)?;
        Ok(Self::to_writer(file))
    }

    /// Writes to `out` (standard error, a buffer in a test).
    pub fn to_writer(out: impl Write + Send + 'static) -> Self {
        Self {
            out: Mutex::new(Box::new(out)),
        }
    }

    /// Writes one line now. A write error is ignored: the gateway serves on without its log
    /// rather than stopping the plant's operator.
    pub fn record(&self, client: &str, request: &str, reply: &str) {
        let line = format!(
            "{} {client} {} -> {}\n",
            utc_now(),
            clean(request),
            clean(reply)
        );
        let mut out = self
            .out
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let _ = out.write_all(line.as_bytes());
        let _ = out.flush();
    }
}

impl core::fmt::Debug for AuditLog {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("AuditLog").finish_non_exhaustive()
    }
}

/// A changing request waiting for its reply.
#[derive(Debug, Clone)]
pub(crate) struct Pending {
    log: Arc<AuditLog>,
    client: String,
    request: String,
}

impl Pending {
    pub(crate) fn new(log: &Arc<AuditLog>, client: String, request: &str) -> Self {
        Self {
            log: log.clone(),
            client,
            request: request.to_owned(),
        }
    }

    pub(crate) fn record(&self, reply: &str) {
        self.log.record(&self.client, &self.request, reply);
    }
}

/// The text trimmed, one line, control characters as `?`.
fn clean(s: &str) -> String {
    s.trim()
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

/// `YYYY-MM-DDTHH:MM:SS.mmmZ` now.
fn utc_now() -> String {
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    let secs = d.as_secs();
    let (y, m, day) = civil_from_days((secs / 86_400) as i64);
    let s = secs % 86_400;
    format!(
        "{y:04}-{m:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        s / 3600,
        s / 60 % 60,
        s % 60,
        d.subsec_millis()
    )
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (the era arithmetic of
/// Howard Hinnant's `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_790), (2026, 12, 3));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }

    #[test]
    fn lines_are_one_line_each_and_appended() {
        let dir = std::env::temp_dir().join(format!("canola-audit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("audit.log");
        std::fs::write(&path, "earlier line\n").unwrap();
        let log = AuditLog::append_to(&path).unwrap();
        log.record("tcp:127.0.0.1:5", "[1] 5 stop\r\n", "[1] OK\r\n");
        log.record("unix", "5 write 0x1017 0 vs \"a\nforged\"", "ERROR:100\r\n");
        drop(log);
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<_> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert_eq!(lines[0], "earlier line");
        assert!(
            lines[1].ends_with(" tcp:127.0.0.1:5 [1] 5 stop -> [1] OK"),
            "{}",
            lines[1]
        );
        assert!(lines[2].ends_with("unix 5 write 0x1017 0 vs \"a?forged\" -> ERROR:100"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
