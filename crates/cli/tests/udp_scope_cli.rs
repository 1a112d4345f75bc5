//! Who hears the UDP multicast bus: by default this machine only. A listener joined on a
//! non-loopback interface (the view of a host on that LAN segment) does not see the default
//! bus's frames; it does see a bus put on that interface on purpose with `udp:...@IFACE`. And a
//! host on a segment (a network namespace this test makes, behind a veth pair) cannot inject a
//! frame into the default bus, though its datagram reaches this machine.
//!
//! The listener is a plain Python socket (standard library) with `IP_MULTICAST_ALL` off, so it
//! receives only what arrives on the interface it joined. Its positive control is a datagram
//! sent on that interface with a TTL of 0: the kernel loops it back to this machine and never
//! puts it on the wire. The interface is a veth pair this test makes (root) when it can, else
//! the machine's first non-loopback IPv4 address (then only the default bus is tried, so that
//! nothing is sent onto a real segment); without either the test is skipped, saying why.

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};

mod common;
use common::stderr;

const LISTENER: &str = r#"
import socket, struct, sys, time
group, port, lan = sys.argv[1], int(sys.argv[2]), sys.argv[3]
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
s.setsockopt(socket.IPPROTO_IP, 49, 0)  # IP_MULTICAST_ALL off: this socket's joins only
s.bind((group, port))
s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
             socket.inet_aton(group) + socket.inet_aton(lan))
print("READY", flush=True)
sys.stdin.readline()
# The positive control: on the LAN interface, TTL 0 (looped back here, never on the wire).
c = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
c.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(lan))
c.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
c.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
c.sendto(b"CONTROL", (group, port))
s.settimeout(5)
others, control = 0, False
try:
    while True:
        d = s.recv(4096)
        if d == b"CONTROL":
            control = True
            break
        others += 1
except socket.timeout:
    pass
print(f"control={control} frames={others}", flush=True)
"#;

/// An interface made for the test, removed when dropped.
struct Dummy(String);

impl Drop for Dummy {
    fn drop(&mut self) {
        let _ = Command::new("ip").args(["link", "del", &self.0]).output();
    }
}

fn ip(args: &[&str]) -> bool {
    Command::new("ip")
        .args(args)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// A veth pair of this machine (both ends here, so what is sent on it stays here), the first
/// end with an address of 198.18.0.0/15 (reserved for benchmarks, routed nowhere).
fn make_dummy() -> Option<(Dummy, String, String)> {
    let name = format!("canola-u{}", std::process::id() % 100_000);
    let peer = format!("{name}p");
    let addr = format!("198.18.{}.1", std::process::id() % 250);
    if !ip(&["link", "add", &name, "type", "veth", "peer", "name", &peer]) {
        return None;
    }
    let d = Dummy(name.clone());
    let ok = ip(&["addr", "add", &format!("{addr}/32"), "dev", &name])
        && ip(&["link", "set", &peer, "up"])
        && ip(&["link", "set", &name, "up"]);
    ok.then_some((d, name, addr))
}

/// The machine's first non-loopback IPv4 address.
fn lan_address() -> Option<String> {
    let o = Command::new("ip")
        .args(["-4", "-o", "addr", "show"])
        .output()
        .ok()?;
    String::from_utf8_lossy(&o.stdout).lines().find_map(|l| {
        let mut w = l.split_whitespace();
        let _ = w.next()?;
        let name = w.next()?;
        let _ = w.next()?;
        let addr = w.next()?.split('/').next()?;
        (name != "lo" && !addr.starts_with("127.")).then(|| addr.to_owned())
    })
}

/// Runs the listener on `lan`, lets `send` put frames on the bus, and returns (control seen,
/// frames seen).
fn listen_while(python: &str, bus: &str, lan: &str, send: impl FnOnce()) -> (bool, u32) {
    let (group, port) = bus.strip_prefix("udp:").unwrap().split_once(':').unwrap();
    let port = port.split('@').next().unwrap();
    let mut py = Command::new(python)
        .args(["-c", LISTENER, group, port, lan])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(py.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "READY", "the listener did not start");
    send();
    py.stdin.take().unwrap().write_all(b"go\n").unwrap();
    line.clear();
    out.read_line(&mut line).unwrap();
    assert!(py.wait().unwrap().success());
    let (c, f) = line.trim().split_once(' ').expect("listener's report");
    (
        c == "control=True",
        f.strip_prefix("frames=").unwrap().parse().unwrap(),
    )
}

fn nmt_start(iface: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["--iface", iface, "nmt", "start", "5"])
        .output()
        .unwrap()
}

