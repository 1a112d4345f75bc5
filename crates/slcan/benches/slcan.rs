//! Frames per second and CPU time per frame of the slcan codec alone and of the serial link on a
//! pseudo-terminal pair, printed side by side (`cargo bench -p canola-slcan --bench slcan`).
//!
//! - codec: encode N frame lines into a buffer; decode the same byte stream in 4 KiB chunks.
//! - pty, host -> adapter: `Link::send` of N frames; a peer thread on the pty master reads and
//!   counts the lines. Timed until the peer has all of them.
//! - pty, adapter -> host: the peer writes N frame lines as fast as the pty takes them, in
//!   4 KiB writes (a USB adapter's bursts) or one line per write (as the kernel's slcan driver
//!   writes); `Link::recv` until all N frames are decoded.
//!
//! CPU is the calling thread's (CLOCK_THREAD_CPUTIME_ID): the link's own cost per frame,
//! without the peer's.

use std::hint::black_box;
use std::os::fd::{AsFd, OwnedFd};
use std::thread;
use std::time::{Duration, Instant};

use canola_frame::{CanFrame, CanId, FdFrame};
use canola_slcan::{
    AckMode, Command, Decoder, Frame, Incoming, Item, Link, LinkConfig, MAX_COMMAND,
};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
use nix::time::{ClockId, clock_gettime};

fn thread_cpu() -> Duration {
    let t = clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID).expect("thread CPU clock");
    Duration::new(t.tv_sec() as u64, t.tv_nsec() as u32)
}

fn frames(kind: &str, n: usize) -> Vec<Frame> {
    (0..n)
        .map(|i| {
            let b = (i as u64).to_le_bytes();
            match kind {
                "std8" => {
                    let id = CanId::standard((i % 0x800) as u16).unwrap();
                    CanFrame::new(id, &b).unwrap().into()
                }
                "ext8" => {
                    let id = CanId::extended((i as u32 * 7919) & 0x1FFF_FFFF).unwrap();
                    CanFrame::new(id, &b).unwrap().into()
                }
                _ => {
                    let id = CanId::standard((i % 0x800) as u16).unwrap();
                    let data: Vec<u8> = b.iter().cycle().take(64).copied().collect();
                    FdFrame::new(id, &data).unwrap().with_brs(true).into()
                }
            }
        })
        .collect()
}

fn encode_all(frames: &[Frame]) -> Vec<u8> {
    let mut out = Vec::with_capacity(frames.len() * 24);
    let mut buf = [0u8; MAX_COMMAND];
    for f in frames {
        let n = Command::Transmit(*f).encode(&mut buf).unwrap();
        out.extend_from_slice(&buf[..n]);
    }
    out
}

struct Row {
    what: String,
    frames: usize,
    wall: Duration,
    cpu: Duration,
}

impl Row {
    fn print(&self) {
        let n = self.frames as f64;
        println!(
            "{:<38} {:>9} {:>12.0} {:>12.1} {:>12.1}",
            self.what,
            self.frames,
            n / self.wall.as_secs_f64(),
            self.wall.as_nanos() as f64 / n,
            self.cpu.as_nanos() as f64 / n,
        );
    }
}

fn timed(what: String, frames: usize, f: impl FnOnce()) -> Row {
    let (t0, c0) = (Instant::now(), thread_cpu());
    f();
    Row {
        what,
        frames,
        wall: t0.elapsed(),
        cpu: thread_cpu() - c0,
    }
}

fn codec(kind: &str, n: usize) -> [Row; 2] {
    let fs = frames(kind, n);
    let mut out = vec![0u8; n * (MAX_COMMAND)];
    let enc = timed(format!("codec encode {kind}"), n, || {
        let mut at = 0;
        for f in &fs {
            at += Command::Transmit(*black_box(f))
                .encode(&mut out[at..])
                .unwrap();
        }
        black_box(at);
    });
    let stream = encode_all(&fs);
    let dec = timed(format!("codec decode {kind} (4 KiB chunks)"), n, || {
        let mut d = Decoder::new();
        let mut count = 0usize;
        for chunk in stream.chunks(4096) {
            for item in d.feed(black_box(chunk)) {
                if let Ok(Item::Frame(rx)) = item {
                    black_box(rx);
                    count += 1;
                }
            }
        }
        assert_eq!(count, n);
    });
    [enc, dec]
}

