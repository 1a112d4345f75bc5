//! The async API: the same core, futures on top; dropping a future cancels its request.

use canola::mem::{BusConfig, ClockMode, MemoryBus};
use canola::transport::{Received, Transport};
use canola::{Network, SimDevice};
use canola_frame::{Duration, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

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
    let a = net.node(n(5)).sdo().write((0x1017, 0), 123u16);
    let b = net.node(n(6)).sdo().read((0x1018, 1));
    let (a, b) = tokio::join!(a, b);
    a.unwrap();
    assert_eq!(b.unwrap(), 0x39u32.to_le_bytes());
    assert_eq!(
        net.node(n(5)).sdo().read((0x1017, 0)).await.unwrap(),
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
        .read((0x1018, 1));
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
        net.node(n(5)).sdo().read((0x1017, 0)).await.unwrap(),
        500u16.to_le_bytes()
    );
}

// ---------------------------------------------------------------------------------------------
// The virtual bus under tokio's clock: virtual time follows tokio's (paused here: it jumps to
// the earliest timer whenever every task is idle, so these tests take microseconds).

use canola::lss::{
    AssignConfig, FastscanConfig, LssAddress, Mode, NodeIdPool, Procedure, SlaveConfig, Step,
};
use canola::{CanFrame, CanId, CommandSpecifier, Error, NetworkEvent, NmtState, Value};
use canola::{Instant, Lagged};

/// Waits (on the network's tokio-tied clock) for an SDO abort from the master to `node`.
fn abort_to(tap: &mut canola::Endpoint, node: u8) -> Option<CanFrame> {
    while let Ok(Some(got)) = tap.try_recv() {
        if let Received::Frame { frame, .. } = got
            && frame.cob_id() == Some(0x600 + u16::from(node))
            && frame.data()[0] == 0x80
        {
            return Some(frame);
        }
    }
    None
}

#[tokio::test(start_paused = true)]
async fn a_tokio_timeout_around_a_read_on_the_virtual_bus_fires_first_and_aborts() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    assert!(net.is_virtual_clock());
    let mut tap = bus.endpoint();
    let t0 = tokio::time::Instant::now();
    let v0 = net.now();
    // Nobody answers: the SDO's own timeout would end the read after 10 s.
    let read = net
        .node(n(5))
        .sdo()
        .timeout(Duration::from_secs(10))
        .read((0x1018, 1));
    let r = tokio::time::timeout(std::time::Duration::from_millis(50), read).await;
    assert!(r.is_err(), "the tokio timeout fires before the SDO timeout");
    assert_eq!(t0.elapsed(), std::time::Duration::from_millis(50));
    // The bus followed tokio's clock: 50 ms of virtual time, not 10 s.
    let v = net.now() - v0;
    assert!(v <= Duration::from_millis(50), "virtual time passed: {v}");
    // The dropped read sent its abort, and the node is free for the next request.
    let abort = abort_to(&mut tap, 5).expect("cancel sent an SDO abort");
    assert_eq!(&abort.data()[4..8], &0x0800_0000u32.to_le_bytes());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    assert_eq!(
        net.node(n(5)).sdo().read((0x1017, 0)).await.unwrap(),
        500u16.to_le_bytes()
    );
}

#[tokio::test(start_paused = true)]
async fn an_unanswered_read_times_out_after_its_timeout_of_tokio_time() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let t0 = tokio::time::Instant::now();
    let r = net
        .node(n(7))
        .sdo()
        .timeout(Duration::from_secs(10))
        .read((0x1000, 0))
        .await;
    match r {
        Err(Error::Sdo(e)) => assert!(e.to_string().contains("time"), "{e}"),
        other => panic!("{other:?}"),
    }
    let elapsed = t0.elapsed();
    assert!(
        elapsed >= std::time::Duration::from_secs(10)
            && elapsed < std::time::Duration::from_millis(10_010),
        "{elapsed:?}"
    );
    assert!(net.now() >= Instant::ZERO + Duration::from_secs(10));
}

