//! Faults on the in-memory bus (virtual clock, 1 Mbit/s timing model), each with its outcome
//! stated exactly: a device power-cycled in the middle of a transfer (its boot-up ends the
//! transfer with its own error), frame loss and duplication across every SDO method, a
//! babbling node on identifier 0x001, and scripted servers that break the SDO protocol (CiA 301 §7.2.4.3). Every check counts or compares;
//! none reads a wall clock.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use canola::frame::CanId;
use canola::mem::StationId;
use canola::sdo::{ErrorKind, Violation};
use canola::{
    AbortCode, BusConfig, CanFrame, Duration, Faults, Instant, MemoryBus, Method, Network, NodeId,
    SdoErrorKind, SimDevice, Station, Transport,
};

const EDS: &[u8] = include_bytes!("../../../../tests/vcan/test-device.eds");
const NODE: u8 = 5;
/// The variable-size object the transfers move (VISIBLE_STRING "Test text").
const BIG: (u16, u8) = (0x2001, 0);

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

fn payload(len: usize, salt: u8) -> Vec<u8> {
    (0..len)
        .map(|i| (i as u8).wrapping_mul(31).wrapping_add(salt) | 0x20)
        .collect()
}

/// The rig's test device with `BIG` holding `big` bytes.
fn device(big: usize) -> SimDevice {
    let mut d = SimDevice::from_eds(n(NODE), EDS).unwrap();
    d.values_mut().set(BIG.0, BIG.1, payload(big, 0));
    d
}

fn bus(faults: Faults) -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        faults,
        ..BusConfig::default()
    })
}

/// Master and one device, the device's boot-up consumed.
fn rig(faults: Faults, big: usize) -> (MemoryBus, Network, StationId<SimDevice>) {
    let bus = bus(Faults::none());
    let net = Network::new(bus.endpoint());
    let dev = bus.attach(device(big));
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    bus.set_faults(faults);
    (bus, net, dev)
}

/// Drives the network in small steps until `cond` holds (bounded).
fn run_until_true(net: &Network, mut cond: impl FnMut() -> bool) {
    for _ in 0..100_000 {
        if cond() {
            return;
        }
        net.run_for(Duration::from_micros(200)).wait().unwrap();
    }
    panic!("condition never held");
}

fn transfer_kind(e: &canola::SdoError) -> ErrorKind {
    match &e.kind {
        SdoErrorKind::Transfer(k) => *k,
        other => panic!("not a transfer error: {other:?} ({e})"),
    }
}

/// [`transfer_kind`] of an SDO error of the API.
fn kind(e: &canola::Error) -> ErrorKind {
    match e {
        canola::Error::Sdo(s) => transfer_kind(s),
        other => panic!("not an SDO error: {other}"),
    }
}

// ---------------------------------------------------------------------------------------------
// A device power-cycled in the middle of a transfer.

/// How long a power-cycled device stays off the bus (shorter than the transfers' response
/// timeout, so the boot-up, not the timeout, ends them).
const OFF: Duration = Duration::from_millis(50);
const POWER_CYCLE_TIMEOUT: Duration = Duration::from_millis(200);

/// Power cycle: the device is taken off the bus, the bus runs for [`OFF`] without it, and a new
/// one (factory values, idle SDO server) is attached, which boots at once (boot-up message
/// 0x700 + node-ID). Returns the new device and the time it was attached.
fn power_cycle(
    bus: &MemoryBus,
    net: &Network,
    dev: StationId<SimDevice>,
    big: usize,
) -> (StationId<SimDevice>, Instant) {
    bus.detach(dev).unwrap();
    net.run_for(OFF).wait().unwrap();
    (bus.attach(device(big)), net.now())
}

