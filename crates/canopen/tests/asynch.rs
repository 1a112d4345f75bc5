//! The async API: the same core, futures on top; dropping a future cancels its request.
#![cfg(feature = "tokio")]

use can_frame::{Duration, NodeId};
use canopen::mem::{BusConfig, ClockMode, MemoryBus};
use canopen::transport::{Received, Transport};
use canopen::{Network, SimDevice};

const EDS: &[u8] = include_bytes!("../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn real_time_bus() -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        clock: ClockMode::RealTime,
        ..BusConfig::default()
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn async_reads_and_writes_run_in_parallel() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    for id in [5, 6] {
        bus.attach(SimDevice::from_eds(n(id), EDS).unwrap());
    }
    let a = net.node(n(5)).sdo().write_async((0x1017, 0), 123u16);
    let b = net.node(n(6)).sdo().read_async((0x1018, 1));
    let (a, b) = tokio::join!(a, b);
    a.unwrap();
    assert_eq!(b.unwrap(), 0x39u32.to_le_bytes());
    assert_eq!(
        net.node(n(5)).sdo().read_async((0x1017, 0)).await.unwrap(),
        123u16.to_le_bytes()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropping_the_future_sends_an_abort_and_frees_the_node() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    let mut tap = bus.endpoint();
    // No device yet: the read cannot complete before the future is dropped.
    let fut = net
        .node(n(5))
        .sdo()
        .timeout(Duration::from_secs(10))
        .read_async((0x1018, 1));
    let r = tokio::time::timeout(std::time::Duration::from_millis(50), fut).await;
    assert!(r.is_err(), "the read cannot finish without a device");
    // The abort goes out promptly.
    let deadline = tap.now() + Duration::from_secs(2);
    let mut abort = None;
    while let Ok(Some(got)) = tap.recv_until(deadline) {
        if let Received::Frame { frame, .. } = got
            && frame.cob_id() == Some(0x605)
            && frame.data()[0] == 0x80
        {
            abort = Some(frame);
            break;
        }
    }
    let abort = abort.expect("cancel sent an SDO abort");
    assert_eq!(&abort.data()[4..8], &0x0800_0000u32.to_le_bytes());
    // The node is free: the next request completes once a device is there.
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    assert_eq!(
        net.node(n(5)).sdo().read_async((0x1017, 0)).await.unwrap(),
        500u16.to_le_bytes()
    );
}
