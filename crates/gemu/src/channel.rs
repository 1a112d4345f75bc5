//! The 8-byte parameter channel (manual 5.6 "Parameter data: Parameters / Actions / Errors").
//!
//! ```text
//! byte 0   toggle       change it to have the same request processed again
//! byte 1   instruction  'N' 'S' 'G' 'E' 'D' 'W' 'A' 'Q'
//! bytes 2..4 id         parameter ID / list position / action number, big-endian
//! bytes 4..8 value      v3 v2 v1 v0, big-endian
//! ```
//!
//! Two levels, as elsewhere in the workspace: [`Channel`] is the raw, lossless view of the eight
//! bytes (any byte sequence decodes, unknown instructions are kept); [`Request`] and [`Answer`]
//! give the bytes their meaning per instruction.
//!
//! The "action already active" answer (5.6.8) is `[tg, 'A', id_hi, id_lo, 0xFF, source,
//! number_hi, number_lo]`: the manual's table gives the field widths 1, 1, 2, 1, 1, 2 bytes, so the
//! value field splits into v3 = 0xFF (marker), v2 = source (1 keypad, 2 web interface
//! "e.sy-com", 3 fieldbus) and v1:v0 = the number of the active action (0 when the fieldbus does
//! not know the active action). The id echoes the action that was requested. No regular action
//! status has 0xFF in v3 (their high byte is 0x00..0x07 or 0x01 for "cannot be started"), so the
//! marker is unambiguous.
//!
//! External diagnostic codes (0x20, 0x21, 0x22, 0x34, 0x40, 0x42) are not part of the channel:
//! the device raises them through the fieldbus' own diagnostic service (DeviceNet/Profinet
//! diagnosis). [`DiagnosticCode`] types them; the client takes them through its own input.
//!
//! Ambiguities resolved here:
//! - 'D' and 'W' answers: the manual gives the 4-byte value as "number of active errors |
//!   value of active error". The "Pot Wrong Dir" example answers `0x00,0x01,0x00,0x14`
//!   (one active error, code 20) and the "Air missing" example `0x00,0x01,0x00,0x1E`, so the count
//!   is v3:v2 and the code is v1:v0.
//! - 'E' answer "error information": the manual gives no example; the error code is taken from
//!   v1:v0 (the error table gives codes as two bytes "0x00 0x14"), v3:v2 are kept raw.
//!   `0xFFFFFFFF` means "no such entry" (with diagnostic 0x34).
//! - Parameter values are signed where the table's range is signed (Pos Ctrl Out -1000..1000,
//!   4 mA/20 mA scaling -999..9999); the manual does not say how negative values are coded, so
//!   the 32-bit value is taken as two's complement.

use crate::action::{ActionId, ActionStatus, ErrorCode};
use core::fmt;

/// A channel instruction (byte 1). Open: unknown bytes are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Instruction {
    /// 'N' 0x4E: no operation; the answer is another NOP.
    #[default]
    Nop,
    /// 'S' 0x53: set a parameter; the answer echoes the new value.
    Set,
    /// 'G' 0x47: get a parameter; also used by the device for unsolicited change notices.
    Get,
    /// 'E' 0x45: read an error-list entry (id = position, 0 = current error).
    ErrorList,
    /// 'D' 0x44: number of active errors and the selected active error.
    ActiveErrors,
    /// 'W' 0x57: number of active warnings and the selected active warning.
    ActiveWarnings,
    /// 'A' 0x41: start or control an action.
    Action,
    /// 'Q' 0x51: quit all actions started over the fieldbus.
    Quit,
    /// Any other byte.
    Unknown(u8),
}

impl Instruction {
    /// From the wire byte (total).
    pub const fn from_byte(b: u8) -> Self {
        match b {
            b'N' => Self::Nop,
            b'S' => Self::Set,
            b'G' => Self::Get,
            b'E' => Self::ErrorList,
            b'D' => Self::ActiveErrors,
            b'W' => Self::ActiveWarnings,
            b'A' => Self::Action,
            b'Q' => Self::Quit,
            other => Self::Unknown(other),
        }
    }

