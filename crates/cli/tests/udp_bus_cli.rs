//! Several CLI processes on one bus without CAN hardware: `--iface udp:GROUP:PORT`, the UDP
//! multicast bus in python-can's `udp_multicast` format.

use std::process::{Command, Stdio};

mod common;
use common::{stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_canopen"))
}

fn bus(salt: u16) -> String {
    common::udp_bus(salt)
}

fn simulator(iface: &str, secs: &str) -> std::process::Child {
    common::simulator(iface, EDS, "5", secs)
}

#[test]
fn simulate_and_sdo_read_in_two_processes() {
    let iface = bus(0);
    let mut sim = simulator(&iface, "20");
    let eds = format!("5={EDS}");
    let o = bin()
        .args([
            "--iface",
            &iface,
            "--eds",
            &eds,
            "sdo",
            "read",
            "5",
            "Producer heartbeat time",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500\n");
    // A write from a third process is seen by the next read.
    let o = bin()
        .args([
            "--iface", &iface, "--eds", &eds, "sdo", "write", "5", "0x1017", "250",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bin()
        .args([
            "--iface", &iface, "--eds", &eds, "sdo", "read", "5", "0x1017",
        ])
        .output()
        .unwrap();
    assert_eq!(stdout(&o), "250\n");
    let o = bin().args(["--iface", &iface, "scan"]).output().unwrap();
    assert!(
        stdout(&o)
            .lines()
            .any(|l| l.split_whitespace().take(2).eq(["5", "57"])),
        "{}",
        stdout(&o)
    );
    let _ = sim.kill();
    let _ = sim.wait();
}

/// `record` without `--duration` runs until Ctrl-C, and then puts its log in place.
#[test]
fn record_ends_on_ctrl_c_with_its_log_in_place() {
    let iface = bus(2);
    let dir = std::env::temp_dir().join(format!("canopen-cli-udp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("until-ctrl-c.log");
    let mut rec = bin()
        .args(["--iface", &iface, "record", "-o", log.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = std::io::BufRead::lines(std::io::BufReader::new(rec.stderr.take().unwrap()));
    assert!(err.next().unwrap().unwrap().starts_with("recording"));
    let o = bin()
        .args(["--iface", &iface, "nmt", "start", "5"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    std::thread::sleep(std::time::Duration::from_millis(300));
    assert!(!log.exists(), "the log appears when recording ends");
    let kill = Command::new("kill")
        .args(["-INT", &rec.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = rec.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let last = err.next().unwrap().unwrap();
    assert!(last.starts_with("1 frames recorded"), "{last}");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.trim_end().ends_with(" 000#0105"), "{text}");
}

#[test]
fn a_bad_udp_spec_is_refused() {
    let o = bin()
        .args(["--iface", "udp:10.1.2.3", "scan"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("not a multicast address"),
        "{}",
        stderr(&o)
    );
}

/// python-can and python-canopen on the same bus: python-canopen reads the CLI's simulator,
/// and the CLI's `monitor` sees what python-can sends, `sdo read` sees a python-canopen
/// LocalNode's answer, and python-can receives what the CLI sends. Needs the workspace's
/// `.venv` with python-can, python-canopen and `msgpack` (python-can's udp_multicast needs
/// it; scripts/test-all's setup stage installs them).
///
/// python-can runs with its defaults but `hop_limit=0` (TTL 0): it joins the group on its
/// default interface and sends there, and the kernel loops its frames back to this machine
/// without putting them on the wire, so the test sends nothing beyond this machine. The CLI's
/// bus is on the loopback scope (the default): python-can still hears it and is heard.
#[test]
fn interoperates_with_python_can_udp_multicast() {
    let iface = bus(1);
    let (group, port) = iface.strip_prefix("udp:").unwrap().split_once(':').unwrap();
    let python = concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python");
    let mut sim = simulator(&iface, "20");
    let script = format!(
        "import can, canopen\n\
         net = canopen.Network()\n\
         net.connect(interface='udp_multicast', channel='{group}', port={port}, hop_limit=0)\n\
         node = net.add_node(5, '{EDS}')\n\
         print(node.sdo[0x1017].raw, node.sdo[0x1008].raw)\n\
         net.disconnect()\n"
    );
    let o = Command::new(python).args(["-c", &script]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500 Buerkert generic device\n");
    let _ = sim.kill();
    let _ = sim.wait();

    let monitor = bin()
        .args(["--iface", &iface, "monitor", "--duration", "3"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let send = format!(
        "import can\n\
         bus = can.Bus(interface='udp_multicast', channel='{group}', port={port}, hop_limit=0)\n\
         bus.send(can.Message(arbitration_id=0x705, data=[0x05], is_extended_id=False))\n\
         bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0x00], is_extended_id=False))\n\
         bus.shutdown()\n"
    );
    let o = Command::new(python).args(["-c", &send]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = monitor.wait_with_output().unwrap();
    let text = stdout(&out);
    assert!(text.contains("705#05"), "{text}");
    assert!(text.contains("000#0100"), "{text}");

    // The CLI sends, python-can receives: NMT start node 5 and an SDO request.
    let recv = format!(
        "import can, sys\n\
         bus = can.Bus(interface='udp_multicast', channel='{group}', port={port}, hop_limit=0)\n\
         print('READY', flush=True)\n\
         seen = []\n\
         while len(seen) < 2:\n\
         \x20   m = bus.recv(timeout=10)\n\
         \x20   if m is None: break\n\
         \x20   if m.arbitration_id in (0x000, 0x605):\n\
         \x20       seen.append(f'{{m.arbitration_id:03X}}#{{m.data.hex().upper()}}')\n\
         print(' '.join(seen))\n\
         bus.shutdown()\n"
    );
    let mut py = Command::new(python)
        .args(["-c", &recv])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(py.stdout.take().unwrap()));
    assert_eq!(lines.next().unwrap().unwrap(), "READY");
    let o = bin()
        .args(["--iface", &iface, "nmt", "start", "5"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // Nothing answers this read: its request is on the bus all the same.
    let o = bin()
        .args(["--iface", &iface, "sdo", "read", "5", "0x1017"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let seen = lines.next().unwrap().unwrap();
    assert_eq!(seen, "000#0105 605#4017100000000000", "python-can received");
    assert!(py.wait().unwrap().success());
}

/// An IPv6 bus of this test process's own (`udp:[ff15:7079:7468:6f6e::SALT]:PORT`, python-can's
/// default group's prefix), or `None`, said on stderr, where this host carries no IPv6
/// multicast.
fn ipv6_bus(salt: u16) -> Option<(String, u16)> {
    let port = 30000 + (std::process::id() % 4000) as u16 * 8 + salt;
    let iface = format!("udp:[ff15:7079:7468:6f6e::{salt:x}]:{port}");
    let o = bin()
        .args(["--iface", &iface, "nmt", "state", "--listen", "0"])
        .output()
        .unwrap();
    if o.status.success() {
        return Some((iface, port));
    }
    let err = stderr(&o);
    assert!(err.contains("IPv6"), "not an IPv6 multicast failure: {err}");
    eprintln!("SKIPPED: this host carries no IPv6 multicast: {err}");
    None
}

#[test]
fn an_ipv6_group_carries_the_bus_between_processes() {
    let Some((iface, _)) = ipv6_bus(2) else {
        return;
    };
    let mut sim = simulator(&iface, "20");
    let o = bin()
        .args(["--iface", &iface, "sdo", "read", "5", "0x1008"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "Buerkert generic device\n");
    let _ = sim.kill();
    let _ = sim.wait();
    // python-can's default channel spelled without brackets, and a bad one.
    let o = bin()
        .args([
            "--iface",
            "udp:ff15:7079:7468:6f6e:6465:6d6f:6d63:6173",
            "nmt",
            "state",
            "--listen",
            "0",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bin()
        .args(["--iface", "udp:ff15", "scan"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        !stderr(&o).contains("invalid IPv4 address syntax"),
        "{}",
        stderr(&o)
    );
}

/// python-canopen with python-can's default channel (the IPv6 group) reads the CLI's simulator
/// on `udp:ff15:7079:7468:6f6e:6465:6d6f:6d63:6173`: the README's "python-can with its
/// defaults". A port of the test's own, and `hop_limit=0` so that python-can's frames stay on
/// this machine. Needs the workspace's `.venv` (as the test above).
#[test]
fn python_can_with_its_default_channel_meets_the_ipv6_bus() {
    if ipv6_bus(3).is_none() {
        return;
    }
    let port = 30000 + (std::process::id() % 4000) as u16 * 8 + 4;
    let iface = format!("udp:[ff15:7079:7468:6f6e:6465:6d6f:6d63:6173]:{port}");
    let python = concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python");
    let mut sim = simulator(&iface, "20");
    let script = format!(
        "import can, canopen\n\
         net = canopen.Network()\n\
         net.connect(interface='udp_multicast', port={port}, hop_limit=0)\n\
         from can.interfaces.udp_multicast import UdpMulticastBus\n\
         assert UdpMulticastBus.DEFAULT_GROUP_IPv6 == 'ff15:7079:7468:6f6e:6465:6d6f:6d63:6173'\n\
         node = net.add_node(5, '{EDS}')\n\
         node.sdo[0x1017].raw = 750\n\
         print(node.sdo[0x1017].raw, node.sdo[0x1008].raw)\n\
         net.disconnect()\n"
    );
    let o = Command::new(python).args(["-c", &script]).output().unwrap();
    let _ = sim.kill();
    let _ = sim.wait();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "750 Buerkert generic device\n");
}
