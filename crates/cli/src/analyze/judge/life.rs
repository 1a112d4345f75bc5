//! A node's life as the log shows it: LSS sessions, NMT commands, heartbeats against the
//! producer time (late, lost, state changes nothing explains, two producers of one node-ID) and
//! boot-ups (loops, NMT commands sent while nodes boot).

use super::*;

impl Analyzer {
    pub(super) fn lss(&mut self, t: u64, frame: &CanFrame) {
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

    pub(super) fn nmt(&mut self, line: usize, t: u64, frame: &CanFrame) {
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

    pub(super) fn heartbeat(&mut self, line: usize, t: u64, n: u8, byte: u8, frame: &CanFrame) {
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

    pub(super) fn boot_up(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
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
}