/// Checks the outcome every power-cycle test states: the transfer ended with
/// `SdoErrorKind::NodeRebooted`, whose text names the boot-up, in `window` (a transfer the
/// server had answered: within a few frame times of the boot-up, not at the response timeout),
/// and the master sent no SDO abort on the way (the rebooted server has no transfer to abort).
fn assert_ended_by_the_boot_up(
    e: &canola::SdoError,
    ended: Instant,
    window: (Instant, Instant),
    net: &Network,
    tap: &mut canola::Endpoint,
) {
    assert_eq!(e.kind, SdoErrorKind::NodeRebooted, "{e}");
    let text = e.to_string();
    assert!(
        text.contains("node 5 rebooted (boot-up message received) during the transfer"),
        "{text}"
    );
    assert!(
        window.0 <= ended && ended <= window.1,
        "ended at {ended:?}, not in {window:?}"
    );
    // Let whatever the master still queued reach the bus before looking.
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let mut aborts = 0;
    while let Some(r) = tap.try_recv().unwrap() {
        if let canola::Received::Frame { frame, .. } = r
            && frame.cob_id() == Some(0x600 + u16::from(NODE))
            && frame.data().first() == Some(&0x80)
        {
            aborts += 1;
        }
    }
    assert_eq!(
        aborts, 0,
        "the master sent an SDO abort to the rebooted node"
    );
}

#[test]
fn power_cycle_during_a_block_upload_ends_it_naming_the_boot_up_and_the_next_request_works() {
    const LEN: usize = 8 * 1024;
    let (bus, net, dev) = rig(Faults::none(), LEN);
    let mut tap = bus.endpoint();
    let done = Arc::new(AtomicU64::new(0));
    let seen = done.clone();
    let p = net
        .node(n(NODE))
        .sdo()
        .block(true)
        .timeout(POWER_CYCLE_TIMEOUT)
        .on_progress(move |pr| seen.store(pr.done, Ordering::SeqCst))
        .submit_read(BIG);
    run_until_true(&net, || done.load(Ordering::SeqCst) > 0);
    let got = done.load(Ordering::SeqCst);
    assert!(got > 0 && got < LEN as u64, "{got}");
    let (_dev, booted) = power_cycle(&bus, &net, dev, LEN);
    // The segments of the block that were already waiting for the wire still arrive (the
    // in-memory bus keeps a detached station's queued frames) and the client acknowledges
    // the block to nobody; then it waits for the next block, and the boot-up ends the upload.
    let e = p.wait().unwrap_err();
    let ended = net.now();
    println!("block upload cut after {got} bytes: {e}");
    let soon = booted + Duration::from_millis(2);
    assert_ended_by_the_boot_up(&e, ended, (booted, soon), &net, &mut tap);
    // The next request works, and so does the whole upload again.
    let v = net.node(n(NODE)).sdo().read((0x1000, 0)).wait().unwrap();
    assert_eq!(v, 0x0002_0191u32.to_le_bytes());
    let all = net
        .node(n(NODE))
        .sdo()
        .block(true)
        .read(BIG)
        .wait()
        .unwrap();
    assert_eq!(all, payload(LEN, 0));
}

#[test]
fn power_cycle_during_a_segmented_download_ends_it_naming_the_boot_up_and_the_next_request_works() {
    const LEN: usize = 2 * 1024;
    let (bus, net, dev) = rig(Faults::none(), 16);
    let mut tap = bus.endpoint();
    let done = Arc::new(AtomicU64::new(0));
    let seen = done.clone();
    let p = net
        .node(n(NODE))
        .sdo()
        .method(Method::Segmented)
        .timeout(POWER_CYCLE_TIMEOUT)
        .on_progress(move |pr| seen.store(pr.done, Ordering::SeqCst))
        .submit_write(BIG, payload(LEN, 7));
    run_until_true(&net, || done.load(Ordering::SeqCst) >= 70);
    let sent = done.load(Ordering::SeqCst);
    assert!(sent < LEN as u64, "{sent}");
    // The segment on its way reaches nobody; the client waits for its confirmation, and the
    // boot-up ends the download.
    let (dev, booted) = power_cycle(&bus, &net, dev, 16);
    let e = p.wait().unwrap_err();
    let ended = net.now();
    println!("segmented download cut after {sent} bytes: {e}");
    let soon = booted + Duration::from_millis(2);
    assert_ended_by_the_boot_up(&e, ended, (booted, soon), &net, &mut tap);
    // The device has its factory value: nothing of the cut download was committed.
    let stored = bus
        .with_station(dev, |d| d.values().get(BIG.0, BIG.1).map(<[u8]>::to_vec))
        .unwrap();
    assert_eq!(stored, Some(payload(16, 0)));
    net.node(n(NODE))
        .sdo()
        .method(Method::Segmented)
        .write(BIG, payload(LEN, 9))
        .wait()
        .unwrap();
    assert_eq!(
        net.node(n(NODE)).sdo().read(BIG).wait().unwrap(),
        payload(LEN, 9)
    );
}

