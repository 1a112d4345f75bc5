//! PDOs from the master against an independent device: python-canopen 2.4.1's `LocalNode` with
//! the Bürkert EDS (`tests/py/pdo_peer.py`) on a UDP multicast bus (python-can's
//! `udp_multicast` format) between this test and the python process.
//!
//! * `node.tpdo().read()` / `node.rpdo().read()` read python-canopen's object dictionary;
//! * `save()` moves TPDO1 to COB-ID 0x1F0 with a new mapping, and python-canopen's own
//!   `tpdo.read()` of its dictionary finds exactly that configuration;
//! * the TPDO python-canopen then packs and sends from 0x1F0 is decoded by this master;
//! * the RPDO this master's engine packs is decoded by python-canopen to the values set.
//!
//! Runs with `$CANOPEN_PYTHON` or `<workspace>/.venv/bin/python` (python-canopen, python-can and
//! msgpack importable); without them the test prints that it skipped, unless
//! `CANOPEN_REQUIRE_PYTHON=1`.

use std::io::{BufRead, BufReader, Write};
use std::net::{Ipv4Addr, SocketAddrV4};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration as StdDuration;

use canola::Value;
use canola::pdo::{PdoCobId, TransmissionType};
use canola::udp::UdpMulticast;
use canola::{Network, NetworkEvent, ObjectAddress, Transmission};
use canola_frame::{CanId, Duration, NodeId};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");
const PEER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/py/pdo_peer.py");

fn python() -> Option<String> {
    let python = std::env::var("CANOPEN_PYTHON").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../.venv/bin/python").to_string()
    });
    let ok = Command::new(&python)
        .args(["-c", "import canopen, can, msgpack"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        return Some(python);
    }
    assert!(
        std::env::var("CANOPEN_REQUIRE_PYTHON").is_err(),
        "CANOPEN_REQUIRE_PYTHON is set but {python} cannot import canopen, can and msgpack"
    );
    eprintln!("skipped: {python} cannot import canopen, can and msgpack");
    None
}

/// The next line from the peer that starts with `prefix`, within `secs` seconds.
fn expect(lines: &mpsc::Receiver<String>, prefix: &str, secs: u64) -> String {
    let end = std::time::Instant::now() + StdDuration::from_secs(secs);
    while let Some(left) = end.checked_duration_since(std::time::Instant::now()) {
        match lines.recv_timeout(left) {
            Ok(line) if line.starts_with(prefix) => return line,
            Ok(_) => {}
            Err(_) => break,
        }
    }
    panic!("the python peer did not print {prefix:?} within {secs} s");
}

#[test]
fn pdos_with_python_canopen_as_the_device() {
    let Some(python) = python() else {
        return;
    };
    // A group and port of this test's own, so parallel runs do not meet.
    let port = 40000 + (std::process::id() % 10000) as u16;
    let group = SocketAddrV4::new(Ipv4Addr::new(239, 74, 163, 40), port);
    let mut peer = Command::new(python)
        .args([PEER, &group.ip().to_string(), &port.to_string(), EDS])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("python starts");
    let (tx, lines) = mpsc::channel();
    let stdout = peer.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut stdin = peer.stdin.take().unwrap();
    expect(&lines, "READY", 20);

    let net = Network::new(UdpMulticast::open(group).unwrap());
    net.start_driver().unwrap();
    let id = NodeId::new(5).unwrap();
    let od = canola::od::parse(&std::fs::read(EDS).unwrap()[..])
        .unwrap()
        .od;
    let node = net.add_node_with_dictionary(id, od);
    let events = net.subscribe();

    let mut tpdos = node.tpdo().read().wait().unwrap();
    let t1 = tpdos.get_mut(1).unwrap();
    assert_eq!(t1.comm.cob_id, PdoCobId(0x185));
    assert_eq!(t1.transmission_type(), TransmissionType::EventManufacturer);
    assert_eq!(t1.event_timer(), Duration::from_millis(1000));
    assert_eq!(t1.mapped.len(), 2);
    t1.set_can_id(CanId::standard(0x1F0).unwrap());
    t1.set_transmission_type(TransmissionType::EventProfile);
    t1.set_event_timer(Duration::ZERO).unwrap();
    t1.clear();
    t1.map("Device Status Object.Device Status NamurNe107")
        .unwrap();
    t1.map("Sensor Value 1.Value").unwrap();
    node.tpdo().save(&mut tpdos).wait().unwrap();

    let rpdos = node.rpdo().read().wait().unwrap();
    assert_eq!(rpdos.get(1).unwrap().comm.cob_id, PdoCobId(0x205));
    let rpdo1 = node
        .rpdo()
        .start(rpdos.get(1).unwrap(), Transmission::on_change())
        .unwrap();
    rpdo1
        .set_many([
            ("Control Value 1.Value", 12.5f32),
            ("Control Value 2.Value", -3.0f32),
        ])
        .unwrap();
    assert_eq!(expect(&lines, "RPDO1", 10), "RPDO1 12.5 -3.0");

    writeln!(stdin, "TPDO").unwrap();
    assert_eq!(
        expect(&lines, "TPDO1", 10),
        "TPDO1 cob=0x1f0 enabled=True type=255 event=0 map=2004:01/8,2500:01/32"
    );
    expect(&lines, "SENT", 10);
    let end = std::time::Instant::now() + StdDuration::from_secs(10);
    let values = loop {
        let left = end
            .checked_duration_since(std::time::Instant::now())
            .expect("TPDO1 from python-canopen decoded within 10 s");
        if let Ok(NetworkEvent::PdoValues {
            number: 1, values, ..
        }) = events.recv_timeout(left)
        {
            break values;
        }
    };
    assert_eq!(
        values,
        [
            (ObjectAddress::new(0x2004, 1), Value::Unsigned8(3)),
            (ObjectAddress::new(0x2500, 1), Value::Real32(21.5)),
        ]
    );
    writeln!(stdin, "QUIT").unwrap();
    drop(stdin);
    let _ = peer.wait();
    net.stop_driver().unwrap();
}