#[tokio::test(start_paused = true)]
async fn blocking_steps_jump_ahead_and_the_async_side_goes_on_from_there() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    net.node(n(5)).sdo().read((0x1017, 0)).await.unwrap();
    // The stepping API still jumps virtual time at once (no tokio time passes).
    let t0 = tokio::time::Instant::now();
    let before = net.now();
    net.run_for(Duration::from_secs(3)).wait().unwrap();
    assert_eq!(t0.elapsed(), std::time::Duration::ZERO);
    assert!(net.now() >= before + Duration::from_secs(3));
    // Async time goes on from there, never back.
    let mid = net.now();
    net.run_for(Duration::from_millis(200)).await.unwrap();
    assert_eq!(t0.elapsed(), std::time::Duration::from_millis(200));
    assert!(net.now() >= mid + Duration::from_millis(200));
}

#[tokio::test(start_paused = true)]
async fn nmt_commands_and_state_waits() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    // The device's first boot-up is received; boot-ups count for waits from `add_node`, so
    // a wait after it waits for the next one.
    net.run_for(Duration::from_millis(1)).await.unwrap();
    let nmt = net.add_node(n(5)).nmt();
    // Nothing happened since the node was added: a boot-up wait times out on tokio's clock.
    let t0 = tokio::time::Instant::now();
    match nmt.wait_for_bootup(Duration::from_millis(200)).await {
        Err(Error::Timeout { .. }) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(t0.elapsed(), std::time::Duration::from_millis(200));
    // Reset, then the boot-up (counted, not missed even if a heartbeat follows at once).
    nmt.reset_node().unwrap();
    nmt.wait_for_bootup(Duration::from_secs(1)).await.unwrap();
    nmt.start().unwrap();
    // Heartbeats every 500 ms (0x1017 default) report the new state.
    // std's Duration works as well.
    nmt.wait_for_state(NmtState::Operational, std::time::Duration::from_secs(1))
        .await
        .unwrap();
    assert_eq!(nmt.state(), Some(NmtState::Operational));
    nmt.stop().unwrap();
    nmt.wait_for_state(NmtState::Stopped, Duration::from_secs(1))
        .await
        .unwrap();
    net.nmt_all(CommandSpecifier::EnterPreOperational).unwrap();
    nmt.wait_for_state(NmtState::PreOperational, Duration::from_secs(1))
        .await
        .unwrap();
    // Waits are per node.
    assert!(matches!(
        canola::Nmt::all(&net)
            .wait_for_state(NmtState::Operational, Duration::from_secs(1))
            .await,
        Err(Error::InvalidRequest(_))
    ));
}

#[tokio::test(start_paused = true)]
async fn typed_access_by_name() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(EDS).unwrap().od;
    bus.attach(SimDevice::new(n(5), od.clone()));
    let node = net.add_node_with_dictionary(n(5), od);
    node.sdo()
        .set("Producer heartbeat time", 200)
        .await
        .unwrap();
    // Two bytes went out: the UNSIGNED16 reads back as itself.
    assert_eq!(
        node.sdo().read((0x1017, 0)).await.unwrap(),
        200u16.to_le_bytes()
    );
    assert_eq!(
        node.sdo().get("producer heartbeat TIME").await.unwrap(),
        Value::Unsigned16(200)
    );
    // A value that does not fit fails before anything is sent.
    let e = node
        .sdo()
        .set("Producer heartbeat time", 70_000)
        .await
        .unwrap_err();
    assert!(matches!(e, Error::Value { .. }), "{e}");
}

#[tokio::test(start_paused = true)]
async fn scan_finds_the_nodes_in_one_timeout() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for id in [3, 9, 120] {
        bus.attach(SimDevice::from_eds(n(id), EDS).unwrap());
    }
    let t0 = tokio::time::Instant::now();
    let found = net.scan(Duration::from_millis(100)).await.unwrap();
    let ids: Vec<u8> = found.iter().map(|s| s.node.get()).collect();
    assert_eq!(ids, [3, 9, 120]);
    assert!(found.iter().all(|s| s.identity.vendor_id == 0x39));
    // All 127 reads ran at once: one response timeout, not 124 of them.
    assert!(t0.elapsed() < std::time::Duration::from_millis(300));
    // The same as the blocking scan.
    assert_eq!(net.scan(Duration::from_millis(100)).wait().unwrap(), found);
}

