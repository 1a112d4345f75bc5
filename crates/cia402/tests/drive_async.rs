//! The `Drive` commands awaited (canola's `tokio` feature): the same operations the blocking
//! tests finish with `.wait()`, here `.await`ed on a paused tokio clock that the in-memory
//! bus's virtual time follows, against the simulated drive (`DriveHook` behind a `SimDevice`
//! from `eds/cia402-servo.eds`) through the real SDO codec. Two drives moved at once with
//! `tokio::join!`, and a move whose future is dropped half-way.

use std::future::IntoFuture;
use std::sync::{Arc, Mutex};

use canola::{Duration, MemoryBus, Network, NodeId};
use canola_cia402::master::{
    Awaited, Drive, DriveError, Move, OnCancel, Reached, Timeouts, simulated_drive,
};
use canola_cia402::sim::{SimDrive, SimFault};
use canola_cia402::{ModeOfOperation, State};

const EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");

/// A simulated drive at `id` on `bus`, booted, and its `Drive`.
async fn drive_at(bus: &MemoryBus, net: &Network, id: u8) -> (Drive, Arc<Mutex<SimDrive>>) {
    let id = NodeId::new(id).unwrap();
    let node = net.add_node(id);
    let (device, model) = simulated_drive(id, EDS, SimDrive::default()).unwrap();
    bus.attach(device);
    node.nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .await
        .unwrap();
    (Drive::new(node), model)
}

fn shaft(model: &Arc<Mutex<SimDrive>>) -> f64 {
    model.lock().unwrap().position()
}

#[tokio::test(start_paused = true)]
async fn awaited_enable_mode_move_home_quick_stop_and_fault_reset() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let (drive, model) = drive_at(&bus, &net, 5).await;

    assert_eq!(drive.enable().await.unwrap(), State::OperationEnabled);
    drive
        .set_mode(ModeOfOperation::ProfilePosition)
        .await
        .unwrap();
    assert_eq!(
        drive.mode().await.unwrap(),
        ModeOfOperation::ProfilePosition
    );
    let (bus_start, clock_start) = (net.now(), tokio::time::Instant::now());
    let pos = drive
        .move_to(Move {
            target: 4_000,
            velocity: Some(20_000),
            ..Move::default()
        })
        .await
        .unwrap();
    assert!((pos - 4_000).abs() <= 10, "{pos}");
    assert!((shaft(&model) - 4_000.0).abs() <= 10.0);
    let sw = drive.statusword().await.unwrap();
    assert!(sw.target_reached(), "{sw}");
    // The move took bus time, and that time is tokio's (paused: it jumped).
    let on_bus = net.now() - bus_start;
    let on_tokio = clock_start.elapsed();
    assert!(on_bus >= Duration::from_millis(100), "{on_bus}");
    assert!(
        on_tokio
            .as_micros()
            .abs_diff(u128::from(on_bus.as_micros()))
            <= 10_000,
        "bus {on_bus}, tokio {on_tokio:?}"
    );

    // Method 19: the home switch (from 5000 counts) searched in the positive direction; that
    // point becomes position 0.
    let pos = drive.home(Some(19)).await.unwrap();
    assert!(pos.abs() <= 10, "position after homing {pos}");
    assert_eq!(drive.mode().await.unwrap(), ModeOfOperation::Homing);

    // 0x605A is 2 on the simulated drive: a quick stop ends in switch on disabled.
    assert_eq!(drive.quick_stop().await.unwrap(), State::SwitchOnDisabled);
    assert_eq!(drive.state().await.unwrap(), State::SwitchOnDisabled);

    drive.enable().await.unwrap();
    drive
        .start_move(Move {
            target: 50_000,
            ..Move::default()
        })
        .await
        .unwrap();
    model.lock().unwrap().inject_fault(SimFault::FollowingError);
    match drive.wait_target_reached(|_| {}).await {
        Err(DriveError::Fault { code, .. }) => assert_eq!(code.0, 0x8611),
        other => panic!("{other:?}"),
    }
    let report = drive.fault_reset().await.unwrap();
    assert_eq!(report.code.0, 0x8611);
    assert_eq!(report.from, State::Fault);
    assert_eq!(report.state, State::SwitchOnDisabled);
    assert_eq!(drive.error_code().await.unwrap().0, 0);
    assert_eq!(drive.enable().await.unwrap(), State::OperationEnabled);
}

#[tokio::test(start_paused = true)]
async fn two_drives_move_together_under_join() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let (a, model_a) = drive_at(&bus, &net, 5).await;
    let (b, model_b) = drive_at(&bus, &net, 6).await;
    let (ea, eb) = tokio::join!(a.enable(), b.enable());
    assert_eq!(ea.unwrap(), State::OperationEnabled);
    assert_eq!(eb.unwrap(), State::OperationEnabled);
    let to = |target| Move {
        target,
        velocity: Some(20_000),
        ..Move::default()
    };

    // One move alone, for its duration.
    let start = net.now();
    a.move_to(to(4_000)).await.unwrap();
    let alone = net.now() - start;

    // The same distance on both drives at once: each sees the other's axis moving while it
    // waits, and together they take about as long as one.
    let seen_b_moving = Arc::new(Mutex::new(Vec::new()));
    let seen = Arc::clone(&seen_b_moving);
    let mb = Arc::clone(&model_b);
    let start = net.now();
    let back = async {
        a.start_move(to(0)).await?;
        a.wait_target_reached(move |_| seen.lock().unwrap().push(shaft(&mb)))
            .await
    };
    let (pa, pb) = tokio::join!(back, b.move_to(to(-4_000)));
    let together = net.now() - start;
    let (pa, pb) = (pa.unwrap(), pb.unwrap());
    assert!(pa.abs() <= 10, "{pa}");
    assert!((pb + 4_000).abs() <= 10, "{pb}");
    assert!(shaft(&model_a).abs() <= 10.0);
    assert!((shaft(&model_b) + 4_000.0).abs() <= 10.0);
    let seen = seen_b_moving.lock().unwrap();
    assert!(
        seen.iter().any(|p| *p < -100.0 && *p > -3_900.0),
        "drive 6 was never seen between its start and its target while drive 5 moved: {seen:?}"
    );
    assert!(
        together.as_micros() < alone.as_micros() * 3 / 2,
        "one move {alone}, two together {together}"
    );
}

