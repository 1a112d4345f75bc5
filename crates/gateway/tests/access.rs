//! Access control over real TCP connections: tokens and roles, the allow-list, `read_only`,
//! the audit log; against simulated devices from the Bürkert EDS on the in-memory bus.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::time::Duration;

use canola_gateway::{Access, AuditLog, Config, Gateway, Token};
use common::{Client, gateway};

const WRITE: &str = "write-token-5d41402abc4b2a76b9719d911017c592";
const READ: &str = "read-token-7d793037a0760186574b0282f2f435e7";

fn tokens() -> Access {
    Access {
        write_token: Some(Token::new(WRITE).unwrap()),
        read_token: Some(Token::new(READ).unwrap()),
        ..Access::default()
    }
}

fn listen(gw: &Gateway) -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    gw.serve_tcp(listener);
    port
}

struct Tcp {
    w: TcpStream,
    r: BufReader<TcpStream>,
}

impl Tcp {
    fn connect(port: u16) -> Self {
        let s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        Self {
            w: s.try_clone().unwrap(),
            r: BufReader::new(s),
        }
    }

    fn ask(&mut self, req: &str) -> String {
        self.w.write_all(req.as_bytes()).unwrap();
        let mut l = String::new();
        self.r.read_line(&mut l).unwrap();
        l
    }

    /// Whether the gateway closed the connection (end of stream, or reset).
    fn closed(&mut self) -> bool {
        let mut rest = Vec::new();
        match self.r.read_to_end(&mut rest) {
            Ok(_) => rest.is_empty(),
            Err(e) => e.kind() == std::io::ErrorKind::ConnectionReset,
        }
    }
}

#[test]
fn a_client_without_the_token_gets_an_error_and_is_disconnected() {
    let (gw, _bus) = gateway(
        &[4],
        Config {
            access: tokens(),
            ..Config::default()
        },
    );
    let port = listen(&gw);
    let mut none = Tcp::connect(port);
    assert_eq!(none.ask("[1] 4 r 0x1017 0 u16\n"), "[1] ERROR:102\r\n");
    assert!(none.closed());
    let mut wrong = Tcp::connect(port);
    assert_eq!(
        wrong.ask("[1] auth write-token-5d41402abc4b2a76b9719d911017c593\n"),
        "[1] ERROR:102\r\n"
    );
    assert!(wrong.closed());
    assert_eq!(gw.access_counters().auth_failures, 2);
    // The right token opens the connection.
    let mut right = Tcp::connect(port);
    assert_eq!(right.ask(&format!("[1] auth {WRITE}\n")), "[1] OK\r\n");
    assert_eq!(right.ask("[2] 4 r 0x1017 0 u16\n"), "[2] 500\r\n");
    assert_eq!(
        right.ask(&format!("[3] auth {WRITE}\n")),
        "[3] ERROR:100\r\n"
    );
}

#[test]
fn the_read_token_cannot_write_and_the_write_token_can() {
    let (gw, _bus) = gateway(
        &[4],
        Config {
            access: tokens(),
            ..Config::default()
        },
    );
    let port = listen(&gw);
    let mut reader = Tcp::connect(port);
    assert_eq!(reader.ask(&format!("auth {READ}\n")), "OK\r\n");
    assert_eq!(reader.ask("[1] 4 r 0x1017 0 u16\n"), "[1] 500\r\n");
    for (i, req) in [
        "4 w 0x1017 0 u16 250",
        "4 stop",
        "0 reset node",
        "lss_switch_glob 1",
        "set node 4",
    ]
    .iter()
    .enumerate()
    {
        assert_eq!(
            reader.ask(&format!("[{}] {req}\n", i + 2)),
            format!("[{}] ERROR:100\r\n", i + 2),
            "{req}"
        );
    }
    assert_eq!(gw.access_counters().refused, 5);
    // Nothing changed: the node is not stopped (it still serves SDO) and 0x1017 is as before.
    assert_eq!(reader.ask("[9] 4 r 0x1017 0 u16\n"), "[9] 500\r\n");
    let mut writer = Tcp::connect(port);
    assert_eq!(writer.ask(&format!("auth {WRITE}\n")), "OK\r\n");
    assert_eq!(writer.ask("[1] 4 w 0x1017 0 u16 250\n"), "[1] OK\r\n");
    assert_eq!(reader.ask("[10] 4 r 0x1017 0 u16\n"), "[10] 250\r\n");
}

