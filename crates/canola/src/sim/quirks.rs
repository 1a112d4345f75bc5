//! Habits of real devices a [`SimDevice`](super::SimDevice) can copy ([`Quirks`]), so that a
//! master is tested against what it meets on real buses, not only against answers the way
//! CiA 301 recommends them.

/// Habits of real devices, all off by default (see
/// [`SimDevice::with_quirks`](super::SimDevice::with_quirks)).
/// Built with the setters, so habits added later do not break callers:
/// `Quirks::default().with_expedited_without_size(true)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct Quirks {
    /// Answer every expedited upload without the size indicated: command byte `0x42`
    /// (e = 1, s = 0) and all four data bytes, those past the object's length unspecified
    /// (filled with `0xAA` here, so a master that reads them shows it). CiA 301 allows this,
    /// and the master must take the object type's length. Devices whose SDO server always
    /// copies a whole 32-bit word into the response behave like this: small firmware stacks
    /// that keep every object in a 4-byte slot, and some gateways and drives that answer
    /// UNSIGNED8 and UNSIGNED16 objects with four bytes.
    pub expedited_without_size: bool,
}

impl Quirks {
    /// Sets [`expedited_without_size`](Self::expedited_without_size).
    pub const fn with_expedited_without_size(mut self, on: bool) -> Self {
        self.expedited_without_size = on;
        self
    }

    /// The SDO server's response `data` as a device with these habits sends it.
    pub(super) fn sdo_response(&self, mut data: [u8; 8]) -> [u8; 8] {
        // Expedited upload response with the size indicated: scs = 2, e = 1, s = 1.
        if self.expedited_without_size && data[0] & 0xE3 == 0x43 {
            let n = usize::from(4 - ((data[0] >> 2) & 3));
            for b in &mut data[4 + n..] {
                *b = 0xAA;
            }
            data[0] = 0x42;
        }
        data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_expedited_answer_loses_its_size() {
        let q = Quirks::default().with_expedited_without_size(true);
        // UNSIGNED16 500 from 0x1017:00 (n = 2).
        let sized = [0x4B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0x00, 0x00];
        assert_eq!(
            q.sdo_response(sized),
            [0x42, 0x17, 0x10, 0x00, 0xF4, 0x01, 0xAA, 0xAA]
        );
        // Four bytes: only the command byte changes.
        let four = [0x43, 0x18, 0x10, 0x01, 0x39, 0x00, 0x00, 0x00];
        assert_eq!(
            q.sdo_response(four)[..],
            [0x42, 0x18, 0x10, 0x01, 0x39, 0, 0, 0]
        );
        // Other answers (a download response, a segment) pass unchanged.
        let down = [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0];
        assert_eq!(q.sdo_response(down), down);
        assert_eq!(Quirks::default().sdo_response(sized), sized);
    }
}
