//! Every command line that README.md shows, run as written against simulated devices in other
//! processes on a UDP bus of the test's own: `--iface can0`, `vcan0` and `udp` stand for that
//! bus, `dev.eds` for the Bürkert EDS, the gateway's port for a free one; everything else is
//! the README's text. Where the README shows the output (`$ canopen ...` in a console block),
//! the output must be the README's (`...` there stands for any lines); where a comment says
//! what a line prints, the test checks that.
//!
//! [`every_readme_line_is_run`] fails when the README gains a command line no test here runs.

use std::collections::BTreeSet;
use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

mod common;
use common::{stderr, stdout};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// A command of the README: the line as written (tokens joined by one space) and the output
/// that follows it in a console block.
#[derive(Debug, Clone)]
struct ReadmeCommand {
    line: String,
    /// The line as the README writes it (quotes kept), comment and `&` cut.
    text: String,
    output: Vec<String>,
}

/// Splits a shell line into words (double and single quotes, `#` comments); `None` for an
/// unterminated quote.
fn words(line: &str) -> Option<Vec<String>> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '#' if !in_word => break,
            ' ' | '\t' => {
                if in_word {
                    out.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            '"' | '\'' => {
                in_word = true;
                loop {
                    match chars.next()? {
                        q if q == c => break,
                        x => cur.push(x),
                    }
                }
            }
            x => {
                in_word = true;
                cur.push(x);
            }
        }
    }
    if in_word {
        out.push(cur);
    }
    Some(out)
}