    /// The wire byte.
    pub const fn to_byte(self) -> u8 {
        match self {
            Self::Nop => b'N',
            Self::Set => b'S',
            Self::Get => b'G',
            Self::ErrorList => b'E',
            Self::ActiveErrors => b'D',
            Self::ActiveWarnings => b'W',
            Self::Action => b'A',
            Self::Quit => b'Q',
            Self::Unknown(b) => b,
        }
    }

    /// Whether the manual asks for an 'N' after this query so it is processed only once.
    pub const fn needs_nop_after(self) -> bool {
        matches!(
            self,
            Self::ErrorList | Self::ActiveErrors | Self::ActiveWarnings
        )
    }
}

/// The raw eight channel bytes, decoded field by field. Lossless for any byte sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Channel {
    /// Byte 0: the toggle byte.
    pub toggle: u8,
    /// Byte 1: the instruction.
    pub instruction: Instruction,
    /// Bytes 2..4: parameter ID, list position or action number (big-endian).
    pub id: u16,
    /// Bytes 4..8: the value (big-endian).
    pub value: u32,
}

/// The channel bytes had the wrong length.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("parameter channel is {0} bytes, expected 8")]
pub struct ChannelLengthError(pub usize);

debug_as_display!(ChannelLengthError);

impl Channel {
    /// A channel with all fields given.
    pub const fn request(toggle: u8, instruction: Instruction, id: u16, value: u32) -> Self {
        Self {
            toggle,
            instruction,
            id,
            value,
        }
    }

    /// From exactly eight bytes (total).
    pub const fn from_bytes(b: [u8; 8]) -> Self {
        Self {
            toggle: b[0],
            instruction: Instruction::from_byte(b[1]),
            id: u16::from_be_bytes([b[2], b[3]]),
            value: u32::from_be_bytes([b[4], b[5], b[6], b[7]]),
        }
    }

    /// From a slice that must be eight bytes long. Never panics.
    pub fn parse(bytes: &[u8]) -> Result<Self, ChannelLengthError> {
        let b: [u8; 8] = bytes
            .try_into()
            .map_err(|_| ChannelLengthError(bytes.len()))?;
        Ok(Self::from_bytes(b))
    }

    /// The eight wire bytes.
    pub const fn to_bytes(&self) -> [u8; 8] {
        let id = self.id.to_be_bytes();
        let v = self.value.to_be_bytes();
        [
            self.toggle,
            self.instruction.to_byte(),
            id[0],
            id[1],
            v[0],
            v[1],
            v[2],
            v[3],
        ]
    }

    /// The value read as a signed 32-bit number (two's complement).
    pub const fn signed_value(&self) -> i32 {
        self.value as i32
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.to_bytes();
        write!(
            f,
            "[{:02X} {:02X} {:02X} {:02X} {:02X} {:02X} {:02X} {:02X}]",
            b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]
        )
    }
}

/// Who started the action that is already active (byte 5 of the 0xFF answer). Open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ActionSource {
    /// 0x01: the cPos keypad; acknowledge it on the device.
    Keypad,
    /// 0x02: the web interface (e.sy-com); close the active browser window.
    WebInterface,
    /// 0x03: the fieldbus; end it with 'Q' or select the action again and end it.
    Fieldbus,
    /// Any other byte.
    Unknown(u8),
}

impl ActionSource {
    /// From the wire byte (total).
    pub const fn from_byte(b: u8) -> Self {
        match b {
            1 => Self::Keypad,
            2 => Self::WebInterface,
            3 => Self::Fieldbus,
            other => Self::Unknown(other),
        }
    }

    /// The wire byte.
    pub const fn to_byte(self) -> u8 {
        match self {
            Self::Keypad => 1,
            Self::WebInterface => 2,
            Self::Fieldbus => 3,
            Self::Unknown(b) => b,
        }
    }
}

impl fmt::Display for ActionSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Keypad => f.write_str("keypad"),
            Self::WebInterface => f.write_str("web interface"),
            Self::Fieldbus => f.write_str("fieldbus"),
            Self::Unknown(b) => write!(f, "source 0x{b:02X}"),
        }
    }
}

/// The content of the "action already active" answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ActionBusy {
    /// Who started the active action.
    pub source: ActionSource,
    /// The active action's number; `ActionId::Unknown(0)` when the fieldbus does not know it.
    pub active: ActionId,
}

impl ActionBusy {
    /// The marker in v3.
    pub const MARKER: u8 = 0xFF;

