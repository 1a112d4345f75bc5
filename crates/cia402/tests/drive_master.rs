//! The `Drive` API against the simulated drive (`DriveHook` behind a `SimDevice` from
//! `eds/cia402-servo.eds`) on the in-memory bus, through the real SDO and PDO codecs: the
//! state walk, moves, modes, homing, faults, and one test per master pitfall known from
//! other stacks.

use std::sync::{Arc, Mutex};

use canola::{CanFrame, CanId, Duration, MemoryBus, Network, NodeId, Received, Transport as _};
use canola_cia402::master::{Awaited, Drive, DriveError, Homing, Move, Reached, simulated_drive};
use canola_cia402::sim::{SimConfig, SimDrive, SimFault};
use canola_cia402::{ModeOfOperation, PlanError, QuickStopOption, State};

const EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");

struct Rig {
    bus: MemoryBus,
    net: Network,
    model: Arc<Mutex<SimDrive>>,
    drive: Drive,
}

fn rig(config: SimConfig) -> Rig {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5).unwrap();
    let node = net.add_node(id);
    let (device, model) = simulated_drive(id, EDS, SimDrive::new(config)).unwrap();
    bus.attach(device);
    node.nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    let drive = Drive::new(node);
    Rig {
        bus,
        net,
        model,
        drive,
    }
}

fn abort_code(e: &DriveError) -> Option<u32> {
    match e {
        DriveError::Sdo(e) => e.server_abort().map(|c| c.0),
        _ => None,
    }
}

#[test]
fn enable_then_absolute_and_relative_moves_end_at_target_reached_bit_10() {
    let r = rig(SimConfig::default());
    // Straight after boot the drive may still be in not ready to switch on: the walk waits
    // for transition 1.
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
    let pos = r
        .drive
        .move_to(Move {
            target: 4_000,
            ..Move::default()
        })
        .wait()
        .unwrap();
    // Bit 4 (voltage enabled) was set all along: returning on it would leave the drive near 0.
    assert!((pos - 4_000).abs() <= 10, "position {pos}");
    let sw = r.drive.statusword().wait().unwrap();
    assert!(sw.target_reached());
    let mut seen = Vec::new();
    r.drive
        .start_move(Move {
            target: 1_000,
            relative: true,
            velocity: Some(20_000),
            immediate: false,
        })
        .wait()
        .unwrap();
    let pos = r
        .drive
        .wait_target_reached(|p| seen.push(p))
        .wait()
        .unwrap();
    assert!((pos - 5_000).abs() <= 10, "position {pos}");
    // The live positions rose through the move.
    assert!(seen.len() > 2 && seen.first() < seen.last(), "{seen:?}");
    assert!((r.model.lock().unwrap().position() - 5_000.0).abs() <= 10.0);
}

#[test]
fn quick_stop_ends_in_switch_on_disabled_with_605a_2() {
    // python-canopen #167: QSA, then automatically SOD.
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive.set_velocity(20_000).wait().unwrap();
    r.net.run_for(Duration::from_millis(200)).wait().unwrap();
    assert_eq!(
        r.drive.quick_stop().wait().unwrap(),
        State::SwitchOnDisabled
    );
    assert_eq!(r.drive.state().wait().unwrap(), State::SwitchOnDisabled);
    assert!(r.model.lock().unwrap().velocity().abs() < 1.0);
}

#[test]
fn quick_stop_stays_active_with_605a_6_and_transition_16_enables_again() {
    let r = rig(SimConfig::default());
    r.drive
        .node()
        .sdo()
        .write((0x605A, 0), 6i16)
        .wait()
        .unwrap();
    r.drive.enable().wait().unwrap();
    assert_eq!(r.drive.quick_stop().wait().unwrap(), State::QuickStopActive);
    r.net.run_for(Duration::from_millis(300)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::QuickStopActive);
    // Transition 16: 0x000F in quick stop active.
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
}

