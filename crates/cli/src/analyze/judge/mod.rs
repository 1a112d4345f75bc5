//! The analyzer of `canopen analyze`: one streaming pass over a candump log that keeps a
//! bounded state per node, per PDO and for SYNC, and turns what it sees into a summary, a
//! timeline and a problem list.
//!
//! Frames are read with the stack's own decoders (the SDO, NMT, EMCY and LSS wire types that
//! [`canola::describe()`] shows, and [`Monitor`]'s tracking of SDO block transfers); the text of
//! a problem's "seen" is the line `canopen monitor` prints for the frame. Memory does not grow
//! with the log: per node a few numbers, one pending SDO request and the last boot-ups; per
//! PDO identifier a few numbers; problems and timeline entries are capped ([`MAX_ENTRIES`]),
//! and a problem that repeats (same kind, same node) within [`REPEAT_WINDOW_US`] of the last
//! one reported counts as a repeat of it instead of a new entry.
//!
//! The rules model what CiA 301 devices do (heartbeat producer 0x1017, boot-up then
//! Pre-operational, EMCY with error register, SDO client/server with one transfer at a time
//! per channel) and what CANopenNode, the most common device stack, sends: a heartbeat every
//! producer time without jitter beyond its timer tick, an EMCY when an error is set and an EMCY
//! with code 0x0000 when all are cleared.

mod faults;
mod life;
mod rates;
mod sdo;

use std::collections::{HashMap, VecDeque};

use canola::candump::LogFrame;
use canola::frame::cob::{CobId, FunctionCode, LSS_MASTER_TO_SLAVE};
use canola::nmt::{Emcy, ErrorControlFrame, NmtCommand, NmtTarget};
use canola::sdo::{ClientRequest, Initiate, ServerResponse};
use canola::{BusDictionary, CanFrame, CommandSpecifier, Monitor, NmtState, NodeId, describe};

/// At most this many problems and this many timeline entries are kept; the rest are counted.
pub(crate) const MAX_ENTRIES: usize = 10_000;

/// A problem of the same kind and node within this time of the last one reported is counted as
/// its repeat.
pub(crate) const REPEAT_WINDOW_US: u64 = 2_000_000;

/// How often (log time) the analyzer looks for what did not happen: heartbeats, SYNC, PDOs.
const SWEEP_US: u64 = 10_000;

/// How serious a problem is. `--check` fails on [`Level::Error`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Level {
    /// Worth knowing, not wrong: an LSS session, a heartbeat that came back.
    Info,
    /// Likely a fault, or the sign of one: a late heartbeat, an SDO abort, bus load.
    Warning,
    /// The network did not work as configured: a lost node, an EMCY, a bus-off, a bad line.
    Error,
}

impl Level {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Info => "info",
            Self::Warning => "warning",
            Self::Error => "error",
        }
    }
}

/// The kinds of problem (their names are the `kind` of the JSON output).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Kind {
    /// A log line that does not read.
    BadLine,
    /// No heartbeat for three producer times.
    HeartbeatLost,
    /// A heartbeat later than 1.5 producer times.
    HeartbeatLate,
    /// Heartbeats again after a loss.
    HeartbeatBack,
    /// A boot-up without an NMT reset before it.
    UnexpectedBootUp,
    /// Three boot-ups within 30 s.
    BootUpLoop,
    /// An emergency message.
    Emcy,
    /// An SDO transfer aborted.
    SdoAbort,
    /// An SDO request never answered.
    SdoUnanswered,
    /// An SDO request answered after the timeout.
    SdoLate,
    /// SYNC stopped.
    SyncLost,
    /// A SYNC interval off the period.
    SyncPeriod,
    /// A cyclic PDO stopped.
    PdoStopped,
    /// A cyclic PDO changed its rate.
    PdoRate,
    /// A CAN error frame.
    ErrorFrame,
    /// Two devices with one node-ID.
    DuplicateNodeId,
    /// LSS configuration traffic.
    LssSession,
    /// An NMT command to a node that had not yet booted after a reset.
    NmtWhileBooting,
    /// Bus load above the threshold.
    BusLoad,
}