/// The README's command lines: every line of a `sh` block, and the `$ ` lines of `console`
/// and `text` blocks with the output lines after them; `\` continuations joined, comments and
/// a trailing `&` dropped.
fn readme_commands() -> Vec<ReadmeCommand> {
    let text = std::fs::read_to_string(format!("{ROOT}/README.md")).unwrap();
    let mut out: Vec<ReadmeCommand> = Vec::new();
    let mut block: Option<String> = None;
    let mut pending = String::new();
    let mut in_output = false;
    for raw in text.lines() {
        let line = raw.trim_start();
        if let Some(lang) = line.strip_prefix("```") {
            block = match block {
                Some(_) => None,
                None => Some(lang.to_string()),
            };
            in_output = false;
            continue;
        }
        let Some(lang) = block.as_deref() else {
            continue;
        };
        let command = match lang {
            "sh" => Some(line),
            "console" | "text" => line.strip_prefix("$ "),
            _ => None,
        };
        let continued = !pending.is_empty();
        let body = match (continued, command) {
            (true, _) => line,
            (false, Some(c)) => c,
            (false, None) => {
                if in_output && let Some(last) = out.last_mut() {
                    last.output.push(raw.to_string());
                }
                continue;
            }
        };
        match body.strip_suffix('\\') {
            Some(head) => {
                pending.push_str(head);
                pending.push(' ');
            }
            None => {
                pending.push_str(body);
                let text = std::mem::take(&mut pending);
                let mut w = words(&text).unwrap();
                if w.last().is_some_and(|l| l == "&") {
                    w.pop();
                }
                if w.is_empty() {
                    continue;
                }
                in_output = lang != "sh";
                // The text without its comment and `&`: the words, quoted where they must be.
                let text = w
                    .iter()
                    .map(|x| {
                        if x.contains(' ') {
                            format!("\"{x}\"")
                        } else {
                            x.clone()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join(" ");
                out.push(ReadmeCommand {
                    line: w.join(" "),
                    text,
                    output: Vec::new(),
                });
            }
        }
    }
    out
}

/// The README command whose line is `line`; fails when the README does not show it.
fn readme(line: &str) -> ReadmeCommand {
    readme_commands()
        .into_iter()
        .find(|c| c.line == line)
        .unwrap_or_else(|| panic!("README.md shows no command line `{line}`"))
}

/// A directory to run the README's lines in: `eds`, `crates` and `tests` of the checkout,
/// `dev.eds` the Bürkert EDS.
fn workdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-readme-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for d in ["eds", "crates", "tests"] {
        std::os::unix::fs::symlink(Path::new(ROOT).join(d), dir.join(d)).unwrap();
    }
    std::fs::copy(
        format!("{ROOT}/eds/burkert-generic.eds"),
        dir.join("dev.eds"),
    )
    .unwrap();
    dir
}

/// The README line as a command: `canopen` (or `cargo run ... --`) is the binary under test,
/// the interface the test's `bus`, a gateway port `port`.
fn command(line: &str, dir: &Path, bus: &str, port: u16) -> Command {
    let w = words(line).unwrap();
    let args: Vec<String> = match w.iter().position(|a| a == "--") {
        Some(i) if w[0] == "cargo" => w[i + 1..].to_vec(),
        _ => {
            assert_eq!(w[0], "canopen", "{line}");
            w[1..].to_vec()
        }
    };
    let mut out = Vec::new();
    let mut it = args.into_iter().peekable();
    while let Some(a) = it.next() {
        if a == "--iface" {
            let iface = it.next().unwrap();
            assert!(
                ["can0", "vcan0", "udp"].contains(&iface.as_str()),
                "{iface}"
            );
            out.push(a);
            out.push(bus.to_string());
            continue;
        }
        let a = a
            .replace("tcp:0.0.0.0:6000", &format!("tcp:0.0.0.0:{port}"))
            .replace("tcp:6000", &format!("tcp:{port}"));
        out.push(a);
    }
    let mut c = Command::new(env!("CARGO_BIN_EXE_canopen"));
    c.args(out).current_dir(dir);
    c
}

fn run(line: &str, dir: &Path, bus: &str) -> Output {
    command(line, dir, bus, 0).output().unwrap()
}

fn ok(line: &str, dir: &Path, bus: &str) -> String {
    let o = run(line, dir, bus);
    assert!(o.status.success(), "`{line}`: {}", stderr(&o));
    stdout(&o)
}

/// `actual` against the README's output lines, where `...` stands for any lines.
fn matches_readme(expected: &[String], actual: &str) -> bool {
    fn go(e: &[String], a: &[&str]) -> bool {
        match e.split_first() {
            None => a.is_empty(),
            Some((first, rest)) if first.trim() == "..." => {
                (0..=a.len()).any(|k| go(rest, &a[k..]))
            }
            Some((first, rest)) => a.first() == Some(&first.as_str()) && go(rest, &a[1..]),
        }
    }
    let lines: Vec<&str> = actual.lines().collect();
    go(expected, &lines)
}

/// A background process, killed when dropped.
struct Background(Child);

impl Drop for Background {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The README line as a process running beside the test, its output dropped, killed at the end.
fn background(line: &str, dir: &Path, bus: &str) -> Background {
    Background(
        command(line, dir, bus, 0)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    )
}

/// Waits until node `node` answers an SDO read of 0x1000 on `bus`.
fn wait_for_node(bus: &str, node: &str) {
    for _ in 0..50 {
        if common::canopen(&["--iface", bus, "sdo", "read", node, "0x1000"])
            .status
            .success()
        {
            return;
        }
    }
    panic!("node {node} never answered on {bus}");
}

/// A device with a signed 64-bit object 0x2120:01, node 4 of the README's `sdo write` lines.
const SIGNED_EDS: &str = "[FileInfo]\nFileName=signed.eds\nFileVersion=1\nEDSVersion=4.0\n\
[DeviceInfo]\nVendorName=test\nProductName=signed\nVendorNumber=0x39\nProductNumber=1\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1001]\nParameterName=Error register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\nPDOMapping=0\n\
[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[1018sub1]\nParameterName=Vendor-ID\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x39\nPDOMapping=0\n\
[OptionalObjects]\nSupportedObjects=0\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2120\n\
[2120]\nParameterName=Offset\nObjectType=0x9\nSubNumber=2\n\
[2120sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\nPDOMapping=0\n\
[2120sub1]\nParameterName=Signed offset\nObjectType=0x7\nDataType=0x0015\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n";

/// Reads a child's stdout in a thread of its own (a full pipe would block the child), handing
/// it all back when the child has ended.
fn drain(child: &mut Child) -> std::thread::JoinHandle<String> {
    let mut out = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    })
}

/// Sends SIGINT (Ctrl-C) to a background process and waits for it.
fn ctrl_c(child: &mut Child) -> std::process::ExitStatus {
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    child.wait().unwrap()
}

const ON_A_BUS: &[&str] = &[
    "canopen --iface can0 sdo read 5 0x1017",
    "canopen --iface can0 --hex sdo read 5 0x1018 1",
    "canopen --iface can0 --eds 5=dev.eds sdo read 5 Producer heartbeat time",
    "canopen --iface can0 --eds 5=dev.eds sdo read 5 Identity object/Serial number",
    "canopen --iface can0 sdo write 4 0x2120 1 -42 --type i64",
    "canopen --iface can0 sdo write 4 0x2120 1 -- -0x10 -t i64",
    "canopen --iface can0 sdo upload 5 0x1008 -o name.bin",
    "canopen --iface can0 scan",
    "canopen --iface can0 monitor 705:7FF,080~7FF",
    "canopen --iface can0 record -o bus.log",
    "canopen --iface can0 replay bus.log",
];

/// "The `canopen` command on a bus".
#[test]
fn the_command_on_a_bus() {
    let bus = common::udp_bus(0);
    let dir = workdir("bus");
    let l: Vec<String> = ON_A_BUS.iter().map(|l| readme(l).text).collect();
    std::fs::write(dir.join("signed.eds"), SIGNED_EDS).unwrap();
    let _node5 = Background(common::simulator(&bus, EDS, "5", "60"));
    let _node4 = Background(common::simulator(
        &bus,
        dir.join("signed.eds").to_str().unwrap(),
        "4",
        "60",
    ));

    // "prints 500"; "0x00000039 (default decimal: 57)".
    assert_eq!(ok(&l[0], &dir, &bus), "500\n");
    assert_eq!(ok(&l[1], &dir, &bus), "0x00000039\n");
    assert_eq!(ok(&l[2], &dir, &bus), "500\n");
    let serial = ok(&l[3], &dir, &bus);
    assert!(serial.trim().parse::<u32>().is_ok(), "{serial}");
    // The writes, each read back.
    let back = |dir: &Path| {
        ok(
            "canopen --iface can0 sdo read 4 0x2120 1 --type i64",
            dir,
            &bus,
        )
    };
    ok(&l[4], &dir, &bus);
    assert_eq!(back(&dir), "-42\n");
    ok(&l[5], &dir, &bus);
    assert_eq!(back(&dir), "-16\n");
    ok(&l[6], &dir, &bus);
    assert_eq!(
        std::fs::read(dir.join("name.bin")).unwrap(),
        b"Buerkert generic device"
    );
    // "identity in decimal": node 4 and 5 with vendor-ID 57.
    let scan = ok(&l[7], &dir, &bus);
    for node in ["4", "5"] {
        assert!(
            scan.lines()
                .any(|x| x.split_whitespace().take(2).eq([node, "57"])),
            "{scan}"
        );
    }

    // monitor and record run until Ctrl-C; node 5's heartbeat (0x705 every 500 ms) passes
    // the filters, and is recorded; the log replays.
    let mut monitor = command(&l[8], &dir, &bus, 0)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let shown = drain(&mut monitor);
    let mut record = command(&l[9], &dir, &bus, 0)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut rec_err = BufReader::new(record.stderr.take().unwrap()).lines();
    assert!(rec_err.next().unwrap().unwrap().starts_with("recording"));
    std::thread::sleep(Duration::from_millis(1300));
    assert!(ctrl_c(&mut monitor).success());
    let shown = shown.join().unwrap();
    assert!(shown.contains("705"), "{shown}");
    assert!(ctrl_c(&mut record).success());
    let log = std::fs::read_to_string(dir.join("bus.log")).unwrap();
    assert!(log.contains(" 705#"), "{log}");
    ok(&l[10], &dir, &bus);
}

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

/// The two terminals of the UDP bus.
#[test]
fn two_terminals_on_the_udp_bus() {
    let bus = common::udp_bus(1);
    let dir = workdir("udp");
    let sim = readme("canopen --iface udp simulate eds/burkert-generic.eds --node-id 5");
    let read = readme("canopen --iface udp sdo read 5 0x1008");
    let _sim = background(&sim.text, &dir, &bus);
    wait_for_node(&bus, "5");
    assert_eq!(ok(&read.text, &dir, &bus), "Buerkert generic device\n");
}

const USDO: &[&str] = &[
    "canopen --iface vcan0 --fd simulate eds/burkert-generic.eds --node-id 5",
    "canopen --iface vcan0 --fd usdo read 5 0x1008",
    "canopen --iface vcan0 --fd usdo write 5 0x1017 0 750",
    "canopen --iface vcan0 --fd usdo upload 5 0x2003 4 -o logbook.xml",
];

/// "CANopen FD: USDO": the FD device in another process, USDO over the UDP bus's CAN FD frames.
#[test]
fn usdo_lines() {
    // A group and port of its own (the eight of `udp_bus` are taken by the tests above).
    let bus = format!("udp:239.74.163.30:{}", 20000 + std::process::id() % 9000);
    let dir = workdir("usdo");
    let l: Vec<String> = USDO.iter().map(|l| readme(l).text).collect();
    let _sim = background(&l[0], &dir, &bus);
    wait_for_node(&bus, "5");
    assert_eq!(ok(&l[1], &dir, &bus), "Buerkert generic device\n");
    ok(&l[2], &dir, &bus);
    // The logbook, a DOMAIN, into a file.
    ok(&l[3], &dir, &bus);
    let xml = std::fs::read_to_string(dir.join("logbook.xml")).unwrap();
    assert!(xml.starts_with("<?xml"), "{xml}");
    // What the write put there, read back by USDO.
    let o = common::canopen(&["--iface", &bus, "--fd", "usdo", "read", "5", "0x1017"]);
    assert_eq!(stdout(&o), "750\n", "{}", stderr(&o));
}

const LSS: &[&str] = &[
    "canopen --iface vcan0 lss --unconfigured 2 --real-slaves simulate",
    "canopen --iface can0 lss --step-timeout 60 discover-all",
    "canopen --iface can0 lss assign-all --first 2 --last 127",
    "canopen --iface can0 lss configure-node-id 5",
    "canopen lss --unconfigured 3 --record-bus lss.log assign-all",
];

/// "LSS commissioning from the command line".
#[test]
fn lss_commissioning() {
    let bus = common::udp_bus(2);
    let dir = workdir("lss");
    let l: Vec<String> = LSS.iter().map(|l| readme(l).text).collect();
    let slaves = background(&l[0], &dir, &bus);
    std::thread::sleep(Duration::from_millis(500));
    let found = ok(&l[1], &dir, &bus);
    assert_eq!(
        found
            .lines()
            .filter(|l| l.starts_with("found vendor-id 57"))
            .count(),
        2,
        "{found}"
    );
    let assigned = ok(&l[2], &dir, &bus);
    // Each slave its node-ID from the pool, in order ("Fastscan, configure, store, one by one").
    let ids: Vec<&str> = assigned
        .lines()
        .filter_map(|l| l.rsplit_once("node-ID ").map(|(_, id)| id.trim()))
        .collect();
    assert_eq!(ids, ["2", "3"], "{assigned}");
    drop(slaves);
    // "the one slave on the bus".
    let _one = background(
        "canopen --iface can0 lss --unconfigured 1 --real-slaves simulate",
        &dir,
        &bus,
    );
    std::thread::sleep(Duration::from_millis(500));
    ok(&l[3], &dir, &bus);
    // In memory, the bus kept as a candump log.
    let o = command(&l[4], &dir, "", 0).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::read_to_string(dir.join("lss.log"))
            .unwrap()
            .contains("7E5#")
    );
}

