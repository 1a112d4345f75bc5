//! `canopen`: the command-line tool of the stack, in the habits of can-utils and python-canopen.
//!
//! One module per command group; each parses its own arguments (clap derive) and returns the
//! process exit code. Errors go to stderr, results to stdout (`--json` for scripts).

use std::process::ExitCode;

use clap::{CommandFactory as _, Parser, Subcommand};

mod adapter;
mod analyze;
mod argv;
mod boot;
mod burkert;
mod bus;
mod cpos;
mod demo;
mod drive_cmd;
mod eds;
mod error;
mod gateway;
mod gateway_access;
mod lss_cmd;
mod nmt_cmd;
mod objaddr;
mod outfile;
mod pdo_cmd;
mod sdo_cmd;
mod sim_device;
mod simulate;
mod store_cmd;
mod top;
mod traffic;

/// CANopen master tools: EDS files, and (with the bus commands) devices on SocketCAN or a
/// simulated bus.
#[derive(Debug, Parser)]
#[command(name = "canopen", version, about)]
struct Cli {
    /// Print machine-readable JSON instead of text; errors too, as one JSON object on stderr
    /// (`error`, and for SDO failures `node`, `index`, `sub`, `abort_code`, `meaning`).
    #[arg(long, global = true)]
    json: bool,

    /// Print unsigned values in zero-padded hex (`0x00000039`) instead of decimal (`57`), the
    /// default of every command: object values (sdo read, audit), identities (scan, lss,
    /// burkert status). Indices, COB-IDs, abort codes and CAN identifiers are always hex;
    /// signed values, strings and EDS text (eds show) print as they are.
    #[arg(long, global = true)]
    hex: bool,

    #[command(flatten)]
    bus: bus::BusOpts,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// EDS/DCF files: check, lint, show, convert to DCF, generate Rust.
    #[command(subcommand)]
    Eds(eds::EdsCommand),
    /// GEMÜ 1436 cPos positioner: parameters, actions, error list; over DeviceNet with --iface,
    /// else against a SIMULATED positioner.
    Cpos(cpos::CposArgs),
    /// SDO upload/download: read, write, upload to a file, download from a file.
    #[command(subcommand)]
    Sdo(sdo_cmd::SdoCommand),
    /// USDO transfers (CANopen FD): read|write|upload, as `sdo`, over CAN FD frames: on
    /// SocketCAN and the in-memory bus give `--fd`; the UDP bus carries CAN FD without it.
    #[command(subcommand)]
    Usdo(sdo_cmd::UsdoCommand),
    /// NMT module control: start|stop|preop|reset|reset-comm NODE|all [--wait]; `state`
    /// lists every node's last state and heartbeat age.
    Nmt(nmt_cmd::NmtArgs),
    /// List the nodes that answer, with their identity (0x1018).
    Scan,
    /// Store a node's parameters in its non-volatile memory (0x1010, signature `save`).
    Store(store_cmd::StoreArgs),
    /// Restore a node's default parameters (0x1011, signature `load`); they take effect at
    /// its next reset.
    Restore(store_cmd::StoreArgs),
    /// A node's PDOs by SDO: `show [tpdo|rpdo] [N]` reads their parameters and mapping; `map
    /// tpdo|rpdo N ENTRY...` remaps one the CiA 301 way (in pre-operational), up to 64 bytes
    /// on a node marked CANopen FD on a CAN FD bus.
    Pdo(pdo_cmd::PdoArgs),
    /// Decoded live traffic, optionally filtered as candump filters (CAN FD frames shown in
    /// candump's syntax; those that are PDOs an `--eds` maps, up to 64 bytes, decoded).
    Monitor {
        /// Stop after this many seconds (required on the in-memory bus).
        #[arg(long, value_parser = bus::parse_seconds)]
        duration: Option<f64>,
        /// Decode the frames as DeviceNet instead of CANopen.
        #[arg(long)]
        devicenet: bool,
        /// candump-style filters, hex: `ID:MASK` shows frames with `id & MASK == ID & MASK`,
        /// `ID~MASK` those without; 8-digit IDs filter 29-bit frames. A frame passing any filter
        /// is shown (comma-separated or repeated: `705:7FF,080~7FF`).
        #[arg(value_name = "FILTER", value_delimiter = ',', value_parser = traffic::parse_filter)]
        filters: Vec<traffic::Filter>,
    },
    /// Run a simulated device from an EDS on the bus.
    Simulate {
        /// EDS/DCF file.
        eds: std::path::PathBuf,
        /// Node-ID.
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=127))]
        node_id: u8,
        /// Stop after this many seconds (required on the in-memory bus).
        #[arg(long, value_parser = bus::parse_seconds)]
        duration: Option<f64>,
    },
    /// Record traffic in the candump log format, CAN FD frames in candump's FD syntax
    /// (`123##1...`; on SocketCAN the socket receives FD frames when the interface's MTU is
    /// 72), until --duration ends or Ctrl-C (SIGINT, SIGTERM). The file is written under a
    /// temporary name and renamed when recording succeeds: a failed run leaves an existing
    /// file alone.
    Record {
        /// Output file.
        #[arg(short, long)]
        output: std::path::PathBuf,
        /// Stop after this many seconds (required on the in-memory bus).
        #[arg(long, value_parser = bus::parse_seconds)]
        duration: Option<f64>,
    },
    /// Replay a candump log with its recorded timing. The whole log is read and checked
    /// before the first frame is sent; CAN FD and error frames are skipped with a count.
    Replay {
        /// candump log file.
        file: std::path::PathBuf,
    },
    /// Judge a candump log: summary, timeline and problem list (lost heartbeats, boot-up
    /// loops, EMCY, SDO aborts and silence, SYNC, PDOs, error frames, duplicate node-IDs, bus
    /// load); --check for CI, --frames to decode every frame.
    Analyze(analyze::AnalyzeArgs),
    /// A live view of the network in the terminal: nodes, bus load, PDO values, SDO transfers,
    /// events; keys for NMT, SDO read and write (see `?` inside). With --replay, a candump log.
    Top(top::TopArgs),
    /// LSS (CiA 305): switch mode, configure node-ID and bit rate, inquire, Fastscan,
    /// assign-all.
    Lss(lss_cmd::LssArgs),
    /// Walk through commissioning simulated devices (no hardware, no flags).
    Demo,
    /// Bürkert devices: status with the LED colour, locate, maintenance, LED, logbook.
    Burkert(burkert::BurkertArgs),
    /// CiA 402 drives: status, enable, disable, quick stop, fault reset, mode, homing, moves,
    /// velocity and torque.
    Drive(drive_cmd::DriveArgs),
    /// CiA 309-3 ASCII gateway over TCP, Unix sockets and stdio.
    Gateway(gateway::GatewayArgs),
    /// Boot a network from its description (bus.toml) the CiA 302-2 way.
    Boot(boot::BootArgs),
    /// Compare every device's configuration with its DCF (bus.toml).
    Audit(boot::AuditArgs),
    /// The CAN adapter itself: `adapter info --iface slcan:PATH` shows an slcan adapter's
    /// version, serial number and status flags.
    #[command(subcommand)]
    Adapter(adapter::AdapterCommand),
}

