//! The LSS master for single services and short procedures (CiA 305 switch mode, configuration, inquiry and identification services).
//!
//! A [`Procedure`] is a list of [`Step`]s that [`LssMaster`] performs in order, stopping at the
//! first error. The seed's sequences (Bürkert manual §2.3.1) are ready-made:
//! - [`Procedure::change_bit_rate`]: switch mode global (configuration), configure bit timing,
//!   activate bit timing, wait twice the switch delay, switch mode global (waiting) — the seed's
//!   steps 1, 2, 3, 5;
//! - [`Procedure::assign_node_id`]: switch mode global (configuration), configure node-ID,
//!   optionally store configuration, switch mode global (waiting) — steps 1, 4, 5 (+ store),
//!   with a check between steps 1 and 4 that exactly one slave is in configuration state
//!   (switch mode global reaches them all; [`Step::InquireSingle`]);
//! - selective variants that address one slave by its LSS address, so other slaves may stay
//!   on the bus.
//!
//! Services without an answer (switch mode global, activate bit timing) complete when queued.
//! Identify remote slave and identify non-configured remote slave report whether anybody
//! answered (silence is a result, not an error); every other service fails with
//! [`LssError::Timeout`] when its answer does not come, and with [`LssError::Rejected`] when the
//! slave answers with an error code — except store configuration answered with error 1 (store
//! not supported, common in real slaves): the procedure goes on and the report says
//! [`ServiceReport::stored`] `Some(false)`.

use canola_frame::{Duration, Instant, NodeId};
use heapless::Vec;

use crate::address::{AddressPart, BitTiming, LssAddress};
use crate::error::{LssError, Service};
use crate::machine::{Driven, Io, MasterEvent, Reply, ResponsePolicy, driven_machine};
use crate::wire::{
    ConfigStatus, IdentifyField, Mode, Request, Response, ResponseError, UNCONFIGURED_NODE_ID, cs,
};

/// Response timeouts of [`LssMaster`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MasterConfig {
    /// For switch mode selective, configure, inquire and identify.
    pub response_timeout: Duration,
    /// For store configuration (a slave may be writing flash).
    pub store_timeout: Duration,
    /// For identify remote slave / identify non-configured remote slave.
    pub identify_policy: ResponsePolicy,
}

impl Default for MasterConfig {
    /// 100 ms for answers, 1 s for store, wait out identify windows.
    fn default() -> Self {
        Self {
            response_timeout: Duration::from_millis(100),
            store_timeout: Duration::from_secs(1),
            identify_policy: ResponsePolicy::WholeWindow,
        }
    }
}

/// An inclusive range of 32-bit values (revision or serial numbers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Range {
    /// Lowest value.
    pub low: u32,
    /// Highest value.
    pub high: u32,
}

impl Range {
    /// Every value.
    pub const ALL: Range = Range {
        low: 0,
        high: u32::MAX,
    };

    /// One value.
    pub const fn exactly(v: u32) -> Self {
        Self { low: v, high: v }
    }
}

/// The slaves identify remote slave asks for: vendor-ID and product code exact, revision and
/// serial number in ranges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IdentifyQuery {
    /// Vendor-ID.
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision numbers.
    pub revision: Range,
    /// Serial numbers.
    pub serial: Range,
}

impl IdentifyQuery {
    /// The six requests, in protocol order.
    pub fn requests(&self) -> [Request; 6] {
        let v = [
            self.vendor_id,
            self.product_code,
            self.revision.low,
            self.revision.high,
            self.serial.low,
            self.serial.high,
        ];
        let f = IdentifyField::ALL;
        [
            Request::IdentifyRemoteSlave(f[0], v[0]),
            Request::IdentifyRemoteSlave(f[1], v[1]),
            Request::IdentifyRemoteSlave(f[2], v[2]),
            Request::IdentifyRemoteSlave(f[3], v[3]),
            Request::IdentifyRemoteSlave(f[4], v[4]),
            Request::IdentifyRemoteSlave(f[5], v[5]),
        ]
    }
}

