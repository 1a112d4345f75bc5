//! `canopen pdo NODE show|map`: a node's PDO parameters (CiA 301 §7.2.2, objects §7.4.8) read
//! and changed by SDO through the library's PDO handles ([`canola::Node::tpdo`] /
//! [`canola::Node::rpdo`]: `read()` and `save()`, which writes the CiA 301 sequence: COB-ID
//! invalid, mapping count 0, the entries, the count, the other parameters, the COB-ID as
//! wanted). A PDO of more than 8 bytes (up to 64, CANopen FD) is saved on a node marked
//! CANopen FD on a CAN FD bus; elsewhere the library refuses it before anything is written and
//! says why in bits and bytes.
//!
//! Which PDOs are read is the library's rule: those the node's `--eds` dictionary lists, else
//! PDO 1..4 (the predefined connection set), those the node has.

use std::process::ExitCode;

use canola::pdo::{Direction, TransmissionType};
use canola::{CanId, Duration, Node, NodeId, ObjectAddress, PdoParameters, PdoSet};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

use crate::bus::{BusOpts, fail, parse_node};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen pdo NODE COMMAND`
#[derive(Debug, Args)]
pub(crate) struct PdoArgs {
    /// Node-ID.
    #[arg(value_parser = parse_node)]
    node: NodeId,
    #[command(subcommand)]
    command: PdoCommand,
}

/// Transmit or receive PDOs, seen from the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Kind {
    /// Transmit PDOs: the node sends them (0x1800.., mapping 0x1A00..).
    Tpdo,
    /// Receive PDOs: the node takes them (0x1400.., mapping 0x1600..).
    Rpdo,
}

impl Kind {
    fn direction(self) -> Direction {
        match self {
            Self::Tpdo => Direction::Transmit,
            Self::Rpdo => Direction::Receive,
        }
    }
}

#[derive(Debug, Subcommand)]
enum PdoCommand {
    /// Read PDOs by SDO: their communication parameters and mapping.
    ///
    /// Each PDO's communication parameters (COB-ID with its valid bit, transmission type,
    /// inhibit time, event timer, SYNC start value, those the node has) and its mapping: every
    /// entry as INDEX:SUB, its length in bits and, with `--eds NODE=FILE`, the object's name;
    /// the total in bits and bytes. Without KIND, the RPDOs and the TPDOs; without N, every one
    /// read: those the node's `--eds` dictionary lists, else PDO 1..4, those the node has.
    Show {
        /// tpdo or rpdo (default: both).
        #[arg(value_enum)]
        kind: Option<Kind>,
        /// The PDO number (1 is TPDO1 at 0x1800/0x1A00, RPDO1 at 0x1400/0x1600).
        #[arg(value_name = "N", value_parser = clap::value_parser!(u16).range(1..=512))]
        number: Option<u16>,
    },
    /// Remap a PDO the CiA 301 way (node in pre-operational: `nmt preop` first).
    ///
    /// Writes by SDO: COB-ID invalid, mapping count 0, the entries, the count, the parameters
    /// given, COB-ID valid; then reads the PDO back. On a node marked CANopen FD (CANopenFD=1
    /// in its --eds file; without --eds, --fd marks it) on a bus that carries CAN FD (--fd, or
    /// the UDP bus) a PDO maps up to 64 bytes; elsewhere up to 64 bits (8 bytes), and more is
    /// refused before anything is written (exit 1).
    ///
    /// NMT state: CiA 301 changes a mapping while its PDO is invalid, and devices commonly
    /// accept that in pre-operational only. The command does not change the node's state: it
    /// sends the sequence in whatever state the node is in, and a device may refuse it while
    /// operational (SDO abort 0x08000022). Put the node in pre-operational first (`canopen nmt
    /// preop NODE`) and start it afterwards (`canopen nmt start NODE`).
    #[command(
        override_usage = "canopen pdo <NODE> map [OPTIONS] <KIND> <N> <ENTRY>...",
        after_help = "Example: canopen --fd --eds 7=fd-device.eds pdo 7 map tpdo 1 \
                      0x2101:00 0x2100:01 0x2100:02/32 --event-timer 100"
    )]
    Map {
        /// tpdo or rpdo.
        #[arg(value_enum)]
        kind: Kind,
        /// The PDO number.
        #[arg(value_name = "N", value_parser = clap::value_parser!(u16).range(1..=512))]
        number: u16,
        /// The objects in PDO order: INDEX:SUB in hex (0x2100:05), its length from the node's
        /// --eds dictionary, or INDEX:SUB/BITS (0x2100:05/32) with the length given; with
        /// --eds also an object's name ("Measured values.Value 1"). A dummy entry is a data
        /// type index with its length (0x0005:00/8).
        #[arg(value_name = "ENTRY", required = true, value_parser = parse_entry)]
        entries: Vec<Entry>,
        /// The CAN identifier (0x0..0x7FF; above, a 29-bit one); default: the one it has.
        #[arg(long, value_name = "ID", value_parser = parse_can_id)]
        cob_id: Option<CanId>,
        /// Transmission type: 0 synchronous acyclic, 1..240 every Nth SYNC, 252/253 on a
        /// remote request (after SYNC / at once), 254/255 event-driven (manufacturer /
        /// profile events); default: the one it has.
        #[arg(long, value_name = "T", value_parser = parse_transmission_type)]
        transmission_type: Option<TransmissionType>,
        /// Event timer in ms (sub 5; 0 off), for a TPDO the period of an event-driven one.
        #[arg(long, value_name = "MS")]
        event_timer: Option<u16>,
        /// Inhibit time in ms, in steps of 0.1 ms (sub 3; a TPDO's minimum gap).
        #[arg(long, value_name = "MS", value_parser = parse_inhibit)]
        inhibit_time: Option<u16>,
        /// SYNC start value (sub 6; 0 none).
        #[arg(long, value_name = "N")]
        sync_start: Option<u8>,
        /// Leave the PDO invalid (COB-ID bit 31 set) instead of making it valid.
        #[arg(long)]
        disabled: bool,
    },
}

