//! The tie between a network's clock and tokio's, for the async API (`tokio` feature): one
//! anchor per network, a pair (tokio instant, network instant) that correspond, and the
//! wake-up futures that drive a virtual clock wait on. It lives beside the network, which holds
//! one, and knows nothing of it; the tokio driving (`network/tokio_driving.rs`) uses it.

use std::sync::Mutex;

use canola_frame::{Duration, Instant};

/// The async side of a network: wake-ups between futures driving a virtual clock, and the tie
/// between that clock and tokio's.
pub(crate) struct Reactor {
    /// Whether the transport runs on a virtual clock (the futures then drive it themselves).
    pub(crate) virtual_clock: bool,
    /// Notified when a future driving the network made progress.
    pub(crate) progress: tokio::sync::Notify,
    /// A tokio instant and the network instant it corresponds to.
    anchor: Mutex<Option<(tokio::time::Instant, Instant)>>,
}

impl Reactor {
    pub(crate) fn new(virtual_clock: bool) -> Self {
        Self {
            virtual_clock,
            progress: tokio::sync::Notify::new(),
            anchor: Mutex::new(None),
        }
    }

    /// The network instant tokio's clock is at, given the bus's `now`. Moves the anchor when
    /// the bus is ahead (blocking calls jumped it), so time never goes back.
    pub(crate) fn target(&self, now: Instant) -> Instant {
        let t = tokio::time::Instant::now();
        let mut anchor = self.anchor.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((at, v)) = *anchor {
            let mapped = v + Duration::from_micros(micros(t.saturating_duration_since(at)));
            if mapped >= now {
                return mapped;
            }
        }
        *anchor = Some((t, now));
        now
    }

    /// The tokio instant at which the network's clock reaches `at`.
    pub(crate) fn tokio_at(&self, at: Instant) -> tokio::time::Instant {
        let anchor = *self.anchor.lock().unwrap_or_else(|p| p.into_inner());
        match anchor {
            Some((t, v)) => {
                let d: std::time::Duration = at.saturating_duration_since(v).into();
                // A deadline too far for tokio's clock is as good as never.
                t.checked_add(d)
                    .unwrap_or_else(|| t + std::time::Duration::from_secs(86_400 * 365))
            }
            None => tokio::time::Instant::now(),
        }
    }
}

fn micros(d: std::time::Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}