impl Kind {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::BadLine => "bad-line",
            Self::HeartbeatLost => "heartbeat-lost",
            Self::HeartbeatLate => "heartbeat-late",
            Self::HeartbeatBack => "heartbeat-back",
            Self::UnexpectedBootUp => "unexpected-boot-up",
            Self::BootUpLoop => "boot-up-loop",
            Self::Emcy => "emcy",
            Self::SdoAbort => "sdo-abort",
            Self::SdoUnanswered => "sdo-unanswered",
            Self::SdoLate => "sdo-late",
            Self::SyncLost => "sync-lost",
            Self::SyncPeriod => "sync-period",
            Self::PdoStopped => "pdo-stopped",
            Self::PdoRate => "pdo-rate",
            Self::ErrorFrame => "error-frame",
            Self::DuplicateNodeId => "duplicate-node-id",
            Self::LssSession => "lss-session",
            Self::NmtWhileBooting => "nmt-while-booting",
            Self::BusLoad => "bus-load",
        }
    }
}

/// One entry of the problem list.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Problem {
    /// When it happened, µs in the log's time base.
    pub(crate) time_us: u64,
    /// The log line that shows it, where one does.
    pub(crate) line: Option<usize>,
    pub(crate) node: Option<u8>,
    pub(crate) level: Level,
    pub(crate) kind: Kind,
    /// What was seen.
    pub(crate) seen: String,
    /// What it likely means.
    pub(crate) meaning: String,
    /// How often it happened again within [`REPEAT_WINDOW_US`] of the previous time.
    pub(crate) repeats: u64,
}

/// One entry of the timeline: NMT commands, boot-ups, state changes, LSS.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Event {
    pub(crate) time_us: u64,
    pub(crate) line: usize,
    pub(crate) node: Option<u8>,
    pub(crate) text: String,
}

/// Where a node's heartbeat producer time came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PeriodSource {
    /// Its EDS or DCF (`--eds`), object 0x1017.
    Dictionary,
    /// An SDO write of 0x1017 seen in the log.
    SdoWrite,
    /// The intervals of its first heartbeats.
    Observed,
}

impl PeriodSource {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Dictionary => "eds",
            Self::SdoWrite => "sdo-write",
            Self::Observed => "observed",
        }
    }
}

/// What is known of a node at the end.
#[derive(Debug, Clone, Default)]
pub(crate) struct NodeSummary {
    pub(crate) node: u8,
    pub(crate) state: Option<NmtState>,
    pub(crate) heartbeat_ms: Option<u64>,
    pub(crate) heartbeat_from: Option<PeriodSource>,
    pub(crate) boot_ups: u64,
    pub(crate) emcys: u64,
    pub(crate) frames: u64,
    pub(crate) vendor_id: Option<u32>,
    pub(crate) product_code: Option<u32>,
    pub(crate) name: Option<String>,
}

/// Settings of one analysis.
#[derive(Debug, Clone)]
pub(crate) struct Config {
    /// Bit rate for the bus load, bit/s.
    pub(crate) bitrate: u32,
    /// Bus load above this percentage in a second is a problem.
    pub(crate) load_threshold: f64,
    /// An SDO answer later than this is late (µs).
    pub(crate) sdo_timeout_us: u64,
    /// The nodes' dictionaries (`--eds`).
    pub(crate) dictionary: BusDictionary,
}

/// The per-node state.
#[derive(Debug, Default)]
struct Node {
    summary: NodeSummary,
    /// Known from a dictionary, a frame of its own, or an NMT command to it.
    seen: bool,
    last_hb: Option<u64>,
    /// Producer time in µs.
    period: Option<u64>,
    /// The first heartbeat intervals, while the period is observed.
    first_intervals: Vec<u64>,
    hb_lost: bool,
    /// Heartbeats counted since `window_start` (ten producer times a window).
    window_start: u64,
    window_count: u32,
    /// An NMT command to the node since its last state change.
    commanded: bool,
    /// State changes no NMT command or boot-up explains.
    unexplained: u32,
    duplicate_reported: bool,
    boot_ups: VecDeque<u64>,
    loop_reported: bool,
    /// An NMT reset sent at this time, no boot-up since.
    resetting: Option<u64>,
    /// An SDO request waiting for its answer: time, line, frame.
    sdo: Option<(u64, usize, CanFrame)>,
    /// The last initiate answer: time (a second one right after it with no request is another
    /// device's).
    last_answer: Option<u64>,
    drive: bool,
}

/// The state per PDO identifier.
#[derive(Debug, Default, Clone, Copy)]
struct Pdo {
    last: u64,
    count: u64,
    /// Mean interval, µs (exponential average).
    mean: f64,
    stopped: bool,
    window_sum: u64,
    window_n: u32,
    window_mean: Option<f64>,
}