    /// The 4-byte value field `[0xFF, source, number_hi, number_lo]`.
    pub const fn to_value(self) -> u32 {
        let n = self.active.to_u16().to_be_bytes();
        u32::from_be_bytes([Self::MARKER, self.source.to_byte(), n[0], n[1]])
    }

    /// From a value field, if v3 is the 0xFF marker.
    pub const fn from_value(value: u32) -> Option<Self> {
        let b = value.to_be_bytes();
        if b[0] != Self::MARKER {
            return None;
        }
        Some(Self {
            source: ActionSource::from_byte(b[1]),
            active: ActionId::from_u16(u16::from_be_bytes([b[2], b[3]])),
        })
    }
}

/// An external diagnostic code the cPos raises through the fieldbus' diagnostic service.
/// A newtype so unknown codes survive and still print.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DiagnosticCode(pub u8);

impl DiagnosticCode {
    /// 0x20: the value of an 'S' is below the parameter's range.
    pub const BELOW_RANGE: Self = Self(0x20);
    /// 0x21: the value of an 'S' is above the parameter's range.
    pub const ABOVE_RANGE: Self = Self(0x21);
    /// 0x22: no such parameter ('S' or 'G'); the value 0 is returned.
    pub const NO_SUCH_PARAMETER: Self = Self(0x22);
    /// 0x34: no error-list entry at the requested position; 0xFFFFFFFF is returned.
    pub const NO_SUCH_ERROR_ENTRY: Self = Self(0x34);
    /// 0x40: an action was requested while another one is active; the new one is ignored.
    pub const ACTION_ALREADY_ACTIVE: Self = Self(0x40);
    /// 0x42: NoInit was requested although the valve is already initialised.
    pub const NOINIT_ON_INITIALISED_VALVE: Self = Self(0x42);

    /// Every code the manual defines, with its meaning.
    pub const ALL: [(Self, &'static str); 6] = [
        (Self::BELOW_RANGE, "value below the valid range"),
        (Self::ABOVE_RANGE, "value above the valid range"),
        (Self::NO_SUCH_PARAMETER, "parameter does not exist"),
        (
            Self::NO_SUCH_ERROR_ENTRY,
            "no entry at this position of the error list",
        ),
        (
            Self::ACTION_ALREADY_ACTIVE,
            "another action is already active",
        ),
        (
            Self::NOINIT_ON_INITIALISED_VALVE,
            "NoInit refused: the valve is already initialised",
        ),
    ];

    /// The manual's meaning, if the code is known.
    pub fn meaning(self) -> Option<&'static str> {
        Self::ALL.iter().find(|(c, _)| *c == self).map(|(_, m)| *m)
    }
}

impl fmt::Display for DiagnosticCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.meaning() {
            Some(m) => write!(f, "diagnostic 0x{:02X}: {m}", self.0),
            None => write!(f, "diagnostic 0x{:02X}", self.0),
        }
    }
}

/// A request the master puts into the channel (without its toggle byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Request {
    /// 'N'.
    Nop,
    /// 'S' parameter `id` to `value` (raw 32-bit).
    Set {
        /// Parameter ID.
        id: u16,
        /// Raw value.
        value: u32,
    },
    /// 'G' parameter `id`.
    Get {
        /// Parameter ID.
        id: u16,
    },
    /// 'E' error-list entry at `position` (0 = current error).
    ErrorList {
        /// Position in the list.
        position: u16,
    },
    /// 'D' active error number `number` (the first is 1).
    ActiveErrors {
        /// Which active error.
        number: u16,
    },
    /// 'W' active warning number `number` (the first is 1).
    ActiveWarnings {
        /// Which active warning.
        number: u16,
    },
    /// 'A' action `action` with its function/parameter `value`.
    Action {
        /// The action.
        action: ActionId,
        /// The 4-byte function.
        value: u32,
    },
    /// 'Q' quit all fieldbus-started actions.
    Quit,
}

