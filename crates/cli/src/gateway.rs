//! `canopen gateway`: the CiA 309-3 ASCII gateway (`canola-gateway`) on the bus the global
//! options open (`--iface`, or the in-memory bus with the `--eds` devices simulated), over TCP,
//! Unix sockets and stdio at once.
//!
//! A Unix socket is the gateway's for as long as it runs: it is removed when the gateway ends,
//! by the end of stdin or by SIGINT/SIGTERM (then exit status 0). At start, a socket at the
//! path that nobody listens on (left by a gateway that was killed) is replaced; one that
//! answers, or a path that is not a socket, is refused.

use std::process::ExitCode;

use canola_gateway::{Config, Gateway};
use clap::Args;

use crate::bus::{BusOpts, open_network};
use crate::error::CliError;

/// Arguments of `canopen gateway`.
#[derive(Debug, Args)]
pub(crate) struct GatewayArgs {
    /// Where to accept connections (repeatable): `tcp:HOST:PORT`, `tcp:PORT` (loopback) or
    /// `unix:PATH`. Port 0 picks a free port; the address is printed on stderr. An address
    /// other than the loopback needs --allow-remote and a token or --allow; a Unix socket is
    /// created owner-only (--socket-mode).
    #[arg(long, value_name = "tcp:HOST:PORT|unix:PATH")]
    listen: Vec<String>,
    /// Serve standard input and output as one more connection; the gateway ends with stdin.
    #[arg(long)]
    stdio: bool,
    /// SDO timeout every connection starts with, in ms (`set sdo_timeout` changes it).
    #[arg(long, default_value_t = 500)]
    sdo_timeout: u64,
    /// Who may connect and what they may do.
    #[command(flatten)]
    access: crate::gateway_access::AccessArgs,
}

enum Listener {
    Tcp(std::net::TcpListener),
    #[cfg(unix)]
    Unix(std::os::unix::net::UnixListener),
}

fn bind(spec: &str, socket_mode: u32) -> Result<(Listener, String), CliError> {
    if let Some(rest) = spec.strip_prefix("tcp:") {
        let addr = if rest.contains(':') {
            rest.to_owned()
        } else {
            format!("127.0.0.1:{rest}")
        };
        let l = std::net::TcpListener::bind(&addr).map_err(system(spec))?;
        let local = l.local_addr().map_err(system(spec))?;
        return Ok((Listener::Tcp(l), format!("tcp:{local}")));
    }
    #[cfg(not(unix))]
    let _ = socket_mode; // Unix sockets only
    #[cfg(unix)]
    if let Some(path) = spec.strip_prefix("unix:") {
        clear_stale_socket(spec, std::path::Path::new(path))?;
        let l = crate::gateway_access::bind_unix(path, socket_mode).map_err(system(spec))?;
        return Ok((Listener::Unix(l), spec.to_owned()));
    }
    Err(CliError::Argument(format!(
        "--listen {spec}: expected tcp:HOST:PORT, tcp:PORT or unix:PATH"
    )))
}

/// Makes way for the Unix socket `path`: a socket there that nobody listens on is removed; one
/// that answers, or a file that is not a socket, is an error with a hint.
#[cfg(unix)]
fn clear_stale_socket(spec: &str, path: &std::path::Path) -> Result<(), CliError> {
    use std::io::{Error, ErrorKind};
    use std::os::unix::fs::FileTypeExt as _;
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(system(spec)(e)),
    };
    if !meta.file_type().is_socket() {
        return Err(system(spec)(Error::new(
            ErrorKind::AlreadyExists,
            "the path exists and is not a socket; it is left alone\nhint: remove it, or give \
             another --listen unix:PATH",
        )));
    }
    match std::os::unix::net::UnixStream::connect(path) {
        Ok(_) => Err(system(spec)(Error::new(
            ErrorKind::AddrInUse,
            "a program is listening on this socket (another gateway?)\nhint: stop it first, \
             or give another --listen unix:PATH",
        ))),
        // A socket file whose listener is gone (a gateway that was killed).
        Err(e) if e.kind() == ErrorKind::ConnectionRefused => {
            std::fs::remove_file(path).map_err(system(spec))
        }
        Err(e) => Err(system(spec)(e)),
    }
}

/// The gateway's Unix sockets: removed when dropped, and when the process ends by a signal.
#[derive(Default)]
struct Sockets(Vec<crate::bus::SignalGuard>);

impl Drop for Sockets {
    fn drop(&mut self) {
        for s in self.0.drain(..) {
            s.remove();
        }
    }
}

/// A listening socket `spec` that failed.
fn system(spec: &str) -> impl Fn(std::io::Error) -> CliError {
    move |source| CliError::System {
        what: spec.to_owned(),
        source,
    }
}

/// `canopen gateway ...`
pub(crate) fn run(args: GatewayArgs, opts: &BusOpts) -> ExitCode {
    if args.listen.is_empty() && !args.stdio {
        return CliError::usage(
            "nothing to serve: give --listen tcp:HOST:PORT, --listen unix:PATH or --stdio",
        )
        .report();
    }
    // A signal is how a gateway is stopped: its sockets are removed, the exit status is 0.
    crate::bus::signals_end_normally("canopen gateway");
    // Access hook: tokens, allow-list, read-only, audit log; refuses a remote listen address
    // that is not guarded.
    let access = match crate::gateway_access::settings(&args.access, &args.listen) {
        Ok(a) => a,
        Err(e) => return crate::bus::fail(e),
    };
    let mut listeners = Vec::new();
    let mut sockets = Sockets::default();
    for spec in &args.listen {
        match bind(spec, access.socket_mode) {
            Ok(l) => {
                if let Some(path) = l.1.strip_prefix("unix:") {
                    sockets
                        .0
                        .push(crate::bus::remove_on_signal(std::path::Path::new(path)));
                }
                listeners.push(l);
            }
            Err(e) => return crate::bus::fail(e),
        }
    }
    // The in-memory bus (if that is the bus) lives as long as the gateway.
    let (net, _memory) = match open_network(opts) {
        Ok(n) => n,
        Err(e) => return crate::bus::fail(e),
    };
    let config = Config {
        sdo_timeout: canola::Duration::from_millis(args.sdo_timeout),
        access: access.access,
        audit: Some(access.audit),
        ..Config::default()
    };
    let gateway = Gateway::new(net, config);
    let mut threads = Vec::new();
    for (l, name) in listeners {
        eprintln!("canopen gateway: listening on {name}");
        threads.push(match l {
            Listener::Tcp(l) => gateway.serve_tcp(l),
            #[cfg(unix)]
            Listener::Unix(l) => gateway.serve_unix(l),
        });
    }
    if args.stdio {
        gateway.serve_stdio();
        drop(sockets);
        return ExitCode::SUCCESS;
    }
    for t in threads {
        let _ = t.join();
    }
    drop(sockets);
    ExitCode::SUCCESS
}
