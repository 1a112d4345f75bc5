//! The master machine running SDO requests: submitting, queueing per channel, starting the
//! next transfer when a channel is idle (after the settle time), handing responses to the
//! client, cancelling (with an abort on the bus) and taking results by request id.

use std::io::Write;

use canola_frame::{CanFrame, Instant, NodeId};
use canola_sdo::{Event as SdoEvent, Multiplexer, SdoCobIds};

use super::Core;
use super::events::{CANCEL_ABORT, Completion, RequestId, TransferProgress};
use super::sdo::{Op, Outgoing, ReqState, Request, SdoChannel, SdoRequest, Taken, UpSink};
use crate::error::{SdoError, SdoErrorKind};

impl Core {
    /// The index of `node`'s channel on `ids`, opened (and routed) on first use.
    pub(super) fn channel_index(&mut self, node: NodeId, ids: SdoCobIds) -> usize {
        if !self.nodes.contains_key(&node) {
            self.add_node(node, None);
        }
        let Some(slot) = self.nodes.get_mut(&node) else {
            return 0;
        };
        if let Some(i) = slot.channels.iter().position(|c| c.ids == ids) {
            return i;
        }
        slot.channels.push(SdoChannel::new(ids));
        let i = slot.channels.len() - 1;
        self.sdo_routes.insert(ids.response, (node, i));
        i
    }

    /// Takes back the frames of an SDO transfer that failed and are still waiting for the
    /// transport. If none of its frames left, the server never heard of the transfer and its
    /// abort goes too; otherwise the abort (command byte 0x80, no other client frame starts
    /// so) stays, so the server ends its side, and only the data frames behind it go. Without
    /// this, a client that times out while its frames wait for a busy bus queues an abort and
    /// the next transfer behind them, the queue grows for as long as the bus is overloaded,
    /// and the server gets the stale requests long after the client gave up.
    ///
    /// With `server_forgot` (the server rebooted) every waiting frame goes, the abort too.
    pub(super) fn withdraw(
        &mut self,
        tag: (NodeId, usize, u64),
        queued: usize,
        server_forgot: bool,
    ) {
        let waiting = self.tx.iter().filter(|o| o.transfer == Some(tag)).count();
        if waiting == 0 {
            return;
        }
        let keep_abort = waiting < queued && !server_forgot;
        self.tx.retain(|o| {
            o.transfer != Some(tag) || (keep_abort && o.frame.data().first() == Some(&0x80))
        });
    }

    /// A boot-up message from `node`: its SDO servers start idle. A transfer the server has
    /// answered can no longer complete: it ends with [`SdoErrorKind::NodeRebooted`] at once
    /// (rather than with the response timeout, or with the abort the rebooted server answers
    /// the next segment with). A transfer not answered yet may have been sent to the server
    /// after its reboot (a boot-up can lose arbitration to the device's first SDO response,
    /// or wait behind it), so it goes on; if it then times out, the error is `NodeRebooted`.
    /// Either way without an abort: the server has no transfer to abort, and the abort
    /// service is unconfirmed (CiA 301), so one reaching an idle server changes nothing and
    /// would only cost bus time. The transfer's frames still waiting for the transport are
    /// withdrawn; queued requests start on the rebooted server as usual.
    pub(super) fn end_transfers_on_boot(&mut self, node: NodeId) {
        let now = self.now;
        let Some(slot) = self.nodes.get_mut(&node) else {
            return;
        };
        let mut running = Vec::new();
        for (i, c) in slot.channels.iter_mut().enumerate() {
            if c.active.is_none() {
                continue;
            }
            if c.answered {
                // The client's abort path ends the transfer; its abort frame is withdrawn
                // with the rest (see `pump_channel`).
                c.rebooted = c.client.abort(now, CANCEL_ABORT);
                running.push(i);
            } else {
                c.boot_seen = true;
            }
        }
        for ch in running {
            self.pump_channel(node, ch);
        }
    }

