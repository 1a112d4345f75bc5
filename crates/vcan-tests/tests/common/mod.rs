//! Shared by the master's real-bus tests: the simulator on its own SocketCAN socket in a thread,
//! python-canopen's LocalNode in a child process, the test EDS, and waiting for network events.

#![allow(dead_code, unreachable_pub)]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::thread::JoinHandle;

use canola::socketcan::SocketCan;
use canola::{Network, NetworkEvent, SimDevice, TransportError, run_station};
use canola_frame::{Duration, NodeId};

/// The rig's test EDS (`tests/vcan/test-device.eds`).
pub const EDS: &[u8] = include_bytes!("../../../../tests/vcan/test-device.eds");

/// Path of a file under `tests/vcan/` of the repository.
pub fn rig_file(name: &str) -> String {
    format!("{}/../../tests/vcan/{name}", env!("CARGO_MANIFEST_DIR"))
}

pub fn node(id: u8) -> NodeId {
    NodeId::new(id).expect("node-ID 1..=127")
}

/// A simulated device from [`EDS`].
pub fn device(id: u8) -> SimDevice {
    SimDevice::from_eds(node(id), EDS).expect("the test EDS parses")
}

/// Drives the network for up to `limit` until an event satisfies `want`; returns that event.
pub fn wait_event(
    net: &Network,
    events: &Receiver<NetworkEvent>,
    limit: Duration,
    what: &str,
    want: impl Fn(&NetworkEvent) -> bool,
) -> NetworkEvent {
    let deadline = net.now() + limit;
    let mut seen = Vec::new();
    while net.now() < deadline {
        net.run_for(Duration::from_millis(50))
            .wait()
            .expect("drive the network");
        for e in events.try_iter() {
            if want(&e) {
                return e;
            }
            if seen.len() < 40 {
                seen.push(e);
            }
        }
    }
    panic!("no {what} within {limit:?}; first events seen: {seen:?}");
}

/// Drives the network for `span` and returns the events that satisfy `want`.
pub fn events_during(
    net: &Network,
    events: &Receiver<NetworkEvent>,
    span: Duration,
    want: impl Fn(&NetworkEvent) -> bool,
) -> Vec<NetworkEvent> {
    net.run_for(span).wait().expect("drive the network");
    events.try_iter().filter(|e| want(e)).collect()
}

/// A [`SimDevice`] served on its own socket by a thread until stopped.
pub struct RunningSim {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<SimDevice>>,
}

impl RunningSim {
    /// Starts serving `dev` on the rig's interface (boot-up message first).
    pub fn start(mut dev: SimDevice) -> Self {
        let mut transport =
            SocketCan::open(&vcan_tests::interface()).expect("open the simulator's socket");
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            // Like a device on a real bus, the simulator outlives a downed interface: it keeps
            // serving once the link returns.
            loop {
                match run_station(&mut transport, &mut dev, || flag.load(Ordering::Relaxed)) {
                    Ok(()) => break,
                    Err(TransportError::InterfaceDown) => {
                        std::thread::sleep(std::time::Duration::from_millis(20));
                    }
                    Err(e) => panic!("the simulator's transport failed: {e}"),
                }
            }
            dev
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }

    /// Stops serving (the device goes silent) and returns the device with its state.
    pub fn stop(mut self) -> SimDevice {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .take()
            .expect("running")
            .join()
            .expect("simulator thread")
    }
}

impl Drop for RunningSim {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// python-canopen's LocalNode (`tests/vcan/canopen_server.py`) in a child process, serving the
/// test EDS. Needs `CANOPEN_PYTHON` (run-all sets it to the project's venv python).
pub struct PythonDevice {
    child: std::process::Child,
}

impl PythonDevice {
    /// Starts the LocalNode with `args` (e.g. `["--tpdo-ms", "100", "0x43"]`) and waits until it
    /// serves (its READY line; Python under TCG needs several seconds to import canopen).
    pub fn start(args: &[&str]) -> Self {
        Self::start_on(&vcan_tests::interface(), args)
    }

    /// [`start`](Self::start) on the SocketCAN interface `iface` (`slcan0`).
    pub fn start_on(iface: &str, args: &[&str]) -> Self {
        use std::io::BufRead;
        use std::process::{Command, Stdio};

        let python = std::env::var("CANOPEN_PYTHON").expect(
            "CANOPEN_PYTHON must name a python with python-canopen (tests/vcan/run-all sets it)",
        );
        let mut child = Command::new(&python)
            .arg("-u")
            .arg(rig_file("canopen_server.py"))
            .args(args)
            .env("CANOPEN_VCAN_IFACE", iface)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("start {python}: {e}"));
        let stdout = child.stdout.take().expect("piped stdout");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                eprintln!("python-canopen: {line}");
                if line.starts_with("READY") {
                    let _ = tx.send(());
                }
            }
        });
        let mut device = Self { child };
        if rx
            .recv_timeout(std::time::Duration::from_secs(180))
            .is_err()
        {
            let status = device.child.try_wait();
            panic!("the python-canopen LocalNode did not get ready (process: {status:?})");
        }
        device
    }

    /// Asks the process to quit and returns its exit status.
    pub fn stop(mut self) -> std::process::ExitStatus {
        self.quit()
    }

    fn quit(&mut self) -> std::process::ExitStatus {
        use std::io::Write;
        if let Some(mut stdin) = self.child.stdin.take() {
            let _ = stdin.write_all(b"quit\n");
        }
        self.child
            .wait()
            .expect("wait for the python-canopen process")
    }
}

impl Drop for PythonDevice {
    fn drop(&mut self) {
        if self.child.stdin.is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
