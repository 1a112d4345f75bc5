//! Who may drive the network through the gateway: tokens, roles, the client allow-list and
//! `--read-only`.
//!
//! CiA 309-3 has no authentication: any client that reaches the gateway may read, write, reset
//! nodes and reassign node-IDs. This module adds, on top of the mapping:
//! * **Tokens.** With a token configured ([`Access::write_token`], [`Access::read_token`]),
//!   every TCP and Unix-socket connection must first send `[<seq>] auth <token>` (standard
//!   input and a stream handed to [`crate::Gateway::serve_stream`] are the embedding
//!   process's own and need none). The token is
//!   compared in constant time (the time taken does not depend on where the first difference
//!   is). A right token is answered `OK` and gives the connection the token's [`Role`]; a
//!   wrong one, or any other line first, is answered `ERROR:102` (request not processed due to
//!   internal state) and the connection is closed.
//! * **Roles.** [`Role::Read`] may read (`read`, `help`, `info`, `_events`); a request that
//!   changes the network or the connection's settings (`write`, NMT, LSS, `set`, see
//!   [`Class`]) is answered `ERROR:100`, request not supported, and counted. [`Role::Write`]
//!   may do everything. [`Access::read_only`] makes every connection a reader.
//! * **Allow-list.** With [`Access::allow`] non-empty, a TCP client whose address is in none of
//!   the networks is refused at once (`ERROR:102`, closed) and counted.
//!
//! The counters ([`AccessCounters`]) are the gateway's, readable with
//! [`crate::Gateway::access_counters`].

use core::fmt;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::command::{Command, ErrorCode, Reply, Response};

/// What a connection may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Reads and information only.
    Read,
    /// Everything, including what changes the network.
    Write,
}

/// What a command does, as far as access goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Reads the network or the gateway: SDO `read`, `help`, `info version`, `_events`.
    Read,
    /// Changes the connection's own defaults only: `set network`, `set node`,
    /// `set sdo_timeout`, `set sdo_block`.
    Setting,
    /// Changes the network: SDO `write` (store and restore included), NMT, every LSS service
    /// (even the inquiries switch or select slaves).
    Change,
}

impl Class {
    /// The class of `command`.
    pub fn of(command: &Command) -> Self {
        match command {
            Command::Read { .. } | Command::Help(_) | Command::InfoVersion | Command::Events(_) => {
                Self::Read
            }
            Command::SetNetwork(_)
            | Command::SetNode(_)
            | Command::SetSdoTimeout(_)
            | Command::SetSdoBlock(_) => Self::Setting,
            _ => Self::Change,
        }
    }
}

/// A secret token. Its `Debug` form does not show it.
#[derive(Clone, PartialEq, Eq)]
pub struct Token(Vec<u8>);

impl fmt::Debug for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Token(..)")
    }
}

/// Why a token is refused.
#[derive(Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TokenError {
    /// Nothing (or only blanks) given.
    #[error("the token is empty")]
    Empty,
    /// Shorter than [`Token::MIN_LEN`].
    #[error("the token is shorter than {} characters", Token::MIN_LEN)]
    TooShort,
    /// Holds a blank or control character inside (a line cannot carry it).
    #[error("the token holds a blank or control character")]
    BadCharacter,
}

debug_as_display!(TokenError);

impl Token {
    /// Shortest token taken.
    pub const MIN_LEN: usize = 16;

    /// A token from text: the text with blanks and line ends around it trimmed (a token file's
    /// final newline is not part of the token).
    pub fn new(text: &str) -> Result<Self, TokenError> {
        let t = text.trim();
        if t.is_empty() {
            return Err(TokenError::Empty);
        }
        if t.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(TokenError::BadCharacter);
        }
        if t.len() < Self::MIN_LEN {
            return Err(TokenError::TooShort);
        }
        Ok(Self(t.as_bytes().to_vec()))
    }

    /// Whether `given` is this token, in time that depends on the lengths only.
    pub fn matches(&self, given: &[u8]) -> bool {
        constant_time_eq(&self.0, given)
    }
}

/// `a == b`, reading every byte of `b` whatever differs where.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    let mut diff = a.len() ^ b.len();
    for (i, &y) in b.iter().enumerate() {
        let x = a.get(i).copied().unwrap_or(!y);
        diff |= usize::from(x ^ y);
    }
    core::hint::black_box(diff) == 0
}

/// A network of client addresses: `ADDR` or `ADDR/PREFIX`, IPv4 or IPv6.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AllowNet {
    addr: IpAddr,
    prefix: u8,
}

/// Why an allow-list entry does not read.
#[derive(Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not ADDR or ADDR/PREFIX")]
pub struct AllowNetError(String);

