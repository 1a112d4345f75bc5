//! What `canopen top` shows, built from the frames on the bus alone (no terminal code here):
//! the nodes (NMT state from heartbeats, boot-ups and the NMT commands seen, heartbeat age,
//! EMCY count and the last one decoded, what LSS did), the bus (frames per second, load at the
//! bit rate, error and FD frames, frames lost), the PDO values decoded by name with their
//! recent history, the SDO transfers in flight (`sdo`) and an event log. The same model serves a live
//! bus and a replayed candump log: it only ever sees [`Seen`] frames with their times.

use std::collections::{BTreeMap, VecDeque};

use canola::candump::LogFrame;
use canola::frame::{CobId, FunctionCode, HexBytes};
use canola::lss::{Mode, Request as LssRequest, Response as LssResponse};
use canola::mem::frame_bits;
use canola::nmt::{
    CommandSpecifier, Emcy, ErrorControlFrame, ErrorControlMessage, NmtCommand, NmtState, NmtTarget,
};
use canola::pdo::RawValue;
use canola::{BusDictionary, CanFrame, Duration, Instant, NodeId, ObjectDictionary};

use super::tap::Seen;

// The path is spelt out because the `top_load` benchmark includes this file by `#[path]`, where
// a plain `mod sdo;` would be looked for beside it.
#[path = "model/sdo.rs"]
mod sdo;

use sdo::SdoTransfer;

/// Lines the event log keeps.
pub(crate) const LOG_LINES: usize = 500;
/// Points of history a PDO value's sparkline keeps.
pub(crate) const HISTORY: usize = 120;
/// The shortest time between two points of a value's history.
const HISTORY_STEP: Duration = Duration::from_millis(100);
/// How long an SDO transfer may go without a frame before the log calls it unanswered (the
/// master's default SDO timeout is 1 s; this leaves room for a slower client).
pub(crate) const SDO_SILENCE: Duration = Duration::from_millis(2000);

/// How far behind the clock the frames may be (a loaded host takes them late): a heartbeat is
/// judged late by the newest frame's time, or by the clock less this when the bus is silent.
pub(crate) const LAG: Duration = Duration::from_millis(1000);

/// Where a node's NMT state comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum StateSource {
    /// Its own heartbeat, node-guarding answer or boot-up message.
    Node,
    /// An NMT command seen on the bus (the node does not report its state).
    Command,
}

/// One node of the nodes pane.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NodeRow {
    /// Product name from the EDS, if one was given.
    pub(crate) name: Option<String>,
    /// Last known NMT state.
    pub(crate) state: Option<NmtState>,
    /// Where [`state`](Self::state) comes from.
    pub(crate) source: StateSource,
    /// Last heartbeat (or guarding answer, or boot-up).
    pub(crate) heard: Option<Instant>,
    /// The producer heartbeat time the EDS gives (0x1017), if not 0.
    pub(crate) configured_period: Option<Duration>,
    /// The time between the last two heartbeats.
    pub(crate) measured_period: Option<Duration>,
    /// Whether the heartbeat is late now (logged once per lateness).
    pub(crate) late: bool,
    /// Emergency messages received.
    pub(crate) emcy_count: u64,
    /// The last one, decoded.
    pub(crate) last_emcy: Option<String>,
    /// What LSS did to this node (node-ID configured, inquired).
    pub(crate) lss: Option<String>,
    /// Vendor-ID and product code (0x1018:01, :02) as read over SDO on the bus, for a node
    /// without an EDS.
    pub(crate) identity: (Option<u32>, Option<u32>),
    /// Frames this node sent.
    pub(crate) frames: u64,
}

impl NodeRow {
    fn new(name: Option<String>, configured_period: Option<Duration>) -> Self {
        Self {
            name,
            state: None,
            source: StateSource::Node,
            heard: None,
            configured_period,
            measured_period: None,
            late: false,
            emcy_count: 0,
            last_emcy: None,
            lss: None,
            identity: (None, None),
            frames: 0,
        }
    }

    /// The name the nodes pane shows: the EDS's product name, else the identity read on the
    /// bus (`vendor 0x00000039 product 0x00000001`).
    pub(crate) fn shown_name(&self) -> Option<String> {
        if let Some(n) = &self.name {
            return Some(n.clone());
        }
        match self.identity {
            (None, None) => None,
            (v, p) => {
                let hex = |x: Option<u32>| x.map_or("?".to_owned(), |x| format!("0x{x:08X}"));
                Some(format!("vendor {} product {}", hex(v), hex(p)))
            }
        }
    }

