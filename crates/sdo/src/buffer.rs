//! Caller-owned buffers for the client: uploads write into a [`Sink`], downloads read from a
//! [`Source`]. The client holds the buffer for the length of one transfer and hands it back in
//! its completion [`Event`](crate::client::Event).
//!
//! Implemented for `heapless::Vec<u8, N>`, [`SliceSink`] and byte slices without an allocator;
//! with the `alloc` feature also for `Vec<u8>` and boxed trait objects.

/// Where an upload's data goes. Data arrives in order, in pieces of up to seven bytes.
pub trait Sink {
    /// The server announced the object size before any data. Return `Err(Full)` if the sink
    /// cannot take that many bytes (the client then aborts with 0x05040005, out of memory).
    fn expect_size(&mut self, size: u32) -> Result<(), Full> {
        let _ = size;
        Ok(())
    }

    /// Appends bytes. Return `Err(Full)` if they do not fit.
    fn write(&mut self, data: &[u8]) -> Result<(), Full>;
}

/// Where a download's data comes from. The client reads by offset because block transfers
/// re-send unacknowledged segments; the same offset must always give the same bytes.
pub trait Source {
    /// Total number of bytes to download (announced to the server).
    fn len(&self) -> u32;

    /// Whether there is nothing to download.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Copies the bytes at `offset..offset + out.len()` (clipped at the end) into `out` and
    /// returns how many were copied.
    fn read(&mut self, offset: u32, out: &mut [u8]) -> usize;
}

/// The buffer cannot take more data.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the buffer is full")]
pub struct Full;

debug_as_display!(Full);

fn read_slice(data: &[u8], offset: u32, out: &mut [u8]) -> usize {
    let start = (offset as usize).min(data.len());
    let n = out.len().min(data.len() - start);
    out[..n].copy_from_slice(&data[start..start + n]);
    n
}

fn slice_len(data: &[u8]) -> u32 {
    u32::try_from(data.len()).unwrap_or(u32::MAX)
}

impl Source for &[u8] {
    fn len(&self) -> u32 {
        slice_len(self)
    }
    fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
        read_slice(self, offset, out)
    }
}

impl<const N: usize> Source for heapless::Vec<u8, N> {
    fn len(&self) -> u32 {
        slice_len(self)
    }
    fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
        read_slice(self, offset, out)
    }
}

impl<const N: usize> Sink for heapless::Vec<u8, N> {
    fn expect_size(&mut self, size: u32) -> Result<(), Full> {
        if (size as usize).saturating_add(self.as_slice().len()) > N {
            Err(Full)
        } else {
            Ok(())
        }
    }
    fn write(&mut self, data: &[u8]) -> Result<(), Full> {
        self.extend_from_slice(data).map_err(|_| Full)
    }
}

/// A [`Sink`] over a caller's slice: fills it from the start.
#[derive(Debug)]
pub struct SliceSink<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> SliceSink<'a> {
    /// An empty sink writing into `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, len: 0 }
    }

    /// The bytes written so far.
    pub fn filled(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Number of bytes written.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing was written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Gives back the slice and the number of bytes written.
    pub fn into_inner(self) -> (&'a mut [u8], usize) {
        (self.buf, self.len)
    }
}

impl Sink for SliceSink<'_> {
    fn expect_size(&mut self, size: u32) -> Result<(), Full> {
        if (size as usize).saturating_add(self.len) > self.buf.len() {
            Err(Full)
        } else {
            Ok(())
        }
    }
    fn write(&mut self, data: &[u8]) -> Result<(), Full> {
        let end = self.len.checked_add(data.len()).ok_or(Full)?;
        let dst = self.buf.get_mut(self.len..end).ok_or(Full)?;
        dst.copy_from_slice(data);
        self.len = end;
        Ok(())
    }
}

impl<T: Sink + ?Sized> Sink for &mut T {
    fn expect_size(&mut self, size: u32) -> Result<(), Full> {
        (**self).expect_size(size)
    }
    fn write(&mut self, data: &[u8]) -> Result<(), Full> {
        (**self).write(data)
    }
}

#[cfg(feature = "alloc")]
mod with_alloc {
    use super::{Full, Sink, Source, read_slice, slice_len};
    use alloc::boxed::Box;
    use alloc::vec::Vec;

    /// Growth reserved up front for an announced size, so a bogus size cannot make the sink
    /// allocate gigabytes before any data arrived.
    const MAX_RESERVE: u32 = 64 * 1024;

    impl Sink for Vec<u8> {
        fn expect_size(&mut self, size: u32) -> Result<(), Full> {
            self.reserve(size.min(MAX_RESERVE) as usize);
            Ok(())
        }
        fn write(&mut self, data: &[u8]) -> Result<(), Full> {
            self.extend_from_slice(data);
            Ok(())
        }
    }

    impl Source for Vec<u8> {
        fn len(&self) -> u32 {
            slice_len(self)
        }
        fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
            read_slice(self, offset, out)
        }
    }

    impl<T: Sink + ?Sized> Sink for Box<T> {
        fn expect_size(&mut self, size: u32) -> Result<(), Full> {
            (**self).expect_size(size)
        }
        fn write(&mut self, data: &[u8]) -> Result<(), Full> {
            (**self).write(data)
        }
    }

    impl<T: Source + ?Sized> Source for Box<T> {
        fn len(&self) -> u32 {
            (**self).len()
        }
        fn read(&mut self, offset: u32, out: &mut [u8]) -> usize {
            (**self).read(offset, out)
        }
    }
}
