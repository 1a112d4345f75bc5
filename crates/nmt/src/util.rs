//! Small private helpers: frame building from already-valid identifiers.

use can_frame::{CanFrame, CanId};

/// COB-ID 0x000 as a `CanId`; the fallback for the (unreachable) failure paths below.
const ZERO_ID: CanId = match CanId::standard(0) {
    Ok(id) => id,
    Err(_) => panic!("0 is a valid standard identifier"),
};

/// A standard identifier from an 11-bit COB-ID (masked, so it cannot fail).
pub(crate) fn std_id(raw: u16) -> CanId {
    CanId::standard(raw & 0x7FF).unwrap_or(ZERO_ID)
}

/// A data frame with at most eight bytes (longer input is cut; callers never pass more).
pub(crate) fn data_frame(cob_id: u16, data: &[u8]) -> CanFrame {
    let n = data.len().min(8);
    let id = std_id(cob_id);
    CanFrame::new(id, data.get(..n).unwrap_or(&[])).unwrap_or(CanFrame::from_array(id, [0; 8]))
}

/// A remote frame requesting `dlc` bytes (`dlc` <= 8).
pub(crate) fn remote_frame(cob_id: u16, dlc: usize) -> CanFrame {
    let id = std_id(cob_id);
    CanFrame::remote(id, dlc.min(8)).unwrap_or(CanFrame::from_array(id, [0; 8]))
}