#[test]
fn a_drive_without_transition_16_is_enabled_through_switch_on_disabled() {
    // python-canopen #169: the drive ignores 0x000F in quick stop active.
    let mut config = SimConfig::default();
    config.device.transition_16 = false;
    config.device.quick_stop_option = QuickStopOption(6);
    let r = rig(config);
    r.drive.enable().wait().unwrap();
    assert_eq!(r.drive.quick_stop().wait().unwrap(), State::QuickStopActive);
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
    // Told beforehand, the planner does not try transition 16 at all.
    let drive = Drive::new(r.drive.node().clone()).with_transition_16(false);
    assert_eq!(drive.quick_stop().wait().unwrap(), State::QuickStopActive);
    assert_eq!(drive.enable().wait().unwrap(), State::OperationEnabled);
}

#[test]
fn mode_0_at_power_up_and_an_unknown_mode_are_values_not_failures() {
    // python-canopen #183.
    let r = rig(SimConfig::default());
    assert_eq!(r.drive.mode().wait().unwrap(), ModeOfOperation::NoMode);
    // A reserved code the drive refuses: its SDO abort, no panic, mode unchanged.
    let e = r
        .drive
        .set_mode(ModeOfOperation::Reserved(5))
        .wait()
        .unwrap_err();
    assert_eq!(abort_code(&e), Some(0x0609_0030), "{e}");
    assert_eq!(r.drive.mode().wait().unwrap(), ModeOfOperation::NoMode);
    assert_eq!(
        r.drive
            .set_mode(ModeOfOperation::ProfileVelocity)
            .wait()
            .unwrap(),
        ModeOfOperation::NoMode
    );
    assert_eq!(
        r.drive.mode().wait().unwrap(),
        ModeOfOperation::ProfileVelocity
    );
}

#[test]
fn a_mode_already_set_succeeds_without_writing_0x6060() {
    // ros2_canopen #445.
    let r = rig(SimConfig::default());
    r.drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap();
    let mut tap = r.bus.endpoint();
    assert_eq!(
        r.drive
            .set_mode(ModeOfOperation::ProfilePosition)
            .wait()
            .unwrap(),
        ModeOfOperation::ProfilePosition
    );
    let mut writes = 0;
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        let d = frame.data();
        let sdo_download = frame.cob_id() == Some(0x605) && d.len() == 8 && d[0] & 0xE0 == 0x20;
        if sdo_download && u16::from_le_bytes([d[1], d[2]]) == 0x6060 {
            writes += 1;
        }
    }
    assert_eq!(writes, 0);
}

#[test]
fn modes_work_without_0x6502() {
    // ros2_canopen #299: 0x6502 absent (SDO abort 0x06020000); modes are verified by 0x6061.
    let r = rig(SimConfig {
        supported_modes: None,
        ..SimConfig::default()
    });
    let e = r.drive.node().sdo().read((0x6502, 0)).wait().unwrap_err();
    assert_eq!(abort_code(&DriveError::Sdo(e)), Some(0x0602_0000));
    r.drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap();
    r.drive.enable().wait().unwrap();
    let pos = r
        .drive
        .move_to(Move {
            target: -2_000,
            ..Move::default()
        })
        .wait()
        .unwrap();
    assert!((pos + 2_000).abs() <= 10);
}

#[test]
fn homing_from_switch_on_disabled_selects_the_mode_and_asks_for_enable() {
    // python-canopen #244: homing mode can be chosen in switch on disabled; the power state is
    // not changed behind the caller's back, and homing itself needs operation enabled.
    let r = rig(SimConfig::default());
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::SwitchOnDisabled);
    match r.drive.home(Some(19)).wait() {
        Err(DriveError::NotEnabled { state, .. }) => assert_eq!(state, State::SwitchOnDisabled),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.drive.mode().wait().unwrap(), ModeOfOperation::Homing);
    assert_eq!(r.drive.state().wait().unwrap(), State::SwitchOnDisabled);
    r.drive.enable().wait().unwrap();
    // Method 19: the home switch (active from 5000 counts) searched in the positive direction.
    let pos = r.drive.home(Some(19)).wait().unwrap();
    assert!(pos.abs() <= 10, "position after homing {pos}");
    let shaft = r.model.lock().unwrap().position();
    assert!(shaft.abs() <= 10.0, "{shaft}");
}

