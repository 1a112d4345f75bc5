//! The model and the view against a known network: simulated devices on the in-memory bus
//! (virtual clock, 500 kbit/s timing model), a master [`Network`] on a [`tap`](super::tap), and
//! the panes drawn with ratatui's test backend and compared with the snapshots in
//! `snapshots/` (`UPDATE_SNAPSHOTS=1` rewrites them).

use std::path::PathBuf;

use canola::mem::MemoryBus;
use canola::nmt::{Emcy, EmcyCode, ErrorRegister};
use canola::{BusConfig, CanFrame, CanId, Duration, Instant, Network, NmtState, NodeId, SimDevice};
use ratatui::Terminal;
use ratatui::backend::TestBackend;

use super::keys::Mode;
use super::model::{LogKind, Model};
use super::tap::{self, Seen};
use super::view::{self, Screen};

const BURKERT: &str = include_str!("../../../../eds/burkert-generic.eds");
const SERVO: &str = include_str!("../../../../eds/cia402-servo.eds");

fn od(text: &str) -> canola::ObjectDictionary {
    canola::od::parse(text.as_bytes()).unwrap().od
}

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

/// Node 5 (the generic Bürkert device, heartbeat 500 ms) and node 6 (the simulated servo, no
/// heartbeat): booted, node 5 started, node 6's controlword written (its statusword TPDO
/// changes), an EMCY from node 5, 3 s of bus time in all. Returns the model fed by the tap.
fn known_network() -> Model {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(500_000),
        ..BusConfig::default()
    });
    let (endpoint, rx, stats) = tap::tap(bus.endpoint());
    let net = Network::new(endpoint);
    let dictionaries = vec![(n(5), od(BURKERT)), (n(6), od(SERVO))];
    for (node, od) in &dictionaries {
        net.add_node_with_dictionary(*node, od.clone());
    }
    let dev5 = bus.attach(SimDevice::new(n(5), od(BURKERT)));
    bus.attach(crate::sim_device::simulated_device(n(6), od(SERVO)));
    let mut model = Model::new(&dictionaries, 500_000);
    let pump = |net: &Network, model: &mut Model, d: u64| {
        net.run_for(Duration::from_millis(d)).wait().unwrap();
        for seen in rx.try_iter() {
            model.ingest(&seen);
        }
        model.tick(net.now());
    };
    pump(&net, &mut model, 100);
    net.node(n(5)).nmt().start().unwrap();
    net.node(n(6)).nmt().start().unwrap();
    pump(&net, &mut model, 600);
    net.node(n(6))
        .sdo()
        .write(canola::ObjectAddress::new(0x6040, 0), 6u16)
        .wait()
        .unwrap();
    pump(&net, &mut model, 600);
    let now = bus.now();
    bus.with_station(dev5, |d| {
        d.signal_emcy(now, Emcy::new(EmcyCode(0x5000), ErrorRegister::GENERIC))
    });
    pump(&net, &mut model, 1700);
    assert_eq!(stats.lost.load(std::sync::atomic::Ordering::Relaxed), 0);
    model
}

