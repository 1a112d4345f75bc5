//! Full bus load on the in-memory bus: many simulated nodes, each sending two 8-byte
//! synchronous TPDOs (CiA 301 §7.2.2, transmission type 1) with a sequence counter inside on
//! every SYNC, received by a [`Network`] whose subscriber decodes the typed values; optionally
//! SDO traffic of random sizes to every node at once. The soak binary (`--bin soak`) and the
//! load tests share this code.
//!
//! The device ([`load_dictionary`], a dictionary written here): 0x2000 holds the process data:
//! sub 1 the sequence counter (UNSIGNED32), sub 2 an INTEGER32 and sub 3 a REAL32 derived from
//! the counter ([`expected_i32`], [`expected_real`]) so a frame whose bytes were mixed up or
//! decoded with the wrong type is caught. TPDO1 (0x180 + node-ID) maps 0x2000:01 and 0x2000:02,
//! TPDO2 (0x280 + node-ID) maps 0x2000:01 and 0x2000:03. 0x2100 is a DOMAIN for the SDO traffic.
//! [`LoadNode`] wraps a [`SimDevice`] and advances the counter (through
//! [`SimDevice::set_value`]) when a SYNC arrives, before the device's PDO engine samples it.
//!
//! Counting: "sent" is what the devices put on the bus (counted by [`LoadNode`]), "received"
//! the `PdoValues` events the subscriber saw; lost = sent − received. Per node and TPDO, a
//! counter that does not exceed the previous one is "reordered"; a jump is a gap.

use std::collections::BTreeMap;
use std::sync::mpsc::Receiver;

use canola::mem::{StationId, frame_bits};
use canola::{
    BusConfig, ClockMode, MemoryBus, Method, Network, NetworkEvent, ObjectDictionary, Pending,
    SimDevice, Station, Transport, Value,
};
use canola_frame::{CanFrame, Duration, Instant, NodeId};

use crate::thread_cpu_seconds;

/// Index of the process-data record.
pub const PROCESS_DATA: u16 = 0x2000;

/// Index of the DOMAIN the SDO traffic writes and reads back.
pub const SDO_DOMAIN: u16 = 0x2100;

/// The INTEGER32 that TPDO1 carries with counter `c` of node `node`.
pub fn expected_i32(node: u8, c: u32) -> i32 {
    (c as i32).wrapping_mul(-i32::from(node))
}

/// The REAL32 that TPDO2 carries with counter `c` (exact in binary floating point).
pub fn expected_real(c: u32) -> f32 {
    (c % 65_536) as f32 * 0.25
}

fn var(out: &mut String, section: &str, name: &str, ty: u16, access: &str, default: &str) {
    out.push_str(&format!(
        "[{section}]\nParameterName={name}\nObjectType=0x7\nDataType=0x{ty:04X}\n\
         AccessType={access}\nDefaultValue={default}\nPDOMapping=1\n\n"
    ));
}

fn record(out: &mut String, index: &str, name: &str, subs: u8) {
    out.push_str(&format!(
        "[{index}]\nParameterName={name}\nObjectType=0x9\nSubNumber={subs}\n\n"
    ));
}

