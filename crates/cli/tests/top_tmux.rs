//! `canopen top` in a real terminal: the binary runs in a detached tmux session against two
//! simulated devices on the in-memory bus (the README's line, `--eds 5=eds/burkert-generic.eds
//! --eds 6=eds/cia402-servo.eds top`), and the test reads the screen with `tmux capture-pane` as
//! the keys go in: both nodes and their states, `o` starting them, a PDO value changing after a
//! write with `w` (the servo's statusword), an EMCY after a fault is brought about through the
//! keys (the servo runs into its limit switch: EMCY 0x8612), `x` stopping a node and `o`
//! starting it again, `g` by index and by name, `p`, `r`, `c`, `O` and `X`, the panes at 80x24,
//! `/`, `s`, and `q` giving the shell back its terminal (primary screen, cooked mode); then the
//! saved log replayed (the README's `--replay` line: pause, step, seek, `NO_COLOR`), Ctrl-C and
//! SIGTERM ending the view; a panic in the running view (a debug build's test key) giving the
//! shell its terminal back too.
//!
//! Without tmux the test says it skipped, unless `CANOPEN_REQUIRE_TMUX=1` (scripts/test-all
//! sets it and installs tmux), where a missing tmux fails it.

#![cfg(unix)]

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The README's lines, typed as they are in a folder with the checkout's `eds`, `canopen` on
/// the PATH.
const DEMO: &str = "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/cia402-servo.eds top";
const REPLAY: &str =
    "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/cia402-servo.eds top --replay bus.log";

/// A tmux server of this test's own (its own socket), killed on drop.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn cmd(&self, args: &[&str]) -> std::process::Output {
        Command::new("tmux")
            .arg("-L")
            .arg(&self.socket)
            .args(args)
            .output()
            .expect("tmux runs")
    }

    fn keys(&self, keys: &[&str]) {
        let mut args = vec!["send-keys", "-t", "top"];
        args.extend_from_slice(keys);
        assert!(self.cmd(&args).status.success());
    }

    /// Types `text` as it is (tmux would read `0x6040` as a key code).
    fn text(&self, text: &str) {
        assert!(
            self.cmd(&["send-keys", "-t", "top", "-l", text])
                .status
                .success()
        );
    }

    /// The screen with its colours (SGR escape sequences).
    fn screen_escaped(&self) -> String {
        String::from_utf8_lossy(&self.cmd(&["capture-pane", "-p", "-e", "-t", "top"]).stdout)
            .into_owned()
    }

    fn screen(&self) -> String {
        String::from_utf8_lossy(&self.cmd(&["capture-pane", "-p", "-t", "top"]).stdout).into_owned()
    }

    /// Waits (15 s at most) until `ok` holds for the screen; the last screen otherwise.
    fn wait(&self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        let end = Instant::now() + Duration::from_secs(15);
        loop {
            let s = self.screen();
            if ok(&s) {
                return s;
            }
            assert!(Instant::now() < end, "waited for {what}; the screen:\n{s}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The shell's terminal is in cooked mode again (canonical input, echo).
    fn check_cooked(&self, tag: &str) {
        self.text(&format!(
            "echo {tag}:$(stty -a | tr ' ;' '\\n\\n' | grep -x -e '-\\?icanon' -e '-\\?echo')"
        ));
        self.keys(&["Enter"]);
        let prefix = format!("{tag}:");
        let s = self.wait("stty's answer", |s| {
            s.lines().any(|l| l.starts_with(&prefix))
        });
        let stty = s.lines().find(|l| l.starts_with(&prefix)).unwrap();
        assert_eq!(stty.trim(), format!("{tag}:icanon echo"), "{s}");
    }

    /// `w`, `OBJECT VALUE`, Enter, and `y` once the confirmation shows.
    fn write(&self, object_value: &str) {
        self.keys(&["w"]);
        self.text(object_value);
        self.keys(&["Enter"]);
        self.wait("the write's confirmation", |s| s.contains("y: yes"));
        self.keys(&["y"]);
        let (object, _) = object_value.split_once(' ').unwrap();
        let object = object.to_uppercase().replace("0X", "0x");
        self.wait("the write's result", |s| {
            s.lines()
                .last()
                .is_some_and(|l| l.starts_with(&format!("wrote node 6 {object}")))
        });
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = self.cmd(&["kill-server"]);
    }
}

/// The nodes pane's row of the node named `name`.
fn row<'a>(screen: &'a str, name: &str) -> &'a str {
    screen.lines().find(|l| l.contains(name)).unwrap_or("")
}

