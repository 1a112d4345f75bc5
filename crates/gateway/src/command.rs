//! The typed requests, responses and event lines of the CiA 309-3 ASCII mapping, and the
//! formatter from each back to its line (the parser is [`crate::parse`]).
//!
//! A request line is `[seq] [[net] node] command args` (node-level commands: SDO, NMT),
//! `[seq] [net] command args` (network-level: `set`, LSS) or `[seq] command` (gateway-level:
//! `help`, `info version`). The formatter writes the canonical spelling (`read`, `write`,
//! `preoperational`, `reset communication`, indices as `0x` and four hex digits); the parser
//! also takes the abbreviations and any letter case. Responses and events end with CR LF
//! (the inner lines of a multi-line reply with LF alone).

use core::fmt;

use crate::value::{DataType, Value};

/// One request line.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// The sequence number in brackets, echoed in the response.
    pub seq: Option<u32>,
    /// The network number before the node-ID (or alone before a network-level command).
    pub net: Option<u16>,
    /// The node-ID (node-level commands only).
    pub node: Option<u8>,
    /// What to do.
    pub command: Command,
}

/// The NMT module control services (CiA 301 §7.2.8.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtService {
    /// `start`
    Start,
    /// `stop`
    Stop,
    /// `preop[erational]`
    PreOperational,
    /// `reset node`
    ResetNode,
    /// `reset comm[unication]`
    ResetCommunication,
}

/// What `help` prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HelpTopic {
    /// `help datatype`
    DataType,
    /// `help lss`
    Lss,
}

/// How `lss_allnodes` treats one part of the LSS address (CANopenNode's scan types).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanType {
    /// 0: find the value by Fastscan.
    Scan,
    /// 1: ignore the part.
    Ignore,
    /// 2: the part must match the given value.
    Match,
}

impl ScanType {
    /// The number on the line.
    pub const fn code(self) -> u8 {
        match self {
            Self::Scan => 0,
            Self::Ignore => 1,
            Self::Match => 2,
        }
    }

    /// The scan type for a number on the line.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Scan),
            1 => Some(Self::Ignore),
            2 => Some(Self::Match),
            _ => None,
        }
    }
}

/// The optional arguments of `lss_allnodes`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AllNodes {
    /// LSS response timeout in milliseconds.
    pub timeout_ms: u16,
    /// First node-ID to give and whether to store it, with the optional scan of the address.
    pub assign: Option<AllNodesAssign>,
}

/// `<nodeStart> <store> [<scanType> <value>]×4` of `lss_allnodes`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AllNodesAssign {
    /// The first node-ID given.
    pub node_start: u8,
    /// Store the configuration in each slave.
    pub store: bool,
    /// Per address part (vendor-ID, product code, revision, serial): scan type and value.
    pub scan: Option<[(ScanType, u32); 4]>,
}

/// A command of the gateway.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Command {
    /// `r[ead] index sub [type]`: SDO upload.
    Read {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The type to show the value as (else the node's dictionary, else `hex`).
        data_type: Option<DataType>,
    },
    /// `w[rite] index sub type value`: SDO download.
    Write {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The typed value.
        value: Value,
    },
    /// NMT module control of the node (node 0: all nodes).
    Nmt(NmtService),
    /// `set network <n>`: the default network.
    SetNetwork(u16),
    /// `set node <n>`: the default node.
    SetNode(u8),
    /// `set sdo_timeout <ms>`.
    SetSdoTimeout(u32),
    /// `set sdo_block 0|1`.
    SetSdoBlock(bool),
    /// `lss_switch_glob 0|1`: switch state global (1: configuration state).
    LssSwitchGlobal(bool),
    /// `lss_switch_sel vendor product revision serial`: switch state selective.
    LssSwitchSelective([u32; 4]),
    /// `lss_set_node <node>`: configure node-ID.
    LssSetNode(u8),
    /// `lss_conf_bitrate <table> <index>`: configure bit timing.
    LssConfBitrate {
        /// Table selector (0: the CiA table).
        table: u8,
        /// Index in the table.
        index: u8,
    },
    /// `lss_activate_bitrate <delay_ms>`.
    LssActivateBitrate(u16),
    /// `lss_store`: store configuration.
    LssStore,
    /// `lss_inquire_addr [0..3]`: one part of the address, or all four.
    LssInquireAddr(Option<u8>),
    /// `lss_get_node`: inquire node-ID.
    LssGetNode,
    /// `_lss_fastscan [timeout_ms]` (non-standard, CANopenNode).
    LssFastscan(Option<u16>),
    /// `lss_allnodes [...]`: Fastscan every unconfigured slave and give each a node-ID.
    LssAllNodes(Option<AllNodes>),
    /// `help [datatype|lss]`.
    Help(Option<HelpTopic>),
    /// `info version`.
    InfoVersion,
    /// `_events 0|1` (non-standard): unsolicited event lines on this connection.
    Events(bool),
}

