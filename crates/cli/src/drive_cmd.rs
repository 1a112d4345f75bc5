//! `canopen drive NODE ...`: a CiA 402 drive through [`canola_cia402::master::Drive`]: status,
//! the power states, modes, homing, profile-position moves with their live position, velocity
//! and torque. Also the simulated drive the bus commands run for a 402 dictionary (on the
//! in-memory bus and in `canopen simulate`).
//!
//! The commands that start motion (`home`, `move`, `velocity`, `torque`) take SIGINT and SIGTERM
//! (Ctrl-C) while they run: the drive gets a quick stop (it brakes on its quick stop ramp and
//! ends as its 0x605A says), the command says what it did and where the drive stopped, and exits
//! with status 128 + the signal's number (130 for SIGINT, 143 for SIGTERM). A second signal ends
//! the process at once.

use std::future::{Future, IntoFuture};
use std::pin::Pin;
use std::process::ExitCode;
use std::task::{Context, Poll};

use canola::{Duration, NodeId, Operation};
use canola_cia402::master::{Drive, DriveError, DriveStatus, Move};
use canola_cia402::{ModeOfOperation, State};
use clap::{Args, Subcommand};
use serde_json::json;

use crate::bus::{
    BusOpts, fail, open_network, parse_node, stop_on_signals, stop_requested, stopped_by,
};
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
    /// Homing (mode hm), optionally with a method (0x6098); needs operation enabled. Ctrl-C
    /// (SIGINT) or SIGTERM quick-stops the drive (it ends as 0x605A says) and exits 130 (143
    /// for SIGTERM).
    Home {
        /// The homing method.
        #[arg(allow_negative_numbers = true)]
        method: Option<i8>,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
    /// Profile-position move to POS (counts), printing the position while it moves, until
    /// target reached (statusword bit 10). Needs operation enabled. Ctrl-C (SIGINT) or SIGTERM
    /// quick-stops the drive (it ends as 0x605A says) and exits 130 (143 for SIGTERM).
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
    /// Profile velocity: mode pv, target velocity 0x60FF (counts/s). The drive keeps the
    /// velocity after the command ends; stop it with `quick-stop`, `velocity 0` or `disable`.
    Velocity {
        /// Counts/s.
        #[arg(allow_negative_numbers = true)]
        velocity: i32,
        /// Enable the drive first when it is not enabled.
        #[arg(long)]
        enable: bool,
    },
    /// Profile torque: mode tq, target torque 0x6071 (‰ of rated torque). The drive keeps the
    /// torque after the command ends; stop it with `quick-stop`, `torque 0` or `disable`.
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

/// Why a motion command ended early.
enum Ended {
    /// The drive command failed.
    Drive(DriveError),
    /// SIGINT or SIGTERM arrived.
    Signal,
}

impl From<DriveError> for Ended {
    fn from(e: DriveError) -> Self {
        Self::Drive(e)
    }
}

/// `canopen drive NODE COMMAND`
pub(crate) fn run(args: DriveArgs, opts: &BusOpts, g: Global) -> ExitCode {
    let moves = matches!(
        args.command,
        DriveCommand::Home { .. }
            | DriveCommand::Move { .. }
            | DriveCommand::Velocity { .. }
            | DriveCommand::Torque { .. }
    );
    // Before the network's threads start: the signals go to a thread of their own.
    if moves && let Err(e) = stop_on_signals() {
        return fail(e);
    }
    let (net, _mem) = match open_network(opts) {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    let drive = Drive::on_axis(net.node(args.node), args.axis);
    match run_command(&drive, args.command, g) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Ended::Drive(e @ DriveError::NotEnabled { .. })) if moves => {
            let hint = "give --enable to enable the drive first";
            if g.json {
                eprintln!("{}", json!({"error": e.to_string(), "hint": hint}));
            } else {
                eprintln!("error: {e}\nhint: {hint}");
            }
            ExitCode::FAILURE
        }
        Err(Ended::Drive(e)) => fail(e),
        Err(Ended::Signal) => interrupted(&drive, g),
    }
}

/// `op` run until it ends or SIGINT/SIGTERM arrives ([`Ended::Signal`]; `op` is then
/// dropped, which starts the drive's quick stop).
fn until_signal<T: Send>(drive: &Drive, op: Operation<'_, T, DriveError>) -> Result<T, Ended> {
    let net = drive.node().network().clone();
    let watch = Box::pin(async move {
        while !stop_requested() {
            if net.run_for(Duration::from_millis(20)).await.is_err() {
                // The bus failed: the command's own operation says so.
                std::future::pending::<()>().await;
            }
        }
    });
    let first = First {
        op: Box::pin(op.into_future()),
        watch,
    };
    // In a join, the operations awaited inside poll without blocking (a plain wait would run
    // the command's operation to its end before the watch is looked at).
    let raced = Operation::new(async move { Ok::<_, DriveError>(first.await) });
    match canola::join_all([raced]).wait()?.pop() {
        Some(Ok(Some(r))) => Ok(r?),
        Some(Err(e)) => Err(e.into()),
        Some(Ok(None)) | None => Err(Ended::Signal),
    }
}

