//! One connection's side of the gateway: its outbox of replies and event lines with the
//! bounds on it, the writer that drains it to the stream, and the reading of request lines
//! (cut at the line limit, the sequence number recovered for the error reply).

use std::collections::VecDeque;
use std::io::{BufRead, Write};
use std::sync::atomic::AtomicBool;
use std::sync::{Condvar, Mutex, MutexGuard};

use crate::command::{ErrorCode, Reply, Response};

pub(super) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// One item of a connection's outbox.
pub(super) enum Out {
    Reply(String),
    Event(String),
}

#[derive(Default)]
pub(super) struct OutboxState {
    pub(super) queue: VecDeque<Out>,
    /// Requests dispatched to a queue whose reply is not yet in `queue`.
    pub(super) pending: usize,
    /// Replies in `queue`.
    pub(super) replies: usize,
    pub(super) events: usize,
    /// Event lines dropped because the outbox was full.
    pub(super) dropped_events: u64,
    /// The reader is done (end of stream): the writer ends when everything is sent.
    pub(super) reading_done: bool,
    /// Writing failed: the peer is gone; nothing more is queued.
    pub(super) gone: bool,
}

/// A connection as the dispatcher sees it.
pub(super) struct Client {
    pub(super) id: u64,
    pub(super) out: Mutex<OutboxState>,
    /// Signalled when the outbox gains an item or loses one.
    pub(super) cond: Condvar,
    pub(super) events: AtomicBool,
}

impl Client {
    pub(super) fn gone(&self) -> bool {
        lock(&self.out).gone
    }

    /// Queues the reply of a dispatched request.
    pub(super) fn complete(&self, text: String) {
        let mut o = lock(&self.out);
        o.pending = o.pending.saturating_sub(1);
        if !o.gone {
            o.queue.push_back(Out::Reply(text));
            o.replies += 1;
        }
        drop(o);
        self.cond.notify_all();
    }

    /// Queues an immediate reply (the reader waited for room before reading the line).
    pub(super) fn reply(&self, text: String) {
        let mut o = lock(&self.out);
        if !o.gone {
            o.queue.push_back(Out::Reply(text));
            o.replies += 1;
        }
        drop(o);
        self.cond.notify_all();
    }

    pub(super) fn event(&self, text: &str, max: usize) {
        let mut o = lock(&self.out);
        if o.gone {
            return;
        }
        if o.events >= max {
            o.dropped_events += 1;
            return;
        }
        o.queue.push_back(Out::Event(text.to_owned()));
        o.events += 1;
        drop(o);
        self.cond.notify_all();
    }
}

/// Reads one line (up to and including LF, or to the end of the stream) into `line`, keeping
/// at most `max` bytes of it. Returns (too long, end of stream).
pub(super) fn read_line(
    r: &mut impl BufRead,
    line: &mut Vec<u8>,
    max: usize,
) -> std::io::Result<(bool, bool)> {
    let mut too_long = false;
    loop {
        let buf = match r.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            return Ok((too_long, true));
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(p) => (p + 1, true),
            None => (buf.len(), false),
        };
        let room = max.saturating_sub(line.len());
        if take > room {
            too_long = true;
        }
        line.extend_from_slice(&buf[..take.min(room)]);
        r.consume(take);
        if done {
            return Ok((too_long, false));
        }
    }
}

/// The sequence number at the start of raw line bytes, if readable.
pub(super) fn leading_seq(line: &[u8]) -> Option<u32> {
    let t = line.strip_prefix(b"[")?;
    let end = t.iter().position(|&b| b == b']')?;
    std::str::from_utf8(&t[..end]).ok()?.trim().parse().ok()
}

pub(super) fn error_text(seq: Option<u32>, code: ErrorCode) -> String {
    Response {
        seq,
        reply: Reply::Error(code),
    }
    .to_text()
}

pub(super) fn write_outbox(client: &Client, mut writer: impl Write) {
    loop {
        let item = {
            let mut o = lock(&client.out);
            loop {
                if let Some(item) = o.queue.pop_front() {
                    break Some(item);
                }
                if o.reading_done && o.pending == 0 {
                    break None;
                }
                o = client
                    .cond
                    .wait(o)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        };
        let Some(item) = item else {
            let _ = writer.flush();
            return;
        };
        let text = match &item {
            Out::Reply(t) | Out::Event(t) => t,
        };
        let ok = writer.write_all(text.as_bytes()).is_ok() && writer.flush().is_ok();
        let mut o = lock(&client.out);
        match item {
            Out::Reply(_) => o.replies -= 1,
            Out::Event(_) => o.events -= 1,
        }
        if !ok {
            o.gone = true;
            o.queue.clear();
            o.replies = 0;
            o.events = 0;
        }
        drop(o);
        client.cond.notify_all();
        if !ok {
            return;
        }
    }
}