#[test]
fn safe_torque_off_at_start_up_leaves_the_drive_usable_but_not_enabled() {
    // ros2_canopen #421/#422: nothing at set-up needs operation enabled; enabling says why it
    // cannot.
    let r = rig(SimConfig {
        safe_torque_off: true,
        ..SimConfig::default()
    });
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::SwitchOnDisabled);
    r.drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap();
    match r.drive.enable().wait() {
        Err(DriveError::Plan(PlanError::VoltageNotEnabled { state, .. })) => {
            assert_eq!(state, State::ReadyToSwitchOn)
        }
        other => panic!("{other:?}"),
    }
    r.model.lock().unwrap().set_safe_torque_off(false);
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
}

#[test]
fn a_fault_names_0x603f_and_the_emcy_and_the_reset_clears_it() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive
        .start_move(Move {
            target: 50_000,
            ..Move::default()
        })
        .wait()
        .unwrap();
    r.model
        .lock()
        .unwrap()
        .inject_fault(SimFault::FollowingError);
    match r.drive.wait_target_reached(|_| {}).wait() {
        Err(DriveError::Fault { code, emcy, .. }) => {
            assert_eq!(code.0, 0x8611);
            assert_eq!(emcy.unwrap().code.0, 0x8611);
        }
        other => panic!("{other:?}"),
    }
    let report = r.drive.fault_reset().wait().unwrap();
    assert_eq!(report.code.0, 0x8611);
    assert_eq!(report.emcy.map(|e| e.code.0), Some(0x8611), "{report:?}");
    assert_eq!(report.from, State::Fault);
    assert_eq!(report.state, State::SwitchOnDisabled);
    assert_eq!(r.drive.error_code().wait().unwrap().0, 0);
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
}

#[test]
fn a_wait_that_times_out_names_expected_reached_and_statusword() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    let drive = Drive::new(r.drive.node().clone()).with_timeouts(canola_cia402::master::Timeouts {
        motion: Duration::from_millis(50),
        ..Default::default()
    });
    let e = drive
        .move_to(Move {
            target: 100_000,
            ..Move::default()
        })
        .wait()
        .unwrap_err();
    match &e {
        DriveError::Timeout {
            awaited,
            reached,
            statusword,
            ..
        } => {
            assert_eq!(*awaited, Awaited::TargetReached);
            assert!(
                matches!(reached, Reached::Position(p) if *p > 0 && *p < 100_000),
                "{reached}"
            );
            assert!(!statusword.target_reached());
        }
        other => panic!("{other:?}"),
    }
    let text = e.to_string();
    assert!(
        text.contains("waiting for target reached (statusword bit 10): the drive is at position")
            && text.contains("statusword"),
        "{text}"
    );
    // What `main` prints when it returns the error with `?`: the same sentence.
    assert_eq!(format!("{e:?}"), text);
}

