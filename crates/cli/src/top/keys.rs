//! The keys of `canopen top`: what each does in each mode of the view (browsing, typing an
//! answer to a prompt, confirming a write, reading the help), as [`Action`]s the app carries
//! out. No terminal here: a key is a [`KeyEvent`] value, so the mapping is tested as it is.

use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use canola::CommandSpecifier;

/// What a prompt asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ask {
    /// `g`: an object to read from the selected node.
    Read,
    /// `w`: an object and a value to write to the selected node.
    Write,
    /// `/`: a filter for the panes.
    Filter,
    /// `s`: the file to save the traffic in.
    Save,
}

impl Ask {
    /// The prompt's text.
    pub(crate) fn label(self) -> &'static str {
        match self {
            Self::Read => "read OBJECT (0x1018:1, or a name): ",
            Self::Write => "write OBJECT VALUE (0x1017 1000): ",
            Self::Filter => "filter: ",
            Self::Save => "save traffic as candump log: ",
        }
    }
}

/// The view's mode: what keys mean now.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) enum Mode {
    /// Browsing.
    #[default]
    Normal,
    /// Typing an answer.
    Prompt {
        /// What for.
        ask: Ask,
        /// Typed so far.
        text: String,
    },
    /// A write waits for `y`.
    Confirm {
        /// The question shown.
        question: String,
    },
    /// The help pane is open.
    Help,
}

/// What a key asks the app to do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Action {
    /// Nothing (the mode may have changed).
    None,
    Quit,
    /// Select the previous / next node.
    Up,
    Down,
    /// An NMT command to the selected node, or to all nodes.
    Nmt {
        command: CommandSpecifier,
        all: bool,
    },
    /// A prompt was answered.
    Submit {
        ask: Ask,
        text: String,
    },
    /// The write waiting for confirmation goes ahead.
    Confirmed,
    /// The write waiting for confirmation is dropped.
    Declined,
    /// Open a prompt (the app may put a default answer in).
    Open(Ask),
    TogglePause,
    /// Replay: one frame forward.
    Step,
    /// Replay: jump by this many seconds (negative: back).
    Seek(i32),
}

/// The action of `key` in `mode`; changes `mode` for keys that open or close a prompt or the
/// help. `replay` adds the replay keys (n, ←, →).
pub(crate) fn handle(mode: &mut Mode, key: KeyEvent, replay: bool) -> Action {
    if key.kind == KeyEventKind::Release {
        return Action::None;
    }
    let ctrl = key.modifiers.contains(KeyModifiers::CONTROL);
    if ctrl && key.code == KeyCode::Char('c') {
        return Action::Quit;
    }
    match mode {
        Mode::Help => {
            *mode = Mode::Normal;
            Action::None
        }
        Mode::Confirm { .. } => {
            *mode = Mode::Normal;
            match key.code {
                KeyCode::Char('y' | 'Y') => Action::Confirmed,
                _ => Action::Declined,
            }
        }
        Mode::Prompt { ask, text } => match key.code {
            KeyCode::Esc => {
                *mode = Mode::Normal;
                Action::None
            }
            KeyCode::Enter => {
                let action = Action::Submit {
                    ask: *ask,
                    text: text.trim().to_owned(),
                };
                *mode = Mode::Normal;
                action
            }
            KeyCode::Backspace => {
                text.pop();
                Action::None
            }
            KeyCode::Char('u') if ctrl => {
                text.clear();
                Action::None
            }
            KeyCode::Char(c) if !ctrl => {
                text.push(c);
                Action::None
            }
            _ => Action::None,
        },
        Mode::Normal => normal(mode, key, replay),
    }
}