#[test]
fn a_listener_on_a_lan_interface_sees_only_a_bus_put_there_on_purpose() {
    let python = concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python");
    if Command::new(python).args(["-c", "1"]).output().is_err() {
        eprintln!("SKIPPED: no python at {python}");
        return;
    }
    let dummy = make_dummy();
    let iface = dummy
        .as_ref()
        .map(|(_, name, addr)| (name.clone(), addr.clone()));
    // Every non-loopback address tried: the machine's own (where its default route, and so a
    // bus joined on the default interface, would put frames) and the test's veth.
    let lans: Vec<String> = lan_address()
        .into_iter()
        .chain(iface.iter().map(|(_, a)| a.clone()))
        .collect();
    if lans.is_empty() {
        eprintln!(
            "SKIPPED: no non-loopback IPv4 address here and no veth pair can be made \
             (needs root: ip link add NAME type veth)"
        );
        return;
    }
    let bus = common::udp_bus(0);
    // The default bus: a listener on a LAN interface sees nothing, its control only.
    for lan in &lans {
        let (control, frames) = listen_while(python, &bus, lan, || {
            let o = nmt_start(&bus);
            assert!(o.status.success(), "{}", stderr(&o));
        });
        assert!(control, "the listener on {lan} does not work");
        assert_eq!(
            frames, 0,
            "a listener on {lan} saw the default bus's frames"
        );
        println!("default bus: a listener on {lan} saw 0 frames (control seen)");
    }

    // On purpose on the test's veth pair (frames go nowhere beyond this machine): seen, with a
    // warning.
    let Some((name, lan)) = iface else {
        eprintln!("SKIPPED the @IFACE half: no veth pair could be made (not root)");
        return;
    };
    let scoped = format!("{bus}@{name}");
    let (control, frames) = listen_while(python, &scoped, &lan, || {
        let o = nmt_start(&scoped);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("anyone on that network segment can read every frame and inject"),
            "{}",
            stderr(&o)
        );
    });
    assert!(control);
    assert_eq!(frames, 1, "the bus on {name} was not seen there");
    drop(dummy);
}

/// A network namespace with a veth pair to this machine: a host on a LAN segment of its own.
/// Removed when dropped.
struct Netns {
    ns: String,
    link: String,
}

impl Drop for Netns {
    fn drop(&mut self) {
        let _ = Command::new("ip")
            .args(["link", "del", &self.link])
            .output();
        let _ = Command::new("ip").args(["netns", "del", &self.ns]).output();
    }
}

/// Makes the namespace; returns it, this machine's address on the link and the host's.
fn make_netns() -> Option<(Netns, String)> {
    let pid = std::process::id() % 100_000;
    let (ns, link, peer) = (
        format!("canola-ns{pid}"),
        format!("canola-i{pid}"),
        format!("canola-i{pid}p"),
    );
    let k = pid % 250;
    let (here, there) = (format!("198.19.{k}.1"), format!("198.19.{k}.2"));
    if !ip(&["netns", "add", &ns]) {
        return None;
    }
    let n = Netns {
        ns: ns.clone(),
        link: link.clone(),
    };
    let inside = |args: &[&str]| {
        let mut a = vec!["netns", "exec", &ns, "ip"];
        a.extend_from_slice(args);
        ip(&a)
    };
    let ok = ip(&["link", "add", &link, "type", "veth", "peer", "name", &peer])
        && ip(&["link", "set", &peer, "netns", &ns])
        && ip(&["addr", "add", &format!("{here}/24"), "dev", &link])
        && ip(&["link", "set", &link, "up"])
        && inside(&["addr", "add", &format!("{there}/24"), "dev", &peer])
        && inside(&["link", "set", &peer, "up"])
        && inside(&["route", "add", "224.0.0.0/4", "dev", &peer]);
    ok.then_some((n, here))
}

/// A host on the segment sends an NMT "stop node 5" to the group. A program on this machine
/// joined on that segment's interface (python-can with its defaults would be one) receives it,
/// so it reaches this machine; the default bus still does not take it.
#[test]
fn a_host_on_the_segment_cannot_inject_into_the_default_bus() {
    let python = concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python");
    if Command::new(python).args(["-c", "1"]).output().is_err() {
        eprintln!("SKIPPED: no python at {python}");
        return;
    }
    let Some((netns, here)) = make_netns() else {
        eprintln!("SKIPPED: no network namespace with a veth pair can be made (needs root)");
        return;
    };
    let bus = common::udp_bus(1);
    let (group, port) = bus.strip_prefix("udp:").unwrap().split_once(':').unwrap();
    // The member here, joined on the segment's interface (IP_MULTICAST_ALL as by default).
    let member = format!(
        "import socket, sys\n\
         s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n\
         s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)\n\
         s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)\n\
         s.bind(('', {port}))\n\
         s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, \
         socket.inet_aton('{group}') + socket.inet_aton('{here}'))\n\
         s.settimeout(8)\n\
         print('READY', flush=True)\n\
         while True:\n\
         \x20   d, a = s.recvfrom(4096)\n\
         \x20   if a[0] != '{here}' and not a[0].startswith('127.'):\n\
         \x20       print('FROM', a[0], flush=True)\n\
         \x20       break\n"
    );
    let mut member = Command::new(python)
        .args(["-c", &member])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut member_out = BufReader::new(member.stdout.take().unwrap());
    let mut line = String::new();
    member_out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "READY");
    let monitor = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["--iface", &bus, "monitor", "--duration", "3"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    // The injection, from the other host (python-can there, TTL 1).
    let inject = format!(
        "import can\n\
         b = can.Bus(interface='udp_multicast', channel='{group}', port={port})\n\
         b.send(can.Message(arbitration_id=0, data=[2, 5], is_extended_id=False))\n\
         b.shutdown()\n"
    );
    let o = Command::new("ip")
        .args(["netns", "exec", &netns.ns, python, "-c", &inject])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // A frame from this machine, which the monitor must show.
    let o = nmt_start(&bus);
    assert!(o.status.success(), "{}", stderr(&o));
    line.clear();
    member_out.read_line(&mut line).unwrap();
    assert!(
        line.starts_with("FROM 198.19."),
        "the injected frame did not reach this machine: {line:?}"
    );
    let _ = member.wait();
    let out = monitor.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("000#0105"), "{text}");
    assert!(
        !text.contains("000#0205"),
        "the injected frame got in: {text}"
    );
    println!(
        "injected from {}: seen by a member here, not by the bus",
        line.trim()
    );
    drop(netns);
}