#[test]
fn rpdo_controlwords_reach_the_drive_and_tpdos_carry_its_statusword() {
    // The drive behind the device's PDOs: RPDO1 = controlword + mode, TPDO1 = statusword + mode
    // display (event-driven), as the EDS maps them.
    let r = rig(SimConfig::default());
    r.net.run_for(Duration::from_millis(50)).wait().unwrap();
    r.drive.node().nmt().start().unwrap();
    let events = r.net.subscribe();
    let rpdo = CanId::standard(0x205).unwrap();
    for cw in [0x0006u16, 0x0007, 0x000F] {
        let [lo, hi] = cw.to_le_bytes();
        r.net
            .send(CanFrame::new(rpdo, &[lo, hi, 1]).unwrap())
            .unwrap();
        r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    }
    assert_eq!(r.model.lock().unwrap().state(), State::OperationEnabled);
    assert_eq!(r.drive.state().wait().unwrap(), State::OperationEnabled);
    let mut last = None;
    while let Ok(ev) = events.try_recv() {
        if let canola::NetworkEvent::Pdo {
            node, number, data, ..
        } = ev
            && node.get() == 5
            && number == 1
        {
            last = Some(data.to_vec());
        }
    }
    let data = last.expect("a TPDO1");
    assert_eq!(u16::from_le_bytes([data[0], data[1]]) & 0x6F, 0x27);
    assert_eq!(data[2], 1, "mode display pp");
}

#[test]
fn a_set_point_edge_sent_by_two_back_to_back_rpdos_is_not_lost() {
    // RPDO2 = controlword + target position, synchronous (type 1): 0x001F, SYNC, 0x000F, SYNC
    // within the same millisecond; the drive takes each RPDO when its SYNC applies it.
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap();
    r.drive.node().nmt().start().unwrap();
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    let rpdo2 = CanId::standard(0x305).unwrap();
    for cw in [0x001Fu16, 0x000F] {
        let mut data = cw.to_le_bytes().to_vec();
        data.extend_from_slice(&3_000i32.to_le_bytes());
        r.net.send(CanFrame::new(rpdo2, &data).unwrap()).unwrap();
        r.net
            .send(CanFrame::new(CanId::standard(0x080).unwrap(), &[]).unwrap())
            .unwrap();
    }
    let pos = r.drive.wait_target_reached(|_| {}).wait().unwrap();
    assert!((pos - 3_000).abs() <= 10, "{pos}");
}

#[test]
fn halt_stops_profile_velocity_in_operation_enabled_and_release_runs_again() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive.set_velocity(10_000).wait().unwrap();
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    let moving = r.model.lock().unwrap().velocity();
    assert!((moving - 10_000.0).abs() < 200.0, "{moving}");
    r.drive.halt(true).wait().unwrap();
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    assert!(r.model.lock().unwrap().velocity().abs() < 1.0);
    // Halt keeps the drive enabled (0x605D = 1: slow down and stay).
    assert_eq!(r.drive.state().wait().unwrap(), State::OperationEnabled);
    r.drive.halt(false).wait().unwrap();
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    assert!(r.model.lock().unwrap().velocity() > 5_000.0);
}

#[test]
fn profile_torque_accelerates_the_motor_and_shows_in_the_status() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive.set_torque(100).wait().unwrap();
    r.net.run_for(Duration::from_millis(200)).wait().unwrap();
    let s = r.drive.status().wait().unwrap();
    assert_eq!(s.mode, ModeOfOperation::ProfileTorque);
    assert_eq!(s.state, Some(State::OperationEnabled));
    assert!(s.torque > 0 && s.velocity > 0, "{s:?}");
    r.drive.set_torque(0).wait().unwrap();
    assert_eq!(r.drive.disable().wait().unwrap(), State::SwitchOnDisabled);
}

#[test]
fn enable_from_fault_resets_it_on_a_rising_edge_of_bit_7() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.model.lock().unwrap().inject_fault(SimFault::OverCurrent);
    r.net.run_for(Duration::from_millis(200)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::Fault);
    assert_eq!(r.drive.error_code().wait().unwrap().0, 0x2310);
    // The last controlword had bit 7 clear (0x000F): the planner's reset sends 0x0080 at once.
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
    assert_eq!(r.drive.error_code().wait().unwrap().0, 0);
}

#[test]
fn a_homing_method_the_drive_cannot_run_ends_in_a_homing_error() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    // Method 7 (home switch with a limit switch reversal) is not among the simulated methods.
    match r.drive.home(Some(7)).wait() {
        Err(DriveError::Homing { status, .. }) => assert!(status.is_error()),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.drive.state().wait().unwrap(), State::OperationEnabled);
}

