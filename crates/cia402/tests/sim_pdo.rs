//! The simulated drive behind the real PDO engine of `canola-pdo`, configured from
//! eds/cia402-servo.eds as a device simulator would: the master's RPDOs (packed with the same
//! mappings by `canola_pdo::pack`) set the mode, walk the state machine and stream cyclic
//! synchronous positions at each SYNC; the drive's TPDOs carry the statusword, the mode display
//! and the position actual value back, unpacked with `canola_pdo::unpack`.

use std::time::Duration as StdDuration;

use canola_cia402::mode::ModeOfOperation;
use canola_cia402::sim::SimDrive;
use canola_cia402::state::State;
use canola_cia402::words::Statusword;
use canola_frame::{CanFrame, CanId, Duration, Instant, StandardId};
use canola_pdo::{CommParams, Direction, Engine, Mapping, OdView, PdoConfig, RawValue};

const NODE: u8 = 5;

fn eds() -> canola_od::model::ObjectDictionary {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/cia402-servo.eds");
    canola_od::parse(&std::fs::read(path).unwrap()).unwrap().od
}

struct Bench {
    engine: Engine<4, 4>,
    rpdo: Vec<(u16, Mapping)>,
    tpdo: Vec<(u16, Mapping)>,
    sim: SimDrive,
    now: Instant,
}

impl Bench {
    fn new() -> Self {
        let od = eds();
        let view = OdView::new(&od, NODE);
        let mut engine = Engine::<4, 4>::default();
        let now = Instant::ZERO;
        let (mut rpdo, mut tpdo) = (vec![], vec![]);
        for n in 0..4u16 {
            let comm = CommParams::read_from(&view, 0x1400 + n).unwrap();
            let map = Mapping::read_from(&view, Direction::Receive, 0x1600 + n).unwrap();
            rpdo.push((0x200 + 0x100 * n + u16::from(NODE), map.clone()));
            engine.add_rpdo(PdoConfig::new(comm, map)).unwrap();
            let comm = CommParams::read_from(&view, 0x1800 + n).unwrap();
            let map = Mapping::read_from(&view, Direction::Transmit, 0x1A00 + n).unwrap();
            tpdo.push((0x180 + 0x100 * n + u16::from(NODE), map.clone()));
            engine.add_tpdo(now, PdoConfig::new(comm, map)).unwrap();
        }
        // NMT operational.
        engine.set_enabled(now, true);
        let mut sim = SimDrive::default();
        while sim.state() != State::SwitchOnDisabled {
            sim.step(StdDuration::from_millis(1));
        }
        Self {
            engine,
            rpdo,
            tpdo,
            sim,
            now,
        }
    }

    /// The master sends RPDO `n` (1-based) with these values.
    fn rpdo(&mut self, n: usize, values: &[RawValue]) {
        let (cob, map) = &self.rpdo[n - 1];
        let mut data = [0u8; 8];
        let len = canola_pdo::pack(map, values, &mut data).unwrap();
        let frame =
            CanFrame::new(CanId::from(StandardId::new(*cob).unwrap()), &data[..len]).unwrap();
        assert!(self.engine.handle_frame(self.now, &frame, &mut self.sim));
    }

    /// One 1 ms cycle: SYNC to the engine (synchronous RPDOs take effect, synchronous TPDOs
    /// are sampled), the drive steps, event-driven TPDOs see the changes. Returns the frames the
    /// drive sent.
    fn cycle(&mut self) -> Vec<CanFrame> {
        self.now = self.now.checked_add(Duration::from_millis(1)).unwrap();
        self.engine.handle_sync(self.now, None, &mut self.sim);
        self.sim.step(StdDuration::from_millis(1));
        self.engine.update(self.now, &mut self.sim);
        self.engine.handle_timeout(self.now, &mut self.sim);
        std::iter::from_fn(|| self.engine.poll_transmit()).collect()
    }

    /// The values of the drive's TPDO `n` (1-based) in `frames`, the last one sent.
    fn tpdo(&self, frames: &[CanFrame], n: usize) -> Option<Vec<RawValue>> {
        let (cob, map) = &self.tpdo[n - 1];
        let frame = frames
            .iter()
            .rev()
            .find(|f| f.id() == CanId::from(StandardId::new(*cob).unwrap()))?;
        let unpacked = canola_pdo::unpack(map, frame.data()).unwrap();
        Some(unpacked.iter().map(|(_, v)| v).collect())
    }
}

fn u(v: u64) -> RawValue {
    RawValue::Unsigned(v)
}

fn statusword(values: &[RawValue]) -> Statusword {
    match values[0] {
        RawValue::Unsigned(v) => Statusword::from_raw(v as u16),
        ref other => panic!("{other:?}"),
    }
}

#[test]
fn mode_state_machine_and_csp_stream_over_the_default_pdos() {
    let mut b = Bench::new();
    // RPDO1 (event-driven): controlword + modes of operation. Shutdown, then csp.
    b.rpdo(1, &[u(0x0006), RawValue::Signed(8)]);
    let frames = b.cycle();
    let tpdo1 = b.tpdo(&frames, 1).expect("TPDO1 on the change");
    assert_eq!(
        State::decode(statusword(&tpdo1)),
        Some(State::ReadyToSwitchOn)
    );
    assert_eq!(tpdo1[1], RawValue::Signed(8), "0x6061 confirms csp");
    assert_eq!(b.sim.mode(), ModeOfOperation::CyclicSyncPosition);
    for cw in [0x0007, 0x000F] {
        b.rpdo(1, &[u(cw), RawValue::Signed(8)]);
        b.cycle();
    }
    assert_eq!(b.sim.state(), State::OperationEnabled);

    // RPDO2 (synchronous): controlword + target position, one per cycle, applied at SYNC.
    let mut last_actual = 0;
    for k in 1..=200u64 {
        b.rpdo(2, &[u(0x000F), RawValue::Signed(k as i64 * 10)]);
        let frames = b.cycle();
        let tpdo2 = b.tpdo(&frames, 2).expect("TPDO2 at every SYNC");
        let sw = statusword(&tpdo2);
        assert!(sw.bit(12), "csp: drive follows the command");
        assert!(!sw.bit(13), "no following error");
        if let RawValue::Signed(p) = tpdo2[1] {
            last_actual = p;
        }
    }
    // TPDO2 is sampled at the SYNC, before that cycle's step: the position reached for the
    // previous cycle's target. The drive follows the ramp without lag once it is up to speed.
    assert_eq!(last_actual, 1_990);
    assert!(
        (b.sim.position() - 2_000.0).abs() < 1.0,
        "{}",
        b.sim.position()
    );

    // RPDO3 is target velocity, RPDO4 target torque: written into the drive.
    b.rpdo(3, &[u(0x000F), RawValue::Signed(1_234)]);
    b.rpdo(4, &[u(0x000F), RawValue::Signed(-56)]);
    b.cycle();
    assert_eq!(b.sim.value(canola_cia402::objects::TARGET_VELOCITY), 1_234);
    assert_eq!(b.sim.value(canola_cia402::objects::TARGET_TORQUE), -56);
}
