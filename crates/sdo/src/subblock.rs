//! The receiving side of a block transfer's sub-blocks (CiA 301 §7.2.4.3.9–16): which segments
//! to take, and when to acknowledge which one. The client runs it in a block upload, the
//! server in a block download.
//!
//! The sender sends up to `blksize` segments numbered 1.. without waiting; the receiver
//! answers once, after the segment numbered `blksize` or the one marked last (c = 1), with
//! `ackseq`, the last segment received in sequence, and the sender starts the next sub-block
//! with the segment after that one. On a bus, a segment may be lost, repeated (a CAN
//! transmitter repeats a frame the receivers took when the last bit of its end of frame was
//! disturbed) or, behind some interfaces, overtaken by the one after it. So:
//!
//! - the segment after the last one taken is taken while no gap has been seen;
//! - a repeat of the segment taken last is dropped and changes nothing;
//! - any other segment is a gap: it and the rest of the sub-block are dropped (even the
//!   missing segment, should it arrive late), and the acknowledgement asks for all of them
//!   again;
//! - a repeat of the segment that ended the previous sub-block (the same eight bytes), before
//!   anything of the next one arrived, is dropped without a second acknowledgement (which the
//!   sender would take as the answer to the sub-block it is sending).
//!
//! So a segment is only ever stored in its place, whatever the bus does. One case cannot be
//! told apart: with `blksize` 1 every segment is numbered 1, and a repeat is the next segment.

use crate::wire::BlockSegment;

/// What to do with one received segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Verdict {
    /// The segment is the next in sequence: store its data (or hold it, when it is the last
    /// of the transfer, until the end message tells its length).
    pub(crate) take: bool,
    /// The sub-block ended: acknowledge with this `ackseq`.
    pub(crate) ack: Option<u8>,
}

/// Why a segment ends the transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SequenceError {
    /// A sequence number outside 1..=blksize.
    Invalid(u8),
    /// Too many sub-blocks in a row without one segment in sequence (see
    /// [`MAX_FRUITLESS_SUB_BLOCKS`](crate::MAX_FRUITLESS_SUB_BLOCKS)).
    Fruitless(u8),
}

/// The sequence state of the sub-block being received.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Receiver {
    /// Sequence number of the next segment in sequence.
    expected: u8,
    /// A segment out of sequence arrived: the rest of this sub-block is dropped.
    gap: bool,
    /// The segment that ended the previous sub-block.
    ended: Option<BlockSegment>,
    /// Sub-blocks in a row that ended without one segment taken.
    fruitless: u8,
}

impl Receiver {
    /// Waiting for the first segment of the first sub-block.
    pub(crate) const fn new() -> Self {
        Self {
            expected: 1,
            gap: false,
            ended: None,
            fruitless: 0,
        }
    }

    /// Judges one segment of a sub-block of at most `blksize` segments.
    pub(crate) fn on_segment(
        &mut self,
        seg: &BlockSegment,
        blksize: u8,
    ) -> Result<Verdict, SequenceError> {
        let seqno = seg.seqno;
        if seqno == 0 || seqno > blksize {
            return Err(SequenceError::Invalid(seqno));
        }
        let fresh = self.expected == 1 && !self.gap;
        let repeat = if fresh {
            self.ended == Some(*seg) && seqno != 1
        } else {
            seqno + 1 == self.expected
        };
        if repeat {
            return Ok(Verdict {
                take: false,
                ack: None,
            });
        }
        let take = !self.gap && seqno == self.expected;
        if take {
            self.expected += 1;
        } else {
            self.gap = true;
        }
        if !(seg.last || seqno == blksize) {
            return Ok(Verdict { take, ack: None });
        }
        let ackseq = self.expected - 1;
        if ackseq == 0 {
            // A lost segment costs one such round; an endless run of them is a peer in
            // another transfer, whose "segments" would each rearm the timeout.
            self.fruitless += 1;
            if self.fruitless > crate::MAX_FRUITLESS_SUB_BLOCKS {
                return Err(SequenceError::Fruitless(seqno));
            }
        } else {
            self.fruitless = 0;
        }
        self.expected = 1;
        self.gap = false;
        self.ended = Some(*seg);
        Ok(Verdict {
            take,
            ack: Some(ackseq),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(seqno: u8, last: bool) -> BlockSegment {
        BlockSegment {
            seqno,
            last,
            data: [seqno; 7],
        }
    }

    fn feed(r: &mut Receiver, seqnos: &[(u8, bool)], blksize: u8) -> Vec<(bool, Option<u8>)> {
        seqnos
            .iter()
            .map(|&(s, last)| {
                let v = r.on_segment(&seg(s, last), blksize).unwrap();
                (v.take, v.ack)
            })
            .collect()
    }

    extern crate std;
    use std::vec::Vec;

    #[test]
    fn in_sequence_gap_repeat_and_reorder() {
        let mut r = Receiver::new();
        // 1 2 2 4 3 5: the repeat of 2 is dropped, 4 is a gap, 3 and 5 come after it.
        let v = feed(
            &mut r,
            &[
                (1, false),
                (2, false),
                (2, false),
                (4, false),
                (3, false),
                (5, false),
            ],
            5,
        );
        assert_eq!(
            v,
            [
                (true, None),
                (true, None),
                (false, None),
                (false, None),
                (false, None),
                (false, Some(2)),
            ]
        );
        // The repeated sub-block, then a repeat of its end: no second acknowledgement.
        let v = feed(&mut r, &[(1, false), (2, false), (3, false), (3, false)], 3);
        assert_eq!(
            v,
            [(true, None), (true, None), (true, Some(3)), (false, None)]
        );
        // The last segment of the transfer.
        let v = feed(&mut r, &[(1, false), (2, true)], 3);
        assert_eq!(v, [(true, None), (true, Some(2))]);
    }

    #[test]
    fn invalid_and_fruitless() {
        let mut r = Receiver::new();
        assert_eq!(
            r.on_segment(&seg(0, false), 4),
            Err(SequenceError::Invalid(0))
        );
        assert_eq!(
            r.on_segment(&seg(5, false), 4),
            Err(SequenceError::Invalid(5))
        );
        // Sub-blocks that end without a segment in sequence (each ending segment differs from
        // the one before, or it would be a repeat).
        for i in 0..=crate::MAX_FRUITLESS_SUB_BLOCKS {
            let s = 2 + i % 2;
            let v = r.on_segment(&seg(s, true), 4);
            // The same bytes again: a repeat, no second acknowledgement.
            if i < crate::MAX_FRUITLESS_SUB_BLOCKS {
                assert_eq!(
                    r.on_segment(&seg(s, true), 4),
                    Ok(Verdict {
                        take: false,
                        ack: None
                    })
                );
            }
            if i < crate::MAX_FRUITLESS_SUB_BLOCKS {
                assert_eq!(
                    v,
                    Ok(Verdict {
                        take: false,
                        ack: Some(0)
                    })
                );
            } else {
                assert_eq!(v, Err(SequenceError::Fruitless(s)));
            }
        }
    }
}