#[test]
fn halt_outside_operation_enabled_is_refused_without_a_controlword() {
    let r = rig(SimConfig::default());
    r.drive.set_state(State::ReadyToSwitchOn).wait().unwrap();
    match r.drive.halt(true).wait() {
        Err(DriveError::NotEnabled { state, .. }) => assert_eq!(state, State::ReadyToSwitchOn),
        other => panic!("{other:?}"),
    }
    r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::ReadyToSwitchOn);
}

#[test]
fn a_drive_handle_sends_nothing_at_set_up_and_forces_no_nmt_state() {
    // python-canopen #178: set-up forced NMT and 402 transitions and timed out. A `Drive` is
    // made without bus traffic; its first read fails on its own SDO timeout when no device
    // answers, and no NMT command is ever sent.
    let r = rig(SimConfig::default());
    let mut tap = r.bus.endpoint();
    let absent = Drive::new(r.net.node(NodeId::new(9).unwrap()));
    r.net.run_for(Duration::from_millis(10)).wait().unwrap();
    let e = absent.state().wait().unwrap_err();
    assert!(matches!(e, DriveError::Sdo(_)), "{e}");
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
    let mut sent_nmt = false;
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        sent_nmt |= frame.cob_id() == Some(0x000);
    }
    assert!(!sent_nmt);
}

#[test]
fn the_statusword_is_read_fresh_without_any_tpdo() {
    // python-canopen #168/#554: a state machine run from a TPDO cache fails or lags when the
    // TPDO is missing or stale. With the device operational and TPDO1 switched off (0x1800:1
    // bit 31), every step still sees the drive's present state.
    let r = rig(SimConfig::default());
    let sdo = r.drive.node().sdo();
    let cob = u32::from_le_bytes(sdo.read((0x1800, 1)).wait().unwrap().try_into().unwrap());
    r.drive
        .node()
        .sdo()
        .write((0x1800, 1), cob | 0x8000_0000)
        .wait()
        .unwrap();
    r.drive.node().nmt().start().unwrap();
    let events = r.net.subscribe();
    assert_eq!(r.drive.enable().wait().unwrap(), State::OperationEnabled);
    assert_eq!(
        r.drive.quick_stop().wait().unwrap(),
        State::SwitchOnDisabled
    );
    let tpdo1 = events.try_iter().any(|e| {
        matches!(
            e,
            canola::NetworkEvent::Pdo { number: 1, .. }
                | canola::NetworkEvent::PdoValues { number: 1, .. }
        )
    });
    assert!(!tpdo1);
}

#[test]
fn two_axes_of_one_device_are_commanded_apart() {
    // A two-axis device: the EDS's profile objects again at + 0x800 (CiA 402-2 axis 1), one
    // simulated drive behind each axis.
    let mut od = canola::od::parse(EDS).unwrap().od;
    let axis0: Vec<_> = (0x6000..0x6800u16)
        .filter_map(|i| od.get(i).cloned())
        .collect();
    for mut o in axis0 {
        o.index += 0x800;
        od.insert(o);
    }
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(6).unwrap();
    let second = canola_cia402::master::DriveHook::new(SimDrive::new(SimConfig {
        axis: 1,
        ..SimConfig::default()
    }));
    let model1 = second.drive();
    bus.attach(
        canola::SimDevice::new(id, od)
            .with_hook(canola_cia402::master::DriveHook::new(SimDrive::default()))
            .with_hook(second),
    );
    net.node(id)
        .nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    let a0 = Drive::new(net.node(id));
    let a1 = Drive::on_axis(net.node(id), 1);
    assert_eq!(a1.enable().wait().unwrap(), State::OperationEnabled);
    let pos = a1
        .move_to(Move {
            target: 1_234,
            ..Move::default()
        })
        .wait()
        .unwrap();
    assert!((pos - 1_234).abs() <= 10);
    assert!((model1.lock().unwrap().position() - 1_234.0).abs() <= 10.0);
    assert_eq!(a0.state().wait().unwrap(), State::SwitchOnDisabled);
    assert_eq!(a0.position().wait().unwrap(), 0);
    assert_eq!(a0.mode().wait().unwrap(), ModeOfOperation::NoMode);
}

