//! The link against the Linux kernel's own slcan driver (`drivers/net/can/slcan`), an
//! implementation this crate did not write: a pseudo-terminal pair, can-utils' `slcand` attaches
//! the kernel's N_SLCAN line discipline to the slave side and names the interface `slcan0`; the
//! link runs on the master side. Frames go both ways and are checked with can-utils' `cansend`
//! and `candump` on `slcan0`. Then the pty is dropped (slcand ended, the slave closed): the link
//! reports the adapter vanished; on a new pty with the driver attached again, traffic flows.
//!
//! Needs CAP_NET_ADMIN, the `slcan` module and can-utils: run by `tests/vcan/run-all
//! 'rust-slcan-kernel'` in the QEMU guest, where these are present; `cargo test` lists it as
//! ignored.

#![cfg(all(target_os = "linux", feature = "serial"))]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use canola_frame::{CanFrame, CanId};
use canola_slcan::{Frame, Incoming, Link, LinkConfig, LinkError};
use serialport::{SerialPort, TTYPort};

const IFACE: &str = "slcan0";

/// A child process killed (by its own id) when the test ends, however it ends.
struct Reaped(Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn run(cmd: &str, args: &[&str]) {
    let status = Command::new(cmd)
        .args(args)
        .status()
        .unwrap_or_else(|e| panic!("{cmd}: {e}"));
    assert!(status.success(), "{cmd} {args:?}: {status}");
}

/// The next frame from the link, skipping nothing.
fn recv(link: &mut Link) -> Incoming {
    let until = Instant::now() + Duration::from_secs(20);
    while Instant::now() < until {
        if let Some(i) = link.recv(Duration::from_millis(200)).unwrap() {
            return i;
        }
    }
    panic!("the link received nothing from the kernel driver");
}

fn frame(i: Incoming) -> Frame {
    match i {
        Incoming::Frame(rx) => {
            // The kernel driver sends no timestamps.
            assert_eq!(rx.timestamp, None);
            rx.frame
        }
        other => panic!("{other:?}"),
    }
}

/// A pty pair with the kernel driver on its slave as `slcan0` (up), and the link on its master.
struct Attached {
    link: Link,
    slcand: Reaped,
    slave: TTYPort,
}

fn attach() -> Attached {
    let (master, slave) = TTYPort::pair().expect("pty pair");
    let slave_path = slave.name().expect("slave name");
    // slcand: C, S6 and O written to the slave in N_TTY mode (the link's end reads them as stray
    // lines), then TIOCSETD N_SLCAN and the rename to slcan0; -F keeps it in the foreground,
    // holding the slave open for the life of the interface.
    let slcand = Reaped(
        Command::new("slcand")
            .args(["-o", "-c", "-s6", "-F", &slave_path, IFACE])
            .spawn()
            .expect("slcand (can-utils)"),
    );
    let until = Instant::now() + Duration::from_secs(20);
    while !iface_exists() {
        assert!(Instant::now() < until, "slcand did not create {IFACE}");
        thread::sleep(Duration::from_millis(50));
    }
    // No bit rate configured on the netdev: the kernel writes nothing on `up`.
    run("ip", &["link", "set", IFACE, "up"]);
    // The kernel never answers commands: the link finds that out from the first C.
    let mut config = LinkConfig::new(slave_path);
    config.reply_timeout = Duration::from_millis(500);
    let link = Link::with_port(config, Box::new(master)).expect("link on the pty master");
    assert!(!link.acknowledges());
    Attached {
        link,
        slcand,
        slave,
    }
}

fn iface_exists() -> bool {
    Path::new("/sys/class/net").join(IFACE).exists()
}

/// `cansend` on slcan0 makes the driver write frame lines; the link decodes each.
fn kernel_to_link(link: &mut Link, cases: &[(&str, CanFrame)]) {
    for (text, want) in cases {
        run("cansend", &[IFACE, text]);
        assert_eq!(frame(recv(link)), Frame::Classic(*want), "{text}");
    }
}

/// The link's frames as `candump -L slcan0` shows them, in order.
fn link_to_kernel(link: &mut Link, sent: &[CanFrame]) -> Vec<String> {
    let mut candump = Reaped(
        Command::new("candump")
            .args(["-L", IFACE])
            .stdout(Stdio::piped())
            .spawn()
            .expect("candump (can-utils)"),
    );
    let (tx, lines) = mpsc::channel();
    let out = candump.0.stdout.take().unwrap();
    thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            // "(1700000000.123456) slcan0 123#1122": keep "123#1122".
            let Some(frame) = line.split_whitespace().nth(2) else {
                continue;
            };
            if tx.send(frame.to_string()).is_err() {
                break;
            }
        }
    });
    // candump prints nothing until it has a frame: send a probe until it shows, so the frames
    // below cannot go out before candump's socket is bound.
    let probe = CanFrame::new(CanId::standard(0x7AB).unwrap(), &[0xAB]).unwrap();
    let until = Instant::now() + Duration::from_secs(30);
    loop {
        assert!(Instant::now() < until, "candump never showed the probe");
        link.send(&probe.into()).unwrap();
        if let Ok(l) = lines.recv_timeout(Duration::from_millis(500)) {
            assert_eq!(l, "7AB#AB");
            break;
        }
    }
    for f in sent {
        link.send(&(*f).into()).unwrap();
    }
    let mut seen = Vec::new();
    while seen.len() < sent.len() {
        let l = lines
            .recv_timeout(Duration::from_secs(20))
            .expect("candump line");
        // Late copies of the probe may still come.
        if l != "7AB#AB" {
            seen.push(l);
        }
    }
    seen
}

