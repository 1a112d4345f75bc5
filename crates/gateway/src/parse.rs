//! The request line parser (nom): one line of text to a typed [`Request`].
//!
//! Grammar (CiA 309-3 as CANopenNode implements it; `#` starts a comment at the start of the
//! line or after whitespace; blanks are spaces or tabs; a line may end in CR LF, LF or CR):
//!
//! ```text
//! line    = blank* [ "[" seq "]" ] blank* [ num blank+ [ num blank+ ] ] command blank* [ comment ]
//! command = ("r" | "read") index sub [ type ]
//!         | ("w" | "write") index sub type [ value ]
//!         | "start" | "stop" | "preop" | "preoperational"
//!         | "reset" ("node" | "comm" | "communication")
//!         | "set" ("network" | "node" | "sdo_timeout" | "sdo_block") num
//!         | "lss_switch_glob" num | "lss_switch_sel" num num num num | "lss_set_node" num
//!         | "lss_conf_bitrate" num num | "lss_activate_bitrate" num | "lss_store"
//!         | "lss_inquire_addr" [ num ] | "lss_get_node" | "_lss_fastscan" [ num ]
//!         | "lss_allnodes" [ num [ num num [ (num num){4} ] ] ]
//!         | "help" [ "datatype" | "lss" ] | "info" "version" | "_events" num
//! num     = decimal | "0x" hex
//! ```
//!
//! Numbers before a node-level command (SDO, NMT) are `[[net] node]`; one number before a
//! network-level command (`set`, LSS) is the net; gateway-level commands take none. An unknown
//! command word is [`ParseError::NotSupported`] (gateway error 100), anything else malformed a
//! [`ParseError::Syntax`] (101); both keep the sequence number when it was readable. Never
//! panics.

use nom::branch::alt;
use nom::bytes::complete::{tag, take_while, take_while1};
use nom::character::complete::{char, digit1, hex_digit1, space0, space1};
use nom::combinator::{all_consuming, map_res, opt, recognize};
use nom::sequence::{delimited, preceded};
use nom::{IResult, Parser};

use crate::command::{
    AllNodes, AllNodesAssign, Command, HelpTopic, Level, NmtService, Request, ScanType,
};
use crate::value::{DataType, Value, parse_unsigned};

/// Why a line is not a request.
#[derive(Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ParseError {
    /// Malformed (gateway error 101).
    #[error("syntax error")]
    Syntax {
        /// The sequence number, when the line started with a readable one.
        seq: Option<u32>,
    },
    /// An unknown command word (gateway error 100).
    #[error("request not supported")]
    NotSupported {
        /// The sequence number, when the line started with a readable one.
        seq: Option<u32>,
    },
    /// A write whose value is a number outside its type's range: answered with CiA 301's SDO
    /// abort code for a value above (0x06090031) or below (0x06090032) the range, as a device
    /// answers such a value. CiA 309-3's own error codes have none for a range.
    #[error("value out of range")]
    OutOfRange {
        /// The sequence number.
        seq: Option<u32>,
        /// Above the type's maximum (else below its minimum).
        above: bool,
    },
    /// A node-ID above 127 before a node-level command (gateway error 107, as CANopenNode
    /// answers it).
    #[error("unsupported node")]
    UnsupportedNode {
        /// The sequence number.
        seq: Option<u32>,
    },
}

debug_as_display!(ParseError);

impl ParseError {
    /// The SDO abort code this error is answered with (`ERROR:0x........`), if it is one.
    pub fn abort_code(&self) -> Option<u32> {
        match self {
            Self::OutOfRange { above: true, .. } => Some(0x0609_0031),
            Self::OutOfRange { above: false, .. } => Some(0x0609_0032),
            _ => None,
        }
    }

    /// The sequence number to echo.
    pub fn seq(&self) -> Option<u32> {
        match *self {
            Self::Syntax { seq }
            | Self::NotSupported { seq }
            | Self::UnsupportedNode { seq }
            | Self::OutOfRange { seq, .. } => seq,
        }
    }
}

type Res<'a, T> = IResult<&'a str, T>;