debug_as_display!(AllowNetError);

impl core::str::FromStr for AllowNet {
    type Err = AllowNetError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || AllowNetError(s.to_owned());
        let (a, p) = match s.split_once('/') {
            Some((a, p)) => (a, Some(p)),
            None => (s, None),
        };
        let addr: IpAddr = a.parse().map_err(|_| bad())?;
        let max = if addr.is_ipv4() { 32 } else { 128 };
        let prefix = match p {
            None => max,
            Some(p) => p.parse::<u8>().ok().filter(|&p| p <= max).ok_or_else(bad)?,
        };
        Ok(Self { addr, prefix })
    }
}

impl AllowNet {
    /// Whether `ip` is in this network (an IPv4-mapped IPv6 address counts as its IPv4 one).
    pub fn contains(&self, ip: IpAddr) -> bool {
        let ip = match ip {
            IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
            v4 => v4,
        };
        let (a, b, bits) = match (self.addr, ip) {
            (IpAddr::V4(a), IpAddr::V4(b)) => (
                u128::from(u32::from(a)) << 96,
                u128::from(u32::from(b)) << 96,
                self.prefix,
            ),
            (IpAddr::V6(a), IpAddr::V6(b)) => (u128::from(a), u128::from(b), self.prefix),
            _ => return false,
        };
        let mask = if bits == 0 {
            0
        } else {
            u128::MAX << (128 - u32::from(bits))
        };
        a & mask == b & mask
    }
}

/// The access settings of a gateway (part of [`crate::Config`]). The default admits every
/// client with the write role, as CiA 309-3 does: fit for a loopback address or a Unix socket
/// only.
#[derive(Debug, Clone, Default)]
pub struct Access {
    /// The token that gives the write role.
    pub write_token: Option<Token>,
    /// The token that gives the read role.
    pub read_token: Option<Token>,
    /// TCP clients admitted (empty: every address).
    pub allow: Vec<AllowNet>,
    /// Every connection is a reader, whatever its token.
    pub read_only: bool,
}

impl Access {
    /// Whether connections must send `auth <token>` first.
    pub fn needs_token(&self) -> bool {
        self.write_token.is_some() || self.read_token.is_some()
    }

    /// Whether a TCP client at `ip` is admitted by the allow-list.
    pub fn admits(&self, ip: IpAddr) -> bool {
        self.allow.is_empty() || self.allow.iter().any(|n| n.contains(ip))
    }

    fn cap(&self, role: Role) -> Role {
        if self.read_only { Role::Read } else { role }
    }
}

/// Counts of what access control refused.
#[derive(Debug, Default)]
pub(crate) struct Counters {
    refused: AtomicU64,
    auth_failures: AtomicU64,
    not_allowed: AtomicU64,
}

/// What access control refused so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AccessCounters {
    /// Requests refused with `ERROR:100` for the connection's role (or `--read-only`).
    pub refused: u64,
    /// Connections closed for a missing or wrong token.
    pub auth_failures: u64,
    /// TCP connections refused by the allow-list.
    pub not_allowed: u64,
}

impl Counters {
    pub(crate) fn snapshot(&self) -> AccessCounters {
        AccessCounters {
            refused: self.refused.load(Ordering::Relaxed),
            auth_failures: self.auth_failures.load(Ordering::Relaxed),
            not_allowed: self.not_allowed.load(Ordering::Relaxed),
        }
    }

    pub(crate) fn count_not_allowed(&self) {
        self.not_allowed.fetch_add(1, Ordering::Relaxed);
    }
}

/// Where a connection comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Peer {
    /// A TCP client.
    Tcp(std::net::SocketAddr),
    /// A Unix socket client.
    #[cfg(unix)]
    Unix,
    /// Standard input, or a byte stream handed to [`crate::Gateway::serve_stream`]: the
    /// gateway's own process; no token asked.
    Local,
}

impl fmt::Display for Peer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Tcp(a) => write!(f, "tcp:{a}"),
            #[cfg(unix)]
            Self::Unix => f.write_str("unix"),
            Self::Local => f.write_str("local"),
        }
    }
}

/// One connection's standing.
#[derive(Debug)]
pub(crate) struct ConnAccess {
    pub(crate) peer: Peer,
    /// `None` until a token is accepted (where one is needed).
    role: Option<Role>,
    closed: bool,
}

impl ConnAccess {
    pub(crate) fn new(access: &Access, peer: Peer) -> Self {
        let role = if access.needs_token() && peer != Peer::Local {
            None
        } else {
            Some(access.cap(Role::Write))
        };
        Self {
            peer,
            role,
            closed: false,
        }
    }

