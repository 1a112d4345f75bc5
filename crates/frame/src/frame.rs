//! Classic CAN frames (ISO 11898-1): data frames with 0..=8 bytes and remote (RTR) frames.

use core::fmt;

use crate::id::CanId;

/// A classic CAN frame: identifier, RTR flag and up to eight data bytes.
///
/// The data length is validated on construction; bytes past `len` are always zero, so derived
/// equality and hashing compare only what is on the wire.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: CanId,
    rtr: bool,
    len: u8,
    data: [u8; 8],
}

/// Why a frame could not be built.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// More than eight data bytes, or a remote frame DLC above 8.
    #[error("a classic CAN frame carries at most 8 data bytes, not {0}")]
    TooLong(usize),
    /// More than 64 data bytes for a CAN FD frame.
    #[error("a CAN FD frame carries at most 64 data bytes, not {0}")]
    FdTooLong(usize),
    /// A CAN FD data length that is not one of 0..=8, 12, 16, 20, 24, 32, 48, 64.
    #[error("{0} is not a CAN FD length (0..=8, 12, 16, 20, 24, 32, 48 or 64 bytes)")]
    InvalidFdLength(usize),
    /// A remote frame cannot become a CAN FD frame: CAN FD has no remote frames.
    #[error("CAN FD has no remote frames")]
    RemoteInFd,
    /// The CAN FD frame has the bit-rate switch or error state indicator set (these flag bits),
    /// which a classic frame cannot carry.
    #[error("CAN FD flags {0:#x} have no classic CAN equivalent")]
    FdFlagsLost(u8),
}

debug_as_display!(FrameError);

impl CanFrame {
    /// A data frame. Fails if `data` is longer than eight bytes.
    pub fn new(id: CanId, data: &[u8]) -> Result<Self, FrameError> {
        if data.len() > 8 {
            return Err(FrameError::TooLong(data.len()));
        }
        let mut buf = [0u8; 8];
        buf[..data.len()].copy_from_slice(data);
        Ok(Self {
            id,
            rtr: false,
            len: data.len() as u8,
            data: buf,
        })
    }

    /// A data frame from a full eight-byte buffer (most CANopen services send exactly 8 bytes).
    pub const fn from_array(id: CanId, data: [u8; 8]) -> Self {
        Self {
            id,
            rtr: false,
            len: 8,
            data,
        }
    }

    /// A remote frame requesting `dlc` bytes. Fails if `dlc` is above 8.
    pub fn remote(id: CanId, dlc: usize) -> Result<Self, FrameError> {
        if dlc > 8 {
            return Err(FrameError::TooLong(dlc));
        }
        Ok(Self {
            id,
            rtr: true,
            len: dlc as u8,
            data: [0; 8],
        })
    }

    /// The identifier.
    pub const fn id(&self) -> CanId {
        self.id
    }

    /// The raw 11-bit COB-ID if this is a standard-identifier frame (all of CANopen's
    /// predefined connection set).
    pub const fn cob_id(&self) -> Option<u16> {
        self.id.as_standard()
    }

    /// Whether this is a remote transmission request.
    pub const fn is_remote(&self) -> bool {
        self.rtr
    }

    /// The data length code: number of data bytes (or requested bytes for a remote frame).
    pub const fn dlc(&self) -> usize {
        self.len as usize
    }

    /// The data bytes (empty for a remote frame).
    #[inline]
    pub fn data(&self) -> &[u8] {
        if self.rtr {
            &[]
        } else {
            &self.data[..self.len as usize]
        }
    }

    /// The whole eight-byte buffer, zero past the data length.
    pub const fn data_padded(&self) -> &[u8; 8] {
        &self.data
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl fmt::Display for CanFrame {
    /// candump compact form: `123#DEADBEEF`, `123#R` / `123#R4` for remote frames.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}#", self.id.candump())?;
        if self.rtr {
            f.write_str("R")?;
            if self.len > 0 {
                write!(f, "{}", self.len)?;
            }
            return Ok(());
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// Bytes as lower-case hex pairs separated by spaces (`01 02 ff`; nothing for no bytes), for
/// the `Display` texts of the protocol messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HexBytes<'a>(pub &'a [u8]);

impl fmt::Display for HexBytes<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, b) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

impl embedded_can::Frame for CanFrame {
    fn new(id: impl Into<embedded_can::Id>, data: &[u8]) -> Option<Self> {
        Self::new(CanId::from(id.into()), data).ok()
    }

    fn new_remote(id: impl Into<embedded_can::Id>, dlc: usize) -> Option<Self> {
        Self::remote(CanId::from(id.into()), dlc).ok()
    }

    fn is_extended(&self) -> bool {
        self.id.is_extended()
    }

    fn is_remote_frame(&self) -> bool {
        self.rtr
    }

    fn id(&self) -> embedded_can::Id {
        self.id.into()
    }

    fn dlc(&self) -> usize {
        self.len as usize
    }

    fn data(&self) -> &[u8] {
        CanFrame::data(self)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::format;

    use super::*;
    use proptest::prelude::*;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    #[test]
    fn hex_bytes() {
        assert_eq!(format!("{}", HexBytes(&[0x01, 0xAB, 0x00])), "01 ab 00");
        assert_eq!(format!("{}", HexBytes(&[])), "");
    }

    #[test]
    fn lengths() {
        assert!(CanFrame::new(sid(1), &[0; 8]).is_ok());
        assert_eq!(CanFrame::new(sid(1), &[0; 9]), Err(FrameError::TooLong(9)));
        assert_eq!(CanFrame::remote(sid(1), 9), Err(FrameError::TooLong(9)));
        let f = CanFrame::new(sid(0x701), &[0x7F]).unwrap();
        assert_eq!(f.data(), &[0x7F]);
        assert_eq!(f.data_padded(), &[0x7F, 0, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn candump_text() {
        let f = CanFrame::new(sid(0x605), &[0x40, 0x17, 0x10, 0]).unwrap();
        assert_eq!(format!("{f}"), "605#40171000");
        assert_eq!(
            format!("{}", CanFrame::remote(sid(0x705), 1).unwrap()),
            "705#R1"
        );
        assert_eq!(
            format!("{}", CanFrame::remote(sid(0x705), 0).unwrap()),
            "705#R"
        );
    }

    proptest! {
        #[test]
        fn embedded_can_round_trip(raw in 0u16..=0x7FF, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let f = CanFrame::new(sid(raw), &data).unwrap();
            let g = <CanFrame as embedded_can::Frame>::new(embedded_can::Frame::id(&f), embedded_can::Frame::data(&f)).unwrap();
            prop_assert_eq!(f, g);
            prop_assert_eq!(f.dlc(), data.len());
        }
    }
}