#[test]
#[ignore = "needs the kernel's slcan driver, can-utils and CAP_NET_ADMIN: run by tests/vcan/run-all"]
fn kernel_slcan_driver_on_the_other_end_of_a_pty() {
    let sid = |raw| CanId::standard(raw).unwrap();
    let eid = |raw| CanId::extended(raw).unwrap();
    let mut a = attach();
    kernel_to_link(
        &mut a.link,
        &[
            (
                "123#1122",
                CanFrame::new(sid(0x123), &[0x11, 0x22]).unwrap(),
            ),
            (
                "12ABCDEF#0102030405060708",
                CanFrame::new(eid(0x12AB_CDEF), &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap(),
            ),
            ("7FF#R", CanFrame::remote(sid(0x7FF), 0).unwrap()),
            ("080#", CanFrame::new(sid(0x080), &[]).unwrap()),
        ],
    );
    let seen = link_to_kernel(
        &mut a.link,
        &[
            CanFrame::new(sid(0x456), &[0x11, 0x22, 0x33]).unwrap(),
            CanFrame::new(eid(0x1FFF_FFFF), &[0xDE, 0xAD, 0xBE, 0xEF, 0, 1, 2, 3]).unwrap(),
            CanFrame::remote(sid(0x123), 0).unwrap(),
            CanFrame::new(sid(0x000), &[]).unwrap(),
        ],
    );
    assert_eq!(
        seen,
        ["456#112233", "1FFFFFFF#DEADBEEF00010203", "123#R", "000#"]
    );
    // The kernel's lines all decoded.
    assert_eq!(a.link.stats().bad_lines, 0);

    // The pty dropped: this test's slave descriptor closed and slcand killed. The link on the
    // master sees the hang-up as a vanished adapter and closes the master. The line discipline
    // belongs to the pty pair: only when both sides are closed does the driver detach and
    // slcan0 disappear.
    run("ip", &["link", "set", IFACE, "down"]);
    let Attached {
        mut link,
        slcand,
        slave,
    } = a;
    drop(slave);
    drop(slcand);
    let until = Instant::now() + Duration::from_secs(20);
    let err = loop {
        match link.recv(Duration::from_millis(200)) {
            Ok(None) => assert!(Instant::now() < until, "no hang-up seen"),
            Ok(Some(i)) => panic!("{i:?}"),
            Err(e) => break e,
        }
    };
    assert!(matches!(err, LinkError::Vanished { .. }), "{err}");
    assert!(!link.is_open());
    while iface_exists() {
        assert!(
            Instant::now() < until,
            "{IFACE} stayed after both sides of the pty closed"
        );
        thread::sleep(Duration::from_millis(50));
    }
    assert!(matches!(
        link.send(&CanFrame::new(sid(1), &[]).unwrap().into()),
        Err(LinkError::Closed)
    ));

    // A new pty, the driver attached again: traffic flows both ways.
    let mut b = attach();
    kernel_to_link(
        &mut b.link,
        &[(
            "321#CAFE",
            CanFrame::new(sid(0x321), &[0xCA, 0xFE]).unwrap(),
        )],
    );
    let seen = link_to_kernel(
        &mut b.link,
        &[CanFrame::new(sid(0x654), &[0xBE, 0xEF]).unwrap()],
    );
    assert_eq!(seen, ["654#BEEF"]);
    run("ip", &["link", "set", IFACE, "down"]);
}