fn number(i: &str) -> Res<'_, u64> {
    map_res(
        alt((
            recognize(preceded(alt((tag("0x"), tag("0X"))), hex_digit1)),
            digit1,
        )),
        |s: &str| parse_unsigned(s).ok_or(()),
    )
    .parse(i)
}

fn num_max(max: u64) -> impl Fn(&str) -> Res<'_, u64> {
    move |i| {
        let (rest, v) = number(i)?;
        if v > max {
            return Err(nom::Err::Error(nom::error::Error::new(
                i,
                nom::error::ErrorKind::TooLarge,
            )));
        }
        // A number ends at a blank, a comment or the end.
        if rest.starts_with(|c: char| !c.is_ascii_whitespace()) {
            return Err(nom::Err::Error(nom::error::Error::new(
                rest,
                nom::error::ErrorKind::Verify,
            )));
        }
        Ok((rest, v))
    }
}

/// One argument: blanks, then a number no larger than `max`.
fn arg(max: u64) -> impl Fn(&str) -> Res<'_, u64> {
    move |i| preceded(space1, num_max(max)).parse(i)
}

fn word(i: &str) -> Res<'_, &str> {
    recognize((
        take_while1(|c: char| c.is_ascii_alphabetic() || c == '_'),
        take_while(|c: char| c.is_ascii_alphanumeric() || c == '_'),
    ))
    .parse(i)
}

fn seq(i: &str) -> Res<'_, u32> {
    delimited(
        (char('['), space0),
        map_res(digit1, str::parse::<u32>),
        (space0, char(']')),
    )
    .parse(i)
}

/// The optional trailing blanks and comment.
fn tail(i: &str) -> Res<'_, ()> {
    let (i, _) = space0.parse(i)?;
    if i.starts_with('#') {
        return Ok(("", ()));
    }
    Ok((i, ()))
}

fn bit(i: &str) -> Res<'_, bool> {
    let (i, v) = arg(1)(i)?;
    Ok((i, v == 1))
}

fn data_type(i: &str) -> Res<'_, DataType> {
    let (rest, w) = preceded(space1, word).parse(i)?;
    match DataType::from_name(w) {
        Some(t) => Ok((rest, t)),
        None => Err(nom::Err::Error(nom::error::Error::new(
            i,
            nom::error::ErrorKind::Tag,
        ))),
    }
}

/// The value text: up to an unquoted comment, blanks at the end removed.
fn value_text(i: &str) -> (&str, &str) {
    let mut quoted = false;
    let mut prev_blank = true;
    for (pos, c) in i.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '#' if !quoted && prev_blank => return (i[..pos].trim_end(), &i[pos..]),
            _ => {}
        }
        prev_blank = c == ' ' || c == '\t';
    }
    (i.trim_end_matches([' ', '\t']), "")
}

fn write_args(i: &str) -> Res<'_, Command> {
    let (i, index) = arg(0xFFFF)(i)?;
    let (i, sub) = arg(0xFF)(i)?;
    let (i, dt) = data_type(i)?;
    let fail = || nom::Err::Error(nom::error::Error::new(i, nom::error::ErrorKind::Verify));
    let (rest, text) = match space1::<&str, nom::error::Error<&str>>(i) {
        Ok((after, _)) => {
            let (text, rest) = value_text(after);
            (rest, text)
        }
        Err(_) => (i, ""),
    };
    if text.is_empty() && !dt.may_be_empty() {
        return Err(fail());
    }
    let value = Value::parse(dt, text).map_err(|e| match e {
        // Kept apart from the syntax errors: `command_args` answers it as a range error.
        crate::value::ValueError::Range { above, .. } => nom::Err::Failure(nom::error::Error::new(
            i,
            if above { RANGE_ABOVE } else { RANGE_BELOW },
        )),
        _ => fail(),
    })?;
    Ok((
        rest,
        Command::Write {
            index: index as u16,
            sub: sub as u8,
            value,
        },
    ))
}

fn read_args(i: &str) -> Res<'_, Command> {
    let (i, index) = arg(0xFFFF)(i)?;
    let (i, sub) = arg(0xFF)(i)?;
    let (i, data_type) = opt(data_type).parse(i)?;
    Ok((
        i,
        Command::Read {
            index: index as u16,
            sub: sub as u8,
            data_type,
        },
    ))
}