/// One step of a [`Procedure`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Step {
    /// Switch mode global; no answer.
    SwitchModeGlobal(Mode),
    /// Switch mode selective to the slave with this address; waits for 0x44.
    SwitchModeSelective(LssAddress),
    /// Configure node-ID (raw: 1..=127 or 0xFF).
    ConfigureNodeId(u8),
    /// Configure bit timing.
    ConfigureBitTiming(BitTiming),
    /// Activate bit timing; reports [`MasterEvent::SwitchBitRate`] and waits twice the delay
    /// (the slaves switch after one delay and talk again after the second).
    ActivateBitTiming {
        /// The switch delay in ms.
        delay_ms: u16,
    },
    /// Store configuration.
    StoreConfiguration,
    /// Inquire one part of the identity.
    InquireIdentity(AddressPart),
    /// Inquire one part of the identity of the one slave that must be in configuration state:
    /// the whole response window is waited out, and a second answer (several slaves are in
    /// configuration state) fails the procedure with [`LssError::SeveralSlaves`]. Any failure
    /// of this step switches every slave back to waiting state before the procedure ends.
    InquireSingle(AddressPart),
    /// Inquire the node-ID.
    InquireNodeId,
    /// Identify remote slave; the report says whether anybody answered.
    IdentifyRemoteSlave(IdentifyQuery),
    /// Identify non-configured remote slave; the report says whether anybody answered.
    IdentifyNonConfigured,
    /// Do nothing for a while.
    Wait(Duration),
}

/// At most this many steps per procedure.
pub const MAX_STEPS: usize = 12;

/// A sequence of LSS services performed in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Procedure {
    steps: Vec<Step, MAX_STEPS>,
}

impl Procedure {
    /// An empty procedure.
    pub const fn new() -> Self {
        Self { steps: Vec::new() }
    }

    /// A procedure of one step.
    pub fn single(step: Step) -> Self {
        let mut p = Self::new();
        let _ = p.steps.push(step);
        p
    }

    /// Appends a step. Fails with [`LssError::InvalidConfig`] beyond [`MAX_STEPS`].
    pub fn then(mut self, step: Step) -> Result<Self, LssError> {
        self.steps
            .push(step)
            .map_err(|_| LssError::InvalidConfig("too many steps in the LSS procedure"))?;
        Ok(self)
    }

    /// The steps.
    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    fn of(steps: &[Step]) -> Self {
        let mut p = Self::new();
        for s in steps {
            let _ = p.steps.push(*s);
        }
        p
    }

    /// The seed's bit rate change (steps 1, 2, 3, 5): every slave on the bus gets the new bit
    /// timing. The master must switch its own controller on [`MasterEvent::SwitchBitRate`].
    pub fn change_bit_rate(bit_timing: BitTiming, delay_ms: u16) -> Self {
        Self::of(&[
            Step::SwitchModeGlobal(Mode::Configuration),
            Step::ConfigureBitTiming(bit_timing),
            Step::ActivateBitTiming { delay_ms },
            Step::SwitchModeGlobal(Mode::Waiting),
        ])
    }

    /// The seed's node-ID assignment (steps 1, 4, 5), with store configuration before step 5
    /// when `store`, made safe for a bus with several LSS slaves: switch mode global reaches
    /// every slave (configured or not), and each would take the node-ID. So after the switch
    /// the procedure inquires the four parts of the LSS address ([`Step::InquireSingle`]) and
    /// configures only when exactly one slave answers; with several it switches them back to
    /// waiting and fails with [`LssError::SeveralSlaves`] (then use
    /// [`assign_node_id_selective`](Self::assign_node_id_selective) or
    /// [`AssignAll`](crate::AssignAll)). The report holds the configured slave's address.
    pub fn assign_node_id(node_id: NodeId, store: bool) -> Self {
        Self::assign(None, node_id.get(), store)
    }

    /// Node-ID assignment to the slave with `address` (switch mode selective instead of
    /// global), so other slaves may be on the bus.
    pub fn assign_node_id_selective(address: LssAddress, node_id: NodeId, store: bool) -> Self {
        Self::assign(Some(address), node_id.get(), store)
    }

    /// Makes the selected slave unconfigured again (node-ID 0xFF) and stores that.
    pub fn unconfigure_selective(address: LssAddress) -> Self {
        Self::assign(Some(address), UNCONFIGURED_NODE_ID, true)
    }