/// The EDS text of the load device (CiA 306), written here rather than kept as a file so the
/// layout above is stated once; `transmission_type` goes into 0x1800:02 and 0x1801:02.
pub fn load_eds(transmission_type: u8) -> String {
    let tt = transmission_type.to_string();
    let mut s = String::from(
        "[FileInfo]\nFileName=load-device.eds\nFileVersion=1\nFileRevision=0\nEDSVersion=4.0\n\
         Description=canopen-rs full-load test device\n\n\
         [DeviceInfo]\nVendorName=canopen-rs tests\nVendorNumber=0x00000ABC\n\
         ProductName=load device\nProductNumber=0x00000043\nRevisionNumber=1\n\
         BaudRate_1000=1\nSimpleBootUpSlave=1\nGranularity=8\nNrOfRXPDO=0\nNrOfTXPDO=2\n\
         LSS_Supported=0\n\n\
         [MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\n\
         [OptionalObjects]\nSupportedObjects=5\n1=0x1017\n2=0x1800\n3=0x1801\n4=0x1A00\n\
         5=0x1A01\n\n\
         [ManufacturerObjects]\nSupportedObjects=2\n1=0x2000\n2=0x2100\n\n",
    );
    var(&mut s, "1000", "Device type", 0x7, "ro", "0");
    var(&mut s, "1001", "Error register", 0x5, "ro", "0");
    var(&mut s, "1017", "Producer heartbeat time", 0x6, "rw", "0");
    record(&mut s, "1018", "Identity object", 2);
    var(&mut s, "1018sub0", "Highest sub-index", 0x5, "const", "1");
    var(&mut s, "1018sub1", "Vendor-ID", 0x7, "ro", "0x00000ABC");
    for (n, base, second) in [(0u16, 0x180, 0x2000_0220u32), (1, 0x280, 0x2000_0320)] {
        let comm = format!("{:04X}", 0x1800 + n);
        record(&mut s, &comm, &format!("TPDO{} communication", n + 1), 4);
        var(&mut s, &format!("{comm}sub0"), "Highest", 0x5, "const", "5");
        let cob = format!("$NODEID+0x{base:X}");
        var(&mut s, &format!("{comm}sub1"), "COB-ID", 0x7, "rw", &cob);
        var(
            &mut s,
            &format!("{comm}sub2"),
            "Transmission type",
            0x5,
            "rw",
            &tt,
        );
        var(
            &mut s,
            &format!("{comm}sub3"),
            "Inhibit time",
            0x6,
            "rw",
            "0",
        );
        let map = format!("{:04X}", 0x1A00 + n);
        record(&mut s, &map, &format!("TPDO{} mapping", n + 1), 3);
        var(
            &mut s,
            &format!("{map}sub0"),
            "Number of mapped",
            0x5,
            "rw",
            "2",
        );
        var(
            &mut s,
            &format!("{map}sub1"),
            "Mapped 1",
            0x7,
            "rw",
            "0x20000120",
        );
        let second = format!("0x{second:08X}");
        var(
            &mut s,
            &format!("{map}sub2"),
            "Mapped 2",
            0x7,
            "rw",
            &second,
        );
    }
    record(&mut s, "2000", "Process data", 4);
    var(&mut s, "2000sub0", "Highest", 0x5, "const", "3");
    var(&mut s, "2000sub1", "Sequence counter", 0x7, "rw", "0");
    var(&mut s, "2000sub2", "Signed check value", 0x4, "rw", "0");
    var(&mut s, "2000sub3", "Real check value", 0x8, "rw", "0");
    var(&mut s, "2100", "Soak domain", 0xF, "rw", "");
    s
}

/// The device's dictionary: [`load_eds`] with synchronous TPDOs (transmission type 1: sent on
/// every SYNC).
///
/// # Panics
/// If the text does not parse (it is a constant of this crate; a unit test parses it).
pub fn load_dictionary() -> ObjectDictionary {
    parse(&load_eds(1))
}

/// The dictionary the master is given for each node: the device's own, with its synchronous
/// TPDOs (the master mirrors them as event-driven receive PDOs, so each decodes on arrival).
pub fn master_dictionary() -> ObjectDictionary {
    parse(&load_eds(1))
}

fn parse(text: &str) -> ObjectDictionary {
    canola::od::parse(text.as_bytes())
        .expect("the load device's EDS parses")
        .od
}

/// A simulated load device: advances its sequence counter on every SYNC and counts the PDOs
/// it sends.
pub struct LoadNode {
    dev: SimDevice,
    counter: u32,
    /// PDO frames this node put on the bus.
    pub sent: u64,
}