/// The whole state of an analysis.
pub(crate) struct Analyzer {
    config: Config,
    monitor: Monitor,
    nodes: Vec<Node>,
    pdos: HashMap<u16, Pdo>,
    pub(crate) problems: Vec<Problem>,
    pub(crate) problems_dropped: u64,
    last_of_kind: HashMap<(Kind, Option<u8>), usize>,
    pub(crate) timeline: Vec<Event>,
    pub(crate) timeline_dropped: u64,
    pub(crate) first_us: Option<u64>,
    pub(crate) last_us: u64,
    pub(crate) frames: u64,
    pub(crate) fd_frames: u64,
    pub(crate) error_frames: u64,
    pub(crate) bad_lines: u64,
    next_sweep: u64,
    sync_last: Option<u64>,
    sync_intervals: Vec<u64>,
    sync_period: Option<u64>,
    sync_lost: bool,
    /// Bus load: the current second (relative index) and its bits.
    load_second: u64,
    load_bits: u64,
    pub(crate) load_peak: f64,
    pub(crate) load_peak_at_us: u64,
    pub(crate) total_bits: u64,
    line: usize,
}

impl Analyzer {
    pub(crate) fn new(config: Config) -> Self {
        let mut nodes: Vec<Node> = (0..128).map(|_| Node::default()).collect();
        for (i, n) in nodes.iter_mut().enumerate() {
            n.summary.node = i as u8;
        }
        for id in 1..=127u8 {
            let Ok(node_id) = NodeId::new(id) else {
                continue;
            };
            let Some(od) = config.dictionary.dictionary(node_id) else {
                continue;
            };
            let n = &mut nodes[usize::from(id)];
            n.seen = true;
            let value = |index: u16, sub: u8| {
                let bytes = od.sub(index, sub)?.effective_value(id)?.to_le_bytes();
                let mut b = [0u8; 8];
                let k = bytes.len().min(8);
                b[..k].copy_from_slice(&bytes[..k]);
                Some(u64::from_le_bytes(b))
            };
            if let Some(ms) = value(0x1017, 0).filter(|ms| *ms > 0) {
                n.period = Some(ms * 1000);
                n.summary.heartbeat_ms = Some(ms);
                n.summary.heartbeat_from = Some(PeriodSource::Dictionary);
            }
            n.drive = value(0x1000, 0).is_some_and(|t| t & 0xFFFF == 402);
            let info = &od.device_info;
            n.summary.vendor_id = info.vendor_number;
            n.summary.product_code = info.product_number;
            n.summary.name = match (&info.vendor_name, &info.product_name) {
                (Some(v), Some(p)) => Some(format!("{v} {p}")),
                (None, Some(p)) => Some(p.clone()),
                (Some(v), None) => Some(v.clone()),
                (None, None) => None,
            };
        }
        let monitor = Monitor::new(config.dictionary.clone());
        Self {
            config,
            monitor,
            nodes,
            pdos: HashMap::new(),
            problems: Vec::new(),
            problems_dropped: 0,
            last_of_kind: HashMap::new(),
            timeline: Vec::new(),
            timeline_dropped: 0,
            first_us: None,
            last_us: 0,
            frames: 0,
            fd_frames: 0,
            error_frames: 0,
            bad_lines: 0,
            next_sweep: 0,
            sync_last: None,
            sync_intervals: Vec::new(),
            sync_period: None,
            sync_lost: false,
            load_second: 0,
            load_bits: 0,
            load_peak: 0.0,
            load_peak_at_us: 0,
            total_bits: 0,
            line: 0,
        }
    }

    /// Adds a problem (or counts it as a repeat of the last one of its kind and node).
    #[allow(clippy::too_many_arguments)]
    fn problem(
        &mut self,
        time_us: u64,
        line: Option<usize>,
        node: Option<u8>,
        level: Level,
        kind: Kind,
        seen: String,
        meaning: String,
    ) {
        if let Some(&i) = self.last_of_kind.get(&(kind, node)) {
            let p = &mut self.problems[i];
            if time_us.saturating_sub(p.time_us) <= REPEAT_WINDOW_US * (p.repeats + 1) {
                p.repeats += 1;
                return;
            }
        }
        if self.problems.len() >= MAX_ENTRIES {
            self.problems_dropped += 1;
            return;
        }
        self.last_of_kind.insert((kind, node), self.problems.len());
        self.problems.push(Problem {
            time_us,
            line,
            node,
            level,
            kind,
            seen,
            meaning,
            repeats: 0,
        });
    }

