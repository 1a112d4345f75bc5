//! A thread that drives the network itself: `Network::run_step` around several `Pending`
//! requests, and `Sdo::submit_upload_to`, the streamed upload as a `Pending` (in-memory bus,
//! virtual clock).

use std::io::Write;
use std::sync::{Arc, Mutex};

use canola::{MemoryBus, Network, SdoErrorKind, SimDevice};
use canola_frame::{Duration, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn network(ids: &[u8]) -> (Network, MemoryBus) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for &id in ids {
        bus.attach(SimDevice::from_eds(n(id), EDS).unwrap());
    }
    (net, bus)
}

/// Keeps what it is given, up to `limit` bytes.
struct Sink {
    buf: Arc<Mutex<Vec<u8>>>,
    limit: usize,
}

impl Write for Sink {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        let mut b = self.buf.lock().unwrap();
        if b.len() + data.len() > self.limit {
            return Err(std::io::Error::other("full"));
        }
        b.extend_from_slice(data);
        Ok(data.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn steps_finish_requests_to_several_nodes() {
    let (net, _bus) = network(&[5, 6, 7]);
    let a = net.node(n(5)).sdo().submit_read((0x1017, 0));
    let b = net.node(n(6)).sdo().submit_write((0x1017, 0), 250u16);
    let c = net.node(n(7)).sdo().submit_read((0x1018, 1));
    let mut steps = 0;
    while !(a.is_done() && b.is_done() && c.is_done()) {
        net.run_step(Duration::from_millis(1)).unwrap();
        steps += 1;
        assert!(steps < 1000, "the requests never finished");
    }
    assert_eq!(a.wait().unwrap(), 500u16.to_le_bytes());
    b.wait().unwrap();
    assert_eq!(c.wait().unwrap(), 0x39u32.to_le_bytes());
    assert_eq!(
        net.node(n(6)).sdo().read((0x1017, 0)).wait().unwrap(),
        250u16.to_le_bytes()
    );
}

#[test]
fn a_quiet_step_runs_no_longer_than_its_limit() {
    let (net, _bus) = network(&[]);
    let before = net.now();
    assert!(!net.run_step(Duration::from_micros(300)).unwrap());
    let ran = net.now() - before;
    assert!(ran <= Duration::from_micros(300), "{ran:?}");
    // Nor longer than the driving slice when the limit is longer.
    let before = net.now();
    net.run_step(Duration::from_secs(1)).unwrap();
    assert!(net.now() - before <= Duration::from_millis(2));
}

#[test]
fn a_streamed_upload_runs_as_a_pending_request() {
    let (net, _bus) = network(&[5]);
    // The device name (0x1008), a segmented upload.
    let whole = net.node(n(5)).sdo().read((0x1008, 0)).wait().unwrap();
    assert!(whole.len() > 4);
    let buf = Arc::new(Mutex::new(Vec::new()));
    let sink = Sink {
        buf: buf.clone(),
        limit: 1024,
    };
    let p = net.node(n(5)).sdo().submit_upload_to((0x1008, 0), sink);
    while !p.is_done() {
        net.run_step(Duration::from_millis(1)).unwrap();
    }
    assert_eq!(p.wait().unwrap(), whole.len() as u64);
    assert_eq!(*buf.lock().unwrap(), whole);

    // A writer that refuses the data ends the request with an I/O error.
    let small = Sink {
        buf: Arc::new(Mutex::new(Vec::new())),
        limit: 2,
    };
    let p = net.node(n(5)).sdo().submit_upload_to((0x1008, 0), small);
    let e = p.wait().unwrap_err();
    assert!(matches!(e.kind, SdoErrorKind::Io { .. }), "{e:?}");
}
