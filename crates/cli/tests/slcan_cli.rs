//! The bus commands over `--iface slcan:PTY`: the CLI opens the slave side of a
//! pseudo-terminal pair as it would a USB adapter's `/dev/ttyACM0`; on the master side a fake
//! Lawicel-style adapter, written by hand from the slcan command table (not from the stack's
//! codec), answers commands and queries and bridges frame lines to a simulated device (the
//! library's `SimDevice`, stepped on a real clock). Everything above the transport (SDO, NMT,
//! scan, monitor, record) runs unchanged; `adapter info` shows the adapter's `V`, `N` and `F`
//! answers. A second fake, two adapters bridged onto one bus, carries `canopen simulate` on one
//! and the master's SDO on the other, and LSS slaves on one and `lss assign-all` on the other;
//! the gateway (stdio), `replay`, and a CiA 302-2 boot and audit run through the first. A pty
//! that never answers is not taken for an empty bus.

#![cfg(unix)]

use std::os::fd::{AsFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;

use canola::frame::time::MonotonicClock;
use canola::{CanFrame, CanId, NodeId, SimDevice, Station};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

/// A fake adapter with a device behind it, on a fresh pty pair.
struct Adapter {
    path: String,
    /// Every line the host sent, without its CR.
    lines: Arc<Mutex<Vec<String>>>,
    stop: Arc<AtomicBool>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Adapter {
    fn start(node: u8) -> Self {
        Self::start_with(node, EDS)
    }

    /// A fake adapter with the device of `eds` (an EDS or DCF file) behind it.
    fn start_with(node: u8, eds: &str) -> Self {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        let path = nix::unistd::ttyname(pty.slave.as_fd())
            .expect("ttyname")
            .to_string_lossy()
            .into_owned();
        // Writes never block the adapter: with no host reading, frames are dropped (the host
        // clears its buffers when it opens the port).
        let fl = nix::fcntl::fcntl(pty.master.as_fd(), nix::fcntl::FcntlArg::F_GETFL).unwrap();
        let fl = nix::fcntl::OFlag::from_bits_truncate(fl) | nix::fcntl::OFlag::O_NONBLOCK;
        nix::fcntl::fcntl(pty.master.as_fd(), nix::fcntl::FcntlArg::F_SETFL(fl)).unwrap();
        let eds = std::fs::read(eds).unwrap();
        let device = SimDevice::from_eds(NodeId::new(node).unwrap(), &eds).unwrap();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (l, s) = (lines.clone(), stop.clone());
        let thread = thread::spawn(move || run(pty.master, pty.slave, device, l, s));
        Self {
            path,
            lines,
            stop,
            thread: Some(thread),
        }
    }

    fn iface(&self) -> String {
        format!("slcan:{}@500k", self.path)
    }

    fn lines(&self) -> Vec<String> {
        self.lines.lock().unwrap().clone()
    }

    /// Whether the host sent `line`, waiting up to 5 s for the adapter thread to read it.
    fn saw(&self, line: &str) -> bool {
        let until = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while std::time::Instant::now() < until {
            if self.lines().iter().any(|l| l == line) {
                return true;
            }
            thread::sleep(std::time::Duration::from_millis(10));
        }
        false
    }
}

impl Drop for Adapter {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn write_line(master: &OwnedFd, bytes: &[u8]) {
    // Non-blocking: a full buffer (no host reading) drops the line, as a real adapter would.
    let _ = nix::unistd::write(master, bytes);
}

/// `tIIILDD...` or `TIIIIIIIILDD...` as a frame, by hand.
fn parse_frame(line: &str) -> Option<CanFrame> {
    let (ext, rest) = match line.as_bytes().first()? {
        b't' => (false, &line[1..]),
        b'T' => (true, &line[1..]),
        _ => return None,
    };
    let idlen = if ext { 8 } else { 3 };
    let raw = u32::from_str_radix(rest.get(..idlen)?, 16).ok()?;
    let len = rest.get(idlen..idlen + 1)?.parse::<usize>().ok()?;
    let hex = rest.get(idlen + 1..idlen + 1 + 2 * len)?;
    let data: Vec<u8> = (0..len)
        .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16))
        .collect::<Result<_, _>>()
        .ok()?;
    let id = if ext {
        CanId::extended(raw).ok()?
    } else {
        CanId::standard(raw as u16).ok()?
    };
    CanFrame::new(id, &data).ok()
}

fn format_frame(f: &CanFrame) -> String {
    let mut s = if f.id().is_extended() {
        format!("T{:08X}{}", f.id().as_raw(), f.data().len())
    } else {
        format!("t{:03X}{}", f.id().as_raw(), f.data().len())
    };
    for b in f.data() {
        s.push_str(&format!("{b:02X}"));
    }
    s.push('\r');
    s
}

fn run(
    master: OwnedFd,
    // Held so the master never reads EIO between two CLI runs.
    _slave: OwnedFd,
    mut device: SimDevice,
    lines: Arc<Mutex<Vec<String>>>,
    stop: Arc<AtomicBool>,
) {
    let clock = MonotonicClock::new();
    let mut open = false;
    let mut pending = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        if device.poll_timeout().is_some_and(|t| t <= now) {
            device.handle_timeout(now);
        }
        while let Some(f) = device.poll_transmit() {
            if open {
                write_line(&master, format_frame(&f).as_bytes());
            }
        }
        let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
        if poll(&mut fds, PollTimeout::from(2u8)).unwrap_or(0) == 0 {
            continue;
        }
        let mut buf = [0u8; 512];
        let n = match nix::unistd::read(&master, &mut buf) {
            Ok(n) => n,
            Err(_) => continue,
        };
        pending.extend_from_slice(&buf[..n]);
        while let Some(cr) = pending.iter().position(|&b| b == b'\r') {
            let line: Vec<u8> = pending.drain(..=cr).take(cr).collect();
            let line = String::from_utf8_lossy(&line).into_owned();
            lines.lock().unwrap().push(line.clone());
            let reply: Vec<u8> = match line.as_str() {
                "" => Vec::new(),
                "O" | "L" => {
                    open = true;
                    b"\r".to_vec()
                }
                "C" => {
                    open = false;
                    b"\r".to_vec()
                }
                l if l.len() == 2 && l.starts_with('S') && l.as_bytes()[1].is_ascii_digit() => {
                    b"\r".to_vec()
                }
                "V" => b"V1013\r".to_vec(),
                "N" => b"NSIM7\r".to_vec(),
                "F" => b"F20\r".to_vec(),
                l => match parse_frame(l) {
                    Some(f) if open => {
                        device.handle_frame(clock.now(), &f);
                        if l.starts_with('t') {
                            b"z\r".to_vec()
                        } else {
                            b"Z\r".to_vec()
                        }
                    }
                    _ => b"\x07".to_vec(),
                },
            };
            write_line(&master, &reply);
        }
    }
}