#[tokio::test(start_paused = true)]
async fn dropping_a_scan_cancels_its_reads() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut tap = bus.endpoint();
    let scan = net.scan(Duration::from_secs(5));
    assert!(
        tokio::time::timeout(std::time::Duration::from_millis(20), scan)
            .await
            .is_err()
    );
    let mut aborts = 0;
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        if frame.data().first() == Some(&0x80) {
            aborts += 1;
        }
    }
    assert_eq!(aborts, 127, "one abort per running read");
}

fn lss_address(i: u32) -> LssAddress {
    LssAddress::new(0x39, 0x0100_0001, 1, 1001 + i * 0x0101_0101)
}

#[tokio::test(start_paused = true)]
async fn lss_services_and_assign_all() {
    let od = canola::od::parse(EDS).unwrap().od;
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    for i in 0..3 {
        bus.attach(SimDevice::unconfigured_with(
            od.clone(),
            SlaveConfig::unconfigured_real(lss_address(i)),
        ));
    }
    let lss = net.lss();
    // Fastscan finds the lowest address and leaves it in configuration state.
    let one = lss.fastscan(FastscanConfig::default()).await.unwrap();
    assert!(one.is_some());
    lss.procedure(Procedure::single(Step::SwitchModeGlobal(Mode::Waiting)))
        .await
        .unwrap();
    let found = lss.discover_all(FastscanConfig::default()).await.unwrap();
    assert_eq!(found, (0..3).map(lss_address).collect::<Vec<_>>());
    let pool = NodeIdPool::range(n(10), NodeId::MAX);
    let report = lss.assign_all(AssignConfig::with_pool(pool)).await.unwrap();
    let assigned: Vec<_> = report.assigned().collect();
    assert_eq!(assigned.len(), 3, "{report:?}");
    net.run_for(Duration::from_millis(10)).await.unwrap();
    for (a, id) in assigned {
        assert_eq!(
            net.node(id).sdo().read((0x1018, 4)).await.unwrap(),
            a.serial_number.to_le_bytes()
        );
    }
}

/// Sends TPDO1 of node 1 every millisecond, numbered, `left` times.
struct Counter {
    next: Instant,
    sent: u16,
    left: u16,
    out: Option<CanFrame>,
}

impl canola::Station for Counter {
    fn handle_frame(&mut self, _: Instant, _: &CanFrame) {}
    fn handle_timeout(&mut self, now: Instant) {
        if self.left > 0 && now >= self.next {
            let id = CanId::standard(0x181).unwrap();
            self.out = Some(CanFrame::new(id, &self.sent.to_le_bytes()).unwrap());
            self.sent += 1;
            self.left -= 1;
            self.next = now + Duration::from_millis(1);
        }
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.take()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        (self.left > 0).then_some(self.next)
    }
}

/// The numbers of the PDO events a subscriber saw, and what it lost.
async fn collect(
    mut events: canola::EventStream,
    pause: std::time::Duration,
) -> (Vec<u16>, Vec<u64>) {
    let (mut got, mut lost) = (Vec::new(), Vec::new());
    while let Some(item) = events.next().await {
        match item {
            Ok(NetworkEvent::Pdo { data, .. }) => got.push(u16::from_le_bytes([data[0], data[1]])),
            Ok(_) => {}
            Err(Lagged(k)) => lost.push(k),
        }
        if !pause.is_zero() {
            tokio::time::sleep(pause).await;
        }
    }
    (got, lost)
}

