//! The simulated device's side of the benchmark: serving it (`--serve`, in a process of its
//! own, or from a thread of this process with `--sim-thread`), reading its CPU time and
//! context switches, and the transport wrapper that counts a side's socket calls.

use std::io::{BufRead, Write};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use canola::socketcan::SocketCan;
use canola::{Received, Transport, TransportError, run_station};
use canola_bench::{BenchError, context_switches, device};
use canola_frame::NodeId;

use super::Args;

/// Transport calls, to show how a side drives its socket (blocking waits or polling). Counting
/// costs no system call (an earlier version read the clock per receive, which in the guest
/// costs a system call of its own and slowed both sides).
#[derive(Debug, Default)]
pub(super) struct Calls {
    pub(super) sends: AtomicU64,
    pub(super) recvs: AtomicU64,
    /// `recv_until` calls that returned nothing (deadline passed).
    pub(super) empty: AtomicU64,
}

impl Calls {
    pub(super) fn snapshot(&self) -> [u64; 3] {
        [&self.sends, &self.recvs, &self.empty].map(|c| c.load(Ordering::Relaxed))
    }
}

/// A transport that counts its calls.
pub(super) struct Counting<T> {
    pub(super) inner: T,
    pub(super) calls: Arc<Calls>,
}

impl<T: Transport> Transport for Counting<T> {
    fn send(&mut self, frame: &canola_frame::CanFrame) -> Result<(), TransportError> {
        self.calls.sends.fetch_add(1, Ordering::Relaxed);
        self.inner.send(frame)
    }

    fn recv_until(
        &mut self,
        deadline: canola_frame::Instant,
    ) -> Result<Option<Received>, TransportError> {
        self.calls.recvs.fetch_add(1, Ordering::Relaxed);
        let r = self.inner.recv_until(deadline);
        if matches!(r, Ok(None)) {
            self.calls.empty.fetch_add(1, Ordering::Relaxed);
        }
        r
    }

    fn now(&self) -> canola_frame::Instant {
        self.inner.now()
    }
}

/// CPU seconds a thread has used, from the scheduler's own account (`schedstat`: nanoseconds
/// on the CPU); 0 when unavailable.
pub(super) fn schedstat_seconds(path: &str) -> f64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map_or(0.0, |ns| ns as f64 / 1e9)
}

/// `vcan_sdo --serve`: the simulated device on its own socket, served by `run_station` in the
/// main thread (so `/proc/PID/schedstat` is its CPU time). Prints `READY` once the socket is
/// open; answers a `calls` line on stdin with `CALLS SENDS RECEIVES EMPTY`; stops when stdin
/// closes.
pub(super) fn serve(args: &Args) -> Result<(), BenchError> {
    let node = NodeId::new(args.node).map_err(|_| BenchError("node-ID 1..=127".into()))?;
    let calls = Arc::new(Calls::default());
    let mut transport = Counting {
        inner: SocketCan::open(&args.iface)
            .map_err(|e| BenchError(format!("open {} for the simulator: {e}", args.iface)))?,
        calls: calls.clone(),
    };
    let mut dev = device(node, args.size);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    println!("READY");
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if line.trim() == "calls" {
                let [s, r, e] = calls.snapshot();
                println!("CALLS {s} {r} {e}");
            }
        }
        flag.store(true, Ordering::Relaxed);
    });
    run_station(&mut transport, &mut dev, || stop.load(Ordering::Relaxed))
        .map_err(|e| BenchError(format!("the simulator's transport failed: {e}")))
}

/// The simulated device, served by a child process (`--serve`) or a thread of this process.
pub(super) enum Sim {
    Process {
        child: std::process::Child,
        stdin: Option<std::process::ChildStdin>,
        lines: std::io::Lines<std::io::BufReader<std::process::ChildStdout>>,
    },
    Thread {
        stop: Arc<AtomicBool>,
        thread: Option<std::thread::JoinHandle<Result<(), TransportError>>>,
        tid: i32,
        calls: Arc<Calls>,
    },
}

impl Sim {
    pub(super) fn start(args: &Args) -> Result<Self, BenchError> {
        let node = NodeId::new(args.node).map_err(|_| BenchError("node-ID 1..=127".into()))?;
        if args.sim_thread {
            let calls = Arc::new(Calls::default());
            // Opened here, so the device's socket receives from the moment this returns.
            let mut transport = Counting {
                inner: SocketCan::open(&args.iface).map_err(|e| {
                    BenchError(format!("open {} for the simulator: {e}", args.iface))
                })?,
                calls: calls.clone(),
            };
            let mut dev = device(node, args.size);
            let stop = Arc::new(AtomicBool::new(false));
            let flag = stop.clone();
            let (tid_tx, tid_rx) = std::sync::mpsc::channel();
            let thread = std::thread::spawn(move || {
                let _ = tid_tx.send(nix::unistd::gettid().as_raw());
                run_station(&mut transport, &mut dev, || flag.load(Ordering::Relaxed))
            });
            let tid = tid_rx.recv().unwrap_or(0);
            return Ok(Self::Thread {
                stop,
                thread: Some(thread),
                tid,
                calls,
            });
        }
        if !args.sim_normal {
            match Self::spawn(args, true) {
                Ok(sim) => return Ok(sim),
                Err(e) => println!("no real-time priority for the simulator ({e}); SCHED_OTHER"),
            }
        }
        Self::spawn(args, false)
    }