#[test]
fn power_cycle_during_expedited_transfers_ends_them_naming_the_boot_up_and_the_next_request_works()
{
    let (bus, net, mut dev) = rig(Faults::none(), 16);
    let mut tap = bus.endpoint();
    // An expedited upload and an expedited download, each sent while the device is off (its
    // request reaches nobody) and still waiting for the response when the device boots. The
    // server never answered, so the request may have reached it after its reboot: the client
    // waits out its response timeout, then the error names the boot-up.
    for download in [false, true] {
        let sdo = net.node(n(NODE)).sdo().timeout(POWER_CYCLE_TIMEOUT);
        let started = net.now();
        let (e, booted) = if download {
            let p = sdo.submit_write((0x2000, 0), 0xCAFE_F00Du32.to_le_bytes().to_vec());
            let (d, booted) = power_cycle(&bus, &net, dev, 16);
            dev = d;
            (p.wait().unwrap_err(), booted)
        } else {
            let p = sdo.submit_read((0x1000, 0));
            let (d, booted) = power_cycle(&bus, &net, dev, 16);
            dev = d;
            (p.wait().unwrap_err(), booted)
        };
        let ended = net.now();
        println!(
            "expedited {}: {e}",
            if download { "download" } else { "upload" }
        );
        assert!(booted < started + POWER_CYCLE_TIMEOUT);
        let at_timeout = started + POWER_CYCLE_TIMEOUT;
        let window = (at_timeout, at_timeout + Duration::from_millis(2));
        assert_ended_by_the_boot_up(&e, ended, window, &net, &mut tap);
        // The rebooted device kept its factory value; the next requests work.
        assert_eq!(
            net.node(n(NODE)).sdo().read((0x2000, 0)).wait().unwrap(),
            0x1234_5678u32.to_le_bytes()
        );
        net.node(n(NODE))
            .sdo()
            .write((0x2000, 0), 0x0BAD_CAFEu32.to_le_bytes().to_vec())
            .wait()
            .unwrap();
        assert_eq!(
            net.node(n(NODE)).sdo().read((0x2000, 0)).wait().unwrap(),
            0x0BAD_CAFEu32.to_le_bytes()
        );
    }
}

#[test]
fn a_boot_up_before_the_first_answer_does_not_end_the_transfer() {
    // A device that boots and then answers a request sent while it booted: the boot-up can
    // reach the master after the request left. Played by hand on the device's identifiers.
    let (bus, net, dev) = rig(Faults::none(), 16);
    bus.detach(dev).unwrap();
    let mut device_side = bus.endpoint();
    let p = net.node(n(NODE)).sdo().submit_read((0x1000, 0));
    net.run_for(Duration::from_millis(2)).wait().unwrap();
    let id = |raw| CanId::standard(raw).unwrap();
    device_side
        .send(&CanFrame::new(id(0x705), &[0x00]).unwrap())
        .unwrap();
    net.run_for(Duration::from_millis(2)).wait().unwrap();
    device_side
        .send(&CanFrame::new(id(0x585), &[0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x02, 0x00]).unwrap())
        .unwrap();
    assert_eq!(p.wait().unwrap(), 0x0002_0191u32.to_le_bytes());
}

// ---------------------------------------------------------------------------------------------
// 20 % frame loss and 5 % duplication across every SDO method.

#[derive(Debug, Clone, Copy)]
enum Op {
    Upload(Method),
    Download(Method, usize),
}

const OPS: [Op; 7] = [
    Op::Upload(Method::Normal), // expedited (4 bytes) and segmented (200 bytes)
    Op::Upload(Method::Block),  // 200 bytes
    Op::Download(Method::Normal, 3), // expedited
    Op::Download(Method::Normal, 150), // segmented
    Op::Download(Method::Segmented, 3), // segmented, 3 bytes
    Op::Download(Method::Block, 3), // block, one segment
    Op::Download(Method::Block, 1000), // block, several blocks
];

