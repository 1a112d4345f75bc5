//! The master on the slcan transport against the Linux kernel's own slcan driver and
//! python-canopen: a pseudo-terminal pair, can-utils' `slcand` attaching the kernel's N_SLCAN
//! line discipline to the slave side as `slcan0`, this stack's slcan transport (`canola::slcan`)
//! on the master side under a `Network`, and python-canopen's LocalNode
//! (`tests/vcan/canopen_server.py`) on `slcan0` as the device. So every frame crosses the
//! transport's codec and the kernel driver's, two implementations written apart.
//!
//! Checked: boot-up, SDO expedited and segmented both ways, SDO block (python-canopen's
//! LocalNode has no block server: a block upload is answered by the protocol switch to a plain
//! upload, a block download is aborted, both as CiA 301 allows), the server's abort code, NMT
//! start seen in the heartbeat, TPDO from the device and RPDO to it (applied, read back by SDO),
//! then the pty dropped (the network reports the interface down and sends fail) and a new pty
//! with the driver attached again (the network reports it up, and SDO works with a new device
//! process on the new `slcan0`).
//!
//! Needs CAP_NET_ADMIN, the `slcan` module, can-utils and python-canopen: run by
//! `tests/vcan/run-all 'rust-master-slcan-kernel'` in the QEMU guest; ignored on the host.

#![cfg(target_os = "linux")]

mod common;

use std::path::Path;
use std::process::{Child, Command};
use std::sync::mpsc;
use std::thread;
use std::time::Instant as StdInstant;

use canola::slcan::{Link, LinkConfig, LinkError, Slcan};
use canola::{BusEvent, CanFrame, CanId, Network, NetworkEvent, TransportError};
use canola_frame::Duration;
use canola_nmt::{HeartbeatEvent, NmtState};
use canola_sdo::AbortCode;
use common::{PythonDevice, node, wait_event};
use serialport::{SerialPort, TTYPort};

const IFACE: &str = "slcan0";
const ID: u8 = 0x45;

/// A child process killed (by its own id) when dropped.
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

fn iface_exists() -> bool {
    Path::new("/sys/class/net").join(IFACE).exists()
}

/// A pty pair with the kernel driver on its slave as `slcan0` (up), and a link on its master.
struct Attached {
    link: Link,
    slcand: Reaped,
    slave: TTYPort,
}

fn attach() -> Attached {
    let (master, slave) = TTYPort::pair().expect("pty pair");
    let slave_path = slave.name().expect("slave name");
    let slcand = Reaped(
        Command::new("slcand")
            .args(["-o", "-c", "-s6", "-F", &slave_path, IFACE])
            .spawn()
            .expect("slcand (can-utils)"),
    );
    let until = StdInstant::now() + std::time::Duration::from_secs(20);
    while !iface_exists() {
        assert!(StdInstant::now() < until, "slcand did not create {IFACE}");
        thread::sleep(std::time::Duration::from_millis(50));
    }
    run("ip", &["link", "set", IFACE, "up"]);
    let mut config = LinkConfig::new(slave_path);
    config.reply_timeout = std::time::Duration::from_millis(500);
    let link = Link::with_port(config, Box::new(master)).expect("link on the pty master");
    Attached {
        link,
        slcand,
        slave,
    }
}

/// Drives the network until the bus event `want` is published. While the adapter is gone,
/// driving fails with the interface down (a send that could not go out): that is expected
/// here and waited through.
fn wait_bus_event(net: &Network, events: &mpsc::Receiver<NetworkEvent>, want: BusEvent) {
    let until = StdInstant::now() + std::time::Duration::from_secs(20);
    loop {
        match net.run_for(Duration::from_millis(50)).wait() {
            Ok(()) | Err(canola::Error::Transport(TransportError::InterfaceDown)) => {}
            Err(e) => panic!("drive the network: {e}"),
        }
        if events
            .try_iter()
            .any(|e| e == NetworkEvent::Bus(want.clone()))
        {
            return;
        }
        assert!(StdInstant::now() < until, "no {want:?} within 20 s");
    }
}

fn pdo_from(e: &NetworkEvent) -> Option<Vec<u8>> {
    match e {
        NetworkEvent::Pdo {
            node: n,
            number: 1,
            data,
            ..
        } if *n == node(ID) => Some(data.to_vec()),
        _ => None,
    }
}

