//! A gateway on the in-memory bus with simulated devices from the Bürkert EDS, and a line client
//! over a Unix socket pair.

#![allow(dead_code, unreachable_pub)]

use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::time::Duration;

use canola::frame::NodeId;
use canola::{MemoryBus, Network, SimDevice};
use canola_gateway::{Config, Gateway};

pub const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

/// A gateway and the bus, with devices at `nodes` (their dictionaries known to the master).
pub fn gateway(nodes: &[u8], config: Config) -> (Gateway, MemoryBus) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(EDS).unwrap().od;
    for &n in nodes {
        let id = NodeId::new(n).unwrap();
        bus.attach(SimDevice::new(id, od.clone()));
        net.add_node_with_dictionary(id, od.clone());
    }
    (Gateway::new(net, config), bus)
}

/// A connection to the gateway.
pub struct Client {
    pub writer: UnixStream,
    pub reader: BufReader<UnixStream>,
}

impl Client {
    pub fn connect(gw: &Gateway) -> Self {
        let (ours, theirs) = UnixStream::pair().unwrap();
        let gw = gw.clone();
        let w = theirs.try_clone().unwrap();
        std::thread::spawn(move || gw.serve_stream(theirs, w));
        ours.set_read_timeout(Some(Duration::from_secs(30)))
            .unwrap();
        Self {
            writer: ours.try_clone().unwrap(),
            reader: BufReader::new(ours),
        }
    }

    pub fn send(&mut self, text: &str) {
        self.writer.write_all(text.as_bytes()).unwrap();
    }

    /// One line, with its line end.
    pub fn line(&mut self) -> String {
        let mut s = String::new();
        self.reader.read_line(&mut s).unwrap();
        s
    }

    /// Sends `request` and reads `n` lines.
    pub fn ask(&mut self, request: &str, n: usize) -> String {
        self.send(request);
        (0..n).map(|_| self.line()).collect()
    }
}
