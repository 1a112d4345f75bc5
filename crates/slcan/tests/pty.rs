//! The serial link on a pseudo-terminal pair: the link opens the pty's slave side by path, as it
//! would a USB adapter's `/dev/ttyACM0`; on the master side a fake adapter answers.
//!
//! The fake adapter is written from the command table of the project's slcan notes, not from
//! this crate's codec: it splits on CR, matches command strings by hand and answers as two kinds
//! of firmware do. `Lawicel` (CAN232/CANUSB and the Nakakiyo CANable 2 firmware): CR for OK, BEL
//! for errors (including `C` while closed and any unknown command), `z`/`Z` after a frame,
//! `Vhhss`, `Nxxxx`, `Fxx`, `Z0`/`Z1`. `Canable` (the official CANable 2.0 firmware): no
//! reply to any command, a free-text `V` reply, no `N`, `F` or `Z`; `Y2`/`Y5` and CAN FD frame
//! lines.

#![cfg(all(unix, feature = "serial"))]

use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use canola_frame::{CanFrame, CanId, FdFrame};
use canola_slcan::{
    AckMode, DataBitrate, Frame, Incoming, LineError, Link, LinkConfig, LinkError, RxFrame,
    StatusFlags, Timestamp, TimestampMode,
};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Firmware {
    Lawicel,
    Canable,
}

enum ToFake {
    /// Bytes the adapter sends to the host.
    Emit(Vec<u8>),
    /// Unplug: close both ends of the pty.
    Vanish,
}

/// A fake adapter on the master side of a fresh pty pair.
struct Fake {
    path: PathBuf,
    to_fake: mpsc::Sender<ToFake>,
    /// Every command line the host sent, without its CR.
    lines: mpsc::Receiver<String>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Fake {
    fn start(firmware: Firmware) -> Self {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        let path = nix::unistd::ttyname(pty.slave.as_fd()).expect("ttyname");
        let (to_fake, from_test) = mpsc::channel();
        let (to_test, lines) = mpsc::channel();
        let thread =
            thread::spawn(move || run(firmware, pty.master, pty.slave, from_test, to_test));
        Self {
            path,
            to_fake,
            lines,
            thread: Some(thread),
        }
    }

    fn emit(&self, bytes: &[u8]) {
        self.to_fake.send(ToFake::Emit(bytes.to_vec())).unwrap();
    }

    fn vanish(mut self) {
        self.to_fake.send(ToFake::Vanish).unwrap();
        self.thread.take().unwrap().join().unwrap();
    }

    /// The next command line the host sent.
    fn line(&self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(5))
            .expect("the host sent a line")
    }

    fn lines(&self, n: usize) -> Vec<String> {
        (0..n).map(|_| self.line()).collect()
    }
}

impl Drop for Fake {
    fn drop(&mut self) {
        if let Some(t) = self.thread.take() {
            let _ = self.to_fake.send(ToFake::Vanish);
            let _ = t.join();
        }
    }
}

