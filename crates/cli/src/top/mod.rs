//! `canopen top`: a live terminal view of a CANopen network, on any bus the CLI opens (the
//! `--eds` nodes simulated on the in-memory bus, in real time) or on a candump log
//! (`--replay FILE`).
//!
//! Files by job: [`tap`] (the bus side: a transport wrapper that copies every frame into a
//! queue without waiting for the view), [`model`] (the state built from the frames, no
//! terminal), [`view`] (ratatui drawing), [`keys`] (what each key does), [`replay`] (a log's
//! timing, pause, step and seek), and this file (the terminal and the loop that draws
//! `--fps` times a second and carries the keys' actions out on the network).

pub(crate) mod keys;
pub(crate) mod model;
pub(crate) mod replay;
pub(crate) mod tap;
pub(crate) mod view;

use std::collections::VecDeque;
use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};

use canola::candump::{self, LogEntry, LogFrame};
use canola::{CommandSpecifier, DataType, Instant, MemoryBus, Network, NodeId, ObjectAddress};
use ratatui::crossterm::event::{self, Event};

use crate::bus::{BusOpts, fail};
use crate::error::CliError;
use keys::{Action, Ask, Mode};
use model::{LogKind, Model};
use tap::{Seen, TapStats};

/// `canopen top` options.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct TopArgs {
    /// Show a candump log (as `record` writes it) with its timing instead of a bus: space
    /// pauses, n steps one frame, ← and → jump 10 s.
    #[arg(long, value_name = "FILE")]
    replay: Option<PathBuf>,
    /// The bus's bit rate, for the load in percent (and the in-memory bus's timing):
    /// 125k, 250k, 500k, 1M or bit/s.
    #[arg(long, default_value = "500k", value_parser = parse_bitrate)]
    bitrate: u32,
    /// Draws per second (frames are counted as they come, whatever this is).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=60))]
    fps: u32,
}

/// `500k`, `1M`, `250000` ([`canola::frame::parse_bitrate`]), 10k..1M.
fn parse_bitrate(s: &str) -> Result<u32, CliError> {
    let bps = canola::frame::parse_bitrate(s)
        .ok_or_else(|| CliError::Argument(format!("`{s}` is not a bit rate (500k, 1M, 250000)")))?;
    if (10_000..=1_000_000).contains(&bps) {
        Ok(bps)
    } else {
        Err(CliError::Argument(format!("`{s}`: give 10k..1M")))
    }
}

/// Frames [`Recording`] keeps for `s` (the oldest go first beyond it).
const KEEP: usize = 1_000_000;

/// The traffic so far, for `s`: candump time stamps and frames.
pub(crate) struct Recording {
    pub(crate) frames: VecDeque<(u64, LogFrame)>,
    /// Frames no longer kept.
    pub(crate) dropped: u64,
    interface: String,
}

impl Recording {
    pub(crate) fn push(&mut self, ts: u64, frame: LogFrame) {
        if self.frames.len() == KEEP {
            self.frames.pop_front();
            self.dropped += 1;
        }
        self.frames.push_back((ts, frame));
    }

    /// Writes every frame kept; `filtered` (a filter narrows the view) puts "unfiltered" in the
    /// message, which the status line shows beside `[filter: ...]`.
    fn save(&self, path: &std::path::Path, filtered: bool) -> Result<String, CliError> {
        let out = crate::outfile::OutFile::create(path)?;
        let mut w = candump::Writer::new(std::io::BufWriter::new(out.writer()?));
        for (ts, frame) in &self.frames {
            w.write(&LogEntry {
                timestamp_us: *ts,
                interface: self.interface.clone(),
                frame: *frame,
                len8_dlc: None,
            })
            .map_err(CliError::file(path))?;
        }
        w.flush().map_err(CliError::file(path))?;
        drop(w);
        out.commit()?;
        let older = if self.dropped > 0 {
            format!(" (the {} oldest no longer kept)", self.dropped)
        } else {
            String::new()
        };
        let which = if filtered { " unfiltered" } else { "" };
        Ok(format!(
            "saved {}{which} frames to {}{older}",
            self.frames.len(),
            path.display()
        ))
    }
}

/// A live bus: the network the keys act on, the tap's queue and counters.
struct Live {
    net: Network,
    rx: Receiver<Seen>,
    stats: Arc<TapStats>,
    /// Keeps the in-memory bus's simulated devices alive.
    _memory: Option<MemoryBus>,
    /// Candump time of `start`.
    epoch_us: u64,
    start: Instant,
}