/// Which prefix numbers a command takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Level {
    /// `[[net] node]`
    Node,
    /// `[net]`
    Network,
    /// none
    Gateway,
}

impl Command {
    pub(crate) fn level(&self) -> Level {
        match self {
            Self::Read { .. } | Self::Write { .. } | Self::Nmt(_) => Level::Node,
            Self::Help(_) | Self::InfoVersion | Self::Events(_) => Level::Gateway,
            _ => Level::Network,
        }
    }
}

fn bit(b: bool) -> u8 {
    u8::from(b)
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Read {
                index,
                sub,
                data_type,
            } => {
                write!(f, "read 0x{index:04X} {sub}")?;
                if let Some(t) = data_type {
                    write!(f, " {t}")?;
                }
                Ok(())
            }
            Self::Write { index, sub, value } => {
                write!(f, "write 0x{index:04X} {sub} {}", value.data_type())?;
                let text = value.to_string();
                if !text.is_empty() {
                    write!(f, " {text}")?;
                }
                Ok(())
            }
            Self::Nmt(s) => f.write_str(match s {
                NmtService::Start => "start",
                NmtService::Stop => "stop",
                NmtService::PreOperational => "preoperational",
                NmtService::ResetNode => "reset node",
                NmtService::ResetCommunication => "reset communication",
            }),
            Self::SetNetwork(n) => write!(f, "set network {n}"),
            Self::SetNode(n) => write!(f, "set node {n}"),
            Self::SetSdoTimeout(ms) => write!(f, "set sdo_timeout {ms}"),
            Self::SetSdoBlock(b) => write!(f, "set sdo_block {}", bit(*b)),
            Self::LssSwitchGlobal(b) => write!(f, "lss_switch_glob {}", bit(*b)),
            Self::LssSwitchSelective([v, p, r, s]) => {
                write!(f, "lss_switch_sel 0x{v:08X} 0x{p:08X} 0x{r:08X} 0x{s:08X}")
            }
            Self::LssSetNode(n) => write!(f, "lss_set_node {n}"),
            Self::LssConfBitrate { table, index } => write!(f, "lss_conf_bitrate {table} {index}"),
            Self::LssActivateBitrate(ms) => write!(f, "lss_activate_bitrate {ms}"),
            Self::LssStore => f.write_str("lss_store"),
            Self::LssInquireAddr(None) => f.write_str("lss_inquire_addr"),
            Self::LssInquireAddr(Some(p)) => write!(f, "lss_inquire_addr {p}"),
            Self::LssGetNode => f.write_str("lss_get_node"),
            Self::LssFastscan(None) => f.write_str("_lss_fastscan"),
            Self::LssFastscan(Some(ms)) => write!(f, "_lss_fastscan {ms}"),
            Self::LssAllNodes(a) => {
                f.write_str("lss_allnodes")?;
                if let Some(a) = a {
                    write!(f, " {}", a.timeout_ms)?;
                    if let Some(asg) = &a.assign {
                        write!(f, " {} {}", asg.node_start, bit(asg.store))?;
                        if let Some(scan) = &asg.scan {
                            for (t, v) in scan {
                                write!(f, " {} 0x{v:08X}", t.code())?;
                            }
                        }
                    }
                }
                Ok(())
            }
            Self::Help(None) => f.write_str("help"),
            Self::Help(Some(HelpTopic::DataType)) => f.write_str("help datatype"),
            Self::Help(Some(HelpTopic::Lss)) => f.write_str("help lss"),
            Self::InfoVersion => f.write_str("info version"),
            Self::Events(b) => write!(f, "_events {}", bit(*b)),
        }
    }
}

impl fmt::Display for Request {
    /// The request line without its line end.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(seq) = self.seq {
            write!(f, "[{seq}] ")?;
        }
        if let Some(net) = self.net {
            write!(f, "{net} ")?;
        }
        if let Some(node) = self.node {
            write!(f, "{node} ")?;
        }
        write!(f, "{}", self.command)
    }
}

/// A gateway error code of CiA 309-3 (`ERROR:<code>`). Open: unknown codes still print.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ErrorCode(pub u16);

macro_rules! error_codes {
    ($($name:ident = $value:literal, $text:literal;)*) => {
        impl ErrorCode {
            $(
                #[doc = concat!($value, ": ", $text, ".")]
                pub const $name: Self = Self($value);
            )*

            /// The standard's meaning of the code, if it names one.
            pub fn description(self) -> Option<&'static str> {
                match self.0 {
                    $($value => Some($text),)*
                    _ => None,
                }
            }
        }
    };
}