    /// The heartbeat period the lateness is judged by: the configured one, else the measured.
    pub(crate) fn period(&self) -> Option<Duration> {
        self.configured_period.or(self.measured_period)
    }

    /// Age of the last heartbeat at `now`.
    pub(crate) fn age(&self, now: Instant) -> Option<Duration> {
        self.heard.map(|h| now.saturating_duration_since(h))
    }

    /// Whether a heartbeat of period `p` heard at `age` ago is late: more than 1.5 periods
    /// (and 100 ms, for a jittery host) without one.
    fn is_late(age: Duration, p: Duration) -> bool {
        age.as_micros() > p.as_micros() * 3 / 2 + 100_000
    }
}

/// The bus pane's counters.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct BusCounters {
    /// Frames seen (classic, FD and error frames).
    pub(crate) frames: u64,
    /// CAN FD frames.
    pub(crate) fd: u64,
    /// Error frames.
    pub(crate) errors: u64,
    /// Frames the transport's receive queue dropped (reported by the transport).
    pub(crate) overflowed: u64,
    /// Frames per second over the last second.
    pub(crate) fps: u64,
    /// Bus load over the last second, percent of the bit rate.
    pub(crate) load: f64,
    /// Peak of [`load`](Self::load).
    pub(crate) peak_load: f64,
}

/// A PDO value of the PDO pane.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Signal {
    /// The producing node.
    pub(crate) node: Option<NodeId>,
    /// `TPDO1 node 5`.
    pub(crate) pdo: String,
    /// The mapped object's name (`Statusword`), or `data` for an undecoded PDO.
    pub(crate) name: String,
    /// The value as text.
    pub(crate) text: String,
    /// Numeric history for the sparkline (empty for bytes).
    pub(crate) history: VecDeque<f64>,
    /// When the last point went into the history.
    last_point: Option<Instant>,
    /// Times the value changed.
    pub(crate) changes: u64,
}

/// One line of the event log.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LogLine {
    pub(crate) at: Instant,
    pub(crate) kind: LogKind,
    pub(crate) text: String,
}

/// What a log line is about (the view colours by it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LogKind {
    Info,
    Warning,
    Error,
}

/// The whole state the view draws. See the module docs.
#[derive(Debug, Clone)]
pub(crate) struct Model {
    dictionary: BusDictionary,
    bitrate: u32,
    pub(crate) nodes: BTreeMap<NodeId, NodeRow>,
    pub(crate) bus: BusCounters,
    /// Keyed by COB-ID and position in the PDO.
    pub(crate) signals: BTreeMap<(u16, usize), Signal>,
    pub(crate) sdo: BTreeMap<NodeId, SdoTransfer>,
    pub(crate) log: VecDeque<LogLine>,
    /// The last LSS mode a global switch set, and the last LSS exchange.
    pub(crate) lss_mode: Option<Mode>,
    pub(crate) lss_last: Option<String>,
    /// A configure node-ID request waiting for its answer.
    lss_pending_id: Option<u8>,
    /// The time of the latest frame or tick.
    pub(crate) now: Instant,
    /// The time of the newest frame.
    newest: Instant,
    /// The first time the model saw (the event log counts from it).
    origin: Option<Instant>,
    /// (time, bits) of the frames of the last second.
    window: VecDeque<(Instant, u32)>,
    window_bits: u64,
}

/// The name of `index:sub` in `od` (`Object / Sub-object` for records and arrays).
pub(crate) fn object_name(od: &ObjectDictionary, index: u16, sub: u8) -> Option<String> {
    let obj = od.get(index)?;
    match obj.sub(sub) {
        Some(s) if !obj.is_simple() => Some(format!("{} / {}", obj.name, s.name)),
        _ => Some(obj.name.to_string()),
    }
}

fn raw_text(v: &RawValue) -> (String, Option<f64>) {
    match v {
        RawValue::Bool(b) => (b.to_string(), Some(f64::from(u8::from(*b)))),
        RawValue::Unsigned(u) => (u.to_string(), Some(*u as f64)),
        RawValue::Signed(i) => (i.to_string(), Some(*i as f64)),
        RawValue::Real32(x) => (format!("{x}"), Some(f64::from(*x))),
        RawValue::Real64(x) => (format!("{x}"), Some(*x)),
        RawValue::Bytes(b) => (HexBytes(b.as_slice()).to_string(), None),
    }
}