#[test]
fn clients_outside_the_allow_list_are_refused() {
    let (gw, _bus) = gateway(
        &[4],
        Config {
            access: Access {
                allow: vec!["10.1.2.0/24".parse().unwrap()],
                ..Access::default()
            },
            ..Config::default()
        },
    );
    let port = listen(&gw);
    let mut c = Tcp::connect(port);
    let mut l = String::new();
    c.r.read_line(&mut l).unwrap();
    assert_eq!(l, "ERROR:102\r\n");
    assert!(c.closed());
    assert_eq!(gw.access_counters().not_allowed, 1);
    // The loopback admitted: served.
    let (gw, _bus) = gateway(
        &[4],
        Config {
            access: Access {
                allow: vec!["127.0.0.0/8".parse().unwrap()],
                ..Access::default()
            },
            ..Config::default()
        },
    );
    let mut c = Tcp::connect(listen(&gw));
    assert_eq!(c.ask("[1] 4 r 0x1017 0 u16\n"), "[1] 500\r\n");
}

#[test]
fn the_audit_log_holds_each_change() {
    let dir = std::env::temp_dir().join(format!("canola-gw-audit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("audit.log");
    std::fs::write(&path, "kept from before\n").unwrap();
    let (gw, _bus) = gateway(
        &[4, 5],
        Config {
            access: tokens(),
            audit: Some(Arc::new(AuditLog::append_to(&path).unwrap())),
            ..Config::default()
        },
    );
    let port = listen(&gw);
    let mut w = Tcp::connect(port);
    let mut r = Tcp::connect(port);
    assert_eq!(w.ask(&format!("auth {WRITE}\n")), "OK\r\n");
    assert_eq!(r.ask(&format!("auth {READ}\n")), "OK\r\n");
    assert_eq!(w.ask("[1] 4 w 0x1017 0 u16 300\n"), "[1] OK\r\n");
    assert_eq!(w.ask("[2] 4 r 0x1017 0 u16\n"), "[2] 300\r\n");
    assert_eq!(w.ask("[3] 5 preop\n"), "[3] OK\r\n");
    assert_eq!(w.ask("[4] 0 start\n"), "[4] OK\r\n");
    // The Bürkert device has no 0x1010 (store): the failed attempt is logged with its reply.
    assert_eq!(
        w.ask("[5] 4 w 0x1010 1 vs save\n"),
        "[5] ERROR:0x06020000\r\n"
    );
    assert_eq!(r.ask("[6] 5 stop\n"), "[6] ERROR:100\r\n");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let peer_w = format!("tcp:{}", w.w.local_addr().unwrap());
    let peer_r = format!("tcp:{}", r.w.local_addr().unwrap());
    assert_eq!(lines.len(), 6, "{text}");
    assert_eq!(lines[0], "kept from before");
    let expect = [
        (&peer_w, "[1] 4 w 0x1017 0 u16 300 -> [1] OK"),
        (&peer_w, "[3] 5 preop -> [3] OK"),
        (&peer_w, "[4] 0 start -> [4] OK"),
        (&peer_w, "[5] 4 w 0x1010 1 vs save -> [5] ERROR:0x06020000"),
        (&peer_r, "[6] 5 stop -> [6] ERROR:100"),
    ];
    for (line, (peer, rest)) in lines[1..].iter().zip(expect) {
        // `<time> <client> <request> -> <reply>`
        let (time, tail) = line.split_once(' ').unwrap();
        assert!(time.ends_with('Z') && time.contains('T'), "{line}");
        assert_eq!(tail, format!("{peer} {rest}"));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn read_only_refuses_every_changing_command_with_100() {
    let (gw, _bus) = gateway(
        &[4],
        Config {
            access: Access {
                read_only: true,
                ..Access::default()
            },
            ..Config::default()
        },
    );
    let mut c = Client::connect(&gw);
    let changing = [
        "4 write 0x1017 0 u16 250",
        "4 w 0x1010 1 vs save",
        "4 start",
        "4 stop",
        "4 preop",
        "4 reset node",
        "4 reset communication",
        "0 stop",
        "0 reset node",
        "lss_switch_glob 1",
        "lss_switch_sel 1 2 3 4",
        "lss_set_node 5",
        "lss_conf_bitrate 0 2",
        "lss_activate_bitrate 100",
        "lss_store",
        "lss_inquire_addr 0",
        "lss_get_node",
        "_lss_fastscan 10",
        "lss_allnodes",
        "set network 1",
        "set node 4",
        "set sdo_timeout 100",
        "set sdo_block 1",
    ];
    for (i, req) in changing.iter().enumerate() {
        assert_eq!(
            c.ask(&format!("[{i}] {req}\n"), 1),
            format!("[{i}] ERROR:100\r\n"),
            "{req}"
        );
    }
    assert_eq!(gw.access_counters().refused, changing.len() as u64);
    // Reads and information still work, and nothing changed: the node still serves SDO.
    assert_eq!(c.ask("[100] 4 r 0x1017 0 u16\n", 1), "[100] 500\r\n");
    assert!(c.ask("[101] info version\n", 1).starts_with("[101] 0 0 "));
    assert_eq!(c.ask("[102] _events 1\n", 1), "[102] OK\r\n");
}