#[tokio::test(start_paused = true)]
async fn events_reach_every_subscriber_and_lag_is_reported_not_hidden() {
    const N: u16 = 200;
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let fast = net.events_with_capacity(16);
    let slow = net.events_with_capacity(8);
    bus.attach(Counter {
        next: Instant::ZERO + Duration::from_millis(1),
        sent: 0,
        left: N,
        out: None,
    });
    let fast = tokio::spawn(collect(fast, std::time::Duration::ZERO));
    // Four times slower than the producer.
    let slow = tokio::spawn(collect(slow, std::time::Duration::from_millis(4)));
    // The driver: N ms of frames, then the network goes and the streams end.
    net.run_for(Duration::from_millis(u64::from(N) + 10))
        .await
        .unwrap();
    drop(net);
    let (fast_got, fast_lost) = fast.await.unwrap();
    let (slow_got, slow_lost) = slow.await.unwrap();
    assert_eq!(
        fast_got,
        (0..N).collect::<Vec<_>>(),
        "the fast subscriber saw all"
    );
    assert!(fast_lost.is_empty());
    assert!(!slow_lost.is_empty(), "the slow subscriber fell behind");
    // Nothing silent: what the slow one saw, in order, plus what it was told it lost, is all.
    assert!(slow_got.windows(2).all(|w| w[0] < w[1]), "{slow_got:?}");
    let lost: u64 = slow_lost.iter().sum();
    assert_eq!(slow_got.len() as u64 + lost, u64::from(N));
    assert_eq!(
        slow_got.last(),
        Some(&(N - 1)),
        "the newest events are kept"
    );
}

#[tokio::test(start_paused = true)]
async fn a_lagged_item_stands_where_the_events_were_lost() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut events = net.events_with_capacity(3);
    let mut tap = bus.endpoint();
    for i in 0..5u16 {
        tap.send(&CanFrame::new(CanId::standard(0x181).unwrap(), &i.to_le_bytes()).unwrap())
            .unwrap();
    }
    net.run_for(Duration::from_millis(1)).await.unwrap();
    let mut seen = Vec::new();
    while let Some(item) = events.try_next() {
        seen.push(match item {
            Ok(NetworkEvent::Pdo { data, .. }) => format!("{}", data[0]),
            Ok(other) => format!("{other:?}"),
            Err(Lagged(k)) => format!("lagged {k}"),
        });
    }
    assert_eq!(seen, ["lagged 2", "2", "3", "4"]);
}

// ---------------------------------------------------------------------------------------------
// Real-clock transports: the waits run on tokio's blocking pool.

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waits_on_a_real_clock_bus_and_a_dropped_wait_ends() {
    let bus = real_time_bus();
    let net = Network::new(bus.endpoint());
    assert!(!net.is_virtual_clock());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    let nmt = net.node(n(5)).nmt();
    nmt.reset_node().unwrap();
    nmt.wait_for_bootup(Duration::from_secs(2)).await.unwrap();
    // A wait that cannot end, dropped by a timeout: the blocking wait stops, the network goes
    // on serving requests.
    let never = nmt.wait_for_state(NmtState::Stopped, Duration::from_secs(30));
    assert!(
        tokio::time::timeout(std::time::Duration::from_millis(30), never)
            .await
            .is_err()
    );
    let found = net.scan(Duration::from_millis(200)).await.unwrap();
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].node, n(5));
    let mut events = net.events();
    nmt.start().unwrap();
    nmt.wait_for_state(NmtState::Operational, Duration::from_secs(2))
        .await
        .unwrap();
    let mut saw_change = false;
    while let Some(Ok(ev)) = events.try_next() {
        if let NetworkEvent::Heartbeat(canola::HeartbeatEvent::StateChanged { node, .. }) = ev {
            saw_change |= node == n(5);
        }
    }
    assert!(saw_change, "the state change is an event");
}

#[tokio::test(start_paused = true)]
async fn the_driver_on_a_virtual_bus_keeps_it_at_tokio_time() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut events = net.events();
    bus.attach(Counter {
        next: Instant::ZERO + Duration::from_millis(1),
        sent: 0,
        left: 1000,
        out: None,
    });
    net.start_driver_on_runtime();
    assert!(net.is_driven());
    let t0 = tokio::time::Instant::now();
    // Events flow while the test only awaits the stream.
    for want in 0..50u16 {
        match events.next().await {
            Some(Ok(NetworkEvent::Pdo { data, .. })) => {
                assert_eq!(u16::from_le_bytes([data[0], data[1]]), want);
            }
            other => panic!("{other:?}"),
        }
    }
    // One frame per millisecond of tokio time: the bus did not run ahead of it.
    let elapsed = t0.elapsed();
    assert!(
        elapsed >= std::time::Duration::from_millis(49)
            && elapsed <= std::time::Duration::from_millis(51),
        "{elapsed:?}"
    );
    // Requests work beside the driver.
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    assert_eq!(
        net.node(n(5)).sdo().read((0x1018, 1)).await.unwrap(),
        0x39u32.to_le_bytes()
    );
    // Stopped, the bus stands still.
    net.stop_driver().unwrap();
    tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    while events.try_next().is_some() {}
    tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    assert!(events.try_next().is_none(), "no driver, no events");
    // Started again and then let go with the network: the driver ends, the stream ends.
    net.start_driver_on_runtime();
    tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    drop(net);
    let ended = tokio::time::timeout(std::time::Duration::from_secs(1), async {
        while events.next().await.is_some() {}
    })
    .await;
    assert!(ended.is_ok(), "the stream ends when the network is gone");
}