#[test]
fn actual_values_come_from_sync_tpdos_when_followed_and_by_sdo_when_stale() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5).unwrap();
    let node = net.add_node_with_dictionary(id, canola::od::parse(EDS).unwrap().od);
    let (device, _model) = simulated_drive(id, EDS, SimDrive::default()).unwrap();
    bus.attach(device);
    node.nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    node.nmt().start().unwrap();
    net.start_sync(Duration::from_millis(10)); // TPDO2 (statusword, 0x6064) on each SYNC
    let drive = Drive::new(node);
    drive.follow_tpdos(Duration::from_millis(50));
    drive.enable().wait().unwrap();
    drive
        .move_to(Move {
            target: 2_000,
            ..Move::default()
        })
        .wait()
        .unwrap();
    net.run_for(Duration::from_millis(30)).wait().unwrap();
    let uploads_of_6064 = |tap: &mut canola::Endpoint| {
        let mut n = 0;
        while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
            let d = frame.data();
            let upload = frame.cob_id() == Some(0x605) && d.len() == 8 && d[0] == 0x40;
            n += usize::from(upload && u16::from_le_bytes([d[1], d[2]]) == 0x6064);
        }
        n
    };
    let mut tap = bus.endpoint();
    assert!((drive.position().wait().unwrap() - 2_000).abs() <= 10);
    assert_eq!(uploads_of_6064(&mut tap), 0, "served from TPDO2");
    net.stop_sync();
    net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert!((drive.position().wait().unwrap() - 2_000).abs() <= 10);
    assert_eq!(uploads_of_6064(&mut tap), 1, "stale: read by SDO");
}

#[test]
fn a_csp_stream_on_sync_moves_the_drive_without_a_jump() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive
        .move_to(Move {
            target: 500,
            ..Move::default()
        })
        .wait()
        .unwrap();
    r.drive.node().nmt().start().unwrap();
    r.net.start_sync(Duration::from_millis(1));
    let stream = r
        .drive
        .start_cyclic(
            ModeOfOperation::CyclicSyncPosition,
            4,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    assert_eq!(
        r.drive.mode().wait().unwrap(),
        ModeOfOperation::CyclicSyncPosition
    );
    assert_eq!(r.drive.state().wait().unwrap(), State::OperationEnabled);
    // No jump to 0 when the mode switched: the first target was the actual position.
    r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    assert!((r.model.lock().unwrap().position() - 500.0).abs() <= 10.0);
    let mut farthest: f64 = 0.0;
    for i in 1..=300 {
        stream.set_target(500 + i * 10).unwrap();
        r.net.run_for(Duration::from_millis(1)).wait().unwrap();
        farthest = farthest.max(r.model.lock().unwrap().position());
    }
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    let pos = r.drive.position().wait().unwrap();
    assert!((pos - 3_500).abs() <= 20, "{pos} {farthest}");
    assert!(
        r.drive.statusword().wait().unwrap().bit(12),
        "csp: following the command"
    );
    stream.stop().unwrap();
    // Not a cyclic mode: refused before anything is written.
    assert!(matches!(
        r.drive
            .start_cyclic(
                ModeOfOperation::ProfilePosition,
                4,
                Duration::from_millis(1)
            )
            .wait(),
        Err(DriveError::NotCyclic(_))
    ));
}