#[test]
fn loss_and_duplication_give_correct_data_or_a_clean_error_never_wrong_data() {
    let mut ok = 0u32;
    let mut failed = std::collections::BTreeMap::<String, u32>::new();
    for seed in 0..40u64 {
        let (bus, net, dev) = rig(
            Faults {
                drop: 0.20,
                duplicate: 0.05,
                seed: 0xF00D + seed,
                ..Faults::none()
            },
            200,
        );
        let mut current = payload(200, 0);
        for (i, op) in OPS.iter().enumerate() {
            let sdo = || net.node(n(NODE)).sdo().timeout(Duration::from_millis(50));
            match *op {
                Op::Upload(method) => {
                    // A 4-byte object (expedited) and the 200-byte one (segmented or block).
                    match sdo().read((0x2000, 0)).wait() {
                        Ok(v) => {
                            assert_eq!(v, 0x1234_5678u32.to_le_bytes(), "seed {seed}");
                            ok += 1;
                        }
                        Err(e) => *failed.entry(kind_text(&e)).or_default() += 1,
                    }
                    match sdo().method(method).read(BIG).wait() {
                        Ok(v) => {
                            assert_eq!(v, current, "seed {seed} {op:?}: wrong data");
                            ok += 1;
                        }
                        Err(e) => *failed.entry(kind_text(&e)).or_default() += 1,
                    }
                }
                Op::Download(method, len) => {
                    let new = payload(len, (seed as u8).wrapping_add(i as u8));
                    let r = sdo().method(method).write(BIG, new.clone()).wait();
                    // Let late and duplicated frames settle before looking at the device.
                    net.run_for(Duration::from_millis(20)).wait().unwrap();
                    let stored = bus
                        .with_station(dev, |d| d.values().get(BIG.0, BIG.1).map(<[u8]>::to_vec))
                        .unwrap()
                        .unwrap();
                    match r {
                        Ok(()) => {
                            assert_eq!(stored, new, "seed {seed} {op:?}: wrong data stored");
                            ok += 1;
                        }
                        Err(e) => {
                            // A failed download leaves the old value or, when only the
                            // server's confirmation was lost, the whole new one: never a mix.
                            assert!(
                                stored == current || stored == new,
                                "seed {seed} {op:?}: {e}: stored {} bytes",
                                stored.len()
                            );
                            *failed.entry(kind_text(&e)).or_default() += 1;
                        }
                    }
                    current = stored;
                }
            }
        }
    }
    println!("loss and duplication: {ok} transfers correct, failed cleanly: {failed:?}");
    assert!(ok > 0);
}

/// The kind of a failure, without node and object; panics on anything but a clean SDO error.
fn kind_text(e: &canola::Error) -> String {
    let canola::Error::Sdo(s) = e else {
        panic!("not an SDO error: {e}")
    };
    match s.kind {
        SdoErrorKind::Transfer(ErrorKind::Timeout) => "timeout".into(),
        SdoErrorKind::Transfer(ErrorKind::ServerAbort(code)) => format!("server abort {code}"),
        SdoErrorKind::Transfer(ErrorKind::Protocol(v)) => format!("protocol: {v}"),
        ref other => panic!("unexpected failure {other:?}: {e}"),
    }
}

// ---------------------------------------------------------------------------------------------
// A babbling node flooding identifier 0x001.

/// Puts an 8-byte frame with identifier 0x001 on the bus every `period` (faster than the wire
/// takes them: it always has one waiting, as a babbling controller does).
struct Babbler {
    period: Duration,
    next: Instant,
    out: VecDeque<CanFrame>,
}

impl Station for Babbler {
    fn handle_frame(&mut self, _now: Instant, _frame: &CanFrame) {}
    fn handle_timeout(&mut self, now: Instant) {
        while self.next <= now {
            self.out
                .push_back(CanFrame::new(CanId::standard(0x001).unwrap(), &[0xBA; 8]).unwrap());
            self.next += self.period;
        }
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        Some(self.next)
    }
}