/// One mapping entry as given on the command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Entry {
    /// `INDEX:SUB`, with `/BITS` when the length is given.
    Address(ObjectAddress, Option<u8>),
    /// An object's name in the node's dictionary.
    Name(String),
}

impl std::fmt::Display for Entry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Address(a, None) => write!(f, "{a}"),
            Self::Address(a, Some(bits)) => write!(f, "{a}/{bits}"),
            Self::Name(n) => f.write_str(n),
        }
    }
}

/// A hex number with or without `0x`.
fn hex<T>(s: &str, from: fn(&str, u32) -> Result<T, std::num::ParseIntError>) -> Option<T> {
    let digits = s
        .strip_prefix("0x")
        .or_else(|| s.strip_prefix("0X"))
        .unwrap_or(s);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    from(digits, 16).ok()
}

/// `INDEX:SUB[/BITS]` (hex index and sub-index, decimal bits) or a name.
fn parse_entry(s: &str) -> Result<Entry, CliError> {
    if !s.starts_with(|c: char| c.is_ascii_digit()) {
        return if s.trim().is_empty() {
            Err(CliError::Argument("an empty mapping entry".into()))
        } else {
            Ok(Entry::Name(s.to_owned()))
        };
    }
    let bad = || {
        CliError::Argument(format!(
            "`{s}` is not a mapping entry: give INDEX:SUB in hex (0x2100:05), with the length \
             in bits after a slash when the node has no --eds (0x2100:05/32)"
        ))
    };
    let (addr, bits) = match s.split_once('/') {
        Some((a, b)) => (a, Some(b)),
        None => (s, None),
    };
    let (index, sub) = addr.split_once(':').ok_or_else(bad)?;
    let index = hex(index, u16::from_str_radix).ok_or_else(bad)?;
    let sub = hex(sub, u8::from_str_radix).ok_or_else(bad)?;
    let bits = match bits {
        None => None,
        Some(b) => match b.parse::<u8>() {
            Ok(n) if n > 0 => Some(n),
            _ => {
                return Err(CliError::Argument(format!(
                    "`{s}`: the length after the slash is a number of bits, 1..=255"
                )));
            }
        },
    };
    Ok(Entry::Address(ObjectAddress::new(index, sub), bits))
}