/// A writer whose bytes the test keeps, and whose flush fails when asked to.
#[derive(Clone)]
struct Kept {
    bytes: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
    fail_flush: bool,
}

impl std::io::Write for Kept {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.bytes.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        if self.fail_flush {
            Err(std::io::Error::other("disk full"))
        } else {
            Ok(())
        }
    }
}

#[tokio::test(start_paused = true)]
async fn streamed_upload_and_download() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    let out = Kept {
        bytes: Default::default(),
        fail_flush: false,
    };
    // 0x1008 (device name) is longer than 4 bytes: a segmented upload.
    let n_bytes = net
        .node(n(5))
        .sdo()
        .upload_to((0x1008, 0), out.clone())
        .await
        .unwrap();
    assert_eq!(&out.bytes.lock().unwrap()[..], b"Buerkert generic device");
    assert_eq!(n_bytes, 23);
    // A flush that fails fails the upload: no silent data loss.
    let bad = Kept {
        bytes: Default::default(),
        fail_flush: true,
    };
    let e = net
        .node(n(5))
        .sdo()
        .upload_to((0x1008, 0), bad)
        .await
        .unwrap_err();
    assert!(e.to_string().contains("disk full"), "{e}");
    let sent = net
        .node(n(5))
        .sdo()
        .download_from((0x1017, 0), &300u16.to_le_bytes()[..])
        .await
        .unwrap();
    assert_eq!(sent, 2);
    assert_eq!(
        net.node(n(5)).sdo().read((0x1017, 0)).await.unwrap(),
        300u16.to_le_bytes()
    );
}