#[test]
fn a_babbling_node_on_0x001_the_master_keeps_its_deadlines() {
    let (bus, net, _dev) = rig(Faults::none(), 16);
    let start = net.now();
    let stats0 = bus.stats();
    let babbler = bus.attach(Babbler {
        period: Duration::from_micros(100),
        next: start,
        out: VecDeque::new(),
    });
    let timeout = Duration::from_millis(100);
    let t0 = net.now();
    let e = net
        .node(n(NODE))
        .sdo()
        .timeout(timeout)
        .read((0x1000, 0))
        .wait()
        .unwrap_err();
    let waited = net.now() - t0;
    // The request (0x605) never wins arbitration against 0x001: the response timeout fires on
    // time (within one 2 ms drive slice) and the error says so.
    assert_eq!(kind(&e), ErrorKind::Timeout, "{e}");
    assert!(
        waited >= timeout && waited <= timeout + Duration::from_millis(2),
        "{waited:?}"
    );
    let stats = bus.stats();
    let elapsed = (net.now() - start).as_micros() as f64;
    let load = (stats.busy.as_micros() - stats0.busy.as_micros()) as f64 / elapsed;
    println!(
        "babbler: bus load {:.1} %, {} frames in {:?}; SDO timeout after {waited:?}",
        load * 100.0,
        stats.frames - stats0.frames,
        net.now() - start
    );
    assert!(load > 0.99, "{load}");
    // Quiet again: the next request works.
    bus.detach(babbler).unwrap();
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    assert_eq!(
        net.node(n(NODE)).sdo().read((0x1000, 0)).wait().unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
}

// ---------------------------------------------------------------------------------------------
// A full transmit queue.

#[test]
fn a_request_that_never_left_a_full_transmit_queue_is_withdrawn_with_its_abort() {
    // The master's endpoint takes one frame; a babbling node on 0x001 holds the wire, and a
    // frame on 0x7FF (which never wins arbitration against it) fills that one place.
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        tx_queue_capacity: 1,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let _dev = bus.attach(device(16));
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let mut tap = bus.endpoint();
    let babbler = bus.attach(Babbler {
        period: Duration::from_micros(100),
        next: net.now(),
        out: VecDeque::new(),
    });
    net.send(CanFrame::new(CanId::standard(0x7FF).unwrap(), &[1]).unwrap())
        .unwrap();
    // The request cannot reach the transport: it times out on time, and neither it nor the
    // abort the client queued at the timeout is left to reach the server later.
    let timeout = Duration::from_millis(50);
    let t0 = net.now();
    let e = net
        .node(n(NODE))
        .sdo()
        .timeout(timeout)
        .read((0x1000, 0))
        .wait()
        .unwrap_err();
    let waited = net.now() - t0;
    assert_eq!(kind(&e), ErrorKind::Timeout, "{e}");
    assert!(waited <= timeout + Duration::from_millis(2), "{waited:?}");
    assert_eq!(net.occupancy().unsent_frames, 0);
    // Quiet again (once the babbler's backlog has drained): the 0x7FF frame goes, and no SDO
    // frame of the timed-out request follows it.
    bus.detach(babbler).unwrap();
    net.run_for(Duration::from_millis(50)).wait().unwrap();
    let (mut filler, mut sdo) = (0, 0);
    while let Some(r) = tap.try_recv().unwrap() {
        if let canola::Received::Frame { frame, .. } = r {
            match frame.cob_id() {
                Some(0x7FF) => filler += 1,
                Some(0x580..=0x67F) => sdo += 1,
                _ => {}
            }
        }
    }
    assert_eq!((filler, sdo), (1, 0));
    // The next request works.
    assert_eq!(
        net.node(n(NODE)).sdo().read((0x1000, 0)).wait().unwrap(),
        0x0002_0191u32.to_le_bytes()
    );
}

#[test]
fn a_block_download_through_a_transmit_queue_of_two_frames_arrives_whole() {
    // Back-pressure, not loss: the master keeps what the transport refuses and sends it as the
    // queue empties.
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        tx_queue_capacity: 2,
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    let dev = bus.attach(device(16));
    net.run_for(Duration::from_millis(5)).wait().unwrap();
    let data = payload(3000, 3);
    net.node(n(NODE))
        .sdo()
        .method(Method::Block)
        .write(BIG, data.clone())
        .wait()
        .unwrap();
    let stored = bus
        .with_station(dev, |d| d.values().get(BIG.0, BIG.1).map(<[u8]>::to_vec))
        .unwrap();
    assert_eq!(stored, Some(data));
    assert_eq!(net.occupancy().unsent_frames, 0);
}

// ---------------------------------------------------------------------------------------------
// Servers that break the protocol, scripted frame by frame.

/// The responses to one request.
type Script = Box<dyn FnMut(&[u8]) -> Vec<[u8; 8]> + Send>;

/// An SDO server on node `NODE` that answers each request with the frames `script` returns,
/// and records every request.
struct Scripted {
    script: Script,
    requests: Arc<std::sync::Mutex<Vec<[u8; 8]>>>,
    out: VecDeque<CanFrame>,
}

impl Station for Scripted {
    fn handle_frame(&mut self, _now: Instant, frame: &CanFrame) {
        if frame.cob_id() != Some(0x600 + u16::from(NODE)) {
            return;
        }
        let mut req = [0u8; 8];
        let len = frame.data().len().min(8);
        req[..len].copy_from_slice(&frame.data()[..len]);
        self.requests.lock().unwrap().push(req);
        for data in (self.script)(&req) {
            let id = CanId::standard(0x580 + u16::from(NODE)).unwrap();
            self.out.push_back(CanFrame::new(id, &data).unwrap());
        }
    }
    fn handle_timeout(&mut self, _now: Instant) {}
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
}

type Requests = Arc<std::sync::Mutex<Vec<[u8; 8]>>>;

fn scripted(
    script: impl FnMut(&[u8]) -> Vec<[u8; 8]> + Send + 'static,
) -> (MemoryBus, Network, Requests) {
    let bus = bus(Faults::none());
    let net = Network::new(bus.endpoint());
    let requests = Requests::default();
    bus.attach(Scripted {
        script: Box::new(script),
        requests: requests.clone(),
        out: VecDeque::new(),
    });
    (bus, net, requests)
}

/// The abort the client put on the bus last (command 0x80), if any, once the bus carried it.
fn last_abort(net: &Network, requests: &Requests) -> Option<u32> {
    net.run_for(Duration::from_millis(1)).wait().unwrap();
    requests
        .lock()
        .unwrap()
        .iter()
        .rev()
        .find(|r| r[0] == 0x80)
        .map(|r| u32::from_le_bytes([r[4], r[5], r[6], r[7]]))
}

const TIMEOUT: Duration = Duration::from_millis(50);

#[test]
fn a_response_with_the_wrong_multiplexer_is_ignored_and_the_request_times_out() {
    // Upload of 0x1000:00 answered with an expedited response for 0x1001:00.
    let (_bus, net, requests) = scripted(|req| match req[0] {
        0x40 => vec![[0x43, 0x01, 0x10, 0x00, 1, 2, 3, 4]],
        _ => vec![],
    });
    let e = net
        .node(n(NODE))
        .sdo()
        .timeout(TIMEOUT)
        .read((0x1000, 0))
        .wait()
        .unwrap_err();
    println!("wrong multiplexer: {e}");
    assert_eq!(kind(&e), ErrorKind::Timeout, "{e}");
    assert_eq!(last_abort(&net, &requests), Some(AbortCode::TIMEOUT.get()));
}

#[test]
fn a_segment_with_the_wrong_toggle_bit_aborts_with_0x05030000() {
    // Segmented upload of 20 bytes; the first segment carries toggle 1 instead of 0.
    let (_bus, net, requests) = scripted(|req| match req[0] {
        0x40 => vec![[0x41, 0x01, 0x20, 0x00, 20, 0, 0, 0]],
        0x60 => vec![[0x10, b'a', b'b', b'c', b'd', b'e', b'f', b'g']],
        _ => vec![],
    });
    let e = net
        .node(n(NODE))
        .sdo()
        .timeout(TIMEOUT)
        .read((0x2001, 0))
        .wait()
        .unwrap_err();
    println!("wrong toggle: {e}");
    assert_eq!(kind(&e), ErrorKind::Protocol(Violation::Toggle), "{e}");
    assert_eq!(last_abort(&net, &requests), Some(0x0503_0000));
}

#[test]
fn segments_beyond_the_announced_size_abort_with_0x06070012() {
    // Announces 10 bytes, then sends 7 + 7.
    let (_bus, net, requests) = scripted(|req| match req[0] {
        0x40 => vec![[0x41, 0x01, 0x20, 0x00, 10, 0, 0, 0]],
        0x60 => vec![[0x00, 1, 2, 3, 4, 5, 6, 7]],
        0x70 => vec![[0x11, 8, 9, 10, 11, 12, 13, 14]],
        _ => vec![],
    });
    let e = net
        .node(n(NODE))
        .sdo()
        .timeout(TIMEOUT)
        .read((0x2001, 0))
        .wait()
        .unwrap_err();
    println!("oversized segments: {e}");
    assert_eq!(
        kind(&e),
        ErrorKind::Protocol(Violation::TooLong { size: 10 }),
        "{e}"
    );
    assert_eq!(last_abort(&net, &requests), Some(0x0607_0012));
}

#[test]
fn a_block_upload_whose_crc_does_not_match_aborts_with_0x05040004() {
    let data: Vec<u8> = (0..20u8).collect();
    let good = canola::sdo::crc16(&data);
    let bad = good ^ 0x5A5A;
    let d = data.clone();
    let (_bus, net, requests) = scripted(move |req| match req[0] & 0xE3 {
        // Initiate block upload (ccs 5, cs 0): CRC supported, size 20.
        0xA0 => vec![[0xC6, 0x01, 0x20, 0x00, 20, 0, 0, 0]],
        // Start upload (cs 3): three segments, the last one flagged.
        0xA3 => (0..3)
            .map(|k| {
                let mut f = [0u8; 8];
                f[0] = (k + 1) as u8 | if k == 2 { 0x80 } else { 0 };
                for (j, b) in d.iter().skip(k * 7).take(7).enumerate() {
                    f[1 + j] = *b;
                }
                f
            })
            .collect(),
        // Block ack (cs 2): end of block, 1 byte of the last segment unused, wrong CRC.
        0xA2 => vec![[0xC1 | (1 << 2), bad as u8, (bad >> 8) as u8, 0, 0, 0, 0, 0]],
        _ => vec![],
    });
    let e = net
        .node(n(NODE))
        .sdo()
        .block(true)
        .timeout(TIMEOUT)
        .read((0x2001, 0))
        .wait()
        .unwrap_err();
    println!("block CRC: {e}");
    assert_eq!(
        kind(&e),
        ErrorKind::Protocol(Violation::Crc {
            computed: good,
            received: bad
        }),
        "{e}"
    );
    assert_eq!(last_abort(&net, &requests), Some(0x0504_0004));
}

/// A device rebooted while a block download had a whole sub-block of segments on their way, with
/// seven requests queued behind it (the shape the `canopen_network_sequence` fuzz target found).
/// The segments reach the rebooted device, which answers them with aborts of 0000:00 and, for
/// one that parses as a block download initiate, enters a block download of its own. Those
/// aborts used to fail the next five requests one by one, and a later block upload's client
/// and that server took each other's acknowledgements for segments and acknowledged back
/// forever, every frame rearming both timeouts. Now every request ends within the timeouts of
/// the requests before it, only the one the boot-up met fails (naming the boot-up), and the
/// stack reads the device again.
#[test]
fn a_reboot_under_a_block_download_with_requests_queued_behind_ends_every_one() {
    const TIMEOUT: Duration = Duration::from_millis(50);
    // The fuzz target's text: which stale segment parses as what depends on these bytes.
    let text = |len: u16, salt: u8| -> Vec<u8> {
        (0..len)
            .map(|i| (i as u8).wrapping_mul(13).wrapping_add(salt) | 0x20)
            .collect()
    };
    let bus = bus(Faults::none());
    let net = Network::new(bus.endpoint());
    let dev = bus.attach(SimDevice::from_eds(n(NODE), EDS).unwrap());
    net.run_for(Duration::from_millis(2)).wait().unwrap();
    // Off and on again at once, as the fuzz target does.
    let reboot = |dev| {
        bus.detach(dev).unwrap();
        bus.attach(SimDevice::from_eds(n(NODE), EDS).unwrap())
    };
    let dev = reboot(dev);
    let sdo = || net.node(n(NODE)).sdo().timeout(TIMEOUT);
    let first = sdo().method(Method::Block).submit_read((0x1018, 0));
    let big = sdo().method(Method::Block).submit_write(BIG, text(415, 48));
    net.run_for(Duration::from_micros(3014)).wait().unwrap();
    drop(first);
    let mut reads = vec![sdo().method(Method::Block).submit_read((0x1017, 0))];
    let small = sdo().method(Method::Block).submit_write(BIG, text(97, 105));
    for method in [
        Method::Block,
        Method::Block,
        Method::Block,
        Method::Segmented,
    ] {
        reads.push(sdo().method(method).submit_read((0x1017, 0)));
    }
    let last = sdo().method(Method::Block).submit_read((0x1017, 0));
    reboot(dev);
    let start = net.now();
    run_until_true(&net, || {
        big.is_done() && small.is_done() && last.is_done() && reads.iter().all(|r| r.is_done())
    });
    // Seven requests queued behind the first, each allowed its timeout (and then some for the
    // frames still in the transmit queue): far less than this, but never unbounded.
    assert!(
        net.now() - start < TIMEOUT.saturating_mul(8),
        "took {:?}",
        net.now() - start
    );
    assert!(
        big.wait().is_err(),
        "the download cannot have completed on a rebooted device"
    );
    // The transfer the boot-up met ends naming it; the leftovers' answers (aborts of 0000:00
    // from the rebooted server, one for each stale segment) are not taken as the later
    // requests' answers, so they succeed.
    let outcomes: Vec<_> = std::iter::once(small.wait().map(|()| Vec::new()))
        .chain(reads.into_iter().map(|r| r.wait()))
        .collect();
    let failed: Vec<_> = outcomes.iter().filter_map(|r| r.as_ref().err()).collect();
    assert!(failed.len() <= 1, "{outcomes:?}");
    assert!(
        failed.iter().all(|e| e.kind == SdoErrorKind::NodeRebooted),
        "{outcomes:?}"
    );
    // 0x1017 is 100 ms in the rig's EDS.
    assert_eq!(last.wait().unwrap(), 100u16.to_le_bytes());
    assert_eq!(
        sdo().read((0x1000, 0)).wait().unwrap().len(),
        4,
        "the stack still reads the device"
    );
}

/// A block upload cancelled in the middle of a sub-block: the device has the rest of the
/// sub-block on its way already, and those segments reach the master after the abort, when the
/// next requests have started. Each segment parses as some server command (one with zero
/// bytes as an abort of 0000:00); they were taken as the next request's answer and failed it
/// (`UnexpectedCommand`; found by the `canopen_network_sequence` fuzz target). Now leftovers
/// are dropped until the next transfer is answered: the requests after the cancel succeed.
#[test]
fn the_requests_after_a_cancelled_block_upload_ignore_its_leftover_segments() {
    let (_bus, net, _dev) = rig(Faults::none(), 1285);
    let sdo = || net.node(n(NODE)).sdo().timeout(Duration::from_millis(50));
    let upload = sdo().method(Method::Block).submit_read(BIG);
    let queued = sdo().method(Method::Segmented).submit_read((0x1000, 0));
    // About 40 segments into the first sub-block of 127 (111 µs a frame at 1 Mbit/s).
    net.run_for(Duration::from_micros(5396)).wait().unwrap();
    assert!(!upload.is_done());
    drop(upload);
    assert_eq!(
        queued.wait().unwrap().len(),
        4,
        "the queued read is answered"
    );
    for (i, method) in [Method::Segmented, Method::Normal, Method::Block]
        .into_iter()
        .enumerate()
    {
        let data = payload(377, i as u8);
        sdo()
            .method(method)
            .write(BIG, data.clone())
            .wait()
            .unwrap();
        assert_eq!(sdo().method(method).read(BIG).wait().unwrap(), data);
    }
}