/// `--cob-id`: a CAN identifier, 11-bit up to 0x7FF, 29-bit above.
fn parse_can_id(s: &str) -> Result<CanId, CliError> {
    let v = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    }
    .map_err(|e| CliError::Argument(format!("`{s}`: {e}")))?;
    let id = if v <= 0x7FF {
        u16::try_from(v).ok().and_then(|v| CanId::standard(v).ok())
    } else {
        CanId::extended(v).ok()
    };
    id.ok_or_else(|| {
        CliError::Argument(format!(
            "`{s}` is not a CAN identifier (0x0..0x7FF, or 29-bit up to 0x1FFFFFFF); the valid \
             bit is not part of it (--disabled leaves the PDO invalid)"
        ))
    })
}

/// `--transmission-type`: 0..=240 and 252..=255 (241..=251 are reserved).
fn parse_transmission_type(s: &str) -> Result<TransmissionType, CliError> {
    let code = crate::bus::parse_u8(s)?;
    match TransmissionType::from_code(code) {
        TransmissionType::Reserved(_) => Err(CliError::Argument(format!(
            "transmission type {code} is reserved (CiA 301: 241..=251)"
        ))),
        t => Ok(t),
    }
}

/// `--inhibit-time MS`: in units of 100 µs.
fn parse_inhibit(s: &str) -> Result<u16, CliError> {
    let bad = |why: &str| CliError::Argument(format!("inhibit time `{s}` ms: {why}"));
    let ms: f64 = s.parse().map_err(|_| bad("not a number"))?;
    let units = ms * 10.0;
    if !units.is_finite() || units < 0.0 || (units - units.round()).abs() > 1e-6 {
        return Err(bad(
            "give milliseconds in steps of 0.1 (CiA 301: units of 100 µs)",
        ));
    }
    u16::try_from(units.round() as u64).map_err(|_| bad("at most 6553.5 ms"))
}

/// `canopen pdo ...`
pub(crate) fn run(args: PdoArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match opts.open() {
        Ok(b) => b.into_network(),
        Err(e) => return fail(e),
    };
    let node = net.node(args.node);
    // A node with a dictionary is marked CANopen FD by it (CANopenFD=1); without one, --fd
    // says the node is a CANopen FD device (as `usdo` takes it).
    if opts.fd && node.dictionary().is_none() {
        node.set_fd(true);
    }
    let r = match args.command {
        PdoCommand::Show { kind, number } => show(&node, kind, number, g),
        PdoCommand::Map {
            kind,
            number,
            entries,
            cob_id,
            transmission_type,
            event_timer,
            inhibit_time,
            sync_start,
            disabled,
        } => {
            let change = Change {
                entries,
                cob_id,
                transmission_type,
                event_timer,
                inhibit_time,
                sync_start,
                disabled,
            };
            map(&node, kind, number, &change, opts, g)
        }
    };
    r.map_or_else(CliError::report, |()| ExitCode::SUCCESS)
}

/// Reads the node's PDOs of `kind`.
fn read(node: &Node, kind: Kind) -> Result<PdoSet, CliError> {
    let op = match kind {
        Kind::Tpdo => node.tpdo().read(),
        Kind::Rpdo => node.rpdo().read(),
    };
    Ok(op.wait()?)
}

/// `TPDO1`, `RPDO2`.
fn label(p: &PdoParameters) -> String {
    format!("{}{}", kind_name(p.direction()), p.number())
}

fn kind_name(d: Direction) -> &'static str {
    match d {
        Direction::Transmit => "TPDO",
        Direction::Receive => "RPDO",
    }
}

/// The error for a PDO the node does not have (or that was not read).
fn absent(node: &Node, kind: Kind, number: u16, set: &PdoSet) -> CliError {
    let name = kind_name(kind.direction());
    let read: Vec<String> = set.iter().map(label).collect();
    let read = if read.is_empty() {
        format!("no {name}")
    } else {
        read.join(", ")
    };
    let rule = if node.dictionary().is_some() {
        "the PDOs its --eds dictionary lists"
    } else {
        "without --eds NODE=FILE, PDO 1..4, those the node has"
    };
    CliError::Device(format!(
        "node {}: no {name}{number} (read {rule}: {read})",
        node.id()
    ))
}

