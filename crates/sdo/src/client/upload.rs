//! The client's upload (read) steps: the answers to initiate upload (expedited, segmented or
//! block), upload segments, and the sub-blocks and end of a block upload.

use super::{Active, Client, Flow, Kind, Step, UpPhase, protocol};
use crate::buffer::{Sink, Source};
use crate::error::{ErrorKind, Violation};
use crate::subblock::{Receiver, SequenceError};
use crate::wire::{BlockSegment, ClientRequest, Initiate, ServerResponse};
use canola_frame::Instant;

impl<S: Sink, D: Source> Client<S, D> {
    pub(super) fn on_upload(
        &mut self,
        active: &mut Active<S, D>,
        msg: ServerResponse,
    ) -> Result<Flow, ErrorKind> {
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
                ServerResponse::InitiateUpload { data, .. },
            ) => match data {
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
            },
            (UpPhase::BlockInitiate, ServerResponse::BlockUploadInitiate { crc, size, .. }) => {
                if let Some(size) = size {
                    sink.expect_size(size).map_err(|_| ErrorKind::BufferFull)?;
                }
                *total = size;
                *phase = UpPhase::SubBlock {
                    crc: crc && self.config.crc,
                    receiver: Receiver::new(),
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
                let bytes = &held.data[..usize::from(7 - unused.min(7))];
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
            phase: UpPhase::SubBlock { crc, receiver },
            total,
            ..
        } = &mut active.kind
        else {
            return Step::Continue(active);
        };
        let verdict = match receiver.on_segment(&seg, blksize) {
            Ok(verdict) => verdict,
            Err(SequenceError::Invalid(seqno) | SequenceError::Fruitless(seqno)) => {
                return Step::Finish(active, Err(protocol(Violation::SequenceNumber(seqno))));
            }
        };
        let crc = *crc;
        if verdict.take && !seg.last {
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
        if let Some(ackseq) = verdict.ack {
            self.tx
                .push(ClientRequest::BlockUploadAck { ackseq, blksize }.emit());
            if verdict.take && seg.last {
                active.hold_last_segment(crc, seg);
            }
            active.rearm(now, self.config.timeout);
        }
        Step::Continue(active)
    }
}

impl<S, D> Active<S, D> {
    /// The last segment of the transfer is held: wait for the end message.
    fn hold_last_segment(&mut self, crc: bool, held: BlockSegment) {
        if let Kind::Up { phase, .. } = &mut self.kind {
            *phase = UpPhase::BlockEnd { crc, held };
        }
    }
}