#[test]
fn sdo_nmt_and_scan_run_unchanged_over_an_slcan_adapter() {
    let adapter = Adapter::start(5);
    let iface = adapter.iface();
    let eds = format!("5={EDS}");

    // The open sequence: close, bit rate (500 kbit/s is S6), open.
    let o = canopen(&[
        "--iface", &iface, "sdo", "read", "5", "0x1017", "0", "-t", "u16",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500\n");
    let first: Vec<String> = adapter.lines().into_iter().take(3).collect();
    assert_eq!(first, ["C", "S6", "O"]);
    // Expedited write and read back, the frames as slcan lines.
    let o = canopen(&[
        "--iface", &iface, "sdo", "write", "5", "0x1017", "0", "250", "-t", "u16",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        adapter.lines().iter().any(|l| l == "t60582B171000FA000000"),
        "{:?}",
        adapter.lines()
    );
    let o = canopen(&[
        "--iface", &iface, "sdo", "read", "5", "0x1017", "0", "-t", "u16",
    ]);
    assert_eq!(stdout(&o), "250\n", "{}", stderr(&o));
    // Segmented: the device name (23 bytes), through the dictionary's name.
    let o = canopen(&[
        "--iface", &iface, "--eds", &eds, "sdo", "read", "5", "0x1008", "0",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "Buerkert generic device\n");

    // NMT: the command frame reaches the adapter.
    let o = canopen(&["--iface", &iface, "nmt", "start", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(adapter.saw("t00020105"), "{:?}", adapter.lines());

    // Scan finds the device with its identity.
    let o = canopen(&["--iface", &iface, "scan"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let rows: Vec<Vec<&str>> = out
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .filter(|r: &Vec<&str>| !r.is_empty())
        .collect();
    // Node 5 alone, with the vendor-ID of its dictionary (0x1018:1 = 57).
    assert_eq!(rows.len(), 1, "{out}");
    assert_eq!(&rows[0][..2], ["5", "57"], "{out}");
}

/// Two fake adapters on one bus: each a pty, commands answered with CR, every frame line from
/// one passed to the other while its channel is open.
struct Bridge {
    paths: [String; 2],
    stop: Arc<AtomicBool>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Bridge {
    fn start() -> Self {
        let a = nix::pty::openpty(None, None).expect("openpty");
        let b = nix::pty::openpty(None, None).expect("openpty");
        let name = |p: &nix::pty::OpenptyResult| {
            nix::unistd::ttyname(p.slave.as_fd())
                .unwrap()
                .to_string_lossy()
                .into_owned()
        };
        let paths = [name(&a), name(&b)];
        for p in [&a, &b] {
            let fl = nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_GETFL).unwrap();
            let fl = nix::fcntl::OFlag::from_bits_truncate(fl) | nix::fcntl::OFlag::O_NONBLOCK;
            nix::fcntl::fcntl(p.master.as_fd(), nix::fcntl::FcntlArg::F_SETFL(fl)).unwrap();
        }
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = thread::spawn(move || {
            let masters = [a.master, b.master];
            let _slaves = [a.slave, b.slave];
            let mut open = [false; 2];
            let mut pending = [Vec::new(), Vec::new()];
            while !s.load(Ordering::Relaxed) {
                let mut fds = [
                    PollFd::new(masters[0].as_fd(), PollFlags::POLLIN),
                    PollFd::new(masters[1].as_fd(), PollFlags::POLLIN),
                ];
                if poll(&mut fds, PollTimeout::from(5u8)).unwrap_or(0) == 0 {
                    continue;
                }
                for i in 0..2 {
                    let mut buf = [0u8; 512];
                    if let Ok(n) = nix::unistd::read(&masters[i], &mut buf) {
                        pending[i].extend_from_slice(&buf[..n]);
                    }
                    while let Some(cr) = pending[i].iter().position(|&b| b == b'\r') {
                        let line: Vec<u8> = pending[i].drain(..=cr).collect();
                        let text = std::str::from_utf8(&line[..line.len() - 1]).unwrap_or("");
                        let frame = parse_frame(text).is_some();
                        match line[0] {
                            b'O' | b'L' => open[i] = true,
                            b'C' => open[i] = false,
                            _ if frame && open[i] && open[1 - i] => {
                                write_line(&masters[1 - i], &line);
                            }
                            _ => {}
                        }
                        write_line(&masters[i], b"\r");
                    }
                }
            }
        });
        Self {
            paths,
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Bridge {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn simulate_on_one_adapter_answers_the_master_on_another() {
    let bridge = Bridge::start();
    let device = format!("slcan:{}", bridge.paths[1]);
    let master = format!("slcan:{}", bridge.paths[0]);
    let mut sim = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            &device,
            "simulate",
            EDS,
            "--node-id",
            "7",
            "--duration",
            "20",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("simulate starts");
    let mut answered = false;
    for _ in 0..50 {
        let o = canopen(&[
            "--iface", &master, "sdo", "read", "7", "0x1018", "1", "-t", "u32",
        ]);
        if o.status.success() {
            assert_eq!(stdout(&o), "57\n");
            answered = true;
            break;
        }
    }
    let eds = format!("7={EDS}");
    let o = canopen(&[
        "--iface", &master, "--eds", &eds, "sdo", "read", "7", "0x1008",
    ]);
    let _ = sim.kill();
    let _ = sim.wait();
    assert!(
        answered,
        "the simulated device never answered over the adapters"
    );
    assert_eq!(stdout(&o), "Buerkert generic device\n", "{}", stderr(&o));
}

#[test]
fn monitor_and_record_over_an_slcan_adapter() {
    let adapter = Adapter::start(6);
    let iface = adapter.iface();
    // The device's heartbeats (0x1017 = 500 ms in its dictionary), decoded.
    let o = canopen(&["--iface", &iface, "monitor", "--duration", "1.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("706"), "{out}");
    assert!(out.to_lowercase().contains("heartbeat"), "{out}");
    // Recorded as a candump log.
    let log = std::env::temp_dir().join(format!("canopen-slcan-{}.log", std::process::id()));
    let o = canopen(&[
        "--iface",
        &iface,
        "record",
        "-o",
        log.to_str().unwrap(),
        "--duration",
        "1.5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&log).unwrap();
    let _ = std::fs::remove_file(&log);
    assert!(text.lines().any(|l| l.contains("706#")), "{text}");
}

#[test]
fn adapter_info_shows_version_serial_and_status() {
    let adapter = Adapter::start(5);
    let iface = adapter.iface();
    let o = canopen(&["--iface", &iface, "adapter", "info"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("version   1013 (hardware 10, software 13)"),
        "{out}"
    );
    assert!(out.contains("serial    SIM7"), "{out}");
    assert!(out.contains("status    0x20 (error passive)"), "{out}");
    assert!(out.contains("acknowledges commands"), "{out}");
    assert!(out.contains("500000 bit/s (S6)"), "{out}");
    assert!(out.contains("can fd    unknown"), "{out}");
    let o = canopen(&["--json", "--iface", &iface, "adapter", "info"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(v["serial"], "SIM7");
    assert_eq!(v["status"], 0x20);
    assert_eq!(v["hardware_version"], 10);
    assert_eq!(v["bitrate"], 500_000);
    // Not an slcan bus, and no adapter at the path: errors that say so.
    let o = canopen(&["--iface", "udp", "adapter", "info"]);
    assert!(
        stderr(&o).contains("not an slcan adapter"),
        "{}",
        stderr(&o)
    );
    let o = canopen(&["--iface", "slcan:/nonexistent/ttyACM9", "adapter", "info"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.starts_with("error: slcan:/nonexistent/ttyACM9: no such serial device"),
        "{e}"
    );
    assert!(e.contains("hint: "), "{e}");
}

#[test]
fn lss_assign_all_runs_unchanged_over_slcan_adapters() {
    let bridge = Bridge::start();
    let slaves_iface = format!("slcan:{}", bridge.paths[1]);
    let master = format!("slcan:{}", bridge.paths[0]);
    let mut slaves = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            &slaves_iface,
            "lss",
            "--unconfigured",
            "2",
            "--real-slaves",
            "simulate",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("the LSS slaves start");
    thread::sleep(std::time::Duration::from_millis(500));
    let o = canopen(&[
        "--iface",
        &master,
        "lss",
        "assign-all",
        "--first",
        "2",
        "--last",
        "3",
    ]);
    let _ = slaves.kill();
    let _ = slaves.wait();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let ids: Vec<&str> = out
        .lines()
        .filter_map(|l| l.rsplit_once("node-ID ").map(|(_, id)| id.trim()))
        .collect();
    assert_eq!(ids, ["2", "3"], "{out}");
}

#[test]
fn the_gateway_and_replay_run_unchanged_over_an_slcan_adapter() {
    use std::io::Write as _;
    let adapter = Adapter::start(5);
    let iface = adapter.iface();
    // CiA 309-3 over stdio: a read and a write through the adapter to the device.
    let mut gw = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["--iface", &iface, "gateway", "--stdio"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the gateway starts");
    gw.stdin
        .take()
        .unwrap()
        .write_all(b"[1] 5 r 0x1017 0 u16\n[2] 5 w 0x1017 0 u16 300\n[3] 5 r 0x1017 0 u16\n")
        .unwrap();
    let o = gw.wait_with_output().unwrap();
    assert_eq!(
        stdout(&o),
        "[1] 500\r\n[2] OK\r\n[3] 300\r\n",
        "{}",
        stderr(&o)
    );
    assert!(
        adapter.saw("t60582B1710002C010000"),
        "{:?}",
        adapter.lines()
    );
    // A candump log replayed onto the adapter: its frames become slcan lines.
    let log = std::env::temp_dir().join(format!("canopen-slcan-replay-{}.log", std::process::id()));
    std::fs::write(&log, "(1700000000.000000) can0 000#8005\n").unwrap();
    let o = canopen(&["--iface", &iface, "replay", log.to_str().unwrap()]);
    let _ = std::fs::remove_file(&log);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(adapter.saw("t00028005"), "{:?}", adapter.lines());
}

#[test]
fn boot_and_audit_run_unchanged_over_an_slcan_adapter() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../manager/tests/data");
    let adapter = Adapter::start_with(5, &format!("{data}/valve.dcf"));
    let iface = adapter.iface();
    let dir = std::env::temp_dir().join(format!("canopen-slcan-boot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let toml = dir.join("one.toml");
    std::fs::write(
        &toml,
        format!(
            "[master]\nnode_id = 1\nsdo_timeout_ms = 500\nboot_timeout_ms = 2000\n\n\
             [[slave]]\nnode_id = 5\ndcf = \"{data}/valve.dcf\"\nmandatory = true\n"
        ),
    )
    .unwrap();
    let toml = toml.to_str().unwrap();
    // CiA 302-2 boot: configuration from the DCF written by SDO, then NMT start.
    let o = canopen(&["--iface", &iface, "boot", toml]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    // NMT start, of the node or of all nodes (the master starts all when every slave booted).
    assert!(
        adapter.saw("t00020100") || adapter.saw("t00020105"),
        "{:?}",
        adapter.lines()
    );
    // The audit finds the device as its DCF describes it.
    let o = canopen(&["--iface", &iface, "audit", toml]);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
}

#[test]
fn a_silent_serial_device_is_not_taken_for_an_empty_bus() {
    // A pty nobody answers on: no acknowledgement, no frame, ever.
    let pty = nix::pty::openpty(None, None).expect("openpty");
    let path = nix::unistd::ttyname(pty.slave.as_fd())
        .expect("ttyname")
        .to_string_lossy()
        .into_owned();
    let iface = format!("slcan:{path}@500k");
    for args in [vec!["scan"], vec!["nmt", "state", "--listen", "0.3"]] {
        let mut all = vec!["--iface", iface.as_str()];
        all.extend(args.iter().copied());
        let o = canopen(&all);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("the adapter acknowledged no command and no frame arrived"),
            "{args:?}: {err}"
        );
        assert!(err.contains("\nhint: "), "{err}");
        assert!(!stdout(&o).contains("node"), "{}", stdout(&o));
    }
    // Under --json, one object with the hint apart.
    let o = canopen(&["--json", "--iface", &iface, "scan"]);
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).unwrap();
    assert!(v["hint"].as_str().unwrap().contains("CANable"), "{v}");
    drop(pty);
}