    fn assign(address: Option<LssAddress>, raw: u8, store: bool) -> Self {
        let mut p = Self::new();
        match address {
            Some(a) => {
                let _ = p.steps.push(Step::SwitchModeSelective(a));
            }
            None => {
                let _ = p.steps.push(Step::SwitchModeGlobal(Mode::Configuration));
                for part in AddressPart::ALL {
                    let _ = p.steps.push(Step::InquireSingle(part));
                }
            }
        }
        let _ = p.steps.push(Step::ConfigureNodeId(raw));
        if store {
            let _ = p.steps.push(Step::StoreConfiguration);
        }
        let _ = p.steps.push(Step::SwitchModeGlobal(Mode::Waiting));
        p
    }

    /// Configure and store a new bit timing in one selected slave, without activating it (it
    /// takes effect at the slave's next power-on).
    pub fn store_bit_timing_selective(address: LssAddress, bit_timing: BitTiming) -> Self {
        Self::of(&[
            Step::SwitchModeSelective(address),
            Step::ConfigureBitTiming(bit_timing),
            Step::StoreConfiguration,
            Step::SwitchModeGlobal(Mode::Waiting),
        ])
    }

    /// Reads the whole LSS address and the node-ID of the slave in configuration state
    /// (switch one slave into configuration first).
    pub fn inquire_all() -> Self {
        Self::of(&[
            Step::InquireIdentity(AddressPart::Vendor),
            Step::InquireIdentity(AddressPart::Product),
            Step::InquireIdentity(AddressPart::Revision),
            Step::InquireIdentity(AddressPart::Serial),
            Step::InquireNodeId,
        ])
    }
}

impl Default for Procedure {
    fn default() -> Self {
        Self::new()
    }
}

/// What a procedure learnt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ServiceReport {
    /// Inquired identity parts, indexed by [`AddressPart::index`].
    pub identity: [Option<u32>; 4],
    /// Inquired node-ID (0xFF = unconfigured).
    pub node_id: Option<u8>,
    /// Whether the last identify step got an answer.
    pub present: Option<bool>,
    /// Whether store configuration stored: `Some(false)` when the slave answered that it does
    /// not support store (error 1), which does not fail the procedure: the configured values
    /// still take effect (a node-ID when the slave returns to waiting state), they are only not
    /// persistent.
    pub stored: Option<bool>,
}

impl ServiceReport {
    /// The address, if all four parts were inquired.
    pub fn address(&self) -> Option<LssAddress> {
        let [Some(v), Some(p), Some(r), Some(s)] = self.identity else {
            return None;
        };
        Some(LssAddress::new(v, p, r, s))
    }
}

/// Runs one [`Procedure`] at a time; see [`LssMachine`](crate::LssMachine) for the call order.
#[derive(Debug, Clone)]
pub struct LssMaster {
    config: MasterConfig,
    io: Io<ServiceReport>,
    steps: Vec<Step, MAX_STEPS>,
    next: usize,
    /// The step awaiting an answer or a timer.
    current: Option<Step>,
    wait_until: Option<Instant>,
    report: ServiceReport,
    running: bool,
}

impl LssMaster {
    /// An idle master.
    pub const fn new(config: MasterConfig) -> Self {
        Self {
            config,
            io: Io::new(),
            steps: Vec::new(),
            next: 0,
            current: None,
            wait_until: None,
            report: ServiceReport {
                identity: [None; 4],
                node_id: None,
                present: None,
                stored: None,
            },
            running: false,
        }
    }

    /// Whether a procedure is running.
    pub fn is_busy(&self) -> bool {
        self.running
    }

    /// Starts `procedure`. Fails with [`LssError::Busy`] while another one runs.
    pub fn start(&mut self, now: Instant, procedure: Procedure) -> Result<(), LssError> {
        if self.running {
            return Err(LssError::Busy);
        }
        self.io.ex.clear();
        self.io.events.clear();
        self.steps = procedure.steps;
        self.next = 0;
        self.current = None;
        self.wait_until = None;
        self.report = ServiceReport::default();
        self.running = true;
        self.io.finished = false;
        self.advance(now);
        Ok(())
    }