#[tokio::test(start_paused = true)]
async fn dropping_a_move_half_way_quick_stops_the_drive_and_leaves_it_usable() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let (drive, model) = drive_at(&bus, &net, 5).await;
    assert_eq!(drive.on_cancel(), OnCancel::QuickStop);
    drive.enable().await.unwrap();
    let long = drive.move_to(Move {
        target: 100_000,
        velocity: Some(20_000),
        ..Move::default()
    });
    let r = tokio::time::timeout(std::time::Duration::from_millis(300), long).await;
    assert!(r.is_err(), "a 100 000-count move cannot end in 300 ms");
    let halfway = shaft(&model);
    assert!(
        halfway > 100.0 && halfway < 99_000.0,
        "the move had started: {halfway}"
    );
    // The drop sent a quick stop: the drive brakes and ends as 0x605A (2) says, standing still
    // far from the target.
    net.run_for(Duration::from_millis(500)).await.unwrap();
    assert_eq!(drive.state().await.unwrap(), State::SwitchOnDisabled);
    let stopped = shaft(&model);
    net.run_for(Duration::from_millis(200)).await.unwrap();
    assert!(
        (shaft(&model) - stopped).abs() < 1.0,
        "{stopped} -> {}",
        shaft(&model)
    );
    assert!(stopped < 20_000.0, "{stopped}");
    drive.enable().await.unwrap();
    // The dropped move's requests are gone: the next commands run at once, and a new move
    // (a rising set-point edge again) starts from wherever the shaft is.
    assert_eq!(drive.state().await.unwrap(), State::OperationEnabled);
    let pos = drive
        .move_to(Move {
            target: 1_000,
            velocity: Some(20_000),
            immediate: true,
            ..Move::default()
        })
        .await
        .unwrap();
    assert!((pos - 1_000).abs() <= 10, "{pos}");
    assert!((shaft(&model) - 1_000.0).abs() <= 10.0);
    // And blocking again from the same drive.
    let pos = tokio::task::spawn_blocking({
        let drive = drive.clone();
        move || {
            drive
                .move_to(Move {
                    target: 2_000,
                    ..Move::default()
                })
                .wait()
        }
    })
    .await
    .unwrap()
    .unwrap();
    assert!((pos - 2_000).abs() <= 10, "{pos}");
}

#[tokio::test(start_paused = true)]
async fn a_move_dropped_with_on_cancel_halt_halts_and_stays_enabled() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let (drive, model) = drive_at(&bus, &net, 5).await;
    let drive = drive.with_on_cancel(OnCancel::Halt);
    drive.enable().await.unwrap();
    let long = drive.move_to(Move {
        target: 100_000,
        velocity: Some(20_000),
        ..Move::default()
    });
    assert!(
        tokio::time::timeout(std::time::Duration::from_millis(300), long)
            .await
            .is_err()
    );
    net.run_for(Duration::from_millis(500)).await.unwrap();
    let status = drive.status().await.unwrap();
    assert_eq!(status.state, Some(State::OperationEnabled));
    assert!(status.statusword.bit(10), "halted: the axis stands still");
    let stopped = shaft(&model);
    net.run_for(Duration::from_millis(200)).await.unwrap();
    assert!((shaft(&model) - stopped).abs() < 1.0);
    assert!(stopped < 20_000.0, "{stopped}");
    // Halt cleared, a new move runs to its end (and, finished, stops nothing).
    drive.halt(false).await.unwrap();
    let pos = drive
        .move_to(Move {
            target: 1_000,
            immediate: true,
            ..Move::default()
        })
        .await
        .unwrap();
    assert!((pos - 1_000).abs() <= 10, "{pos}");
    assert_eq!(drive.state().await.unwrap(), State::OperationEnabled);
}

#[tokio::test(start_paused = true)]
async fn a_spawned_move_times_out_on_the_bus_clock_naming_expected_reached_and_statusword() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let (drive, _model) = drive_at(&bus, &net, 5).await;
    drive.enable().await.unwrap();
    // A clone with a short motion timeout, its move spawned as a task of its own.
    let short = drive.clone().with_timeouts(Timeouts {
        motion: Duration::from_millis(50),
        ..Timeouts::default()
    });
    let task = tokio::spawn(
        short
            .move_to(Move {
                target: 100_000,
                ..Move::default()
            })
            .into_future(),
    );
    match task.await.unwrap() {
        Err(e @ DriveError::Timeout { .. }) => {
            let text = e.to_string();
            let DriveError::Timeout {
                awaited,
                reached,
                statusword,
                waited,
                ..
            } = e
            else {
                unreachable!()
            };
            assert_eq!(awaited, Awaited::TargetReached);
            assert!(matches!(reached, Reached::Position(_)), "{reached}");
            assert!(!statusword.target_reached(), "{statusword}");
            assert!(
                waited >= Duration::from_millis(50) && waited < Duration::from_millis(100),
                "{waited}"
            );
            assert!(text.contains("statusword"), "{text}");
        }
        other => panic!("{other:?}"),
    }
    // The drive (and the first handle) is still enabled and answers.
    assert_eq!(drive.state().await.unwrap(), State::OperationEnabled);
}