fn show(node: &Node, kind: Option<Kind>, number: Option<u16>, g: Global) -> Result<(), CliError> {
    let kinds = match kind {
        Some(k) => vec![k],
        None => vec![Kind::Rpdo, Kind::Tpdo],
    };
    let mut pdos = Vec::new();
    for k in kinds {
        let set = read(node, k)?;
        match number {
            Some(n) => {
                let p = set.get(n).ok_or_else(|| absent(node, k, n, &set))?;
                pdos.push(p.clone());
            }
            None => pdos.extend(set.iter().cloned()),
        }
    }
    if g.json {
        let list: Vec<_> = pdos.iter().map(pdo_json).collect();
        outln(&json!({"node": node.id().get(), "pdos": list}).to_string());
        return Ok(());
    }
    if pdos.is_empty() {
        eprintln!(
            "node {}: no PDOs read{}",
            node.id(),
            if node.dictionary().is_some() {
                " (its --eds dictionary lists none)"
            } else {
                " (without --eds NODE=FILE PDO 1..4 are read; the node has none of them)"
            }
        );
    }
    let mut text = String::new();
    for p in &pdos {
        text.push_str(&pdo_text(p));
    }
    crate::out(&text);
    Ok(())
}

/// What `map` changes in the PDO.
struct Change {
    entries: Vec<Entry>,
    cob_id: Option<CanId>,
    transmission_type: Option<TransmissionType>,
    event_timer: Option<u16>,
    inhibit_time: Option<u16>,
    sync_start: Option<u8>,
    disabled: bool,
}

fn map(
    node: &Node,
    kind: Kind,
    number: u16,
    change: &Change,
    opts: &BusOpts,
    g: Global,
) -> Result<(), CliError> {
    // Before anything is sent: entries that need the node's dictionary.
    if node.dictionary().is_none() {
        for e in &change.entries {
            let why = match e {
                Entry::Address(a, None) => format!("its length is not known: give {a}/BITS"),
                Entry::Name(_) => "a name needs the node's dictionary".to_string(),
                Entry::Address(_, Some(_)) => continue,
            };
            return Err(CliError::usage(format!(
                "`{e}`: {why}, or give --eds {}=FILE",
                node.id()
            )));
        }
    }
    let mut set = read(node, kind)?;
    let absent_err = absent(node, kind, number, &set);
    let p = set.get_mut(number).ok_or(absent_err)?;
    p.clear();
    for e in &change.entries {
        match e {
            Entry::Address(a, Some(bits)) => p.map_entry(*a, *bits),
            Entry::Address(a, None) => p.map(*a).map_err(|x| CliError::from(x).into_usage())?,
            Entry::Name(name) => p
                .map(name.as_str())
                .map_err(|x| CliError::from(x).into_usage())?,
        }
    }
    if let Some(id) = change.cob_id {
        p.set_can_id(id);
    }
    if let Some(t) = change.transmission_type {
        p.set_transmission_type(t);
    }
    if let Some(ms) = change.event_timer {
        p.set_event_timer(Duration::from_millis(ms.into()))?;
    }
    if let Some(units) = change.inhibit_time {
        p.set_inhibit_time(Duration::from_micros(u64::from(units) * 100))?;
    }
    if let Some(v) = change.sync_start {
        if !p.has_sync_start() {
            return Err(CliError::Device(format!(
                "node {}, {}: the node has no SYNC start value (sub 6) for this PDO",
                node.id(),
                label(p)
            )));
        }
        p.comm.sync_start = v;
    }
    p.set_enabled(!change.disabled);
    let (bits, _) = size(p);
    let saved = match kind {
        Kind::Tpdo => node.tpdo().save(&mut set),
        Kind::Rpdo => node.rpdo().save(&mut set),
    };
    if let Err(e) = saved.wait() {
        let e = CliError::from(e);
        return Err(match fd_hint(node, opts, bits, &e) {
            Some(hint) => e.with_hint(hint),
            None => e,
        });
    }
    // Read back what the node holds now.
    let back = read(node, kind)?;
    let p = back
        .get(number)
        .ok_or_else(|| absent(node, kind, number, &back))?;
    if g.json {
        let mut v = pdo_json(p);
        v["node"] = json!(node.id().get());
        outln(&v.to_string());
    } else {
        eprintln!(
            "node {}: {} {} with {} object(s), {}",
            node.id(),
            label(p),
            if p.is_enabled() {
                "mapped and valid"
            } else {
                "mapped, left invalid"
            },
            p.mapped.len(),
            length_text(p)
        );
    }
    Ok(())
}