/// The fake adapter's loop: its state is only "channel open" and "timestamps on".
fn run(
    firmware: Firmware,
    master: OwnedFd,
    // Held so the master never reads EIO while the host has the slave closed.
    _slave: OwnedFd,
    from_test: mpsc::Receiver<ToFake>,
    to_test: mpsc::Sender<String>,
) {
    let lawicel = firmware == Firmware::Lawicel;
    let mut open = false;
    let mut pending = Vec::new();
    loop {
        loop {
            match from_test.try_recv() {
                Ok(ToFake::Emit(bytes)) => write_all(&master, &bytes),
                Ok(ToFake::Vanish) | Err(mpsc::TryRecvError::Disconnected) => return,
                Err(mpsc::TryRecvError::Empty) => break,
            }
        }
        let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
        if poll(&mut fds, PollTimeout::from(5u8)).unwrap_or(0) == 0 {
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
            let ok: &[u8] = if lawicel { b"\r" } else { b"" };
            let bel: &[u8] = if lawicel { b"\x07" } else { b"" };
            let reply: Vec<u8> = match line.as_str() {
                "" => Vec::new(),
                "O" | "L" if !open => {
                    open = true;
                    ok.to_vec()
                }
                "C" if open => {
                    open = false;
                    ok.to_vec()
                }
                "S0" | "S1" | "S2" | "S3" | "S4" | "S5" | "S6" | "S7" | "S8" if !open => {
                    ok.to_vec()
                }
                "Z0" | "Z1" if lawicel && !open => ok.to_vec(),
                // CANable 2.0: CAN FD data bit rates 2 and 5 Mbit/s, and FD frame lines.
                "Y2" | "Y5" if !lawicel && !open => ok.to_vec(),
                l if !lawicel && open && l.starts_with(['d', 'D', 'b', 'B']) => Vec::new(),
                "V" if lawicel => b"V1013\r".to_vec(),
                "V" => b"b6fe3a1 git@github.com:normaldotcom/canable2-fw.git\r".to_vec(),
                "N" if lawicel => b"NA1B2\r".to_vec(),
                "F" if lawicel => b"F24\r".to_vec(),
                l if open && (l.starts_with('t') || l.starts_with('r')) => {
                    if lawicel {
                        b"z\r".to_vec()
                    } else {
                        Vec::new()
                    }
                }
                l if open && (l.starts_with('T') || l.starts_with('R')) => {
                    if lawicel {
                        b"Z\r".to_vec()
                    } else {
                        Vec::new()
                    }
                }
                _ => bel.to_vec(),
            };
            write_all(&master, &reply);
            let _ = to_test.send(line);
        }
    }
}

fn write_all(fd: &OwnedFd, mut bytes: &[u8]) {
    while !bytes.is_empty() {
        match nix::unistd::write(fd, bytes) {
            Ok(n) => bytes = &bytes[n..],
            Err(nix::errno::Errno::EAGAIN | nix::errno::Errno::EINTR) => {}
            Err(e) => panic!("fake adapter write: {e}"),
        }
    }
}

fn sid(raw: u16) -> CanId {
    CanId::standard(raw).unwrap()
}

fn config(path: &Path, bitrate: u32) -> LinkConfig {
    let mut c = LinkConfig::from_spec(&format!("{}@{bitrate}", path.display())).unwrap();
    c.reply_timeout = Duration::from_millis(300);
    c
}

/// The next frame or event, skipping nothing; fails the test after a few seconds.
fn recv(link: &mut Link) -> Incoming {
    let until = Instant::now() + Duration::from_secs(5);
    while Instant::now() < until {
        if let Some(i) = link.recv(Duration::from_millis(100)).unwrap() {
            return i;
        }
    }
    panic!("nothing received");
}

fn rx(frame: impl Into<Frame>, timestamp: Option<Timestamp>) -> Incoming {
    Incoming::Frame(RxFrame {
        frame: frame.into(),
        timestamp,
        esi: None,
    })
}

#[test]
fn lawicel_adapter_open_frames_both_ways_and_queries() {
    let fake = Fake::start(Firmware::Lawicel);
    let mut cfg = config(&fake.path, 500_000);
    cfg.timestamps = Some(TimestampMode::Millis);
    let mut link = Link::open(cfg).expect("open");
    // C answered BEL (closed already), S6, Z1 and O answered CR.
    assert_eq!(fake.lines(4), ["C", "S6", "Z1", "O"]);
    assert!(link.acknowledges());

    let frames: [Frame; 3] = [
        CanFrame::new(sid(0x123), &[0x11, 0x22]).unwrap().into(),
        CanFrame::new(CanId::extended(0x1234).unwrap(), &[0xAA, 0x55])
            .unwrap()
            .into(),
        CanFrame::remote(sid(0x7FF), 8).unwrap().into(),
    ];
    for f in &frames {
        link.send(f).unwrap();
    }
    assert_eq!(fake.lines(3), ["t12321122", "T000012342AA55", "r7FF8"]);

    // Adapter to host, after the z/Z acknowledgements of the three frames.
    fake.emit(b"t4563112233EA5F\rT12ABCDEF2AA550001\r");
    assert_eq!(
        recv(&mut link),
        rx(
            CanFrame::new(sid(0x456), &[0x11, 0x22, 0x33]).unwrap(),
            Some(Timestamp::Millis(59_999))
        )
    );
    assert_eq!(
        recv(&mut link),
        rx(
            CanFrame::new(CanId::extended(0x12AB_CDEF).unwrap(), &[0xAA, 0x55]).unwrap(),
            Some(Timestamp::Millis(1))
        )
    );
    let stats = link.stats();
    assert_eq!((stats.frames_tx, stats.frames_rx, stats.acks), (3, 2, 3));

    let info = link.info().unwrap();
    assert_eq!(info.version.as_deref(), Some("1013"));
    assert_eq!(info.hw_sw, Some((10, 13)));
    assert_eq!(info.serial.as_deref(), Some("A1B2"));
    assert_eq!(
        info.status,
        Some(StatusFlags(
            StatusFlags::ERROR_WARNING | StatusFlags::ERROR_PASSIVE
        ))
    );
    assert!(info.acknowledges);
    assert_eq!(fake.lines(3), ["V", "N", "F"]);

    link.close().unwrap();
    assert_eq!(fake.line(), "C");
    assert!(matches!(link.send(&frames[0]), Err(LinkError::Closed)));
}