impl Model {
    /// A model for a bus at `bitrate` bit/s whose nodes' dictionaries are `dictionaries` (their
    /// nodes are listed before they are heard).
    pub(crate) fn new(dictionaries: &[(NodeId, ObjectDictionary)], bitrate: u32) -> Self {
        let mut dictionary = BusDictionary::new();
        let mut nodes = BTreeMap::new();
        for (node, od) in dictionaries {
            dictionary.add_node(*node, od.clone());
            let period = od
                .sub(0x1017, 0)
                .and_then(|s| s.effective_value(node.get()))
                .and_then(|v| v.as_i128())
                .and_then(|ms| u64::try_from(ms).ok())
                .filter(|ms| *ms > 0)
                .map(Duration::from_millis);
            nodes.insert(
                *node,
                NodeRow::new(od.device_info.product_name.clone(), period),
            );
        }
        Self {
            dictionary,
            bitrate: bitrate.max(1),
            nodes,
            bus: BusCounters::default(),
            signals: BTreeMap::new(),
            sdo: BTreeMap::new(),
            log: VecDeque::new(),
            lss_mode: None,
            lss_last: None,
            lss_pending_id: None,
            now: Instant::ZERO,
            newest: Instant::ZERO,
            origin: None,
            window: VecDeque::new(),
            window_bits: 0,
        }
    }

    /// Seconds from the first frame or tick to `at` (the transport's clock may count from the
    /// host's boot).
    pub(crate) fn seconds(&self, at: Instant) -> f64 {
        at.saturating_duration_since(self.origin.unwrap_or(Instant::ZERO))
            .as_micros() as f64
            / 1e6
    }

    /// The bit rate the load is computed at.
    pub(crate) fn bitrate(&self) -> u32 {
        self.bitrate
    }

    /// The dictionary of `node`, if one was given.
    pub(crate) fn dictionary(&self, node: NodeId) -> Option<&ObjectDictionary> {
        self.dictionary.dictionary(node)
    }

    /// Adds a line to the event log.
    pub(crate) fn note(&mut self, at: Instant, kind: LogKind, text: impl Into<String>) {
        if self.log.len() == LOG_LINES {
            self.log.pop_front();
        }
        self.log.push_back(LogLine {
            at,
            kind,
            text: text.into(),
        });
    }

    fn node(&mut self, node: NodeId) -> &mut NodeRow {
        self.nodes
            .entry(node)
            .or_insert_with(|| NodeRow::new(None, None))
    }

    /// Takes what the bus side saw.
    pub(crate) fn ingest(&mut self, seen: &Seen) {
        match *seen {
            Seen::Overflow { at, dropped } => {
                self.advance(at);
                self.bus.overflowed += dropped;
                self.note(
                    at,
                    LogKind::Error,
                    format!("receive queue overflowed: {dropped} frame(s) lost"),
                );
            }
            Seen::Frame { at, frame, .. } => {
                self.advance(at);
                self.bus.frames += 1;
                match frame {
                    LogFrame::Can(f) => {
                        self.count_bits(at, frame_bits(&f, false));
                        self.can_frame(at, &f);
                    }
                    LogFrame::Fd(f) => {
                        self.bus.fd += 1;
                        // Arbitration and data phase at the nominal rate: an upper bound.
                        let bits = 67 + 8 * f.data().len() as u32;
                        self.count_bits(at, bits);
                    }
                    LogFrame::Error { class, .. } => {
                        self.bus.errors += 1;
                        self.note(
                            at,
                            LogKind::Error,
                            format!("error frame, class 0x{class:08X}"),
                        );
                    }
                }
            }
        }
    }

    fn advance(&mut self, at: Instant) {
        self.origin.get_or_insert(at);
        if at > self.now {
            self.now = at;
        }
        if at > self.newest {
            self.newest = at;
        }
    }

    fn count_bits(&mut self, at: Instant, bits: u32) {
        self.window.push_back((at, bits));
        self.window_bits += u64::from(bits);
    }

