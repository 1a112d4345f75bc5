//! Frames per second and CPU per frame of the slcan link through the Linux kernel's slcan driver
//! on a pty pair, against the same traffic through SocketCAN on `vcan0`, printed side by side.
//!
//! Runs in the QEMU guest of `tests/vcan` (root, the `slcan` module, can-utils' `slcand`,
//! `vcan0`): `tests/vcan/run-all 'bench-slcan-vs-socketcan'`, or by hand
//! `tests/vcan/rig run -- "$CARGO_TARGET_DIR"/release/examples/kernel_bench --count 20000`.
//!
//! - slcan TX: `Link::send` of N frames into the pty master; the kernel driver decodes them on
//!   `slcan0`, where a raw SocketCAN socket counts them.
//! - slcan RX: a raw socket writes N frames to `slcan0`; the driver writes the lines into the
//!   pty; `Link::recv` decodes them.
//! - vcan: a raw socket writes N frames to `vcan0`, another reads them: the same traffic with no
//!   serial line and no text encoding.
//!
//! CPU is per thread (CLOCK_THREAD_CPUTIME_ID): "local" is the side under test (the link, or
//! the vcan reader), "peer" the socket on the other side. The kernel driver's own work runs in
//! either, or in softirq context, and shows in the wall rate.

#[cfg(target_os = "linux")]
mod linux {
    use std::io;
    use std::path::Path;
    use std::process::{Child, Command};
    use std::thread;
    use std::time::{Duration, Instant};

    use canola_frame::CanId;
    use canola_slcan::{AckMode, Frame, Incoming, Link, LinkConfig};
    use nix::time::{ClockId, clock_gettime};
    use serialport::{SerialPort, TTYPort};
    use socketcan::{CanSocket, EmbeddedFrame, Socket, StandardId};

    const IFACE: &str = "slcan0";