/// One of `words`, in any letter case; returns the word as listed.
fn keyword<'a>(words: &'static [&'static str]) -> impl Fn(&'a str) -> Res<'a, &'static str> {
    move |i| {
        let (rest, w) = preceded(space1, word).parse(i)?;
        if let Some(k) = words.iter().find(|k| k.eq_ignore_ascii_case(w)) {
            Ok((rest, k))
        } else {
            Err(nom::Err::Error(nom::error::Error::new(
                i,
                nom::error::ErrorKind::Tag,
            )))
        }
    }
}

fn all_nodes(i: &str) -> Res<'_, Option<AllNodes>> {
    let (i, timeout) = opt(arg(0xFFFF)).parse(i)?;
    let Some(timeout_ms) = timeout else {
        return Ok((i, None));
    };
    // The first node-ID is 1..=127, as CANopenNode takes it.
    let node_start = nom::combinator::verify(arg(127), |&n| n >= 1);
    let (i, assign) = opt((node_start, bit)).parse(i)?;
    let Some((node_start, store)) = assign else {
        return Ok((
            i,
            Some(AllNodes {
                timeout_ms: timeout_ms as u16,
                assign: None,
            }),
        ));
    };
    let scan_part = |i| {
        let (i, t) = arg(2)(i)?;
        let (i, v) = arg(u32::MAX.into())(i)?;
        Ok((
            i,
            (
                ScanType::from_code(t as u8).unwrap_or(ScanType::Ignore),
                v as u32,
            ),
        ))
    };
    let (i, scan) = opt((scan_part, scan_part, scan_part, scan_part)).parse(i)?;
    Ok((
        i,
        Some(AllNodes {
            timeout_ms: timeout_ms as u16,
            assign: Some(AllNodesAssign {
                node_start: node_start as u8,
                store,
                scan: scan.map(|(a, b, c, d)| [a, b, c, d]),
            }),
        }),
    ))
}

/// The arguments of command word `w`; `Ok(None)` for an unknown word.
/// The error kinds `write_args` marks a value out of range with (above, below).
const RANGE_ABOVE: nom::error::ErrorKind = nom::error::ErrorKind::TooLarge;
const RANGE_BELOW: nom::error::ErrorKind = nom::error::ErrorKind::Satisfy;

/// Why a command's arguments did not parse.
enum ArgError {
    Syntax,
    /// A written value outside its type's range (above it, else below).
    Range(bool),
}

impl From<()> for ArgError {
    fn from((): ()) -> Self {
        Self::Syntax
    }
}

