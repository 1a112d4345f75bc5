//! Random operation sequences against the simulated drive: writes of random values to random
//! profile objects, controlwords, safe torque off, injected faults and steps of random length.
//! The drive never panics, its statusword always shows a CiA 402 state that agrees with
//! `state()`, every object stays readable, and the motion stays finite.

use std::time::Duration;

use canola_cia402::objects;
use canola_cia402::sim::{SimDrive, SimFault};
use canola_cia402::state::State;
use canola_cia402::words::Controlword;
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Op {
    Write(usize, i64),
    Controlword(u16),
    SafeTorqueOff(bool),
    Fault(u8),
    Step(u16),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (0..objects::ALL.len(), any::<i64>()).prop_map(|(o, v)| Op::Write(o, v)),
        prop::sample::select(vec![
            0x00u16, 0x02, 0x06, 0x07, 0x0F, 0x1F, 0x5F, 0x80, 0x10F, 0x7F
        ])
        .prop_map(Op::Controlword),
        any::<u16>().prop_map(Op::Controlword),
        any::<bool>().prop_map(Op::SafeTorqueOff),
        (0u8..3).prop_map(Op::Fault),
        (0u16..5_000).prop_map(Op::Step),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_operations_keep_the_drive_consistent(ops in prop::collection::vec(op(), 1..60)) {
        let mut sim = SimDrive::default();
        for op in ops {
            match op {
                Op::Write(i, v) => {
                    let o = objects::ALL[i];
                    let size = o.data_type.size().unwrap_or(4);
                    let _ = sim.write(o.index, o.sub_index, &v.to_le_bytes()[..size]);
                }
                Op::Controlword(cw) => sim.set_controlword(Controlword::from_raw(cw)),
                Op::SafeTorqueOff(on) => sim.set_safe_torque_off(on),
                Op::Fault(k) => sim.inject_fault([SimFault::OverCurrent, SimFault::FollowingError, SimFault::LimitSwitch][usize::from(k)]),
                Op::Step(us) => {
                    for _ in 0..10 {
                        sim.step(Duration::from_micros(u64::from(us)));
                    }
                }
            }
            prop_assert_eq!(State::decode(sim.statusword()), Some(sim.state()));
            prop_assert!(sim.position().is_finite() && sim.velocity().is_finite() && sim.torque().is_finite());
            let mut buf = [0u8; 8];
            for o in objects::ALL {
                if o.index != 0x6502 || sim.config().supported_modes.is_some() {
                    prop_assert!(sim.read(o.index, o.sub_index, &mut buf).is_ok());
                }
            }
        }
    }
}