impl LoadNode {
    /// A device with node-ID `node` and the [`load_dictionary`].
    pub fn new(node: NodeId, od: ObjectDictionary) -> Self {
        Self {
            dev: SimDevice::new(node, od),
            counter: 0,
            sent: 0,
        }
    }

    /// The simulated device.
    pub fn device(&mut self) -> &mut SimDevice {
        &mut self.dev
    }

    /// The counter value of the last SYNC.
    pub fn counter(&self) -> u32 {
        self.counter
    }
}

impl Station for LoadNode {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        if frame.cob_id() == Some(0x080) && self.dev.state() == canola::DeviceState::Operational {
            let c = self.counter.wrapping_add(1);
            self.counter = c;
            let node = self.dev.node().get();
            self.dev.set_value(now, PROCESS_DATA, 1, c.to_le_bytes());
            let i = expected_i32(node, c).to_le_bytes();
            self.dev.set_value(now, PROCESS_DATA, 2, i);
            let r = expected_real(c).to_le_bytes();
            self.dev.set_value(now, PROCESS_DATA, 3, r);
        }
        self.dev.handle_frame(now, frame);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.dev.handle_timeout(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        let f = self.dev.poll_transmit()?;
        if f.cob_id().is_some_and(|c| (0x181..=0x4FF).contains(&c)) {
            self.sent += 1;
        }
        Some(f)
    }
    fn poll_timeout(&self) -> Option<Instant> {
        self.dev.poll_timeout()
    }
}

/// Bits on the wire per SYNC period: the SYNC (no data) and two 8-byte PDOs per node.
pub fn bits_per_sync(nodes: u8, worst_case_stuffing: bool) -> u32 {
    let id = |raw| canola_frame::CanId::standard(raw).expect("valid identifier");
    let sync = CanFrame::new(id(0x080), &[]).expect("valid frame");
    let pdo = CanFrame::new(id(0x181), &[0; 8]).expect("valid frame");
    frame_bits(&sync, worst_case_stuffing)
        + 2 * u32::from(nodes) * frame_bits(&pdo, worst_case_stuffing)
}

/// The SYNC period (whole microseconds) that makes the PDO traffic load a bus of `bitrate` to
/// at least `load` (a share, e.g. 0.95).
pub fn sync_period_for(nodes: u8, bitrate: u32, stuffing: bool, load: f64) -> Duration {
    let wire_us = f64::from(bits_per_sync(nodes, stuffing)) * 1e6 / f64::from(bitrate);
    Duration::from_micros((wire_us / load).floor() as u64)
}

/// Settings of one load run.
#[derive(Debug, Clone)]
pub struct LoadConfig {
    /// Simulated nodes (node-IDs 1..=nodes).
    pub nodes: u8,
    /// Bus time with SYNC running.
    pub bus_time: Duration,
    /// The SYNC period.
    pub sync_period: Duration,
    /// Bit rate of the timing model.
    pub bitrate: u32,
    /// Worst-case stuff bits in the timing model.
    pub worst_case_stuffing: bool,
    /// SDO traffic of random sizes to every node at once.
    pub sdo: bool,
    /// Largest SDO value written and read back.
    pub sdo_max_len: usize,
    /// SDO response timeout.
    pub sdo_timeout: Duration,
    /// Seed of the SDO sizes and data.
    pub seed: u64,
    /// Bus time between two memory samples.
    pub sample_every: Duration,
    /// Frames each endpoint may have waiting for the wire ([`BusConfig::tx_queue_capacity`]).
    pub tx_queue: usize,
}

