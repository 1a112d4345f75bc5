//! The client's download (write) steps: the answers to initiate download, download segments,
//! and the acknowledgements and end of a block download. The sub-block segments themselves go
//! out from [`Client::poll_transmit`].

use super::{Active, Client, DownPhase, Flow, Kind, protocol};
use crate::buffer::{Sink, Source};
use crate::error::{ErrorKind, Violation};
use crate::wire::{
    ClientRequest, MAX_BLOCK_SIZE, Segment, ServerResponse, segments_for, unused_in_last,
};

impl<S: Sink, D: Source> Client<S, D> {
    pub(super) fn on_download(
        &mut self,
        active: &mut Active<S, D>,
        msg: ServerResponse,
    ) -> Result<Flow, ErrorKind> {
        let Kind::Down {
            source, phase, len, ..
        } = &mut active.kind
        else {
            return Err(protocol(Violation::UnexpectedCommand));
        };
        let len = *len;
        match (&*phase, msg) {
            (&DownPhase::Initiate { expedited }, ServerResponse::InitiateDownload { .. }) => {
                if expedited {
                    active.done = len;
                    return Ok(Flow::Done);
                }
                *phase = self.send_segment(source, 0, len, false);
                Ok(Flow::Continue)
            }
            (
                &DownPhase::Segment { toggle, end, last },
                ServerResponse::DownloadSegment { toggle: t },
            ) => {
                if t != toggle {
                    return Err(protocol(Violation::Toggle));
                }
                active.done = end;
                if last {
                    return Ok(Flow::Done);
                }
                *phase = self.send_segment(source, end, len, !toggle);
                Ok(Flow::Continue)
            }
            (
                DownPhase::BlockInitiate,
                ServerResponse::BlockDownloadInitiate { crc, blksize, .. },
            ) => {
                if blksize == 0 || blksize > MAX_BLOCK_SIZE {
                    return Err(protocol(Violation::BlockSize(blksize)));
                }
                let total = segments_for(len);
                *phase = DownPhase::SubBlock {
                    crc: crc && self.config.crc,
                    count: total.min(u32::from(blksize)) as u8,
                    sent: 0,
                    acked: 0,
                    total,
                };
                Ok(Flow::Continue)
            }
            (
                &DownPhase::SubBlock {
                    crc,
                    sent,
                    acked,
                    total,
                    ..
                },
                ServerResponse::BlockDownloadAck { ackseq, blksize },
            ) => {
                if ackseq > sent {
                    return Err(protocol(Violation::SequenceNumber(ackseq)));
                }
                if blksize == 0 || blksize > MAX_BLOCK_SIZE {
                    return Err(protocol(Violation::BlockSize(blksize)));
                }
                let acked = acked + u32::from(ackseq);
                active.done = acked.saturating_mul(7).min(len);
                if acked >= total {
                    let crc = if crc { active.crc.get() } else { 0 };
                    self.tx.push(
                        ClientRequest::BlockDownloadEnd {
                            unused: unused_in_last(len),
                            crc,
                        }
                        .emit(),
                    );
                    *phase = DownPhase::BlockEnd;
                } else {
                    *phase = DownPhase::SubBlock {
                        crc,
                        count: (total - acked).min(u32::from(blksize)) as u8,
                        sent: 0,
                        acked,
                        total,
                    };
                }
                Ok(Flow::Continue)
            }
            (DownPhase::BlockEnd, ServerResponse::BlockDownloadEnd) => {
                active.done = len;
                Ok(Flow::Done)
            }
            _ => Err(protocol(Violation::UnexpectedCommand)),
        }
    }

    /// Queues the download segment starting at `offset` and returns the phase waiting for it.
    fn send_segment(&mut self, source: &mut D, offset: u32, len: u32, toggle: bool) -> DownPhase {
        let mut data = [0u8; 7];
        let want = len.saturating_sub(offset).min(7) as usize;
        let n = source.read(offset, &mut data[..want]);
        let end = offset.saturating_add(n as u32);
        // A source that returns less than it promised ends the transfer here; the server
        // then sees the size mismatch.
        let last = end >= len || n < want;
        self.tx
            .push(ClientRequest::DownloadSegment(Segment::new(toggle, &data[..n], last)).emit());
        DownPhase::Segment { toggle, end, last }
    }
}