fn render(model: &Model, w: u16, h: u16, mode: &Mode, color: bool) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    let screen = Screen {
        title: "in-memory bus, 2 simulated node(s)",
        selected: Some(n(5)),
        filter: "",
        mode,
        status: "? help, q quit",
        paused: false,
        color,
        lost: 0,
        replay: None,
    };
    t.draw(|f| view::draw(f, model, &screen)).unwrap();
    let buf = t.backend().buffer().clone();
    let mut out = String::new();
    for y in 0..h {
        let line: String = (0..w)
            .map(|x| buf.cell((x, y)).map_or(" ", |c| c.symbol()))
            .collect();
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

fn snapshot(name: &str, text: &str) {
    let path: PathBuf = [env!("CARGO_MANIFEST_DIR"), "src", "top", "snapshots", name]
        .iter()
        .collect();
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (UPDATE_SNAPSHOTS=1 writes it)", path.display()));
    assert_eq!(text, want, "{name} differs from the snapshot:\n{text}");
}

#[test]
fn the_model_follows_the_simulated_network() {
    let m = known_network();
    let states = m.states();
    assert_eq!(states[&5], (Some(NmtState::Operational), 1));
    assert_eq!(states[&6], (Some(NmtState::Operational), 0));
    let n5 = &m.nodes[&n(5)];
    assert!(n5.last_emcy.as_deref().unwrap().contains("0x5000"));
    assert!(!n5.late);
    // The servo's statusword went from switch on disabled to ready to switch on.
    let sw = m
        .signals
        .values()
        .find(|s| s.name == "Statusword" && s.pdo.contains("node 6"))
        .expect("the statusword PDO");
    assert!(sw.changes >= 1, "{sw:?}");
    assert!(m.bus.frames > 10 && m.bus.fps > 0 && m.bus.load > 0.0);
    assert!(m.log.iter().any(|l| l.text == "node 5: boot-up"));
    assert!(
        m.log
            .iter()
            .any(|l| l.kind == LogKind::Error && l.text.contains("EMCY"))
    );
}

#[test]
fn snapshots_of_the_panes_wide_and_at_80x24() {
    let m = known_network();
    snapshot("wide.txt", &render(&m, 120, 32, &Mode::Normal, true));
    let narrow = render(&m, 80, 24, &Mode::Normal, true);
    snapshot("80x24.txt", &narrow);
    // Everything that matters is in the text, colours or not.
    assert_eq!(render(&m, 80, 24, &Mode::Normal, false), narrow);
    snapshot("help.txt", &render(&m, 80, 24, &Mode::Help, true));
}

#[test]
fn no_color_draws_no_colour() {
    let m = known_network();
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    let screen = Screen {
        title: "t",
        selected: Some(n(5)),
        filter: "",
        mode: &Mode::Normal,
        status: "",
        paused: true,
        color: false,
        lost: 0,
        replay: None,
    };
    t.draw(|f| view::draw(f, &m, &screen)).unwrap();
    let buf = t.backend().buffer();
    assert!(
        buf.content()
            .iter()
            .all(|c| c.fg == ratatui::style::Color::Reset && c.bg == ratatui::style::Color::Reset)
    );
    // With colours, the operational state is green.
    let screen = Screen {
        color: true,
        ..screen
    };
    t.draw(|f| view::draw(f, &m, &screen)).unwrap();
    assert!(
        t.backend()
            .buffer()
            .content()
            .iter()
            .any(|c| c.fg == ratatui::style::Color::Green)
    );
}

fn frame(id: u16, data: &[u8]) -> Seen {
    frame_at(id, data, 0)
}

fn frame_at(id: u16, data: &[u8], ms: u64) -> Seen {
    Seen::Frame {
        at: Instant::from_millis(ms),
        frame: canola::candump::LogFrame::Can(
            CanFrame::new(CanId::standard(id).unwrap(), data).unwrap(),
        ),
        sent: false,
    }
}

#[test]
fn a_late_heartbeat_is_flagged_once_and_cleared_by_the_next() {
    let mut m = Model::new(&[(n(5), od(BURKERT))], 500_000);
    m.ingest(&frame_at(0x705, &[0x05], 0));
    // Other traffic goes on (a SYNC): 500 ms configured, late after 850 ms.
    m.ingest(&frame_at(0x080, &[], 800));
    m.tick(Instant::from_millis(800));
    assert!(!m.nodes[&n(5)].late);
    m.ingest(&frame_at(0x080, &[], 900));
    m.tick(Instant::from_millis(900));
    assert!(m.nodes[&n(5)].late);
    m.tick(Instant::from_millis(1000));
    let late_lines = m.log.iter().filter(|l| l.text.contains("late")).count();
    assert_eq!(late_lines, 1);
    let screen = render(&m, 80, 24, &Mode::Normal, false);
    assert!(screen.contains("1.0s!"), "{screen}");
    m.ingest(&frame_at(0x705, &[0x05], 1100));
    assert!(!m.nodes[&n(5)].late);
    // On a silent bus the clock decides, a second later (frames may come in late).
    m.tick(Instant::from_millis(2900));
    assert!(!m.nodes[&n(5)].late);
    m.tick(Instant::from_millis(3000));
    assert!(m.nodes[&n(5)].late);
    m.ingest(&frame_at(0x705, &[0x05], 3100));
    assert!(!m.nodes[&n(5)].late);
    assert!(m.log.back().unwrap().text.contains("heartbeat again"));
}

#[test]
fn sdo_transfers_in_flight_end_by_answer_abort_or_silence() {
    let mut m = Model::new(&[(n(5), od(BURKERT))], 500_000);
    // Initiate upload of 0x1018:01.
    m.ingest(&frame(0x605, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
    let t = &m.sdo[&n(5)];
    assert_eq!((t.index, t.sub), (0x1018, 1));
    assert!(t.name.as_deref().unwrap().contains("Vendor"));
    let screen = render(&m, 120, 32, &Mode::Normal, false);
    assert!(screen.contains("SDO node 5 read 0x1018:01"), "{screen}");
    // Expedited answer: done.
    m.ingest(&frame(0x585, &[0x43, 0x18, 0x10, 0x01, 0x39, 0, 0, 0]));
    assert!(m.sdo.is_empty());
    // A segmented download aborted by the server.
    m.ingest(&frame(0x605, &[0x21, 0x08, 0x10, 0x00, 20, 0, 0, 0]));
    assert_eq!(m.sdo[&n(5)].size, Some(20));
    m.ingest(&frame(
        0x585,
        &[0x80, 0x08, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06],
    ));
    assert!(m.sdo.is_empty());
    assert!(m.log.back().unwrap().text.contains("0x06010002"));
    // A request nobody answers.
    m.ingest(&frame(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    m.tick(Instant::from_millis(2500));
    assert!(m.sdo.is_empty());
    assert!(m.log.back().unwrap().text.contains("timed out"));
}

#[test]
fn error_fd_and_lost_frames_are_counted() {
    let mut m = Model::new(&[], 500_000);
    m.ingest(&Seen::Frame {
        at: Instant::ZERO,
        frame: canola::candump::LogFrame::Error {
            class: 0x4,
            data: [0; 8],
        },
        sent: false,
    });
    let fd = canola::candump::FdFrame::new(CanId::standard(0x123).unwrap(), &[0; 12])
        .unwrap()
        .with_brs(true);
    m.ingest(&Seen::Frame {
        at: Instant::ZERO,
        frame: canola::candump::LogFrame::Fd(fd),
        sent: false,
    });
    m.ingest(&Seen::Overflow {
        at: Instant::ZERO,
        dropped: 3,
    });
    m.tick(Instant::from_millis(10));
    assert_eq!((m.bus.errors, m.bus.fd, m.bus.overflowed), (1, 1, 3));
    assert_eq!(m.bus.frames, 2);
    // Garbage on any identifier never panics the model.
    for id in 0..0x800u16 {
        for data in [&[][..], &[0xFF; 8][..], &[0x80][..]] {
            m.ingest(&frame(id, data));
        }
    }
}

#[test]
fn a_replay_plays_steps_and_seeks() {
    use canola::candump::LogFrame;
    let f =
        |id: u16, d: &[u8]| LogFrame::Can(CanFrame::new(CanId::standard(id).unwrap(), d).unwrap());
    let frames = vec![
        (1_000_000, f(0x705, &[0x00])),
        (1_500_000, f(0x705, &[0x7F])),
        (12_000_000, f(0x000, &[0x01, 0x05])),
        (12_100_000, f(0x705, &[0x05])),
        (30_000_000, f(0x085, &[0x00, 0x50, 0x01, 0, 0, 0, 0, 0])),
    ];
    let dicts = vec![(n(5), od(BURKERT))];
    let mut r = super::replay::Replay::new(frames, dicts.clone(), 500_000);
    let mut m = Model::new(&dicts, 500_000);
    let mut rec = super::Recording {
        frames: Default::default(),
        dropped: 0,
        interface: "can0".into(),
    };
    r.toggle(); // paused
    r.step(&mut m, &mut rec);
    r.step(&mut m, &mut rec);
    assert_eq!(m.nodes[&n(5)].state, Some(NmtState::PreOperational));
    assert!(
        r.position_text()
            .starts_with("0.5 s of 29.0 s, frame 2 of 5, paused")
    );
    r.seek(20, &mut m, &mut rec);
    assert_eq!(m.nodes[&n(5)].state, Some(NmtState::Operational));
    assert_eq!(rec.frames.len(), 4);
    r.seek(-10, &mut m, &mut rec);
    // Back to 10.5 s: the model is rebuilt from the start.
    assert_eq!(m.nodes[&n(5)].state, Some(NmtState::PreOperational));
    assert_eq!(rec.frames.len(), 2);
    r.seek(30, &mut m, &mut rec);
    assert_eq!(m.nodes[&n(5)].emcy_count, 1);
    assert!(r.position_text().ends_with("end of log"));
}

#[test]
fn prompt_objects_by_number_or_name() {
    let od = od(SERVO);
    let a = super::object("0x6040", Some(&od)).unwrap();
    assert_eq!((a.index, a.sub_index), (0x6040, 0));
    let a = super::object("0x1018:2", None).unwrap();
    assert_eq!((a.index, a.sub_index), (0x1018, 2));
    let a = super::object("controlword", Some(&od)).unwrap();
    assert_eq!(a.index, 0x6040);
    assert!(super::object("", None).is_err());
    assert!(super::object("0x1018:x", None).is_err());
    assert!(super::object("Controlword", None).is_err());
}

#[test]
fn bit_rates_parse() {
    assert_eq!(super::parse_bitrate("500k").ok(), Some(500_000));
    assert_eq!(super::parse_bitrate("1M").ok(), Some(1_000_000));
    assert_eq!(super::parse_bitrate("250000").ok(), Some(250_000));
    assert!(super::parse_bitrate("2M").is_err());
    assert!(super::parse_bitrate("fast").is_err());
}

#[test]
fn lss_shows_on_the_bus_and_on_the_node_it_configured() {
    use canola::lss::{ConfigStatus, Mode as LssMode, Request, Response};
    let mut m = Model::new(&[], 500_000);
    let seen = |f: CanFrame| Seen::Frame {
        at: Instant::ZERO,
        frame: canola::candump::LogFrame::Can(f),
        sent: false,
    };
    m.ingest(&seen(
        Request::SwitchModeGlobal(LssMode::Configuration).to_frame(),
    ));
    m.ingest(&seen(Request::ConfigureNodeId(7).to_frame()));
    m.ingest(&seen(
        Response::ConfigureNodeId(ConfigStatus::OK).to_frame(),
    ));
    assert_eq!(m.lss_mode, Some(LssMode::Configuration));
    assert_eq!(m.nodes[&n(7)].lss.as_deref(), Some("node-ID set by LSS"));
    let screen = render(&m, 120, 32, &Mode::Normal, false);
    assert!(screen.contains("node-ID set by LSS"), "{screen}");
    assert!(screen.contains("LSS: "), "{screen}");
    // A refused configuration sets nothing.
    m.ingest(&seen(Request::ConfigureNodeId(9).to_frame()));
    m.ingest(&seen(
        Response::ConfigureNodeId(ConfigStatus {
            code: 1,
            extension: 0,
        })
        .to_frame(),
    ));
    assert!(!m.nodes.contains_key(&n(9)));
}

#[test]
fn a_node_without_eds_is_named_by_the_identity_read_on_the_bus() {
    let mut m = Model::new(&[], 500_000);
    m.ingest(&frame(0x707, &[0x7F]));
    assert_eq!(m.nodes[&n(7)].shown_name(), None);
    // Vendor-ID and product code read by someone's SDO client (a scan).
    m.ingest(&frame(0x607, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
    m.ingest(&frame(0x587, &[0x43, 0x18, 0x10, 0x01, 0x39, 0, 0, 0]));
    m.ingest(&frame(0x607, &[0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0]));
    m.ingest(&frame(0x587, &[0x43, 0x18, 0x10, 0x02, 0x01, 0x02, 0, 0]));
    assert_eq!(
        m.nodes[&n(7)].shown_name().as_deref(),
        Some("vendor 0x00000039 product 0x00000201")
    );
    // Its PDOs, without a mapping, as bytes.
    m.ingest(&frame(0x187, &[1, 2, 3, 4, 5, 6, 7, 8]));
    let screen = render(&m, 80, 24, &Mode::Normal, false);
    assert!(
        screen.contains("TPDO1 node 7     data") && screen.contains("01 02 03 04 05 06 07 08"),
        "{screen}"
    );
    let screen = render(&m, 120, 32, &Mode::Normal, false);
    assert!(
        screen.contains("vendor 0x00000039 product 0x00000201"),
        "{screen}"
    );
}

#[test]
fn any_terminal_size_draws_without_panicking() {
    let m = known_network();
    let confirm = Mode::Confirm {
        question: "write node 6 0x6040:00 (Controlword) = 6?".into(),
    };
    let prompt = Mode::Prompt {
        ask: super::keys::Ask::Write,
        text: "0x6040 6".into(),
    };
    for (w, h) in [
        (1, 1),
        (10, 3),
        (40, 10),
        (79, 23),
        (109, 29),
        (110, 30),
        (250, 80),
    ] {
        for mode in [&Mode::Normal, &Mode::Help, &confirm, &prompt] {
            let screen = render(&m, w, h, mode, true);
            assert_eq!(screen.lines().count(), usize::from(h));
        }
    }
}

#[test]
fn a_full_view_queue_costs_the_view_copies_never_the_master_frames() {
    use canola::Transport as _;
    use canola::transport::Received;
    let bus = MemoryBus::new();
    let mut other = bus.endpoint();
    let (mut master, rx, stats) = tap::tap_with(bus.endpoint(), 4);
    for i in 0..10u8 {
        other
            .send(&CanFrame::new(CanId::standard(0x181).unwrap(), &[i]).unwrap())
            .unwrap();
    }
    let mut got = Vec::new();
    while let Some(r) = master.recv_until(Instant::from_millis(10)).unwrap() {
        if let Received::Frame { frame, .. } = r {
            got.push(frame.data()[0]);
        }
    }
    // The master got every frame, in order; the view the first four and a count of the rest.
    assert_eq!(got, (0..10).collect::<Vec<u8>>());
    assert_eq!(rx.try_iter().count(), 4);
    assert_eq!(stats.lost.load(std::sync::atomic::Ordering::Relaxed), 6);
    assert_eq!(stats.queued.load(std::sync::atomic::Ordering::Relaxed), 4);
    // What the master sends is copied too.
    master
        .send(&CanFrame::new(CanId::standard(0x000).unwrap(), &[1, 5]).unwrap())
        .unwrap();
    assert!(matches!(rx.try_recv(), Ok(Seen::Frame { sent: true, .. })));
}

/// A transport that only records the receive coalescing asked of it.
struct Recorder(std::sync::Arc<std::sync::Mutex<Option<canola::RxCoalescing>>>);

impl canola::Transport for Recorder {
    fn send(&mut self, _: &CanFrame) -> Result<(), canola::TransportError> {
        Ok(())
    }
    fn recv_until(
        &mut self,
        _: Instant,
    ) -> Result<Option<canola::transport::Received>, canola::TransportError> {
        Ok(None)
    }
    fn now(&self) -> Instant {
        Instant::ZERO
    }
    fn set_rx_coalescing(&mut self, coalescing: canola::RxCoalescing) -> bool {
        *self.0.lock().unwrap() = Some(coalescing);
        true
    }
}

#[test]
fn the_tap_coalesces_receive_wake_ups_and_tells_the_time_without_the_network() {
    use canola::Transport as _;
    let asked = std::sync::Arc::new(std::sync::Mutex::new(None));
    let (mut t, _rx, _stats) = tap::tap(Recorder(asked.clone()));
    assert_eq!(
        *asked.lock().unwrap(),
        Some(canola::RxCoalescing::new(tap::RX_COALESCING))
    );
    // Passed through to the transport.
    assert!(t.set_rx_coalescing(canola::RxCoalescing::OFF));
    assert_eq!(*asked.lock().unwrap(), Some(canola::RxCoalescing::OFF));
    // A virtual clock follows no host time: the view asks the network.
    let (_t, _rx, stats) = tap::tap(MemoryBus::new().endpoint());
    assert_eq!(stats.now(), None);
    // A real one is read without the transport: it runs on (by the 2 ms slept at least) and
    // never ahead of the transport's own clock.
    let bus = MemoryBus::with_config(BusConfig {
        clock: canola::ClockMode::RealTime,
        ..BusConfig::default()
    });
    let before = bus.now();
    let (_t, _rx, stats) = tap::tap(bus.endpoint());
    std::thread::sleep(std::time::Duration::from_millis(2));
    let now = stats.now().unwrap();
    assert!(now >= before + Duration::from_millis(2), "{now:?}");
    assert!(now <= bus.now(), "{now:?}");
}
