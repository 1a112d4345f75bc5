//! Waiting for a slave's sign of life with a deadline, as the boot's node-state and error
//! control steps need it: a heartbeat received after a given instant, or a state change or
//! recovery its heartbeat or node guarding reports.
//!
//! The facade waits for a boot-up or for a given NMT state, not for "any heartbeat since";
//! this wait drives the network with [`Network::run_until`] in short slices and looks between
//! them, so a sign of life is seen at most [`LOOK`] of network time late.

use std::sync::mpsc::Receiver;

use canola::nmt::GuardingEvent;
use canola::{Duration, HeartbeatEvent, Instant, Network, NetworkEvent, NodeId};

/// How much network time the wait drives between two looks.
const LOOK: Duration = Duration::from_micros(100);

/// Waits until `node` shows a sign of life or the network's clock reaches `deadline`; `true`
/// for a sign of life. `events`: a subscription taken before the wait's error control was
/// started; a state change or recovery reported there by heartbeat or guarding counts, and
/// with `heartbeat` so does any heartbeat received after `since`. An error is the transport's
/// failure while driving.
pub(super) async fn sign_of_life(
    net: &Network,
    node: NodeId,
    events: Receiver<NetworkEvent>,
    since: Instant,
    deadline: Instant,
    heartbeat: bool,
) -> Result<bool, canola::Error> {
    loop {
        let reported = events.try_iter().any(|ev| is_life(&ev, node));
        if reported || (heartbeat && net.last_heartbeat(node).is_some_and(|t| t > since)) {
            return Ok(true);
        }
        let now = net.now();
        if now >= deadline {
            return Ok(false);
        }
        net.run_until(deadline.min(now + LOOK)).await?;
    }
}

/// Whether `ev` says `node` is alive: a state change or a recovery by heartbeat or guarding.
fn is_life(ev: &NetworkEvent, node: NodeId) -> bool {
    match ev {
        NetworkEvent::Heartbeat(
            HeartbeatEvent::StateChanged { node: n, .. }
            | HeartbeatEvent::Recovered { node: n, .. },
        )
        | NetworkEvent::Guarding(
            GuardingEvent::StateChanged { node: n, .. } | GuardingEvent::Recovered { node: n, .. },
        ) => *n == node,
        _ => false,
    }
}
