//! Drawing `canopen top` with ratatui: the panes of a [`Model`] (nodes, bus, PDO values, SDO
//! transfers, event log), the title and status lines, the prompt and the help. Two layouts: two
//! columns on a terminal of 110x30 or more, one column below that (down to 80x24, where the bus
//! pane folds into one line and the SDO pane into the log). `NO_COLOR` draws without colours;
//! what a colour says is also in the text (a late heartbeat ends in `!`).

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Clear, Paragraph};

use canola::{Instant, NmtState, NodeId};

use super::keys::{HELP, Mode};
use super::model::{LogKind, Model, NodeRow, StateSource};

/// Everything one draw needs besides the model.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Screen<'a> {
    /// The bus, as the title shows it (`mem0 (in-memory bus)`, `can0`, `replay FILE`).
    pub(crate) title: &'a str,
    /// The selected node.
    pub(crate) selected: Option<NodeId>,
    /// The filter typed with `/` (empty: none).
    pub(crate) filter: &'a str,
    pub(crate) mode: &'a Mode,
    /// The last message for the user (a command's result).
    pub(crate) status: &'a str,
    pub(crate) paused: bool,
    /// Colours on (`NO_COLOR` unset).
    pub(crate) color: bool,
    /// Frames the view's queue had no room for (the bus side never waits for the view).
    pub(crate) lost: u64,
    /// Where a replay is (`12.3 s of 60.0 s, playing`).
    pub(crate) replay: Option<&'a str>,
}

/// The smallest size of the two-column layout.
pub(crate) const WIDE: (u16, u16) = (110, 30);

/// The sparkline's characters, lowest first.
const BARS: [char; 8] = ['▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];

impl Screen<'_> {
    fn style(&self, color: Color) -> Style {
        if self.color {
            Style::default().fg(color)
        } else {
            Style::default()
        }
    }

    fn matches(&self, text: &str) -> bool {
        self.filter.is_empty() || text.to_lowercase().contains(&self.filter.to_lowercase())
    }
}

/// The text of a node's state: CiA 301's names, `*` when the state is the last command seen
/// rather than what the node reported.
pub(crate) fn state_text(row: &NodeRow) -> String {
    let s = match row.state {
        None => return "?".into(),
        Some(NmtState::Operational) => "OPERATIONAL",
        Some(NmtState::PreOperational) => "PRE-OP",
        Some(NmtState::Stopped) => "STOPPED",
        Some(NmtState::BootUp) => "BOOT-UP",
        Some(NmtState::Unknown(_)) => "UNKNOWN",
    };
    match row.source {
        StateSource::Node => s.into(),
        StateSource::Command => format!("{s}*"),
    }
}

fn state_color(state: Option<NmtState>) -> Color {
    match state {
        Some(NmtState::Operational) => Color::Green,
        Some(NmtState::PreOperational) => Color::Yellow,
        Some(NmtState::Stopped) => Color::Red,
        _ => Color::Gray,
    }
}

/// Seconds with one decimal.
fn secs(micros: u64) -> String {
    format!("{:.1}s", micros as f64 / 1e6)
}

/// The heartbeat column: age of the last heartbeat, `!` when late, `-` when none was heard.
fn heartbeat_text(row: &NodeRow, now: Instant) -> String {
    match row.age(now) {
        // Only a boot-up was heard: the node sends no heartbeat.
        _ if row.period().is_none() => "-".into(),
        None => "-".into(),
        Some(age) => {
            let late = if row.late { "!" } else { "" };
            format!("{}{late}", secs(age.as_micros()))
        }
    }
}

/// A sparkline of `values` in at most `width` characters (the latest values).
pub(crate) fn sparkline(values: &std::collections::VecDeque<f64>, width: usize) -> String {
    let take = values.len().min(width);
    let recent: Vec<f64> = values.iter().skip(values.len() - take).copied().collect();
    let (lo, hi) = recent
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    recent
        .iter()
        .map(|v| {
            if hi > lo && v.is_finite() {
                let i = ((v - lo) / (hi - lo) * 7.0).round() as usize;
                BARS[i.min(7)]
            } else {
                BARS[0]
            }
        })
        .collect()
}

fn cut(s: &str, width: usize) -> String {
    if s.chars().count() <= width {
        format!("{s:<width$}")
    } else {
        let mut t: String = s.chars().take(width.saturating_sub(1)).collect();
        t.push('…');
        t
    }
}