/// What to do when a mapping of `bits` was refused with `e` because the node or the bus is
/// not CANopen FD.
fn fd_hint(node: &Node, opts: &BusOpts, bits: u32, e: &CliError) -> Option<String> {
    if bits <= 64 || !matches!(e, CliError::Op(canola::Error::Value { .. })) {
        return None;
    }
    let udp = opts.iface.as_deref().is_some_and(|i| i.starts_with("udp"));
    let mut what = Vec::new();
    if !opts.fd && !udp {
        what.push(
            "give --fd for a CAN FD bus (a SocketCAN interface with MTU 72; the in-memory bus \
             then carries CAN FD; the UDP bus always does)"
                .to_string(),
        );
    }
    if !node.is_fd() {
        what.push(format!(
            "a node is marked CANopen FD by CANopenFD=1 in its --eds file (without --eds, by \
             --fd); or map at most 64 bits (8 bytes) on node {}",
            node.id()
        ));
    }
    (!what.is_empty()).then(|| what.join("; "))
}

/// The mapping's length: bits and whole bytes.
fn size(p: &PdoParameters) -> (u32, u32) {
    let bits: u32 = p.mapped.iter().map(|m| u32::from(m.bits)).sum();
    (bits, bits.div_ceil(8))
}

/// `96 bits (12 bytes)`, `8 bits (1 byte)`.
fn length_text(p: &PdoParameters) -> String {
    let (bits, bytes) = size(p);
    let unit = if bytes == 1 { "byte" } else { "bytes" };
    format!("{bits} bits ({bytes} {unit})")
}

/// The transmission type in words.
fn transmission_text(t: TransmissionType) -> String {
    match t {
        TransmissionType::SyncAcyclic => "synchronous, acyclic".into(),
        TransmissionType::SyncCyclic(1) => "synchronous, every SYNC".into(),
        TransmissionType::SyncCyclic(n) => format!("synchronous, every {n}th SYNC"),
        TransmissionType::Reserved(_) => "reserved".into(),
        TransmissionType::RtrSync => "on a remote request, sampled at SYNC".into(),
        TransmissionType::RtrEvent => "on a remote request".into(),
        TransmissionType::EventManufacturer => "event-driven, manufacturer-specific".into(),
        TransmissionType::EventProfile => "event-driven, device profile".into(),
    }
}

/// The entry's name: the dictionary's, or `dummy` for a data type index.
fn entry_name(m: &canola::MappedVariable) -> Option<String> {
    m.name.clone().or_else(|| {
        (m.addr.index != 0 && m.addr.index <= 0x0007 && m.addr.sub_index == 0)
            .then(|| "dummy".to_string())
    })
}

/// `1.5` for 15 units of 100 µs.
fn inhibit_ms(units: u16) -> String {
    format!("{}.{}", units / 10, units % 10)
}

fn cob_id_text(p: &PdoParameters) -> String {
    let raw = p.comm.cob_id.0;
    let id = p
        .comm
        .cob_id
        .can_id()
        .map_or_else(|_| "no CAN identifier".to_string(), |id| id.to_string());
    let mut text = format!(
        "COB-ID 0x{raw:08X} ({id}, {}",
        if p.is_enabled() { "valid" } else { "not valid" }
    );
    if p.direction() == Direction::Transmit && !p.rtr_allowed() {
        text.push_str(", no RTR");
    }
    text.push(')');
    text
}

