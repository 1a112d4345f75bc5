//! Host-to-adapter commands (the Lawicel command set plus the CAN FD extensions of the CANable 2
//! firmwares): one line each, ended by CR.
//!
//! [`Command::encode`] writes what a host sends; [`Command::parse`] reads it back, which is what an
//! adapter (or a test double of one) does.

use crate::bitrate::{Btr, DataBitrate, NominalBitrate, TimestampMode};
use crate::error::{EncodeError, LineError};
use crate::frame::{self, Frame};
use crate::hex::{self, Writer};

/// One command line from host to adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Command {
    /// `O`: open the channel in normal mode.
    Open,
    /// `L`: open the channel listen-only (Lawicel, the kernel, python-can; CANable's official
    /// firmware has no `L`).
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `Sn`: the nominal bit rate; only while the channel is closed.
    Bitrate(NominalBitrate),
    /// `sxxyy`: SJA1000 bus timing registers.
    Btr(Btr),
    /// `Yn`: the CAN FD data bit rate.
    DataBitrate(DataBitrate),
    /// `Zn`: timestamps on received frames.
    Timestamps(TimestampMode),
    /// `V`: hardware and software version.
    Version,
    /// `N`: serial number.
    Serial,
    /// `F`: read and clear the status flags.
    Status,
    /// A frame line: transmit this frame.
    Transmit(Frame),
}

impl Command {
    /// The encoded length, CR included.
    pub fn encoded_len(&self) -> usize {
        match self {
            Self::Open | Self::ListenOnly | Self::Close => 2,
            Self::Version | Self::Serial | Self::Status => 2,
            Self::Bitrate(_) | Self::DataBitrate(_) | Self::Timestamps(_) => 3,
            Self::Btr(_) => 6,
            Self::Transmit(f) => frame::line_len(f) + 1,
        }
    }

    /// Writes the command line, CR included, into `out`; returns its length (at most
    /// [`MAX_COMMAND`](crate::MAX_COMMAND)). Hex digits are upper case, as the kernel driver and
    /// python-can send them.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let mut w = Writer::new(out, self.encoded_len())?;
        match self {
            Self::Open => w.byte(b'O'),
            Self::ListenOnly => w.byte(b'L'),
            Self::Close => w.byte(b'C'),
            Self::Version => w.byte(b'V'),
            Self::Serial => w.byte(b'N'),
            Self::Status => w.byte(b'F'),
            Self::Bitrate(b) => {
                w.byte(b'S');
                w.byte(b'0' + b.code());
            }
            Self::DataBitrate(b) => {
                w.byte(b'Y');
                w.byte(b'0' + b.code());
            }
            Self::Timestamps(m) => {
                w.byte(b'Z');
                w.byte(b'0' + m.code());
            }
            Self::Btr(btr) => {
                w.byte(b's');
                w.hex(u32::from(btr.btr0), 2);
                w.hex(u32::from(btr.btr1), 2);
            }
            Self::Transmit(f) => frame::write_frame(&mut w, f),
        }
        w.byte(crate::CR);
        Ok(w.finish())
    }

    /// Parses one command line without its CR. Never panics; anything that is not one of the
    /// commands above is a [`LineError`].
    pub fn parse(line: &[u8]) -> Result<Self, LineError> {
        let (&letter, args) = line.split_first().ok_or(LineError::Empty)?;
        if let Some(&b) = line.iter().find(|&&b| !(0x20..0x7F).contains(&b)) {
            return Err(LineError::BadByte(b));
        }
        if frame::is_frame_letter(letter) {
            let (f, rest) = frame::parse_frame(line)?;
            if !rest.is_empty() {
                return Err(LineError::TrailingCharacters);
            }
            return Ok(Self::Transmit(f));
        }
        let digit = |args: &[u8]| -> Result<u8, LineError> {
            match args {
                [d @ b'0'..=b'9'] => Ok(d - b'0'),
                [d] => Err(LineError::BadArgument(*d)),
                [] => Err(LineError::Truncated),
                _ => Err(LineError::TrailingCharacters),
            }
        };
        let none = |cmd: Self| {
            if args.is_empty() {
                Ok(cmd)
            } else {
                Err(LineError::TrailingCharacters)
            }
        };
        match letter {
            b'O' => none(Self::Open),
            b'L' => none(Self::ListenOnly),
            b'C' => none(Self::Close),
            b'V' => none(Self::Version),
            b'N' => none(Self::Serial),
            b'F' => none(Self::Status),
            b'S' => {
                let n = digit(args)?;
                NominalBitrate::from_code(n)
                    .map(Self::Bitrate)
                    .ok_or(LineError::BadArgument(args[0]))
            }
            b'Y' => {
                let n = digit(args)?;
                DataBitrate::from_code(n)
                    .map(Self::DataBitrate)
                    .ok_or(LineError::BadArgument(args[0]))
            }
            b'Z' => {
                let n = digit(args)?;
                TimestampMode::from_code(n)
                    .map(Self::Timestamps)
                    .ok_or(LineError::BadArgument(args[0]))
            }
            b's' => match args.len() {
                4 => Ok(Self::Btr(Btr {
                    btr0: hex::number(&args[..2])? as u8,
                    btr1: hex::number(&args[2..])? as u8,
                })),
                n if n < 4 => Err(LineError::Truncated),
                _ => Err(LineError::TrailingCharacters),
            },
            other => Err(LineError::UnknownCommand(other)),
        }
    }
}