    /// Starts a one-step procedure.
    pub fn start_step(&mut self, now: Instant, step: Step) -> Result<(), LssError> {
        self.start(now, Procedure::single(step))
    }

    fn finish(&mut self, result: Result<(), LssError>) {
        self.running = false;
        self.io.finished = true;
        self.current = None;
        self.wait_until = None;
        self.io.events.finish(result.map(|()| self.report));
    }

    /// Starts steps until one has to wait or the procedure is over.
    fn advance(&mut self, now: Instant) {
        while self.running && self.current.is_none() {
            let Some(step) = self.steps.get(self.next).copied() else {
                self.finish(Ok(()));
                return;
            };
            self.next += 1;
            self.begin(now, step);
        }
    }

    fn ask(&mut self, now: Instant, step: Step, req: Request, cs: u8) {
        let timeout = match step {
            Step::StoreConfiguration => self.config.store_timeout,
            _ => self.config.response_timeout,
        };
        let collect = matches!(
            step,
            Step::IdentifyRemoteSlave(_) | Step::IdentifyNonConfigured
        ) && self.config.identify_policy == ResponsePolicy::WholeWindow;
        self.io.ex.ask(now, req, cs, timeout, collect);
        self.current = Some(step);
    }

    fn begin(&mut self, now: Instant, step: Step) {
        match step {
            Step::SwitchModeGlobal(mode) => self.io.ex.send(Request::SwitchModeGlobal(mode)),
            Step::SwitchModeSelective(a) => {
                for part in [
                    AddressPart::Vendor,
                    AddressPart::Product,
                    AddressPart::Revision,
                ] {
                    self.io
                        .ex
                        .send(Request::SwitchModeSelective(part, a.get(part)));
                }
                let last = Request::SwitchModeSelective(AddressPart::Serial, a.serial_number);
                self.ask(now, step, last, cs::SWITCH_SELECTIVE_RESPONSE);
            }
            Step::ConfigureNodeId(id) => self.ask(
                now,
                step,
                Request::ConfigureNodeId(id),
                cs::CONFIGURE_NODE_ID,
            ),
            Step::ConfigureBitTiming(t) => self.ask(
                now,
                step,
                Request::ConfigureBitTiming(t),
                cs::CONFIGURE_BIT_TIMING,
            ),
            Step::ActivateBitTiming { delay_ms } => {
                self.io.ex.send(Request::ActivateBitTiming { delay_ms });
                let delay = Duration::from_millis(u64::from(delay_ms));
                // The bit timing the slaves switch to is the one configured earlier in this
                // procedure, if any.
                let timing = self
                    .steps
                    .iter()
                    .take(self.next)
                    .rev()
                    .find_map(|s| match s {
                        Step::ConfigureBitTiming(t) => Some(*t),
                        _ => None,
                    });
                if let Some(bit_timing) = timing {
                    self.io.events.push(MasterEvent::SwitchBitRate {
                        bit_timing,
                        at: now + delay,
                    });
                }
                self.wait_until = Some(now + delay + delay);
                self.current = Some(step);
            }
            Step::StoreConfiguration => self.ask(
                now,
                step,
                Request::StoreConfiguration,
                cs::STORE_CONFIGURATION,
            ),
            Step::InquireIdentity(part) => self.ask(
                now,
                step,
                Request::InquireIdentity(part),
                cs::INQUIRE_VENDOR + part.index(),
            ),
            Step::InquireSingle(part) => {
                self.io.ex.ask_one(
                    now,
                    Request::InquireIdentity(part),
                    cs::INQUIRE_VENDOR + part.index(),
                    self.config.response_timeout,
                );
                self.current = Some(step);
            }
            Step::InquireNodeId => self.ask(now, step, Request::InquireNodeId, cs::INQUIRE_NODE_ID),
            Step::IdentifyRemoteSlave(q) => {
                let [a, b, c, d, e, f] = q.requests();
                for r in [a, b, c, d, e] {
                    self.io.ex.send(r);
                }
                self.ask(now, step, f, cs::IDENTIFY_SLAVE);
            }
            Step::IdentifyNonConfigured => self.ask(
                now,
                step,
                Request::IdentifyNonConfigured,
                cs::IDENTIFY_NON_CONFIGURED_SLAVE,
            ),
            Step::Wait(d) => {
                self.wait_until = Some(now + d);
                self.current = Some(step);
            }
        }
    }