    fn event(&mut self, time_us: u64, node: Option<u8>, text: String) {
        if self.timeline.len() >= MAX_ENTRIES {
            self.timeline_dropped += 1;
            return;
        }
        self.timeline.push(Event {
            time_us,
            line: self.line,
            node,
            text,
        });
    }

    /// A line that does not read: an error-level problem with its line number, at the time of
    /// the last line that did.
    pub(crate) fn bad_line(&mut self, line: usize, what: String) {
        self.bad_lines += 1;
        self.problem(
            self.last_us,
            Some(line),
            None,
            Level::Error,
            Kind::BadLine,
            what,
            "the log is damaged here (cut, edited, or not a candump log); its frames are missing"
                .into(),
        );
        // Bad lines do not repeat into one another: each keeps its line number.
        self.last_of_kind.remove(&(Kind::BadLine, None));
    }

    /// Relative seconds of a time in the log, for texts.
    fn rel(&self, us: u64) -> String {
        let base = self.first_us.unwrap_or(0);
        format!("{:.6} s", us.saturating_sub(base) as f64 / 1e6)
    }

    /// The next frame of the log, from line `line`.
    pub(crate) fn frame(&mut self, line: usize, time_us: u64, frame: &LogFrame) {
        self.line = line;
        let first = *self.first_us.get_or_insert(time_us);
        // A log's time stamps normally rise; one that goes back is taken as the same time.
        let time_us = time_us.max(self.last_us);
        self.last_us = time_us;
        if time_us >= self.next_sweep {
            self.sweep(time_us);
            self.next_sweep = time_us + SWEEP_US;
        }
        let bits = match frame {
            LogFrame::Can(f) => u64::from(canola::mem::frame_bits(f, false)),
            LogFrame::Fd(f) => {
                let (a, d) = canola::mem::fd_frame_bits(f, false);
                u64::from(a + d)
            }
            // An error frame: the error flag and delimiter, 14 bits on the wire at most.
            LogFrame::Error { .. } => 14,
        };
        self.load(first, time_us, bits);
        self.frames += 1;
        match frame {
            LogFrame::Can(f) => self.can(line, time_us, f),
            LogFrame::Fd(_) => self.fd_frames += 1,
            LogFrame::Error { class, data } => self.error_frame(line, time_us, *class, data),
        }
    }

    fn seen(&self, frame: &CanFrame) -> String {
        format!(
            "{}  {}",
            frame,
            describe(frame, &self.config.dictionary).what()
        )
    }

    fn can(&mut self, line: usize, t: u64, frame: &CanFrame) {
        let block_segment = self.monitor.observe(frame);
        let Some(raw) = frame.cob_id() else {
            return;
        };
        if raw == LSS_MASTER_TO_SLAVE {
            self.lss(t, frame);
            return;
        }
        let Some(cob) = CobId::classify(raw) else {
            return;
        };
        if let Some(n) = cob.node {
            self.touch(n.get());
        }
        match (cob.function, cob.node) {
            (FunctionCode::Nmt, _) => self.nmt(line, t, frame),
            (FunctionCode::Sync, _) => self.sync(line, t),
            (FunctionCode::Emcy, Some(n)) => self.emcy(line, t, n.get(), frame),
            (FunctionCode::NmtErrorControl, Some(n)) => {
                if let Ok(ErrorControlFrame::Payload(b)) =
                    ErrorControlFrame::from_frame(frame).map(|(_, k)| k)
                {
                    self.heartbeat(line, t, n.get(), b, frame);
                }
            }
            (FunctionCode::SdoRx, Some(n)) if !block_segment => {
                self.sdo_request(line, t, n.get(), frame)
            }
            (FunctionCode::SdoTx, Some(n)) if !block_segment => {
                self.sdo_response(line, t, n.get(), frame)
            }
            (FunctionCode::Tpdo(_) | FunctionCode::Rpdo(_), Some(_)) if !frame.is_remote() => {
                self.pdo(line, t, raw, frame)
            }
            _ => {}
        }
    }

    fn touch(&mut self, n: u8) {
        let node = &mut self.nodes[usize::from(n)];
        node.seen = true;
        node.summary.frames += 1;
    }

