//! CAN FD frames between this stack's UDP bus and python-can's `udp_multicast` interface (the
//! independent peer, `tests/py/fd_peer.py`): python-can decodes the FD frame this transport
//! sends (`is_fd`, `bitrate_switch`, `error_state_indicator`, 48 data bytes), and this transport
//! decodes the FD frame python-can sends (20 bytes with the bit-rate switch).
//!
//! Runs with `$CANOPEN_PYTHON` or `<workspace>/.venv/bin/python` (python-can and msgpack
//! importable); without them the test prints that it skipped, unless
//! `CANOPEN_REQUIRE_PYTHON=1`.

use std::io::{BufRead, BufReader};
use std::net::{Ipv4Addr, SocketAddrV4};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration as StdDuration;

use canola::frame::{CanId, FdFlags, FdFrame};
use canola::udp::UdpMulticast;
use canola::{BusEvent, Received, Transport};

const PEER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/py/fd_peer.py");

fn python() -> Option<String> {
    let python = std::env::var("CANOPEN_PYTHON").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python").to_string()
    });
    let ok = Command::new(&python)
        .args(["-c", "import can, msgpack"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        return Some(python);
    }
    assert!(
        std::env::var("CANOPEN_REQUIRE_PYTHON").is_err(),
        "CANOPEN_REQUIRE_PYTHON is set but {python} cannot import can and msgpack"
    );
    eprintln!("skipped: {python} cannot import can and msgpack");
    None
}

fn expect(lines: &mpsc::Receiver<String>, prefix: &str, secs: u64) -> String {
    let end = std::time::Instant::now() + StdDuration::from_secs(secs);
    while let Some(left) = end.checked_duration_since(std::time::Instant::now()) {
        match lines.recv_timeout(left) {
            Ok(line) if line.starts_with(prefix) => return line,
            Ok(line) if line.starts_with("TIMEOUT") => break,
            Ok(_) => {}
            Err(_) => break,
        }
    }
    panic!("the python peer did not print {prefix:?} within {secs} s");
}

#[test]
fn fd_frames_with_python_can() {
    let Some(python) = python() else {
        return;
    };
    let port = 40000 + ((std::process::id() + 3) % 10000) as u16;
    let group = SocketAddrV4::new(Ipv4Addr::new(239, 74, 163, 41), port);
    let mut bus = UdpMulticast::open(group).expect("UDP multicast bus");
    assert!(bus.fd_support().is_ok());
    let mut peer = Command::new(python)
        .args([PEER, &group.ip().to_string(), &port.to_string()])
        .stdout(Stdio::piped())
        .spawn()
        .expect("python starts");
    let (tx, lines) = mpsc::channel();
    let stdout = peer.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    expect(&lines, "READY", 20);

    let data: Vec<u8> = (0..48u8).map(|i| i.wrapping_mul(5)).collect();
    let ours = FdFrame::new(CanId::standard(0x123).unwrap(), &data)
        .unwrap()
        .with_flags(FdFlags::BRS);
    bus.send_fd(&ours).unwrap();
    let got = expect(&lines, "GOT", 10);
    let hex: String = data.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(got, format!("GOT 123 1 1 0 {hex}"));

    let theirs = expect(&lines, "SENT", 10);
    assert_eq!(theirs, "SENT");
    let end = std::time::Instant::now() + StdDuration::from_secs(10);
    let frame = loop {
        assert!(
            std::time::Instant::now() < end,
            "python-can's FD frame never arrived"
        );
        match bus
            .recv_timeout(canola::Duration::from_millis(500))
            .unwrap()
        {
            Some(Received::Event(BusEvent::FdFrame { frame, .. })) => break frame,
            _ => continue,
        }
    };
    let want: Vec<u8> = (0..20u8).collect();
    assert_eq!(frame.id(), CanId::standard(0x5A5).unwrap());
    assert!(frame.brs() && !frame.esi());
    assert_eq!(frame.data(), &want[..]);
    let _ = peer.wait();
}
