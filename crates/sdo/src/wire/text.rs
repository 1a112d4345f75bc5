//! The `Display` texts of the SDO messages: each names the message as CiA 301 §7.2.4.3 does
//! ("initiate upload request", "end block download response", ...), then its object and
//! fields, as one line a bus monitor or a log shows as it is.

use core::fmt;

use canola_frame::HexBytes;

use super::{BlockSegment, ClientRequest, Initiate, Multiplexer, Segment, ServerResponse};
use crate::abort::AbortCode;

impl fmt::Display for Initiate {
    /// `expedited, 2 bytes e8 03`, `expedited, size not indicated, 01 02 03 04`,
    /// `segmented, 26 bytes`, `segmented, size not indicated`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Expedited { data, size: None } => {
                write!(f, "expedited, size not indicated, {}", HexBytes(data))
            }
            Self::Expedited { size: Some(n), .. } => write!(
                f,
                "expedited, {n} byte{} {}",
                plural(u32::from(*n)),
                HexBytes(self.expedited_data())
            ),
            Self::Segmented { size: Some(n) } => write!(f, "segmented, {n} byte{}", plural(*n)),
            Self::Segmented { size: None } => f.write_str("segmented, size not indicated"),
        }
    }
}

impl fmt::Display for Segment {
    /// `toggle 1, 3 bytes 78 79 7a, last`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let data = self.bytes();
        write!(
            f,
            "toggle {}, {} byte{}",
            u8::from(self.toggle),
            data.len(),
            plural(data.len() as u32)
        )?;
        if !data.is_empty() {
            write!(f, " {}", HexBytes(data))?;
        }
        if self.last {
            f.write_str(", last")?;
        }
        Ok(())
    }
}

fn plural(n: u32) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// `, CRC` or `, no CRC`: whether the side supports CRC.
fn crc_text(crc: bool) -> &'static str {
    if crc { ", CRC" } else { ", no CRC" }
}

fn size_text(f: &mut fmt::Formatter<'_>, size: Option<u32>) -> fmt::Result {
    match size {
        Some(n) => write!(f, ", {n} byte{}", plural(n)),
        None => f.write_str(", size not indicated"),
    }
}

fn abort_text(f: &mut fmt::Formatter<'_>, mux: Multiplexer, code: AbortCode) -> fmt::Result {
    write!(f, "SDO abort transfer {mux}: {code}")
}

fn block_end_text(f: &mut fmt::Formatter<'_>, what: &str, unused: u8, crc: u16) -> fmt::Result {
    write!(
        f,
        "SDO end block {what}, {unused} byte{} of the last segment unused, CRC {crc:#06x}",
        plural(u32::from(unused))
    )
}

impl fmt::Display for ClientRequest {
    /// `SDO initiate upload request 0x1018:01`, `SDO download segment request toggle 0, 7 bytes
    /// ...`, `SDO abort transfer 0x6000:01: 0x06020000 (Object does not exist ...)`, ...
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InitiateDownload { mux, data } => {
                write!(f, "SDO initiate download request {mux}, {data}")
            }
            Self::DownloadSegment(seg) => write!(f, "SDO download segment request {seg}"),
            Self::InitiateUpload { mux } => write!(f, "SDO initiate upload request {mux}"),
            Self::UploadSegment { toggle } => {
                write!(f, "SDO upload segment request toggle {}", u8::from(toggle))
            }
            Self::Abort { mux, code } => abort_text(f, mux, code),
            Self::BlockDownloadInitiate { mux, crc, size } => {
                write!(
                    f,
                    "SDO initiate block download request {mux}{}",
                    crc_text(crc)
                )?;
                size_text(f, size)
            }
            Self::BlockDownloadEnd { unused, crc } => {
                block_end_text(f, "download request", unused, crc)
            }
            Self::BlockUploadInitiate {
                mux,
                crc,
                blksize,
                pst,
            } => write!(
                f,
                "SDO initiate block upload request {mux}{}, blksize {blksize}, pst {pst}",
                crc_text(crc)
            ),
            Self::BlockUploadStart => f.write_str("SDO start block upload request"),
            Self::BlockUploadAck { ackseq, blksize } => write!(
                f,
                "SDO block upload response ackseq {ackseq}, blksize {blksize}"
            ),
            Self::BlockUploadEnd => f.write_str("SDO end block upload response"),
        }
    }
}

impl fmt::Display for ServerResponse {
    /// `SDO initiate upload response 0x1000:00, expedited, 4 bytes 91 01 02 00`,
    /// `SDO block download response ackseq 127, blksize 64`, ...
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InitiateUpload { mux, data } => {
                write!(f, "SDO initiate upload response {mux}, {data}")
            }
            Self::UploadSegment(seg) => write!(f, "SDO upload segment response {seg}"),
            Self::InitiateDownload { mux } => write!(f, "SDO initiate download response {mux}"),
            Self::DownloadSegment { toggle } => {
                write!(
                    f,
                    "SDO download segment response toggle {}",
                    u8::from(toggle)
                )
            }
            Self::Abort { mux, code } => abort_text(f, mux, code),
            Self::BlockDownloadInitiate { mux, crc, blksize } => write!(
                f,
                "SDO initiate block download response {mux}{}, blksize {blksize}",
                crc_text(crc)
            ),
            Self::BlockDownloadAck { ackseq, blksize } => write!(
                f,
                "SDO block download response ackseq {ackseq}, blksize {blksize}"
            ),
            Self::BlockDownloadEnd => f.write_str("SDO end block download response"),
            Self::BlockUploadInitiate { mux, crc, size } => {
                write!(
                    f,
                    "SDO initiate block upload response {mux}{}",
                    crc_text(crc)
                )?;
                size_text(f, size)
            }
            Self::BlockUploadEnd { unused, crc } => {
                block_end_text(f, "upload request", unused, crc)
            }
        }
    }
}

impl fmt::Display for BlockSegment {
    /// `SDO block segment 5, 01 02 03 04 05 06 07` (`, last` on the last one).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "SDO block segment {}, {}",
            self.seqno,
            HexBytes(&self.data)
        )?;
        if self.last {
            f.write_str(", last")?;
        }
        Ok(())
    }
}
