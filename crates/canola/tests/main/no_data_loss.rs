//! A streamed upload reports a writer that cannot take the data, also when the failure only
//! shows when the writer is flushed (a buffered writer over a full disk).

use std::io::{BufWriter, Write};

use canola::mem::MemoryBus;
use canola::{Error, Network, SdoErrorKind, SimDevice};
use canola_frame::NodeId;

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

/// Takes nothing: like writing to `/dev/full`.
struct Full;

impl Write for Full {
    fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
        Err(std::io::Error::new(
            std::io::ErrorKind::StorageFull,
            "no space left on device",
        ))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_failing_flush_fails_the_upload() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5).unwrap();
    bus.attach(SimDevice::from_eds(id, EDS).unwrap());
    // Segmented (23 bytes): the buffered writer takes every segment, then fails on flush.
    let e = net
        .node(id)
        .sdo()
        .upload_to((0x1008, 0), BufWriter::new(Full))
        .wait()
        .unwrap_err();
    let Error::Sdo(e) = &e else {
        panic!("expected an SDO error, got {e}");
    };
    assert!(
        matches!(
            e.kind,
            SdoErrorKind::Io {
                kind: std::io::ErrorKind::StorageFull,
                ..
            }
        ),
        "{e}"
    );
    // Unbuffered, the first write fails and the transfer is aborted.
    let e = net
        .node(id)
        .sdo()
        .upload_to((0x1008, 0), Full)
        .wait()
        .unwrap_err();
    assert!(e.to_string().contains("no space left"), "{e}");
    // The node is free for the next request.
    assert_eq!(
        net.node(id).sdo().read((0x1008, 0)).wait().unwrap(),
        b"Buerkert generic device"
    );
}
