//! What SIGINT and SIGTERM leave behind, through the binary: `sdo upload -o FILE` interrupted
//! mid-transfer removes its temporary file; the gateway removes its Unix socket and exits 0;
//! at start it replaces a socket nobody listens on and refuses one that answers.

#![cfg(unix)]

use std::io::{BufRead as _, BufReader, Read as _};
use std::os::unix::process::ExitStatusExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

mod common;

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("canopen-signals-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn signal(child: &Child, s: Signal) {
    kill(Pid::from_raw(child.id() as i32), s).unwrap();
}

/// Waits up to `secs` for `f`.
fn until(secs: u64, mut f: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + Duration::from_secs(secs);
    while Instant::now() < end {
        if f() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    false
}

/// The files in `dir`.
fn files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn ctrl_c_during_sdo_upload_leaves_no_temporary_file() {
    let dir = scratch("upload");
    let out = dir.join("out.bin");
    // On a UDP bus of its own nobody answers: the upload waits for its SDO timeout, with the
    // temporary file open, long enough to be interrupted (tried again if the timeout won).
    for attempt in 0..5 {
        let iface = common::udp_bus(attempt % 8);
        let child = Command::new(env!("CARGO_BIN_EXE_canopen"))
            .args(["--iface", &iface, "sdo", "upload", "5", "0x1008", "-o"])
            .arg(&out)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let temp = dir.join(format!(".out.bin.{}.tmp", child.id()));
        assert!(until(10, || temp.exists()), "no temporary file {temp:?}");
        signal(&child, Signal::SIGINT);
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        if o.status.code() == Some(1) && err.contains("SDO timeout") {
            continue; // the transfer ended before the signal arrived
        }
        assert_eq!(o.status.code(), Some(130), "{err}");
        assert!(err.contains("interrupted by SIGINT"), "{err}");
        assert_eq!(files(&dir), Vec::<String>::new(), "left behind");
        std::fs::remove_dir_all(&dir).ok();
        return;
    }
    panic!("the upload never ran long enough to be interrupted");
}

/// Starts the gateway on `listen` with node 3 simulated; returns it once it listens, or its
/// output when it ended.
fn gateway(listen: &str) -> Result<(Child, BufReader<std::process::ChildStderr>), String> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["--eds", &format!("3={EDS}"), "gateway", "--listen", listen])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    if line.starts_with("canopen gateway: listening on ") {
        return Ok((child, err));
    }
    err.read_to_string(&mut line).unwrap();
    let status = child.wait().unwrap();
    Err(format!("{status}: {line}"))
}

#[test]
fn the_gateway_removes_its_socket_on_sigint_and_sigterm() {
    let dir = scratch("gateway");
    let path = dir.join("gw.sock");
    let spec = format!("unix:{}", path.display());
    for s in [Signal::SIGTERM, Signal::SIGINT] {
        let (mut child, mut err) = gateway(&spec).unwrap();
        assert!(path.exists());
        signal(&child, s);
        let status = child.wait().unwrap();
        let mut text = String::new();
        err.read_to_string(&mut text).unwrap();
        // Stopping a gateway is its normal end.
        assert_eq!(status.code(), Some(0), "{status:?} {text}");
        assert_eq!(status.signal(), None);
        assert!(
            text.contains(&format!("canopen gateway: stopped by {}", s.as_str())),
            "{text}"
        );
        assert!(!path.exists(), "the socket stayed after {s}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_stale_socket_is_replaced_and_a_live_one_refused() {
    let dir = scratch("stale");
    let path = dir.join("gw.sock");
    let spec = format!("unix:{}", path.display());
    // A socket file whose listener is gone, as a killed gateway leaves it.
    drop(std::os::unix::net::UnixListener::bind(&path).unwrap());
    assert!(path.exists());
    let (mut child, _err) = gateway(&spec).expect("the stale socket is replaced");
    let mut s = std::os::unix::net::UnixStream::connect(&path).unwrap();
    std::io::Write::write_all(&mut s, b"[1] 3 r 0x1017 0 u16\n").unwrap();
    s.shutdown(std::net::Shutdown::Write).unwrap();
    let mut answer = String::new();
    s.read_to_string(&mut answer).unwrap();
    assert_eq!(answer, "[1] 500\r\n");
    // A second gateway on the same path is refused while the first answers.
    let e = gateway(&spec).expect_err("a live socket is not replaced");
    assert!(e.starts_with("exit status: 1"), "{e}");
    assert!(e.contains("a program is listening on this socket"), "{e}");
    assert!(e.contains("hint: "), "{e}");
    assert!(path.exists(), "the live socket was removed");
    signal(&child, Signal::SIGTERM);
    child.wait().unwrap();
    // A path that is not a socket is left alone.
    std::fs::write(&path, b"data").unwrap();
    let e = gateway(&spec).expect_err("a file is not replaced");
    assert!(e.contains("is not a socket"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), b"data");
    std::fs::remove_dir_all(&dir).ok();
}
