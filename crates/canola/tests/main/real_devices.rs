//! Habits of real devices the master must take, through the facade on the virtual-clock bus: a
//! simulated device answering expedited uploads without the size indicated (`42 …`, four data
//! bytes), as devices that always send four bytes do, read with the typed reads; and an
//! expedited answer in a frame shorter than eight bytes.

use canola::mem::MemoryBus;
use canola::sim::Quirks;
use canola::transport::{Received, Transport};
use canola::{Network, SimDevice, Value};
use canola_frame::{Duration, NodeId};
use canola_od::{DataType, Entry};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn rig() -> (MemoryBus, Network) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let quirks = Quirks::default().with_expedited_without_size(true);
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap().with_quirks(quirks));
    net.add_node_with_dictionary(n(5), canola_od::parse(EDS).unwrap().od);
    (bus, net)
}

#[test]
fn the_quirk_sends_42_and_four_bytes() {
    let (bus, net) = rig();
    let mut tap = bus.endpoint();
    let raw = net.node(n(5)).sdo().read((0x1017, 0)).wait().unwrap();
    // The raw read hands back what the device sent: all four bytes.
    assert_eq!(raw.len(), 4);
    assert_eq!(raw[..2], 500u16.to_le_bytes());
    let now = tap.now();
    let mut answer = None;
    while let Ok(Some(r)) = tap.recv_until(now + Duration::from_millis(1)) {
        if let Received::Frame { frame, .. } = r
            && frame.cob_id() == Some(0x585)
        {
            answer = Some(frame.data().to_vec());
        }
    }
    let answer = answer.expect("an SDO answer on the bus");
    assert_eq!(answer[0], 0x42, "{answer:02X?}");
    assert_eq!(answer[4..6], 500u16.to_le_bytes());
}

#[test]
fn typed_reads_take_the_type_length_of_an_answer_without_size() {
    let (_bus, net) = rig();
    let sdo = || net.node(n(5)).sdo();
    // UNSIGNED16 (producer heartbeat time) and UNSIGNED8 (error register).
    assert_eq!(
        sdo().read_value((0x1017, 0)).wait().unwrap(),
        Value::Unsigned16(500)
    );
    assert_eq!(
        sdo().get((0x1017, 0)).wait().unwrap(),
        Value::Unsigned16(500)
    );
    assert_eq!(
        sdo()
            .read_as((0x1001, 0), DataType::Unsigned8)
            .wait()
            .unwrap(),
        Value::Unsigned8(0)
    );
    let hb: Entry<u16> = Entry::new(0x1017, 0, DataType::Unsigned16);
    assert_eq!(sdo().read_entry(&hb).wait().unwrap(), 500);
    let reg: Entry<u8> = Entry::new(0x1001, 0, DataType::Unsigned8);
    assert_eq!(sdo().read_entry(&reg).wait().unwrap(), 0);
    // A four-byte type is unchanged.
    assert_eq!(
        sdo().read_value((0x1018, 1)).wait().unwrap(),
        Value::Unsigned32(0x39)
    );
}

#[cfg(feature = "tokio")]
#[tokio::test(start_paused = true)]
async fn async_typed_reads_take_the_type_length_too() {
    let (_bus, net) = rig();
    let sdo = || net.node(n(5)).sdo();
    assert_eq!(
        sdo().read_value((0x1017, 0)).await.unwrap(),
        Value::Unsigned16(500)
    );
    let reg: Entry<u8> = Entry::new(0x1001, 0, DataType::Unsigned8);
    assert_eq!(sdo().read_entry(&reg).await.unwrap(), 0);
}

/// A device that answers an expedited upload with a frame only as long as its data (DLC 5:
/// `4F 00 14 02 FE`), as some devices do.
struct ShortAnswers {
    out: Option<canola::CanFrame>,
}

impl canola::Station for ShortAnswers {
    fn handle_frame(&mut self, _now: canola::Instant, frame: &canola::CanFrame) {
        let d = frame.data();
        if frame.cob_id() == Some(0x605) && d.len() == 8 && d[0] == 0x40 {
            let id = canola::CanId::standard(0x585).unwrap();
            self.out = Some(canola::CanFrame::new(id, &[0x4F, d[1], d[2], d[3], 0xFE]).unwrap());
        }
    }
    fn handle_timeout(&mut self, _now: canola::Instant) {}
    fn poll_transmit(&mut self) -> Option<canola::CanFrame> {
        self.out.take()
    }
    fn poll_timeout(&self) -> Option<canola::Instant> {
        None
    }
}

#[test]
fn an_expedited_answer_shorter_than_eight_bytes_is_taken() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(ShortAnswers { out: None });
    let sdo = || net.node(n(5)).sdo().timeout(Duration::from_millis(100));
    assert_eq!(sdo().read((0x1400, 2)).wait().unwrap(), [0xFE]);
    assert_eq!(
        sdo()
            .read_as((0x1400, 2), DataType::Unsigned8)
            .wait()
            .unwrap(),
        Value::Unsigned8(0xFE)
    );
}
