//! CAN FD frames (ISO 11898-1:2015 flexible data rate): 0..=64 data bytes, the DLC table, and
//! the bit-rate switch (BRS) and error state indicator (ESI) flags.
//!
//! A CAN FD frame's 4-bit data length code (DLC) encodes one of sixteen lengths:
//!
//! | DLC   | 0..=8 | 9  | 10 | 11 | 12 | 13 | 14 | 15 |
//! |-------|-------|----|----|----|----|----|----|----|
//! | bytes | 0..=8 | 12 | 16 | 20 | 24 | 32 | 48 | 64 |
//!
//! (the same table as can-utils `dlc2len`, python-can `CAN_FD_DLC` and the Linux
//! `struct canfd_frame` documentation). A payload of another length travels **padded to the next
//! valid length**: [`padded_len`] gives that length (9..=12 → 12, 25..=32 → 32, 49..=64 → 64),
//! [`FdFrame::new_padded`] builds such a frame with the tail bytes set to zero (what Linux, the
//! SOFA CANopen FD stack and python-can send), and receivers of CANopen FD services must accept
//! the padding after the protocol length. [`FdFrame::new`] takes only valid lengths.
//!
//! CAN FD has no remote frames. FD frames carry [`FdFlags`]: BRS (the data phase runs at the
//! data bit rate), ESI (the sender was error passive), and FDF, the flag Linux 6.2 and later set
//! on received FD frames (`CANFD_FDF`); the candump `##F` digit holds all four low bits, so they
//! are kept as they are.
//!
//! [`FdFrame`]'s `Display` is the candump compact form `123##1DEADBEEF`, as [`CanFrame`]'s is
//! `123#DEADBEEF`.

use core::fmt;

use crate::frame::{CanFrame, FrameError};
use crate::id::CanId;

/// The largest CAN FD payload.
pub const MAX_FD_LEN: usize = 64;

/// The data lengths a CAN FD frame can have, indexed by DLC code.
pub const FD_LENGTHS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

/// The number of data bytes of DLC code `dlc` (0..=15); `None` above 15.
pub const fn dlc_to_len(dlc: u8) -> Option<usize> {
    if dlc < 16 {
        Some(FD_LENGTHS[dlc as usize])
    } else {
        None
    }
}

/// The DLC code for `len` data bytes, rounding up to the next valid length (9 → 9, which is 12
/// bytes; 64 → 15); `None` above 64.
pub const fn len_to_dlc(len: usize) -> Option<u8> {
    let mut dlc = 0;
    while dlc < 16 {
        if FD_LENGTHS[dlc] >= len {
            return Some(dlc as u8);
        }
        dlc += 1;
    }
    None
}

/// The length `len` bytes travel as on a CAN FD bus: the next valid length at or above `len`;
/// `None` above 64.
pub const fn padded_len(len: usize) -> Option<usize> {
    match len_to_dlc(len) {
        Some(dlc) => Some(FD_LENGTHS[dlc as usize]),
        None => None,
    }
}

/// Whether `len` is one of the sixteen CAN FD lengths.
pub const fn is_valid_len(len: usize) -> bool {
    matches!(padded_len(len), Some(p) if p == len)
}

/// The flags of a CAN FD frame: the low four bits of Linux `canfd_frame.flags` and of the
/// candump `##F` digit.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct FdFlags(u8);

impl FdFlags {
    /// No flag set.
    pub const EMPTY: Self = Self(0);
    /// Bit-rate switch: the data phase uses the data bit rate (`CANFD_BRS`, 0x01).
    pub const BRS: Self = Self(0x01);
    /// Error state indicator: the transmitter was error passive (`CANFD_ESI`, 0x02).
    pub const ESI: Self = Self(0x02);
    /// FD frame format, set by Linux 6.2 and later on received FD frames (`CANFD_FDF`, 0x04).
    pub const FDF: Self = Self(0x04);
    /// The bits a flags value may hold (one candump hex digit).
    pub const ALL_BITS: u8 = 0x0F;

    /// Flags from raw bits; `None` when a bit above [`ALL_BITS`](Self::ALL_BITS) is set.
    pub const fn from_bits(bits: u8) -> Option<Self> {
        if bits & !Self::ALL_BITS == 0 {
            Some(Self(bits))
        } else {
            None
        }
    }

    /// Flags from raw bits, dropping bits above [`ALL_BITS`](Self::ALL_BITS).
    pub const fn from_bits_truncate(bits: u8) -> Self {
        Self(bits & Self::ALL_BITS)
    }

    /// The raw bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Whether every flag of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Both sets of flags.
    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// Whether no flag is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl core::ops::BitOr for FdFlags {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        self.union(rhs)
    }
}