/// The value shown for the PDO value named `name`.
fn pdo_value(screen: &str, name: &str) -> Option<String> {
    let line = screen.lines().find(|l| l.contains(&format!(" {name} ")))?;
    let after = line.split(name).nth(1)?;
    after.split_whitespace().next().map(str::to_owned)
}

/// Whether a screen captured with its escape sequences sets a colour: an SGR sequence
/// (`ESC [ ... m`) with a foreground or background colour (30–38, 40–48, 90–97, 100–107; 39 and
/// 49, back to the default, are no colour).
fn coloured(escaped: &str) -> bool {
    escaped.split("\x1b[").skip(1).any(|seq| {
        let Some(params) = seq.split_once('m').map(|(p, _)| p) else {
            return false;
        };
        if !params.bytes().all(|b| b.is_ascii_digit() || b == b';') {
            return false;
        }
        params.split(';').any(|p| {
            matches!(
                p.parse::<u16>(),
                Ok(30..=38 | 40..=48 | 90..=97 | 100..=107)
            )
        })
    })
}

/// Whether a line with `then` comes after the last line with `first`.
fn after(screen: &str, first: &str, then: &str) -> bool {
    let lines: Vec<&str> = screen.lines().collect();
    lines
        .iter()
        .rposition(|l| l.contains(first))
        .is_some_and(|i| lines[i..].iter().any(|l| l.contains(then)))
}

/// Whether tmux runs; without it the test skips, unless `CANOPEN_REQUIRE_TMUX=1`.
fn tmux_or_skip() -> bool {
    let runs = Command::new("tmux")
        .arg("-V")
        .output()
        .is_ok_and(|o| o.status.success());
    if !runs {
        assert!(
            std::env::var("CANOPEN_REQUIRE_TMUX").as_deref() != Ok("1"),
            "CANOPEN_REQUIRE_TMUX=1 but tmux does not run"
        );
        eprintln!("skipped: tmux is not installed");
    }
    runs
}

