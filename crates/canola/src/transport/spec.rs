//! One way to name a bus: the spec a user types after `canopen --iface` and gives
//! [`Network::open`](crate::Network::open), parsed by [`BusSpec::parse`] and opened by
//! [`BusSpec::open`].
//!
//! Forms:
//! - `can0`, `vcan0`, any other name: a SocketCAN interface (`socketcan` feature, Linux).
//! - `udp[:GROUP[:PORT]][@IFACE]`: the UDP multicast bus in python-can's `udp_multicast`
//!   format, on this machine only unless `@IFACE` puts it on that interface's network segment
//!   (`socketcan` feature, Linux).
//! - `slcan:PATH[@BITRATE]`: a serial-line CAN adapter (`slcan` feature): `slcan:/dev/ttyACM0`,
//!   `slcan:COM3@500k`, `slcan:/dev/cu.usbmodem1@1M`. Without a bit rate the adapter keeps
//!   its own setting.
//!
//! Failures are an [`OpenError`]: it names the bus as the user wrote it, says what went wrong
//! in words ([`OpenErrorKind`]) and carries a hint (which interfaces exist and how to make a
//! virtual one, which group grants access to serial ports, what an adapter that does not answer
//! may be).

use crate::transport::contract::{Transport, TransportError};

/// A parsed bus spec; see the module docs.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum BusSpec {
    /// A SocketCAN network interface.
    SocketCan(String),
    /// The UDP multicast bus: its group and how far it reaches.
    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    Udp {
        /// Multicast group (IPv4 or IPv6) and port.
        group: std::net::SocketAddr,
        /// This machine only, or an interface's segment.
        scope: crate::transport::udp::UdpScope,
    },
    /// A serial-line CAN adapter.
    #[cfg(feature = "slcan")]
    Slcan(crate::transport::slcan::LinkConfig),
}

/// Why a bus could not be opened; its `Display` is `SPEC: what` and, when there is one, a
/// second line `hint: ...`.
#[derive(Debug, thiserror::Error)]
#[error("{spec}: {kind}{}", hint.as_ref().map(|h| format!("\nhint: {h}")).unwrap_or_default())]
pub struct OpenError {
    /// The bus as given.
    pub spec: String,
    /// What went wrong.
    pub kind: OpenErrorKind,
    /// What to do about it, if the library knows.
    pub hint: Option<String>,
}

/// What went wrong opening a bus.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenErrorKind {
    /// The spec did not parse.
    #[error("{0}")]
    BadSpec(String),
    /// This build has no transport for the spec (the crate feature is off, or the operating
    /// system has no such thing).
    #[error("this build cannot open it (needs the `{feature}` feature{os})")]
    Unsupported {
        /// The crate feature.
        feature: &'static str,
        /// A note on the operating system, if it matters.
        os: &'static str,
    },
    /// There is no network interface by that name.
    #[error("no such network interface")]
    NoSuchInterface,
    /// The interface exists but is not a CAN interface (`eth0`, `lo`).
    #[error("{iface} is not a CAN interface (its link type is {link_type}, CAN is 280)")]
    NotCan {
        /// The interface.
        iface: String,
        /// Its `ARPHRD_*` type from `/sys/class/net/IFACE/type`.
        link_type: u32,
    },
    /// The kernel has no CAN protocol support (`Address family not supported`).
    #[error("the kernel has no CAN socket support loaded")]
    NoCanSupport,
    /// There is no serial device at that path.
    #[error("no such serial device")]
    NoSuchDevice,
    /// The operating system refused access.
    #[error("permission denied")]
    PermissionDenied,
    /// The adapter did not answer a command of the open sequence.
    #[error("the adapter did not answer: {0}")]
    NoReply(String),
    /// The adapter answered with an error (BEL) to a command of the open sequence.
    #[error("the adapter refused: {0}")]
    Refused(String),
    /// CAN FD was asked for on a bus that carries classic frames only: the bus and why
    /// (`vcan0 (MTU 16: classic CAN only; ...)`).
    #[error("FD not supported on {0}")]
    FdNotSupported(String),
    /// Anything else, in the operating system's or the transport's words.
    #[error("{0}")]
    Other(String),
}

