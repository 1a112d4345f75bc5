//! How many bytes each SDO message uses, and the frames shorter than eight bytes (see "Frames
//! shorter than eight bytes" in the parent module): a frame that holds every byte its command
//! needs is padded with zeros to eight; the multiplexer of one that does not is still read
//! when it is there, so a client or server can answer the transfer it belongs to.

use super::{DecodeError, Multiplexer, field};

/// The frame's bytes padded with zeros to eight, when it holds the `needs(command)` bytes its
/// command uses.
pub(super) fn padded(data: &[u8], needs: fn(u8) -> usize) -> Result<[u8; 8], DecodeError> {
    let (&command, _) = data
        .split_first()
        .filter(|_| data.len() <= 8)
        .ok_or(DecodeError::Length(data.len()))?;
    let needs = needs(command);
    if data.len() < needs {
        return Err(DecodeError::Short {
            command,
            needs,
            len: data.len(),
        });
    }
    let mut b = [0u8; 8];
    b[..data.len()].copy_from_slice(data);
    Ok(b)
}

/// The multiplexer of a frame too short for its command, when its command carries one
/// (initiate, block initiate, abort) and the frame holds it.
pub(crate) fn short_frame_mux(data: &[u8]) -> Option<Multiplexer> {
    let cmd = *data.first()?;
    match data.get(..4) {
        Some(&[_, lo, hi, subindex]) if carries_mux(cmd) => Some(Multiplexer {
            index: u16::from_le_bytes([lo, hi]),
            subindex,
        }),
        _ => None,
    }
}

/// Whether messages with command byte `cmd` carry a multiplexer, in either direction: the
/// initiate messages, the abort and the block initiate messages do; the acknowledgements, the
/// ends and the block upload start do not.
pub(crate) fn carries_mux(cmd: u8) -> bool {
    match cmd >> field::CS_SHIFT {
        1..=4 => true,
        5 => cmd & 0x03 == 0,
        6 => cmd & 0x01 == 0,
        _ => false,
    }
}

/// Bytes a segment (download segment request, upload segment response) uses: the command byte
/// and its 7 − n data bytes.
fn segment_needs(cmd: u8) -> usize {
    8 - usize::from((cmd & field::SEG_N_MASK) >> field::SEG_N_SHIFT)
}

/// Bytes an initiate download request or initiate upload response uses: expedited with size
/// indicated, the command, multiplexer and its 4 − n data bytes; expedited without size, all
/// eight; segmented, the size if indicated, else the multiplexer.
fn initiate_needs(cmd: u8) -> usize {
    let sized = cmd & field::SIZE != 0;
    match (cmd & field::EXPEDITED != 0, sized) {
        (true, true) => 8 - usize::from((cmd & field::INIT_N_MASK) >> field::INIT_N_SHIFT),
        (true, false) | (false, true) => 8,
        (false, false) => field::DATA.start,
    }
}

/// Bytes a block initiate with an optional size uses (block download request, block upload
/// response).
fn sized_block_initiate_needs(cmd: u8) -> usize {
    if cmd & field::BLOCK_SIZE != 0 {
        8
    } else {
        field::DATA.start
    }
}

/// Bytes each client request uses (commands that do not exist need only their command byte,
/// to be told apart as unknown).
pub(super) fn client_needs(cmd: u8) -> usize {
    match (cmd >> field::CS_SHIFT, cmd & 0x03) {
        (0, _) => segment_needs(cmd),
        (1, _) => initiate_needs(cmd),
        (2, _) => field::DATA.start,
        (4, _) => 8,
        (5, 0) => field::PST + 1,
        (5, 2) => field::ACK_BLKSIZE + 1,
        (6, 1) | (6, 3) => field::CRC.end,
        (6, _) => sized_block_initiate_needs(cmd),
        _ => 1,
    }
}

/// Bytes each server response uses.
pub(super) fn server_needs(cmd: u8) -> usize {
    match (cmd >> field::CS_SHIFT, cmd & 0x03) {
        (0, _) => segment_needs(cmd),
        (2, _) => initiate_needs(cmd),
        (3, _) => field::DATA.start,
        (4, _) => 8,
        (5, 0) => field::INIT_RESP_BLKSIZE + 1,
        (5, 2) => field::ACK_BLKSIZE + 1,
        (6, 1) | (6, 3) => field::CRC.end,
        (6, _) => sized_block_initiate_needs(cmd),
        _ => 1,
    }
}