    /// Whether the connection is to be closed (a failed `auth`).
    pub(crate) fn closed(&self) -> bool {
        self.closed
    }

    pub(crate) fn authenticated(&self) -> bool {
        self.role.is_some()
    }
}

/// What to do with a line before parsing it.
pub(crate) enum Gate {
    /// Parse and serve it.
    Pass,
    /// Answer this (the `auth` line, or a refusal; [`ConnAccess::closed`] tells whether to
    /// close) and go on with the next line.
    Answer(String),
}

/// `[<seq>] auth <token>`: the sequence number and the token, if the line is one.
fn auth_line(text: &str) -> Option<(Option<u32>, &str)> {
    let mut t = text.trim();
    let mut seq = None;
    if let Some(rest) = t.strip_prefix('[') {
        let (n, rest) = rest.split_once(']')?;
        seq = Some(n.trim().parse().ok()?);
        t = rest.trim_start();
    }
    let (word, rest) = t.split_once(char::is_whitespace).unwrap_or((t, ""));
    word.eq_ignore_ascii_case("auth")
        .then(|| (seq, rest.trim()))
}

/// The `[<seq>]` a line starts with, if any.
fn leading_seq(text: &str) -> Option<u32> {
    let (n, _) = text.trim_start().strip_prefix('[')?.split_once(']')?;
    n.trim().parse().ok()
}

fn answer(seq: Option<u32>, reply: Reply) -> String {
    Response { seq, reply }.to_text()
}

/// Handles the `auth` line and refuses anything before it on a connection that needs a token.
pub(crate) fn gate(
    access: &Access,
    conn: &mut ConnAccess,
    counters: &Counters,
    text: &str,
) -> Gate {
    let auth = auth_line(text);
    if conn.authenticated() {
        return match auth {
            // A second `auth` (or one where none is needed) is not a request the gateway serves.
            Some((seq, _)) => {
                Gate::Answer(answer(seq, Reply::Error(ErrorCode::REQUEST_NOT_SUPPORTED)))
            }
            None => Gate::Pass,
        };
    }
    // Blank lines and comments before `auth` get no reply, as everywhere.
    let bare = text.trim();
    if auth.is_none() && (bare.is_empty() || bare.starts_with('#')) {
        return Gate::Pass;
    }
    let seq = auth.map_or_else(|| leading_seq(text), |(s, _)| s);
    let token = auth.map(|(_, t)| t.as_bytes());
    // Both tokens are always compared, so the time does not tell which one matched.
    let (w, r) = match token {
        Some(t) => (
            access.write_token.as_ref().is_some_and(|k| k.matches(t)),
            access.read_token.as_ref().is_some_and(|k| k.matches(t)),
        ),
        None => (false, false),
    };
    let role = if w {
        Role::Write
    } else if r {
        Role::Read
    } else {
        counters.auth_failures.fetch_add(1, Ordering::Relaxed);
        conn.closed = true;
        return Gate::Answer(answer(seq, Reply::Error(ErrorCode::INTERNAL_STATE)));
    };
    conn.role = Some(access.cap(role));
    Gate::Answer(answer(seq, Reply::Ok))
}

