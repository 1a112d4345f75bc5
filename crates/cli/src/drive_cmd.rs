//! `canopen drive NODE ...`: a CiA 402 drive through [`canola_cia402::master::Drive`]: status,
//! the power states, modes, homing, profile-position moves with their live position, velocity
//! and torque. Also the simulated drive the bus commands run for a 402 dictionary (on the
//! in-memory bus and in `canopen simulate`).

use std::process::ExitCode;

use canola::NodeId;
use canola_cia402::master::{Drive, DriveError, DriveStatus, Move};
use canola_cia402::{ModeOfOperation, State};
use clap::{Args, Subcommand};
use serde_json::json;

use crate::bus::{BusOpts, fail, open_network, parse_node};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen drive NODE COMMAND`
#[derive(Debug, Args)]
pub(crate) struct DriveArgs {
    /// Node-ID.
    #[arg(value_parser = parse_node)]
    node: NodeId,
    /// The axis of a multi-axis drive (objects at index + axis × 0x800).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=7))]
    axis: u8,
    #[command(subcommand)]
    command: DriveCommand,
}

#[derive(Debug, Subcommand)]
enum DriveCommand {
    /// Statusword, state, mode, actual position, velocity and torque, error code.
    Status,
    /// Operation enabled, from any state (resetting a fault on the way).
    Enable,
    /// Switch on disabled.
    Disable,
    /// Quick stop: ends in quick stop active or switch on disabled, as 0x605A says.
    QuickStop,
    /// Fault reset: prints 0x603F and the last EMCY, ends in switch on disabled.
    FaultReset,
    /// Select a mode (pp, vl, pv, tq, hm, ip, csp, csv, cst or its number), confirmed by 0x6061.
    Mode {
        /// The mode.
        #[arg(value_parser = parse_mode, allow_negative_numbers = true)]
        mode: ModeOfOperation,
    },
    /// Homing (mode hm), optionally with a method (0x6098); needs operation enabled.
    Home {
        /// The homing method.
        #[arg(allow_negative_numbers = true)]
        method: Option<i8>,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
    /// Profile-position move to POS (counts), printing the position while it moves, until
    /// target reached (statusword bit 10). Needs operation enabled.
    Move {
        /// The target, counts.
        #[arg(allow_negative_numbers = true)]
        position: i32,
        /// Relative to the present target.
        #[arg(long)]
        relative: bool,
        /// Profile velocity (0x6081), counts/s.
        #[arg(long)]
        velocity: Option<u32>,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
    /// Profile velocity: mode pv, target velocity 0x60FF (counts/s).
    Velocity {
        /// Counts/s.
        #[arg(allow_negative_numbers = true)]
        velocity: i32,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
    /// Profile torque: mode tq, target torque 0x6071 (‰ of rated torque).
    Torque {
        /// ‰ of rated torque.
        #[arg(allow_negative_numbers = true)]
        torque: i16,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
}

fn mode_text(m: ModeOfOperation) -> String {
    match m.short_name() {
        Some(n) => format!("{n} ({})", m.code()),
        None if m == ModeOfOperation::NoMode => "no mode (0)".to_string(),
        None => format!("{}", m.code()),
    }
}

fn parse_mode(s: &str) -> Result<ModeOfOperation, CliError> {
    if let Some(m) = ModeOfOperation::from_short_name(&s.to_ascii_lowercase()) {
        return Ok(m);
    }
    s.parse::<i8>()
        .map(ModeOfOperation::from_code)
        .map_err(|_| {
            CliError::Argument(format!(
                "`{s}`: not a mode (pp, vl, pv, tq, hm, ip, csp, csv, cst or -128..127)"
            ))
        })
}

fn status_json(s: &DriveStatus) -> serde_json::Value {
    json!({
        "statusword": format!("{:#06x}", s.statusword.raw()),
        "state": s.state.map(State::name),
        "mode": s.mode.code(),
        "mode_name": s.mode.short_name(),
        "position": s.position,
        "velocity": s.velocity,
        "torque": s.torque,
        "error_code": format!("{:#06x}", s.error_code.0),
        "target_reached": s.statusword.target_reached(),
    })
}

fn print_state(g: Global, state: State) {
    if g.json {
        outln(&json!({"state": state.name()}).to_string());
    } else {
        outln(state.name());
    }
}

fn enable_first(drive: &Drive, enable: bool) -> Result<(), DriveError> {
    if enable && drive.state().wait()? != State::OperationEnabled {
        drive.enable().wait()?;
    }
    Ok(())
}

/// `canopen drive NODE COMMAND`
pub(crate) fn run(args: DriveArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let drive = Drive::on_axis(net.node(args.node), args.axis);
    match run_command(&drive, args.command, g) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

fn run_command(drive: &Drive, command: DriveCommand, g: Global) -> Result<(), DriveError> {
    match command {
        DriveCommand::Status => {
            let s = drive.status().wait()?;
            if g.json {
                outln(&status_json(&s).to_string());
            } else {
                outln(&format!(
                    "state: {}\nstatusword: {:#06x}\nmode: {}\nposition: {}\nvelocity: {}\ntorque: {}\nerror code: {}",
                    s.state.map_or("(no state)", State::name),
                    s.statusword.raw(),
                    mode_text(s.mode),
                    s.position,
                    s.velocity,
                    s.torque,
                    s.error_code
                ));
            }
        }
        DriveCommand::Enable => print_state(g, drive.enable().wait()?),
        DriveCommand::Disable => print_state(g, drive.disable().wait()?),
        DriveCommand::QuickStop => print_state(g, drive.quick_stop().wait()?),
        DriveCommand::FaultReset => {
            let r = drive.fault_reset().wait()?;
            if g.json {
                outln(
                    &json!({
                        "error_code": format!("{:#06x}", r.code.0),
                        "error": r.code.name(),
                        "emcy": r.emcy.map(|e| e.to_string()),
                        "from": r.from.name(),
                        "state": r.state.name(),
                    })
                    .to_string(),
                );
            } else {
                outln(&format!("error code: {}", r.code));
                if let Some(e) = &r.emcy {
                    outln(&format!("last EMCY: {e}"));
                }
                outln(&format!("{} -> {}", r.from, r.state));
            }
        }
        DriveCommand::Mode { mode } => {
            let before = drive.set_mode(mode).wait()?;
            if g.json {
                outln(&json!({"mode": mode.code(), "mode_name": mode.short_name(), "before": before.code()}).to_string());
            } else {
                outln(&format!("mode: {}", mode_text(mode)));
            }
        }
        DriveCommand::Home { method, enable } => {
            if enable {
                // The mode first (any state), then the power.
                drive.set_mode(ModeOfOperation::Homing).wait()?;
                enable_first(drive, true)?;
            }
            let pos = drive.home(method).wait()?;
            if g.json {
                outln(&json!({"homed": true, "position": pos}).to_string());
            } else {
                outln(&format!("homing completed at position {pos}"));
            }
        }
        DriveCommand::Move {
            position,
            relative,
            velocity,
            enable,
        } => {
            enable_first(drive, enable)?;
            drive
                .start_move(Move {
                    target: position,
                    relative,
                    velocity,
                    immediate: false,
                })
                .wait()?;
            let net = drive.node().network().clone();
            let mut last_print = None;
            let pos = drive
                .wait_target_reached(|p| {
                    let now = net.now();
                    let due =
                        last_print.is_none_or(|t| now - t >= canola::Duration::from_millis(100));
                    if due && !g.json {
                        outln(&format!("position {p}"));
                        last_print = Some(now);
                    }
                })
                .wait()?;
            let sw = drive.statusword().wait()?;
            if g.json {
                outln(&json!({"target_reached": true, "position": pos, "statusword": format!("{:#06x}", sw.raw())}).to_string());
            } else {
                outln(&format!("target reached at position {pos}"));
            }
        }
        DriveCommand::Velocity { velocity, enable } => {
            drive.set_velocity(velocity).wait()?;
            enable_first(drive, enable)?;
            let state = drive.state().wait()?;
            if g.json {
                outln(
                    &json!({"mode": "pv", "target_velocity": velocity, "state": state.name()})
                        .to_string(),
                );
            } else {
                outln(&format!("target velocity {velocity} (pv), drive {state}"));
            }
        }
        DriveCommand::Torque { torque, enable } => {
            drive.set_torque(torque).wait()?;
            enable_first(drive, enable)?;
            let state = drive.state().wait()?;
            if g.json {
                outln(
                    &json!({"mode": "tq", "target_torque": torque, "state": state.name()})
                        .to_string(),
                );
            } else {
                outln(&format!("target torque {torque} (tq), drive {state}"));
            }
        }
    }
    Ok(())
}
