//! The client's upload (read) steps: the answers to initiate upload (expedited, segmented or
//! block), upload segments, and the sub-blocks and end of a block upload.

use super::{Active, Client, Flow, Kind, Step, UpPhase, protocol};
use crate::buffer::{Sink, Source};
use crate::error::{ErrorKind, Violation};
use crate::wire::{BlockSegment, ClientRequest, Initiate, ServerResponse};
use canola_frame::Instant;

impl<S: Sink, D: Source> Client<S, D> {
    pub(super) fn on_upload(
        &mut self,
        active: &mut Active<S, D>,
        msg: ServerResponse,
    ) -> Result<Flow, ErrorKind> {
        let mux = active.mux;
        let Kind::Up {
            sink,
            phase,
            total,
            unsized_expedited,
        } = &mut active.kind
        else {
            return Err(protocol(Violation::UnexpectedCommand));
        };
        match (&*phase, msg) {
            (
                UpPhase::Initiate | UpPhase::BlockInitiate,
                ServerResponse::InitiateUpload { mux: m, data },
            ) => {
                if m != mux {
                    return Ok(Flow::Ignore);
                }
                match data {
                    Initiate::Expedited { size, .. } => {
                        *unsized_expedited = size.is_none();
                        let bytes = data.expedited_data();
                        let n = bytes.len() as u32;
                        *total = Some(n);
                        sink.expect_size(n).map_err(|_| ErrorKind::BufferFull)?;
                        sink.write(bytes).map_err(|_| ErrorKind::BufferFull)?;
                        active.done = n;
                        Ok(Flow::Done)
                    }
                    Initiate::Segmented { size } => {
                        if let Some(size) = size {
                            sink.expect_size(size).map_err(|_| ErrorKind::BufferFull)?;
                        }
                        *total = size;
                        *phase = UpPhase::Segment { toggle: false };
                        self.tx
                            .push(ClientRequest::UploadSegment { toggle: false }.emit());
                        Ok(Flow::Continue)
                    }
                }
            }
            (UpPhase::BlockInitiate, ServerResponse::BlockUploadInitiate { mux: m, crc, size }) => {
                if m != mux {
                    return Ok(Flow::Ignore);
                }
                if let Some(size) = size {
                    sink.expect_size(size).map_err(|_| ErrorKind::BufferFull)?;
                }
                *total = size;
                *phase = UpPhase::SubBlock {
                    crc: crc && self.config.crc,
                    expected: 1,
                    held: None,
                    fruitless: 0,
                };
                self.tx.push(ClientRequest::BlockUploadStart.emit());
                Ok(Flow::Continue)
            }
            (&UpPhase::Segment { toggle }, ServerResponse::UploadSegment(seg)) => {
                if seg.toggle != toggle {
                    return Err(protocol(Violation::Toggle));
                }
                let bytes = seg.bytes();
                let done = active.done.saturating_add(bytes.len() as u32);
                if let Some(size) = *total
                    && done > size
                {
                    return Err(protocol(Violation::TooLong { size }));
                }
                sink.write(bytes).map_err(|_| ErrorKind::BufferFull)?;
                active.done = done;
                if seg.last {
                    if let Some(size) = *total
                        && done != size
                    {
                        return Err(protocol(Violation::TooShort {
                            size,
                            received: done,
                        }));
                    }
                    return Ok(Flow::Done);
                }
                *phase = UpPhase::Segment { toggle: !toggle };
                self.tx
                    .push(ClientRequest::UploadSegment { toggle: !toggle }.emit());
                Ok(Flow::Continue)
            }
            (
                &UpPhase::BlockEnd { crc, held },
                ServerResponse::BlockUploadEnd {
                    unused,
                    crc: received,
                },
            ) => {
                let bytes = &held[..usize::from(7 - unused.min(7))];
                let done = active.done.saturating_add(bytes.len() as u32);
                if let Some(size) = *total {
                    if done > size {
                        return Err(protocol(Violation::TooLong { size }));
                    }
                    if done < size {
                        return Err(protocol(Violation::TooShort {
                            size,
                            received: done,
                        }));
                    }
                }
                sink.write(bytes).map_err(|_| ErrorKind::BufferFull)?;
                active.crc.update(bytes);
                active.done = done;
                if crc && active.crc.get() != received {
                    return Err(protocol(Violation::Crc {
                        computed: active.crc.get(),
                        received,
                    }));
                }
                self.tx.push(ClientRequest::BlockUploadEnd.emit());
                Ok(Flow::Done)
            }
            _ => Err(protocol(Violation::UnexpectedCommand)),
        }
    }

    pub(super) fn on_block_segment(
        &mut self,
        now: Instant,
        mut active: Active<S, D>,
        seg: BlockSegment,
    ) -> Step<S, D> {
        let blksize = self.config.block_size;
        let Kind::Up {
            sink,
            phase:
                UpPhase::SubBlock {
                    crc,
                    expected,
                    held,
                    fruitless,
                },
            total,
            ..
        } = &mut active.kind
        else {
            return Step::Continue(active);
        };
        if seg.seqno == 0 || seg.seqno > blksize {
            return Step::Finish(active, Err(protocol(Violation::SequenceNumber(seg.seqno))));
        }
        if seg.seqno == *expected {
            if seg.last {
                *held = Some(seg.data);
            } else {
                let done = active.done.saturating_add(7);
                if let Some(size) = *total
                    && done > size
                {
                    return Step::Finish(active, Err(protocol(Violation::TooLong { size })));
                }
                if sink.write(&seg.data).is_err() {
                    return Step::Finish(active, Err(ErrorKind::BufferFull));
                }
                active.crc.update(&seg.data);
                active.done = done;
            }
            *expected += 1;
        }
        if seg.last || seg.seqno == blksize {
            if *expected == 1 {
                // Nothing of this sub-block arrived in sequence. A lost segment costs one such
                // round; an endless run of them is a peer in another transfer (stale frames of
                // an earlier one, a server that rebooted into a block download of its own), whose
                // "segments" would each rearm the timeout: give up instead.
                *fruitless += 1;
                if *fruitless > crate::MAX_FRUITLESS_SUB_BLOCKS {
                    return Step::Finish(
                        active,
                        Err(protocol(Violation::SequenceNumber(seg.seqno))),
                    );
                }
            } else {
                *fruitless = 0;
            }
            self.tx.push(
                ClientRequest::BlockUploadAck {
                    ackseq: *expected - 1,
                    blksize,
                }
                .emit(),
            );
            let crc = *crc;
            match held.take() {
                Some(held) => {
                    if let Kind::Up { phase, .. } = &mut active.kind {
                        *phase = UpPhase::BlockEnd { crc, held };
                    }
                }
                None => *expected = 1,
            }
            active.rearm(now, self.config.timeout);
        }
        Step::Continue(active)
    }
}