impl LoadConfig {
    /// `nodes` nodes at 1 Mbit/s (no stuff bits) with the SYNC period for 95 % PDO load.
    pub fn full_load(nodes: u8, bus_time: Duration) -> Self {
        Self {
            nodes,
            bus_time,
            sync_period: sync_period_for(nodes, 1_000_000, false, 0.95),
            bitrate: 1_000_000,
            worst_case_stuffing: false,
            sdo: false,
            sdo_max_len: 256,
            sdo_timeout: Duration::from_secs(5),
            seed: 1,
            sample_every: Duration::from_secs(1),
            // The transmit queue length Linux gives a CAN interface (`txqueuelen` 10): with
            // the SDO traffic the master offers more than the bus carries, and a deeper queue
            // only holds more requests that reach their server after the client gave up.
            tx_queue: 10,
        }
    }
}

/// One memory sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Bus time of the sample, seconds.
    pub bus_seconds: f64,
    /// Resident set size, KiB.
    pub rss_kib: u64,
    /// Bytes allocated and not freed (from the caller's counting allocator), if known.
    pub live_bytes: Option<u64>,
    /// Table sizes at the sample.
    pub tables: Tables,
}

/// Sizes of the tables a long run must keep bounded: the master's (see
/// [`canola::Occupancy`]), the bus's backlog and the subscriber's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Tables {
    /// The master's table sizes.
    pub master: canola::Occupancy,
    /// Frames waiting for the wire on the in-memory bus.
    pub bus_backlog: usize,
    /// Entries of the subscriber's per-node, per-TPDO counter table.
    pub counters: usize,
}

impl Tables {
    /// The tables with an entry per node, channel, request or subscriber (the rest are queues).
    pub const KEYED: [&'static str; 6] = [
        "nodes",
        "SDO channels",
        "requests",
        "boot-up counts",
        "subscribers",
        "PDO counters",
    ];

    /// The sizes by name, for printing and comparing.
    pub fn named(&self) -> [(&'static str, usize); 9] {
        let m = &self.master;
        [
            ("nodes", m.nodes),
            ("SDO channels", m.sdo_channels),
            ("requests", m.requests),
            ("queued requests", m.queued_requests),
            ("unsent frames", m.unsent_frames),
            ("boot-up counts", m.boot_counts),
            ("subscribers", m.subscribers),
            ("bus backlog", self.bus_backlog),
            ("PDO counters", self.counters),
        ]
    }
}

/// Outcome of the SDO traffic.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SdoTally {
    /// Downloads that succeeded.
    pub writes_ok: u64,
    /// Uploads that succeeded and returned the bytes last written.
    pub reads_ok: u64,
    /// Uploads that returned other bytes than the last successful download (must stay 0).
    pub wrong_data: u64,
    /// Failed transfers by error text (the kind, without node and object).
    pub errors: BTreeMap<String, u64>,
    /// Bytes moved by successful transfers, both ways.
    pub bytes: u64,
}

/// What a load run measured.
#[derive(Debug, Clone, Default)]
pub struct LoadReport {
    /// PDO frames the devices sent.
    pub sent: u64,
    /// `PdoValues` events the subscriber received.
    pub frames: u64,
    /// sent − received.
    pub lost: i64,
    /// Received counters that did not exceed the previous one of the same node and TPDO.
    pub reordered: u64,
    /// Counters skipped (a gap of n counts n).
    pub gaps: u64,
    /// Events whose typed values did not match the counter (wrong type or bytes).
    pub bad_values: u64,
    /// SYNC periods run.
    pub syncs: u64,
    /// Frames on the wire, all kinds.
    pub bus_frames: u64,
    /// Busy share of the wire over the SYNC-running time.
    pub bus_load: f64,
    /// CPU time of the driving thread (bus, simulators, master, subscriber), seconds.
    pub cpu_seconds: f64,
    /// Memory samples, the first before the run.
    pub samples: Vec<Sample>,
    /// SDO traffic outcome (when enabled).
    pub sdo: Option<SdoTally>,
}

/// Resident set size of this process in KiB (Linux `/proc/self/statm`), 0 elsewhere.
pub fn rss_kib() -> u64 {
    let page_kib = 4;
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * page_kib)
}

