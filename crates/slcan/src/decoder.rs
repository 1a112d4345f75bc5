//! The streaming decoder of adapter output: bytes in arbitrary chunks in, [`Item`]s out.
//!
//! Lines end at CR or at BEL (the error reply carries no CR, and the kernel driver ends a line at
//! either). A BEL is always reported as [`Item::Error`]; if a line was pending when it came, that
//! line is reported first. A line with a byte that is not printable ASCII, or one longer than
//! [`MAX_LINE`], is reported once as a [`LineError`] and the rest of it is skipped up to the next
//! CR or BEL, where decoding starts afresh. Nothing the adapter sends can make it panic.

use crate::error::LineError;
use crate::reply::Item;
use crate::{BEL, CR, MAX_LINE};

/// Turns adapter output into [`Item`]s; see the module docs for the framing rules.
///
/// Call [`decode`](Self::decode) (or iterate [`feed`](Self::feed)) with each chunk read from the
/// serial line, in order.
#[derive(Clone)]
pub struct Decoder {
    buf: [u8; MAX_LINE],
    len: usize,
    /// Skipping a bad line up to its terminator.
    skipping: bool,
    /// A BEL ended a non-empty line: report [`Item::Error`] after that line.
    pending_error: bool,
    items: u64,
    errors: u64,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl core::fmt::Debug for Decoder {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Decoder")
            .field("pending", &self.len)
            .field("skipping", &self.skipping)
            .field("items", &self.items)
            .field("errors", &self.errors)
            .finish()
    }
}

impl Decoder {
    /// A decoder at the start of a line.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_LINE],
            len: 0,
            skipping: false,
            pending_error: false,
            items: 0,
            errors: 0,
        }
    }

    /// Consumes bytes of `input` up to the end of the first complete item or error; returns how
    /// many bytes it consumed and what it found. `(input.len(), None)` means everything was
    /// consumed and the line is not complete yet. Call again with the rest of the input.
    pub fn decode(&mut self, input: &[u8]) -> (usize, Option<Result<Item, LineError>>) {
        if self.pending_error {
            self.pending_error = false;
            self.items += 1;
            return (0, Some(Ok(Item::Error)));
        }
        for (i, &b) in input.iter().enumerate() {
            let used = i + 1;
            if b == CR || b == BEL {
                let had_line = self.len > 0;
                let result = if core::mem::take(&mut self.skipping) {
                    None
                } else if b == BEL && !had_line {
                    Some(Ok(Item::Error))
                } else {
                    Some(Item::parse(&self.buf[..self.len]))
                };
                self.len = 0;
                match result {
                    Some(r) => {
                        if b == BEL && had_line {
                            self.pending_error = true;
                        }
                        self.count(&r);
                        return (used, Some(r));
                    }
                    // The end of a skipped line: a BEL still is an error reply.
                    None if b == BEL => {
                        self.items += 1;
                        return (used, Some(Ok(Item::Error)));
                    }
                    None => continue,
                }
            }
            if self.skipping {
                continue;
            }
            let error = if !(0x20..0x7F).contains(&b) {
                LineError::BadByte(b)
            } else if self.len == MAX_LINE {
                LineError::TooLong
            } else {
                self.buf[self.len] = b;
                self.len += 1;
                continue;
            };
            self.len = 0;
            self.skipping = true;
            self.errors += 1;
            return (used, Some(Err(error)));
        }
        (input.len(), None)
    }

    /// Iterates over the items and errors in `input` (the rest of an incomplete line stays in
    /// the decoder for the next chunk).
    pub fn feed<'d, 'a>(&'d mut self, input: &'a [u8]) -> Items<'d, 'a> {
        Items {
            decoder: self,
            input,
        }
    }

    /// Items decoded so far (acknowledgements, frames, replies).
    pub const fn items(&self) -> u64 {
        self.items
    }

    /// Bad lines so far: bytes that are not printable ASCII, overlong lines, lines that do not
    /// parse.
    pub const fn errors(&self) -> u64 {
        self.errors
    }

    /// Forgets a partial line (after reopening the port, for example); the counters stay.
    pub fn reset(&mut self) {
        self.len = 0;
        self.skipping = false;
        self.pending_error = false;
    }

    fn count(&mut self, r: &Result<Item, LineError>) {
        match r {
            Ok(_) => self.items += 1,
            Err(_) => self.errors += 1,
        }
    }
}

/// The items of one chunk, from [`Decoder::feed`].
#[derive(Debug)]
pub struct Items<'d, 'a> {
    decoder: &'d mut Decoder,
    input: &'a [u8],
}

impl Iterator for Items<'_, '_> {
    type Item = Result<Item, LineError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (used, item) = self.decoder.decode(self.input);
        self.input = &self.input[used..];
        item
    }
}
