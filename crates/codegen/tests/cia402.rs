//! A CiA 402 drive's EDS through the generator like any device's: the checked-in output of the
//! facade preset for `eds/cia402-servo.eds` (kept current by the golden test) compiled here and
//! run against the device simulator built from the same EDS on the in-memory bus. The TPDO2
//! struct decodes the statusword and position actual value the device sends on SYNC, the RPDO2
//! struct builds the controlword and target position the device takes on the next SYNC, and the
//! typed client reads and writes the profile objects.

use canola::transport::Transport;
use canola::{CanFrame, CanId, Duration, MemoryBus, Network, NodeId, Received, SimDevice};

// The workspace warns on `pub` items a crate does not export; a test crate exports none.
#[allow(unreachable_pub, dead_code)]
mod servo {
    include!("golden/cia402-servo.rs");
}
use servo::client::Device;
use servo::{Rpdo2, Tpdo2};

const EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");

fn node() -> NodeId {
    NodeId::new(3).unwrap()
}

#[test]
fn the_position_tpdo_decodes_into_its_struct() {
    let bus = MemoryBus::new();
    let mut raw = bus.endpoint();
    let net = Network::new(bus.endpoint());
    let device = bus.attach(SimDevice::from_eds(node(), EDS).unwrap());
    net.node(node()).nmt().start().unwrap();
    let now = bus.now();
    bus.with_station(device, |d| {
        d.set_value(now, 0x6041, 0, 0x0637u16.to_le_bytes());
        d.set_value(now, 0x6064, 0, (-123_456i32).to_le_bytes());
    });
    net.start_sync(Duration::from_millis(5));
    net.run_for(Duration::from_millis(20)).wait().unwrap();

    let id = Tpdo2::cob_id(node()).unwrap().can_id().unwrap();
    assert_eq!(id.as_raw(), 0x280 + 3);
    let mut last = None;
    while let Some(r) = raw.try_recv().unwrap() {
        if let Received::Frame { frame, .. } = r
            && frame.id() == id
        {
            last = Some(frame);
        }
    }
    let frame = last.expect("TPDO2 on SYNC");
    // Statusword in bytes 0..2, position actual value in bytes 2..6 (little-endian).
    assert_eq!(frame.data(), [0x37, 0x06, 0xC0, 0x1D, 0xFE, 0xFF]);
    assert_eq!(
        Tpdo2::from_frame(&frame).unwrap(),
        Tpdo2 {
            statusword: 0x0637,
            position_actual_value: -123_456,
        }
    );
}

#[test]
fn the_target_rpdo_built_by_its_struct_reaches_the_device_and_the_client_reads_it_back() {
    let bus = MemoryBus::new();
    let mut raw = bus.endpoint();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(node(), EDS).unwrap());
    let dev = Device::new(net.node(node()));
    net.node(node()).nmt().start().unwrap();
    net.run_for(Duration::from_millis(10)).wait().unwrap();

    let frame = Rpdo2 {
        controlword: 0x000F,
        target_position: -5_000,
    }
    .to_frame(node())
    .unwrap();
    assert_eq!(frame.id().as_raw(), 0x300 + 3);
    assert_eq!(frame.data(), [0x0F, 0x00, 0x78, 0xEC, 0xFF, 0xFF]);
    raw.send(&frame).unwrap();
    // RPDO2 is synchronous (type 1): the device takes it on the next SYNC.
    raw.send(&CanFrame::new(CanId::standard(0x080).unwrap(), &[]).unwrap())
        .unwrap();
    net.run_for(Duration::from_millis(10)).wait().unwrap();
    assert_eq!(dev.controlword().read().wait().unwrap(), 0x000F);
    assert_eq!(dev.target_position().read().wait().unwrap(), -5_000);

    // Typed objects of the profile through the client.
    dev.modes_of_operation().write(8).wait().unwrap();
    assert_eq!(dev.modes_of_operation().read().wait().unwrap(), 8i8);
    assert_eq!(
        dev.device_type().read().wait().unwrap() & 0xFFFF,
        402,
        "0x1000 names the profile"
    );
}