/// Peak resident set size in KiB (`VmHWM` of `/proc/self/status`), 0 when unknown.
pub fn peak_rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        })
        .unwrap_or(0)
}

/// Least-squares slope of `y` over `x` (per unit of x); 0 for fewer than two points.
pub fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    if points.len() < 2 {
        return 0.0;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx == 0.0 { 0.0 } else { sxy / sxx }
}

/// SplitMix64 for the SDO sizes and data: seeded, so every run is the same.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// One node's SDO job: a download of random bytes, then an upload that must return them.
enum SdoJob {
    Write(Pending<()>, Vec<u8>),
    Read(Pending<Vec<u8>>, Vec<u8>),
}

/// What each SDO job needs to know.
struct SdoPlan {
    max_len: usize,
    timeout: Duration,
}

fn new_write(net: &Network, node: NodeId, rng: &mut Rng, plan: &SdoPlan) -> SdoJob {
    let len = 1 + rng.below(plan.max_len as u64) as usize;
    let data: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
    let method = [Method::Normal, Method::Segmented, Method::Block][rng.below(3) as usize];
    let p = net
        .node(node)
        .sdo()
        .timeout(plan.timeout)
        .method(method)
        .submit_write((SDO_DOMAIN, 0), data.clone());
    SdoJob::Write(p, data)
}

fn new_read(net: &Network, node: NodeId, rng: &mut Rng, plan: &SdoPlan, expect: Vec<u8>) -> SdoJob {
    let block = rng.below(2) == 0;
    let p = net
        .node(node)
        .sdo()
        .timeout(plan.timeout)
        .block(block)
        .submit_read((SDO_DOMAIN, 0));
    SdoJob::Read(p, expect)
}

fn error_text(e: &canola::SdoError) -> String {
    // "node 5, object 0x2100:00 ...: TEXT": keep the text.
    let s = e.to_string();
    match s.split_once(": ") {
        Some((_, t)) => t.to_string(),
        None => s,
    }
}

/// Advances finished SDO jobs and starts the next ones.
fn pump_sdo(
    net: &Network,
    jobs: &mut [Option<SdoJob>],
    rng: &mut Rng,
    plan: &SdoPlan,
    tally: &mut SdoTally,
) {
    for (i, slot) in jobs.iter_mut().enumerate() {
        let node = NodeId::new(i as u8 + 1).expect("node-IDs 1..=127");
        let done = match slot {
            Some(SdoJob::Write(p, _)) => p.is_done(),
            Some(SdoJob::Read(p, _)) => p.is_done(),
            None => true,
        };
        if !done {
            continue;
        }
        *slot = Some(match slot.take() {
            Some(SdoJob::Write(p, data)) => match p.wait() {
                Ok(()) => {
                    tally.writes_ok += 1;
                    tally.bytes += data.len() as u64;
                    new_read(net, node, rng, plan, data)
                }
                Err(e) => {
                    *tally.errors.entry(error_text(&e)).or_default() += 1;
                    new_write(net, node, rng, plan)
                }
            },
            Some(SdoJob::Read(p, expect)) => {
                match p.wait() {
                    Ok(got) if got == expect => {
                        tally.reads_ok += 1;
                        tally.bytes += got.len() as u64;
                    }
                    Ok(_) => tally.wrong_data += 1,
                    Err(e) => *tally.errors.entry(error_text(&e)).or_default() += 1,
                }
                new_write(net, node, rng, plan)
            }
            None => new_write(net, node, rng, plan),
        });
    }
}

/// Per node and TPDO: the last counter.
struct Tracker {
    last: BTreeMap<(u8, u8), u32>,
}