/// A tmux server of its own with one session `top` of `w`x`h` running `sh`.
fn session(name: &str, w: u16, h: u16) -> Tmux {
    let t = Tmux {
        socket: format!("canopen-top-{name}-{}", std::process::id()),
    };
    let (w, h) = (w.to_string(), h.to_string());
    let out = t.cmd(&["new-session", "-d", "-s", "top", "-x", &w, "-y", &h, "sh"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    t
}

#[test]
fn top_in_tmux_shows_the_network_and_takes_the_keys() {
    if !tmux_or_skip() {
        return;
    }
    let readme = std::fs::read_to_string(format!("{ROOT}/README.md")).unwrap();
    assert!(readme.contains(DEMO) && readme.contains(REPLAY));
    let dir = std::env::temp_dir().join(format!("canopen-top-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::os::unix::fs::symlink(format!("{ROOT}/eds"), dir.join("eds")).unwrap();
    let bin = std::path::Path::new(env!("CARGO_BIN_EXE_canopen"));
    let t = session("demo", 120, 40);
    t.text(&format!(
        "cd '{}' && PATH='{}':$PATH",
        dir.display(),
        bin.parent().unwrap().display()
    ));
    t.keys(&["Enter"]);
    t.text(&format!(
        "printf 'BEFORE-%s\\n' TOP; {DEMO}; echo TOP-EXIT=$?"
    ));
    t.keys(&["Enter"]);

    // Both nodes, booted (pre-operational).
    let s = t.wait("both nodes in pre-operational", |s| {
        row(s, "Generic CANopen").contains("PRE-OP") && row(s, "CiA 402 servo").contains("PRE-OP")
    });
    assert!(s.contains("canopen top"), "{s}");
    assert!(
        s.contains("node 5: boot-up") && s.contains("node 6: boot-up"),
        "{s}"
    );

    // `o` on the first node (selected), then on the servo (`j`): operational.
    t.keys(&["o"]);
    t.wait("node 5 operational", |s| {
        row(s, "Generic CANopen").contains("OPERATIONAL")
    });
    t.keys(&["j", "o"]);
    let s = t.wait("node 6 operational and its statusword PDO", |s| {
        row(s, "CiA 402 servo").contains("OPERATIONAL") && pdo_value(s, "Statusword").is_some()
    });
    let before = pdo_value(&s, "Statusword").unwrap();
    // Colours: operational in green.
    assert!(coloured(&t.screen_escaped()), "no colour");

    // A PDO value change: controlword 6 (shutdown) moves the servo to ready to switch on.
    t.write("0x6040 6");
    let s = t.wait("the statusword to change", |s| {
        pdo_value(s, "Statusword").is_some_and(|v| v != before)
    });
    assert!(
        row(&s, "CiA 402 servo").contains("   0 "),
        "no EMCY yet: {s}"
    );

    // An EMCY: profile velocity mode, enable, a velocity that runs into the limit switch.
    t.write("0x6060 3");
    t.write("0x6040 7");
    t.write("0x6040 15");
    t.write("0x60FF 200000");
    let s = t.wait("the servo's EMCY", |s| {
        row(s, "CiA 402 servo").contains("EMCY 0x8612")
    });
    assert!(row(&s, "CiA 402 servo").contains("   1 EMCY"), "{s}");
    assert!(s.contains("node 6: EMCY 0x8612"), "the event log: {s}");

    // `x` stops node 5 (back up with `k`), `o` starts it again: its heartbeat says so.
    t.keys(&["k", "x"]);
    t.wait("node 5 stopped", |s| {
        row(s, "Generic CANopen").contains("STOPPED")
    });
    t.keys(&["o"]);
    t.wait("node 5 operational again", |s| {
        row(s, "Generic CANopen").contains("OPERATIONAL")
    });

    // `g` reads an object of the selected node, by index or by its EDS name.
    for (object, result) in [
        ("0x1018:1", "node 5 0x1018:01 = 57"),
        ("Producer heartbeat time", "node 5 0x1017:00 = 500"),
    ] {
        t.keys(&["g"]);
        t.text(object);
        t.keys(&["Enter"]);
        t.wait(result, |s| {
            s.lines().last().is_some_and(|l| l.starts_with(result))
        });
    }

    // `p`: pre-operational; `r` and `c`: the node resets and boots again.
    t.keys(&["p"]);
    t.wait("node 5 pre-operational", |s| {
        row(s, "Generic CANopen").contains("PRE-OP")
    });
    for (key, command) in [
        ("r", "NMT Reset node, node 5"),
        ("c", "NMT Reset communication, node 5"),
    ] {
        t.keys(&[key]);
        t.wait(command, |s| after(s, command, "node 5: boot-up"));
    }
    // The capital letters go to all nodes.
    t.keys(&["O"]);
    t.wait("all operational", |s| {
        after(
            s,
            "NMT Start remote node, all nodes",
            "node 5: Pre-operational -> Operational",
        )
    });
    t.keys(&["X"]);
    let s = t.wait("all stopped", |s| {
        row(s, "Generic CANopen").contains("STOPPED") && row(s, "CiA 402 servo").contains("STOPPED")
    });
    assert!(s.contains("NMT Stop remote node, all nodes"), "{s}");
    t.keys(&["O"]);
    t.wait("all operational again", |s| {
        row(s, "Generic CANopen").contains("OPERATIONAL")
            && row(s, "CiA 402 servo").contains("OPERATIONAL")
    });

    // 80x24: the panes fold, both nodes still there.
    assert!(
        t.cmd(&["resize-window", "-t", "top", "-x", "80", "-y", "24"])
            .status
            .success()
    );
    let s = t.wait("the one-column layout", |s| s.contains("bus: "));
    assert!(
        row(&s, "Generic CANop").contains("OPERATIONAL")
            && row(&s, "CiA 402 servo").contains("EMCY"),
        "{s}"
    );
    assert!(s.lines().all(|l| l.chars().count() <= 80), "{s}");

    // `/` filters the panes: only the servo's row and values are left.
    t.keys(&["/"]);
    t.text("servo");
    t.keys(&["Enter"]);
    let s = t.wait("the filter", |s| s.contains("[filter: servo]"));
    assert!(row(&s, "Generic CANop").is_empty(), "{s}");
    assert!(!row(&s, "CiA 402 servo").is_empty(), "{s}");

    // `s` saves the traffic so far as a candump log: every frame, also while a filter narrows
    // the view, and the message says so ("unfiltered") beside the filter shown.
    let log = dir.join("bus.log");
    t.keys(&["s", "C-u"]);
    t.text("bus.log");
    t.keys(&["Enter"]);
    let s = t.wait("the log saved", |s| {
        s.lines().last().is_some_and(|l| l.starts_with("saved "))
    });
    assert!(s.contains(" unfiltered frames to bus.log"), "{s}");
    t.keys(&["/", "C-u", "Enter"]);
    t.wait("no filter", |s| !row(s, "Generic CANop").is_empty());
    let text = std::fs::read_to_string(&log).unwrap();
    let entries: Vec<_> = canola::candump::Reader::new(text.as_bytes())
        .collect::<Result<_, _>>()
        .expect("the saved log reads back");
    assert!(entries.len() > 20, "{text}");
    assert!(
        text.contains("086#1286"),
        "the servo's EMCY 0x8612 is in the log: {text}"
    );

    // `q`: the shell's screen and cooked mode are back.
    t.keys(&["q"]);
    let s = t.wait("top to end", |s| {
        s.lines().any(|l| l.starts_with("TOP-EXIT="))
    });
    assert!(s.contains("TOP-EXIT=0"), "{s}");
    assert!(s.contains("BEFORE-TOP"), "the primary screen is back: {s}");
    assert!(!s.contains("canopen top"), "{s}");
    t.check_cooked("STTY1");

    // The saved log replayed: paused, stepped, then run to its end with →; the EMCY is there.
    t.text(&format!(
        "export NO_COLOR=1; clear; {REPLAY}; echo TOP-EXIT2=$?"
    ));
    t.keys(&["Enter"]);
    t.wait("the replay", |s| {
        s.contains("replay ") && s.contains("node 5: boot-up")
    });
    t.keys(&["Space"]);
    let s = t.wait("the replay paused", |s| s.contains("paused"));
    let frame = |s: &str| -> u64 {
        let after = s.split("frame ").nth(1).unwrap_or("");
        after
            .split_whitespace()
            .next()
            .unwrap_or("0")
            .parse()
            .unwrap_or(0)
    };
    let at = frame(&s);
    t.keys(&["n"]);
    t.wait("one frame on", |s| frame(s) == at + 1);
    for _ in 0..12 {
        t.keys(&["Right"]);
    }
    let s = t.wait("the end of the log", |s| s.contains("end of log"));
    assert!(row(&s, "CiA 402 servo").contains("EMCY 0x8612"), "{s}");
    // NO_COLOR: no colour anywhere (bold and reverse video stay).
    let escaped = t.screen_escaped();
    assert!(!coloured(&escaped), "a colour under NO_COLOR: {escaped:?}");
    // Ctrl-C ends it as q does.
    t.keys(&["C-c"]);
    let s = t.wait("the replay to end", |s| {
        s.lines().any(|l| l.starts_with("TOP-EXIT2="))
    });
    assert!(s.contains("TOP-EXIT2=0"), "{s}");
    t.check_cooked("STTY2");

    // SIGTERM ends it as q does: the terminal comes back.
    t.text(&format!("clear; {DEMO}; echo TOP-EXIT3=$?"));
    t.keys(&["Enter"]);
    t.wait("top again", |s| row(s, "Generic CANop").contains("PRE-OP"));
    let shell: i32 = String::from_utf8_lossy(
        &t.cmd(&["display-message", "-p", "-t", "top", "#{pane_pid}"])
            .stdout,
    )
    .trim()
    .parse()
    .unwrap();
    let children = std::fs::read_to_string(format!("/proc/{shell}/task/{shell}/children")).unwrap();
    let top: i32 = children.split_whitespace().next().unwrap().parse().unwrap();
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(top),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let s = t.wait("top to end on SIGTERM", |s| {
        s.lines().any(|l| l.starts_with("TOP-EXIT3="))
    });
    assert!(s.contains("TOP-EXIT3=0"), "{s}");
    t.check_cooked("STTY3");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_panic_in_the_running_view_restores_the_terminal() {
    if !tmux_or_skip() {
        return;
    }
    let t = session("panic", 100, 30);
    t.text(&format!(
        "cd {ROOT} && RUST_BACKTRACE=0 CANOPEN_TOP_TEST_PANIC=1 '{}' --eds 5=eds/burkert-generic.eds top; echo TOP-EXIT=$?",
        env!("CARGO_BIN_EXE_canopen")
    ));
    t.keys(&["Enter"]);
    t.wait("the view with node 5", |s| {
        row(s, ">   5").contains("PRE-OP")
    });
    t.keys(&["!"]);
    let s = t.wait("the shell after the panic", |s| {
        s.lines().any(|l| l.starts_with("TOP-EXIT="))
    });
    assert!(s.lines().any(|l| l.trim() == "TOP-EXIT=101"), "{s}");
    assert!(s.contains("test panic requested"), "{s}");
    // The primary screen: the command line typed before the view is visible again.
    assert!(s.contains("CANOPEN_TOP_TEST_PANIC=1"), "{s}");
    t.check_cooked("STTYP");
}

#[test]
fn without_a_terminal_top_says_so_and_fails() {
    let o = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["top"])
        .stdin(std::process::Stdio::null())
        .output()
        .expect("the binary runs");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("draws on a terminal"), "{err}");
    // Options are checked first: a bad bit rate is a usage error.
    let o = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["top", "--bitrate", "fast"])
        .output()
        .expect("the binary runs");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn top_over_the_udp_bus_against_canopen_simulate() {
    if !tmux_or_skip() {
        return;
    }
    let iface = common::udp_bus(3);
    let eds = format!("{ROOT}/eds/burkert-generic.eds");
    let mut sim = common::simulator(&iface, &eds, "5", "60");
    let t = session("udp", 100, 30);
    t.text(&format!(
        "'{}' --iface {iface} --hex top; echo TOP-EXIT=$?",
        env!("CARGO_BIN_EXE_canopen")
    ));
    t.keys(&["Enter"]);
    // No EDS here: the node is known by its frames, its PDOs shown as bytes.
    let node = |s: &str| row(s, ">   5").to_owned();
    t.wait("node 5 over UDP", |s| node(s).contains("PRE-OP"));
    t.keys(&["o"]);
    let s = t.wait("node 5 operational and its PDOs", |s| {
        node(s).contains("OPERATIONAL") && s.contains("TPDO1 node 5     data")
    });
    assert!(s.contains(&iface), "{s}");
    // `g` without an EDS: CiA 301 types 0x1018; `--hex` prints it in hex.
    t.keys(&["g"]);
    t.text("0x1018:1");
    t.keys(&["Enter"]);
    t.wait("the vendor-ID in hex", |s| {
        s.lines()
            .last()
            .is_some_and(|l| l.starts_with("node 5 0x1018:01 = 0x00000039"))
    });
    // The read went by on the bus: the node is named by its identity now.
    t.wait("the node named", |s| node(s).contains("vendor 0x0000"));
    t.keys(&["q"]);
    let s = t.wait("top to end", |s| {
        s.lines().any(|l| l.starts_with("TOP-EXIT="))
    });
    assert!(s.contains("TOP-EXIT=0"), "{s}");
    let _ = sim.kill();
    let _ = sim.wait();
}