fn pty() -> (OwnedFd, String) {
    let pty = nix::pty::openpty(None, None).expect("openpty");
    let path = nix::unistd::ttyname(pty.slave.as_fd()).expect("ttyname");
    // The slave stays open in the caller only through the link; keep it alive by leaking it
    // into the peer thread along with the master.
    std::mem::forget(pty.slave);
    (pty.master, path.to_string_lossy().into_owned())
}

fn open_link(path: &str) -> Link {
    let mut cfg = LinkConfig::new(path);
    cfg.ack = AckMode::Never;
    Link::open(cfg).expect("open link on pty")
}

fn pty_tx(kind: &str, n: usize) -> Row {
    let (master, path) = pty();
    let fs = frames(kind, n);
    // C and O come first.
    let want = n + 2;
    let peer = thread::spawn(move || {
        let mut seen = 0usize;
        let mut buf = vec![0u8; 65536];
        while seen < want {
            let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
            if poll(&mut fds, PollTimeout::from(1000u16)).unwrap_or(0) == 0 {
                panic!("peer: no data");
            }
            let got = nix::unistd::read(&master, &mut buf).expect("peer read");
            seen += buf[..got].iter().filter(|&&b| b == b'\r').count();
        }
        master
    });
    let mut link = open_link(&path);
    let row = timed(format!("pty link send {kind}"), n, || {
        for f in &fs {
            link.send(f).unwrap();
        }
        let _master = peer.join().unwrap();
    });
    drop(link);
    row
}

/// `per_line`: the peer writes one line per system call, as the kernel's slcan driver does;
/// otherwise up to 4 KiB per call, as a USB CDC adapter delivers bursts.
fn pty_rx(kind: &str, n: usize, per_line: bool) -> Row {
    let (master, path) = pty();
    let stream = encode_all(&frames(kind, n));
    let line_len = stream.iter().position(|&b| b == b'\r').map_or(1, |i| i + 1);
    let chunk = if per_line { line_len } else { 4096 };
    let mut link = open_link(&path);
    let peer = thread::spawn(move || {
        let mut rest = &stream[..];
        while !rest.is_empty() {
            let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLOUT)];
            let _ = poll(&mut fds, PollTimeout::from(1000u16));
            match nix::unistd::write(&master, &rest[..rest.len().min(chunk)]) {
                Ok(w) => rest = &rest[w..],
                Err(nix::errno::Errno::EAGAIN | nix::errno::Errno::EINTR) => {}
                Err(e) => panic!("peer write: {e}"),
            }
        }
        master
    });
    let what = if per_line {
        format!("pty link recv {kind}, line per write")
    } else {
        format!("pty link recv {kind}")
    };
    let row = timed(what, n, || {
        let mut count = 0;
        while count < n {
            match link.recv(Duration::from_secs(2)).unwrap() {
                Some(Incoming::Frame(rx)) => {
                    black_box(rx);
                    count += 1;
                }
                Some(other) => panic!("{other:?}"),
                None => panic!("recv timed out after {count} frames"),
            }
        }
    });
    let _master = peer.join().unwrap();
    row
}

fn main() {
    // `cargo bench` passes `--bench`; a plain `cargo test --benches` run passes nothing and
    // gets a quick pass with few frames.
    let full = std::env::args().any(|a| a == "--bench");
    let (nc, np) = if full {
        (1_000_000, 200_000)
    } else {
        (2_000, 500)
    };
    println!(
        "{:<38} {:>9} {:>12} {:>12} {:>12}",
        "path", "frames", "frames/s", "wall ns/fr", "CPU ns/fr"
    );
    for kind in ["std8", "ext8", "fd64"] {
        for r in codec(kind, nc) {
            r.print();
        }
    }
    for kind in ["std8", "ext8", "fd64"] {
        pty_tx(kind, np).print();
        pty_rx(kind, np, false).print();
        pty_rx(kind, np, true).print();
    }
}