impl Request {
    /// The channel with the given toggle byte.
    pub const fn to_channel(self, toggle: u8) -> Channel {
        let (instruction, id, value) = match self {
            Self::Nop => (Instruction::Nop, 0, 0),
            Self::Set { id, value } => (Instruction::Set, id, value),
            Self::Get { id } => (Instruction::Get, id, 0),
            Self::ErrorList { position } => (Instruction::ErrorList, position, 0),
            Self::ActiveErrors { number } => (Instruction::ActiveErrors, number, 0),
            Self::ActiveWarnings { number } => (Instruction::ActiveWarnings, number, 0),
            Self::Action { action, value } => (Instruction::Action, action.to_u16(), value),
            Self::Quit => (Instruction::Quit, 0, 0),
        };
        Channel {
            toggle,
            instruction,
            id,
            value,
        }
    }

    /// The request a channel carries, or `None` for an unknown instruction. Fields the manual
    /// requires to be zero (the value of 'G', 'E', 'D', 'W'; everything of 'N' and 'Q') are
    /// ignored.
    pub const fn from_channel(ch: &Channel) -> Option<Self> {
        Some(match ch.instruction {
            Instruction::Nop => Self::Nop,
            Instruction::Set => Self::Set {
                id: ch.id,
                value: ch.value,
            },
            Instruction::Get => Self::Get { id: ch.id },
            Instruction::ErrorList => Self::ErrorList { position: ch.id },
            Instruction::ActiveErrors => Self::ActiveErrors { number: ch.id },
            Instruction::ActiveWarnings => Self::ActiveWarnings { number: ch.id },
            Instruction::Action => Self::Action {
                action: ActionId::from_u16(ch.id),
                value: ch.value,
            },
            Instruction::Quit => Self::Quit,
            Instruction::Unknown(_) => return None,
        })
    }

    /// The instruction of this request.
    pub const fn instruction(&self) -> Instruction {
        self.to_channel(0).instruction
    }
}

/// An 'E' answer's error information.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorEntry {
    /// An entry (code 0 = no error in the list).
    Entry(ErrorCode),
    /// 0xFFFFFFFF: no entry at this position (diagnostic 0x34).
    NoEntry,
    /// Any other value: v1:v0 is not a plain code (v3:v2 non-zero).
    Raw(u32),
}

impl ErrorEntry {
    /// From the 4-byte value (total).
    pub const fn from_value(v: u32) -> Self {
        if v == u32::MAX {
            Self::NoEntry
        } else if v >> 16 == 0 {
            Self::Entry(ErrorCode(v as u16))
        } else {
            Self::Raw(v)
        }
    }

    /// The 4-byte value.
    pub const fn to_value(self) -> u32 {
        match self {
            Self::Entry(c) => c.0 as u32,
            Self::NoEntry => u32::MAX,
            Self::Raw(v) => v,
        }
    }
}

/// What a 'D' or 'W' answer says: how many are active and which one was selected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ActiveList {
    /// Number of active errors (warnings), v3:v2.
    pub count: u16,
    /// The selected one's code, v1:v0.
    pub code: ErrorCode,
}

impl ActiveList {
    /// From the 4-byte value (total).
    pub const fn from_value(v: u32) -> Self {
        Self {
            count: (v >> 16) as u16,
            code: ErrorCode(v as u16),
        }
    }

    /// The 4-byte value.
    pub const fn to_value(self) -> u32 {
        (self.count as u32) << 16 | self.code.0 as u32
    }
}

/// An answer the device puts into the channel (without its toggle byte), typed per instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Answer {
    /// 'N'.
    Nop,
    /// 'S': the parameter's value after the set (0 if the parameter does not exist).
    Set {
        /// Parameter ID.
        id: u16,
        /// Raw value.
        value: u32,
    },
    /// 'G': the parameter's value; also an unsolicited change notice.
    Get {
        /// Parameter ID.
        id: u16,
        /// Raw value.
        value: u32,
    },
    /// 'E': error-list entry.
    ErrorList {
        /// Position asked for.
        position: u16,
        /// The entry.
        entry: ErrorEntry,
    },
    /// 'D': active errors.
    ActiveErrors {
        /// Which active error was selected.
        number: u16,
        /// Count and code.
        list: ActiveList,
    },
    /// 'W': active warnings.
    ActiveWarnings {
        /// Which active warning was selected.
        number: u16,
        /// Count and code.
        list: ActiveList,
    },
    /// 'A': the action's status.
    Action {
        /// The action.
        action: ActionId,
        /// Its status.
        status: ActionStatus,
    },
    /// 'A' with 0xFF in v3: another action is already active.
    ActionBusy {
        /// The action that was requested.
        action: ActionId,
        /// Who runs which action.
        busy: ActionBusy,
    },
    /// 'Q'.
    Quit,
    /// An instruction this crate does not know, or an 'N'/'Q' whose id and value are not zero;
    /// the raw channel is kept.
    Unknown(Channel),
}