/// An endpoint that counts its receive calls.
struct Counting {
    inner: canola::Endpoint,
    calls: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl Transport for Counting {
    fn send(&mut self, frame: &CanFrame) -> Result<(), canola::TransportError> {
        self.inner.send(frame)
    }
    fn recv_until(
        &mut self,
        deadline: Instant,
    ) -> Result<Option<Received>, canola::TransportError> {
        self.calls
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.recv_until(deadline)
    }
    fn now(&self) -> Instant {
        self.inner.now()
    }
    fn is_virtual(&self) -> bool {
        self.inner.is_virtual()
    }
    fn next_event(&self) -> Option<Instant> {
        self.inner.next_event()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waiting_futures_on_a_virtual_bus_in_real_time_sleep_rather_than_spin() {
    let bus = MemoryBus::new();
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let net = Network::new(Counting {
        inner: bus.endpoint(),
        calls: calls.clone(),
    });
    assert!(net.is_virtual_clock());
    // The driver task and two waits that only time can end, side by side, for 300 ms of real
    // time.
    net.start_driver_on_runtime();
    let nmt = net.node(n(5)).nmt();
    let (a, b) = tokio::join!(
        nmt.wait_for_state(NmtState::Stopped, Duration::from_millis(300)),
        net.run_for(Duration::from_millis(300)),
    );
    assert!(matches!(a, Err(Error::Timeout { .. })), "{a:?}");
    b.unwrap();
    // Each catches up to tokio's time when its timer fires (in steps of at most 2 ms), not in
    // a loop that wakes the others: spinning futures would make hundreds of thousands of calls
    // in 300 ms.
    let calls = calls.load(std::sync::atomic::Ordering::Relaxed);
    assert!(calls < 5_000, "{calls} receive calls");
}

/// The PDO services awaited, each in a spawned task (so their futures are `Send`): TPDO1
/// read, changed and saved (the device then sends it from the new COB-ID and the master decodes
/// it), RPDO1 read, started and set; the device takes the value.
#[tokio::test(start_paused = true)]
async fn pdo_services_async() {
    use canola::{CanId, NetworkEvent, Transmission, Value};
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(EDS).unwrap().od;
    let device = bus.attach(SimDevice::new(n(5), od.clone()));
    let node = net.add_node_with_dictionary(n(5), od);
    node.sdo().write((0x1017, 0), 0u16).await.unwrap();
    let events = net.subscribe();

    let tpdo = node.tpdo();
    let saved = tokio::spawn(async move {
        let mut set = tpdo.read().await?;
        let t1 = set.get_mut(1).expect("TPDO1");
        t1.set_can_id(CanId::standard(0x1F0).unwrap());
        t1.set_event_timer(Duration::from_millis(20))?;
        tpdo.save(&mut set).await?;
        Ok::<_, canola::Error>(set)
    })
    .await
    .unwrap()
    .unwrap();
    assert!(!saved.get(1).unwrap().is_changed());
    assert_eq!(node.tpdo().read().await.unwrap(), saved);
    assert_eq!(
        node.sdo().read((0x1800, 1)).await.unwrap(),
        0x1F0u32.to_le_bytes()
    );

    let rpdo = node.rpdo();
    let tx = tokio::spawn(async move {
        let set = rpdo.read().await?;
        let tx = rpdo.start(set.get(1).expect("RPDO1"), Transmission::on_change())?;
        tx.set("Control Value 1.Value", 12.5f32)?;
        Ok::<_, canola::Error>(tx)
    })
    .await
    .unwrap()
    .unwrap();
    node.nmt().start().unwrap();
    tx.trigger().unwrap();
    net.run_for(Duration::from_millis(50)).await.unwrap();
    let held = bus
        .with_station(device, |d| d.values().get(0x2540, 1).map(<[u8]>::to_vec))
        .unwrap();
    assert_eq!(held.as_deref(), Some(&12.5f32.to_le_bytes()[..]));
    assert!(tx.set((0x2500, 1), 1.0f32).is_err(), "not mapped");

    // The device sends TPDO1 from 0x1F0 now: decoded only because the master followed.
    let decoded = events.try_iter().any(|e| {
        matches!(&e, NetworkEvent::PdoValues { node, number: 1, values, .. }
            if *node == n(5) && values.iter().any(|(_, v)| matches!(v, Value::Real32(_))))
    });
    assert!(decoded, "TPDO1 decoded from its new COB-ID");
}

/// `PdoSubscriber::recv` awaited: with the driver on the runtime, a task awaiting PDO batches
/// gets the device's TPDOs decoded, and the end when the network is gone.
#[tokio::test(start_paused = true)]
async fn pdo_batches_async() {
    use canola::Value;
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let od = canola::od::parse(EDS).unwrap().od;
    bus.attach(SimDevice::new(n(5), od.clone()));
    let node = net.add_node_with_dictionary(n(5), od);
    node.sdo().write((0x1017, 0), 0u16).await.unwrap();
    let mut pdos = net.subscribe_pdos();
    net.start_driver_on_runtime();
    node.nmt().start().unwrap();
    let reader = tokio::spawn(async move {
        let mut decoded = Vec::new();
        while let Ok(batch) = pdos.recv().await {
            decoded.extend(
                batch
                    .iter()
                    .filter(|p| p.node == n(5))
                    .map(|p| (p.number, p.values.to_vec())),
            );
        }
        decoded
    });
    tokio::time::sleep(std::time::Duration::from_millis(1500)).await;
    drop(node);
    drop(net);
    let decoded = tokio::time::timeout(std::time::Duration::from_secs(5), reader)
        .await
        .expect("the subscription ends with the network")
        .unwrap();
    let tpdo1 = decoded
        .iter()
        .find(|(n, _)| *n == 1)
        .expect("TPDO1 arrived");
    assert!(
        matches!(tpdo1.1.first(), Some((_, Value::Real32(_)))),
        "{tpdo1:?}"
    );
}
