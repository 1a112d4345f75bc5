//! The slcan transport on a pseudo-terminal pair: the transport opens the pty's slave side by
//! path (a symlink, as udev's `/dev/serial/by-id` names are), and a fake Lawicel-style adapter
//! on the master side, written by hand from the slcan command table, answers every command with
//! CR and sends what the test tells it to. Checks what the transport makes of frames, bad
//! bytes and BEL, and that a vanished adapter is an event and an error and comes back when the
//! path works again.

use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;
use std::sync::mpsc;
use std::thread;

use canola::slcan::{LinkConfig, Slcan};
use canola::{BusEvent, CanFrame, CanId, Duration, Received, Transport, TransportError};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

enum ToFake {
    Emit(Vec<u8>),
    Vanish,
}

struct Fake {
    slave: PathBuf,
    to_fake: mpsc::Sender<ToFake>,
    lines: mpsc::Receiver<String>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Fake {
    fn start() -> Self {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        let slave = nix::unistd::ttyname(pty.slave.as_fd()).expect("ttyname");
        let (to_fake, rx) = mpsc::channel();
        let (tx, lines) = mpsc::channel();
        let thread = thread::spawn(move || run(pty.master, pty.slave, rx, tx));
        Self {
            slave,
            to_fake,
            lines,
            thread: Some(thread),
        }
    }

    fn emit(&self, b: &[u8]) {
        self.to_fake.send(ToFake::Emit(b.to_vec())).unwrap();
    }

    fn vanish(mut self) {
        self.to_fake.send(ToFake::Vanish).unwrap();
        self.thread.take().unwrap().join().unwrap();
    }

    /// The next line the host sent that starts with one of `kinds`.
    fn line_of(&self, kinds: &[char]) -> String {
        loop {
            let l = self
                .lines
                .recv_timeout(std::time::Duration::from_secs(5))
                .expect("the host sent a line");
            if l.starts_with(kinds) {
                return l;
            }
        }
    }

    /// The next line the host sent that is a frame.
    fn frame_line(&self) -> String {
        loop {
            let l = self
                .lines
                .recv_timeout(std::time::Duration::from_secs(5))
                .expect("the host sent a line");
            if l.starts_with('t') || l.starts_with('T') {
                return l;
            }
        }
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

fn run(master: OwnedFd, _slave: OwnedFd, rx: mpsc::Receiver<ToFake>, tx: mpsc::Sender<String>) {
    let mut pending = Vec::new();
    loop {
        loop {
            match rx.try_recv() {
                Ok(ToFake::Emit(b)) => {
                    nix::unistd::write(&master, &b).unwrap();
                }
                Ok(ToFake::Vanish) | Err(mpsc::TryRecvError::Disconnected) => return,
                Err(mpsc::TryRecvError::Empty) => break,
            }
        }
        let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
        if poll(&mut fds, PollTimeout::from(5u8)).unwrap_or(0) == 0 {
            continue;
        }
        let mut buf = [0u8; 256];
        let Ok(n) = nix::unistd::read(&master, &mut buf) else {
            continue;
        };
        pending.extend_from_slice(&buf[..n]);
        while let Some(cr) = pending.iter().position(|&b| b == b'\r') {
            let line: Vec<u8> = pending.drain(..=cr).take(cr).collect();
            let line = String::from_utf8_lossy(&line).into_owned();
            // Lawicel: CR after every command, `z` after a frame.
            let reply: &[u8] = if line.starts_with(['t', 'b', 'd']) {
                b"z\r"
            } else {
                b"\r"
            };
            let _ = tx.send(line);
            nix::unistd::write(&master, reply).unwrap();
        }
    }
}

fn next(t: &mut Slcan) -> Received {
    let deadline = t.now() + Duration::from_secs(3);
    t.recv_until(deadline)
        .expect("receive works")
        .expect("something arrived")
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(CanId::standard(id).unwrap(), data).unwrap()
}

#[test]
fn frames_bad_bytes_refusals_and_a_vanished_adapter_that_comes_back() {
    let dir = std::env::temp_dir().join(format!("canola-slcan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("adapter");
    let _ = std::fs::remove_file(&link);

    let fake = Fake::start();
    std::os::unix::fs::symlink(&fake.slave, &link).unwrap();
    let mut t = Slcan::open(LinkConfig::from_spec(&format!("{}@250k", link.display())).unwrap())
        .expect("opens");
    let stats = t.stats();
    assert!(t.link().acknowledges());

    // Frames both ways.
    t.send(&frame(0x701, &[0x05])).unwrap();
    assert_eq!(fake.frame_line(), "t701105");
    fake.emit(b"t1232AABB\r");
    match next(&mut t) {
        Received::Frame { frame: f, .. } => assert_eq!(f, frame(0x123, &[0xAA, 0xBB])),
        other => panic!("{other:?}"),
    }

    // Bytes that are not slcan: an event with the count, and the next line still decodes.
    fake.emit(b"t12ZQ\rt1230\r");
    match next(&mut t) {
        Received::Event(BusEvent::BadInput { total, detail }) => {
            assert_eq!(total, 1);
            assert!(!detail.is_empty());
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(next(&mut t), Received::Frame { .. }));
    assert_eq!(stats.bad_input(), 1);
    // BEL outside a command: the adapter refused a frame.
    fake.emit(b"\x07");
    assert_eq!(next(&mut t), Received::Event(BusEvent::TxRefused));
    assert_eq!(stats.refused(), 1);

    // Unplugged: one event, then sends fail with the reason kept.
    fake.vanish();
    assert_eq!(next(&mut t), Received::Event(BusEvent::InterfaceDown));
    assert!(matches!(
        t.send(&frame(0x701, &[0x05])),
        Err(TransportError::InterfaceDown)
    ));
    assert!(
        t.last_error().unwrap().contains("vanished"),
        "{:?}",
        t.last_error()
    );
    assert_eq!(stats.vanished(), 1);
    // Nothing while it is gone; receiving keeps trying the path.
    let deadline = t.now() + Duration::from_millis(300);
    assert_eq!(t.recv_until(deadline).unwrap(), None);

    // Plugged in again (a new pty behind the same name): the transport reopens by itself.
    let fake = Fake::start();
    std::fs::remove_file(&link).unwrap();
    std::os::unix::fs::symlink(&fake.slave, &link).unwrap();
    assert_eq!(next(&mut t), Received::Event(BusEvent::InterfaceUp));
    assert_eq!(stats.reopened(), 1);
    assert_eq!(t.last_error(), None);
    t.send(&frame(0x702, &[0x7F])).unwrap();
    assert_eq!(fake.frame_line(), "t70217F");
    fake.emit(b"t0000\r");
    assert!(matches!(next(&mut t), Received::Frame { .. }));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn can_fd_only_on_an_adapter_opened_with_a_data_bit_rate() {
    use canola::frame::{FdFlags, FdFrame};
    // Without a data bit rate: classic only, by name.
    let fake = Fake::start();
    let mut t =
        Slcan::open(LinkConfig::from_spec(&format!("{}@500k", fake.slave.display())).unwrap())
            .expect("opens");
    let fd = FdFrame::new(CanId::standard(0x123).unwrap(), &[0xAB; 12])
        .unwrap()
        .with_flags(FdFlags::BRS);
    let e = t.send_fd(&fd).unwrap_err();
    assert!(matches!(e, TransportError::FdNotSupported { .. }), "{e}");
    assert!(
        e.to_string().starts_with("FD not supported on slcan:"),
        "{e}"
    );
    assert!(t.fd_support().is_err());
    drop(t);
    drop(fake);

    // With a data bit rate (the `Y` command accepted): FD frames both ways.
    let fake = Fake::start();
    let mut config = LinkConfig::from_spec(&format!("{}@500k", fake.slave.display())).unwrap();
    config.data_bitrate = canola::slcan::DataBitrate::from_bps(2_000_000);
    let mut t = Slcan::open(config).expect("opens");
    assert!(t.fd_support().is_ok());
    t.send_fd(&fd).unwrap();
    // `b`: an FD frame with the bit-rate switch, DLC code 9 for 12 bytes.
    assert_eq!(
        fake.line_of(&['b', 'd']),
        format!("b1239{}", "AB".repeat(12))
    );
    fake.emit(format!("d4569{}\r", "01".repeat(12)).as_bytes());
    match next(&mut t) {
        Received::Event(BusEvent::FdFrame { frame, .. }) => {
            assert_eq!(frame.id(), CanId::standard(0x456).unwrap());
            assert_eq!(frame.data(), &[1u8; 12]);
            assert!(!frame.brs());
        }
        other => panic!("{other:?}"),
    }
}