/// The gateway with a token, reached from "another machine" (here: this one), and the
/// documented session against two simulated devices.
#[test]
fn the_gateway() {
    let bus = common::udp_bus(3);
    let dir = workdir("gateway");
    let port = free_port();
    let token_line = readme("(umask 077; head -c 24 /dev/urandom | base64 > gateway.token)");
    let st = Command::new("sh")
        .args(["-c", &token_line.line])
        .current_dir(&dir)
        .status()
        .unwrap();
    assert!(st.success());
    let token = std::fs::read_to_string(dir.join("gateway.token")).unwrap();
    let remote = readme(
        "canopen --iface can0 gateway --listen tcp:0.0.0.0:6000 --allow-remote --token-file gateway.token --audit-log gateway-audit.log",
    );
    let mut gw = command(&remote.text, &dir, &bus, port)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(gw.stderr.take().unwrap()).lines();
    let _gw = Background(gw);
    let listening = err.next().unwrap().unwrap();
    assert!(listening.contains("listening"), "{listening}");
    let nc = readme("nc plant-pc 6000");
    assert_eq!(nc.output, ["[1] auth <the token>", "[1] OK"]);
    let mut c = Conn::new(port);
    c.send(&format!("[1] auth {}\n", token.trim()));
    assert_eq!(c.line(), "[1] OK");

    // The session: requests are the README's lines of the nc session, replies its replies.
    let session = readme(
        "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/burkert-generic.eds gateway --listen tcp:6000",
    );
    let port = free_port();
    let mut gw = command(&session.text, &dir, "", port)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(gw.stderr.take().unwrap()).lines();
    let _gw2 = Background(gw);
    let first = err.next().unwrap().unwrap();
    assert_eq!(
        first,
        session.output[0].replace("6000", &port.to_string()),
        "the README's line after the command"
    );
    let nc = readme("nc 127.0.0.1 6000");
    let mut c = Conn::new(port);
    // A line starting with `[n]` while no request waits is a request; the next `[n]` line its
    // reply; lines without a sequence number are events, read as they come.
    let seq = |l: &str| l.split(']').next().unwrap_or_default().to_string();
    let mut waiting: Option<String> = None;
    for line in &nc.output {
        if line.starts_with('[') && waiting.is_none() {
            c.send(&format!("{line}\r\n"));
            waiting = Some(seq(line));
            continue;
        }
        assert_eq!(&c.line(), line, "README: {line}");
        if line.starts_with('[') {
            assert_eq!(waiting.take(), Some(seq(line)));
        }
    }
    assert!(waiting.is_none());
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A TCP client of the gateway, line by line (replies end in CR LF).
struct Conn {
    stream: std::net::TcpStream,
    reader: BufReader<std::net::TcpStream>,
}

impl Conn {
    fn new(port: u16) -> Self {
        for _ in 0..100 {
            if let Ok(stream) = std::net::TcpStream::connect(("127.0.0.1", port)) {
                stream
                    .set_read_timeout(Some(Duration::from_secs(10)))
                    .unwrap();
                let reader = BufReader::new(stream.try_clone().unwrap());
                return Self { stream, reader };
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("the gateway never listened on {port}");
    }
    fn send(&mut self, text: &str) {
        self.stream.write_all(text.as_bytes()).unwrap();
    }
    fn line(&mut self) -> String {
        let mut l = String::new();
        self.reader.read_line(&mut l).unwrap();
        l.trim_end_matches(['\r', '\n']).to_string()
    }
}

const CPOS: &[&str] = &[
    "canopen --iface vcan0 cpos --mac 63 simulate",
    "canopen --iface can0 cpos --mac 63 get Mode",
    "canopen --iface can0 cpos --mac 63 set Mode manual",
    "canopen --iface can0 cpos --mac 63 action init-valve",
    "canopen --iface can0 cpos --mac 63 errors",
    "canopen --iface can0 monitor --devicenet",
];

/// "A GEMÜ 1436 cPos over DeviceNet".
#[test]
fn a_cpos_over_devicenet() {
    let bus = common::udp_bus(4);
    let dir = workdir("cpos");
    let l: Vec<String> = CPOS.iter().map(|l| readme(l).text).collect();
    let _sim = background(&l[0], &dir, &bus);
    std::thread::sleep(Duration::from_millis(500));
    let mut monitor = command(&l[5], &dir, &bus, 0)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let shown = drain(&mut monitor);
    let mode = ok(&l[1], &dir, &bus);
    assert!(!mode.trim().is_empty());
    ok(&l[2], &dir, &bus);
    assert!(ok(&l[1], &dir, &bus).to_lowercase().contains("manual"));
    ok(&l[3], &dir, &bus);
    ok(&l[4], &dir, &bus);
    assert!(ctrl_c(&mut monitor).success());
    assert!(!shown.join().unwrap().is_empty());
}

/// "Boot a network": the boot in memory, the audit against devices in other processes, each
/// output as the README shows it.
#[test]
fn boot_and_audit() {
    let dir = workdir("boot");
    let boot = readme("canopen boot crates/manager/tests/data/three.toml --absent 6");
    let o = command(&boot.text, &dir, "", 0).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "a mandatory slave is absent");
    assert!(
        matches_readme(&boot.output, &stdout(&o)),
        "README:\n{}\nactual:\n{}",
        boot.output.join("\n"),
        stdout(&o)
    );

    let bus = common::udp_bus(5);
    let data = format!("{ROOT}/crates/manager/tests/data");
    let toml = std::fs::read_to_string(format!("{data}/three.toml")).unwrap();
    let mut sims = Vec::new();
    for (node, file) in nodes_of(&toml) {
        let path = format!("{data}/{file}");
        sims.push(Background(common::simulator(&bus, &path, &node, "120")));
    }
    let audits: Vec<ReadmeCommand> = readme_commands()
        .into_iter()
        .filter(|c| c.line.contains(" audit "))
        .collect();
    assert_eq!(audits.len(), 3);
    for (a, status) in audits.iter().zip([1, 0, 0]) {
        let o = command(&a.text, &dir, &bus, 0).output().unwrap();
        assert_eq!(o.status.code(), Some(status), "{}: {}", a.line, stderr(&o));
        assert!(
            matches_readme(&a.output, &stdout(&o)),
            "{}\nREADME:\n{}\nactual:\n{}",
            a.line,
            a.output.join("\n"),
            stdout(&o)
        );
    }
}

/// The `node_id` and `dcf`/`eds` file of each `[[slave]]` of a bus description.
fn nodes_of(toml: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut node = None;
    for line in toml.lines() {
        let mut kv = line.splitn(2, '=').map(str::trim);
        match (kv.next(), kv.next()) {
            (Some("node_id"), Some(v)) => node = Some(v.to_string()),
            (Some("dcf" | "eds"), Some(v)) => {
                if let Some(n) = node.take() {
                    out.push((n, v.trim_matches('"').to_string()));
                }
            }
            _ => {}
        }
    }
    out
}

/// The two commands of the README's start.
#[test]
fn the_demo_runs() {
    let dir = workdir("demo");
    let demo = readme("cargo run -q -p canola-cli -- demo");
    ok(&demo.text, &dir, "");
}

/// Lines the tests above do not run, and why.
/// "CiA 402 drives": one process on the in-memory bus, then the drive in `simulate` and the
/// commands in other processes on the UDP bus.
const DRIVE: &[&str] = &[
    "canopen --eds 5=eds/cia402-servo.eds drive 5 move 4000 --enable --velocity 20000",
    "canopen --iface udp simulate eds/cia402-servo.eds --node-id 5",
    "canopen --iface udp drive 5 mode pp",
    "canopen --iface udp drive 5 enable",
    "canopen --iface udp drive 5 move 4000",
    "canopen --iface udp drive 5 move -1500 --relative",
    "canopen --iface udp --json drive 5 status",
    "canopen --iface udp drive 5 home 19",
    "canopen --iface udp drive 5 quick-stop",
];

#[test]
fn a_drive() {
    let bus = common::udp_bus(6);
    let dir = workdir("drive");
    let l: Vec<String> = DRIVE.iter().map(|l| readme(l).text).collect();
    let moved = ok(&l[0], &dir, &bus);
    assert!(moved.contains("target reached at position 4000"), "{moved}");
    let _drive = background(&l[1], &dir, &bus);
    wait_for_node(&bus, "5");
    // Each line's comment says what it prints.
    let expect = [
        (2, "mode: pp (1)"),
        (3, "operation enabled"),
        (4, "target reached at position 4000"),
        (5, "target reached at position 2500"),
        (7, "homing completed at position 0"),
        (8, "switch on disabled"),
    ];
    for (i, want) in expect {
        if i == 7 {
            let status = ok(&l[6], &dir, &bus);
            assert!(
                status.trim_start().starts_with('{') && status.contains("operation"),
                "{status}"
            );
        }
        let out = ok(&l[i], &dir, &bus);
        assert!(
            out.contains(want),
            "`{}` printed {out:?}, not {want:?}",
            l[i]
        );
    }
}

/// "NMT from the command line", against nodes 5 and 6 (heartbeat 500 ms) on the UDP bus.
const NMT: &[&str] = &[
    "canopen --iface can0 nmt start 5 --wait",
    "canopen --iface can0 nmt reset 5,6 --wait",
    "canopen --iface can0 nmt state",
];

#[test]
fn nmt_from_the_command_line() {
    let bus = common::udp_bus(7);
    let dir = workdir("nmt");
    let l: Vec<String> = NMT.iter().map(|l| readme(l).text).collect();
    let _node5 = Background(common::simulator(&bus, EDS, "5", "60"));
    let _node6 = Background(common::simulator(&bus, EDS, "6", "60"));
    ok(&l[0], &dir, &bus);
    ok(&l[1], &dir, &bus);
    // After the reset both boot again and go on with their heartbeats; `nmt state` lists both.
    let state = ok(&l[2], &dir, &bus);
    for node in ["5", "6"] {
        assert!(
            state
                .lines()
                .any(|x| x.split_whitespace().next() == Some(node)),
            "{state}"
        );
    }
}

/// `--running 5,6` on the in-memory bus: the pool 4..=10 gives the three slaves 4, 7 and 8.
#[test]
fn assign_all_leaves_running_nodes_alone() {
    let dir = workdir("lss-running");
    let line = readme(
        "canopen lss --unconfigured 3 --real-slaves --running 5,6 assign-all --first 4 --last 10",
    )
    .text;
    let out = ok(&line, &dir, "unused");
    let ids: Vec<&str> = out
        .lines()
        .filter_map(|l| l.rsplit_once("node-ID ").map(|(_, id)| id.trim()))
        .collect();
    for id in ["4", "7", "8"] {
        assert!(ids.contains(&id), "{out}");
    }
    assert!(!ids.contains(&"5") && !ids.contains(&"6"), "{out}");
}

const PDO: &[&str] = &[
    "canopen --iface can0 --eds 5=dev.eds pdo 5 show",
    "canopen --iface can0 nmt preop 5",
    "canopen --iface can0 --eds 5=dev.eds pdo 5 map tpdo 1 0x2500:01 0x2004:01 --event-timer 1000",
    "canopen --iface can0 nmt start 5",
    "canopen --iface vcan0 --fd simulate tests/vcan/fd-device.eds --node-id 7",
    "canopen --iface vcan0 --fd --eds 7=tests/vcan/fd-device.eds pdo 7 map tpdo 1 0x2101:00 0x2100:01 0x2100:02",
    "canopen --iface vcan0 --fd --eds 7=tests/vcan/fd-device.eds pdo 7 show tpdo 1",
    "canopen --iface vcan0 --fd --eds 5=eds/burkert-generic.eds pdo 5 map tpdo 1 0x2500:01 0x2501:01 0x2502:01",
];

/// `canopen pdo`: a Bürkert device (node 5) remapped in pre-operational, the CANopen FD device
/// (node 7) given a TPDO of 96 bits and shown as the README shows it, and the same 96 bits
/// refused on the Bürkert device with the README's error.
#[test]
fn pdo_lines() {
    // A group and port of their own (as `usdo_lines`).
    let bus = format!("udp:239.74.163.31:{}", 20000 + std::process::id() % 9000);
    let dir = workdir("pdo");
    let c: Vec<ReadmeCommand> = PDO.iter().map(|l| readme(l)).collect();
    let _node5 = Background(common::simulator(&bus, EDS, "5", "60"));
    let _node7 = background(&c[4].text, &dir, &bus);
    wait_for_node(&bus, "7");

    let shown = ok(&c[0].text, &dir, &bus);
    assert!(shown.starts_with("RPDO1 (0x1400, 0x1600): "), "{shown}");
    assert!(shown.contains("\nTPDO4 (0x1803, 0x1A03): "), "{shown}");
    ok(&c[1].text, &dir, &bus);
    let o = run(&c[2].text, &dir, &bus);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        "node 5: TPDO1 mapped and valid with 2 object(s), 40 bits (5 bytes)\n"
    );
    ok(&c[3].text, &dir, &bus);

    let o = run(&c[5].text, &dir, &bus);
    assert!(o.status.success(), "{}", stderr(&o));
    let shown = ok(&c[6].text, &dir, &bus);
    assert!(matches_readme(&c[6].output, &shown), "{shown}");

    // The error, exit 1: the README's lines are its stderr.
    let o = run(&c[7].text, &dir, &bus);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(matches_readme(&c[7].output, &stderr(&o)), "{}", stderr(&o));
}

const NOT_RUN: &[(&str, &str)] = &[
    (
        "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/cia402-servo.eds top",
        "draws on a terminal: top_tmux.rs types this line in tmux and reads the screen",
    ),
    (
        "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/cia402-servo.eds top --replay bus.log",
        "draws on a terminal: top_tmux.rs saves bus.log with `s` and types this line in tmux",
    ),
    (
        "canopen --iface can0 --eds 5=dev.eds top --bitrate 250k",
        "needs a CAN interface and a terminal; top_tmux.rs runs the view on the in-memory bus",
    ),
    (
        "./scripts/test-all",
        "the whole test run, of which this test is a part",
    ),
    (
        "python3 -m venv .venv && .venv/bin/pip install maturin",
        "the python stage of scripts/test-all makes this venv and installs maturin into it",
    ),
    (
        "VIRTUAL_ENV=$PWD/.venv .venv/bin/maturin develop --release -m crates/python/Cargo.toml",
        "the python stage of scripts/test-all runs `maturin develop` (a debug build, to share \
         the tests' target dir) and then the package's pytest suite",
    ),
    (
        "canopen --iface slcan:/dev/ttyACM0@500k scan",
        "needs a USB slcan adapter; the same commands run through a fake adapter on a \
         pseudo-terminal in slcan_cli.rs, and against the kernel's slcan driver in the rig",
    ),
    (
        "canopen --iface slcan:/dev/ttyACM0 adapter info",
        "needs a USB slcan adapter; slcan_cli.rs runs `adapter info` against fake adapters",
    ),
];

#[test]
fn every_readme_line_is_run() {
    let run: BTreeSet<&str> = ON_A_BUS
        .iter()
        .chain(LSS)
        .chain(CPOS)
        .chain(DRIVE)
        .chain(NMT)
        .chain(USDO)
        .chain(PDO)
        .copied()
        .chain([
            "canopen --iface udp simulate eds/burkert-generic.eds --node-id 5",
            "canopen --iface udp sdo read 5 0x1008",
            "(umask 077; head -c 24 /dev/urandom | base64 > gateway.token)",
            "canopen --iface can0 gateway --listen tcp:0.0.0.0:6000 --allow-remote --token-file gateway.token --audit-log gateway-audit.log",
            "nc plant-pc 6000",
            "canopen --eds 5=eds/burkert-generic.eds --eds 6=eds/burkert-generic.eds gateway --listen tcp:6000",
            "nc 127.0.0.1 6000",
            "canopen boot crates/manager/tests/data/three.toml --absent 6",
            "canopen --iface udp audit crates/manager/tests/data/three.toml",
            "canopen --iface udp audit --fix crates/manager/tests/data/three.toml",
            "cargo run -q -p canola-cli -- demo",
            "canopen lss --unconfigured 3 --real-slaves --running 5,6 assign-all --first 4 --last 10",
        ])
        .chain(NOT_RUN.iter().map(|(l, _)| *l))
        .collect();
    let missing: Vec<String> = readme_commands()
        .into_iter()
        .map(|c| c.line)
        .filter(|l| !run.contains(l.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "README command lines no test runs: {missing:#?}"
    );
}
