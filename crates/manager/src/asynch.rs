//! The async API (`tokio` feature): the boot and the audit from a tokio runtime, each event as
//! it happens.
//!
//! The blocking [`boot_with`] and [`audit_with`] themselves run on tokio's blocking pool (they
//! drive the network, which blocks: each runs every slave's straight-line body on that one
//! thread with `canola::wait_all_with`); their events come through a channel the caller
//! awaits. There is no second implementation of either. (Awaiting the slaves' bodies on tokio
//! instead would put a virtual-clock bus on tokio's clock, so a simulated boot would take its
//! heartbeat windows in real time.)

use canola::Network;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

use crate::audit::{AuditEvent, AuditOptions, AuditReport, audit_with};
use crate::boot::{BootEvent, BootReport, boot_with};
use crate::config::NetworkConfig;

/// A boot or audit running on the blocking pool: its events as they happen, then its report.
#[derive(Debug)]
pub struct Running<R, E> {
    events: mpsc::UnboundedReceiver<E>,
    task: JoinHandle<R>,
}

impl<R, E> Running<R, E> {
    /// The next event; `None` once the run is over and every event was taken.
    pub async fn next_event(&mut self) -> Option<E> {
        self.events.recv().await
    }

    /// Waits for the end and returns the report (events not taken are dropped). A panic of the
    /// run is resumed here.
    pub async fn finish(self) -> R {
        match self.task.await {
            Ok(r) => r,
            Err(e) => std::panic::resume_unwind(e.into_panic()),
        }
    }
}

fn spawn<R: Send + 'static, E: Send + 'static>(
    run: impl FnOnce(&mut dyn FnMut(E)) -> R + Send + 'static,
) -> Running<R, E> {
    let (tx, events) = mpsc::unbounded_channel();
    let task = tokio::task::spawn_blocking(move || {
        // A caller that stopped listening does not stop the run.
        run(&mut |e| {
            let _ = tx.send(e);
        })
    });
    Running { events, task }
}

/// Starts booting `net` as `config` describes ([`boot_with`]); must be called within a tokio
/// runtime.
pub fn spawn_boot(net: &Network, config: &NetworkConfig) -> Running<BootReport, BootEvent> {
    let (net, config) = (net.clone(), config.clone());
    spawn(move |send| boot_with(&net, &config, |e| send(e.clone())))
}

/// Boots `net` as `config` describes, without blocking the runtime.
pub async fn boot_async(net: &Network, config: &NetworkConfig) -> BootReport {
    spawn_boot(net, config).finish().await
}

/// Starts auditing `net` against `config` ([`audit_with`]); must be called within a tokio
/// runtime.
pub fn spawn_audit(
    net: &Network,
    config: &NetworkConfig,
    options: AuditOptions,
) -> Running<AuditReport, AuditEvent> {
    let (net, config) = (net.clone(), config.clone());
    spawn(move |send| audit_with(&net, &config, options, |e| send(e.clone())))
}

/// Audits `net` against `config`, without blocking the runtime.
pub async fn audit_async(
    net: &Network,
    config: &NetworkConfig,
    options: AuditOptions,
) -> AuditReport {
    spawn_audit(net, config, options).finish().await
}
