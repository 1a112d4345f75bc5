//! A profile-position move on the simulated servo (no hardware): the drive from
//! `eds/cia402-servo.eds` on the in-memory bus, enabled, moved to 4000 counts and back by
//! 1500, with its position printed while it moves.
//!
//! `cargo run -p canola-cia402 --features master --example drive_move`. On a real bus, replace
//! the first lines of `run` with `let net = Network::open("can0")?;` (canola's `socketcan`
//! feature) and leave out the simulated device.

use canola::{Duration, MemoryBus, Network, NodeId};
use canola_cia402::master::{Drive, Move, simulated_drive};
use canola_cia402::sim::SimDrive;
use canola_cia402::{ModeOfOperation, State};

const EDS: &[u8] = include_bytes!("../../../eds/cia402-servo.eds");

fn run() -> Result<i32, Box<dyn std::error::Error>> {
    let bus = MemoryBus::new(); // virtual clock: runs in no time, deterministically
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(5)?;
    let (device, _model) = simulated_drive(id, EDS, SimDrive::default())?;
    bus.attach(device);
    net.node(id)
        .nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()?;

    let drive = Drive::new(net.node(id));
    drive.set_mode(ModeOfOperation::ProfilePosition).wait()?; // confirmed by 0x6061
    assert_eq!(drive.enable().wait()?, State::OperationEnabled);
    let pos = drive
        .move_to(Move {
            target: 4_000,
            velocity: Some(20_000),
            ..Move::default()
        })
        .wait()?;
    println!("target reached at {pos}");
    drive
        .start_move(Move {
            target: -1_500,
            relative: true,
            ..Move::default()
        })
        .wait()?;
    let mut shown = i32::MAX;
    let pos = drive
        .wait_target_reached(|p| {
            if p.abs_diff(shown) >= 250 {
                println!("position {p}");
                shown = p;
            }
        })
        .wait()?;
    println!("target reached at {pos}; {}", drive.state().wait()?);
    Ok(pos)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run().map(|_| ())
}

#[cfg(test)]
#[test]
fn runs() {
    let pos = run().unwrap();
    assert!((pos - 2_500).abs() <= 10, "{pos}");
}