#[test]
fn two_drives_follow_one_sync_with_both_rpdos_in_every_cycle() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut drives = Vec::new();
    for n in [5u8, 6] {
        let id = NodeId::new(n).unwrap();
        let (device, _) = simulated_drive(id, EDS, SimDrive::default()).unwrap();
        bus.attach(device);
        net.node(id)
            .nmt()
            .wait_for_bootup(Duration::from_secs(1))
            .wait()
            .unwrap();
        drives.push(Drive::new(net.node(id)));
    }
    net.nmt_all(canola::CommandSpecifier::Start).unwrap();
    for d in &drives {
        d.enable().wait().unwrap();
    }
    net.start_sync(Duration::from_millis(1));
    let streams: Vec<_> = drives
        .iter()
        .map(|d| {
            d.start_cyclic(
                ModeOfOperation::CyclicSyncPosition,
                4,
                Duration::from_millis(1),
            )
            .wait()
            .unwrap()
        })
        .collect();
    let mut tap = bus.endpoint();
    for i in 1..=100 {
        for (k, s) in streams.iter().enumerate() {
            s.set_target(i * 10 * (k as i32 + 1)).unwrap();
        }
        net.run_for(Duration::from_millis(1)).wait().unwrap();
    }
    net.stop_sync();
    // Between two SYNCs: RPDO4 of node 5 (0x505) and of node 6 (0x506), once each.
    let mut cycles: Vec<Vec<u16>> = Vec::new();
    while let Ok(Some(Received::Frame { frame, .. })) = tap.try_recv() {
        match frame.cob_id() {
            Some(0x080) => cycles.push(Vec::new()),
            Some(id @ (0x505 | 0x506)) => {
                if let Some(c) = cycles.last_mut() {
                    c.push(id);
                }
            }
            _ => {}
        }
    }
    cycles.pop(); // the last cycle may be cut short
    assert!(cycles.len() >= 90, "{}", cycles.len());
    for c in &cycles {
        let mut ids = c.clone();
        ids.sort_unstable();
        assert_eq!(ids, [0x505, 0x506], "{cycles:?}");
    }
    net.run_for(Duration::from_millis(500)).wait().unwrap();
    assert!((drives[0].position().wait().unwrap() - 1_000).abs() <= 20);
    assert!((drives[1].position().wait().unwrap() - 2_000).abs() <= 20);
}

#[test]
fn a_csv_stream_dropped_unstopped_quick_stops_the_drive() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive.node().nmt().start().unwrap();
    r.net.start_sync(Duration::from_millis(1));
    let stream = r
        .drive
        .start_cyclic(
            ModeOfOperation::CyclicSyncVelocity,
            4,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    stream.set_target(5_000).unwrap();
    r.net.run_for(Duration::from_millis(300)).wait().unwrap();
    assert!(r.model.lock().unwrap().velocity() > 4_000.0);
    // A task that held the stream ended early (an error, a panic): the stream is dropped.
    drop(stream);
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::SwitchOnDisabled);
    assert!(r.model.lock().unwrap().velocity().abs() < 1.0);
    // Stopped on purpose, a stream leaves the drive as commanded.
    r.drive.enable().wait().unwrap();
    let stream = r
        .drive
        .start_cyclic(
            ModeOfOperation::CyclicSyncVelocity,
            4,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    stream.set_target(2_000).unwrap();
    r.net.run_for(Duration::from_millis(300)).wait().unwrap();
    stream.stop().unwrap();
    r.net.run_for(Duration::from_millis(100)).wait().unwrap();
    assert_eq!(r.drive.state().wait().unwrap(), State::OperationEnabled);
    assert!(r.model.lock().unwrap().velocity() > 1_500.0);
}