enum Source {
    Live(Live),
    Replay(replay::Replay),
}

/// A line for the event log and the status line.
type Note = (LogKind, String);

/// A write that waits for `y`.
struct PendingWrite {
    node: NodeId,
    entry: ObjectAddress,
    bytes: Vec<u8>,
    shown: String,
}

/// The app: model, view state and the source of frames.
struct App {
    model: Model,
    /// The model as it was when the live view was paused.
    frozen: Option<Model>,
    mode: Mode,
    selected: Option<NodeId>,
    filter: String,
    status: String,
    color: bool,
    /// Values read with `g` in hex (`--hex`).
    hex: bool,
    title: String,
    source: Source,
    recording: Recording,
    pending: Option<PendingWrite>,
    /// Results of the reads and writes running on threads of their own.
    results: (Sender<Note>, Receiver<Note>),
}

/// `canopen top [--replay FILE]` (`--hex`: values read with `g` in hex)
pub(crate) fn run(args: &TopArgs, opts: &BusOpts, g: crate::Global) -> ExitCode {
    if !std::io::stdout().is_terminal() {
        // Where it runs, not a wrong command line: exit 1.
        return fail(CliError::System {
            what: "canopen top draws on a terminal".into(),
            source: std::io::Error::other("stdout is not one (use `monitor` for text)"),
        });
    }
    // Before the bus opens (its transport may start threads): SIGTERM ends the view cleanly.
    if let Err(e) = crate::bus::stop_on_signals() {
        return fail(e);
    }
    let mut app = match App::open(args, opts) {
        Ok(a) => a,
        Err(e) => return fail(e),
    };
    app.hex = g.hex;
    let terminal = match ratatui::try_init() {
        Ok(t) => t,
        Err(source) => {
            return fail(CliError::System {
                what: "cannot set the terminal up".into(),
                source,
            });
        }
    };
    let r = app.run(terminal, args.fps);
    ratatui::restore();
    if let Source::Live(live) = &app.source {
        let _ = live.net.stop_driver();
    }
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

impl App {
    fn open(args: &TopArgs, opts: &BusOpts) -> Result<Self, CliError> {
        let color = std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty());
        let (source, dictionaries, title, interface) = match &args.replay {
            Some(file) => {
                let dictionaries = opts.dictionaries()?;
                let r = replay::Replay::load(file, dictionaries.clone(), args.bitrate)?;
                let title = format!("replay {}", file.display());
                (Source::Replay(r), dictionaries, title, "can0".to_owned())
            }
            None => {
                let bus = opts.open_live(args.bitrate)?;
                let dictionaries = bus.dictionaries.clone();
                let (transport, rx, stats) = tap::tap(bus.transport);
                let net = Network::new(transport);
                for (node, od) in &dictionaries {
                    net.add_node_with_dictionary(*node, od.clone());
                }
                net.start_driver()?;
                let (title, interface) = match &opts.iface {
                    Some(i) => (i.clone(), i.clone()),
                    None => (
                        format!("in-memory bus, {} simulated node(s)", dictionaries.len()),
                        "mem0".to_owned(),
                    ),
                };
                let epoch_us = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map(|d| d.as_micros() as u64)
                    .unwrap_or(0);
                let start = net.now();
                let live = Live {
                    net,
                    rx,
                    stats,
                    _memory: bus.memory,
                    epoch_us,
                    start,
                };
                (Source::Live(live), dictionaries, title, interface)
            }
        };
        let model = Model::new(&dictionaries, args.bitrate);
        let selected = model.nodes.keys().next().copied();
        Ok(Self {
            model,
            frozen: None,
            mode: Mode::Normal,
            selected,
            filter: String::new(),
            status: "? help, q quit".into(),
            color,
            hex: false,
            title,
            source,
            recording: Recording {
                frames: VecDeque::new(),
                dropped: 0,
                interface,
            },
            pending: None,
            results: channel(),
        })
    }

    fn run(&mut self, mut terminal: ratatui::DefaultTerminal, fps: u32) -> Result<(), CliError> {
        let period = std::time::Duration::from_secs(1) / fps;
        let mut next = std::time::Instant::now();
        loop {
            self.take_frames();
            while let Ok((kind, text)) = self.results.1.try_recv() {
                let now = self.model.now;
                self.model.note(now, kind, text.clone());
                self.status = text;
            }
            if self.selected.is_none() {
                self.selected = self.model.nodes.keys().next().copied();
            }
            let shown = self.frozen.as_ref().unwrap_or(&self.model);
            let replay_text = match &self.source {
                Source::Replay(r) => Some(r.position_text()),
                Source::Live(_) => None,
            };
            let lost = match &self.source {
                Source::Live(l) => l.stats.lost.load(std::sync::atomic::Ordering::Relaxed),
                Source::Replay(_) => 0,
            };
            let screen = view::Screen {
                title: &self.title,
                selected: self.selected,
                filter: &self.filter,
                mode: &self.mode,
                status: &self.status,
                paused: self.paused(),
                color: self.color,
                lost,
                replay: replay_text.as_deref(),
            };
            terminal
                .draw(|f| view::draw(f, shown, &screen))
                .map_err(|source| CliError::System {
                    what: "cannot draw".into(),
                    source,
                })?;
            // The next draw at a fixed rate; a late one is dropped, not caught up.
            next += period;
            let now = std::time::Instant::now();
            if next < now {
                next = now + period;
            }
            loop {
                let wait = next.saturating_duration_since(std::time::Instant::now());
                if wait.is_zero() || !event::poll(wait).map_err(CliError::Terminal)? {
                    break;
                }
                if let Event::Key(key) = event::read().map_err(CliError::Terminal)? {
                    test_panic(&key);
                    let replay = matches!(self.source, Source::Replay(_));
                    let action = keys::handle(&mut self.mode, key, replay);
                    if action == Action::Quit {
                        return Ok(());
                    }
                    self.act(action);
                    // Show what the key did at once.
                    break;
                }
            }
            if crate::bus::stop_requested() {
                return Ok(());
            }
        }
    }

    fn paused(&self) -> bool {
        match &self.source {
            Source::Live(_) => self.frozen.is_some(),
            Source::Replay(r) => !r.playing(),
        }
    }

    /// Takes the frames the bus side queued (or the replay's next ones) into the model and
    /// the recording, and lets the model's time pass.
    fn take_frames(&mut self) {
        match &mut self.source {
            Source::Live(live) => {
                for seen in live.rx.try_iter() {
                    if let Seen::Frame { at, frame, .. } = seen {
                        let ts =
                            live.epoch_us + at.saturating_duration_since(live.start).as_micros();
                        self.recording.push(ts, frame);
                    }
                    self.model.ingest(&seen);
                }
                // The tap's clock: the network's would wait for its driver's step.
                let now = live.stats.now().unwrap_or_else(|| live.net.now());
                self.model.tick(now);
            }
            Source::Replay(r) => {
                r.advance(&mut self.model, &mut self.recording);
            }
        }
    }

    fn act(&mut self, action: Action) {
        match action {
            Action::None | Action::Quit => {}
            Action::Up | Action::Down => self.move_selection(action == Action::Down),
            Action::Nmt { command, all } => self.nmt(command, all),
            Action::Open(Ask::Save) => {
                let stamp = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map(|d| d.as_secs())
                    .unwrap_or(0);
                self.mode = Mode::Prompt {
                    ask: Ask::Save,
                    text: format!("canopen-top-{stamp}.log"),
                };
            }
            Action::Open(Ask::Filter) => {
                self.mode = Mode::Prompt {
                    ask: Ask::Filter,
                    text: self.filter.clone(),
                };
            }
            Action::Open(_) => {}
            Action::Submit { ask, text } => self.submit(ask, &text),
            Action::Confirmed => self.write(),
            Action::Declined => {
                self.pending = None;
                self.status = "write cancelled".into();
            }
            Action::TogglePause => match &mut self.source {
                Source::Live(_) => {
                    self.frozen = match self.frozen.take() {
                        Some(_) => None,
                        None => Some(self.model.snapshot()),
                    };
                }
                Source::Replay(r) => r.toggle(),
            },
            Action::Step => {
                if let Source::Replay(r) = &mut self.source {
                    r.step(&mut self.model, &mut self.recording);
                }
            }
            Action::Seek(s) => {
                if let Source::Replay(r) = &mut self.source {
                    r.seek(s, &mut self.model, &mut self.recording);
                }
            }
        }
    }

    /// The nodes the nodes pane lists now (after the filter).
    fn listed(&self) -> Vec<NodeId> {
        let f = self.filter.to_lowercase();
        self.model
            .nodes
            .iter()
            .filter(|(n, r)| {
                f.is_empty()
                    || format!("node {n} {}", r.shown_name().unwrap_or_default())
                        .to_lowercase()
                        .contains(&f)
            })
            .map(|(n, _)| *n)
            .collect()
    }

    fn move_selection(&mut self, down: bool) {
        let nodes = self.listed();
        if nodes.is_empty() {
            return;
        }
        let i = self
            .selected
            .and_then(|s| nodes.iter().position(|n| *n == s));
        let j = match (i, down) {
            (None, _) => 0,
            (Some(i), true) => (i + 1).min(nodes.len() - 1),
            (Some(i), false) => i.saturating_sub(1),
        };
        self.selected = nodes.get(j).copied();
    }

    fn live(&mut self) -> Option<&Network> {
        match &self.source {
            Source::Live(l) => Some(&l.net),
            Source::Replay(_) => {
                self.status = "a replay has no bus to send to".into();
                None
            }
        }
    }

    fn nmt(&mut self, command: CommandSpecifier, all: bool) {
        let selected = self.selected;
        let Some(net) = self.live() else { return };
        let r = if all {
            let n = canola::Nmt::all(net);
            send_nmt(&n, command).map(|()| "all nodes".to_owned())
        } else {
            let Some(id) = selected else {
                self.status = "no node selected".into();
                return;
            };
            send_nmt(&net.node(id).nmt(), command).map(|()| format!("node {id}"))
        };
        self.status = match r {
            Ok(to) => format!("sent NMT {} to {to}", command_name(command)),
            Err(e) => format!("NMT failed: {e}"),
        };
    }

    fn submit(&mut self, ask: Ask, text: &str) {
        match ask {
            Ask::Filter => {
                self.filter = text.to_owned();
                if let Some(first) = self.listed().first()
                    && !self.listed().contains(&self.selected.unwrap_or(*first))
                {
                    self.selected = Some(*first);
                }
            }
            Ask::Save => {
                if text.is_empty() {
                    return;
                }
                self.status = match self
                    .recording
                    .save(std::path::Path::new(text), !self.filter.is_empty())
                {
                    Ok(s) => s,
                    Err(e) => format!("cannot save: {e}"),
                };
            }
            Ask::Read => self.read(text),
            Ask::Write => self.prepare_write(text),
        }
    }

    fn target(&mut self) -> Option<(Network, NodeId)> {
        let selected = self.selected;
        let net = self.live()?.clone();
        match selected {
            Some(id) => Some((net, id)),
            None => {
                self.status = "no node selected".into();
                None
            }
        }
    }

    fn read(&mut self, text: &str) {
        let Some((net, id)) = self.target() else {
            return;
        };
        let entry = match object(text, self.model.dictionary(id)) {
            Ok(e) => e,
            Err(e) => {
                self.status = e.to_string();
                return;
            }
        };
        self.status = format!(
            "reading node {id} 0x{:04X}:{:02X} ...",
            entry.index, entry.sub_index
        );
        // The type from the node's EDS, else CiA 301's for a communication object; without
        // either the bytes are shown in hex.
        let dt = data_type(self.model.dictionary(id), entry);
        let tx = self.results.0.clone();
        let hex = self.hex;
        std::thread::spawn(move || {
            let what = format!("node {id} 0x{:04X}:{:02X}", entry.index, entry.sub_index);
            let sdo = net.node(id).sdo();
            let r = match dt {
                Some(dt) => sdo
                    .read_as(entry, dt)
                    .wait()
                    .map(|v| crate::sdo_cmd::format_value(&v, hex)),
                None => sdo.read(entry).wait().map(|b| {
                    let bytes: String = b.iter().map(|x| format!("{x:02x}")).collect();
                    format!("{bytes} (bytes: no type known without an EDS)")
                }),
            };
            let msg = match r {
                Ok(text) => (LogKind::Info, format!("{what} = {text}")),
                Err(e) => (LogKind::Warning, format!("{what}: {e}")),
            };
            let _ = tx.send(msg);
        });
    }

    fn prepare_write(&mut self, text: &str) {
        let Some((_, id)) = self.target() else {
            return;
        };
        let Some((obj, value)) = text.rsplit_once(' ') else {
            self.status = "write: give OBJECT VALUE (0x1017 1000)".into();
            return;
        };
        let od = self.model.dictionary(id);
        let entry = match object(obj.trim(), od) {
            Ok(e) => e,
            Err(e) => {
                self.status = e.to_string();
                return;
            }
        };
        let Some(dt) = data_type(od, entry) else {
            self.status = format!(
                "write: the type of 0x{:04X}:{:02X} is unknown (give the node's EDS with --eds)",
                entry.index, entry.sub_index
            );
            return;
        };
        let bytes = match crate::sdo_cmd::parse_value(dt, value) {
            Ok(b) => b,
            Err(e) => {
                self.status = format!("write: {e}");
                return;
            }
        };
        let name = od
            .and_then(|od| model::object_name(od, entry.index, entry.sub_index))
            .map(|n| format!(" ({n})"))
            .unwrap_or_default();
        let shown = format!(
            "node {id} 0x{:04X}:{:02X}{name} = {value}",
            entry.index, entry.sub_index
        );
        self.mode = Mode::Confirm {
            question: format!("write {shown}?"),
        };
        self.pending = Some(PendingWrite {
            node: id,
            entry,
            bytes,
            shown,
        });
    }

    fn write(&mut self) {
        let Some(p) = self.pending.take() else { return };
        let Some(net) = self.live().cloned() else {
            return;
        };
        self.status = format!("writing {} ...", p.shown);
        let tx = self.results.0.clone();
        std::thread::spawn(move || {
            let msg = match net.node(p.node).sdo().write(p.entry, p.bytes).wait() {
                Ok(()) => (LogKind::Info, format!("wrote {}", p.shown)),
                Err(e) => (LogKind::Warning, format!("write {}: {e}", p.shown)),
            };
            let _ = tx.send(msg);
        });
    }
}