    fn service(step: Step) -> Service {
        match step {
            Step::SwitchModeSelective(_) => Service::SwitchModeSelective,
            Step::ConfigureNodeId(_) => Service::ConfigureNodeId,
            Step::ConfigureBitTiming(_) => Service::ConfigureBitTiming,
            Step::StoreConfiguration => Service::StoreConfiguration,
            Step::InquireIdentity(p) | Step::InquireSingle(p) => Service::InquireIdentity(p),
            Step::InquireNodeId => Service::InquireNodeId,
            Step::IdentifyRemoteSlave(_) => Service::IdentifyRemoteSlave,
            Step::IdentifyNonConfigured => Service::IdentifyNonConfigured,
            // Never asked: these steps complete without an answer, so `on_reply` never sees
            // them. A value is still needed for the match.
            Step::SwitchModeGlobal(_) | Step::ActivateBitTiming { .. } | Step::Wait(_) => {
                Service::SwitchModeSelective
            }
        }
    }

    fn react(&mut self, now: Instant, reply: Reply) {
        let Some(step) = self.current.take() else {
            return;
        };
        let service = Self::service(step);
        let result = match reply {
            Reply::Silence => match step {
                Step::IdentifyRemoteSlave(_) | Step::IdentifyNonConfigured => {
                    self.report.present = Some(false);
                    Ok(())
                }
                _ => {
                    let timeout = match step {
                        Step::StoreConfiguration => self.config.store_timeout,
                        _ => self.config.response_timeout,
                    };
                    Err(crate::machine::timeout(service, timeout))
                }
            },
            Reply::Several(a, b) => match (a, b) {
                (Response::InquireIdentity(part, first), Response::InquireIdentity(_, second)) => {
                    Err(LssError::SeveralSlaves {
                        part,
                        first,
                        second,
                    })
                }
                // Only inquire-single asks for one answerer.
                _ => Ok(()),
            },
            Reply::Answer(r) => match r {
                Response::StoreConfiguration(s)
                    if s.result() == Err(ResponseError::NotSupported) =>
                {
                    self.report.stored = Some(false);
                    Ok(())
                }
                Response::StoreConfiguration(ConfigStatus::OK) => {
                    self.report.stored = Some(true);
                    Ok(())
                }
                Response::ConfigureNodeId(s)
                | Response::ConfigureBitTiming(s)
                | Response::StoreConfiguration(s) => s
                    .result()
                    .map_err(|error| LssError::Rejected { service, error }),
                Response::InquireIdentity(part, v) => {
                    self.report.identity[usize::from(part.index() & 3)] = Some(v);
                    Ok(())
                }
                Response::InquireNodeId(id) => {
                    self.report.node_id = Some(id);
                    Ok(())
                }
                Response::IdentifySlave | Response::IdentifyNonConfiguredSlave => {
                    self.report.present = Some(true);
                    Ok(())
                }
                Response::SwitchModeSelective | Response::Unknown { .. } => Ok(()),
            },
        };
        match result {
            Ok(()) => self.advance(now),
            Err(e) => {
                self.io.ex.clear();
                if let Step::InquireSingle(_) = step {
                    // Nothing was configured: leave every slave in waiting state, as found.
                    self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
                }
                self.finish(Err(e));
            }
        }
    }
}

driven_machine!(LssMaster, ServiceReport);

impl Driven for LssMaster {
    type Output = ServiceReport;
    type Progress = core::convert::Infallible;

    fn io(&self) -> &Io<Self::Output, Self::Progress> {
        &self.io
    }

    fn io_mut(&mut self) -> &mut Io<Self::Output, Self::Progress> {
        &mut self.io
    }

    fn on_reply(&mut self, now: Instant, reply: Reply) {
        self.react(now, reply);
    }

    fn timer(&self) -> Option<Instant> {
        self.wait_until
    }

    fn on_timer(&mut self, now: Instant) {
        self.wait_until = None;
        self.current = None;
        self.advance(now);
    }
}
