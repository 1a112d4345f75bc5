//! Hexadecimal fields of slcan lines: emitted in upper case (as the kernel driver and python-can
//! do), accepted in either case (as both of them accept).

use crate::error::{EncodeError, LineError};

const DIGITS: &[u8; 16] = b"0123456789ABCDEF";

/// The value of one hexadecimal digit.
pub(crate) fn digit(c: u8) -> Result<u8, LineError> {
    match c {
        b'0'..=b'9' => Ok(c - b'0'),
        b'A'..=b'F' => Ok(c - b'A' + 10),
        b'a'..=b'f' => Ok(c - b'a' + 10),
        _ => Err(LineError::BadHex(c)),
    }
}

/// Up to eight hexadecimal digits as a number.
pub(crate) fn number(digits: &[u8]) -> Result<u32, LineError> {
    digits
        .iter()
        .try_fold(0u32, |acc, &c| Ok((acc << 4) | u32::from(digit(c)?)))
}

/// Reads `out.len()` bytes from twice as many hexadecimal digits.
pub(crate) fn bytes(digits: &[u8], out: &mut [u8]) -> Result<(), LineError> {
    for (pair, b) in digits.chunks_exact(2).zip(out.iter_mut()) {
        *b = (digit(pair[0])? << 4) | digit(pair[1])?;
    }
    Ok(())
}

/// A cursor that writes a line into a caller's buffer.
pub(crate) struct Writer<'a> {
    out: &'a mut [u8],
    len: usize,
}

impl<'a> Writer<'a> {
    /// Checks up front that `needed` bytes fit, so the pushes below cannot fail.
    pub(crate) fn new(out: &'a mut [u8], needed: usize) -> Result<Self, EncodeError> {
        if out.len() < needed {
            return Err(EncodeError::BufferTooSmall { needed });
        }
        Ok(Self { out, len: 0 })
    }

    pub(crate) fn byte(&mut self, b: u8) {
        self.out[self.len] = b;
        self.len += 1;
    }

    /// The low `digits` nibbles of `value`, most significant first.
    pub(crate) fn hex(&mut self, value: u32, digits: u32) {
        for i in (0..digits).rev() {
            self.byte(DIGITS[((value >> (4 * i)) & 0xF) as usize]);
        }
    }

    pub(crate) fn hex_bytes(&mut self, data: &[u8]) {
        for &b in data {
            self.byte(DIGITS[usize::from(b >> 4)]);
            self.byte(DIGITS[usize::from(b & 0xF)]);
        }
    }

    pub(crate) fn finish(self) -> usize {
        self.len
    }
}