impl Tracker {
    fn take(&mut self, report: &mut LoadReport, event: NetworkEvent) {
        let NetworkEvent::PdoValues {
            node,
            number,
            values,
            ..
        } = event
        else {
            return;
        };
        report.frames += 1;
        let (Some((_, Value::Unsigned32(c))), Some((_, second))) = (values.first(), values.get(1))
        else {
            report.bad_values += 1;
            return;
        };
        let c = *c;
        let ok = match (number, second) {
            (1, Value::Integer32(v)) => *v == expected_i32(node.get(), c),
            (2, Value::Real32(v)) => *v == expected_real(c),
            _ => false,
        };
        if !ok {
            report.bad_values += 1;
        }
        let key = (node.get(), number);
        match self.last.insert(key, c) {
            Some(prev) if c <= prev => report.reordered += 1,
            Some(prev) => report.gaps += u64::from(c - prev - 1),
            None => report.gaps += u64::from(c.saturating_sub(1)),
        }
    }
}

/// The bus, the devices and the master of one run, before SYNC starts.
struct Rig {
    bus: MemoryBus,
    devices: Vec<StationId<LoadNode>>,
}

fn rig(config: &LoadConfig) -> Rig {
    let bus = MemoryBus::with_config(BusConfig {
        clock: ClockMode::Virtual,
        bitrate: Some(config.bitrate),
        worst_case_stuffing: config.worst_case_stuffing,
        tx_queue_capacity: config.tx_queue,
        ..BusConfig::default()
    });
    let od = load_dictionary();
    let devices = (1..=config.nodes)
        .map(|n| {
            let node = NodeId::new(n).expect("node-IDs 1..=127");
            bus.attach(LoadNode::new(node, od.clone()))
        })
        .collect();
    Rig { bus, devices }
}

/// Runs the load: devices started, SYNC for [`LoadConfig::bus_time`], then a quiet period in
/// which frames still on the way arrive. `live_bytes` reads the caller's allocation counter
/// (the soak binary's counting allocator), if it has one.
pub fn run(
    config: &LoadConfig,
    live_bytes: &dyn Fn() -> Option<u64>,
) -> Result<LoadReport, canola::Error> {
    let mut report = LoadReport::default();
    let rig = rig(config);
    let net = Network::new(rig.bus.endpoint());
    let od = master_dictionary();
    for n in 1..=config.nodes {
        let node = NodeId::new(n).expect("node-IDs 1..=127");
        net.add_node_with_dictionary(node, od.clone());
    }
    let events: Receiver<NetworkEvent> = net.subscribe();
    net.nmt_all(canola::CommandSpecifier::Start)?;
    net.run_for(Duration::from_millis(10)).wait()?;
    let _ = events.try_iter().count();

    let mut tracker = Tracker {
        last: BTreeMap::new(),
    };
    let mut rng = Rng(config.seed);
    let mut jobs: Vec<Option<SdoJob>> = (0..config.nodes).map(|_| None).collect();
    let mut tally = SdoTally::default();
    let plan = SdoPlan {
        max_len: config.sdo_max_len,
        timeout: config.sdo_timeout,
    };

    let sample = |t: Instant, start: Instant, counters: usize| Sample {
        bus_seconds: (t - start).as_micros() as f64 / 1e6,
        rss_kib: rss_kib(),
        live_bytes: live_bytes(),
        tables: Tables {
            master: net.occupancy(),
            bus_backlog: rig.bus.pending_frames(),
            counters,
        },
    };
    // Room for every sample up front, so the sample list does not grow the heap it measures.
    let expected = config.bus_time.as_micros() / config.sample_every.as_micros().max(1);
    report.samples.reserve(expected as usize + 3);
    let start = net.now();
    let stats0 = rig.bus.stats();
    report
        .samples
        .push(sample(start, start, tracker.last.len()));
    let cpu0 = thread_cpu_seconds();
    net.start_sync(config.sync_period);
    let end = start + config.bus_time;
    let mut next_sample = start + config.sample_every;
    let mut t = start;
    while t < end {
        t = (t + config.sync_period).min(end);
        net.run_until(t).wait()?;
        for e in events.try_iter() {
            tracker.take(&mut report, e);
        }
        if config.sdo {
            pump_sdo(&net, &mut jobs, &mut rng, &plan, &mut tally);
        }
        if t >= next_sample {
            report.samples.push(sample(t, start, tracker.last.len()));
            next_sample += config.sample_every;
        }
    }
    net.stop_sync();
    let stats1 = rig.bus.stats();
    // Let the last SYNC's PDOs and the SDO transfers in flight finish.
    jobs.clear();
    net.run_for(Duration::from_millis(50)).wait()?;
    for e in events.try_iter() {
        tracker.take(&mut report, e);
    }
    report.cpu_seconds = thread_cpu_seconds() - cpu0;
    report
        .samples
        .push(sample(net.now(), start, tracker.last.len()));
    for id in &rig.devices {
        report.sent += rig.bus.with_station(*id, |d| d.sent).unwrap_or(0);
    }
    report.syncs = rig
        .devices
        .first()
        .and_then(|id| rig.bus.with_station(*id, |d| u64::from(d.counter())))
        .unwrap_or(0);
    report.lost = report.sent as i64 - report.frames as i64;
    report.bus_frames = stats1.frames - stats0.frames;
    let busy = (stats1.busy.as_micros() - stats0.busy.as_micros()) as f64;
    report.bus_load = busy / config.bus_time.as_micros().max(1) as f64;
    report.sdo = config.sdo.then_some(tally);
    Ok(report)
}