fn command_args<'a>(w: &str, i: &'a str) -> Result<Option<(&'a str, Command)>, ArgError> {
    let r: Res<'a, Command> = match w {
        "r" | "read" => read_args(i),
        "w" | "write" => write_args(i),
        "start" => Ok((i, Command::Nmt(NmtService::Start))),
        "stop" => Ok((i, Command::Nmt(NmtService::Stop))),
        "preop" | "preoperational" => Ok((i, Command::Nmt(NmtService::PreOperational))),
        "reset" => keyword(&["node", "comm", "communication"])(i).map(|(r, k)| {
            let s = if k == "node" {
                NmtService::ResetNode
            } else {
                NmtService::ResetCommunication
            };
            (r, Command::Nmt(s))
        }),
        "set" => {
            let (i, k) =
                keyword(&["network", "node", "sdo_timeout", "sdo_block"])(i).map_err(|_| ())?;
            match k {
                "network" => arg(0xFFFF)(i).map(|(r, v)| (r, Command::SetNetwork(v as u16))),
                "node" => arg(0xFF)(i).map(|(r, v)| (r, Command::SetNode(v as u8))),
                "sdo_timeout" => {
                    arg(u32::MAX.into())(i).map(|(r, v)| (r, Command::SetSdoTimeout(v as u32)))
                }
                _ => bit(i).map(|(r, b)| (r, Command::SetSdoBlock(b))),
            }
        }
        "lss_switch_glob" => bit(i).map(|(r, b)| (r, Command::LssSwitchGlobal(b))),
        "lss_switch_sel" => {
            let n = arg(u32::MAX.into());
            (&n, &n, &n, &n).parse(i).map(|(r, (a, b, c, d))| {
                (
                    r,
                    Command::LssSwitchSelective([a as u32, b as u32, c as u32, d as u32]),
                )
            })
        }
        "lss_set_node" => arg(0xFF)(i).map(|(r, v)| (r, Command::LssSetNode(v as u8))),
        "lss_conf_bitrate" => (arg(0xFF), arg(0xFF)).parse(i).map(|(r, (t, x))| {
            (
                r,
                Command::LssConfBitrate {
                    table: t as u8,
                    index: x as u8,
                },
            )
        }),
        "lss_activate_bitrate" => {
            arg(0xFFFF)(i).map(|(r, v)| (r, Command::LssActivateBitrate(v as u16)))
        }
        "lss_store" => Ok((i, Command::LssStore)),
        // The part as CANopenNode numbers it (0..3) or as the LSS command specifier of the
        // inquire service, as Lely takes it (0x5A..0x5D).
        "lss_inquire_addr" => match opt(arg(0x5D)).parse(i) {
            Ok((r, None)) => Ok((r, Command::LssInquireAddr(None))),
            Ok((r, Some(v @ 0..=3))) => Ok((r, Command::LssInquireAddr(Some(v as u8)))),
            Ok((r, Some(v @ 0x5A..=0x5D))) => {
                Ok((r, Command::LssInquireAddr(Some((v - 0x5A) as u8))))
            }
            _ => return Err(ArgError::Syntax),
        },
        "lss_get_node" => Ok((i, Command::LssGetNode)),
        "_lss_fastscan" => opt(arg(0xFFFF))
            .parse(i)
            .map(|(r, v)| (r, Command::LssFastscan(v.map(|v| v as u16)))),
        "lss_allnodes" => all_nodes(i).map(|(r, a)| (r, Command::LssAllNodes(a))),
        "help" => opt(keyword(&["datatype", "lss"])).parse(i).map(|(r, k)| {
            let topic = k.map(|k| {
                if k == "lss" {
                    HelpTopic::Lss
                } else {
                    HelpTopic::DataType
                }
            });
            (r, Command::Help(topic))
        }),
        "info" => keyword(&["version"])(i).map(|(r, _)| (r, Command::InfoVersion)),
        "_events" => bit(i).map(|(r, b)| (r, Command::Events(b))),
        _ => return Ok(None),
    };
    r.map(Some).map_err(|e| match e {
        nom::Err::Failure(e) if e.code == RANGE_ABOVE => ArgError::Range(true),
        nom::Err::Failure(e) if e.code == RANGE_BELOW => ArgError::Range(false),
        _ => ArgError::Syntax,
    })
}

