//! The subscribers of the master's events: mpsc channels (the blocking API) and sinks (the
//! async API's event streams), with the hold-back of events while a batch of frames is handled.

use std::sync::mpsc;

use super::events::{EventSink, NetworkEvent};

/// The event subscribers: channels and sinks.
#[derive(Default)]
pub(super) struct Subscribers {
    pub(super) channels: Vec<mpsc::Sender<NetworkEvent>>,
    pub(super) sinks: Vec<Box<dyn EventSink>>,
    /// Events for the channels held back while a batch of received frames is handled (see
    /// [`Core::hold_events`]); the buffer is kept between batches.
    pub(super) held: Vec<NetworkEvent>,
    pub(super) holding: bool,
}

impl Subscribers {
    pub(super) fn is_empty(&self) -> bool {
        self.channels.is_empty() && self.sinks.is_empty()
    }

    /// Hands `ev` to every subscriber (or holds it for the channels) and forgets the sinks
    /// that are gone.
    pub(super) fn deliver(&mut self, ev: NetworkEvent) {
        self.sinks.retain(|s| s.deliver(&ev));
        if self.holding && !self.channels.is_empty() {
            self.held.push(ev);
        } else {
            Self::send_to(&mut self.channels, ev);
        }
    }

    /// Sends `ev` to every channel (the last one gets it without a copy) and forgets those
    /// that are gone.
    pub(super) fn send_to(channels: &mut Vec<mpsc::Sender<NetworkEvent>>, ev: NetworkEvent) {
        let n = channels.len();
        let mut ev = Some(ev);
        let mut seen = 0;
        channels.retain(|s| {
            seen += 1;
            let e = if seen == n { ev.take() } else { ev.clone() };
            e.is_none_or(|e| s.send(e).is_ok())
        });
    }
}