/// Options every command group may read.
#[derive(Debug, Clone, Copy)]
struct Global {
    json: bool,
    /// Unsigned values in hex (`--hex`).
    hex: bool,
}

impl Global {
    /// A 32-bit unsigned value (an identity value, an object's value) as every command prints
    /// it: decimal, with `--hex` zero-padded hex.
    fn u32(self, v: u32) -> String {
        if self.hex {
            // As `Value` writes it in hex (`sdo read --hex`): upper-case digits.
            format!("0x{v:08X}")
        } else {
            v.to_string()
        }
    }
}

/// Writes to stdout. A closed pipe (`canopen eds show F | head`) ends output quietly instead of
/// panicking the way `print!` does; other write errors are reported once on stderr.
pub(crate) fn out(text: &str) {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        && e.kind() != std::io::ErrorKind::BrokenPipe
    {
        eprintln!("canopen: cannot write to stdout: {e}");
    }
}

/// [`out`] with a newline.
pub(crate) fn outln(text: &str) {
    out(&format!("{text}\n"));
}

fn main() -> ExitCode {
    // First, before any thread starts (see `handle_signals`).
    let signals = bus::handle_signals();
    let args = argv::options_after_values(&Cli::command(), std::env::args_os().collect());
    let json = argv::asks_for_json(&args);
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => return error::report_clap(&e, json),
    };
    let global = Global {
        json: cli.json,
        hex: cli.hex,
    };
    error::set_json(cli.json);
    if let Err(e) = signals {
        bus::warn("warning", &e.to_string(), serde_json::Map::new());
    }
    match cli.command {
        Command::Eds(cmd) => eds::run(cmd, global),
        Command::Sdo(cmd) => sdo_cmd::run(cmd, &cli.bus, global),
        Command::Usdo(cmd) => sdo_cmd::run_usdo(cmd, &cli.bus, global),
        Command::Nmt(args) => nmt_cmd::run(args, &cli.bus, global),
        Command::Scan => nmt_cmd::run_scan(&cli.bus, global),
        Command::Store(args) => store_cmd::run(args, false, &cli.bus, global),
        Command::Restore(args) => store_cmd::run(args, true, &cli.bus, global),
        Command::Pdo(args) => pdo_cmd::run(args, &cli.bus, global),
        Command::Monitor {
            duration,
            devicenet,
            filters,
        } => traffic::run_monitor(&cli.bus, duration, &filters, devicenet, global),
        Command::Simulate {
            eds,
            node_id,
            duration,
        } => match canola::NodeId::new(node_id) {
            Ok(n) => simulate::run(&cli.bus, &eds, n, duration, global),
            Err(e) => bus::fail(e),
        },
        Command::Record { output, duration } => traffic::run_record(&cli.bus, &output, duration),
        Command::Replay { file } => traffic::run_replay(&cli.bus, &file, global),
        Command::Analyze(args) => analyze::run(&args, &cli.bus, global),
        Command::Demo => demo::run(),
        Command::Top(args) => top::run(&args, &cli.bus, global),
        Command::Lss(args) => lss_cmd::run(args, &cli.bus, global),
        Command::Cpos(args) => cpos::run(args, cli.bus.iface.as_deref(), global),
        Command::Burkert(args) => burkert::run(args, &cli.bus, global),
        Command::Drive(args) => drive_cmd::run(args, &cli.bus, global),
        Command::Gateway(args) => gateway::run(args, &cli.bus),
        Command::Boot(args) => boot::run_boot(args, &cli.bus, global),
        Command::Audit(args) => boot::run_audit(args, &cli.bus, global),
        Command::Adapter(cmd) => adapter::run(cmd, &cli.bus, global),
    }
}