/// Parses one line. `Ok(None)` for an empty or comment-only line.
pub fn parse_line(line: &str) -> Result<Option<Request>, ParseError> {
    let line = line
        .strip_suffix("\r\n")
        .or_else(|| line.strip_suffix('\n'))
        .or_else(|| line.strip_suffix('\r'))
        .unwrap_or(line);
    let line = line.trim_start_matches([' ', '\t']);
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let syntax = |seq| ParseError::Syntax { seq };
    // The sequence number first, so that every later error can echo it.
    let (i, seq) = match opt(seq).parse(line) {
        Ok(v) => v,
        Err(_) => return Err(syntax(None)),
    };
    if line.starts_with('[') && seq.is_none() {
        return Err(syntax(None));
    }
    let (i, _) = space0::<&str, nom::error::Error<&str>>(i).map_err(|_| syntax(seq))?;
    if i.is_empty() || i.starts_with('#') {
        // A sequence number alone is not a request.
        return Err(syntax(seq));
    }
    let prefix_num = |i| {
        let (i, n) = num_max(0xFFFF)(i)?;
        let (i, _) = space1(i)?;
        Ok((i, n))
    };
    let (i, (first, second)) = (opt(prefix_num), opt(prefix_num))
        .parse(i)
        .map_err(|_: nom::Err<nom::error::Error<&str>>| syntax(seq))?;
    let (i, w) = word(i).map_err(|_| syntax(seq))?;
    // The word must end at a blank or the end of the line.
    let after: Res<'_, &str> = take_while(|c: char| !c.is_ascii_whitespace()).parse(i);
    if after.is_ok_and(|(_, junk)| !junk.is_empty()) {
        return Err(syntax(seq));
    }
    // Command words in any letter case, as both CANopenNode and Lely take them.
    let (i, command) = match command_args(&w.to_ascii_lowercase(), i) {
        Ok(Some(v)) => v,
        Ok(None) => return Err(ParseError::NotSupported { seq }),
        Err(ArgError::Syntax) => return Err(syntax(seq)),
        Err(ArgError::Range(above)) => return Err(ParseError::OutOfRange { seq, above }),
    };
    all_consuming(tail)
        .parse(i)
        .map_err(|_: nom::Err<nom::error::Error<&str>>| syntax(seq))?;
    let (net, node) = match (command.level(), first, second) {
        (_, None, Some(_)) => return Err(syntax(seq)),
        (Level::Gateway, None, None) => (None, None),
        (Level::Gateway, ..) => return Err(syntax(seq)),
        (Level::Network, Some(_), Some(_)) => return Err(syntax(seq)),
        (Level::Network, net, None) => (net, None),
        (Level::Node, Some(net), Some(node)) => (Some(net), Some(node)),
        (Level::Node, node, None) => (None, node),
    };
    if node.is_some_and(|n| n > 127) {
        return Err(ParseError::UnsupportedNode { seq });
    }
    Ok(Some(Request {
        seq,
        net: net.map(|n| n as u16),
        node: node.map(|n| n as u8),
        command,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Time;

    fn p(line: &str) -> Request {
        parse_line(line)
            .unwrap_or_else(|e| panic!("{line:?}: {e}"))
            .unwrap()
    }

    #[test]
    fn standard_forms() {
        let r = p("[1] 4 read 0x1017 0 i16\r\n");
        assert_eq!(r.seq, Some(1));
        assert_eq!((r.net, r.node), (None, Some(4)));
        assert_eq!(
            r.command,
            Command::Read {
                index: 0x1017,
                sub: 0,
                data_type: Some(DataType::I16)
            }
        );
        let r = p("[2] 1 4 w 0x1017 0 u16 1000");
        assert_eq!((r.net, r.node), (Some(1), Some(4)));
        assert_eq!(
            r.command,
            Command::Write {
                index: 0x1017,
                sub: 0,
                value: Value::U16(1000)
            }
        );
        assert_eq!(p("[3] 4 r 0x1008 0").command.to_string(), "read 0x1008 0");
        assert_eq!(
            p("[4] 0 reset comm").command,
            Command::Nmt(NmtService::ResetCommunication)
        );
        assert_eq!(
            p("[5] 4 preop").command,
            Command::Nmt(NmtService::PreOperational)
        );
        let r = p("[6] 1 set node 4");
        assert_eq!(
            (r.net, r.node, r.command),
            (Some(1), None, Command::SetNode(4))
        );
        assert_eq!(
            p("[7] lss_switch_sel 0x360 2 3 4").command,
            Command::LssSwitchSelective([0x360, 2, 3, 4])
        );
        assert_eq!(
            p("[8] lss_allnodes 10 5 1 2 0x360 0 0 1 0 0 0").command,
            Command::LssAllNodes(Some(AllNodes {
                timeout_ms: 10,
                assign: Some(AllNodesAssign {
                    node_start: 5,
                    store: true,
                    scan: Some([
                        (ScanType::Match, 0x360),
                        (ScanType::Scan, 0),
                        (ScanType::Ignore, 0),
                        (ScanType::Scan, 0)
                    ])
                })
            }))
        );
        assert_eq!(p("info version").command, Command::InfoVersion);
        assert_eq!(
            p("[9] help lss").command,
            Command::Help(Some(HelpTopic::Lss))
        );
    }

    #[test]
    fn values_and_comments() {
        let v = |line| match p(line).command {
            Command::Write { value, .. } => value,
            c => panic!("{c:?}"),
        };
        assert_eq!(
            v("[1] 5 w 0x2000 0 vs \"a # b\"  # comment"),
            Value::VisibleString("a # b".into())
        );
        assert_eq!(
            v("[1] 5 w 0x2000 0 vs word#x"),
            Value::VisibleString("word#x".into())
        );
        assert_eq!(v("[1] 5 w 0x2000 0 os"), Value::OctetString(vec![]));
        assert_eq!(v("[1] 5 w 0x2000 0 d AAEC"), Value::Domain(vec![0, 1, 2]));
        assert_eq!(
            v("[1] 5 w 0x2000 0 t 1 2 # noon"),
            Value::TimeOfDay(Time { days: 1, ms: 2 })
        );
    }

    #[test]
    fn errors_keep_the_sequence_number() {
        assert_eq!(parse_line("# c"), Ok(None));
        assert_eq!(parse_line("\r\n"), Ok(None));
        assert_eq!(
            parse_line("[7] 4 frobnicate"),
            Err(ParseError::NotSupported { seq: Some(7) })
        );
        for bad in [
            "[7] 4 read",
            "[7] 4 read 0x10000 0",
            "[7] 4 read 0x1000 256",
            "[7] 4 read 0x1000 0 q8",
            "[7] 4 write 0x1000 0 u8",
            "[7] 4 write 0x1000 0 u8 2x6",
            "[7] 1 2 3 start",
            "[7] 1 2 set node 3",
            "[7] 3 help",
            "[7] 4 start now",
            "[7] set sdo_block 2",
            "[7]",
            "[7] 4 read 0x1000 0 u8 extra",
        ] {
            assert_eq!(
                parse_line(bad),
                Err(ParseError::Syntax { seq: Some(7) }),
                "{bad}"
            );
        }
        // A number outside the type's range: a range error, answered with the abort code.
        for (bad, above) in [
            ("[7] 4 write 0x1000 0 u8 256", true),
            ("[7] 4 write 0x1000 0 i16 -40000", false),
            ("[7] 4 write 0x1000 0 u32 -0x1", false),
        ] {
            let e = parse_line(bad).unwrap_err();
            assert_eq!(
                e,
                ParseError::OutOfRange {
                    seq: Some(7),
                    above
                },
                "{bad}"
            );
            let code = if above { 0x0609_0031 } else { 0x0609_0032 };
            assert_eq!(e.abort_code(), Some(code));
        }
        // A node-ID above 127: unsupported node, as CANopenNode answers.
        for bad in ["[7] 300 start", "[7] 128 r 0x1000 0", "[7] 1 200 stop"] {
            assert_eq!(
                parse_line(bad),
                Err(ParseError::UnsupportedNode { seq: Some(7) }),
                "{bad}"
            );
        }
        // Any letter case, as both CANopenNode and Lely take it.
        assert_eq!(
            p("[8] 4 READ 0x1017 0 U16").command,
            Command::Read {
                index: 0x1017,
                sub: 0,
                data_type: Some(DataType::U16)
            }
        );
        assert_eq!(
            p("[9] 4 Reset Comm").command,
            Command::Nmt(NmtService::ResetCommunication)
        );
        // lss_inquire_addr takes the part (CANopenNode) or its command specifier (Lely).
        assert_eq!(
            p("[10] lss_inquire_addr 0x5D").command,
            Command::LssInquireAddr(Some(3))
        );
        assert_eq!(
            parse_line("[11] lss_allnodes 25 0 1"),
            Err(ParseError::Syntax { seq: Some(11) })
        );
        assert_eq!(
            parse_line("[10] lss_inquire_addr 4"),
            Err(ParseError::Syntax { seq: Some(10) })
        );
        assert_eq!(
            parse_line("[x] start"),
            Err(ParseError::Syntax { seq: None })
        );
        assert_eq!(
            parse_line("[99999999999] start"),
            Err(ParseError::Syntax { seq: None })
        );
    }
}