    /// Queues a request: an SDO one starts when the node's earlier requests on its channel
    /// are done, a USDO one when a session of the USDO client is free.
    pub(crate) fn submit(&mut self, req: Request) -> RequestId {
        let id = RequestId(self.next_request);
        self.next_request += 1;
        let req = match req {
            Request::Sdo(req) => req,
            Request::Usdo(req) => {
                self.submit_usdo(id, req);
                return id;
            }
        };
        let node = req.node;
        let ch = self.channel_index(node, req.channel);
        let now = self.now;
        let Some(c) = self
            .nodes
            .get_mut(&node)
            .and_then(|s| s.channels.get_mut(ch))
        else {
            self.requests.push(id, ReqState::Queued(req));
            return id;
        };
        if !self.sdo_busy.contains(&(node, ch)) {
            self.sdo_busy.push((node, ch));
        }
        // A free channel starts the request at once, as `pump_channel` would from the queue.
        let state = if c.queue.is_empty()
            && c.active.is_none()
            && c.client.is_idle()
            && c.ready_at <= now
        {
            Self::start(c, now, id, req, ch)
        } else {
            c.queue.push_back(id);
            ReqState::Queued(req)
        };
        self.requests.push(id, state);
        self.pump_channel(node, ch);
        id
    }

    /// Whether the request ended (and its result waits to be taken).
    pub(crate) fn is_done(&self, id: RequestId) -> bool {
        matches!(self.requests.get(&id), Some(ReqState::Done(_)) | None)
    }

    /// Takes a finished request's result. `None` while it runs.
    pub(crate) fn take_result(&mut self, id: RequestId) -> Taken {
        self.requests.take_result(id)
    }

    /// Cancels a request: a queued one is dropped, a running one is aborted on the bus (the
    /// channel is free for the next request at once). Its result is discarded.
    pub(crate) fn cancel(&mut self, id: RequestId) {
        let Some(state) = self.requests.remove(&id) else {
            return;
        };
        match state {
            ReqState::QueuedUsdo(_) => self.unqueue_usdo(id),
            ReqState::Queued(req) => {
                if let Some(slot) = self.nodes.get_mut(&req.node) {
                    for c in &mut slot.channels {
                        c.queue.retain(|q| *q != id);
                    }
                }
            }
            ReqState::UsdoActive { node, session, .. } => self.cancel_usdo(node, session),
            ReqState::Active { node, channel, .. } => {
                let now = self.now;
                if let Some(c) = self
                    .nodes
                    .get_mut(&node)
                    .and_then(|s| s.channels.get_mut(channel))
                {
                    c.client.abort(now, CANCEL_ABORT);
                }
                self.pump_channel(node, channel);
            }
            ReqState::Done(_) => {}
        }
    }