impl OpenError {
    fn new(spec: &str, kind: OpenErrorKind, hint: Option<String>) -> Self {
        Self {
            spec: spec.to_owned(),
            kind,
            hint,
        }
    }
}

impl BusSpec {
    /// Parses a bus spec (see the module docs). A form this build cannot open is
    /// [`OpenErrorKind::Unsupported`].
    pub fn parse(spec: &str) -> Result<Self, OpenError> {
        if spec.is_empty() {
            return Err(OpenError::new(
                spec,
                OpenErrorKind::BadSpec("empty bus name".into()),
                Some("give a SocketCAN interface (can0), udp, or slcan:PATH[@BITRATE]".into()),
            ));
        }
        if let Some(rest) = spec.strip_prefix("slcan:") {
            return Self::parse_slcan(spec, rest);
        }
        if spec == "udp" || spec.starts_with("udp:") || spec.starts_with("udp@") {
            return Self::parse_udp(spec);
        }
        // A Linux interface name: at most 15 bytes, no '/', no whitespace, no ':' (aliases).
        if spec.len() > 15
            || spec
                .chars()
                .any(|c| c == '/' || c == ':' || c.is_whitespace())
        {
            return Err(OpenError::new(
                spec,
                OpenErrorKind::BadSpec(
                    "not a bus: expected a SocketCAN interface name (at most 15 characters), \
                     udp[:GROUP[:PORT]][@IFACE] or slcan:PATH[@BITRATE]"
                        .into(),
                ),
                None,
            ));
        }
        Ok(Self::SocketCan(spec.to_owned()))
    }

    #[cfg(feature = "slcan")]
    fn parse_slcan(spec: &str, rest: &str) -> Result<Self, OpenError> {
        crate::transport::slcan::LinkConfig::from_spec(rest)
            .map(Self::Slcan)
            .map_err(|e| {
                OpenError::new(
                    spec,
                    OpenErrorKind::BadSpec(e.to_string()),
                    Some("slcan:PATH[@BITRATE], e.g. slcan:/dev/ttyACM0@500k or slcan:COM3".into()),
                )
            })
    }

