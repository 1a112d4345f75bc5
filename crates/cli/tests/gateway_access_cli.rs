//! `canopen gateway` access options as a binary: refusing a non-loopback listen address without
//! `--allow-remote` and a token or allow-list; a token from a file or the environment; the
//! audit log file; Unix socket permissions.

use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");
const TOKEN: &str = "cli-write-token-3f2a9c81d07e4b56";

struct Gateway(Child);

impl Drop for Gateway {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("canopen-gwa-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn command(extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_canopen"));
    c.args(["--eds", &format!("4={EDS}"), "gateway"])
        .args(extra)
        .env_remove("CANOPEN_GATEWAY_TOKEN")
        .env_remove("CANOPEN_GATEWAY_READ_TOKEN");
    c
}

/// Starts the gateway; returns it and the address it printed.
fn start(mut c: Command) -> (Gateway, String) {
    let mut child = c
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    let addr = line
        .trim()
        .strip_prefix("canopen gateway: listening on ")
        .unwrap_or_else(|| panic!("unexpected stderr: {line:?}"))
        .to_owned();
    // Keep draining standard error (audit lines) so that the gateway never blocks on it.
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    (Gateway(child), addr)
}

fn ask(s: &mut (std::net::TcpStream, BufReader<std::net::TcpStream>), req: &str) -> String {
    s.0.write_all(req.as_bytes()).unwrap();
    let mut l = String::new();
    s.1.read_line(&mut l).unwrap();
    l
}

fn connect(port: u16) -> (std::net::TcpStream, BufReader<std::net::TcpStream>) {
    let s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
        .unwrap();
    (s.try_clone().unwrap(), BufReader::new(s))
}

#[test]
fn refuses_a_remote_address_without_allow_remote_and_a_guard() {
    let out = command(&["--listen", "tcp:0.0.0.0:0"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("refusing to listen on tcp:0.0.0.0:0"), "{err}");
    assert!(err.contains("--allow-remote"), "{err}");
    let out = command(&["--listen", "tcp:0.0.0.0:0", "--allow-remote"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no token and no --allow"), "{err}");
    // A token on the command line is no option at all.
    let out = command(&[
        "--listen",
        "tcp:0.0.0.0:0",
        "--allow-remote",
        "--token",
        TOKEN,
    ])
    .output()
    .unwrap();
    assert!(!out.status.success());
    // Loopback needs nothing.
    let (_gw, addr) = start(command(&["--listen", "tcp:127.0.0.1:0"]));
    assert!(addr.starts_with("tcp:127.0.0.1:"), "{addr}");
}

#[test]
fn a_remote_gateway_with_a_token_file_asks_for_it_and_audits() {
    let d = dir("token");
    let token_file = d.join("token");
    std::fs::write(&token_file, format!("{TOKEN}\n")).unwrap();
    let audit = d.join("audit.log");
    let (_gw, addr) = start(command(&[
        "--listen",
        "tcp:0.0.0.0:0",
        "--allow-remote",
        "--token-file",
        token_file.to_str().unwrap(),
        "--audit-log",
        audit.to_str().unwrap(),
    ]));
    let port: u16 = addr.rsplit(':').next().unwrap().parse().unwrap();
    let mut none = connect(port);
    assert_eq!(
        ask(&mut none, "[1] 4 w 0x1017 0 u16 100\n"),
        "[1] ERROR:102\r\n"
    );
    let mut rest = String::new();
    assert_eq!(none.1.read_to_string(&mut rest).unwrap_or(0), 0, "closed");
    let mut ok = connect(port);
    assert_eq!(ask(&mut ok, &format!("[1] auth {TOKEN}\n")), "[1] OK\r\n");
    assert_eq!(ask(&mut ok, "[2] 4 w 0x1017 0 u16 100\n"), "[2] OK\r\n");
    assert_eq!(ask(&mut ok, "[3] 4 r 0x1017 0 u16\n"), "[3] 100\r\n");
    let log = std::fs::read_to_string(&audit).unwrap();
    assert_eq!(log.lines().count(), 1, "{log}");
    assert!(
        log.trim_end()
            .ends_with("[2] 4 w 0x1017 0 u16 100 -> [2] OK"),
        "{log}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_token_from_the_environment_and_read_only() {
    let (_gw, addr) = start({
        let mut c = command(&["--listen", "tcp:0.0.0.0:0", "--allow-remote", "--read-only"]);
        c.env("CANOPEN_GATEWAY_TOKEN", TOKEN);
        c
    });
    let port: u16 = addr.rsplit(':').next().unwrap().parse().unwrap();
    let mut c = connect(port);
    assert_eq!(ask(&mut c, &format!("auth {TOKEN}\n")), "OK\r\n");
    assert_eq!(ask(&mut c, "[1] 4 r 0x1017 0 u16\n"), "[1] 500\r\n");
    assert_eq!(ask(&mut c, "[2] 4 stop\n"), "[2] ERROR:100\r\n");
}

#[test]
fn unix_sockets_are_owner_only_unless_shared() {
    let d = dir("unix");
    for (mode_arg, want) in [(None, 0o600), (Some("660"), 0o660)] {
        let path = d.join(format!("gw-{want:o}.sock"));
        let spec = format!("unix:{}", path.display());
        let mut args = vec!["--listen", spec.as_str()];
        if let Some(m) = mode_arg {
            args.extend(["--socket-mode", m]);
        }
        let (_gw, addr) = start(command(&args));
        assert_eq!(addr, spec);
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, want, "{mode:o}");
        let mut s = std::os::unix::net::UnixStream::connect(&path).unwrap();
        s.write_all(b"[1] 4 r 0x1017 0 u16\n").unwrap();
        s.shutdown(std::net::Shutdown::Write).unwrap();
        let mut text = String::new();
        s.read_to_string(&mut text).unwrap();
        assert_eq!(text, "[1] 500\r\n");
    }
    // Nothing of the private directory is left.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
    let _ = std::fs::remove_dir_all(&d);
}