/// The command's operation raced against the signal watch: `None` when the watch ends first.
struct First<A, W> {
    op: Pin<Box<A>>,
    watch: Pin<Box<W>>,
}

impl<A: Future, W: Future<Output = ()>> Future for First<A, W> {
    type Output = Option<A::Output>;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        if let Poll::Ready(r) = self.op.as_mut().poll(cx) {
            return Poll::Ready(Some(r));
        }
        match self.watch.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(None),
            Poll::Pending => Poll::Pending,
        }
    }
}

/// After a signal: the quick stop (sent already when the command's operation was dropped),
/// waited until the drive stands still or leaves quick stop active, then reported; exit status
/// 128 + the signal's number (130 for SIGINT, 143 for SIGTERM).
fn interrupted(drive: &Drive, g: Global) -> ExitCode {
    let (status, signal) = stopped_by();
    let stopped = (|| -> Result<(State, i32), DriveError> {
        let mut state = drive.quick_stop().wait()?;
        let net = drive.node().network();
        // Braking on the quick stop ramp takes a while. A drive whose 0x605A (2 when it has
        // none) ends the quick stop in switch on disabled says so when it stands still; one
        // that stays in quick stop active, by its velocity.
        let at = canola_cia402::objects::on_axis(
            canola_cia402::objects::QUICK_STOP_OPTION_CODE,
            drive.axis(),
        );
        let stays = match at {
            Some(e) => match drive.node().sdo().read((e.index(), e.sub_index())).wait() {
                Ok(b) if b.len() >= 2 => {
                    canola_cia402::QuickStopOption(i16::from_le_bytes([b[0], b[1]]))
                        .stays_in_quick_stop()
                }
                _ => false,
            },
            None => false,
        };
        let start = net.now();
        while state == State::QuickStopActive && net.now() - start < Duration::from_secs(10) {
            if stays && drive.velocity().wait()? == 0 {
                break;
            }
            net.run_for(Duration::from_millis(20)).wait()?;
            state = drive.state().wait()?;
        }
        Ok((state, drive.position().wait()?))
    })();
    match stopped {
        Ok((state, position)) => {
            if g.json {
                eprintln!(
                    "{}",
                    json!({"error": "interrupted", "signal": signal, "stopped_by": "quick stop", "state": state.name(), "position": position})
                );
            } else {
                eprintln!(
                    "interrupted by {signal}: quick stop sent; the drive stopped in state \"{state}\" at position {position}"
                );
            }
        }
        Err(e) => {
            let text = format!(
                "interrupted by {signal}: quick stop sent, but the drive did not confirm it: {e}"
            );
            if g.json {
                eprintln!("{}", json!({"error": text, "signal": signal}));
            } else {
                eprintln!("error: {text}");
            }
        }
    }
    ExitCode::from(status)
}

fn run_command(drive: &Drive, command: DriveCommand, g: Global) -> Result<(), Ended> {
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
            let pos = until_signal(drive, drive.home(method))?;
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
            until_signal(
                drive,
                drive.start_move(Move {
                    target: position,
                    relative,
                    velocity,
                    immediate: false,
                }),
            )?;
            let net = drive.node().network().clone();
            let mut last_print = None;
            let pos = until_signal(
                drive,
                drive.wait_target_reached(|p| {
                    let now = net.now();
                    let due = last_print.is_none_or(|t| now - t >= Duration::from_millis(100));
                    if due && !g.json {
                        outln(&format!("position {p}"));
                        last_print = Some(now);
                    }
                }),
            )?;
            let sw = drive.statusword().wait()?;
            if g.json {
                outln(&json!({"target_reached": true, "position": pos, "statusword": format!("{:#06x}", sw.raw())}).to_string());
            } else {
                outln(&format!("target reached at position {pos}"));
            }
        }
        DriveCommand::Velocity { velocity, enable } => {
            until_signal(drive, drive.set_velocity(velocity))?;
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
            until_signal(drive, drive.set_torque(torque))?;
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

/// The type of a CiA 402 object (0x6000..=0x9FFF, any axis) on a node whose device type 0x1000
/// names profile 402 (read by SDO once the other sources of a type gave none), as the CLI knows
/// the CiA 301 objects' types without an EDS.
pub(crate) fn profile_type(
    net: &canola::Network,
    node: NodeId,
    entry: canola::ObjectAddress,
) -> Option<canola::od::DataType> {
    let info = canola_cia402::objects::find(entry.index, entry.sub_index)?;
    let bytes = net.node(node).sdo().read((0x1000, 0)).wait().ok()?;
    let device_type = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?);
    canola_cia402::objects::is_drive_profile(device_type).then_some(info.data_type)
}
