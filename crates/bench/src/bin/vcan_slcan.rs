//! Frames per second and CPU per frame through the facade's transports: `canola::slcan::Slcan`
//! on the master of a pty pair with the Linux kernel's slcan driver (`slcand`) on the slave as
//! `slcan0`, against `canola::socketcan::SocketCan` on `vcan0`; the same frames (11-bit, 8
//! bytes) both ways, printed side by side.
//!
//! Runs in the QEMU guest of `tests/vcan` (root, the `slcan` module, can-utils, `vcan0`):
//! `tests/vcan/run-all 'bench-slcan-transport'`.
//!
//! - slcan TX: `Transport::send` on the slcan transport; a raw socket on `slcan0` counts.
//! - slcan RX: a raw socket on `slcan0` writes; `Transport::recv_until` on the slcan transport.
//! - SocketCAN TX/RX: the same with the SocketCAN transport on `vcan0` and a raw socket there.
//!
//! CPU is per thread (CLOCK_THREAD_CPUTIME_ID): "local" is the transport's thread, "peer" the
//! raw socket's. The kernel's own work lands in whichever thread triggers it.

#[cfg(target_os = "linux")]
mod linux {
    use std::io;
    use std::path::Path;
    use std::process::{Child, Command};
    use std::thread;
    use std::time::{Duration, Instant};

    use canola::slcan::{AckMode, Link, LinkConfig, Slcan};
    use canola::socketcan::SocketCan;
    use canola::{CanFrame, CanId, Received, Transport, TransportError};
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

    /// Sends until the transport takes the frame.
    fn send_insist(t: &mut dyn Transport, f: &CanFrame) {
        loop {
            match t.send(f) {
                Ok(()) => return,
                Err(TransportError::TxQueueFull) => thread::sleep(Duration::from_micros(50)),
                Err(e) => panic!("send: {e}"),
            }
        }
    }

    /// Writes until the kernel takes the frame (a full queue is ENOBUFS on CAN sockets).
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

    /// A raw socket with a 4 MiB receive buffer, so a reader behind a burst loses nothing.
    fn open_reader(iface: &str) -> CanSocket {
        let sock = CanSocket::open(iface).unwrap_or_else(|e| panic!("socket on {iface}: {e}"));
        nix::sys::socket::setsockopt(&sock, nix::sys::socket::sockopt::RcvBufForce, &(4 << 20))
            .expect("SO_RCVBUFFORCE");
        sock
    }

    /// Reads until `n` frames or 3 s without one: how many, when the last came, thread CPU.
    fn count_frames(sock: &CanSocket, n: usize) -> (usize, Instant, Duration) {
        sock.set_read_timeout(Duration::from_secs(3)).unwrap();
        let c0 = thread_cpu();
        let (mut got, mut last) = (0, Instant::now());
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
                "{:<38} {:>7} {:>8} {:>10.0} {:>14.0} {:>13.0}",
                self.what,
                self.sent,
                self.got,
                self.got as f64 / self.wall.as_secs_f64(),
                self.local.as_nanos() as f64 / n,
                self.peer.as_nanos() as f64 / n,
            );
        }
    }

    /// TX: the transport sends `count` frames, a raw socket on `iface` counts them.
    fn tx(what: &'static str, t: &mut dyn Transport, iface: &str, count: usize) -> Row {
        let reader = open_reader(iface);
        let peer = thread::spawn(move || count_frames(&reader, count));
        let (t0, c0) = (Instant::now(), thread_cpu());
        for i in 0..count {
            let f = CanFrame::new(CanId::standard(id(i)).unwrap(), &payload(i)).unwrap();
            send_insist(t, &f);
        }
        let local = thread_cpu() - c0;
        let (got, last, peer) = peer.join().unwrap();
        Row {
            what,
            sent: count,
            got,
            wall: last - t0,
            local,
            peer,
        }
    }

    /// RX: a raw socket on `iface` writes `count` frames, the transport receives them.
    fn rx(what: &'static str, t: &mut dyn Transport, iface: &str, count: usize) -> Row {
        let writer = CanSocket::open(iface).expect("raw socket");
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
        let (mut got, mut last) = (0, Instant::now());
        while got < count {
            let deadline = t.now() + canola::Duration::from_secs(3);
            match t.recv_until(deadline).expect("receive") {
                Some(Received::Frame { .. }) => {
                    got += 1;
                    last = Instant::now();
                }
                Some(Received::Event(_)) => {}
                None => break,
            }
        }
        let local = thread_cpu() - c0;
        Row {
            what,
            sent: count,
            got,
            wall: last - t0,
            local,
            peer: peer.join().unwrap(),
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
        let link = Link::with_port(config, Box::new(master)).expect("link on the pty master");
        let mut slcan = Slcan::with_link(link);
        let mut vcan = SocketCan::open("vcan0").expect("SocketCAN transport on vcan0");

        let rows = [
            tx("slcan transport TX -> slcan0", &mut slcan, IFACE, count),
            rx("slcan0 -> slcan transport RX", &mut slcan, IFACE, count),
            tx("SocketCAN transport TX -> vcan0", &mut vcan, "vcan0", count),
            rx("vcan0 -> SocketCAN transport RX", &mut vcan, "vcan0", count),
        ];
        println!(
            "{:<38} {:>7} {:>8} {:>10} {:>14} {:>13}",
            "path", "sent", "received", "frames/s", "local CPU ns/f", "peer CPU ns/f"
        );
        for r in &rows {
            r.print();
        }
        assert_eq!(
            slcan.stats().bad_input(),
            0,
            "the kernel's lines all decoded"
        );
        let _ = Command::new("ip")
            .args(["link", "set", IFACE, "down"])
            .status();
        drop(slcan);
        drop(slave);
    }
}

fn main() {
    #[cfg(target_os = "linux")]
    linux::main();
    #[cfg(not(target_os = "linux"))]
    eprintln!("vcan_slcan needs Linux (the kernel slcan driver and SocketCAN)");
}