    fn thread_cpu() -> Duration {
        let t = clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID).expect("thread CPU clock");
        Duration::new(t.tv_sec() as u64, t.tv_nsec() as u32)
    }

    fn payload(i: usize) -> [u8; 8] {
        (i as u64).to_le_bytes()
    }

    fn id(i: usize) -> u16 {
        (i % 0x7FF) as u16
    }

    /// Writes until the kernel takes the frame (a full transmit queue is ENOBUFS on CAN sockets).
    fn write_insist(sock: &CanSocket, f: &socketcan::CanFrame) {
        loop {
            match sock.write_frame(f) {
                Ok(()) => return,
                Err(e)
                    if e.raw_os_error() == Some(nix::libc::ENOBUFS)
                        || e.kind() == io::ErrorKind::WouldBlock
                        || e.kind() == io::ErrorKind::Interrupted =>
                {
                    thread::sleep(Duration::from_micros(50));
                }
                Err(e) => panic!("write: {e}"),
            }
        }
    }

    /// A raw socket on `iface` with a 4 MiB receive buffer (as root, past `rmem_max`), so a
    /// reader that falls behind a burst loses nothing.
    fn open_reader(iface: &str) -> CanSocket {
        let sock = CanSocket::open(iface).unwrap_or_else(|e| panic!("socket on {iface}: {e}"));
        nix::sys::socket::setsockopt(&sock, nix::sys::socket::sockopt::RcvBufForce, &(4 << 20))
            .expect("SO_RCVBUFFORCE");
        sock
    }

    /// Reads until `n` frames or 3 s without one; returns how many, when the last one came,
    /// and the thread's CPU time.
    fn count_frames(sock: &CanSocket, n: usize) -> (usize, Instant, Duration) {
        sock.set_read_timeout(Duration::from_secs(3)).unwrap();
        let c0 = thread_cpu();
        let mut got = 0;
        let mut last = Instant::now();
        while got < n {
            match sock.read_frame() {
                Ok(_) => {
                    got += 1;
                    last = Instant::now();
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(_) => break,
            }
        }
        (got, last, thread_cpu() - c0)
    }

    struct Row {
        what: &'static str,
        sent: usize,
        got: usize,
        wall: Duration,
        local: Duration,
        peer: Duration,
    }

    impl Row {
        fn print(&self) {
            let n = self.got.max(1) as f64;
            println!(
                "{:<34} {:>7} {:>8} {:>10.0} {:>14.0} {:>13.0}",
                self.what,
                self.sent,
                self.got,
                self.got as f64 / self.wall.as_secs_f64(),
                self.local.as_nanos() as f64 / n,
                self.peer.as_nanos() as f64 / n,
            );
        }
    }

    struct Slcand(Child);

    impl Drop for Slcand {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }

    pub(crate) fn main() {
        let mut args = std::env::args().skip(1);
        let mut count = 5_000;
        while let Some(a) = args.next() {
            match a.as_str() {
                "--count" => count = args.next().and_then(|v| v.parse().ok()).expect("--count N"),
                other => panic!("unknown argument {other} (--count N)"),
            }
        }

        let (master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = slave.name().expect("slave name");
        let _slcand = Slcand(
            Command::new("slcand")
                .args(["-o", "-c", "-s8", "-F", &slave_path, IFACE])
                .spawn()
                .expect("slcand (can-utils)"),
        );
        let until = Instant::now() + Duration::from_secs(20);
        while !Path::new("/sys/class/net").join(IFACE).exists() {
            assert!(Instant::now() < until, "slcand did not create {IFACE}");
            thread::sleep(Duration::from_millis(50));
        }
        let up = Command::new("ip")
            .args(["link", "set", IFACE, "up"])
            .status();
        assert!(up.is_ok_and(|s| s.success()), "ip link set {IFACE} up");
        let mut config = LinkConfig::new(slave_path);
        config.ack = AckMode::Never;
        let mut link = Link::with_port(config, Box::new(master)).expect("link on the pty master");

        let mut rows = Vec::new();

        // slcan TX: the link writes, a socket on slcan0 counts.
        let reader = open_reader(IFACE);
        let peer = thread::spawn(move || count_frames(&reader, count));
        let (t0, c0) = (Instant::now(), thread_cpu());
        for i in 0..count {
            let f =
                canola_frame::CanFrame::new(CanId::standard(id(i)).unwrap(), &payload(i)).unwrap();
            link.send(&Frame::Classic(f)).unwrap();
        }
        let local = thread_cpu() - c0;
        let (got, last, peer_cpu) = peer.join().unwrap();
        rows.push(Row {
            what: "slcan TX: Link::send -> slcan0",
            sent: count,
            got,
            wall: last - t0,
            local,
            peer: peer_cpu,
        });

        // slcan RX: a socket on slcan0 writes, the link decodes.
        let writer = CanSocket::open(IFACE).expect("socket on slcan0");
        let (t0, c0) = (Instant::now(), thread_cpu());
        let peer = thread::spawn(move || {
            let c0 = thread_cpu();
            for i in 0..count {
                let f =
                    socketcan::CanFrame::new(StandardId::new(id(i)).unwrap(), &payload(i)).unwrap();
                write_insist(&writer, &f);
            }
            thread_cpu() - c0
        });
        let mut got = 0;
        let mut last = Instant::now();
        while got < count {
            match link.recv(Duration::from_secs(3)).expect("link recv") {
                Some(Incoming::Frame(_)) => {
                    got += 1;
                    last = Instant::now();
                }
                Some(_) => {}
                None => break,
            }
        }
        let local = thread_cpu() - c0;
        rows.push(Row {
            what: "slcan RX: slcan0 -> Link::recv",
            sent: count,
            got,
            wall: last - t0,
            local,
            peer: peer.join().unwrap(),
        });

        // The same traffic on vcan0.
        let reader = open_reader("vcan0");
        let writer = CanSocket::open("vcan0").expect("socket on vcan0");
        let t0 = Instant::now();
        let peer = thread::spawn(move || {
            let c0 = thread_cpu();
            for i in 0..count {
                let f =
                    socketcan::CanFrame::new(StandardId::new(id(i)).unwrap(), &payload(i)).unwrap();
                write_insist(&writer, &f);
            }
            thread_cpu() - c0
        });
        let (got, last, local) = count_frames(&reader, count);
        rows.push(Row {
            what: "vcan0: socket -> socket",
            sent: count,
            got,
            wall: last - t0,
            local,
            peer: peer.join().unwrap(),
        });

        println!(
            "{:<34} {:>7} {:>8} {:>10} {:>14} {:>13}",
            "path", "sent", "received", "frames/s", "local CPU ns/f", "peer CPU ns/f"
        );
        for r in &rows {
            r.print();
        }
        let _ = Command::new("ip")
            .args(["link", "set", IFACE, "down"])
            .status();
        drop(link);
        drop(slave);
    }
}

fn main() {
    #[cfg(target_os = "linux")]
    linux::main();
    #[cfg(not(target_os = "linux"))]
    eprintln!("kernel_bench needs Linux (the kernel slcan driver and SocketCAN)");
}