    #[cfg(not(feature = "slcan"))]
    fn parse_slcan(spec: &str, _rest: &str) -> Result<Self, OpenError> {
        Err(OpenError::new(
            spec,
            OpenErrorKind::Unsupported {
                feature: "slcan",
                os: "",
            },
            None,
        ))
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    fn parse_udp(spec: &str) -> Result<Self, OpenError> {
        match crate::transport::udp::parse_scoped_spec(spec) {
            Some(Ok((group, scope))) => Ok(Self::Udp { group, scope }),
            Some(Err(e)) => Err(OpenError::new(spec, OpenErrorKind::BadSpec(e), None)),
            None => Err(OpenError::new(
                spec,
                OpenErrorKind::BadSpec("expected udp[:GROUP[:PORT]][@IFACE]".into()),
                None,
            )),
        }
    }

    #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
    fn parse_udp(spec: &str) -> Result<Self, OpenError> {
        Err(OpenError::new(
            spec,
            OpenErrorKind::Unsupported {
                feature: "socketcan",
                os: ", on Linux",
            },
            None,
        ))
    }

    /// What the user should know before using this bus: a UDP bus reaching beyond this
    /// machine says who else can read and write it.
    pub fn warning(&self) -> Option<String> {
        match self {
            #[cfg(all(feature = "socketcan", target_os = "linux"))]
            Self::Udp { group, scope } => scope.warning(*group),
            _ => None,
        }
    }

    /// The spec as the user would write it.
    pub fn name(&self) -> String {
        match self {
            Self::SocketCan(iface) => iface.clone(),
            #[cfg(all(feature = "socketcan", target_os = "linux"))]
            Self::Udp { group, scope } => match scope {
                crate::transport::udp::UdpScope::Loopback => format!("udp:{group}"),
                crate::transport::udp::UdpScope::Interface { name, .. } => {
                    format!("udp:{group}@{name}")
                }
            },
            #[cfg(feature = "slcan")]
            Self::Slcan(c) => format!("slcan:{}", c.path),
        }
    }

    /// Opens an slcan adapter as its own type (for [`Slcan::info`](crate::slcan::Slcan::info)
    /// and its counters); another kind of bus is [`OpenErrorKind::BadSpec`].
    #[cfg(feature = "slcan")]
    pub fn open_slcan(&self) -> Result<crate::transport::slcan::Slcan, OpenError> {
        match self {
            Self::Slcan(config) => crate::transport::slcan::Slcan::open(config.clone())
                .map_err(|e| slcan_error(&self.name(), e)),
            _ => Err(OpenError::new(
                &self.name(),
                OpenErrorKind::BadSpec("not an slcan adapter".into()),
                Some("give slcan:PATH[@BITRATE]".into()),
            )),
        }
    }

    /// Opens the bus.
    pub fn open(&self) -> Result<Box<dyn Transport>, OpenError> {
        self.open_with(false)
    }

    /// Opens the bus; with `fd` a SocketCAN interface that carries CAN FD (MTU 72) is opened
    /// for it (FD frames received as [`BusEvent::FdFrame`](crate::BusEvent::FdFrame) and sent),
    /// a classic-only one as classic (for watching traffic: use [`open_fd`](Self::open_fd) when
    /// CAN FD is required). The UDP bus and an slcan adapter report FD frames either way.
    pub fn open_with(&self, fd: bool) -> Result<Box<dyn Transport>, OpenError> {
        self.open_mode(if fd { Fd::IfCarried } else { Fd::Off })
    }

    /// Opens the bus for CAN FD: fails with [`OpenErrorKind::FdNotSupported`] when the bus
    /// carries classic frames only (a SocketCAN interface with MTU 16, an slcan adapter opened
    /// without a data bit rate).
    pub fn open_fd(&self) -> Result<Box<dyn Transport>, OpenError> {
        let t = self.open_mode(Fd::Required)?;
        match t.fd_support() {
            Ok(()) => Ok(t),
            Err(e) => Err(transport_error(&self.name(), e)),
        }
    }

    fn open_mode(&self, fd: Fd) -> Result<Box<dyn Transport>, OpenError> {
        match self {
            Self::SocketCan(iface) => open_socketcan(iface, fd),
            #[cfg(all(feature = "socketcan", target_os = "linux"))]
            Self::Udp { group, scope } => {
                crate::transport::udp::UdpMulticast::open_scoped(*group, scope.clone())
                    .map(|t| Box::new(t) as Box<dyn Transport>)
                    .map_err(|e| transport_error(&self.name(), e))
            }
            #[cfg(feature = "slcan")]
            Self::Slcan(config) => crate::transport::slcan::Slcan::open(config.clone())
                .map(|t| Box::new(t) as Box<dyn Transport>)
                .map_err(|e| slcan_error(&self.name(), e)),
        }
    }
}

/// What an open asks of CAN FD.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
enum Fd {
    /// Classic frames only.
    Off,
    /// CAN FD when the interface carries it.
    IfCarried,
    /// CAN FD or an error.
    Required,
}

#[cfg(all(feature = "socketcan", target_os = "linux"))]
fn open_socketcan(iface: &str, fd: Fd) -> Result<Box<dyn Transport>, OpenError> {
    use crate::transport::socketcan::SocketCan;
    // A network interface that is not CAN fails in the kernel with a misleading error (no
    // such device, or no address family when CAN is not loaded): say what it is first.
    match link_type(iface) {
        Some(t) if t != ARPHRD_CAN => return Err(not_can(iface, t)),
        None if std::path::Path::new("/sys/class/net").is_dir() => {
            return Err(no_such_interface(iface));
        }
        _ => {}
    }
    let carried = crate::transport::socketcan::interface_mtu(iface) == Some(72);
    let socket = match fd {
        Fd::Required => SocketCan::open_fd(iface),
        Fd::IfCarried if carried => SocketCan::open_fd(iface),
        _ => SocketCan::open(iface),
    };
    socket
        .map(|t| Box::new(t) as Box<dyn Transport>)
        .map_err(|e| socketcan_error(iface, e))
}

#[cfg(not(all(feature = "socketcan", target_os = "linux")))]
fn open_socketcan(iface: &str, _fd: Fd) -> Result<Box<dyn Transport>, OpenError> {
    Err(OpenError::new(
        iface,
        OpenErrorKind::Unsupported {
            feature: "socketcan",
            os: ", on Linux",
        },
        Some("on this system use an slcan adapter: --iface slcan:PATH[@BITRATE]".into()),
    ))
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
/// `ARPHRD_CAN`, the link type of CAN interfaces.
const ARPHRD_CAN: u32 = 280;

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
/// The link type of a network interface (`/sys/class/net/IFACE/type`), `None` when there is
/// no such interface (or no sysfs).
fn link_type(iface: &str) -> Option<u32> {
    if iface.contains('/') || iface.starts_with('.') {
        return None;
    }
    std::fs::read_to_string(format!("/sys/class/net/{iface}/type"))
        .ok()?
        .trim()
        .parse()
        .ok()
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
fn not_can(iface: &str, link_type: u32) -> OpenError {
    OpenError::new(
        iface,
        OpenErrorKind::NotCan {
            iface: iface.to_owned(),
            link_type,
        },
        Some(format!(
            "{}; `ip -details link` shows each interface's kind",
            can_list()
        )),
    )
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
/// `CAN interfaces here: can0, vcan0` or `no CAN interface exists`.
fn can_list() -> String {
    let mut known: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| link_type(n) == Some(ARPHRD_CAN))
                .collect()
        })
        .unwrap_or_default();
    known.sort();
    if known.is_empty() {
        "no CAN interface exists".to_string()
    } else {
        format!("CAN interfaces here: {}", known.join(", "))
    }
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
/// The hint for a SocketCAN interface that does not exist: which do, and how to make a
/// virtual one.
fn no_such_interface(iface: &str) -> OpenError {
    if let Some(meant) = misspelt_bus(iface) {
        return OpenError::new(
            iface,
            OpenErrorKind::NoSuchInterface,
            Some(format!(
                "there is no interface `{iface}`; did you mean `{meant}`? ({}; `ip link` lists \
                 all)",
                can_list()
            )),
        );
    }
    OpenError::new(
        iface,
        OpenErrorKind::NoSuchInterface,
        Some(format!(
            "there is no interface `{iface}` ({}; `ip link` lists all). A virtual one: \
             `sudo modprobe vcan && sudo ip link add dev {iface} type vcan && sudo ip link set {iface} up`; \
             a USB serial adapter: `--iface slcan:/dev/ttyACM0`; \
             without CAN, `--iface udp` is a bus between processes on this machine (python-can's udp_multicast)",
            can_list()
        )),
    )
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
/// The bus a name that is no interface was likely meant to be: a spelling of `udp` or `slcan`
/// one letter off (`udpp`, `upd`, `slcna`), or `slcan` without its path.
fn misspelt_bus(name: &str) -> Option<&'static str> {
    let name = name.to_ascii_lowercase();
    [("udp", "udp"), ("slcan", "slcan:PATH[@BITRATE]")]
        .into_iter()
        .find(|(word, _)| one_edit_apart(&name, word))
        .map(|(_, meant)| meant)
}

/// Whether `a` and `b` are equal or one insertion, deletion, substitution or swap of two
/// neighbours apart.
fn one_edit_apart(a: &str, b: &str) -> bool {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    if a == b {
        return true;
    }
    let (short, long) = if a.len() <= b.len() {
        (&a, &b)
    } else {
        (&b, &a)
    };
    match long.len() - short.len() {
        0 => {
            let diff: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
            match diff[..] {
                [_] => true,
                [i, j] => j == i + 1 && a[i] == b[j] && a[j] == b[i],
                _ => false,
            }
        }
        1 => (0..long.len()).any(|skip| {
            long.iter()
                .enumerate()
                .filter(|&(i, _)| i != skip)
                .map(|(_, c)| c)
                .eq(short.iter())
        }),
        _ => false,
    }
}

#[cfg(all(feature = "socketcan", target_os = "linux"))]
fn socketcan_error(iface: &str, e: TransportError) -> OpenError {
    let TransportError::Io(io) = &e else {
        return transport_error(iface, e);
    };
    let errno = io.raw_os_error();
    if errno == Some(nix::libc::ENODEV) {
        return no_such_interface(iface);
    }
    match errno {
        Some(nix::libc::EAFNOSUPPORT) => OpenError::new(
            iface,
            OpenErrorKind::NoCanSupport,
            Some(
                "load it with `sudo modprobe can-raw` (and `sudo modprobe vcan` for virtual buses)"
                    .into(),
            ),
        ),
        Some(nix::libc::EACCES | nix::libc::EPERM) => OpenError::new(
            iface,
            OpenErrorKind::PermissionDenied,
            Some(
                "a security policy (container, seccomp, SELinux) keeps this process from CAN \
                 sockets; run it where it may open them"
                    .into(),
            ),
        ),
        _ => transport_error(iface, e),
    }
}

#[cfg_attr(not(all(feature = "socketcan", target_os = "linux")), allow(dead_code))]
fn transport_error(spec: &str, e: TransportError) -> OpenError {
    if let TransportError::Io(io) = &e
        && io.kind() == std::io::ErrorKind::PermissionDenied
    {
        return OpenError::new(spec, OpenErrorKind::PermissionDenied, None);
    }
    if let TransportError::FdNotSupported { bus } = e {
        return OpenError::new(spec, OpenErrorKind::FdNotSupported(bus), None);
    }
    OpenError::new(spec, OpenErrorKind::Other(e.to_string()), None)
}

#[cfg(feature = "slcan")]
fn slcan_error(spec: &str, e: crate::transport::slcan::LinkError) -> OpenError {
    use crate::transport::slcan::LinkError;
    let adapters = "is it an slcan adapter (CANable or CANable 2 with slcan firmware, USBtin, \
                    Lawicel CANUSB) at this serial speed, and is no other program using it? A \
                    CANable with candleLight firmware is a SocketCAN interface (can0) instead";
    match e {
        LinkError::Open { path, source } => {
            let not_found = matches!(source.kind(), serialport::ErrorKind::NoDevice)
                || matches!(
                    source.kind(),
                    serialport::ErrorKind::Io(std::io::ErrorKind::NotFound)
                );
            let denied = matches!(
                source.kind(),
                serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied)
            ) || source.description.contains("ermission denied");
            if denied {
                OpenError::new(
                    spec,
                    OpenErrorKind::PermissionDenied,
                    Some(format!(
                        "{path} belongs to a group this user is not in; on Linux \
                         `sudo usermod -aG dialout $USER` (uucp on Arch), then log in again"
                    )),
                )
            } else if not_found {
                OpenError::new(
                    spec,
                    OpenErrorKind::NoSuchDevice,
                    Some(format!(
                        "nothing at {path}: is the adapter plugged in? USB adapters appear as \
                         /dev/ttyACM* or /dev/ttyUSB* on Linux, /dev/cu.usbmodem* on macOS, COMn \
                         on Windows"
                    )),
                )
            } else {
                OpenError::new(
                    spec,
                    OpenErrorKind::Other(format!("cannot open {path}: {source}")),
                    None,
                )
            }
        }
        LinkError::NoReply { command } => OpenError::new(
            spec,
            OpenErrorKind::NoReply(format!("no reply to `{command}`")),
            Some(adapters.into()),
        ),
        LinkError::Refused { command } => OpenError::new(
            spec,
            OpenErrorKind::Refused(format!("`{command}` was answered with BEL")),
            Some("the adapter may not support that bit rate or mode; try without @BITRATE".into()),
        ),
        LinkError::WriteTimeout => OpenError::new(
            spec,
            OpenErrorKind::NoReply("it does not read what is written to it".into()),
            Some(adapters.into()),
        ),
        LinkError::BadSpec(_) | LinkError::UnsupportedBitrate(_) => {
            OpenError::new(spec, OpenErrorKind::BadSpec(e.to_string()), None)
        }
        e => OpenError::new(spec, OpenErrorKind::Other(e.to_string()), None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(spec: &str) -> OpenError {
        match BusSpec::parse(spec).and_then(|s| s.open()) {
            Ok(_) => panic!("{spec} opened"),
            Err(e) => e,
        }
    }

    #[test]
    fn socketcan_names() {
        assert_eq!(
            BusSpec::parse("can0").unwrap(),
            BusSpec::SocketCan("can0".into())
        );
        assert_eq!(
            BusSpec::parse("vcan0").unwrap(),
            BusSpec::SocketCan("vcan0".into())
        );
        for bad in ["", "a/b", "sixteen-chars-xx", "can 0", "can0:1"] {
            let e = BusSpec::parse(bad).unwrap_err();
            assert!(matches!(e.kind, OpenErrorKind::BadSpec(_)), "{bad}: {e}");
            assert!(e.to_string().starts_with(&format!("{bad}: ")), "{e}");
        }
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn udp_forms() {
        use crate::transport::udp::UdpScope;
        let BusSpec::Udp { group, scope } = BusSpec::parse("udp").unwrap() else {
            panic!("not udp")
        };
        assert_eq!(group.to_string(), "239.74.163.2:43113");
        assert_eq!(scope, UdpScope::Loopback);
        let s = BusSpec::parse("udp:239.1.2.3:5000").unwrap();
        assert_eq!(s.name(), "udp:239.1.2.3:5000");
        assert_eq!(s.warning(), None);
        // The network opens it as it opens every other bus.
        let port = 31000 + (std::process::id() % 4000) as u16;
        let net =
            crate::Network::open(&format!("udp:239.74.163.99:{port}")).expect("UDP bus opens");
        drop(net);
        for bad in ["udp:1.2.3.4", "udp:nonsense", "udp@", "udp@nosuchif9"] {
            let e = BusSpec::parse(bad).unwrap_err();
            assert!(matches!(e.kind, OpenErrorKind::BadSpec(_)), "{bad}: {e}");
        }
        // python-can's default group is IPv6; its name round-trips.
        let s = BusSpec::parse("udp:ff15:7079:7468:6f6e:6465:6d6f:6d63:6173").unwrap();
        assert_eq!(
            s.name(),
            "udp:[ff15:7079:7468:6f6e:6465:6d6f:6d63:6173]:43113"
        );
        assert_eq!(BusSpec::parse(&s.name()).unwrap(), s);
    }

    #[cfg(feature = "slcan")]
    #[test]
    fn slcan_forms() {
        let BusSpec::Slcan(c) = BusSpec::parse("slcan:/dev/ttyACM0@500k").unwrap() else {
            panic!("not slcan")
        };
        assert_eq!(c.path, "/dev/ttyACM0");
        assert_eq!(c.bitrate.map(canola_slcan::NominalBitrate::code), Some(6));
        let BusSpec::Slcan(c) = BusSpec::parse("slcan:COM3").unwrap() else {
            panic!("not slcan")
        };
        assert_eq!((c.path.as_str(), c.bitrate), ("COM3", None));
        for bad in [
            "slcan:",
            "slcan:@500k",
            "slcan:/dev/x@fast",
            "slcan:/dev/x@333333",
        ] {
            let e = BusSpec::parse(bad).unwrap_err();
            assert!(matches!(e.kind, OpenErrorKind::BadSpec(_)), "{bad}: {e}");
            assert!(e.hint.unwrap().contains("slcan:PATH[@BITRATE]"));
        }
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn missing_interface_names_it_and_gives_the_vcan_recipe() {
        let e = err("nosuchcan7");
        assert!(matches!(e.kind, OpenErrorKind::NoSuchInterface), "{e}");
        let text = e.to_string();
        assert!(
            text.starts_with("nosuchcan7: no such network interface\nhint: "),
            "{text}"
        );
        assert!(
            text.contains("there is no interface `nosuchcan7`"),
            "{text}"
        );
        assert!(
            text.contains("ip link add dev nosuchcan7 type vcan"),
            "{text}"
        );
        // Through the network, as an application sees it.
        let e = crate::Network::open("nosuchcan7").unwrap_err();
        assert!(matches!(e, crate::Error::Open(_)));
        assert!(e.to_string().contains("type vcan"), "{e}");
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn a_misspelt_bus_name_is_answered_with_the_bus_meant() {
        for (typo, meant) in [
            ("udpp", "`udp`"),
            ("upd", "`udp`"),
            ("UDP", "`udp`"),
            ("slcna", "`slcan:PATH[@BITRATE]`"),
            ("slcan", "`slcan:PATH[@BITRATE]`"),
        ] {
            let e = err(typo);
            assert!(matches!(e.kind, OpenErrorKind::NoSuchInterface), "{e}");
            let text = e.to_string();
            assert!(text.contains(&format!("did you mean {meant}?")), "{text}");
            assert!(!text.contains("type vcan"), "{text}");
        }
        // Two letters off is a name of its own.
        assert!(!err("udpxx").to_string().contains("did you mean"));
        assert!(one_edit_apart("udp", "ud") && one_edit_apart("dup", "udp"));
        assert!(!one_edit_apart("pdu", "udp"));
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn a_network_interface_that_is_not_can_is_named_as_such() {
        // The loopback interface exists on every Linux machine with a network stack.
        if link_type("lo").is_none() {
            return;
        }
        let e = err("lo");
        assert!(
            matches!(e.kind, OpenErrorKind::NotCan { link_type: 772, .. }),
            "{e}"
        );
        assert!(
            e.to_string().starts_with("lo: lo is not a CAN interface"),
            "{e}"
        );
        assert!(!e.to_string().contains("Address family"), "{e}");
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn kernel_errors_get_their_hints() {
        let io = |errno| TransportError::Io(std::io::Error::from_raw_os_error(errno));
        let e = socketcan_error("can0", io(nix::libc::EAFNOSUPPORT));
        assert!(matches!(e.kind, OpenErrorKind::NoCanSupport));
        assert!(e.to_string().contains("modprobe can-raw"), "{e}");
        let e = socketcan_error("can0", io(nix::libc::EPERM));
        assert!(matches!(e.kind, OpenErrorKind::PermissionDenied), "{e}");
        assert!(e.hint.is_some());
        let e = socketcan_error("nosuchcan7", io(nix::libc::ENODEV));
        assert!(matches!(e.kind, OpenErrorKind::NoSuchInterface), "{e}");
        let e = socketcan_error("can0", io(nix::libc::EIO));
        assert!(matches!(e.kind, OpenErrorKind::Other(_)), "{e}");
        assert!(e.to_string().starts_with("can0: "), "{e}");
    }

    #[cfg(feature = "slcan")]
    #[test]
    fn missing_serial_device() {
        let e = err("slcan:/nonexistent/ttyACM9@500k");
        assert!(matches!(e.kind, OpenErrorKind::NoSuchDevice), "{e}");
        let text = e.to_string();
        assert!(
            text.starts_with("slcan:/nonexistent/ttyACM9: no such serial device"),
            "{text}"
        );
        assert!(text.contains("/dev/ttyACM*"), "{text}");
    }

    #[cfg(feature = "slcan")]
    #[test]
    fn serial_permission_denied_names_the_group() {
        let source = serialport::Error::new(
            serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied),
            "Permission denied",
        );
        let e = slcan_error(
            "slcan:/dev/ttyACM0",
            crate::transport::slcan::LinkError::Open {
                path: "/dev/ttyACM0".into(),
                source,
            },
        );
        assert!(matches!(e.kind, OpenErrorKind::PermissionDenied), "{e}");
        assert!(e.to_string().contains("dialout"), "{e}");
    }

    #[cfg(all(feature = "slcan", unix))]
    #[test]
    fn a_silent_adapter_did_not_answer() {
        use std::os::fd::AsFd as _;
        // A pseudo-terminal nobody answers on: an acknowledging adapter would reply to `C`.
        let pty = nix::pty::openpty(None, None).unwrap();
        let path = nix::unistd::ttyname(pty.slave.as_fd()).unwrap();
        let mut config = canola_slcan::LinkConfig::new(path.to_str().unwrap());
        config.ack = canola_slcan::AckMode::Always;
        config.reply_timeout = std::time::Duration::from_millis(50);
        let spec = BusSpec::Slcan(config);
        let e = match spec.open() {
            Ok(_) => panic!("opened"),
            Err(e) => e,
        };
        assert!(matches!(e.kind, OpenErrorKind::NoReply(_)), "{e}");
        let text = e.to_string();
        assert!(text.contains("the adapter did not answer"), "{text}");
        assert!(text.contains("slcan firmware"), "{text}");
        drop(pty);
    }
}