    /// Looks for what should have happened by `now` and did not.
    fn sweep(&mut self, now: u64) {
        for n in 1..=127u8 {
            let node = &self.nodes[usize::from(n)];
            let (Some(last), Some(period)) = (node.last_hb, node.period) else {
                continue;
            };
            if node.hb_lost || now.saturating_sub(last) <= period * 3 {
                continue;
            }
            self.nodes[usize::from(n)].hb_lost = true;
            let from = self.nodes[usize::from(n)].summary.heartbeat_from;
            let last_at = self.rel(last);
            self.problem(
                last + period,
                None,
                Some(n),
                Level::Error,
                Kind::HeartbeatLost,
                format!(
                    "no heartbeat of node {n} after the one at {last_at}; producer time {} ms ({})",
                    period / 1000,
                    from.map_or("?", PeriodSource::name)
                ),
                "the node stopped working, lost power or its connection to the bus (a \
                 heartbeat consumer reports a heartbeat event)"
                    .into(),
            );
        }
        if let (Some(last), Some(period)) = (self.sync_last, self.sync_period)
            && !self.sync_lost
            && now.saturating_sub(last) > period * 3
        {
            self.sync_lost = true;
            let last_at = self.rel(last);
            self.problem(
                last + period,
                None,
                None,
                Level::Error,
                Kind::SyncLost,
                format!(
                    "no SYNC after the one at {last_at}; period {:.1} ms",
                    period as f64 / 1000.0
                ),
                "the SYNC producer stopped: synchronous PDOs stop with it".into(),
            );
        }
        let mut stopped = Vec::new();
        for (raw, p) in &mut self.pdos {
            // Cyclic PDOs only: ten or more at under a second each.
            if p.stopped || p.count < 10 || p.mean <= 0.0 || p.mean > 1e6 {
                continue;
            }
            let silence = now.saturating_sub(p.last) as f64;
            if silence > (p.mean * 5.0).max(50_000.0) {
                p.stopped = true;
                stopped.push((*raw, p.last, p.mean));
            }
        }
        stopped.sort_unstable_by_key(|s| s.0);
        for (raw, last, mean) in stopped {
            let last_at = self.rel(last);
            let label = pdo_label(raw);
            self.problem(
                last + mean as u64,
                None,
                u8::try_from(raw & 0x7F).ok(),
                Level::Warning,
                Kind::PdoStopped,
                format!(
                    "{label} (0x{raw:03X}) every {:.1} ms until {last_at}, then no more",
                    mean / 1000.0
                ),
                "the producer stopped sending it: not Operational any more, its SYNC stopped, \
                 or it lost the bus"
                    .into(),
            );
        }
    }

    /// Ends the analysis at the log's last time stamp.
    pub(crate) fn finish(&mut self) {
        if self.first_us.is_none() {
            return;
        }
        let end = self.last_us;
        self.sweep(end);
        self.close_second();
        let timeout = self.config.sdo_timeout_us;
        for n in 1..=127u8 {
            if let Some((at, line, request)) = self.nodes[usize::from(n)].sdo.take()
                && end - at > timeout
            {
                self.unanswered(n, at, line, &request, "the log ends");
            }
        }
        self.problems.sort_by_key(|p| p.time_us);
    }

    /// The nodes seen, in node order.
    pub(crate) fn nodes(&self) -> impl Iterator<Item = &NodeSummary> {
        self.nodes.iter().filter(|n| n.seen).map(|n| &n.summary)
    }

    /// Whether the list has an error-level problem.
    pub(crate) fn has_errors(&self) -> bool {
        self.problems.iter().any(|p| p.level == Level::Error)
    }

    /// The mean bus load over the log, percent.
    pub(crate) fn load_mean(&self) -> f64 {
        let secs = self.duration_us().max(1) as f64 / 1e6;
        self.total_bits as f64 * 100.0 / f64::from(self.config.bitrate.max(1)) / secs
    }

    pub(crate) fn duration_us(&self) -> u64 {
        self.first_us.map_or(0, |f| self.last_us - f)
    }
}

/// `TPDO1 node 5` for a PDO identifier of the predefined connection set.
fn pdo_label(raw: u16) -> String {
    match CobId::classify(raw) {
        Some(CobId {
            function: FunctionCode::Tpdo(p),
            node: Some(n),
        }) => format!("TPDO{} node {n}", p.get()),
        Some(CobId {
            function: FunctionCode::Rpdo(p),
            node: Some(n),
        }) => format!("RPDO{} node {n}", p.get()),
        _ => format!("PDO 0x{raw:03X}"),
    }
}