#[test]
fn homing_by_method_number_on_the_present_position_or_skipped_when_already_homed() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive
        .move_to(Move {
            target: 1_234,
            ..Move::default()
        })
        .wait()
        .unwrap();
    // Already homed (an absolute encoder): nothing written, no mode change, no motion.
    let before = r.drive.mode().wait().unwrap();
    let pos = r.drive.home_with(Homing::AlreadyHomed).wait().unwrap();
    assert!((pos - 1_234).abs() <= 10, "{pos}");
    assert_eq!(r.drive.mode().wait().unwrap(), before);
    // Homing on the present position (method 37): no motion, the position becomes the home
    // offset (0).
    let shaft = r.model.lock().unwrap().position();
    let pos = r.drive.home_with(Homing::CurrentPosition).wait().unwrap();
    assert_eq!(pos, 0);
    assert_eq!(r.drive.mode().wait().unwrap(), ModeOfOperation::Homing);
    assert!((r.model.lock().unwrap().position() - 0.0).abs() <= 1.0);
    assert!(
        (r.model.lock().unwrap().position() - shaft + 1_234.0).abs() <= 10.0,
        "the shaft did not move"
    );
    // A method by number: 19, the home switch from 5000 counts of the shaft.
    let pos = r.drive.home_with(Homing::Method(19)).wait().unwrap();
    assert!(pos.abs() <= 10, "{pos}");
}

#[test]
fn a_mode_change_refused_while_halted_says_halt_is_set() {
    let r = rig(SimConfig {
        refuse_mode_change_while_halt: true,
        ..SimConfig::default()
    });
    r.drive.enable().wait().unwrap();
    r.drive.set_velocity(5_000).wait().unwrap();
    r.drive.halt(true).wait().unwrap();
    let e = r
        .drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap_err();
    match &e {
        DriveError::ModeRefusedWhileHalted { mode, controlword } => {
            assert_eq!(*mode, ModeOfOperation::ProfilePosition);
            assert!(controlword.halt());
        }
        other => panic!("{other}"),
    }
    assert!(e.to_string().contains("clear halt first"), "{e}");
    // Nothing changed behind the caller's back: still halted in pv.
    assert_eq!(
        r.drive.mode().wait().unwrap(),
        ModeOfOperation::ProfileVelocity
    );
    r.drive.halt(false).wait().unwrap();
    r.drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .wait()
        .unwrap();
}

#[test]
fn an_ip_stream_on_sync_follows_its_set_points() {
    let r = rig(SimConfig::default());
    r.drive.enable().wait().unwrap();
    r.drive
        .move_to(Move {
            target: 500,
            ..Move::default()
        })
        .wait()
        .unwrap();
    r.drive.node().nmt().start().unwrap();
    r.net.start_sync(Duration::from_millis(1));
    let stream = r
        .drive
        .start_cyclic(
            ModeOfOperation::InterpolatedPosition,
            4,
            Duration::from_millis(1),
        )
        .wait()
        .unwrap();
    assert_eq!(
        r.drive.mode().wait().unwrap(),
        ModeOfOperation::InterpolatedPosition
    );
    // Linear sub-mode, period 1 ms (0x60C2 = 1 × 10^-3 s), ip enabled (statusword bit 12).
    let sdo = || r.drive.node().sdo();
    assert_eq!(sdo().read((0x60C0, 0)).wait().unwrap(), [0, 0]);
    assert_eq!(sdo().read((0x60C2, 1)).wait().unwrap(), [1]);
    assert_eq!(sdo().read((0x60C2, 2)).wait().unwrap(), [0xFD]);
    r.net.run_for(Duration::from_millis(20)).wait().unwrap();
    assert!(
        r.drive.statusword().wait().unwrap().bit(12),
        "ip mode active"
    );
    assert!((r.model.lock().unwrap().position() - 500.0).abs() <= 10.0);
    for i in 1..=300 {
        stream.set_target(500 + i * 10).unwrap();
        r.net.run_for(Duration::from_millis(1)).wait().unwrap();
    }
    r.net.run_for(Duration::from_millis(500)).wait().unwrap();
    let pos = r.drive.position().wait().unwrap();
    assert!((pos - 3_500).abs() <= 20, "{pos}");
    stream.stop().unwrap();
}