error_codes! {
    REQUEST_NOT_SUPPORTED = 100, "Request not supported";
    SYNTAX = 101, "Syntax error";
    INTERNAL_STATE = 102, "Request not processed due to internal state";
    TIMEOUT = 103, "Time-out";
    NO_DEFAULT_NET = 104, "No default net set";
    NO_DEFAULT_NODE = 105, "No default node set";
    UNSUPPORTED_NET = 106, "Unsupported net";
    UNSUPPORTED_NODE = 107, "Unsupported node";
    LOST_GUARDING = 200, "Lost guarding message";
    LOST_CONNECTION = 201, "Lost connection";
    HEARTBEAT_STARTED = 202, "Heartbeat started";
    HEARTBEAT_LOST = 203, "Heartbeat lost";
    WRONG_NMT_STATE = 204, "Wrong NMT state";
    BOOT_UP = 205, "Boot-up";
    ERROR_PASSIVE = 300, "Error passive";
    BUS_OFF = 301, "Bus off";
    CAN_BUFFER_OVERFLOW = 303, "CAN buffer overflow";
    CAN_INIT = 304, "CAN init";
    CAN_ACTIVE = 305, "CAN active (at init or start-up)";
    PDO_ALREADY_USED = 400, "PDO already used";
    PDO_LENGTH_EXCEEDED = 401, "PDO length exceeded";
    LSS_MANUFACTURER = 501, "LSS implementation- / manufacturer-specific error";
    LSS_NODE_ID_NOT_SUPPORTED = 502, "LSS node-ID not supported";
    LSS_BIT_RATE_NOT_SUPPORTED = 503, "LSS bit-rate not supported";
    LSS_STORE_FAILED = 504, "LSS parameter storing failed";
    LSS_MEDIA_ERROR = 505, "LSS command failed because of media error";
    OUT_OF_MEMORY = 600, "Running out of memory";
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The body of a response line.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// `OK`
    Ok,
    /// A value or other result text (`500`, `"name"`, `0x00000360 ...`).
    Text(String),
    /// `ERROR:0x........`: an SDO abort code.
    Abort(u32),
    /// `ERROR:<code>`: a gateway error code.
    Error(ErrorCode),
    /// Lines of text (help, the `lss_allnodes` report), then `OK`. Each of these lines ends in
    /// LF alone and the `OK` line in CR LF, so the whole reply is one response ending in CR
    /// LF, as CANopenNode's gateway writes its multi-line replies.
    Lines(Vec<String>),
}

/// One response: the sequence number and what happened.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// The request's sequence number.
    pub seq: Option<u32>,
    /// The result.
    pub reply: Reply,
}

impl Response {
    /// Appends the response lines, each ending in CR LF, to `out`.
    pub fn write_to(&self, out: &mut String) {
        use fmt::Write as _;
        let prefix = |out: &mut String| {
            if let Some(seq) = self.seq {
                let _ = write!(out, "[{seq}] ");
            }
        };
        if let Reply::Lines(lines) = &self.reply {
            for l in lines {
                out.push_str(l);
                out.push('\n');
            }
        }
        prefix(out);
        let _ = match &self.reply {
            Reply::Ok | Reply::Lines(_) => write!(out, "OK"),
            Reply::Text(t) => write!(out, "{t}"),
            Reply::Abort(code) => write!(out, "ERROR:0x{code:08X}"),
            Reply::Error(code) => write!(out, "ERROR:{code}"),
        };
        out.push_str("\r\n");
    }

    /// The response as text (CR LF line ends).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        self.write_to(&mut s);
        s
    }
}

/// What an unsolicited event line reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventKind {
    /// `BOOT_UP`: the node sent its boot-up message.
    BootUp,
    /// `ERROR <code> (<text>)`: an error control event (heartbeat lost 203, heartbeat
    /// started 202, guarding lost 200, ...), with the code's text as Lely's gateway writes it.
    Error(ErrorCode),
    /// `EMCY <code> <register> <5 bytes>`: an emergency message.
    Emcy {
        /// Emergency error code.
        code: u16,
        /// Error register.
        register: u8,
        /// Manufacturer-specific error field.
        manufacturer: [u8; 5],
    },
}

/// An unsolicited event line: `<net> <node> ...`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Event {
    /// The network.
    pub net: u16,
    /// The node.
    pub node: u8,
    /// What happened.
    pub kind: EventKind,
}

impl fmt::Display for Event {
    /// The event line without its line end.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} ", self.net, self.node)?;
        match self.kind {
            EventKind::BootUp => f.write_str("BOOT_UP"),
            EventKind::Error(code) => {
                write!(f, "ERROR {code}")?;
                match code.description() {
                    Some(text) => write!(f, " ({text})"),
                    None => Ok(()),
                }
            }
            EventKind::Emcy {
                code,
                register,
                manufacturer: m,
            } => write!(
                f,
                "EMCY {code:04X} {register:02X} {} {} {} {} {}",
                m[0], m[1], m[2], m[3], m[4]
            ),
        }
    }
}