impl Answer {
    /// Gives a channel its meaning (total).
    pub fn from_channel(ch: &Channel) -> Self {
        match ch.instruction {
            Instruction::Nop | Instruction::Quit if ch.id != 0 || ch.value != 0 => {
                Self::Unknown(*ch)
            }
            Instruction::Nop => Self::Nop,
            Instruction::Set => Self::Set {
                id: ch.id,
                value: ch.value,
            },
            Instruction::Get => Self::Get {
                id: ch.id,
                value: ch.value,
            },
            Instruction::ErrorList => Self::ErrorList {
                position: ch.id,
                entry: ErrorEntry::from_value(ch.value),
            },
            Instruction::ActiveErrors => Self::ActiveErrors {
                number: ch.id,
                list: ActiveList::from_value(ch.value),
            },
            Instruction::ActiveWarnings => Self::ActiveWarnings {
                number: ch.id,
                list: ActiveList::from_value(ch.value),
            },
            Instruction::Action => {
                let action = ActionId::from_u16(ch.id);
                match ActionBusy::from_value(ch.value) {
                    Some(busy) => Self::ActionBusy { action, busy },
                    None => Self::Action {
                        action,
                        status: ActionStatus::decode(action, ch.value),
                    },
                }
            }
            Instruction::Quit => Self::Quit,
            Instruction::Unknown(_) => Self::Unknown(*ch),
        }
    }