    /// Lets time pass to `now` (the view calls it before each draw): the rates over the last
    /// second, late heartbeats, SDO transfers that went silent.
    pub(crate) fn tick(&mut self, now: Instant) {
        self.origin.get_or_insert(now);
        if now > self.now {
            self.now = now;
        }
        let now = self.now;
        let since = now - Duration::from_secs(1);
        while let Some(&(t, bits)) = self.window.front() {
            if t >= since {
                break;
            }
            self.window.pop_front();
            self.window_bits -= u64::from(bits);
        }
        self.bus.fps = self.window.len() as u64;
        self.bus.load = self.window_bits as f64 * 100.0 / f64::from(self.bitrate);
        if self.bus.load > self.bus.peak_load {
            self.bus.peak_load = self.bus.load;
        }
        let mut late = Vec::new();
        let reference = self.newest.max(now - LAG);
        for (id, n) in &mut self.nodes {
            if let (Some(age), Some(p)) = (n.age(reference), n.period())
                && !n.late
                && NodeRow::is_late(age, p)
            {
                n.late = true;
                late.push((*id, age));
            }
        }
        for (id, age) in late {
            self.note(
                now,
                LogKind::Warning,
                format!(
                    "node {id}: heartbeat late, none for {:.1} s",
                    age.as_micros() as f64 / 1e6
                ),
            );
        }
        let silent: Vec<NodeId> = self
            .sdo
            .iter()
            .filter(|(_, t)| now.saturating_duration_since(t.last) > SDO_SILENCE)
            .map(|(n, _)| *n)
            .collect();
        for n in silent {
            if let Some(t) = self.sdo.remove(&n) {
                self.note(
                    now,
                    LogKind::Warning,
                    format!(
                        "node {n}: SDO {} 0x{:04X}:{:02X} timed out (no frame for {} s)",
                        t.kind.label(),
                        t.index,
                        t.sub,
                        SDO_SILENCE.as_millis() / 1000
                    ),
                );
            }
        }
    }