/// Draws the whole view.
pub(crate) fn draw(f: &mut Frame<'_>, model: &Model, s: &Screen<'_>) {
    let area = f.area();
    let wide = area.width >= WIDE.0 && area.height >= WIDE.1;
    let [title, body, status] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(0),
        Constraint::Length(1),
    ])
    .areas(area);
    draw_title(f, title, model, s);
    draw_status(f, status, s);
    let nodes = model
        .nodes
        .iter()
        .filter(|(n, r)| s.matches(&format!("node {n} {}", r.shown_name().unwrap_or_default())))
        .count() as u16;
    if wide {
        // The nodes across the top; below, the PDO values beside the bus, the SDO transfers
        // and the log.
        let [node_area, lower] =
            Layout::vertical([Constraint::Length(nodes.max(1) + 3), Constraint::Min(8)])
                .areas(body);
        let [pdo_area, right] =
            Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)])
                .areas(lower);
        let sdo_rows = model.sdo.len().clamp(1, 6) as u16;
        let [bus_area, sdo_area, log_area] = Layout::vertical([
            Constraint::Length(8),
            Constraint::Length(sdo_rows + 2),
            Constraint::Min(3),
        ])
        .areas(right);
        draw_nodes(f, node_area, model, s, true);
        draw_pdos(f, pdo_area, model, s);
        draw_bus(f, bus_area, model, s);
        draw_sdo(f, sdo_area, model, s);
        draw_log(f, log_area, model, s, false);
    } else {
        // One column: the bus in one line, the nodes, the PDO values, the log (SDO transfers
        // in flight as the log's first lines).
        let node_rows = nodes.clamp(1, 6) + 3;
        let pdo_rows = (model.signals.len() as u16).clamp(1, 6) + 2;
        let [bus_area, node_area, pdo_area, log_area] = Layout::vertical([
            Constraint::Length(1),
            Constraint::Length(node_rows),
            Constraint::Length(pdo_rows),
            Constraint::Min(3),
        ])
        .areas(body);
        draw_bus_line(f, bus_area, model, s);
        draw_nodes(f, node_area, model, s, false);
        draw_pdos(f, pdo_area, model, s);
        draw_log(f, log_area, model, s, true);
    }
    match s.mode {
        Mode::Help => draw_help(f, area, s),
        Mode::Confirm { question } => draw_popup(
            f,
            area,
            " confirm ",
            &[question, "y: yes, any other key: no"],
            s,
        ),
        _ => {}
    }
}

fn draw_title(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>) {
    // What changes first (a replay's position, the pause), then the bus, which a narrow
    // terminal may cut.
    let mut spans = vec![Span::styled(
        "canopen top",
        Style::default().add_modifier(Modifier::BOLD),
    )];
    if let Some(r) = s.replay {
        spans.push(Span::raw(format!("  {r}")));
    }
    if s.paused {
        spans.push(Span::styled(
            "  PAUSED",
            s.style(Color::Yellow).add_modifier(Modifier::BOLD),
        ));
    }
    spans.push(Span::raw(format!(
        "  {}  {} kbit/s  ? help  q quit",
        s.title,
        model.bitrate() / 1000
    )));
    f.render_widget(Paragraph::new(Line::from(spans)), area);
}

fn draw_status(f: &mut Frame<'_>, area: Rect, s: &Screen<'_>) {
    let line = match s.mode {
        Mode::Prompt { ask, text } => Line::from(vec![
            Span::styled(ask.label(), Style::default().add_modifier(Modifier::BOLD)),
            Span::raw(text.clone()),
            Span::styled("_", Style::default().add_modifier(Modifier::SLOW_BLINK)),
        ]),
        _ => {
            let mut spans = vec![Span::raw(s.status.to_owned())];
            if !s.filter.is_empty() {
                spans.push(Span::styled(
                    format!("  [filter: {}]", s.filter),
                    s.style(Color::Cyan),
                ));
            }
            Line::from(spans)
        }
    };
    f.render_widget(Paragraph::new(line), area);
}