#[test]
fn canable_adapter_without_acknowledgements() {
    let fake = Fake::start(Firmware::Canable);
    let mut link = Link::open(config(&fake.path, 250_000)).expect("open");
    assert_eq!(fake.lines(3), ["C", "S5", "O"]);
    assert!(!link.acknowledges());

    let f = CanFrame::new(sid(0x601), &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap();
    link.send(&f.into()).unwrap();
    assert_eq!(fake.line(), "t60184000100000000000");
    fake.emit(b"t58184300100009200000\r");
    assert_eq!(
        recv(&mut link),
        rx(
            CanFrame::new(
                sid(0x581),
                &[0x43, 0x00, 0x10, 0x00, 0x09, 0x20, 0x00, 0x00]
            )
            .unwrap(),
            None
        )
    );

    // The free-text version is kept; N and F get no answer at all.
    let info = link.info().unwrap();
    assert_eq!(
        info.version.as_deref(),
        Some("b6fe3a1 git@github.com:normaldotcom/canable2-fw.git")
    );
    assert_eq!((info.hw_sw, info.serial, info.status), (None, None, None));
    assert!(!info.acknowledges);
}

#[test]
fn ack_mode_always_fails_on_a_silent_adapter() {
    let fake = Fake::start(Firmware::Canable);
    let mut cfg = config(&fake.path, 500_000);
    cfg.ack = AckMode::Always;
    assert!(matches!(
        Link::open(cfg),
        Err(LinkError::NoReply { command: 'C' })
    ));
}

#[test]
fn bel_errors_and_bad_bytes() {
    let fake = Fake::start(Firmware::Lawicel);
    // The Lawicel fake knows no Y (CAN FD data bit rate): it answers BEL.
    let mut cfg = config(&fake.path, 1_000_000);
    cfg.data_bitrate = canola_slcan::DataBitrate::from_bps(2_000_000);
    assert!(matches!(
        Link::open(cfg),
        Err(LinkError::Refused { command: 'Y' })
    ));
    assert_eq!(fake.lines(3), ["C", "S8", "Y2"]);

    let mut link = Link::open(config(&fake.path, 1_000_000)).unwrap();
    assert_eq!(fake.lines(3), ["C", "S8", "O"]);
    // A BEL outside a command; garbage; a line too long; then a good frame.
    let mut noise = b"\x07t12\xff3\r".to_vec();
    noise.extend_from_slice(&[b'7'; 300]);
    noise.extend_from_slice(b"\rt0010\r");
    fake.emit(&noise);
    assert_eq!(recv(&mut link), Incoming::TxRefused);
    assert_eq!(recv(&mut link), Incoming::BadLine(LineError::BadByte(0xFF)));
    assert_eq!(recv(&mut link), Incoming::BadLine(LineError::TooLong));
    assert_eq!(
        recv(&mut link),
        rx(CanFrame::new(sid(1), &[]).unwrap(), None)
    );
    let stats = link.stats();
    assert_eq!((stats.bad_lines, stats.refused, stats.frames_rx), (2, 1, 1));
}

#[test]
fn vanished_adapter_is_an_error_and_reopen_works() {
    // A stable name for the adapter, re-pointed at each new pty, as udev keeps
    // /dev/serial/by-id/... for a USB adapter plugged in again.
    let dir = std::env::temp_dir().join(format!("canola-slcan-pty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link_path = dir.join("ttyCANABLE");
    let _ = std::fs::remove_file(&link_path);

    let fake = Fake::start(Firmware::Lawicel);
    std::os::unix::fs::symlink(&fake.path, &link_path).unwrap();
    let mut link = Link::open(config(&link_path, 125_000)).unwrap();
    assert_eq!(fake.lines(3), ["C", "S4", "O"]);
    fake.emit(b"t1001AB\r");
    assert_eq!(
        recv(&mut link),
        rx(CanFrame::new(sid(0x100), &[0xAB]).unwrap(), None)
    );

    fake.vanish();
    let err = loop {
        match link.recv(Duration::from_millis(100)) {
            Ok(None) => continue,
            Ok(Some(i)) => panic!("{i:?}"),
            Err(e) => break e,
        }
    };
    assert!(matches!(err, LinkError::Vanished { .. }), "{err}");
    assert!(!link.is_open());
    let f: Frame = CanFrame::new(sid(0x200), &[1]).unwrap().into();
    assert!(matches!(link.send(&f), Err(LinkError::Closed)));
    assert_eq!(link.stats().vanished, 1);

    // Not plugged in again yet: the path is dangling.
    std::fs::remove_file(&link_path).unwrap();
    assert!(matches!(link.reopen(), Err(LinkError::Open { .. })));

    let fake = Fake::start(Firmware::Lawicel);
    std::os::unix::fs::symlink(&fake.path, &link_path).unwrap();
    link.reopen().unwrap();
    assert_eq!(fake.lines(3), ["C", "S4", "O"]);
    link.send(&f).unwrap();
    assert_eq!(fake.line(), "t200101");
    fake.emit(b"t2001FE\r");
    assert_eq!(
        recv(&mut link),
        rx(CanFrame::new(sid(0x200), &[0xFE]).unwrap(), None)
    );
    drop(link);
    drop(fake);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_deadline_in_the_past_still_takes_what_has_arrived() {
    let fake = Fake::start(Firmware::Canable);
    let mut link = Link::open(config(&fake.path, 500_000)).unwrap();
    assert_eq!(fake.lines(3), ["C", "S6", "O"]);
    fake.emit(b"t1230\rt1231AA\r");
    let mut got = Vec::new();
    let until = Instant::now() + Duration::from_secs(5);
    while got.len() < 2 {
        assert!(Instant::now() < until, "got only {got:?}");
        match link.recv_until(Instant::now()).unwrap() {
            Some(i) => got.push(i),
            None => thread::sleep(Duration::from_millis(1)),
        }
    }
    assert_eq!(
        got,
        [
            rx(CanFrame::new(sid(0x123), &[]).unwrap(), None),
            rx(CanFrame::new(sid(0x123), &[0xAA]).unwrap(), None)
        ]
    );
    assert!(!link.has_pending());
}

#[test]
fn canable_fd_frames_and_data_bitrate() {
    let fake = Fake::start(Firmware::Canable);
    let mut cfg = config(&fake.path, 500_000);
    cfg.data_bitrate = DataBitrate::from_bps(2_000_000);
    let mut link = Link::open(cfg).unwrap();
    assert_eq!(fake.lines(4), ["C", "S6", "Y2", "O"]);

    let data: Vec<u8> = (0..64).collect();
    let f = FdFrame::new(CanId::extended(0x01AB_CDEF).unwrap(), &data)
        .unwrap()
        .with_brs(true);
    link.send(&f.into()).unwrap();
    let hex: String = data.iter().map(|b| format!("{b:02X}")).collect();
    assert_eq!(fake.line(), format!("B01ABCDEFF{hex}"));

    // Nakakiyo's example line: standard id 0x200, DLC 9 = 12 bytes, no BRS.
    fake.emit(b"d200900112233445566778899AABB\r");
    let twelve = [
        0x00, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xAA, 0xBB,
    ];
    assert_eq!(
        recv(&mut link),
        rx(FdFrame::new(sid(0x200), &twelve).unwrap(), None)
    );
}