    /// Sends what the channel's client has, completes its finished transfer, starts the next.
    pub(super) fn pump_channel(&mut self, node: NodeId, ch: usize) {
        // Each turn either finishes a transfer or starts one, so the loop ends when the queue
        // is empty or a transfer runs.
        loop {
            let Some(c) = self
                .nodes
                .get_mut(&node)
                .and_then(|s| s.channels.get_mut(ch))
            else {
                return;
            };
            while let Some(data) = c.client.poll_transmit() {
                c.queued += 1;
                self.tx.push_back(Outgoing {
                    frame: c.ids.request_frame(data).into(),
                    transfer: Some((node, ch, c.transfer)),
                });
            }
            if c.reports_progress
                && let (Some(active), Some(p)) = (c.active, c.client.progress())
                && let Some(ReqState::Active {
                    progress: Some(cb),
                    entry,
                    ..
                }) = self.requests.get_mut(&active)
            {
                cb(TransferProgress {
                    node,
                    entry: *entry,
                    done: u64::from(p.done),
                    total: p.total.map(u64::from),
                });
            }
            if let Some(ev) = c.client.poll_event() {
                let finished = c.active.take();
                let failed =
                    matches!(ev, SdoEvent::Failed { .. }).then_some((c.transfer, c.queued));
                let boot_seen = core::mem::take(&mut c.boot_seen);
                let timed_out = matches!(
                    &ev,
                    SdoEvent::Failed { error, .. } if error.kind == canola_sdo::ErrorKind::Timeout
                );
                let rebooted = core::mem::take(&mut c.rebooted) || (boot_seen && timed_out);
                let result = match ev {
                    SdoEvent::Uploaded {
                        sink,
                        unsized_expedited,
                        ..
                    } => match sink {
                        UpSink::Mem(data) => Ok(Completion {
                            transferred: data.len() as u64,
                            data,
                            unsized_expedited,
                        }),
                        // A buffered writer may hold the tail still: flush it, and a failing
                        // flush fails the upload (the bytes did not all arrive).
                        UpSink::Stream { mut w, written, .. } => match w.flush() {
                            Ok(()) => Ok(Completion {
                                data: Vec::new(),
                                transferred: written,
                                unsized_expedited,
                            }),
                            Err(e) => Err(SdoErrorKind::Io {
                                kind: e.kind(),
                                message: format!("flushing the output: {e}"),
                            }),
                        },
                    },
                    SdoEvent::Downloaded { source, .. } => Ok(Completion {
                        data: Vec::new(),
                        transferred: source.0.len() as u64,
                        unsized_expedited: false,
                    }),
                    SdoEvent::Failed { .. } if rebooted => Err(SdoErrorKind::NodeRebooted),
                    SdoEvent::Failed { error, buffer } => Err(match buffer {
                        canola_sdo::Buffer::Sink(UpSink::Stream { error: Some(e), .. }) => {
                            SdoErrorKind::Io {
                                kind: e.kind(),
                                message: e.to_string(),
                            }
                        }
                        _ => SdoErrorKind::Transfer(error.kind),
                    }),
                };
                c.ready_at = self.now + self.settle;
                if let Some((transfer, queued)) = failed {
                    self.withdraw((node, ch, transfer), queued, rebooted);
                }
                // A cancelled request is no longer in the table: its result is dropped here.
                if let Some(id) = finished
                    && let Some(state) = self.requests.get_mut(&id)
                    && let ReqState::Active { entry, .. } = state
                {
                    let entry = *entry;
                    let result = result.map_err(|kind| {
                        Box::new(SdoError {
                            node,
                            entry,
                            name: None,
                            kind,
                        })
                    });
                    *state = ReqState::Done(result);
                }
                continue;
            }
            if c.active.is_some() || !c.client.is_idle() || c.ready_at > self.now {
                return;
            }
            let Some(next) = c.queue.pop_front() else {
                return;
            };
            // Changed in place: a request is looked up once while it starts.
            let Some(slot) = self.requests.get_mut(&next) else {
                continue;
            };
            let req = match core::mem::replace(slot, ReqState::Done(Ok(Completion::default()))) {
                ReqState::Queued(req) => req,
                other => {
                    *slot = other;
                    continue;
                }
            };
            *slot = Self::start(c, self.now, next, req, ch);
        }
    }

    /// Starts request `id` on channel `ch` (free and ready); its new state.
    pub(super) fn start(
        c: &mut SdoChannel,
        now: Instant,
        id: RequestId,
        req: SdoRequest,
        ch: usize,
    ) -> ReqState {
        let SdoRequest {
            node,
            entry,
            op,
            method,
            timeout,
            progress,
            ..
        } = req;
        c.transfer += 1;
        c.queued = 0;
        c.answered = false;
        c.reports_progress = progress.is_some();
        c.boot_seen = false;
        let cfg = c.client.config().with_timeout(timeout);
        c.client.set_config(cfg);
        let mux = Multiplexer::new(entry.index, entry.sub_index);
        let started = match op {
            Op::Upload(sink) => c.client.start_upload(now, mux, sink, method).is_ok(),
            Op::Download(src) => c.client.start_download(now, mux, src, method).is_ok(),
        };
        if started {
            c.active = Some(id);
            ReqState::Active {
                progress,
                entry,
                node,
                channel: ch,
            }
        } else {
            ReqState::Done(Err(Box::new(SdoError {
                node,
                entry,
                name: None,
                kind: SdoErrorKind::Busy,
            })))
        }
    }

    /// A response on an SDO channel's server → client identifier.
    pub(super) fn handle_sdo_response(
        &mut self,
        now: Instant,
        node: NodeId,
        ch: usize,
        frame: &CanFrame,
    ) {
        if let Some(c) = self
            .nodes
            .get_mut(&node)
            .and_then(|s| s.channels.get_mut(ch))
        {
            c.answered |= c.active.is_some();
            c.client.handle_response(now, frame.data());
            self.pump_channel(node, ch);
        }
    }

    /// Fills in the object name of an error from the node's dictionary.
    pub(crate) fn name_error(&self, mut e: SdoError) -> SdoError {
        if e.name.is_none() {
            e.name = self.object_name(e.node, e.entry);
        }
        e
    }
}