fn normal(mode: &mut Mode, key: KeyEvent, replay: bool) -> Action {
    let nmt = |command, all| Action::Nmt { command, all };
    match key.code {
        KeyCode::Char('q') => Action::Quit,
        KeyCode::Up | KeyCode::Char('k') => Action::Up,
        KeyCode::Down | KeyCode::Char('j') => Action::Down,
        KeyCode::Char('o') => nmt(CommandSpecifier::Start, false),
        KeyCode::Char('O') => nmt(CommandSpecifier::Start, true),
        KeyCode::Char('p') => nmt(CommandSpecifier::EnterPreOperational, false),
        KeyCode::Char('P') => nmt(CommandSpecifier::EnterPreOperational, true),
        KeyCode::Char('x') => nmt(CommandSpecifier::Stop, false),
        KeyCode::Char('X') => nmt(CommandSpecifier::Stop, true),
        KeyCode::Char('r') => nmt(CommandSpecifier::ResetNode, false),
        KeyCode::Char('R') => nmt(CommandSpecifier::ResetNode, true),
        KeyCode::Char('c') => nmt(CommandSpecifier::ResetCommunication, false),
        KeyCode::Char('C') => nmt(CommandSpecifier::ResetCommunication, true),
        KeyCode::Char('g') => open(mode, Ask::Read),
        KeyCode::Char('w') => open(mode, Ask::Write),
        KeyCode::Char('/') => open(mode, Ask::Filter),
        KeyCode::Char('s') => open(mode, Ask::Save),
        KeyCode::Char(' ') => Action::TogglePause,
        KeyCode::Char('?') | KeyCode::F(1) => {
            *mode = Mode::Help;
            Action::None
        }
        KeyCode::Char('n') if replay => Action::Step,
        KeyCode::Right if replay => Action::Seek(10),
        KeyCode::Left if replay => Action::Seek(-10),
        _ => Action::None,
    }
}

fn open(mode: &mut Mode, ask: Ask) -> Action {
    *mode = Mode::Prompt {
        ask,
        text: String::new(),
    };
    Action::Open(ask)
}

/// The help pane's lines: key, what it does.
pub(crate) const HELP: &[(&str, &str)] = &[
    ("↑ ↓  k j", "select a node"),
    ("o / O", "start (operational) the node / all nodes"),
    ("p / P", "enter pre-operational, the node / all"),
    ("x / X", "stop the node / all"),
    ("r / R", "reset the node / all"),
    ("c / C", "reset communication, the node / all"),
    ("g", "read an object of the node (index or name)"),
    ("w", "write an object of the node (asks to confirm)"),
    (
        "/",
        "filter nodes, PDO values and the log (Enter on empty: none)",
    ),
    ("space", "pause the view (replay: pause the log)"),
    ("s", "save the traffic so far as a candump log"),
    ("n  ← →", "replay: one frame, 10 s back / forward"),
    ("Ctrl-U", "clear a prompt's text (Esc leaves it)"),
    ("?", "this help (any key closes it)"),
    ("q  Ctrl-C", "quit"),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn key(c: char) -> KeyEvent {
        KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE)
    }

    #[test]
    fn nmt_keys_go_to_the_node_or_all() {
        let mut m = Mode::Normal;
        assert_eq!(
            handle(&mut m, key('x'), false),
            Action::Nmt {
                command: CommandSpecifier::Stop,
                all: false
            }
        );
        assert_eq!(
            handle(&mut m, key('O'), false),
            Action::Nmt {
                command: CommandSpecifier::Start,
                all: true
            }
        );
        assert_eq!(handle(&mut m, key('q'), false), Action::Quit);
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(handle(&mut m, ctrl_c, false), Action::Quit);
        // Replay keys only in a replay.
        assert_eq!(handle(&mut m, key('n'), false), Action::None);
        assert_eq!(handle(&mut m, key('n'), true), Action::Step);
    }

    #[test]
    fn a_prompt_collects_text_and_a_write_asks_first() {
        let mut m = Mode::Normal;
        assert_eq!(handle(&mut m, key('w'), false), Action::Open(Ask::Write));
        for c in "0x1017 1000x".chars() {
            assert_eq!(handle(&mut m, key(c), false), Action::None);
        }
        let bs = KeyEvent::new(KeyCode::Backspace, KeyModifiers::NONE);
        handle(&mut m, bs, false);
        // `q` inside a prompt is text, not quit.
        let enter = KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE);
        assert_eq!(
            handle(&mut m, enter, false),
            Action::Submit {
                ask: Ask::Write,
                text: "0x1017 1000".into()
            }
        );
        assert_eq!(m, Mode::Normal);
        m = Mode::Confirm {
            question: "?".into(),
        };
        assert_eq!(handle(&mut m, key('n'), false), Action::Declined);
        m = Mode::Confirm {
            question: "?".into(),
        };
        assert_eq!(handle(&mut m, key('y'), false), Action::Confirmed);
        assert_eq!(m, Mode::Normal);
        // Esc leaves a prompt without an action.
        handle(&mut m, key('/'), false);
        let esc = KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE);
        assert_eq!(handle(&mut m, esc, false), Action::None);
        assert_eq!(m, Mode::Normal);
    }
}