/// `Err(100)` when the connection's role does not allow `command` (counted).
pub(crate) fn permit(
    conn: &ConnAccess,
    counters: &Counters,
    command: &Command,
) -> Result<(), ErrorCode> {
    let allowed = matches!(
        (conn.role, Class::of(command)),
        (Some(Role::Write), _) | (Some(Role::Read), Class::Read)
    );
    if allowed {
        Ok(())
    } else {
        counters.refused.fetch_add(1, Ordering::Relaxed);
        Err(ErrorCode::REQUEST_NOT_SUPPORTED)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse_line;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        /// Any line before `auth` is refused (and closes) or passes as blank; never a panic.
        #[test]
        fn the_gate_takes_any_line(text in ".{0,80}") {
            let access = Access {
                write_token: Some(Token::new("write-token-0123456789").unwrap()),
                ..Access::default()
            };
            let mut c = ConnAccess::new(&access, Peer::Unix);
            let g = gate(&access, &mut c, &Counters::default(), &text);
            prop_assert!(!c.authenticated() || text.contains("write-token-0123456789"));
            if let Gate::Answer(a) = g {
                prop_assert!(a.ends_with("\r\n"));
            }
        }

        #[test]
        fn allow_entries_and_tokens_never_panic(text in "\\PC{0,60}") {
            let _ = text.parse::<AllowNet>();
            let _ = Token::new(&text);
            let _ = auth_line(&text);
        }
    }

    fn tok(s: &str) -> Token {
        Token::new(s).unwrap()
    }

    #[test]
    fn tokens_compare_whole() {
        let t = tok("0123456789abcdef");
        assert!(t.matches(b"0123456789abcdef"));
        assert!(!t.matches(b"0123456789abcdeg"));
        assert!(!t.matches(b"0123456789abcde"));
        assert!(!t.matches(b"0123456789abcdef0"));
        assert!(!t.matches(b""));
        assert_eq!(Token::new(" \n"), Err(TokenError::Empty));
        assert_eq!(Token::new("short"), Err(TokenError::TooShort));
        assert_eq!(
            Token::new("0123456789 abcdef"),
            Err(TokenError::BadCharacter)
        );
        assert_eq!(tok("0123456789abcdef\n"), t);
        assert_eq!(format!("{t:?}"), "Token(..)");
    }

    #[test]
    fn allow_nets() {
        let n: AllowNet = "192.168.1.0/24".parse().unwrap();
        assert!(n.contains("192.168.1.77".parse().unwrap()));
        assert!(!n.contains("192.168.2.1".parse().unwrap()));
        assert!(n.contains("::ffff:192.168.1.5".parse().unwrap()));
        assert!(!n.contains("::1".parse().unwrap()));
        let one: AllowNet = "10.0.0.1".parse().unwrap();
        assert!(one.contains("10.0.0.1".parse().unwrap()));
        assert!(!one.contains("10.0.0.2".parse().unwrap()));
        let all: AllowNet = "::/0".parse().unwrap();
        assert!(all.contains("fd00::5".parse().unwrap()));
        assert!("10.0.0.1/33".parse::<AllowNet>().is_err());
        assert!("host/8".parse::<AllowNet>().is_err());
    }

    #[test]
    fn classes() {
        let class = |l: &str| Class::of(&parse_line(l).unwrap().unwrap().command);
        assert_eq!(class("1 read 0x1017 0 u16"), Class::Read);
        assert_eq!(class("info version"), Class::Read);
        assert_eq!(class("_events 1"), Class::Read);
        assert_eq!(class("help"), Class::Read);
        assert_eq!(class("set node 4"), Class::Setting);
        assert_eq!(class("1 write 0x1017 0 u16 5"), Class::Change);
        assert_eq!(class("1 reset node"), Class::Change);
        assert_eq!(class("0 stop"), Class::Change);
        assert_eq!(class("lss_set_node 5"), Class::Change);
        assert_eq!(class("lss_inquire_addr 0"), Class::Change);
        assert_eq!(class("lss_store"), Class::Change);
    }

    #[test]
    fn auth_lines() {
        assert_eq!(auth_line("auth abc\r\n"), Some((None, "abc")));
        assert_eq!(auth_line("[7] AUTH  abc "), Some((Some(7), "abc")));
        assert_eq!(auth_line("auth"), Some((None, "")));
        assert_eq!(auth_line("[1] 4 read 0x1017 0"), None);
        assert_eq!(auth_line("authx y"), None);
    }

    #[test]
    fn the_gate_takes_a_token_once() {
        let access = Access {
            write_token: Some(tok("write-token-0123456789")),
            read_token: Some(tok("read-token-0123456789")),
            ..Access::default()
        };
        let counters = Counters::default();
        let tcp = Peer::Tcp("127.0.0.1:5".parse().unwrap());
        let mut c = ConnAccess::new(&access, tcp.clone());
        assert!(matches!(
            gate(&access, &mut c, &counters, "# hi\n"),
            Gate::Pass
        ));
        let Gate::Answer(a) = gate(
            &access,
            &mut c,
            &counters,
            "[1] auth read-token-0123456789\n",
        ) else {
            panic!()
        };
        assert_eq!(a, "[1] OK\r\n");
        let write = parse_line("1 write 0x1017 0 u16 5")
            .unwrap()
            .unwrap()
            .command;
        assert_eq!(
            permit(&c, &counters, &write),
            Err(ErrorCode::REQUEST_NOT_SUPPORTED)
        );
        assert_eq!(counters.snapshot().refused, 1);
        let mut bad = ConnAccess::new(&access, tcp);
        let Gate::Answer(a) = gate(&access, &mut bad, &counters, "[3] 1 read 0x1017 0\n") else {
            panic!()
        };
        assert_eq!(a, "[3] ERROR:102\r\n");
        assert!(bad.closed());
        assert_eq!(counters.snapshot().auth_failures, 1);
        // Standard input needs no token; read-only caps it.
        let ro = Access {
            read_only: true,
            ..access.clone()
        };
        let local = ConnAccess::new(&ro, Peer::Local);
        assert_eq!(
            permit(&local, &counters, &write),
            Err(ErrorCode::REQUEST_NOT_SUPPORTED)
        );
    }
}