/// The same devices and SYNC schedule with a bare endpoint in place of the master (it sends
/// the SYNCs and drops every frame): the CPU time of bus and simulators alone, to tell the
/// master's share. Returns (frames received, CPU seconds).
pub fn baseline(config: &LoadConfig) -> Result<(u64, f64), canola::TransportError> {
    let rig = rig(config);
    let mut ep = rig.bus.endpoint();
    let id = canola_frame::CanId::standard(0x000).expect("valid identifier");
    ep.send(&CanFrame::new(id, &[0x01, 0x00]).expect("valid frame"))?;
    let mut until = ep.now() + Duration::from_millis(10);
    while ep.recv_until(until)?.is_some() {}
    let sync =
        CanFrame::new(canola_frame::CanId::standard(0x080).expect("valid"), &[]).expect("valid");
    let start = ep.now();
    let end = start + config.bus_time;
    let cpu0 = thread_cpu_seconds();
    let mut frames = 0u64;
    let mut next_sync = start;
    while next_sync < end {
        ep.send(&sync)?;
        next_sync += config.sync_period;
        until = next_sync.min(end);
        while let Some(r) = ep.recv_until(until)? {
            if matches!(r, canola::Received::Frame { .. }) {
                frames += 1;
            }
        }
    }
    while ep
        .recv_until(ep.now() + Duration::from_millis(50))?
        .is_some()
    {
        frames += 1;
    }
    Ok((frames, thread_cpu_seconds() - cpu0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_load_dictionary_maps_two_eight_byte_tpdos() {
        let od = load_dictionary();
        assert_eq!(
            od.sub(0x1A00, 1).map(|s| s.data_type),
            Some(canola::DataType::Unsigned32)
        );
        assert!(od.sub(0x1801, 2).is_some());
        assert!(od.get(SDO_DOMAIN).is_some());
    }

    #[test]
    fn sixty_four_nodes_load_the_bus_to_at_least_ninety_percent() {
        let p = sync_period_for(64, 1_000_000, false, 0.95);
        let load = f64::from(bits_per_sync(64, false)) / p.as_micros() as f64;
        assert!((0.95..0.96).contains(&load), "{load} at {p:?}");
    }

    #[test]
    fn slope_of_a_line() {
        let pts: Vec<_> = (0..10)
            .map(|x| (f64::from(x), 3.0 * f64::from(x) + 1.0))
            .collect();
        assert!((slope(&pts) - 3.0).abs() < 1e-9);
    }
}
