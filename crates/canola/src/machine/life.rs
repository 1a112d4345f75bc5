//! Boot-ups, EMCY and signs of life: the bookkeeping of what each node said about itself
//! (boot-up counts and which of them a wait has taken, the latest EMCY, how many state changes
//! and recoveries its heartbeat or node guarding reported), the heartbeat consumer and the
//! guarding master they come from, and the NMT commands that reset the boot-up counts. The
//! waits for boot-up, for a state and for a sign of life read these counts.

use canola_frame::{CanFrame, Duration, Instant, NodeId};
use canola_nmt::{CommandSpecifier, NmtCommand, NmtState, NmtTarget};

use super::{Core, NetworkEvent};

impl Core {
    /// Takes an error-control frame (boot-up, heartbeat or node-guarding answer) of `node`.
    pub(super) fn handle_error_control(&mut self, now: Instant, node: NodeId, frame: &CanFrame) {
        if !frame.is_remote() && frame.data() == [0] {
            *self.boots.entry(node).or_default() += 1;
            self.end_transfers_on_boot(node);
        }
        // A node-ID in use: an LSS job handing out node-IDs must not give it.
        if !frame.is_remote()
            && frame.data().len() == 1
            && let Some(job) = &mut self.lss
        {
            job.node_id_heard(node);
            self.pump_lss();
        }
        // A guarded node's answers go to the guarding master alone (their toggle bit is no
        // heartbeat state); every other node's frames to the heartbeat consumer, which reports
        // boot-ups and state changes of unmonitored nodes too.
        let guarded = self.guarding.handle_frame(now, frame).unwrap_or(false);
        self.drain_guarding();
        if !guarded {
            let _ = self.heartbeat.handle_frame(now, frame);
            self.drain_heartbeat();
        }
    }

    /// Takes an EMCY frame: the node's latest EMCY is kept and published.
    pub(super) fn handle_emcy(&mut self, now: Instant, frame: &CanFrame) {
        let _ = self.emcy.handle_frame(now, frame);
        while let Some(ev) = self.emcy.poll_event() {
            self.emcys.insert(ev.node, ev);
            self.publish(NetworkEvent::Emcy(ev));
        }
    }

    /// Counts a state change or recovery that heartbeat or node guarding reports (before the
    /// event goes to the subscribers).
    pub(super) fn count_life_report(&mut self, ev: &NetworkEvent) {
        use canola_nmt::{GuardingEvent, HeartbeatEvent};
        if let NetworkEvent::Heartbeat(
            HeartbeatEvent::StateChanged { node, .. } | HeartbeatEvent::Recovered { node, .. },
        )
        | NetworkEvent::Guarding(
            GuardingEvent::StateChanged { node, .. } | GuardingEvent::Recovered { node, .. },
        ) = ev
        {
            *self.life_reports.entry(*node).or_insert(0) += 1;
        }
    }

    /// How many state changes and recoveries the heartbeat or node guarding of `node` reported
    /// since the network started.
    pub(crate) fn life_reports(&self, node: NodeId) -> u64 {
        self.life_reports.get(&node).copied().unwrap_or(0)
    }

    pub(crate) fn last_state(&self, node: NodeId) -> Option<NmtState> {
        self.guarding
            .state(node)
            .or_else(|| self.heartbeat.state(node))
    }

    /// When the latest heartbeat or boot-up of `node` arrived.
    pub(crate) fn last_heartbeat(&self, node: NodeId) -> Option<Instant> {
        self.heartbeat.last_seen(node)
    }

    /// The latest EMCY `node` sent.
    pub(crate) fn last_emcy(&self, node: NodeId) -> Option<canola_nmt::EmcyEvent> {
        self.emcys.get(&node).copied()
    }

    /// How many boot-up messages `node` has sent since the network started.
    pub(crate) fn boot_count(&self, node: NodeId) -> u64 {
        self.boots.get(&node).copied().unwrap_or(0)
    }

    /// The boot-ups of `node` already accounted for (see `boots_taken`).
    pub(crate) fn boots_taken(&self, node: NodeId) -> u64 {
        self.boots_taken.get(&node).copied().unwrap_or(0)
    }

    /// Marks the first `count` boot-ups of `node` as accounted for.
    pub(crate) fn take_boots(&mut self, node: NodeId, count: u64) {
        let t = self.boots_taken.entry(node).or_default();
        *t = (*t).max(count);
    }

    /// Queues an NMT command (COB-ID 0x000).
    /// The boot-ups heard before it no longer count for waits.
    pub(crate) fn nmt(&mut self, cmd: CommandSpecifier, target: NmtTarget) {
        match target {
            NmtTarget::Node(id) => self.take_boots(id, self.boot_count(id)),
            _ => {
                let counts: Vec<_> = self.boots.iter().map(|(n, c)| (*n, *c)).collect();
                for (n, c) in counts {
                    self.take_boots(n, c);
                }
            }
        }
        self.queue(NmtCommand::new(cmd, target).to_frame());
    }

    pub(crate) fn monitor_heartbeat(&mut self, node: NodeId, timeout: Duration) -> bool {
        self.heartbeat.monitor(node, timeout).is_ok()
    }

    pub(crate) fn guard_node(&mut self, node: NodeId, guard_time: Duration, factor: u8) -> bool {
        let now = self.now;
        let ok = self.guarding.guard(now, node, guard_time, factor).is_ok();
        self.drain_guarding();
        ok
    }

    pub(super) fn drain_guarding(&mut self) {
        while let Some(f) = self.guarding.poll_transmit_frame() {
            self.queue_periodic(f, false);
        }
        while let Some(ev) = self.guarding.poll_event() {
            self.publish(NetworkEvent::Guarding(ev));
        }
    }

    pub(super) fn drain_heartbeat(&mut self) {
        while let Some(ev) = self.heartbeat.poll_event() {
            self.publish(NetworkEvent::Heartbeat(ev));
        }
    }
}