impl fmt::Debug for FdFlags {
    /// `BRS | ESI`, `(empty)`, or the hex bits when an unnamed bit is set.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("(empty)");
        }
        if self.0 & 0x08 != 0 {
            return write!(f, "{:#x}", self.0);
        }
        let mut first = true;
        for (flag, name) in [(Self::BRS, "BRS"), (Self::ESI, "ESI"), (Self::FDF, "FDF")] {
            if self.contains(flag) {
                if !first {
                    f.write_str(" | ")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// A CAN FD frame: identifier, [`FdFlags`] and 0..=64 data bytes of a valid FD length.
///
/// Bytes past the length are always zero, so derived equality and hashing compare only what is
/// on the wire. Build one with [`new`](Self::new) (exact lengths) or
/// [`new_padded`](Self::new_padded) (any length up to 64, zero-padded).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct FdFrame {
    id: CanId,
    flags: FdFlags,
    len: u8,
    data: [u8; MAX_FD_LEN],
}

impl FdFrame {
    /// An FD frame without flags. Fails unless `data.len()` is one of the sixteen FD lengths
    /// ([`FrameError::InvalidFdLength`]); above 64 bytes it is [`FrameError::FdTooLong`].
    pub fn new(id: CanId, data: &[u8]) -> Result<Self, FrameError> {
        if data.len() > MAX_FD_LEN {
            return Err(FrameError::FdTooLong(data.len()));
        }
        if !is_valid_len(data.len()) {
            return Err(FrameError::InvalidFdLength(data.len()));
        }
        let mut buf = [0u8; MAX_FD_LEN];
        buf[..data.len()].copy_from_slice(data);
        Ok(Self {
            id,
            flags: FdFlags::EMPTY,
            len: data.len() as u8,
            data: buf,
        })
    }

    /// An FD frame without flags carrying `data` padded with zeros to the next valid length
    /// ([`padded_len`]). Fails above 64 bytes.
    pub fn new_padded(id: CanId, data: &[u8]) -> Result<Self, FrameError> {
        let len = padded_len(data.len()).ok_or(FrameError::FdTooLong(data.len()))?;
        let mut buf = [0u8; MAX_FD_LEN];
        buf[..data.len()].copy_from_slice(data);
        Ok(Self {
            id,
            flags: FdFlags::EMPTY,
            len: len as u8,
            data: buf,
        })
    }

    /// The same frame with `flags`.
    #[must_use]
    pub const fn with_flags(mut self, flags: FdFlags) -> Self {
        self.flags = flags;
        self
    }

    /// The same frame with the bit-rate switch set or cleared.
    #[must_use]
    pub const fn with_brs(mut self, brs: bool) -> Self {
        self.flags = if brs {
            FdFlags(self.flags.0 | FdFlags::BRS.0)
        } else {
            FdFlags(self.flags.0 & !FdFlags::BRS.0)
        };
        self
    }

    /// The identifier.
    pub const fn id(&self) -> CanId {
        self.id
    }

    /// The raw 11-bit COB-ID if this is a standard-identifier frame.
    pub const fn cob_id(&self) -> Option<u16> {
        self.id.as_standard()
    }

    /// The flags.
    pub const fn flags(&self) -> FdFlags {
        self.flags
    }

    /// Whether the bit-rate switch is set.
    pub const fn brs(&self) -> bool {
        self.flags.contains(FdFlags::BRS)
    }

    /// Whether the error state indicator is set.
    pub const fn esi(&self) -> bool {
        self.flags.contains(FdFlags::ESI)
    }

    /// The number of data bytes (like [`CanFrame::dlc`]; for the 4-bit code see
    /// [`dlc_code`](Self::dlc_code)).
    pub const fn dlc(&self) -> usize {
        self.len as usize
    }

    /// The 4-bit data length code on the wire (0..=15).
    pub const fn dlc_code(&self) -> u8 {
        match len_to_dlc(self.len as usize) {
            Some(code) => code,
            // Unreachable: the length is validated on construction.
            None => 15,
        }
    }

    /// The data bytes.
    #[inline]
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// The whole 64-byte buffer, zero past the data length.
    pub const fn data_padded(&self) -> &[u8; MAX_FD_LEN] {
        &self.data
    }
}

impl TryFrom<CanFrame> for FdFrame {
    type Error = FrameError;

    /// A classic data frame's identifier and data as an FD frame without flags. Fails for a
    /// remote frame ([`FrameError::RemoteInFd`]): CAN FD has none.
    fn try_from(frame: CanFrame) -> Result<Self, FrameError> {
        if frame.is_remote() {
            return Err(FrameError::RemoteInFd);
        }
        Self::new(frame.id(), frame.data())
    }
}

impl TryFrom<FdFrame> for CanFrame {
    type Error = FrameError;

    /// An FD frame of at most 8 bytes without BRS or ESI as a classic data frame. Fails when the
    /// data are longer ([`FrameError::TooLong`]) or a flag other than FDF would be lost
    /// ([`FrameError::FdFlagsLost`]).
    fn try_from(frame: FdFrame) -> Result<Self, FrameError> {
        if frame.flags.bits() & !FdFlags::FDF.bits() != 0 {
            return Err(FrameError::FdFlagsLost(frame.flags.bits()));
        }
        CanFrame::new(frame.id, frame.data())
    }
}

impl fmt::Debug for FdFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl fmt::Display for FdFrame {
    /// candump compact form: `123##1DEADBEEF` (identifier, `##`, the flags digit, the data).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}##{:X}", self.id.candump(), self.flags.bits())?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

impl embedded_can::Frame for FdFrame {
    /// An FD frame padded to the next valid length; `None` above 64 bytes.
    fn new(id: impl Into<embedded_can::Id>, data: &[u8]) -> Option<Self> {
        Self::new_padded(CanId::from(id.into()), data).ok()
    }

    /// Always `None`: CAN FD has no remote frames.
    fn new_remote(_id: impl Into<embedded_can::Id>, _dlc: usize) -> Option<Self> {
        None
    }

    fn is_extended(&self) -> bool {
        self.id.is_extended()
    }

    fn is_remote_frame(&self) -> bool {
        false
    }

    fn id(&self) -> embedded_can::Id {
        self.id.into()
    }

    /// The number of data bytes.
    fn dlc(&self) -> usize {
        self.len as usize
    }

    fn data(&self) -> &[u8] {
        FdFrame::data(self)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::format;
    use std::vec::Vec;

    use super::*;
    use proptest::prelude::*;

    fn sid(raw: u16) -> CanId {
        CanId::standard(raw).unwrap()
    }

    #[test]
    fn dlc_table() {
        // can-utils lib.c dlc2len / len2dlc.
        let expect = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];
        for (dlc, len) in expect.iter().enumerate() {
            assert_eq!(dlc_to_len(dlc as u8), Some(*len));
            assert_eq!(len_to_dlc(*len), Some(dlc as u8));
        }
        assert_eq!(dlc_to_len(16), None);
        assert_eq!(len_to_dlc(9), Some(9));
        assert_eq!(len_to_dlc(13), Some(10));
        assert_eq!(len_to_dlc(25), Some(13));
        assert_eq!(len_to_dlc(33), Some(14));
        assert_eq!(len_to_dlc(49), Some(15));
        assert_eq!(len_to_dlc(65), None);
        assert_eq!(padded_len(9), Some(12));
        assert_eq!(padded_len(60), Some(64));
        assert_eq!(padded_len(8), Some(8));
        assert!(is_valid_len(48) && !is_valid_len(47));
    }

    #[test]
    fn construction() {
        assert_eq!(
            FdFrame::new(sid(1), &[0; 9]),
            Err(FrameError::InvalidFdLength(9))
        );
        assert_eq!(
            FdFrame::new(sid(1), &[0; 65]),
            Err(FrameError::FdTooLong(65))
        );
        let f = FdFrame::new_padded(sid(0x581), &[1; 9]).unwrap();
        assert_eq!(f.dlc(), 12);
        assert_eq!(f.dlc_code(), 9);
        assert_eq!(&f.data()[..9], &[1; 9]);
        assert_eq!(&f.data()[9..], &[0; 3]);
        assert_eq!(
            FdFrame::new_padded(sid(1), &[0; 65]),
            Err(FrameError::FdTooLong(65))
        );
        let g = FdFrame::new(sid(1), &[]).unwrap();
        assert_eq!((g.dlc(), g.dlc_code(), g.data()), (0, 0, &[][..]));
    }

    #[test]
    fn flags() {
        let f = FdFrame::new(sid(0x123), &[0xAA; 12])
            .unwrap()
            .with_brs(true);
        assert!(f.brs() && !f.esi());
        assert_eq!(f.flags(), FdFlags::BRS);
        let f = f.with_flags(FdFlags::BRS | FdFlags::ESI);
        assert!(f.esi());
        assert_eq!(f.with_brs(false).flags(), FdFlags::ESI);
        assert_eq!(FdFlags::from_bits(0x10), None);
        assert_eq!(FdFlags::from_bits_truncate(0x17).bits(), 0x07);
        assert_eq!(format!("{:?}", FdFlags::BRS | FdFlags::FDF), "BRS | FDF");
        assert_eq!(format!("{:?}", FdFlags::EMPTY), "(empty)");
        assert_eq!(format!("{:?}", FdFlags::from_bits(0x9).unwrap()), "0x9");
    }

    #[test]
    fn candump_text() {
        let f = FdFrame::new(sid(0x123), &(0u8..12).collect::<Vec<_>>())
            .unwrap()
            .with_brs(true);
        assert_eq!(format!("{f}"), "123##1000102030405060708090A0B");
        let e = FdFrame::new(CanId::extended(0x1ABC_DEF0).unwrap(), &[])
            .unwrap()
            .with_flags(FdFlags::BRS | FdFlags::ESI);
        assert_eq!(format!("{e:?}"), "1ABCDEF0##3");
    }

    #[test]
    fn classic_conversions() {
        let c = CanFrame::new(sid(0x181), &[1, 2, 3]).unwrap();
        let f = FdFrame::try_from(c).unwrap();
        assert_eq!(f.data(), &[1, 2, 3]);
        assert!(f.flags().is_empty());
        assert_eq!(CanFrame::try_from(f), Ok(c));
        assert_eq!(
            FdFrame::try_from(CanFrame::remote(sid(0x701), 1).unwrap()),
            Err(FrameError::RemoteInFd)
        );
        assert_eq!(
            CanFrame::try_from(f.with_brs(true)),
            Err(FrameError::FdFlagsLost(1))
        );
        // FDF only marks the format on receive; the classic frame loses nothing else.
        assert_eq!(CanFrame::try_from(f.with_flags(FdFlags::FDF)), Ok(c));
        let long = FdFrame::new(sid(1), &[0; 12]).unwrap();
        assert_eq!(CanFrame::try_from(long), Err(FrameError::TooLong(12)));
    }

    #[test]
    fn embedded_can_frame() {
        use embedded_can::Frame;
        let f = <FdFrame as Frame>::new(embedded_can::StandardId::new(0x7E).unwrap(), &[5; 20])
            .unwrap();
        assert_eq!(Frame::dlc(&f), 20);
        assert!(!f.is_remote_frame() && !f.is_extended());
        assert!(<FdFrame as Frame>::new_remote(embedded_can::StandardId::ZERO, 0).is_none());
        let g = <FdFrame as Frame>::new(embedded_can::StandardId::ZERO, &[5; 21]).unwrap();
        assert_eq!(Frame::dlc(&g), 24);
        assert!(<FdFrame as Frame>::new(embedded_can::StandardId::ZERO, &[0; 65]).is_none());
    }

    fn any_id() -> impl Strategy<Value = CanId> {
        prop_oneof![
            (0u16..=0x7FF).prop_map(|r| CanId::standard(r).unwrap()),
            (0u32..=0x1FFF_FFFF).prop_map(|r| CanId::extended(r).unwrap()),
        ]
    }

    proptest! {
        #[test]
        fn padding_and_dlc_agree(len in 0usize..=64) {
            let p = padded_len(len).unwrap();
            prop_assert!(p >= len && is_valid_len(p));
            // No valid length lies between len and p.
            prop_assert!(FD_LENGTHS.iter().all(|&l| l < len || l >= p));
            prop_assert_eq!(dlc_to_len(len_to_dlc(len).unwrap()), Some(p));
        }

        #[test]
        fn padded_frames_keep_data(id in any_id(), data in proptest::collection::vec(any::<u8>(), 0..=64), bits in 0u8..16) {
            let f = FdFrame::new_padded(id, &data).unwrap().with_flags(FdFlags::from_bits(bits).unwrap());
            prop_assert_eq!(&f.data()[..data.len()], &data[..]);
            prop_assert!(f.data()[data.len()..].iter().all(|&b| b == 0));
            prop_assert_eq!(dlc_to_len(f.dlc_code()), Some(f.dlc()));
            prop_assert_eq!(f.flags().bits(), bits);
            // Rebuilding from the wire data gives the same frame.
            prop_assert_eq!(FdFrame::new(id, f.data()).unwrap().with_flags(f.flags()), f);
            let e = <FdFrame as embedded_can::Frame>::new(embedded_can::Frame::id(&f), embedded_can::Frame::data(&f)).unwrap();
            prop_assert_eq!(e.with_flags(f.flags()), f);
        }

        #[test]
        fn classic_round_trip(id in any_id(), data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let c = CanFrame::new(id, &data).unwrap();
            let f = FdFrame::try_from(c).unwrap();
            prop_assert_eq!(f.data(), &data[..]);
            prop_assert_eq!(CanFrame::try_from(f), Ok(c));
        }
    }
}
