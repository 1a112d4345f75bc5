//! The object dictionary as the SDO server sees it: [`ObjectAccess`] with [`ObjectInfo`] (access
//! rights, length, accepted download lengths), and the checks the server makes before and
//! during a transfer, each failing with the CiA 301 abort code to send.

use crate::abort::AbortCode;
use crate::usdo::DataType;
use crate::wire::Multiplexer;

/// Access rights of an object (CiA 301 / CiA 306 `AccessType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Access {
    /// Read only.
    ReadOnly,
    /// Write only.
    WriteOnly,
    /// Read and write.
    ReadWrite,
    /// Constant (read only).
    Const,
}

impl Access {
    /// Whether an upload is allowed.
    pub const fn readable(self) -> bool {
        !matches!(self, Self::WriteOnly)
    }

    /// Whether a download is allowed.
    pub const fn writable(self) -> bool {
        matches!(self, Self::WriteOnly | Self::ReadWrite)
    }
}

/// Which download lengths an object accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LengthRule {
    /// Exactly this many bytes (numeric types).
    Exact(u32),
    /// Any length up to this many bytes (strings, DOMAIN).
    UpTo(u32),
}

impl LengthRule {
    pub(crate) fn max(self) -> u32 {
        match self {
            Self::Exact(n) | Self::UpTo(n) => n,
        }
    }

    /// Checks a complete length.
    pub(crate) fn check(self, len: u32) -> Result<(), AbortCode> {
        match self {
            Self::Exact(n) | Self::UpTo(n) if len > n => Err(AbortCode::LENGTH_TOO_HIGH),
            Self::Exact(n) if len < n => Err(AbortCode::LENGTH_TOO_LOW),
            _ => Ok(()),
        }
    }
}

/// What the server needs to know about an object before a transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ObjectInfo {
    /// Access rights.
    pub access: Access,
    /// The current length of the value in bytes: what an upload delivers.
    pub len: u32,
    /// Which lengths a download may have.
    pub accepts: LengthRule,
}

impl ObjectInfo {
    /// A fixed-length object (numeric types): reads and writes are exactly `len` bytes.
    pub const fn fixed(access: Access, len: u32) -> Self {
        Self {
            access,
            len,
            accepts: LengthRule::Exact(len),
        }
    }

    /// A variable-length object (strings, DOMAIN) currently `len` bytes long, accepting
    /// downloads of up to `max` bytes.
    pub const fn variable(access: Access, len: u32, max: u32) -> Self {
        Self {
            access,
            len,
            accepts: LengthRule::UpTo(max),
        }
    }
}

/// The device's objects as the SDO server sees them.
///
/// Downloads call `write` with consecutive pieces from offset 0 and then `commit` with the
/// total length once all data arrived and was checked (length, CRC); if the transfer is aborted
/// instead, `discard` is called. An implementation that cannot stage a value may apply the
/// pieces directly. Uploads call `read` at increasing offsets (block upload re-reads a range
/// after a lost segment).
pub trait ObjectAccess {
    /// Existence, access and length of an object; `Err` with 0x06020000 (object does not
    /// exist) or 0x06090011 (sub-index does not exist), or any other code.
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode>;

    /// Copies the value's bytes at `offset..offset + buf.len()` into `buf` and returns how many
    /// were copied; fewer than asked only at the end of the value.
    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode>;

    /// Takes the download bytes at `offset`.
    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode>;

    /// All `len` bytes arrived: store the value (or refuse it, e.g. 0x06090030).
    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode>;

    /// The download was aborted: forget the pieces written.
    fn discard(&mut self, mux: Multiplexer) {
        let _ = mux;
    }

    /// The data type code of the object (CiA 301 §7.4.7.1), for the data type byte of USDO
    /// (CiA 1301). The default, DOMAIN, makes the USDO server announce DOMAIN and accept any
    /// type a client sends; any other code is announced, and a download with another type
    /// (other than DOMAIN) is refused with 1-byte abort 0x36.
    fn data_type(&mut self, mux: Multiplexer) -> DataType {
        let _ = mux;
        DataType::DOMAIN
    }
}

impl<T: ObjectAccess + ?Sized> ObjectAccess for &mut T {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        (**self).info(mux)
    }
    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        (**self).read(mux, offset, buf)
    }
    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        (**self).write(mux, offset, data)
    }
    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        (**self).commit(mux, len)
    }
    fn discard(&mut self, mux: Multiplexer) {
        (**self).discard(mux)
    }
    fn data_type(&mut self, mux: Multiplexer) -> DataType {
        (**self).data_type(mux)
    }
}

/// Why a request ended the transfer: the object and the code to send.
pub(crate) struct Fail(pub(crate) Multiplexer, pub(crate) AbortCode);

pub(crate) fn writable<O: ObjectAccess + ?Sized>(
    od: &mut O,
    mux: Multiplexer,
) -> Result<ObjectInfo, Fail> {
    let info = od.info(mux).map_err(|c| Fail(mux, c))?;
    if !info.access.writable() {
        return Err(Fail(mux, AbortCode::READ_ONLY));
    }
    Ok(info)
}

pub(crate) fn readable<O: ObjectAccess + ?Sized>(
    od: &mut O,
    mux: Multiplexer,
) -> Result<ObjectInfo, Fail> {
    let info = od.info(mux).map_err(|c| Fail(mux, c))?;
    if !info.access.readable() {
        return Err(Fail(mux, AbortCode::WRITE_ONLY));
    }
    Ok(info)
}

/// Reads exactly `buf.len()` bytes (in as many calls as the object needs).
pub(crate) fn read_exact<O: ObjectAccess + ?Sized>(
    od: &mut O,
    mux: Multiplexer,
    offset: u32,
    buf: &mut [u8],
) -> Result<usize, Fail> {
    let mut done = 0;
    while done < buf.len() {
        let n = od
            .read(mux, offset + done as u32, &mut buf[done..])
            .map_err(|c| Fail(mux, c))?;
        if n == 0 || n > buf.len() - done {
            // The object is shorter than it said.
            return Err(Fail(mux, AbortCode::NO_DATA_AVAILABLE));
        }
        done += n;
    }
    Ok(done)
}

/// Data so far may not exceed the announced size or the object's maximum.
pub(crate) fn check_progress(
    end: u32,
    size: Option<u32>,
    accepts: LengthRule,
) -> Result<(), AbortCode> {
    if let Some(size) = size
        && end > size
    {
        return Err(AbortCode::LENGTH_MISMATCH);
    }
    if end > accepts.max() {
        return Err(AbortCode::LENGTH_TOO_HIGH);
    }
    Ok(())
}

/// The complete data must have the announced size and a length the object accepts.
pub(crate) fn check_end(end: u32, size: Option<u32>, accepts: LengthRule) -> Result<(), AbortCode> {
    if let Some(size) = size
        && end != size
    {
        return Err(AbortCode::LENGTH_MISMATCH);
    }
    accepts.check(end)
}