fn draw_nodes(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>, wide: bool) {
    let inner = area.width.saturating_sub(2) as usize;
    // ID, state, heartbeat and EMCY count take 3+1+12+1+7+1+4+1 = 30 columns and the marker 2.
    let name_w = if wide { 36 } else { 14 };
    let rest = inner.saturating_sub(32 + name_w + 1);
    let head = format!(
        "  {:>3} {:<name_w$} {:<12} {:>7} {:>4} {}",
        "ID", "name", "NMT state", "HB age", "EMCY", "last EMCY / LSS"
    );
    let mut lines = vec![Line::styled(
        cut(&head, inner),
        Style::default().add_modifier(Modifier::BOLD),
    )];
    let now = model.now;
    for (id, row) in &model.nodes {
        let shown = row.shown_name().unwrap_or_default();
        let name = shown.as_str();
        if !s.matches(&format!("node {id} {name}")) {
            continue;
        }
        let sel = s.selected == Some(*id);
        let marker = if sel { "> " } else { "  " };
        let mut last = row.last_emcy.clone().unwrap_or_default();
        if let Some(lss) = &row.lss {
            if !last.is_empty() {
                last.push_str("; ");
            }
            last.push_str(lss);
        }
        let hb = heartbeat_text(row, now);
        let hb_style = if row.late {
            s.style(Color::Red).add_modifier(Modifier::BOLD)
        } else {
            Style::default()
        };
        let emcy_style = if row.emcy_count > 0 {
            s.style(Color::Red)
        } else {
            Style::default()
        };
        let mut line = Line::from(vec![
            Span::raw(format!("{marker}{:>3} ", id.get())),
            Span::raw(format!("{} ", cut(name, name_w))),
            Span::styled(
                format!("{:<12} ", state_text(row)),
                s.style(state_color(row.state)),
            ),
            Span::styled(format!("{hb:>7} "), hb_style),
            Span::styled(format!("{:>4} ", row.emcy_count), emcy_style),
            Span::styled(cut(&last, rest), emcy_style),
        ]);
        if sel {
            line = line.style(Style::default().add_modifier(Modifier::REVERSED));
        }
        lines.push(line);
    }
    if model.nodes.is_empty() {
        lines.push(Line::raw("  no node heard yet"));
    }
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" nodes ")),
        area,
    );
}

fn draw_bus(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>) {
    let b = &model.bus;
    let warn = |n: u64| {
        if n > 0 {
            s.style(Color::Red)
        } else {
            Style::default()
        }
    };
    let mut lines = vec![
        Line::raw(format!("frames/s   {:>8}   total {}", b.fps, b.frames)),
        Line::raw(format!(
            "load       {:>7.1}%   peak {:.1}%",
            b.load, b.peak_load
        )),
        Line::styled(format!("error frames {:>6}", b.errors), warn(b.errors)),
        Line::raw(format!("FD frames  {:>8}", b.fd)),
        Line::styled(
            format!(
                "lost       {:>8}   (receive queue {}, view {})",
                b.overflowed + s.lost,
                b.overflowed,
                s.lost
            ),
            warn(b.overflowed + s.lost),
        ),
    ];
    let lss = match (&model.lss_mode, &model.lss_last) {
        (None, None) => "LSS: -".to_owned(),
        (mode, last) => format!(
            "LSS: {}{}",
            mode.map(|m| format!("{m}; ")).unwrap_or_default(),
            last.as_deref().unwrap_or("")
        ),
    };
    lines.push(Line::raw(cut(&lss, area.width.saturating_sub(2) as usize)));
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" bus ")),
        area,
    );
}

/// The bus pane folded into one line (narrow terminals).
fn draw_bus_line(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>) {
    let b = &model.bus;
    let lost = b.overflowed + s.lost;
    let text = format!(
        "bus: {} fr/s  load {:.1}%  err {}  FD {}  lost {}  total {}",
        b.fps, b.load, b.errors, b.fd, lost, b.frames
    );
    let style = if lost > 0 || b.errors > 0 {
        s.style(Color::Red)
    } else {
        Style::default()
    };
    f.render_widget(Paragraph::new(Line::styled(text, style)), area);
}