fn pdo_text(p: &PdoParameters) -> String {
    let dir = p.direction();
    let n = p.number() - 1;
    let t = p.transmission_type();
    let mut head = format!(
        "{} (0x{:04X}, 0x{:04X}): {}\n  transmission type {} ({})",
        label(p),
        dir.comm_index(n),
        dir.mapping_index(n),
        cob_id_text(p),
        t.code(),
        transmission_text(t)
    );
    if p.has_inhibit_time() {
        head.push_str(&format!(
            ", inhibit time {} ms",
            inhibit_ms(p.comm.inhibit_time)
        ));
    }
    if p.has_event_timer() {
        match p.comm.event_timer {
            0 => head.push_str(", event timer off"),
            ms => head.push_str(&format!(", event timer {ms} ms")),
        }
    }
    if p.has_sync_start() {
        head.push_str(&format!(", SYNC start {}", p.comm.sync_start));
    }
    let mut out = format!("{head}\n");
    if let Some(code) = p.mpdo() {
        let kind = if code == 0xFE { "SAM-MPDO" } else { "DAM-MPDO" };
        out.push_str(&format!(
            "  MPDO: mapping sub-index 0 is 0x{code:02X} ({kind})\n"
        ));
        return out;
    }
    for m in &p.mapped {
        let addr = format!("{}", m.addr);
        match entry_name(m) {
            Some(name) => out.push_str(&format!("  {addr}  {:>2} bits  {name}\n", m.bits)),
            None => out.push_str(&format!("  {addr}  {:>2} bits\n", m.bits)),
        }
    }
    if p.mapped.is_empty() {
        out.push_str("  nothing mapped\n");
    } else {
        out.push_str(&format!(
            "  {} object(s), {}\n",
            p.mapped.len(),
            length_text(p)
        ));
    }
    out
}

fn pdo_json(p: &PdoParameters) -> serde_json::Value {
    let dir = p.direction();
    let n = p.number() - 1;
    let t = p.transmission_type();
    let (bits, bytes) = size(p);
    let mapped: Vec<_> = p
        .mapped
        .iter()
        .map(|m| {
            json!({
                "index": m.addr.index,
                "sub": m.addr.sub_index,
                "bits": m.bits,
                "name": entry_name(m),
            })
        })
        .collect();
    json!({
        "pdo": label(p),
        "kind": kind_name(dir).to_lowercase(),
        "number": p.number(),
        "comm_index": dir.comm_index(n),
        "mapping_index": dir.mapping_index(n),
        "cob_id": p.comm.cob_id.0,
        "can_id": p.comm.cob_id.can_id().ok().map(|id| id.as_raw()),
        "valid": p.is_enabled(),
        "rtr_allowed": p.rtr_allowed(),
        "transmission_type": t.code(),
        "transmission": transmission_text(t),
        "inhibit_time_ms": p.has_inhibit_time().then(|| f64::from(p.comm.inhibit_time) / 10.0),
        "event_timer_ms": p.has_event_timer().then_some(p.comm.event_timer),
        "sync_start": p.has_sync_start().then_some(p.comm.sync_start),
        "mpdo": p.mpdo(),
        "mapped": mapped,
        "bits": bits,
        "bytes": bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_parse_as_index_sub_and_bits() {
        let a = |i, s| ObjectAddress::new(i, s);
        assert_eq!(
            parse_entry("0x2100:05").unwrap(),
            Entry::Address(a(0x2100, 5), None)
        );
        assert_eq!(
            parse_entry("2100:0A/32").unwrap(),
            Entry::Address(a(0x2100, 10), Some(32))
        );
        assert_eq!(
            parse_entry("Temperature").unwrap(),
            Entry::Name("Temperature".into())
        );
        for bad in [
            "0x2100",
            "0x2100:",
            "0x2100:zz",
            "0x2100:05/0",
            "0x2100:05/x",
            "0x12345:0",
        ] {
            assert!(parse_entry(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn inhibit_time_is_in_steps_of_100_us() {
        assert_eq!(parse_inhibit("1.5").unwrap(), 15);
        assert_eq!(parse_inhibit("0").unwrap(), 0);
        assert_eq!(parse_inhibit("6553.5").unwrap(), 65535);
        assert!(parse_inhibit("0.05").is_err());
        assert!(parse_inhibit("6553.6").is_err());
        assert!(parse_inhibit("-1").is_err());
    }

    #[test]
    fn cob_ids_and_transmission_types() {
        assert_eq!(
            parse_can_id("0x187").unwrap(),
            CanId::standard(0x187).unwrap()
        );
        assert!(matches!(parse_can_id("0x800").unwrap(), CanId::Extended(_)));
        assert!(parse_can_id("0x80000187").is_err());
        assert!(parse_transmission_type("245").is_err());
        assert_eq!(
            parse_transmission_type("254").unwrap(),
            TransmissionType::EventManufacturer
        );
    }
}
