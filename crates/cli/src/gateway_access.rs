//! Who may reach `canopen gateway`: the options for tokens, the allow-list, `--read-only`, the
//! audit log and the Unix socket's permissions, and the check that refuses to listen beyond
//! the loopback without them (see `canola_gateway::access`).

use std::net::ToSocketAddrs;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use canola_gateway::{Access, AllowNet, AuditLog, Token};
use clap::Args;

use crate::error::CliError;

/// The environment variable holding the write token.
pub(crate) const TOKEN_ENV: &str = "CANOPEN_GATEWAY_TOKEN";
/// The environment variable holding the read token.
pub(crate) const READ_TOKEN_ENV: &str = "CANOPEN_GATEWAY_READ_TOKEN";

/// Access options of `canopen gateway`.
#[derive(Debug, Args)]
pub(crate) struct AccessArgs {
    /// Allow listening on an address other than the loopback. Needs a token (--token-file,
    /// --read-token-file or the environment) or --allow; anyone who reaches the gateway can
    /// otherwise stop, reset and reconfigure the network.
    #[arg(long)]
    allow_remote: bool,
    /// File holding the write token (first line; at least 16 characters). Clients send
    /// `auth <token>` first. Else the environment variable CANOPEN_GATEWAY_TOKEN. Tokens are
    /// never taken from the command line.
    #[arg(long, value_name = "FILE")]
    token_file: Option<PathBuf>,
    /// File holding the read token (reads, `info`, `help`, `_events` only). Else the
    /// environment variable CANOPEN_GATEWAY_READ_TOKEN.
    #[arg(long, value_name = "FILE")]
    read_token_file: Option<PathBuf>,
    /// TCP clients admitted: ADDR or ADDR/PREFIX (repeatable); others are refused.
    #[arg(long, value_name = "ADDR[/PREFIX]")]
    allow: Vec<String>,
    /// Reads and `info` only: every write, NMT, LSS and `set` request is answered ERROR:100.
    #[arg(long)]
    read_only: bool,
    /// Append a line per request that changes the network (write, NMT, LSS) to FILE (never
    /// truncated). Without it those lines go to standard error.
    #[arg(long, value_name = "FILE")]
    audit_log: Option<PathBuf>,
    /// Permissions of Unix sockets, octal (default 600: the owner only; 660 shares with the
    /// socket's group).
    #[arg(long, value_name = "OCTAL", default_value = "600")]
    socket_mode: String,
}

/// What the options give: the access settings, the audit log, the socket mode.
pub(crate) struct Settings {
    pub(crate) access: Access,
    pub(crate) audit: Arc<AuditLog>,
    pub(crate) socket_mode: u32,
}

fn token(file: Option<&Path>, env: &str, what: &str) -> Result<Option<Token>, CliError> {
    let (text, from) = match file {
        Some(p) => (
            std::fs::read_to_string(p).map_err(CliError::file(p))?,
            p.display().to_string(),
        ),
        None => match std::env::var(env) {
            Ok(t) => (t, env.to_owned()),
            Err(_) => return Ok(None),
        },
    };
    let first = text.lines().next().unwrap_or("");
    Token::new(first).map(Some).map_err(|e| CliError::Rejected {
        what: format!("the {what} token from {from}"),
        source: Box::new(e),
    })
}

/// Reads the options; refuses listen addresses beyond the loopback without `--allow-remote`
/// and a token or allow-list.
pub(crate) fn settings(args: &AccessArgs, listen: &[String]) -> Result<Settings, CliError> {
    let write_token = token(args.token_file.as_deref(), TOKEN_ENV, "write")?;
    let read_token = token(args.read_token_file.as_deref(), READ_TOKEN_ENV, "read")?;
    if let (Some(w), Some(r)) = (&write_token, &read_token)
        && w == r
    {
        return Err(CliError::Argument(
            "the read and the write token are the same".into(),
        ));
    }
    let allow = args
        .allow
        .iter()
        .map(|a| {
            a.parse::<AllowNet>().map_err(|e| CliError::Rejected {
                what: "--allow".into(),
                source: Box::new(e),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let access = Access {
        write_token,
        read_token,
        allow,
        read_only: args.read_only,
    };
    for spec in listen {
        check_listen(spec, args.allow_remote, &access)?;
    }
    let audit = match &args.audit_log {
        Some(p) => AuditLog::append_to(p).map_err(|source| CliError::System {
            what: format!("--audit-log {}", p.display()),
            source,
        })?,
        None => AuditLog::to_writer(std::io::stderr()),
    };
    let socket_mode = u32::from_str_radix(&args.socket_mode, 8)
        .ok()
        .filter(|m| *m <= 0o777)
        .ok_or_else(|| {
            CliError::Argument(format!(
                "--socket-mode {}: expected octal, e.g. 600",
                args.socket_mode
            ))
        })?;
    Ok(Settings {
        access,
        audit: Arc::new(audit),
        socket_mode,
    })
}

/// Refuses a TCP listen address that is not loopback unless remote access is allowed and
/// guarded.
fn check_listen(spec: &str, allow_remote: bool, access: &Access) -> Result<(), CliError> {
    let Some(rest) = spec.strip_prefix("tcp:") else {
        return Ok(());
    };
    // `tcp:PORT` is the loopback.
    if !rest.contains(':') {
        return Ok(());
    }
    let addrs: Vec<_> = rest
        .to_socket_addrs()
        .map_err(|source| CliError::System {
            what: format!("--listen {spec}"),
            source,
        })?
        .collect();
    if addrs.iter().all(|a| a.ip().is_loopback()) {
        return Ok(());
    }
    if !allow_remote {
        return Err(CliError::Argument(format!(
            "refusing to listen on {spec}: not a loopback address, so every host that reaches it \
             could write, stop and reset nodes and reassign node-IDs. Give --allow-remote with a \
             token (--token-file FILE or {TOKEN_ENV}) or --allow ADDR[/PREFIX], or listen on \
             tcp:127.0.0.1:PORT or unix:PATH"
        )));
    }
    if !access.needs_token() && access.allow.is_empty() {
        return Err(CliError::Argument(format!(
            "refusing to listen on {spec} with --allow-remote but no token and no --allow: give \
             a token (--token-file FILE, --read-token-file FILE, {TOKEN_ENV}, {READ_TOKEN_ENV}) \
             or --allow ADDR[/PREFIX]"
        )));
    }
    Ok(())
}

/// Binds a Unix socket at `path` with `mode` from the start: bound inside a fresh directory
/// only the owner can enter, given its mode, then moved into place, so no other user can
/// connect in between.
#[cfg(unix)]
pub(crate) fn bind_unix(
    path: &str,
    mode: u32,
) -> std::io::Result<std::os::unix::net::UnixListener> {
    use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
    let target = Path::new(path);
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = parent.join(format!(".canopen-gateway-{}", std::process::id()));
    std::fs::DirBuilder::new().mode(0o700).create(&dir)?;
    let inner = dir.join("s");
    let result = (|| {
        let l = std::os::unix::net::UnixListener::bind(&inner)?;
        std::fs::set_permissions(&inner, std::fs::Permissions::from_mode(mode))?;
        if target.exists() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                "the path exists",
            ));
        }
        std::fs::rename(&inner, target)?;
        Ok(l)
    })();
    let _ = std::fs::remove_file(&inner);
    let _ = std::fs::remove_dir(&dir);
    result
}
