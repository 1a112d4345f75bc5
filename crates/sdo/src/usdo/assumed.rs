//! Every USDO fact this crate uses that public sources do **not** establish, in one table.
//!
//! The CiA 1301 text is not public. What the CiA and tool-vendor pages say in prose (a
//! destination byte, session-IDs, a data type byte, up to 56 expedited bytes, confirmed
//! segments, a 1-byte abort code, a client-side timeout) is built in elsewhere. The byte values
//! below come from one code base, EmSA's SOFA-CANopenFD (Gen 1, `fbsec_co_fd_usdo.{h,c}`, whose
//! comments cite CiA 1301 v1.1 tables 22, 31 and 32), or are this crate's own choices where no
//! source gives a value. Each row says which. When the CiA 1301 text or a second
//! implementation becomes available, this is the one place to check and change.
//!
//! | constant | value | source |
//! |---|---|---|
//! | [`SUBINDEX_AT`], [`INDEX_AT`] | 3, 4..=5 | SOFA only: sub-index before index (no second source) |
//! | [`CS_DOWNLOAD_EXPEDITED`] .. [`CS_UPLOAD_END`] | 0x01..0x34 | SOFA (bit 5 response, bit 4 upload) |
//! | [`CS_ABORT`] | 0x7F | SOFA V3.1+, citing CiA 1301 table 22 (SOFA before V3.1 used 0x80 with a 4-byte code) |
//! | [`REMOTE_FLAG`] | 0x80 | SOFA comment "remote FFh" for abort; remote layouts not established, such frames are refused |
//! | [`SEGMENT_DATA`] | 60 | SOFA: a segment fills a 64-byte frame after a 4-byte header |
//! | [`COUNTER_WRAPS`] | modulo 256 | own choice: SOFA's counter starts at 0 and never passes 256 bytes; bodies > 15 360 bytes wrap |
//! | [`SESSION_ZERO_VALID`] | false | SOFA rejects session-ID 0 |
//! | [`REQUEST_BASE`], [`RESPONSE_BASE`] | 0x600, 0x580 + sender | SOFA, "observed on real CANopen FD buses"; CiA text: the CAN-ID holds the source node-ID |
//! | [`DEFAULT_DATA_TYPE`] | 0x0F DOMAIN | SOFA always sends DOMAIN |
//! | the 1-byte abort codes in [`UsdoAbortCode`] | 0x13..0x62 | SOFA, citing CiA 1301 table 31; a subset |
//! | [`ABORT_TIMEOUT`], [`ABORT_CANCELLED`], [`ABORT_BUSY`], [`ABORT_GENERAL`] | 0x60 | own choice: the codes for timeout, cancel, "server busy" and a general error are not established; 0x60 ("data cannot be transferred or stored") is the nearest established meaning |
//! | [`DEFAULT_TIMEOUT_MS`] | 1000 | own choice (no default is published; the SDO machines use 1 s) |
//! | destination values for broadcast and multicast | — | not established: only unicast node-IDs 1..=127 are served |
//! | bulk transfer, remote (routed) services | — | not established: not implemented |

use super::UsdoAbortCode;

/// Offset of the sub-index in every frame that carries the multiplexer (SOFA).
pub const SUBINDEX_AT: usize = 3;
/// Offset of the little-endian index in every frame that carries the multiplexer (SOFA).
pub const INDEX_AT: usize = 4;

/// Expedited download request (SOFA).
pub const CS_DOWNLOAD_EXPEDITED: u8 = 0x01;
/// Expedited download response (SOFA).
pub const CS_DOWNLOAD_EXPEDITED_RESPONSE: u8 = 0x21;
/// Upload request (SOFA; answered expedited or segmented).
pub const CS_UPLOAD: u8 = 0x11;
/// Expedited upload response (SOFA).
pub const CS_UPLOAD_EXPEDITED_RESPONSE: u8 = 0x31;
/// Segmented download initiate request (SOFA).
pub const CS_DOWNLOAD_INITIATE: u8 = 0x02;
/// Segmented download initiate response (SOFA).
pub const CS_DOWNLOAD_INITIATE_RESPONSE: u8 = 0x22;
/// Download segment request (SOFA).
pub const CS_DOWNLOAD_SEGMENT: u8 = 0x03;
/// Download segment response (SOFA).
pub const CS_DOWNLOAD_SEGMENT_RESPONSE: u8 = 0x23;
/// Download end request (SOFA).
pub const CS_DOWNLOAD_END: u8 = 0x04;
/// Download end response (SOFA).
pub const CS_DOWNLOAD_END_RESPONSE: u8 = 0x24;
/// Segmented upload initiate response (SOFA).
pub const CS_UPLOAD_INITIATE_RESPONSE: u8 = 0x32;
/// Upload segment request (SOFA).
pub const CS_UPLOAD_SEGMENT: u8 = 0x13;
/// Upload segment response (SOFA).
pub const CS_UPLOAD_SEGMENT_RESPONSE: u8 = 0x33;
/// Upload end response (SOFA).
pub const CS_UPLOAD_END: u8 = 0x34;
/// Abort, both directions (SOFA V3.1+, citing CiA 1301 table 22).
pub const CS_ABORT: u8 = 0x7F;
/// Set in the command specifier of remote (routed) services (SOFA comment; layouts unknown).
pub const REMOTE_FLAG: u8 = 0x80;

/// Data bytes of a full segment (SOFA).
pub const SEGMENT_DATA: usize = 60;
/// The segment counter counts modulo 256 (own choice; see the table).
pub const COUNTER_WRAPS: u16 = 256;
/// Whether session-ID 0 is a valid session (SOFA: no).
pub const SESSION_ZERO_VALID: bool = false;

/// CAN-ID base of client → server frames; the low 7 bits hold the client's node-ID (SOFA).
pub const REQUEST_BASE: u16 = 0x600;
/// CAN-ID base of server → client frames; the low 7 bits hold the server's node-ID (SOFA).
pub const RESPONSE_BASE: u16 = 0x580;

/// The data type a server announces when the object's type is not known (SOFA: always DOMAIN).
pub const DEFAULT_DATA_TYPE: u8 = 0x0F;

/// Sent when a peer stopped answering within the timeout (own choice, see the table).
pub const ABORT_TIMEOUT: UsdoAbortCode = UsdoAbortCode::CANNOT_STORE;
/// Sent when the client cancels a transfer (own choice, see the table).
pub const ABORT_CANCELLED: UsdoAbortCode = UsdoAbortCode::CANNOT_STORE;
/// Sent when a server has no free session (own choice, see the table).
pub const ABORT_BUSY: UsdoAbortCode = UsdoAbortCode::CANNOT_STORE;
/// Sent for a CiA 301 abort code without a 1-byte equivalent (own choice, see the table).
pub const ABORT_GENERAL: UsdoAbortCode = UsdoAbortCode::CANNOT_STORE;

/// Response timeout when the application sets none (own choice).
pub const DEFAULT_TIMEOUT_MS: u64 = 1000;
