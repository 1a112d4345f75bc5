//! The analyzer of `canopen analyze`: one streaming pass over a candump log that keeps a
//! bounded state per node, per PDO and for SYNC, and turns what it sees into a summary, a
//! timeline and a problem list.
//!
//! Frames are read with the stack's own decoders (the SDO, NMT, EMCY and LSS wire types that
//! [`canola::describe`] shows, and [`Monitor`]'s tracking of SDO block transfers); the text of
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

    /// Bus load per second of log time, at the configured bit rate.
    fn load(&mut self, first: u64, time_us: u64, bits: u64) {
        let second = (time_us - first) / 1_000_000;
        if second != self.load_second {
            self.close_second();
            self.load_second = second;
            self.load_bits = 0;
        }
        self.load_bits += bits;
        self.total_bits += bits;
    }

    fn close_second(&mut self) {
        let load = self.load_bits as f64 * 100.0 / f64::from(self.config.bitrate.max(1));
        let at = self.first_us.unwrap_or(0) + self.load_second * 1_000_000;
        if load > self.load_peak {
            self.load_peak = load;
            self.load_peak_at_us = at;
        }
        if load > self.config.load_threshold {
            self.problem(
                at,
                None,
                None,
                Level::Warning,
                Kind::BusLoad,
                format!(
                    "bus load {load:.1} % in the second from {} (at {} bit/s)",
                    self.rel(at),
                    self.config.bitrate
                ),
                format!(
                    "above {:.0} %: low-priority frames (SDO, heartbeats) wait for the bus and \
                     arrive late",
                    self.config.load_threshold
                ),
            );
        }
    }

    fn error_frame(&mut self, line: usize, t: u64, class: u32, data: &[u8; 8]) {
        self.error_frames += 1;
        // Linux can/error.h: the class bits and the controller status in data[1].
        let (level, what, meaning) = if class & 0x40 != 0 {
            (
                Level::Error,
                "bus-off",
                "the controller left the bus after too many transmit errors (wiring, \
                 termination, bit rate, a faulty node)",
            )
        } else if class & 0x04 != 0 && data[1] & 0x30 != 0 {
            (
                Level::Warning,
                "controller error-passive",
                "error counters above 127: the bus has frequent errors (wiring, termination, \
                 bit rate)",
            )
        } else if class & 0x20 != 0 {
            (
                Level::Warning,
                "no acknowledgement",
                "nobody acknowledged a frame: no other node is on the bus, or it uses another \
                 bit rate",
            )
        } else if class & 0x08 != 0 {
            (
                Level::Warning,
                "protocol violation",
                "bit, form or stuff errors on the bus (noise, termination, bit timing)",
            )
        } else {
            (
                Level::Warning,
                "error frame",
                "the controller reported an error on the bus",
            )
        };
        let seen = format!("{what} (error class {class:#x}, data {})", hex(data));
        self.problem(
            t,
            Some(line),
            None,
            level,
            Kind::ErrorFrame,
            seen,
            meaning.into(),
        );
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

    fn lss(&mut self, t: u64, frame: &CanFrame) {
        use canola::lss::{Mode, Request};
        let Ok(req) = Request::from_frame(frame) else {
            return;
        };
        let text = describe(frame, &self.config.dictionary).what().to_string();
        match req {
            Request::SwitchModeGlobal(Mode::Configuration) | Request::SwitchModeSelective(..) => {
                self.event(t, None, text.clone());
                self.problem(
                    t,
                    Some(self.line),
                    None,
                    Level::Info,
                    Kind::LssSession,
                    text,
                    "an LSS master puts slaves into configuration state (CiA 305) to set \
                     node-ID or bit rate"
                        .into(),
                );
            }
            Request::SwitchModeGlobal(_)
            | Request::ConfigureNodeId(_)
            | Request::ConfigureBitTiming(_)
            | Request::ActivateBitTiming { .. }
            | Request::StoreConfiguration => self.event(t, None, text),
            _ => {}
        }
    }

    fn nmt(&mut self, line: usize, t: u64, frame: &CanFrame) {
        let text = describe(frame, &self.config.dictionary).what().to_string();
        let Ok(cmd) = NmtCommand::parse(frame.data()) else {
            self.problem(
                t,
                Some(line),
                None,
                Level::Warning,
                Kind::BadLine,
                self.seen(frame),
                "an NMT frame that is not two bytes: no node acts on it".into(),
            );
            return;
        };
        let targets: Vec<u8> = match cmd.target {
            NmtTarget::All => (1..=127u8)
                .filter(|n| self.nodes[usize::from(*n)].seen)
                .collect(),
            NmtTarget::Node(n) => vec![n.get()],
            _ => Vec::new(),
        };
        let target_node = match cmd.target {
            NmtTarget::Node(n) => Some(n.get()),
            _ => None,
        };
        self.event(t, target_node, text.clone());
        let reset = matches!(
            cmd.command,
            CommandSpecifier::ResetNode | CommandSpecifier::ResetCommunication
        );
        for n in targets {
            let node = &mut self.nodes[usize::from(n)];
            node.seen = true;
            node.commanded = true;
            // A node answers a reset with its boot-up within a few seconds (CiA 301 §7.3.2);
            // one that did not in 10 s is taken as gone.
            let booting = node
                .resetting
                .filter(|at| t.saturating_sub(*at) < 10_000_000);
            if reset {
                node.resetting = Some(t);
            } else if let Some(at) = booting {
                let since = self.rel(at);
                self.problem(
                    t,
                    Some(line),
                    Some(n),
                    Level::Warning,
                    Kind::NmtWhileBooting,
                    format!("{text} while node {n} was booting (reset at {since}, no boot-up yet)"),
                    "a node still initialising ignores NMT commands; it will boot into \
                     Pre-operational, not the state the master asked for"
                        .into(),
                );
            }
        }
    }

    fn heartbeat(&mut self, line: usize, t: u64, n: u8, byte: u8, frame: &CanFrame) {
        let state = NmtState::from_u8(byte);
        if state == NmtState::BootUp {
            self.boot_up(line, t, n, frame);
            return;
        }
        let rel_t = self.rel(t);
        let node = &mut self.nodes[usize::from(n)];
        let previous = node.summary.state.replace(state);
        let mut late = None;
        let mut duplicate: Option<String> = None;
        let mut back = None;
        // Two devices on one node-ID: their heartbeats disagree on the state with no NMT
        // command between (one was started, the other has just booted)...
        if previous.is_some_and(|p| p != state) {
            if std::mem::take(&mut node.commanded) {
                node.unexplained = 0;
            } else {
                node.unexplained += 1;
                if node.unexplained >= 3 && !node.duplicate_reported {
                    node.duplicate_reported = true;
                    duplicate = Some(format!(
                        "heartbeats of node {n} change between {} and {} with no NMT command",
                        state_name(previous.unwrap_or(state)),
                        state_name(state)
                    ));
                }
            }
        }
        if let Some(last) = node.last_hb {
            let interval = t - last;
            match node.period {
                Some(period) => {
                    if node.hb_lost {
                        node.hb_lost = false;
                        back = Some(interval);
                    } else if interval * 2 > period * 3 {
                        late = Some((interval, period));
                    }
                    // ...or come half again as often as the producer time allows.
                    if t - node.window_start >= period * 10 {
                        let (count, span) = (node.window_count, t - node.window_start);
                        if count > 15 && !node.duplicate_reported {
                            node.duplicate_reported = true;
                            duplicate = Some(format!(
                                "{count} heartbeats of node {n} in {} ms, producer time {} ms",
                                span / 1000,
                                period / 1000
                            ));
                        }
                        node.window_start = t;
                        node.window_count = 0;
                    }
                    node.window_count += 1;
                }
                None => {
                    node.first_intervals.push(interval);
                    if node.first_intervals.len() == 3 {
                        let mut v = std::mem::take(&mut node.first_intervals);
                        v.sort_unstable();
                        let period = v[1].max(1);
                        node.period = Some(period);
                        node.summary.heartbeat_ms = Some(period.div_ceil(1000));
                        node.summary.heartbeat_from = Some(PeriodSource::Observed);
                    }
                }
            }
        }
        node.last_hb = Some(t);
        let from = node.summary.heartbeat_from;
        if previous.is_some_and(|p| p != state) {
            self.event(
                t,
                Some(n),
                format!(
                    "node {n}: {} → {}",
                    state_name(previous.unwrap_or(state)),
                    state_name(state)
                ),
            );
        }
        if let Some(after) = back {
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Info,
                Kind::HeartbeatBack,
                format!("{seen} (after {} ms of silence)", after / 1000),
                "the node is back without a boot-up: its connection to the bus was interrupted"
                    .into(),
            );
        }
        if let Some((interval, period)) = late {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::HeartbeatLate,
                format!(
                    "heartbeat of node {n} {} ms after the one before at {rel_t}; producer time {} ms ({})",
                    interval / 1000,
                    period / 1000,
                    from.map_or("?", PeriodSource::name)
                ),
                "a consumer with a consumer time near the producer time may already report a \
                 heartbeat event: bus load, a busy device, or a producer time set differently"
                    .into(),
            );
        }
        if let Some(seen) = duplicate {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Error,
                Kind::DuplicateNodeId,
                seen,
                format!("two devices use node-ID {n}: their SDO answers and PDOs collide"),
            );
        }
    }

    fn boot_up(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let seen = self.seen(frame);
        self.event(t, Some(n), format!("boot-up node {n}"));
        let node = &mut self.nodes[usize::from(n)];
        let commanded = node.resetting.take().is_some();
        let had_one = node.summary.boot_ups > 0 || node.last_hb.is_some();
        let twin = node.boot_ups.back().is_some_and(|b| t - b < 100_000);
        node.summary.boot_ups += 1;
        node.summary.state = Some(NmtState::PreOperational);
        node.commanded = false;
        node.window_start = t;
        node.window_count = 0;
        node.last_hb = Some(t);
        node.hb_lost = false;
        node.boot_ups.push_back(t);
        while node.boot_ups.front().is_some_and(|b| t - b > 30_000_000) {
            node.boot_ups.pop_front();
        }
        if node.boot_ups.len() == 1 {
            node.loop_reported = false;
        }
        let looping = node.boot_ups.len() >= 3 && !node.loop_reported;
        if looping {
            node.loop_reported = true;
        }
        let count = node.boot_ups.len();
        if twin {
            let report = !node.duplicate_reported;
            node.duplicate_reported = true;
            if report {
                self.problem(
                    t,
                    Some(line),
                    Some(n),
                    Level::Error,
                    Kind::DuplicateNodeId,
                    format!("two boot-ups of node {n} within 100 ms"),
                    format!("two devices use node-ID {n}: their SDO answers and PDOs collide"),
                );
            }
            return;
        }
        if looping {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Error,
                Kind::BootUpLoop,
                format!("{count} boot-ups of node {n} within 30 s"),
                "the node resets again and again: supply voltage, a watchdog, or a master that \
                 resets it because its configuration fails"
                    .into(),
            );
        } else if had_one && !commanded {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::UnexpectedBootUp,
                seen,
                "the node booted again without an NMT reset: power loss, a watchdog or a \
                 software reset; it lost its configuration and is Pre-operational"
                    .into(),
            );
        }
    }

    fn emcy(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let seen = self.seen(frame);
        let Ok(emcy) = Emcy::parse(frame.data()) else {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::Emcy,
                seen,
                "an EMCY of the wrong length (CiA 301 EMCY carries 8 bytes)".into(),
            );
            return;
        };
        let node = &mut self.nodes[usize::from(n)];
        node.summary.emcys += 1;
        let drive = node.drive;
        if emcy.code.is_reset() {
            self.event(t, Some(n), format!("node {n}: EMCY error reset"));
            return;
        }
        let profile = drive
            .then(|| canola_cia402::ErrorCode(emcy.code.0).name())
            .flatten();
        let what = match (profile, emcy.code.description()) {
            (Some(p), _) => format!("CiA 402: {p}"),
            (None, Some(d)) => d.to_string(),
            (None, None) => "a manufacturer-specific error".into(),
        };
        self.problem(
            t,
            Some(line),
            Some(n),
            Level::Error,
            Kind::Emcy,
            seen,
            format!(
                "node {n} signals {what} (error register {:#04x}: {})",
                emcy.register.0, emcy.register
            ),
        );
    }

    fn sdo_request(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let Ok(req) = ClientRequest::parse(frame.data()) else {
            return;
        };
        if let ClientRequest::Abort { code, .. } = req {
            self.nodes[usize::from(n)].sdo = None;
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoAbort,
                seen,
                format!("the client (master) aborted the transfer: {code}"),
            );
            return;
        }
        let expects_answer = matches!(
            req,
            ClientRequest::InitiateUpload { .. }
                | ClientRequest::InitiateDownload { .. }
                | ClientRequest::UploadSegment { .. }
                | ClientRequest::DownloadSegment(_)
                | ClientRequest::BlockUploadInitiate { .. }
                | ClientRequest::BlockDownloadInitiate { .. }
                | ClientRequest::BlockDownloadEnd { .. }
        );
        if !expects_answer {
            return;
        }
        if let Some((at, l, request)) = self.nodes[usize::from(n)].sdo.take() {
            self.unanswered(n, at, l, &request, "the client sent another request");
        }
        // An SDO write of the heartbeat producer time: the period from then on.
        if let ClientRequest::InitiateDownload {
            mux,
            data: Initiate::Expedited { data, .. },
        } = req
            && (mux.index, mux.subindex) == (0x1017, 0)
        {
            let ms = u64::from(u16::from_le_bytes([data[0], data[1]]));
            let node = &mut self.nodes[usize::from(n)];
            node.period = (ms > 0).then_some(ms * 1000);
            node.first_intervals.clear();
            node.summary.heartbeat_ms = (ms > 0).then_some(ms);
            node.summary.heartbeat_from = (ms > 0).then_some(PeriodSource::SdoWrite);
        }
        self.nodes[usize::from(n)].sdo = Some((t, line, *frame));
    }

    fn unanswered(&mut self, n: u8, at: u64, line: usize, request: &CanFrame, why: &str) {
        let seen = self.seen(request);
        self.problem(
            at,
            Some(line),
            Some(n),
            Level::Error,
            Kind::SdoUnanswered,
            format!("{seen} never answered ({why})"),
            format!(
                "node {n} did not answer: it is absent, not in a state that serves SDO, or the \
                 request was lost"
            ),
        );
    }

    fn sdo_response(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let Ok(resp) = ServerResponse::parse(frame.data()) else {
            return;
        };
        let timeout = self.config.sdo_timeout_us;
        let node = &mut self.nodes[usize::from(n)];
        let pending = node.sdo.take();
        let initiate = matches!(
            resp,
            ServerResponse::InitiateUpload { .. }
                | ServerResponse::InitiateDownload { .. }
                | ServerResponse::BlockUploadInitiate { .. }
                | ServerResponse::BlockDownloadInitiate { .. }
        );
        let second_answer =
            pending.is_none() && initiate && node.last_answer.is_some_and(|a| t - a < 50_000);
        if initiate {
            node.last_answer = Some(t);
        }
        if let ServerResponse::InitiateUpload {
            mux,
            data: Initiate::Expedited { data, .. },
        } = resp
        {
            let v = u32::from_le_bytes(data);
            match (mux.index, mux.subindex) {
                (0x1018, 1) => node.summary.vendor_id = Some(v),
                (0x1018, 2) => node.summary.product_code = Some(v),
                (0x1000, 0) => node.drive = v & 0xFFFF == 402,
                _ => {}
            }
        }
        let report_twin = second_answer && !node.duplicate_reported;
        if report_twin {
            node.duplicate_reported = true;
        }
        let late = pending.filter(|(at, _, _)| t - at > timeout);
        let abort = match resp {
            ServerResponse::Abort { code, .. } => Some(code),
            _ => None,
        };
        if !report_twin && late.is_none() && abort.is_none() {
            return;
        }
        let seen = self.seen(frame);
        if report_twin {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Error,
                Kind::DuplicateNodeId,
                format!("{seen}: a second answer to one SDO request"),
                format!("two devices use node-ID {n}: their SDO answers and PDOs collide"),
            );
        }
        if let Some((at, _, request)) = &late {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoLate,
                format!(
                    "{seen}: answered {} ms after the request ({})",
                    (t - at) / 1000,
                    self.seen(request)
                ),
                format!(
                    "slower than {} ms: a client with that timeout aborted the transfer already",
                    timeout / 1000
                ),
            );
        }
        if let Some(code) = abort {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoAbort,
                seen,
                format!("node {n} refused the transfer: {code}"),
            );
        }
    }

    fn sync(&mut self, line: usize, t: u64) {
        if let Some(last) = self.sync_last {
            let interval = t - last;
            if self.sync_lost {
                self.sync_lost = false;
                self.problem(
                    t,
                    Some(line),
                    None,
                    Level::Info,
                    Kind::SyncLost,
                    format!("SYNC again after {} ms", interval / 1000),
                    "the SYNC producer is back".into(),
                );
            } else if let Some(period) = self.sync_period {
                let off = interval.abs_diff(period);
                // Jitter under a quarter of the period (at least 1 ms) is a master's timer.
                if off > (period / 4).max(1000) {
                    self.problem(
                        t,
                        Some(line),
                        None,
                        Level::Warning,
                        Kind::SyncPeriod,
                        format!(
                            "SYNC {:.1} ms after the one before; period {:.1} ms",
                            interval as f64 / 1000.0,
                            period as f64 / 1000.0
                        ),
                        "synchronous PDOs are sampled and applied off their cycle: a busy \
                         SYNC producer or a loaded bus"
                            .into(),
                    );
                }
            } else {
                self.sync_intervals.push(interval);
                if self.sync_intervals.len() == 5 {
                    let mut v = std::mem::take(&mut self.sync_intervals);
                    v.sort_unstable();
                    self.sync_period = Some(v[2].max(1));
                }
            }
        }
        self.sync_last = Some(t);
    }

    fn pdo(&mut self, line: usize, t: u64, raw: u16, frame: &CanFrame) {
        let mut rate_change = None;
        let p = self.pdos.entry(raw).or_default();
        let back = p.stopped;
        p.stopped = false;
        if p.count > 0 {
            let interval = (t - p.last) as f64;
            p.mean = if p.count == 1 {
                interval
            } else {
                p.mean * 0.9 + interval * 0.1
            };
            p.window_sum += t - p.last;
            p.window_n += 1;
            if p.window_n == 20 {
                let mean = p.window_sum as f64 / 20.0;
                if let Some(before) = p.window_mean
                    && before > 0.0
                    && (mean / before > 2.0 || before / mean > 2.0)
                {
                    rate_change = Some((before, mean));
                }
                p.window_mean = Some(mean);
                p.window_sum = 0;
                p.window_n = 0;
            }
        }
        p.count += 1;
        p.last = t;
        let node = u8::try_from(raw & 0x7F).ok();
        if back {
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                node,
                Level::Info,
                Kind::PdoStopped,
                format!("{seen}: the PDO again"),
                "the PDO is sent again".into(),
            );
        }
        if let Some((before, after)) = rate_change {
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                node,
                Level::Warning,
                Kind::PdoRate,
                format!(
                    "{seen}: every {:.1} ms, before every {:.1} ms",
                    after / 1000.0,
                    before / 1000.0
                ),
                "the PDO's rate changed: its event timer, inhibit time or SYNC changed, or the \
                 producer is overloaded"
                    .into(),
            );
        }
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
