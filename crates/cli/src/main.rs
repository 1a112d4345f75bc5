//! `canopen`: the command-line tool of the stack, in the habits of can-utils and python-canopen.
//!
//! One module per command group; each parses its own arguments (clap derive) and returns the
//! process exit code. Errors go to stderr, results to stdout (`--json` for scripts).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod eds;

/// CANopen master tools: EDS files, and (with the bus commands) devices on SocketCAN or a
/// simulated bus.
#[derive(Debug, Parser)]
#[command(name = "canopen", version, about)]
struct Cli {
    /// Print machine-readable JSON instead of text.
    #[arg(long, global = true)]
    json: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// EDS/DCF files: check, lint, show, convert to DCF, generate Rust.
    #[command(subcommand)]
    Eds(eds::EdsCommand),
}

/// Options every command group may read.
#[derive(Debug, Clone, Copy)]
struct Global {
    json: bool,
}

/// Writes to stdout. A closed pipe (`canopen eds show F | head`) ends output quietly instead of
/// panicking the way `print!` does; other write errors are reported once on stderr.
pub(crate) fn out(text: &str) {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("canopen: cannot write to stdout: {e}");
        }
    }
}

/// [`out`] with a newline.
pub(crate) fn outln(text: &str) {
    out(&format!("{text}\n"));
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let global = Global { json: cli.json };
    match cli.command {
        Command::Eds(cmd) => eds::run(cmd, global),
    }
}