fn draw_pdos(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>) {
    let inner = area.width.saturating_sub(2) as usize;
    let spark_w = (inner / 5).clamp(8, 30);
    let label_w = 16;
    let value_w = 14;
    let name_w = inner.saturating_sub(label_w + value_w + spark_w + 3).max(8);
    let mut lines = Vec::new();
    for sig in model.signals.values() {
        if !s.matches(&format!("{} {}", sig.pdo, sig.name)) {
            continue;
        }
        let node_sel = sig.node.is_some() && sig.node == s.selected;
        let label_style = if node_sel {
            Style::default().add_modifier(Modifier::BOLD)
        } else {
            Style::default()
        };
        let bold = Style::default().add_modifier(Modifier::BOLD);
        let mut spans = vec![Span::styled(
            format!("{} ", cut(&sig.pdo, label_w)),
            label_style,
        )];
        if sig.history.is_empty() {
            // Bytes (an undecoded PDO): no sparkline, the name's and the line's room for them.
            let w = name_w + value_w + spark_w + 1;
            spans.push(Span::raw(format!("{} ", cut(&sig.name, name_w))));
            spans.push(Span::styled(cut(&sig.text, w - name_w - 1), bold));
        } else {
            spans.push(Span::raw(format!("{} ", cut(&sig.name, name_w))));
            spans.push(Span::styled(format!("{} ", cut(&sig.text, value_w)), bold));
            spans.push(Span::styled(
                sparkline(&sig.history, spark_w),
                s.style(Color::Cyan),
            ));
        }
        lines.push(Line::from(spans));
    }
    if lines.is_empty() {
        lines.push(Line::raw("no PDO yet (nodes send PDOs when operational)"));
    }
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" PDO values ")),
        area,
    );
}

fn sdo_lines(model: &Model, s: &Screen<'_>) -> Vec<Line<'static>> {
    model
        .sdo
        .iter()
        .filter(|(n, t)| s.matches(&format!("node {n} {}", t.name.as_deref().unwrap_or(""))))
        .map(|(n, t)| {
            let size = t.size.map(|z| format!("/{z}")).unwrap_or_default();
            Line::styled(
                format!(
                    "SDO node {n} {} 0x{:04X}:{:02X} {} {}{size} B, {}",
                    t.kind.label(),
                    t.index,
                    t.sub,
                    t.name.as_deref().unwrap_or(""),
                    t.bytes,
                    secs(model.now.saturating_duration_since(t.started).as_micros())
                ),
                s.style(Color::Magenta),
            )
        })
        .collect()
}

fn draw_sdo(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>) {
    let mut lines = sdo_lines(model, s);
    if lines.is_empty() {
        lines.push(Line::raw("none in flight"));
    }
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" SDO transfers ")),
        area,
    );
}

/// The event log, newest last; `with_sdo` (one column) puts the SDO transfers in flight first.
fn draw_log(f: &mut Frame<'_>, area: Rect, model: &Model, s: &Screen<'_>, with_sdo: bool) {
    let rows = area.height.saturating_sub(2) as usize;
    let mut lines = if with_sdo {
        sdo_lines(model, s)
    } else {
        Vec::new()
    };
    let room = rows.saturating_sub(lines.len());
    let picked: Vec<_> = model
        .log
        .iter()
        .rev()
        .filter(|l| s.matches(&l.text))
        .take(room)
        .collect();
    for l in picked.into_iter().rev() {
        let style = match l.kind {
            LogKind::Info => Style::default(),
            LogKind::Warning => s.style(Color::Yellow),
            LogKind::Error => s.style(Color::Red),
        };
        lines.push(Line::styled(
            format!("{:>8.3} {}", model.seconds(l.at), l.text),
            style,
        ));
    }
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" events ")),
        area,
    );
}

fn popup_area(area: Rect, w: u16, h: u16) -> Rect {
    let w = w.min(area.width);
    let h = h.min(area.height);
    Rect {
        x: area.x + (area.width - w) / 2,
        y: area.y + (area.height - h) / 2,
        width: w,
        height: h,
    }
}

fn draw_popup(f: &mut Frame<'_>, area: Rect, title: &str, text: &[&str], _s: &Screen<'_>) {
    let w = text.iter().map(|t| t.chars().count()).max().unwrap_or(10) as u16 + 4;
    let r = popup_area(area, w, text.len() as u16 + 2);
    f.render_widget(Clear, r);
    let lines: Vec<Line<'_>> = text.iter().map(|t| Line::raw(t.to_string())).collect();
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(title.to_owned())),
        r,
    );
}

fn draw_help(f: &mut Frame<'_>, area: Rect, s: &Screen<'_>) {
    let lines: Vec<String> = HELP
        .iter()
        .map(|(k, what)| format!("{k:<10} {what}"))
        .collect();
    let refs: Vec<&str> = lines.iter().map(String::as_str).collect();
    draw_popup(f, area, " keys ", &refs, s);
}