#[test]
#[ignore = "needs the kernel's slcan driver, can-utils, python-canopen and CAP_NET_ADMIN: run by tests/vcan/run-all"]
fn master_on_slcan_against_the_kernel_driver_and_python_canopen() {
    let first = attach();
    // The pty has no path to open again: the test hands the transport the next link.
    let (next_link, links) = mpsc::channel::<Link>();
    let transport = Slcan::with_reopen(first.link, move |_config| {
        links.try_recv().map_err(|_| LinkError::Closed)
    });
    let stats = transport.stats();
    let (mut slcand, mut slave) = (Some(first.slcand), Some(first.slave));

    let net = Network::new(transport);
    let events = net.subscribe();
    net.monitor_heartbeat(node(ID), Duration::from_secs(2));
    let device = PythonDevice::start_on(IFACE, &["--tpdo-ms", "100", "--rpdo", "0x45"]);
    wait_event(&net, &events, Duration::from_secs(20), "boot-up", |e| {
        *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) })
    });

    let n = net.node(node(ID));
    let sdo = || n.sdo().timeout(Duration::from_secs(5));
    // Expedited and segmented uploads.
    assert_eq!(
        sdo().read((0x1000, 0)).wait().unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
    assert_eq!(
        sdo().read((0x1018, 1)).wait().unwrap(),
        0x0ABCu32.to_le_bytes()
    );
    assert_eq!(
        sdo().read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    // Expedited and segmented downloads, read back.
    sdo().write((0x2002, 1), -1234i16).wait().unwrap();
    assert_eq!(
        sdo().read((0x2002, 1)).wait().unwrap(),
        (-1234i16).to_le_bytes()
    );
    let text = "over slcan: the kernel driver between master and python-canopen";
    sdo().write((0x2001, 0), text).wait().unwrap();
    assert_eq!(sdo().read((0x2001, 0)).wait().unwrap(), text.as_bytes());
    let e = sdo().read((0x5FFF, 0)).wait().unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0602_0000)), "{e}");
    // Block: the protocol switch to a plain upload, and a refused block download.
    assert_eq!(
        sdo().block(true).read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    let e = sdo()
        .block(true)
        .write((0x2001, 0), text)
        .wait()
        .unwrap_err();
    assert_eq!(e.server_abort(), Some(AbortCode(0x0504_0001)), "{e}");

    // NMT start, seen in the heartbeat.
    n.nmt().start().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "heartbeat OPERATIONAL",
        |e| matches!(e, NetworkEvent::Heartbeat(HeartbeatEvent::StateChanged { node: x, to: NmtState::Operational, .. }) if *x == node(ID)),
    );

    // TPDO1 from the device carries 0x2000; an SDO download changes it.
    wait_event(&net, &events, Duration::from_secs(10), "TPDO1", |e| {
        pdo_from(e) == Some(0x1234_5678u32.to_le_bytes().to_vec())
    });
    sdo().write((0x2000, 0), 0xCAFE_BABEu32).wait().unwrap();
    wait_event(
        &net,
        &events,
        Duration::from_secs(10),
        "TPDO1 changed",
        |e| pdo_from(e) == Some(0xCAFE_BABEu32.to_le_bytes().to_vec()),
    );
    // RPDO1 to the device (0x2003, then 0x2002:02): applied, read back by SDO.
    let mut rpdo = 0x0BAD_F00Du32.to_le_bytes().to_vec();
    rpdo.extend_from_slice(&777i16.to_le_bytes());
    net.send(CanFrame::new(CanId::standard(0x200 + u16::from(ID)).unwrap(), &rpdo).unwrap())
        .unwrap();
    let until = StdInstant::now() + std::time::Duration::from_secs(10);
    loop {
        if sdo().read((0x2003, 0)).wait().unwrap() == 0x0BAD_F00Du32.to_le_bytes() {
            break;
        }
        assert!(StdInstant::now() < until, "the RPDO was not applied");
        net.run_for(Duration::from_millis(100)).wait().unwrap();
    }
    assert_eq!(
        sdo().read((0x2002, 2)).wait().unwrap(),
        777i16.to_le_bytes()
    );
    assert_eq!(stats.bad_input(), 0, "the kernel's lines all decoded");

    // The pty dropped: slcan0 goes, the transport reports the adapter gone, sends fail.
    drop(device);
    run("ip", &["link", "set", IFACE, "down"]);
    drop(slave.take());
    drop(slcand.take());
    wait_event(
        &net,
        &events,
        Duration::from_secs(20),
        "interface down",
        |e| *e == NetworkEvent::Bus(BusEvent::InterfaceDown),
    );
    assert!(
        n.sdo()
            .timeout(Duration::from_millis(500))
            .read((0x1000, 0))
            .wait()
            .is_err()
    );
    let until = StdInstant::now() + std::time::Duration::from_secs(20);
    while iface_exists() {
        assert!(
            StdInstant::now() < until,
            "{IFACE} stayed after the pty closed"
        );
        thread::sleep(std::time::Duration::from_millis(50));
    }

    // A new pty with the driver attached again: the network comes back and serves a new device.
    let second = attach();
    next_link.send(second.link).unwrap();
    wait_bus_event(&net, &events, BusEvent::InterfaceUp);
    assert_eq!((stats.vanished(), stats.reopened()), (1, 1));
    let device = PythonDevice::start_on(IFACE, &["0x45"]);
    wait_event(
        &net,
        &events,
        Duration::from_secs(20),
        "boot-up again",
        |e| *e == NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node: node(ID) }),
    );
    assert_eq!(
        sdo().read((0x1008, 0)).wait().unwrap(),
        b"canopen-rs vcan test device"
    );
    let status = device.stop();
    assert!(status.success(), "python-canopen LocalNode exit: {status}");
    run("ip", &["link", "set", IFACE, "down"]);
    drop(second.slave);
    drop(second.slcand);
}
