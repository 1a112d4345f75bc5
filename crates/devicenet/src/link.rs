//! One end of an explicit messaging connection: sends a message whole or with the acknowledged
//! fragmentation protocol, reassembles incoming fragments and acknowledges them. Used by both
//! the master and the slave machine.
//!
//! The sender waits for each fragment's acknowledgement ([`Link::ack_timeout`]); a missing or
//! negative acknowledgement abandons the message ([`LinkEvent::SendFailed`]).

use canola_frame::{CanFrame, CanId, Duration, Instant};
use heapless::Deque;

use crate::explicit::{ExplicitFrame, Header};
use crate::fragment::{
    AckStatus, EXPLICIT_FRAGMENT_DATA, FragmentByte, FragmentError, FragmentType, MAX_MESSAGE,
    MessageBuf, Reassembler,
};
use crate::id::MacId;

/// Outgoing frames a machine may hold before the caller drains them.
pub(crate) const TX_LEN: usize = 32;

/// What the link reports to its machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum LinkEvent {
    /// A complete message arrived (service and body) with its header's XID bit.
    Message(MessageBuf, bool),
    /// A fragmented send was not acknowledged in time or was refused.
    SendFailed,
    /// A fragment out of sequence or too long; the partial message was dropped.
    BadFragment(FragmentError),
}

#[derive(Debug, Clone)]
struct Sending {
    message: MessageBuf,
    xid: bool,
    offset: usize,
    count: u8,
    deadline: Instant,
}

/// An explicit link.
#[derive(Debug, Clone)]
pub(crate) struct Link {
    /// Identifier the link sends on.
    tx_id: CanId,
    /// MAC ID written into the header of sent frames (the other end).
    peer: MacId,
    pub(crate) ack_timeout: Duration,
    sending: Option<Sending>,
    rx: Reassembler,
}

impl Link {
    pub(crate) fn new(tx_id: CanId, peer: MacId, ack_timeout: Duration) -> Self {
        Self {
            tx_id,
            peer,
            ack_timeout,
            sending: None,
            rx: Reassembler::new(),
        }
    }

    pub(crate) fn reset(&mut self) {
        self.sending = None;
        self.rx.reset();
    }

    fn header(&self, fragmented: bool, xid: bool) -> Header {
        Header {
            fragmented,
            xid,
            mac: self.peer,
        }
    }

    fn push(&self, tx: &mut Deque<CanFrame, TX_LEN>, f: ExplicitFrame<'_>) {
        if let Some(bytes) = f.emit()
            && let Ok(frame) = CanFrame::new(self.tx_id, &bytes)
        {
            let _ = tx.push_back(frame);
        }
    }

    /// Sends a message (service + body); a longer one than 7 bytes is fragmented.
    pub(crate) fn send(
        &mut self,
        now: Instant,
        message: &[u8],
        xid: bool,
        tx: &mut Deque<CanFrame, TX_LEN>,
    ) {
        if message.len() <= 7 {
            self.push(
                tx,
                ExplicitFrame::Whole {
                    header: self.header(false, xid),
                    message,
                },
            );
            return;
        }
        let mut buf = MessageBuf::new();
        if buf.extend_from_slice(message).is_err() {
            return;
        }
        self.sending = Some(Sending {
            message: buf,
            xid,
            offset: 0,
            count: 0,
            deadline: now,
        });
        self.next_fragment(now, tx);
    }

    fn next_fragment(&mut self, now: Instant, tx: &mut Deque<CanFrame, TX_LEN>) {
        let Some(s) = &mut self.sending else { return };
        let end = (s.offset + EXPLICIT_FRAGMENT_DATA).min(s.message.len());
        let kind = if s.offset == 0 {
            FragmentType::First
        } else if end == s.message.len() {
            FragmentType::Last
        } else {
            FragmentType::Middle
        };
        s.deadline = now + self.ack_timeout;
        let (xid, count) = (s.xid, s.count);
        let data: heapless::Vec<u8, EXPLICIT_FRAGMENT_DATA> =
            heapless::Vec::from_slice(&s.message[s.offset..end]).unwrap_or_default();
        s.offset = end;
        self.push(
            tx,
            ExplicitFrame::Fragment {
                header: self.header(true, xid),
                fragment: FragmentByte { kind, count },
                data: &data,
            },
        );
    }

    /// Feeds the data of a frame received on the link's incoming identifier.
    pub(crate) fn handle(
        &mut self,
        now: Instant,
        data: &[u8],
        tx: &mut Deque<CanFrame, TX_LEN>,
    ) -> Option<LinkEvent> {
        let frame = ExplicitFrame::parse(data).ok()?;
        match frame {
            ExplicitFrame::Whole { header, message } => {
                let mut buf = MessageBuf::new();
                buf.extend_from_slice(message).ok()?;
                Some(LinkEvent::Message(buf, header.xid))
            }
            ExplicitFrame::Ack { count, status, .. } => {
                let s = self.sending.as_ref()?;
                if count != s.count {
                    return None;
                }
                if status != AckStatus::Success {
                    self.sending = None;
                    return Some(LinkEvent::SendFailed);
                }
                if s.offset >= s.message.len() {
                    self.sending = None;
                } else if let Some(s) = &mut self.sending {
                    s.count = (s.count + 1) & 0x3F;
                    self.next_fragment(now, tx);
                }
                None
            }
            ExplicitFrame::Fragment {
                header,
                fragment,
                data,
            } => {
                let result = self.rx.push(fragment, data);
                let status = match result {
                    Err(FragmentError::TooMuchData) => AckStatus::TooMuchData,
                    Err(_) => {
                        // Out of sequence: no acknowledgement, the sender times out.
                        return result.err().map(LinkEvent::BadFragment);
                    }
                    Ok(_) => AckStatus::Success,
                };
                let done = match &result {
                    Ok(Some(m)) => MessageBuf::from_slice(m).ok(),
                    _ => None,
                };
                let err = result.err();
                self.push(
                    tx,
                    ExplicitFrame::Ack {
                        header: self.header(true, header.xid),
                        count: fragment.count,
                        status,
                    },
                );
                match (done, err) {
                    (Some(m), _) => Some(LinkEvent::Message(m, header.xid)),
                    (None, Some(e)) => Some(LinkEvent::BadFragment(e)),
                    _ => None,
                }
            }
        }
    }

    pub(crate) fn poll_timeout(&self) -> Option<Instant> {
        self.sending.as_ref().map(|s| s.deadline)
    }

    pub(crate) fn handle_timeout(&mut self, now: Instant) -> Option<LinkEvent> {
        match &self.sending {
            Some(s) if now >= s.deadline => {
                self.sending = None;
                Some(LinkEvent::SendFailed)
            }
            _ => None,
        }
    }
}

const _: () = assert!(MAX_MESSAGE >= 64);