pub(crate) fn state_name(s: NmtState) -> String {
    match s {
        NmtState::BootUp => "Boot-up".into(),
        NmtState::Stopped => "Stopped".into(),
        NmtState::Operational => "Operational".into(),
        NmtState::PreOperational => "Pre-operational".into(),
        NmtState::Unknown(b) => format!("state {b:#04x}"),
    }
}

fn hex(data: &[u8]) -> String {
    data.iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Judges a log written as `SECONDS FRAME` lines (candump's format around them).
    fn judge(lines: &[(f64, &str)], bitrate: u32) -> Analyzer {
        let text: String = lines
            .iter()
            .map(|(t, f)| format!("({:.6}) can0 {f}\n", 1000.0 + t))
            .collect();
        let mut a = Analyzer::new(Config {
            bitrate,
            load_threshold: 70.0,
            sdo_timeout_us: 500_000,
            dictionary: BusDictionary::new(),
        });
        let mut reader = canola::candump::Reader::new(text.as_bytes());
        while let Some(entry) = reader.next() {
            let e = entry.expect("a good line");
            a.frame(reader.line(), e.timestamp_us, &e.frame);
        }
        a.finish();
        a
    }

    fn found(a: &Analyzer, kind: Kind) -> Vec<&Problem> {
        a.problems.iter().filter(|p| p.kind == kind).collect()
    }

    fn at(a: &Analyzer, p: &Problem) -> f64 {
        (p.time_us - a.first_us.unwrap()) as f64 / 1e6
    }

    /// Heartbeats of `node` every `period` s from `from` to `to` (exclusive).
    fn heartbeats(node: u8, state: u8, from: f64, to: f64, period: f64) -> Vec<(f64, String)> {
        let n = ((to - from) / period).round() as usize;
        (0..n)
            .map(|i| {
                (
                    from + i as f64 * period,
                    format!("{:03X}#{state:02X}", 0x700 + u16::from(node)),
                )
            })
            .collect()
    }

    fn lines(v: &[(f64, String)]) -> Vec<(f64, &str)> {
        let mut out: Vec<(f64, &str)> = v.iter().map(|(t, s)| (*t, s.as_str())).collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    #[test]
    fn an_nmt_command_while_a_node_boots_is_found() {
        let a = judge(
            &[
                (0.0, "705#00"),
                (1.0, "000#8105"),
                (1.01, "000#0105"),
                (1.5, "705#00"),
                (2.0, "000#0105"),
            ],
            500_000,
        );
        let p = found(&a, Kind::NmtWhileBooting);
        assert_eq!(p.len(), 1, "{:#?}", a.problems);
        assert_eq!((p[0].node, p[0].line), (Some(5), Some(3)));
        assert!((at(&a, p[0]) - 1.01).abs() < 1e-6);
        // The boot-up after the reset was asked for: not unexpected.
        assert!(found(&a, Kind::UnexpectedBootUp).is_empty());
        assert_eq!(a.timeline.len(), 5, "{:#?}", a.timeline);
    }

    #[test]
    fn error_frames_bus_off_and_error_passive_are_found() {
        let a = judge(
            &[
                (0.0, "705#05"),
                (0.5, "20000004#0010000000000000"),
                (0.6, "20000040#0000000000000000"),
                (0.7, "20000020#0000000000000000"),
            ],
            500_000,
        );
        let p = found(&a, Kind::ErrorFrame);
        // One problem per kind and node within the repeat window: the first, counted after.
        assert_eq!(p.len(), 1, "{:#?}", a.problems);
        assert!(p[0].seen.contains("error-passive"), "{}", p[0].seen);
        assert_eq!(p[0].repeats, 2);
        assert_eq!(a.error_frames, 3);
        let a = judge(&[(0.0, "20000040#0000000000000000")], 500_000);
        let p = found(&a, Kind::ErrorFrame);
        assert_eq!(p[0].level, Level::Error);
        assert!(p[0].seen.starts_with("bus-off"));
    }

    #[test]
    fn an_lss_session_is_noted() {
        let a = judge(
            &[
                (0.0, "7E5#0401000000000000"),
                (0.01, "7E5#1109000000000000"),
                (0.02, "7E4#1100000000000000"),
                (0.03, "7E5#0400000000000000"),
            ],
            500_000,
        );
        let p = found(&a, Kind::LssSession);
        assert_eq!(p.len(), 1, "{:#?}", a.problems);
        assert_eq!(p[0].level, Level::Info);
        assert_eq!(a.timeline.len(), 3, "{:#?}", a.timeline);
        assert!(a.timeline[1].text.contains("9"), "{:#?}", a.timeline);
    }

    #[test]
    fn bus_load_above_the_threshold_is_found() {
        // 100 frames of 8 bytes (111 bits each) in one second at 10 kbit/s: 111 %.
        let frames: Vec<(f64, String)> = (0..100)
            .map(|i| (f64::from(i) * 0.01, "181#0102030405060708".to_string()))
            .chain([(1.5, "705#05".to_string())])
            .collect();
        let a = judge(&lines(&frames), 10_000);
        let p = found(&a, Kind::BusLoad);
        assert_eq!(p.len(), 1, "{:#?}", a.problems);
        assert!(p[0].seen.contains("111.0 %"), "{}", p[0].seen);
        assert!((a.load_peak - 111.0).abs() < 0.01);
        assert_eq!(at(&a, p[0]), 0.0);
    }

    #[test]
    fn a_pdo_that_changes_rate_and_then_stops_is_found() {
        let mut v = heartbeats(5, 5, 0.0, 3.0, 0.1);
        v.extend((0..100).map(|i| (f64::from(i) * 0.01, "185#01".to_string())));
        v.extend((0..30).map(|i| (1.0 + f64::from(i) * 0.05, "185#02".to_string())));
        let a = judge(&lines(&v), 500_000);
        let rate = found(&a, Kind::PdoRate);
        assert_eq!(rate.len(), 1, "{:#?}", a.problems);
        assert_eq!(rate[0].node, Some(5));
        assert!(
            rate[0].seen.contains("every 50.0 ms, before every 10.0 ms"),
            "{}",
            rate[0].seen
        );
        let stopped = found(&a, Kind::PdoStopped);
        assert_eq!(stopped.len(), 1, "{:#?}", a.problems);
        assert!(
            stopped[0].seen.starts_with("TPDO1 node 5"),
            "{}",
            stopped[0].seen
        );
        let t = at(&a, stopped[0]);
        // Due one mean interval after the last one, at 2.45 s.
        assert!(t > 2.45 && t < 2.55, "{t}");
    }

    #[test]
    fn a_sync_off_its_period_and_a_late_heartbeat_are_found() {
        let mut v: Vec<(f64, String)> = (0..50)
            .map(|i| (f64::from(i) * 0.01, "080#".to_string()))
            .collect();
        // One SYNC 10 ms late.
        v.push((0.51, "080#".into()));
        v.extend((0..20).map(|i| (0.52 + f64::from(i) * 0.01, "080#".to_string())));
        v.extend(heartbeats(5, 5, 0.0, 0.5, 0.1));
        v.push((0.58, "705#05".into()));
        v.push((0.68, "705#05".into()));
        let a = judge(&lines(&v), 500_000);
        let sync = found(&a, Kind::SyncPeriod);
        assert_eq!(sync.len(), 1, "{:#?}", a.problems);
        assert!((at(&a, sync[0]) - 0.51).abs() < 1e-6);
        let late = found(&a, Kind::HeartbeatLate);
        assert_eq!(late.len(), 1, "{:#?}", a.problems);
        assert_eq!(late[0].node, Some(5));
        assert!((at(&a, late[0]) - 0.58).abs() < 1e-6);
        assert!(late[0].seen.contains("180 ms"), "{}", late[0].seen);
    }

    #[test]
    fn two_sdo_answers_to_one_request_are_a_duplicate_node_id() {
        let a = judge(
            &[
                (0.0, "605#4018100100000000"),
                (0.001, "585#4318100178000000"),
                (0.0012, "585#4318100179000000"),
            ],
            500_000,
        );
        let p = found(&a, Kind::DuplicateNodeId);
        assert_eq!(p.len(), 1, "{:#?}", a.problems);
        assert_eq!((p[0].node, p[0].line), (Some(5), Some(3)));
        // The first answer's vendor-ID is the node's.
        let five = a.nodes().find(|n| n.node == 5).unwrap();
        assert_eq!(five.vendor_id, Some(0x79));
    }
}