/// The type of `entry`: from the node's EDS, else the one CiA 301 gives a communication
/// profile object (0x1017 UNSIGNED16 on every device).
fn data_type(od: Option<&canola::ObjectDictionary>, entry: ObjectAddress) -> Option<DataType> {
    od.and_then(|od| od.sub(entry.index, entry.sub_index).map(|s| s.data_type))
        .or_else(|| canola::od::profile::communication_type(entry.index, entry.sub_index))
}

fn send_nmt(n: &canola::Nmt, command: CommandSpecifier) -> Result<(), canola::Error> {
    match command {
        CommandSpecifier::Start => n.start(),
        CommandSpecifier::Stop => n.stop(),
        CommandSpecifier::EnterPreOperational => n.enter_preoperational(),
        CommandSpecifier::ResetNode => n.reset_node(),
        _ => n.reset_communication(),
    }
}

fn command_name(c: CommandSpecifier) -> &'static str {
    match c {
        CommandSpecifier::Start => "start",
        CommandSpecifier::Stop => "stop",
        CommandSpecifier::EnterPreOperational => "enter pre-operational",
        CommandSpecifier::ResetNode => "reset node",
        _ => "reset communication",
    }
}

/// An object typed at a prompt: `0x1018:1` / `0x1018` (index in hex or decimal, sub-index
/// after a colon), or a name from the node's dictionary (`Identity object/Vendor-ID`).
pub(crate) fn object(
    text: &str,
    od: Option<&canola::ObjectDictionary>,
) -> Result<ObjectAddress, CliError> {
    let text = text.trim();
    if text.is_empty() {
        return Err(CliError::Argument("no object given".into()));
    }
    if text.bytes().next().is_some_and(|b| b.is_ascii_digit()) {
        let (index, sub) = match text.split_once(':') {
            Some((i, s)) => (i, crate::bus::parse_u8(s.trim())?),
            None => (text, 0),
        };
        return Ok(ObjectAddress::new(
            crate::bus::parse_u16(index.trim())?,
            sub,
        ));
    }
    let r = crate::objaddr::resolve(text, od)?;
    Ok(ObjectAddress::new(r.index, r.sub.unwrap_or(0)))
}

#[cfg(test)]
mod tests;

/// Debug builds only: with `CANOPEN_TOP_TEST_PANIC` set, the key `!` panics, so the tmux test
/// can see the panic hook that `ratatui::try_init` installs give the shell its terminal back.
fn test_panic(key: &event::KeyEvent) {
    if cfg!(debug_assertions)
        && key.code == event::KeyCode::Char('!')
        && std::env::var_os("CANOPEN_TOP_TEST_PANIC").is_some()
    {
        panic!("test panic requested with `!` (CANOPEN_TOP_TEST_PANIC)");
    }
}