    /// Starts `vcan_sdo --serve` (under `chrt -f 1` when `fifo`) and waits for its `READY`.
    fn spawn(args: &Args, fifo: bool) -> Result<Self, BenchError> {
        let exe = std::env::current_exe()
            .map_err(|e| BenchError(format!("where is this program: {e}")))?;
        let mut cmd = if fifo {
            let mut c = Command::new("chrt");
            c.args(["-f", "1"]).arg(exe);
            c
        } else {
            Command::new(exe)
        };
        let mut child = cmd
            .arg("--serve")
            .args(["--iface", &args.iface])
            .args(["--node-id", &args.node.to_string()])
            .args(["--size", &args.size.to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(if fifo {
                Stdio::null()
            } else {
                Stdio::inherit()
            })
            .spawn()
            .map_err(|e| BenchError(format!("start the simulator: {e}")))?;
        let stdin = child.stdin.take();
        let Some(out) = child.stdout.take() else {
            return Err(BenchError("the simulator has no stdout".into()));
        };
        let mut lines = std::io::BufReader::new(out).lines();
        match lines.next() {
            Some(Ok(l)) if l == "READY" => {}
            other => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(BenchError(format!(
                    "the simulator did not start: {other:?}"
                )));
            }
        }
        Ok(Self::Process {
            child,
            stdin,
            lines,
        })
    }

    /// Whether the serving process runs with `SCHED_FIFO` (`/proc/PID/stat` field 41).
    pub(super) fn is_fifo(&self) -> bool {
        let Self::Process { child, .. } = self else {
            return false;
        };
        std::fs::read_to_string(format!("/proc/{}/stat", child.id()))
            .ok()
            .and_then(|s| {
                // Fields after the command name in parentheses: state is field 3.
                let rest = s.rsplit_once(')')?.1;
                rest.split_whitespace().nth(41 - 3).map(|p| p == "1")
            })
            .unwrap_or(false)
    }

    /// CPU seconds and context switches of the serving thread so far.
    pub(super) fn usage(&self) -> (f64, u64) {
        let dir = match self {
            Self::Process { child, .. } => format!("/proc/{}", child.id()),
            Self::Thread { tid, .. } => format!("/proc/self/task/{tid}"),
        };
        (
            schedstat_seconds(&format!("{dir}/schedstat")),
            context_switches(&format!("{dir}/status")),
        )
    }

    /// The simulator's transport calls so far: sends, receives, empty receives.
    pub(super) fn calls(&mut self) -> Result<[u64; 3], BenchError> {
        match self {
            Self::Thread { calls, .. } => Ok(calls.snapshot()),
            Self::Process { stdin, lines, .. } => {
                let lost = || BenchError("the simulator stopped answering".into());
                let stdin = stdin.as_mut().ok_or_else(lost)?;
                writeln!(stdin, "calls").map_err(|_| lost())?;
                stdin.flush().map_err(|_| lost())?;
                let line = lines.next().ok_or_else(lost)?.map_err(|_| lost())?;
                let mut out = [0u64; 3];
                let mut fields = line.strip_prefix("CALLS ").ok_or_else(lost)?.split(' ');
                for v in &mut out {
                    *v = fields
                        .next()
                        .and_then(|f| f.parse().ok())
                        .ok_or_else(lost)?;
                }
                Ok(out)
            }
        }
    }

    pub(super) fn stop(mut self) -> Result<(), BenchError> {
        match &mut self {
            Self::Thread { stop, thread, .. } => {
                stop.store(true, Ordering::Relaxed);
                match thread.take().map(|t| t.join()) {
                    Some(Ok(Err(e))) => {
                        Err(BenchError(format!("the simulator's transport failed: {e}")))
                    }
                    Some(Err(_)) => Err(BenchError("the simulator thread panicked".into())),
                    _ => Ok(()),
                }
            }
            Self::Process { child, stdin, .. } => {
                drop(stdin.take());
                match child.wait() {
                    Ok(s) if s.success() => Ok(()),
                    Ok(s) => Err(BenchError(format!("the simulator failed: {s}"))),
                    Err(e) => Err(BenchError(format!("wait for the simulator: {e}"))),
                }
            }
        }
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        match self {
            Self::Thread { stop, thread, .. } => {
                stop.store(true, Ordering::Relaxed);
                if let Some(t) = thread.take() {
                    let _ = t.join();
                }
            }
            Self::Process { child, stdin, .. } => {
                if stdin.take().is_some() {
                    // Not stopped in order: an error ended the run.
                    let _ = child.kill();
                }
                let _ = child.wait();
            }
        }
    }
}