    /// The channel carrying this answer with the given toggle byte.
    pub fn to_channel(&self, toggle: u8) -> Channel {
        let (instruction, id, value) = match *self {
            Self::Nop => (Instruction::Nop, 0, 0),
            Self::Set { id, value } => (Instruction::Set, id, value),
            Self::Get { id, value } => (Instruction::Get, id, value),
            Self::ErrorList { position, entry } => {
                (Instruction::ErrorList, position, entry.to_value())
            }
            Self::ActiveErrors { number, list } => {
                (Instruction::ActiveErrors, number, list.to_value())
            }
            Self::ActiveWarnings { number, list } => {
                (Instruction::ActiveWarnings, number, list.to_value())
            }
            Self::Action { action, status } => {
                (Instruction::Action, action.to_u16(), status.to_value())
            }
            Self::ActionBusy { action, busy } => {
                (Instruction::Action, action.to_u16(), busy.to_value())
            }
            Self::Quit => (Instruction::Quit, 0, 0),
            Self::Unknown(ch) => return Channel { toggle, ..ch },
        };
        Channel {
            toggle,
            instruction,
            id,
            value,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::{InitValveStatus, NoInitFunction};
    use proptest::prelude::*;

    #[test]
    fn instruction_letters() {
        let all = [
            (Instruction::Nop, 0x4E),
            (Instruction::Set, 0x53),
            (Instruction::Get, 0x47),
            (Instruction::ErrorList, 0x45),
            (Instruction::ActiveErrors, 0x44),
            (Instruction::ActiveWarnings, 0x57),
            (Instruction::Action, 0x41),
            (Instruction::Quit, 0x51),
        ];
        for (i, b) in all {
            assert_eq!(i.to_byte(), b);
            assert_eq!(Instruction::from_byte(b), i);
        }
        assert_eq!(Instruction::from_byte(0x00), Instruction::Unknown(0));
        assert!(Instruction::ErrorList.needs_nop_after());
        assert!(Instruction::ActiveErrors.needs_nop_after());
        assert!(Instruction::ActiveWarnings.needs_nop_after());
        assert!(!Instruction::Get.needs_nop_after());
    }

    /// 5.6.1: NOP request and answer are `[YY, 0x4E, 0, 0, 0, 0, 0, 0]`.
    #[test]
    fn manual_nop() {
        for tg in [0x00, 0x5A] {
            let bytes = [tg, 0x4E, 0, 0, 0, 0, 0, 0];
            assert_eq!(Request::Nop.to_channel(tg).to_bytes(), bytes);
            assert_eq!(
                Answer::from_channel(&Channel::from_bytes(bytes)),
                Answer::Nop
            );
        }
    }

    /// 5.6.2 example: set Mode to Manual = `[YY, 0x53, 0x00, 0x64, 0x00, 0x00, 0x00, 0x02]`;
    /// the answer is the same SET with the new value.
    #[test]
    fn manual_set_mode_manual() {
        let ch = Request::Set {
            id: 0x0064,
            value: 2,
        }
        .to_channel(0x11);
        assert_eq!(
            ch.to_bytes(),
            [0x11, 0x53, 0x00, 0x64, 0x00, 0x00, 0x00, 0x02]
        );
        assert_eq!(
            Answer::from_channel(&ch),
            Answer::Set { id: 100, value: 2 },
            "the answer echoes the request"
        );
    }

    /// 5.6.3: GET request `[YY, 0x47, id, 0, 0, 0, 0]`.
    #[test]
    fn manual_get() {
        let ch = Request::Get { id: 0x03E8 }.to_channel(1);
        assert_eq!(ch.to_bytes(), [0x01, 0x47, 0x03, 0xE8, 0, 0, 0, 0]);
    }

    /// 5.6.5 example "Pot Wrong Dir": request `[0x00, 0x44, 0x00, 0x01, 0, 0, 0, 0]`,
    /// answer `[0x00, 0x44, 0x00, 0x01, 0x00, 0x01, 0x00, 0x14]`.
    #[test]
    fn manual_pot_wrong_dir() {
        let req = Request::ActiveErrors { number: 1 }.to_channel(0);
        assert_eq!(
            req.to_bytes(),
            [0x00, 0x44, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00]
        );
        let ans = Channel::from_bytes([0x00, 0x44, 0x00, 0x01, 0x00, 0x01, 0x00, 0x14]);
        let typed = Answer::from_channel(&ans);
        assert_eq!(
            typed,
            Answer::ActiveErrors {
                number: 1,
                list: ActiveList {
                    count: 1,
                    code: ErrorCode::POT_WRONG_DIR
                }
            }
        );
        assert_eq!(typed.to_channel(0), ans);
    }

    /// 5.6.6 example "Air missing": request `[0x00, 0x57, 0x00, 0x01, 0, 0, 0, 0]`,
    /// answer `[0x00, 0x57, 0x00, 0x01, 0x00, 0x01, 0x00, 0x1E]`.
    #[test]
    fn manual_air_missing() {
        let req = Request::ActiveWarnings { number: 1 }.to_channel(0);
        assert_eq!(
            req.to_bytes(),
            [0x00, 0x57, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00]
        );
        let ans = Channel::from_bytes([0x00, 0x57, 0x00, 0x01, 0x00, 0x01, 0x00, 0x1E]);
        let typed = Answer::from_channel(&ans);
        assert_eq!(
            typed,
            Answer::ActiveWarnings {
                number: 1,
                list: ActiveList {
                    count: 1,
                    code: ErrorCode::AIR_MISSING
                }
            }
        );
        assert_eq!(typed.to_channel(0), ans);
    }

    /// 5.6.4: 'E' request; "no entry" answers 0xFF 0xFF 0xFF 0xFF; "no error" 0x00000000.
    #[test]
    fn manual_error_list() {
        let req = Request::ErrorList { position: 0 }.to_channel(3);
        assert_eq!(req.to_bytes(), [0x03, 0x45, 0, 0, 0, 0, 0, 0]);
        let none = Channel::from_bytes([3, 0x45, 0, 5, 0xFF, 0xFF, 0xFF, 0xFF]);
        assert_eq!(
            Answer::from_channel(&none),
            Answer::ErrorList {
                position: 5,
                entry: ErrorEntry::NoEntry
            }
        );
        let empty = Channel::from_bytes([3, 0x45, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            Answer::from_channel(&empty),
            Answer::ErrorList {
                position: 0,
                entry: ErrorEntry::Entry(ErrorCode::NONE)
            }
        );
    }

    /// 5.6.8: the "action already active" answer `[YY, 'A', id, 0xFF, source, number]`.
    #[test]
    fn manual_action_busy() {
        let ch = Channel::from_bytes([0x09, 0x41, 0x00, 0x05, 0xFF, 0x03, 0x00, 0x04]);
        let a = Answer::from_channel(&ch);
        assert_eq!(
            a,
            Answer::ActionBusy {
                action: ActionId::GoClose,
                busy: ActionBusy {
                    source: ActionSource::Fieldbus,
                    active: ActionId::InitValve
                }
            }
        );
        assert_eq!(a.to_channel(0x09), ch);
        for (b, s) in [
            (1, ActionSource::Keypad),
            (2, ActionSource::WebInterface),
            (3, ActionSource::Fieldbus),
            (9, ActionSource::Unknown(9)),
        ] {
            assert_eq!(ActionSource::from_byte(b), s);
            assert_eq!(s.to_byte(), b);
        }
        // An action unknown to the fieldbus is reported as number 0.
        let unknown = ActionBusy::from_value(0xFF01_0000).unwrap();
        assert_eq!(unknown.active, ActionId::Unknown(0));
        assert_eq!(unknown.source, ActionSource::Keypad);
    }

    /// 5.6.9: 'Q' request and answer `[YY, 0x51, 0, 0, 0, 0, 0, 0]`.
    #[test]
    fn manual_quit() {
        assert_eq!(
            Request::Quit.to_channel(0x20).to_bytes(),
            [0x20, 0x51, 0, 0, 0, 0, 0, 0]
        );
        assert_eq!(
            Answer::from_channel(&Channel::from_bytes([0x20, 0x51, 0, 0, 0, 0, 0, 0])),
            Answer::Quit
        );
    }

    #[test]
    fn action_status_answers() {
        let ch = Channel::from_bytes([0, 0x41, 0, 4, 0, 0, 0x16, 0xFE]);
        assert_eq!(
            Answer::from_channel(&ch),
            Answer::Action {
                action: ActionId::InitValve,
                status: ActionStatus::InitValve(InitValveStatus::ErrorActive(ErrorCode::PNEUMATIC))
            }
        );
        let ch = Channel::from_bytes([0, 0x41, 0, 1, 0x05, 0, 0x01, 0xF4]);
        assert!(matches!(
            Answer::from_channel(&ch),
            Answer::Action { status: ActionStatus::NoInit(NoInitFunction::OpenPwm(p)), .. } if p.get() == 500
        ));
    }

    #[test]
    fn diagnostic_codes() {
        let codes: [u8; 6] = [0x20, 0x21, 0x22, 0x34, 0x40, 0x42];
        for (i, (c, m)) in DiagnosticCode::ALL.iter().enumerate() {
            assert_eq!(c.0, codes[i]);
            assert!(!m.is_empty());
        }
        assert_eq!(DiagnosticCode(0x99).meaning(), None);
    }

    #[test]
    fn channel_parse_length() {
        assert_eq!(Channel::parse(&[0; 7]), Err(ChannelLengthError(7)));
        assert!(Channel::parse(&[0; 8]).is_ok());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn channel_round_trip(b in any::<[u8; 8]>()) {
            let ch = Channel::from_bytes(b);
            prop_assert_eq!(ch.to_bytes(), b);
            prop_assert_eq!(Channel::parse(&b), Ok(ch));
        }

        #[test]
        fn answer_round_trip(b in any::<[u8; 8]>()) {
            let ch = Channel::from_bytes(b);
            let a = Answer::from_channel(&ch);
            prop_assert_eq!(a.to_channel(ch.toggle), ch);
        }

        #[test]
        fn request_round_trip(tg in any::<u8>(), i in 0usize..8, id in any::<u16>(), v in any::<u32>()) {
            let r = match i {
                0 => Request::Nop,
                1 => Request::Set { id, value: v },
                2 => Request::Get { id },
                3 => Request::ErrorList { position: id },
                4 => Request::ActiveErrors { number: id },
                5 => Request::ActiveWarnings { number: id },
                6 => Request::Action { action: ActionId::from_u16(id), value: v },
                _ => Request::Quit,
            };
            let ch = r.to_channel(tg);
            prop_assert_eq!(ch.toggle, tg);
            prop_assert_eq!(Request::from_channel(&Channel::from_bytes(ch.to_bytes())), Some(r));
        }
    }
}