    fn can_frame(&mut self, at: Instant, f: &CanFrame) {
        let Some(raw) = f.cob_id() else { return };
        match raw {
            0x7E5 => return self.lss_request(at, f),
            0x7E4 => return self.lss_response(at, f),
            _ => {}
        }
        if !f.is_remote()
            && let Some(decoded) = self.dictionary.decode_pdo(f)
        {
            let node = CobId::classify(raw).and_then(|c| c.node);
            if let Some(n) = node {
                self.node(n).frames += 1;
            }
            match decoded {
                Ok(pdo) => {
                    for (i, v) in pdo.values.iter().enumerate() {
                        let (text, number) = raw_text(&v.value);
                        self.signal(at, raw, i, node, &pdo.label, &v.name, text, number);
                    }
                }
                Err(e) => {
                    let text = format!("{} (does not fit the mapping: {e})", HexBytes(f.data()));
                    self.signal(
                        at,
                        raw,
                        0,
                        node,
                        &format!("0x{raw:03X}"),
                        "data",
                        text,
                        None,
                    );
                }
            }
            return;
        }
        let Some(cob) = CobId::classify(raw) else {
            return;
        };
        if let Some(n) = cob.node
            && !matches!(cob.function, FunctionCode::SdoRx | FunctionCode::Rpdo(_))
        {
            self.node(n).frames += 1;
        }
        match (cob.function, cob.node) {
            (FunctionCode::Nmt, _) => self.nmt_command(at, f),
            (FunctionCode::NmtErrorControl, Some(_)) => self.error_control(at, f),
            (FunctionCode::Emcy, Some(n)) => self.emcy(at, n, f),
            (FunctionCode::SdoRx, Some(n)) => self.sdo_request(at, n, f.data()),
            (FunctionCode::SdoTx, Some(n)) => self.sdo_response(at, n, f.data()),
            (FunctionCode::Tpdo(p), Some(n)) => {
                let label = format!("TPDO{} node {n}", p.get());
                let text = HexBytes(f.data()).to_string();
                self.signal(at, raw, 0, Some(n), &label, "data", text, None);
            }
            _ => {}
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn signal(
        &mut self,
        at: Instant,
        cob: u16,
        pos: usize,
        node: Option<NodeId>,
        pdo: &str,
        name: &str,
        text: String,
        number: Option<f64>,
    ) {
        let s = self.signals.entry((cob, pos)).or_insert_with(|| Signal {
            node,
            pdo: pdo.to_owned(),
            name: name.to_owned(),
            text: String::new(),
            history: VecDeque::new(),
            last_point: None,
            changes: 0,
        });
        if s.text != text {
            if !s.text.is_empty() {
                s.changes += 1;
            }
            s.text = text;
        }
        if let Some(x) = number
            && s.last_point
                .is_none_or(|t| at.saturating_duration_since(t) >= HISTORY_STEP)
        {
            if s.history.len() == HISTORY {
                s.history.pop_front();
            }
            s.history.push_back(x);
            s.last_point = Some(at);
        }
    }

    fn set_state(&mut self, at: Instant, id: NodeId, state: NmtState, source: StateSource) {
        let n = self.node(id);
        let before = n.state;
        // A command does not override what the node itself reports.
        if source == StateSource::Command && n.heard.is_some() && n.period().is_some() {
            return;
        }
        n.state = Some(state);
        n.source = source;
        if let Some(b) = before
            && b != state
        {
            let how = match source {
                StateSource::Node => "",
                StateSource::Command => " (commanded)",
            };
            self.note(at, LogKind::Info, format!("node {id}: {b} -> {state}{how}"));
        }
    }

    fn nmt_command(&mut self, at: Instant, f: &CanFrame) {
        let Ok(cmd) = NmtCommand::from_frame(f) else {
            return;
        };
        self.note(at, LogKind::Info, cmd.to_string());
        let state = match cmd.command {
            CommandSpecifier::Start => NmtState::Operational,
            CommandSpecifier::Stop => NmtState::Stopped,
            CommandSpecifier::EnterPreOperational => NmtState::PreOperational,
            // The node answers a reset with its boot-up message.
            _ => return,
        };
        let targets: Vec<NodeId> = match cmd.target {
            NmtTarget::All => self.nodes.keys().copied().collect(),
            NmtTarget::Node(n) => vec![n],
            NmtTarget::Invalid(_) => Vec::new(),
        };
        for n in targets {
            self.set_state(at, n, state, StateSource::Command);
        }
    }

    fn error_control(&mut self, at: Instant, f: &CanFrame) {
        let Ok(msg) = ErrorControlMessage::from_frame(f) else {
            return;
        };
        let ErrorControlFrame::Payload(b) = msg.kind else {
            return;
        };
        let id = msg.node;
        // Bit 7 is the node-guarding toggle bit.
        let state = NmtState::from_u8(b & 0x7F);
        let n = self.node(id);
        if let Some(h) = n.heard {
            let gap = at.saturating_duration_since(h);
            if state != NmtState::BootUp && gap > Duration::ZERO {
                n.measured_period = Some(gap);
            }
        }
        n.heard = Some(at);
        let was_late = std::mem::replace(&mut n.late, false);
        if was_late {
            self.note(at, LogKind::Info, format!("node {id}: heartbeat again"));
        }
        if state == NmtState::BootUp {
            self.note(at, LogKind::Info, format!("node {id}: boot-up"));
            let n = self.node(id);
            n.measured_period = None;
            n.state = Some(NmtState::PreOperational);
            n.source = StateSource::Node;
            return;
        }
        self.set_state(at, id, state, StateSource::Node);
    }

    fn emcy(&mut self, at: Instant, id: NodeId, f: &CanFrame) {
        let text = match Emcy::parse(f.data()) {
            Ok(e) => e.to_string(),
            Err(e) => format!("undecodable EMCY ({e}): {}", HexBytes(f.data())),
        };
        let n = self.node(id);
        n.emcy_count += 1;
        n.last_emcy = Some(text.clone());
        self.note(at, LogKind::Error, format!("node {id}: {text}"));
    }

    fn lss_request(&mut self, at: Instant, f: &CanFrame) {
        let Ok(req) = LssRequest::from_frame(f) else {
            return;
        };
        match req {
            LssRequest::SwitchModeGlobal(mode) => self.lss_mode = Some(mode),
            LssRequest::ConfigureNodeId(id) => self.lss_pending_id = Some(id),
            _ => {}
        }
        self.lss_last = Some(req.to_string());
        self.note(at, LogKind::Info, format!("LSS: {req}"));
    }

    fn lss_response(&mut self, at: Instant, f: &CanFrame) {
        let Ok(resp) = LssResponse::from_frame(f) else {
            return;
        };
        let text = resp.to_string();
        match resp {
            LssResponse::ConfigureNodeId(status) if status == canola::lss::ConfigStatus::OK => {
                if let Some(id) = self.lss_pending_id.take().and_then(|i| NodeId::new(i).ok()) {
                    self.node(id).lss = Some("node-ID set by LSS".into());
                }
            }
            LssResponse::InquireNodeId(id) => {
                if let Ok(id) = NodeId::new(id) {
                    self.node(id).lss = Some("answered LSS inquiry".into());
                }
            }
            _ => {}
        }
        self.lss_last = Some(text.clone());
        self.note(at, LogKind::Info, format!("LSS: {text}"));
    }

    /// A copy of this model whose event log is kept, for a paused view.
    pub(crate) fn snapshot(&self) -> Self {
        self.clone()
    }

    /// Counts of what the nodes pane shows, for tests: node → (state, EMCY count).
    #[cfg(test)]
    pub(crate) fn states(&self) -> std::collections::HashMap<u8, (Option<NmtState>, u64)> {
        self.nodes
            .iter()
            .map(|(n, r)| (n.get(), (r.state, r.emcy_count)))
            .collect()
    }
}
