//! Small private helpers: frame building from already-valid identifiers, decoding a frame of
//! a service on a known COB-ID, and the bounded queues that drop their oldest entry.

use canola_frame::{CanFrame, CanId};
use heapless::Deque;

use crate::error::DecodeError;

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

/// The data of `frame` if it is a data frame on `cob_id`; the errors name `message`.
pub(crate) fn service_data<'f>(
    frame: &'f CanFrame,
    cob_id: u16,
    message: &'static str,
) -> Result<&'f [u8], DecodeError> {
    if frame.cob_id() != Some(cob_id) {
        return Err(DecodeError::WrongCobId(frame.id().as_raw()));
    }
    if frame.is_remote() {
        return Err(DecodeError::UnexpectedRemote { message });
    }
    Ok(frame.data())
}

/// Appends `item`; when the queue is full the oldest entry makes room (a caller that does not
/// drain loses the stalest). Returns whether an entry was dropped.
pub(crate) fn push_dropping_oldest<T, const N: usize>(queue: &mut Deque<T, N>, item: T) -> bool {
    match queue.push_back(item) {
        Ok(()) => false,
        Err(item) => {
            queue.pop_front();
            let _ = queue.push_back(item);
            true
        }
    }
}
